/* The adaptive patch hierarchy (lib/hierarchy/adaptive.c, variable d_p through geometry, operator,
 * files and solvers). */
#include "testutil.h"

#include "formfactor/formfactor.h"
#include "hierarchy/hierarchy.h"
#include "operator/operator.h"

#include <float.h>

/* OpenCL against the CPU: the device rounds the same float terms in another order;
 * 9 float roundings of the largest value (k = 1, n = 9). */
#define DEVICE_TOL TU_TOL_FLT(1, 9)

/* The objective is a double sum over the patches' variances (n <= 1024 terms, k = 8);
 * a running total updated at every split and exchange against one recomputed from
 * scratch: n = 2^20 bounds the updates times the terms each one re-sums, k = 8. */
#define OBJ_STEP_TOL TU_TOL_DBL(8, 1024)
#define OBJ_TOTAL_TOL TU_TOL_DBL(8, 1 << 20)

#define HEMI 32 /* small hemicubes: these tests compare like with like */

static lrr_scene *cornell(lrr_context *ctx, size_t patches)
{
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    lrr_subdivision sd = {.target_patches = patches};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    return s;
}

static float *solve(lrr_context *ctx, const lrr_operator *op, lrr_backend backend)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *b = malloc(oi.n * 3 * sizeof(float));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, backend, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, lrr_operator_emission(op), b));
    lrr_solver_destroy(sv);
    return b;
}

/* max |a − b| / max |b| over 3n entries */
static double rel_max(const float *a, const float *b, size_t n3)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < n3; i++) {
        num = fmax(num, fabs((double)a[i] - b[i]));
        den = fmax(den, fabs((double)b[i]));
    }
    return num / den;
}

/* K = N: every patch one subpatch, so the low-rank model is exact: the operator solves the
 * same system as the direct n×n reference from the same hemicubes. */
static void test_k_equals_n_is_exact(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 150);
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    lrr_build_options bo = {.hemicube_resolution = HEMI, .seed = 3,
                            .adaptive_patches = si.subpatches};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_int_equal(oi.k, si.subpatches);
    assert_int_equal(oi.d, 0);
    assert_int_equal(oi.d_min, 1);
    assert_int_equal(oi.d_max, 1);
    float *b = solve(ctx, op, LRR_BACKEND_CPU);
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_reference_build(s, &bo, 0, &ref));
    float *r = malloc(si.subpatches * 3 * sizeof(float));
    LRR_CHECK(ctx, lrr_reference_solve(ref, LRR_METHOD_DIRECT, 0, 0, lrr_operator_emission(op),
                                       r, NULL, 0));
    double e = rel_max(b, r, 3 * si.subpatches);
    printf("K = N = %zu: max |B − B_direct| / max B = %.3g\n", oi.k, e);
    assert_true(e < 2e-6);
    free(b);
    free(r);
    lrr_reference_destroy(ref);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* LRR_SPLIT_AREA over the N = 4K pieces of a subdivision gives back the uniform hierarchy
 * of K patches with levels = 1 when every triangle splits: same F̄ columns, same B. */
static void test_area_split_is_uniform(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *fine = cornell(ctx, 864), *coarse;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &coarse));
    lrr_subdivision sd = {.target_patches = 216, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(coarse, &sd));
    lrr_scene_info fi, ci;
    lrr_scene_get_info(fine, &fi, sizeof fi);
    lrr_scene_get_info(coarse, &ci, sizeof ci);
    assert_int_equal(fi.subpatches, ci.subpatches);
    lrr_build_options bo = {.hemicube_resolution = HEMI, .seed = 5,
                            .adaptive_patches = ci.patches, .adaptive_split = LRR_SPLIT_AREA};
    lrr_operator *a, *u;
    LRR_CHECK(ctx, lrr_operator_build(fine, &bo, &a));
    bo.adaptive_patches = 0;
    LRR_CHECK(ctx, lrr_operator_build(coarse, &bo, &u));
    lrr_operator_info ai;
    lrr_operator_get_info(a, &ai, sizeof ai);
    assert_int_equal(ai.k, ci.patches);
    assert_int_equal(ai.d_min, 4);
    assert_int_equal(ai.d_max, 4);
    const size_t *off = lrr_operator_patch_offsets(a), *uoff = lrr_operator_patch_offsets(u);
    for (size_t p = 0; p <= ai.k; p++)
        assert_int_equal(off[p], uoff[p]);
    size_t nk = ai.n * ai.k;
    LRR_CHECK(ctx, lrr_operator_set_layout(a, LRR_LAYOUT_ROWS));
    LRR_CHECK(ctx, lrr_operator_set_layout(u, LRR_LAYOUT_ROWS));
    const float *fa = lrr_operator_fbar(a), *fu = lrr_operator_fbar(u);
    for (size_t i = 0; i < nk; i++)
        if (fa[i] != fu[i])
            fail_msg("F̄ entry (%zu, %zu): %g (adaptive, area split) vs %g (uniform)",
                     i / ai.k, i % ai.k, (double)fa[i], (double)fu[i]);
    lrr_operator_destroy(a);
    lrr_operator_destroy(u);
    lrr_scene_destroy(fine);
    lrr_scene_destroy(coarse);
    lrr_context_destroy(ctx);
}

/* The patches of ag tile the n subpatches in order, none empty. */
static void assert_tiling(const lrr__geometry *ag, size_t n)
{
    assert_int_equal(ag->first[0], 0);
    assert_int_equal(ag->first[ag->k], n);
    for (size_t p = 0; p < ag->k; p++)
        assert_true(ag->first[p + 1] > ag->first[p]);
}

/* The unweighted objective Σ_p V_p never grows with a split (a finer grouping's
 * within-group sum of squares is never larger), and the hierarchy reaches the budget. */
static void test_objective_monotone(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 600);
    const lrr__geometry *g = &s->geom;
    float *rho = malloc(g->n * 3 * sizeof(float));
    LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, rho, NULL));
    const size_t K = 300, steps = (K - g->n_tri) / 3 + 1;
    double *obj = calloc(steps, sizeof(double));
    lrr_build_options bo = {.hemicube_resolution = HEMI, .seed = 9, .adaptive_patches = K,
                            .adaptive_samples = 64};
    lrr__geometry ag;
    lrr__adaptive_trace trace = {.objective = obj};
    LRR_CHECK(ctx, lrr__adaptive_select(ctx, g, rho, NULL, NULL, NULL, &bo,
                                        lrr__hemicube_sample_rows, &ag, &trace));
    assert_true(ag.k <= K && ag.k + 3 > K);
    assert_true(obj[0] > 0);
    for (size_t q = 1; q < steps; q++)
        if (!(obj[q] <= obj[q - 1] * (1 + OBJ_STEP_TOL)))
            fail_msg("split %zu raised the objective from %.10g to %.10g", q, obj[q - 1],
                     obj[q]);
    printf("objective %.4g -> %.4g over %zu splits\n", obj[0], obj[steps - 1], steps - 1);
    assert_true(obj[steps - 1] < obj[0]);
    /* no exchanges without radiosity weights; the running total is the sum of the final
     * patches' variances */
    assert_int_equal(trace.exchanges, 0);
    assert_true(trace.greedy == obj[steps - 1] && trace.exchanged == trace.greedy);
    ASSERT_NEAR(trace.recomputed, trace.exchanged, OBJ_TOTAL_TOL * obj[0],
                "recomputed objective");
    assert_tiling(&ag, g->n);
    lrr__geometry_free(&ag);
    free(obj);
    free(rho);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* With radiosity weights the greedy result is refined by exchanges (merge four sibling
 * patches, split another): each lowers the objective, so the final one is below the
 * greedy's, the incremental total equals the objective summed anew over the final patches,
 * the budget is kept and the patches tile the subpatches. */
static void test_exchange(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 2000);
    const lrr__geometry *g = &s->geom;
    float *rho = malloc(g->n * 3 * sizeof(float)), *em = malloc(g->n * 3 * sizeof(float)),
          *area = malloc(g->n * sizeof(float));
    LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, area, rho, em));
    const size_t K = 600;
    lrr_build_options bo = {.hemicube_resolution = HEMI, .seed = 5, .adaptive_patches = K,
                            .adaptive_samples = 256};
    lrr__geometry ag;
    lrr__adaptive_trace trace = {0};
    LRR_CHECK(ctx, lrr__adaptive_select(ctx, g, rho, em, area, NULL, &bo,
                                        lrr__hemicube_sample_rows, &ag, &trace));
    printf("n = %zu, K = %zu: %zu exchanges, objective %.6g -> %.6g (summed anew %.6g)\n",
           g->n, K, trace.exchanges, trace.greedy, trace.exchanged, trace.recomputed);
    assert_true(trace.greedy > 0);
    assert_true(trace.exchanged <= trace.greedy);
    if (trace.exchanges > 0)
        assert_true(trace.exchanged < trace.greedy);
    ASSERT_NEAR(trace.recomputed, trace.exchanged, OBJ_TOTAL_TOL * trace.greedy,
                "recomputed objective");
    assert_true(ag.k <= K && ag.k + 3 > K);
    assert_tiling(&ag, g->n);
    lrr__geometry_free(&ag);
    free(rho);
    free(em);
    free(area);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* The sampled estimate of V over a few node ranges agrees with the exact one (every row)
 * within four of its standard errors. */
static void test_sampled_variance(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 400);
    const lrr__geometry *g = &s->geom;
    float *rho = malloc(g->n * 3 * sizeof(float));
    LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, rho, NULL));
    lrr_build_options bo = {.hemicube_resolution = HEMI, .seed = 11};
    lrr__ffsample all, some;
    LRR_CHECK(ctx, lrr__ffsample_take(ctx, g, rho, &bo, lrr__hemicube_sample_rows, 0, &all));
    LRR_CHECK(ctx, lrr__ffsample_take(ctx, g, rho, &bo, lrr__hemicube_sample_rows, 100,
                                      &some));
    assert_int_equal(all.count, g->n);
    assert_int_equal(some.count, 100);
    for (size_t r = 1; r < some.count; r++)
        assert_true(some.rows[r] > some.rows[r - 1]);
    /* sampled rows are the exact rows: same hemicubes */
    for (size_t r = 0; r < some.count; r++)
        assert_memory_equal(some.f + r * g->n, all.f + some.rows[r] * g->n,
                            g->n * sizeof(float));
    /* The estimate's spread is judged with the true standard error, from every row's term
     * (a small sample of a heavy-tailed population underestimates its own): each z-score
     * within 6 (Chebyshev: a 1/36 chance each) and their RMS near 1 (somewhat below: the
     * formula is that of a simple random sample, an upper estimate for the stratified one). */
    int checked = 0;
    double z2 = 0;
    const double S = (double)some.count, N = (double)g->n;
    for (size_t t = 0; t < g->n_tri; t++) {
        size_t j0 = g->sub0[t], j1 = g->sub0[t + 1];
        if (j1 - j0 < 4)
            continue;
        double se_all, se;
        double exact = lrr__ffsample_variance(&all, j0, j1, &se_all);
        double est = lrr__ffsample_variance(&some, j0, j1, &se);
        assert_true(se_all == 0);
        double sum = 0, sum2 = 0;
        for (size_t r = 0; r < all.count; r++) {
            lrr__ffsample one = {1, all.n, all.rows + r, all.weight + r, all.rho + 3 * r, NULL,
                                 all.f + r * all.n};
            double term = lrr__ffsample_variance(&one, j0, j1, NULL) / N;
            sum += term;
            sum2 += term * term;
        }
        ASSERT_NEAR(sum, exact, OBJ_TOTAL_TOL * exact, "triangle %zu: sum of row terms", t);
        double var = (sum2 - sum * sum / N) / (N - 1);
        double se_true = N * sqrt((1 - S / N) * var / S);
        if (!(se_true > 0))
            continue;
        double z = (est - exact) / se_true;
        if (!(fabs(z) <= 6))
            fail_msg("triangle %zu: sampled %.6g vs exact %.6g: %.1f standard errors (%.3g)", t,
                     est, exact, z, se_true);
        z2 += z * z;
        checked++;
    }
    double rms = sqrt(z2 / checked);
    printf("%d triangles: sampled variance vs exact, RMS z-score %.2f\n", checked, rms);
    assert_true(checked >= 10);
    assert_true(rms > 0.2 && rms < 2.5);
    lrr__ffsample_free(&all);
    lrr__ffsample_free(&some);
    free(rho);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Variable-size operators survive save/load bit for bit, in f32 and f16, and the loaded
 * one solves to the same B. */
static void test_file_round_trip(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 500);
    lrr_build_options bo = {.hemicube_resolution = HEMI, .seed = 2, .adaptive_patches = 120,
                            .adaptive_samples = 64};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_true(oi.d_min < oi.d_max); /* really adaptive */
    char path[4096];
    snprintf(path, sizeof path, "%s/lrr-adaptive-XXXXXX", tu_tmp_dir());
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    close(fd);
    for (int storage = LRR_STORAGE_F32; storage <= LRR_STORAGE_F16; storage++) {
        LRR_CHECK(ctx, lrr_operator_set_storage(op, (lrr_storage)storage));
        LRR_CHECK(ctx, lrr_operator_save(op, path));
        lrr_operator *back;
        LRR_CHECK(ctx, lrr_operator_load(ctx, path, &back));
        lrr_operator_info bi;
        lrr_operator_get_info(back, &bi, sizeof bi);
        assert_int_equal(bi.k, oi.k);
        assert_int_equal(bi.n, oi.n);
        assert_int_equal(bi.d, 0);
        assert_int_equal(bi.d_min, oi.d_min);
        assert_int_equal(bi.d_max, oi.d_max);
        assert_true(bi.selection_seconds == oi.selection_seconds);
        assert_memory_equal(lrr_operator_patch_offsets(back), lrr_operator_patch_offsets(op),
                            (oi.k + 1) * sizeof(size_t));
        assert_memory_equal(lrr_operator_m(back), lrr_operator_m(op),
                            3 * oi.k * oi.k * sizeof(float));
        float *b1 = solve(ctx, op, LRR_BACKEND_CPU), *b2 = solve(ctx, back, LRR_BACKEND_CPU);
        assert_memory_equal(b1, b2, oi.n * 3 * sizeof(float));
        free(b1);
        free(b2);
        lrr_operator_destroy(back);
    }
    /* a version-2 file with a PATCHES byte changed is refused (the checksum catches it) */
    FILE *f = fopen(path, "r+b");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, len - 1, SEEK_SET); /* PATCHES is the last section */
    int c = fgetc(f);
    fseek(f, len - 1, SEEK_SET);
    fputc(c ^ 1, f);
    fclose(f);
    lrr_operator *bad = NULL;
    assert_int_equal(lrr_operator_load(ctx, path, &bad), LRR_ERR_CORRUPT);
    assert_null(bad);
    unlink(path);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* The OpenCL solver's segmented sum takes the patch offsets: same B as the CPU. */
static void test_opencl_agrees(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 500);
    lrr_build_options bo = {.hemicube_resolution = HEMI, .seed = 4, .adaptive_patches = 150,
                            .adaptive_samples = 64};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
    lrr_solver *sv = NULL;
    lrr_status st = lrr_solver_create(op, LRR_BACKEND_OPENCL, &sv);
    lrr_solver_destroy(sv);
    if (st == LRR_ERR_UNSUPPORTED) {
        const char *req = getenv("LRR_REQUIRE_OPENCL");
        char msg[512];
        lrr_context_last_error(ctx, msg, sizeof msg);
        printf("OpenCL comparison %s: %s\n", req && *req ? "required" : "skipped", msg);
        if (req && *req)
            fail_msg("LRR_REQUIRE_OPENCL is set but OpenCL is unavailable");
    } else {
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        float *cpu = solve(ctx, op, LRR_BACKEND_CPU), *cl = solve(ctx, op, LRR_BACKEND_OPENCL);
        double e = rel_max(cl, cpu, 3 * oi.n);
        printf("OpenCL vs CPU on an adaptive operator (k = %zu, d %zu..%zu): %.3g\n", oi.k,
               oi.d_min, oi.d_max, e);
        assert_true(e <= DEVICE_TOL);
        free(cpu);
        free(cl);
        /* the device-side hemicube integration divides by d_p too */
        lrr_operator *dev;
        bo.backend = LRR_BACKEND_OPENCL;
        LRR_CHECK(ctx, lrr_operator_build(s, &bo, &dev));
        LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS));
        LRR_CHECK(ctx, lrr_operator_set_layout(dev, LRR_LAYOUT_ROWS));
        const float *fc = lrr_operator_fbar(op), *fd = lrr_operator_fbar(dev);
        assert_memory_equal(lrr_operator_patch_offsets(dev), lrr_operator_patch_offsets(op),
                            (oi.k + 1) * sizeof(size_t));
        double worst = 0;
        for (size_t i = 0; i < oi.n * oi.k; i++)
            worst = fmax(worst, fabs((double)fd[i] - fc[i]) / fmax(fabs((double)fc[i]), 1e-30));
        printf("device-integrated F̄ vs CPU, worst relative difference %.3g\n", worst);
        assert_true(worst <= 2 * FLT_EPSILON);
        lrr_operator_destroy(dev);
    }
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Bad budgets and levels give clear errors. */
static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 100);
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    lrr_operator *op = NULL;
    char msg[512];
    lrr_build_options bo = {.hemicube_resolution = HEMI, .adaptive_patches = si.triangles - 1};
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "between"));
    bo.adaptive_patches = si.subpatches + 1;
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    bo.adaptive_patches = si.triangles;
    bo.adaptive_split = 7;
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "adaptive_split = 7"));
    /* the budget counts the selection's sampled rows (every row here: n² floats, far more
     * than F̄, M and the hemicube buffers of this small build) */
    {
        lrr_scene *big = cornell(ctx, 600);
        lrr_scene_info bi;
        lrr_scene_get_info(big, &bi, sizeof bi);
        lrr_build_options b2 = {.hemicube_resolution = HEMI, .adaptive_patches = bi.triangles,
                                .adaptive_samples = bi.subpatches,
                                .memory_budget = bi.subpatches * bi.subpatches * sizeof(float)};
        assert_int_equal(lrr_operator_build(big, &b2, &op), LRR_ERR_BUDGET);
        lrr_context_last_error(ctx, msg, sizeof msg);
        assert_non_null(strstr(msg, "memory budget"));
        b2.memory_budget *= 3;
        LRR_CHECK(ctx, lrr_operator_build(big, &b2, &op));
        lrr_operator_destroy(op);
        op = NULL;
        lrr_scene_destroy(big);
    }
    lrr_subdivision sd = {.target_patches = 40, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    bo.adaptive_split = LRR_SPLIT_VARIANCE;
    assert_int_equal(lrr_operator_build(s, &bo, &op), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    if (!strstr(msg, "levels = 0"))
        fail_msg("message: %s", msg);
    assert_null(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    setenv("OMP_NUM_THREADS", "2", 0);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_k_equals_n_is_exact),
        cmocka_unit_test(test_area_split_is_uniform),
        cmocka_unit_test(test_objective_monotone),
        cmocka_unit_test(test_exchange),
        cmocka_unit_test(test_sampled_variance),
        cmocka_unit_test(test_file_round_trip),
        cmocka_unit_test(test_opencl_agrees),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
