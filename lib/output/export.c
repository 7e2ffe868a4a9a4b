/* The lit mesh that the exporters write (gltf.c, ply_out.c; lrr.h "export"): the request
 * checked, the materials found, the subpatch corners welded (weld.c, the renderer's weld,
 * with materials as groups) and the triangles' corners mapped to compact vertices. */
#include "config.h"
#include "output/render_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The options (defaults when opts is NULL) into *o, the operator and the radiosity checked:
 * errors name `what` and the path. */
static lrr_status check_export(const lrr_operator *op, const float *radiosity,
                               const lrr_export_options *opts, const char *what,
                               const char *path, lrr_export_options *o)
{
    lrr_context *ctx = op->ctx;
    *o = lrr_export_options_defaults();
    lrr_status st;
    if (opts && (st = lrr__options_read(ctx, opts, sizeof *o,
                                        LRR__FIRST_SIZE(lrr_export_options, exposure), o,
                                        "lrr_export_options")))
        return st;
    if (!*path)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "%s: empty output path", what);
    if (o->subpatches < 0 || o->subpatches > 1)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "%s %s: subpatches = %d: expected 0 or 1",
                          what, path, o->subpatches);
    if (!isfinite(o->exposure) || o->exposure < 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "%s %s: exposure %g must be finite and >= 0 (0 = automatic)", what,
                          path, o->exposure);
    /* vertex and index numbers are 32-bit in both formats; 3 corners per subpatch */
    if (op->n > UINT32_MAX / 3)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "%s %s: %zu subpatches: their %zu corners exceed 32-bit indices",
                          what, path, op->n, 3 * op->n);
    if (op->n == 0 || op->geom.n_tri == 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "%s %s: the operator has no triangles",
                          what, path);
    if (!op->area || !op->normal || !op->rho || op->geom.n != op->n)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "%s %s: operator without subpatch geometry", what, path);
    for (size_t i = 0; i < op->n; i++)
        for (int j = 0; j < 3; j++) {
            float b = radiosity[3 * i + j];
            if (!isfinite(b) || b < 0)
                return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                                  "%s %s: radiosity of subpatch %zu, channel %d is %g: must be "
                                  "finite and >= 0",
                                  what, path, i, j, (double)b);
        }
    return LRR_OK;
}

/* ------------------------------------------------------------------ materials */

/* An item (triangle or subpatch) and its material key (rho, E). */
typedef struct mat_item {
    float key[6];
    uint32_t item;
} mat_item;

static int cmp_mat_item(const void *pa, const void *pb)
{
    const mat_item *a = pa, *b = pb;
    for (int j = 0; j < 6; j++)
        if (a->key[j] != b->key[j])
            return a->key[j] < b->key[j] ? -1 : 1;
    return a->item < b->item ? -1 : a->item > b->item;
}

/* The material key of subpatch i: its reflectance and emission (0 without emission). */
static void subpatch_key(const lrr_operator *op, size_t i, float key[6])
{
    for (int j = 0; j < 3; j++) {
        key[j] = op->rho[3 * i + j];
        key[3 + j] = op->emission ? op->emission[3 * i + j] : 0.0f;
    }
}

/* mat[item] (n_items): the material of each item, numbered in increasing order of (rho, E),
 * m->nm, m->rho and m->emission. An input triangle's material is its first subpatch's. */
static lrr_status find_materials(const lrr_operator *op, size_t n_items, int subpatches,
                                 uint32_t *mat, lrr__export_mesh *m)
{
    lrr_context *ctx = op->ctx;
    const lrr__geometry *g = &op->geom;
    mat_item *it;
    lrr_status st = lrr__calloc(ctx, &it, n_items, sizeof *it, "export: material keys");
    if (st)
        return st;
    for (size_t t = 0; t < n_items; t++) {
        size_t i = subpatches ? t : lrr__subpatch_id(g, g->sub0[t]);
        subpatch_key(op, i, it[t].key);
        it[t].item = (uint32_t)t;
    }
    qsort(it, n_items, sizeof *it, cmp_mat_item);
    size_t nm = 0;
    for (size_t r = 0; r < n_items; r++)
        if (r == 0 || memcmp(it[r].key, it[r - 1].key, sizeof it[r].key) != 0)
            nm++;
    if ((st = lrr__calloc(ctx, &m->rho, nm, 3 * sizeof *m->rho, "export: materials")) ||
        (st = lrr__calloc(ctx, &m->emission, nm, 3 * sizeof *m->emission,
                          "export: materials")))
        goto done;
    size_t id = 0;
    for (size_t r = 0; r < n_items; r++) {
        if (r > 0 && memcmp(it[r].key, it[r - 1].key, sizeof it[r].key) != 0)
            id++;
        memcpy(m->rho + 3 * id, it[r].key, 3 * sizeof(float));
        memcpy(m->emission + 3 * id, it[r].key + 3, 3 * sizeof(float));
        mat[it[r].item] = (uint32_t)id;
    }
    m->nm = nm;
done:
    lrr_aligned_free(it);
    return st;
}

/* ------------------------------------------------------------------ the mesh */

/* The work arrays of one build. */
typedef struct export_work {
    double *pos;            /* 9 per subpatch: its corners */
    uint32_t *group;        /* per subpatch: the material the weld keeps apart */
    uint32_t *mat;          /* per item (triangle or subpatch) its material */
    uint32_t *corner_vertex;/* 3 per subpatch: the welded vertex */
    float *vcol;            /* per welded vertex: the mean radiosity */
    size_t nw;              /* welded vertices */
    uint32_t *out_id;       /* per welded vertex: the output vertex + 1; 0 = unused */
} export_work;

static void work_free(export_work *w)
{
    lrr_aligned_free(w->pos);
    lrr_aligned_free(w->group);
    lrr_aligned_free(w->mat);
    lrr_aligned_free(w->corner_vertex);
    lrr_aligned_free(w->vcol);
    lrr_aligned_free(w->out_id);
}

/* Item t's corner k: its welded vertex, the subpatch whose normal it takes and its position
 * (the input triangle's own vertex, or the subpatch's corner). Corner k of an input triangle
 * is corner k of the subpatch at that corner (children 0, 1, 2 of a split keep a, b, c). */
static void item_corner(const lrr_operator *op, const export_work *w, int subpatches, size_t t,
                        int k, uint32_t *wv, size_t *sub, float p[3])
{
    static const double bary[3][2] = {{0, 0}, {1, 0}, {0, 1}};
    size_t i = subpatches ? t : lrr__subpatch_at(&op->geom, t, bary[k][0], bary[k][1]);
    *wv = w->corner_vertex[3 * i + (size_t)k];
    *sub = i;
    for (int j = 0; j < 3; j++)
        p[j] = subpatches ? (float)w->pos[9 * i + 3 * k + j] : op->geom.vert[9 * t + 3 * k + j];
}

/* The output vertex of welded vertex wv, made on its first use (position p, the normal of
 * subpatch sub, the welded colour). */
static uint32_t use_vertex(const lrr_operator *op, export_work *w, lrr__export_mesh *m,
                           uint32_t wv, size_t sub, const float p[3])
{
    if (w->out_id[wv])
        return w->out_id[wv] - 1;
    uint32_t v = (uint32_t)m->nv++;
    w->out_id[wv] = v + 1;
    double nrm[3] = {op->normal[3 * sub], op->normal[3 * sub + 1], op->normal[3 * sub + 2]};
    lrr__normalize3(nrm); /* float normals are unit to ~1e-7; the validator checks */
    for (int j = 0; j < 3; j++) {
        double b = w->vcol[3 * (size_t)wv + j];
        m->pos[3 * v + j] = p[j];
        m->normal[3 * v + j] = (float)nrm[j];
        m->radiosity[3 * v + j] = (float)b;
        m->colour[3 * v + j] = (float)fmin(1.0, b * m->exposure);
    }
    return v;
}

/* m->index grouped by material (a counting sort of the items), and the vertices in order of
 * first use. */
static lrr_status emit_triangles(const lrr_operator *op, export_work *w, lrr__export_mesh *m)
{
    lrr_context *ctx = op->ctx;
    size_t nt = m->nt, nm = m->nm;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &m->tri_start, nm + 1, sizeof *m->tri_start,
                          "export: material ranges")) ||
        (st = lrr__calloc(ctx, &m->index, nt, 3 * sizeof *m->index, "export: indices")) ||
        (st = lrr__calloc(ctx, &w->out_id, w->nw, sizeof *w->out_id, "export: vertex map")))
        return st;
    size_t nv_max = m->subpatches ? w->nw : (3 * nt < w->nw ? 3 * nt : w->nw);
    if ((st = lrr__calloc(ctx, &m->pos, nv_max, 3 * sizeof *m->pos, "export: positions")) ||
        (st = lrr__calloc(ctx, &m->normal, nv_max, 3 * sizeof *m->normal, "export: normals")) ||
        (st = lrr__calloc(ctx, &m->radiosity, nv_max, 3 * sizeof *m->radiosity,
                          "export: radiosity")) ||
        (st = lrr__calloc(ctx, &m->colour, nv_max, 3 * sizeof *m->colour, "export: colours")))
        return st;
    for (size_t t = 0; t < nt; t++)
        m->tri_start[w->mat[t] + 1]++;
    for (size_t k = 0; k < nm; k++)
        m->tri_start[k + 1] += m->tri_start[k];
    size_t *next = NULL;
    if ((st = lrr__calloc(ctx, &next, nm, sizeof *next, "export: material cursors")))
        return st;
    memcpy(next, m->tri_start, nm * sizeof *next);
    for (size_t t = 0; t < nt; t++) {
        size_t slot = next[w->mat[t]]++;
        for (int k = 0; k < 3; k++) {
            uint32_t wv;
            size_t sub;
            float p[3];
            item_corner(op, w, m->subpatches, t, k, &wv, &sub, p);
            m->index[3 * slot + (size_t)k] = use_vertex(op, w, m, wv, sub, p);
        }
    }
    lrr_aligned_free(next);
    return LRR_OK;
}

/* Subpatch corners, groups (the materials) and the weld. */
static lrr_status weld_corners(const lrr_operator *op, const float *radiosity, export_work *w,
                               const lrr__export_mesh *m)
{
    lrr_context *ctx = op->ctx;
    const lrr__geometry *g = &op->geom;
    size_t n = op->n;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &w->pos, n, 9 * sizeof *w->pos, "export: subpatch corners")) ||
        (st = lrr__calloc(ctx, &w->group, n, sizeof *w->group, "export: subpatch groups")) ||
        (st = lrr__calloc(ctx, &w->corner_vertex, n, 3 * sizeof *w->corner_vertex,
                          "export: corner vertices")))
        return st;
    for (size_t i = 0; i < n; i++)
        lrr__subpatch_vertices(g, i, w->pos + 9 * i);
    if (m->subpatches)
        memcpy(w->group, w->mat, n * sizeof *w->group);
    else /* every subpatch in its triangle's material: the triangle's corners find theirs */
        for (size_t t = 0; t < g->n_tri; t++)
            for (size_t j = g->sub0[t]; j < g->sub0[t + 1]; j++)
                w->group[lrr__subpatch_id(g, j)] = w->mat[t];
    return lrr__render_weld_vertices(op, w->pos, radiosity, w->group, w->corner_vertex,
                                     &w->vcol, &w->nw);
}

lrr_status lrr__export_mesh_build(const lrr_operator *op, const float *radiosity,
                                  const lrr_export_options *opts, const char *what,
                                  const char *path, lrr__export_mesh *m)
{
    memset(m, 0, sizeof *m);
    lrr_export_options o;
    lrr_status st = check_export(op, radiosity, opts, what, path, &o);
    if (st)
        return st;
    m->subpatches = o.subpatches;
    m->exposure = o.exposure > 0 ? o.exposure : lrr_render_auto_exposure(op, radiosity);
    m->nt = o.subpatches ? op->n : op->geom.n_tri;
    export_work w = {0};
    if ((st = lrr__calloc(op->ctx, &w.mat, m->nt, sizeof *w.mat, "export: item materials")) ||
        (st = find_materials(op, m->nt, o.subpatches, w.mat, m)) ||
        (st = weld_corners(op, radiosity, &w, m)) || (st = emit_triangles(op, &w, m)))
        goto done;
done:
    work_free(&w);
    return st;
}

void lrr__export_mesh_free(lrr__export_mesh *m)
{
    lrr_aligned_free(m->pos);
    lrr_aligned_free(m->normal);
    lrr_aligned_free(m->radiosity);
    lrr_aligned_free(m->colour);
    lrr_aligned_free(m->index);
    lrr_aligned_free(m->tri_start);
    lrr_aligned_free(m->rho);
    lrr_aligned_free(m->emission);
    memset(m, 0, sizeof *m);
}

lrr_status lrr_export_get_info(const lrr_operator *op, const float *radiosity,
                               const lrr_export_options *opts, const char *path,
                               lrr_export_info *info, size_t info_size)
{
    lrr__export_mesh m;
    lrr_status st = lrr__export_mesh_build(op, radiosity, opts, "export", path, &m);
    if (!st) {
        lrr_export_info in = {m.nv, m.nt, m.nm, m.exposure};
        lrr__info_write(info, info_size, &in, sizeof in);
    }
    lrr__export_mesh_free(&m);
    return st;
}
