/* The solve stage (lib/solve/): the real-time step on the CPU (row kernels chosen at run
 * time) and on an OpenCL device. */
#ifndef LRR_SOLVE_H
#define LRR_SOLVE_H

#include "core/cpu.h"
#include "operator/operator.h"

struct lrr__kernel;

/* ------------------------------------------------------------ sparse F̄ (sparse.c) */
/* Tiles of LRR__TILE rows and the AUTO rule are in operator.h (tiles.c; sparse.c says why
 * 16 rows). */
typedef struct lrr__sparse {
    size_t n, k, tiles, strips, nonzeros, bytes;
    lrr_storage storage;
    size_t *start;       /* tiles + 1: tile t's strips are [start[t], start[t + 1]) */
    uint16_t *col;       /* strips: each strip's column, ascending within a tile */
    float *val;          /* F32: strips × LRR__TILE values (rows past n are 0) */
    uint16_t *val16;     /* F16, BF16: the operator's codes, likewise */
    const float *scale;  /* the operator's row scales (16-bit), else NULL */
    size_t *chunk;       /* chunks + 1 tile boundaries of about equal strip bytes */
    size_t chunks;
} lrr__sparse;
typedef struct lrr__sparse_stats {
    size_t nonzeros, strips, bytes; /* bytes: what a frame reads of the sparse F̄ */
} lrr__sparse_stats;
/* Counts F̄'s strips (stats) and, for LRR_FBAR_SPARSE or an AUTO that favours it, builds
 * the sparse copy (*out; NULL when dense is kept). LRR_ERR_UNSUPPORTED for a forced sparse
 * F̄ whose k exceeds the 16-bit column index. */
lrr_status lrr__sparse_create(const lrr_operator *op, lrr_fbar_format format,
                              lrr__sparse_stats *stats, lrr__sparse **out);
void lrr__sparse_destroy(lrr__sparse *sp);
/* B_c = E_c + rho_c ∘ (F̄ z_c) for count frames (as lrr__fbar_apply_frames) */
void lrr__sparse_apply_frames(const struct lrr__kernel *kn, const lrr__sparse *sp,
                              size_t count, const float *z, const float *E, const float *rho,
                              float *B);
/* tiles [t0, t1) of one frame: the kernels (sparse.c portable, realtime_avx2.c,
 * realtime_avx512.c) and their shared epilogue (acc[c][r]: tile row r, channel c) */
void lrr__sparse_epilogue(const lrr__sparse *sp, size_t t, float acc[3][LRR__TILE],
                          const float *E, const float *rho, float *B);
#define LRR__DECLARE_SPARSE(ISA)                                                             \
    void lrr__sparse_tiles_##ISA(const lrr__sparse *, size_t, size_t, const float *,         \
                                 const float *, const float *, float *);
LRR__DECLARE_SPARSE(c)
LRR__DECLARE_SPARSE(avx2)
LRR__DECLARE_SPARSE(avx512)

/* ------------------------------------------------------------ real-time kernels */
/* One instruction-set variant of the two row kernels (realtime_kernel.c). */
typedef struct lrr__kernel {
    const char *name; /* its LRR_SIMD name (core/cpu.h): "c", "avx2", "avx512+prefetch", … */
    lrr__isa isa;
    int prefetch;     /* the panels' software prefetch (panel_kernel.c) */
    /* rows [i0, i1): B_c = E_c + rho_c ∘ (F̄ z_c), z 3×k channel-major */
    void (*fbar_rows)(const float *fbar, size_t i0, size_t i1, size_t k, const float *z,
                      const float *E, const float *rho, float *B);
    /* the same with F̄ stored as binary16 / bfloat16, row i scaled by scale[i] */
    void (*f16_rows)(const uint16_t *fbar, const float *scale, size_t i0, size_t i1, size_t k,
                     const float *z, const float *E, const float *rho, float *B);
    void (*bf16_rows)(const uint16_t *fbar, const float *scale, size_t i0, size_t i1,
                      size_t k, const float *z, const float *E, const float *rho, float *B);
    /* rows [i0, i1) of y = A x, A row-major with k columns */
    void (*gemv_rows)(const float *a, size_t i0, size_t i1, size_t k, const float *x, float *y);
    /* the same with A stored as binary16, row i scaled by scale[i] (M − I, m_f16.c) */
    void (*gemv_f16_rows)(const uint16_t *a, const float *scale, size_t i0, size_t i1, size_t k,
                          const float *x, float *y);
    /* fbar_rows and the 16-bit pair over F̄ in panels (operator.h), rows [i0, i1) a whole
     * number of panels (panel_kernel.c) */
    void (*fbar_panels)(const float *fbar, size_t i0, size_t i1, size_t k, const float *z,
                        const float *E, const float *rho, float *B);
    void (*f16_panels)(const uint16_t *fbar, const float *scale, size_t i0, size_t i1,
                       size_t k, const float *z, const float *E, const float *rho, float *B);
    void (*bf16_panels)(const uint16_t *fbar, const float *scale, size_t i0, size_t i1,
                        size_t k, const float *z, const float *E, const float *rho, float *B);
    /* tiles [t0, t1) of a sparse F̄ (sparse.c), any storage */
    void (*sparse_tiles)(const lrr__sparse *sp, size_t t0, size_t t1, const float *z,
                         const float *E, const float *rho, float *B);
} lrr__kernel;

/* panel_kernel.c's variants (the signatures of lrr__kernel's *_panels) */
#define LRR__DECLARE_PANELS(ISA)                                                             \
    void lrr__panels_f32_##ISA(const float *, size_t, size_t, size_t, const float *,       \
                               const float *, const float *, float *);                     \
    void lrr__panels_f16_##ISA(const uint16_t *, const float *, size_t, size_t, size_t,    \
                               const float *, const float *, const float *, float *);      \
    void lrr__panels_bf16_##ISA(const uint16_t *, const float *, size_t, size_t, size_t,   \
                                const float *, const float *, const float *, float *);
LRR__DECLARE_PANELS(c)
LRR__DECLARE_PANELS(avx2)
LRR__DECLARE_PANELS(avx512)
LRR__DECLARE_PANELS(avx2_pf)
LRR__DECLARE_PANELS(avx512_pf)

/* M − I in binary16 with a power-of-two scale per row (m_f16.c): what a full frame reads of
 * M when F̄ is 16-bit. val holds channel c's row i at (c·k + i)·k, scale at c·k + i. */
typedef struct lrr__m_f16 {
    size_t k;
    uint16_t *val;
    float *scale;
} lrr__m_f16;
lrr_status lrr__m_f16_create(const lrr_operator *op, lrr__m_f16 **out);
void lrr__m_f16_destroy(lrr__m_f16 *m);
size_t lrr__m_f16_bytes(size_t k); /* what a frame reads of it */
/* z_c = w_c + scale_c ∘ (H_c w_c) for H = M − I as lrr__m_f16 holds it */
void lrr__smw_apply_f16(const struct lrr__kernel *kn, const uint16_t *m16, const float *scale,
                        size_t k, const float *w, float *z);

/* Σ_i weight_i·E_i over subpatches [i0, i1) per channel into acc (segment_sum.c); 0 when an
 * entry may be negative, NaN or infinite, for the caller's scan. */
int lrr__segment_sum(const float *weight, const float *E, size_t i0, size_t i1, double acc[3]);

/* The variant of choice (lrr__cpu_choose: LRR_SIMD, else the widest this CPU runs) for
 * rows of k entries. */
const lrr__kernel *lrr__kernel_select(const lrr__cpu_choice *choice, size_t k);
/* z (3×k, channel-major) = M_c w_c (w likewise), M = three k×k row-major blocks. */
void lrr__smw_apply(const lrr__kernel *kn, const float *m, size_t k, const float *w, float *z);
/* B_c = E_c + rho_c ∘ (F̄ z_c) for count frames (z: 3k per frame, E and B: 3n per frame,
 * rho shared; rho is usually op->rho), F̄ dense in the operator's storage and layout: each
 * block of rows serves every frame while it is in cache, so F̄ is read once. */
void lrr__fbar_apply_frames(const lrr__kernel *kn, const lrr_operator *op, size_t count,
                            const float *z, const float *E, const float *rho, float *B);

/* Tests only: when lrr_solve_batch takes the batched pass (at least min_count frames and
 * F̄ of at least min_bytes), so small test operators can exercise both ways. */
void lrr__solver_batch_thresholds(lrr_solver *s, size_t min_count, size_t min_bytes);

/* ------------------------------------------------------------ OpenCL backend */
/* Validates one frame of emission (3n entries): finite and >= 0, the message naming the
 * subpatch and channel; shared by the CPU and OpenCL solvers so both say the same. */
lrr_status lrr__emission_check(lrr_context *ctx, size_t n, const float *E);
/* The error for entry `bad` of E (index 3·subpatch + channel). */
lrr_status lrr__emission_error(lrr_context *ctx, const float *E, size_t bad);

/* The device side of an OpenCL solver (solve_opencl.c); without OpenCL support create
 * returns LRR_ERR_UNSUPPORTED. */
typedef struct lrr__cl_solver lrr__cl_solver;
/* F̄ goes up as `format` says (lrr__sparse_create's choice; stats its counts). */
lrr_status lrr__cl_create(const lrr_operator *op, lrr_fbar_format format,
                          lrr__sparse_stats *stats, lrr__cl_solver **out);
/* F̄ on the device dense or as strips from now on (lrr_solver_set_fbar). */
lrr_status lrr__cl_set_fbar(lrr__cl_solver *cl, lrr_fbar_format format,
                            lrr__sparse_stats *stats);
/* The bytes of F̄ a frame reads on the device: dense, or (*sparse = 1) the strips with their
 * indices. */
size_t lrr__cl_fbar_bytes(const lrr__cl_solver *cl, int *sparse);
void lrr__cl_destroy(lrr__cl_solver *cl);
const char *lrr__cl_name(const lrr__cl_solver *cl); /* "opencl:<device name>" */
/* One full pass for validated E: E up, three kernels, B down. */
lrr_status lrr__cl_solve(lrr__cl_solver *cl, const float *E, float *B);
/* The last frame's kernel and transfer times (profiling events; 0 before the first frame). */
void lrr__cl_timings(const lrr__cl_solver *cl, double *kernel_ms, double *transfer_ms);
/* Tests only: the GPU kernels (segsum_groups, smw_groups, fbar_panels or fbar_groups) or
 * the CPU devices' (segsum, smw, fbar_rows). */
void lrr__cl_use_groups(lrr__cl_solver *cl, int groups);
/* The last frame's kernel times for w, z and B (ms; tests and diagnostics). */
void lrr__cl_step_times(const lrr__cl_solver *cl, double ms[3]);
void lrr__solver_opencl_step_times(const lrr_solver *s, double ms[3]);
void lrr__solver_opencl_groups(lrr_solver *s, int groups);
/* Tests only: F̄ uploaded again in the operator's panels (1, what GPUs get) or as rows (0,
 * what CPU devices get). */
lrr_status lrr__cl_fbar_panels(lrr__cl_solver *cl, int panels);
lrr_status lrr__solver_opencl_panels(lrr_solver *s, int panels);
/* lib/solve/realtime.cl as a string (generated at build time). */
extern const char lrr__kernel_realtime_cl[];
#endif
