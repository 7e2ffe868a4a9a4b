/* assimp's file I/O routed through lrr__open_regular (assimp_io.h says why). */
#include "config.h"
#include "scene/assimp_io.h"

#ifdef LRR_HAVE_ASSIMP

#include "core/path.h"
#include "scene/gltf_ext.h"
#include "scene/scene.h"

#include <assimp/cfileio.h>
#include <assimp/cimport.h>

#include <errno.h>
#include <stdint.h>
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

/* ------------------------------------------------------------------ checks before assimp */
/* assimp's own message for a missing file is vague ("Unable to open file"), so check first;
 * it would also block in its own fopen of a FIFO, hence lrr__open_regular (core/path.h). */
static lrr_status check_readable(lrr_context *ctx, const char *path)
{
    FILE *f = NULL;
    int e = lrr__open_regular(path, &f, NULL);
    if (e == EISDIR)
        return lrr__error(ctx, LRR_ERR_IO, "file %s: is a directory, not a scene file", path);
    if (e == LRR__NOT_REGULAR)
        return lrr__error(ctx, LRR_ERR_IO, "file %s: " LRR__NOT_REGULAR_TEXT, path);
    if (e) {
        char eb[128];
        return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot open: %s", path,
                          lrr__errno_text(e, eb, sizeof eb));
    }
    fclose(f);
    return LRR_OK;
}

/* lrr__ply_check (scene/ply.c), when assimp will read path as PLY: by the extension, or by
 * the "ply" signature when the extension is not one of the other formats. */
static lrr_status check_if_ply(lrr_context *ctx, const char *path)
{
    int other = lrr__path_has_extension(path, "obj") || lrr__path_has_extension(path, "gltf") ||
                 lrr__path_has_extension(path, "glb");
    if (other)
        return LRR_OK;
    FILE *f = NULL;
    if (lrr__open_regular(path, &f, NULL) != 0)
        return LRR_OK; /* check_readable has reported it */
    char magic[4] = "";
    size_t got = fread(magic, 1, 4, f);
    struct stat st;
    lrr_status status = LRR_OK;
    if ((lrr__path_has_extension(path, "ply") ||
         (got == 4 && memcmp(magic, "ply", 3) == 0 && (magic[3] == '\n' || magic[3] == '\r'))) &&
        fstat(fileno(f), &st) == 0 && st.st_size >= 0) {
        rewind(f);
        status = lrr__ply_check(ctx, path, f, (uint64_t)st.st_size);
    }
    fclose(f);
    return status;
}

lrr_status lrr__assimp_read(lrr_context *ctx, const char *path, const struct aiScene **out)
{
    *out = NULL;
    lrr_status st = check_readable(ctx, path);
    if (st == LRR_OK)
        st = check_if_ply(ctx, path);
    float *strength = NULL;
    if (st == LRR_OK &&
        (lrr__path_has_extension(path, "gltf") || lrr__path_has_extension(path, "glb")))
        st = lrr__gltf_emissive_strength(ctx, path, NULL, &strength);
    free(strength);
    if (st != LRR_OK)
        return st;
    /* No post-processing: triangulation, normals and winding are import.c's. */
    char refused[512];
    const struct aiScene *scene = lrr__assimp_import(path, 0, refused, sizeof refused);
    if (refused[0]) {
        aiReleaseImport(scene);
        return lrr__error(ctx, LRR_ERR_IO, "file %s: %s: " LRR__NOT_REGULAR_TEXT, path,
                          refused);
    }
    if (!scene) {
        const char *why = aiGetErrorString();
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: cannot import: %s", path,
                          why && *why ? why : "assimp gave no reason");
    }
    *out = scene;
    return LRR_OK;
}

#else
typedef int lrr__assimp_io_unused; /* ISO C wants a declaration in every file */
#endif /* LRR_HAVE_ASSIMP */
