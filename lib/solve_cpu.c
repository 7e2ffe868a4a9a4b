/* The real-time step on the CPU (DESIGN.md "Low-rank model"), per frame and channel c:
 *     w_c = Vᵀ E_c             O(n) segmented sum over each patch's d subpatches
 *     z_c = M_c w_c            k×k products, all channels in one pass
 *     B_c = E_c + rho_c ∘ (F̄ z_c)   F̄ read once for all channels, epilogue fused
 * The products live in realtime_kernel.c (why not BLAS: see there).
 */
#include "config.h"
#include "internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct lrr_solver {
    const lrr_operator *op;
    lrr_backend backend;
    float *w;   /* 3×k, channel-major */
    float *z;   /* 3×k, channel-major: the right-hand sides of the n×k product */
    const lrr__kernel *kernel; /* SIMD variant, chosen once (environment LRR_SIMD forces one) */
};

void lrr_solver_destroy(lrr_solver *s)
{
    if (!s)
        return;
    lrr_aligned_free(s->w);
    lrr_aligned_free(s->z);
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
    const lrr__kernel *kernel;
    lrr_status st = lrr__kernel_select(op->ctx, getenv("LRR_SIMD"), &kernel);
    if (st)
        return st;
    lrr_solver *s = calloc(1, sizeof *s);
    if (!s)
        return lrr__error(op->ctx, LRR_ERR_NOMEM, "cannot allocate a solver");
    s->op = op;
    s->kernel = kernel;
    s->backend = backend;
    if ((st = lrr__calloc(op->ctx, &s->w, op->k, 3 * sizeof(float), "solver w (3×k)")) ||
        (st = lrr__calloc(op->ctx, &s->z, op->k, 3 * sizeof(float), "solver z (3×k)"))) {
        lrr_solver_destroy(s);
        return st;
    }
    *out = s;
    return LRR_OK;
}

lrr_status lrr_solve(lrr_solver *s, const float *E, float *B)
{
    const lrr_operator *op = s->op;
    const size_t k = op->k, d = op->d;
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
    lrr__smw_apply(s->kernel, op->m, k, s->w, s->z);
    lrr__fbar_apply(s->kernel, op, s->z, E, B);
    return LRR_OK;
}

const char *lrr_solver_kernel(const lrr_solver *s)
{
    return s->kernel->name;
}
