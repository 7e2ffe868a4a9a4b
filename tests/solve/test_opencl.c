/* The OpenCL solver (lib/solve/opencl.c) against the CPU solver on the same operator.
 * Skips (exit 77) when the library has no OpenCL or the machine no OpenCL platform. */
#include "testutil.h"
#include "solve/solve.h"

static lrr_operator *cornell_op(lrr_context *ctx, size_t K, unsigned levels)
{
    return tu_cornell_op(ctx, K, levels, 32, 2);
}

/* One emitting triangle facing nothing: F̄ = 0, B = E (k = 1, n = d). */
static lrr_operator *triangle_op(lrr_context *ctx, unsigned levels)
{
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, rho[3] = {0.5f, 0.4f, 0.3f},
                e[3] = {1, 2, 3};
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, 1, v, rho, e, "triangle", &s));
    lrr_subdivision sd = {.levels = levels};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, NULL, &op));
    lrr_scene_destroy(s);
    return op;
}

/* An emission with every patch lit differently, so every term of F̄ matters. */
static float *test_emission(const lrr_operator *op)
{
    float *e = malloc(3 * op->n * sizeof *e);
    assert_non_null(e);
    for (size_t j = 0; j < 3 * op->n; j++)
        e[j] = op->emission[j] + (float)((j * 2654435761u) % 1000) * 1e-3f;
    return e;
}

/* OpenCL (both product kernels) against the CPU solver's full path, in each storage. */
static void compare_op(lrr_context *ctx, lrr_operator *op, const char *what)
{
    static const lrr_storage storages[] = {LRR_STORAGE_F32, LRR_STORAGE_F16, LRR_STORAGE_BF16};
    const size_t n = op->n;
    float *e = test_emission(op);
    float *ref = malloc(3 * n * sizeof *ref), *b = malloc(3 * n * sizeof *b);
    float *batch = malloc(2 * 3 * n * sizeof *batch), *e2 = malloc(2 * 3 * n * sizeof *e2);
    assert_true(ref && b && batch && e2);
    memcpy(e2, e, 3 * n * sizeof *e);
    memcpy(e2 + 3 * n, op->emission, 3 * n * sizeof *e);
    for (int sl = 0; sl < 6; sl++) { /* every storage, F̄ in panels and in rows */
        const int si = sl % 3;
        LRR_CHECK(ctx, lrr_operator_set_storage(op, storages[si]));
        LRR_CHECK(ctx, lrr_operator_set_layout(op, sl < 3 ? LRR_LAYOUT_PANELS : LRR_LAYOUT_ROWS));
        lrr_solver *cpu, *cl;
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &cpu));
        LRR_CHECK(ctx, lrr_solver_set_m(cpu, LRR_STORAGE_F32)); /* as the device reads M */
        LRR_CHECK(ctx, lrr_solver_set_path(cpu, LRR_PATH_FULL));
        LRR_CHECK(ctx, lrr_solve(cpu, e, ref));
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_OPENCL, &cl));
        assert_int_equal(strncmp(lrr_solver_kernel(cl), "opencl:", 7), 0);
        /* the device reads M in f32 only */
        assert_int_equal(lrr_solver_set_m(cl, LRR_STORAGE_F16), LRR_ERR_UNSUPPORTED);
        lrr_context_last_error(ctx, NULL, 0);
        LRR_CHECK(ctx, lrr_solver_set_m(cl, LRR_STORAGE_F32));
        LRR_CHECK(ctx, lrr_solver_set_fbar(cl, LRR_FBAR_DENSE));
        /* F̄ on the device as the operator's panels (what GPUs get) and as rows (CPU
         * devices), each through both product kernels */
        for (int up = 0; up < 4; up++) {
            const int panels = up >> 1, groups = up & 1;
            if ((up & 1) == 0)
                LRR_CHECK(ctx, lrr__solver_opencl_panels(cl, panels));
            lrr__solver_opencl_groups(cl, groups);
            memset(b, 0xff, 3 * n * sizeof *b);
            LRR_CHECK(ctx, lrr_solve(cl, e, b));
            assert_int_equal(lrr_solver_last_path(cl), LRR_PATH_FULL);
            double r = tu_max_rel(3 * n, b, ref);
            print_message("%s, %s %s (device: %s), %s kernel (%s): max |dB| / max |B| = %.2e\n",
                          what, lrr_storage_name(storages[si]), sl < 3 ? "panels" : "rows",
                          panels && sl < 3 ? "panels" : "rows", groups ? "group" : "row",
                          lrr_solver_kernel(cl), r);
            assert_true(r <= 1e-5);
        }
        /* a batch loops frames; the second frame is the stored emission */
        LRR_CHECK(ctx, lrr_solve_batch(cl, 2, e2, batch));
        assert_true(tu_max_rel(3 * n, batch, ref) <= 1e-5);
        LRR_CHECK(ctx, lrr_solve(cpu, op->emission, ref));
        assert_true(tu_max_rel(3 * n, batch + 3 * n, ref) <= 1e-5);
        lrr_solver_destroy(cl);
        lrr_solver_destroy(cpu);
    }
    free(e2);
    free(batch);
    free(b);
    free(ref);
    free(e);
}

/* Sparse F̄ on the device (fbar_strips) against the CPU's dense pass: every storage and
 * layout, 1 to 8 strip groups (LRR_OPENCL_STRIP_GROUPS), both smw kernels; AUTO chooses as
 * the CPU solver does; DENSE goes back to the dense kernels. */
static void compare_sparse(lrr_context *ctx, lrr_operator *op, const char *what)
{
    static const lrr_storage storages[] = {LRR_STORAGE_F32, LRR_STORAGE_F16, LRR_STORAGE_BF16};
    const size_t n = op->n;
    float *e = test_emission(op);
    float *ref = malloc(3 * n * sizeof *ref), *b = malloc(3 * n * sizeof *b);
    assert_true(ref && b);
    for (int sl = 0; sl < 6; sl++) {
        LRR_CHECK(ctx, lrr_operator_set_storage(op, storages[sl % 3]));
        LRR_CHECK(ctx, lrr_operator_set_layout(op, sl < 3 ? LRR_LAYOUT_PANELS : LRR_LAYOUT_ROWS));
        lrr_solver *cpu, *cl;
        lrr_solver_info ci, gi;
        LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &cpu));
        LRR_CHECK(ctx, lrr_solver_set_m(cpu, LRR_STORAGE_F32)); /* as the device reads M */
        lrr_solver_get_info(cpu, &ci, sizeof ci);
        LRR_CHECK(ctx, lrr_solver_set_fbar(cpu, LRR_FBAR_DENSE));
        LRR_CHECK(ctx, lrr_solver_set_path(cpu, LRR_PATH_FULL));
        LRR_CHECK(ctx, lrr_solve(cpu, e, ref));
        for (unsigned sg = 1; sg <= 8; sg *= 2) {
            char env[8];
            snprintf(env, sizeof env, "%u", sg);
            setenv("LRR_OPENCL_STRIP_GROUPS", env, 1);
            LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_OPENCL, &cl));
            unsetenv("LRR_OPENCL_STRIP_GROUPS");
            lrr_solver_get_info(cl, &gi, sizeof gi);
            assert_int_equal(gi.fbar, ci.fbar); /* AUTO: the CPU's choice */
            assert_true(gi.fbar_density == ci.fbar_density);
            LRR_CHECK(ctx, lrr_solver_set_fbar(cl, LRR_FBAR_SPARSE));
            lrr_solver_get_info(cl, &gi, sizeof gi);
            assert_int_equal(gi.fbar, LRR_FBAR_SPARSE);
            lrr__solver_opencl_groups(cl, sg & 1); /* both smw kernels */
            memset(b, 0xff, 3 * n * sizeof *b);
            LRR_CHECK(ctx, lrr_solve(cl, e, b));
            const double r = tu_max_rel(3 * n, b, ref);
            print_message("%s, %s %s, sparse on the device (%.1f%% of dense bytes), %u strip "
                          "groups: max |dB| / max |B| = %.2e\n",
                          what, lrr_storage_name(storages[sl % 3]), sl < 3 ? "panels" : "rows",
                          100.0 * (double)gi.fbar_bytes / (double)gi.fbar_dense_bytes, sg, r);
            assert_true(r <= 1e-5);
            if (sg == 8) { /* and back to dense */
                LRR_CHECK(ctx, lrr_solver_set_fbar(cl, LRR_FBAR_DENSE));
                lrr_solver_get_info(cl, &gi, sizeof gi);
                assert_int_equal(gi.fbar, LRR_FBAR_DENSE);
                assert_int_equal(gi.fbar_bytes, gi.fbar_dense_bytes);
                memset(b, 0xff, 3 * n * sizeof *b);
                LRR_CHECK(ctx, lrr_solve(cl, e, b));
                assert_true(tu_max_rel(3 * n, b, ref) <= 1e-5);
            }
            lrr_solver_destroy(cl);
        }
        lrr_solver_destroy(cpu);
    }
    free(b);
    free(ref);
    free(e);
}

static void test_sparse(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = tu_rooms_op(ctx, 96); /* n not a multiple of 16: a partial tile */
    compare_sparse(ctx, op, "four rooms");
    lrr_operator_destroy(op);
    op = triangle_op(ctx, 1); /* F̄ = 0: no strips at all */
    compare_sparse(ctx, op, "one triangle");
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void test_odd_sizes(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    for (unsigned levels = 1; levels <= 2; levels++) {
        lrr_operator *op = cornell_op(ctx, 37, levels);
        compare_op(ctx, op, levels == 1 ? "Cornell 37 patches, levels 1"
                                        : "Cornell 37 patches, levels 2");
        lrr_operator_destroy(op);
    }
    lrr_operator *op = triangle_op(ctx, 1);
    compare_op(ctx, op, "one triangle");
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void test_cornell_216(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 216, 1);
    assert_int_equal(op->k, 216);
    compare_op(ctx, op, "Cornell k = 216");
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = triangle_op(ctx, 1);
    char msg[512];
    lrr_solver *cl = NULL;

    setenv("LRR_OPENCL_DEVICE", "no-such-device", 1);
    assert_int_equal(lrr_solver_create(op, LRR_BACKEND_OPENCL, &cl), LRR_ERR_UNSUPPORTED);
    unsetenv("LRR_OPENCL_DEVICE");
    assert_null(cl);
    lrr_context_last_error(ctx, msg, sizeof msg);
    print_message("%s\n", msg);
    assert_non_null(strstr(msg, "LRR_OPENCL_DEVICE"));
    assert_non_null(strstr(msg, "no-such-device"));

    /* by index 0:0 is always there when a platform is */
    setenv("LRR_OPENCL_DEVICE", "0:0", 1);
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_OPENCL, &cl));
    unsetenv("LRR_OPENCL_DEVICE");
    assert_int_equal(lrr_solver_set_path(cl, LRR_PATH_SPARSE), LRR_ERR_UNSUPPORTED);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "full path only"));
    LRR_CHECK(ctx, lrr_solver_set_path(cl, LRR_PATH_AUTO));

    /* NaN in E: the CPU solver's message, before anything goes to the device */
    const size_t n = op->n;
    float *e = calloc(3 * n, sizeof *e), *b = calloc(3 * n, sizeof *b);
    assert_true(e && b);
    e[3 * 2 + 1] = NAN;
    assert_int_equal(lrr_solve(cl, e, b), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    print_message("%s\n", msg);
    assert_non_null(strstr(msg, "subpatch 2, channel 1"));
    char cpu_msg[512];
    lrr_solver *cpu;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &cpu));
    assert_int_equal(lrr_solve(cpu, e, b), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, cpu_msg, sizeof cpu_msg);
    assert_string_equal(msg, cpu_msg);
    lrr_solver_destroy(cpu);
    lrr_solver_destroy(cl);
    free(b);
    free(e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* lrr_solver_timings: device kernel and transfer times of the last frame, within its wall
 * time; a CPU solver has none. */
static void test_timings(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = cornell_op(ctx, 216, 1);
    const size_t n = op->n;
    float *e = test_emission(op), *b = malloc(3 * n * sizeof *b);
    assert_non_null(b);
    lrr_solver *cl, *cpu;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_OPENCL, &cl));
    double kms = -1, tms = -1;
    LRR_CHECK(ctx, lrr_solver_timings(cl, &kms, &tms));
    assert_true(kms == 0 && tms == 0); /* no frame yet */
    LRR_CHECK(ctx, lrr_solve(cl, e, b)); /* warm-up */
    for (int rep = 0; rep < 3; rep++) {
        double t0 = lrr__now();
        LRR_CHECK(ctx, lrr_solve(cl, e, b));
        double wall_ms = (lrr__now() - t0) * 1e3;
        LRR_CHECK(ctx, lrr_solver_timings(cl, &kms, &tms));
        double step[3];
        lrr__solver_opencl_step_times(cl, step);
        print_message("n = %zu, k = %zu: kernel %.4f ms (w %.4f, z %.4f, B %.4f) + transfer "
                      "%.4f ms, wall %.4f ms\n",
                      n, op->k, kms, step[0], step[1], step[2], tms, wall_ms);
        assert_true(step[0] > 0 && step[1] > 0 && step[2] > 0);
        assert_true(fabs(step[0] + step[1] + step[2] - kms) <= 1e-9 * kms);
        assert_true(isfinite(kms) && kms > 0);
        assert_true(isfinite(tms) && tms > 0);
        /* slack: device and host clocks differ in resolution */
        assert_true(kms + tms <= wall_ms + 0.05);
    }
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &cpu));
    LRR_CHECK(ctx, lrr_solve(cpu, e, b));
    assert_int_equal(lrr_solver_timings(cpu, &kms, &tms), LRR_ERR_UNSUPPORTED);
    lrr_solver_destroy(cpu);
    lrr_solver_destroy(cl);
    free(b);
    free(e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    /* skip when there is no OpenCL to test: not built in, or no platform on this machine */
    unsetenv("LRR_OPENCL_DEVICE");
    lrr_context *ctx;
    if (lrr_context_create(&ctx) != LRR_OK)
        return 1;
    lrr_scene *s;
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, rho[3] = {0.5f, 0.5f, 0.5f},
                em[3] = {1, 1, 1};
    lrr_operator *op = NULL;
    lrr_subdivision sd = {0};
    if (lrr_scene_create(ctx, 1, v, rho, em, "probe", &s) != LRR_OK ||
        lrr_scene_subdivide(s, &sd) != LRR_OK || lrr_operator_build(s, NULL, &op) != LRR_OK)
        return 1;
    lrr_scene_destroy(s);
    lrr_solver *sv = NULL;
    lrr_status st = lrr_solver_create(op, LRR_BACKEND_OPENCL, &sv);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    lrr_solver_destroy(sv);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    if (st == LRR_ERR_UNSUPPORTED &&
        (strstr(msg, "not built into") || strstr(msg, "no OpenCL platform"))) {
        /* CI installs PoCL and sets LRR_REQUIRE_OPENCL: a skip there would hide a broken
         * OpenCL build, so it fails instead */
        const char *req = getenv("LRR_REQUIRE_OPENCL");
        printf("%s: %s\n", req && *req ? "FAIL (LRR_REQUIRE_OPENCL is set)" : "SKIP", msg);
        return req && *req ? 1 : 77;
    }
    /* any other failure is a real one and shows up in the tests below */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_odd_sizes),
        cmocka_unit_test(test_sparse),
        cmocka_unit_test(test_cornell_216),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_timings),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
