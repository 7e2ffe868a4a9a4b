/* The form-factor stage (lib/formfactor/): one hemicube per subpatch gives a row of F̄ (or of
 * the full F for the reference solvers and the adaptive selection's samples), on the CPU or
 * with the integration on an OpenCL device. */
#ifndef LRR_FORMFACTOR_H
#define LRR_FORMFACTOR_H

#include "scene/scene.h"

/* The options of lrr_operator_build and lrr_reference_build with defaults filled in
 * (opts may be NULL); checks that the scene is subdivided and the thread count. */
lrr_status lrr__build_options_resolve(const lrr_scene *scene, const lrr_build_options *opts,
                                      lrr_build_options *o);
/* The method a build with opts uses on g: opts->formfactor_method, or for
 * LRR_FORMFACTOR_AUTO raycast above R²/4 triangles (hemicube_private.h), raster otherwise;
 * LRR_ERR_INVALID_ARG for an unknown value. */
lrr_status lrr__formfactor_method(lrr_context *ctx, const lrr__geometry *g,
                                  const lrr_build_options *opts, int *method);
/* Where the hemicubes of a build with opts look from, given the method it uses:
 * LRR_RECEIVER_AREA for opts->receiver_sampling AREA, or AUTO with rays; else CENTRE. */
int lrr__receiver_sampling(const lrr_build_options *opts, int method);
/* Bytes of hemicube.c's per-triangle table entry (16 doubles; checked there), for the
 * memory budget of a build (operator/budget.c). */
#define LRR__HEMICUBE_TRI_BYTES ((size_t)16 * sizeof(double))

typedef struct lrr__multiplier_map {
    unsigned res;          /* R */
    double *top;           /* R×R delta form factors */
    double *side;          /* (R/2)×R: row 0 at the horizon, columns across the face */
    double raw_sum;        /* midpoint-rule total before normalisation (→ 1 as R grows) */
} lrr__multiplier_map;

lrr_status lrr__multiplier_map_create(lrr_context *ctx, unsigned res, lrr__multiplier_map *m);
void lrr__multiplier_map_free(lrr__multiplier_map *m);

/* Fills fbar (n×k) from geometry g with one hemicube per subpatch, and back (n doubles, may
 * be NULL) with each receiver's back-face share: the part of its hemisphere (Σ delta form
 * factors, 0..1) whose first hit is the back of a triangle, in the same pass. */
lrr_status lrr__hemicube_fbar(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, float *fbar, double *back);
/* Rows rows[0..count-1] of the same F̄ and their back-face shares (back may be NULL), bit
 * for bit those rows of lrr__hemicube_fbar's (a receiver's hemicube depends on its index
 * alone): row r of the list at fbar's row r and back[r], or when placed at row rows[r]
 * (fbar n×k, back n). On the CPU (LRR_ERR_UNSUPPORTED for the OpenCL backend). For the
 * build across MPI ranks (operator/build.h). */
lrr_status lrr__hemicube_fbar_rows(lrr_context *ctx, const lrr__geometry *g,
                                   const lrr_build_options *opts, const size_t *rows,
                                   size_t count, int placed, float *fbar, double *back);
/* The same hemicubes with subpatch columns when by_subpatch (out n×n: the full F, not
 * divided by d) or patch columns otherwise (out n×k: F̄). */
lrr_status lrr__hemicube_rows(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, int by_subpatch, float *out);

/* Rows rows[0..count-1] of the full F (count×n, subpatch columns, not divided by d) from the
 * same hemicubes (same per-receiver rotation) as lrr__hemicube_rows; on the CPU. */
lrr_status lrr__hemicube_sample_rows(lrr_context *ctx, const lrr__geometry *g,
                                     const lrr_build_options *opts, const size_t *rows,
                                     size_t count, float *out);

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

#endif
