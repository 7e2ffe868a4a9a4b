/* Opening a user's path for reading without blocking on it. open() of a FIFO that has no
 * writer waits for one (`mkfifo g.obj; lrr info g.obj` waited forever), a character device
 * such as /dev/zero never reaches its end and a socket cannot be opened at all, so every
 * path the library and the tools read (scenes, .lrr files, textures, light probes, scripts,
 * CSVs) goes through one of these first and anything but a regular file is refused with the
 * same words, LRR__NOT_REGULAR_TEXT.
 *
 * lrr__open_regular opens with O_NONBLOCK (a FIFO's open returns at once), checks the
 * descriptor with fstat and only then clears O_NONBLOCK: no window between the check and
 * the open. lrr__stat_regular is for a path another library opens itself (assimp, OpenEXR):
 * stat() before handing it over, which leaves a window only for a file replaced meanwhile.
 *
 * Self-contained (POSIX and stdio only, no lrr_context), like atomic_file.c: tools/ and
 * bench/ compile this file into their programs. */
#ifndef LRR_CORE_PATH_H
#define LRR_CORE_PATH_H

#include <stdio.h>
#include <sys/stat.h>

/* Returned for a FIFO, socket or device (never a valid errno, which is positive). */
#define LRR__NOT_REGULAR (-1)
#define LRR__NOT_REGULAR_TEXT "not a regular file"

#ifdef __cplusplus
extern "C" {
#endif

/* Opens path for reading ("rb", close-on-exec). Returns 0 with *f open and *st its fstat,
 * or, with *f = NULL: the errno of open/fstat, EISDIR for a directory, LRR__NOT_REGULAR for
 * anything else that is not a regular file. st may be NULL. */
int lrr__open_regular(const char *path, FILE **f, struct stat *st);
/* The same as a descriptor (O_RDONLY | O_CLOEXEC, blocking): 0 with *fd open, or the same
 * codes with *fd = -1. */
int lrr__open_regular_fd(const char *path, int *fd, struct stat *st);
/* The same check by stat() without opening: 0, an errno, EISDIR or LRR__NOT_REGULAR. */
int lrr__stat_regular(const char *path, struct stat *st);

/* Whether path's extension (after the last '.' of its last component) is ext, any case. */
int lrr__path_has_extension(const char *path, const char *ext);

#ifdef __cplusplus
}
#endif

#endif /* LRR_CORE_PATH_H */
