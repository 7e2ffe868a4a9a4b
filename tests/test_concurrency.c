/* Thread safety as include/lrr.h documents it:
 *   - operators are read-only once built and may be shared: "many solvers may share one
 *     operator", solver create/destroy "any thread", "one thread per solver at a time";
 *   - lrr_operator_build and lrr_operator_save: "any thread" (a scene is read-only: many
 *     builds may share it);
 *   - the context's error record: "any thread".
 * THREADS pthreads each create their own CPU solvers on two shared operators (float and
 * binary16 storage), run a fixed sequence of frames (every path: full, sparse, incremental,
 * a batch through sgemm, a rejected NaN frame), destroy them, ROUNDS times, and compare every
 * output bit for bit with the same sequence run serially beforehand: a solver's results
 * depend only on its own history, never on another thread. Then threads build operators
 * from one shared scene and save them, compared with a serial build and save.
 *
 * `make check` runs this with OpenMP's default threads (OMP_NUM_THREADS=2), so every solver
 * also runs parallel regions. .ci/run builds it with --enable-sanitizers=thread and runs it
 * with OMP_NUM_THREADS=1: libgomp is not built with ThreadSanitizer, so its barriers are
 * invisible to it and every parallel region with more than one thread would be reported as
 * a race (false positives); with one OpenMP thread the lrr code under test is the same and
 * all the concurrency comes from the pthreads here, which TSan sees whole. */
#include "testutil.h"
#include "solve/solve.h"

#include <pthread.h>

#define THREADS 8
#define ROUNDS 3
#define EMISSIONS 6
#define FRAMES 14
#define BATCH 3

typedef struct shared {
    lrr_context *ctx;
    lrr_operator *op[2];        /* float and binary16 storage */
    size_t n, k, d;
    float *emission[EMISSIONS]; /* n×3 each */
    float *bad;                 /* n×3 with one NaN */
    /* reference outputs: per thread, FRAMES single frames then one batch of BATCH */
    float *ref[THREADS];
    float *ref_rows[THREADS];   /* rows of F̄ decoded serially */
} shared;

static shared S;

/* Emission j: a few patches emit (sparse path) for j < 3, most of them for j >= 3 (full
 * path); consecutive frames of one sequence often differ in few patches (incremental). */
static void make_emissions(void)
{
    uint64_t x = 0x9e3779b97f4a7c15ULL;
    for (int j = 0; j < EMISSIONS; j++) {
        float *e = calloc(S.n * 3, sizeof *e);
        assert_non_null(e);
        size_t emitting = j < 3 ? (size_t)j + 1 : S.k * (size_t)(j + 2) / 10;
        for (size_t m = 0; m < emitting; m++) {
            x = x * 6364136223846793005ULL + 1442695040888963407ULL;
            size_t p = (size_t)(x >> 33) % S.k;
            for (size_t i = p * S.d; i < (p + 1) * S.d; i++)
                for (int c = 0; c < 3; c++)
                    e[3 * i + c] = 1.0f + (float)((x >> (8 * c)) & 0xff) / 64.0f;
        }
        S.emission[j] = e;
    }
    S.bad = calloc(S.n * 3, sizeof *S.bad);
    assert_non_null(S.bad);
    S.bad[3 * (S.n / 2) + 1] = NAN;
}

/* Which emission frame f of thread t solves. */
static int frame_emission(int t, int f)
{
    return (t * 3 + f * (1 + t % 3) + (f / 4)) % EMISSIONS;
}

/* The sequence of thread t: its own solver on one of the shared operators. Writes FRAMES +
 * BATCH frames of n×3 into out; 0 on success, else the failing call's status (negated for
 * an unexpected acceptance of the NaN frame). paths (may be NULL) counts the paths taken. */
static int run_sequence(int t, float *out, float *rows, unsigned paths[4])
{
    const lrr_operator *op = S.op[t % 2];
    const size_t frame = 3 * S.n;
    lrr_solver *s;
    lrr_status st = lrr_solver_create(op, LRR_BACKEND_CPU, &s);
    if (st)
        return (int)st;
    /* the sgemm batch path on these small matrices (default: only beyond 32 MiB) */
    lrr__solver_batch_thresholds(s, 2, 0);
    if (t % 4 == 3 && (st = lrr_solver_set_path(s, LRR_PATH_INCREMENTAL)))
        goto done;
    for (int f = 0; f < FRAMES; f++) {
        if (f == FRAMES / 2) {
            /* a rejected frame: the error goes to the shared context, the solver is fine */
            if (lrr_solve(s, S.bad, out + f * frame) != LRR_ERR_INVALID_ARG) {
                st = LRR_ERR_INVALID_ARG;
                goto done;
            }
            (void)lrr_context_last_error(S.ctx, NULL, 0);
        }
        if ((st = lrr_solve(s, S.emission[frame_emission(t, f)], out + f * frame)))
            goto done;
        if (paths)
            paths[lrr_solver_last_path(s)]++;
    }
    float *e = malloc(BATCH * frame * sizeof *e);
    if (!e) {
        st = LRR_ERR_NOMEM;
        goto done;
    }
    for (int b = 0; b < BATCH; b++)
        memcpy(e + b * frame, S.emission[(t + b) % EMISSIONS], frame * sizeof *e);
    st = lrr_solve_batch(s, BATCH, e, out + FRAMES * frame);
    free(e);
    /* reading the shared operator while others solve with it */
    for (size_t i = 0; i < S.n && !st; i += 97)
        lrr_operator_fbar_row(op, i, rows + (i / 97) * S.k);
done:
    lrr_solver_destroy(s);
    return (int)st;
}

static size_t out_floats(void) { return (FRAMES + BATCH) * 3 * S.n; }
static size_t rows_floats(void) { return ((S.n + 96) / 97) * S.k; }

typedef struct job {
    int t;
    int status;
    size_t mismatches;
    size_t first; /* first differing float */
} job;

static void *solver_thread(void *arg)
{
    job *j = arg;
    float *out = malloc(out_floats() * sizeof *out);
    float *rows = malloc(rows_floats() * sizeof *rows);
    if (!out || !rows) {
        j->status = LRR_ERR_NOMEM;
    } else {
        for (int r = 0; r < ROUNDS && j->status == 0; r++) {
            memset(out, 0xff, out_floats() * sizeof *out);
            j->status = run_sequence(j->t, out, rows, NULL);
            if (j->status)
                break;
            /* bit for bit: memcmp, not a tolerance */
            for (size_t q = 0; q < out_floats(); q++)
                if (memcmp(&out[q], &S.ref[j->t][q], sizeof(float)) != 0 &&
                    j->mismatches++ == 0)
                    j->first = q;
            if (memcmp(rows, S.ref_rows[j->t], rows_floats() * sizeof *rows) != 0)
                j->mismatches++;
        }
    }
    free(out);
    free(rows);
    return NULL;
}

static int setup(void **state)
{
    (void)state;
    if (lrr_context_create(&S.ctx))
        return -1;
    lrr_scene *scene;
    lrr_subdivision sub = {.target_patches = 120, .levels = 2};
    lrr_build_options bo = {.hemicube_resolution = 16, .seed = 11, .threads = 1};
    if (lrr_scene_cornell_box(S.ctx, 0, &scene) || lrr_scene_subdivide(scene, &sub) ||
        lrr_operator_build(scene, &bo, &S.op[0]) || lrr_operator_build(scene, &bo, &S.op[1]) ||
        lrr_operator_set_storage(S.op[1], LRR_STORAGE_F16))
        return -1;
    lrr_scene_destroy(scene);
    lrr_operator_info info;
    lrr_operator_get_info(S.op[0], &info, sizeof info);
    S.n = info.n;
    S.k = info.k;
    S.d = info.d;
    make_emissions();
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    for (int j = 0; j < EMISSIONS; j++)
        free(S.emission[j]);
    free(S.bad);
    for (int t = 0; t < THREADS; t++) {
        free(S.ref[t]);
        free(S.ref_rows[t]);
    }
    lrr_operator_destroy(S.op[0]);
    lrr_operator_destroy(S.op[1]);
    lrr_context_destroy(S.ctx);
    return 0;
}

static void test_shared_operator(void **state)
{
    (void)state;
    /* n·k above LRR__PARALLEL_MIN: the full pass runs OpenMP regions inside each thread */
    assert_true(S.n * S.k >= LRR__PARALLEL_MIN);
    unsigned paths[4] = {0, 0, 0, 0};
    for (int t = 0; t < THREADS; t++) {
        S.ref[t] = malloc(out_floats() * sizeof(float));
        S.ref_rows[t] = malloc(rows_floats() * sizeof(float));
        assert_true(S.ref[t] && S.ref_rows[t]);
        assert_int_equal(run_sequence(t, S.ref[t], S.ref_rows[t], paths), 0);
    }
    /* every path is exercised */
    print_message("paths of the serial run: full %u, sparse %u, incremental %u\n",
                  paths[LRR_PATH_FULL], paths[LRR_PATH_SPARSE], paths[LRR_PATH_INCREMENTAL]);
    assert_true(paths[LRR_PATH_FULL] > 0 && paths[LRR_PATH_SPARSE] > 0 &&
                paths[LRR_PATH_INCREMENTAL] > 0);
    /* the sequences differ between threads (else equal outputs would prove little) */
    assert_true(memcmp(S.ref[0], S.ref[2], out_floats() * sizeof(float)) != 0);
    assert_true(memcmp(S.ref[0], S.ref[1], out_floats() * sizeof(float)) != 0);
    /* and the serial reference is itself repeatable */
    float *again = malloc(out_floats() * sizeof *again), *rows = malloc(rows_floats() * 4);
    assert_true(again && rows);
    assert_int_equal(run_sequence(5, again, rows, NULL), 0);
    assert_memory_equal(again, S.ref[5], out_floats() * sizeof(float));
    free(again);
    free(rows);

    pthread_t th[THREADS];
    job jobs[THREADS];
    for (int t = 0; t < THREADS; t++) {
        jobs[t] = (job){t, 0, 0, 0};
        assert_int_equal(pthread_create(&th[t], NULL, solver_thread, &jobs[t]), 0);
    }
    for (int t = 0; t < THREADS; t++)
        assert_int_equal(pthread_join(th[t], NULL), 0);
    for (int t = 0; t < THREADS; t++) {
        if (jobs[t].status)
            fail_msg("thread %d: %s", t, lrr_strerror((lrr_status)jobs[t].status));
        if (jobs[t].mismatches)
            fail_msg("thread %d: %zu floats differ from the serial run (first at %zu)", t,
                     jobs[t].mismatches, jobs[t].first);
    }
    print_message("%d threads × %d rounds × %d frames on shared operators (n = %zu, k = %zu): "
                  "bit-identical to serial\n",
                  THREADS, ROUNDS, FRAMES + BATCH, S.n, S.k);
}

/* ------------------------------------------------------------ builds and saves */
#define BUILDERS 4

typedef struct build_job {
    const lrr_scene *scene;
    lrr_context *ctx; /* the scene's: errors of all builders go to one record */
    lrr_operator *op;
    char path[256];
    int status;
} build_job;

static void *build_thread(void *arg)
{
    build_job *b = arg;
    lrr_build_options bo = {.hemicube_resolution = 16, .seed = 5, .threads = 1};
    b->status = lrr_operator_build(b->scene, &bo, &b->op);
    if (!b->status)
        b->status = lrr_operator_save(b->op, b->path);
    return NULL;
}

static unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long sz = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(sz > 0 ? (size_t)sz : 1);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)sz, f), (size_t)sz);
    fclose(f);
    *len = (size_t)sz;
    return b;
}

static void test_shared_scene(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *scene = tu_cornell(ctx, 1, 0, 0);
    lrr_subdivision sub = {.target_patches = 40, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(scene, &sub));
    build_job serial = {scene, ctx, NULL, "", 0};
    tu_tmp_path(serial.path, sizeof serial.path, "test_concurrency_serial.lrr");
    build_thread(&serial);
    assert_int_equal(serial.status, LRR_OK);
    size_t want_len;
    unsigned char *want = slurp(serial.path, &want_len);

    build_job jobs[BUILDERS];
    pthread_t th[BUILDERS];
    for (int t = 0; t < BUILDERS; t++) {
        jobs[t] = (build_job){scene, ctx, NULL, "", 0};
        char name[64];
        snprintf(name, sizeof name, "test_concurrency_%d.lrr", t);
        tu_tmp_path(jobs[t].path, sizeof jobs[t].path, name);
        assert_int_equal(pthread_create(&th[t], NULL, build_thread, &jobs[t]), 0);
    }
    for (int t = 0; t < BUILDERS; t++)
        assert_int_equal(pthread_join(th[t], NULL), 0);
    lrr_operator_info a, b;
    lrr_operator_get_info(serial.op, &a, sizeof a);
    for (int t = 0; t < BUILDERS; t++) {
        if (jobs[t].status)
            fail_msg("builder %d: %s", t, lrr_strerror((lrr_status)jobs[t].status));
        lrr_operator_get_info(jobs[t].op, &b, sizeof b);
        assert_int_equal(a.n, b.n);
        LRR_CHECK(ctx, lrr_operator_set_layout(serial.op, LRR_LAYOUT_ROWS));
        LRR_CHECK(ctx, lrr_operator_set_layout(jobs[t].op, LRR_LAYOUT_ROWS));
        assert_memory_equal(lrr_operator_fbar(serial.op), lrr_operator_fbar(jobs[t].op),
                            a.n * a.k * sizeof(float));
        assert_memory_equal(lrr_operator_m(serial.op), lrr_operator_m(jobs[t].op),
                            3 * a.k * a.k * sizeof(float));
        /* the files differ only in the build time (INFO section, and its checksums) */
        size_t len;
        unsigned char *got = slurp(jobs[t].path, &len);
        assert_int_equal(len, want_len);
        size_t differ = 0;
        for (size_t q = 0; q < len; q++)
            differ += got[q] != want[q];
        assert_true(differ <= 64);
        free(got);
        remove(jobs[t].path);
        lrr_operator_destroy(jobs[t].op);
    }
    free(want);
    remove(serial.path);
    lrr_operator_destroy(serial.op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_shared_operator),
        cmocka_unit_test(test_shared_scene),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
