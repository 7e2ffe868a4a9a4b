/*
 * lrr-bench table, one cell (table.c has the command, its options and its output): the
 * operator built for the cell, the real-time step timed (ours, on OpenCL, the default path,
 * the paper's method, three sgemv) and the error against the full n×n solution.
 */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

#define PAPER_MATCH_TOL 1e-4

static int reference_error(lrr_context *ctx, const lrr_scene *scene,
                           const lrr_build_options *bo, size_t budget, const float *b,
                           cell_result *r, const char *label)
{
    size_t need = lrr_reference_bytes(r->n);
    if (need == SIZE_MAX || need > budget) {
        char nb[32], bb[32];
        snprintf(r->note, sizeof r->note, "n×n needs %s > budget %s",
                 need == SIZE_MAX ? "more than SIZE_MAX bytes"
                                  : bench_fmt_bytes(nb, sizeof nb, need),
                 bench_fmt_bytes(bb, sizeof bb, budget));
        return 0;
    }
    lrr_reference *ref = NULL;
    cli_progress bar;
    lrr_build_options o = *bo;
    bench_note("%s: reference: n×n form factors (%.1f MB)", label, (double)need / MB);
    bench_progress_begin(&bar, "n×n hemicubes", &o);
    double t0 = cli_now();
    lrr_status s = lrr_reference_build(scene, &o, budget, &ref);
    cli_progress_finish(&bar);
    if (s == LRR_ERR_BUDGET) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        snprintf(r->note, sizeof r->note, "reference refused: %s", msg);
        return 0;
    }
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "reference build");
    float *bref = cli_alloc_rgb(r->n);
    if (!bref) {
        lrr_reference_destroy(ref);
        return CLI_EXIT_FAIL;
    }
    lrr_reference_stats st = {0};
    s = lrr_reference_solve(ref, LRR_METHOD_GAUSS_SEIDEL, REFERENCE_TOL, 0,
                            lrr_reference_emission(ref), bref, &st, sizeof st);
    r->reference_s = cli_now() - t0;
    r->reference_residual = st.residual;
    if (s != LRR_OK && s != LRR_NOT_CONVERGED) {
        free(bref);
        lrr_reference_destroy(ref);
        return bench_lib_fail(ctx, s, "Gauss-Seidel reference solve");
    }
    if (s == LRR_NOT_CONVERGED) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        snprintf(r->note, sizeof r->note, "Gauss-Seidel stopped at residual %.2g after %zu",
                 st.residual, st.iterations);
    }
    bench_note("%s: reference: Gauss-Seidel %zu sweeps, residual %.2g, %.2f s (%.1f s with F)",
               label, st.iterations, st.residual, st.seconds, r->reference_s);
    const float *area = lrr_reference_area(ref);
    bench_compare_b(r->n, area, b, bref, NULL, &r->rel_l2, &r->max_rel);
    bench_compare_b(r->n, area, b, bref, lrr_reference_emission(ref), &r->rel_l2_reflected, NULL);
    free(bref);
    lrr_reference_destroy(ref);
    return 0;
}

/* ---------------------------------------------------------------- one cell */
/* Every measurement nan (the device "cpu") until taken. */
static void cell_init(cell_result *r, const cell *c, double bandwidth)
{
    memset(r, 0, sizeof *r);
    r->target = *c;
    r->rel_l2 = r->max_rel = r->rel_l2_reflected = r->reference_s = NAN;
    r->reference_residual = r->paper_vs_ours = r->floor_ms = r->floor_ms_full = NAN;
    r->threads = omp_get_max_threads();
    r->ocl.median = r->ocl.min = r->ocl.max = NAN;
    r->ocl_kernel_ms = r->ocl_transfer_ms = r->ocl_ratio = NAN;
    snprintf(r->ocl_device, sizeof r->ocl_device, "cpu");
    r->bandwidth_gbs = bandwidth / 1e9;
}

/* Subdivides the scene for the cell and builds the operator (*op, stored as float) with the
 * options *bo (kept for the reference, without the progress bar). */
static int cell_build(lrr_context *ctx, const table_args *a, const cell *c, const char *label,
                      lrr_scene *scene, lrr_build_options *bo, lrr_operator **op,
                      cell_result *r)
{
    lrr_subdivision sub = {.target_patches = c->k, .levels = (unsigned)bench_levels_of(c->d)};
    lrr_status s = lrr_scene_subdivide(scene, &sub);
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "subdivision");
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    r->n = si.subpatches;
    r->k = si.patches;
    r->d = si.d;
    snprintf(r->label, sizeof r->label, "%zu×%zu", r->n, r->k);
    bench_note("%s: %zu patches, %zu subpatches; building the operator (hemicube %u)", label, r->k,
               r->n, a->hemicube);

    *bo = (lrr_build_options){.hemicube_resolution = a->hemicube, .seed = a->seed};
    cli_progress bar;
    bench_progress_begin(&bar, "hemicubes", bo);
    double t0 = cli_now();
    s = lrr_operator_build(scene, bo, op);
    r->preprocess_s = cli_now() - t0;
    cli_progress_finish(&bar);
    bo->progress = NULL;
    bo->progress_user = NULL;
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "operator build");
    lrr_operator_info oi;
    lrr_operator_get_info(*op, &oi, sizeof oi);
    memcpy(r->cond, oi.condition, sizeof r->cond);
    return 0;
}

/* The memory of ours and of the paper's method, and the floors at `bandwidth`. */
static void cell_memory(cell_result *r, double bandwidth)
{
    double nk = (double)r->n * (double)r->k;
    r->mem_mb = (nk + 3.0 * (double)r->k * (double)r->k) * sizeof(float) / MB;
    r->mem_mb_paper = 2.0 * nk * sizeof(float) / MB;
    r->mem_mib_paper = 2.0 * nk * sizeof(float) / (1024.0 * 1024.0);
    /* every method reads F̄ (or Y) once; our full path also reads the three M_c */
    r->floor_ms = bandwidth > 0 ? 1e3 * nk * sizeof(float) / bandwidth : NAN;
    r->floor_ms_full = bandwidth > 0 ? 1e3 * r->mem_mb * MB / bandwidth : NAN;
}

/* ours: lrr_solve forced to the full path, B in b (*solver is kept for the default path) */
static int time_ours(lrr_context *ctx, const table_args *a, const lrr_operator *op,
                     const float *e, float *b, const char *label, lrr_solver **solver,
                     cell_result *r)
{
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_CPU, solver);
    if (s == LRR_OK) /* the dense pass the paper's table compares (lrr-bench fbar: sparse) */
        s = lrr_solver_set_fbar(*solver, LRR_FBAR_DENSE);
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "solver");
    snprintf(r->kernel, sizeof r->kernel, "%s", lrr_solver_kernel(*solver));
    if ((s = lrr_solver_set_path(*solver, LRR_PATH_FULL)) != LRR_OK)
        return bench_lib_fail(ctx, s, "solver path");
    ours_frame of = {*solver, e, NULL, b, LRR_OK, 0};
    if (bench_time_frames(bench_ours_step, &of, a->repeat, &r->ours))
        return of.status != LRR_OK ? bench_lib_fail(ctx, of.status, "lrr_solve") : CLI_EXIT_FAIL;
    if (lrr_solver_last_path(*solver) != LRR_PATH_FULL)
        return bench_fail("%s: lrr_solve took the %s path, not the full one it was told to",
                          label, bench_path_name(lrr_solver_last_path(*solver)));
    return 0;
}

/* the OpenCL solver, f32, full path (its own B buffer; ours stays the reference) */
static int time_opencl(lrr_context *ctx, const table_args *a, const lrr_operator *op,
                       const float *e, const char *label, cell_result *r)
{
    int rc = 0;
    lrr_status s;
    lrr_solver *cls = NULL;
    float *bcl = cli_alloc_rgb(r->n);
    cl_frame cf = {{NULL, e, NULL, bcl, LRR_OK, 0}, NULL, NULL, 0, 0};
    cf.cap = 3 + (a->repeat ? a->repeat : MAX_RUNS);
    cf.kernel_ms = malloc(cf.cap * sizeof *cf.kernel_ms);
    cf.transfer_ms = malloc(cf.cap * sizeof *cf.transfer_ms);
    if (!bcl || !cf.kernel_ms || !cf.transfer_ms)
        rc = bench_fail("cannot allocate the OpenCL timings");
    else if ((s = lrr_solver_create(op, LRR_BACKEND_OPENCL, &cls)) != LRR_OK)
        rc = bench_lib_fail(ctx, s, "OpenCL solver");
    else {
        bench_note("%s: ours on %s", label, lrr_solver_kernel(cls));
        bench_cl_device_name(cls, r->ocl_device, sizeof r->ocl_device);
        cf.of.solver = cls;
        if (bench_time_frames(bench_cl_step, &cf, a->repeat, &r->ocl))
            rc = cf.of.status != LRR_OK ? bench_lib_fail(ctx, cf.of.status, "lrr_solve (OpenCL)")
                                        : CLI_EXIT_FAIL;
        else {
            bench_cl_medians(&cf, r->ocl.runs, &r->ocl_kernel_ms, &r->ocl_transfer_ms);
            r->ocl_ratio = r->ours.median / r->ocl.median;
            r->have_cl = 1;
        }
    }
    lrr_solver_destroy(cls);
    free(bcl);
    free(cf.kernel_ms);
    free(cf.transfer_ms);
    return rc;
}

/* the default path, for an emission that changes every frame (into its own buffer) */
static int time_auto(lrr_context *ctx, const table_args *a, lrr_solver *solver,
                     const float *e, cell_result *r)
{
    float *e_half = cli_alloc_rgb(r->n), *b_auto = cli_alloc_rgb(r->n);
    if (!e_half || !b_auto) {
        free(e_half);
        free(b_auto);
        return CLI_EXIT_FAIL;
    }
    for (size_t i = 0; i < 3 * r->n; i++)
        e_half[i] = 0.5f * e[i];
    ours_frame af = {solver, e, e_half, b_auto, LRR_OK, 0};
    lrr_status s;
    if ((s = lrr_solver_set_path(solver, LRR_PATH_AUTO)) != LRR_OK)
        af.status = s;
    int arc = s != LRR_OK || bench_time_frames(bench_ours_step, &af, a->repeat, &r->ours_auto);
    snprintf(r->auto_path, sizeof r->auto_path, "%s",
             bench_path_name(lrr_solver_last_path(solver)));
    free(e_half);
    free(b_auto);
    if (arc)
        return bench_lib_fail(ctx, af.status, "lrr_solve (auto path)");
    return 0;
}

/* The paper's B against ours (b): the same operator, so they must agree. Returns 0, or
 * CLI_EXIT_FAIL having printed the disagreement. */
static int paper_check(const paper_frame *pf, const float *b, const char *label,
                       cell_result *r)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < r->n; i++)
        for (int ch = 0; ch < 3; ch++) {
            double dlt = (double)pf->b[ch][i] - b[3 * i + ch];
            num += dlt * dlt;
            den += (double)b[3 * i + ch] * b[3 * i + ch];
        }
    r->paper_vs_ours = den > 0 ? sqrt(num / den) : sqrt(num);
    if (!(r->paper_vs_ours < PAPER_MATCH_TOL))
        return bench_fail("error: %s: the paper's method and lrr_solve disagree: relative "
                          "L2 %.3g >= %g (they are the same operator)",
                          label, r->paper_vs_ours, PAPER_MATCH_TOL);
    return 0;
}

/* three plain sgemv, with z_c = M_c Vᵀ E_c as the vectors (from the paper's V, which is freed
 * with its Y before the timing) */
static int time_sgemv3(const table_args *a, const lrr_operator *op, paper_frame *pf,
                       sgemv_frame *sf, cell_result *r)
{
    sf->n = pf->n;
    sf->k = pf->k;
    sf->fbar = sf->rows = bench_fbar_rows(op);
    if (!sf->rows)
        return bench_fail("cannot allocate a row-major copy of F̄");
    for (int ch = 0; ch < 3; ch++) {
        sf->z[ch] = bench_alloc_floats(r->k, 1);
        sf->out[ch] = pf->b[ch]; /* reuse: the paper's check is done */
        if (!sf->z[ch])
            return bench_fail("cannot allocate z");
        cblas_sgemv(CblasRowMajor, CblasTrans, pf->n, pf->k, 1.0f, pf->v, pf->k, pf->e[ch], 1,
                    0.0f, pf->w, 1);
        cblas_sgemv(CblasRowMajor, CblasNoTrans, pf->k, pf->k, 1.0f,
                    lrr_operator_m(op) + (size_t)ch * r->k * r->k, pf->k, pf->w, 1, 0.0f,
                    sf->z[ch], 1);
    }
    lrr_aligned_free(pf->v); /* V and Y are not needed any more */
    pf->v = NULL;
    for (int ch = 0; ch < 3; ch++) {
        lrr_aligned_free(pf->y[ch]);
        pf->y[ch] = NULL;
    }
    return bench_time_frames(bench_sgemv_step, sf, a->repeat, &r->sgemv3);
}

int run_cell(lrr_context *ctx, const table_args *a, const cell *c, size_t index,
             double bandwidth, cell_result *r)
{
    cell_init(r, c, bandwidth);
    char label[96];
    snprintf(label, sizeof label, "[%zu/%zu] %zu×%zu (d %zu)", index + 1, a->n_cells, c->n, c->k,
             c->d);

    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    lrr_solver *solver = NULL;
    float *b = NULL;
    paper_frame pf = {0};
    sgemv_frame sf = {0};
    lrr_build_options bo;
    int rc = bench_open_scene(ctx, a->scene, &scene);
    if (rc)
        return rc;
    if ((rc = cell_build(ctx, a, c, label, scene, &bo, &op, r)))
        goto done;
    cell_memory(r, bandwidth);
    bench_note("%s: operator built in %.2f s; timing the real-time step", label, r->preprocess_s);

    /* ours, on OpenCL, the default path */
    const float *e = lrr_operator_emission(op);
    b = cli_alloc_rgb(r->n);
    if (!b) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    if ((rc = time_ours(ctx, a, op, e, b, label, &solver, r)) ||
        (a->opencl && (rc = time_opencl(ctx, a, op, e, label, r))) ||
        (rc = time_auto(ctx, a, solver, e, r)))
        goto done;
    for (size_t i = 0; i < 3 * r->n; i++)
        if (!isfinite(b[i])) {
            rc = bench_fail("%s: lrr_solve gave a non-finite value at subpatch %zu", label,
                            i / 3);
            goto done;
        }

    /* the paper's method; a disagreement with ours is reported and the cell carries on */
    if ((rc = bench_paper_setup(op, e, &pf)))
        goto done;
    if ((rc = bench_time_frames(bench_paper_step, &pf, a->repeat, &r->paper)))
        goto done;
    rc = paper_check(&pf, b, label, r);
    int rc3 = time_sgemv3(a, op, &pf, &sf, r);
    if (rc3) {
        rc = rc3;
        goto done;
    }
    bench_note("%s: ms ours %.3f (auto %.3f, %s), paper %.3f, 3 sgemv %.3f", label, r->ours.median,
               r->ours_auto.median, r->auto_path, r->paper.median, r->sgemv3.median);

    /* error against the n×n reference (the paper arrays are freed first) */
    for (int ch = 0; ch < 3; ch++) {
        lrr_aligned_free(sf.z[ch]);
        sf.z[ch] = NULL;
    }
    bench_paper_free(&pf);
    lrr_solver_destroy(solver);
    solver = NULL;
    int rce = reference_error(ctx, scene, &bo, a->budget, b, r, label);
    if (rce)
        rc = rce;
done:
    for (int ch = 0; ch < 3; ch++)
        lrr_aligned_free(sf.z[ch]);
    lrr_aligned_free(sf.rows);
    bench_paper_free(&pf);
    lrr_solver_destroy(solver);
    free(b);
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    return rc;
}
