/* Direct light of directional sources (a fitted light probe) on the operator's subpatches,
 * with shadows from Embree occlusion rays: the emission vector of the first bounce. The
 * lights are checked here (errors name lrr_probe_direct_light), then traced as
 * LRR_LIGHT_SUN sources by lib/light/. */
#include "config.h"
#include "probe/probe.h"

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
    /* directional lights are LRR_LIGHT_SUN sources (lib/light/), the same rays and sums */
    lrr_light_source *src = NULL;
    if ((st = lrr__calloc(ctx, &src, count, sizeof *src, "sun sources")) != LRR_OK) {
        lrr_aligned_free(L);
        return st;
    }
    for (size_t l = 0; l < count; l++) {
        src[l].kind = LRR_LIGHT_SUN;
        for (int c = 0; c < 3; c++) { /* normalised there as light_table does here */
            src[l].direction[c] = lights[l].dir[c];
            src[l].rgb[c] = lights[l].rgb[c];
        }
    }
    lrr_aligned_free(L);
    lrr_lighting *lt = NULL;
    if ((st = lrr_lighting_create(op, &lt)) == LRR_OK)
        st = lrr_lighting_direct(lt, src, count, emission);
    lrr_lighting_destroy(lt);
    lrr_aligned_free(src);
    if (st != LRR_OK)
        memset(emission, 0, 3 * n * sizeof(float));
    return st;
}
