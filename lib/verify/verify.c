/* The error bar of an operator (docs/METHOD.md "Verification"): the operator's radiosity for
 * the scene's emission against the path tracer on a sample of its own subpatches, compared
 * in regions so that neither side's per-subpatch noise passes for error.
 *
 *   1. N draws ∝ area (systematic sampling of the cumulative area, a random start) among the
 *      subpatches that reflect (ρ ≠ 0) and do not emit; a subpatch drawn m times is path
 *      traced with min(m, 16)·S paths (lib/reference/path_trace.c), and the operator's B
 *      comes from one solve for the same emission;
 *   2. regions: the cells of an 8×8×8 grid over the scene's box × the six axis directions
 *      nearest the normal (the judges of lrr-bench scenes use the same cells × materials);
 *      in region r, w_r the draws, d̄_r the draws' mean difference of the reflected light
 *      B − E, p̄_r the path tracer's mean, V̂_r an unbiased estimate of the variance of d̄_r
 *      (the draws' spread; where a region holds one subpatch, the spread pooled over the
 *      others relative to |p̄|²);
 *
 *      verify_rel_l2 = √(Σ_r w_r (|d̄_r|² − V̂_r) / Σ_r w_r |p̄_r|²)      (RGB vectors)
 *      verify_noise  = √(Σ_r w_r σ̄_r² / Σ_r w_r |p̄_r|²),   σ̄_r² the path tracer's
 *                                                             variance of p̄_r
 *
 *      |d̄_r|² − V̂_r is unbiased for the square of the mean difference over all of r, so
 *      neither a sparse draw nor the noise passes for error.
 * A scene that emits nothing is verified for E = 1 on every triangle (all subpatches then
 * take part). */
#include "config.h"
#include "operator/operator.h"
#include "reference/reference.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRID 8               /* cells per axis of the regions' grid */
#define DEFAULT_SAMPLES 1024 /* paths per drawn subpatch */
#define MAX_REPEAT 16        /* a subpatch drawn m times: min(m, MAX_REPEAT)·S paths */
/* The automatic count: the pilot's PILOT draws are traced and timed (the BVH built before),
 * then as many draws as a fifth of the build's time (lrr_operator_info.build_seconds)
 * allows at that speed, at least MIN_DRAWS: with fewer the regions hold one draw or none,
 * and the pooled spread stands in for most of them. */
#define PILOT 64
#define MIN_DRAWS 1000
#define BUILD_SHARE 0.2

static lrr_status read_options(lrr_context *ctx, const lrr_verify_options *opts,
                               lrr_verify_options *o)
{
    *o = lrr_verify_options_defaults();
    lrr_status st;
    if (opts && (st = lrr__options_read(ctx, opts, sizeof *o,
                                        LRR__FIRST_SIZE(lrr_verify_options, progress_user), o,
                                        "lrr_verify_options")))
        return st;
    if (o->samples == 0)
        o->samples = DEFAULT_SAMPLES;
    if (o->samples < 2)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "lrr_verify_options.samples = %zu: at "
                          "least 2 paths per subpatch are needed for a standard error",
                          o->samples);
    if (o->threads < 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "lrr_verify_options.threads = %d: must be >= 0", o->threads);
    return LRR_OK;
}

/* The scene is the one the operator was built from: same triangles, same subpatches. */
static lrr_status same_scene(const lrr_operator *op, const lrr_scene *scene)
{
    const lrr__geometry *sg = &scene->geom, *og = &op->geom;
    if (!sg->depth)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "lrr_operator_verify: the scene is not "
                          "subdivided: subdivide it as for the build");
    if (sg->n_tri != og->n_tri || sg->n != og->n ||
        memcmp(sg->vert, og->vert, sg->n_tri * 9 * sizeof(float)) != 0 ||
        memcmp(sg->depth, og->depth, sg->n_tri) != 0)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG,
                          "lrr_operator_verify: the scene (%zu triangles, %zu subpatches) is "
                          "not the one the operator was built from (%zu triangles, %zu "
                          "subpatches, or other vertices or subdivision)",
                          sg->n_tri, sg->n, og->n_tri, og->n);
    return LRR_OK;
}

/* The operator's index of the scene-order subpatch j. */
static size_t op_index(const lrr_operator *op, size_t j)
{
    return op->geom.order ? op->geom.order[j] : j;
}

/* 1 where scene-order subpatch j takes part: it reflects, and emits nothing unless the
 * emission is the uniform default. */
static int takes_part(const lrr_operator *op, int uniform, size_t j)
{
    const size_t i = op_index(op, j);
    const float *r = op->rho + 3 * i, *e = op->emission + 3 * i;
    return (r[0] > 0 || r[1] > 0 || r[2] > 0) && (uniform || !(e[0] > 0 || e[1] > 0 || e[2] > 0));
}

/* Draws `count` times a subpatch ∝ area among those that take part (systematic sampling from
 * a random start): the distinct ones into rows (scene order, ascending), how often each was
 * drawn into times; returns how many distinct (0: none takes part). */
static size_t draw(const lrr_operator *op, int uniform, uint64_t seed, size_t count,
                   size_t *rows, double *times)
{
    double total = 0;
    for (size_t j = 0; j < op->n; j++)
        if (takes_part(op, uniform, j))
            total += op->area[op_index(op, j)];
    if (!(total > 0))
        return 0;
    const double step = total / (double)count;
    double next = step * (double)(lrr__splitmix64(seed ^ 0x7665726966ULL) >> 11) * 0x1p-53;
    double run = 0;
    size_t got = 0, drawn = 0;
    for (size_t j = 0; j < op->n && drawn < count; j++) {
        if (!takes_part(op, uniform, j))
            continue;
        run += op->area[op_index(op, j)];
        size_t m = 0;
        for (; drawn < count && next < run; drawn++, m++)
            next += step;
        if (m) {
            rows[got] = j;
            times[got++] = (double)m;
        }
    }
    return got;
}

/* The grid's cells per axis for `draws` draws: about 8 draws a region (cells³ × 6 facings),
 * between 1 and GRID: a region needs two draws or more for its spread (compare). */

/* The region of operator subpatch i: grid cell × the axis direction nearest its normal. */
static size_t region_of(const lrr_operator *op, size_t i, const double lo[3],
                        const double span[3])
{
    size_t cell = 0;
    for (int a = 0; a < 3; a++) {
        double u = span[a] > 0 ? (op->centre[3 * i + a] - lo[a]) / span[a] : 0;
        long c = (long)floor(u * GRID);
        c = c < 0 ? 0 : c >= GRID ? GRID - 1 : c;
        cell = cell * GRID + (size_t)c;
    }
    const float *nv = op->normal + 3 * i;
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (fabsf(nv[a]) > fabsf(nv[axis]))
            axis = a;
    return cell * 6 + (size_t)(2 * axis + (nv[axis] < 0));
}

/* Per region: its distinct subpatches, w = Σ m, Σ m², Σ m d (RGB), Σ m |d|², Σ m p (RGB) and
 * Σ m² σ² (m a subpatch's draws, d = b − p, σ² the path tracer's variance summed over RGB). */
enum { R_N, R_W, R_M2, R_D, R_D2 = 6, R_P, R_VAR = 10, R_SIZE };

/* Σ_{r with two subpatches or more} of the spread S_r = Σ m |d − d̄|² and of
 * (w − Σm²/w) |p̄|²: their ratio is the pooled per-draw variance relative to |p̄|². */
static double pooled_spread(const double *acc, size_t regions)
{
    double num = 0, den = 0;
    for (size_t g = 0; g < regions; g++) {
        const double *r = acc + R_SIZE * g, w = r[R_W];
        if (r[R_N] < 2)
            continue;
        double d2 = 0, p2 = 0;
        for (int c = 0; c < 3; c++) {
            d2 += (r[R_D + c] / w) * (r[R_D + c] / w);
            p2 += (r[R_P + c] / w) * (r[R_P + c] / w);
        }
        num += r[R_D2] - w * d2;
        den += (w - r[R_M2] / w) * p2;
    }
    return den > 0 ? num / den : -1;
}

/* verify_rel_l2 and verify_noise (see the top) from the acc of the regions. */
static void figures(const double *acc, size_t regions, double *rel, double *noise)
{
    const double nu = pooled_spread(acc, regions);
    double num = 0, den = 0, var = 0;
    for (size_t g = 0; g < regions; g++) {
        const double *r = acc + R_SIZE * g, w = r[R_W];
        if (w == 0)
            continue;
        double d2 = 0, p2 = 0;
        for (int c = 0; c < 3; c++) {
            d2 += (r[R_D + c] / w) * (r[R_D + c] / w);
            p2 += (r[R_P + c] / w) * (r[R_P + c] / w);
        }
        const double noise_var = r[R_VAR] / (w * w), m2 = r[R_M2];
        const double v = r[R_N] >= 2 ? m2 / (w * w) * (r[R_D2] - w * d2) / (w - m2 / w)
                         : nu >= 0  ? nu * p2 * m2 / (w * w)
                                    : noise_var;
        num += w * (d2 - v);
        den += w * p2;
        var += w * noise_var;
    }
    *rel = den > 0 && num > 0 ? sqrt(num / den) : 0;
    *noise = den > 0 ? sqrt(var / den) : 0;
}

/* Accumulates the draws into regions and computes the figures: rows and times as draw gives
 * them, b the operator's reflected light, p the path tracer's, se its standard errors (each
 * count×3). */
static lrr_status compare(const lrr_operator *op, const size_t *rows, const double *times,
                          size_t count, const float *b, const float *p, const float *se,
                          double *rel, double *noise)
{
    const size_t regions = (size_t)GRID * GRID * GRID * 6;
    double *acc;
    lrr_status st = lrr__calloc(op->ctx, &acc, regions, R_SIZE * sizeof(double), "regions");
    if (st)
        return st;
    double lo[3], hi[3], span[3];
    lrr__geometry_bounds(&op->geom, lo, hi);
    for (int a = 0; a < 3; a++)
        span[a] = hi[a] - lo[a];
    for (size_t s = 0; s < count; s++) {
        double *r = acc + R_SIZE * region_of(op, op_index(op, rows[s]), lo, span);
        const double m = times[s];
        r[R_N] += 1;
        r[R_W] += m;
        r[R_M2] += m * m;
        for (int c = 0; c < 3; c++) {
            const double d = (double)b[3 * s + c] - p[3 * s + c];
            r[R_D + c] += m * d;
            r[R_D2] += m * d * d;
            r[R_P + c] += m * p[3 * s + c];
            r[R_VAR] += m * m * (double)se[3 * s + c] * se[3 * s + c];
        }
    }
    figures(acc, regions, rel, noise);
    lrr_aligned_free(acc);
    return LRR_OK;
}

/* The operator's B for emission E (n×3, its order), from one CPU solve. */
static lrr_status operator_radiosity(lrr_operator *op, const float *E, float *B)
{
    lrr_solver *solver;
    lrr_status st = lrr_solver_create(op, LRR_BACKEND_CPU, &solver);
    if (st)
        return st;
    st = lrr_solve(solver, E, B);
    lrr_solver_destroy(solver);
    return st;
}

/* The emissions verified: the scene's (E NULL for the path tracer), or where it emits
 * nothing E = 1 everywhere (*tri_e: n_tri×3 ones for the path tracer, *E: n×3). */
static lrr_status emissions(const lrr_operator *op, int *uniform, float **E, float **tri_e)
{
    *uniform = 1;
    *E = *tri_e = NULL;
    for (size_t i = 0; i < 3 * op->n && *uniform; i++)
        *uniform = !(op->emission[i] > 0);
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, E, op->n, 3 * sizeof(float), "verified emission")))
        return st;
    if (!*uniform) {
        memcpy(*E, op->emission, op->n * 3 * sizeof(float));
        return LRR_OK;
    }
    if ((st = lrr__calloc(op->ctx, tri_e, op->geom.n_tri, 3 * sizeof(float),
                          "verified emission")))
        return st;
    for (size_t i = 0; i < 3 * op->n; i++)
        (*E)[i] = 1.0f;
    for (size_t t = 0; t < 3 * op->geom.n_tri; t++)
        (*tri_e)[t] = 1.0f;
    return LRR_OK;
}

/* What one verification works with. */
typedef struct job {
    lrr_operator *op;
    const lrr__tracer *tracer;
    const lrr_verify_options *o;
    const float *E;        /* n×3, the operator's order */
    int uniform;
} job;

/* Path traces the draws (rows, times: got distinct), a subpatch drawn m times with
 * min(m, MAX_REPEAT)·S paths, one batch per path count, into p and se (got×3). */
static lrr_status trace(const job *jb, const size_t *rows, const double *times, size_t got,
                        int pilot, float *p, float *se)
{
    size_t *batch = NULL, *at = NULL;
    float *bp = NULL, *bse = NULL;
    lrr_status st;
    if ((st = lrr__calloc(jb->op->ctx, &batch, got, sizeof(size_t), "verify batch")) ||
        (st = lrr__calloc(jb->op->ctx, &at, got, sizeof(size_t), "verify batch")) ||
        (st = lrr__calloc(jb->op->ctx, &bp, got, 3 * sizeof(float), "verify batch")) ||
        (st = lrr__calloc(jb->op->ctx, &bse, got, 3 * sizeof(float), "verify batch")))
        goto out;
    for (size_t m = 1; m <= MAX_REPEAT && !st; m++) {
        size_t count = 0;
        for (size_t s = 0; s < got; s++)
            if ((times[s] >= MAX_REPEAT ? MAX_REPEAT : (size_t)times[s]) == m) {
                batch[count] = rows[s];
                at[count++] = s;
            }
        if (count == 0)
            continue;
        lrr_path_trace_options po = lrr_path_trace_options_defaults();
        po.samples = jb->o->samples * m;
        po.seed = jb->o->seed;
        po.threads = jb->o->threads;
        po.progress = pilot || m > 1 ? NULL : jb->o->progress; /* the bulk: once drawn */
        po.progress_user = jb->o->progress_user;
        if ((st = lrr__tracer_rows(jb->tracer, &po, batch, count, bp, bse)))
            break;
        for (size_t k = 0; k < count; k++)
            for (int c = 0; c < 3; c++) {
                p[3 * at[k] + c] = bp[3 * k + c];
                se[3 * at[k] + c] = bse[3 * k + c];
            }
    }
out:
    lrr_aligned_free(batch);
    lrr_aligned_free(at);
    lrr_aligned_free(bp);
    lrr_aligned_free(bse);
    return st;
}

/* Traces the draws and, unless it is the pilot, compares them with the operator's B (steps
 * 2 and 3 of the top); the figures go into op->verify. */
static lrr_status trace_and_compare(const job *jb, const float *B, const size_t *rows,
                                    const double *times, size_t got, int pilot)
{
    lrr_operator *op = jb->op;
    float *b = NULL, *p = NULL, *se = NULL;
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, &b, got, 3 * sizeof(float), "verified radiosity")) ||
        (st = lrr__calloc(op->ctx, &p, got, 3 * sizeof(float), "path-traced radiosity")) ||
        (st = lrr__calloc(op->ctx, &se, got, 3 * sizeof(float), "standard errors")) ||
        (st = trace(jb, rows, times, got, pilot, p, se)) || pilot)
        goto out;
    for (size_t s = 0; s < got; s++) {
        const size_t i = op_index(op, rows[s]);
        for (int c = 0; c < 3; c++) { /* reflected light: B − E on both sides */
            b[3 * s + c] = B[3 * i + c] - jb->E[3 * i + c];
            p[3 * s + c] -= jb->E[3 * i + c];
        }
    }
    st = compare(op, rows, times, got, b, p, se, &op->verify.rel_l2, &op->verify.noise);
out:
    lrr_aligned_free(b);
    lrr_aligned_free(p);
    lrr_aligned_free(se);
    return st;
}

/* Draws `count` subpatches (draw) into fresh rows and times; *got distinct. */
static lrr_status draw_new(const job *jb, size_t count, size_t **rows, double **times,
                           size_t *got)
{
    lrr_aligned_free(*rows);
    lrr_aligned_free(*times);
    *rows = NULL;
    *times = NULL;
    lrr_status st;
    if ((st = lrr__calloc(jb->op->ctx, rows, count, sizeof(size_t), "verified subpatches")) ||
        (st = lrr__calloc(jb->op->ctx, times, count, sizeof(double), "verified subpatches")))
        return st;
    *got = draw(jb->op, jb->uniform, jb->o->seed, count, *rows, *times);
    return *got ? LRR_OK
                : lrr__error(jb->op->ctx, LRR_ERR_INVALID_ARG, "lrr_operator_verify: no "
                             "subpatch that emits nothing reflects light (every reflectance "
                             "is 0)");
}

/* The automatic draw count (see PILOT): the pilot's draws are traced and timed. */
static lrr_status auto_count(const job *jb, size_t *count)
{
    size_t *rows = NULL, got = 0;
    double *times = NULL, seconds = 0;
    lrr_status st = draw_new(jb, PILOT, &rows, &times, &got);
    if (!st) {
        const double t0 = lrr__now();
        st = trace_and_compare(jb, NULL, rows, times, got, 1);
        seconds = lrr__now() - t0;
    }
    double drawn = 0;
    for (size_t s = 0; s < got; s++)
        drawn += times[s];
    lrr_aligned_free(rows);
    lrr_aligned_free(times);
    const double per_draw = seconds / (drawn > 0 ? drawn : 1);
    const double fit = per_draw > 0 ? BUILD_SHARE * jb->op->build_seconds / per_draw : 0;
    *count = fit > MIN_DRAWS ? (size_t)fit : MIN_DRAWS;
    return st;
}

/* The draws, their path tracing and the comparison, with the tracer built. */
static lrr_status run(const job *jb, size_t count, size_t *got)
{
    size_t *rows = NULL;
    double *times = NULL;
    float *B = NULL;
    lrr_status st;
    if ((!count && (st = auto_count(jb, &count))) ||
        (st = lrr__calloc(jb->op->ctx, &B, jb->op->n, 3 * sizeof(float),
                          "operator radiosity")) ||
        (st = operator_radiosity(jb->op, jb->E, B)) ||
        (st = draw_new(jb, count, &rows, &times, got)))
        goto out;
    st = trace_and_compare(jb, B, rows, times, *got, 0);
out:
    lrr_aligned_free(rows);
    lrr_aligned_free(times);
    lrr_aligned_free(B);
    return st;
}

lrr_status lrr_operator_verify(lrr_operator *op, const lrr_scene *scene,
                               const lrr_verify_options *opts)
{
    lrr_verify_options o;
    lrr_status st;
    if ((st = read_options(op->ctx, opts, &o)) || (st = same_scene(op, scene)))
        return st;
    const double t0 = lrr__now();
    job jb = {op, NULL, &o, NULL, 0};
    float *E = NULL, *tri_e = NULL;
    lrr__tracer *tracer = NULL;
    size_t got = 0;
    if (!(st = emissions(op, &jb.uniform, &E, &tri_e)) &&
        !(st = lrr__tracer_create(scene, tri_e, &tracer))) {
        jb.E = E;
        jb.tracer = tracer;
        st = run(&jb, o.subpatches, &got);
    }
    if (!st) {
        op->verify.subpatches = got;
        op->verify.samples = o.samples;
        op->verify.uniform = jb.uniform;
        op->verify.seconds = lrr__now() - t0;
    }
    lrr__tracer_destroy(tracer);
    lrr_aligned_free(E);
    lrr_aligned_free(tri_e);
    return st;
}
