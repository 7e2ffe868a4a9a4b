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
/* Shadow rays traced together (shadow.c): up to LRR__SHADOW_RAYS rays in 16-wide packets;
 * each carries its receiver (an index into acc) and the weight it adds to acc[receiver] when
 * nothing is in the way. A flush adds them in push order. */
#define LRR__SHADOW_LANES 16
#define LRR__SHADOW_RAYS 256
typedef struct lrr__shadow_batch {
    struct RTCRay16 packet[LRR__SHADOW_RAYS / LRR__SHADOW_LANES];
    unsigned receiver[LRR__SHADOW_RAYS];
    double weight[LRR__SHADOW_RAYS];
    unsigned count;
    RTCScene scene;
    double *acc;
    uint64_t rays; /* rays pushed since init */
} lrr__shadow_batch;

void lrr__shadow_init(lrr__shadow_batch *b, RTCScene scene, double *acc);
/* The segment from o (already off the surface) along unit w for length t (INFINITY: a ray
 * to infinity); finite segments are traced from their far end back towards o. */
void lrr__shadow_push(lrr__shadow_batch *b, const float o[3], const double w[3], float t,
                      unsigned receiver, double weight);
void lrr__shadow_flush(lrr__shadow_batch *b);

/* Pushes the shadow rays of s at receiver i (centre x, unit normal nv, ray offset eps) into b,
 * accumulating into acc[slot]; after the flush, lrr__source_irradiance turns acc[slot] into
 * the irradiance H (rgb). */
void lrr__source_rays(const lrr__source *s, lrr__shadow_batch *b, size_t i, unsigned slot,
                      const float *x, const float *nv, float eps);
void lrr__source_irradiance(const lrr__source *s, double acc, float H[3]);
/* Point and spot lights: the weight a receiver's one shadow ray adds when unoccluded
 * (cosine / r², times the cone), 0 when the light cannot reach it. */
double lrr__source_weight(const lrr__source *s, const float *x, const float *nv);

/* The error budget of a point or spot light's shadow rays (budget.c, docs/METHOD.md
 * "Lights"): receivers binned by their key a ρ̄² g² (a area, ρ̄² the mean of ρ_c², g the
 * unshadowed weight) in half octaves, bin 0 holding the largest keys; LRR__BUDGET_DARK marks
 * receivers the light cannot reach. cost[b][c] is the sum of a ρ_c² g² over bin b: what the
 * bin's receivers can be wrong by, squared, in channel c. */
#define LRR__BUDGET_BINS 512
#define LRR__BUDGET_DARK 0xFFFFu
typedef double lrr__budget_cost[LRR__BUDGET_BINS][3];
/* The receivers as the budget reads them, built once per lighting (budget.c): the centres'
 * and normals' coordinates each contiguous (x, y, z, nx, ny, nz), and a ρ_c² per channel
 * (a area, ρ_c albedo), n floats each, in one allocation. */
typedef struct lrr__budget_receivers {
    float *x, *y, *z, *nx, *ny, *nz, *ar[3];
} lrr__budget_receivers;
lrr_status lrr__budget_receivers_init(lrr_context *ctx, const lrr_operator *op,
                                      lrr__budget_receivers *r);
void lrr__budget_receivers_free(lrr__budget_receivers *r);
/* A point light at p on receivers [i0, i1): g = cos / r² (0 where it cannot reach) and the
 * key's bin (LRR__BUDGET_DARK where g = 0). budget.c's C and budget_avx2.c's AVX2 (8 at a
 * time) give the same g and bins to the bit. */
void lrr__budget_point_keys(const lrr__budget_receivers *r, size_t i0, size_t i1,
                            const float p[3], float *g, uint16_t *bin);
void lrr__budget_point_keys_avx2(const lrr__budget_receivers *r, size_t i0, size_t i1,
                                 const float p[3], float *g, uint16_t *bin);
/* Fills g[l] (n), bin[l] (n) and cost[l] for the m <= LRR__BUDGET_GROUP point or spot
 * sources s[l] on op's receivers r, in one pass (AVX2 where avx2). OpenMP. */
#define LRR__BUDGET_GROUP 4
void lrr__budget_weigh(const lrr_operator *op, const lrr__budget_receivers *r,
                       const lrr__source *s, size_t m, float *const *g, uint16_t *const *bin,
                       lrr__budget_cost *cost, int avx2);
/* The first bin T from which on the receivers may keep a guessed visibility: the smallest T
 * with Σ_{b ≥ T} cost[b][c] <= tol² S_c in every channel; S NULL: S_c the cost of the bins
 * before T (every traced receiver visible, an upper bound of the traced light). */
unsigned lrr__budget_cut(const lrr__budget_cost cost, double tol, const double *S);

#endif
