/* The hierarchy stage (lib/hierarchy/): which quadtree nodes become patches. The rows of F
 * it ranks splits with come from the caller's renderer (lrr__rows_fn; the operator build
 * passes the hemicube's), so this stage does not depend on the form factors. */
#ifndef LRR_HIERARCHY_H
#define LRR_HIERARCHY_H

#include "scene/scene.h"

/* Renders rows rows[0..count-1] of the full F (count×n, subpatch columns, not divided by d)
 * of geometry g with opts' hemicube settings: lrr__hemicube_sample_rows. */
typedef lrr_status (*lrr__rows_fn)(lrr_context *ctx, const lrr__geometry *g,
                                   const lrr_build_options *opts, const size_t *rows,
                                   size_t count, float *out);

#define LRR__ADAPTIVE_DEFAULT_SAMPLES 2048 /* lrr_build_options.adaptive_samples = 0 */
#define LRR__ADAPTIVE_MAX_EMITTER_ROWS 256 /* emitters rendered for the radiosity weights */
/* Rows of the full F (subpatch columns) for a uniform sample of receivers (ffsample.c). */
typedef struct lrr__ffsample {
    size_t count, n;   /* sampled receivers, columns */
    size_t *rows;      /* count receiver indices, ascending */
    double *weight;    /* count: Σ_c rho_ic² of each receiver */
    double *rho;       /* count×3 */
    double *b;         /* n×3 radiosity weights, or NULL (unweighted column variance) */
    float *f;          /* count×n */
} lrr__ffsample;
/* Draws count receivers (all n when count is 0 or >= n) from opts->seed and renders their
 * rows of F with `rows` and opts' hemicube settings. */
lrr_status lrr__ffsample_take(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                              const lrr_build_options *opts, lrr__rows_fn rows, size_t count,
                              lrr__ffsample *out);
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
 * opts->adaptive_patches patches, chosen by opts->adaptive_split; the sampled rows of F (and
 * the emitters' rows) come from `rows`. With emission (n×3, may be NULL) and area (n), the
 * variance is weighted by an estimate of the scene's radiosity; weights (n×3, may be NULL;
 * tests) gives that radiosity instead. trace may be NULL. */
lrr_status lrr__adaptive_select(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                                const float *emission, const float *area,
                                const double *weights, const lrr_build_options *opts,
                                lrr__rows_fn rows, lrr__geometry *out,
                                lrr__adaptive_trace *trace);

/* The cluster hierarchy over g's patches (g uniform, levels 0; they become the subpatches):
 * about opts->adaptive_patches clusters across triangles (cluster.c), chosen by
 * opts->adaptive_split; centre, normal (n×3), area, rho and emission (n×3; emitters and
 * other surfaces never share a cluster) are g's per-subpatch frames and materials; the
 * sampled rows (LRR_SPLIT_VARIANCE) come from `rows`. out gets the clustered geometry
 * (origin/order set). */
lrr_status lrr__cluster_select(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                               const float *emission, const float *centre,
                               const float *normal, const float *area,
                               const lrr_build_options *opts, lrr__rows_fn rows,
                               lrr__geometry *out);
/* The sampled rows the cluster selection takes for n subpatches (adaptive_samples, capped
 * so they hold at most 512 MiB), and the bytes it holds besides the scene's per-subpatch
 * copies (false on overflow): for the memory budget. */
size_t lrr__cluster_samples(size_t n, size_t samples);
bool lrr__cluster_bytes(size_t n, size_t samples, int split, size_t *out);

#endif
