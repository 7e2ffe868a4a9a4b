/* The value checks of a loaded operator (load.c, strips.c): each names the section and the
 * entry at fault, LRR_ERR_CORRUPT. A non-finite or out-of-range F̄ or M would turn every
 * solve into silent NaN or overflow. */
#include "config.h"
#include "file/format.h"

#include <math.h>

/* RHO and EMISSION in range. */
lrr_status lrr__check_materials(struct reader *r, const lrr_operator *op)
{
    size_t n3 = op->n * 3;
    for (size_t i = 0; i < n3; i++) {
        float v = op->rho[i];
        if (!(v >= 0.0f && v < 1.0f))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section RHO: subpatch %zu channel %zu has reflectance "
                              "%g outside [0,1)",
                              r->path, i / 3, i % 3, (double)v);
        float e = op->emission[i];
        if (!(e >= 0.0f) || isinf(e))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section EMISSION: subpatch %zu channel %zu has emission "
                              "%g (must be finite and >= 0)",
                              r->path, i / 3, i % 3, (double)e);
    }
    return LRR_OK;
}

bool lrr__fbar_entry_ok(lrr_storage storage, uint32_t raw, float scale, float *value,
                        bool *finite)
{
    if (storage == LRR_STORAGE_F32) {
        memcpy(value, &raw, sizeof *value);
        *finite = isfinite(*value);
    } else {
        /* binary16 and bfloat16 mark Inf/NaN by an all-ones exponent */
        const uint16_t expmask = storage == LRR_STORAGE_F16 ? 0x7c00u : 0x7f80u;
        *finite = (raw & expmask) != expmask;
        *value = scale * (storage == LRR_STORAGE_F16 ? lrr__f16_to_f32((uint16_t)raw)
                                                     : lrr__bf16_to_f32((uint16_t)raw));
    }
    return *finite && *value >= 0.0f && *value <= FBAR_MAX;
}

/* ROWSCALE: positive powers of two (1 for bfloat16). */
lrr_status lrr__check_row_scales(struct reader *r, const lrr_operator *op)
{
    for (size_t i = 0; op->row_scale && i < op->n; i++) {
        int e;
        if (!(op->row_scale[i] > 0) || !isfinite(op->row_scale[i]) ||
            frexpf(op->row_scale[i], &e) != 0.5f)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section ROWSCALE: row %zu has scale %g (must be a "
                              "positive power of two)",
                              r->path, i, (double)op->row_scale[i]);
        /* bfloat16 has float's range and is stored unscaled (storage.c). The kernels fold
         * the scale in after the dot product, so huge stored values under a tiny scale
         * would overflow there although the decoded F̄ is small. */
        if (op->storage == LRR_STORAGE_BF16 && op->row_scale[i] != 1.0f)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section ROWSCALE: row %zu has scale %g (bfloat16 rows "
                              "are stored unscaled: 1)",
                              r->path, i, (double)op->row_scale[i]);
    }
    return LRR_OK;
}

/* FBAR held dense (rows): finite, then each in [0, FBAR_MAX] (lrr__fbar_entry_ok's tests,
 * all entries' finiteness first); then the row scales those values needed. */
lrr_status lrr__check_fbar(struct reader *r, const lrr_operator *op)
{
    /* A non-finite F̄ or M would turn every solve into silent NaN. */
    size_t nk = op->n * op->k;
    /* binary16 and bfloat16 mark Inf/NaN by an all-ones exponent */
    const uint16_t expmask = op->storage == LRR_STORAGE_F16 ? 0x7c00u : 0x7f80u;
    for (size_t i = 0; i < nk; i++)
        if (op->fbar ? !isfinite(op->fbar[i]) : (op->fbar16[i] & expmask) == expmask)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section FBAR: entry (%zu, %zu) is not finite", r->path,
                              i / op->k, i % op->k);
    lrr_status st = lrr__check_row_scales(r, op);
    if (st)
        return st;
    /* F̄ holds form factors divided by d: each in [0, 1] (FBAR_MAX allows for the rounding
     * of 16-bit storage). Anything else is corruption, and could make a solve overflow. */
    float *row = NULL;
    st = lrr__calloc(r->ctx, &row, op->k, sizeof(float), "F̄ row");
    if (st)
        return st;
    for (size_t i = 0; i < op->n && st == LRR_OK; i++) {
        lrr_operator_fbar_row(op, i, row);
        for (size_t j = 0; j < op->k; j++)
            if (!(row[j] >= 0.0f && row[j] <= FBAR_MAX)) {
                st = lrr__error(r->ctx, LRR_ERR_CORRUPT,
                                "file %s: section FBAR: entry (%zu, %zu) is %g (form factors "
                                "divided by d lie in [0, 1])",
                                r->path, i, j, (double)row[j]);
                break;
            }
    }
    lrr_aligned_free(row);
    return st;
}

/* M finite. */
lrr_status lrr__check_m(struct reader *r, const lrr_operator *op)
{
    size_t kk = op->k * op->k;
    for (size_t i = 0; i < 3 * kk; i++)
        if (!isfinite(op->m[i]))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section M: channel %zu entry (%zu, %zu) is not finite",
                              r->path, i / kk, i % kk / op->k, i % op->k);
    return LRR_OK;
}
