/* What the rasteriser's files share: hemicube.c (per receiver: the frame, the five faces,
 * the row; per build: the tables, the threads), hemicube_raster.c (the input triangles into
 * a face's depth and item buffers) and hemicube_integrate.c (a face's item buffer into the
 * row). The SIMD steps they call come from one table chosen per build (hemi_ctx.simd). */
#ifndef LRR_FORMFACTOR_HEMICUBE_RASTER_H
#define LRR_FORMFACTOR_HEMICUBE_RASTER_H

#include "formfactor/hemicube_private.h"

/* The barycentric coordinates of the point that pixel (sx, sy) of a face shows on a
 * triangle's plane, as ratios of linear functions of (sx, sy): with dir = sx·right + sy·up +
 * fwd, w0 = v0 − x, c = n·w0 and α_j the dual basis of (e1, e2) (Gram inverse), the ray
 * x + t·dir meets the plane at t = c / n·dir, so b_j = (c·dir·α_j − (w0·α_j)·n·dir) / n·dir.
 * Set up once per face and triangle (the SIMD depth test) or run of pixels showing it (the
 * scalar path): 9 coefficients instead of a ray-plane intersection per pixel (which costs
 * 36% of a Cornell R 64 profile). */
typedef struct {
    double b1[3], b2[3], den[3]; /* coefficients of sx, sy, 1 */
} lrr__bary_plane;

void lrr__hemi_bary_setup(const lrr__tri_info *ti, const double x[3], const lrr__hemi_face *f,
                          lrr__bary_plane *bp);

/* The leaves of triangle t: depth[t] levels for patches, depth[t] + levels for subpatches. */
static inline unsigned lrr__hemi_leaf_depth(const lrr__hemi_ctx *h, size_t t)
{
    return h->g->depth[t] + (h->by_subpatch ? h->g->levels : 0);
}

/* A thread's buffers for one hemicube at a time: the five faces' depth, item and code
 * buffers one after another, and a row of doubles. */
typedef struct {
    float *depth;
    int32_t *item;
    uint32_t *code;
    double *row;
    int clean; /* depth 0 and item LRR__ITEM_NONE everywhere (as lrr__hemi_integrate_face
                  leaves them) */
} lrr__hemi_scratch;

/* Rasterises every input triangle into the five faces (cost ∝ triangles); x is the
 * receiver's centre, N its unit normal (hemicube_raster.c). */
void lrr__hemi_raster_faces(const lrr__hemi_ctx *h, const double x[3], const double N[3],
                            lrr__hemi_face *faces, lrr__hemi_scratch *sc);
/* Accumulates the visible patches (or subpatches) of face f into row (k or n doubles), or
 * only resolves the item buffer to patch ids when row is NULL (the device integration then
 * sums the multiplier map per patch; markers stay); clear: leave the face's depth and item
 * buffers cleared for the next hemicube. Returns the delta form factors of the pixels
 * showing back faces (hemicube_integrate.c). */
double lrr__hemi_integrate_face(const lrr__hemi_ctx *h, const double x[3],
                                const lrr__hemi_face *f, double *row, int clear);
/* The leaf table of the regular grids of depth 0..LRR__LEAF_TABLE_DEPTH (hemi_ctx.cells;
 * hemicube_integrate.c, "leaves of a row"). */
lrr_status lrr__hemi_cell_table(lrr_context *ctx, uint16_t **out);

#endif
