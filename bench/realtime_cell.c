/*
 * lrr-bench realtime, one cell (realtime.c has the command, its options and its output): the
 * operator built once, its f16 and bf16 copies, then every implementation timed in its own
 * block on the same matrix (fused f32, f16, bf16 and on OpenCL; the sparse and incremental
 * paths; sgemv3 and sgemm3; the paper's method; lrr_solve_batch), and the floors: measured
 * once, and for the fused CPU rows also in pairs alternating with the pass (rt_pairs).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "bench.h"

static const char *const rt_impl[RT_COUNT] = {"fused",  "fused",  "fused",  "sgemv3",
                                              "sgemm3", "paper",  "sparse", "incremental"};
static const lrr_storage rt_storage[RT_COUNT] = {
    LRR_STORAGE_F32, LRR_STORAGE_F16, LRR_STORAGE_BF16, LRR_STORAGE_F32,
    LRR_STORAGE_F32, LRR_STORAGE_F32, LRR_STORAGE_F32, LRR_STORAGE_F32};

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
    int rc = bench_ours_step(&p->of);
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
    bench_timing_from_samples(v, runs, t);
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
        return bench_lib_fail(ctx, s, "lrr_solver_set_path");
    snprintf(row->kernel, sizeof row->kernel, "%s", lrr_solver_kernel(solver));
    path_frame pf = {{solver, e, e_alt, b, LRR_OK, 0}, NULL, 0, 0};
    pf.cap = RT_WARMUPS + (repeat ? repeat : MAX_RUNS) + 1;
    pf.paths = malloc(pf.cap);
    if (!pf.paths)
        return bench_fail("cannot allocate %zu path records", pf.cap);
    if (rt_time(path_step, &pf, repeat, &row->t)) {
        free(pf.paths);
        return pf.of.status != LRR_OK ? bench_lib_fail(ctx, pf.of.status, "lrr_solve")
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
             bench_path_name(2 * other > timed ? other_path : want));
    row->other_path = 2 * other > timed ? timed - other : other;
    snprintf(row->other_name, sizeof row->other_name, "%s",
             bench_path_name(2 * other > timed ? want : other_path));
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
        return bench_lib_fail(ctx, s, "OpenCL solver");
    snprintf(row->kernel, sizeof row->kernel, "opencl");
    bench_cl_device_name(sv, row->device, sizeof row->device);
    snprintf(row->path, sizeof row->path, "full");
    cl_frame cf = {{sv, e, NULL, b, LRR_OK, 0}, NULL, NULL, 0, 0};
    cf.cap = RT_WARMUPS + (repeat ? repeat : MAX_RUNS) + 1;
    cf.kernel_ms = malloc(cf.cap * sizeof *cf.kernel_ms);
    cf.transfer_ms = malloc(cf.cap * sizeof *cf.transfer_ms);
    int rc = 0;
    if (!cf.kernel_ms || !cf.transfer_ms)
        rc = bench_fail("cannot allocate %zu timings", cf.cap);
    else if (rt_time(bench_cl_step, &cf, repeat, &row->t))
        rc = cf.of.status != LRR_OK ? bench_lib_fail(ctx, cf.of.status, "lrr_solve (OpenCL)")
                                    : CLI_EXIT_FAIL;
    else
        bench_cl_medians(&cf, row->t.runs, &row->kernel_ms, &row->transfer_ms);
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

double storage_bytes(size_t n, size_t k, lrr_storage st)
{
    return (double)n * (double)k * (st == LRR_STORAGE_F32 ? 4.0 : 2.0);
}

/* Loads a fresh copy of the operator at `path` and converts it to `storage`. */
static int load_copy(lrr_context *ctx, const char *path, lrr_storage storage, lrr_operator **op)
{
    lrr_status s = lrr_operator_load(ctx, path, op);
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "reloading the operator");
    if ((s = lrr_operator_set_storage(*op, storage)) != LRR_OK) {
        lrr_operator_destroy(*op);
        *op = NULL;
        return bench_lib_fail(ctx, s, lrr_storage_name(storage));
    }
    return 0;
}


/* ------------------------------------------------------------------ one cell */
/* What the measurements of one cell share. */
typedef struct rt_work {
    lrr_context *ctx;
    const rt_args *a;
    char label[96];
    size_t n, k, d;
    lrr_operator *op, *op16[2]; /* op16: the f16 and bf16 copies */
    lrr_solver *solver;         /* fused f32's, also timed by lrr_solve_batch */
    const float *e, *area;
    float *b32, *b, *e_half, *tmp; /* b32: fused f32's B, the reference of every comparison */
} rt_work;

/* Every row nan (or "-") until measured. */
static void rt_cell_init(rt_cell *r, const cell *c)
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
        w->pairs = (bench_pairs){NAN, NAN, NAN, NAN, 0};
        w->roofline_ms = NAN;
        snprintf(w->device, sizeof w->device, "cpu");
    }
    for (int i = 0; i < 3; i++) {
        rt_row *w = &r->cl_rows[i];
        *w = r->rows[RT_FUSED_F32 + i];
        w->backend = "opencl";
    }
}

/* Subdivides the scene for the cell and builds the operator (wk->op, stored as float). */
static int rt_build(rt_work *wk, const cell *c, rt_cell *r)
{
    const rt_args *a = wk->a;
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    int rc = bench_open_scene(wk->ctx, a->scene, &scene);
    if (rc)
        return rc;
    lrr_subdivision sub = {.target_patches = c->k, .levels = (unsigned)bench_levels_of(c->d)};
    lrr_status s = lrr_scene_subdivide(scene, &sub);
    if (s != LRR_OK) {
        lrr_scene_destroy(scene);
        return bench_lib_fail(wk->ctx, s, "subdivision");
    }
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    const size_t n = si.subpatches, k = si.patches, d = si.d;
    bench_note("%s: %zu patches, %zu subpatches; building the operator (hemicube %u)", wk->label, k,
               n, a->hemicube);
    lrr_build_options bo = {.hemicube_resolution = a->hemicube, .seed = DEFAULT_SEED};
    cli_progress bar;
    bench_progress_begin(&bar, "hemicubes", &bo);
    double t0 = cli_now();
    s = lrr_operator_build(scene, &bo, &op);
    r->preprocess_s = cli_now() - t0;
    cli_progress_finish(&bar);
    lrr_scene_destroy(scene);
    wk->op = op;
    if (s != LRR_OK)
        return bench_lib_fail(wk->ctx, s, "operator build");
    r->n = wk->n = n;
    r->k = wk->k = k;
    r->d = wk->d = d;
    return 0;
}

/* the 16-bit copies: saved, loaded afresh, converted; the file is removed at once */
static int rt_copies(rt_work *wk, const rt_cell *r)
{
    char path[4096] = "";
    const char *tmpdir = getenv("TMPDIR");
    if (!tmpdir || !tmpdir[0])
        tmpdir = "/tmp";
    int plen = snprintf(path, sizeof path, "%s/lrr-bench-realtime-XXXXXX.lrr", tmpdir);
    if (plen < 0 || (size_t)plen >= sizeof path)
        return bench_fail("TMPDIR '%s' is too long", tmpdir);
    int fd = mkstemps(path, 4);
    if (fd < 0)
        return bench_fail("cannot create a temporary file in '%s': %s", tmpdir, strerror(errno));
    close(fd);
    int rc;
    lrr_status s = lrr_operator_save(wk->op, path);
    if (s != LRR_OK)
        rc = bench_lib_fail(wk->ctx, s, "saving the operator to a temporary file");
    else {
        bench_note("%s: operator built in %.2f s; f16 and bf16 copies", wk->label, r->preprocess_s);
        if (!(rc = load_copy(wk->ctx, path, LRR_STORAGE_F16, &wk->op16[0])))
            rc = load_copy(wk->ctx, path, LRR_STORAGE_BF16, &wk->op16[1]);
    }
    unlink(path);
    return rc;
}

/* The B buffers and the x0.5 emission of the incremental path. */
static int rt_buffers(rt_work *wk)
{
    const size_t n = wk->n;
    wk->e = lrr_operator_emission(wk->op);
    wk->area = lrr_operator_area(wk->op);
    wk->b32 = cli_alloc_rgb(n);
    wk->b = cli_alloc_rgb(n);
    wk->e_half = cli_alloc_rgb(n);
    wk->tmp = cli_alloc_rgb(n);
    if (!wk->b32 || !wk->b || !wk->e_half || !wk->tmp)
        return CLI_EXIT_FAIL;
    for (size_t i = 0; i < 3 * n; i++)
        wk->e_half[i] = 0.5f * wk->e[i];
    return 0;
}

/* The fused pass on sv and its floor in alternation (bench_interleave), over every byte a
 * frame must read: F̄ as stored, M as the solver reads it, E and B (n·3 floats each); and the
 * multiply-add roofline, 2·n·k·3 + 2·3·k² flops at the measured FMA peak. */
static int rt_pairs(rt_work *wk, lrr_solver *sv, lrr_storage st, rt_row *row)
{
    const double n = (double)wk->n, k = (double)wk->k;
    lrr_solver_info si;
    lrr_solver_get_info(sv, &si, sizeof si);
    row->m_bytes = (double)si.m_bytes;
    const double bytes = storage_bytes(wk->n, wk->k, st) + row->m_bytes + 2.0 * 12.0 * n;
    ours_frame of = {sv, wk->e, NULL, wk->b, LRR_OK, 0};
    bench_note("%s: fused %s and its floor, %u interleaved pairs", wk->label, row->storage,
               RT_PAIRS);
    int rc = bench_interleave(bench_ours_step, &of, bytes, row->t.median, RT_PAIRS, &row->pairs);
    if (rc && of.status != LRR_OK)
        return bench_lib_fail(wk->ctx, of.status, "lrr_solve (interleaved)");
    row->roofline_ms = wk->a->fma_peak > 0 ? 1e3 * (6.0 * n * k + 6.0 * k * k) / wk->a->fma_peak
                                           : NAN;
    return rc;
}

/* fused f32: the reference B of every comparison */
static int rt_fused_f32(rt_work *wk, rt_cell *r)
{
    bench_note("%s: fused f32", wk->label);
    lrr_status s = lrr_solver_create(wk->op, LRR_BACKEND_CPU, &wk->solver);
    if (s == LRR_OK) /* the fused pass over dense F̄, whose floor this is (lrr-bench fbar) */
        s = lrr_solver_set_fbar(wk->solver, LRR_FBAR_DENSE);
    if (s != LRR_OK)
        return bench_lib_fail(wk->ctx, s, "solver");
    int rc = time_solver(wk->ctx, wk->solver, LRR_PATH_FULL, wk->e, NULL, wk->b32, wk->a->repeat,
                         &r->rows[RT_FUSED_F32]);
    if (rc)
        return rc;
    if (!finite_all(wk->b32, 3 * wk->n))
        return bench_fail("%s: fused f32 gave a non-finite B", wk->label);
    if ((rc = rt_pairs(wk, wk->solver, LRR_STORAGE_F32, &r->rows[RT_FUSED_F32])))
        return rc;
    if (wk->a->opencl) {
        bench_note("%s: fused f32 (OpenCL)", wk->label);
        if ((rc = time_cl(wk->ctx, wk->op, wk->e, wk->b, wk->a->repeat, &r->cl_rows[0])))
            return rc;
        bench_compare_b(wk->n, wk->area, wk->b, wk->b32, NULL, &r->cl_rows[0].rel_l2, NULL);
        r->have_cl = 1;
    }
    return 0;
}

/* The 16-bit pass as the solver chose it (M − I in binary16) against the same pass with M in
 * f32, in alternation: what halving M's bytes buys where M is a large part of a frame. */
static int rt_m_ab(rt_work *wk, const lrr_operator *op, lrr_solver *sv, rt_row *row)
{
    lrr_solver *s32 = NULL;
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_CPU, &s32);
    if (s == LRR_OK)
        s = lrr_solver_set_fbar(s32, LRR_FBAR_DENSE);
    if (s == LRR_OK)
        s = lrr_solver_set_m(s32, LRR_STORAGE_F32);
    if (s == LRR_OK)
        s = lrr_solver_set_path(s32, LRR_PATH_FULL);
    if (s != LRR_OK) {
        lrr_solver_destroy(s32);
        return bench_lib_fail(wk->ctx, s, "solver (M in f32)");
    }
    bench_note("%s: fused %s, M − I in binary16 against M in f32, %u pairs", wk->label,
               row->storage, RT_PAIRS);
    ours_frame a = {sv, wk->e, NULL, wk->b, LRR_OK, 0}, b = {s32, wk->e, NULL, wk->tmp, LRR_OK, 0};
    int rc = bench_ab(bench_ours_step, &a, bench_ours_step, &b, row->t.median, RT_PAIRS,
                      &row->m_ab);
    lrr_solver_destroy(s32);
    if (rc && (a.status != LRR_OK || b.status != LRR_OK))
        return bench_lib_fail(wk->ctx, a.status ? a.status : b.status, "lrr_solve (A/B)");
    return rc;
}

/* fused f16 and bf16, one solver each */
static int rt_fused_16bit(rt_work *wk, rt_cell *r)
{
    for (int j = 0; j < 2; j++) {
        rt_row *row = &r->rows[RT_FUSED_F16 + j];
        bench_note("%s: fused %s", wk->label, row->storage);
        lrr_solver *sv = NULL;
        lrr_status s = lrr_solver_create(wk->op16[j], LRR_BACKEND_CPU, &sv);
        if (s == LRR_OK)
            s = lrr_solver_set_fbar(sv, LRR_FBAR_DENSE);
        if (s != LRR_OK) {
            lrr_solver_destroy(sv);
            return bench_lib_fail(wk->ctx, s, "solver");
        }
        int rc = time_solver(wk->ctx, sv, LRR_PATH_FULL, wk->e, NULL, wk->b, wk->a->repeat, row);
        if (!rc)
            bench_compare_b(wk->n, wk->area, wk->b, wk->b32, NULL, &row->rel_l2, NULL);
        if (!rc)
            rc = rt_pairs(wk, sv, rt_storage[RT_FUSED_F16 + j], row);
        if (!rc)
            rc = rt_m_ab(wk, wk->op16[j], sv, row);
        lrr_solver_destroy(sv);
        if (rc)
            return rc;
        if (wk->a->opencl) {
            bench_note("%s: fused %s (OpenCL)", wk->label, row->storage);
            if ((rc = time_cl(wk->ctx, wk->op16[j], wk->e, wk->b, wk->a->repeat,
                              &r->cl_rows[1 + j])))
                return rc;
            bench_compare_b(wk->n, wk->area, wk->b, wk->b32, NULL, &r->cl_rows[1 + j].rel_l2, NULL);
        }
        lrr_operator_destroy(wk->op16[j]);
        wk->op16[j] = NULL;
    }
    return 0;
}

/* sparse: the scene's emission from cached columns */
static int rt_sparse(rt_work *wk, rt_cell *r)
{
    bench_note("%s: sparse path", wk->label);
    lrr_solver *sv = NULL;
    lrr_status s = lrr_solver_create(wk->op, LRR_BACKEND_CPU, &sv);
    if (s != LRR_OK)
        return bench_lib_fail(wk->ctx, s, "solver");
    int rc = time_solver(wk->ctx, sv, LRR_PATH_SPARSE, wk->e, NULL, wk->b, wk->a->repeat,
                         &r->rows[RT_SPARSE]);
    if (!rc)
        bench_compare_b(wk->n, wk->area, wk->b, wk->b32, NULL, &r->rows[RT_SPARSE].rel_l2, NULL);
    lrr_solver_destroy(sv);
    return rc;
}

/* incremental: x1 and x0.5 on alternate frames; B of an x1 frame against fused f32 */
static int rt_incremental(rt_work *wk, rt_cell *r)
{
    bench_note("%s: incremental path", wk->label);
    lrr_solver *sv = NULL;
    lrr_status s = lrr_solver_create(wk->op, LRR_BACKEND_CPU, &sv);
    if (s != LRR_OK)
        return bench_lib_fail(wk->ctx, s, "solver");
    int rc = time_solver(wk->ctx, sv, LRR_PATH_INCREMENTAL, wk->e, wk->e_half, wk->b,
                         wk->a->repeat, &r->rows[RT_INCREMENTAL]);
    if (rc)
        goto done;
    for (int tries = 0; tries < 4; tries++) {
        if ((s = lrr_solve(sv, wk->e_half, wk->tmp)) != LRR_OK ||
            (s = lrr_solve(sv, wk->e, wk->b)) != LRR_OK) {
            rc = bench_lib_fail(wk->ctx, s, "lrr_solve (incremental)");
            goto done;
        }
        if (lrr_solver_last_path(sv) == LRR_PATH_INCREMENTAL)
            break;
    }
    if (lrr_solver_last_path(sv) == LRR_PATH_INCREMENTAL)
        bench_compare_b(wk->n, wk->area, wk->b, wk->b32, NULL, &r->rows[RT_INCREMENTAL].rel_l2,
                        NULL);
    else
        bench_note("%s: the incremental path never served an x1 frame: rel_l2_vs_f32 is nan",
                   wk->label);
done:
    lrr_solver_destroy(sv);
    return rc;
}

/* the baselines: three sgemv and one sgemm with z_c = M_c Vᵀ E_c */
static int rt_baselines(rt_work *wk, rt_cell *r)
{
    const size_t n = wk->n, k = wk->k;
    bench_note("%s: sgemv3, sgemm3", wk->label);
    sgemv_frame sf = {0};
    float *z = bench_alloc_floats(3, k), *zt = bench_alloc_floats(k, 3);
    for (int ch = 0; ch < 3; ch++)
        sf.out[ch] = bench_alloc_floats(n, 1);
    int rc = 0;
    if (!z || !zt || !sf.out[0] || !sf.out[1] || !sf.out[2]) {
        rc = bench_fail("cannot allocate the sgemv vectors");
        goto done;
    }
    rt_make_z(wk->op, n, k, wk->d, wk->e, z);
    for (size_t p = 0; p < k; p++)
        for (int ch = 0; ch < 3; ch++)
            zt[3 * p + ch] = z[(size_t)ch * k + p];
    sf.n = (blasint)n;
    sf.k = (blasint)k;
    sf.fbar = sf.rows = bench_fbar_rows(wk->op);
    if (!sf.rows) {
        rc = bench_fail("cannot allocate a row-major copy of F̄");
        goto done;
    }
    for (int ch = 0; ch < 3; ch++)
        sf.z[ch] = z + (size_t)ch * k;
    if ((rc = rt_time(bench_sgemv_step, &sf, wk->a->repeat, &r->rows[RT_SGEMV3].t)))
        goto done;
    sgemm_frame gf = {(blasint)n, (blasint)k, sf.rows, zt, wk->b};
    rc = rt_time(sgemm_step, &gf, wk->a->repeat, &r->rows[RT_SGEMM3].t);
done:
    for (int ch = 0; ch < 3; ch++)
        lrr_aligned_free(sf.out[ch]);
    lrr_aligned_free(sf.rows);
    lrr_aligned_free(z);
    lrr_aligned_free(zt);
    return rc;
}

/* the paper's method */
static int rt_paper(rt_work *wk, rt_cell *r)
{
    bench_note("%s: the paper's method", wk->label);
    paper_frame pf = {0};
    int rc = bench_paper_setup(wk->op, wk->e, &pf);
    if (!rc)
        rc = rt_time(bench_paper_step, &pf, wk->a->repeat, &r->rows[RT_PAPER].t);
    if (!rc) {
        for (size_t i = 0; i < wk->n; i++)
            for (int ch = 0; ch < 3; ch++)
                wk->b[3 * i + ch] = pf.b[ch][i];
        bench_compare_b(wk->n, wk->area, wk->b, wk->b32, NULL, &r->rows[RT_PAPER].rel_l2, NULL);
    }
    bench_paper_free(&pf);
    return rc;
}

/* lrr_solve_batch: 16 frames, the emission scaled by 1/16, 2/16, ..., 1 */
static int rt_batch(rt_work *wk, rt_cell *r)
{
    const size_t n = wk->n;
    bench_note("%s: lrr_solve_batch (%d frames)", wk->label, RT_BATCH);
    float *be = cli_alloc_rgb(n * RT_BATCH), *bb = cli_alloc_rgb(n * RT_BATCH);
    int rc = 0;
    if (!be || !bb) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    for (size_t f = 0; f < RT_BATCH; f++)
        for (size_t i = 0; i < 3 * n; i++)
            be[f * 3 * n + i] = wk->e[i] * (float)(f + 1) / (float)RT_BATCH;
    batch_frame bf = {wk->solver, be, bb, LRR_OK};
    if (rt_time(batch_step, &bf, wk->a->repeat, &r->batch)) {
        rc = bf.status != LRR_OK ? bench_lib_fail(wk->ctx, bf.status, "lrr_solve_batch")
                                 : CLI_EXIT_FAIL;
        goto done;
    }
    r->batch_ms_per_frame = r->batch.median / RT_BATCH;
    bench_compare_b(n, wk->area, bb + (RT_BATCH - 1) * 3 * n, wk->b32, NULL, &r->batch_rel_l2,
                    NULL);
done:
    free(be);
    free(bb);
    return rc;
}

/* A floor's bandwidth becomes candidate (from source name) where that is higher; NAN never. */
static void take_faster(double *bw, const char **source, double candidate, const char *name)
{
    if (candidate > *bw) {
        *bw = candidate;
        *source = name;
    }
}

/* The floors, the ratios to them and to the paper's method, the bytes each row reads. */
static void rt_floors(const rt_args *a, size_t n, size_t k, rt_cell *r)
{
    /* the floor's bandwidth: the best of the tuned read kernel and of what OpenBLAS sgemv
     * itself streams over this matrix, so no baseline can run below its own floor */
    const double f32_bytes = storage_bytes(n, k, LRR_STORAGE_F32), m32_bytes = 12.0 * k * k;
    r->fits_llc = a->llc > 0 && f32_bytes <= (double)a->llc;
    r->bw_kernel = a->bandwidth;
    r->bw = a->bandwidth;
    r->bw_source = "read-kernel";
    if (r->rows[RT_SGEMV3].t.median > 0) {
        r->bw_sgemv3 = 3.0 * f32_bytes / (r->rows[RT_SGEMV3].t.median / 1e3);
        take_faster(&r->bw, &r->bw_source, r->bw_sgemv3, "sgemv3");
    }
    /* A matrix the last-level cache holds is read from the cache, warm, frame after frame:
     * its floor is the read loops over as many bytes, repeated the same way (a 260 MiB L3
     * holds every cell of the paper's table; the DRAM loop alone would put the floor too
     * low). */
    r->bw_resident = r->bw_resident16 = NAN;
    if (r->fits_llc) {
        r->bw_resident = bench_measure_bandwidth((size_t)f32_bytes);
        r->bw_resident16 = bench_measure_bandwidth((size_t)(f32_bytes / 2));
        take_faster(&r->bw, &r->bw_source, r->bw_resident, "resident-read");
    }
    r->bw16 = r->bw;
    r->bw16_source = r->bw_source;
    take_faster(&r->bw16, &r->bw16_source, r->bw_resident16, "resident-read");
    const double paper_ms = r->rows[RT_PAPER].t.median;
    for (int i = 0; i < RT_COUNT; i++) {
        rt_row *w = &r->rows[i];
        const lrr_storage st = rt_storage[i];
        const double fb = storage_bytes(n, k, st);
        const double bw = st == LRR_STORAGE_F32 ? r->bw : r->bw16;
        const double m_bytes = w->m_bytes > 0 ? w->m_bytes : m32_bytes; /* as the row read M */
        w->floor_ms = bw > 0 ? 1e3 * fb / bw : NAN;
        w->floor_ms_full = bw > 0 ? 1e3 * (fb + m_bytes) / bw : NAN;
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
}

int rt_cell_run(lrr_context *ctx, const rt_args *a, const cell *c, size_t index, rt_cell *r)
{
    rt_cell_init(r, c);
    rt_work wk = {.ctx = ctx, .a = a};
    snprintf(wk.label, sizeof wk.label, "[%zu/%zu] %zu×%zu (d %zu)", index + 1, a->n_cells, c->n,
             c->k, c->d);
    int rc;
    if ((rc = rt_build(&wk, c, r)) || (rc = rt_copies(&wk, r)) || (rc = rt_buffers(&wk)) ||
        (rc = rt_fused_f32(&wk, r)) || (rc = rt_fused_16bit(&wk, r)) ||
        (rc = rt_sparse(&wk, r)) || (rc = rt_incremental(&wk, r)) ||
        (rc = rt_baselines(&wk, r)) || (rc = rt_paper(&wk, r)) || (rc = rt_batch(&wk, r)))
        goto done;
    rt_floors(a, wk.n, wk.k, r);
done:
    lrr_solver_destroy(wk.solver);
    lrr_operator_destroy(wk.op16[0]);
    lrr_operator_destroy(wk.op16[1]);
    lrr_operator_destroy(wk.op);
    free(wk.b32);
    free(wk.b);
    free(wk.e_half);
    free(wk.tmp);
    return rc;
}
