/* The error bar of an operator (docs/METHOD.md "Verification"): the operator's radiosity for
 * the scene's emission against the path tracer on a sample of its own subpatches, compared
 * in regions so that neither side's per-subpatch noise passes for error.
 *
 *   1. N receivers drawn with probability ∝ area (systematic sampling of the cumulative area,
 *      a random start), among the subpatches that reflect (ρ ≠ 0) and do not emit;
 *   2. each path traced with S paths (lib/reference/path_trace.c), the operator's B from one
 *      solve for the same emission;
 *   3. regions: cells of a g×g×g grid over the scene's box (g = ∛(N/48) between 1 and 8,
 *      about eight draws a region) × the six axis directions nearest the normal; per region
 *      the mean over its draws of the reflected light B − E of both sides, d̄_r their mean
 *      difference, s_r² its spread, and the draws' count w_r as its weight (draws ∝ area, so
 *      counts are area weights);
 *
 *      verify_rel_l2 = √(Σ_r w_r (|d̄_r|² − s_r²/w_r) / Σ_r w_r |p̄_r|²)   (RGB vectors)
 *      verify_noise  = √(Σ_r w_r σ̄_r² / Σ_r w_r |p̄_r|²),   σ̄_r² = Σ_{s∈r} σ_s² / w_r²
 *
 * The judges of bench/ (lrr-bench scenes) use the same regions with materials in place of
 * the axis directions, over every subpatch. A scene that emits nothing is verified for a
 * uniform emission E = 1 of every triangle (all subpatches then take part). */
#include "config.h"
#include "operator/operator.h"
#include "reference/reference.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define GRID 8               /* cells per axis of the regions' grid */
#define DEFAULT_SAMPLES 1024 /* paths per drawn subpatch */
/* The automatic count: a pilot of PILOT draws is timed, then as many draws as a fifth of the
 * build's time (lrr_operator_info.build_seconds) allows at that speed, at least MIN_DRAWS
 * (below ~1000 the regions are few and coarse: on the Cornell box, 216 patches of 16, 90
 * draws gave 0 ± 0.8%, 2000 and 3216 1.25% and 1.36%). */
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
static size_t grid_for(size_t draws)
{
    size_t g = (size_t)cbrt((double)draws / 48.0);
    return g < 1 ? 1 : g > GRID ? GRID : g;
}

/* The region of operator subpatch i: cell of a grid × grid × grid over the box × the axis
 * direction nearest its normal. */
static size_t region_of(const lrr_operator *op, size_t i, size_t grid, const double lo[3],
                        const double span[3])
{
    size_t cell = 0;
    for (int a = 0; a < 3; a++) {
        double u = span[a] > 0 ? (op->centre[3 * i + a] - lo[a]) / span[a] : 0;
        long c = (long)floor(u * (double)grid);
        c = c < 0 ? 0 : c >= (long)grid ? (long)grid - 1 : c;
        cell = cell * grid + (size_t)c;
    }
    const float *nv = op->normal + 3 * i;
    int axis = 0;
    for (int a = 1; a < 3; a++)
        if (fabsf(nv[a]) > fabsf(nv[axis]))
            axis = a;
    return cell * 6 + (size_t)(2 * axis + (nv[axis] < 0));
}

/* Per region: w = Σ m (m a draw's multiplicity), Σ m d, Σ m |d|², Σ m p, Σ m² σ² (d = b − p,
 * RGB); 11 doubles. */
enum { R_W, R_D, R_D2 = 4, R_P, R_VAR = 8, R_SIZE = 11 };

/* verify_rel_l2 and verify_noise (see the top) from the draws: rows and times as draw gives
 * them, b the operator's reflected light, p the path tracer's, se its standard errors (each
 * count×3). A region's mean difference d̄ over w draws estimates the mean over all its
 * subpatches up to the draws' spread: |d̄|² − s²/w (s² their sample variance, which holds the
 * path tracer's noise too) is unbiased for the squared mean difference, so neither a small
 * draw nor the noise passes for error; a region of one draw subtracts the path tracer's
 * variance only. */
static lrr_status compare(const lrr_operator *op, const size_t *rows, const double *times,
                          size_t count, const float *b, const float *p, const float *se,
                          double *rel, double *noise)
{
    size_t draws = 0;
    for (size_t s = 0; s < count; s++)
        draws += (size_t)times[s];
    const size_t grid = grid_for(draws), regions = grid * grid * grid * 6;
    double *acc;
    lrr_status st = lrr__calloc(op->ctx, &acc, regions, R_SIZE * sizeof(double), "regions");
    if (st)
        return st;
    double lo[3], hi[3], span[3];
    lrr__geometry_bounds(&op->geom, lo, hi);
    for (int a = 0; a < 3; a++)
        span[a] = hi[a] - lo[a];
    for (size_t s = 0; s < count; s++) {
        double *r = acc + R_SIZE * region_of(op, op_index(op, rows[s]), grid, lo, span);
        const double m = times[s];
        r[R_W] += m;
        for (int c = 0; c < 3; c++) {
            const double d = (double)b[3 * s + c] - p[3 * s + c];
            r[R_D + c] += m * d;
            r[R_D2] += m * d * d;
            r[R_P + c] += m * p[3 * s + c];
            r[R_VAR + c] += m * m * (double)se[3 * s + c] * se[3 * s + c];
        }
    }
    double num = 0, den = 0, var = 0;
    for (size_t g = 0; g < regions; g++) {
        const double *r = acc + R_SIZE * g, w = r[R_W];
        if (w == 0)
            continue;
        double d2 = 0, p2 = 0, v = 0;
        for (int c = 0; c < 3; c++) {
            d2 += (r[R_D + c] / w) * (r[R_D + c] / w);
            p2 += (r[R_P + c] / w) * (r[R_P + c] / w);
            v += r[R_VAR + c] / (w * w);
        }
        const double spread = w > 1 ? (r[R_D2] - w * d2) / (w - 1) / w : v;
        num += w * (d2 - spread);
        den += w * p2;
        var += w * v;
    }
    lrr_aligned_free(acc);
    *rel = den > 0 && num > 0 ? sqrt(num / den) : 0;
    *noise = den > 0 ? sqrt(var / den) : 0;
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
    if (!*uniform) {
        if ((st = lrr__calloc(op->ctx, E, op->n, 3 * sizeof(float), "verified emission")))
            return st;
        memcpy(*E, op->emission, op->n * 3 * sizeof(float));
        return LRR_OK;
    }
    if ((st = lrr__calloc(op->ctx, E, op->n, 3 * sizeof(float), "verified emission")) ||
        (st = lrr__calloc(op->ctx, tri_e, op->geom.n_tri, 3 * sizeof(float),
                          "verified emission")))
        return st;
    for (size_t i = 0; i < 3 * op->n; i++)
        (*E)[i] = 1.0f;
    for (size_t t = 0; t < 3 * op->geom.n_tri; t++)
        (*tri_e)[t] = 1.0f;
    return LRR_OK;
}

/* Path traces the draws and compares (steps 2 and 3 of the top). */
static lrr_status trace_and_compare(lrr_operator *op, const lrr_scene *scene,
                                    const lrr_verify_options *o, const float *E,
                                    const float *tri_e, const size_t *rows,
                                    const double *times, size_t got, int pilot)
{
    float *B = NULL, *b = NULL, *p = NULL, *se = NULL;
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, &B, op->n, 3 * sizeof(float), "operator radiosity")) ||
        (st = lrr__calloc(op->ctx, &b, got, 3 * sizeof(float), "verified radiosity")) ||
        (st = lrr__calloc(op->ctx, &p, got, 3 * sizeof(float), "path-traced radiosity")) ||
        (st = lrr__calloc(op->ctx, &se, got, 3 * sizeof(float), "standard errors")) ||
        (st = operator_radiosity(op, E, B)))
        goto out;
    lrr_path_trace_options po = lrr_path_trace_options_defaults();
    po.samples = o->samples;
    po.seed = o->seed;
    po.threads = o->threads;
    po.progress = pilot ? NULL : o->progress;
    po.progress_user = o->progress_user;
    if ((st = lrr__path_trace_rows(scene, &po, rows, got, tri_e, p, se)))
        goto out;
    for (size_t s = 0; s < got; s++) {
        const size_t i = op_index(op, rows[s]);
        for (int c = 0; c < 3; c++) { /* reflected light: B − E on both sides */
            b[3 * s + c] = B[3 * i + c] - E[3 * i + c];
            p[3 * s + c] -= E[3 * i + c];
        }
    }
    if (!pilot)
        st = compare(op, rows, times, got, b, p, se, &op->verify.rel_l2, &op->verify.noise);
out:
    lrr_aligned_free(B);
    lrr_aligned_free(b);
    lrr_aligned_free(p);
    lrr_aligned_free(se);
    return st;
}

/* Draws `count` subpatches (draw) into fresh rows and times; *got distinct. */
static lrr_status draw_new(lrr_operator *op, int uniform, uint64_t seed, size_t count,
                           size_t **rows, double **times, size_t *got)
{
    lrr_aligned_free(*rows);
    lrr_aligned_free(*times);
    *rows = NULL;
    *times = NULL;
    lrr_status st;
    if ((st = lrr__calloc(op->ctx, rows, count, sizeof(size_t), "verified subpatches")) ||
        (st = lrr__calloc(op->ctx, times, count, sizeof(double), "verified subpatches")))
        return st;
    *got = draw(op, uniform, seed, count, *rows, *times);
    return *got ? LRR_OK
                : lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "lrr_operator_verify: no subpatch "
                             "that emits nothing reflects light (every reflectance is 0)");
}

/* The automatic draw count (see PILOT): the pilot's draws are traced and timed. */
static lrr_status auto_count(lrr_operator *op, const lrr_scene *scene,
                             const lrr_verify_options *o, int uniform, const float *E,
                             const float *tri_e, size_t *count)
{
    size_t *rows = NULL, got = 0;
    double *times = NULL;
    const double t0 = lrr__now();
    lrr_status st = draw_new(op, uniform, o->seed, PILOT, &rows, &times, &got);
    if (!st)
        st = trace_and_compare(op, scene, o, E, tri_e, rows, times, got, 1);
    const double per_draw = (lrr__now() - t0) / (double)(got ? got : 1);
    lrr_aligned_free(rows);
    lrr_aligned_free(times);
    const double fit = per_draw > 0 ? BUILD_SHARE * op->build_seconds / per_draw : 0;
    *count = fit > MIN_DRAWS ? (size_t)fit : MIN_DRAWS;
    *count = *count < op->n ? *count : op->n;
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
    int uniform;
    float *E = NULL, *tri_e = NULL;
    size_t *rows = NULL, count = o.subpatches, got = 0;
    double *times = NULL;
    if ((st = emissions(op, &uniform, &E, &tri_e)) ||
        (!count && (st = auto_count(op, scene, &o, uniform, E, tri_e, &count))) ||
        (st = draw_new(op, uniform, o.seed, count, &rows, &times, &got)) ||
        (st = trace_and_compare(op, scene, &o, E, tri_e, rows, times, got, 0)))
        goto out;
    op->verify.subpatches = got;
    op->verify.samples = o.samples;
    op->verify.uniform = uniform;
    op->verify.seconds = lrr__now() - t0;
out:
    lrr_aligned_free(E);
    lrr_aligned_free(tri_e);
    lrr_aligned_free(rows);
    lrr_aligned_free(times);
    return st;
}
