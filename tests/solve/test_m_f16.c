/* M − I in binary16 (lib/solve/m_f16.c): its row kernels against double precision, its
 * encoding's rounding bound, the solver's choice and its error beside 16-bit F̄'s own, and
 * copies of M that follow lrr_operator_set_reflectance. */
#include "testutil.h"
#include "solve/solve.h"

/* a float dot product of k terms against the double one, relative to Σ|terms| (as
 * test_realtime_kernel.c's DOT_TOL: 8 or 16 lanes keep each chain short) */
#define DOT_TOL TU_TOL_FLT(1, 9)

static uint64_t rng = 987654321;
static double rnd(void)
{
    rng = rng * 6364136223846793005ull + 1442695040888963407ull;
    return (double)(rng >> 40) / (1 << 24);
}

/* gemv_f16_rows of every variant this CPU runs: rows [i0, i1) of y = scale ∘ (A x) against
 * the decoded values in double, and nothing written outside [i0, i1); k and the row span
 * cover the 8- and 16-lane tails and the 8-row groups. */
static void test_kernels(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const char *variants[] = {"c", "avx2", "avx512"};
    const size_t ks[] = {1, 7, 8, 9, 15, 16, 17, 33, 200};
    int ran = 0;
    for (int v = 0; v < 3; v++) {
        lrr__cpu_choice choice;
        if (lrr__cpu_parse(ctx, variants[v], &choice) != LRR_OK) {
            lrr_context_last_error(ctx, NULL, 0);
            continue;
        }
        const lrr__kernel *kn = lrr__kernel_select(&choice, 16);
        ran++;
        for (size_t t = 0; t < sizeof ks / sizeof ks[0]; t++) {
            const size_t k = ks[t], rows = 21;
            uint16_t *a = malloc(rows * k * sizeof *a);
            float *x = malloc(k * sizeof *x), *y = malloc((rows + 2) * sizeof *y),
                  scale[21];
            assert_non_null(a && x && y);
            for (size_t j = 0; j < rows * k; j++) /* signs mixed, magnitudes to 2^15 */
                a[j] = lrr__f32_to_f16((float)((rnd() - 0.2) * 30000.0));
            for (size_t q = 0; q < k; q++)
                x[q] = (float)rnd();
            for (size_t i = 0; i < rows; i++)
                scale[i] = ldexpf(1.0f, -(int)(i % 5) - 12);
            for (size_t i0 = 0; i0 < 3; i0++) {
                const size_t i1 = rows - i0 % 2;
                for (size_t i = 0; i < rows + 2; i++)
                    y[i] = -7.0f;
                kn->gemv_f16_rows(a, scale, i0, i1, k, x, y);
                for (size_t i = 0; i < rows + 2; i++) {
                    if (i < i0 || i >= i1) {
                        assert_true(y[i] == -7.0f);
                        continue;
                    }
                    double ref = 0, mag = 0;
                    for (size_t q = 0; q < k; q++) {
                        double term = (double)lrr__f16_to_f32(a[i * k + q]) * x[q];
                        ref += term;
                        mag += fabs(term);
                    }
                    ASSERT_NEAR(y[i], scale[i] * ref, DOT_TOL * scale[i] * mag + 1e-30,
                                "%s: k %zu row %zu of [%zu, %zu)\n", kn->name, k, i, i0, i1);
                }
            }
            free(a), free(x), free(y);
        }
    }
    assert_true(ran >= 1);
    lrr_context_destroy(ctx);
}

/* The encoding: decoded, H + I is M within binary16's half an ulp of each entry (2^-11
 * relative) plus half the smallest subnormal step of the row's scale (2^-25·s), and every
 * row's largest entry lies in [2^14, 2^15)·s, which keeps its entries normal numbers. */
static void test_encoding(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t n;
    lrr_operator *op = tu_closed_cornell_op(ctx, &n);
    const size_t k = op->k;
    /* rows whose M − I is tiny (a loaded file may hold any finite M): the largest entry
     * subnormal, FLT_MIN, and 2^-111, where the power of two reaches FLT_MIN; their scale
     * must stay a normal float, not 0 (division by it gave NaN) */
    const float tiny[] = {2.5e-42f, FLT_MIN, 0x1p-111f};
    for (size_t t = 0; t < 3; t++) {
        float *row = op->m + (t * k + t) * k; /* channel t, row t */
        for (size_t p = 0; p < k; p++)
            row[p] = p == t ? 1.0f : (p % 2 ? tiny[t] : -tiny[t] / 3);
    }
    lrr__m_f16 *m;
    LRR_CHECK(ctx, lrr__m_f16_create(op, &m));
    assert_int_equal(m->k, k);
    for (size_t r = 0; r < 3 * k; r++) {
        const float s = m->scale[r];
        double mx = 0;
        for (size_t p = 0; p < k; p++) {
            const double want = (double)op->m[r * k + p] - (p == r % k ? 1.0 : 0.0);
            const double got = (double)lrr__f16_to_f32(m->val[r * k + p]) * s;
            ASSERT_NEAR(got, want, ldexp(fabs(want), -11) + ldexp(s, -25),
                        "channel %zu row %zu column %zu\n", r / k, r % k, p);
            mx = fmax(mx, fabs(got));
        }
        assert_true(s >= FLT_MIN && isfinite(s));
        assert_true(mx == 0 || ((mx >= ldexp(s, 14) || s == FLT_MIN) && mx < ldexp(s, 15)));
    }
    lrr__m_f16_destroy(m);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void solve_full(lrr_context *ctx, const lrr_operator *op, lrr_storage m_storage,
                       const float *E, float *B, lrr_solver_info *info)
{
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solver_set_m(sv, m_storage));
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
    LRR_CHECK(ctx, lrr_solve(sv, E, B));
    lrr_solver_get_info(sv, info, sizeof *info);
    lrr_solver_destroy(sv);
}

/* The solver's choice (M − I in binary16 exactly when F̄ is 16-bit), its bytes, and the
 * issue's condition for it: on the closed Cornell box (every bounce kept: the most light in
 * M − I) it adds at most a fifth of the error that 16-bit F̄ makes (B against the f32
 * operator's, rel L2), for f16 and bf16 F̄ alike. */
static void test_choice_and_error(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t n;
    lrr_operator *op32 = tu_closed_cornell_op(ctx, &n);
    const size_t k = op32->k;
    float *E = malloc(3 * n * sizeof *E), *b32 = malloc(3 * n * sizeof *b32),
          *bm32 = malloc(3 * n * sizeof *bm32), *bm16 = malloc(3 * n * sizeof *bm16);
    assert_non_null(E && b32 && bm32 && bm16);
    for (size_t j = 0; j < 3 * n; j++) /* every patch emits a little: all of M is read */
        E[j] = op32->emission[j] + (float)(0.05 * rnd());
    lrr_solver *sv;
    lrr_solver_info info;
    LRR_CHECK(ctx, lrr_solver_create(op32, LRR_BACKEND_CPU, &sv));
    lrr_solver_get_info(sv, &info, sizeof info);
    assert_int_equal(info.m, LRR_STORAGE_F32);
    assert_int_equal(info.m_bytes, 3 * k * k * sizeof(float));
    assert_int_equal(lrr_solver_set_m(sv, LRR_STORAGE_BF16), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, NULL, 0);
    lrr_solver_destroy(sv);
    solve_full(ctx, op32, LRR_STORAGE_F32, E, b32, &info);
    for (int st = LRR_STORAGE_F16; st <= LRR_STORAGE_BF16; st++) {
        lrr_operator *op16;
        size_t n16;
        op16 = tu_closed_cornell_op(ctx, &n16);
        LRR_CHECK(ctx, lrr_operator_set_storage(op16, (lrr_storage)st));
        LRR_CHECK(ctx, lrr_solver_create(op16, LRR_BACKEND_CPU, &sv));
        lrr_solver_get_info(sv, &info, sizeof info);
        assert_int_equal(info.m, LRR_STORAGE_F16);
        assert_int_equal(info.m_bytes, 3 * k * k * 2 + 3 * k * 4);
        lrr_solver_destroy(sv);
        solve_full(ctx, op16, LRR_STORAGE_F32, E, bm32, &info);
        solve_full(ctx, op16, LRR_STORAGE_F16, E, bm16, &info);
        const double fbar_err = tu_rel_l2(3 * n, bm32, b32);
        const double m_err = tu_rel_l2(3 * n, bm16, bm32);
        print_message("%s F̄: its error %.3g, M − I in binary16 adds %.3g\n",
                      lrr_storage_name((lrr_storage)st), fbar_err, m_err);
        assert_true(fbar_err > 0 && m_err > 0); /* both really rounded */
        assert_true(m_err <= 0.2 * fbar_err);
        lrr_operator_destroy(op16);
    }
    free(E), free(b32), free(bm32), free(bm16);
    lrr_operator_destroy(op32);
    lrr_context_destroy(ctx);
}

/* New reflectances reach a solver made before them: its M − I in binary16 and its cached
 * columns (sparse path) are made again, so B equals a new solver's bit for bit. */
static void test_new_reflectance(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t n;
    lrr_operator *op = tu_closed_cornell_op(ctx, &n);
    LRR_CHECK(ctx, lrr_operator_set_storage(op, LRR_STORAGE_F16));
    float *rho = malloc(3 * n * sizeof *rho), *b0 = malloc(3 * n * sizeof *b0),
          *b1 = malloc(3 * n * sizeof *b1);
    assert_non_null(rho && b0 && b1);
    for (lrr_path path = LRR_PATH_FULL; path <= LRR_PATH_SPARSE; path++) {
        lrr_solver *old, *fresh;
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &old));
        LRR_CHECK(ctx, lrr_solver_set_path(old, path));
        LRR_CHECK(ctx, lrr_solve(old, op->emission, b0));
        assert_int_equal(lrr_solver_last_path(old), path);
        for (size_t j = 0; j < 3 * n; j++)
            rho[j] = 0.5f * op->rho[j];
        LRR_CHECK(ctx, lrr_operator_set_reflectance(op, rho));
        LRR_CHECK(ctx, lrr_solve(old, op->emission, b0));
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &fresh));
        LRR_CHECK(ctx, lrr_solver_set_path(fresh, path));
        LRR_CHECK(ctx, lrr_solve(fresh, op->emission, b1));
        assert_memory_equal(b0, b1, 3 * n * sizeof *b0);
        lrr_solver_destroy(old);
        lrr_solver_destroy(fresh);
    }
    free(rho), free(b0), free(b1);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_kernels),
        cmocka_unit_test(test_encoding),
        cmocka_unit_test(test_choice_and_error),
        cmocka_unit_test(test_new_reflectance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
