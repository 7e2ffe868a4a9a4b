/* The irradiance of one light source at one receiver, with its shadow rays
 * (docs/METHOD.md "Lights"). */
#include "config.h"
#include "light/light.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static int finite3(const float *v)
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

static double norm3(const float *v)
{
    return sqrt((double)v[0] * v[0] + (double)v[1] * v[1] + (double)v[2] * v[2]);
}

static lrr_status bad(lrr_context *ctx, size_t index, const char *what)
{
    return lrr__error(ctx, LRR_ERR_INVALID_ARG, "lrr_lighting_direct: light %zu: %s", index,
                      what);
}

/* The checks every kind shares: rgb, and the position where the kind has one. */
static lrr_status check_common(lrr_context *ctx, const lrr_light_source *l, size_t index)
{
    if (l->kind < LRR_LIGHT_POINT || l->kind > LRR_LIGHT_SUN)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "lrr_lighting_direct: light %zu: kind %d is not one of "
                          "LRR_LIGHT_POINT, _SPOT, _AREA, _SUN", index, l->kind);
    if (!finite3(l->rgb) || !(l->rgb[0] >= 0 && l->rgb[1] >= 0 && l->rgb[2] >= 0))
        return bad(ctx, index, "rgb must be finite and >= 0");
    if (l->kind != LRR_LIGHT_SUN && !finite3(l->position))
        return bad(ctx, index, "position is not finite");
    return LRR_OK;
}

static lrr_status check_area(lrr_context *ctx, const lrr_light_source *l, size_t index,
                             lrr__source *s)
{
    if (!finite3(l->u) || !finite3(l->v))
        return bad(ctx, index, "the edges u, v are not finite");
    if (l->samples > 1024)
        return bad(ctx, index, "more than 1024 samples");
    double c[3];
    for (int j = 0; j < 3; j++) {
        s->u[j] = l->u[j];
        s->v[j] = l->v[j];
    }
    lrr__cross3(s->u, s->v, c);
    s->area = sqrt(lrr__dot3(c, c));
    if (!(s->area > 0) || !isfinite(s->area))
        return bad(ctx, index, "the rectangle's edges u, v are parallel or zero");
    for (int j = 0; j < 3; j++)
        s->d[j] = c[j] / s->area;
    unsigned want = l->samples ? l->samples : 16;
    s->side = (unsigned)ceil(sqrt((double)want) - 1e-9);
    return LRR_OK;
}

lrr_status lrr__source_check(lrr_context *ctx, const lrr_light_source *l, size_t index,
                             lrr__source *s)
{
    memset(s, 0, sizeof *s);
    lrr_status st = check_common(ctx, l, index);
    if (st)
        return st;
    s->kind = l->kind;
    for (int j = 0; j < 3; j++) {
        s->p[j] = l->position[j];
        s->rgb[j] = l->rgb[j];
    }
    s->seed = 0x9e3779b97f4a7c15ULL ^ (uint64_t)index;
    if (l->kind == LRR_LIGHT_AREA)
        return check_area(ctx, l, index, s);
    if (l->kind == LRR_LIGHT_POINT)
        return LRR_OK;
    double len = norm3(l->direction);
    if (!finite3(l->direction) || !(len > 0) || !isfinite(len))
        return bad(ctx, index, "direction is zero or not finite");
    for (int j = 0; j < 3; j++)
        s->d[j] = l->direction[j] / len;
    if (l->kind == LRR_LIGHT_SPOT) {
        if (!(l->cone_angle > 0 && l->cone_angle < M_PI))
            return bad(ctx, index, "cone_angle must be in (0, π) radians");
        if (!(l->cone_softness >= 0 && l->cone_softness <= l->cone_angle))
            return bad(ctx, index, "cone_softness must be in [0, cone_angle]");
        s->angle = l->cone_angle;
        s->softness = l->cone_softness;
        s->cos_outer = cos(s->angle);
    }
    return LRR_OK;
}

/* Smoothstep fall-off of a spot at angle theta from its axis. */
static double cone_factor(const lrr__source *s, double cos_theta)
{
    if (cos_theta <= s->cos_outer)
        return 0;
    double theta = acos(cos_theta > 1 ? 1 : cos_theta), inner = s->angle - s->softness;
    if (theta <= inner)
        return 1;
    double x = (s->angle - theta) / s->softness; /* softness > 0 here */
    return x * x * (3 - 2 * x);
}

/* The weight cosine / r² (times the cone) of a point-like source at q seen from receiver x
 * (unit normal nv), with the unit direction w and distance r towards it; 0 when it sends
 * nothing there. */
static double point_weight(const lrr__source *s, const float *x, const float *nv,
                           const double q[3], double w[3], double *r)
{
    for (int j = 0; j < 3; j++)
        w[j] = q[j] - x[j];
    double r2 = lrr__dot3(w, w);
    *r = sqrt(r2);
    if (!(*r > 0))
        return 0;
    for (int j = 0; j < 3; j++)
        w[j] /= *r;
    double cosine = nv[0] * w[0] + nv[1] * w[1] + nv[2] * w[2];
    if (!(cosine > 0))
        return 0;
    double f = cosine / r2;
    if (s->kind == LRR_LIGHT_SPOT)
        f *= cone_factor(s, -lrr__dot3(w, s->d));
    return f > 0 ? f : 0;
}

double lrr__source_weight(const lrr__source *s, const float *x, const float *nv)
{
    double w[3], r;
    return point_weight(s, x, nv, s->p, w, &r);
}

/* A point-like source at q: its weight with its ray. */
static void towards_point(const lrr__source *s, lrr__shadow_batch *b, unsigned slot,
                          const float *o, const float *x, const float *nv, const double q[3])
{
    double w[3], r, f = point_weight(s, x, nv, q, w, &r);
    if (!(f > 0))
        return;
    /* stop just short of the light: it is a point, not geometry */
    lrr__shadow_push(b, o, w, (float)(r * (1 - 1e-6)), slot, f);
}

/* The area light by side² stratified, jittered points: weights cr·cl / r², whose visible sum
 * times area / (side² π) is the F(x → rectangle) estimate. */
static void towards_area(const lrr__source *s, lrr__shadow_batch *b, unsigned slot,
                         const float *o, size_t i, const float *x, const float *nv)
{
    const unsigned m = s->side;
    uint64_t state = s->seed ^ lrr__splitmix64((uint64_t)i);
    for (unsigned a = 0; a < m; a++)
        for (unsigned c = 0; c < m; c++) {
            double ja = (lrr__splitmix64_next(&state) >> 11) * 0x1.0p-53,
                   jb = (lrr__splitmix64_next(&state) >> 11) * 0x1.0p-53;
            double sa = (a + ja) / m - 0.5, sb = (c + jb) / m - 0.5, q[3], w[3];
            for (int j = 0; j < 3; j++) {
                q[j] = s->p[j] + sa * s->u[j] + sb * s->v[j];
                w[j] = q[j] - x[j];
            }
            double r2 = lrr__dot3(w, w), r = sqrt(r2);
            if (!(r > 0))
                continue;
            double cr = (nv[0] * w[0] + nv[1] * w[1] + nv[2] * w[2]) / r,
                   cl = -lrr__dot3(w, s->d) / r;
            if (!(cr > 0 && cl > 0))
                continue;
            for (int j = 0; j < 3; j++)
                w[j] /= r;
            lrr__shadow_push(b, o, w, (float)(r * (1 - 1e-6)), slot, cr * cl / r2);
        }
}

void lrr__source_rays(const lrr__source *s, lrr__shadow_batch *b, size_t i, unsigned slot,
                      const float *x, const float *nv, float eps)
{
    const float o[3] = {x[0] + eps * nv[0], x[1] + eps * nv[1], x[2] + eps * nv[2]};
    if (s->kind == LRR_LIGHT_SUN) {
        /* as lrr_probe_direct_light always did: a float cosine (its weight, exact in double) */
        const float w[3] = {(float)s->d[0], (float)s->d[1], (float)s->d[2]};
        float cosine = nv[0] * w[0] + nv[1] * w[1] + nv[2] * w[2];
        if (!(cosine > 0.0f))
            return;
        const double wd[3] = {w[0], w[1], w[2]};
        lrr__shadow_push(b, o, wd, INFINITY, slot, cosine);
    } else if (s->kind == LRR_LIGHT_AREA)
        towards_area(s, b, slot, o, i, x, nv);
    else
        towards_point(s, b, slot, o, x, nv, s->p);
}

void lrr__source_irradiance(const lrr__source *s, double acc, float H[3])
{
    if (s->kind == LRR_LIGHT_SUN) { /* float products, as before */
        for (int c = 0; c < 3; c++)
            H[c] = (float)s->rgb[c] * (float)acc;
        return;
    }
    double f = s->kind == LRR_LIGHT_AREA ? acc * s->area / ((double)s->side * s->side * M_PI)
                                         : acc;
    for (int c = 0; c < 3; c++)
        H[c] = (float)(s->rgb[c] * f);
}
