/* assimp's file I/O routed through lrr__open_regular (assimp_io.h says why). */
#include "config.h"
#include "scene/assimp_io.h"

#ifdef LRR_HAVE_ASSIMP

#include "core/path.h"

#include <assimp/cfileio.h>
#include <assimp/cimport.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

typedef struct io_state {
    char *refused;
    size_t len;
} io_state;

static FILE *file_of(struct aiFile *file)
{
    return (FILE *)(void *)file->UserData;
}

static size_t io_read(struct aiFile *file, char *buf, size_t size, size_t count)
{
    return fread(buf, size, count, file_of(file));
}

static size_t io_write(struct aiFile *file, const char *buf, size_t size, size_t count)
{
    (void)file, (void)buf, (void)size, (void)count;
    return 0; /* opened for reading only */
}

static size_t io_tell(struct aiFile *file)
{
    long at = ftell(file_of(file));
    return at < 0 ? 0 : (size_t)at;
}

static size_t io_size(struct aiFile *file)
{
    struct stat st;
    return fstat(fileno(file_of(file)), &st) == 0 && st.st_size > 0 ? (size_t)st.st_size : 0;
}

static void io_flush(struct aiFile *file)
{
    (void)file;
}

static enum aiReturn io_seek(struct aiFile *file, size_t offset, enum aiOrigin origin)
{
    int whence = origin == aiOrigin_CUR ? SEEK_CUR : origin == aiOrigin_END ? SEEK_END : SEEK_SET;
    /* (long) as assimp's own DefaultIOStream casts it: a backward SEEK_CUR wraps round */
    return fseek(file_of(file), (long)offset, whence) == 0 ? aiReturn_SUCCESS : aiReturn_FAILURE;
}

static struct aiFile *io_open(struct aiFileIO *io, const char *name, const char *mode)
{
    if (!name || !mode || strchr(mode, 'w') || strchr(mode, 'a') || strchr(mode, '+'))
        return NULL;
    FILE *f = NULL;
    int e = lrr__open_regular(name, &f, NULL);
    io_state *s = (io_state *)(void *)io->UserData;
    if (e == LRR__NOT_REGULAR && s->len && !s->refused[0])
        snprintf(s->refused, s->len, "%s", name);
    if (e)
        return NULL;
    struct aiFile *file = calloc(1, sizeof *file);
    if (!file) {
        fclose(f);
        return NULL;
    }
    *file = (struct aiFile){io_read, io_write, io_tell, io_size, io_seek, io_flush,
                            (aiUserData)(void *)f};
    return file;
}

static void io_close(struct aiFileIO *io, struct aiFile *file)
{
    (void)io;
    if (file) {
        fclose(file_of(file));
        free(file);
    }
}

const struct aiScene *lrr__assimp_import(const char *path, unsigned flags, char *refused,
                                         size_t len)
{
    if (len)
        refused[0] = '\0';
    io_state s = {refused, len};
    struct aiFileIO io = {io_open, io_close, (aiUserData)(void *)&s};
    return aiImportFileEx(path, flags, &io);
}

#else
typedef int lrr__assimp_io_unused; /* ISO C wants a declaration in every file */
#endif /* LRR_HAVE_ASSIMP */
