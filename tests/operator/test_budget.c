/* The memory budget of lrr_operator_build (lrr_build_options.memory_budget) and the size
 * checks before it allocates: a budget one byte below the need is refused with
 * LRR_ERR_BUDGET, the message naming the need in MiB, and no allocation is made through the
 * context; the exact need and above build; sizes whose byte counts overflow size_t are
 * refused with LRR_ERR_OVERFLOW, again before any allocation. */
#include "testutil.h"
#include "formfactor/formfactor.h"
#include "operator/operator.h"

static lrr_scene *cornell(lrr_context *ctx, size_t patches, unsigned levels)
{
    lrr_scene *scene = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sub = {.target_patches = patches, .levels = levels};
    LRR_CHECK(ctx, lrr_scene_subdivide(scene, &sub));
    return scene;
}

/* The need the library computes for this scene and these options. */
static lrr__operator_bytes_t need_of(lrr_context *ctx, const lrr_scene *scene,
                                     const lrr_build_options *bo)
{
    lrr__operator_bytes_t b;
    LRR_CHECK(ctx, lrr__operator_bytes(ctx, scene->geom.n_tri, scene->geom.n, scene->geom.k,
                                       LRR_STORAGE_F32, bo, &b));
    return b;
}

static void test_budget_boundary(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *scene = cornell(ctx, 60, 1);
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    lrr_build_options bo = {.hemicube_resolution = 16, .seed = 3, .threads = 2};
    lrr__operator_bytes_t b = need_of(ctx, scene, &bo);
    const size_t n = si.subpatches, k = si.patches;
    /* the parts are what the operator keeps and the build's working set */
    assert_int_equal(b.fbar, n * k * sizeof(float));
    assert_int_equal(b.m, 3 * k * k * sizeof(float));
    assert_true(b.per_subpatch >= 13 * n * sizeof(float));
    assert_true(b.working >= 2 * 3 * 16 * 16 * (sizeof(float) + sizeof(int32_t)));
    assert_true(b.working >= k * k * sizeof(double)); /* G of the factorisation */
    assert_int_equal(b.total, b.fbar + b.m + b.per_subpatch + b.working);
    assert_int_equal(b.threads, 2);

    /* one byte short: refused before any allocation, the need named in MiB */
    bo.memory_budget = b.total - 1;
    lrr__context_fail_after(ctx, 0);
    lrr_operator *op = (lrr_operator *)&op; /* must be reset to NULL */
    assert_int_equal(lrr_operator_build(scene, &bo, &op), LRR_ERR_BUDGET);
    assert_null(op);
    assert_int_equal(lrr__context_alloc_count(ctx), 0);
    char msg[512], want[64];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_BUDGET);
    snprintf(want, sizeof want, "needs %.1f MiB", b.total / 1048576.0);
    if (!strstr(msg, want))
        fail_msg("message \"%s\" does not say \"%s\"", msg, want);
    snprintf(want, sizeof want, "n = %zu subpatches and k = %zu patches", n, k);
    if (!strstr(msg, want))
        fail_msg("message \"%s\" does not say \"%s\"", msg, want);
    assert_non_null(strstr(msg, "memory budget of"));

    /* exactly the need, and one byte more: builds, and what the operator keeps is within */
    for (size_t extra = 0; extra < 2; extra++) {
        bo.memory_budget = b.total + extra;
        LRR_CHECK(ctx, lrr_operator_build(scene, &bo, &op));
        lrr_operator_info info;
        lrr_operator_get_info(op, &info, sizeof info);
        assert_true(info.bytes <= b.fbar + b.m + b.per_subpatch);
        assert_true(info.bytes >= b.fbar + b.m);
        lrr_operator_destroy(op);
    }
    /* 0: no limit */
    bo.memory_budget = 0;
    LRR_CHECK(ctx, lrr_operator_build(scene, &bo, &op));
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
}

/* More threads hold more hemicube buffers; 16-bit storage halves F̄ and adds n row scales. */
static void test_budget_parts(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr__operator_bytes_t one, eight, f16;
    lrr_build_options bo = {.hemicube_resolution = 512, .threads = 1};
    const size_t n = 4096, k = 64, n_tri = 36;
    LRR_CHECK(ctx, lrr__operator_bytes(ctx, n_tri, n, k, LRR_STORAGE_F32, &bo, &one));
    bo.threads = 8;
    LRR_CHECK(ctx, lrr__operator_bytes(ctx, n_tri, n, k, LRR_STORAGE_F32, &bo, &eight));
    /* per thread: depth, item and leaf-code buffers (3R² floats, int32 and uint32) and one
     * row of k doubles */
    assert_int_equal(eight.working - one.working,
                     7 * (3 * 512 * 512 * (sizeof(float) + sizeof(int32_t) + sizeof(uint32_t)) +
                          k * sizeof(double)));
    LRR_CHECK(ctx, lrr__operator_bytes(ctx, n_tri, n, k, LRR_STORAGE_F16, &bo, &f16));
    assert_int_equal(f16.fbar, n * k * 2 + n * sizeof(float));
    /* a bad resolution is refused here too, before anything is allocated */
    bo.hemicube_resolution = 6;
    assert_int_equal(lrr__operator_bytes(ctx, n_tri, n, k, LRR_STORAGE_F32, &bo, &one),
                     LRR_ERR_INVALID_ARG);
    char msg[256];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
    assert_non_null(strstr(msg, "hemicube resolution 6"));
    lrr_context_destroy(ctx);
}

/* Byte counts that overflow size_t: LRR_ERR_OVERFLOW naming n and k, before any allocation.
 * The Cornell box split into ~2.4 million patches (depth 8 per triangle: the hierarchy is
 * stored per triangle, so this costs nothing) with 10 more levels: n = k·4^10 ≈ 2.5e12 and
 * n·k·4 ≈ 2.4e19 > 2^64. */
static void test_overflow(void **state)
{
    (void)state;
    if (sizeof(size_t) < 8)
        skip();
    lrr_context *ctx = tu_context();
    lrr_scene *scene = cornell(ctx, 2400000, 10);
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    size_t bytes;
    assert_false(lrr__mul_size(si.subpatches, si.patches, &bytes) &&
                 lrr__mul_size(bytes, sizeof(float), &bytes));
    for (size_t budget = 0; budget < 2; budget++) {
        lrr_build_options bo = {.hemicube_resolution = 16, .memory_budget = budget << 30};
        lrr__context_fail_after(ctx, 0);
        lrr_operator *op = (lrr_operator *)&op;
        assert_int_equal(lrr_operator_build(scene, &bo, &op), LRR_ERR_OVERFLOW);
        assert_null(op);
        assert_int_equal(lrr__context_alloc_count(ctx), 0);
        char msg[512], want[96];
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_OVERFLOW);
        snprintf(want, sizeof want, "n = %zu subpatches and k = %zu patches", si.subpatches,
                 si.patches);
        if (!strstr(msg, want) || !strstr(msg, "overflows"))
            fail_msg("message \"%s\" does not say \"%s ... overflows\"", msg, want);
    }
    /* a size that fits size_t but not the budget: LRR_ERR_BUDGET, still before allocating */
    lrr_scene_destroy(scene);
    scene = cornell(ctx, 100000, 4);
    lrr_build_options bo = {.hemicube_resolution = 16, .memory_budget = (size_t)1 << 30};
    lrr__context_fail_after(ctx, 0);
    lrr_operator *op;
    assert_int_equal(lrr_operator_build(scene, &bo, &op), LRR_ERR_BUDGET);
    assert_int_equal(lrr__context_alloc_count(ctx), 0);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_budget_boundary),
        cmocka_unit_test(test_budget_parts),
        cmocka_unit_test(test_overflow),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
