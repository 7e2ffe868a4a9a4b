/* The real-time step on the CPU (DESIGN.md "Low-rank model"), per frame and channel c:
 *     w_c = Vᵀ E_c             O(n) segmented sum over each patch's d subpatches
 *     z_c = M_c w_c            k×k sgemv
 *     T   = F̄ [z_r z_g z_b]    one n×k×3 sgemm (F̄ read once for all channels)
 *     B_c = E_c + rho_c ∘ T_c
 */
#include "config.h"
#include "internal.h"

#include <cblas.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

struct lrr_solver {
    const lrr_operator *op;
    lrr_backend backend;
    float *w;   /* 3×k, channel-major */
    float *z;   /* k×3, row-major: the right-hand sides of the n×k×3 product */
    float *t;   /* n×3 */
};

void lrr_solver_destroy(lrr_solver *s)
{
    if (!s)
        return;
    lrr_aligned_free(s->w);
    lrr_aligned_free(s->z);
    lrr_aligned_free(s->t);
    free(s);
}

lrr_status lrr_solver_create(const lrr_operator *op, lrr_backend backend, lrr_solver **out)
{
    *out = NULL;
    if (backend == LRR_BACKEND_OPENCL)
        return lrr__error(op->ctx, LRR_ERR_UNSUPPORTED,
                          "the OpenCL backend is not built into this library");
    if (backend != LRR_BACKEND_CPU)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "unknown backend %d", (int)backend);
    if (op->k > (size_t)INT32_MAX || op->n > (size_t)INT32_MAX)
        return lrr__error(op->ctx, LRR_ERR_OVERFLOW, "n = %zu, k = %zu exceed BLAS int range",
                          op->n, op->k);
    lrr_solver *s = calloc(1, sizeof *s);
    if (!s)
        return lrr__error(op->ctx, LRR_ERR_NOMEM, "cannot allocate a solver");
    s->op = op;
    s->backend = backend;
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, &s->w, op->k, 3 * sizeof(float), "solver w (3×k)")) ||
        (st = lrr__calloc(op->ctx, &s->z, op->k, 3 * sizeof(float), "solver z (k×3)")) ||
        (st = lrr__calloc(op->ctx, &s->t, op->n, 3 * sizeof(float), "solver T (n×3)"))) {
        lrr_solver_destroy(s);
        return st;
    }
    *out = s;
    return LRR_OK;
}

lrr_status lrr_solve(lrr_solver *s, const float *E, float *B)
{
    const lrr_operator *op = s->op;
    const size_t n = op->n, k = op->k, d = op->d;
    if (E == B)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "emission and radiosity may not alias");
    /* w = Vᵀ E, validating E on the way (one pass) */
    size_t bad = SIZE_MAX;
    #pragma omp parallel for schedule(static) reduction(min : bad)
    for (size_t p = 0; p < k; p++) {
        double acc[3] = {0, 0, 0};
        for (size_t i = p * d; i < (p + 1) * d; i++)
            for (int c = 0; c < 3; c++) {
                float e = E[3 * i + c];
                if (!(e >= 0.0f) || !isfinite(e))
                    bad = bad < 3 * i + c ? bad : 3 * i + c;
                acc[c] += e;
            }
        for (int c = 0; c < 3; c++)
            s->w[c * k + p] = (float)acc[c];
    }
    if (bad != SIZE_MAX)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG,
                          "emission of subpatch %zu, channel %zu = %g (must be finite and >= 0)",
                          bad / 3, bad % 3, (double)E[bad]);
    const int ki = (int)k, ni = (int)n;
    for (int c = 0; c < 3; c++)
        /* z_c = M_c w_c, written with stride 3 into the k×3 right-hand side */
        cblas_sgemv(CblasRowMajor, CblasNoTrans, ki, ki, 1.0f, op->m + (size_t)c * k * k, ki,
                    s->w + (size_t)c * k, 1, 0.0f, s->z + c, 3);
    cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, ni, 3, ki, 1.0f, op->fbar, ki, s->z,
                3, 0.0f, s->t, 3);
    #pragma omp parallel for schedule(static)
    for (size_t j = 0; j < 3 * n; j++)
        B[j] = E[j] + op->rho[j] * s->t[j];
    return LRR_OK;
}
