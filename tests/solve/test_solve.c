/* The CPU solver's paths (lib/solve/cpu.c): full, sparse emitters, incremental, batches. */
#include "testutil.h"
#include "solve/solve.h"

static lrr_operator *cornell_op(lrr_context *ctx, size_t K, unsigned levels)
{
    return tu_cornell_op(ctx, K, levels, 32, 2);
}

/* A reference B computed on the full path by a second solver. */
/* The full path with M in f32, as the column paths and the batches read it (M − I in
 * binary16, what 16-bit operators get by default, has its own tests: test_m_f16.c). */
static void full_solve(lrr_context *ctx, const lrr_operator *op, const float *E, float *B)
{
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solver_set_m(sv, LRR_STORAGE_F32));
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
    LRR_CHECK(ctx, lrr_solve(sv, E, B));
    assert_int_equal(lrr_solver_last_path(sv), LRR_PATH_FULL);
    lrr_solver_destroy(sv);
}

/* The Cornell light covers a few of k = 216 patches: the automatic choice is the sparse
 * path, and it gives the full path's answer. */
static void test_sparse_emitters(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 216, 1);
    const size_t n = op->n;
    float *ref = malloc(3 * n * sizeof *ref), *b = malloc(3 * n * sizeof *b);
    full_solve(ctx, op, op->emission, ref);
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    for (int rep = 0; rep < 2; rep++) { /* the second frame reads cached columns only */
        LRR_CHECK(ctx, lrr_solve(sv, op->emission, b));
        /* the first frame is sparse; the repeat may be either column path (they cost the
         * same when two patches emit) but never a pass over F̄ */
        lrr_path path = lrr_solver_last_path(sv);
        if (rep == 0)
            assert_int_equal(path, LRR_PATH_SPARSE);
        else
            assert_true(path == LRR_PATH_SPARSE || path == LRR_PATH_INCREMENTAL);
        double e = tu_max_rel(3 * n, b, ref);
        print_message("frame %d (path %d): max relative difference to the full path %.2e\n",
                      rep, (int)path, e);
        assert_true(e <= 1e-5);
    }
    /* forced sparse, and an all-dark frame (no emitter: B = 0) */
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_SPARSE));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, b));
    assert_int_equal(lrr_solver_last_path(sv), LRR_PATH_SPARSE);
    assert_true(tu_max_rel(3 * n, b, ref) <= 1e-5);
    float *zero = calloc(3 * n, sizeof *zero);
    LRR_CHECK(ctx, lrr_solve(sv, zero, b));
    for (size_t j = 0; j < 3 * n; j++)
        assert_true(b[j] == 0.0f);
    /* without a cache only the full path remains (for an emission unlike the last one
     * kept: an unchanged frame needs no columns and is still incremental) */
    LRR_CHECK(ctx, lrr_solver_set_cache(sv, 0));
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_AUTO));
    float *twice = malloc(3 * n * sizeof *twice);
    for (size_t j = 0; j < 3 * n; j++)
        twice[j] = 2 * op->emission[j];
    LRR_CHECK(ctx, lrr_solve(sv, twice, b));
    assert_int_equal(lrr_solver_last_path(sv), LRR_PATH_FULL);
    for (size_t j = 0; j < 3 * n; j++)
        /* not rounding alone: the float solve amplifies it by the condition of I - rho F */
        ASSERT_NEAR(b[j], 2 * ref[j], 1e-5 * fabs(ref[j]) + 1e-6, "entry %zu\n", j);
    free(twice);
    assert_int_equal(lrr_solver_set_path(sv, (lrr_path)9), LRR_ERR_INVALID_ARG);
    free(zero);
    free(ref);
    free(b);
    lrr_solver_destroy(sv);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* An animation: a dim glow on every subpatch plus a light whose intensity changes each
 * frame, and now and then a wall that switches on. Most frames are incremental; every
 * frame matches a fresh full solve, also after more frames than the re-anchoring limit. */
static void test_incremental_animation(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 216, 1);
    const size_t n = op->n;
    float *E = malloc(3 * n * sizeof *E), *ref = malloc(3 * n * sizeof *ref),
          *b = malloc(3 * n * sizeof *b);
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    int counts[4] = {0, 0, 0, 0};
    double worst = 0;
    for (int f = 0; f < 150; f++) {
        double a = 1 + 0.5 * sin(0.1 * f);
        for (size_t j = 0; j < 3 * n; j++)
            E[j] = (float)(op->emission[j] * a) + 0.001f;
        if (f % 40 >= 20) /* the first 20 subpatches glow for a while */
            for (size_t j = 0; j < 60; j++)
                E[j] += 0.5f;
        LRR_CHECK(ctx, lrr_solve(sv, E, b));
        counts[lrr_solver_last_path(sv)]++;
        full_solve(ctx, op, E, ref);
        worst = fmax(worst, tu_max_rel(3 * n, b, ref));
    }
    print_message("150 frames: %d full, %d sparse, %d incremental; worst max relative "
                  "difference %.2e\n", counts[1], counts[2], counts[3], worst);
    assert_true(counts[LRR_PATH_INCREMENTAL] >= 100);
    assert_true(counts[LRR_PATH_FULL] >= 2); /* the first frame and the re-anchoring ones */
    assert_true(worst <= 1e-5);
    /* forcing incremental without a previous frame falls back to full */
    lrr_solver *fresh;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &fresh));
    LRR_CHECK(ctx, lrr_solver_set_path(fresh, LRR_PATH_INCREMENTAL));
    LRR_CHECK(ctx, lrr_solve(fresh, E, b));
    assert_int_equal(lrr_solver_last_path(fresh), LRR_PATH_FULL);
    for (size_t j = 0; j < 3 * n; j++) /* only the light changes */
        if (op->emission[j] > 0)
            E[j] *= 2;
    LRR_CHECK(ctx, lrr_solve(fresh, E, b));
    assert_int_equal(lrr_solver_last_path(fresh), LRR_PATH_INCREMENTAL);
    full_solve(ctx, op, E, ref);
    assert_true(tu_max_rel(3 * n, b, ref) <= 1e-5);
    lrr_solver_destroy(fresh);
    free(E), free(ref), free(b);
    lrr_solver_destroy(sv);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Batches equal frame-by-frame solves (sgemm for float storage, a loop for 16-bit). */
static void test_batch(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 37, 1);
    const size_t n = op->n, count = 7;
    float *E = malloc(count * 3 * n * sizeof *E), *B = malloc(count * 3 * n * sizeof *B),
          *ref = malloc(3 * n * sizeof *ref);
    uint64_t x = 5;
    for (size_t j = 0; j < count * 3 * n; j++) {
        x = x * 6364136223846793005ull + 1442695040888963407ull;
        E[j] = (x >> 40) % 5 == 0 ? (float)((x >> 20) % 1000) / 100.0f : 0.0f;
    }
    for (int storage = 0; storage < 2; storage++) {
        if (storage)
            LRR_CHECK(ctx, lrr_operator_set_storage(op, LRR_STORAGE_F16));
        lrr_solver *sv;
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
        lrr__solver_batch_thresholds(sv, 2, 0); /* sgemm even for this small operator */
        LRR_CHECK(ctx, lrr_solve_batch(sv, count, E, B));
        double worst = 0;
        for (size_t f = 0; f < count; f++) {
            full_solve(ctx, op, E + f * 3 * n, ref);
            worst = fmax(worst, tu_max_rel(3 * n, B + f * 3 * n, ref));
        }
        print_message("batch of %zu (%s): worst max relative difference %.2e\n", count,
                      storage ? "f16, frame by frame" : "f32, sgemm", worst);
        if (!storage) { /* and the default thresholds: a loop of single frames here */
            lrr_solver *plain;
            LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &plain));
            float *B2 = malloc(count * 3 * n * sizeof *B2);
            LRR_CHECK(ctx, lrr_solve_batch(plain, count, E, B2));
            assert_true(tu_max_rel(count * 3 * n, B2, B) <= 1e-5);
            free(B2);
            lrr_solver_destroy(plain);
        }
        assert_true(worst <= 1e-5);
        LRR_CHECK(ctx, lrr_solve_batch(sv, 0, E, B));
        /* a bad value is reported with its frame */
        float keep = E[3 * 3 * n + 7];
        E[3 * 3 * n + 7] = -1;
        B[0] = -42;
        assert_int_equal(lrr_solve_batch(sv, count, E, B), LRR_ERR_INVALID_ARG);
        assert_true(B[0] == -42); /* nothing written */
        char msg[256];
        lrr_context_last_error(ctx, msg, sizeof msg);
        if (!strstr(msg, "frame 3"))
            fail_msg("message does not name the frame: %s", msg);
        E[3 * 3 * n + 7] = keep;
        assert_int_equal(lrr_solve_batch(sv, 2, E, E + 3 * n), LRR_ERR_INVALID_ARG);
        lrr_context_last_error(ctx, NULL, 0);
        lrr_solver_destroy(sv);
    }
    free(E), free(B), free(ref);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Black subpatches (rho = 0) skip their rows: B = E there, the rest unchanged. */
static void test_black_rows(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 40, 3);
    const size_t n = op->n;
    float *rho = malloc(3 * n * sizeof *rho), *E = malloc(3 * n * sizeof *E),
          *b = malloc(3 * n * sizeof *b);
    memcpy(rho, op->rho, 3 * n * sizeof *rho);
    for (size_t j = 0; j < 3 * 200; j++) /* subpatches 0..199: whole blocks of 64 and a part */
        rho[j] = 0;
    LRR_CHECK(ctx, lrr_operator_set_reflectance(op, rho));
    for (size_t j = 0; j < 3 * n; j++)
        E[j] = op->emission[j] + 0.01f;
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
    LRR_CHECK(ctx, lrr_solve(sv, E, b));
    for (size_t j = 0; j < 3 * 200; j++)
        assert_true(b[j] == E[j]);
    setenv("LRR_SIMD", "c", 1);
    lrr_solver *plain;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &plain));
    unsetenv("LRR_SIMD");
    float *ref = malloc(3 * n * sizeof *ref);
    LRR_CHECK(ctx, lrr_solver_set_path(plain, LRR_PATH_FULL));
    LRR_CHECK(ctx, lrr_solve(plain, E, ref));
    assert_true(tu_max_rel(3 * n, b, ref) <= 1e-5);
    lrr_solver_destroy(plain);
    free(rho), free(E), free(b), free(ref);
    lrr_solver_destroy(sv);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Tiny operators: one triangle (n = k = 1: it cannot see itself, so B = E) and two facing
 * triangles (k = 2); every path, storage and batch gives the full path's answer. */
static void test_tiny(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const float v[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0,      /* facing +z */
                         0, 0, 0.5f, 0, 1, 0.5f, 1, 0, 0.5f}; /* above it, facing -z */
    const float rho[6] = {0.5f, 0.6f, 0.7f, 0.8f, 0.2f, 0.4f};
    const float em[6] = {1, 2, 3, 0, 0, 0};
    for (size_t tris = 1; tris <= 2; tris++)
        for (unsigned levels = 0; levels <= 1; levels++) {
            lrr_scene *s;
            LRR_CHECK(ctx, lrr_scene_create(ctx, tris, v, rho, em, "tiny", &s));
            lrr_subdivision sd = {.max_patch_area = 1e9, .levels = levels};
            LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
            lrr_build_options o = {.hemicube_resolution = 16, .seed = 1};
            lrr_operator *op;
            LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
            lrr_scene_destroy(s);
            const size_t n = op->n;
            assert_int_equal(op->k, tris);
            float *ref = malloc(3 * n * sizeof *ref), *b = malloc(6 * n * sizeof *b),
                  *e2 = malloc(6 * n * sizeof *e2);
            full_solve(ctx, op, op->emission, ref);
            if (tris == 1)
                for (size_t j = 0; j < 3 * n; j++)
                    assert_true(ref[j] == op->emission[j]);
            else
                assert_true(ref[3 * (n - 1)] > 0); /* the upper triangle receives light */
            for (int storage = 0; storage < 3; storage++) {
                LRR_CHECK(ctx, lrr_operator_set_storage(op, (lrr_storage)storage));
                /* the storage's precision: float, binary16 (2^-11), bfloat16 (2^-8), times
                 * the solve's amplification */
                const double tol = storage == 0 ? 1e-6 : storage == 1 ? 1e-3 : 1e-2;
                for (int path = LRR_PATH_AUTO; path <= LRR_PATH_INCREMENTAL; path++) {
                    lrr_solver *sv;
                    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
                    LRR_CHECK(ctx, lrr_solver_set_path(sv, (lrr_path)path));
                    for (int f = 0; f < 2; f++) { /* the second frame can be incremental */
                        LRR_CHECK(ctx, lrr_solve(sv, op->emission, b));
                        assert_true(tu_max_rel(3 * n, b, ref) <= tol);
                    }
                    memcpy(e2, op->emission, 3 * n * sizeof *e2);
                    memcpy(e2 + 3 * n, op->emission, 3 * n * sizeof *e2);
                    LRR_CHECK(ctx, lrr_solve_batch(sv, 2, e2, b));
                    assert_true(tu_max_rel(3 * n, b, ref) <= tol);
                    assert_true(tu_max_rel(3 * n, b + 3 * n, ref) <= tol);
                    lrr_solver_destroy(sv);
                }
            }
            free(ref), free(b), free(e2);
            lrr_operator_destroy(op);
        }
    lrr_context_destroy(ctx);
}

/* Every entry of the emission checked where the sums read it (cpu.c's segment_sum: four
 * subpatches a step and a scalar tail, so d = 1 and d = 16 between them cover both): a
 * negative value however small, NaN of either sign and ±∞ are refused naming the subpatch
 * and the channel, and B is left as it was; −0 is accepted and lights nothing. */
static void test_emission_check(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const float bad[] = {-1e-30f, -1.0f, NAN, -NAN, INFINITY, -INFINITY};
    for (unsigned levels = 0; levels <= 2; levels += 2) {
        lrr_operator *op = cornell_op(ctx, 36, levels);
        const size_t n = op->n;
        float *E = malloc(3 * n * sizeof *E), *B = malloc(3 * n * sizeof *B),
              *ref = malloc(3 * n * sizeof *ref);
        for (size_t j = 0; j < 3 * n; j++)
            E[j] = op->emission[j] + 0.01f * (float)(j % 7);
        lrr_solver *sv;
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
        LRR_CHECK(ctx, lrr_solver_set_path(sv, LRR_PATH_FULL));
        for (size_t j = 0; j < 3 * n; j++) {
            const float keep = E[j];
            for (size_t v = 0; v < sizeof bad / sizeof bad[0]; v++) {
                E[j] = bad[v];
                for (size_t i = 0; i < 3 * n; i++)
                    B[i] = -7.0f;
                assert_int_equal(lrr_solve(sv, E, B), LRR_ERR_INVALID_ARG);
                char msg[256], want[64];
                lrr_context_last_error(ctx, msg, sizeof msg);
                snprintf(want, sizeof want, "subpatch %zu, channel %zu =", j / 3, j % 3);
                assert_non_null(strstr(msg, want));
                for (size_t i = 0; i < 3 * n; i++)
                    assert_true(B[i] == -7.0f);
            }
            E[j] = 0.0f;
            LRR_CHECK(ctx, lrr_solve(sv, E, ref));
            E[j] = -0.0f;
            LRR_CHECK(ctx, lrr_solve(sv, E, B));
            for (size_t i = 0; i < 3 * n; i++)
                assert_true(B[i] == ref[i] || (i == j && B[i] == 0.0f));
            E[j] = keep;
        }
        lrr_solver_destroy(sv);
        free(E), free(B), free(ref);
        lrr_operator_destroy(op);
    }
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sparse_emitters),
        cmocka_unit_test(test_incremental_animation),
        cmocka_unit_test(test_batch),
        cmocka_unit_test(test_black_rows),
        cmocka_unit_test(test_tiny),
        cmocka_unit_test(test_emission_check),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
