/* The core every stage shares: contexts and errors, counted and checked allocation, the I/O
 * fault hook, time. Not installed. Each stage of lib/ has its own header beside its code
 * (scene/scene.h, hierarchy/hierarchy.h, formfactor/formfactor.h, operator/operator.h,
 * solve/solve.h, probe/probe.h) that declares only what later stages use; a stage includes
 * only its own and earlier stages' headers (docs/ARCHITECTURE.md). */
#ifndef LRR_CORE_INTERNAL_H
#define LRR_CORE_INTERNAL_H

#include "lrr.h"
#include "core/atomic_file.h"
#include <pthread.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

/* ------------------------------------------------------------ context and errors */
struct lrr_context {
    int refs;                 /* guarded by lock */
    pthread_mutex_t lock;
    lrr_error_fn callback;
    void *callback_user;
    lrr_status first_status;  /* first error since the last lrr_context_last_error() */
    char first_message[512];
    /* Tests only (allocation-failure injection), guarded by lock: every allocation made
     * through lrr__alloc/lrr__calloc/lrr__realloc with this context counts; when fail_at is
     * non-zero the fail_at-th one returns NULL. */
    unsigned long alloc_count;
    unsigned long fail_at;
    /* Tests only (I/O fault injection, see lrr__context_set_io_hook), guarded by lock. */
    int (*io_hook)(void *user, unsigned long step, const char *what);
    void *io_user;
    unsigned long io_steps;
};

lrr_context *lrr__context_retain(lrr_context *ctx);
void lrr__context_release(lrr_context *ctx);

/* Records an error on ctx (printf-style message naming what and where) and returns status.
 * ctx may be NULL (then only the status is returned). */
lrr_status lrr__error(lrr_context *ctx, lrr_status status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* ------------------------------------------------------------ checked sizes and memory */
/* *out = a*b; returns false on overflow. */
static inline bool lrr__mul_size(size_t a, size_t b, size_t *out)
{
    return !__builtin_mul_overflow(a, b, out);
}
/* Allocates count*elem zeroed bytes, 64-byte aligned. On failure records LRR_ERR_OVERFLOW or
 * LRR_ERR_NOMEM naming `what`, sets *out = NULL. count == 0 gives a valid 64-byte block. */
lrr_status lrr__calloc(lrr_context *ctx, void *out, size_t count, size_t elem, const char *what);
/* malloc / zeroed malloc / realloc counted on ctx (which may be NULL): every library
 * allocation goes through these or lrr__calloc so that tests can make one fail. They record
 * no error; the caller does. Free with free() (or lrr_aligned_free, the same). */
void *lrr__alloc(lrr_context *ctx, size_t bytes);
void *lrr__zalloc(lrr_context *ctx, size_t bytes);
void *lrr__realloc(lrr_context *ctx, void *p, size_t bytes);
/* Tests only: makes the n-th allocation counted from now on ctx fail (0: none) and resets the
 * count; lrr__context_alloc_count gives the number of allocations counted since. */
void lrr__context_fail_after(lrr_context *ctx, unsigned long n);
unsigned long lrr__context_alloc_count(lrr_context *ctx);

/* Tests only: I/O fault injection. lrr_operator_save calls lrr__io_step before each of its
 * I/O steps (creating the temporary file, every block it writes, the flush, the fsync, the
 * close, the rename and the directory sync), which calls hook(user, step, what) with the
 * steps counted from 1 since the hook was set. A non-zero return is the errno that step fails
 * with (the step is not attempted; the close still releases the file; the directory sync is
 * best effort, so its failure is ignored). The hook may also not return (a test raises
 * SIGKILL there). hook = NULL turns it off. */
typedef int (*lrr__io_hook_fn)(void *user, unsigned long step, const char *what);
void lrr__context_set_io_hook(lrr_context *ctx, lrr__io_hook_fn hook, void *user);
/* The injected errno for the next step (0: go ahead); 0 without a hook or a context. */
int lrr__io_step(lrr_context *ctx, const char *what);
/* The atomic writer's hooks for ctx (core/atomic_file.h): its steps go through lrr__io_step,
 * its temporary name through lrr__alloc, so the tests' fault injection reaches every file
 * the library writes. */
void lrr__context_atomic_io(lrr_context *ctx, lrr__atomic_io *io);
/* The error of a failed atomic write, recorded on ctx: LRR_ERR_IO naming the file, the step,
 * the temporary file and the errno (LRR_ERR_NOMEM when the temporary name was not had). */
lrr_status lrr__atomic_error(lrr_context *ctx, const lrr__atomic_file *w);
/* Growable structs (lrr.h "Conventions"). lrr__options_read copies the caller's option
 * struct `in` (starting with its size_t size) over out (holding the defaults), `known` =
 * sizeof the struct in this lrr, `first` = its size in ABI 1 (LRR__FIRST_SIZE): size 0 is
 * read as the first layout; a size below it or misaligned is LRR_ERR_INVALID_ARG; bytes
 * beyond `known` must be zero (LRR_ERR_UNSUPPORTED otherwise); fields an older caller lacks
 * keep out's defaults. out->size = known. Errors name `what` (the struct's type name).
 * lrr__info_write copies info (info_size bytes) into the caller's out (out_size bytes),
 * zeroing what this lrr does not fill. */
lrr_status lrr__options_read(lrr_context *ctx, const void *in, size_t known, size_t first,
                             void *out, const char *what);
/* The size a growable struct T had in ABI 1, whose last field was `last`: new fields are
 * only ever appended, so this stays what size = 0 means. */
#define LRR__FIRST_SIZE(T, last)                                                             \
    ((offsetof(T, last) + sizeof(((T *)0)->last) + _Alignof(T) - 1) / _Alignof(T) *           \
     _Alignof(T))
void lrr__info_write(void *out, size_t out_size, const void *info, size_t info_size);
/* Thread-safe strerror: the text of errno err, in buf or a static string. */
const char *lrr__errno_text(int err, char *buf, size_t len);
/* ------------------------------------------------------------ misc */
/* Below about this many multiply-adds (or bytes touched) a parallel region costs more than it
 * saves: waking the OpenMP team takes microseconds when idle, and milliseconds on a loaded
 * machine where a worker is descheduled (measured: Jacobi sweeps at n = 112 took 4 ms each
 * with two threads under load, 9 µs with one). */
#define LRR__PARALLEL_MIN ((size_t)1 << 16)
double lrr__now(void);  /* monotonic seconds */

/* splitmix64 (Steele, Lea and Flood 2014): lrr__mix64 is its output function, a bijective
 * mix of 64 bits; lrr__splitmix64(x) the value the generator gives from state x (a good
 * hash of x); lrr__splitmix64_next the generator itself. The per-receiver hemicube
 * rotations, the adaptive selection's sample and the picture welding's hash use them. */
static inline uint64_t lrr__mix64(uint64_t x)
{
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}
static inline uint64_t lrr__splitmix64(uint64_t x)
{
    return lrr__mix64(x + 0x9e3779b97f4a7c15ULL);
}
static inline uint64_t lrr__splitmix64_next(uint64_t *state)
{
    uint64_t x = *state;
    *state = x + 0x9e3779b97f4a7c15ULL;
    return lrr__splitmix64(x);
}

#endif
