/* lrr-bench fbar --backend opencl: the OpenCL solver reading F̄ dense and as strips
 * (lib/solve/opencl.c, realtime.cl fbar_strips), each pass's kernel time against the
 * device's read floor measured in the same run: a plain read kernel (below) over a
 * buffer of the bytes the pass reads, the best of FLOOR_RUNS. */
#include "bench.h"
#include "config.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define WARMUPS 3 /* untimed frames per solver */

#ifdef LRR_HAVE_OPENCL
#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#define FLOOR_RUNS 5
#define FLOOR_ITEMS 2048 /* work-items per compute unit: enough loads in flight on a GPU */

/* every 16-byte word read once, grid-strided (coalesced), one value per item written */
static const char read_src[] =
    "__kernel void read_floor(__global const uint4 *buf, ulong words, __global uint *out)\n"
    "{\n"
    "    const size_t id = get_global_id(0), step = get_global_size(0);\n"
    "    uint4 acc = (uint4)(0, 0, 0, 0);\n"
    "    for (size_t j = id; j < words; j += step)\n"
    "        acc ^= buf[j];\n"
    "    out[id] = acc.x ^ acc.y ^ acc.z ^ acc.w;\n"
    "}\n";

/* The device whose name the solver reports ("opencl:<name>"). */
static cl_device_id find_device(const char *solver_name)
{
    const char *want = strncmp(solver_name, "opencl:", 7) == 0 ? solver_name + 7 : solver_name;
    cl_platform_id plat[16];
    cl_uint np = 0;
    if (clGetPlatformIDs(16, plat, &np) != CL_SUCCESS)
        return NULL;
    for (cl_uint p = 0; p < np && p < 16; p++) {
        cl_device_id dev[16];
        cl_uint nd = 0;
        if (clGetDeviceIDs(plat[p], CL_DEVICE_TYPE_ALL, 16, dev, &nd) != CL_SUCCESS)
            continue;
        for (cl_uint d = 0; d < nd && d < 16; d++) {
            char name[128] = "";
            clGetDeviceInfo(dev[d], CL_DEVICE_NAME, sizeof name - 1, name, NULL);
            if (strcmp(name, want) == 0)
                return dev[d];
        }
    }
    return NULL;
}

/* ms of the fastest read of `bytes` on the device, NAN when it could not be measured */
static double read_floor_ms(const char *solver_name, size_t bytes)
{
    cl_device_id dev = find_device(solver_name);
    if (!dev || bytes < 16)
        return NAN;
    cl_int err;
    cl_uint cu = 1;
    clGetDeviceInfo(dev, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof cu, &cu, NULL);
    cl_context cx = clCreateContext(NULL, 1, &dev, NULL, NULL, &err);
    cl_command_queue q = err ? NULL : clCreateCommandQueue(cx, dev, CL_QUEUE_PROFILING_ENABLE, &err);
    const char *src = read_src;
    cl_program pr = err ? NULL : clCreateProgramWithSource(cx, 1, &src, NULL, &err);
    if (!err)
        err = clBuildProgram(pr, 1, &dev, NULL, NULL, NULL);
    cl_kernel kn = err ? NULL : clCreateKernel(pr, "read_floor", &err);
    const cl_ulong words = bytes / 16;
    size_t items = (size_t)cu * FLOOR_ITEMS;
    if (items > words)
        items = (size_t)words;
    cl_mem buf = err ? NULL : clCreateBuffer(cx, CL_MEM_READ_ONLY, words * 16, NULL, &err);
    cl_mem out = err ? NULL : clCreateBuffer(cx, CL_MEM_WRITE_ONLY, items * 4, NULL, &err);
    const cl_uint pattern = 0x3c003c00u;
    if (!err)
        err = clEnqueueFillBuffer(q, buf, &pattern, sizeof pattern, 0, words * 16, 0, NULL, NULL);
    if (!err && !(err = clSetKernelArg(kn, 0, sizeof buf, &buf)) &&
        !(err = clSetKernelArg(kn, 1, sizeof words, &words)))
        err = clSetKernelArg(kn, 2, sizeof out, &out);
    double best = INFINITY;
    for (int r = 0; r < FLOOR_RUNS + 1 && !err; r++) { /* the first run warms up */
        cl_event ev;
        cl_ulong t0 = 0, t1 = 0;
        if ((err = clEnqueueNDRangeKernel(q, kn, 1, NULL, &items, NULL, 0, NULL, &ev)))
            break;
        if (!(err = clWaitForEvents(1, &ev)) &&
            !(err = clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL)))
            err = clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL);
        clReleaseEvent(ev);
        if (!err && r > 0)
            best = fmin(best, (double)(t1 - t0) * 1e-6);
    }
    if (out)
        clReleaseMemObject(out);
    if (buf)
        clReleaseMemObject(buf);
    if (kn)
        clReleaseKernel(kn);
    if (pr)
        clReleaseProgram(pr);
    if (q)
        clReleaseCommandQueue(q);
    if (cx)
        clReleaseContext(cx);
    return err ? NAN : best;
}
#else
static double read_floor_ms(const char *solver_name, size_t bytes)
{
    (void)solver_name, (void)bytes;
    return NAN;
}
#endif

typedef struct cl_row {
    lrr_solver_info info;
    double kernel_ms, transfer_ms, wall_ms, floor_ms, b_diff;
    size_t bytes; /* what the kernels read: F̄ as held, M, E, rho, B */
    char device[160];
} cl_row;

/* One OpenCL solver reading F̄ as `format` (strip groups g when sparse, 0: the default):
 * `frames` timed frames after WARMUPS, medians; B against ref. */
static int measure_cl(lrr_context *ctx, const lrr_operator *op, lrr_fbar_format format,
                      unsigned g, const float *e, const float *ref, float *b, unsigned frames,
                      cl_row *row)
{
    char env[16];
    snprintf(env, sizeof env, "%u", g);
    if (g)
        setenv("LRR_OPENCL_STRIP_GROUPS", env, 1);
    lrr_solver *sv = NULL;
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_OPENCL, &sv);
    unsetenv("LRR_OPENCL_STRIP_GROUPS");
    if (!s)
        s = lrr_solver_set_fbar(sv, format);
    double *t = s ? NULL : malloc(3 * (size_t)frames * sizeof *t);
    int rc = s ? bench_lib_fail(ctx, s, "OpenCL solver") : !t ? bench_fail("out of memory") : 0;
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    for (unsigned f = 0; f < WARMUPS + frames && !rc; f++) {
        const double t0 = cli_now();
        if ((s = lrr_solve(sv, e, b)) != LRR_OK) {
            rc = bench_lib_fail(ctx, s, "lrr_solve (OpenCL)");
            break;
        }
        if (f < WARMUPS)
            continue;
        t[f - WARMUPS] = 1e3 * (cli_now() - t0);
        if ((s = lrr_solver_timings(sv, &t[frames + f - WARMUPS], &t[2 * frames + f - WARMUPS])))
            rc = bench_lib_fail(ctx, s, "lrr_solver_timings");
    }
    if (!rc) {
        lrr_solver_get_info(sv, &row->info, sizeof row->info);
        bench_cl_device_name(sv, row->device, sizeof row->device);
        row->wall_ms = cli_median(t, frames);
        row->kernel_ms = cli_median(t + frames, frames);
        row->transfer_ms = cli_median(t + 2 * frames, frames);
        row->b_diff = bench_max_rel(3 * oi.n, b, ref);
        row->bytes = row->info.fbar_bytes + row->info.m_bytes + 36 * oi.n;
        row->floor_ms = read_floor_ms(lrr_solver_kernel(sv), row->bytes);
    }
    free(t);
    lrr_solver_destroy(sv);
    return rc;
}

static void print_cl(const char *what, const cl_row *r)
{
    const double gbs = r->bytes / (r->kernel_ms * 1e6), floor_gbs = r->bytes / (r->floor_ms * 1e6);
    printf("  %-18s %8.1f MB  kernels %8.4f ms (%6.0f GB/s, %.2f× the read floor: %.4f ms, "
           "%.0f GB/s)  transfer %.4f ms  frame %.4f ms  b_diff %.2e\n",
           what, r->bytes / 1e6, r->kernel_ms, gbs, r->kernel_ms / r->floor_ms, r->floor_ms,
           floor_gbs, r->transfer_ms, r->wall_ms, r->b_diff);
}

static void csv_cl(FILE *f, const char *file, lrr_storage st, const char *what, const cl_row *r)
{
    fprintf(f, "%s,%s,%s,", file, lrr_storage_name(st), what);
    const double v[] = {r->bytes / 1e6, r->kernel_ms, r->floor_ms, r->kernel_ms / r->floor_ms,
                        r->transfer_ms, r->wall_ms, r->b_diff};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++)
        bench_csv_num(f, v[i], 0);
    fprintf(f, "%s\n", r->device);
}

int bench_fbar_opencl(lrr_context *ctx, const lrr_operator *op, const float *e, const char *file,
                      lrr_storage st, const unsigned *groups, int n_groups, unsigned frames,
                      FILE *csv)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *ref = bench_alloc_floats(oi.n, 3), *b = bench_alloc_floats(oi.n, 3);
    lrr_solver *cpu = NULL;
    int rc = !ref || !b ? bench_fail("out of memory for B (n = %zu)", oi.n) : 0;
    lrr_status s = rc ? LRR_OK : lrr_solver_create(op, LRR_BACKEND_CPU, &cpu);
    if (!s && !rc && !(s = lrr_solver_set_fbar(cpu, LRR_FBAR_DENSE)) &&
        !(s = lrr_solver_set_path(cpu, LRR_PATH_FULL)))
        s = lrr_solve(cpu, e, ref);
    if (s)
        rc = bench_lib_fail(ctx, s, "CPU reference");
    lrr_solver_destroy(cpu);
    cl_row row;
    if (!rc && !(rc = measure_cl(ctx, op, LRR_FBAR_DENSE, 0, e, ref, b, frames, &row))) {
        printf("%s %s (n %zu, k %zu) on %s: density %.4f (strips %.4f); kernels' bytes: F̄ as "
               "held + M + E, rho, B\n",
               file, lrr_storage_name(st), oi.n, oi.k, row.device, row.info.fbar_density,
               row.info.fbar_strip_density);
        print_cl("dense", &row);
        if (csv)
            csv_cl(csv, file, st, "dense", &row);
    }
    for (int i = 0; i < n_groups && !rc; i++) {
        char what[32], impl[32];
        snprintf(what, sizeof what, "sparse, %u groups", groups[i]);
        snprintf(impl, sizeof impl, "sparse_g%u", groups[i]);
        if (!(rc = measure_cl(ctx, op, LRR_FBAR_SPARSE, groups[i], e, ref, b, frames, &row))) {
            print_cl(what, &row);
            if (csv)
                csv_cl(csv, file, st, impl, &row);
        }
    }
    fflush(stdout);
    lrr_aligned_free(ref);
    lrr_aligned_free(b);
    return rc;
}
