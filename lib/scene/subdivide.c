/* The patch/subpatch hierarchy: 4-way midpoint subdivision, patch-major indices and the
 * barycentric → index map (docs/METHOD.md "Patches", "Subpatches" and
 * "Barycentric map"). */
#include "config.h"
#include "scene/scene.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

void lrr__geometry_free(lrr__geometry *g)
{
    lrr_aligned_free(g->vert);
    lrr_aligned_free(g->depth);
    lrr_aligned_free(g->patch0);
    lrr_aligned_free(g->sub0);
    lrr_aligned_free(g->first);
    lrr_aligned_free(g->node);
    lrr_aligned_free(g->order);
    lrr_aligned_free(g->origin);
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
            (src->patch0 && (st = lrr__calloc(ctx, &dst->patch0, src->n_tri + 1, sizeof(size_t),
                                              "patch index"))) ||
            (st = lrr__calloc(ctx, &dst->sub0, src->n_tri + 1, sizeof(size_t),
                              "subpatch index")) ||
            (st = lrr__calloc(ctx, &dst->first, src->k + 1, sizeof(size_t), "patch offsets")) ||
            (src->node && (st = lrr__calloc(ctx, &dst->node, src->k, 1, "patch node depths"))) ||
            (src->order && (st = lrr__calloc(ctx, &dst->order, src->n, sizeof(size_t),
                                             "cluster order"))) ||
            (src->origin && (st = lrr__calloc(ctx, &dst->origin, src->n, sizeof(size_t),
                                              "cluster origin")))) {
            lrr__geometry_free(dst);
            return st;
        }
        memcpy(dst->depth, src->depth, src->n_tri);
        if (src->patch0)
            memcpy(dst->patch0, src->patch0, (src->n_tri + 1) * sizeof(size_t));
        memcpy(dst->sub0, src->sub0, (src->n_tri + 1) * sizeof(size_t));
        memcpy(dst->first, src->first, (src->k + 1) * sizeof(size_t));
        if (src->node)
            memcpy(dst->node, src->node, src->k);
        if (src->order)
            memcpy(dst->order, src->order, src->n * sizeof(size_t));
        if (src->origin)
            memcpy(dst->origin, src->origin, src->n * sizeof(size_t));
    }
    return LRR_OK;
}

/* Largest depth: 4^31 patches of one triangle would overflow 64-bit indices long before. */
#define LRR__MAX_DEPTH 24

lrr_status lrr__geometry_index(lrr_context *ctx, lrr__geometry *g, size_t max_subpatches)
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
    if (g->n > max_subpatches)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "%zu subpatches: more than the %zu expected",
                          g->n, max_subpatches);
    /* the offsets: freshly allocated (the caller owns any previous arrays) */
    g->sub0 = g->first = NULL;
    g->node = NULL;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &g->sub0, g->n_tri + 1, sizeof(size_t), "subpatch index")))
        return st;
    if ((st = lrr__calloc(ctx, &g->first, k + 1, sizeof(size_t), "patch offsets"))) {
        lrr_aligned_free(g->sub0);
        g->sub0 = NULL;
        return st;
    }
    for (size_t t = 0; t <= g->n_tri; t++)
        g->sub0[t] = g->patch0[t] * g->d;
    for (size_t p = 0; p <= k; p++)
        g->first[p] = p * g->d;
    return LRR_OK;
}

lrr_status lrr__geometry_adaptive(lrr_context *ctx, const lrr__geometry *src,
                                  const uint8_t *node, size_t k, const char *where,
                                  lrr_status bad, lrr__geometry *dst)
{
    memset(dst, 0, sizeof *dst);
    if (!src->depth || src->levels != 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "%s: an adaptive hierarchy needs the subpatches as a uniform "
                          "subdivision with levels = 0 (levels = %u)", where, src->levels);
    if (k < src->n_tri || k > src->n)
        return lrr__error(ctx, bad,
                          "%s: %zu patches: an adaptive hierarchy over %zu triangles and %zu "
                          "subpatches has between %zu and %zu", where, k, src->n_tri, src->n,
                          src->n_tri, src->n);
    /* src's patches are the subpatches: copy it, then replace the patch level */
    lrr__geometry g;
    lrr_status st = lrr__geometry_copy(ctx, &g, src);
    if (st)
        return st;
    lrr_aligned_free(g.first);
    g.first = NULL;
    if ((st = lrr__calloc(ctx, &g.first, k + 1, sizeof(size_t), "patch offsets")) ||
        (st = lrr__calloc(ctx, &g.node, k, 1, "patch node depths"))) {
        lrr__geometry_free(&g);
        return st;
    }
    memcpy(g.node, node, k);
    size_t p = 0, i = 0;
    for (size_t t = 0; t < g.n_tri; t++) {
        g.patch0[t] = p;
        const size_t end = g.sub0[t + 1];
        while (i < end) {
            if (p == k || node[p] > g.depth[t]) {
                st = p == k ? lrr__error(ctx, bad,
                                         "%s: %zu patches end before triangle %zu is covered",
                                         where, k, t)
                            : lrr__error(ctx, bad,
                                         "%s: patch %zu has depth %u, below triangle %zu's "
                                         "subpatch depth %u", where, p, node[p], t, g.depth[t]);
                lrr__geometry_free(&g);
                return st;
            }
            const size_t size = (size_t)1 << (2 * (g.depth[t] - node[p]));
            if ((i - g.sub0[t]) % size != 0 || size > end - i) {
                st = lrr__error(ctx, bad,
                                "%s: patch %zu (depth %u) is not a quadtree node of triangle %zu "
                                "at subpatch %zu", where, p, node[p], t, i);
                lrr__geometry_free(&g);
                return st;
            }
            g.first[p++] = i;
            i += size;
        }
    }
    if (p != k) {
        st = lrr__error(ctx, bad, "%s: %zu patches cover the scene, %zu given",
                        where, p, k);
        lrr__geometry_free(&g);
        return st;
    }
    g.patch0[g.n_tri] = k;
    g.first[k] = g.n;
    g.k = k;
    g.d = 0;
    *dst = g;
    return LRR_OK;
}

lrr_status lrr__geometry_clusters(lrr_context *ctx, const lrr__geometry *src,
                                 const size_t *origin, const size_t *first, size_t k,
                                 const char *where, lrr_status bad, lrr__geometry *dst)
{
    memset(dst, 0, sizeof *dst);
    if (!src->depth || src->levels != 0 || src->origin || src->node)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "%s: clusters need the subpatches as a uniform subdivision with "
                          "levels = 0", where);
    const size_t n = src->n;
    if (k < 1 || k > n || first[0] != 0 || first[k] != n)
        return lrr__error(ctx, bad, "%s: %zu clusters over %zu subpatches (between 1 and n, "
                          "offsets from 0 to n)", where, k, n);
    for (size_t p = 0; p < k; p++)
        if (first[p + 1] <= first[p])
            return lrr__error(ctx, bad, "%s: cluster %zu is empty or its offsets descend",
                              where, p);
    lrr__geometry g;
    lrr_status st = lrr__geometry_copy(ctx, &g, src);
    if (st)
        return st;
    lrr_aligned_free(g.first);
    lrr_aligned_free(g.patch0);
    g.first = NULL;
    g.patch0 = NULL;
    if ((st = lrr__calloc(ctx, &g.first, k + 1, sizeof(size_t), "patch offsets")) ||
        (st = lrr__calloc(ctx, &g.order, n, sizeof(size_t), "cluster order")) ||
        (st = lrr__calloc(ctx, &g.origin, n, sizeof(size_t), "cluster origin"))) {
        lrr__geometry_free(&g);
        return st;
    }
    memcpy(g.first, first, (k + 1) * sizeof(size_t));
    for (size_t j = 0; j < n; j++)
        g.order[j] = SIZE_MAX;
    for (size_t i = 0; i < n; i++) {
        size_t j = origin[i];
        if (j >= n || g.order[j] != SIZE_MAX) {
            st = lrr__error(ctx, bad, "%s: subpatch %zu is %s", where, j >= n ? i : j,
                            j >= n ? "out of range" : "in two clusters");
            lrr__geometry_free(&g);
            return st;
        }
        g.order[j] = i;
        g.origin[i] = j;
    }
    g.k = k;
    g.d = 0;
    *dst = g;
    return LRR_OK;
}

void lrr__patch_weights(const lrr__geometry *g, float *w)
{
    if (!g->origin) { /* quadtree patches: equal subpatch areas */
        for (size_t i = 0; i < g->n; i++)
            w[i] = 1.0f;
        return;
    }
    #pragma omp parallel for schedule(dynamic, 64)
    for (size_t p = 0; p < g->k; p++) {
        /* the modelled area of a subpatch: its triangle's over 4^depth (equal within one) */
        double sum = 0;
        for (size_t i = g->first[p]; i < g->first[p + 1]; i++) {
            size_t t = lrr__subpatch_triangle(g, i);
            sum += lrr__tri_area(g->vert + 9 * t) * ldexp(1.0, -2 * g->depth[t]);
        }
        const double dp = (double)(g->first[p + 1] - g->first[p]);
        for (size_t i = g->first[p]; i < g->first[p + 1]; i++) {
            size_t t = lrr__subpatch_triangle(g, i);
            double a = lrr__tri_area(g->vert + 9 * t) * ldexp(1.0, -2 * g->depth[t]);
            w[i] = sum > 0 ? (float)(dp * a / sum) : 1.0f;
        }
    }
}

/* Index of the last entry of a[lo..hi) that is <= x (a ascending, a[lo] <= x). */
static size_t bsearch_le(const size_t *a, size_t lo, size_t hi, size_t x)
{
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (a[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

size_t lrr__patch_of(const lrr__geometry *g, size_t i)
{
    return g->d ? i / g->d : bsearch_le(g->first, 0, g->k, i);
}

size_t lrr__patch_of_leaf(const lrr__geometry *g, size_t t, size_t leaf)
{
    if (g->origin)
        return bsearch_le(g->first, 0, g->k, g->order[g->sub0[t] + leaf]);
    if (g->node)
        return bsearch_le(g->first, g->patch0[t], g->patch0[t + 1], g->sub0[t] + leaf);
    return g->patch0[t] + leaf;
}

size_t lrr__subpatch_at(const lrr__geometry *g, size_t t, double b1, double b2)
{
    double b0;
    lrr__clamp_bary(&b1, &b2, &b0);
    return lrr__subpatch_id(g, g->sub0[t] + lrr__descend(&b0, &b1, &b2, g->depth[t] + g->levels));
}

size_t lrr__subpatch_triangle(const lrr__geometry *g, size_t i)
{
    return bsearch_le(g->sub0, 0, g->n_tri, g->origin ? g->origin[i] : i);
}

void lrr__child_corners(const double *v, int dim, unsigned c, double *out)
{
    double ab[3], bc[3], ca[3];
    for (int j = 0; j < dim; j++) {
        ab[j] = 0.5 * (v[j] + v[dim + j]);
        bc[j] = 0.5 * (v[dim + j] + v[2 * dim + j]);
        ca[j] = 0.5 * (v[2 * dim + j] + v[j]);
    }
    const double *p[3];
    switch (c) {
    case 0: p[0] = v; p[1] = ab; p[2] = ca; break;
    case 1: p[0] = ab; p[1] = v + dim; p[2] = bc; break;
    case 2: p[0] = ca; p[1] = bc; p[2] = v + 2 * dim; break;
    default: p[0] = bc; p[1] = ca; p[2] = ab; break;
    }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < dim; j++)
            out[dim * i + j] = p[i][j];
}

void lrr__subpatch_vertices(const lrr__geometry *g, size_t i, double v[9])
{
    size_t t = lrr__subpatch_triangle(g, i);
    size_t local = (g->origin ? g->origin[i] : i) - g->sub0[t];
    unsigned depth = g->depth[t] + g->levels;
    for (int j = 0; j < 9; j++)
        v[j] = g->vert[9 * t + j];
    double tmp[9];
    for (unsigned l = depth; l-- > 0;) {
        lrr__child_corners(v, 3, (unsigned)((local >> (2 * l)) & 3), tmp);
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

double lrr__geometry_bounds(const lrr__geometry *g, double lo[3], double hi[3])
{
    double l[3] = {INFINITY, INFINITY, INFINITY}, h[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < 9 * g->n_tri; i++) {
        int j = (int)(i % 3);
        l[j] = fmin(l[j], g->vert[i]);
        h[j] = fmax(h[j], g->vert[i]);
    }
    if (g->n_tri == 0)
        for (int j = 0; j < 3; j++)
            l[j] = h[j] = 0;
    for (int j = 0; j < 3 && lo && hi; j++) {
        lo[j] = l[j];
        hi[j] = h[j];
    }
    return sqrt((h[0] - l[0]) * (h[0] - l[0]) + (h[1] - l[1]) * (h[1] - l[1]) +
                (h[2] - l[2]) * (h[2] - l[2]));
}
