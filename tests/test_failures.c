/* Allocation-failure injection: every library allocation made with a context goes through
 * one counted function (lib/core/error.c); lrr__context_fail_after(ctx, N) makes the N-th fail.
 * A full preprocess + save + load + solve sequence is first run with counting only, to learn
 * the number A of allocations, then once for every N in 1..A: each public call must return
 * LRR_OK or LRR_ERR_NOMEM, the sequence stops at the first failure, everything created is
 * destroyed (leaks are caught by the ASan/LSan pass of .ci/run) and a failed save leaves
 * neither the file nor a temporary behind. Allocations inside third-party libraries
 * (OpenBLAS, OpenMP, stb, OpenEXR, assimp, Embree, OpenCL) are not counted. */
#include "testutil.h"
#include "solve/solve.h"

#include <dirent.h>
#include <sys/stat.h>

static char dir[4096];
static char path[4160];

/* Names of the entries of dir other than . and .., concatenated; returns their count. */
static int dir_entries(char *names, size_t len)
{
    DIR *d = opendir(dir);
    assert_non_null(d);
    int count = 0;
    names[0] = '\0';
    struct dirent *e;
    while ((e = readdir(d))) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        count++;
        size_t used = strlen(names);
        snprintf(names + used, len - used, "%s ", e->d_name);
    }
    closedir(d);
    return count;
}

typedef struct run_result {
    int steps_ok;          /* calls that returned LRR_OK before the first failure */
    lrr_status failed;     /* the first failure's status (LRR_OK: none) */
    const char *step;      /* its name */
    unsigned long allocs;  /* allocations counted */
    double solve_sum;      /* sum of B from the first lrr_solve, and the reference solve */
    double ref_sum;
} run_result;

static double sum(const float *x, size_t len)
{
    double s = 0;
    for (size_t i = 0; i < len; i++)
        s += x[i];
    return s;
}

/* The whole sequence on a fresh context with the N-th allocation failing (0: none); with
 * adaptive = 1, the operator is an adaptive hierarchy (the selection's sampled rows, radiosity
 * weights, greedy heap and exchanges, and a version-2 file) with ray-cast form factors; with
 * adaptive = 2 a cluster hierarchy (its tree, sample, cut and a version-3 file). */
static run_result run_sequence(unsigned long fail_at, int adaptive)
{
    run_result res = {0, LRR_OK, NULL, 0, 0, 0};
    lrr_context *ctx = tu_context();
    lrr__context_fail_after(ctx, fail_at);

    lrr_scene *scene = NULL;
    lrr_operator *op = NULL, *loaded = NULL;
    lrr_solver *solver = NULL;
    lrr_reference *ref = NULL;
    float *E = NULL, *B = NULL;
    lrr_subdivision sub = {.target_patches = 24, .levels = 1};
    lrr_build_options bo = {.hemicube_resolution = 16, .seed = 7, .threads = 1};
    if (adaptive) {
        sub = (lrr_subdivision){.target_patches = 200, .levels = 0};
        bo.adaptive_patches = 90;
        bo.adaptive_samples = 48;
        bo.formfactor_method = LRR_FORMFACTOR_RAYCAST; /* and the ray caster's allocations */
    }
    if (adaptive == 2) {
        bo.size = sizeof bo; /* hierarchy came after ABI 1 */
        bo.hierarchy = LRR_HIERARCHY_CLUSTER;
        bo.adaptive_patches = 40;
    }
    lrr_status st;

#define STEP(name, call)                                                                      \
    do {                                                                                      \
        st = (call);                                                                          \
        if (st != LRR_OK) {                                                                   \
            res.failed = st;                                                                  \
            res.step = name;                                                                  \
            goto done;                                                                        \
        }                                                                                     \
        res.steps_ok++;                                                                       \
    } while (0)

    STEP("lrr_scene_cornell_box", lrr_scene_cornell_box(ctx, 0, &scene));
    STEP("lrr_scene_subdivide", lrr_scene_subdivide(scene, &sub));
    STEP("lrr_operator_build", lrr_operator_build(scene, &bo, &op));
    STEP("lrr_operator_save", lrr_operator_save(op, path));
    STEP("lrr_operator_load", lrr_operator_load(ctx, path, &loaded));
    lrr_operator_info info;
    lrr_operator_get_info(loaded, &info, sizeof info);
    if (adaptive == 1) /* variable patch sizes: d = 0, d_min < d_max */
        assert_true(info.d == 0 && info.d_min < info.d_max && info.k <= 90 && info.k > 87);
    if (adaptive == 2)
        assert_true(info.hierarchy == LRR_HIERARCHY_CLUSTER && info.k == 40);
    B = malloc(info.n * 3 * sizeof *B);
    assert_non_null(B);
    STEP("lrr_solver_create", lrr_solver_create(loaded, LRR_BACKEND_CPU, &solver));
    STEP("lrr_solve", lrr_solve(solver, lrr_operator_emission(loaded), B));
    res.solve_sum = sum(B, info.n * 3);
    lrr_solver_destroy(solver);
    solver = NULL;
    STEP("lrr_operator_set_storage", lrr_operator_set_storage(loaded, LRR_STORAGE_F16));
    STEP("lrr_solver_create (f16)", lrr_solver_create(loaded, LRR_BACKEND_CPU, &solver));
    STEP("lrr_solve (f16)", lrr_solve(solver, lrr_operator_emission(loaded), B));
    STEP("lrr_reference_build", lrr_reference_build(scene, &bo, 0, &ref));
    size_t n = lrr_reference_size(ref);
    E = malloc(n * 3 * sizeof *E);
    free(B);
    B = malloc(n * 3 * sizeof *B);
    assert_true(E && B);
    memcpy(E, lrr_reference_emission(ref), n * 3 * sizeof *E);
    STEP("lrr_reference_solve", lrr_reference_solve(ref, LRR_METHOD_DIRECT, 0, 0, E, B, NULL, 0));
    res.ref_sum = sum(B, n * 3);
    lrr_path_trace_options po = lrr_path_trace_options_defaults();
    po.samples = 2;
    po.threads = 1;
    STEP("lrr_reference_path_trace", lrr_reference_path_trace(scene, &po, B, NULL));
#undef STEP

done:
    res.allocs = lrr__context_alloc_count(ctx);
    if (res.failed != LRR_OK) {
        /* the failure was recorded on the context with the same status */
        char msg[512];
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), res.failed);
        /* a failed call hands back nothing */
        if (!strcmp(res.step, "lrr_scene_cornell_box"))
            assert_null(scene);
        else if (!strcmp(res.step, "lrr_operator_build"))
            assert_null(op);
        else if (!strcmp(res.step, "lrr_operator_load"))
            assert_null(loaded);
        else if (!strncmp(res.step, "lrr_solver_create", 17))
            assert_null(solver);
        else if (!strcmp(res.step, "lrr_reference_build"))
            assert_null(ref);
    }
    free(E);
    free(B);
    lrr_reference_destroy(ref);
    lrr_solver_destroy(solver);
    lrr_operator_destroy(loaded);
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);

    /* the file exists exactly when the save succeeded; never a temporary */
    char names[1024];
    int entries = dir_entries(names, sizeof names);
    int saved = res.steps_ok >= 4;
    if (entries != saved)
        fail_msg("fail at %lu (%s): directory holds [%s], expected %s", fail_at,
                 res.step ? res.step : "-", names, saved ? "the operator file" : "nothing");
    if (saved) {
        struct stat sb;
        assert_int_equal(stat(path, &sb), 0);
        assert_int_equal(remove(path), 0);
    }
    return res;
}

static void sweep(int adaptive)
{
    run_result full = run_sequence(0, adaptive);
    if (full.failed != LRR_OK)
        fail_msg("the sequence fails without injection: %s -> %s", full.step,
                 lrr_strerror(full.failed));
    unsigned long A = full.allocs;
    assert_true(A > 0);
    print_message("allocation-failure sweep over A = %lu allocations\n", A);
    unsigned long by_step[16] = {0}, absorbed = 0;
    for (unsigned long N = 1; N <= A; N++) {
        run_result r = run_sequence(N, adaptive);
        /* the sequence is deterministic (one thread): the N-th allocation happens and fails.
         * A failure may be absorbed where the allocation is an optional cache (lrr_solve's
         * cached columns of F̄ M: it falls back to the full pass); then the whole sequence
         * runs and gives the same results. */
        if (r.failed == LRR_OK) {
            assert_true(r.allocs >= N && r.allocs <= A);
            /* the fallback sums in another order (float solve: 1e-5 relative, the
             * rounding times the condition of I - rho F; the double reference: 1e-9) */
            ASSERT_NEAR(r.solve_sum, full.solve_sum, 1e-5 * fabs(full.solve_sum),
                        "allocation %lu absorbed: lrr_solve", N);
            ASSERT_NEAR(r.ref_sum, full.ref_sum, 1e-9 * fabs(full.ref_sum),
                        "allocation %lu absorbed: lrr_reference_solve", N);
            absorbed++;
            continue;
        }
        if (r.failed != LRR_ERR_NOMEM)
            fail_msg("allocation %lu of %lu: %s returned %s, expected LRR_ERR_NOMEM", N, A,
                     r.step, lrr_strerror(r.failed));
        assert_int_equal(r.allocs, N);
        by_step[r.steps_ok]++;
    }
    print_message("  absorbed (optional caches, same results): %lu\n", absorbed);
    for (int i = 0; i < 16; i++)
        if (by_step[i])
            print_message("  failures in step %d: %lu\n", i + 1, by_step[i]);
    /* one past the end: nothing fails */
    run_result past = run_sequence(A + 1, adaptive);
    assert_int_equal(past.failed, LRR_OK);
    assert_int_equal(past.allocs, A);
}

static void test_sweep(void **state)
{
    (void)state;
    sweep(0);
}

static void test_sweep_adaptive(void **state)
{
    (void)state;
    sweep(1);
}

static void test_sweep_clusters(void **state)
{
    (void)state;
    sweep(2);
}

static int setup(void **state)
{
    (void)state;
    snprintf(dir, sizeof dir, "%s/lrr_failures_XXXXXX", tu_tmp_dir());
    if (!mkdtemp(dir))
        return -1;
    snprintf(path, sizeof path, "%s/op.lrr", dir);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    remove(path);
    return rmdir(dir);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sweep),
        cmocka_unit_test(test_sweep_adaptive),
        cmocka_unit_test(test_sweep_clusters),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
