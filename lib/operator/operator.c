/* The low-rank operator's life: its allocation (lrr_operator_build is in build.c: scene →
 * [adaptive hierarchy] → F̄ from hemicubes → SMW factorisation, smw.c), the accessors, and
 * the changes that refactor it (reflectance, storage). */
#include "config.h"
#include "operator/operator.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

void lrr_operator_destroy(lrr_operator *op)
{
    if (!op)
        return;
    lrr__geometry_free(&op->geom);
    lrr_aligned_free(op->rho);
    lrr_aligned_free(op->emission);
    lrr_aligned_free(op->area);
    lrr_aligned_free(op->weight);
    lrr_aligned_free(op->centre);
    lrr_aligned_free(op->normal);
    lrr_aligned_free(op->fbar);
    lrr_aligned_free(op->fbar16);
    lrr_aligned_free(op->row_scale);
    lrr_aligned_free(op->m);
    lrr__context_release(op->ctx);
    free(op);
}

lrr_status lrr__operator_new(lrr_context *ctx, const lrr__geometry *g, lrr_storage storage,
                             lrr_operator **out)
{
    return lrr__operator_alloc(ctx, g, storage, 1, out);
}

lrr_status lrr__operator_alloc(lrr_context *ctx, const lrr__geometry *g, lrr_storage storage,
                               int parts, lrr_operator **out)
{
    *out = NULL;
    lrr_operator *op = lrr__zalloc(ctx, sizeof *op);
    if (!op)
        return lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate an operator");
    op->ctx = lrr__context_retain(ctx);
    for (int w = 0; w < LRR_BACK_FACE_WORST; w++)
        op->worst_tri[w] = SIZE_MAX;
    lrr_status st;
    size_t kk;
    if ((st = lrr__geometry_copy(ctx, &op->geom, g)))
        goto fail;
    op->n = g->n;
    op->k = g->k;
    op->d = g->d;
    if (!lrr__mul_size(g->k, g->k, &kk)) {
        st = lrr__error(ctx, LRR_ERR_OVERFLOW, "k² overflows for k = %zu", g->k);
        goto fail;
    }
    if ((st = lrr__calloc(ctx, &op->rho, g->n, 3 * sizeof(float), "reflectances (n×3)")) ||
        (st = lrr__calloc(ctx, &op->emission, g->n, 3 * sizeof(float), "emission (n×3)")) ||
        (st = lrr__calloc(ctx, &op->area, g->n, sizeof(float), "subpatch areas")) ||
        (st = lrr__calloc(ctx, &op->weight, g->n, sizeof(float), "Vᵀ weights")) ||
        (st = lrr__calloc(ctx, &op->centre, g->n, 3 * sizeof(float), "subpatch centres")) ||
        (st = lrr__calloc(ctx, &op->normal, g->n, 3 * sizeof(float), "subpatch normals")) ||
        (!(parts & LRR__ALLOC_NO_M) &&
         (st = lrr__calloc(ctx, &op->m, kk, 3 * sizeof(float), "M (3×k×k floats)"))))
        goto fail;
    op->storage = storage;
    const int with_fbar = parts & LRR__ALLOC_FBAR;
    if (storage == LRR_STORAGE_F32)
        st = with_fbar ? lrr__calloc(ctx, &op->fbar, g->n, g->k * sizeof(float),
                                     "F̄ (n×k floats)")
                       : LRR_OK;
    else if (!with_fbar || !(st = lrr__calloc(ctx, &op->fbar16, g->n, g->k * sizeof(uint16_t),
                                              "F̄ (n×k 16-bit)")))
        st = lrr__calloc(ctx, &op->row_scale, g->n, sizeof(float), "F̄ row scales");
    if (st)
        goto fail;
    lrr__subpatch_frames(&op->geom, op->centre, op->normal, op->area);
    lrr__patch_weights(&op->geom, op->weight);
    *out = op;
    return LRR_OK;
fail:
    lrr_operator_destroy(op);
    return st;
}

lrr_status lrr__need_fbar(const lrr_operator *op, const char *what)
{
    if (lrr__fbar_data(op))
        return LRR_OK;
    return lrr__error(op->ctx, LRR_ERR_INVALID_ARG,
                      "%s: the operator holds no F̄ (loaded without it by lrr_operator_load_head, "
                      "or the root's of lrr_mpi_operator_build_save); load it with "
                      "lrr_operator_load to solve, change or save it", what);
}

lrr_status lrr_operator_set_storage(lrr_operator *op, lrr_storage storage)
{
    if (!lrr_storage_name(storage))
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "unknown storage %d", (int)storage);
    lrr_status st = lrr__need_fbar(op, "lrr_operator_set_storage");
    if (st || storage == op->storage)
        return st;
    memset(&op->verify, 0, sizeof op->verify); /* the error bar was for the other F̄ */
    const int panels = op->panels;
    st = lrr__fbar_convert(op, storage);
    /* M must invert I − Vᵀ R F̄ for the F̄ the kernels now read */
    if (!st)
        st = lrr__smw_factor(op);
    return st ? st : lrr__fbar_set_panels(op, panels);
}

lrr_status lrr_operator_set_reflectance(lrr_operator *op, const float *rho)
{
    lrr_status st = lrr__need_fbar(op, "lrr_operator_set_reflectance"); /* M needs F̄ */
    if (st)
        return st;
    for (size_t i = 0; i < 3 * op->n; i++)
        if (!(rho[i] >= 0.0f && rho[i] < 1.0f))
            return lrr__error(op->ctx, LRR_ERR_MATERIAL,
                              "reflectance of subpatch %zu, channel %zu = %g is outside [0,1)",
                              i / 3, i % 3, (double)rho[i]);
    float *old;
    st = lrr__calloc(op->ctx, &old, op->n, 3 * sizeof(float), "reflectance backup");
    if (st)
        return st;
    memcpy(old, op->rho, op->n * 3 * sizeof(float));
    memcpy(op->rho, rho, op->n * 3 * sizeof(float));
    double cond[3];
    memcpy(cond, op->cond, sizeof cond);
    if (!(st = lrr__smw_factor(op)))
        memset(&op->verify, 0, sizeof op->verify); /* the error bar was for the other ρ */
    else {
        /* keep the operator usable: restore the old reflectances and M */
        memcpy(op->rho, old, op->n * 3 * sizeof(float));
        lrr__smw_factor(op);
    }
    lrr_aligned_free(old);
    return st;
}

void lrr_operator_get_info(const lrr_operator *op, lrr_operator_info *out, size_t out_size)
{
    lrr_operator_info all, *info = &all;
    memset(info, 0, sizeof *info);
    info->n = op->n;
    info->k = op->k;
    info->d = op->d;
    info->d_min = SIZE_MAX;
    for (size_t p = 0; p < op->k; p++) {
        size_t dp = lrr__patch_size(&op->geom, p);
        info->d_min = dp < info->d_min ? dp : info->d_min;
        info->d_max = dp > info->d_max ? dp : info->d_max;
    }
    if (op->k == 0)
        info->d_min = 0;
    info->selection_seconds = op->selection_seconds;
    info->formfactor_seconds = op->formfactor_seconds;
    info->smw_seconds = op->smw_seconds;
    info->layout = op->panels ? LRR_LAYOUT_PANELS : LRR_LAYOUT_ROWS;
    info->hierarchy = op->geom.origin ? LRR_HIERARCHY_CLUSTER : LRR_HIERARCHY_QUADTREE;
    info->triangles = op->geom.n_tri;
    memcpy(info->condition, op->cond, sizeof op->cond);
    info->build_seconds = op->build_seconds;
    info->hemicube_resolution = op->hemicube_resolution;
    info->seed = op->seed;
    info->no_rotation = op->no_rotation;
    info->formfactor_method = op->formfactor_method;
    info->receiver_sampling = op->receiver_sampling;
    info->verify_rel_l2 = op->verify.rel_l2;
    info->verify_noise = op->verify.noise;
    info->verify_subpatches = op->verify.subpatches;
    info->verify_samples = op->verify.samples;
    info->verify_seconds = op->verify.seconds;
    info->verify_uniform = op->verify.uniform;
    info->back_face_share = op->back_face_share;
    memcpy(info->worst_back_face_triangle, op->worst_tri, sizeof op->worst_tri);
    memcpy(info->worst_back_face_share, op->worst_share, sizeof op->worst_share);
    info->storage = op->storage;
    /* what is held: no F̄ after lrr_operator_load_head (its row scales stay) */
    info->bytes = (lrr__fbar_data(op) ? op->n * op->k * lrr__fbar_elem_bytes(op) : 0) +
                  (op->row_scale ? op->n * sizeof(float) : 0) +
                  3 * op->k * op->k * sizeof(float) + op->n * 14 * sizeof(float) +
                  (op->geom.origin ? 2 * op->n * sizeof(size_t) : 0);
    lrr__info_write(out, out_size, info, sizeof *info);
}

const float *lrr_operator_m(const lrr_operator *op) { return op->m; }
const float *lrr_operator_reflectance(const lrr_operator *op) { return op->rho; }
const float *lrr_operator_emission(const lrr_operator *op) { return op->emission; }
const float *lrr_operator_area(const lrr_operator *op) { return op->area; }
const float *lrr_operator_centre(const lrr_operator *op) { return op->centre; }
const float *lrr_operator_normal(const lrr_operator *op) { return op->normal; }
const size_t *lrr_operator_patch_offsets(const lrr_operator *op) { return op->geom.first; }

void lrr_operator_scene_order(const lrr_operator *op, const float *in, float *out)
{
    const size_t *origin = op->geom.origin;
    if (!origin) {
        memcpy(out, in, op->n * 3 * sizeof(float));
        return;
    }
    for (size_t i = 0; i < op->n; i++)
        for (int c = 0; c < 3; c++)
            out[3 * origin[i] + c] = in[3 * i + c];
}

const size_t *lrr_operator_subpatch_origin(const lrr_operator *op) { return op->geom.origin; }

void lrr_operator_subpatch_vertices(const lrr_operator *op, float *out)
{
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < op->n; i++) {
        double v[9];
        lrr__subpatch_vertices(&op->geom, i, v);
        for (int j = 0; j < 9; j++)
            out[9 * i + j] = (float)v[j];
    }
}
