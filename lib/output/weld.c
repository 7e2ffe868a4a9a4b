/* Vertex welding for smooth shading: subpatch corners that coincide (and whose subpatches
 * face the same way, and are in the same group: the exporter's materials) become one
 * vertex, coloured by the mean radiosity around it. */
#include "config.h"
#include "output/render_internal.h"

#include <math.h>
#include <string.h>

/* Welding tolerances: positions relative to the scene's bounding-box diagonal; normals per
 * component, so that corners between walls keep one vertex per wall and stay sharp. */
#define WELD_POS_TOL 1e-5
#define WELD_NORMAL_TOL 1e-3f

/* A welded vertex: quantised position, the normal of the first subpatch that made it and
 * its group (0 when the caller gives none). */
typedef struct wvert {
    int32_t key[3];
    float normal[3];
    uint32_t group;
} wvert;

typedef struct weld {
    lrr_context *ctx;
    size_t cap;           /* hash slots, a power of two */
    uint32_t *slot;       /* vertex id + 1; 0 = empty */
    size_t nv, vcap;
    wvert *vert;          /* nv used, vcap allocated */
} weld;

static uint64_t hash_key(const int32_t k[3])
{
    /* splitmix64's finaliser over the packed key: neighbouring grid cells spread out, which
     * linear probing needs */
    uint64_t h = ((uint64_t)(uint32_t)k[0] * 0x9E3779B97F4A7C15ull) ^
                 ((uint64_t)(uint32_t)k[1] << 21) ^ ((uint64_t)(uint32_t)k[2] << 42) ^
                 (uint64_t)(uint32_t)k[2];
    return lrr__mix64(h);
}

static int normals_agree(const float *a, const float *b)
{
    return fabsf(a[0] - b[0]) <= WELD_NORMAL_TOL && fabsf(a[1] - b[1]) <= WELD_NORMAL_TOL &&
           fabsf(a[2] - b[2]) <= WELD_NORMAL_TOL;
}

/* *id = the vertex at key k in group g with a normal agreeing with nrm, added if there is
 * none. */
static lrr_status weld_insert(weld *w, const int32_t k[3], const float nrm[3], uint32_t g,
                              uint32_t *id)
{
    /* the table has at least twice as many slots as corners: probing finds an empty one */
    size_t mask = w->cap - 1, h = hash_key(k) & mask;
    for (; w->slot[h] != 0; h = (h + 1) & mask) {
        const wvert *v = &w->vert[w->slot[h] - 1];
        if (v->key[0] == k[0] && v->key[1] == k[1] && v->key[2] == k[2] &&
            v->group == g && normals_agree(v->normal, nrm)) {
            *id = w->slot[h] - 1;
            return LRR_OK;
        }
    }
    if (w->nv == w->vcap) {
        /* meshes have fewer vertices than corners: grow on demand, touching less memory */
        size_t vcap = 2 * w->vcap;
        wvert *grown;
        lrr_status st = lrr__calloc(w->ctx, &grown, vcap, sizeof *grown, "render: vertices");
        if (st)
            return st;
        memcpy(grown, w->vert, w->nv * sizeof *grown);
        lrr_aligned_free(w->vert);
        w->vert = grown;
        w->vcap = vcap;
    }
    uint32_t v = (uint32_t)w->nv++;
    memcpy(w->vert[v].key, k, sizeof w->vert[v].key);
    memcpy(w->vert[v].normal, nrm, sizeof w->vert[v].normal);
    w->vert[v].group = g;
    w->slot[h] = v + 1;
    *id = v;
    return LRR_OK;
}

/* Per corner (3n) a welded vertex, and per vertex the area-weighted mean radiosity of the
 * subpatches that touch it. */
lrr_status lrr__render_weld_vertices(const lrr_operator *op, const double *pos,
                                     const float *radiosity, const uint32_t *group,
                                     uint32_t *corner_vertex, float **vertex_colour,
                                     size_t *n_vertices)
{
    lrr_context *ctx = op->ctx;
    size_t n = op->n, nc = 3 * n;
    weld w = {0};
    w.ctx = ctx;
    double *acc = NULL;
    lrr_status st;
    size_t cap = 16;
    while (cap < 2 * nc)
        cap *= 2;
    w.cap = cap;
    w.vcap = n + 64;
    if ((st = lrr__calloc(ctx, &w.slot, cap, sizeof *w.slot, "render: vertex hash")) ||
        (st = lrr__calloc(ctx, &w.vert, w.vcap, sizeof *w.vert, "render: vertices")))
        goto done;

    double lo[3], hi[3];
    double q = WELD_POS_TOL * lrr__geometry_bounds(&op->geom, lo, hi);
    if (!(q > 0) || !isfinite(q))
        q = 1;
    /* relative to the minimum corner, keys stay within ±1e5 whatever the scene's offset */
    for (size_t c = 0; c < nc; c++) {
        int32_t k[3];
        for (int j = 0; j < 3; j++)
            k[j] = (int32_t)lround((pos[3 * c + j] - lo[j]) / q);
        uint32_t g = group ? group[c / 3] : 0;
        if ((st = weld_insert(&w, k, op->normal + 3 * (c / 3), g, &corner_vertex[c])))
            goto done;
    }
    /* per vertex: area-weighted sums of r, g, b and the weight */
    if ((st = lrr__calloc(ctx, &acc, w.nv, 4 * sizeof *acc, "render: vertex sums")))
        goto done;
    for (size_t i = 0; i < n; i++) {
        /* zero-area slivers still count, a little, so no vertex is left without a value */
        double a = op->area[i] > 0 ? op->area[i] : 1e-30;
        for (int k = 0; k < 3; k++) {
            double *s = acc + 4 * (size_t)corner_vertex[3 * i + k];
            for (int j = 0; j < 3; j++)
                s[j] += a * radiosity[3 * i + j];
            s[3] += a;
        }
    }
    float *col;
    if ((st = lrr__calloc(ctx, &col, w.nv, 3 * sizeof *col, "render: vertex colours")))
        goto done;
    for (size_t v = 0; v < w.nv; v++)
        for (int j = 0; j < 3; j++)
            col[3 * v + j] = (float)(acc[4 * v + j] / acc[4 * v + 3]);
    *vertex_colour = col;
    if (n_vertices)
        *n_vertices = w.nv;
done:
    lrr_aligned_free(w.slot);
    lrr_aligned_free(w.vert);
    lrr_aligned_free(acc);
    return st;
}
