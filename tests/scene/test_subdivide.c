/* The patch/subpatch hierarchy: child areas, counts, patch-major order and the
 * barycentric → subpatch index map. */
#include "testutil.h"
#include "scene/scene.h"

/* Areas and centroids in double of up to 256 subpatches (n = 256, 32 roundings each:
 * the cross product, the halving, the sum); float areas: 5 roundings, k = 2, and a sum of
 * up to 64 of them (TU_TOL_FLT(2, 64)). */
#define AREA_TOL TU_TOL_DBL(32, 256)
#define FLOAT_TOL TU_TOL_FLT(2, 5)

static double area9(const double v[9])
{
    double e1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]};
    double e2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
    double c0 = e1[1] * e2[2] - e1[2] * e2[1], c1 = e1[2] * e2[0] - e1[0] * e2[2],
           c2 = e1[0] * e2[1] - e1[1] * e2[0];
    return 0.5 * sqrt(c0 * c0 + c1 * c1 + c2 * c2);
}

static lrr_scene *two_triangles(lrr_context *ctx)
{
    /* areas 2 and 0.5, both facing +z */
    const float v[18] = {0, 0, 0, 2, 0, 0, 0, 2, 0, 5, 0, 1, 6, 0, 1, 5, 1, 1};
    const float rho[6] = {0.5f, 0.5f, 0.5f, 0.5f, 0.5f, 0.5f};
    const float em[6] = {0};
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, 2, v, rho, em, "two", &s));
    return s;
}

static void test_counts_and_areas(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = two_triangles(ctx);
    for (unsigned levels = 0; levels <= 3; levels++) {
        lrr_subdivision sd = {.max_patch_area = 0.1, .levels = levels};
        LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
        lrr_scene_info info;
        lrr_scene_get_info(s, &info, sizeof info);
        /* area 2 → depth 3 (2/64 <= 0.1), area 0.5 → depth 2 (0.5/16 <= 0.1) */
        assert_int_equal(info.patches, 64 + 16);
        assert_int_equal(info.d, (size_t)1 << (2 * levels));
        assert_int_equal(info.subpatches, info.patches * info.d);
        ASSERT_NEAR(info.area, 2.5, AREA_TOL, "area\n");
        float *area = malloc(info.subpatches * sizeof(float));
        LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, area, NULL, NULL));
        double sum = 0;
        for (size_t i = 0; i < info.subpatches; i++) {
            double expect = (i < 64 * info.d ? 2.0 / 64 : 0.5 / 16) / info.d;
            ASSERT_NEAR(area[i], expect, FLOAT_TOL * expect, "levels %u subpatch %zu\n", levels, i);
            sum += area[i];
        }
        ASSERT_NEAR(sum, 2.5, TU_TOL_FLT(2, 64), "levels %u total\n", levels);
        free(area);
    }
    /* no limit: one patch per triangle */
    lrr_subdivision none = {.levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &none));
    lrr_scene_info info;
    lrr_scene_get_info(s, &info, sizeof info);
    assert_int_equal(info.patches, 2);
    assert_int_equal(info.subpatches, 8);
    /* invalid options */
    lrr_subdivision bad = {.levels = 11};
    assert_int_equal(lrr_scene_subdivide(s, &bad), LRR_ERR_INVALID_ARG);
    bad.levels = 1;
    bad.max_patch_area = NAN;
    assert_int_equal(lrr_scene_subdivide(s, &bad), LRR_ERR_INVALID_ARG);
    bad.max_patch_area = -1;
    assert_int_equal(lrr_scene_subdivide(s, &bad), LRR_ERR_INVALID_ARG);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Children of a 4-way split have equal areas and tile the parent. */
static void test_children_tile_parent(void **state)
{
    (void)state;
    lrr__geometry g = {0};
    float v[9] = {0.3f, -1.0f, 2.0f, 4.0f, 0.5f, 1.0f, -2.0f, 3.0f, 0.25f};
    uint8_t depth = 2;
    size_t patch0[2];
    g.n_tri = 1;
    g.vert = v;
    g.depth = &depth;
    g.patch0 = patch0;
    g.levels = 2;
    assert_int_equal(lrr__geometry_index(NULL, &g, SIZE_MAX), LRR_OK);
    assert_int_equal(g.k, 16);
    assert_int_equal(g.n, 256);
    double parent[9];
    for (int j = 0; j < 9; j++)
        parent[j] = v[j];
    double A = area9(parent), sum = 0, centroid[3] = {0, 0, 0};
    for (size_t i = 0; i < g.n; i++) {
        double s[9];
        lrr__subpatch_vertices(&g, i, s);
        double a = area9(s);
        ASSERT_NEAR(a, A / 256, AREA_TOL * A, "subpatch %zu\n", i);
        sum += a;
        for (int j = 0; j < 3; j++)
            centroid[j] += (s[j] + s[3 + j] + s[6 + j]) / 3 / g.n;
    }
    ASSERT_NEAR(sum, A, AREA_TOL * A, "total\n");
    /* equal areas tiling the parent: the mean of the centroids is the parent's centroid */
    for (int j = 0; j < 3; j++)
        ASSERT_NEAR(centroid[j], (parent[j] + parent[3 + j] + parent[6 + j]) / 3, AREA_TOL,
                    "axis %d\n", j);
    /* the offsets lrr__geometry_index allocated (the rest lives on the stack) */
    lrr_aligned_free(g.sub0);
    lrr_aligned_free(g.first);
}

/* Barycentric → index round trip: every subpatch's centroid and random interior points map
 * back to that subpatch; patch-major order puts subpatch s of patch p at p·d + s. */
static void test_barycentric_round_trip(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = two_triangles(ctx);
    lrr_subdivision sd = {.max_patch_area = 0.1, .levels = 2};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    const lrr__geometry *g = &s->geom;
    uint64_t rng = 12345;
    for (size_t i = 0; i < g->n; i++) {
        double v[9];
        lrr__subpatch_vertices(g, i, v);
        size_t t = lrr__subpatch_triangle(g, i);
        assert_true(i / g->d >= g->patch0[t] && i / g->d < g->patch0[t + 1]);
        assert_int_equal(lrr__patch_of(g, i), i / g->d);
        assert_true(i >= g->first[i / g->d] && i < g->first[i / g->d + 1]);
        const float *T = g->vert + 9 * t;
        for (int trial = 0; trial < 8; trial++) {
            /* random point strictly inside subpatch i (trial 0: its centroid) */
            double u = 1.0 / 3, w = 1.0 / 3;
            if (trial) {
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                u = 0.02 + 0.96 * (double)(rng >> 11) * 0x1.0p-53;
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                w = 0.02 + 0.96 * (double)(rng >> 11) * 0x1.0p-53;
                if (u + w > 0.98) { u = 0.98 - u; w = 0.98 - w; }
                if (u < 0.01) u = 0.01;
                if (w < 0.01) w = 0.01;
            }
            double p[3];
            for (int j = 0; j < 3; j++)
                p[j] = (1 - u - w) * v[j] + u * v[3 + j] + w * v[6 + j];
            /* barycentric coordinates of p in the input triangle (it lies in the plane z) */
            double e1[2] = {T[3] - T[0], T[4] - T[1]}, e2[2] = {T[6] - T[0], T[7] - T[1]};
            double r[2] = {p[0] - T[0], p[1] - T[1]};
            double det = e1[0] * e2[1] - e1[1] * e2[0];
            double b1 = (r[0] * e2[1] - r[1] * e2[0]) / det;
            double b2 = (e1[0] * r[1] - e1[1] * r[0]) / det;
            size_t got = lrr_scene_subpatch_at(s, t, b1, b2);
            if (got != i)
                fail_msg("subpatch %zu trial %d: point maps to %zu", i, trial, got);
        }
    }
    assert_int_equal(lrr_scene_subpatch_at(s, 99, 0.1, 0.1), (size_t)-1);
    assert_int_equal(lrr_scene_subpatch_at(s, 0, 0.8, 0.8), (size_t)-1);
    assert_int_equal(lrr_scene_subpatch_at(s, 0, NAN, 0.1), (size_t)-1);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Requesting K patches picks the threshold whose count is closest to K. */
static void test_target_patches(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    const size_t targets[] = {1, 36, 100, 216, 864, 3456};
    for (size_t i = 0; i < sizeof targets / sizeof targets[0]; i++) {
        lrr_subdivision sd = {.target_patches = targets[i]};
        LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
        lrr_scene_info info;
        lrr_scene_get_info(s, &info, sizeof info);
        size_t k = info.patches;
        assert_true(k >= 36);
        /* no other threshold is closer: scan thresholds a bit above and below */
        for (double f = 0.25; f <= 4.0; f *= 1.0905) {
            lrr_subdivision other = {.max_patch_area = info.max_patch_area * f};
            LRR_CHECK(ctx, lrr_scene_subdivide(s, &other));
            lrr_scene_info oi;
            lrr_scene_get_info(s, &oi, sizeof oi);
            double dk = fabs((double)k - (double)targets[i]);
            double dother = fabs((double)oi.patches - (double)targets[i]);
            if (dother < dk)
                fail_msg("target %zu: chose k = %zu but threshold ×%g gives %zu", targets[i], k,
                         f, oi.patches);
        }
    }
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_counts_and_areas),
        cmocka_unit_test(test_children_tile_parent),
        cmocka_unit_test(test_barycentric_round_trip),
        cmocka_unit_test(test_target_patches),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
