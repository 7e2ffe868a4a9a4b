/* Helpers of the fuzz targets: see fuzz.h. */
#include "fuzz.h"

#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <omp.h>

#define MAX_NAMES 8
#define PATH_CAP 4096

static char dir[PATH_CAP - 80]; /* room for "/name" in a path */
static struct {
    char name[64];
    char path[PATH_CAP];
} files[MAX_NAMES];

void fuzz_fail(const char *fmt, ...)
{
    va_list ap;
    fputs("fuzz target: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    abort();
}

/* Best effort at exit: files left by an input that crashed stay with the directory. */
static void remove_dir(void)
{
    for (int i = 0; i < MAX_NAMES; i++)
        if (files[i].name[0])
            unlink(files[i].path);
    rmdir(dir);
}

void fuzz_init(void)
{
    if (dir[0])
        return;
    const char *tmp = getenv("TMPDIR");
    if (!tmp || !*tmp)
        tmp = "/tmp";
    int len = snprintf(dir, sizeof dir, "%s/lrr-fuzz-XXXXXX", tmp);
    if (len < 0 || (size_t)len >= sizeof dir || !mkdtemp(dir))
        fuzz_fail("cannot create a private directory under %s: %s", tmp, strerror(errno));
    atexit(remove_dir);
    omp_set_num_threads(1);
}

static const char *path_of(const char *name)
{
    fuzz_init();
    int free_slot = -1;
    for (int i = 0; i < MAX_NAMES; i++) {
        if (strcmp(files[i].name, name) == 0)
            return files[i].path;
        if (!files[i].name[0] && free_slot < 0)
            free_slot = i;
    }
    if (free_slot < 0 || strlen(name) >= sizeof files[0].name)
        fuzz_fail("too many or too long file names (%s)", name);
    strcpy(files[free_slot].name, name);
    snprintf(files[free_slot].path, PATH_CAP, "%s/%s", dir, name);
    return files[free_slot].path;
}

const char *fuzz_write(const char *name, const void *data, size_t size)
{
    const char *path = path_of(name);
    FILE *f = fopen(path, "wb");
    if (!f)
        fuzz_fail("cannot create %s: %s", path, strerror(errno));
    if ((size && fwrite(data, 1, size, f) != size) || fclose(f) != 0)
        fuzz_fail("cannot write %s: %s", path, strerror(errno));
    return path;
}

void fuzz_remove(const char *name)
{
    const char *path = path_of(name);
    if (unlink(path) != 0 && errno != ENOENT)
        fuzz_fail("cannot remove %s: %s", path, strerror(errno));
}
