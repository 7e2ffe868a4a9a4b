/* Reference solvers on the full form-factor matrix: (I − R F) B = E per colour channel,
 * R = diag(rho_c), F the n×n subpatch-to-subpatch matrix from the same hemicubes as F̄
 * (so F̄ = F V / d). These are what the low-rank operator's error is measured against.
 *
 * All three channels are iterated together (one pass over F serves r, g and b) and every
 * sum is accumulated in double. The residual that decides convergence is always the true
 * one, ||E − (I − R F) B||₂ / ||E||₂ per channel, recomputed from F before stopping.
 */
#include "config.h"
#include "formfactor/formfactor.h"

#include <lapacke.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_BUDGET ((size_t)4 << 30)
#define DEFAULT_TOL 1e-6
/* Jacobi and Gauss–Seidel contract by about max rho per sweep: 0.999 needs ~1.4e4 sweeps
 * for 1e-6. Southwell shoots one subpatch at a time, so its count scales with n. */
#define DEFAULT_SWEEPS 200000
#define DEFAULT_SHOTS_PER_SUBPATCH 100000

struct lrr_reference {
    lrr_context *ctx;
    size_t n;
    size_t budget;
    float *f;        /* n×n row-major: F_ij, the fraction leaving i that arrives at j */
    float *rho;      /* n×3 */
    float *emission; /* n×3 */
    float *area;     /* n */
};

size_t lrr_reference_bytes(size_t n)
{
    size_t nn, fb, per;
    if (!lrr__mul_size(n, n, &nn) || !lrr__mul_size(nn, sizeof(float), &fb) ||
        !lrr__mul_size(n, 7 * sizeof(float), &per) || fb > SIZE_MAX - per)
        return SIZE_MAX;
    return fb + per;
}

void lrr_reference_destroy(lrr_reference *ref)
{
    if (!ref)
        return;
    lrr_aligned_free(ref->f);
    lrr_aligned_free(ref->rho);
    lrr_aligned_free(ref->emission);
    lrr_aligned_free(ref->area);
    lrr__context_release(ref->ctx);
    free(ref);
}

lrr_status lrr_reference_build(const lrr_scene *scene, const lrr_build_options *opts,
                               size_t memory_budget, lrr_reference **out)
{
    *out = NULL;
    lrr_context *ctx = scene->ctx;
    lrr_build_options o;
    lrr_status st = lrr__build_options_resolve(scene, opts, &o);
    if (st)
        return st;
    const size_t n = scene->geom.n;
    size_t budget = memory_budget ? memory_budget : DEFAULT_BUDGET;
    size_t need = lrr_reference_bytes(n);
    if (need == SIZE_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "the full form-factor matrix for n = %zu subpatches overflows size_t", n);
    if (need > budget)
        return lrr__error(ctx, LRR_ERR_BUDGET,
                          "the full form-factor matrix for n = %zu subpatches needs %.1f MB "
                          "(n² floats), more than the memory budget of %.1f MB",
                          n, need / 1e6, budget / 1e6);
    lrr_reference *ref = lrr__zalloc(ctx, sizeof *ref);
    if (!ref)
        return lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate a reference");
    ref->ctx = lrr__context_retain(ctx);
    ref->n = n;
    ref->budget = budget;
    if ((st = lrr__calloc(ctx, &ref->f, n * n, sizeof(float), "full F (n×n floats)")) ||
        (st = lrr__calloc(ctx, &ref->rho, n, 3 * sizeof(float), "reflectances (n×3)")) ||
        (st = lrr__calloc(ctx, &ref->emission, n, 3 * sizeof(float), "emission (n×3)")) ||
        (st = lrr__calloc(ctx, &ref->area, n, sizeof(float), "subpatch areas")) ||
        (st = lrr_scene_subpatches(scene, NULL, NULL, ref->area, ref->rho, ref->emission)) ||
        (st = lrr__hemicube_rows(ctx, &scene->geom, &o, 1, ref->f))) {
        lrr_reference_destroy(ref);
        return st;
    }
    *out = ref;
    return LRR_OK;
}

size_t lrr_reference_size(const lrr_reference *ref) { return ref->n; }
const float *lrr_reference_f(const lrr_reference *ref) { return ref->f; }
const float *lrr_reference_reflectance(const lrr_reference *ref) { return ref->rho; }
const float *lrr_reference_emission(const lrr_reference *ref) { return ref->emission; }
const float *lrr_reference_area(const lrr_reference *ref) { return ref->area; }

static const char *const method_names[] = {"jacobi", "gauss-seidel", "southwell", "direct"};

const char *lrr_method_name(lrr_method m)
{
    if (m < LRR_METHOD_JACOBI || m > LRR_METHOD_DIRECT)
        return NULL;
    return method_names[m - LRR_METHOD_JACOBI];
}

lrr_status lrr_method_from_name(const char *name, lrr_method *out)
{
    for (int i = 0; i < 4; i++)
        if (strcmp(name, method_names[i]) == 0) {
            *out = (lrr_method)(LRR_METHOD_JACOBI + i);
            return LRR_OK;
        }
    return LRR_ERR_INVALID_ARG;
}

/* ------------------------------------------------------------------ helpers */

/* y_i = Σ_j F_ij x_j for the three channels (x, y n×3 doubles). */
static void f_times(const lrr_reference *ref, const double *x, double *y)
{
    const size_t n = ref->n;
    #pragma omp parallel for schedule(static) if (3 * n * n >= LRR__PARALLEL_MIN)
    for (size_t i = 0; i < n; i++) {
        const float *row = ref->f + i * n;
        double a0 = 0, a1 = 0, a2 = 0;
        for (size_t j = 0; j < n; j++) {
            double fij = row[j];
            a0 += fij * x[3 * j];
            a1 += fij * x[3 * j + 1];
            a2 += fij * x[3 * j + 2];
        }
        y[3 * i] = a0;
        y[3 * i + 1] = a1;
        y[3 * i + 2] = a2;
    }
}

/* r = E − (I − R F) B (all n×3); returns the largest per-channel ||r||₂ / ||E||₂ (the
 * absolute norm for a channel without emission). tmp is n×3 scratch. */
static double residual(const lrr_reference *ref, const double *E, const double *B, double *tmp,
                       double *r)
{
    const size_t n = ref->n;
    f_times(ref, B, tmp);
    double rr[3] = {0, 0, 0}, ee[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            double v = E[3 * i + c] - B[3 * i + c] + ref->rho[3 * i + c] * tmp[3 * i + c];
            if (r)
                r[3 * i + c] = v;
            rr[c] += v * v;
            ee[c] += E[3 * i + c] * E[3 * i + c];
        }
    double worst = 0;
    for (int c = 0; c < 3; c++)
        worst = fmax(worst, ee[c] > 0 ? sqrt(rr[c] / ee[c]) : sqrt(rr[c]));
    return worst;
}

/* Largest per-channel ||v||₂ / ||E||₂. */
static double rel_norm(size_t n, const double *v, const double *E)
{
    double vv[3] = {0, 0, 0}, ee[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            vv[c] += v[3 * i + c] * v[3 * i + c];
            ee[c] += E[3 * i + c] * E[3 * i + c];
        }
    double worst = 0;
    for (int c = 0; c < 3; c++)
        worst = fmax(worst, ee[c] > 0 ? sqrt(vv[c] / ee[c]) : sqrt(vv[c]));
    return worst;
}

/* ------------------------------------------------------------------ methods */

/* One sweep of an iterative method: updates B in place and writes the step B_new − B_old to
 * delta (n×3); scratch is n×3. */
typedef void (*sweep_fn)(const lrr_reference *ref, const double *E, double *B, double *delta,
                         double *scratch);

/* Jacobi: B ← E + R F B. */
static void jacobi_sweep(const lrr_reference *ref, const double *E, double *B, double *delta,
                         double *FB)
{
    f_times(ref, B, FB);
    for (size_t j = 0; j < 3 * ref->n; j++) {
        double nb = E[j] + ref->rho[j] * FB[j];
        delta[j] = nb - B[j];
        B[j] = nb;
    }
}

/* Gauss–Seidel: row by row, each new B_i used at once (sequential by nature). */
static void gauss_seidel_sweep(const lrr_reference *ref, const double *E, double *B,
                               double *delta, double *scratch)
{
    (void)scratch;
    const size_t n = ref->n;
    for (size_t i = 0; i < n; i++) {
        const float *row = ref->f + i * n;
        double a0 = 0, a1 = 0, a2 = 0;
        for (size_t j = 0; j < n; j++) {
            double fij = row[j];
            a0 += fij * B[3 * j];
            a1 += fij * B[3 * j + 1];
            a2 += fij * B[3 * j + 2];
        }
        const double a[3] = {a0, a1, a2};
        for (int c = 0; c < 3; c++) {
            double nb = E[3 * i + c] + ref->rho[3 * i + c] * a[c];
            delta[3 * i + c] = nb - B[3 * i + c];
            B[3 * i + c] = nb;
        }
    }
}

/* Sweeps from B = E until the step and then the true residual are below tol. The step of a
 * Jacobi sweep is the old iterate's residual, so the true residual (one more product with F)
 * only needs computing once the steps are small; for Gauss–Seidel the step bounds it too. */
static lrr_status iterate(const lrr_reference *ref, sweep_fn sweep, double tol, size_t max_it,
                          const double *E, double *B, double *work, size_t *iters, double *res)
{
    const size_t n = ref->n;
    double *delta = work, *tmp = work + 3 * n;
    memcpy(B, E, 3 * n * sizeof(double));
    for (size_t it = 1; it <= max_it; it++) {
        sweep(ref, E, B, delta, tmp);
        *iters = it;
        if (rel_norm(n, delta, E) <= tol && (*res = residual(ref, E, B, tmp, NULL)) <= tol)
            return LRR_OK;
    }
    *res = residual(ref, E, B, tmp, NULL);
    return *res <= tol ? LRR_OK : LRR_NOT_CONVERGED;
}

/* Southwell (progressive refinement by shooting): the residual r = E − (I − R F) B is the
 * unshot radiosity. Each shot picks the subpatch with the most unshot power A_i Σ_c r_ic,
 * adds r_i to B_i and distributes it: r_j += rho_j F_ji r_i (a column of F). r is kept up
 * to date in double and recomputed from scratch before stopping. */
static lrr_status southwell(const lrr_reference *ref, double tol, size_t max_shots,
                            const double *E, double *B, double *work, size_t *shots,
                            double *res)
{
    const size_t n = ref->n;
    double *r = work, *tmp = work + 3 * n;
    double ee[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++)
            ee[c] += E[3 * i + c] * E[3 * i + c];
    memset(B, 0, 3 * n * sizeof(double));
    memcpy(r, E, 3 * n * sizeof(double));
    size_t s = 0;
    for (;;) {
        double rr[3] = {0, 0, 0};
        for (size_t i = 0; i < n; i++)
            for (int c = 0; c < 3; c++)
                rr[c] += r[3 * i + c] * r[3 * i + c];
        for (;;) {
            double worst = 0;
            for (int c = 0; c < 3; c++)
                worst = fmax(worst, ee[c] > 0 ? sqrt(rr[c] / ee[c]) : sqrt(rr[c]));
            if (worst <= tol || s >= max_shots)
                break;
            size_t best = 0;
            double best_power = -1;
            for (size_t i = 0; i < n; i++) {
                double p = ref->area[i] * (fabs(r[3 * i]) + fabs(r[3 * i + 1]) +
                                           fabs(r[3 * i + 2]));
                if (p > best_power) {
                    best_power = p;
                    best = i;
                }
            }
            double shot[3];
            for (int c = 0; c < 3; c++) {
                shot[c] = r[3 * best + c];
                B[3 * best + c] += shot[c];
                r[3 * best + c] = 0;
            }
            rr[0] = rr[1] = rr[2] = 0;
            for (size_t j = 0; j < n; j++) {
                double fji = ref->f[j * n + best];
                for (int c = 0; c < 3; c++) {
                    double v = r[3 * j + c] + ref->rho[3 * j + c] * fji * shot[c];
                    r[3 * j + c] = v;
                    rr[c] += v * v;
                }
            }
            s++;
        }
        *shots = s;
        /* the running residual drifts by rounding: trust only a recomputed one */
        *res = residual(ref, E, B, tmp, r);
        if (*res <= tol)
            return LRR_OK;
        if (s >= max_shots)
            return LRR_NOT_CONVERGED;
    }
}

/* LU of A_c = I − R_c F in double (LAPACKE dgetrf/dgetrs); channels with identical
 * reflectances share one factorisation. */
static lrr_status direct(const lrr_reference *ref, const double *E, double *B, double *work,
                         double *res)
{
    const size_t n = ref->n;
    lrr_context *ctx = ref->ctx;
    if (n > (size_t)INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "n = %zu exceeds LAPACK's int range", n);
    size_t extra;
    if (!lrr__mul_size(n * n, sizeof(double), &extra) || extra > ref->budget ||
        lrr_reference_bytes(n) > ref->budget - extra)
        return lrr__error(ctx, LRR_ERR_BUDGET,
                          "the direct solve for n = %zu needs %.1f MB more (n² doubles) than "
                          "the matrix, beyond the memory budget of %.1f MB",
                          n, 8.0 * n * n / 1e6, ref->budget / 1e6);
    double *A, *x;
    lapack_int *ipiv;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &A, n * n, sizeof(double), "direct solve matrix (n² doubles)")))
        return st;
    if ((st = lrr__calloc(ctx, &ipiv, n, sizeof(lapack_int), "pivots"))) {
        lrr_aligned_free(A);
        return st;
    }
    x = work; /* n doubles */
    const lapack_int ni = (lapack_int)n;
    int factored = -1;
    for (int c = 0; c < 3 && !st; c++) {
        int same = factored >= 0;
        for (size_t i = 0; same && i < n; i++)
            same = ref->rho[3 * i + c] == ref->rho[3 * i + factored];
        if (!same) {
            #pragma omp parallel for schedule(static)
            for (size_t i = 0; i < n; i++)
                for (size_t j = 0; j < n; j++)
                    A[i * n + j] = (i == j) - (double)ref->rho[3 * i + c] * ref->f[i * n + j];
            lapack_int info = LAPACKE_dgetrf(LAPACK_ROW_MAJOR, ni, ni, A, ni, ipiv);
            if (info != 0) {
                st = lrr__error(ctx, LRR_ERR_SINGULAR,
                                "I − R F of channel %d is singular (dgetrf info %d)", c,
                                (int)info);
                break;
            }
            factored = c;
        }
        for (size_t i = 0; i < n; i++)
            x[i] = E[3 * i + c];
        lapack_int info = LAPACKE_dgetrs(LAPACK_ROW_MAJOR, 'N', ni, 1, A, ni, ipiv, x, 1);
        if (info != 0)
            st = lrr__error(ctx, LRR_ERR_SINGULAR, "dgetrs failed for channel %d (info %d)", c,
                            (int)info);
        for (size_t i = 0; i < n; i++)
            B[3 * i + c] = x[i];
    }
    lrr_aligned_free(A);
    lrr_aligned_free(ipiv);
    if (!st)
        *res = residual(ref, E, B, work, NULL);
    return st;
}

lrr_status lrr_reference_solve(const lrr_reference *ref, lrr_method method, double tol,
                               size_t max_iterations, const float *emission, float *radiosity,
                               lrr_reference_stats *stats, size_t stats_size)
{
    lrr_context *ctx = ref->ctx;
    const size_t n = ref->n;
    if (stats)
        memset(stats, 0, stats_size);
    if (!lrr_method_name(method))
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "unknown reference method %d", (int)method);
    if (!(tol == 0 || (tol >= 1e-13 && tol < 1)))
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "tolerance %g: must be 0 (default 1e-6) or in [1e-13, 1)", tol);
    if ((const void *)emission == (const void *)radiosity)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "emission and radiosity may not alias");
    for (size_t j = 0; j < 3 * n; j++)
        if (!(emission[j] >= 0.0f) || !isfinite(emission[j]))
            return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                              "emission of subpatch %zu, channel %zu = %g (must be finite and "
                              ">= 0)", j / 3, j % 3, (double)emission[j]);
    if (tol == 0)
        tol = DEFAULT_TOL;
    if (max_iterations == 0) {
        max_iterations = DEFAULT_SWEEPS;
        if (method == LRR_METHOD_SOUTHWELL)
            max_iterations = n > SIZE_MAX / DEFAULT_SHOTS_PER_SUBPATCH
                                 ? SIZE_MAX
                                 : n * DEFAULT_SHOTS_PER_SUBPATCH;
    }
    double *E, *B, *work;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &E, n, 3 * sizeof(double), "emission (n×3 doubles)")))
        return st;
    if ((st = lrr__calloc(ctx, &B, n, 3 * sizeof(double), "radiosity (n×3 doubles)"))) {
        lrr_aligned_free(E);
        return st;
    }
    if ((st = lrr__calloc(ctx, &work, n, 6 * sizeof(double), "solver scratch (n×6 doubles)"))) {
        lrr_aligned_free(E);
        lrr_aligned_free(B);
        return st;
    }
    for (size_t j = 0; j < 3 * n; j++)
        E[j] = emission[j];
    double t0 = lrr__now(), res = 0;
    size_t iters = 1;
    switch (method) {
    case LRR_METHOD_JACOBI:
        st = iterate(ref, jacobi_sweep, tol, max_iterations, E, B, work, &iters, &res);
        break;
    case LRR_METHOD_GAUSS_SEIDEL:
        st = iterate(ref, gauss_seidel_sweep, tol, max_iterations, E, B, work, &iters, &res);
        break;
    case LRR_METHOD_SOUTHWELL:
        st = southwell(ref, tol, max_iterations, E, B, work, &iters, &res);
        break;
    case LRR_METHOD_DIRECT:
        st = direct(ref, E, B, work, &res);
        break;
    }
    if (st == LRR_OK || st == LRR_NOT_CONVERGED) {
        for (size_t j = 0; j < 3 * n; j++)
            radiosity[j] = (float)B[j];
        if (stats) {
            lrr_reference_stats s = {iters, res, lrr__now() - t0};
            lrr__info_write(stats, stats_size, &s, sizeof s);
        }
        if (st == LRR_NOT_CONVERGED)
            lrr__error(ctx, LRR_NOT_CONVERGED,
                       "%s stopped after %zu %s with relative residual %.3g > %.3g",
                       lrr_method_name(method), iters,
                       method == LRR_METHOD_SOUTHWELL ? "shots" : "sweeps", res, tol);
    }
    lrr_aligned_free(E);
    lrr_aligned_free(B);
    lrr_aligned_free(work);
    return st;
}
