/* lrr_operator_build in three stages (build.h): begin (options, memory budget, hierarchy),
 * rows (hemicubes over a block of receivers), finish (weights, SMW, panels, leak
 * indicator). The serial build runs rows once over every receiver; liblrr_mpi's
 * distributed build runs the same stages across ranks (lib/mpi/build.c). */
#include "config.h"
#include "formfactor/formfactor.h"
#include "hierarchy/hierarchy.h"
#include "operator/build.h"
#include "operator/operator.h"

#include <stdlib.h>
#include <string.h>

struct lrr__build {
    lrr_context *ctx;
    const lrr_scene *scene;
    lrr_build_options o;  /* defaults filled in */
    lrr__geometry own;    /* an adaptive or cluster selection's hierarchy */
    const lrr__geometry *g; /* the hierarchy: the scene's, own, or the whole operator's */
    int cluster;          /* its patches are clusters (visibility weights) */
    lrr_operator *op;     /* whole builds: F̄ filled in place */
    double *back;         /* whole builds: n back-face shares */
    double t0, selection; /* lrr__now() at begin, the selection's seconds */
};

/* The leak indicator from the receivers' back-face shares: their mean, and the input
 * triangles whose subpatches (equal areas within a triangle) have the largest mean share. */
static void back_face_summary(lrr_operator *op, const double *back)
{
    const lrr__geometry *g = &op->geom;
    double sum = 0;
    for (size_t i = 0; i < g->n; i++)
        sum += back[i];
    op->back_face_share = g->n ? sum / (double)g->n : 0;
    for (size_t t = 0; t < g->n_tri; t++) {
        size_t i0 = g->sub0[t], i1 = g->sub0[t + 1];
        double s = 0;
        for (size_t j = i0; j < i1; j++)
            s += back[lrr__subpatch_id(g, j)];
        s = i1 > i0 ? s / (double)(i1 - i0) : 0;
        /* insertion into the sorted list; ties keep the lower triangle first */
        int w = LRR_BACK_FACE_WORST;
        while (w > 0 && s > op->worst_share[w - 1])
            w--;
        if (w == LRR_BACK_FACE_WORST)
            continue;
        for (int j = LRR_BACK_FACE_WORST - 1; j > w; j--) {
            op->worst_share[j] = op->worst_share[j - 1];
            op->worst_tri[j] = op->worst_tri[j - 1];
        }
        op->worst_share[w] = s;
        op->worst_tri[w] = t;
    }
}

/* The operator's reflectances and emission, in its subpatch order. */
static lrr_status scene_materials(const lrr_scene *scene, lrr_operator *op)
{
    const size_t *origin = op->geom.origin;
    if (!origin)
        return lrr_scene_subpatches(scene, NULL, NULL, NULL, op->rho, op->emission);
    float *rho, *emission;
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, &rho, op->n, 3 * sizeof(float), "subpatch reflectances")))
        return st;
    if ((st = lrr__calloc(op->ctx, &emission, op->n, 3 * sizeof(float), "subpatch emission")) ||
        (st = lrr_scene_subpatches(scene, NULL, NULL, NULL, rho, emission))) {
        lrr_aligned_free(rho);
        lrr_aligned_free(emission);
        return st;
    }
    for (size_t i = 0; i < op->n; i++)
        for (int c = 0; c < 3; c++) {
            op->rho[3 * i + c] = rho[3 * origin[i] + c];
            op->emission[3 * i + c] = emission[3 * origin[i] + c];
        }
    lrr_aligned_free(rho);
    lrr_aligned_free(emission);
    return LRR_OK;
}

/* The grouping of the scene's patches the options ask for: an adaptive quadtree selection
 * or clusters (both over the scene's patches as subpatches) into *hg, *cluster saying
 * which; nothing for the scene's own (uniform, *hg left empty). */
static lrr_status select_hierarchy(const lrr_scene *scene, const lrr_build_options *o,
                                   size_t fbar_rows, int with_m, lrr__geometry *hg,
                                   int *cluster)
{
    lrr_context *ctx = scene->ctx;
    memset(hg, 0, sizeof *hg);
    *cluster = o->adaptive_patches && o->hierarchy == LRR_HIERARCHY_CLUSTER;
    if (!o->adaptive_patches)
        return LRR_OK;
    const size_t n = scene->geom.n;
    float *rho = NULL, *emission = NULL, *area = NULL, *centre = NULL, *normal = NULL;
    lrr_status st;
    if (!(st = lrr__calloc(ctx, &rho, n, 3 * sizeof(float), "subpatch reflectances")) &&
        !(st = lrr__calloc(ctx, &emission, n, 3 * sizeof(float), "subpatch emission")) &&
        !(st = lrr__calloc(ctx, &area, n, sizeof(float), "subpatch areas")) &&
        (!*cluster ||
         (!(st = lrr__calloc(ctx, &centre, n, 3 * sizeof(float), "subpatch centres")) &&
          !(st = lrr__calloc(ctx, &normal, n, 3 * sizeof(float), "subpatch normals")))) &&
        !(st = lrr_scene_subpatches(scene, centre, normal, area, rho, emission)))
        st = *cluster ? lrr__cluster_select(ctx, &scene->geom, rho, emission, centre, normal,
                                            area, o, lrr__hemicube_sample_rows, hg)
                      : lrr__adaptive_select(ctx, &scene->geom, rho, emission, area, NULL, o,
                                             lrr__hemicube_sample_rows, hg, NULL);
    lrr_aligned_free(rho);
    lrr_aligned_free(emission);
    lrr_aligned_free(area);
    lrr_aligned_free(centre);
    lrr_aligned_free(normal);
    /* the normal rule may have made more clusters than asked: check the budget anew */
    if (!st)
        st = lrr__operator_budget_check_rows(ctx, hg->n_tri, hg->n, fbar_rows, hg->k,
                                             LRR_STORAGE_F32, with_m, o);
    if (st)
        lrr__geometry_free(hg);
    return st;
}

/* The whole build's operator over b->g (F̄ in floats, or none in storage; M unless parts
 * has LRR__ALLOC_NO_M: lrr__operator_alloc), with what the hemicubes do not give; b->g is
 * then the operator's copy (the selection's is freed). */
static lrr_status new_whole(lrr__build *b, int parts, lrr_storage storage)
{
    lrr_status st = lrr__operator_alloc(b->ctx, b->g, storage, parts, &b->op);
    if (st)
        return st;
    lrr_operator *op = b->op;
    lrr__geometry_free(&b->own);
    b->g = &op->geom;
    if (b->cluster)
        op->weighting = LRR__WEIGHTS_VISIBILITY;
    op->selection_seconds = b->selection;
    op->builtin = b->scene->builtin;
    op->hemicube_resolution = b->o.hemicube_resolution;
    op->seed = b->o.seed;
    op->no_rotation = b->o.no_rotation != 0;
    if ((st = lrr__formfactor_method(b->ctx, &op->geom, &b->o, &op->formfactor_method)))
        return st;
    op->receiver_sampling = lrr__receiver_sampling(&b->o, op->formfactor_method);
    if ((st = scene_materials(b->scene, op)))
        return st;
    return lrr__calloc(b->ctx, &b->back, op->n, sizeof(double), "back-face shares");
}

/* begin's kinds of build: rows only, whole (the operator with F̄), or the operator without
 * F̄ in a storage (rows held apart: lrr__build_begin_rows). */
enum { BUILD_ROWS, BUILD_WHOLE, BUILD_HEAD };

static lrr_status begin(const lrr_scene *scene, const lrr_build_options *opts, int kind,
                        lrr_storage storage, size_t fbar_rows, int with_m, lrr__build **out)
{
    *out = NULL;
    lrr_context *ctx = scene->ctx;
    lrr_build_options o;
    lrr_status st = lrr__build_options_resolve(scene, opts, &o);
    if (st)
        return st;
    /* memory budget and size overflow, before anything is allocated (budget.c); an
     * adaptive build has at most adaptive_patches patches over the scene's n */
    const lrr__geometry *sg = &scene->geom;
    size_t k_max = o.adaptive_patches ? (o.adaptive_patches < sg->n ? o.adaptive_patches : sg->n)
                                      : sg->k;
    if ((st = lrr__operator_budget_check_rows(ctx, sg->n_tri, sg->n, fbar_rows, k_max,
                                              LRR_STORAGE_F32, with_m, &o)))
        return st;
    lrr__build *b = lrr__zalloc(ctx, sizeof *b);
    if (!b)
        return lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate a build");
    b->ctx = ctx;
    b->scene = scene;
    b->o = o;
    b->t0 = lrr__now();
    if (!(st = select_hierarchy(scene, &b->o, fbar_rows, with_m, &b->own, &b->cluster))) {
        b->selection = lrr__now() - b->t0;
        b->g = o.adaptive_patches ? &b->own : &scene->geom;
        if (kind != BUILD_ROWS)
            st = new_whole(b, kind == BUILD_WHOLE ? LRR__ALLOC_FBAR
                                                  : with_m ? 0 : LRR__ALLOC_NO_M,
                           kind == BUILD_WHOLE ? LRR_STORAGE_F32 : storage);
        else /* the method is checked as a whole build checks it */
            st = lrr__formfactor_method(ctx, b->g, &b->o, &(int){0});
    }
    if (st) {
        lrr__build_destroy(b);
        return st;
    }
    *out = b;
    return LRR_OK;
}

lrr_status lrr__build_begin(const lrr_scene *scene, const lrr_build_options *opts, int whole,
                            lrr__build **out)
{
    return begin(scene, opts, whole ? BUILD_WHOLE : BUILD_ROWS, LRR_STORAGE_F32,
                 scene->geom.n, 1, out);
}

lrr_status lrr__build_begin_rows(const lrr_scene *scene, const lrr_build_options *opts,
                                 lrr_storage storage, size_t fbar_rows, int with_m,
                                 lrr__build **out)
{
    *out = NULL;
    if (!lrr_storage_name(storage))
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG, "unknown storage %d", (int)storage);
    return begin(scene, opts, BUILD_HEAD, storage,
                 fbar_rows < scene->geom.n ? fbar_rows : scene->geom.n, with_m, out);
}

void lrr__build_destroy(lrr__build *b)
{
    if (!b)
        return;
    lrr_operator_destroy(b->op);
    lrr_aligned_free(b->back);
    lrr__geometry_free(&b->own);
    free(b);
}

lrr_context *lrr__build_scene_context(const lrr_scene *scene) { return scene->ctx; }

void lrr__build_size(const lrr__build *b, size_t *n, size_t *k)
{
    *n = b->g->n;
    *k = b->g->k;
}

/* FNV-1a over bytes, continuing from h. */
static uint64_t fnv(uint64_t h, const void *data, size_t len)
{
    const unsigned char *p = data;
    for (size_t i = 0; i < len; i++)
        h = (h ^ p[i]) * 0x100000001b3ULL;
    return h;
}

uint64_t lrr__build_fingerprint(const lrr__build *b)
{
    const lrr__geometry *g = b->g;
    uint64_t h = fnv(0xcbf29ce484222325ULL, &g->n, sizeof g->n);
    h = fnv(h, &g->k, sizeof g->k);
    h = fnv(h, g->first, (g->k + 1) * sizeof *g->first);
    if (g->origin)
        h = fnv(h, g->origin, g->n * sizeof *g->origin);
    return fnv(h, g->vert, g->n_tri * 9 * sizeof *g->vert);
}

float *lrr__build_fbar(lrr__build *b) { return b->op ? b->op->fbar : NULL; }
double *lrr__build_back(lrr__build *b) { return b->back; }

lrr_status lrr__build_rows(lrr__build *b, const size_t *rows, size_t count, int placed,
                           float *fbar, double *back)
{
    if (!rows)
        return b->op ? lrr__hemicube_fbar(b->ctx, b->g, &b->o, b->op->fbar, b->back)
                     : lrr__error(b->ctx, LRR_ERR_INVALID_ARG, "every row of a build that is "
                                  "not whole");
    return lrr__hemicube_fbar_rows(b->ctx, b->g, &b->o, rows, count, placed, fbar, back);
}

lrr_status lrr__build_finish(lrr__build *b, double formfactor_seconds, lrr_operator **out)
{
    *out = NULL;
    lrr_operator *op = b->op;
    if (!op)
        return lrr__error(b->ctx, LRR_ERR_INVALID_ARG, "finish of a build that is not whole");
    op->formfactor_seconds = formfactor_seconds;
    double t1 = lrr__now();
    lrr_status st = lrr__smw_factor(op);
    op->smw_seconds = lrr__now() - t1;
    if (!st)
        st = lrr__fbar_set_panels(op, 1);
    if (st)
        return st;
    back_face_summary(op, b->back);
    op->build_seconds = lrr__now() - b->t0;
    b->op = NULL;
    *out = op;
    return LRR_OK;
}

lrr_status lrr_operator_build(const lrr_scene *scene, const lrr_build_options *opts,
                              lrr_operator **out)
{
    *out = NULL;
    lrr__build *b;
    lrr_status st = lrr__build_begin(scene, opts, 1, &b);
    if (st)
        return st;
    const double t1 = lrr__now();
    if (!(st = lrr__build_rows(b, NULL, 0, 0, NULL, NULL)))
        st = lrr__build_finish(b, lrr__now() - t1, out);
    lrr__build_destroy(b);
    return st;
}

/* ------------------------------------------------------------ rows held apart */
lrr_operator *lrr__build_operator(lrr__build *b) { return b->op; }

float *lrr__build_row_scales(lrr__build *b) { return b->op ? b->op->row_scale : NULL; }

/* Row i of F̄ as held apart (row in op's storage) decoded into scratch, as
 * lrr_operator_fbar_row decodes it; floats are read in place. */
static const float *decoded(const lrr_operator *op, size_t i, const void *row, float *scratch)
{
    if (op->storage == LRR_STORAGE_F32)
        return row;
    lrr__fbar_decode_row(op->storage, op->row_scale[i], row, op->k, scratch);
    return scratch;
}

void lrr__build_encode(lrr__build *b, const size_t *rows, size_t count, float *block,
                       float *scratch)
{
    lrr_operator *op = b->op;
    const size_t k = op->k;
    if (op->storage == LRR_STORAGE_F32)
        return;
    /* row j's codes go to element j·k of block as uint16_t, before row j's floats: every
     * row is read whole (into scratch) before its codes overwrite anything unread */
    unsigned char *bytes = (unsigned char *)block;
    for (size_t j = 0; j < count; j++) {
        memcpy(scratch, bytes + j * k * sizeof(float), k * sizeof(float));
        uint16_t *codes = (uint16_t *)(void *)(scratch + k);
        op->row_scale[rows[j]] = lrr__fbar_encode_row(op->storage, scratch, k, codes);
        memcpy(bytes + j * k * sizeof(uint16_t), codes, k * sizeof(uint16_t));
    }
}

int lrr__build_visibility(const lrr__build *b)
{
    return b->op && b->op->weighting == LRR__WEIGHTS_VISIBILITY;
}

void lrr__build_row_sums(lrr__build *b, const size_t *rows, size_t count, const void *block,
                         float *scratch, double *ar)
{
    const lrr_operator *op = b->op;
    const size_t rb = op->k * lrr__fbar_elem_bytes(op);
    for (size_t j = 0; j < count; j++)
        ar[j] = lrr__visibility_row_sum(
            op, rows[j], decoded(op, rows[j], (const unsigned char *)block + j * rb, scratch));
}

void lrr__build_set_weights(lrr__build *b, const double *ar)
{
    lrr__visibility_normalise(b->op, 0, b->op->k, ar);
}

void lrr__build_g_add(lrr__build *b, int c, size_t i, const void *row, float *scratch,
                      double *gp)
{
    const lrr_operator *op = b->op;
    if (op->weight[i] == 0 || op->rho[3 * i + c] == 0)
        return; /* reflects nothing: no row to decode */
    lrr__smw_g_add(op, c, i, decoded(op, i, row, scratch), gp);
}

lrr_status lrr__build_invert(lrr__build *b, int c, double *G)
{
    return lrr__smw_invert(b->op, c, G);
}

float *lrr__build_m(lrr__build *b, int c)
{
    return b->op->m ? b->op->m + (size_t)c * b->op->k * b->op->k : NULL;
}

void lrr__build_set_cond(lrr__build *b, int c, double cond)
{
    b->op->cond[c] = cond;
    b->op->m_epoch++; /* solvers' copies of M are stale (operator.h) */
}

lrr_status lrr__build_finish_rows(lrr__build *b, double formfactor_seconds, double smw_seconds,
                                  lrr_operator **out)
{
    lrr_operator *op = b->op;
    op->formfactor_seconds = formfactor_seconds;
    op->smw_seconds = smw_seconds;
    back_face_summary(op, b->back);
    op->build_seconds = lrr__now() - b->t0;
    b->op = NULL;
    *out = op;
    return LRR_OK;
}
