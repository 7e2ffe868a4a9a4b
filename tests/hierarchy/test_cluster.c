/* The cluster hierarchy (lib/hierarchy/cluster.c): patches across triangles, the area-weighted
 * Vᵀ (scene/subdivide.c lrr__patch_weights), the patch-major renumbering through operator,
 * files, solvers and lrr_operator_scene_order. */
#include "testutil.h"

#include "hierarchy/hierarchy.h"
#include "operator/operator.h"

/* OpenCL against the CPU: the device rounds the same float terms in another order;
 * 9 float roundings of the largest value (k = 1, n = 9). */
#define DEVICE_TOL TU_TOL_FLT(1, 9)

#define HEMI 32 /* small hemicubes: these tests compare like with like */
#define CONE_COS 0.8660254037844386 /* the normal rule: 30° */

static lrr_build_options cluster_opts(size_t K, int split)
{
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = HEMI;
    bo.seed = 5;
    bo.adaptive_patches = K;
    bo.adaptive_split = split;
    bo.adaptive_samples = 256;
    bo.hierarchy = LRR_HIERARCHY_CLUSTER;
    return bo;
}

static lrr_scene *subdivided(lrr_context *ctx, lrr_scene *s, size_t target)
{
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.target_patches = target;
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    return s;
}

static float *solve(lrr_context *ctx, const lrr_operator *op)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *b = malloc(oi.n * 3 * sizeof(float));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, lrr_operator_emission(op), b));
    lrr_solver_destroy(sv);
    return b;
}

/* The operator's B in the scene's order and the direct n×n solve's, from the same hemicubes. */
static void both_solutions(lrr_context *ctx, const lrr_scene *s, const lrr_build_options *bo,
                           const lrr_operator *op, float **low, float **dense)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *b = solve(ctx, op), *e = malloc(oi.n * 3 * sizeof(float));
    *low = malloc(oi.n * 3 * sizeof(float));
    *dense = malloc(oi.n * 3 * sizeof(float));
    lrr_operator_scene_order(op, b, *low);
    lrr_operator_scene_order(op, lrr_operator_emission(op), e);
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_reference_build(s, bo, 0, &ref));
    LRR_CHECK(ctx, lrr_reference_solve(ref, LRR_METHOD_DIRECT, 0, 0, e, *dense, NULL, 0));
    lrr_reference_destroy(ref);
    free(b);
    free(e);
}

/* Every subpatch in exactly one cluster; each cluster within the normal rule and of
 * emitters only or of other surfaces only; k close to K. */
static void assert_clusters(const lrr_operator *op, size_t K)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_int_equal(oi.hierarchy, LRR_HIERARCHY_CLUSTER);
    assert_true(oi.k >= K && oi.k <= K + K / 4);
    const size_t *first = lrr_operator_patch_offsets(op), *origin = lrr_operator_subpatch_origin(op);
    assert_non_null(origin);
    unsigned char *seen = calloc(oi.n, 1);
    for (size_t i = 0; i < oi.n; i++) {
        assert_true(origin[i] < oi.n);
        assert_false(seen[origin[i]]);
        seen[origin[i]] = 1;
    }
    free(seen);
    const float *nrm = lrr_operator_normal(op), *area = lrr_operator_area(op),
                *em = lrr_operator_emission(op);
    assert_int_equal(first[0], 0);
    assert_int_equal(first[oi.k], oi.n);
    for (size_t p = 0; p < oi.k; p++) {
        assert_true(first[p + 1] > first[p]);
        double m[3] = {0, 0, 0};
        for (size_t i = first[p]; i < first[p + 1]; i++)
            for (int c = 0; c < 3; c++)
                m[c] += area[i] * nrm[3 * i + c];
        double len = sqrt(m[0] * m[0] + m[1] * m[1] + m[2] * m[2]);
        int emits0 = em[3 * first[p]] > 0;
        for (size_t i = first[p]; i < first[p + 1]; i++) {
            double cosv = (m[0] * nrm[3 * i] + m[1] * nrm[3 * i + 1] + m[2] * nrm[3 * i + 2]) / len;
            assert_true(cosv >= CONE_COS - TU_TOL_FLT(2, 5)); /* float normals: 5 roundings */
            assert_int_equal(em[3 * i] > 0, emits0);
        }
    }
}

static void test_tiling_and_rules(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    subdivided(ctx, s, 1200);
    for (int split = LRR_SPLIT_VARIANCE; split <= LRR_SPLIT_AREA; split++) {
        lrr_build_options bo = cluster_opts(60, split);
        lrr_operator *op;
        LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
        assert_clusters(op, 60);
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        assert_true(oi.d_max > oi.d_min); /* really across triangles: the box has 32 */
        lrr_operator_destroy(op);
    }
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* A thin panel in a box: its two sides (1 mm apart, normals opposite) never share a
 * cluster, however few are asked for. */
static void test_thin_wall(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108 + 36], rho[48], em[48];
    tu_box_inward(v, 2, 2, 2);
    const double a[3] = {0.5, 0.2, 1.0}, b[3] = {1.5, 0.2, 1.0}, c[3] = {1.5, 1.8, 1.0},
                 d[3] = {0.5, 1.8, 1.0}, a2[3] = {0.5, 0.2, 1.001}, b2[3] = {1.5, 0.2, 1.001},
                 c2[3] = {1.5, 1.8, 1.001}, d2[3] = {0.5, 1.8, 1.001};
    tu_quad(v + 108, a, d, c, b);      /* facing −z */
    tu_quad(v + 126, a2, b2, c2, d2);  /* facing +z */
    for (int t = 0; t < 16; t++)
        for (int ch = 0; ch < 3; ch++) {
            rho[3 * t + ch] = 0.5f;
            em[3 * t + ch] = t == 6 ? 1.0f : 0.0f; /* one ceiling triangle emits */
        }
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, 16, v, rho, em, "thin wall", &s));
    subdivided(ctx, s, 800);
    lrr_build_options bo = cluster_opts(1, LRR_SPLIT_AREA);
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    /* K = 1: only the rules split: by normal (a panel side may join the box face that
     * faces the same way) and the emitter apart: at least 7 */
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_true(oi.k >= 7);
    assert_clusters(op, oi.k);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Every subpatch its own cluster: the low-rank model is exact, so the operator (in its
 * renumbered order, mapped back) solves the same system as the direct n×n solve. */
static void test_every_subpatch_is_exact(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    subdivided(ctx, s, 300);
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    lrr_build_options bo = cluster_opts(si.subpatches, LRR_SPLIT_AREA);
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_int_equal(oi.k, si.subpatches);
    assert_int_equal(oi.d_max, 1);
    /* the corners follow the renumbering: each subpatch's centre is its corners' mean */
    float *corner = malloc(oi.n * 9 * sizeof(float));
    lrr_operator_subpatch_vertices(op, corner);
    const float *ce = lrr_operator_centre(op);
    for (size_t i = 0; i < oi.n; i++)
        for (int j = 0; j < 3; j++)
            ASSERT_NEAR((corner[9 * i + j] + corner[9 * i + 3 + j] + corner[9 * i + 6 + j]) / 3,
                        ce[3 * i + j], 1e-4, "subpatch %zu", i);
    free(corner);
    const size_t *origin = lrr_operator_subpatch_origin(op);
    size_t moved = 0;
    for (size_t i = 0; i < oi.n; i++)
        moved += origin[i] != i;
    assert_true(moved > oi.n / 2); /* the renumbering is really exercised */
    float *low, *dense;
    both_solutions(ctx, s, &bo, op, &low, &dense);
    double num = 0, den = 0;
    for (size_t i = 0; i < 3 * oi.n; i++) {
        num = fmax(num, fabs((double)low[i] - dense[i]));
        den = fmax(den, fabs((double)dense[i]));
    }
    printf("K = n = %zu: max |B − B_direct| / max B = %.3g\n", oi.k, num / den);
    assert_true(num / den <= 1e-5);
    free(low);
    free(dense);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Midpoint-subdivides triangle v (9 floats) `levels` times into out (9·4^levels floats). */
static size_t split_triangle(const float *v, int levels, float *out)
{
    if (levels == 0) {
        memcpy(out, v, 9 * sizeof(float));
        return 1;
    }
    float m[9], kids[4][9];
    for (int j = 0; j < 3; j++) {
        m[j] = 0.5f * (v[j] + v[3 + j]);
        m[3 + j] = 0.5f * (v[3 + j] + v[6 + j]);
        m[6 + j] = 0.5f * (v[6 + j] + v[j]);
    }
    const float *corner[4][3] = {{v, m, m + 6}, {m, v + 3, m + 3}, {m + 6, m + 3, v + 6},
                                 {m + 3, m + 6, m}};
    size_t count = 0;
    for (int k = 0; k < 4; k++) {
        for (int i = 0; i < 3; i++)
            memcpy(kids[k] + 3 * i, corner[k][i], 3 * sizeof(float));
        count += split_triangle(kids[k], levels - 1, out + 9 * count);
    }
    return count;
}

/* Vᵀ weights by area: a cube whose ceiling lamp is one large triangle (emission 1) and its
 * mirror image cut into 64 small ones (emission 0.01), one cluster. By symmetry the floor
 * receives exactly what the lamp's area-weighted mean emission (0.505) sends, while the
 * mean over subpatches (0.025) would be 20 times too dark: the floor's mean radiosity must
 * match the direct n×n solve. */
static void test_area_weights(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    enum { T = 10 + 1 + 64 };
    float box[108], v[9 * T], rho[3 * T], em[3 * T];
    tu_box_inward(box, 1, 1, 1);
    memcpy(v, box, 6 * 9 * sizeof(float));                 /* x = 0, x = 1, floor y = 0 */
    memcpy(v + 6 * 9, box + 8 * 9, 4 * 9 * sizeof(float)); /* z = 0, z = 1 */
    memcpy(v + 10 * 9, box + 6 * 9, 9 * sizeof(float));    /* the lamp's large half */
    size_t small = split_triangle(box + 7 * 9, 3, v + 11 * 9);
    assert_int_equal(small, 64);
    for (int t = 0; t < T; t++)
        for (int c = 0; c < 3; c++) {
            rho[3 * t + c] = 0.3f;
            em[3 * t + c] = t < 10 ? 0.0f : t == 10 ? 1.0f : 0.01f;
        }
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, T, v, rho, em, "lamp", &s));
    lrr_subdivision sd = lrr_subdivision_defaults(); /* one subpatch per triangle */
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_build_options bo = cluster_opts(1, LRR_SPLIT_AREA);
    bo.hemicube_resolution = 128;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_int_equal(oi.k, 6); /* the rules only: five walls and the lamp */
    float *low, *dense;
    both_solutions(ctx, s, &bo, op, &low, &dense);
    /* the floor (y = 0): triangles 4 and 5, one subpatch each, in the scene's order */
    double fl = 0.5 * (low[3 * 4] + low[3 * 5]), fd = 0.5 * (dense[3 * 4] + dense[3 * 5]);
    printf("floor: low rank %.5f, direct %.5f (%.2f%%)\n", fl, fd, 100 * fabs(fl / fd - 1));
    assert_true(fabs(fl / fd - 1) < 0.02);
    free(low);
    free(dense);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

static void test_file_round_trip(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    subdivided(ctx, s, 600);
    lrr_build_options bo = cluster_opts(40, LRR_SPLIT_VARIANCE);
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    char path[256];
    tu_tmp_path(path, sizeof path, "lrr-cluster.lrr");
    for (int storage = LRR_STORAGE_F32; storage <= LRR_STORAGE_F16; storage++) {
        LRR_CHECK(ctx, lrr_operator_set_storage(op, (lrr_storage)storage));
        LRR_CHECK(ctx, lrr_operator_save(op, path));
        lrr_operator *back;
        LRR_CHECK(ctx, lrr_operator_load(ctx, path, &back));
        lrr_operator_info bi;
        lrr_operator_get_info(back, &bi, sizeof bi);
        assert_int_equal(bi.hierarchy, LRR_HIERARCHY_CLUSTER);
        assert_int_equal(bi.k, oi.k);
        assert_true(bi.selection_seconds == oi.selection_seconds);
        assert_memory_equal(lrr_operator_patch_offsets(back), lrr_operator_patch_offsets(op),
                            (oi.k + 1) * sizeof(size_t));
        assert_memory_equal(lrr_operator_subpatch_origin(back), lrr_operator_subpatch_origin(op),
                            oi.n * sizeof(size_t));
        assert_memory_equal(lrr_operator_area(back), lrr_operator_area(op),
                            oi.n * sizeof(float));
        float *b1 = solve(ctx, op), *b2 = solve(ctx, back);
        assert_memory_equal(b1, b2, oi.n * 3 * sizeof(float));
        free(b1);
        free(b2);
        lrr_operator_destroy(back);
    }
    unlink(path);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* The OpenCL solver's segmented sum takes the Vᵀ weights, and the device-side hemicube
 * integration the cluster sizes: the same B and F̄ as on the CPU. Skipped without OpenCL
 * (failed when LRR_REQUIRE_OPENCL is set, as in CI). */
static void test_opencl_agrees(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    subdivided(ctx, s, 600);
    lrr_build_options bo = cluster_opts(60, LRR_SPLIT_AREA);
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_solver *sv = NULL;
    lrr_status st = lrr_solver_create(op, LRR_BACKEND_OPENCL, &sv);
    if (st == LRR_ERR_UNSUPPORTED) {
        const char *req = getenv("LRR_REQUIRE_OPENCL");
        char msg[512];
        lrr_context_last_error(ctx, msg, sizeof msg);
        printf("OpenCL comparison %s: %s\n", req && *req ? "required" : "skipped", msg);
        if (req && *req)
            fail_msg("LRR_REQUIRE_OPENCL is set but OpenCL is unavailable");
    } else {
        LRR_CHECK(ctx, st);
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        float *cpu = solve(ctx, op), *cl = malloc(3 * oi.n * sizeof(float));
        LRR_CHECK(ctx, lrr_solve(sv, lrr_operator_emission(op), cl));
        double num = 0, den = 0;
        for (size_t i = 0; i < 3 * oi.n; i++) {
            num = fmax(num, fabs((double)cl[i] - cpu[i]));
            den = fmax(den, fabs((double)cpu[i]));
        }
        printf("OpenCL vs CPU on clusters (k = %zu, d %zu..%zu): %.3g\n", oi.k, oi.d_min,
               oi.d_max, num / den);
        assert_true(num / den <= DEVICE_TOL);
        free(cpu);
        free(cl);
        lrr_operator *dev;
        bo.backend = LRR_BACKEND_OPENCL;
        LRR_CHECK(ctx, lrr_operator_build(s, &bo, &dev));
        assert_memory_equal(lrr_operator_subpatch_origin(dev), lrr_operator_subpatch_origin(op),
                            oi.n * sizeof(size_t));
        LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS));
        LRR_CHECK(ctx, lrr_operator_set_layout(dev, LRR_LAYOUT_ROWS));
        const float *fc = lrr_operator_fbar(op), *fd = lrr_operator_fbar(dev);
        double worst = 0;
        for (size_t i = 0; i < oi.n * oi.k; i++)
            worst = fmax(worst, fabs((double)fd[i] - fc[i]) / fmax(fabs((double)fc[i]), 1e-30));
        printf("device-integrated F̄ vs CPU, worst relative difference %.3g\n", worst);
        assert_true(worst <= 2 * 1.1920929e-7);
        lrr_operator_destroy(dev);
    }
    lrr_solver_destroy(sv);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* What a file's CLUSTERS section must be (the loader's check, lrr__geometry_clusters). */
static void test_bad_clusters(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    subdivided(ctx, s, 100);
    const lrr__geometry *g = &s->geom;
    const size_t n = g->n;
    size_t *origin = malloc(n * sizeof(size_t)), first[3] = {0, n / 2, n};
    for (size_t i = 0; i < n; i++)
        origin[i] = n - 1 - i;
    lrr__geometry c;
    LRR_CHECK(ctx, lrr__geometry_clusters(ctx, g, origin, first, 2, "test", LRR_ERR_CORRUPT, &c));
    assert_int_equal(lrr__subpatch_triangle(&c, 0), lrr__subpatch_triangle(g, n - 1));
    lrr__geometry_free(&c);
    char msg[512];
    origin[3] = origin[4]; /* a subpatch twice, another in none */
    assert_int_equal(lrr__geometry_clusters(ctx, g, origin, first, 2, "test", LRR_ERR_CORRUPT, &c),
                     LRR_ERR_CORRUPT);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "in two clusters"));
    origin[3] = n; /* out of range */
    assert_int_equal(lrr__geometry_clusters(ctx, g, origin, first, 2, "test", LRR_ERR_CORRUPT, &c),
                     LRR_ERR_CORRUPT);
    lrr_context_last_error(ctx, msg, sizeof msg); /* the first error since the last read */
    assert_non_null(strstr(msg, "out of range"));
    origin[3] = n - 4;
    first[1] = 0; /* an empty cluster */
    assert_int_equal(lrr__geometry_clusters(ctx, g, origin, first, 2, "test", LRR_ERR_CORRUPT, &c),
                     LRR_ERR_CORRUPT);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "empty"));
    free(origin);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.target_patches = 100;
    sd.levels = 1;
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_operator *op = NULL;
    lrr_build_options bo = cluster_opts(10, LRR_SPLIT_AREA);
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG); /* levels 1 */
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "levels = 0"));
    sd.levels = 0;
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    bo.adaptive_patches = 0;
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "needs adaptive_patches"));
    bo = cluster_opts(10, LRR_SPLIT_AREA);
    bo.hierarchy = 7;
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "hierarchy = 7"));
    bo = cluster_opts(10, 5);
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG);
    assert_null(op);
    /* a caller built against ABI 1 (size 0: no hierarchy field) gets the quadtree */
    lrr_build_options old = {.hemicube_resolution = HEMI, .adaptive_patches = 40};
    LRR_CHECK(ctx, lrr_operator_build(s, &old, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_int_equal(oi.hierarchy, LRR_HIERARCHY_QUADTREE);
    assert_null(lrr_operator_subpatch_origin(op));
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* A real scene of 35,907 triangles (the FZK house, data/scenes): k ≪ T, the rules hold, the
 * form factors of every row sum to at most 1 and the solve adds light, never removes it. */
static void test_real_house(void **state)
{
    (void)state;
    TU_REQUIRE("assimp");
    lrr_context *ctx = tu_context();
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_load(ctx, LRR_DATA_DIR "/scenes/fzk_haus.obj", &s));
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    assert_true(si.triangles > 30000);
    const size_t K = 200;
    subdivided(ctx, s, si.triangles + 16 * K);
    lrr_build_options bo = cluster_opts(K, LRR_SPLIT_AREA);
    bo.hemicube_resolution = 8; /* 192 rays a receiver: the test is about sizes, not accuracy */
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    printf("house: T = %zu, n = %zu, k = %zu, %.2f s (%s)\n", oi.triangles, oi.n, oi.k,
           oi.build_seconds, oi.formfactor_method == LRR_FORMFACTOR_RAYCAST ? "raycast" : "raster");
    assert_true(oi.k < oi.triangles / 100);
    assert_int_equal(oi.formfactor_method, LRR_FORMFACTOR_RAYCAST);
    assert_clusters(op, K);
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS));
    const float *fbar = lrr_operator_fbar(op), *e = lrr_operator_emission(op);
    const size_t *first = lrr_operator_patch_offsets(op);
    for (size_t i = 0; i < oi.n; i++) {
        double row = 0;
        for (size_t p = 0; p < oi.k; p++)
            row += fbar[i * oi.k + p] * (double)(first[p + 1] - first[p]);
        assert_true(row <= 1 + 1e-4);
    }
    float *b = solve(ctx, op);
    for (size_t i = 0; i < 3 * oi.n; i++)
        assert_true(isfinite(b[i]) && b[i] >= e[i] * (1 - 1e-6f));
    free(b);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tiling_and_rules),
        cmocka_unit_test(test_thin_wall),
        cmocka_unit_test(test_every_subpatch_is_exact),
        cmocka_unit_test(test_area_weights),
        cmocka_unit_test(test_file_round_trip),
        cmocka_unit_test(test_opencl_agrees),
        cmocka_unit_test(test_bad_clusters),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_real_house),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
