/* The one atomic file writer of lrr: the library's .lrr files and pictures, the lrr tool's
 * CSV and OBJ outputs and lrr-bench's tables and plots all write through it, so no output
 * ever appears half-written under its final name.
 *
 * Writing goes to "PATH.tmp.XXXXXX" in PATH's directory (rename() stays on one file system),
 * which gets the mode an ordinary creat(0666) would give (that of the file it replaces, else
 * 0666 minus the umask); lrr__atomic_commit flushes, fsyncs and closes it, renames it onto
 * PATH and syncs the directory (best effort). Any failure removes the temporary file; a
 * process killed mid-write leaves it behind, never a partial PATH.
 *
 * Self-contained (POSIX and stdio only, no lrr_context): tools/ and bench/ compile this file
 * into their programs, as liblrr.so exports only the public API. The library passes an I/O
 * hook that injects faults (lrr__io_step) and an allocator that counts (lrr__alloc). */
#ifndef LRR_CORE_ATOMIC_FILE_H
#define LRR_CORE_ATOMIC_FILE_H

#include <stddef.h>
#include <stdio.h>

typedef struct lrr__atomic_io {
    /* Called before each step ("create", every lrr__atomic_write "write", "flush", "fsync",
     * "close", "rename", "sync directory"); a non-zero return is the errno that step fails
     * with, and the step is not attempted ("sync directory" is best effort: ignored). NULL:
     * no hook. */
    int (*step)(void *user, const char *what);
    /* Allocates the temporary name (free()d); NULL: malloc. */
    void *(*alloc)(void *user, size_t bytes);
    void *user;
} lrr__atomic_io;

typedef struct lrr__atomic_file {
    FILE *f;          /* the temporary file: lrr__atomic_write, or stdio on f directly */
    char *tmp;        /* its name; valid until lrr__atomic_free */
    const char *path; /* the final name (the caller's string, kept until commit) */
    const lrr__atomic_io *io;
    int err;          /* errno of the first failure, 0 if none */
    const char *what; /* what failed, for a message: "cannot write temporary file", ... */
} lrr__atomic_file;

/* Creates the temporary file. Returns 0, or an errno with w->what set and nothing left on
 * disk (ENOMEM when the name cannot be allocated); lrr__atomic_free(w) in both cases. io may
 * be NULL. */
int lrr__atomic_open(lrr__atomic_file *w, const char *path, const lrr__atomic_io *io);
/* Writes len bytes (one "write" step); the first error sticks and is returned. */
int lrr__atomic_write(lrr__atomic_file *w, const void *p, size_t len);
/* Moves on len bytes without writing them (a range other processes write: the file's size
 * then covers it once they have). Returns 0 or the first error, as lrr__atomic_write. */
int lrr__atomic_skip(lrr__atomic_file *w, size_t len);
/* Ends the file: flush, fsync, close, rename onto path, sync the directory. Returns 0, or
 * the errno of the first failure (an earlier write's, or a stdio error on f: EIO) with
 * w->what set and the temporary file removed. Then lrr__atomic_free(w). */
int lrr__atomic_commit(lrr__atomic_file *w);
/* Gives up: closes and removes the temporary file. Then lrr__atomic_free(w). */
void lrr__atomic_abort(lrr__atomic_file *w);
/* Frees the temporary name (after open failed, commit or abort). */
void lrr__atomic_free(lrr__atomic_file *w);

#endif
