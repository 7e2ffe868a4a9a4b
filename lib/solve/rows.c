/* A block of F̄'s rows for a distributed frame (declared in rows.h, used by liblrr_mpi).
 *
 * A frame B_c = E_c + rho_c ∘ (F̄ (M_c (Vᵀ E_c))) splits at w = Vᵀ E: each rank holds the rows
 * of whole patches (rows are patch-major, so a patch's subpatches are consecutive rows and
 * its Vᵀ sum needs no other rank's E), computes its patches' entries of w, the ranks sum
 * their w (one allreduce of 3k floats: every entry is nonzero on one rank only, so the sum
 * is the serial w exactly), and each applies M and its rows of F̄. The second half is the
 * serial full path's own kernels (lrr__smw_apply, lrr__fbar_apply_frames or the sparse
 * strips) run over a sub-operator that holds only the block's rows: n = rows, k = all
 * patches, F̄ in panels (its panels start at the block's first row).
 *
 * The first half's sums are the serial solver's own (lrr__segment_sum), so w is its w bit
 * for bit; M is read as lrr_solver_create reads it (M − I in binary16 when F̄ is 16-bit,
 * lrr__m_f16, else the floats), so z is its z. */
#include "config.h"
#include "solve/rows.h"
#include "solve/solve.h"

#include <math.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

struct lrr__rows {
    lrr_operator *sub;         /* the block's rows as an operator: n = rows, all k, all M */
    const lrr__kernel *kernel; /* SIMD variant, as lrr_solver_create chooses */
    lrr__sparse *sparse;       /* F̄ as strips, or NULL: sub's dense panels */
    lrr__m_f16 *m16;           /* M − I in binary16 (F̄ 16-bit), or NULL: sub->m */
    size_t row0, rows, p0, p1;
    size_t *first;             /* p1 − p0 + 1: the block's patches' first rows, local */
    size_t fbar_bytes;         /* what a frame reads of F̄ */
    float *z;                  /* 3×k, channel-major: M_c w_c */
};

void lrr__rows_destroy(lrr__rows *r)
{
    if (!r)
        return;
    lrr__sparse_destroy(r->sparse);
    lrr__m_f16_destroy(r->m16);
    lrr_operator_destroy(r->sub); /* releases the context last */
    lrr_aligned_free(r->first);
    lrr_aligned_free(r->z);
    free(r);
}

/* s's F̄ (rows × k in op's storage, and row scales) from op's rows [row0, row0 + rows), or
 * the block *own of those rows (row-major, taken over: *own becomes NULL), then rewritten
 * into panels for the kernels. */
static lrr_status copy_fbar(const lrr_operator *op, lrr_operator *s, size_t row0, void **own)
{
    lrr_context *ctx = op->ctx;
    const size_t rows = s->n, k = s->k;
    lrr_status st = LRR_OK;
    void **dst = op->storage == LRR_STORAGE_F32 ? (void **)&s->fbar : (void **)&s->fbar16;
    if (own) {
        *dst = *own;
        *own = NULL;
    } else if (op->storage == LRR_STORAGE_F32) {
        st = lrr__calloc(ctx, &s->fbar, rows, k * sizeof(float), "row block F̄ (rows×k floats)");
    } else {
        st = lrr__calloc(ctx, &s->fbar16, rows, k * sizeof(uint16_t),
                         "row block F̄ (rows×k 16-bit)");
    }
    if (!st && op->storage != LRR_STORAGE_F32 &&
        !(st = lrr__calloc(ctx, &s->row_scale, rows, sizeof(float), "row block F̄ row scales")))
        memcpy(s->row_scale, op->row_scale + row0, rows * sizeof(float));
    if (st)
        return st;
    if (!own)
        lrr__fbar_copy_rows(op, row0, row0 + rows, *dst);
    s->panels = 0;
    return lrr__fbar_set_panels(s, 1);
}

/* r->sub: the rows of r's block of op (or of own, taken over), their per-row data and all
 * of M. Sizes fit: op holds arrays of n ≥ rows entries of each kind and M itself. */
static lrr_status sub_operator(const lrr_operator *op, lrr__rows *r, void **own)
{
    lrr_context *ctx = op->ctx;
    lrr_operator *s = lrr__zalloc(ctx, sizeof *s);
    if (!s)
        return lrr__error(ctx, LRR_ERR_NOMEM, "row block: cannot allocate its operator");
    s->ctx = lrr__context_retain(ctx);
    r->sub = s;
    s->n = r->rows;
    s->k = op->k;
    s->d = op->d;
    s->storage = op->storage;
    const size_t rows = r->rows, k = op->k, row0 = r->row0;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &s->rho, rows, 3 * sizeof(float), "row block rho (rows×3)")) ||
        (st = lrr__calloc(ctx, &s->emission, rows, 3 * sizeof(float),
                          "row block emission (rows×3)")) ||
        (st = lrr__calloc(ctx, &s->weight, rows, sizeof(float), "row block Vᵀ weights")) ||
        (st = lrr__calloc(ctx, &s->m, k * k, 3 * sizeof(float), "M (3×k×k floats)")))
        return st;
    memcpy(s->rho, op->rho + 3 * row0, rows * 3 * sizeof(float));
    memcpy(s->emission, op->emission + 3 * row0, rows * 3 * sizeof(float));
    memcpy(s->weight, op->weight + row0, rows * sizeof(float));
    memcpy(s->m, op->m, k * k * 3 * sizeof(float));
    return copy_fbar(op, s, row0, own);
}

static lrr_status rows_make(const lrr_operator *op, size_t p0, size_t p1, void **own,
                            lrr__rows **out);

lrr_status lrr__rows_create(const lrr_operator *op, size_t p0, size_t p1, lrr__rows **out)
{
    *out = NULL;
    lrr_status st = lrr__need_fbar(op, "a row block of F̄");
    return st ? st : rows_make(op, p0, p1, NULL, out);
}

lrr_status lrr__rows_load(lrr_context *ctx, const char *path, lrr__rows_pick_fn pick,
                          void *user, lrr__rows **out)
{
    *out = NULL;
    lrr_operator *op = NULL;
    lrr__fbar_block b;
    lrr_status st = lrr__operator_load_rows(ctx, path, pick, user, &op, &b);
    if (st)
        return st;
    st = rows_make(op, b.p0, b.p1, &b.fbar, out);
    lrr_aligned_free(b.fbar); /* NULL once taken over */
    lrr_operator_destroy(op);
    return st;
}

/* The block of patches [p0, p1) of op: its F̄ copied from op, or taken over from *own. */
static lrr_status rows_make(const lrr_operator *op, size_t p0, size_t p1, void **own,
                            lrr__rows **out)
{
    *out = NULL;
    lrr_context *ctx = op->ctx;
    if (p0 > p1 || p1 > op->k)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "row block: patches [%zu, %zu) are not within the operator's k = %zu",
                          p0, p1, op->k);
    lrr__cpu_choice simd;
    lrr_status st = lrr__cpu_choose(ctx, &simd);
    if (st)
        return st;
    lrr__rows *r = lrr__zalloc(ctx, sizeof *r);
    if (!r)
        return lrr__error(ctx, LRR_ERR_NOMEM, "row block: cannot allocate it");
    const size_t *first = op->geom.first;
    r->p0 = p0;
    r->p1 = p1;
    r->row0 = first[p0];
    r->rows = first[p1] - first[p0];
    r->kernel = lrr__kernel_select(&simd, op->k);
    if ((st = sub_operator(op, r, own)) ||
        (st = lrr__calloc(ctx, &r->first, p1 - p0 + 1, sizeof(size_t), "row block offsets")) ||
        (st = lrr__calloc(ctx, &r->z, op->k, 3 * sizeof(float), "row block z (3×k)")))
        goto fail;
    for (size_t p = p0; p <= p1; p++)
        r->first[p - p0] = first[p] - r->row0;
    /* M as a serial solver of op reads it in a full frame (lrr_solver_create's choice);
     * the floats are then needed no more */
    if (op->storage != LRR_STORAGE_F32) {
        if ((st = lrr__m_f16_create(r->sub, &r->m16)))
            goto fail;
        lrr_aligned_free(r->sub->m);
        r->sub->m = NULL;
    }
    r->fbar_bytes = r->rows * op->k * lrr__fbar_elem_bytes(op);
    if (r->rows > 0) {
        lrr__sparse_stats stats;
        if ((st = lrr__sparse_create(r->sub, LRR_FBAR_AUTO, &stats, &r->sparse)))
            goto fail;
        if (r->sparse)
            r->fbar_bytes = r->sparse->bytes;
    }
    *out = r;
    return LRR_OK;
fail:
    lrr__rows_destroy(r);
    return st;
}

lrr_context *lrr__rows_context(const lrr__rows *r) { return r->sub->ctx; }

void lrr__rows_range(const lrr__rows *r, size_t *row0, size_t *rows)
{
    *row0 = r->row0;
    *rows = r->rows;
}

const float *lrr__rows_emission(const lrr__rows *r) { return r->rows ? r->sub->emission : NULL; }

const char *lrr__rows_kernel(const lrr__rows *r) { return r->kernel->name; }

void lrr__rows_bytes(const lrr__rows *r, size_t *fbar_bytes, size_t *m_bytes)
{
    *fbar_bytes = r->fbar_bytes;
    *m_bytes = r->m16 ? lrr__m_f16_bytes(r->sub->k) : 3 * r->sub->k * r->sub->k * sizeof(float);
}

lrr_status lrr__rows_vte(lrr__rows *r, const float *E, float *w)
{
    const lrr_operator *s = r->sub;
    const size_t k = s->k, np = r->p1 - r->p0;
    memset(w, 0, 3 * k * sizeof(float));
    size_t bad = SIZE_MAX;
    #pragma omp parallel for schedule(static) reduction(min : bad) \
        if (3 * s->n >= LRR__PARALLEL_MIN / 8)
    for (size_t lp = 0; lp < np; lp++) {
        const size_t i0 = r->first[lp], i1 = r->first[lp + 1];
        double acc[3];
        if (!lrr__segment_sum(s->weight, E, i0, i1, acc)) {
            /* a sign bit or a non-finite sum: scan for the bad entry (-0 passes), as
             * lrr_solve does, and sum as it does then */
            acc[0] = acc[1] = acc[2] = 0;
            for (size_t i = i0; i < i1; i++)
                for (int c = 0; c < 3; c++) {
                    const float e = E[3 * i + c], v = s->weight[i];
                    if (!(e >= 0.0f) || !isfinite(e))
                        bad = bad < 3 * i + c ? bad : 3 * i + c;
                    acc[c] += v * e;
                }
        }
        for (int c = 0; c < 3; c++)
            w[c * k + r->p0 + lp] = (float)acc[c];
    }
    if (bad != SIZE_MAX)
        return lrr__error(s->ctx, LRR_ERR_INVALID_ARG,
                          "emission of subpatch %zu, channel %zu = %g (must be finite and >= 0)",
                          r->row0 + bad / 3, bad % 3, (double)E[bad]);
    return LRR_OK;
}

void lrr__rows_apply(lrr__rows *r, const float *w, const float *E, float *B)
{
    const lrr_operator *s = r->sub;
    if (r->rows == 0)
        return;
    if (r->m16)
        lrr__smw_apply_f16(r->kernel, r->m16->val, r->m16->scale, s->k, w, r->z);
    else
        lrr__smw_apply(r->kernel, s->m, s->k, w, r->z);
    if (r->sparse)
        lrr__sparse_apply_frames(r->kernel, r->sparse, 1, r->z, E, s->rho, B);
    else
        lrr__fbar_apply_frames(r->kernel, s, 1, r->z, E, s->rho, B);
}

lrr_status lrr__rows_record(lrr_context *ctx, lrr_status status, const char *message)
{
    return lrr__error(ctx, status, "%s", message);
}

lrr_status lrr__rows_peek(lrr_context *ctx, char *msg, size_t len)
{
    pthread_mutex_lock(&ctx->lock);
    lrr_status st = ctx->first_status;
    snprintf(msg, len, "%s", st == LRR_OK ? "" : ctx->first_message);
    pthread_mutex_unlock(&ctx->lock);
    return st;
}

void lrr__rows_fail_after(lrr_context *ctx, unsigned long n) { lrr__context_fail_after(ctx, n); }
