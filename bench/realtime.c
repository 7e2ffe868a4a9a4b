/*
 * lrr-bench realtime: the real-time step alone, every implementation measured in one run on
 * the same matrix: our fused kernel with F̄ in f32, f16 and bf16, three sgemv, one sgemm with
 * three right-hand sides, the paper's method, the sparse and incremental paths; a bandwidth
 * floor per storage, ratios to it and to the paper's method, and the error of 16-bit storage.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bench.h"

#define RT_DEFAULT_HEMICUBE 64u
#define RT_WARMUPS 3u
#define RT_IDLE_MS 200u
#define RT_MIN_SECONDS 0.3
#define RT_BATCH 16
#define RT_TARGET_FLOOR 1.15
#define RT_TARGET_PAPER_F32 5.0
#define RT_TARGET_PAPER_F16 10.0

static const char realtime_help[] =
    "Usage: lrr-bench realtime [--n N --k K | --cells paper|small|LIST] [--scene SCENE]\n"
    "                          [--hemicube R] [--repeat N] [--backend cpu|opencl]\n"
    "                          [--csv OUT.csv]\n"
    "The real-time step alone: every implementation measured in one run on the same matrix.\n"
    "For each cell the scene is subdivided into about k patches of d = 4^levels subpatches\n"
    "and the operator built once; it is saved to a temporary .lrr file in $TMPDIR (deleted\n"
    "afterwards) and a fresh copy is loaded for each 16-bit storage, so that f16 and bf16\n"
    "are both rounded from the float values. The emission is the scene's own.\n"
    "  fused        lrr_solve forced to its full path (LRR_PATH_FULL), one solver per\n"
    "               storage (f32, f16, bf16): one pass over F̄ for all three channels,\n"
    "               B_c = E_c + rho_c ∘ (F̄ (M_c (Vᵀ E_c))) with the epilogue fused\n"
    "  sgemv3       three cblas_sgemv over F̄ (f32), no epilogue\n"
    "  sgemm3       one cblas_sgemm F̄ (n×k) × Z (k×3), no epilogue\n"
    "  paper        the paper's method, as in 'table': dense Y_c = -diag(rho_c) F̄ M_c and\n"
    "               a dense V (built once, not timed), two cblas_sgemv per channel\n"
    "  sparse       LRR_PATH_SPARSE (f32): a sum of cached columns of F̄ M_c for the\n"
    "               emitting patches\n"
    "  incremental  LRR_PATH_INCREMENTAL (f32), the emission scaled by 1 and 0.5 on\n"
    "               alternate frames: the previous B plus the columns of the changed\n"
    "               patches (a frame that took another path is reported)\n"
    "and, in the text only, lrr_solve_batch with 16 frames (ms per frame).\n"
    "With --backend opencl, also fused on an OpenCL solver (LRR_BACKEND_OPENCL; device from\n"
    "LRR_OPENCL_DEVICE) for f32, f16 and bf16: rows with backend=opencl, timed the same way,\n"
    "with the median kernel_ms (the kernels' END - START) and transfer_ms (E up, B down)\n"
    "from OpenCL profiling events (lrr_solver_timings), their sum, and ratio_to_cpu = CPU\n"
    "fused (same storage) median / OpenCL median, measured in the same run.\n"
    "Timing: each implementation in its own block: 3 warm-up runs, then 200 ms idle (the\n"
    "spinning OpenMP or OpenBLAS workers of the previous block go to sleep, so the two\n"
    "thread pools never compete), then the timed runs: median, min and max, ms per frame.\n"
    "Our kernels use OpenMP (OMP_NUM_THREADS), the baselines OpenBLAS\n"
    "(OPENBLAS_NUM_THREADS); the configuration is printed.\n"
    "Floor: bandwidth = the larger of the tuned read kernel (an OpenMP sum with eight\n"
    "accumulators of the widest vectors the CPU has, over max(512 MiB, 4 × the last-level\n"
    "cache), best of 5) and the effective bandwidth of sgemv3 on the same matrix\n"
    "(3·n·k·4 bytes / its median), so no baseline runs below its own floor.\n"
    "floor_ms = F̄'s bytes in the row's storage (n·k·4 or n·k·2) / bandwidth; sgemv3,\n"
    "sgemm3, paper, sparse and incremental get the f32 floor; floor_ms_full (CSV) adds M\n"
    "(12·k² bytes). ratio_to_floor = ms_median / floor_ms (below 1 a warning says whether\n"
    "the matrix was cache-resident or the floor too low; sparse and incremental do not read\n"
    "F̄ and may go below it); ratio_to_paper = the paper's ms_median / ms_median (a\n"
    "speed-up). rel_l2_vs_f32 = the area-weighted relative L2 of B against fused f32's B\n"
    "(incremental: a frame with the x1 emission); nan for fused f32 itself and for sgemv3\n"
    "and sgemm3, which compute no B. The target lines (fused f32 <= 1.15 × floor and\n"
    ">= 5× paper; f16 <= 1.15 × the f16 floor and >= 10× paper) are reported, never\n"
    "enforced.\n"
    "\n"
    "Options:\n"
    "  --n N, --k K         one matrix of about N subpatches and K patches: target_patches K,\n"
    "                       levels = round(log4(N/K)); the actual n and k are reported\n"
    "  --cells SET          the cells of 'table': paper (its 9 cells), small (its 4\n"
    "                       cheapest), all, or a list N/K/D,... with D a power of 4\n"
    "                       (default paper)\n"
    "  --scene SCENE        a scene file (OBJ/PLY/glTF) or built-in name 'cornell',\n"
    "                       'cornell-closed' (default cornell; a file wins over a name)\n"
    "  --hemicube R         hemicube resolution: even, 8..4096 (default 64). Timing does\n"
    "                       not depend on R: only the preprocessing time does\n"
    "  --repeat N           timed runs per implementation (default: adaptive, at least 20\n"
    "                       runs and at least 0.3 s)\n"
    "  --backend B          cpu (default: the rows above) or opencl (also the OpenCL rows;\n"
    "                       fails when no OpenCL device or platform is available)\n"
    "  --csv OUT.csv        one row per implementation and cell (rewritten after each cell):\n"
    "                       impl,storage,n,k,ms_median,ms_min,ms_max,floor_ms,\n"
    "                       ratio_to_floor,ratio_to_paper,rel_l2_vs_f32, then extra columns\n"
    "                       ending in backend,kernel_ms,transfer_ms,device,ratio_to_cpu\n"
    "                       (CPU rows: cpu,nan,nan,cpu,nan; nan where a value does not\n"
    "                       apply)\n"
    "  -h, --help           show this help\n";

/* ------------------------------------------------------------------ results */
enum {
    RT_FUSED_F32,
    RT_FUSED_F16,
    RT_FUSED_BF16,
    RT_SGEMV3,
    RT_SGEMM3,
    RT_PAPER,
    RT_SPARSE,
    RT_INCREMENTAL,
    RT_COUNT
};

static const char *const rt_impl[RT_COUNT] = {"fused",  "fused",  "fused",  "sgemv3",
                                              "sgemm3", "paper",  "sparse", "incremental"};
static const lrr_storage rt_storage[RT_COUNT] = {
    LRR_STORAGE_F32, LRR_STORAGE_F16, LRR_STORAGE_BF16, LRR_STORAGE_F32,
    LRR_STORAGE_F32, LRR_STORAGE_F32, LRR_STORAGE_F32, LRR_STORAGE_F32};

typedef struct rt_row {
    const char *impl, *storage;
    char kernel[32];
    char path[16];      /* the path most timed frames took ("-" for the baselines) */
    size_t other_path;  /* timed frames that took another path */
    char other_name[16];
    timing t;
    double floor_ms, floor_ms_full, ratio_to_floor, ratio_to_paper, rel_l2;
    double bytes;       /* what one frame must read, for the cache warning */
    int reads_fbar;     /* ratio_to_floor < 1 means something */
    const char *backend;  /* "cpu" or "opencl" */
    double kernel_ms, transfer_ms, ratio_to_cpu; /* OpenCL rows; nan otherwise */
    char device[160];   /* OpenCL rows: lrr_solver_kernel; "cpu" otherwise */
} rt_row;

typedef struct rt_cell {
    cell target;
    size_t n, k, d;
    double preprocess_s;
    double bw_kernel, bw_sgemv3, bw; /* bytes per second; bw_sgemv3 NAN when not used */
    const char *bw_source;
    int fits_llc;
    timing batch;
    double batch_ms_per_frame, batch_rel_l2;
    rt_row rows[RT_COUNT];
    rt_row cl_rows[3];  /* --backend opencl: fused f32, f16, bf16 on the OpenCL solver */
    int have_cl;
} rt_cell;

typedef struct rt_args {
    const char *scene, *csv;
    unsigned hemicube, repeat;
    cell *cells;
    size_t n_cells;
    const char *cells_name;
    size_t llc;
    double bandwidth;
    int opencl; /* --backend opencl */
} rt_args;

/* ------------------------------------------------------------------ frames */
/* lrr_solve, recording the path of every frame (warm-up runs first, timed runs last). */
typedef struct path_frame {
    ours_frame of;
    unsigned char *paths;
    size_t cap, count;
} path_frame;

static int path_step(void *user)
{
    path_frame *p = user;
    int rc = ours_step(&p->of);
    if (!rc && p->count < p->cap)
        p->paths[p->count++] = (unsigned char)lrr_solver_last_path(p->of.solver);
    return rc;
}

/* One cblas_sgemm F̄ (n×k) × Z (k×3) → n×3. */
typedef struct sgemm_frame {
    blasint n, k;
    const float *fbar, *z;
    float *out;
} sgemm_frame;

static int sgemm_step(void *user)
{
    sgemm_frame *f = user;
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, f->n, 3, f->k, 1.0f, f->fbar, f->k,
                f->z, 3, 0.0f, f->out, 3);
    return 0;
}

typedef struct batch_frame {
    lrr_solver *solver;
    const float *e;
    float *b;
    lrr_status status;
} batch_frame;

static int batch_step(void *user)
{
    batch_frame *f = user;
    f->status = lrr_solve_batch(f->solver, RT_BATCH, f->e, f->b);
    return f->status != LRR_OK;
}

/* One implementation's block: RT_WARMUPS warm-up runs, RT_IDLE_MS of sleep (the spinning
 * OpenMP or OpenBLAS workers of the previous block go idle), then the timed runs: `repeat`
 * of them, or (repeat 0) until there are at least MIN_RUNS and they took RT_MIN_SECONDS in
 * all (at most MAX_RUNS). Returns 0 or the frame's non-zero status. */
static int rt_time(frame_fn fn, void *user, unsigned repeat, timing *t)
{
    int rc;
    for (unsigned w = 0; w < RT_WARMUPS; w++)
        if ((rc = fn(user)))
            return rc;
    const size_t cap = repeat ? repeat : MAX_RUNS;
    double *v = malloc(cap * sizeof *v);
    if (!v)
        return bench_fail("cannot allocate %zu timings", cap);
    struct timespec ts = {RT_IDLE_MS / 1000, (long)(RT_IDLE_MS % 1000) * 1000000L};
    while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
        ;
    size_t runs = 0;
    double total = 0;
    while (runs < cap && (repeat || runs < MIN_RUNS || total < RT_MIN_SECONDS)) {
        double a = cli_now();
        if ((rc = fn(user))) {
            free(v);
            return rc;
        }
        double s = cli_now() - a;
        v[runs++] = 1e3 * s;
        total += s;
    }
    timing_from_samples(v, runs, t);
    free(v);
    return 0;
}

/* Times lrr_solve on `solver` forced to `want`, B in b (e_alt: alternate frames). Fills the
 * row's timing, kernel and path statistics. */
static int time_solver(lrr_context *ctx, lrr_solver *solver, lrr_path want, const float *e,
                       const float *e_alt, float *b, unsigned repeat, rt_row *row)
{
    lrr_status s = lrr_solver_set_path(solver, want);
    if (s != LRR_OK)
        return lib_fail(ctx, s, "lrr_solver_set_path");
    snprintf(row->kernel, sizeof row->kernel, "%s", lrr_solver_kernel(solver));
    path_frame pf = {{solver, e, e_alt, b, LRR_OK, 0}, NULL, 0, 0};
    pf.cap = RT_WARMUPS + (repeat ? repeat : MAX_RUNS) + 1;
    pf.paths = malloc(pf.cap);
    if (!pf.paths)
        return bench_fail("cannot allocate %zu path records", pf.cap);
    if (rt_time(path_step, &pf, repeat, &row->t)) {
        free(pf.paths);
        return pf.of.status != LRR_OK ? lib_fail(ctx, pf.of.status, "lrr_solve")
                                      : CLI_EXIT_FAIL;
    }
    /* the timed runs are the last t.runs frames */
    size_t first = pf.count >= row->t.runs ? pf.count - row->t.runs : 0, other = 0;
    lrr_path other_path = want;
    for (size_t i = first; i < pf.count; i++)
        if (pf.paths[i] != (unsigned char)want) {
            other++;
            other_path = (lrr_path)pf.paths[i];
        }
    free(pf.paths);
    size_t timed = pf.count - first;
    snprintf(row->path, sizeof row->path, "%s",
             path_name(2 * other > timed ? other_path : want));
    row->other_path = 2 * other > timed ? timed - other : other;
    snprintf(row->other_name, sizeof row->other_name, "%s",
             path_name(2 * other > timed ? want : other_path));
    return 0;
}

/* Times lrr_solve on a fresh OpenCL solver for op (storage row->storage), B in b; fills
 * the row's timing and the medians of its kernel and transfer times. */
static int time_cl(lrr_context *ctx, const lrr_operator *op, const float *e, float *b,
                   unsigned repeat, rt_row *row)
{
    lrr_solver *sv = NULL;
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_OPENCL, &sv);
    if (s != LRR_OK)
        return lib_fail(ctx, s, "OpenCL solver");
    snprintf(row->kernel, sizeof row->kernel, "opencl");
    cl_device_name(sv, row->device, sizeof row->device);
    snprintf(row->path, sizeof row->path, "full");
    cl_frame cf = {{sv, e, NULL, b, LRR_OK, 0}, NULL, NULL, 0, 0};
    cf.cap = RT_WARMUPS + (repeat ? repeat : MAX_RUNS) + 1;
    cf.kernel_ms = malloc(cf.cap * sizeof *cf.kernel_ms);
    cf.transfer_ms = malloc(cf.cap * sizeof *cf.transfer_ms);
    int rc = 0;
    if (!cf.kernel_ms || !cf.transfer_ms)
        rc = bench_fail("cannot allocate %zu timings", cf.cap);
    else if (rt_time(cl_step, &cf, repeat, &row->t))
        rc = cf.of.status != LRR_OK ? lib_fail(ctx, cf.of.status, "lrr_solve (OpenCL)")
                                    : CLI_EXIT_FAIL;
    else
        cl_medians(&cf, row->t.runs, &row->kernel_ms, &row->transfer_ms);
    free(cf.kernel_ms);
    free(cf.transfer_ms);
    lrr_solver_destroy(sv);
    return rc;
}

/* ------------------------------------------------------------------ helpers */
static int finite_all(const float *v, size_t count)
{
    for (size_t i = 0; i < count; i++)
        if (!isfinite(v[i]))
            return 0;
    return 1;
}

/* z_c = M_c (Vᵀ E_c), channel-major 3×k, in double then rounded */
static void rt_make_z(const lrr_operator *op, size_t n, size_t k, size_t d, const float *e,
                      float *z)
{
    const float *m = lrr_operator_m(op);
    double *w = calloc(3 * k, sizeof *w);
    if (!w) {
        for (size_t j = 0; j < 3 * k; j++)
            z[j] = 1.0f / (float)k; /* any vector will do for the baselines */
        return;
    }
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            w[(size_t)c * k + i / d] += e[3 * i + c];
    for (int c = 0; c < 3; c++)
        for (size_t p = 0; p < k; p++) {
            double acc = 0;
            const float *row = m + (size_t)c * k * k + p * k;
            for (size_t q = 0; q < k; q++)
                acc += (double)row[q] * w[(size_t)c * k + q];
            z[(size_t)c * k + p] = (float)acc;
        }
    free(w);
}

static double storage_bytes(size_t n, size_t k, lrr_storage st)
{
    return (double)n * (double)k * (st == LRR_STORAGE_F32 ? 4.0 : 2.0);
}

/* Loads a fresh copy of the operator at `path` and converts it to `storage`. */
static int load_copy(lrr_context *ctx, const char *path, lrr_storage storage, lrr_operator **op)
{
    lrr_status s = lrr_operator_load(ctx, path, op);
    if (s != LRR_OK)
        return lib_fail(ctx, s, "reloading the operator");
    if ((s = lrr_operator_set_storage(*op, storage)) != LRR_OK) {
        lrr_operator_destroy(*op);
        *op = NULL;
        return lib_fail(ctx, s, lrr_storage_name(storage));
    }
    return 0;
}

/* ------------------------------------------------------------------ one cell */
static int rt_cell_run(lrr_context *ctx, const rt_args *a, const cell *c, size_t index,
                       rt_cell *r)
{
    memset(r, 0, sizeof *r);
    r->target = *c;
    r->bw_sgemv3 = r->batch_ms_per_frame = r->batch_rel_l2 = NAN;
    for (int i = 0; i < RT_COUNT; i++) {
        rt_row *w = &r->rows[i];
        w->impl = rt_impl[i];
        w->storage = lrr_storage_name(rt_storage[i]);
        snprintf(w->kernel, sizeof w->kernel, "openblas");
        snprintf(w->path, sizeof w->path, "-");
        w->t.median = w->t.min = w->t.max = NAN;
        w->floor_ms = w->floor_ms_full = w->ratio_to_floor = w->ratio_to_paper = NAN;
        w->rel_l2 = NAN;
        w->backend = "cpu";
        w->kernel_ms = w->transfer_ms = w->ratio_to_cpu = NAN;
        snprintf(w->device, sizeof w->device, "cpu");
    }
    for (int i = 0; i < 3; i++) {
        rt_row *w = &r->cl_rows[i];
        *w = r->rows[RT_FUSED_F32 + i];
        w->backend = "opencl";
    }
    char label[96];
    snprintf(label, sizeof label, "[%zu/%zu] %zu×%zu (d %zu)", index + 1, a->n_cells, c->n, c->k,
             c->d);

    lrr_scene *scene = NULL;
    lrr_operator *op = NULL, *op16[2] = {NULL, NULL};
    lrr_solver *solver = NULL, *sv = NULL;
    float *b32 = NULL, *b = NULL, *e_half = NULL, *be = NULL, *bb = NULL, *tmp = NULL;
    float *z = NULL, *zt = NULL;
    paper_frame pf = {0};
    sgemv_frame sf = {0};
    char path[4096] = "";
    int have_file = 0;
    int rc = open_scene(ctx, a->scene, &scene);
    if (rc)
        return rc;
    lrr_subdivision sub = {0.0, c->k, (unsigned)levels_of(c->d)};
    lrr_status s = lrr_scene_subdivide(scene, &sub);
    if (s != LRR_OK) {
        rc = lib_fail(ctx, s, "subdivision");
        goto done;
    }
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si);
    const size_t n = si.subpatches, k = si.patches, d = si.d;
    note("%s: %zu patches, %zu subpatches; building the operator (hemicube %u)", label, k, n,
         a->hemicube);
    lrr_build_options bo = {.hemicube_resolution = a->hemicube, .seed = DEFAULT_SEED};
    cli_progress bar;
    progress_begin(&bar, "hemicubes", &bo);
    double t0 = cli_now();
    s = lrr_operator_build(scene, &bo, &op);
    r->preprocess_s = cli_now() - t0;
    cli_progress_finish(&bar);
    lrr_scene_destroy(scene);
    scene = NULL;
    if (s != LRR_OK) {
        rc = lib_fail(ctx, s, "operator build");
        goto done;
    }
    if (!lrr_operator_fbar(op)) {
        rc = bench_fail("%s: a fresh build is not stored as float", label);
        goto done;
    }
    r->n = n;
    r->k = k;
    r->d = d;

    /* the 16-bit copies: saved, loaded afresh, converted; the file is removed at once */
    const char *tmpdir = getenv("TMPDIR");
    if (!tmpdir || !tmpdir[0])
        tmpdir = "/tmp";
    int plen = snprintf(path, sizeof path, "%s/lrr-bench-realtime-XXXXXX.lrr", tmpdir);
    if (plen < 0 || (size_t)plen >= sizeof path) {
        rc = bench_fail("TMPDIR '%s' is too long", tmpdir);
        goto done;
    }
    int fd = mkstemps(path, 4);
    if (fd < 0) {
        rc = bench_fail("cannot create a temporary file in '%s': %s", tmpdir, strerror(errno));
        goto done;
    }
    close(fd);
    have_file = 1;
    if ((s = lrr_operator_save(op, path)) != LRR_OK) {
        rc = lib_fail(ctx, s, "saving the operator to a temporary file");
        goto done;
    }
    note("%s: operator built in %.2f s; f16 and bf16 copies", label, r->preprocess_s);
    if ((rc = load_copy(ctx, path, LRR_STORAGE_F16, &op16[0])) ||
        (rc = load_copy(ctx, path, LRR_STORAGE_BF16, &op16[1])))
        goto done;
    unlink(path);
    have_file = 0;

    const float *e = lrr_operator_emission(op), *area = lrr_operator_area(op);
    b32 = cli_alloc_rgb(n);
    b = cli_alloc_rgb(n);
    e_half = cli_alloc_rgb(n);
    tmp = cli_alloc_rgb(n);
    if (!b32 || !b || !e_half || !tmp) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    for (size_t i = 0; i < 3 * n; i++)
        e_half[i] = 0.5f * e[i];

    /* fused f32: the reference B of every comparison */
    note("%s: fused f32", label);
    if ((s = lrr_solver_create(op, LRR_BACKEND_CPU, &solver)) != LRR_OK) {
        rc = lib_fail(ctx, s, "solver");
        goto done;
    }
    if ((rc = time_solver(ctx, solver, LRR_PATH_FULL, e, NULL, b32, a->repeat,
                          &r->rows[RT_FUSED_F32])))
        goto done;
    if (!finite_all(b32, 3 * n)) {
        rc = bench_fail("%s: fused f32 gave a non-finite B", label);
        goto done;
    }
    if (a->opencl) {
        note("%s: fused f32 (OpenCL)", label);
        if ((rc = time_cl(ctx, op, e, b, a->repeat, &r->cl_rows[0])))
            goto done;
        compare_b(n, area, b, b32, NULL, &r->cl_rows[0].rel_l2, NULL);
        r->have_cl = 1;
    }

    /* fused f16 and bf16, one solver each */
    for (int j = 0; j < 2; j++) {
        rt_row *row = &r->rows[RT_FUSED_F16 + j];
        note("%s: fused %s", label, row->storage);
        if ((s = lrr_solver_create(op16[j], LRR_BACKEND_CPU, &sv)) != LRR_OK) {
            rc = lib_fail(ctx, s, "solver");
            goto done;
        }
        if ((rc = time_solver(ctx, sv, LRR_PATH_FULL, e, NULL, b, a->repeat, row)))
            goto done;
        compare_b(n, area, b, b32, NULL, &row->rel_l2, NULL);
        lrr_solver_destroy(sv);
        sv = NULL;
        if (a->opencl) {
            note("%s: fused %s (OpenCL)", label, row->storage);
            if ((rc = time_cl(ctx, op16[j], e, b, a->repeat, &r->cl_rows[1 + j])))
                goto done;
            compare_b(n, area, b, b32, NULL, &r->cl_rows[1 + j].rel_l2, NULL);
        }
        lrr_operator_destroy(op16[j]);
        op16[j] = NULL;
    }

    /* sparse: the scene's emission from cached columns */
    note("%s: sparse path", label);
    if ((s = lrr_solver_create(op, LRR_BACKEND_CPU, &sv)) != LRR_OK) {
        rc = lib_fail(ctx, s, "solver");
        goto done;
    }
    if ((rc = time_solver(ctx, sv, LRR_PATH_SPARSE, e, NULL, b, a->repeat, &r->rows[RT_SPARSE])))
        goto done;
    compare_b(n, area, b, b32, NULL, &r->rows[RT_SPARSE].rel_l2, NULL);
    lrr_solver_destroy(sv);
    sv = NULL;

    /* incremental: x1 and x0.5 on alternate frames; B of an x1 frame against fused f32 */
    note("%s: incremental path", label);
    if ((s = lrr_solver_create(op, LRR_BACKEND_CPU, &sv)) != LRR_OK) {
        rc = lib_fail(ctx, s, "solver");
        goto done;
    }
    if ((rc = time_solver(ctx, sv, LRR_PATH_INCREMENTAL, e, e_half, b, a->repeat,
                          &r->rows[RT_INCREMENTAL])))
        goto done;
    for (int tries = 0; tries < 4; tries++) {
        if ((s = lrr_solve(sv, e_half, tmp)) != LRR_OK || (s = lrr_solve(sv, e, b)) != LRR_OK) {
            rc = lib_fail(ctx, s, "lrr_solve (incremental)");
            goto done;
        }
        if (lrr_solver_last_path(sv) == LRR_PATH_INCREMENTAL)
            break;
    }
    if (lrr_solver_last_path(sv) == LRR_PATH_INCREMENTAL)
        compare_b(n, area, b, b32, NULL, &r->rows[RT_INCREMENTAL].rel_l2, NULL);
    else
        note("%s: the incremental path never served an x1 frame: rel_l2_vs_f32 is nan", label);
    lrr_solver_destroy(sv);
    sv = NULL;

    /* the baselines: three sgemv and one sgemm with z_c = M_c Vᵀ E_c */
    note("%s: sgemv3, sgemm3", label);
    z = alloc_floats(3, k);
    zt = alloc_floats(k, 3);
    for (int ch = 0; ch < 3; ch++)
        sf.out[ch] = alloc_floats(n, 1);
    if (!z || !zt || !sf.out[0] || !sf.out[1] || !sf.out[2]) {
        rc = bench_fail("cannot allocate the sgemv vectors");
        goto done;
    }
    rt_make_z(op, n, k, d, e, z);
    for (size_t p = 0; p < k; p++)
        for (int ch = 0; ch < 3; ch++)
            zt[3 * p + ch] = z[(size_t)ch * k + p];
    sf.n = (blasint)n;
    sf.k = (blasint)k;
    sf.fbar = lrr_operator_fbar(op);
    for (int ch = 0; ch < 3; ch++)
        sf.z[ch] = z + (size_t)ch * k;
    if ((rc = rt_time(sgemv_step, &sf, a->repeat, &r->rows[RT_SGEMV3].t)))
        goto done;
    sgemm_frame gf = {(blasint)n, (blasint)k, lrr_operator_fbar(op), zt, b};
    if ((rc = rt_time(sgemm_step, &gf, a->repeat, &r->rows[RT_SGEMM3].t)))
        goto done;
    for (int ch = 0; ch < 3; ch++) {
        lrr_aligned_free(sf.out[ch]);
        sf.out[ch] = NULL;
    }

    /* the paper's method */
    note("%s: the paper's method", label);
    if ((rc = paper_setup(op, e, &pf)))
        goto done;
    if ((rc = rt_time(paper_step, &pf, a->repeat, &r->rows[RT_PAPER].t)))
        goto done;
    for (size_t i = 0; i < n; i++)
        for (int ch = 0; ch < 3; ch++)
            b[3 * i + ch] = pf.b[ch][i];
    compare_b(n, area, b, b32, NULL, &r->rows[RT_PAPER].rel_l2, NULL);
    paper_free(&pf);

    /* lrr_solve_batch: 16 frames, the emission scaled by 1/16, 2/16, ..., 1 */
    note("%s: lrr_solve_batch (%d frames)", label, RT_BATCH);
    be = cli_alloc_rgb(n * RT_BATCH);
    bb = cli_alloc_rgb(n * RT_BATCH);
    if (!be || !bb) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    for (size_t f = 0; f < RT_BATCH; f++)
        for (size_t i = 0; i < 3 * n; i++)
            be[f * 3 * n + i] = e[i] * (float)(f + 1) / (float)RT_BATCH;
    batch_frame bf = {solver, be, bb, LRR_OK};
    if (rt_time(batch_step, &bf, a->repeat, &r->batch)) {
        rc = bf.status != LRR_OK ? lib_fail(ctx, bf.status, "lrr_solve_batch") : CLI_EXIT_FAIL;
        goto done;
    }
    r->batch_ms_per_frame = r->batch.median / RT_BATCH;
    compare_b(n, area, bb + (RT_BATCH - 1) * 3 * n, b32, NULL, &r->batch_rel_l2, NULL);

    /* the floor's bandwidth: the best of the tuned read kernel and of what OpenBLAS sgemv
     * itself streams over this matrix, so no baseline can run below its own floor */
    const double f32_bytes = storage_bytes(n, k, LRR_STORAGE_F32), m_bytes = 12.0 * k * k;
    r->fits_llc = a->llc > 0 && f32_bytes <= (double)a->llc;
    r->bw_kernel = a->bandwidth;
    r->bw = a->bandwidth;
    r->bw_source = "read-kernel";
    if (r->rows[RT_SGEMV3].t.median > 0) {
        r->bw_sgemv3 = 3.0 * f32_bytes / (r->rows[RT_SGEMV3].t.median / 1e3);
        if (r->bw_sgemv3 > r->bw) {
            r->bw = r->bw_sgemv3;
            r->bw_source = "sgemv3";
        }
    }
    const double paper_ms = r->rows[RT_PAPER].t.median;
    for (int i = 0; i < RT_COUNT; i++) {
        rt_row *w = &r->rows[i];
        const lrr_storage st = rt_storage[i];
        const double fb = storage_bytes(n, k, st);
        w->floor_ms = r->bw > 0 ? 1e3 * fb / r->bw : NAN;
        w->floor_ms_full = r->bw > 0 ? 1e3 * (fb + m_bytes) / r->bw : NAN;
        w->ratio_to_floor = w->t.median / w->floor_ms;
        w->ratio_to_paper = paper_ms / w->t.median;
        w->reads_fbar = i != RT_SPARSE && i != RT_INCREMENTAL;
        w->bytes = i == RT_PAPER ? 4.0 * f32_bytes : i <= RT_FUSED_BF16 ? fb + m_bytes : fb;
    }
    for (int i = 0; r->have_cl && i < 3; i++) {
        rt_row *w = &r->cl_rows[i];
        const rt_row *cpu = &r->rows[RT_FUSED_F32 + i];
        w->floor_ms = cpu->floor_ms;
        w->floor_ms_full = cpu->floor_ms_full;
        w->ratio_to_floor = w->t.median / w->floor_ms;
        w->ratio_to_paper = paper_ms / w->t.median;
        w->ratio_to_cpu = cpu->t.median / w->t.median;
        w->reads_fbar = 1;
        w->bytes = cpu->bytes;
    }
done:
    if (have_file)
        unlink(path);
    for (int ch = 0; ch < 3; ch++)
        lrr_aligned_free(sf.out[ch]);
    lrr_aligned_free(z);
    lrr_aligned_free(zt);
    paper_free(&pf);
    lrr_solver_destroy(sv);
    lrr_solver_destroy(solver);
    lrr_operator_destroy(op16[0]);
    lrr_operator_destroy(op16[1]);
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    free(b32);
    free(b);
    free(e_half);
    free(tmp);
    free(be);
    free(bb);
    return rc;
}

/* ------------------------------------------------------------------ output */
static const char rt_csv_header[] =
    "impl,storage,n,k,ms_median,ms_min,ms_max,floor_ms,ratio_to_floor,ratio_to_paper,"
    "rel_l2_vs_f32,d,runs,kernel,path,other_path_frames,floor_ms_full,bandwidth_gbs,"
    "bandwidth_source,llc_mib,threads_openmp,threads_openblas,n_target,k_target,d_target,"
    "preprocess_s,hemicube,backend,kernel_ms,transfer_ms,device,ratio_to_cpu\n";

static int write_rt_csv(const char *path, const rt_args *a, const rt_cell *cells, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs(rt_csv_header, out.f);
    for (size_t i = 0; i < count; i++) {
        const rt_cell *r = &cells[i];
        for (int j = 0; j < RT_COUNT + (r->have_cl ? 3 : 0); j++) {
            const rt_row *w = j < RT_COUNT ? &r->rows[j] : &r->cl_rows[j - RT_COUNT];
            fprintf(out.f, "%s,%s,%zu,%zu,", w->impl, w->storage, r->n, r->k);
            const double v[] = {w->t.median,       w->t.min,          w->t.max,
                                w->floor_ms,       w->ratio_to_floor, w->ratio_to_paper,
                                w->rel_l2};
            for (size_t q = 0; q < sizeof v / sizeof v[0]; q++)
                csv_num(out.f, v[q], 0);
            fprintf(out.f, "%zu,%zu,%s,%s,%zu,", r->d, w->t.runs, w->kernel, w->path,
                    w->other_path);
            csv_num(out.f, w->floor_ms_full, 0);
            csv_num(out.f, r->bw / 1e9, 0);
            fprintf(out.f, "%s,%zu,%d,%d,%zu,%zu,%zu,", r->bw_source, a->llc >> 20,
                    omp_get_max_threads(), openblas_get_num_threads(), r->target.n,
                    r->target.k, r->target.d);
            csv_num(out.f, r->preprocess_s, 0);
            fprintf(out.f, "%u,%s,", a->hemicube, w->backend);
            csv_num(out.f, w->kernel_ms, 0);
            csv_num(out.f, w->transfer_ms, 0);
            fprintf(out.f, "%s,", w->device);
            csv_num(out.f, w->ratio_to_cpu, 1);
        }
    }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

static const char *fmt_ratio(char *buf, size_t len, double v)
{
    if (isnan(v))
        snprintf(buf, len, "-");
    else
        snprintf(buf, len, v < 10 ? "%.2f" : "%.1f", v);
    return buf;
}

static const char *yes_no(int v)
{
    return v ? "yes" : "no";
}

static void print_rt_cell(const rt_args *a, const rt_cell *r)
{
    char b1[32], b2[32], b3[32];
    const double f32_bytes = storage_bytes(r->n, r->k, LRR_STORAGE_F32);
    printf("\ncell: %zu×%zu (d %zu; target %zu/%zu/%zu)\n", r->n, r->k, r->d, r->target.n,
           r->target.k, r->target.d);
    printf("preprocess_s: %.2f (hemicube %u)\n", r->preprocess_s, a->hemicube);
    printf("fbar_bytes: f32 %s, f16/bf16 %s; M %s; fits in the last-level cache (%zu MiB): "
           "%s\n",
           fmt_bytes(b1, sizeof b1, (size_t)f32_bytes),
           fmt_bytes(b2, sizeof b2, (size_t)(f32_bytes / 2)),
           fmt_bytes(b3, sizeof b3, (size_t)12 * r->k * r->k), a->llc >> 20,
           a->llc ? yes_no(r->fits_llc) : "unknown");
    if (isnan(r->bw_sgemv3))
        printf("bandwidth_gbs: %.2f (the tuned read kernel; no sgemv3 timing)\n", r->bw / 1e9);
    else
        printf("bandwidth_gbs: %.2f (%s; read kernel %.2f, sgemv3 effective 3·n·k·4 B / "
               "median %.2f)\n",
               r->bw / 1e9,
               strcmp(r->bw_source, "sgemv3") == 0 ? "sgemv3's effective bandwidth"
                                                   : "the tuned read kernel",
               r->bw_kernel / 1e9, r->bw_sgemv3 / 1e9);
    char f1[32], f2[32], f3[32], f4[32];
    printf("floor_ms: f32 %s, f16/bf16 %s; floor_ms_full (F̄ + M): f32 %s, f16/bf16 %s\n",
           fmt_ms(f1, sizeof f1, r->rows[RT_FUSED_F32].floor_ms),
           fmt_ms(f2, sizeof f2, r->rows[RT_FUSED_F16].floor_ms),
           fmt_ms(f3, sizeof f3, r->rows[RT_FUSED_F32].floor_ms_full),
           fmt_ms(f4, sizeof f4, r->rows[RT_FUSED_F16].floor_ms_full));
    printf("\n%-12s %-7s %-8s %28s %7s %9s %14s %14s %13s  %s\n", "impl", "storage", "kernel",
           "ms median (min-max)", "runs", "floor_ms", "ratio_to_floor", "ratio_to_paper",
           "rel_l2_vs_f32", "path");
    for (int i = 0; i < RT_COUNT; i++) {
        const rt_row *w = &r->rows[i];
        char med[32], lo[32], hi[32], t[128], fl[32], rf[32], rp[32], el[32], pth[96];
        fmt_ms(med, sizeof med, w->t.median);
        fmt_ms(lo, sizeof lo, w->t.min);
        fmt_ms(hi, sizeof hi, w->t.max);
        snprintf(t, sizeof t, "%s (%s-%s)", med, lo, hi);
        fmt_ms(fl, sizeof fl, w->floor_ms);
        fmt_ratio(rf, sizeof rf, w->ratio_to_floor);
        fmt_ratio(rp, sizeof rp, w->ratio_to_paper);
        if (isnan(w->rel_l2))
            snprintf(el, sizeof el, "-");
        else
            snprintf(el, sizeof el, "%.3g", w->rel_l2);
        if (w->other_path)
            snprintf(pth, sizeof pth, "%s (%zu of %zu timed frames %s)", w->path, w->other_path,
                     w->t.runs, w->other_name);
        else
            snprintf(pth, sizeof pth, "%s", w->path);
        printf("%-12s %-7s %-8s %28s %7zu %9s %14s %14s %13s  %s\n", w->impl, w->storage,
               w->kernel, t, w->t.runs, fl, rf, rp, el, pth);
    }
    if (r->have_cl) {
        printf("\nopencl: %s (fused, full path; kernel and transfer: medians of the OpenCL "
               "profiling events; ratio_to_cpu = CPU fused ms / OpenCL ms)\n",
               r->cl_rows[0].device);
        printf("%-7s %28s %7s %10s %11s %10s %12s %13s\n", "storage", "ms median (min-max)",
               "runs", "kernel_ms", "transfer_ms", "sum_ms", "ratio_to_cpu", "rel_l2_vs_f32");
        for (int i = 0; i < 3; i++) {
            const rt_row *w = &r->cl_rows[i];
            char med[32], lo[32], hi[32], t[128], km[32], tm[32], sm[32], rc[32], el[32];
            fmt_ms(med, sizeof med, w->t.median);
            fmt_ms(lo, sizeof lo, w->t.min);
            fmt_ms(hi, sizeof hi, w->t.max);
            snprintf(t, sizeof t, "%s (%s-%s)", med, lo, hi);
            if (isnan(w->rel_l2))
                snprintf(el, sizeof el, "-");
            else
                snprintf(el, sizeof el, "%.3g", w->rel_l2);
            snprintf(km, sizeof km, "%.3g", w->kernel_ms);
            snprintf(tm, sizeof tm, "%.3g", w->transfer_ms);
            snprintf(sm, sizeof sm, "%.3g", w->kernel_ms + w->transfer_ms);
            printf("%-7s %28s %7zu %10s %11s %10s %12s %13s\n", w->storage, t, w->t.runs, km, tm,
                   sm,
                   fmt_ratio(rc, sizeof rc, w->ratio_to_cpu), el);
        }
    }
    const rt_row *f32 = &r->rows[RT_FUSED_F32], *f16 = &r->rows[RT_FUSED_F16];
    char bm[32], fm[32];
    printf("\nbatch: lrr_solve_batch %d frames: %s ms per frame (median %s ms per batch, %zu "
           "runs); speed-up vs fused f32: %.2f; rel_l2_vs_f32 %.3g\n",
           RT_BATCH, fmt_ms(bm, sizeof bm, r->batch_ms_per_frame),
           fmt_ms(fm, sizeof fm, r->batch.median), r->batch.runs,
           f32->t.median / r->batch_ms_per_frame, r->batch_rel_l2);
    for (int i = 0; i < RT_COUNT; i++) {
        const rt_row *w = &r->rows[i];
        if (!w->reads_fbar || !(w->ratio_to_floor < 1))
            continue;
        char by[32];
        if (a->llc && w->bytes <= (double)a->llc)
            printf("warning: %s %s: ratio_to_floor %.2f < 1: the %s it reads fit in the "
                   "last-level cache (%zu MiB), so it ran from the cache, not from memory\n",
                   w->impl, w->storage, w->ratio_to_floor,
                   fmt_bytes(by, sizeof by, (size_t)w->bytes), a->llc >> 20);
        else
            printf("warning: %s %s: ratio_to_floor %.2f < 1: the floor was measured too low "
                   "(bandwidth %.2f GB/s from the %s; it reads %s, more than the last-level "
                   "cache)\n",
                   w->impl, w->storage, w->ratio_to_floor, r->bw / 1e9,
                   strcmp(r->bw_source, "sgemv3") == 0 ? "sgemv3 baseline" : "read kernel",
                   fmt_bytes(by, sizeof by, (size_t)w->bytes));
    }
    printf("target: fused f32 ≤ %.2f × floor: %s; ≥ %g× paper: %s; f16 ≤ %.2f × f16 floor: %s; "
           "≥ %g× paper: %s\n",
           RT_TARGET_FLOOR, yes_no(f32->ratio_to_floor <= RT_TARGET_FLOOR), RT_TARGET_PAPER_F32,
           yes_no(f32->ratio_to_paper >= RT_TARGET_PAPER_F32), RT_TARGET_FLOOR,
           yes_no(f16->ratio_to_floor <= RT_TARGET_FLOOR), RT_TARGET_PAPER_F16,
           yes_no(f16->ratio_to_paper >= RT_TARGET_PAPER_F16));
    fflush(stdout);
}

static const char *env_or_unset(const char *name)
{
    const char *v = getenv(name);
    return v && v[0] ? v : "(unset)";
}

static const char *openblas_parallel_name(void)
{
    switch (openblas_get_parallel()) {
    case 0:
        return "sequential";
    case 1:
        return "pthreads";
    case 2:
        return "openmp";
    default:
        return "unknown";
    }
}

/* ------------------------------------------------------------------ command */
int cmd_realtime(int argc, char *argv[])
{
    static const char prog[] = "lrr-bench realtime";
    static const struct option longopts[] = {
        {"n", required_argument, NULL, OPT_N},
        {"k", required_argument, NULL, OPT_K},
        {"cells", required_argument, NULL, OPT_CELLS},
        {"scene", required_argument, NULL, OPT_SCENE},
        {"hemicube", required_argument, NULL, OPT_HEMICUBE},
        {"repeat", required_argument, NULL, OPT_REPEAT},
        {"csv", required_argument, NULL, OPT_CSV},
        {"backend", required_argument, NULL, OPT_BACKEND},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    rt_args a = {.scene = "cornell", .hemicube = RT_DEFAULT_HEMICUBE};
    size_t opt_n = 0, opt_k = 0;
    int rc = CLI_EXIT_USAGE;
    char nk_name[96];
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(realtime_help, stdout);
            free(a.cells);
            return CLI_EXIT_OK;
        case OPT_N:
            if (cli_parse_size(prog, "--n", optarg, 1, (size_t)1 << 32, &opt_n) != 0)
                goto out;
            break;
        case OPT_K:
            if (cli_parse_size(prog, "--k", optarg, 1, (size_t)1 << 32, &opt_k) != 0)
                goto out;
            break;
        case OPT_CELLS:
            if (parse_cells(prog, optarg, &a.cells, &a.n_cells, &a.cells_name) != 0)
                goto out;
            break;
        case OPT_SCENE:
            a.scene = optarg;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &a.hemicube) != 0)
                goto out;
            if (a.hemicube % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", a.hemicube);
                goto out;
            }
            break;
        case OPT_REPEAT:
            if (cli_parse_unsigned(prog, "--repeat", optarg, 1, 1000000, &a.repeat) != 0)
                goto out;
            break;
        case OPT_CSV:
            a.csv = optarg;
            break;
        case OPT_BACKEND:
            if (parse_backend(prog, optarg, &a.opencl) != 0)
                goto out;
            break;
        default:
            rc = bad_option(prog, c, argv);
            goto out;
        }
    }
    if (no_positional(prog, argc, argv))
        goto out;
    if (a.csv && !a.csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        goto out;
    }
    if ((opt_n || opt_k) && a.cells) {
        cli_usage_error(prog, "--n/--k and --cells exclude each other");
        goto out;
    }
    if (!opt_n != !opt_k) {
        cli_usage_error(prog, "%s needs %s too", opt_n ? "--n" : "--k", opt_n ? "--k" : "--n");
        goto out;
    }
    if (opt_n) {
        if (opt_n < opt_k) {
            cli_usage_error(prog, "--n %zu is smaller than --k %zu (n = k·4^levels)", opt_n,
                            opt_k);
            goto out;
        }
        double lv = round(log((double)opt_n / (double)opt_k) / log(4.0));
        if (lv > 10) {
            cli_usage_error(prog, "--n/--k: N/K = %g needs more than 10 levels",
                            (double)opt_n / (double)opt_k);
            goto out;
        }
        a.cells = malloc(sizeof *a.cells);
        if (!a.cells) {
            rc = bench_fail("out of memory");
            goto out;
        }
        a.cells[0] = (cell){opt_n, opt_k, (size_t)1 << (2 * (unsigned)lv)};
        a.n_cells = 1;
        snprintf(nk_name, sizeof nk_name, "--n %zu --k %zu, levels %u", opt_n, opt_k,
                 (unsigned)lv);
        a.cells_name = nk_name;
    }
    if (!a.cells && parse_cells(prog, "paper", &a.cells, &a.n_cells, &a.cells_name) != 0) {
        rc = bench_fail("out of memory");
        goto out;
    }

    lrr_context *ctx = NULL;
    if ((rc = bench_start(a.scene, a.opencl, &ctx)) != CLI_EXIT_OK)
        goto out;
    rt_cell *res = calloc(a.n_cells, sizeof *res);
    if (!res) {
        lrr_context_destroy(ctx);
        rc = bench_fail("out of memory");
        goto out;
    }
    double t_start = cli_now();
    printf("benchmark: realtime\n");
    print_machine();
    printf("omp_wait_policy: %s\n", env_or_unset("OMP_WAIT_POLICY"));
    printf("omp_proc_bind: %s\n", env_or_unset("OMP_PROC_BIND"));
    printf("omp_num_threads: %s\n", env_or_unset("OMP_NUM_THREADS"));
    printf("openblas_num_threads: %s\n", env_or_unset("OPENBLAS_NUM_THREADS"));
    printf("openblas_parallel: %s\n", openblas_parallel_name());
    printf("threading: lrr kernels OpenMP (%d threads), baselines OpenBLAS (%d threads); each "
           "implementation in its own block: %u warm-up runs, %u ms idle, timed runs\n",
           omp_get_max_threads(), openblas_get_num_threads(), RT_WARMUPS, RT_IDLE_MS);
    printf("scene: %s\n", a.scene);
    printf("cells: %s (%zu)\n", a.cells_name, a.n_cells);
    printf("hemicube: %u (the timings do not depend on it)\n", a.hemicube);
    if (a.opencl)
        printf("backend: cpu and opencl\n");
    if (a.repeat)
        printf("repeat: %u\n", a.repeat);
    else
        printf("repeat: adaptive (at least %d runs and %.1f s)\n", MIN_RUNS, RT_MIN_SECONDS);
    fflush(stdout);
    a.llc = llc_bytes();
    size_t bw_bytes = bandwidth_buffer_bytes();
    printf("llc_mib: %zu\n", a.llc >> 20);
    note("measuring the read bandwidth (%d passes over %zu MiB)", BANDWIDTH_PASSES,
         bw_bytes >> 20);
    a.bandwidth = measure_bandwidth(bw_bytes);
    if (a.bandwidth > 0)
        printf("read_bandwidth_gbs: %.2f (tuned read kernel: widest-vector OpenMP sum over %zu "
               "MiB, best of %d, %d threads)\n",
               a.bandwidth / 1e9, bw_bytes >> 20, BANDWIDTH_PASSES, omp_get_max_threads());
    else
        printf("read_bandwidth_gbs: nan (cannot allocate %zu MiB)\n", bw_bytes >> 20);
    printf("units: ms per frame, median (min-max); floor = F̄ bytes / bandwidth; "
           "ratio_to_paper = paper ms / ms (a speed-up)\n");
    fflush(stdout);

    rc = CLI_EXIT_OK;
    size_t done = 0;
    for (size_t i = 0; i < a.n_cells; i++) {
        int crc = rt_cell_run(ctx, &a, &a.cells[i], i, &res[done]);
        if (crc) {
            rc = crc;
            break;
        }
        print_rt_cell(&a, &res[done]);
        done++;
        if (a.csv && write_rt_csv(a.csv, &a, res, done) != 0) {
            rc = CLI_EXIT_FAIL;
            break;
        }
    }
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
    if (a.csv && done)
        printf("csv: %s\n", a.csv);
    free(res);
    lrr_context_destroy(ctx);
out:
    free(a.cells);
    return rc;
}
