/* Reduced-precision storage of F̄ (lib/operator/storage.c and the 16-bit kernels). */
#include "testutil.h"
#include "solve/solve.h"

#include <lapacke.h>
#if defined(__x86_64__)
#include <immintrin.h>
#endif

/* Every finite binary16 / bfloat16 value survives decode → encode unchanged. */
static void test_exhaustive_round_trip(void **state)
{
    (void)state;
    for (uint32_t h = 0; h < 65536; h++) {
        uint16_t v = (uint16_t)h;
        if ((v & 0x7c00u) != 0x7c00u) {
            float f = lrr__f16_to_f32(v);
            if (lrr__f32_to_f16(f) != v)
                fail_msg("binary16 %04x -> %g -> %04x", h, (double)f, lrr__f32_to_f16(f));
        }
        if ((v & 0x7f80u) != 0x7f80u) {
            float f = lrr__bf16_to_f32(v);
            if (lrr__f32_to_bf16(f) != v)
                fail_msg("bfloat16 %04x -> %g -> %04x", h, (double)f, lrr__f32_to_bf16(f));
        }
    }
    assert_int_equal(lrr__f32_to_f16(65520.0f), 0x7c00);  /* rounds to Inf */
    assert_int_equal(lrr__f32_to_f16(65519.0f), 0x7bff);  /* 65504 */
    assert_int_equal(lrr__f32_to_f16(ldexpf(1, -25)), 0); /* tie → even (zero) */
    assert_int_equal(lrr__f32_to_f16(ldexpf(1.5f, -25)), 1);
    assert_int_equal(lrr__f32_to_f16(-0.0f), 0x8000);
    assert_true(isnan(lrr__f16_to_f32(lrr__f32_to_f16(NAN))));
    assert_true(isnan(lrr__bf16_to_f32(lrr__f32_to_bf16(NAN))));
}

#if defined(__x86_64__)
__attribute__((target("f16c"))) static uint16_t hw_f16(float f)
{
    return (uint16_t)_cvtss_sh(f, _MM_FROUND_TO_NEAREST_INT);
}
#endif

/* Rounding: against the CPU's own conversion (F16C) where present, and against the
 * definition (nearest of the two neighbours, ties to even) for bfloat16. */
static void test_rounding(void **state)
{
    (void)state;
    uint64_t x = 99;
    int hw = 0;
#if defined(__x86_64__)
    hw = __builtin_cpu_supports("f16c");
#endif
    for (int i = 0; i < 2000000; i++) {
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        uint32_t u = (uint32_t)(x >> 32);
        float f;
        memcpy(&f, &u, 4);
        if (isnan(f))
            continue;
#if defined(__x86_64__)
        if (hw && lrr__f32_to_f16(f) != hw_f16(f))
            fail_msg("binary16 of %a: ours %04x, F16C %04x", (double)f, lrr__f32_to_f16(f),
                     hw_f16(f));
#endif
        uint16_t b = lrr__f32_to_bf16(f);
        if (isinf(f) || (b & 0x7f80u) == 0x7f80u)
            continue;
        double lo = lrr__bf16_to_f32((uint16_t)(u >> 16)), err = fabs((double)f - lrr__bf16_to_f32(b));
        double hi = lrr__bf16_to_f32((uint16_t)((u >> 16) + 1));
        double best = fmin(fabs((double)f - lo), fabs((double)f - hi));
        if (err > best || (err == best && fabs((double)f - lo) == fabs((double)f - hi) && (b & 1)))
            fail_msg("bfloat16 of %a: %04x is not the nearest-even neighbour", (double)f, b);
    }
    if (!hw)
        print_message("F16C not available: binary16 checked exhaustively only\n");
}

/* F̄ as rows: the tests below read its memory directly */
static lrr_operator *cornell_op(lrr_context *ctx, size_t K, unsigned levels)
{
    lrr_operator *op = tu_cornell_op(ctx, K, levels, 32, 4);
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS));
    return op;
}

/* A solve with 16-bit F̄ equals a dense solve of (I − R F̄q Vᵀ) B = E with the decoded F̄q
 * (M is recomputed from what is stored, so the SMW identity holds exactly), for every SIMD
 * variant; against float storage it differs by the quantisation only. */
static void test_solve_16bit(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 45, 1);
    const size_t n = op->n, k = op->k, d = op->d;
    float *b32 = malloc(3 * n * sizeof *b32), *b = malloc(3 * n * sizeof *b),
          *row = malloc(k * sizeof *row);
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, b32));
    lrr_solver_destroy(sv);
    lrr_operator_info i32;
    lrr_operator_get_info(op, &i32, sizeof i32);
    const lrr_storage kinds[2] = {LRR_STORAGE_F16, LRR_STORAGE_BF16};
    const double bound[2] = {1e-4, 1e-3}; /* quantisation only: measured 6e-6 and 6e-5 */
    for (int t = 0; t < 2; t++) {
        /* the f16 pass decodes back to float first: bf16 then re-encodes those values,
         * whose rounding to 8 bits is the same as from the originals up to ties */
        LRR_CHECK(ctx, lrr_operator_set_storage(op, LRR_STORAGE_F32));
        LRR_CHECK(ctx, lrr_operator_set_storage(op, kinds[t]));
        lrr_operator_info info;
        lrr_operator_get_info(op, &info, sizeof info);
        assert_int_equal(info.storage, kinds[t]);
        assert_true(info.bytes < i32.bytes);
        assert_null(lrr_operator_fbar(op));
        /* dense reference with the decoded F̄ */
        double *A = malloc(n * n * sizeof *A), *x = malloc(n * sizeof *x);
        lapack_int *ipiv = malloc(n * sizeof *ipiv);
        float *ref = malloc(3 * n * sizeof *ref);
        for (int c = 0; c < 3; c++) {
            for (size_t i = 0; i < n; i++) {
                lrr_operator_fbar_row(op, i, row);
                for (size_t j = 0; j < n; j++)
                    A[i * n + j] = (i == j) - (double)op->rho[3 * i + c] * row[j / d];
                x[i] = op->emission[3 * i + c];
            }
            assert_int_equal(LAPACKE_dgesv(LAPACK_ROW_MAJOR, (lapack_int)n, 1, A,
                                           (lapack_int)n, ipiv, x, 1), 0);
            for (size_t i = 0; i < n; i++)
                ref[3 * i + c] = (float)x[i];
        }
        const char *variants[] = {"c", "avx2", "avx2+prefetch", "avx512", "avx512+prefetch"};
        for (int v = 0; v < 5; v++) {
            setenv("LRR_SIMD", variants[v], 1);
            lrr_status st = lrr_solver_create(op, LRR_BACKEND_CPU, &sv);
            if (st == LRR_ERR_UNSUPPORTED) {
                lrr_context_last_error(ctx, NULL, 0);
                continue;
            }
            LRR_CHECK(ctx, st);
            LRR_CHECK(ctx, lrr_solve(sv, op->emission, b));
            double e_exact = tu_rel_l2(3 * n, b, ref), e_32 = tu_rel_l2(3 * n, b, b32);
            print_message("%s storage, %s kernel: vs dense with decoded F̄ %.2e, vs f32 %.2e\n",
                          lrr_storage_name(kinds[t]), variants[v], e_exact, e_32);
            assert_true(e_exact <= 1e-5);
            assert_true(e_32 <= bound[t]);
            lrr_solver_destroy(sv);
        }
        unsetenv("LRR_SIMD");
        free(A), free(x), free(ipiv), free(ref);
    }
    free(b32), free(b), free(row);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The per-row scale keeps small form factors: with d = 256 most F̄ entries lie below
 * binary16's smallest normal, yet every entry decodes within binary16's relative precision. */
static void test_small_values_keep_precision(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 20, 4);
    const size_t n = op->n, k = op->k;
    float *orig = malloc(n * k * sizeof *orig), *row = malloc(k * sizeof *row);
    memcpy(orig, op->fbar, n * k * sizeof *orig);
    size_t tiny = 0, nonzero = 0;
    for (size_t j = 0; j < n * k; j++) {
        nonzero += orig[j] > 0;
        tiny += orig[j] > 0 && orig[j] < ldexpf(1, -14);
    }
    LRR_CHECK(ctx, lrr_operator_set_storage(op, LRR_STORAGE_F16));
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        lrr_operator_fbar_row(op, i, row);
        for (size_t q = 0; q < k; q++) {
            float o = orig[i * k + q];
            if (o > 0)
                worst = fmax(worst, fabs(row[q] - o) / o);
            else
                assert_true(row[q] == 0);
        }
    }
    print_message("d = %zu: %zu of %zu non-zero F̄ entries below 2^-14; worst relative "
                  "decode error %.2e\n", op->d, tiny, nonzero, worst);
    assert_true(tiny > nonzero / 4);
    assert_true(worst <= ldexp(1, -11) * 1.0001);
    free(orig), free(row);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* 16-bit operators round-trip through files bit-identically; corruption is detected. */
static void test_file_round_trip(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 30, 1);
    const lrr_storage kinds[2] = {LRR_STORAGE_F16, LRR_STORAGE_BF16};
    char path[256];
    tu_tmp_path(path, sizeof path, "storage");
    for (int t = 0; t < 2; t++) {
        LRR_CHECK(ctx, lrr_operator_set_storage(op, kinds[t]));
        LRR_CHECK(ctx, lrr_operator_save(op, path));
        lrr_operator *back;
        LRR_CHECK(ctx, lrr_operator_load(ctx, path, &back));
        LRR_CHECK(ctx, lrr_operator_set_layout(back, LRR_LAYOUT_ROWS)); /* read as rows below */
        assert_int_equal(back->storage, kinds[t]);
        assert_memory_equal(back->fbar16, op->fbar16, op->n * op->k * sizeof(uint16_t));
        assert_memory_equal(back->row_scale, op->row_scale, op->n * sizeof(float));
        assert_memory_equal(back->m, op->m, 3 * op->k * op->k * sizeof(float));
        lrr_operator_destroy(back);
        /* flip one byte in the middle of the file (inside FBAR, the largest section) */
        FILE *f = fopen(path, "r+b");
        assert_non_null(f);
        fseek(f, 0, SEEK_END);
        long size = ftell(f);
        fseek(f, size / 2, SEEK_SET);
        int ch = fgetc(f);
        fseek(f, size / 2, SEEK_SET);
        fputc(ch ^ 0x10, f);
        fclose(f);
        assert_int_equal(lrr_operator_load(ctx, path, &back), LRR_ERR_CORRUPT);
        lrr_context_last_error(ctx, NULL, 0);
    }
    unlink(path);
    /* back to float: the decoded values */
    LRR_CHECK(ctx, lrr_operator_set_storage(op, LRR_STORAGE_F32));
    assert_non_null(op->fbar);
    assert_null(op->fbar16);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 12, 0);
    assert_int_equal(lrr_operator_set_storage(op, (lrr_storage)3), LRR_ERR_INVALID_ARG);
    assert_int_equal(op->storage, LRR_STORAGE_F32);
    for (int t = 0; t < 3; t++) {
        lrr_storage back;
        assert_int_equal(lrr_storage_from_name(lrr_storage_name((lrr_storage)t), &back), LRR_OK);
        assert_int_equal(back, t);
    }
    lrr_storage dummy;
    assert_int_equal(lrr_storage_from_name("fp16", &dummy), LRR_ERR_INVALID_ARG);
    assert_null(lrr_storage_name((lrr_storage)7));
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_exhaustive_round_trip),
        cmocka_unit_test(test_rounding),
        cmocka_unit_test(test_solve_16bit),
        cmocka_unit_test(test_small_values_keep_precision),
        cmocka_unit_test(test_file_round_trip),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
