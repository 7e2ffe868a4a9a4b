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

/* A triangle as a hit reads it, one cache line: the rasteriser's 128-byte tri_info put v0
 * and n on two lines and the column behind three more lookups (depth, sub0, the cluster
 * tables), whose misses also evicted Embree's nodes. */
typedef struct {
    double v0[3], n[3]; /* lrr__tri_info's: a vertex and the unnormalised normal */
    double tol;         /* h->eps·|n|: a ray's origin within it of the plane is on it */
    int32_t col;        /* the column of the triangle's one leaf, else -1: descend */
    uint32_t depth;     /* its leaves' depth (lrr__hemi_leaf_depth) */
} ray_tri;
_Static_assert(sizeof(ray_tri) == 64, "one cache line a triangle");

struct lrr__raycaster {
    lrr__bvh bvh;       /* the input triangles, robust (watertight) */
    double lift;        /* ray origins sit this far above the receiver along its normal */
    ray_tri *tri;       /* per input triangle, for the build bound last (raycaster_bind) */
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

lrr_status lrr__raycaster_bind(lrr_context *ctx, lrr__raycaster *rc, const lrr__hemi_ctx *h)
{
    const lrr__geometry *g = h->g;
    lrr_aligned_free(rc->tri);
    lrr_status st = lrr__calloc(ctx, &rc->tri, g->n_tri, sizeof *rc->tri, "ray-cast triangles");
    if (st)
        return st;
    for (size_t t = 0; t < g->n_tri; t++) {
        lrr__tri_info ti;
        lrr__hemi_tri_info(g->vert + 9 * t, &ti);
        ray_tri *r = &rc->tri[t];
        memcpy(r->v0, ti.v0, sizeof r->v0);
        memcpy(r->n, ti.n, sizeof r->n);
        r->tol = h->eps * sqrt(lrr__dot3(ti.n, ti.n));
        r->depth = g->depth[t] + (h->by_subpatch ? g->levels : 0);
        r->col = r->depth ? -1 : (int32_t)lrr__hemi_leaf_target(h, t, 0);
    }
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
    lrr_aligned_free(rc->tri);
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
 * uniforms, folded into the triangle where they sum past 1 (an area-preserving map). The fold
 * is a select, not a branch: taken at random half the time, its mispredictions were a third
 * of lrr__raycast_face over the area (FZK-Haus R 32, Zen 5). */
static inline void point_in(const double v[9], uint64_t r, double out[3])
{
    /* in 24-bit integers, where the sums and 1 − a are exact as they are in double: the
     * same a and b bit for bit, and a mask the compiler cannot turn back into a branch */
    const int64_t ia = (int64_t)(r >> 40), ib = (int64_t)((r >> 16) & 0xffffff),
                  one = (int64_t)1 << 24, fold = -(int64_t)(ia + ib > one); /* all ones */
    const double a = (double)(ia + ((one - 2 * ia) & fold)) * 0x1.0p-24,
                 b = (double)(ib + ((one - 2 * ib) & fold)) * 0x1.0p-24;
    for (int j = 0; j < 3; j++)
        out[j] = v[j] + a * (v[3 + j] - v[j]) + b * (v[6 + j] - v[j]);
}

/* Rays of 4×4 pixel tiles go as one 16-wide packet: neighbouring pixels traverse nearly
 * the same BVH nodes. Embree's hit coordinates (u, v) are the barycentrics of v1 and v2, as
 * column_at takes them: the item buffer gets the patch (subpatch) directly, sparing the
 * rasteriser's per-pixel re-intersection (pixel_target, 10–18% of a T = 9,216 profile). */
enum { TILE = 4, PACKET = TILE * TILE };

/* The column (patch, or subpatch for the full F) at barycentrics (b1, b2) of triangle t,
 * whose leaves lie `depth` levels down. */
static size_t column_at(const lrr__hemi_ctx *h, size_t t, unsigned depth, double b1, double b2)
{
    double b0;
    lrr__clamp_bary(&b1, &b2, &b0);
    return lrr__hemi_leaf_target(h, t, lrr__descend(&b0, &b1, &b2, depth));
}

/* Which side of triangle r the point o is on: 1 strictly in front (the rasteriser's test),
 * -1 behind, 0 within eps of its plane (edge-on: nothing, not a back). */
static inline int side_of(const ray_tri *r, const double o[3])
{
    const double w0[3] = {o[0] - r->v0[0], o[1] - r->v0[1], o[2] - r->v0[2]};
    const double side = lrr__dot3(w0, r->n);
    return side > r->tol ? 1 : side < -r->tol ? -1 : 0;
}

/* The item of a ray from o that hit triangle t at (u, v), whose side of o is s. */
static inline int32_t item_of(const lrr__hemi_ctx *h, const ray_tri *r, size_t t, int s,
                              float u, float v)
{
    if (s < 0)
        return LRR__ITEM_BACK;
    if (s == 0)
        return LRR__ITEM_NONE;
    return r->col >= 0 ? r->col : (int32_t)column_at(h, t, r->depth, u, v);
}

/* The fields of a face's packets that no tile changes (Embree writes only tfar and the
 * hit), the origins too when every ray starts at org. */
static void packet_init(struct RTCRayHit16 *rh, const float org[3])
{
    for (int l = 0; l < PACKET; l++) {
        rh->ray.org_x[l] = org[0];
        rh->ray.org_y[l] = org[1];
        rh->ray.org_z[l] = org[2];
        rh->ray.tnear[l] = 0.0f;
        rh->ray.time[l] = 0.0f;
        rh->ray.mask[l] = UINT32_MAX;
        rh->ray.id[l] = (unsigned)l;
        rh->ray.flags[l] = 0;
    }
}

/* four lanes of float (GCC vector extensions: SSE on x86-64, NEON on aarch64), lane by lane
 * the scalar arithmetic: the per-lane loop was 40% of lrr__raycast_face (FZK-Haus R 64) */
typedef float v4f __attribute__((vector_size(16)));

/* The face's frame and pixel grid in float: Embree's rays are float anyway. */
typedef struct {
    float right[3], up[3], fwd[3];
    float inv_half, y_off;
} face_rays;

/* Tile (x0, y0)'s directions through its pixel centres and its per-ray state; valid gets
 * the lanes inside the face. */
static void packet_tile(const face_rays *fr, const lrr__hemi_face *f, int x0, int y0,
                        struct RTCRayHit16 *rh, int *valid)
{
    const v4f cx = {(float)x0, (float)(x0 + 1), (float)(x0 + 2), (float)(x0 + 3)},
              sx = (cx + 0.5f) * fr->inv_half - 1.0f;
    for (int r = 0; r < TILE; r++) {
        const float sy = (y0 + r + 0.5f) * fr->inv_half + fr->y_off;
        const v4f dx = sx * fr->right[0] + sy * fr->up[0] + fr->fwd[0],
                  dy = sx * fr->right[1] + sy * fr->up[1] + fr->fwd[1],
                  dz = sx * fr->right[2] + sy * fr->up[2] + fr->fwd[2];
        memcpy(rh->ray.dir_x + TILE * r, &dx, sizeof dx);
        memcpy(rh->ray.dir_y + TILE * r, &dy, sizeof dy);
        memcpy(rh->ray.dir_z + TILE * r, &dz, sizeof dz);
        for (int c = 0; c < TILE; c++)
            valid[TILE * r + c] = x0 + c < f->W && y0 + r < f->H ? -1 : 0;
    }
    for (int l = 0; l < PACKET; l++) {
        rh->ray.tfar[l] = INFINITY;
        rh->hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
        rh->hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
    }
}

/* Area sampling: each pixel's ray from its own point of the receiver `area` (inset), into
 * px (the double point, for the side test) and the packet's origins. */
static void packet_origins(const double *area, const double N[3], double lift, uint64_t key,
                           const lrr__hemi_face *f, int x0, int y0, struct RTCRayHit16 *rh,
                           double px[PACKET][3])
{
    for (int l = 0; l < PACKET; l++) {
        const int xx = x0 + l % TILE, y = y0 + l / TILE;
        point_in(area, lrr__splitmix64(key ^ (uint64_t)(y * f->W + xx)), px[l]);
        rh->ray.org_x[l] = (float)(px[l][0] + lift * N[0]);
        rh->ray.org_y[l] = (float)(px[l][1] + lift * N[1]);
        rh->ray.org_z[l] = (float)(px[l][2] + lift * N[2]);
    }
}

/* The tile's items from its hits: rays from x (one origin: the side of a triangle is
 * decided once per run of hits on it), or from px. */
static void tile_items(const lrr__hemi_ctx *h, const struct RTCRayHit16 *rh,
                       const int *valid, const double x[3], const double (*px)[3],
                       int x0, int y0, lrr__hemi_face *f)
{
    const ray_tri *rt = h->rc->tri;
    size_t last_t = SIZE_MAX;
    int s = 0;
    for (int l = 0; l < PACKET; l++) {
        if (!valid[l])
            continue;
        int32_t id = LRR__ITEM_NONE;
        if (rh->hit.geomID[l] != RTC_INVALID_GEOMETRY_ID) {
            const size_t t = rh->hit.primID[l];
            if (px || t != last_t)
                s = side_of(&rt[t], px ? px[l] : x);
            last_t = t;
            id = item_of(h, &rt[t], t, s, rh->hit.u[l], rh->hit.v[l]);
        }
        f->item[(size_t)(y0 + l / TILE) * f->W + x0 + l % TILE] = id;
    }
}

void lrr__raycast_face(const lrr__hemi_ctx *h, const double x[3], const double N[3],
                       const double *area, uint64_t key, lrr__hemi_face *f)
{
    const lrr__raycaster *rc = h->rc;
    double inner[9];
    if (area) {
        inset(area, rc->lift, inner);
        area = inner;
    }
    face_rays fr = {.inv_half = 2.0f / (float)f->W, .y_off = f->side ? 0.0f : -1.0f};
    float org[3];
    for (int j = 0; j < 3; j++) {
        org[j] = (float)(x[j] + rc->lift * N[j]);
        fr.right[j] = (float)f->right[j];
        fr.up[j] = (float)f->up[j];
        fr.fwd[j] = (float)f->fwd[j];
    }
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    ictx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    struct RTCRayHit16 rh;
    packet_init(&rh, org);
    double px[PACKET][3]; /* the rays' points on the receiver (area sampling) */
    for (int y0 = 0; y0 < f->H; y0 += TILE)
        for (int x0 = 0; x0 < f->W; x0 += TILE) {
            int valid[PACKET] __attribute__((aligned(64)));
            packet_tile(&fr, f, x0, y0, &rh, valid);
            if (area)
                packet_origins(area, N, rc->lift, key, f, x0, y0, &rh, px);
            rtcIntersect16(valid, rc->bvh.scene, &ictx, &rh);
            tile_items(h, &rh, valid, x, area ? (const double(*)[3])px : NULL, x0, y0, f);
        }
}
