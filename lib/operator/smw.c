/* The low-rank operator's factorisation: per colour channel c, the Sherman–Morrison–Woodbury
 * matrices of F̄ (docs/METHOD.md "Low-rank model" and "Condition")
 *
 *     G_c = I_k - Vᵀ diag(rho_c) F̄        G_pq = δ_pq - Σ_{i∈p} w_i rho_ic F̄_iq
 *
 * (w_i: Vᵀ's weights, 1 for quadtree patches, from areas and F̄'s row sums for clusters:
 * weights.c, docs/METHOD.md "Clusters"; recomputed here, since they follow the stored F̄)
 *     M_c = G_c^{-1}
 *
 * so that B_c = E_c + rho_c ∘ (F̄ · (M_c · (Vᵀ E_c))) solves (I - diag(rho_c) F̄ Vᵀ) B_c = E_c.
 * G_c is factorised in double (its condition grows like (1+rho)/(1-rho)) and M_c stored in
 * float; the 1-norm condition estimate (dgecon) is kept for the user. */
#include "config.h"
#include "operator/operator.h"

#include <lapacke.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>

void lrr__smw_g_add(const lrr_operator *op, int c, size_t i, const float *fi, double *gp)
{
    double r = (double)op->weight[i] * op->rho[3 * i + c];
    if (r == 0)
        return; /* black subpatches reflect nothing */
    for (size_t q = 0; q < op->k; q++)
        gp[q] -= r * fi[q];
}

/* M_c = G⁻¹ (G row-major k×k, overwritten) and cond[c], with the caller's LAPACK arrays. */
static lrr_status invert(lrr_operator *op, int c, double *G, lapack_int *ipiv, double *work,
                         lapack_int *iwork)
{
    const size_t k = op->k, kk = k * k;
    double anorm = LAPACKE_dlange_work(LAPACK_ROW_MAJOR, '1', (lapack_int)k, (lapack_int)k, G,
                                       (lapack_int)k, work);
    lapack_int info = LAPACKE_dgetrf(LAPACK_ROW_MAJOR, (lapack_int)k, (lapack_int)k, G,
                                     (lapack_int)k, ipiv);
    if (info > 0)
        return lrr__error(op->ctx, LRR_ERR_SINGULAR,
                          "channel %d: G = I - Vᵀ diag(rho) F̄ is singular (U[%d][%d] = 0)", c,
                          (int)info, (int)info);
    double rcond = 0;
    if (info == 0)
        info = LAPACKE_dgecon_work(LAPACK_ROW_MAJOR, '1', (lapack_int)k, G, (lapack_int)k,
                                   anorm, &rcond, work, iwork);
    if (info == 0)
        info = LAPACKE_dgetri(LAPACK_ROW_MAJOR, (lapack_int)k, G, (lapack_int)k, ipiv);
    if (info != 0)
        return lrr__error(op->ctx, info < 0 ? LRR_ERR_INVALID_ARG : LRR_ERR_SINGULAR,
                          "channel %d: LAPACK failed (info = %d)", c, (int)info);
    op->cond[c] = rcond > 0 ? 1.0 / rcond : INFINITY;
    float *mc = op->m + (size_t)c * kk;
    for (size_t j = 0; j < kk; j++) {
        if (!isfinite(G[j]))
            return lrr__error(op->ctx, LRR_ERR_SINGULAR,
                              "channel %d: M has a non-finite entry at (%zu, %zu)", c, j / k,
                              j % k);
        mc[j] = (float)G[j];
    }
    return LRR_OK;
}

static void free_lapack(lapack_int *ipiv, double *work, lapack_int *iwork)
{
    lrr_aligned_free(ipiv);
    lrr_aligned_free(work);
    lrr_aligned_free(iwork);
}

/* The pivots and work arrays of invert; freed by free_lapack. */
static lrr_status alloc_lapack(lrr_operator *op, lapack_int **ipiv, double **work,
                               lapack_int **iwork)
{
    const size_t k = op->k;
    *ipiv = NULL;
    *work = NULL;
    *iwork = NULL;
    /* dlange's and dgecon's work arrays are ours, aligned: the LAPACKE wrappers would
     * malloc them wherever the heap has room, and OpenBLAS's kernels sum in an order that
     * follows alignment, so the condition estimates of two processes (the serial build and
     * the distributed one's root) differed in their last bits (bunny room, k = 2000) */
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, ipiv, k, sizeof(lapack_int), "pivots")) ||
        (st = lrr__calloc(op->ctx, work, 4 * k, sizeof(double), "dgecon's work")) ||
        (st = lrr__calloc(op->ctx, iwork, k, sizeof(lapack_int), "dgecon's work"))) {
        free_lapack(*ipiv, *work, *iwork);
        *ipiv = *iwork = NULL;
        *work = NULL;
    }
    return st;
}


lrr_status lrr__smw_invert(lrr_operator *op, int c, double *G)
{
    if (op->k > (size_t)INT32_MAX)
        return lrr__error(op->ctx, LRR_ERR_OVERFLOW, "k = %zu exceeds LAPACK's int range",
                          op->k);
    lapack_int *ipiv, *iwork;
    double *work;
    lrr_status st = alloc_lapack(op, &ipiv, &work, &iwork);
    if (!st)
        st = invert(op, c, G, ipiv, work, iwork);
    op->m_epoch++;
    free_lapack(ipiv, work, iwork);
    return st;
}

lrr_status lrr__smw_factor(lrr_operator *op)
{
    const size_t k = op->k, *first = op->geom.first;
    double *G, *work = NULL;
    lapack_int *ipiv, *iwork = NULL;
    lrr_status st;
    size_t kk = k * k; /* checked in lrr__operator_new */
    if (k > (size_t)INT32_MAX)
        return lrr__error(op->ctx, LRR_ERR_OVERFLOW, "k = %zu exceeds LAPACK's int range", k);
    if ((st = lrr__visibility_weights(op)))
        return st;
    if ((st = lrr__calloc(op->ctx, &G, kk, sizeof(double), "G (k×k doubles)")))
        return st;
    if ((st = alloc_lapack(op, &ipiv, &work, &iwork))) {
        lrr_aligned_free(G);
        return st;
    }
    /* with 16-bit storage or panels, rows are decoded into one scratch row per thread */
    float *rowbuf = NULL;
    int threads = omp_get_max_threads();
    const int rows = op->storage == LRR_STORAGE_F32 && !op->panels; /* read in place */
    if (!rows &&
        (st = lrr__calloc(op->ctx, &rowbuf, (size_t)threads, k * sizeof(float),
                          "decoded F̄ rows"))) {
        lrr_aligned_free(G);
        free_lapack(ipiv, work, iwork);
        return st;
    }
    for (int c = 0; c < 3 && !st; c++) {
        /* G_pq = δ_pq - Σ_{i∈p} rho_ic F̄_iq: rows of G are independent segmented sums */
        #pragma omp parallel for schedule(static) num_threads(threads)
        for (size_t p = 0; p < k; p++) {
            double *gp = G + p * k;
            float *scratch = rowbuf ? rowbuf + (size_t)omp_get_thread_num() * k : NULL;
            for (size_t q = 0; q < k; q++)
                gp[q] = 0;
            for (size_t i = first[p]; i < first[p + 1]; i++) {
                if (op->weight[i] == 0 || op->rho[3 * i + c] == 0)
                    continue; /* reflects nothing: no row to decode */
                if (!rows)
                    lrr_operator_fbar_row(op, i, scratch);
                lrr__smw_g_add(op, c, i, rows ? op->fbar + i * k : scratch, gp);
            }
            gp[p] += 1;
        }
        st = invert(op, c, G, ipiv, work, iwork);
    }
    op->m_epoch++; /* M was written (in part, after an error) */
    lrr_aligned_free(G);
    free_lapack(ipiv, work, iwork);
    lrr_aligned_free(rowbuf);
    return st;
}
