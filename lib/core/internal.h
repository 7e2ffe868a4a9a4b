/* Internal declarations shared by the library's files. Not installed. */
#ifndef LRR_INTERNAL_H
#define LRR_INTERNAL_H

#include "lrr.h"
#include <pthread.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>

/* ------------------------------------------------------------ context and errors */
struct lrr_context {
    int refs;                 /* guarded by lock */
    pthread_mutex_t lock;
    lrr_error_fn callback;
    void *callback_user;
    lrr_status first_status;  /* first error since the last lrr_context_last_error() */
    char first_message[512];
    /* Tests only (allocation-failure injection), guarded by lock: every allocation made
     * through lrr__alloc/lrr__calloc/lrr__realloc with this context counts; when fail_at is
     * non-zero the fail_at-th one returns NULL. */
    unsigned long alloc_count;
    unsigned long fail_at;
    /* Tests only (I/O fault injection, see lrr__context_set_io_hook), guarded by lock. */
    int (*io_hook)(void *user, unsigned long step, const char *what);
    void *io_user;
    unsigned long io_steps;
};

lrr_context *lrr__context_retain(lrr_context *ctx);
void lrr__context_release(lrr_context *ctx);

/* Records an error on ctx (printf-style message naming what and where) and returns status.
 * ctx may be NULL (then only the status is returned). */
lrr_status lrr__error(lrr_context *ctx, lrr_status status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));

/* ------------------------------------------------------------ checked sizes and memory */
/* *out = a*b; returns false on overflow. */
static inline bool lrr__mul_size(size_t a, size_t b, size_t *out)
{
    return !__builtin_mul_overflow(a, b, out);
}
/* Allocates count*elem zeroed bytes, 64-byte aligned. On failure records LRR_ERR_OVERFLOW or
 * LRR_ERR_NOMEM naming `what`, sets *out = NULL. count == 0 gives a valid 64-byte block. */
lrr_status lrr__calloc(lrr_context *ctx, void *out, size_t count, size_t elem, const char *what);
/* malloc / zeroed malloc / realloc counted on ctx (which may be NULL): every library
 * allocation goes through these or lrr__calloc so that tests can make one fail. They record
 * no error; the caller does. Free with free() (or lrr_aligned_free, the same). */
void *lrr__alloc(lrr_context *ctx, size_t bytes);
void *lrr__zalloc(lrr_context *ctx, size_t bytes);
void *lrr__realloc(lrr_context *ctx, void *p, size_t bytes);
/* Tests only: makes the n-th allocation counted from now on ctx fail (0: none) and resets the
 * count; lrr__context_alloc_count gives the number of allocations counted since. */
void lrr__context_fail_after(lrr_context *ctx, unsigned long n);
unsigned long lrr__context_alloc_count(lrr_context *ctx);

/* Tests only: I/O fault injection. lrr_operator_save calls lrr__io_step before each of its
 * I/O steps (creating the temporary file, every block it writes, the flush, the fsync, the
 * close, the rename and the directory sync), which calls hook(user, step, what) with the
 * steps counted from 1 since the hook was set. A non-zero return is the errno that step fails
 * with (the step is not attempted; the close still releases the file; the directory sync is
 * best effort, so its failure is ignored). The hook may also not return (a test raises
 * SIGKILL there). hook = NULL turns it off. */
typedef int (*lrr__io_hook_fn)(void *user, unsigned long step, const char *what);
void lrr__context_set_io_hook(lrr_context *ctx, lrr__io_hook_fn hook, void *user);
/* The injected errno for the next step (0: go ahead); 0 without a hook or a context. */
int lrr__io_step(lrr_context *ctx, const char *what);

/* ------------------------------------------------------------ geometry and hierarchy */
/* Input triangles and their subdivision; shared by scenes and operators.
 * Triangle t is split into 4^depth[t] patches, numbered patch0[t] .. patch0[t+1]-1, and each
 * patch into d = 4^levels subpatches. Children of a split (a,b,c) are, in order:
 *   0 (a, ab, ca)   1 (ab, b, bc)   2 (ca, bc, c)   3 (bc, ca, ab)
 * where ab is the midpoint of a and b. A patch/subpatch's local index is its sequence of
 * child digits, most significant first (base 4), so every node of a triangle's quadtree
 * covers a contiguous, aligned range of its subpatches.
 *
 * Adaptive hierarchy (node != NULL): depth[t] is then the subpatch depth of triangle t,
 * levels = 0 and d = 0, and the patches are quadtree nodes of varying depth node[p] <=
 * depth[t]: patch p holds the 4^(depth[t] - node[p]) subpatches first[p] .. first[p+1]-1.
 * first and sub0 exist in both cases (uniform: first[p] = p·d, sub0[t] = patch0[t]·d), so
 * code that walks patches' subpatches need not know which hierarchy it has. */
typedef struct lrr__geometry {
    size_t n_tri;
    float *vert;        /* n_tri×9 */
    uint8_t *depth;     /* n_tri, patch depth (adaptive: subpatch depth); NULL until subdivided */
    size_t *patch0;     /* n_tri+1: first patch of each triangle; NULL until subdivided */
    size_t *sub0;       /* n_tri+1: first subpatch of each triangle */
    size_t *first;      /* k+1: first subpatch of each patch */
    uint8_t *node;      /* k: quadtree depth of each patch (adaptive only, else NULL) */
    unsigned levels;
    size_t d, k, n;     /* d = 4^levels (0 if adaptive), k patches, n subpatches */
} lrr__geometry;

void lrr__geometry_free(lrr__geometry *g);
/* Deep copy (dst is overwritten). */
lrr_status lrr__geometry_copy(lrr_context *ctx, lrr__geometry *dst, const lrr__geometry *src);
/* Computes patch0/sub0/first/k/n/d from depth and levels (uniform hierarchy); checks for
 * overflow, and refuses (before allocating the offsets) more than max_subpatches
 * subpatches: a file's depths must not make the loader allocate beyond what its header
 * and size allow. */
lrr_status lrr__geometry_index(lrr_context *ctx, lrr__geometry *g, size_t max_subpatches);
/* dst = the adaptive hierarchy over src's subpatches (src uniform with levels = 0) whose
 * patches are the k quadtree nodes of depth node[0..k-1], in index order. Checks that they
 * tile every triangle (each node aligned, inside its triangle, no gaps); errors (status
 * `bad`) name `where` and the patch. */
lrr_status lrr__geometry_adaptive(lrr_context *ctx, const lrr__geometry *src,
                                  const uint8_t *node, size_t k, const char *where,
                                  lrr_status bad, lrr__geometry *dst);
/* Subpatches in patch p. */
static inline size_t lrr__patch_size(const lrr__geometry *g, size_t p)
{
    return g->first[p + 1] - g->first[p];
}
/* Patch holding subpatch i. */
size_t lrr__patch_of(const lrr__geometry *g, size_t i);

/* Index of the child containing barycentric (b0,b1,b2), rewriting them to the child's. */
static inline unsigned lrr__child_at(double *b0, double *b1, double *b2)
{
    double u = *b0, v = *b1, w = *b2;
    if (u >= 0.5) { *b0 = 2 * u - 1; *b1 = 2 * v; *b2 = 2 * w; return 0; }
    if (v >= 0.5) { *b0 = 2 * u; *b1 = 2 * v - 1; *b2 = 2 * w; return 1; }
    if (w >= 0.5) { *b0 = 2 * u; *b1 = 2 * v; *b2 = 2 * w - 1; return 2; }
    *b0 = 1 - 2 * u; *b1 = 1 - 2 * v; *b2 = 1 - 2 * w; return 3;
}
/* Subpatch index of barycentric point (b1, b2) (b0 = 1-b1-b2) of triangle t. */
size_t lrr__subpatch_at(const lrr__geometry *g, size_t t, double b1, double b2);
/* Patch index only (used by the hemicube item buffer). */
size_t lrr__patch_at(const lrr__geometry *g, size_t t, double b1, double b2);
/* Triangle that owns subpatch i (binary search on sub0). */
size_t lrr__subpatch_triangle(const lrr__geometry *g, size_t i);
/* Vertices (9 doubles) of subpatch i, in the triangle's orientation. */
void lrr__subpatch_vertices(const lrr__geometry *g, size_t i, double v[9]);
/* Per-subpatch centre (n×3), unit normal (n×3) and area (n); any may be NULL. */
void lrr__subpatch_frames(const lrr__geometry *g, float *centre, float *normal, float *area);

/* ------------------------------------------------------------ scene */
enum { LRR__SCENE_FILE = 0, LRR__SCENE_CORNELL = 1, LRR__SCENE_CORNELL_CLOSED = 2 };

struct lrr_scene {
    lrr_context *ctx;
    int builtin;          /* LRR__SCENE_* : chooses the render camera */
    size_t skipped;       /* zero-area triangles removed */
    lrr__geometry geom;
    float *rho;           /* n_tri×3 */
    float *emission;      /* n_tri×3 */
    double max_patch_area;
};

/* Checks a PLY file (f at its start, file_size bytes) before assimp reads it: a strict
 * header, and a body that holds what the header declares (scene_ply.c). */
lrr_status lrr__ply_check(lrr_context *ctx, const char *path, FILE *f, uint64_t file_size);
/* Validates and takes a copy of the arrays: NaN/Inf coordinates and bad materials are errors
 * naming `source` and the face index face_ids[t] (or t when face_ids is NULL); zero-area
 * triangles are skipped and counted. */
lrr_status lrr__scene_from_arrays(lrr_context *ctx, size_t n_tri, const float *vert,
                                  const float *rho, const float *emission,
                                  const size_t *face_ids, const char *source, int builtin,
                                  lrr_scene **out);

/* scene_import.c: every imported triangle, degenerate ones included, with its face number
 * (nothing validated); free the arrays with lrr_aligned_free. For the scene check. */
lrr_status lrr__scene_import_raw(lrr_context *ctx, const char *path, size_t *n_tri,
                                 float **vert, float **rho, float **emission,
                                 size_t **face_ids);

/* ------------------------------------------------------------ operator */
struct lrr_operator {
    lrr_context *ctx;
    int builtin;               /* LRR__SCENE_* of the source scene */
    lrr__geometry geom;
    size_t n, k, d;
    float *rho;                /* n×3 */
    float *emission;           /* n×3, the scene's own emission */
    float *area;               /* n */
    float *centre, *normal;    /* n×3, derived from geom (not stored in files) */
    lrr_storage storage;       /* which of fbar / fbar16 holds F̄ */
    float *fbar;               /* n×k row-major, 64-byte aligned: F̄_ip = F_{i→p}/d (F32) */
    uint16_t *fbar16;          /* n×k binary16 or bfloat16 (F16, BF16), F̄_ip / row_scale_i */
    float *row_scale;          /* n powers of two (F16, BF16; all 1 for BF16) */
    float *m;                  /* 3×k×k row-major: M_c = G_c^{-1} */
    double cond[3];            /* dgecon estimates (1-norm) of G_c */
    double build_seconds;
    double selection_seconds;  /* adaptive selection's part of build_seconds */
    unsigned hemicube_resolution;
    uint64_t seed;
    int no_rotation;           /* built with lrr_build_options.no_rotation */
};

/* Allocates an operator for geometry g (copied): rho, emission, area, centre, normal, m and
 * F̄ in the given storage (fbar, or fbar16 + row_scale) are allocated (zeroed);
 * area/centre/normal are filled from the geometry. */
lrr_status lrr__operator_new(lrr_context *ctx, const lrr__geometry *g, lrr_storage storage,
                             lrr_operator **out);

/* Round-to-nearest-even conversions (storage.c). */
uint16_t lrr__f32_to_f16(float f);
float lrr__f16_to_f32(uint16_t h);
uint16_t lrr__f32_to_bf16(float f);
float lrr__bf16_to_f32(uint16_t b);
/* The options of lrr_operator_build and lrr_reference_build with defaults filled in
 * (opts may be NULL); checks that the scene is subdivided and the thread count. */
lrr_status lrr__build_options_resolve(const lrr_scene *scene, const lrr_build_options *opts,
                                      lrr_build_options *o);
/* budget.c: the bytes an operator build holds at its peak (the layout is described there),
 * for n_tri input triangles, n subpatches, k patches, F̄ in `storage` and the resolved build
 * options o (hemicube resolution, threads, backend). Overflow-checked: LRR_ERR_OVERFLOW,
 * naming n and k, when a byte count does not fit in size_t; LRR_ERR_INVALID_ARG for a bad
 * hemicube resolution. Allocates nothing. */
typedef struct lrr__operator_bytes_t {
    size_t fbar;          /* F̄ (and its row scales) */
    size_t m;             /* M_c, 3×k×k floats */
    size_t per_subpatch;  /* 13 floats per subpatch and the geometry */
    size_t working;       /* the build's largest working set (hemicubes or factorisation) */
    size_t total;
    int threads;          /* the thread count the working set was computed for */
} lrr__operator_bytes_t;
lrr_status lrr__operator_bytes(lrr_context *ctx, size_t n_tri, size_t n, size_t k,
                               lrr_storage storage, const lrr_build_options *o,
                               lrr__operator_bytes_t *out);
/* lrr__operator_bytes, then LRR_ERR_BUDGET naming the need (in MiB, with its parts) when it
 * exceeds o->memory_budget (0: no limit). */
lrr_status lrr__operator_budget_check(lrr_context *ctx, size_t n_tri, size_t n, size_t k,
                                      lrr_storage storage, const lrr_build_options *o);
/* Bytes of hemicube.c's per-triangle table entry (16 doubles; checked there). */
#define LRR__HEMICUBE_TRI_BYTES ((size_t)16 * sizeof(double))
/* Recomputes m and cond from fbar and rho (double precision LAPACKE). */
lrr_status lrr__operator_factor(lrr_operator *op);

/* ------------------------------------------------------------ hemicube */
typedef struct lrr__multiplier_map {
    unsigned res;          /* R */
    double *top;           /* R×R delta form factors */
    double *side;          /* (R/2)×R: row 0 at the horizon, columns across the face */
    double raw_sum;        /* midpoint-rule total before normalisation (→ 1 as R grows) */
} lrr__multiplier_map;

lrr_status lrr__multiplier_map_create(lrr_context *ctx, unsigned res, lrr__multiplier_map *m);
void lrr__multiplier_map_free(lrr__multiplier_map *m);

/* Fills fbar (n×k) from geometry g with one hemicube per subpatch. */
lrr_status lrr__hemicube_fbar(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, float *fbar);
/* The same hemicubes with subpatch columns when by_subpatch (out n×n: the full F, not
 * divided by d) or patch columns otherwise (out n×k: F̄). */
lrr_status lrr__hemicube_rows(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, int by_subpatch, float *out);

/* Rows rows[0..count-1] of the full F (count×n, subpatch columns, not divided by d) from the
 * same hemicubes (same per-receiver rotation) as lrr__hemicube_rows; on the CPU. */
lrr_status lrr__hemicube_sample_rows(lrr_context *ctx, const lrr__geometry *g,
                                     const lrr_build_options *opts, const size_t *rows,
                                     size_t count, float *out);

/* ------------------------------------------------------------ adaptive hierarchy */
#define LRR__ADAPTIVE_DEFAULT_SAMPLES 2048 /* lrr_build_options.adaptive_samples = 0 */
#define LRR__ADAPTIVE_MAX_EMITTER_ROWS 256 /* emitters rendered for the radiosity weights */
/* Rows of the full F (subpatch columns) for a uniform sample of receivers (adaptive.c). */
typedef struct lrr__ffsample {
    size_t count, n;   /* sampled receivers, columns */
    size_t *rows;      /* count receiver indices, ascending */
    double *weight;    /* count: Σ_c rho_ic² of each receiver */
    double *rho;       /* count×3 */
    double *b;         /* n×3 radiosity weights, or NULL (unweighted column variance) */
    float *f;          /* count×n */
} lrr__ffsample;
/* Draws count receivers (all n when count is 0 or >= n) from opts->seed and renders their
 * rows of F with opts' hemicube settings. */
lrr_status lrr__ffsample_take(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                              const lrr_build_options *opts, size_t count, lrr__ffsample *out);
void lrr__ffsample_free(lrr__ffsample *s);
/* Estimate of V = Σ_i w_i Σ_{j∈[j0,j1)} (F_ij − mean)² over all n receivers, (n/S)·the sum
 * over the sample; *std_error (may be NULL) gets its standard error (0 when S = n). */
double lrr__ffsample_variance(const lrr__ffsample *s, size_t j0, size_t j1, double *std_error);
/* What lrr__adaptive_select did (tests). */
typedef struct lrr__adaptive_trace {
    double *objective; /* (K − n_tri)/3 + 1 entries, or NULL: the total score after 0, 1,
                          2, … greedy splits (the caller's array) */
    double greedy;     /* the objective when the greedy split stopped */
    double exchanged;  /* after the exchanges (with radiosity weights; else = greedy) */
    double recomputed; /* the final objective summed anew over the final patches */
    size_t exchanges;
} lrr__adaptive_trace;
/* The adaptive hierarchy over g's patches (g uniform, levels 0) with at most
 * opts->adaptive_patches patches, chosen by opts->adaptive_split. With emission (n×3, may be
 * NULL) and area (n), the variance is weighted by an estimate of the scene's radiosity;
 * weights (n×3, may be NULL; tests) gives that radiosity instead. trace may be NULL. */
lrr_status lrr__adaptive_select(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                                const float *emission, const float *area,
                                const double *weights, const lrr_build_options *opts,
                                lrr__geometry *out, lrr__adaptive_trace *trace);

/* Hemicube integration on an OpenCL device (hemicube_opencl.c): rows of F̄ from a batch of
 * resolved hemicubes (patch ids per pixel in the item-buffer layout, 3R² per hemicube, -1 for
 * nothing). Without OpenCL support create returns LRR_ERR_UNSUPPORTED. */
typedef struct lrr__cl_hemi lrr__cl_hemi;
lrr_status lrr__cl_hemi_create(lrr_context *ctx, const lrr__multiplier_map *mm, size_t k,
                               size_t d, size_t batch, lrr__cl_hemi **out);
/* out (count×k) = rows of F̄ of `count` <= batch hemicubes. */
lrr_status lrr__cl_hemi_rows(lrr__cl_hemi *h, const int32_t *ids, size_t count, float *out);
void lrr__cl_hemi_destroy(lrr__cl_hemi *h);
/* lib/formfactor/hemicube.cl as a string (generated at build time). */
extern const char lrr__kernel_hemicube_cl[];

/* ------------------------------------------------------------ real-time kernels */
/* One instruction-set variant of the two row kernels (realtime_kernel.c). */
typedef struct lrr__kernel {
    const char *name; /* "c", "avx2", "avx512" */
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
} lrr__kernel;

/* The fastest variant this CPU runs for rows of k entries, or the one named by force
 * (LRR_SIMD: c, avx2, avx512). */
lrr_status lrr__kernel_select(lrr_context *ctx, const char *force, size_t k,
                              const lrr__kernel **out);
/* z (3×k, channel-major) = M_c w_c (w likewise), M = three k×k row-major blocks. */
void lrr__smw_apply(const lrr__kernel *kn, const float *m, size_t k, const float *w, float *z);
/* B_c = E_c + rho_c ∘ (F̄ z_c): F̄ n×k row-major read once, in the operator's storage;
 * E, rho, B n×3 (rho is usually op->rho). */
void lrr__fbar_apply(const lrr__kernel *kn, const lrr_operator *op, const float *z,
                     const float *E, const float *rho, float *B);

/* Tests only: when lrr_solve_batch hands a batch to sgemm (at least min_count frames and
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
lrr_status lrr__cl_create(const lrr_operator *op, lrr__cl_solver **out);
void lrr__cl_destroy(lrr__cl_solver *cl);
const char *lrr__cl_name(const lrr__cl_solver *cl); /* "opencl:<device name>" */
/* One full pass for validated E: E up, three kernels, B down. */
lrr_status lrr__cl_solve(lrr__cl_solver *cl, const float *E, float *B);
/* The last frame's kernel and transfer times (profiling events; 0 before the first frame). */
void lrr__cl_timings(const lrr__cl_solver *cl, double *kernel_ms, double *transfer_ms);
/* Tests only: the work-group-per-row kernel (GPUs) instead of item-per-row (CPU devices). */
void lrr__cl_use_groups(lrr__cl_solver *cl, int groups);
void lrr__solver_opencl_groups(lrr_solver *s, int groups);
/* lib/solve/realtime.cl as a string (generated at build time). */
extern const char lrr__kernel_realtime_cl[];

/* ------------------------------------------------------------ light probes */
struct lrr_probe {
    lrr_context *ctx;
    size_t w, h;
    float *rgb;          /* w×h×3 radiance */
    /* per pixel (index v·w + u), structure of arrays for the irradiance sum */
    float *dir;          /* 3 arrays of w·h: x, y, z */
    float *q;            /* 3 arrays of w·h: radiance × solid angle, r, g, b */
    double *energy;      /* w·h: luminance × solid angle (median cut) */
};

/* Reads the R, G, B channels (half or float) of a scanline or tiled OpenEXR file
 * (lib/probe/exr.cpp, C++: DWA compression included) into a malloc'd w×h×3 float buffer,
 * pixels unvalidated; a layout other than w = 2h is refused (LRR_ERR_DIM) before decoding.
 * Errors (unreadable, truncated, no R/G/B channel) are recorded naming the file; no
 * exception escapes. */
lrr_status lrr__exr_read_rgb(lrr_context *ctx, const char *path, float **rgb, size_t *width,
                             size_t *height);
/* Reads a Radiance RGBE file (lib/probe/hdr.c) into a w×h×3 float buffer from stb_image
 * (free with stbi_image_free), after checking that the pixel data is all there; a layout
 * other than w = 2h is refused (LRR_ERR_DIM) before decoding. Errors name the file. */
lrr_status lrr__hdr_read_rgb(lrr_context *ctx, const char *path, float **rgb, size_t *width,
                             size_t *height);

/* ------------------------------------------------------------ misc */
/* Below about this many multiply-adds (or bytes touched) a parallel region costs more than it
 * saves: waking the OpenMP team takes microseconds when idle, and milliseconds on a loaded
 * machine where a worker is descheduled (measured: Jacobi sweeps at n = 112 took 4 ms each
 * with two threads under load, 9 µs with one). */
#define LRR__PARALLEL_MIN ((size_t)1 << 16)
double lrr__now(void);  /* monotonic seconds */

#endif
