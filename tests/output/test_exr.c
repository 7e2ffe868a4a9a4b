/* lrr_render_exr (lib/output/exr.cpp): linear radiosity, read back with the probe reader
 * (lrr__exr_read_rgb, which wants width = 2 × height), the same coverage as the PNG, and
 * atomic writing. */
#include "output/render_util.h"

#include "probe/probe.h"

#include <errno.h>

/* A float32 pixel is B times the exposure, both floats: 2 roundings, k = 2
 * (TU_TOL_FLT(2, 2) below). */

/* Uniform radiosity B = (0.25, 0.5, 2): every covered pixel holds B (float precision), no
 * exposure or curve applied, the background is exactly 0, and the covered pixels are the
 * PNG's lit ones. */
static void test_linear_values(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108];
    tu_box_inward(v, 2, 1, 1.5);
    lrr_operator *op = ru_make_op(ctx, 12, v, 2, LRR__SCENE_FILE);
    const float want[3] = {0.25f, 0.5f, 2.0f};
    float *B = ru_uniform(op->n, want[0], want[1], want[2]);
    lrr_render_options o = lrr_render_options_defaults();
    o.width = 128;
    o.height = 64;
    o.exposure = 7; /* the PNG's business only */
    char path[512];
    tu_tmp_path(path, sizeof path, "render.exr");
    LRR_CHECK(ctx, lrr_render_exr(op, B, &o, path));
    float *rgb = NULL;
    size_t w = 0, h = 0;
    LRR_CHECK(ctx, lrr__exr_read_rgb(ctx, path, &rgb, &w, &h));
    assert_int_equal(w, 128);
    assert_int_equal(h, 64);
    int pw, ph;
    unsigned char *png = ru_render(ctx, op, B, &o, "render-exr.png", &pw, &ph);
    size_t covered = 0;
    for (size_t p = 0; p < w * h; p++) {
        const float *c = rgb + 3 * p;
        int lit = png[3 * p] || png[3 * p + 1] || png[3 * p + 2];
        if (!lit) {
            if (c[0] != 0 || c[1] != 0 || c[2] != 0)
                fail_msg("background pixel %zu = (%g, %g, %g)", p, c[0], c[1], c[2]);
            continue;
        }
        covered++;
        for (int j = 0; j < 3; j++)
            ASSERT_NEAR(c[j], want[j], TU_TOL_FLT(2, 2) * want[j], "pixel %zu channel %d", p, j);
    }
    assert_true(covered > w * h / 8 && covered < w * h * 9 / 10);
    assert_true(rgb[0] == 0); /* a corner */
    free(rgb);
    stbi_image_free(png);
    remove(path);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Errors: bad options and radiosity leave no file; an unwritable destination is
 * LRR_ERR_IO; a fault at any step of the atomic writer leaves neither the file nor a
 * temporary one, and an existing file is replaced whole. */
typedef struct exr_fault {
    unsigned long at, steps;
} exr_fault;

static int exr_inject(void *user, unsigned long step, const char *what)
{
    (void)what;
    exr_fault *f = user;
    f->steps = step;
    return step == f->at ? ENOSPC : 0;
}

static void test_errors_atomic(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108];
    tu_box_inward(v, 1, 1, 1);
    lrr_operator *op = ru_make_op(ctx, 12, v, 0, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 1, 1, 1);
    lrr_render_options o = lrr_render_options_defaults();
    o.width = 32;
    o.height = 16;
    char path[512], dir[512], msg[512], prefix[256];
    tu_tmp_path(path, sizeof path, "render-errors.exr");
    remove(path);
    snprintf(prefix, sizeof prefix, "%s.tmp.", strrchr(path, '/') + 1);

    o.fov_degrees = 200;
    assert_int_equal(lrr_render_exr(op, B, &o, path), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
    assert_non_null(strstr(msg, "fov_degrees"));
    o.fov_degrees = 0;
    B[4] = NAN;
    assert_int_equal(lrr_render_exr(op, B, &o, path), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
    assert_non_null(strstr(msg, "subpatch 1"));
    B[4] = 1;
    assert_false(ru_file_exists(path));

    tu_tmp_path(dir, sizeof dir, "render-exr-dir");
    assert_int_equal(mkdir(dir, 0755), 0);
    assert_int_equal(lrr_render_exr(op, B, &o, dir), LRR_ERR_IO);
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_IO);
    assert_non_null(strstr(msg, dir));
    assert_int_equal(rmdir(dir), 0);

    exr_fault f = {0};
    lrr__context_set_io_hook(ctx, exr_inject, &f); /* at = 0: count the steps */
    LRR_CHECK(ctx, lrr_render_exr(op, B, &o, path));
    const unsigned long steps = f.steps;
    assert_true(steps >= 7);
    for (unsigned long at = 1; at < steps; at++) { /* the last, the directory sync, is best effort */
        f = (exr_fault){.at = at};
        lrr__context_set_io_hook(ctx, exr_inject, &f); /* counts from 1 again */
        FILE *old = fopen(path, "wb");
        assert_non_null(old);
        fputs("old", old);
        fclose(old);
        assert_int_equal(lrr_render_exr(op, B, &o, path), LRR_ERR_IO);
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_IO);
        assert_non_null(strstr(msg, path));
        /* the old file is intact, no temporary file is left */
        FILE *in = fopen(path, "rb");
        char buf[8] = {0};
        assert_non_null(in);
        assert_int_equal(fread(buf, 1, sizeof buf, in), 3);
        fclose(in);
        assert_string_equal(buf, "old");
        assert_int_equal(ru_count_prefixed(prefix), 0);
    }
    lrr__context_set_io_hook(ctx, NULL, NULL);
    LRR_CHECK(ctx, lrr_render_exr(op, B, &o, path));
    float *rgb = NULL;
    size_t w, h;
    LRR_CHECK(ctx, lrr__exr_read_rgb(ctx, path, &rgb, &w, &h));
    assert_int_equal(w, 32);
    free(rgb);
    remove(path);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    TU_REQUIRE_PROGRAM("test_exr", "openexr");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_linear_values),
        cmocka_unit_test(test_errors_atomic),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
