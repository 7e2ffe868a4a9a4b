/* F̄ in panels (lib/operator/layout.c, lib/solve/panel_kernel.c): the layout changes where
 * the entries sit, never their values; every kernel variant reads either layout and gives
 * the product computed independently in double; files hold rows whatever the layout. */
#include "testutil.h"
#include "solve/solve.h"

/* Cornell box with about K patches of 4^levels subpatches: n = 32m + r for most K */
static lrr_operator *cornell_op(lrr_context *ctx, size_t K, unsigned levels)
{
    return tu_cornell_op(ctx, K, levels, 16, 3);
}

static float *all_rows(const lrr_operator *op)
{
    float *f = malloc(op->n * op->k * sizeof *f);
    assert_non_null(f);
    for (size_t i = 0; i < op->n; i++)
        lrr_operator_fbar_row(op, i, f + i * op->k);
    return f;
}

/* Rows → panels → rows restores every byte; the decoded rows never change; the panel
 * entries sit where operator.h says (checked against the row-major copy). */
static void test_round_trip(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 50, 1);
    const size_t n = op->n, k = op->k;
    assert_true(n % LRR__PANEL != 0 && n > 2 * LRR__PANEL); /* panels and a row-major tail */
    for (int storage = 0; storage < 3; storage++) {
        LRR_CHECK(ctx, lrr_operator_set_storage(op, (lrr_storage)storage));
        lrr_operator_info info;
        lrr_operator_get_info(op, &info, sizeof info);
        assert_int_equal(info.layout, LRR_LAYOUT_PANELS); /* set_storage keeps the layout */
        assert_null(lrr_operator_fbar(op));
        float *dec = all_rows(op);
        const size_t es = storage ? 2 : 4;
        unsigned char *panels = malloc(n * k * es), *rows = malloc(n * k * es);
        const void *data = storage ? (const void *)op->fbar16 : (const void *)op->fbar;
        memcpy(panels, data, n * k * es);
        LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS));
        lrr_operator_get_info(op, &info, sizeof info);
        assert_int_equal(info.layout, LRR_LAYOUT_ROWS);
        data = storage ? (const void *)op->fbar16 : (const void *)op->fbar;
        memcpy(rows, data, n * k * es);
        if (storage == 0)
            assert_ptr_equal(lrr_operator_fbar(op), op->fbar); /* the row-major view */
        float *dec_rows = all_rows(op);
        assert_memory_equal(dec, dec_rows, n * k * sizeof *dec);
        /* entry (i, q) of a panel: block start i0·k, then column q of 32, row i − i0 */
        const size_t np = n - n % LRR__PANEL;
        for (size_t i = 0; i < n; i++)
            for (size_t q = 0; q < k; q++) {
                size_t at = i < np ? (i - i % 32) * k + 32 * q + i % 32 : i * k + q;
                if (memcmp(panels + at * es, rows + (i * k + q) * es, es) != 0)
                    fail_msg("storage %d: entry (%zu, %zu) not at panel index %zu", storage, i,
                             q, at);
            }
        LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_PANELS));
        data = storage ? (const void *)op->fbar16 : (const void *)op->fbar;
        assert_memory_equal(data, panels, n * k * es);
        assert_int_equal(lrr_operator_set_layout(op, (lrr_layout)7), LRR_ERR_INVALID_ARG);
        lrr_context_last_error(ctx, NULL, 0);
        free(dec), free(dec_rows), free(panels), free(rows);
    }
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* B = E + rho ∘ (F̄ z) with z = M Vᵀ E, in double from the decoded rows: the reference for
 * the kernels (the product itself, not the physics) */
static void reference(const lrr_operator *op, const float *E, double *B)
{
    const size_t n = op->n, k = op->k, *first = lrr_operator_patch_offsets(op);
    double *w = calloc(3 * k, sizeof *w), *z = calloc(3 * k, sizeof *z);
    float *row = malloc(k * sizeof *row);
    for (size_t p = 0; p < k; p++)
        for (size_t i = first[p]; i < first[p + 1]; i++)
            for (int c = 0; c < 3; c++)
                w[c * k + p] += (double)op->weight[i] * E[3 * i + c];
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < k; p++)
            for (size_t q = 0; q < k; q++)
                z[c * k + p] += (double)op->m[(c * k + p) * k + q] * w[c * k + q];
    for (size_t i = 0; i < n; i++) {
        lrr_operator_fbar_row(op, i, row);
        for (int c = 0; c < 3; c++) {
            double t = 0;
            for (size_t q = 0; q < k; q++)
                t += (double)row[q] * z[c * k + q];
            B[3 * i + c] = E[3 * i + c] + op->rho[3 * i + c] * t;
        }
    }
    free(w), free(z), free(row);
}

/* Every SIMD variant, storage and layout against the double reference, at sizes with no
 * whole panel (n < 32), whole panels only (n = 32m) and panels with a tail. */
static void test_kernels(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    static const struct { size_t K; unsigned levels; } sizes[] = {{4, 1}, {8, 2}, {60, 1}};
    const char *variants[] = {"c", "avx2", "avx2+prefetch", "avx512", "avx512+prefetch"};
    int tested = 0, tail_seen = 0, whole_seen = 0;
    for (size_t sz = 0; sz < sizeof sizes / sizeof sizes[0]; sz++) {
        lrr_operator *op = cornell_op(ctx, sizes[sz].K, sizes[sz].levels);
        const size_t n = op->n;
        tail_seen |= n > LRR__PANEL && n % LRR__PANEL != 0;
        whole_seen |= n % LRR__PANEL == 0;
        float *E = malloc(3 * n * sizeof *E), *b = malloc(3 * n * sizeof *b);
        double *ref = malloc(3 * n * sizeof *ref);
        for (size_t j = 0; j < 3 * n; j++)
            E[j] = op->emission[j] + (float)((j * 2654435761u) % 1000) * 1e-3f;
        for (int storage = 0; storage < 3; storage++) {
            LRR_CHECK(ctx, lrr_operator_set_storage(op, (lrr_storage)storage));
            reference(op, E, ref);
            for (int layout = 0; layout < 2; layout++) {
                LRR_CHECK(ctx, lrr_operator_set_layout(op, (lrr_layout)layout));
                for (int v = 0; v < 5; v++) {
                    setenv("LRR_SIMD", variants[v], 1);
                    lrr_solver *sv;
                    lrr_status st = lrr_solver_create(op, LRR_BACKEND_CPU, &sv);
                    unsetenv("LRR_SIMD");
                    if (st == LRR_ERR_UNSUPPORTED) {
                        lrr_context_last_error(ctx, NULL, 0);
                        continue;
                    }
                    LRR_CHECK(ctx, st);
                    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
                    LRR_CHECK(ctx, lrr_solve(sv, E, b));
                    double num = 0, den = 0;
                    for (size_t j = 0; j < 3 * n; j++) {
                        num = fmax(num, fabs(b[j] - ref[j]));
                        den = fmax(den, fabs(ref[j]));
                    }
                    if (!(num <= 1e-5 * den))
                        fail_msg("n = %zu, %s, %s, %s: max |dB| / max |B| = %.2e", n,
                                 lrr_storage_name((lrr_storage)storage),
                                 layout ? "rows" : "panels", variants[v], num / den);
                    tested++;
                    lrr_solver_destroy(sv);
                }
            }
        }
        free(E), free(b), free(ref);
        lrr_operator_destroy(op);
    }
    assert_true(tail_seen && whole_seen);
    assert_true(tested >= 3 * 3 * 2); /* at least the portable variant everywhere */
    lrr_context_destroy(ctx);
}

static unsigned char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    *len = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(*len);
    assert_int_equal(fread(b, 1, *len, f), *len);
    fclose(f);
    return b;
}

/* A file holds rows: the same bytes whether the operator was saved from panels or rows, and
 * loading gives panels with the same entries. */
static void test_file_rows(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 50, 1);
    char pa[256], pb[256];
    tu_tmp_path(pa, sizeof pa, "layout_panels.lrr");
    tu_tmp_path(pb, sizeof pb, "layout_rows.lrr");
    for (int storage = 0; storage < 2; storage++) {
        LRR_CHECK(ctx, lrr_operator_set_storage(op, (lrr_storage)storage));
        LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_PANELS));
        LRR_CHECK(ctx, lrr_operator_save(op, pa));
        LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS));
        LRR_CHECK(ctx, lrr_operator_save(op, pb));
        size_t la, lb;
        unsigned char *a = read_all(pa, &la), *b = read_all(pb, &lb);
        assert_int_equal(la, lb);
        assert_memory_equal(a, b, la);
        free(a), free(b);
        lrr_operator *back;
        LRR_CHECK(ctx, lrr_operator_load(ctx, pa, &back));
        lrr_operator_info info;
        lrr_operator_get_info(back, &info, sizeof info);
        assert_int_equal(info.layout, LRR_LAYOUT_PANELS);
        float *x = all_rows(op), *y = all_rows(back);
        assert_memory_equal(x, y, op->n * op->k * sizeof *x);
        free(x), free(y);
        lrr_operator_destroy(back);
    }
    unlink(pa), unlink(pb);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* A batch large enough for sgemm reaches it through rows copied out of the panels, in
 * several chunks, and gives the per-frame answers. */
static void test_batch_panels(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 300, 1);
    const size_t n = op->n, frames = 3;
    print_message("n = %zu\n", n);
    assert_true(n > 1024 && n % LRR__PANEL != 0);
    float *E = malloc(frames * 3 * n * sizeof *E), *b = malloc(frames * 3 * n * sizeof *b),
          *one = malloc(3 * n * sizeof *one);
    for (size_t j = 0; j < frames * 3 * n; j++)
        E[j] = op->emission[j % (3 * n)] * (float)(1 + j / (3 * n)) + 1e-3f * (float)(j % 7);
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
    lrr__solver_batch_thresholds(sv, 1, 0);
    LRR_CHECK(ctx, lrr_solve_batch(sv, frames, E, b));
    lrr__solver_batch_thresholds(sv, SIZE_MAX, SIZE_MAX);
    for (size_t f = 0; f < frames; f++) {
        LRR_CHECK(ctx, lrr_solve(sv, E + f * 3 * n, one));
        double num = 0, den = 0;
        for (size_t j = 0; j < 3 * n; j++) {
            num = fmax(num, fabs((double)b[f * 3 * n + j] - one[j]));
            den = fmax(den, fabs((double)one[j]));
        }
        print_message("frame %zu: sgemm through panel rows vs fused: %.2e\n", f, num / den);
        assert_true(num <= 1e-5 * den);
    }
    lrr_solver_destroy(sv);
    free(E), free(b), free(one);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_round_trip),
        cmocka_unit_test(test_kernels),
        cmocka_unit_test(test_file_rows),
        cmocka_unit_test(test_batch_panels),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
