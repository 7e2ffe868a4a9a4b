/* The real-time step on the CPU (docs/METHOD.md "Real-time step"), per frame and channel c:
 *     w_c = Vᵀ E_c             O(n) segmented sum over each patch's d subpatches
 *     z_c = M_c w_c            k×k products, all channels in one pass
 *     B_c = E_c + rho_c ∘ (F̄ z_c)   F̄ read once for all channels, epilogue fused
 * The products live in realtime_kernel.c (why not BLAS: see there).
 *
 * B is linear in w, and w only has entries for patches that emit. With Y_c = F̄ M_c (n×k,
 * never formed whole), B_c = E_c + rho_c ∘ Σ_p Y_c[:, p] w_cp, so a frame in which m ≪ k
 * patches emit costs 3·n·m multiply-adds over cached columns Y[:, p] instead of a pass over
 * F̄ (the sparse path), and a frame in which only m patches changed since the previous one
 * costs B = B_prev + ΔE + rho ∘ Σ_p Y[:, p] Δw_p (the incremental path). A column costs one
 * pass over F̄ the first time its patch is needed, and the cache has a memory limit.
 * The incremental path re-anchors with a full frame every INCREMENTAL_LIMIT frames so that
 * rounding cannot accumulate.
 *
 * Batches of frames (lrr_solve_batch) over a large F̄ read it once: each block of rows
 * serves every frame while it is in cache; small ones are a loop of single frames
 * (thresholds measured below).
 */
#include "config.h"
#include "solve/solve.h"

#include <cblas.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define INCREMENTAL_LIMIT 64

/* Frames per batched pass (bounds the 3k·count workspaces) and the smallest batch, and F̄
 * (at least this, and a quarter of the last-level cache), for which it beats one fused pass
 * per frame: once F̄ is in cache the loop of frames reads it from there anyway. Measured on
 * 2 cores (AMD EPYC, 32 MiB L3), 16 frames, ms per frame, batched vs single frames:
 * 55296 × 864 (191 MB) 1.80 vs 4.93; 13824 × 864 (48 MB) 0.84 vs 0.89; 3456 × 216 (3 MB)
 * 0.035 vs 0.033. The count threshold dates from the sgemm pass this one replaced (8
 * frames: 5.5 against 8.1 ms); below 16 frames the batched pass is not re-measured. */
#define BATCH_CHUNK 64
#define BATCH_GEMM_MIN_COUNT 8
#define BATCH_GEMM_MIN_BYTES ((size_t)32 << 20)
#define NO_SLOT SIZE_MAX

struct lrr_solver {
    const lrr_operator *op;
    lrr_backend backend;
    const lrr__kernel *kernel; /* SIMD variant, chosen once (lrr__cpu_choose) */
    lrr__sparse *sparse;       /* F̄ as strips (sparse.c), or NULL: the operator's dense F̄ */
    lrr__sparse_stats fbar_stats; /* its counts (also when dense was kept) */
    lrr__m_f16 *m16;           /* M − I as a full frame reads it (m_f16.c), or NULL: op->m */
    unsigned long m_epoch;     /* op->m_epoch when m16 and the cached columns were made */
    lrr__cl_solver *cl;        /* LRR_BACKEND_OPENCL: every frame goes there (solve/opencl.c) */
    float *w;      /* 3×k, channel-major */
    float *z;      /* 3×k, channel-major: the right-hand sides of the n×k product */
    lrr_path path; /* requested path (LRR_PATH_AUTO chooses per frame) */
    lrr_path last; /* path of the last frame */
    /* column cache: Y[:, p] for a few patches, n×3 each */
    size_t cache_bytes;
    size_t cap;          /* columns that fit in cache_bytes */
    size_t used;         /* columns filled */
    size_t *slot;        /* k: slot of patch p, or NO_SLOT */
    float *cols;         /* cap × n×3 */
    float *ones, *zeros; /* n×3 each: the epilogue's rho and E when computing a column */
    unsigned char *nz;   /* k: patch emits in this frame */
    unsigned char *ch;   /* k: patch's emission changed since the previous frame */
    /* the previous frame, for the incremental path */
    float *e_prev, *b_prev, *dw; /* n×3, n×3, 3×k */
    int have_prev;
    unsigned since_full;
    /* batch workspace, grown on demand, and when the batched pass takes over */
    float *bw, *bz;
    size_t batch_cap;
    size_t gemm_min_count, gemm_min_bytes;
};

void lrr_solver_destroy(lrr_solver *s)
{
    if (!s)
        return;
    lrr__cl_destroy(s->cl);
    lrr__sparse_destroy(s->sparse);
    lrr__m_f16_destroy(s->m16);
    lrr_aligned_free(s->w);
    lrr_aligned_free(s->z);
    lrr_aligned_free(s->slot);
    lrr_aligned_free(s->cols);
    lrr_aligned_free(s->ones);
    lrr_aligned_free(s->zeros);
    lrr_aligned_free(s->nz);
    lrr_aligned_free(s->ch);
    lrr_aligned_free(s->e_prev);
    lrr_aligned_free(s->b_prev);
    lrr_aligned_free(s->dw);
    lrr_aligned_free(s->bw);
    lrr_aligned_free(s->bz);
    free(s);
}

static size_t dense_bytes(const lrr_operator *op)
{
    return op->n * op->k * lrr__fbar_elem_bytes(op);
}

/* the bytes of F̄ a full frame reads */
static size_t fbar_bytes(const lrr_solver *s)
{
    return s->sparse ? s->sparse->bytes : dense_bytes(s->op);
}

/* B_c = E_c + rho_c ∘ (F̄ z_c) for count frames, from whichever F̄ the solver reads */
static void fbar_apply_frames(const lrr_solver *s, size_t count, const float *z,
                              const float *E, const float *rho, float *B)
{
    if (s->sparse)
        lrr__sparse_apply_frames(s->kernel, s->sparse, count, z, E, rho, B);
    else
        lrr__fbar_apply_frames(s->kernel, s->op, count, z, E, rho, B);
}

lrr_status lrr_solver_set_fbar(lrr_solver *s, lrr_fbar_format format)
{
    const lrr_operator *op = s->op;
    if ((unsigned)format > LRR_FBAR_SPARSE)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "unknown F̄ format %d", (int)format);
    if (s->cl) {
        lrr__sparse_stats stats;
        lrr_status st = lrr__cl_set_fbar(s->cl, format, &stats);
        if (!st)
            s->fbar_stats = stats;
        return st;
    }
    lrr__sparse *sp = NULL;
    lrr__sparse_stats stats;
    lrr_status st = lrr__sparse_create(op, format, &stats, &sp);
    if (st)
        return st;
    lrr__sparse_destroy(s->sparse);
    s->sparse = sp;
    s->fbar_stats = stats;
    return LRR_OK; /* cached columns F̄ M_c[:, p] stay valid: the same F̄ */
}

lrr_status lrr_solver_set_m(lrr_solver *s, lrr_storage storage)
{
    const lrr_operator *op = s->op;
    if (storage != LRR_STORAGE_F32 && storage != LRR_STORAGE_F16)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "M in storage %d: only f32 and f16",
                          (int)storage);
    if (s->cl && storage != LRR_STORAGE_F32)
        return lrr__error(op->ctx, LRR_ERR_UNSUPPORTED, "the OpenCL backend reads M in f32");
    lrr__m_f16 *m16 = NULL;
    if (storage == LRR_STORAGE_F16) {
        lrr_status st = lrr__m_f16_create(op, &m16);
        if (st)
            return st;
    }
    lrr__m_f16_destroy(s->m16);
    s->m16 = m16;
    return LRR_OK;
}

void lrr_solver_get_info(const lrr_solver *s, lrr_solver_info *out, size_t out_size)
{
    const lrr_operator *op = s->op;
    lrr_solver_info info;
    memset(&info, 0, sizeof info);
    int sparse = s->sparse != NULL;
    info.fbar_dense_bytes = dense_bytes(op);
    info.fbar_bytes = s->cl ? lrr__cl_fbar_bytes(s->cl, &sparse) : fbar_bytes(s);
    info.fbar = sparse ? LRR_FBAR_SPARSE : LRR_FBAR_DENSE;
    info.m = s->m16 ? LRR_STORAGE_F16 : LRR_STORAGE_F32;
    info.m_bytes = s->m16 ? lrr__m_f16_bytes(op->k) : 3 * op->k * op->k * sizeof(float);
    const double entries = (double)op->n * (double)op->k;
    info.fbar_density = (double)s->fbar_stats.nonzeros / entries;
    info.fbar_strip_density = (double)s->fbar_stats.strips * LRR__TILE / entries;
    lrr__info_write(out, out_size, &info, sizeof info);
}

lrr_status lrr_solver_create(const lrr_operator *op, lrr_backend backend, lrr_solver **out)
{
    *out = NULL;
    /* LRR_SIMD is checked for every backend: one set of names, refused alike everywhere */
    lrr__cpu_choice simd;
    lrr_status st = lrr__need_fbar(op, "lrr_solver_create");
    if (st || (st = lrr__cpu_choose(op->ctx, &simd)))
        return st;
    if (backend == LRR_BACKEND_OPENCL) {
        lrr__cl_solver *cl;
        lrr__sparse_stats stats;
        if ((st = lrr__cl_create(op, LRR_FBAR_AUTO, &stats, &cl)))
            return st;
        lrr_solver *s = lrr__zalloc(op->ctx, sizeof *s);
        if (!s) {
            lrr__cl_destroy(cl);
            return lrr__error(op->ctx, LRR_ERR_NOMEM, "cannot allocate a solver");
        }
        s->op = op;
        s->cl = cl;
        s->fbar_stats = stats;
        s->backend = backend;
        s->path = s->last = LRR_PATH_FULL;
        *out = s;
        return LRR_OK;
    }
    if (backend != LRR_BACKEND_CPU)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "unknown backend %d", (int)backend);
    const lrr__kernel *kernel = lrr__kernel_select(&simd, op->k);
    lrr_solver *s = lrr__zalloc(op->ctx, sizeof *s);
    if (!s)
        return lrr__error(op->ctx, LRR_ERR_NOMEM, "cannot allocate a solver");
    s->op = op;
    s->m_epoch = op->m_epoch;
    s->kernel = kernel;
    s->backend = backend;
    s->path = LRR_PATH_AUTO;
    s->last = LRR_PATH_FULL;
    s->gemm_min_count = BATCH_GEMM_MIN_COUNT;
    s->gemm_min_bytes = BATCH_GEMM_MIN_BYTES;
#ifdef _SC_LEVEL3_CACHE_SIZE
    /* a matrix held by the last-level cache is read from there frame after frame, and the
     * loop wins. Measured on one VM with a 480 MiB L3, 16 frames: 48 MB F̄: sgemm at 0.54×
     * the loop's speed; 191 MB: 2.1×. A quarter of the L3 separates the two there and
     * leaves the 32 MiB floor in charge on ordinary caches (a guess beyond that machine). */
    long l3 = sysconf(_SC_LEVEL3_CACHE_SIZE);
    if (l3 > 0 && (size_t)l3 / 4 > s->gemm_min_bytes)
        s->gemm_min_bytes = (size_t)l3 / 4;
#endif
    if ((st = lrr__calloc(op->ctx, &s->w, op->k, 3 * sizeof(float), "solver w (3×k)")) ||
        (st = lrr__calloc(op->ctx, &s->z, op->k, 3 * sizeof(float), "solver z (3×k)")) ||
        (st = lrr__calloc(op->ctx, &s->nz, op->k, 1, "solver patch flags")) ||
        (st = lrr__calloc(op->ctx, &s->ch, op->k, 1, "solver patch flags")) ||
        (st = lrr__calloc(op->ctx, &s->dw, op->k, 3 * sizeof(float), "solver Δw (3×k)")) ||
        (st = lrr_solver_set_fbar(s, LRR_FBAR_AUTO)) ||
        (st = lrr_solver_set_m(s, op->storage == LRR_STORAGE_F32 ? LRR_STORAGE_F32
                                                                 : LRR_STORAGE_F16)) ||
        (st = lrr_solver_set_cache(s, fbar_bytes(s) / 4))) {
        lrr_solver_destroy(s);
        return st;
    }
    *out = s;
    return LRR_OK;
}

const char *lrr_solver_kernel(const lrr_solver *s)
{
    if (s->cl)
        return lrr__cl_name(s->cl);
    return s->kernel->name;
}

lrr_status lrr_solver_timings(const lrr_solver *s, double *kernel_ms, double *transfer_ms)
{
    if (!s->cl)
        return lrr__error(s->op->ctx, LRR_ERR_UNSUPPORTED,
                          "lrr_solver_timings: only OpenCL solvers have device timings");
    lrr__cl_timings(s->cl, kernel_ms, transfer_ms);
    return LRR_OK;
}

lrr_status lrr_solver_set_cache(lrr_solver *s, size_t max_bytes)
{
    const lrr_operator *op = s->op;
    if (s->cl)
        return LRR_OK; /* OpenCL solvers have no column cache */
    lrr_aligned_free(s->cols);
    lrr_aligned_free(s->slot);
    s->cols = NULL;
    s->slot = NULL;
    s->used = 0;
    s->cache_bytes = max_bytes;
    size_t per = op->n * 3 * sizeof(float); /* n×3 fits: the operator holds such arrays */
    s->cap = max_bytes / per;
    if (s->cap > op->k)
        s->cap = op->k;
    if (s->cap == 0)
        return LRR_OK;
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, &s->slot, op->k, sizeof(size_t), "column slots")) ||
        (st = lrr__calloc(op->ctx, &s->cols, s->cap, per, "column cache"))) {
        lrr_aligned_free(s->slot);
        s->slot = NULL;
        s->cap = 0;
        return st;
    }
    for (size_t p = 0; p < op->k; p++)
        s->slot[p] = NO_SLOT;
    return LRR_OK;
}

lrr_status lrr_solver_set_path(lrr_solver *s, lrr_path path)
{
    if (path < LRR_PATH_AUTO || path > LRR_PATH_INCREMENTAL)
        return lrr__error(s->op->ctx, LRR_ERR_INVALID_ARG, "unknown path %d", (int)path);
    if (s->cl && path != LRR_PATH_AUTO && path != LRR_PATH_FULL)
        return lrr__error(s->op->ctx, LRR_ERR_UNSUPPORTED,
                          "path %d: the OpenCL backend takes the full path only", (int)path);
    s->path = path;
    return LRR_OK;
}

lrr_path lrr_solver_last_path(const lrr_solver *s)
{
    return s->last;
}

lrr_status lrr__emission_error(lrr_context *ctx, const float *E, size_t bad)
{
    return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                      "emission of subpatch %zu, channel %zu = %g (must be finite and >= 0)",
                      bad / 3, bad % 3, (double)E[bad]);
}

lrr_status lrr__emission_check(lrr_context *ctx, size_t n, const float *E)
{
    size_t bad = SIZE_MAX;
    #pragma omp parallel for schedule(static) reduction(min : bad) if (3 * n >= LRR__PARALLEL_MIN)
    for (size_t j = 0; j < 3 * n; j++)
        if (!(E[j] >= 0.0f) || !isfinite(E[j]))
            bad = bad < j ? bad : j;
    return bad == SIZE_MAX ? LRR_OK : lrr__emission_error(ctx, E, bad);
}

void lrr__solver_opencl_groups(lrr_solver *s, int groups)
{
    if (s->cl)
        lrr__cl_use_groups(s->cl, groups);
}

void lrr__solver_opencl_step_times(const lrr_solver *s, double ms[3])
{
    ms[0] = ms[1] = ms[2] = 0;
    if (s->cl)
        lrr__cl_step_times(s->cl, ms);
}

lrr_status lrr__solver_opencl_panels(lrr_solver *s, int panels)
{
    return s->cl ? lrr__cl_fbar_panels(s->cl, panels) : LRR_ERR_INVALID_ARG;
}



/* w = Vᵀ E (3×k), validating E; nz[p] = 1 where w_p ≠ 0 (m_emit of them). With prev, also
 * ch[p] = 1 where the patch's emission changed (m_changed) and dw = Vᵀ(E − prev). */
static lrr_status segment_sums(lrr_solver *s, const float *E, const float *prev,
                               size_t *m_emit, size_t *m_changed)
{
    const lrr_operator *op = s->op;
    const size_t k = op->k, *first = op->geom.first;
    size_t bad = SIZE_MAX, me = 0, mc = 0;
    /* ~1.8 ns an entry before segment_sum (validation, double sums): a frame of 3456
     * subpatches spent 19 µs here serially (13% of it, Intel Xeon, perf), so two threads pay
     * from an eighth of the usual threshold: 80 → 59-70 µs a frame (n 3456, k 216, best of
     * 5 × 5000, interleaved) */
    #pragma omp parallel for schedule(static) reduction(min : bad) reduction(+ : me, mc) \
        if (3 * op->n >= LRR__PARALLEL_MIN / 8)
    for (size_t p = 0; p < k; p++) {
        double acc[3] = {0, 0, 0}, dacc[3] = {0, 0, 0};
        int changed = 0;
        if (prev || !lrr__segment_sum(op->weight, E, first[p], first[p + 1], acc)) {
            acc[0] = acc[1] = acc[2] = 0;
            for (size_t i = first[p]; i < first[p + 1]; i++)
                for (int c = 0; c < 3; c++) {
                    float e = E[3 * i + c], v = op->weight[i];
                    if (!(e >= 0.0f) || !isfinite(e))
                        bad = bad < 3 * i + c ? bad : 3 * i + c;
                    acc[c] += v * e;
                    if (prev && e != prev[3 * i + c]) {
                        changed = 1;
                        dacc[c] += v * ((double)e - prev[3 * i + c]);
                    }
                }
        }
        for (int c = 0; c < 3; c++) {
            s->w[c * k + p] = (float)acc[c];
            s->dw[c * k + p] = (float)dacc[c];
        }
        s->nz[p] = acc[0] != 0 || acc[1] != 0 || acc[2] != 0;
        s->ch[p] = (unsigned char)changed;
        me += s->nz[p];
        mc += s->ch[p];
    }
    if (bad != SIZE_MAX)
        return lrr__emission_error(op->ctx, E, bad);
    *m_emit = me;
    *m_changed = mc;
    return LRR_OK;
}

/* Fills cache columns for the flagged patches that lack one. Returns 0 when they do not
 * fit (nothing is cached then). */
static int ensure_columns(lrr_solver *s, const unsigned char *flag)
{
    const lrr_operator *op = s->op;
    const size_t n = op->n, k = op->k;
    size_t missing = 0;
    for (size_t p = 0; p < k; p++)
        missing += flag[p] && (!s->slot || s->slot[p] == NO_SLOT);
    if (missing == 0)
        return 1;
    if (!s->slot)
        return 0;
    if (s->used + missing > s->cap) {
        /* a new set of emitters: start over if it fits on its own */
        size_t need = 0;
        for (size_t p = 0; p < k; p++)
            need += flag[p];
        if (need > s->cap)
            return 0;
        for (size_t p = 0; p < k; p++)
            s->slot[p] = NO_SLOT;
        s->used = 0;
    }
    if (!s->ones) {
        /* optional: without them the frame takes the full path, so a failure here is not
         * an error and records none (n×3 floats fit: the operator holds such arrays) */
        s->ones = lrr__zalloc(op->ctx, n * 3 * sizeof(float));
        s->zeros = lrr__zalloc(op->ctx, n * 3 * sizeof(float));
        if (!s->ones || !s->zeros) {
            lrr_aligned_free(s->zeros);
            s->zeros = NULL;
            lrr_aligned_free(s->ones);
            s->ones = NULL;
            return 0;
        }
        for (size_t j = 0; j < 3 * n; j++)
            s->ones[j] = 1.0f;
    }
    for (size_t p = 0; p < k; p++) {
        if (!flag[p] || s->slot[p] != NO_SLOT)
            continue;
        /* Y_c[:, p] = F̄ M_c[:, p]: the fused kernel with z = column p of each M_c */
        for (int c = 0; c < 3; c++)
            for (size_t q = 0; q < k; q++)
                s->z[c * k + q] = op->m[(size_t)c * k * k + q * k + p];
        size_t slot = s->used++;
        fbar_apply_frames(s, 1, s->z, s->zeros, s->ones, s->cols + slot * n * 3);
        s->slot[p] = slot;
    }
    return 1;
}

/* out = base + rho ∘ Σ_{flagged p} Y[:, p] ∘ coef_p (coef 3×k channel-major), plus add
 * (n×3, may be NULL). base and out are n×3 and may alias. */
static void combine_columns(const lrr_solver *s, const unsigned char *flag, const float *base,
                            const float *add, const float *coef, float *out)
{
    const lrr_operator *op = s->op;
    const size_t n = op->n, k = op->k;
    size_t list_len = 0;
    for (size_t p = 0; p < k; p++)
        list_len += flag[p];
    #pragma omp parallel for schedule(static) if (3 * n * list_len >= LRR__PARALLEL_MIN)
    for (size_t b = 0; b < (n + 255) / 256; b++) {
        size_t i0 = b * 256, i1 = i0 + 256 < n ? i0 + 256 : n;
        float t[256 * 3];
        memset(t, 0, sizeof t);
        for (size_t p = 0; p < k && list_len; p++) {
            if (!flag[p])
                continue;
            const float *y = s->cols + s->slot[p] * n * 3;
            const float cr = coef[p], cg = coef[k + p], cb = coef[2 * k + p];
            for (size_t i = i0; i < i1; i++) {
                t[3 * (i - i0)] += y[3 * i] * cr;
                t[3 * (i - i0) + 1] += y[3 * i + 1] * cg;
                t[3 * (i - i0) + 2] += y[3 * i + 2] * cb;
            }
        }
        for (size_t j = 3 * i0; j < 3 * i1; j++) {
            float v = base[j] + op->rho[j] * t[j - 3 * i0];
            out[j] = add ? v + add[j] : v;
        }
    }
}

lrr_status lrr_solve(lrr_solver *s, const float *E, float *B)
{
    const lrr_operator *op = s->op;
    const size_t n = op->n, k = op->k;
    if (E == B)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "emission and radiosity may not alias");
    if (s->cl) {
        /* validated here, before upload, so the message is the CPU solver's */
        lrr_status st = lrr__emission_check(op->ctx, n, E);
        return st ? st : lrr__cl_solve(s->cl, E, B);
    }
    if (s->m_epoch != op->m_epoch) {
        /* new reflectances (lrr_operator_set_reflectance): what was made from M is stale */
        lrr_status st = s->m16 ? lrr_solver_set_m(s, LRR_STORAGE_F16) : LRR_OK;
        if (st)
            return st;
        for (size_t p = 0; s->slot && p < k; p++)
            s->slot[p] = NO_SLOT;
        s->used = 0;
        s->have_prev = 0;
        s->m_epoch = op->m_epoch;
    }
    const int want_prev = s->path == LRR_PATH_AUTO || s->path == LRR_PATH_INCREMENTAL;
    if (want_prev && !s->e_prev) {
        lrr_status st;
        if ((st = lrr__calloc(op->ctx, &s->e_prev, n, 3 * sizeof(float), "previous E")) ||
            (st = lrr__calloc(op->ctx, &s->b_prev, n, 3 * sizeof(float), "previous B")))
            return st;
    }
    const int can_incr = want_prev && s->have_prev && s->since_full < INCREMENTAL_LIMIT;
    size_t m_emit = 0, m_changed = 0;
    lrr_status st = segment_sums(s, E, can_incr ? s->e_prev : NULL, &m_emit, &m_changed);
    if (st)
        return st;
    /* bytes each path reads: a full frame F̄ and M; a column path 12 bytes per subpatch per
     * patch involved (+ previous E and B for the incremental one) */
    const double full =
        (double)fbar_bytes(s) + (s->m16 ? (double)lrr__m_f16_bytes(k) : 12.0 * k * k);
    const double sparse = 12.0 * n * (double)m_emit;
    const double incr = can_incr ? 12.0 * n * (double)m_changed + 24.0 * n : INFINITY;
    lrr_path path = s->path;
    if (path == LRR_PATH_AUTO) {
        /* a column path must at least halve the bytes, and its columns must fit */
        path = LRR_PATH_FULL;
        double best = full / 2;
        if (m_emit <= s->cap && sparse < best) {
            path = LRR_PATH_SPARSE;
            best = sparse;
        }
        if (m_changed <= s->cap && incr < best)
            path = LRR_PATH_INCREMENTAL;
    }
    if (path == LRR_PATH_INCREMENTAL && !can_incr)
        path = LRR_PATH_FULL; /* nothing to increment from yet (or time to re-anchor) */
    if (path == LRR_PATH_SPARSE && !ensure_columns(s, s->nz))
        path = LRR_PATH_FULL;
    if (path == LRR_PATH_INCREMENTAL && !ensure_columns(s, s->ch))
        path = LRR_PATH_FULL;

    if (path == LRR_PATH_INCREMENTAL) {
        /* B = B_prev + (E − E_prev) + rho ∘ Σ Y Δw; the ΔE term is added per entry */
        float *delta = s->e_prev; /* becomes E − E_prev, then is overwritten by E below */
        for (size_t j = 0; j < 3 * n; j++)
            delta[j] = E[j] - delta[j];
        combine_columns(s, s->ch, s->b_prev, delta, s->dw, B);
        s->since_full++;
    } else if (path == LRR_PATH_SPARSE) {
        combine_columns(s, s->nz, E, NULL, s->w, B);
        s->since_full = 0;
    } else {
        if (s->m16)
            lrr__smw_apply_f16(s->kernel, s->m16->val, s->m16->scale, k, s->w, s->z);
        else
            lrr__smw_apply(s->kernel, op->m, k, s->w, s->z);
        fbar_apply_frames(s, 1, s->z, E, op->rho, B);
        s->since_full = 0;
    }
    s->last = path;
    if (want_prev) {
        memcpy(s->e_prev, E, 3 * n * sizeof(float));
        memcpy(s->b_prev, B, 3 * n * sizeof(float));
        s->have_prev = 1;
    }
    return LRR_OK;
}

/* ------------------------------------------------------------------ batches */


/* count ≤ BATCH_CHUNK frames of already validated emission: W by segmented sums, Z_c =
 * M_c W_c by sgemm (k×k × k×count: M is read once, not once a frame), then one pass over F̄
 * in blocks of rows, each block applied to every frame while it is in cache
 * (lrr__fbar_apply_frames), so F̄ comes from memory once per batch. */
static lrr_status batch_frames(lrr_solver *s, size_t count, const float *E, float *B)
{
    const lrr_operator *op = s->op;
    lrr_context *ctx = op->ctx;
    const size_t n = op->n, k = op->k, *first = op->geom.first, frame = 3 * n;
    if (count > s->batch_cap) {
        lrr_aligned_free(s->bw);
        lrr_aligned_free(s->bz);
        s->bw = s->bz = NULL;
        s->batch_cap = 0;
        lrr_status st;
        if ((st = lrr__calloc(ctx, &s->bw, k, 3 * count * sizeof(float), "batch W")) ||
            (st = lrr__calloc(ctx, &s->bz, k, 3 * count * sizeof(float), "batch Z")))
            return st;
        s->batch_cap = count;
    }
    /* W_c (k×count, channel-major blocks): segmented sums */
    #pragma omp parallel for schedule(static) if (3 * n * count >= LRR__PARALLEL_MIN)
    for (size_t p = 0; p < k; p++)
        for (size_t f = 0; f < count; f++) {
            const float *e = E + f * frame;
            double acc[3];
            (void)lrr__segment_sum(op->weight, e, first[p], first[p + 1], acc); /* validated */
            for (int c = 0; c < 3; c++)
                s->bw[((size_t)c * k + p) * count + f] = (float)acc[c];
        }
    /* z of frame f (3×k, channel-major, as one frame's z) at bz + 3k·f: Z_cᵀ = W_cᵀ M_cᵀ,
     * count×k with leading dimension 3k */
    const int ki = (int)k, cnt = (int)count;
    for (int c = 0; c < 3; c++)
        cblas_sgemm(CblasRowMajor, CblasTrans, CblasTrans, cnt, ki, ki, 1.0f,
                    s->bw + (size_t)c * k * count, cnt, op->m + (size_t)c * k * k, ki, 0.0f,
                    s->bz + (size_t)c * k, 3 * ki);
    fbar_apply_frames(s, count, s->bz, E, op->rho, B);
    return LRR_OK;
}

void lrr__solver_batch_thresholds(lrr_solver *s, size_t min_count, size_t min_bytes)
{
    s->gemm_min_count = min_count;
    s->gemm_min_bytes = min_bytes;
}

lrr_status lrr_solve_batch(lrr_solver *s, size_t count, const float *E, float *B)
{
    const lrr_operator *op = s->op;
    lrr_context *ctx = op->ctx;
    const size_t n = op->n, k = op->k;
    if (count == 0)
        return LRR_OK;
    const size_t frame = 3 * n;
    size_t total;
    if (!lrr__mul_size(frame, count, &total) || k > INT32_MAX / (3 * BATCH_CHUNK) ||
        n > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "a batch of %zu frames of n = %zu overflows",
                          count, n);
    if ((const void *)E < (const void *)(B + total) && (const void *)B < (const void *)(E + total))
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "emission and radiosity may not overlap");
    /* validate every frame first, so a bad value leaves B untouched and names its frame */
    size_t bad = SIZE_MAX;
    #pragma omp parallel for schedule(static) reduction(min : bad) if (total >= LRR__PARALLEL_MIN)
    for (size_t j = 0; j < total; j++)
        if (!(E[j] >= 0.0f) || !isfinite(E[j]))
            bad = bad < j ? bad : j;
    if (bad != SIZE_MAX)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "frame %zu: emission of subpatch %zu, channel %zu = %g (must be "
                          "finite and >= 0)",
                          bad / frame, bad % frame / 3, bad % 3, (double)E[bad]);
    if (s->cl || count < s->gemm_min_count || fbar_bytes(s) < s->gemm_min_bytes) {
        /* one fused pass per frame (OpenCL frames loop) */
        for (size_t f = 0; f < count; f++) {
            lrr_status st = lrr_solve(s, E + f * frame, B + f * frame);
            if (st)
                return st;
        }
        return LRR_OK;
    }
    for (size_t f0 = 0; f0 < count; f0 += BATCH_CHUNK) {
        size_t c = count - f0 < BATCH_CHUNK ? count - f0 : BATCH_CHUNK;
        lrr_status st = batch_frames(s, c, E + f0 * frame, B + f0 * frame);
        if (st)
            return st;
    }
    s->have_prev = 0; /* the single-frame history no longer describes the last frame */
    s->last = LRR_PATH_FULL;
    return LRR_OK;
}
