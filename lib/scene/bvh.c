/* The scene's triangles as an Embree BVH (bvh.h says who shares it and why). */
#include "config.h"
#include "scene/bvh.h"

#include <stdint.h>
#include <stdio.h>
#include <string.h>

static void error_cb(void *user, enum RTCError code, const char *str)
{
    lrr__bvh *b = user;
    if (b->code != RTC_ERROR_NONE)
        return; /* keep the first */
    b->code = code;
    snprintf(b->message, sizeof b->message, "%s", str ? str : "(no message)");
}

static lrr_status fail(lrr_context *ctx, const lrr__bvh *b, const char *what)
{
    lrr_status s = b->code == RTC_ERROR_OUT_OF_MEMORY ? LRR_ERR_NOMEM : LRR_ERR_UNSUPPORTED;
    return lrr__error(ctx, s, "%s: Embree %s failed (error %d: %s)", b->who, what,
                      (int)b->code, b->code != RTC_ERROR_NONE ? b->message : "unknown");
}

/* The scene of g's triangles; NULL on failure (b->code set by the callback, if Embree
 * said why). */
static RTCScene new_scene(lrr__bvh *b, const lrr__geometry *g, enum RTCBuildQuality quality,
                          int robust)
{
    RTCScene scene = rtcNewScene(b->device);
    if (!scene)
        return NULL;
    if (robust)
        rtcSetSceneFlags(scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(scene, quality);
    RTCGeometry geo = rtcNewGeometry(b->device, RTC_GEOMETRY_TYPE_TRIANGLE);
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
    if (b->code != RTC_ERROR_NONE) {
        rtcReleaseScene(scene);
        return NULL;
    }
    return scene;
}

lrr_status lrr__bvh_build(lrr_context *ctx, const lrr__geometry *g,
                          enum RTCBuildQuality quality, int robust, const char *who,
                          lrr__bvh *b)
{
    memset(b, 0, sizeof *b);
    b->who = who;
    if (g->n_tri > UINT32_MAX / 3)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "%s: %zu triangles exceed Embree's 32-bit indices", who, g->n_tri);
    b->device = rtcNewDevice(NULL);
    if (!b->device) {
        b->code = rtcGetDeviceError(NULL);
        return fail(ctx, b, "device creation");
    }
    rtcSetDeviceErrorFunction(b->device, error_cb, b);
    if (!(b->scene = new_scene(b, g, quality, robust))) {
        lrr_status st = fail(ctx, b, "scene build");
        rtcReleaseDevice(b->device);
        b->device = NULL;
        return st;
    }
    return LRR_OK;
}

lrr_status lrr__bvh_status(lrr_context *ctx, const lrr__bvh *b, const char *what)
{
    return b->code == RTC_ERROR_NONE ? LRR_OK : fail(ctx, b, what);
}

void lrr__bvh_release(lrr__bvh *b)
{
    if (b->scene)
        rtcReleaseScene(b->scene);
    if (b->device)
        rtcReleaseDevice(b->device);
    b->scene = NULL;
    b->device = NULL;
}
