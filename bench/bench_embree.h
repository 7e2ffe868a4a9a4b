/* Embree baselines of lrr-bench (lights.c, raycast_rays.c): a BVH of an operator's subpatch
 * triangles, built as the bench's Embree-only loops trace it. */
#ifndef LRR_BENCH_EMBREE_H
#define LRR_BENCH_EMBREE_H

#include <embree3/rtcore.h>

#include "lrr.h"

/* The scene of op's n subpatch triangles on dev; like_lrr: robust, medium build quality, as
 * lrr's ray caster builds its BVH (lib/scene/bvh.c), else Embree's defaults. NULL when out
 * of memory. Release with rtcReleaseScene. */
RTCScene bench_embree_scene(RTCDevice dev, const lrr_operator *op, size_t n, int like_lrr);

#endif
