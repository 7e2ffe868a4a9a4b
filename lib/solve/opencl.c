/* The real-time step on an OpenCL device (lrr_solver_create with LRR_BACKEND_OPENCL).
 *
 * Our own kernels (lib/solve/realtime.cl, embedded at build time as lrr__kernel_realtime_cl)
 * rather than clBLAS: the three steps are a segmented sum, three k×k products and one n×k
 * product whose epilogue E + rho ∘ (…) is fused, with F̄ decoded from 16 bits in the loads.
 * F̄ (in its storage), its row scales, M and rho go to the device once, at create; per frame
 * E goes up, three kernels run on the solver's in-order queue, and B comes down.
 * F̄ goes up dense or, where that reads at most half the bytes (lrr_solver_set_fbar, the
 * CPU's rule), as the strips of lib/solve/sparse.c, read by fbar_strips; only one of the
 * two is held on the device.
 * Every frame is a full pass: the CPU's sparse and incremental paths stay on the CPU.
 * The queue has CL_QUEUE_PROFILING_ENABLE: each frame's kernel time (the three kernels'
 * END - START) and transfer time (E up, B down) are kept for lrr_solver_timings.
 *
 * Device choice: the first GPU over all platforms, else the first CPU device; the environment
 * variable LRR_OPENCL_DEVICE overrides it with "P:D" (platform and device index) or a
 * substring matched case-insensitively against "platform name / device name".
 * Only the OpenCL 1.2 API is used.
 */
#include "config.h"
#include "solve/solve.h"

#include <stdlib.h>
#include <string.h>

#ifndef LRR_HAVE_OPENCL

lrr_status lrr__cl_create(const lrr_operator *op, lrr_fbar_format format,
                          lrr__sparse_stats *stats, lrr__cl_solver **out)
{
    (void)format;
    memset(stats, 0, sizeof *stats);
    *out = NULL;
    return lrr__error(op->ctx, LRR_ERR_UNSUPPORTED,
                      "the OpenCL backend is not built into this library (configured without "
                      "OpenCL)");
}
void lrr__cl_destroy(lrr__cl_solver *cl)
{
    (void)cl;
}
const char *lrr__cl_name(const lrr__cl_solver *cl)
{
    (void)cl;
    return "opencl";
}
lrr_status lrr__cl_solve(lrr__cl_solver *cl, const float *E, float *B)
{
    (void)cl, (void)E, (void)B;
    return LRR_ERR_UNSUPPORTED;
}
void lrr__cl_timings(const lrr__cl_solver *cl, double *kernel_ms, double *transfer_ms)
{
    (void)cl;
    *kernel_ms = *transfer_ms = 0;
}
void lrr__cl_use_groups(lrr__cl_solver *cl, int groups)
{
    (void)cl, (void)groups;
}
void lrr__cl_step_times(const lrr__cl_solver *cl, double ms[3])
{
    (void)cl;
    ms[0] = ms[1] = ms[2] = 0;
}
lrr_status lrr__cl_fbar_panels(lrr__cl_solver *cl, int panels)
{
    (void)cl, (void)panels;
    return LRR_ERR_UNSUPPORTED;
}
lrr_status lrr__cl_set_fbar(lrr__cl_solver *cl, lrr_fbar_format format,
                            lrr__sparse_stats *stats)
{
    (void)cl, (void)format;
    memset(stats, 0, sizeof *stats);
    return LRR_ERR_UNSUPPORTED;
}
size_t lrr__cl_fbar_bytes(const lrr__cl_solver *cl, int *sparse)
{
    (void)cl;
    *sparse = 0;
    return 0;
}

#else

#include "core/opencl_util.h"

#include <stdio.h>

/* Work-group size of fbar_groups, smw_groups and fbar_strips on GPUs: a few warps or
 * wavefronts per row keep loads contiguous; lowered to the device's limit. */
#define GROUP_SIZE 128
/* Strip groups of fbar_strips (work-items per tile / LRR__TILE): CPU devices 1 (PoCL runs
 * a work-group's items as vector lanes), GPUs STRIP_GROUPS_GPU (H200, Crytek Sponza f16:
 * 0.300 / 0.258 / 0.260 ms at 4 / 8 / 16 groups); the environment variable
 * LRR_OPENCL_STRIP_GROUPS overrides both (lrr-bench fbar --backend opencl --strip-groups). */
#define STRIP_GROUPS_GPU 8
/* fbar_panels's loads in flight per item (realtime.cl UNROLL, measured there): f32, 16-bit */
#define UNROLL_F32 32
#define UNROLL_16 16
/* Build log characters kept in an error message (the context keeps 512 bytes). */
#define LOG_MAX 300

struct lrr__cl_solver {
    const lrr_operator *op;
    cl_context context;
    cl_command_queue queue;
    cl_program program;
    cl_kernel segsum, segg, smw, smwg, rows, panels, groups, strips;
    cl_mem fbar, scale, m, rho, e, w, z, b, first, vw; /* vw: Vᵀ's weights (n) */
    cl_mem sval, scol, sstart; /* a sparse F̄'s strips (fbar is then NULL) */
    size_t group_size, tiles, sparse_bytes;
    unsigned strip_groups;
    int cpu_device;
    int gpu_kernels;     /* segsum_groups, smw_groups and fbar_panels or fbar_groups (GPUs)
                            rather than segsum, smw and fbar_rows (CPU devices) */
    cl_uint dev_np;      /* F̄'s panel rows as it went up (0: rows) */
    double step_ms[3];   /* the last frame's w, z and B kernels */
    char name[160];      /* "opencl:<device name>" */
    double kernel_ms, transfer_ms; /* the last frame's, from profiling events (0 before one) */
};

static void release_mem(cl_mem *m)
{
    if (*m)
        clReleaseMemObject(*m);
    *m = NULL;
}

void lrr__cl_destroy(lrr__cl_solver *cl)
{
    if (!cl)
        return;
    cl_mem *mems[] = {&cl->fbar, &cl->scale, &cl->m,    &cl->rho,  &cl->e,    &cl->w, &cl->z,
                      &cl->b,    &cl->first, &cl->vw,   &cl->sval, &cl->scol, &cl->sstart};
    for (size_t i = 0; i < sizeof mems / sizeof mems[0]; i++)
        release_mem(mems[i]);
    cl_kernel ks[] = {cl->segsum, cl->segg,   cl->smw,   cl->smwg,
                      cl->rows,   cl->panels, cl->groups, cl->strips};
    for (size_t i = 0; i < sizeof ks / sizeof ks[0]; i++)
        if (ks[i])
            clReleaseKernel(ks[i]);
    if (cl->program)
        clReleaseProgram(cl->program);
    if (cl->queue)
        clReleaseCommandQueue(cl->queue);
    if (cl->context)
        clReleaseContext(cl->context);
    free(cl);
}

const char *lrr__cl_name(const lrr__cl_solver *cl)
{
    return cl->name;
}

void lrr__cl_use_groups(lrr__cl_solver *cl, int groups)
{
    cl->gpu_kernels = groups != 0;
}

void lrr__cl_step_times(const lrr__cl_solver *cl, double ms[3])
{
    memcpy(ms, cl->step_ms, sizeof cl->step_ms);
}

/* LRR_OPENCL_STRIP_GROUPS: a power of two within the work-group size, else the default */
static unsigned strip_groups(const lrr__cl_solver *cl)
{
    const char *env = getenv("LRR_OPENCL_STRIP_GROUPS");
    char *end;
    unsigned long g = env ? strtoul(env, &end, 10) : 0;
    if (env && *end == '\0' && g > 0 && (g & (g - 1)) == 0 && g * LRR__TILE <= cl->group_size)
        return (unsigned)g;
    return cl->cpu_device ? 1 : STRIP_GROUPS_GPU;
}

size_t lrr__cl_fbar_bytes(const lrr__cl_solver *cl, int *sparse)
{
    *sparse = cl->fbar == NULL;
    return cl->fbar ? cl->op->n * cl->op->k * lrr__fbar_elem_bytes(cl->op) : cl->sparse_bytes;
}

static lrr_status new_buffer(lrr__cl_solver *cl, cl_mem_flags flags, size_t bytes,
                             const void *host, const char *what, cl_mem *out)
{
    cl_int err;
    if (bytes == 0)
        host = NULL; /* an empty buffer (4 bytes, never read) copies nothing */
    *out = clCreateBuffer(cl->context, flags | (host ? CL_MEM_COPY_HOST_PTR : 0),
                          bytes ? bytes : 4, (void *)host, &err);
    if (err != CL_SUCCESS)
        return lrr__cl_fail(cl->op->ctx, err, "clCreateBuffer", what);
    return LRR_OK;
}

/* Rows of F̄ per write when a panel layout goes up as rows (whole panels) */
#define UPLOAD_ROWS 1024

/* F̄ to the device in panels as the operator holds them, or as rows (panels = 0). CPU
 * devices get rows: PoCL vectorises fbar_rows across work-items better over rows (Cornell
 * n = 13824, k = 864, f32, 2 cores: rows 7.75 ms a frame, panels 8.68 ms); a GPU gets
 * panels, where neighbouring items read neighbouring addresses. */
static lrr_status upload_fbar(lrr__cl_solver *cl, int panels)
{
    const lrr_operator *op = cl->op;
    const size_t n = op->n, k = op->k, es = lrr__fbar_elem_bytes(op);
    cl_int err = CL_SUCCESS;
    cl_uint np = (cl_uint)lrr__fbar_panel_rows(op);
    if (panels || np == 0) {
        err = clEnqueueWriteBuffer(cl->queue, cl->fbar, CL_TRUE, 0, n * k * es,
                                   lrr__fbar_data(op), 0, NULL, NULL);
    } else {
        /* UPLOAD_ROWS·k·es bytes: less than F̄'s n·k·es whenever n > UPLOAD_ROWS */
        const size_t rows = n < UPLOAD_ROWS ? n : UPLOAD_ROWS;
        void *buf = lrr__alloc(op->ctx, rows * k * es);
        if (!buf)
            return lrr__error(op->ctx, LRR_ERR_NOMEM, "cannot allocate %zu rows of F̄", rows);
        for (size_t i = 0; i < n && err == CL_SUCCESS; i += rows) {
            size_t m = n - i < rows ? n - i : rows;
            lrr__fbar_copy_rows(op, i, i + m, buf);
            err = clEnqueueWriteBuffer(cl->queue, cl->fbar, CL_TRUE, i * k * es, m * k * es,
                                       buf, 0, NULL, NULL);
        }
        free(buf);
        np = 0;
    }
    if (err != CL_SUCCESS)
        return lrr__cl_fail(op->ctx, err, "clEnqueueWriteBuffer", "F̄");
    const cl_kernel prod[3] = {cl->rows, cl->groups, cl->panels};
    for (int i = 0; i < 3 && err == CL_SUCCESS; i++) {
        err = clSetKernelArg(prod[i], 0, sizeof(cl_mem), &cl->fbar);
        if (err == CL_SUCCESS)
            err = clSetKernelArg(prod[i], 8, sizeof np, &np);
    }
    cl->dev_np = np;
    return err == CL_SUCCESS ? LRR_OK : lrr__cl_fail(op->ctx, err, "clSetKernelArg", "np");
}

lrr_status lrr__cl_fbar_panels(lrr__cl_solver *cl, int panels)
{
    return cl->fbar ? upload_fbar(cl, panels) : LRR_ERR_INVALID_ARG;
}

/* Refuses `bytes` more on the device beyond its limits (one buffer, all of them). */
static lrr_status check_fits(lrr__cl_solver *cl, size_t largest, size_t total, const char *what)
{
    cl_device_id dev;
    cl_ulong global_mem = 0, max_alloc = 0;
    cl_int err = clGetCommandQueueInfo(cl->queue, CL_QUEUE_DEVICE, sizeof dev, &dev, NULL);
    if (err == CL_SUCCESS)
        err = clGetDeviceInfo(dev, CL_DEVICE_GLOBAL_MEM_SIZE, sizeof global_mem, &global_mem,
                              NULL);
    if (err == CL_SUCCESS)
        err = clGetDeviceInfo(dev, CL_DEVICE_MAX_MEM_ALLOC_SIZE, sizeof max_alloc, &max_alloc,
                              NULL);
    if (err != CL_SUCCESS)
        return lrr__cl_fail(cl->op->ctx, err, "clGetDeviceInfo", "device memory sizes");
    const size_t n = cl->op->n, k = cl->op->k;
    const size_t other = 4 * (3 * k * k + 4 * 3 * n + n + 7 * k + 1);
    if ((cl_ulong)largest > max_alloc || (cl_ulong)total + other > global_mem)
        return lrr__error(cl->op->ctx, LRR_ERR_NOMEM,
                          "OpenCL: %s needs %zu bytes (and %zu more for M, E, B, rho); the "
                          "device has CL_DEVICE_MAX_MEM_ALLOC_SIZE = %llu and "
                          "CL_DEVICE_GLOBAL_MEM_SIZE = %llu bytes",
                          what, total, other, (unsigned long long)max_alloc,
                          (unsigned long long)global_mem);
    return LRR_OK;
}

static lrr_status set_dense(lrr__cl_solver *cl)
{
    const lrr_operator *op = cl->op;
    const size_t bytes = op->n * op->k * lrr__fbar_elem_bytes(op);
    lrr_status st;
    if (cl->fbar)
        return LRR_OK;
    /* the strips stay until F̄ is up: on an error the solver reads them as before */
    if ((st = check_fits(cl, bytes, bytes, "F̄")) ||
        (st = new_buffer(cl, CL_MEM_READ_ONLY, bytes, NULL, "F̄", &cl->fbar)) ||
        (st = upload_fbar(cl, !cl->cpu_device))) {
        release_mem(&cl->fbar);
        return st;
    }
    release_mem(&cl->sval), release_mem(&cl->scol), release_mem(&cl->sstart);
    return LRR_OK;
}

/* The strips of sp on the device (start as 32-bit offsets), the dense F̄ released. */
static lrr_status set_sparse(lrr__cl_solver *cl, const lrr__sparse *sp)
{
    lrr_context *ctx = cl->op->ctx;
    if (sp->strips > UINT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "OpenCL: %zu strips of sparse F̄ exceed the kernels' 32-bit offsets",
                          sp->strips);
    const size_t es = sp->val ? sizeof(float) : sizeof(uint16_t);
    const size_t vbytes = sp->strips * LRR__TILE * es, cbytes = sp->strips * sizeof(uint16_t);
    const size_t sbytes = (sp->tiles + 1) * sizeof(cl_uint);
    lrr_status st = check_fits(cl, vbytes, vbytes + cbytes + sbytes, "sparse F̄");
    cl_uint *start = st ? NULL : lrr__alloc(ctx, sbytes);
    if (!st && !start)
        st = lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate %zu strip offsets", sp->tiles + 1);
    for (size_t t = 0; !st && t <= sp->tiles; t++)
        start[t] = (cl_uint)sp->start[t];
    cl_mem v = NULL, c = NULL, o = NULL;
    const cl_mem_flags ro = CL_MEM_READ_ONLY;
    if (!st && !(st = new_buffer(cl, ro, vbytes, sp->val ? (void *)sp->val : (void *)sp->val16,
                                 "sparse F̄ values", &v)) &&
        !(st = new_buffer(cl, ro, cbytes, sp->col, "sparse F̄ columns", &c)))
        st = new_buffer(cl, ro, sbytes, start, "sparse F̄ tiles", &o);
    free(start);
    const cl_uint un = (cl_uint)cl->op->n, uk = (cl_uint)cl->op->k;
    const cl_mem *args[] = {&v, &c, &o, &cl->scale, &cl->z, &cl->e, &cl->rho};
    cl_int err = CL_SUCCESS;
    for (cl_uint j = 0; !st && j < 7 && err == CL_SUCCESS; j++)
        err = clSetKernelArg(cl->strips, j, sizeof(cl_mem), args[j]);
    if (!st && err == CL_SUCCESS && (err = clSetKernelArg(cl->strips, 7, sizeof un, &un)) ==
                                        CL_SUCCESS &&
        (err = clSetKernelArg(cl->strips, 8, sizeof uk, &uk)) == CL_SUCCESS)
        err = clSetKernelArg(cl->strips, 9, sizeof(cl_mem), &cl->b);
    if (!st && err != CL_SUCCESS)
        st = lrr__cl_fail(ctx, err, "clSetKernelArg", "fbar_strips");
    if (st) {
        release_mem(&v), release_mem(&c), release_mem(&o);
        return st;
    }
    release_mem(&cl->fbar);
    release_mem(&cl->sval), release_mem(&cl->scol), release_mem(&cl->sstart);
    cl->sval = v, cl->scol = c, cl->sstart = o;
    cl->tiles = sp->tiles;
    cl->sparse_bytes = vbytes + cbytes + sbytes;
    return LRR_OK;
}

lrr_status lrr__cl_set_fbar(lrr__cl_solver *cl, lrr_fbar_format format,
                            lrr__sparse_stats *stats)
{
    lrr__sparse *sp = NULL;
    lrr_status st = lrr__sparse_create(cl->op, format, stats, &sp);
    if (!st)
        st = sp ? set_sparse(cl, sp) : set_dense(cl);
    lrr__sparse_destroy(sp);
    return st;
}

/* Builds the program once per solver for the operator's storage; a failed build returns
 * LRR_ERR_UNSUPPORTED with the start of the build log (where the first error is). */
static lrr_status build_program(lrr__cl_solver *cl, cl_device_id dev)
{
    lrr_context *ctx = cl->op->ctx;
    const char *src = lrr__kernel_realtime_cl;
    cl_int err;
    cl->program = clCreateProgramWithSource(cl->context, 1, &src, NULL, &err);
    if (err != CL_SUCCESS)
        return lrr__cl_fail(ctx, err, "clCreateProgramWithSource", "lib/solve/realtime.cl");
    char opts[128];
    const int storage = cl->op->storage == LRR_STORAGE_F16    ? 1
                        : cl->op->storage == LRR_STORAGE_BF16 ? 2
                                                              : 0;
    snprintf(opts, sizeof opts, "-DSTORAGE=%d -DWG=%zu -DPANEL=%d -DTILE=%d -DUNROLL=%d", storage,
             cl->group_size, LRR__PANEL, LRR__TILE, storage ? UNROLL_16 : UNROLL_F32);
    err = clBuildProgram(cl->program, 1, &dev, opts, NULL, NULL);
    if (err != CL_SUCCESS) {
        char log[LOG_MAX + 1] = "";
        size_t len = 0;
        clGetProgramBuildInfo(cl->program, dev, CL_PROGRAM_BUILD_LOG, 0, NULL, &len);
        if (len > 0) {
            char *full = lrr__alloc(ctx, len + 1);
            if (full && clGetProgramBuildInfo(cl->program, dev, CL_PROGRAM_BUILD_LOG, len,
                                              full, NULL) == CL_SUCCESS) {
                full[len] = '\0';
                snprintf(log, sizeof log, "%s", full);
            }
            free(full);
        }
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "OpenCL: clBuildProgram (lib/solve/realtime.cl, %s) failed: %s "
                          "(%d); build log: %s%s",
                          opts, lrr__cl_code_name(err), (int)err, log[0] ? log : "(empty)",
                          len > LOG_MAX + 1 ? " [...]" : "");
    }
    static const char *const names[] = {"segsum",    "segsum_groups", "smw",
                                        "smw_groups", "fbar_rows",     "fbar_panels",
                                        "fbar_groups", "fbar_strips"};
    cl_kernel *ks[] = {&cl->segsum, &cl->segg,   &cl->smw,    &cl->smwg,
                       &cl->rows,   &cl->panels, &cl->groups, &cl->strips};
    for (int i = 0; i < 8; i++) {
        *ks[i] = clCreateKernel(cl->program, names[i], &err);
        if (err != CL_SUCCESS)
            return lrr__cl_fail(ctx, err, "clCreateKernel", names[i]);
    }
    return LRR_OK;
}

/* The arguments never change, only the buffers' contents. */
static lrr_status set_args(lrr__cl_solver *cl)
{
    const lrr_operator *op = cl->op;
    const cl_uint un = (cl_uint)op->n, uk = (cl_uint)op->k;
    struct {
        cl_kernel kn;
        cl_uint index;
        size_t size;
        const void *value;
        const char *what;
    } a[] = {
        {cl->segsum, 0, sizeof(cl_mem), &cl->e, "segsum E"},
        {cl->segsum, 1, sizeof uk, &uk, "segsum k"},
        {cl->segsum, 2, sizeof(cl_mem), &cl->first, "segsum first"},
        {cl->segsum, 3, sizeof(cl_mem), &cl->w, "segsum w"},
        {cl->segsum, 4, sizeof(cl_mem), &cl->vw, "segsum Vᵀ weights"},
        {cl->smw, 0, sizeof(cl_mem), &cl->m, "smw M"},
        {cl->smw, 1, sizeof(cl_mem), &cl->w, "smw w"},
        {cl->smw, 2, sizeof uk, &uk, "smw k"},
        {cl->smw, 3, sizeof(cl_mem), &cl->z, "smw z"},
        {cl->segg, 0, sizeof(cl_mem), &cl->e, "segsum_groups E"},
        {cl->segg, 1, sizeof uk, &uk, "segsum_groups k"},
        {cl->segg, 2, sizeof(cl_mem), &cl->first, "segsum_groups first"},
        {cl->segg, 3, sizeof(cl_mem), &cl->w, "segsum_groups w"},
        {cl->segg, 4, sizeof(cl_mem), &cl->vw, "segsum_groups Vᵀ weights"},
        {cl->smwg, 0, sizeof(cl_mem), &cl->m, "smw_groups M"},
        {cl->smwg, 1, sizeof(cl_mem), &cl->w, "smw_groups w"},
        {cl->smwg, 2, sizeof uk, &uk, "smw_groups k"},
        {cl->smwg, 3, sizeof(cl_mem), &cl->z, "smw_groups z"},
    };
    for (size_t i = 0; i < sizeof a / sizeof a[0]; i++) {
        cl_int err = clSetKernelArg(a[i].kn, a[i].index, a[i].size, a[i].value);
        if (err != CL_SUCCESS)
            return lrr__cl_fail(op->ctx, err, "clSetKernelArg", a[i].what);
    }
    const cl_kernel prod[3] = {cl->rows, cl->groups, cl->panels};
    /* arguments 0 (F̄) and 8 (its panel rows) are set where it goes up (upload_fbar) */
    const cl_mem *bufs[6] = {&cl->fbar, &cl->scale, &cl->z, &cl->e, &cl->rho, &cl->b};
    for (int i = 0; i < 3; i++) {
        const char *what = i == 2 ? "fbar_panels" : i ? "fbar_groups" : "fbar_rows";
        cl_int err = CL_SUCCESS;
        for (cl_uint j = 1; j < 5 && err == CL_SUCCESS; j++)
            err = clSetKernelArg(prod[i], j, sizeof(cl_mem), bufs[j]);
        if (err == CL_SUCCESS)
            err = clSetKernelArg(prod[i], 5, sizeof un, &un);
        if (err == CL_SUCCESS)
            err = clSetKernelArg(prod[i], 6, sizeof uk, &uk);
        if (err == CL_SUCCESS)
            err = clSetKernelArg(prod[i], 7, sizeof(cl_mem), bufs[5]);
        if (err != CL_SUCCESS)
            return lrr__cl_fail(op->ctx, err, "clSetKernelArg", what);
    }
    return LRR_OK;
}

lrr_status lrr__cl_create(const lrr_operator *op, lrr_fbar_format format,
                          lrr__sparse_stats *stats, lrr__cl_solver **out)
{
    lrr_context *ctx = op->ctx;
    *out = NULL;
    const size_t n = op->n, k = op->k;
    if (n > UINT32_MAX || k > UINT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "OpenCL: n = %zu, k = %zu exceed the kernels' 32-bit indices", n, k);
    cl_device_id dev;
    lrr_status st = lrr__cl_pick_device(ctx, &dev);
    if (st)
        return st;

    lrr__cl_solver *cl = lrr__zalloc(ctx, sizeof *cl);
    if (!cl)
        return lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate an OpenCL solver");
    cl->op = op;
    char dn[128] = "";
    cl_device_type type = 0;
    size_t max_wg = 1;
    clGetDeviceInfo(dev, CL_DEVICE_NAME, sizeof dn - 1, dn, NULL);
    clGetDeviceInfo(dev, CL_DEVICE_TYPE, sizeof type, &type, NULL);
    clGetDeviceInfo(dev, CL_DEVICE_MAX_WORK_GROUP_SIZE, sizeof max_wg, &max_wg, NULL);
    snprintf(cl->name, sizeof cl->name, "opencl:%s", dn);
    /* GPUs get F̄ in panels, where the items of fbar_panels (one per row) read adjacent
     * addresses at every step, and a work-group per row where F̄ is row-major */
    cl->cpu_device = (type & CL_DEVICE_TYPE_CPU) != 0;
    cl->gpu_kernels = !cl->cpu_device;
    cl->group_size = 1;
    while (cl->group_size * 2 <= GROUP_SIZE && cl->group_size * 2 <= max_wg)
        cl->group_size *= 2;
    cl->strip_groups = strip_groups(cl);

    const int half = op->storage != LRR_STORAGE_F32;
    const cl_mem_flags ro = CL_MEM_READ_ONLY, rw = CL_MEM_READ_WRITE;
    const float one = 1.0f;
    cl_int err;
    /* patch offsets as 32-bit (n <= UINT32_MAX): the segmented sum's ranges */
    cl_uint *first = lrr__alloc(ctx, (k + 1) * sizeof(cl_uint));
    if (!first) {
        free(cl);
        return lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate the patch offsets");
    }
    for (size_t p = 0; p <= k; p++)
        first[p] = (cl_uint)op->geom.first[p];
    cl->context = clCreateContext(NULL, 1, &dev, NULL, NULL, &err);
    if (err != CL_SUCCESS)
        st = lrr__cl_fail(ctx, err, "clCreateContext", dn);
    if (!st) {
        cl->queue = clCreateCommandQueue(cl->context, dev, CL_QUEUE_PROFILING_ENABLE, &err);
        if (err != CL_SUCCESS)
            st = lrr__cl_fail(ctx, err, "clCreateCommandQueue", dn);
    }
    if (st || (st = build_program(cl, dev)) ||
        (st = new_buffer(cl, ro, half ? n * 4 : 4, half ? op->row_scale : &one, "row scales",
                         &cl->scale)) ||
        (st = new_buffer(cl, ro, 3 * k * k * 4, op->m, "M (3×k×k)", &cl->m)) ||
        (st = new_buffer(cl, ro, 3 * n * 4, op->rho, "rho (n×3)", &cl->rho)) ||
        (st = new_buffer(cl, ro, 3 * n * 4, NULL, "E (n×3)", &cl->e)) ||
        (st = new_buffer(cl, rw, 3 * k * 4, NULL, "w (3×k)", &cl->w)) ||
        (st = new_buffer(cl, rw, 3 * k * 4, NULL, "z (3×k)", &cl->z)) ||
        (st = new_buffer(cl, CL_MEM_WRITE_ONLY, 3 * n * 4, NULL, "B (n×3)", &cl->b)) ||
        (st = new_buffer(cl, ro, (k + 1) * sizeof(cl_uint), first, "patch offsets (k+1)",
                         &cl->first)) ||
        (st = new_buffer(cl, ro, n * 4, op->weight, "Vᵀ weights (n)", &cl->vw)) ||
        (st = set_args(cl)) || (st = lrr__cl_set_fbar(cl, format, stats))) {
        free(first);
        lrr__cl_destroy(cl);
        return st;
    }
    free(first);
    *out = cl;
    return LRR_OK;
}

void lrr__cl_timings(const lrr__cl_solver *cl, double *kernel_ms, double *transfer_ms)
{
    *kernel_ms = cl->kernel_ms;
    *transfer_ms = cl->transfer_ms;
}

/* END - START of a finished command in milliseconds (0 when the profile is unavailable). */
static double event_ms(cl_event ev)
{
    cl_ulong t0 = 0, t1 = 0;
    if (clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_START, sizeof t0, &t0, NULL) !=
            CL_SUCCESS ||
        clGetEventProfilingInfo(ev, CL_PROFILING_COMMAND_END, sizeof t1, &t1, NULL) !=
            CL_SUCCESS ||
        t1 < t0)
        return 0;
    return (double)(t1 - t0) * 1e-6;
}

lrr_status lrr__cl_solve(lrr__cl_solver *cl, const float *E, float *B)
{
    const size_t n = cl->op->n, k = cl->op->k, bytes = 3 * n * sizeof(float);
    const char *call = "clEnqueueWriteBuffer", *what = "E";
    /* ev: E up, the three kernels, B down; profiled once the blocking read returns */
    cl_event ev[5] = {NULL, NULL, NULL, NULL, NULL};
    /* E goes up without blocking; the blocking read of B ends the in-order queue's work */
    cl_int err = clEnqueueWriteBuffer(cl->queue, cl->e, CL_FALSE, 0, bytes, E, 0, NULL, &ev[0]);
    if (err != CL_SUCCESS)
        goto fail;
    call = "clEnqueueNDRangeKernel";
    size_t g1 = k, g2[2] = {k, 3};
    what = "segsum";
    if (cl->gpu_kernels) {
        size_t local = cl->group_size, global = k * cl->group_size;
        err = clEnqueueNDRangeKernel(cl->queue, cl->segg, 1, NULL, &global, &local, 0, NULL,
                                     &ev[1]);
    } else {
        err = clEnqueueNDRangeKernel(cl->queue, cl->segsum, 1, NULL, &g1, NULL, 0, NULL, &ev[1]);
    }
    if (err != CL_SUCCESS)
        goto fail;
    what = "smw";
    if (cl->gpu_kernels) {
        size_t local = cl->group_size, global = 3 * k * cl->group_size;
        err = clEnqueueNDRangeKernel(cl->queue, cl->smwg, 1, NULL, &global, &local, 0, NULL,
                                     &ev[2]);
    } else {
        err = clEnqueueNDRangeKernel(cl->queue, cl->smw, 2, NULL, g2, NULL, 0, NULL, &ev[2]);
    }
    if (err != CL_SUCCESS)
        goto fail;
    if (!cl->fbar) {
        const cl_uint sg = cl->strip_groups;
        size_t local = LRR__TILE * sg, global = cl->tiles * local;
        what = "fbar_strips";
        err = clSetKernelArg(cl->strips, 10, sizeof sg, &sg);
        if (err == CL_SUCCESS)
            err = clEnqueueNDRangeKernel(cl->queue, cl->strips, 1, NULL, &global, &local, 0,
                                         NULL, &ev[3]);
    } else if (cl->gpu_kernels && cl->dev_np > 0) {
        size_t local = cl->group_size, global = (n + local - 1) / local * local;
        what = "fbar_panels";
        err = clEnqueueNDRangeKernel(cl->queue, cl->panels, 1, NULL, &global, &local, 0, NULL,
                                     &ev[3]);
    } else if (cl->gpu_kernels) {
        size_t local = cl->group_size, global = n * cl->group_size;
        what = "fbar_groups";
        err = clEnqueueNDRangeKernel(cl->queue, cl->groups, 1, NULL, &global, &local, 0, NULL,
                                     &ev[3]);
    } else {
        size_t global = n;
        what = "fbar_rows";
        err = clEnqueueNDRangeKernel(cl->queue, cl->rows, 1, NULL, &global, NULL, 0, NULL,
                                     &ev[3]);
    }
    if (err != CL_SUCCESS)
        goto fail;
    call = "clEnqueueReadBuffer";
    what = "B";
    err = clEnqueueReadBuffer(cl->queue, cl->b, CL_TRUE, 0, bytes, B, 0, NULL, &ev[4]);
    if (err != CL_SUCCESS)
        goto fail;
    /* the in-order queue has finished every command once the blocking read returned */
    for (int i = 0; i < 3; i++)
        cl->step_ms[i] = event_ms(ev[1 + i]);
    cl->kernel_ms = cl->step_ms[0] + cl->step_ms[1] + cl->step_ms[2];
    cl->transfer_ms = event_ms(ev[0]) + event_ms(ev[4]);
    for (int i = 0; i < 5; i++)
        clReleaseEvent(ev[i]);
    return LRR_OK;
fail:
    clFinish(cl->queue); /* the caller's E must not be read after we return */
    for (int i = 0; i < 5; i++)
        if (ev[i])
            clReleaseEvent(ev[i]);
    return lrr__cl_fail(cl->op->ctx, err, call, what);
}

#endif
