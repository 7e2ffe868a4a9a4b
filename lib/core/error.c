/* Contexts, status codes, error records, versions and checked allocation. */
#include "config.h"
#include "core/internal.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

const char *lrr_strerror(lrr_status status)
{
    switch (status) {
    case LRR_OK: return "success";
    case LRR_NOT_CONVERGED: return "iteration did not converge";
    case LRR_ERR_INVALID_ARG: return "invalid argument";
    case LRR_ERR_NOMEM: return "out of memory";
    case LRR_ERR_OVERFLOW: return "size overflow";
    case LRR_ERR_IO: return "input/output error";
    case LRR_ERR_FORMAT: return "unreadable file format";
    case LRR_ERR_CORRUPT: return "corrupted or truncated file";
    case LRR_ERR_VERSION: return "unsupported file version or kind";
    case LRR_ERR_GEOMETRY: return "invalid geometry";
    case LRR_ERR_MATERIAL: return "invalid material";
    case LRR_ERR_EMPTY: return "empty scene";
    case LRR_ERR_SINGULAR: return "singular matrix";
    case LRR_ERR_UNSUPPORTED: return "not supported by this build";
    case LRR_ERR_CANCELLED: return "cancelled";
    case LRR_ERR_DIM: return "dimension mismatch";
    case LRR_ERR_BUDGET: return "memory budget exceeded";
    }
    return "unknown status";
}

const char *lrr_version_string(void) { return LRR_VERSION_STRING; }
unsigned lrr_version(void) { return LRR_VERSION; }

/* configure's optional dependencies (config.h), in the order lrr.h documents */
#ifdef LRR_HAVE_ASSIMP
#define LRR__FEATURE_ASSIMP " assimp"
#else
#define LRR__FEATURE_ASSIMP ""
#endif
#ifdef LRR_HAVE_CGAL
#define LRR__FEATURE_CGAL " cgal"
#else
#define LRR__FEATURE_CGAL ""
#endif
#ifdef LRR_HAVE_OPENEXR
#define LRR__FEATURE_OPENEXR " openexr"
#else
#define LRR__FEATURE_OPENEXR ""
#endif
#ifdef LRR_HAVE_OPENCL
#define LRR__FEATURE_OPENCL " opencl"
#else
#define LRR__FEATURE_OPENCL ""
#endif

const char *lrr_features(void)
{
    static const char list[] =
        LRR__FEATURE_ASSIMP LRR__FEATURE_CGAL LRR__FEATURE_OPENEXR LRR__FEATURE_OPENCL;
    return list[0] ? list + 1 : list; /* each name has a leading space */
}

lrr_status lrr_context_create(lrr_context **out)
{
    *out = NULL;
    lrr_context *ctx = calloc(1, sizeof *ctx);
    if (!ctx)
        return LRR_ERR_NOMEM;
    if (pthread_mutex_init(&ctx->lock, NULL) != 0) {
        free(ctx);
        return LRR_ERR_NOMEM;
    }
    ctx->refs = 1;
    *out = ctx;
    return LRR_OK;
}

lrr_context *lrr__context_retain(lrr_context *ctx)
{
    if (ctx) {
        pthread_mutex_lock(&ctx->lock);
        ctx->refs++;
        pthread_mutex_unlock(&ctx->lock);
    }
    return ctx;
}

void lrr__context_release(lrr_context *ctx)
{
    if (!ctx)
        return;
    pthread_mutex_lock(&ctx->lock);
    int left = --ctx->refs;
    pthread_mutex_unlock(&ctx->lock);
    if (left == 0) {
        pthread_mutex_destroy(&ctx->lock);
        free(ctx);
    }
}

void lrr_context_destroy(lrr_context *ctx) { lrr__context_release(ctx); }

void lrr_context_set_error_callback(lrr_context *ctx, lrr_error_fn fn, void *user)
{
    pthread_mutex_lock(&ctx->lock);
    ctx->callback = fn;
    ctx->callback_user = user;
    pthread_mutex_unlock(&ctx->lock);
}

lrr_status lrr_context_last_error(lrr_context *ctx, char *msg, size_t msg_len)
{
    pthread_mutex_lock(&ctx->lock);
    lrr_status st = ctx->first_status;
    if (msg && msg_len > 0)
        snprintf(msg, msg_len, "%s", st == LRR_OK ? "" : ctx->first_message);
    ctx->first_status = LRR_OK;
    ctx->first_message[0] = '\0';
    pthread_mutex_unlock(&ctx->lock);
    return st;
}

lrr_status lrr__error(lrr_context *ctx, lrr_status status, const char *fmt, ...)
{
    if (!ctx)
        return status;
    char buf[sizeof ctx->first_message];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    pthread_mutex_lock(&ctx->lock);
    if (ctx->first_status == LRR_OK) {
        ctx->first_status = status;
        memcpy(ctx->first_message, buf, sizeof buf);
    }
    lrr_error_fn fn = ctx->callback;
    void *user = ctx->callback_user;
    pthread_mutex_unlock(&ctx->lock);
    if (fn)
        fn(user, status, buf);
    return status;
}

void *lrr_aligned_alloc(size_t size)
{
    if (size == 0)
        return NULL;
    size_t rounded = (size + 63) & ~(size_t)63;
    if (rounded < size)
        return NULL;
    return aligned_alloc(64, rounded);
}

void lrr_aligned_free(void *p) { free(p); }

void lrr__context_fail_after(lrr_context *ctx, unsigned long n)
{
    pthread_mutex_lock(&ctx->lock);
    ctx->alloc_count = 0;
    ctx->fail_at = n;
    pthread_mutex_unlock(&ctx->lock);
}

unsigned long lrr__context_alloc_count(lrr_context *ctx)
{
    pthread_mutex_lock(&ctx->lock);
    unsigned long n = ctx->alloc_count;
    pthread_mutex_unlock(&ctx->lock);
    return n;
}

void lrr__context_set_io_hook(lrr_context *ctx, lrr__io_hook_fn hook, void *user)
{
    pthread_mutex_lock(&ctx->lock);
    ctx->io_hook = hook;
    ctx->io_user = user;
    ctx->io_steps = 0;
    pthread_mutex_unlock(&ctx->lock);
}

int lrr__io_step(lrr_context *ctx, const char *what)
{
    if (!ctx)
        return 0;
    pthread_mutex_lock(&ctx->lock);
    lrr__io_hook_fn hook = ctx->io_hook;
    void *user = ctx->io_user;
    unsigned long step = hook ? ++ctx->io_steps : 0;
    pthread_mutex_unlock(&ctx->lock);
    return hook ? hook(user, step, what) : 0; /* outside the lock: it may not return */
}

/* Counts one allocation on ctx; false when it is the one to fail. */
static bool count_alloc(lrr_context *ctx)
{
    if (!ctx)
        return true;
    pthread_mutex_lock(&ctx->lock);
    bool ok = ++ctx->alloc_count != ctx->fail_at;
    pthread_mutex_unlock(&ctx->lock);
    return ok;
}

void *lrr__alloc(lrr_context *ctx, size_t bytes)
{
    return count_alloc(ctx) ? malloc(bytes ? bytes : 1) : NULL;
}

void *lrr__zalloc(lrr_context *ctx, size_t bytes)
{
    return count_alloc(ctx) ? calloc(1, bytes ? bytes : 1) : NULL;
}

void *lrr__realloc(lrr_context *ctx, void *p, size_t bytes)
{
    return count_alloc(ctx) ? realloc(p, bytes ? bytes : 1) : NULL;
}

lrr_status lrr__calloc(lrr_context *ctx, void *out, size_t count, size_t elem, const char *what)
{
    void **res = out;
    *res = NULL;
    size_t bytes;
    if (!lrr__mul_size(count, elem, &bytes) || bytes > SIZE_MAX - 64)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "%s: %zu × %zu bytes overflows size_t", what,
                          count, elem);
    void *p = count_alloc(ctx) ? lrr_aligned_alloc(bytes ? bytes : 64) : NULL;
    if (!p)
        return lrr__error(ctx, LRR_ERR_NOMEM, "%s: cannot allocate %zu bytes (%.1f MiB)", what,
                          bytes, bytes / 1048576.0);
    memset(p, 0, bytes ? bytes : 64);
    *res = p;
    return LRR_OK;
}

double lrr__now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

const char *lrr__errno_text(int err, char *buf, size_t len)
{
    /* strerror() may share one buffer between threads; strerror_r does not. glibc gives the
     * GNU variant (returns the text, maybe not in buf) under _GNU_SOURCE, else POSIX's. */
#if defined(__GLIBC__) && defined(_GNU_SOURCE)
    return strerror_r(err, buf, len);
#else
    if (strerror_r(err, buf, len) != 0)
        snprintf(buf, len, "error %d", err);
    return buf;
#endif
}

/* ------------------------------------------------------------ the atomic writer's hooks */
static int atomic_step(void *user, const char *what)
{
    return lrr__io_step(user, what);
}

static void *atomic_alloc(void *user, size_t bytes)
{
    return lrr__alloc(user, bytes);
}

void lrr__context_atomic_io(lrr_context *ctx, lrr__atomic_io *io)
{
    io->step = atomic_step;
    io->alloc = atomic_alloc;
    io->user = ctx;
}

lrr_status lrr__atomic_error(lrr_context *ctx, const lrr__atomic_file *w)
{
    if (!w->tmp)
        return lrr__error(ctx, LRR_ERR_NOMEM, "file %s: no memory for the temporary name",
                          w->path);
    char eb[128];
    return lrr__error(ctx, LRR_ERR_IO, "file %s: %s (%s): %s", w->path, w->what, w->tmp,
                      lrr__errno_text(w->err, eb, sizeof eb));
}
