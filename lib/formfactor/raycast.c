/* Ray-cast hemicube pixels: each pixel of hemicube.c's five faces (same centres, same frame
 * and rotation) finds what it sees with an Embree ray against a BVH of the input triangles
 * built once per build, so a hemicube costs ∝ R² log T instead of the rasteriser's ∝ R² + T
 * triangle setups and clips (docs/METHOD.md "Form factors"). hemicube.c turns the item
 * buffer filled here into a row exactly as it does the rasteriser's.
 *
 * Watertightness: RTC_SCENE_FLAG_ROBUST (Embree's watertight triangle test), so a ray through
 * a shared edge hits one of the two triangles and a closed room's rows still sum to 1.
 * Back faces: Embree reports hits on both sides; a hit from behind occludes (the ray stops)
 * and carries nothing (-1), like the rasteriser's depth-only back faces. */
#include "config.h"
#include "formfactor/hemicube_private.h"

#include <embree3/rtcore.h>
#include <float.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

/* Embree reports errors through a callback: the first one is kept (as in probe/light.c). */
typedef struct embree_error {
    enum RTCError code;
    char message[256];
} embree_error;

struct lrr__raycaster {
    RTCDevice dev;
    RTCScene scene;
    double lift;        /* ray origins sit this far above the receiver along its normal */
    embree_error err;
};

static void embree_error_cb(void *user, enum RTCError code, const char *str)
{
    embree_error *e = user;
    if (e->code != RTC_ERROR_NONE)
        return;
    e->code = code;
    snprintf(e->message, sizeof e->message, "%s", str ? str : "(no message)");
}

static lrr_status embree_fail(lrr_context *ctx, const embree_error *err, const char *what)
{
    lrr_status s = err->code == RTC_ERROR_OUT_OF_MEMORY ? LRR_ERR_NOMEM : LRR_ERR_UNSUPPORTED;
    return lrr__error(ctx, s, "ray-cast form factors: Embree %s failed (error %d: %s)", what,
                      (int)err->code, err->code != RTC_ERROR_NONE ? err->message : "unknown");
}

/* The robust scene of g's triangles (primitive id = triangle index); NULL on failure. */
static RTCScene build_scene(RTCDevice dev, const lrr__geometry *g, const embree_error *err)
{
    RTCScene scene = rtcNewScene(dev);
    if (!scene)
        return NULL;
    rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
    RTCGeometry geo = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!geo) {
        rtcReleaseScene(scene);
        return NULL;
    }
    float *v = rtcSetNewGeometryBuffer(geo, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                       3 * sizeof(float), 3 * g->n_tri);
    unsigned *ix = rtcSetNewGeometryBuffer(geo, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           3 * sizeof(unsigned), g->n_tri);
    if (!v || !ix) {
        rtcReleaseGeometry(geo);
        rtcReleaseScene(scene);
        return NULL;
    }
    memcpy(v, g->vert, 9 * g->n_tri * sizeof(float));
    for (size_t i = 0; i < 3 * g->n_tri; i++)
        ix[i] = (unsigned)i;
    rtcCommitGeometry(geo);
    rtcAttachGeometry(scene, geo);
    rtcReleaseGeometry(geo);
    rtcCommitScene(scene);
    if (err->code != RTC_ERROR_NONE) {
        rtcReleaseScene(scene);
        return NULL;
    }
    return scene;
}

lrr_status lrr__raycaster_create(lrr_context *ctx, const lrr__geometry *g, double diag,
                                 lrr__raycaster **out)
{
    *out = NULL;
    if (g->n_tri > UINT32_MAX / 3)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "ray-cast form factors: %zu triangles exceed Embree's 32-bit indices",
                          g->n_tri);
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
    rc->err.code = RTC_ERROR_NONE;
    rc->dev = rtcNewDevice(NULL);
    if (!rc->dev) {
        rc->err.code = rtcGetDeviceError(NULL);
        st = embree_fail(ctx, &rc->err, "device creation");
        lrr_aligned_free(rc);
        return st;
    }
    rtcSetDeviceErrorFunction(rc->dev, embree_error_cb, &rc->err);
    rc->scene = build_scene(rc->dev, g, &rc->err);
    if (!rc->scene) {
        st = embree_fail(ctx, &rc->err, "scene build");
        rtcReleaseDevice(rc->dev);
        lrr_aligned_free(rc);
        return st;
    }
    *out = rc;
    return LRR_OK;
}

lrr_status lrr__raycaster_status(lrr_context *ctx, const lrr__raycaster *rc)
{
    return rc->err.code == RTC_ERROR_NONE ? LRR_OK : embree_fail(ctx, &rc->err, "ray query");
}

void lrr__raycaster_destroy(lrr__raycaster *rc)
{
    if (!rc)
        return;
    rtcReleaseScene(rc->scene);
    rtcReleaseDevice(rc->dev);
    lrr_aligned_free(rc);
}

lrr_status lrr__formfactor_method(lrr_context *ctx, const lrr__geometry *g,
                                  const lrr_build_options *opts, int *method)
{
    int m = opts->formfactor_method;
    if (m != LRR_FORMFACTOR_AUTO && m != LRR_FORMFACTOR_RASTER && m != LRR_FORMFACTOR_RAYCAST)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "formfactor_method %d: must be LRR_FORMFACTOR_AUTO (0), "
                          "LRR_FORMFACTOR_RASTER or LRR_FORMFACTOR_RAYCAST", m);
    if (m == LRR_FORMFACTOR_AUTO) {
        size_t R = opts->hemicube_resolution ? opts->hemicube_resolution : 128;
        m = g->n_tri > R * R / LRR__RAYCAST_PIXELS_PER_TRIANGLE ? LRR_FORMFACTOR_RAYCAST
                                                                  : LRR_FORMFACTOR_RASTER;
    }
    *method = m;
    return LRR_OK;
}

/* Rays of 4×4 pixel tiles go as one 16-wide packet: neighbouring pixels traverse nearly
 * the same BVH nodes. Embree's hit coordinates (u, v) are the barycentrics of v1 and v2, as
 * lrr__patch_at takes them: the item buffer gets the patch (subpatch) directly, sparing the
 * rasteriser's per-pixel re-intersection (pixel_target, 10–18% of a T = 9,216 profile). */
enum { TILE = 4, PACKET = TILE * TILE };

void lrr__raycast_face(const lrr__hemi_ctx *h, const double x[3], const double N[3],
                       lrr__hemi_face *f)
{
    const lrr__raycaster *rc = h->rc;
    const float inv_half = 2.0f / (float)f->W, y_off = f->side ? 0.0f : -1.0f;
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
            for (int l = 0; l < PACKET; l++) {
                int xx = x0 + l % TILE, y = y0 + l / TILE;
                valid[l] = xx < f->W && y < f->H ? -1 : 0;
                /* the pixel centre, in float: Embree's rays are float anyway */
                float sx = (xx + 0.5f) * inv_half - 1.0f, sy = (y + 0.5f) * inv_half + y_off;
                rh.ray.org_x[l] = org[0];
                rh.ray.org_y[l] = org[1];
                rh.ray.org_z[l] = org[2];
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
            rtcIntersect16(valid, rc->scene, &ictx, &rh);
            for (int l = 0; l < PACKET; l++) {
                int xx = x0 + l % TILE, y = y0 + l / TILE;
                if (!valid[l])
                    continue;
                int32_t id = -1;
                if (rh.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID) {
                    size_t t = rh.hit.primID[l];
                    const lrr__tri_info *ti = &h->tri[t];
                    double w0[3] = {x[0] - ti->v0[0], x[1] - ti->v0[1], x[2] - ti->v0[2]};
                    /* the rasteriser's test: x strictly in front of the triangle's plane */
                    if (lrr__dot3(w0, ti->n) > h->eps * sqrt(lrr__dot3(ti->n, ti->n)))
                        id = (int32_t)(h->by_subpatch
                                           ? lrr__subpatch_at(h->g, t, rh.hit.u[l], rh.hit.v[l])
                                           : lrr__patch_at(h->g, t, rh.hit.u[l], rh.hit.v[l]));
                }
                f->item[(size_t)y * f->W + xx] = id;
            }
        }
}
