/* Ray-cast hemicube pixels: each pixel of hemicube.c's five faces (same centres, same frame
 * and rotation) finds what it sees with an Embree ray against a BVH of the input triangles
 * built once per build, so a hemicube costs ∝ R² log T instead of the rasteriser's ∝ R² + T
 * triangle setups and clips (docs/METHOD.md "Form factors"). hemicube.c turns the item
 * buffer filled here into a row exactly as it does the rasteriser's.
 *
 * Watertightness: RTC_SCENE_FLAG_ROBUST (Embree's watertight triangle test), so a ray through
 * a shared edge hits one of the two triangles and a closed room's rows still sum to 1.
 * Back faces: Embree reports hits on both sides; a hit from behind occludes (the ray stops)
 * and carries nothing (LRR__ITEM_BACK), like the rasteriser's depth-only back faces. */
#include "config.h"
#include "formfactor/hemicube_private.h"
#include "scene/bvh.h"

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

struct lrr__raycaster {
    lrr__bvh bvh;       /* the input triangles, robust (watertight) */
    double lift;        /* ray origins sit this far above the receiver along its normal */
};

lrr_status lrr__raycaster_create(lrr_context *ctx, const lrr__geometry *g, double diag,
                                 lrr__raycaster **out)
{
    *out = NULL;
    lrr__raycaster *rc;
    lrr_status st = lrr__calloc(ctx, &rc, 1, sizeof *rc, "ray caster");
    if (st)
        return st;
    double maxabs = 0;
    for (size_t i = 0; i < 9 * g->n_tri; i++)
        maxabs = fmax(maxabs, fabs(g->vert[i]));
    /* The origin is rounded to float for Embree: lifted by less than that rounding it could
     * fall behind its own surface and the grazing rays of the side faces' bottom row would
     * hit the receiver's (or a coplanar neighbour's) back. A few float ulps of the largest
     * coordinate plus 1e-6 of the scene size stays clear of it and is far below a pixel. */
    rc->lift = 1e-6 * diag + 8 * FLT_EPSILON * maxabs;
    if ((st = lrr__bvh_build(ctx, g, RTC_BUILD_QUALITY_MEDIUM, 1, "ray-cast form factors",
                             &rc->bvh))) {
        lrr_aligned_free(rc);
        return st;
    }
    *out = rc;
    return LRR_OK;
}

lrr_status lrr__raycaster_status(lrr_context *ctx, const lrr__raycaster *rc)
{
    return lrr__bvh_status(ctx, &rc->bvh, "ray query");
}

void lrr__raycaster_destroy(lrr__raycaster *rc)
{
    if (!rc)
        return;
    lrr__bvh_release(&rc->bvh);
    lrr_aligned_free(rc);
}

lrr_status lrr__formfactor_method(lrr_context *ctx, const lrr__geometry *g,
                                  const lrr_build_options *opts, int *method)
{
    int m = opts->formfactor_method, rs = opts->receiver_sampling;
    if (m != LRR_FORMFACTOR_AUTO && m != LRR_FORMFACTOR_RASTER && m != LRR_FORMFACTOR_RAYCAST)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "formfactor_method %d: must be LRR_FORMFACTOR_AUTO (0), "
                          "LRR_FORMFACTOR_RASTER or LRR_FORMFACTOR_RAYCAST", m);
    if (rs != LRR_RECEIVER_AUTO && rs != LRR_RECEIVER_CENTRE && rs != LRR_RECEIVER_AREA)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "receiver_sampling %d: must be LRR_RECEIVER_AUTO (0), "
                          "LRR_RECEIVER_CENTRE or LRR_RECEIVER_AREA", rs);
    if (rs == LRR_RECEIVER_AREA && m == LRR_FORMFACTOR_RASTER)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "receiver_sampling LRR_RECEIVER_AREA needs rays: the rasteriser "
                          "looks from one point (use LRR_FORMFACTOR_RAYCAST or _AUTO)");
    if (rs == LRR_RECEIVER_AREA && m == LRR_FORMFACTOR_AUTO)
        m = LRR_FORMFACTOR_RAYCAST;
    if (m == LRR_FORMFACTOR_AUTO) {
        size_t R = opts->hemicube_resolution ? opts->hemicube_resolution : 128;
        m = g->n_tri > R * R / LRR__RAYCAST_PIXELS_PER_TRIANGLE ? LRR_FORMFACTOR_RAYCAST
                                                                  : LRR_FORMFACTOR_RASTER;
    }
    *method = m;
    return LRR_OK;
}

int lrr__receiver_sampling(const lrr_build_options *opts, int method)
{
    return opts->receiver_sampling == LRR_RECEIVER_AREA ||
                   (opts->receiver_sampling == LRR_RECEIVER_AUTO &&
                    method == LRR_FORMFACTOR_RAYCAST)
               ? LRR_RECEIVER_AREA
               : LRR_RECEIVER_CENTRE;
}

/* The receiver v (9 doubles) shrunk about its centroid until every point is at least
 * 2·lift from its edges (at most by 30%): a point within the float rounding of an edge could
 * round across the plane of a wall meeting it there, and its rays would leave a closed room. */
static void inset(const double v[9], double lift, double out[9])
{
    double c[3], e[3][3], a2 = 0, longest = 0;
    for (int j = 0; j < 3; j++) {
        c[j] = (v[j] + v[3 + j] + v[6 + j]) / 3;
        for (int k = 0; k < 3; k++)
            e[k][j] = v[3 * ((k + 1) % 3) + j] - v[3 * k + j];
    }
    double cr[3];
    lrr__cross3(e[0], e[1], cr);
    a2 = sqrt(lrr__dot3(cr, cr)); /* twice the area */
    for (int k = 0; k < 3; k++)
        longest = fmax(longest, sqrt(lrr__dot3(e[k], e[k])));
    const double h = longest > 0 ? a2 / longest : 0; /* the smallest altitude */
    const double eps = h > 0 ? fmin(0.1, 2 * lift / h) : 0.1;
    for (int k = 0; k < 3; k++)
        for (int j = 0; j < 3; j++)
            out[3 * k + j] = c[j] + (1 - 3 * eps) * (v[3 * k + j] - c[j]);
}

/* A uniform random point of triangle v (9 doubles) from the 64 random bits r: two 24-bit
 * uniforms, folded into the triangle where they sum past 1 (an area-preserving map). */
static void point_in(const double v[9], uint64_t r, double out[3])
{
    double a = (double)(r >> 40) * 0x1.0p-24, b = (double)((r >> 16) & 0xffffff) * 0x1.0p-24;
    if (a + b > 1) {
        a = 1 - a;
        b = 1 - b;
    }
    for (int j = 0; j < 3; j++)
        out[j] = v[j] + a * (v[3 + j] - v[j]) + b * (v[6 + j] - v[j]);
}

/* Rays of 4×4 pixel tiles go as one 16-wide packet: neighbouring pixels traverse nearly
 * the same BVH nodes. Embree's hit coordinates (u, v) are the barycentrics of v1 and v2, as
 * column_at takes them: the item buffer gets the patch (subpatch) directly, sparing the
 * rasteriser's per-pixel re-intersection (pixel_target, 10–18% of a T = 9,216 profile). */
enum { TILE = 4, PACKET = TILE * TILE };

/* The column (patch, or subpatch for the full F) at barycentrics (b1, b2) of triangle t. */
static size_t column_at(const lrr__hemi_ctx *h, size_t t, double b1, double b2)
{
    const lrr__geometry *g = h->g;
    double b0;
    lrr__clamp_bary(&b1, &b2, &b0);
    return lrr__hemi_leaf_target(
        h, t, lrr__descend(&b0, &b1, &b2, g->depth[t] + (h->by_subpatch ? g->levels : 0)));
}

void lrr__raycast_face(const lrr__hemi_ctx *h, const double x[3], const double N[3],
                       const double *area, uint64_t key, lrr__hemi_face *f)
{
    const lrr__raycaster *rc = h->rc;
    const float inv_half = 2.0f / (float)f->W, y_off = f->side ? 0.0f : -1.0f;
    double inner[9];
    if (area) {
        inset(area, rc->lift, inner);
        area = inner;
    }
    float org[3], right[3], up[3], fwd[3];
    for (int j = 0; j < 3; j++) {
        org[j] = (float)(x[j] + rc->lift * N[j]);
        right[j] = (float)f->right[j];
        up[j] = (float)f->up[j];
        fwd[j] = (float)f->fwd[j];
    }
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    ictx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    for (int y0 = 0; y0 < f->H; y0 += TILE)
        for (int x0 = 0; x0 < f->W; x0 += TILE) {
            struct RTCRayHit16 rh;
            int valid[PACKET] __attribute__((aligned(64)));
            double px[PACKET][3]; /* the rays' points on the receiver (area sampling) */
            for (int l = 0; l < PACKET; l++) {
                int xx = x0 + l % TILE, y = y0 + l / TILE;
                valid[l] = xx < f->W && y < f->H ? -1 : 0;
                /* the pixel centre, in float: Embree's rays are float anyway */
                float sx = (xx + 0.5f) * inv_half - 1.0f, sy = (y + 0.5f) * inv_half + y_off;
                rh.ray.org_x[l] = org[0];
                rh.ray.org_y[l] = org[1];
                rh.ray.org_z[l] = org[2];
                if (area) { /* this pixel's own point of the receiver */
                    point_in(area, lrr__splitmix64(key ^ (uint64_t)(y * f->W + xx)), px[l]);
                    rh.ray.org_x[l] = (float)(px[l][0] + rc->lift * N[0]);
                    rh.ray.org_y[l] = (float)(px[l][1] + rc->lift * N[1]);
                    rh.ray.org_z[l] = (float)(px[l][2] + rc->lift * N[2]);
                }
                rh.ray.dir_x[l] = sx * right[0] + sy * up[0] + fwd[0];
                rh.ray.dir_y[l] = sx * right[1] + sy * up[1] + fwd[1];
                rh.ray.dir_z[l] = sx * right[2] + sy * up[2] + fwd[2];
                rh.ray.tnear[l] = 0.0f;
                rh.ray.tfar[l] = INFINITY;
                rh.ray.time[l] = 0.0f;
                rh.ray.mask[l] = UINT32_MAX;
                rh.ray.id[l] = (unsigned)l;
                rh.ray.flags[l] = 0;
                rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect16(valid, rc->bvh.scene, &ictx, &rh);
            for (int l = 0; l < PACKET; l++) {
                int xx = x0 + l % TILE, y = y0 + l / TILE;
                if (!valid[l])
                    continue;
                int32_t id = LRR__ITEM_NONE;
                if (rh.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID) {
                    size_t t = rh.hit.primID[l];
                    const lrr__tri_info *ti = &h->tri[t];
                    const double *o = area ? px[l] : x;
                    double w0[3] = {o[0] - ti->v0[0], o[1] - ti->v0[1], o[2] - ti->v0[2]};
                    /* the rasteriser's test: the ray's point strictly in front of the
                     * triangle's plane (within eps of it the triangle is edge-on: nothing,
                     * not a back) */
                    double side = lrr__dot3(w0, ti->n);
                    double tol = h->eps * sqrt(lrr__dot3(ti->n, ti->n));
                    if (side > tol)
                        id = (int32_t)column_at(h, t, rh.hit.u[l], rh.hit.v[l]);
                    else if (side < -tol)
                        id = LRR__ITEM_BACK;
                }
                f->item[(size_t)y * f->W + xx] = id;
            }
        }
}
