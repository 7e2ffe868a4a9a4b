/* The real-time kernels of the solve (lib/solve/realtime_kernel.c): each SIMD variant and
 * row storage against a naive double-precision product, the variant selection, LRR_SIMD. */
#include "testutil.h"
#include "solve/solve.h"

/* A float dot product of k terms against the double one, relative to the sum of |terms|:
 * the kernels sum in 8 or 16 float lanes, so each chain is short and its roundings of
 * random sign; n = 9 roundings (k = 1) holds for every variant and k <= 217. */
#define DOT_TOL TU_TOL_FLT(1, 9)

/* The real-time kernels (realtime_kernel.c), every SIMD variant this CPU runs and every
 * storage (float, binary16, bfloat16 rows), against a naive double-precision product on
 * sizes that exercise the vector and row-group tails (n = 1, 37; k = 1, 7, 8, 9, 13, 16,
 * 17, 64, 217). */
static void test_realtime_kernels(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const size_t ks[] = {1, 7, 8, 9, 13, 16, 17, 64, 217};
    const size_t ns[] = {1, 37};
    const char *variants[] = {"c", "avx2", "avx2+prefetch", "avx512", "avx512+prefetch"};
    uint64_t x = 12345;
#define RND() ((x = x * 6364136223846793005ull + 1442695040888963407ull), (double)(x >> 40) / (1 << 24))
    int ran = 0;
    for (int v = 0; v < 5; v++) {
        lrr__cpu_choice choice;
        lrr_status st = lrr__cpu_parse(ctx, variants[v], &choice);
        if (st == LRR_ERR_UNSUPPORTED) {
            print_message("kernel %s: not supported by this CPU, skipped\n", variants[v]);
            lrr_context_last_error(ctx, NULL, 0);
            continue;
        }
        assert_int_equal(st, LRR_OK);
        const lrr__kernel *kn = lrr__kernel_select(&choice, 17);
        assert_string_equal(kn->name, variants[v]);
        ran++;
        for (size_t t = 0; t < sizeof ks / sizeof ks[0]; t++)
            for (size_t u = 0; u < 2; u++) {
                size_t k = ks[t], n = ns[u];
                float *m = malloc(3 * k * k * sizeof *m), *w = malloc(3 * k * sizeof *w),
                      *z = malloc(3 * k * sizeof *z), *f = malloc(n * k * sizeof *f),
                      *e = malloc(3 * n * sizeof *e), *rho = malloc(3 * n * sizeof *rho),
                      *b = malloc(3 * n * sizeof *b);
                assert_non_null(m && w && z && f && e && rho && b);
                for (size_t i = 0; i < 3 * k * k; i++)
                    m[i] = (float)(RND() - 0.3);
                for (size_t i = 0; i < 3 * k; i++)
                    w[i] = (float)RND();
                for (size_t i = 0; i < n * k; i++)
                    f[i] = (float)RND();
                for (size_t i = 0; i < 3 * n; i++) {
                    e[i] = (float)RND();
                    rho[i] = (float)(0.9 * RND());
                }
                lrr__smw_apply(kn, m, k, w, z);
                for (int c = 0; c < 3; c++)
                    for (size_t p = 0; p < k; p++) {
                        double ref = 0, mag = 0;
                        for (size_t q = 0; q < k; q++) {
                            ref += (double)m[(c * k + p) * k + q] * w[c * k + q];
                            mag += fabs((double)m[(c * k + p) * k + q] * w[c * k + q]);
                        }
                        ASSERT_NEAR(z[c * k + p], ref, DOT_TOL * mag + 1e-30,
                                    "%s: k %zu c %d p %zu\n", kn->name, k, c, p);
                    }
                /* float rows, then binary16 and bfloat16 rows (with a row scale of 2^-3)
                 * against the same product on the decoded values */
                uint16_t *h = malloc(n * k * sizeof *h);
                float *dec = malloc(n * k * sizeof *dec), scale[37];
                for (int kind = 0; kind < 3; kind++) {
                    const float *src = f;
                    if (kind == 0) {
                        kn->fbar_rows(f, 0, n, k, z, e, rho, b);
                    } else {
                        for (size_t i = 0; i < n; i++)
                            scale[i] = 0.125f;
                        for (size_t j = 0; j < n * k; j++) {
                            h[j] = kind == 1 ? lrr__f32_to_f16(f[j] * 8)
                                             : lrr__f32_to_bf16(f[j] * 8);
                            dec[j] = (kind == 1 ? lrr__f16_to_f32(h[j])
                                                : lrr__bf16_to_f32(h[j])) * 0.125f;
                        }
                        (kind == 1 ? kn->f16_rows : kn->bf16_rows)(h, scale, 0, n, k, z, e,
                                                                    rho, b);
                        src = dec;
                    }
                    for (size_t i = 0; i < n; i++)
                        for (int c = 0; c < 3; c++) {
                            double dot = 0, mag = 0;
                            for (size_t p = 0; p < k; p++) {
                                dot += (double)src[i * k + p] * z[c * k + p];
                                mag += fabs((double)src[i * k + p] * z[c * k + p]);
                            }
                            double ref = e[3 * i + c] + (double)rho[3 * i + c] * dot;
                            ASSERT_NEAR(b[3 * i + c], ref, DOT_TOL * (mag + e[3 * i + c]) + 1e-30,
                                        "%s (%s rows): n %zu k %zu row %zu c %d\n", kn->name,
                                        kind == 0 ? "f32" : kind == 1 ? "f16" : "bf16", n, k,
                                        i, c);
                        }
                }
                free(h), free(dec);
                free(m), free(w), free(z), free(f), free(e), free(rho), free(b);
            }
    }
#undef RND
    assert_true(ran >= 1);
    /* a name that is not a variant is an argument error (tests/core/test_cpu.c: the message) */
    lrr__cpu_choice choice;
    assert_int_equal(lrr__cpu_parse(ctx, "sse9", &choice), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, NULL, 0);
    /* unforced: the widest variant the CPU runs, with the panels' prefetch on Intel */
    assert_int_equal(lrr__cpu_parse(ctx, NULL, &choice), LRR_OK);
    const lrr__kernel *kn = lrr__kernel_select(&choice, 216);
    const char *pf = __builtin_cpu_is("intel") ? "+prefetch" : "";
    char want[32];
    if (lrr__cpu_supports(LRR__ISA_AVX512)) {
        snprintf(want, sizeof want, "avx512%s", pf);
        assert_string_equal(kn->name, want);
    } else if (lrr__cpu_supports(LRR__ISA_AVX2)) {
        snprintf(want, sizeof want, "avx2%s", pf);
        assert_string_equal(kn->name, want);
    }
    /* LRR_SIMD reaches the solver; every variant gives the same B to float rounding */
    lrr_operator *op = tu_cornell_op(ctx, 40, 1, 16, 3);
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* the rows kernels */
    float *b0 = malloc(3 * op->n * sizeof *b0), *b1 = malloc(3 * op->n * sizeof *b1);
    lrr_solver *sv;
    setenv("LRR_SIMD", "c", 1);
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    assert_string_equal(lrr_solver_kernel(sv), "c");
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, b0));
    lrr_solver_destroy(sv);
    unsetenv("LRR_SIMD");
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, b1));
    /* not rounding alone: the solve amplifies the kernels' rounding by the condition of
     * I - rho F (~ 1 / (1 - max rho) = 5 here), so 1e-5 relative, 1e-6 absolute */
    for (size_t j = 0; j < 3 * op->n; j++)
        ASSERT_NEAR(b1[j], b0[j], 1e-5 * fabs(b0[j]) + 1e-6, "%s vs c: entry %zu\n",
                    lrr_solver_kernel(sv), j);
    lrr_solver_destroy(sv);
    setenv("LRR_SIMD", "bogus", 1);
    sv = (lrr_solver *)0x1;
    assert_int_equal(lrr_solver_create(op, LRR_BACKEND_CPU, &sv), LRR_ERR_INVALID_ARG);
    assert_null(sv);
    unsetenv("LRR_SIMD");
    free(b0);
    free(b1);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_realtime_kernels),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
