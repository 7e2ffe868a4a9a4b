/* The low-rank operator and the CPU solve against exact cases and a dense LAPACK solve. */
#include "testutil.h"
#include "solve/solve.h"

#include <lapacke.h>

/* A row of F-bar that sees only back faces: k <= 4096 float entries, each 0 but for a
 * rounding, summed in double (n = 4096, k = 2). */
#define ZERO_ROW_TOL TU_TOL_DBL(2, 4096)

static lrr_operator *build_scene(lrr_context *ctx, lrr_scene *s, size_t K, unsigned levels,
                                 unsigned R)
{
    lrr_subdivision sd = {.target_patches = K, .levels = levels};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_build_options o = {.hemicube_resolution = R, .seed = 3};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
    return op;
}

static int inside_quad_xz(const double q[4][2], double x, double z)
{
    int pos = 0, neg = 0;
    for (int i = 0; i < 4; i++) {
        const double *a = q[i], *b = q[(i + 1) % 4];
        double c = (b[0] - a[0]) * (z - a[1]) - (b[1] - a[1]) * (x - a[0]);
        pos |= c > 0;
        neg |= c < 0;
    }
    return !(pos && neg);
}

/* cornell-closed: every subpatch in the open room sees a full hemisphere of front faces
 * (row of F̄·d sums to 1); the floor under the blocks sees only back faces (sums to 0). */
static void test_closed_box_rows(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 1, 0, 0);
    lrr_operator *op = build_scene(ctx, s, 120, 2, 64);
    const double short_fp[4][2] = {{130, 65}, {82, 225}, {240, 272}, {290, 114}};
    const double tall_fp[4][2] = {{423, 247}, {265, 296}, {314, 456}, {472, 406}};
    size_t open = 0, hidden = 0, above_light = 0;
    double worst = 0;
    for (size_t i = 0; i < op->n; i++) {
        double sum = 0;
        for (size_t p = 0; p < op->k; p++)
            sum += op->fbar[i * op->k + p];
        sum *= (double)op->d;
        const float *c = op->centre + 3 * i, *nn = op->normal + 3 * i;
        int on_floor = fabsf(c[1]) < 1e-3f && nn[1] > 0.99f;
        int on_ceiling = fabsf(c[1] - 548.8f) < 1e-3f && nn[1] < -0.99f;
        if (on_floor && (inside_quad_xz(short_fp, c[0], c[2]) ||
                         inside_quad_xz(tall_fp, c[0], c[2]))) {
            ASSERT_NEAR(sum, 0.0, ZERO_ROW_TOL, "hidden floor subpatch %zu\n", i);
            hidden++;
        } else if (on_ceiling && c[0] > 213 && c[0] < 343 && c[2] > 227 && c[2] < 332) {
            /* 0.05 mm above the light's back face: nearly all of the hemisphere is occluded */
            assert_true(sum < 0.01);
            above_light++;
        } else if (c[1] == 0.0f && nn[1] < -0.99f) {
            /* block bottoms lie in the floor plane facing it: they see nothing */
            ASSERT_NEAR(sum, 0.0, ZERO_ROW_TOL, "block bottom subpatch %zu\n", i);
        } else {
            worst = fmax(worst, fabs(sum - 1));
            if (fabs(sum - 1) > 1e-3)
                fail_msg("open-room subpatch %zu at (%g, %g, %g) normal (%g, %g, %g): row sum "
                         "%.6f", i, c[0], c[1], c[2], nn[0], nn[1], nn[2], sum);
            open++;
        }
    }
    print_message("closed box: %zu open rows (worst |sum-1| = %.2e), %zu hidden, %zu above light\n",
                  open, worst, hidden, above_light);
    assert_true(hidden > 0);
    assert_true(above_light > 0);
    assert_true(open > op->n / 2);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* B from the operator against a dense LAPACK solve of (I - diag(rho_c) F̄ Vᵀ) B_c = E_c: the
 * SMW identity is exact, so they agree to float rounding. With d = 1, F̄ Vᵀ = F and this is
 * the full radiosity system: nothing is approximated. */
static void check_against_dense(lrr_context *ctx, lrr_operator *op, const float *E)
{
    size_t n = op->n, k = op->k, d = op->d;
    float *B = malloc(n * 3 * sizeof(float));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, E, B));
    double worst = 0;
    double *A = malloc(n * n * sizeof(double)), *x = malloc(n * sizeof(double));
    lapack_int *ipiv = malloc(n * sizeof(lapack_int));
    for (int c = 0; c < 3; c++) {
        for (size_t i = 0; i < n; i++) {
            for (size_t j = 0; j < n; j++)
                A[i * n + j] = (i == j) - (double)op->rho[3 * i + c] * op->fbar[i * k + j / d];
            x[i] = E[3 * i + c];
        }
        assert_int_equal(LAPACKE_dgesv(LAPACK_ROW_MAJOR, (lapack_int)n, 1, A, (lapack_int)n, ipiv,
                                       x, 1), 0);
        double num = 0, den = 0, maxerr = 0, maxref = 0;
        for (size_t i = 0; i < n; i++) {
            double e = B[3 * i + c] - x[i];
            num += e * e;
            den += x[i] * x[i];
            maxerr = fmax(maxerr, fabs(e));
            maxref = fmax(maxref, fabs(x[i]));
        }
        worst = fmax(worst, fmax(sqrt(num / den), maxerr / maxref));
        if (!(sqrt(num / den) <= 1e-5) || !(maxerr <= 1e-5 * maxref))
            fail_msg("channel %d (n = %zu, d = %zu): relative L2 %.3e, max %.3e", c, n, d,
                     sqrt(num / den), maxerr / maxref);
    }
    print_message("SMW vs dense dgesv, n = %zu, k = %zu, d = %zu: worst relative error %.2e\n",
                  n, k, d, worst);
    free(A);
    free(x);
    free(ipiv);
    free(B);
    lrr_solver_destroy(sv);
}

static void test_smw_vs_dense(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    const unsigned levels[] = {0, 1, 2};
    for (int l = 0; l < 3; l++) {
        lrr_operator *op = build_scene(ctx, s, 40, levels[l], 32);
        assert_int_equal(op->d, (size_t)1 << (2 * levels[l]));
        check_against_dense(ctx, op, op->emission);
        /* an arbitrary emission pattern on every subpatch */
        float *E = malloc(op->n * 3 * sizeof(float));
        for (size_t i = 0; i < op->n * 3; i++)
            E[i] = (float)((i * 2654435761u) % 1000) / 100.0f;
        check_against_dense(ctx, op, E);
        free(E);
        /* ||M_c||_inf <= 1/(1 - max rho) */
        for (int c = 0; c < 3; c++) {
            double maxrho = 0, norm = 0;
            for (size_t i = 0; i < op->n; i++)
                maxrho = fmax(maxrho, op->rho[3 * i + c]);
            for (size_t p = 0; p < op->k; p++) {
                double row = 0;
                for (size_t q = 0; q < op->k; q++)
                    row += fabs(op->m[c * op->k * op->k + p * op->k + q]);
                norm = fmax(norm, row);
            }
            assert_true(norm <= 1 / (1 - maxrho) * (1 + 1e-5));
            assert_true(op->cond[c] >= 1 && op->cond[c] < 1e3);
        }
        lrr_operator_destroy(op);
    }
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Furnace: a sealed box, uniform rho and E: B = E/(1 - rho) everywhere. */
static void test_furnace(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const float r[3] = {0.9f, 0.5f, 0.99f};
    lrr_scene *s = tu_furnace(ctx, 1.0, 0.7, 1.3, r, 2.0f);
    lrr_operator *op = build_scene(ctx, s, 48, 2, 64);
    float *B = malloc(op->n * 3 * sizeof(float));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, B));
    double worst[3] = {0, 0, 0};
    for (size_t i = 0; i < op->n; i++)
        for (int c = 0; c < 3; c++) {
            double expect = 2.0 / (1.0 - r[c]);
            double rel = fabs(B[3 * i + c] - expect) / expect;
            worst[c] = fmax(worst[c], rel);
            if (!(rel <= 0.01))
                fail_msg("subpatch %zu channel %d: B = %g, expected %g", i, c, B[3 * i + c],
                         expect);
        }
    print_message("furnace: worst relative error %.2e (rho 0.9), %.2e (0.5), %.2e (0.99)\n",
                  worst[0], worst[1], worst[2]);
    lrr_solver_destroy(sv);
    free(B);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* New reflectances recompute M without new form factors and match a fresh build. */
static void test_set_reflectance(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_operator *op = build_scene(ctx, s, 40, 1, 32);
    float *rho = malloc(op->n * 3 * sizeof(float));
    for (size_t i = 0; i < op->n * 3; i++)
        rho[i] = 0.3f + 0.6f * (float)((i * 7919) % 100) / 100.0f;
    LRR_CHECK(ctx, lrr_operator_set_reflectance(op, rho));
    assert_memory_equal(op->rho, rho, op->n * 3 * sizeof(float));
    check_against_dense(ctx, op, op->emission);
    /* invalid reflectance: rejected, operator unchanged */
    float *m_before = malloc(3 * op->k * op->k * sizeof(float));
    memcpy(m_before, op->m, 3 * op->k * op->k * sizeof(float));
    rho[17] = 1.0f;
    assert_int_equal(lrr_operator_set_reflectance(op, rho), LRR_ERR_MATERIAL);
    char msg[512];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_MATERIAL);
    assert_non_null(strstr(msg, "subpatch 5"));
    rho[17] = NAN;
    assert_int_equal(lrr_operator_set_reflectance(op, rho), LRR_ERR_MATERIAL);
    assert_memory_equal(op->m, m_before, 3 * op->k * op->k * sizeof(float));
    /* reflectance 0 everywhere: B = E */
    memset(rho, 0, op->n * 3 * sizeof(float));
    LRR_CHECK(ctx, lrr_operator_set_reflectance(op, rho));
    float *B = malloc(op->n * 3 * sizeof(float));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, B));
    assert_memory_equal(B, op->emission, op->n * 3 * sizeof(float));
    lrr_solver_destroy(sv);
    free(B);
    free(m_before);
    free(rho);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Errors of the solve and build entry points. */
static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_operator *op;
    assert_int_equal(lrr_operator_build(s, NULL, &op), LRR_ERR_INVALID_ARG);
    assert_null(op);
    lrr_context_last_error(ctx, NULL, 0);
    lrr_subdivision sd = {.target_patches = 36};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_build_options odd = {.hemicube_resolution = 33};
    assert_int_equal(lrr_operator_build(s, &odd, &op), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, NULL, 0);
    lrr_build_options o = {.hemicube_resolution = 16};
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
    lrr_solver *sv;
    assert_int_equal(lrr_solver_create(op, (lrr_backend)12345, &sv), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_context_last_error(ctx, NULL, 0), LRR_ERR_INVALID_ARG);
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    float *E = calloc(op->n * 3, sizeof(float)), *B = calloc(op->n * 3, sizeof(float));
    E[3 * 7 + 1] = NAN;
    assert_int_equal(lrr_solve(sv, E, B), LRR_ERR_INVALID_ARG);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "subpatch 7"));
    E[3 * 7 + 1] = -1;
    assert_int_equal(lrr_solve(sv, E, B), LRR_ERR_INVALID_ARG);
    E[3 * 7 + 1] = INFINITY;
    assert_int_equal(lrr_solve(sv, E, B), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_solve(sv, E, E), LRR_ERR_INVALID_ARG);
    free(E);
    free(B);
    lrr_solver_destroy(sv);
    lrr_solver_destroy(NULL);
    lrr_operator_destroy(op);
    lrr_operator_destroy(NULL);
    lrr_scene_destroy(s);
    lrr_scene_destroy(NULL);
    lrr_context_destroy(ctx);
}

static int cancel_half(void *user, size_t done, size_t total)
{
    int *calls = user;
    (*calls)++;
    return done * 2 >= total;
}

static void test_progress_cancel(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sd = {.target_patches = 200, .levels = 2};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    int calls = 0;
    lrr_build_options o = {.hemicube_resolution = 32, .threads = 1, .progress = cancel_half,
                           .progress_user = &calls};
    lrr_operator *op = (lrr_operator *)1;
    assert_int_equal(lrr_operator_build(s, &o, &op), LRR_ERR_CANCELLED);
    assert_null(op);
    assert_true(calls >= 1);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_closed_box_rows),
        cmocka_unit_test(test_smw_vs_dense),
        cmocka_unit_test(test_furnace),
        cmocka_unit_test(test_set_reflectance),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_progress_cancel),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
