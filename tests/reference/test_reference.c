/* The full form-factor matrix and the reference solvers (lib/reference/reference.c). */
#include "testutil.h"
#include "formfactor/formfactor.h"
#include "operator/operator.h"

static lrr_scene *cornell(lrr_context *ctx, int closed, size_t K, unsigned levels)
{
    lrr_scene *s = tu_cornell(ctx, closed, 0, 0);
    lrr_subdivision sd = {.target_patches = K, .levels = levels};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    return s;
}

/* Largest per-channel relative L2 difference of two n×3 arrays. */
static double rel_l2(size_t n, const float *a, const float *b)
{
    double worst = 0;
    for (int c = 0; c < 3; c++) {
        double num = 0, den = 0;
        for (size_t i = 0; i < n; i++) {
            double d = (double)a[3 * i + c] - b[3 * i + c];
            num += d * d;
            den += (double)b[3 * i + c] * b[3 * i + c];
        }
        worst = fmax(worst, sqrt(num / den));
    }
    return worst;
}

/* F̄ = F V / d from the same hemicubes; in the closed box the open-room rows of F sum to 1. */
static void test_fbar_is_f_v_over_d(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 1, 24, 1);
    lrr_build_options o = {.hemicube_resolution = 32, .seed = 9};
    lrr_operator *op;
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
    LRR_CHECK(ctx, lrr_reference_build(s, &o, 0, &ref));
    const size_t n = op->n, k = op->k, d = op->d;
    assert_int_equal(lrr_reference_size(ref), n);
    assert_true(d == 4);
    const float *F = lrr_reference_f(ref);
    double worst = 0;
    size_t full_rows = 0;
    for (size_t i = 0; i < n; i++) {
        double rowsum = 0;
        for (size_t p = 0; p < k; p++) {
            double sum = 0;
            for (size_t j = p * d; j < (p + 1) * d; j++)
                sum += F[i * n + j];
            rowsum += sum;
            worst = fmax(worst, fabs(sum / (double)d - op->fbar[i * k + p]));
        }
        full_rows += fabs(rowsum - 1) < 1e-5;
        assert_true(rowsum <= 1 + 1e-5);
    }
    print_message("F̄ vs F V/d: worst |difference| %.2e; %zu of %zu rows of F sum to 1\n", worst,
                  full_rows, n);
    assert_true(worst <= TU_TOL_FLT(1, 1)); /* F-bar is stored as float: one rounding of <= 1 */
    assert_true(full_rows > n / 2);
    for (size_t i = 0; i < n; i++)
        assert_true(F[i * n + i] == 0.0f); /* a flat subpatch cannot see itself */
    lrr_reference_destroy(ref);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Jacobi, Gauss–Seidel, Southwell and the direct solve agree to their tolerance. */
static void test_methods_agree(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 0, 40, 1);
    lrr_build_options o = {.hemicube_resolution = 32, .seed = 3};
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_reference_build(s, &o, 0, &ref));
    const size_t n = lrr_reference_size(ref);
    /* the scene's light plus a dim glow everywhere, so every channel has work to do */
    float *E = malloc(3 * n * sizeof *E), *B[4];
    for (size_t j = 0; j < 3 * n; j++)
        E[j] = lrr_reference_emission(ref)[j] + 0.01f * (float)(j % 7);
    const double tol = 1e-9;
    for (int m = 0; m < 4; m++) {
        B[m] = malloc(3 * n * sizeof(float));
        lrr_reference_stats st;
        lrr_method method = (lrr_method)(LRR_METHOD_JACOBI + m);
        LRR_CHECK(ctx, lrr_reference_solve(ref, method, tol, 0, E, B[m], &st, sizeof st));
        print_message("%-13s n = %zu: %zu iterations, residual %.2e, %.3f s\n",
                      lrr_method_name(method), n, st.iterations, st.residual, st.seconds);
        assert_true(st.residual <= (method == LRR_METHOD_DIRECT ? 1e-12 : tol));
        assert_true(st.iterations >= 1);
    }
    for (int a = 0; a < 4; a++)
        for (int b = a + 1; b < 4; b++) {
            double e = rel_l2(n, B[a], B[b]);
            /* not rounding: each method stops at its own residual (tol 1e-9) */
            if (!(e <= 1e-6))
                fail_msg("%s vs %s: relative L2 %.3e", lrr_method_name(LRR_METHOD_JACOBI + a),
                         lrr_method_name(LRR_METHOD_JACOBI + b), e);
        }
    for (int m = 0; m < 4; m++)
        free(B[m]);
    free(E);
    lrr_reference_destroy(ref);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* With d = 1 the low-rank operator is exact: it equals the direct solve. */
static void test_direct_equals_operator_at_d1(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 0, 150, 0);
    lrr_build_options o = {.hemicube_resolution = 64, .seed = 5};
    lrr_operator *op;
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
    LRR_CHECK(ctx, lrr_reference_build(s, &o, 0, &ref));
    const size_t n = op->n;
    float *a = malloc(3 * n * sizeof *a), *b = malloc(3 * n * sizeof *b);
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, a));
    LRR_CHECK(ctx, lrr_reference_solve(ref, LRR_METHOD_DIRECT, 0, 0, op->emission, b, NULL, 0));
    double e = rel_l2(n, a, b);
    print_message("d = 1, n = %zu: operator vs direct relative L2 %.2e\n", n, e);
    assert_true(e <= 1e-5);
    free(a);
    free(b);
    lrr_solver_destroy(sv);
    lrr_reference_destroy(ref);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Furnace: a sealed box, uniform rho and E: every method gives E/(1 − rho). */
static void test_furnace(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const float r[3] = {0.5f, 0.9f, 0.99f};
    lrr_scene *s = tu_furnace(ctx, 1.0, 0.8, 1.2, r, 1.0f);
    lrr_subdivision sd = {.target_patches = 48, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_build_options o = {.hemicube_resolution = 64, .seed = 1};
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_reference_build(s, &o, 0, &ref));
    const size_t n = lrr_reference_size(ref);
    float *B = malloc(3 * n * sizeof *B);
    for (int m = 0; m < 4; m++) {
        lrr_method method = (lrr_method)(LRR_METHOD_JACOBI + m);
        lrr_reference_stats st;
        LRR_CHECK(ctx, lrr_reference_solve(ref, method, 1e-8, 0, lrr_reference_emission(ref),
                                           B, &st, sizeof st));
        double worst = 0;
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                worst = fmax(worst, fabs(B[3 * i + c] * (1 - r[c]) - 1));
        print_message("furnace %-13s: worst relative error %.2e (%zu iterations)\n",
                      lrr_method_name(method), worst, st.iterations);
        assert_true(worst <= 1e-3);
    }
    free(B);
    lrr_reference_destroy(ref);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx, 0, 24, 1);
    lrr_scene_info info;
    lrr_scene_get_info(s, &info, sizeof info);
    /* a budget below n² floats is refused before anything is allocated, naming the need */
    lrr_reference *ref = (lrr_reference *)0x1;
    assert_int_equal(lrr_reference_build(s, NULL, 1000, &ref), LRR_ERR_BUDGET);
    assert_null(ref);
    char msg[512];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_BUDGET);
    char need[64];
    snprintf(need, sizeof need, "%.1f MB", lrr_reference_bytes(info.subpatches) / 1e6);
    if (!strstr(msg, need) || !strstr(msg, "budget"))
        fail_msg("message does not name the memory needed (%s): %s", need, msg);
    assert_int_equal(lrr_reference_bytes(SIZE_MAX / 2), SIZE_MAX);
    /* the direct solve needs 8n² more: a budget that fits F only refuses it */
    lrr_build_options o = {.hemicube_resolution = 16, .seed = 1};
    LRR_CHECK(ctx, lrr_reference_build(s, &o, lrr_reference_bytes(info.subpatches), &ref));
    const size_t n = lrr_reference_size(ref);
    float *E = malloc(3 * n * sizeof *E), *B = malloc(3 * n * sizeof *B);
    memcpy(E, lrr_reference_emission(ref), 3 * n * sizeof *E);
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_DIRECT, 0, 0, E, B, NULL, 0),
                     LRR_ERR_BUDGET);
    /* an iteration cap reports LRR_NOT_CONVERGED with the last iterate in B */
    lrr_reference_stats st;
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_JACOBI, 1e-10, 2, E, B, &st, sizeof st),
                     LRR_NOT_CONVERGED);
    assert_int_equal(st.iterations, 2);
    assert_true(st.residual > 1e-10 && isfinite(st.residual));
    for (size_t j = 0; j < 3 * n; j++)
        assert_true(isfinite(B[j]) && B[j] >= E[j]);
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_SOUTHWELL, 1e-10, 3, E, B, &st, sizeof st),
                     LRR_NOT_CONVERGED);
    assert_int_equal(st.iterations, 3);
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_BUDGET);
    assert_non_null(strstr(msg, "direct"));
    /* bad emission, tolerance, method */
    E[3 * 5 + 1] = NAN;
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_JACOBI, 0, 0, E, B, NULL, 0),
                     LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "subpatch 5"));
    E[3 * 5 + 1] = -1;
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_JACOBI, 0, 0, E, B, NULL, 0),
                     LRR_ERR_INVALID_ARG);
    E[3 * 5 + 1] = 0;
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_JACOBI, 1.5, 0, E, B, NULL, 0),
                     LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_JACOBI, 1e-20, 0, E, B, NULL, 0),
                     LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_reference_solve(ref, (lrr_method)7, 0, 0, E, B, NULL, 0),
                     LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_reference_solve(ref, LRR_METHOD_JACOBI, 0, 0, E, E, NULL, 0),
                     LRR_ERR_INVALID_ARG);
    /* names round trip */
    for (int m = LRR_METHOD_JACOBI; m <= LRR_METHOD_DIRECT; m++) {
        lrr_method back;
        assert_int_equal(lrr_method_from_name(lrr_method_name((lrr_method)m), &back), LRR_OK);
        assert_int_equal(back, m);
    }
    lrr_method dummy;
    assert_int_equal(lrr_method_from_name("gauss", &dummy), LRR_ERR_INVALID_ARG);
    assert_null(lrr_method_name((lrr_method)0));
    lrr_reference_destroy(ref);
    /* not subdivided */
    lrr_scene *raw = tu_cornell(ctx, 0, 0, 0);
    assert_int_equal(lrr_reference_build(raw, NULL, 0, &ref), LRR_ERR_INVALID_ARG);
    lrr_scene_destroy(raw);
    free(E);
    free(B);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fbar_is_f_v_over_d),
        cmocka_unit_test(test_methods_agree),
        cmocka_unit_test(test_direct_equals_operator_at_d1),
        cmocka_unit_test(test_furnace),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
