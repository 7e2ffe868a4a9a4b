/* The atomic file writer (atomic_file.h says what it guarantees and who uses it). */
#include "config.h"
#include "core/atomic_file.h"

#include <errno.h>
#include <fcntl.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

static const char tmp_suffix[] = ".tmp.XXXXXX";

/* The injected errno for the next step, 0 to go ahead. */
static int step(const lrr__atomic_file *w, const char *what)
{
    return w->io && w->io->step ? w->io->step(w->io->user, what) : 0;
}

/* mkstemp creates 0600; give the file the mode an ordinary creat(0666) would have: that of
 * the file being replaced, else 0666 minus the umask. umask() itself cannot be read without
 * changing it (process-wide, racy under threads), so read it from /proc when available. */
static mode_t new_file_mode(const char *path)
{
    struct stat st;
    if (stat(path, &st) == 0 && S_ISREG(st.st_mode))
        return st.st_mode & 07777;
    mode_t mask = 022;
    FILE *f = fopen("/proc/self/status", "re");
    if (f) {
        char line[256];
        while (fgets(line, sizeof line, f)) {
            unsigned m;
            if (sscanf(line, "Umask: %o", &m) == 1) {
                mask = (mode_t)(m & 0777);
                break;
            }
        }
        fclose(f);
    }
    return 0666 & ~mask;
}

/* After rename, the directory entry itself must reach the disk for the new name to survive
 * a crash. Best effort: some file systems refuse fsync on directories, and the data is
 * already safe under one of the two names. The directory name is cut from tmp (same
 * directory, already allocated). */
static void sync_parent_dir(char *tmp)
{
    char *slash = strrchr(tmp, '/');
    const char *dir = ".";
    if (slash == tmp)
        dir = "/";
    else if (slash) {
        *slash = '\0';
        dir = tmp;
    }
    int fd = open(dir, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (slash)
        *slash = '/';
    if (fd >= 0) {
        (void)fsync(fd);
        close(fd);
    }
}

static int fail(lrr__atomic_file *w, int err, const char *what)
{
    if (!w->err) {
        w->err = err ? err : EIO;
        w->what = what;
    }
    return w->err;
}

int lrr__atomic_open(lrr__atomic_file *w, const char *path, const lrr__atomic_io *io)
{
    memset(w, 0, sizeof *w);
    w->path = path;
    w->io = io;
    size_t plen = strlen(path);
    if (plen > SIZE_MAX - sizeof tmp_suffix)
        return fail(w, ENAMETOOLONG, "cannot name the temporary file");
    size_t bytes = plen + sizeof tmp_suffix;
    w->tmp = io && io->alloc ? io->alloc(io->user, bytes) : malloc(bytes);
    if (!w->tmp)
        return fail(w, ENOMEM, "no memory for the temporary name");
    memcpy(w->tmp, path, plen);
    memcpy(w->tmp + plen, tmp_suffix, sizeof tmp_suffix);
    int err = step(w, "create");
    int fd = err ? -1 : mkstemp(w->tmp);
    if (fd < 0)
        return fail(w, err ? err : errno, "cannot create temporary file");
    (void)fcntl(fd, F_SETFD, FD_CLOEXEC); /* mkostemp would need _GNU_SOURCE */
    if (fchmod(fd, new_file_mode(path)) != 0) {
        fail(w, errno, "cannot set the mode of the temporary file");
        close(fd);
        unlink(w->tmp);
        return w->err;
    }
    if (!(w->f = fdopen(fd, "wb"))) {
        fail(w, errno, "cannot open temporary file");
        close(fd);
        unlink(w->tmp);
        return w->err;
    }
    return 0;
}

int lrr__atomic_write(lrr__atomic_file *w, const void *p, size_t len)
{
    int err;
    if (w->err || len == 0)
        return w->err;
    if ((err = step(w, "write")))
        return fail(w, err, "cannot write temporary file");
    errno = 0;
    if (fwrite(p, 1, len, w->f) != len)
        return fail(w, errno, "cannot write temporary file");
    return 0;
}

int lrr__atomic_skip(lrr__atomic_file *w, size_t len)
{
    if (w->err || len == 0)
        return w->err;
    if (len > (size_t)INT64_MAX || fseeko(w->f, (off_t)len, SEEK_CUR) != 0)
        return fail(w, len > (size_t)INT64_MAX ? EOVERFLOW : errno,
                    "cannot seek in temporary file");
    return 0;
}

int lrr__atomic_commit(lrr__atomic_file *w)
{
    static const char *const wr = "cannot write temporary file";
    int err;
    if (!w->err && ferror(w->f))
        fail(w, EIO, wr);
    if (!w->err && ((err = step(w, "flush")) || fflush(w->f) != 0))
        fail(w, err ? err : errno, wr);
    if (!w->err && ((err = step(w, "fsync")) || fsync(fileno(w->f)) != 0))
        fail(w, err ? err : errno, wr);
    err = w->err ? 0 : step(w, "close");
    if (fclose(w->f) != 0)
        fail(w, errno, wr);
    w->f = NULL;
    if (err)
        fail(w, err, wr);
    if (!w->err && ((err = step(w, "rename")) || rename(w->tmp, w->path) != 0))
        fail(w, err ? err : errno, "cannot rename the temporary file onto it");
    if (w->err) {
        unlink(w->tmp);
        return w->err;
    }
    (void)step(w, "sync directory"); /* best effort: an injected error changes nothing */
    sync_parent_dir(w->tmp);
    return 0;
}

void lrr__atomic_abort(lrr__atomic_file *w)
{
    if (w->f) {
        fclose(w->f);
        w->f = NULL;
        unlink(w->tmp);
    }
}

void lrr__atomic_free(lrr__atomic_file *w)
{
    free(w->tmp);
    w->tmp = NULL;
}
