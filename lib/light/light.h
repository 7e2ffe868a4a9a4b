/* The light stage (lib/light/): direct light of moving sources on an operator's subpatches
 * (docs/METHOD.md "Lights"). lighting.c owns the plan (BVH, per-light cache, checks),
 * sources.c the irradiance of one source at one receiver. Private to lib/light/ and the
 * probes' directional lights (lrr_probe_direct_light is a set of LRR_LIGHT_SUN sources). */
#ifndef LRR_LIGHT_H
#define LRR_LIGHT_H

#include "operator/operator.h"

#include <embree3/rtcore.h>

/* A checked source, with what the receivers need precomputed. */
typedef struct lrr__source {
    int kind;
    double p[3];        /* position (area: its centre) */
    double d[3];        /* unit: spot axis, sun direction (towards it), area normal */
    double u[3], v[3];  /* area edges */
    double rgb[3];
    double cos_outer, angle, softness; /* spot */
    double area;        /* area light: |u × v| */
    unsigned side;      /* area: samples per side (samples = side²) */
    uint64_t seed;      /* area: jitter stream */
} lrr__source;

/* Checks light l (index `index`, for messages) and fills s; LRR_ERR_INVALID_ARG names the
 * light and the field. */
lrr_status lrr__source_check(lrr_context *ctx, const lrr_light_source *l, size_t index,
                             lrr__source *s);
/* Irradiance H (rgb) of s at receiver i (centre x, unit normal nv, ray offset eps) with
 * shadows from scene; *rays counts the occlusion rays cast. */
void lrr__source_irradiance(const lrr__source *s, RTCScene scene, size_t i, const float *x,
                            const float *nv, float eps, float H[3], uint64_t *rays);

#endif
