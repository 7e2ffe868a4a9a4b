/* Helpers of the picture tests (tests/output/test_render.c, test_camera.c, test_exr.c):
 * operators built by hand from triangles, so that they need no form factors, pictures
 * decoded again, and the temporary files an atomic write must not leave behind. */
#ifndef LRR_TESTS_RENDER_UTIL_H
#define LRR_TESTS_RENDER_UTIL_H

#include "testutil.h"

#include "operator/operator.h"

#include <dirent.h>
#include <sys/stat.h>

#include <stb_image.h>

/* An operator for the given triangles (one patch each, `levels` subdivisions); builtin is
 * the LRR__SCENE_* kind that chooses the render camera. */
static inline lrr_operator *ru_make_op(lrr_context *ctx, size_t n_tri, const float *vert,
                                       unsigned levels, int builtin)
{
    lrr__geometry g = {0};
    g.n_tri = n_tri;
    g.levels = levels;
    LRR_CHECK(ctx, lrr__calloc(ctx, &g.vert, n_tri, 9 * sizeof(float), "test vertices"));
    LRR_CHECK(ctx, lrr__calloc(ctx, &g.depth, n_tri, 1, "test depths"));
    LRR_CHECK(ctx, lrr__calloc(ctx, &g.patch0, n_tri + 1, sizeof(size_t), "test index"));
    memcpy(g.vert, vert, n_tri * 9 * sizeof(float));
    LRR_CHECK(ctx, lrr__geometry_index(ctx, &g, SIZE_MAX));
    lrr_operator *op = NULL;
    LRR_CHECK(ctx, lrr__operator_new(ctx, &g, LRR_STORAGE_F32, &op));
    op->builtin = builtin;
    lrr__geometry_free(&g);
    return op;
}

/* n×3 radiosity, every subpatch (r, g, b). */
static inline float *ru_uniform(size_t n, float r, float g, float b)
{
    float *B = malloc(n * 3 * sizeof *B);
    assert_non_null(B);
    for (size_t i = 0; i < n; i++) {
        B[3 * i] = r;
        B[3 * i + 1] = g;
        B[3 * i + 2] = b;
    }
    return B;
}

/* Renders to a PNG and decodes it (free with stbi_image_free). */
static inline unsigned char *ru_render(lrr_context *ctx, const lrr_operator *op,
                                       const float *b, const lrr_render_options *opts,
                                       const char *name, int *w, int *h)
{
    char path[512];
    tu_tmp_path(path, sizeof path, name);
    LRR_CHECK(ctx, lrr_render_png(op, b, opts, path));
    int comp = 0;
    unsigned char *img = stbi_load(path, w, h, &comp, 3);
    if (!img)
        fail_msg("%s: stb_image cannot decode it: %s", path, stbi_failure_reason());
    assert_int_equal(comp, 3);
    remove(path);
    return img;
}

static inline size_t ru_count_lit(const unsigned char *img, int w, int h)
{
    size_t lit = 0;
    for (size_t p = 0; p < (size_t)w * h; p++)
        if (img[3 * p] || img[3 * p + 1] || img[3 * p + 2])
            lit++;
    return lit;
}

static inline int ru_file_exists(const char *path)
{
    struct stat sb;
    return stat(path, &sb) == 0;
}

/* Where the tests write (LRR_TEST_TMP, else /tmp). */
static inline const char *ru_tmp_dir(void)
{
    const char *dir = getenv("LRR_TEST_TMP");
    return dir && *dir ? dir : "/tmp";
}

/* Number of entries in ru_tmp_dir() whose name starts with prefix. */
static inline int ru_count_prefixed(const char *prefix)
{
    DIR *d = opendir(ru_tmp_dir());
    assert_non_null(d);
    int count = 0;
    struct dirent *e;
    while ((e = readdir(d)))
        if (strncmp(e->d_name, prefix, strlen(prefix)) == 0)
            count++;
    closedir(d);
    return count;
}

#endif
