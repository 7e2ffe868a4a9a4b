/* The patch/subpatch hierarchy: 4-way midpoint subdivision, patch-major indices and the
 * barycentric → index map (DESIGN.md "Patches" and "Subpatches"). */
#include "config.h"
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void lrr__geometry_free(lrr__geometry *g)
{
    lrr_aligned_free(g->vert);
    lrr_aligned_free(g->depth);
    lrr_aligned_free(g->patch0);
    memset(g, 0, sizeof *g);
}

lrr_status lrr__geometry_copy(lrr_context *ctx, lrr__geometry *dst, const lrr__geometry *src)
{
    memset(dst, 0, sizeof *dst);
    lrr_status st;
    if ((st = lrr__calloc(ctx, &dst->vert, src->n_tri, 9 * sizeof(float), "triangle vertices")))
        return st;
    memcpy(dst->vert, src->vert, src->n_tri * 9 * sizeof(float));
    dst->n_tri = src->n_tri;
    dst->levels = src->levels;
    dst->d = src->d;
    dst->k = src->k;
    dst->n = src->n;
    if (src->depth) {
        if ((st = lrr__calloc(ctx, &dst->depth, src->n_tri, 1, "patch depths")) ||
            (st = lrr__calloc(ctx, &dst->patch0, src->n_tri + 1, sizeof(size_t), "patch index"))) {
            lrr__geometry_free(dst);
            return st;
        }
        memcpy(dst->depth, src->depth, src->n_tri);
        memcpy(dst->patch0, src->patch0, (src->n_tri + 1) * sizeof(size_t));
    }
    return LRR_OK;
}

/* Largest depth: 4^31 patches of one triangle would overflow 64-bit indices long before. */
#define LRR__MAX_DEPTH 24

lrr_status lrr__geometry_index(lrr_context *ctx, lrr__geometry *g)
{
    if (g->levels > 10)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "levels = %u: at most 10 (d = 4^10)",
                          g->levels);
    g->d = (size_t)1 << (2 * g->levels);
    size_t k = 0;
    for (size_t t = 0; t < g->n_tri; t++) {
        if (g->depth[t] > LRR__MAX_DEPTH)
            return lrr__error(ctx, LRR_ERR_OVERFLOW,
                              "triangle %zu would need patch depth %u (> %d)", t, g->depth[t],
                              LRR__MAX_DEPTH);
        g->patch0[t] = k;
        size_t add = (size_t)1 << (2 * g->depth[t]);
        if (__builtin_add_overflow(k, add, &k))
            return lrr__error(ctx, LRR_ERR_OVERFLOW, "patch count overflows size_t");
    }
    g->patch0[g->n_tri] = k;
    g->k = k;
    if (!lrr__mul_size(k, g->d, &g->n))
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "n = k·d = %zu·%zu overflows size_t", k, g->d);
    return LRR_OK;
}

/* Descends `depth` levels, returning the base-4 digits as an index. */
static size_t descend(double *b0, double *b1, double *b2, unsigned depth)
{
    size_t idx = 0;
    for (unsigned l = 0; l < depth; l++)
        idx = idx * 4 + lrr__child_at(b0, b1, b2);
    return idx;
}

static void clamp_bary(double *b1, double *b2, double *b0)
{
    if (!(*b1 > 0)) *b1 = 0;
    if (!(*b2 > 0)) *b2 = 0;
    if (*b1 > 1) *b1 = 1;
    if (*b2 > 1) *b2 = 1;
    *b0 = 1 - *b1 - *b2;
    if (*b0 < 0) {
        double s = *b1 + *b2;
        *b1 /= s;
        *b2 /= s;
        *b0 = 0;
    }
}

size_t lrr__patch_at(const lrr__geometry *g, size_t t, double b1, double b2)
{
    double b0;
    clamp_bary(&b1, &b2, &b0);
    return g->patch0[t] + descend(&b0, &b1, &b2, g->depth[t]);
}

size_t lrr__subpatch_at(const lrr__geometry *g, size_t t, double b1, double b2)
{
    double b0;
    clamp_bary(&b1, &b2, &b0);
    size_t p = g->patch0[t] + descend(&b0, &b1, &b2, g->depth[t]);
    return p * g->d + descend(&b0, &b1, &b2, g->levels);
}

size_t lrr__patch_triangle(const lrr__geometry *g, size_t p)
{
    size_t lo = 0, hi = g->n_tri; /* patch0[lo] <= p < patch0[hi] */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (g->patch0[mid] <= p)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

static void child_vertices(const double v[9], unsigned c, double out[9])
{
    double ab[3], bc[3], ca[3];
    for (int j = 0; j < 3; j++) {
        ab[j] = 0.5 * (v[j] + v[3 + j]);
        bc[j] = 0.5 * (v[3 + j] + v[6 + j]);
        ca[j] = 0.5 * (v[6 + j] + v[j]);
    }
    const double *p[3];
    switch (c) {
    case 0: p[0] = v; p[1] = ab; p[2] = ca; break;
    case 1: p[0] = ab; p[1] = v + 3; p[2] = bc; break;
    case 2: p[0] = ca; p[1] = bc; p[2] = v + 6; break;
    default: p[0] = bc; p[1] = ca; p[2] = ab; break;
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            out[3 * i + j] = p[i][j];
}

void lrr__subpatch_vertices(const lrr__geometry *g, size_t i, double v[9])
{
    size_t p = i / g->d, s = i % g->d;
    size_t t = lrr__patch_triangle(g, p);
    size_t local = p - g->patch0[t];
    unsigned depth = g->depth[t];
    for (int j = 0; j < 9; j++)
        v[j] = g->vert[9 * t + j];
    double tmp[9];
    for (unsigned l = depth; l-- > 0;) {
        child_vertices(v, (unsigned)((local >> (2 * l)) & 3), tmp);
        memcpy(v, tmp, sizeof tmp);
    }
    for (unsigned l = g->levels; l-- > 0;) {
        child_vertices(v, (unsigned)((s >> (2 * l)) & 3), tmp);
        memcpy(v, tmp, sizeof tmp);
    }
}

void lrr__subpatch_frames(const lrr__geometry *g, float *centre, float *normal, float *area)
{
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < g->n; i++) {
        double v[9];
        lrr__subpatch_vertices(g, i, v);
        double e1[3] = {v[3] - v[0], v[4] - v[1], v[5] - v[2]};
        double e2[3] = {v[6] - v[0], v[7] - v[1], v[8] - v[2]};
        double c[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                       e1[0] * e2[1] - e1[1] * e2[0]};
        double len = sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]);
        for (int j = 0; j < 3; j++) {
            if (centre) centre[3 * i + j] = (float)((v[j] + v[3 + j] + v[6 + j]) / 3);
            if (normal) normal[3 * i + j] = (float)(len > 0 ? c[j] / len : 0);
        }
        if (area) area[i] = (float)(0.5 * len);
    }
}
