/* The operator's error bar (lib/verify/verify.c, docs/METHOD.md "Verification"): against a
 * judge that path-traces every subpatch, its bookkeeping through files and changes, and the
 * errors it refuses. */
#include "testutil.h"

#include "operator/operator.h"

static lrr_scene *cornell(lrr_context *ctx, size_t patches, unsigned levels)
{
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sd = {.target_patches = patches, .levels = levels};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    return s;
}

static lrr_operator *build(lrr_context *ctx, const lrr_scene *s, int receiver)
{
    lrr_build_options o = lrr_build_options_defaults();
    o.hemicube_resolution = 64;
    o.seed = 4;
    o.receiver_sampling = receiver;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    return op;
}

/* The judge: every non-emitting subpatch path traced with 2048 paths, regions of a 4×4×4
 * grid × facing (coarser than the verification's 8³: another judge, whose own noise is
 * small), area-weighted reflected light. */
static double judge(lrr_context *ctx, const lrr_scene *s, const lrr_operator *op)
{
    const size_t n = op->n;
    float *B = malloc(n * 3 * sizeof(float)), *P = malloc(n * 3 * sizeof(float));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, B));
    lrr_solver_destroy(sv);
    lrr_path_trace_options po = lrr_path_trace_options_defaults();
    po.samples = 2048;
    po.seed = 11;
    LRR_CHECK(ctx, lrr_reference_path_trace(s, &po, P, NULL)); /* uniform: scene order = op's */
    enum { G = 4, REG = G * G * G * 6 };
    double acc[REG][7] = {{0}}, lo[3] = {0, 0, 0}, hi[3] = {556, 549, 560};
    for (size_t i = 0; i < n; i++) {
        if (op->emission[3 * i] > 0)
            continue;
        size_t cell = 0;
        for (int a = 0; a < 3; a++) {
            long c = (long)floor((op->centre[3 * i + a] - lo[a]) / (hi[a] - lo[a]) * G);
            cell = cell * G + (size_t)(c < 0 ? 0 : c >= G ? G - 1 : c);
        }
        const float *nv = op->normal + 3 * i;
        int ax = 0;
        for (int a = 1; a < 3; a++)
            if (fabsf(nv[a]) > fabsf(nv[ax]))
                ax = a;
        double *r = acc[cell * 6 + (size_t)(2 * ax + (nv[ax] < 0))];
        r[0] += op->area[i];
        for (int c = 0; c < 3; c++) {
            r[1 + c] += op->area[i] * (B[3 * i + c] - op->emission[3 * i + c]);
            r[4 + c] += op->area[i] * (P[3 * i + c] - op->emission[3 * i + c]);
        }
    }
    double num = 0, den = 0;
    for (int g = 0; g < REG; g++)
        for (int c = 0; acc[g][0] > 0 && c < 3; c++) {
            double d = (acc[g][1 + c] - acc[g][4 + c]) / acc[g][0], p = acc[g][4 + c] / acc[g][0];
            num += acc[g][0] * d * d;
            den += acc[g][0] * p * p;
        }
    free(B);
    free(P);
    return sqrt(num / den);
}

/* A coarse operator (54 patches of 4, hemicubes from the centres: ~10% off) and a fine one
 * (area-sampled: ~1%): the verification within a factor 2 of the judge on both, its noise
 * below its figure where the error is large. */
static void test_against_judge(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const struct { size_t patches; unsigned levels; int receiver; } cases[] = {
        {54, 1, LRR_RECEIVER_CENTRE}, {216, 2, LRR_RECEIVER_AREA}};
    for (int k = 0; k < 2; k++) {
        lrr_scene *s = cornell(ctx, cases[k].patches, cases[k].levels);
        lrr_operator *op = build(ctx, s, cases[k].receiver);
        lrr_verify_options vo = lrr_verify_options_defaults();
        vo.samples = k == 0 ? 2048 : 256; /* 208 subpatches, or 3392 */
        vo.seed = 3;
        LRR_CHECK(ctx, lrr_operator_verify(op, s, &vo));
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        const double j = judge(ctx, s, op);
        print_message("cornell %zu/%u %s: verify_rel_l2 %.4f (noise %.4f, %zu subpatches, "
                      "%.2f s), judge %.4f\n", cases[k].patches, cases[k].levels,
                      k ? "area" : "centre", oi.verify_rel_l2, oi.verify_noise,
                      oi.verify_subpatches, oi.verify_seconds, j);
        assert_true(oi.verify_subpatches > oi.n / 2 && oi.verify_subpatches < oi.n);
        assert_int_equal(oi.verify_samples, k == 0 ? 2048 : 256);
        assert_int_equal(oi.verify_uniform, 0);
        assert_true(oi.verify_noise > 0);
        assert_true(oi.verify_rel_l2 <= 2 * j + 2 * oi.verify_noise);
        assert_true(oi.verify_rel_l2 >= 0.5 * j - 2 * oi.verify_noise);
        if (k == 0) /* a large error stands out of the noise */
            assert_true(oi.verify_rel_l2 > 3 * oi.verify_noise);
        lrr_operator_destroy(op);
        lrr_scene_destroy(s);
    }
    lrr_context_destroy(ctx);
}

/* Kept in the file (VERIFY), bit for bit; the same figure again from the same draws;
 * cleared by a change of ρ or storage. */
static void test_bookkeeping(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 54, 1);
    lrr_operator *op = build(ctx, s, LRR_RECEIVER_AUTO), *back;
    lrr_operator_info a, b;
    lrr_operator_get_info(op, &a, sizeof a);
    assert_int_equal(a.verify_subpatches, 0); /* not verified yet */
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = 64;
    LRR_CHECK(ctx, lrr_operator_verify(op, s, &vo));
    lrr_operator_get_info(op, &a, sizeof a);
    char path[4096];
    tu_tmp_path(path, sizeof path, "test_verify"); /* in the test's scratch directory */
    LRR_CHECK(ctx, lrr_operator_save(op, path));
    LRR_CHECK(ctx, lrr_operator_load(ctx, path, &back));
    lrr_operator_get_info(back, &b, sizeof b);
    assert_true(a.verify_rel_l2 == b.verify_rel_l2 && a.verify_noise == b.verify_noise &&
                a.verify_seconds == b.verify_seconds);
    assert_int_equal(a.verify_subpatches, b.verify_subpatches);
    assert_int_equal(b.verify_samples, 64);
    /* the same draws and paths give the same figure */
    LRR_CHECK(ctx, lrr_operator_verify(back, s, &vo));
    lrr_operator_get_info(back, &b, sizeof b);
    assert_true(a.verify_rel_l2 == b.verify_rel_l2);
    LRR_CHECK(ctx, lrr_operator_set_storage(back, LRR_STORAGE_F16));
    lrr_operator_get_info(back, &b, sizeof b);
    assert_int_equal(b.verify_subpatches, 0);
    LRR_CHECK(ctx, lrr_operator_set_reflectance(op, lrr_operator_reflectance(op)));
    lrr_operator_get_info(op, &a, sizeof a);
    assert_int_equal(a.verify_subpatches, 0);
    lrr_operator_destroy(back);
    unlink(path);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

static void test_uniform_emission(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108], rho[36], em[36] = {0};
    tu_box_inward(v, 1, 1, 1);
    for (int i = 0; i < 36; i++)
        rho[i] = 0.5f;
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, 12, v, rho, em, "dark box", &s));
    lrr_subdivision sd = {.target_patches = 48, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_operator *op = build(ctx, s, LRR_RECEIVER_AREA);
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = 256;
    LRR_CHECK(ctx, lrr_operator_verify(op, s, &vo));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    print_message("dark box, E = 1: verify_rel_l2 %.4f, noise %.4f\n", oi.verify_rel_l2,
                  oi.verify_noise);
    assert_int_equal(oi.verify_uniform, 1);
    /* the furnace: B = E/(1 − ρ) everywhere, so the reflected light is 1 and the low-rank
     * model exact (row sums 1): only noise remains */
    assert_true(oi.verify_rel_l2 <= 3 * oi.verify_noise + 1e-3);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

static void test_refusals(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 54, 1), *other = cornell(ctx, 60, 1), *raw;
    LRR_CHECK(ctx, lrr_scene_cornell_box(ctx, 0, &raw));
    lrr_operator *op = build(ctx, s, LRR_RECEIVER_AUTO);
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = 16;
    assert_int_equal(lrr_operator_verify(op, other, &vo), LRR_ERR_INVALID_ARG);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "not the one the operator was built from"));
    assert_int_equal(lrr_operator_verify(op, raw, &vo), LRR_ERR_INVALID_ARG);
    vo.samples = 1;
    assert_int_equal(lrr_operator_verify(op, s, &vo), LRR_ERR_INVALID_ARG);
    vo.samples = 16;
    vo.threads = -1;
    assert_int_equal(lrr_operator_verify(op, s, &vo), LRR_ERR_INVALID_ARG);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_int_equal(oi.verify_subpatches, 0); /* nothing recorded by a refusal */
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_scene_destroy(other);
    lrr_scene_destroy(raw);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_against_judge),
        cmocka_unit_test(test_bookkeeping),
        cmocka_unit_test(test_uniform_emission),
        cmocka_unit_test(test_refusals),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
