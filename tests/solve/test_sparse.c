/* Sparse F̄ (lib/solve/sparse.c): the solver reads only the strips that hold a nonzero and
 * gives the dense pass's B up to the order of the sums, on every kernel, storage and path. */
#include "testutil.h"
#include "core/internal.h" /* lrr__context_fail_after */
#include "solve/solve.h"

static const char *const simd[] = {"c", "avx2", "avx512"};

/* B with F̄ read in `format` on the full path. */
static void solve_as(lrr_context *ctx, const lrr_operator *op, lrr_fbar_format format,
                     const float *E, float *B, lrr_solver_info *info)
{
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solver_set_fbar(sv, format));
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
    LRR_CHECK(ctx, lrr_solve(sv, E, B));
    if (info)
        lrr_solver_get_info(sv, info, sizeof *info);
    lrr_solver_destroy(sv);
}

/* The counts lrr_solver_get_info reports are F̄'s own: nonzeros and strips counted here from
 * lrr_operator_fbar_row, and the bytes a frame reads follow from them exactly. */
static void check_counts(const lrr_operator *op, const lrr_solver_info *info)
{
    const size_t n = op->n, k = op->k, tiles = (n + LRR__TILE - 1) / LRR__TILE;
    float *row = malloc(k * sizeof *row);
    unsigned char *any = calloc(k, 1);
    size_t nonzeros = 0, strips = 0;
    for (size_t i = 0; i < n; i++) {
        lrr_operator_fbar_row(op, i, row);
        for (size_t q = 0; q < k; q++)
            if (row[q] != 0) {
                nonzeros++;
                any[q] = 1;
            }
        if ((i + 1) % LRR__TILE == 0 || i + 1 == n)
            for (size_t q = 0; q < k; q++) {
                strips += any[q];
                any[q] = 0;
            }
    }
    assert_true(info->fbar_density == (double)nonzeros / ((double)n * (double)k));
    assert_true(info->fbar_strip_density ==
                (double)strips * LRR__TILE / ((double)n * (double)k));
    const size_t elem = op->storage == LRR_STORAGE_F32 ? 4 : 2;
    assert_int_equal(info->fbar_dense_bytes, n * k * elem);
    if (info->fbar == LRR_FBAR_SPARSE)
        assert_int_equal(info->fbar_bytes,
                         strips * (LRR__TILE * elem + 2) + (tiles + 1) * sizeof(size_t));
    else
        assert_int_equal(info->fbar_bytes, n * k * elem);
    /* M − I in binary16 exactly when F̄ is 16-bit (lrr_solver_set_m) */
    assert_int_equal(info->m, elem == 4 ? LRR_STORAGE_F32 : LRR_STORAGE_F16);
    assert_int_equal(info->m_bytes, elem == 4 ? 3 * k * k * sizeof(float)
                                              : 3 * k * k * 2 + 3 * k * sizeof(float));
    free(row);
    free(any);
}

/* Rooms that do not see each other: AUTO reads F̄ sparse, the dark rooms' B is exactly 0 on
 * both passes (no product of theirs is skipped or added), and the lit room's B is the dense
 * pass's to the rounding of sums of k nonnegative terms in another order (2·k·ε). */
static void test_rooms(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = tu_rooms_op(ctx, 96);
    const size_t n = op->n, k = op->k;
    float *dense = malloc(3 * n * sizeof(float)), *sparse = malloc(3 * n * sizeof(float));
    for (lrr_storage st = LRR_STORAGE_F32; st <= LRR_STORAGE_BF16; st++) {
        LRR_CHECK(ctx, lrr_operator_set_storage(op, st));
        lrr_solver *sv;
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
        lrr_solver_info auto_info;
        lrr_solver_get_info(sv, &auto_info, sizeof auto_info);
        lrr_solver_destroy(sv);
        lrr_solver_info di, si;
        solve_as(ctx, op, LRR_FBAR_DENSE, op->emission, dense, &di);
        solve_as(ctx, op, LRR_FBAR_SPARSE, op->emission, sparse, &si);
        print_message("%s: n %zu k %zu density %.3f strips %.3f, bytes %zu of %zu\n",
                      lrr_storage_name(st), n, k, si.fbar_density, si.fbar_strip_density,
                      si.fbar_bytes, si.fbar_dense_bytes);
        assert_int_equal(auto_info.fbar, LRR_FBAR_SPARSE);
        assert_int_equal(di.fbar, LRR_FBAR_DENSE);
        assert_int_equal(si.fbar, LRR_FBAR_SPARSE);
        assert_true(si.fbar_density <= 0.25);
        assert_true(si.fbar_bytes <= si.fbar_dense_bytes / 2);
        check_counts(op, &di);
        check_counts(op, &si);
        size_t lit = 0;
        for (size_t i = 0; i < n; i++) {
            const float *c = op->centre + 3 * i;
            if (c[0] > 1.25f) /* rooms 1..3 */
                for (int ch = 0; ch < 3; ch++) {
                    assert_true(dense[3 * i + ch] == 0.0f);
                    assert_true(sparse[3 * i + ch] == 0.0f);
                }
            else
                lit++;
        }
        assert_true(lit > 0 && lit < n);
        const double e = tu_max_rel(3 * n, sparse, dense);
        print_message("  sparse vs dense: max relative difference %.2e\n", e);
        assert_true(e <= TU_TOL_FLT(2, k));
    }
    free(dense);
    free(sparse);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Every kernel this CPU runs (LRR_SIMD), every storage, both layouts: sparse and dense give
 * the same B on the Cornell box, whose F̄ has zeros (a wall's patches do not see each other;
 * the blocks hide parts of the room) but is too dense for AUTO to choose sparse. The strips
 * are copied from panels or from rows (lrr_operator_set_layout) alike. */
static void test_kernels(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = tu_cornell_op(ctx, 216, 1, 32, 2);
    const size_t n = op->n, k = op->k;
    float *dense = malloc(3 * n * sizeof(float)), *sparse = malloc(3 * n * sizeof(float));
    for (int cell = 0; cell < 6; cell++) {
        const lrr_storage st = (lrr_storage)(cell % 3);
        const lrr_layout layout = cell < 3 ? LRR_LAYOUT_PANELS : LRR_LAYOUT_ROWS;
        LRR_CHECK(ctx, lrr_operator_set_storage(op, st));
        LRR_CHECK(ctx, lrr_operator_set_layout(op, layout));
        for (size_t v = 0; v < sizeof simd / sizeof simd[0]; v++) {
            setenv("LRR_SIMD", simd[v], 1);
            lrr_solver *sv;
            lrr_status s = lrr_solver_create(op, LRR_BACKEND_CPU, &sv);
            if (s == LRR_ERR_UNSUPPORTED) {
                print_message("LRR_SIMD=%s: not on this CPU\n", simd[v]);
                lrr_context_last_error(ctx, NULL, 0);
                continue;
            }
            LRR_CHECK(ctx, s);
            lrr_solver_info ai;
            lrr_solver_get_info(sv, &ai, sizeof ai);
            assert_int_equal(ai.fbar, LRR_FBAR_DENSE);
            lrr_solver_destroy(sv);
            lrr_solver_info si;
            solve_as(ctx, op, LRR_FBAR_DENSE, op->emission, dense, NULL);
            solve_as(ctx, op, LRR_FBAR_SPARSE, op->emission, sparse, &si);
            check_counts(op, &si);
            assert_true(si.fbar_density < 1.0);
            const double e = tu_max_rel(3 * n, sparse, dense);
            print_message("%s %s %s: density %.3f, max relative difference %.2e\n",
                          lrr_storage_name(st), layout ? "rows" : "panels", simd[v],
                          si.fbar_density, e);
            assert_true(e <= TU_TOL_FLT(2, k));
        }
    }
    unsetenv("LRR_SIMD");
    free(dense);
    free(sparse);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The column paths, the incremental path and batches read the sparse F̄ too, and agree
 * with a dense full pass. */
static void test_paths(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = tu_rooms_op(ctx, 96);
    const size_t n = op->n, k = op->k, count = 5;
    float *E = malloc(count * 3 * n * sizeof *E), *B = malloc(count * 3 * n * sizeof *B),
          *ref = malloc(3 * n * sizeof *ref);
    for (size_t f = 0; f < count; f++)
        for (size_t j = 0; j < 3 * n; j++)
            E[3 * n * f + j] = op->emission[j] * (float)(f + 1) + (j % 7 == f ? 0.25f : 0.0f);
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solver_set_fbar(sv, LRR_FBAR_SPARSE));
    /* the default cache is a quarter of the few bytes the sparse F̄ holds: room for columns */
    LRR_CHECK(ctx, lrr_solver_set_cache(sv, 64 * 3 * n * sizeof(float)));
    static const lrr_path paths[] = {LRR_PATH_SPARSE, LRR_PATH_INCREMENTAL};
    for (int p = 0; p < 2; p++) {
        LRR_CHECK(ctx, lrr_solver_set_path(sv, paths[p]));
        for (size_t f = 0; f < 2; f++) {
            LRR_CHECK(ctx, lrr_solve(sv, op->emission, B));
            solve_as(ctx, op, LRR_FBAR_DENSE, op->emission, ref, NULL);
            print_message("path %d frame %zu (took %d): %.2e\n", (int)paths[p], f,
                          (int)lrr_solver_last_path(sv), tu_max_rel(3 * n, B, ref));
            if (paths[p] == LRR_PATH_SPARSE || f > 0) /* the first incremental is full */
                assert_int_equal(lrr_solver_last_path(sv), paths[p]);
            assert_true(tu_max_rel(3 * n, B, ref) <= 1e-5); /* M's columns: float M, k terms */
        }
    }
    lrr__solver_batch_thresholds(sv, 2, 0); /* the batched pass even for this operator */
    LRR_CHECK(ctx, lrr_solve_batch(sv, count, E, B));
    for (size_t f = 0; f < count; f++) {
        solve_as(ctx, op, LRR_FBAR_DENSE, E + 3 * n * f, ref, NULL);
        assert_true(tu_max_rel(3 * n, B + 3 * n * f, ref) <= TU_TOL_FLT(2, k));
    }
    lrr_solver_destroy(sv);
    free(E), free(B), free(ref);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Names, bad values, what OpenCL refuses, and an allocation that fails while the sparse
 * copy is made: an error, and the solver goes on reading what it read before. */
static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    for (int f = 0; f < 3; f++) {
        lrr_fbar_format back;
        assert_int_equal(lrr_fbar_format_from_name(lrr_fbar_format_name((lrr_fbar_format)f),
                                                   &back),
                         LRR_OK);
        assert_int_equal(back, f);
    }
    assert_null(lrr_fbar_format_name((lrr_fbar_format)3));
    lrr_fbar_format back;
    assert_int_equal(lrr_fbar_format_from_name("csr", &back), LRR_ERR_INVALID_ARG);
    lrr_operator *op = tu_rooms_op(ctx, 24);
    const size_t n = op->n;
    float *b0 = malloc(3 * n * sizeof *b0), *b1 = malloc(3 * n * sizeof *b1);
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    assert_int_equal(lrr_solver_set_fbar(sv, (lrr_fbar_format)7), LRR_ERR_INVALID_ARG);
    LRR_CHECK(ctx, lrr_solver_set_fbar(sv, LRR_FBAR_DENSE));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, b0));
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
    lrr_solver_info info;
    unsigned long fail = 1;
    for (;; fail++) { /* each allocation of the sparse copy fails in turn */
        lrr__context_fail_after(ctx, fail);
        lrr_status s = lrr_solver_set_fbar(sv, LRR_FBAR_SPARSE);
        lrr__context_fail_after(ctx, 0);
        if (s == LRR_OK)
            break;
        assert_int_equal(s, LRR_ERR_NOMEM);
        lrr_solver_get_info(sv, &info, sizeof info);
        assert_int_equal(info.fbar, LRR_FBAR_DENSE);
        LRR_CHECK(ctx, lrr_solve(sv, op->emission, b1));
        assert_memory_equal(b0, b1, 3 * n * sizeof *b0);
    }
    print_message("sparse copy: allocations 1..%lu failed cleanly\n", fail - 1);
    assert_true(fail > 3);
    lrr_solver_get_info(sv, &info, sizeof info);
    assert_int_equal(info.fbar, LRR_FBAR_SPARSE);
    lrr_solver_destroy(sv);
    /* an OpenCL solver likewise: a failed sparse copy leaves F̄ dense on the device */
    lrr_solver *cl;
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_OPENCL, &cl);
    if (s == LRR_OK) {
        LRR_CHECK(ctx, lrr_solver_set_fbar(cl, LRR_FBAR_DENSE));
        LRR_CHECK(ctx, lrr_solve(cl, op->emission, b0));
        for (fail = 1;; fail++) {
            lrr__context_fail_after(ctx, fail);
            s = lrr_solver_set_fbar(cl, LRR_FBAR_SPARSE);
            lrr__context_fail_after(ctx, 0);
            if (s == LRR_OK)
                break;
            assert_int_equal(s, LRR_ERR_NOMEM);
            lrr_solver_get_info(cl, &info, sizeof info);
            assert_int_equal(info.fbar, LRR_FBAR_DENSE);
            LRR_CHECK(ctx, lrr_solve(cl, op->emission, b1));
            assert_memory_equal(b0, b1, 3 * n * sizeof *b0);
        }
        print_message("OpenCL sparse copy: allocations 1..%lu failed cleanly\n", fail - 1);
        assert_true(fail > 3);
        lrr_solver_get_info(cl, &info, sizeof info);
        assert_int_equal(info.fbar, LRR_FBAR_SPARSE);
        assert_true(info.fbar_bytes < info.fbar_dense_bytes);
        LRR_CHECK(ctx, lrr_solve(cl, op->emission, b1));
        assert_true(tu_max_rel(3 * n, b1, b0) <= 1e-5);
        lrr_solver_destroy(cl);
    } else {
        print_message("no OpenCL solver here (%s)\n", lrr_strerror(s));
    }
    free(b0), free(b1);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_rooms),
        cmocka_unit_test(test_kernels),
        cmocka_unit_test(test_paths),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
