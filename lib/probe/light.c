/* Direct light of directional sources (a fitted light probe) on the operator's subpatches,
 * with shadows from Embree occlusion rays: the emission vector of the first bounce. */
#include "config.h"
#include "probe/probe.h"
#include "scene/bvh.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* L (6 floats per light: its unit direction, then its rgb) from the lights, checked: an
 * error names the light. */
static lrr_status light_table(lrr_context *ctx, const lrr_light *lights, size_t count,
                              float **out)
{
    float *L = NULL;
    lrr_status st = lrr__calloc(ctx, &L, count, 6 * sizeof(float), "direct light sources");
    if (st != LRR_OK)
        return st;
    for (size_t l = 0; l < count; l++) {
        const lrr_light *s = &lights[l];
        double len = 0.0;
        int ok = 1;
        for (int c = 0; c < 3; c++) {
            ok &= isfinite(s->dir[c]) && isfinite(s->rgb[c]) && s->rgb[c] >= 0.0f;
            len += (double)s->dir[c] * s->dir[c];
        }
        if (!ok || !(len > 0.0) || !isfinite(len)) {
            lrr_aligned_free(L);
            return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                              "lrr_probe_direct_light: light %zu has a zero or non-finite "
                              "direction or a negative or non-finite rgb",
                              l);
        }
        len = sqrt(len);
        for (int c = 0; c < 3; c++) {
            L[6 * l + c] = (float)(s->dir[c] / len);
            L[6 * l + 3 + c] = s->rgb[c];
        }
    }
    *out = L;
    return LRR_OK;
}

static float ray_offset(const lrr__geometry *g)
{
    /* the ray origins move off the surface by 1e-5 × the scene's bounding-box diagonal */
    return (float)(1e-5 * lrr__geometry_bounds(g, NULL, NULL));
}

/* emission (n×3) = rho × Σ over the lights L that subpatch i's centre sees (an occlusion ray
 * from eps off its surface) of rgb × cosine; returns whether any value is not finite. */
static int gather_direct(const lrr_operator *op, RTCScene scene, const float *L, size_t count,
                         float eps, float *emission)
{
    const size_t n = op->n;
    const float *ce = op->centre, *nr = op->normal, *rho = op->rho;
    int bad = 0;
#pragma omp parallel for schedule(dynamic, 64) reduction(| : bad)
    for (size_t i = 0; i < n; i++) {
        const float *x = ce + 3 * i, *nv = nr + 3 * i;
        float sum[3] = {0.0f, 0.0f, 0.0f};
        struct RTCIntersectContext ictx;
        rtcInitIntersectContext(&ictx);
        for (size_t l = 0; l < count; l++) {
            const float *w = L + 6 * l;
            float cosine = nv[0] * w[0] + nv[1] * w[1] + nv[2] * w[2];
            if (!(cosine > 0.0f))
                continue;
            struct RTCRay ray;
            ray.org_x = x[0] + eps * nv[0];
            ray.org_y = x[1] + eps * nv[1];
            ray.org_z = x[2] + eps * nv[2];
            ray.tnear = 0.0f;
            ray.dir_x = w[0];
            ray.dir_y = w[1];
            ray.dir_z = w[2];
            ray.time = 0.0f;
            ray.tfar = INFINITY;
            ray.mask = UINT32_MAX;
            ray.id = 0;
            ray.flags = 0;
            rtcOccluded1(scene, &ictx, &ray);
            if (ray.tfar < 0.0f) /* -inf: something is in the way */
                continue;
            for (int c = 0; c < 3; c++)
                sum[c] += w[3 + c] * cosine;
        }
        for (int c = 0; c < 3; c++) {
            emission[3 * i + c] = rho[3 * i + c] * sum[c];
            bad |= !isfinite(emission[3 * i + c]);
        }
    }
    return bad;
}

lrr_status lrr_probe_direct_light(const lrr_operator *op, const lrr_light *lights, size_t count,
                                  float *emission)
{
    lrr_context *ctx = op->ctx;
    const size_t n = op->n;
    if (count > 0 && !lights)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "lrr_probe_direct_light: lights is NULL with count %zu", count);
    float *L = NULL;
    lrr_status st = light_table(ctx, lights, count, &L);
    if (st != LRR_OK)
        return st;
    memset(emission, 0, 3 * n * sizeof(float));
    if (count == 0 || n == 0) {
        lrr_aligned_free(L);
        return LRR_OK;
    }
    const lrr__geometry *g = &op->geom;
    const float eps = ray_offset(g);
    lrr__bvh bvh;
    if ((st = lrr__bvh_build(ctx, g, RTC_BUILD_QUALITY_MEDIUM, 0, "lrr_probe_direct_light",
                             &bvh)) != LRR_OK) {
        lrr_aligned_free(L);
        return st;
    }
    int bad = gather_direct(op, bvh.scene, L, count, eps, emission);
    st = lrr__bvh_status(ctx, &bvh, "occlusion query");
    lrr__bvh_release(&bvh);
    lrr_aligned_free(L);
    if (st != LRR_OK) {
        memset(emission, 0, 3 * n * sizeof(float));
        return st;
    }
    if (bad) {
        memset(emission, 0, 3 * n * sizeof(float));
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "lrr_probe_direct_light: the direct light overflows a float");
    }
    return LRR_OK;
}
