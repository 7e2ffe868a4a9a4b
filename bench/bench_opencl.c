/*
 * lrr-bench: --backend opencl: the probe that fails early without a device, the start of a
 * table or realtime run, and the OpenCL solver's per-frame timings.
 */
#include <math.h>
#include <stdio.h>

#include "bench.h"

/* ------------------------------------------------------------------ OpenCL */
int bench_parse_backend(const char *prog, const char *text, int *opencl)
{
    lrr_backend b;
    if (cli_parse_backend(prog, text, &b) != 0)
        return -1;
    *opencl = b == LRR_BACKEND_OPENCL;
    return 0;
}

int bench_opencl_probe(lrr_context *ctx)
{
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, rho[3] = {0.5f, 0.5f, 0.5f},
                em[3] = {1, 1, 1};
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    lrr_solver *sv = NULL;
    lrr_subdivision sd = {0};
    lrr_status s = lrr_scene_create(ctx, 1, v, rho, em, "opencl-probe", &scene);
    if (s == LRR_OK)
        s = lrr_scene_subdivide(scene, &sd);
    if (s == LRR_OK)
        s = lrr_operator_build(scene, NULL, &op);
    if (s != LRR_OK) {
        lrr_scene_destroy(scene);
        return bench_lib_fail(ctx, s, "--backend opencl: probe operator");
    }
    lrr_scene_destroy(scene);
    s = lrr_solver_create(op, LRR_BACKEND_OPENCL, &sv);
    int rc = s == LRR_OK ? CLI_EXIT_OK : bench_lib_fail(ctx, s, "--backend opencl");
    lrr_solver_destroy(sv);
    lrr_operator_destroy(op);
    return rc;
}

int bench_start(const char *scene, int opencl, lrr_context **out)
{
    *out = NULL;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return bench_lib_fail(NULL, s, "context");
    /* a scene that cannot be read fails now, not after the bandwidth measurement */
    lrr_scene *probe = NULL;
    int rc = bench_open_scene(ctx, scene, &probe);
    lrr_scene_destroy(probe);
    if (rc == CLI_EXIT_OK && opencl)
        rc = bench_opencl_probe(ctx);
    if (rc != CLI_EXIT_OK) {
        lrr_context_destroy(ctx);
        return rc;
    }
    *out = ctx;
    return CLI_EXIT_OK;
}

int bench_cl_step(void *user)
{
    cl_frame *f = user;
    if (bench_ours_step(&f->of))
        return 1;
    double km = NAN, tm = NAN;
    if ((f->of.status = lrr_solver_timings(f->of.solver, &km, &tm)) != LRR_OK)
        return 1;
    if (f->count < f->cap) {
        f->kernel_ms[f->count] = km;
        f->transfer_ms[f->count] = tm;
        f->count++;
    }
    return 0;
}

void bench_cl_medians(cl_frame *f, size_t runs, double *kernel_ms, double *transfer_ms)
{
    if (runs > f->count)
        runs = f->count;
    if (!runs) {
        *kernel_ms = *transfer_ms = NAN;
        return;
    }
    const size_t first = f->count - runs;
    *kernel_ms = cli_median(f->kernel_ms + first, runs);
    *transfer_ms = cli_median(f->transfer_ms + first, runs);
}

const char *bench_cl_device_name(const lrr_solver *s, char *buf, size_t len)
{
    snprintf(buf, len, "%s", lrr_solver_kernel(s));
    for (char *p = buf; *p; p++)
        if (*p == ',' || *p == '\n' || *p == '"')
            *p = ';';
    return buf;
}
