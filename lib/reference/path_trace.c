/* Path-traced reference (docs/METHOD.md "Path-traced reference"): B of every subpatch by
 * Monte Carlo with Embree rays, for scenes whose n×n F cannot be stored. It estimates the
 * solution of the same discrete equation B = E + R F B as the exact solve (F exact, i.e.
 * averaged over the receiver's area), so it checks the hemicube's F as well as the solvers.
 *
 * The Embree device, scene and error callback follow lib/probe/light.c (a stage may not
 * include another's code, so the few lines are repeated).
 */
#include "config.h"
#include "reference/reference.h"
#include "reference/rows.h"
#include "scene/bvh.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <string.h>

#define DEFAULT_SAMPLES 1024
/* Russian roulette starts after this many bounces: the first ones carry most of B. */
#define RR_BOUNCES 3
/* Survival probability at most this, so a path through ρ → 1 still ends. */
#define RR_MAX_SURVIVAL 0.95

/* ------------------------------------------------------------------ the scene as traced */
typedef struct tracer {
    const lrr__geometry *g;
    const float *rho, *emission; /* n_tri×3, per input triangle */
    double *normal;              /* n_tri×3 unit front normals */
    double *cdf;                 /* n_emit: cumulative emitter weight A_t Σ_c E_tc */
    size_t *emitter;             /* n_emit triangle indices */
    size_t n_emit;
    double eps; /* ray offset: 1e-5 × bounding-box diagonal, as lib/probe/light.c */
    RTCScene scene;
} tracer;

typedef struct rng {
    uint64_t state;
} rng;
static double uniform(rng *r) { return (double)(lrr__splitmix64_next(&r->state) >> 11) * 0x1p-53; }

/* Uniform point of triangle v (9 doubles). */
static void triangle_point(const double v[9], rng *r, double p[3])
{
    double a = uniform(r), b = uniform(r);
    if (a + b > 1) {
        a = 1 - a;
        b = 1 - b;
    }
    for (int j = 0; j < 3; j++)
        p[j] = v[j] + a * (v[3 + j] - v[j]) + b * (v[6 + j] - v[j]);
}

/* Cosine-weighted direction about unit n (Duff et al. 2017 orthonormal basis). */
static void cosine_direction(const double n[3], rng *r, double w[3])
{
    double s = n[2] >= 0 ? 1.0 : -1.0, a = -1 / (s + n[2]), b = n[0] * n[1] * a;
    double t[3] = {1 + s * n[0] * n[0] * a, s * b, -s * n[0]};
    double u[3] = {b, s + n[1] * n[1] * a, -n[1]};
    double u1 = uniform(r), phi = 2 * M_PI * uniform(r), rad = sqrt(u1), z = sqrt(1 - u1);
    for (int j = 0; j < 3; j++)
        w[j] = rad * cos(phi) * t[j] + rad * sin(phi) * u[j] + z * n[j];
}

static void set_ray(struct RTCRay *ray, const double o[3], const double d[3], double tfar)
{
    ray->org_x = (float)o[0];
    ray->org_y = (float)o[1];
    ray->org_z = (float)o[2];
    ray->tnear = 0.0f;
    ray->dir_x = (float)d[0];
    ray->dir_y = (float)d[1];
    ray->dir_z = (float)d[2];
    ray->time = 0.0f;
    ray->tfar = (float)tfar;
    ray->mask = UINT32_MAX;
    ray->id = 0;
    ray->flags = 0;
}

/* Next-event estimate at x (on triangle t) of Σ_e ∫ E_e G V dy, one point y on an emitter
 * chosen by A_e Σ_c E_ec, weighted by the balance heuristic against the cosine sampling
 * (whose density in area is G itself): bounded by E even where emitters meet x at an edge,
 * where G ~ 1/r² would give plain next-event estimation an infinite variance. */
static void next_event(const tracer *tr, const double x[3], size_t t, rng *r, double out[3])
{
    out[0] = out[1] = out[2] = 0;
    if (tr->n_emit == 0)
        return;
    const double W = tr->cdf[tr->n_emit - 1], pick = uniform(r) * W;
    size_t lo = 0, hi = tr->n_emit - 1;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (tr->cdf[mid] > pick) hi = mid; else lo = mid + 1;
    }
    size_t e = tr->emitter[lo];
    if (e == t)
        return; /* a plane does not see itself */
    double v[9], y[3], d[3];
    for (int j = 0; j < 9; j++)
        v[j] = tr->g->vert[9 * e + j];
    triangle_point(v, r, y);
    const double *nx = tr->normal + 3 * t, *ny = tr->normal + 3 * e;
    for (int j = 0; j < 3; j++)
        d[j] = y[j] - x[j];
    double r2 = lrr__dot3(d, d), len = sqrt(r2);
    double cx = lrr__dot3(nx, d) / len, cy = -lrr__dot3(ny, d) / len;
    if (!(cx > 0 && cy > 0)) /* x behind the emitter, or the emitter's back towards x */
        return;
    double G = cx * cy / (M_PI * r2);
    const float *E = tr->emission + 3 * e;
    double p_nee = ((double)E[0] + E[1] + E[2]) / W; /* area density of y */
    double o[3], to[3];
    for (int j = 0; j < 3; j++) {
        o[j] = x[j] + tr->eps * nx[j];
        to[j] = y[j] + tr->eps * ny[j] - o[j];
    }
    double tl = sqrt(lrr__dot3(to, to));
    for (int j = 0; j < 3; j++)
        to[j] /= tl;
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRay ray;
    set_ray(&ray, o, to, tl);
    rtcOccluded1(tr->scene, &ictx, &ray);
    if (ray.tfar < 0.0f) /* -inf: something is in the way */
        return;
    for (int c = 0; c < 3; c++)
        out[c] = E[c] * G / (p_nee + G);
}

/* The cosine-sampled ray from x (triangle t) along w: the triangle hit from its front, its
 * subpatch and the hit's share of the emission (balance heuristic, see next_event) in emit;
 * (size_t)-1 for a miss or a back face (black). */
static size_t gather_hit(const tracer *tr, const double x[3], size_t t, const double w[3],
                         size_t *sub, double emit[3])
{
    const double *nx = tr->normal + 3 * t;
    double o[3];
    for (int j = 0; j < 3; j++)
        o[j] = x[j] + tr->eps * nx[j];
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    struct RTCRayHit rh;
    set_ray(&rh.ray, o, w, INFINITY);
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(tr->scene, &ictx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
        return (size_t)-1;
    size_t h = rh.hit.primID;
    const double *nh = tr->normal + 3 * h;
    double cy = -lrr__dot3(nh, w);
    if (!(cy > 0))
        return (size_t)-1;
    *sub = lrr__subpatch_at(tr->g, h, rh.hit.u, rh.hit.v);
    const float *E = tr->emission + 3 * h;
    double esum = (double)E[0] + E[1] + E[2];
    emit[0] = emit[1] = emit[2] = 0;
    if (esum > 0) {
        double d[3]; /* from x, not o: the G of next_event for the same y */
        for (int j = 0; j < 3; j++)
            d[j] = o[j] + rh.ray.tfar * w[j] - x[j];
        double r2 = lrr__dot3(d, d);
        double G = lrr__dot3(nx, d) * -lrr__dot3(nh, d) / (M_PI * r2 * r2);
        double p_nee = esum / tr->cdf[tr->n_emit - 1];
        for (int c = 0; c < 3; c++)
            emit[c] = E[c] * G / (G + p_nee);
    }
    return h;
}

/* One path from a uniform point of subpatch i: X = E_i + ρ_i (gather), each bounce moving
 * to a uniform point of the subpatch hit (docs/METHOD.md "Path-traced reference"). */
static void path(const tracer *tr, size_t i, rng *r, double X[3])
{
    const lrr__geometry *g = tr->g;
    size_t t = lrr__subpatch_triangle(g, i), sub = i;
    double thr[3];
    for (int c = 0; c < 3; c++) {
        X[c] = tr->emission[3 * t + c];
        thr[c] = tr->rho[3 * t + c];
    }
    for (unsigned bounce = 0;; bounce++) {
        double v[9], x[3], w[3], le[3], emit[3];
        lrr__subpatch_vertices(g, sub, v);
        triangle_point(v, r, x);
        next_event(tr, x, t, r, le);
        cosine_direction(tr->normal + 3 * t, r, w);
        size_t h = gather_hit(tr, x, t, w, &sub, emit);
        for (int c = 0; c < 3; c++)
            X[c] += thr[c] * (le[c] + (h != (size_t)-1 ? emit[c] : 0));
        if (h == (size_t)-1)
            return;
        double q = 0;
        for (int c = 0; c < 3; c++) {
            thr[c] *= tr->rho[3 * h + c];
            q = fmax(q, thr[c]);
        }
        if (bounce + 1 >= RR_BOUNCES) {
            q = fmin(q, RR_MAX_SURVIVAL);
            if (!(q > 0) || uniform(r) >= q)
                return;
            for (int c = 0; c < 3; c++)
                thr[c] /= q;
        } else if (!(q > 0)) {
            return;
        }
        t = h;
    }
}

/* ------------------------------------------------------------------ setup */
static void tracer_free(tracer *tr)
{
    lrr_aligned_free(tr->normal);
    lrr_aligned_free(tr->cdf);
    lrr_aligned_free(tr->emitter);
}

/* Front normals and the emitter table of the scene's triangles, emitting `emission` (n_tri×3;
 * the scene's own when NULL). */
static lrr_status tracer_init(const lrr_scene *scene, const float *emission, tracer *tr)
{
    const lrr__geometry *g = &scene->geom;
    lrr_context *ctx = scene->ctx;
    memset(tr, 0, sizeof *tr);
    tr->g = g;
    tr->rho = scene->rho;
    tr->emission = emission ? emission : scene->emission;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &tr->normal, g->n_tri, 3 * sizeof(double), "triangle normals")) ||
        (st = lrr__calloc(ctx, &tr->cdf, g->n_tri, sizeof(double), "emitter table")) ||
        (st = lrr__calloc(ctx, &tr->emitter, g->n_tri, sizeof(size_t), "emitter table")))
        return st;
    double total = 0;
    for (size_t t = 0; t < g->n_tri; t++) {
        const float *v = g->vert + 9 * t;
        double e1[3], e2[3];
        for (int j = 0; j < 3; j++) {
            e1[j] = (double)v[3 + j] - v[j];
            e2[j] = (double)v[6 + j] - v[j];
        }
        lrr__cross3(e1, e2, tr->normal + 3 * t);
        lrr__normalize3(tr->normal + 3 * t);
        const float *E = tr->emission + 3 * t;
        double w = lrr__tri_area(v) * ((double)E[0] + E[1] + E[2]);
        if (w > 0) {
            total += w;
            tr->cdf[tr->n_emit] = total;
            tr->emitter[tr->n_emit++] = t;
        }
    }
    tr->eps = 1e-5 * lrr__geometry_bounds(g, NULL, NULL);
    return LRR_OK;
}

static lrr_status read_options(const lrr_scene *scene, const lrr_path_trace_options *opts,
                               lrr_path_trace_options *o)
{
    lrr_context *ctx = scene->ctx;
    if (!scene->geom.depth)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "lrr_reference_path_trace: the scene is "
                          "not subdivided: call lrr_scene_subdivide first");
    *o = lrr_path_trace_options_defaults();
    lrr_status st;
    if (opts && (st = lrr__options_read(ctx, opts, sizeof *o,
                                        LRR__FIRST_SIZE(lrr_path_trace_options, progress_user),
                                        o, "lrr_path_trace_options")))
        return st;
    if (o->samples < 2)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "lrr_path_trace_options.samples = %zu: at least 2 paths per subpatch "
                          "are needed for a standard error",
                          o->samples);
    if (o->threads < 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "lrr_path_trace_options.threads = %d: must be >= 0", o->threads);
    if (scene->geom.n_tri > UINT32_MAX / 3)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "lrr_reference_path_trace: %zu triangles "
                          "exceed Embree's 32-bit indices", scene->geom.n_tri);
    return LRR_OK;
}

/* ------------------------------------------------------------------ estimation */
/* Mean and standard error of subpatch i's paths (Welford's update, in double). Stream of
 * path s: splitmix64 from (seed, i, s), so no result depends on the thread count. */
static void subpatch_estimate(const tracer *tr, const lrr_path_trace_options *o, size_t i,
                              float *mean, float *se)
{
    double m[3] = {0, 0, 0}, m2[3] = {0, 0, 0};
    const uint64_t base = lrr__splitmix64(o->seed ^ lrr__splitmix64(i));
    for (size_t s = 0; s < o->samples; s++) {
        rng r = {lrr__splitmix64(base ^ lrr__mix64(s))};
        double X[3];
        path(tr, i, &r, X);
        for (int c = 0; c < 3; c++) {
            double dl = X[c] - m[c];
            m[c] += dl / (double)(s + 1);
            m2[c] += dl * (X[c] - m[c]);
        }
    }
    const double N = (double)o->samples;
    for (int c = 0; c < 3; c++) {
        mean[c] = (float)m[c];
        if (se)
            se[c] = (float)sqrt(m2[c] / (N - 1) / N);
    }
}

/* Subpatches rows[0..n) (all n of the scene when rows is NULL) in parallel into B and se
 * (n×3); progress from thread 0 (as lib/formfactor/hemicube.c). */
static lrr_status estimate_all(lrr_context *ctx, const tracer *tr,
                               const lrr_path_trace_options *o, const size_t *rows, size_t n,
                               float *B, float *se)
{
    int nthreads = o->threads > 0 ? o->threads : omp_get_max_threads();
    volatile int cancelled = 0;
    size_t done = 0;
    double last_report = lrr__now();
    #pragma omp parallel for schedule(dynamic, 4) num_threads(nthreads)
    for (size_t i = 0; i < n; i++) {
        if (cancelled)
            continue;
        subpatch_estimate(tr, o, rows ? rows[i] : i, B + 3 * i, se ? se + 3 * i : NULL);
        size_t now_done;
        #pragma omp atomic capture
        now_done = ++done;
        if (o->progress && omp_get_thread_num() == 0) {
            double t = lrr__now();
            if (t - last_report > 0.05 || now_done == n) {
                last_report = t;
                if (o->progress(o->progress_user, now_done, n)) {
                    #pragma omp atomic write
                    cancelled = 1;
                }
            }
        }
    }
    if (cancelled)
        return lrr__error(ctx, LRR_ERR_CANCELLED, "lrr_reference_path_trace cancelled after "
                          "%zu of %zu subpatches", done, n);
    if (o->progress)
        o->progress(o->progress_user, n, n);
    return LRR_OK;
}

struct lrr__tracer {
    const lrr_scene *scene;
    tracer tr;
    lrr__bvh bvh;
    int have_bvh;
    float *own; /* lrr__trace_start's uniform emission, or NULL */
};

void lrr__tracer_destroy(lrr__tracer *t)
{
    if (!t)
        return;
    if (t->have_bvh)
        lrr__bvh_release(&t->bvh);
    tracer_free(&t->tr);
    lrr_aligned_free(t->own);
    lrr_aligned_free(t);
}

lrr_status lrr__tracer_create(const lrr_scene *scene, const float *emission, lrr__tracer **out)
{
    lrr_context *ctx = scene->ctx;
    *out = NULL;
    if (!scene->geom.depth)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "path tracing: the scene is not "
                          "subdivided: call lrr_scene_subdivide first");
    if (scene->geom.n_tri > UINT32_MAX / 3)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "path tracing: %zu triangles exceed Embree's "
                          "32-bit indices", scene->geom.n_tri);
    lrr__tracer *t;
    lrr_status st = lrr__calloc(ctx, &t, 1, sizeof *t, "path tracer");
    if (st)
        return st;
    t->scene = scene;
    if ((st = tracer_init(scene, emission, &t->tr)) ||
        (st = lrr__bvh_build(ctx, &scene->geom, RTC_BUILD_QUALITY_HIGH /* many rays */, 0,
                             "lrr_reference_path_trace", &t->bvh))) {
        lrr__tracer_destroy(t);
        return st;
    }
    t->have_bvh = 1;
    t->tr.scene = t->bvh.scene;
    *out = t;
    return LRR_OK;
}

lrr_status lrr__tracer_rows(const lrr__tracer *t, const lrr_path_trace_options *opts,
                            const size_t *rows, size_t count, float *radiosity,
                            float *std_error)
{
    const lrr_scene *scene = t->scene;
    lrr_path_trace_options o;
    lrr_status st = read_options(scene, opts, &o);
    if (st)
        return st;
    for (size_t r = 0; rows && r < count; r++)
        if (rows[r] >= scene->geom.n)
            return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG, "path tracing: subpatch %zu of "
                              "a scene of %zu", rows[r], scene->geom.n);
    st = estimate_all(scene->ctx, &t->tr, &o, rows, rows ? count : scene->geom.n, radiosity,
                      std_error);
    return st ? st : lrr__bvh_status(scene->ctx, &t->bvh, "ray query");
}

lrr_status lrr__trace_rows(const lrr_scene *scene, const lrr_path_trace_options *opts,
                           const size_t *rows, size_t count, float *radiosity, float *std_error)
{
    lrr_path_trace_options o;
    lrr_status st = read_options(scene, opts, &o); /* before the BVH is built */
    lrr__tracer *t;
    if (st || !rows || !count || (st = lrr__tracer_create(scene, NULL, &t)))
        return st;
    st = lrr__tracer_rows(t, &o, rows, count, radiosity, std_error);
    lrr__tracer_destroy(t);
    return st;
}

lrr_status lrr__trace_start(const lrr_scene *scene, int uniform, lrr__tracer **out)
{
    *out = NULL;
    float *ones = NULL;
    const size_t values = 3 * scene->geom.n_tri;
    lrr_status st = uniform ? lrr__calloc(scene->ctx, &ones, values ? values : 1,
                                          sizeof(float), "uniform emission (n_tri×3)")
                            : LRR_OK;
    for (size_t v = 0; !st && ones && v < values; v++)
        ones[v] = 1.0f;
    if (!st && !(st = lrr__tracer_create(scene, ones, out)))
        (*out)->own = ones;
    else
        lrr_aligned_free(ones);
    return st;
}

lrr_context *lrr__trace_context(const lrr_scene *scene) { return scene->ctx; }

lrr_status lrr_reference_path_trace(const lrr_scene *scene, const lrr_path_trace_options *opts,
                                    float *radiosity, float *std_error)
{
    lrr_path_trace_options o;
    lrr_status st = read_options(scene, opts, &o); /* before the BVH is built */
    lrr__tracer *t;
    if (st || (st = lrr__tracer_create(scene, NULL, &t)))
        return st;
    st = lrr__tracer_rows(t, &o, NULL, 0, radiosity, std_error);
    lrr__tracer_destroy(t);
    return st;
}

lrr_status lrr_reference_triangle_means(const lrr_scene *scene, const float *radiosity,
                                        const float *std_error, float *mean,
                                        float *mean_std_error)
{
    const lrr__geometry *g = &scene->geom;
    if (!g->depth)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG, "lrr_reference_triangle_means: the "
                          "scene is not subdivided: call lrr_scene_subdivide first");
    if (mean_std_error && !std_error)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG, "lrr_reference_triangle_means: "
                          "mean_std_error needs std_error");
    for (size_t t = 0; t < g->n_tri; t++) {
        double a = 0, s[3] = {0, 0, 0}, v[3] = {0, 0, 0};
        for (size_t i = g->sub0[t]; i < g->sub0[t + 1]; i++) {
            double sv[9], e1[3], e2[3], cr[3];
            lrr__subpatch_vertices(g, i, sv);
            for (int j = 0; j < 3; j++) {
                e1[j] = sv[3 + j] - sv[j];
                e2[j] = sv[6 + j] - sv[j];
            }
            lrr__cross3(e1, e2, cr);
            double ai = 0.5 * sqrt(lrr__dot3(cr, cr));
            a += ai;
            for (int c = 0; c < 3; c++) {
                s[c] += ai * radiosity[3 * i + c];
                if (mean_std_error)
                    v[c] += ai * ai * (double)std_error[3 * i + c] * std_error[3 * i + c];
            }
        }
        for (int c = 0; c < 3; c++) {
            mean[3 * t + c] = (float)(s[c] / a);
            if (mean_std_error)
                mean_std_error[3 * t + c] = (float)(sqrt(v[c]) / a);
        }
    }
    return LRR_OK;
}
