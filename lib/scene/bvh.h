/* The scene's input triangles as an Embree 3 BVH (one geometry, primitive id = triangle
 * index): the one setup every ray caster of lrr shares (the ray-cast hemicube, the
 * path-traced reference, the probes' shadow rays, the scene check, the render camera's
 * closed-scene test). Embree reports errors through a callback;
 * the first is kept in the struct, which therefore must stay where it is while it lives. */
#ifndef LRR_SCENE_BVH_H
#define LRR_SCENE_BVH_H

#include "scene/scene.h"

#include <embree3/rtcore.h>

typedef struct lrr__bvh {
    RTCDevice device;
    RTCScene scene;
    const char *who;    /* the API function building it, for messages */
    enum RTCError code; /* the first error Embree reported (RTC_ERROR_NONE: none) */
    char message[256];
} lrr__bvh;

/* Builds b in place for g's triangles with the given build quality; robust != 0 asks for
 * Embree's watertight triangle test (RTC_SCENE_FLAG_ROBUST). Errors, recorded on ctx as
 * "WHO: Embree WHAT failed (error N: message)": LRR_ERR_NOMEM when Embree runs out of
 * memory, LRR_ERR_UNSUPPORTED for its other errors, LRR_ERR_OVERFLOW beyond its 32-bit
 * indices; nothing is left to release then. */
lrr_status lrr__bvh_build(lrr_context *ctx, const lrr__geometry *g,
                          enum RTCBuildQuality quality, int robust, const char *who,
                          lrr__bvh *b);
/* After the queries: an error Embree reported during them, recorded as above with `what`
 * ("ray query", "occlusion query"). */
lrr_status lrr__bvh_status(lrr_context *ctx, const lrr__bvh *b, const char *what);
/* Releases the scene and the device (b may be zeroed or already released). */
void lrr__bvh_release(lrr__bvh *b);

#endif
