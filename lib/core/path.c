/* Regular files only, checked before anything can block (path.h says why). */
#include "config.h"
#include "core/path.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <strings.h>
#include <unistd.h>

static int classify(const struct stat *st)
{
    if (S_ISREG(st->st_mode))
        return 0;
    return S_ISDIR(st->st_mode) ? EISDIR : LRR__NOT_REGULAR;
}

int lrr__stat_regular(const char *path, struct stat *st)
{
    struct stat local;
    if (!st)
        st = &local;
    if (stat(path, st) != 0)
        return errno ? errno : EIO;
    return classify(st);
}

int lrr__open_regular_fd(const char *path, int *fd, struct stat *st)
{
    struct stat local;
    if (!st)
        st = &local;
    *fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
    if (*fd < 0) {
        /* a socket fails here (ENXIO): said as for any other file that is not regular */
        int e = errno ? errno : EIO;
        return stat(path, st) == 0 && !S_ISREG(st->st_mode) && !S_ISDIR(st->st_mode)
                   ? LRR__NOT_REGULAR
                   : e;
    }
    int e = fstat(*fd, st) != 0 ? errno : classify(st);
    int flags = e ? 0 : fcntl(*fd, F_GETFL);
    if (!e && (flags < 0 || fcntl(*fd, F_SETFL, flags & ~O_NONBLOCK) != 0))
        e = errno;
    if (e) {
        close(*fd);
        *fd = -1;
    }
    return e;
}

int lrr__open_regular(const char *path, FILE **f, struct stat *st)
{
    *f = NULL;
    int fd;
    int e = lrr__open_regular_fd(path, &fd, st);
    if (!e && !(*f = fdopen(fd, "rb"))) {
        e = errno ? errno : ENOMEM;
        close(fd);
    }
    return e;
}

int lrr__path_has_extension(const char *path, const char *ext)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    return dot && (!slash || dot > slash) && strcasecmp(dot + 1, ext) == 0;
}
