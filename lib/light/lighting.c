/* The lighting plan: the operator's triangles as an Embree BVH built once, and per light the
 * irradiance of the previous call, so that only lights that changed cast new shadow rays
 * (docs/METHOD.md "Lights"). */
#include "config.h"
#include "light/light.h"
#include "scene/bvh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

struct lrr_lighting {
    const lrr_operator *op;
    lrr_context *ctx;
    lrr__bvh bvh;
    float eps;                /* ray offset: 1e-5 × the scene's bounding-box diagonal */
    size_t count, cap;        /* lights cached, slots allocated */
    lrr_light_source *light;  /* cap: the lights of the previous call */
    float *H;                 /* cap × n × 3: their irradiance */
    unsigned char *vis;       /* cap × n: 1 where the receiver's last ray was unoccluded */
    double tol;               /* the error budget (0: every receiver traced) */
    double *g;                /* n: the unshadowed weight of the light being traced */
    uint16_t *bin;            /* n: its budget bin */
    uint64_t rays;            /* shadow rays of the last call */
};

lrr_status lrr_lighting_create(const lrr_operator *op, lrr_lighting **out)
{
    *out = NULL;
    lrr_context *ctx = op->ctx;
    lrr_lighting *lt = lrr__zalloc(ctx, sizeof *lt);
    if (!lt)
        return lrr__error(ctx, LRR_ERR_NOMEM, "lrr_lighting_create: out of memory");
    lt->op = op;
    lt->ctx = lrr__context_retain(ctx);
    lt->eps = (float)(1e-5 * lrr__geometry_bounds(&op->geom, NULL, NULL));
    lrr_status st = lrr__bvh_build(ctx, &op->geom, RTC_BUILD_QUALITY_MEDIUM, 0,
                                   "lrr_lighting_create", &lt->bvh);
    if (st) {
        lrr__context_release(lt->ctx);
        free(lt);
        return st;
    }
    *out = lt;
    return LRR_OK;
}

void lrr_lighting_destroy(lrr_lighting *lt)
{
    if (!lt)
        return;
    lrr__bvh_release(&lt->bvh);
    lrr_aligned_free(lt->light);
    lrr_aligned_free(lt->H);
    lrr_aligned_free(lt->vis);
    lrr_aligned_free(lt->g);
    lrr_aligned_free(lt->bin);
    lrr__context_release(lt->ctx);
    free(lt);
}

lrr_status lrr_lighting_set_tolerance(lrr_lighting *lt, double tolerance)
{
    if (!(tolerance >= 0 && tolerance < 1))
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG,
                          "lrr_lighting_set_tolerance: tolerance %g is not in [0, 1)", tolerance);
    if (tolerance > 0 && !lt->g) {
        lrr_status st;
        if ((st = lrr__calloc(lt->ctx, &lt->g, lt->op->n, sizeof *lt->g, "light weights")) ||
            (st = lrr__calloc(lt->ctx, &lt->bin, lt->op->n, sizeof *lt->bin, "budget bins"))) {
            lrr_aligned_free(lt->g);
            lt->g = NULL;
            return st;
        }
    }
    if (tolerance != lt->tol)
        lt->count = 0; /* what was traced under another budget is traced again */
    lt->tol = tolerance;
    return LRR_OK;
}

uint64_t lrr_lighting_rays(const lrr_lighting *lt) { return lt->rays; }

/* Room for count lights' irradiance (the cache is dropped when it must grow). */
static lrr_status reserve(lrr_lighting *lt, size_t count)
{
    if (count <= lt->cap)
        return LRR_OK;
    size_t n3;
    if (!lrr__mul_size(lt->op->n, 3, &n3))
        return lrr__error(lt->ctx, LRR_ERR_OVERFLOW, "lrr_lighting_direct: n×3 overflows");
    lrr_light_source *light = NULL;
    float *H = NULL;
    unsigned char *vis = NULL;
    lrr_status st;
    if ((st = lrr__calloc(lt->ctx, &light, count, sizeof *light, "cached lights")) ||
        (st = lrr__calloc(lt->ctx, &H, count, n3 * sizeof(float),
                          "per-light irradiance (lights × n × 3 floats)")) ||
        (st = lrr__calloc(lt->ctx, &vis, count, lt->op->n, "per-light visibility"))) {
        lrr_aligned_free(light);
        lrr_aligned_free(H);
        return st;
    }
    memset(vis, 1, count * lt->op->n); /* visible until a ray says otherwise */
    lrr_aligned_free(lt->light);
    lrr_aligned_free(lt->H);
    lrr_aligned_free(lt->vis);
    lt->light = light;
    lt->H = H;
    lt->vis = vis;
    lt->cap = count;
    lt->count = 0;
    return LRR_OK;
}

/* Traces light l (checked as s) into its cache slot: blocks of receivers, each with one
 * batch of shadow rays (lrr__shadow_batch: its rays go to Embree as packets). With bin, only
 * the receivers whose bin is in [lo, hi). */
#define BLOCK 64
static void trace(lrr_lighting *lt, const lrr__source *s, size_t l, const uint16_t *bin,
                  unsigned lo, unsigned hi)
{
    const lrr_operator *op = lt->op;
    float *H = lt->H + l * op->n * 3;
    unsigned char *vis = lt->vis + l * op->n;
    const size_t blocks = (op->n + BLOCK - 1) / BLOCK;
    uint64_t rays = 0;
    #pragma omp parallel for schedule(dynamic, 1) reduction(+ : rays)
    for (size_t blk = 0; blk < blocks; blk++) {
        const size_t i0 = blk * BLOCK, i1 = i0 + BLOCK < op->n ? i0 + BLOCK : op->n;
        double acc[BLOCK] = {0};
        lrr__shadow_batch b;
        lrr__shadow_init(&b, lt->bvh.scene, acc);
        for (size_t i = i0; i < i1; i++)
            if (!bin || (bin[i] >= lo && bin[i] < hi))
                lrr__source_rays(s, &b, i, (unsigned)(i - i0), op->centre + 3 * i,
                                 op->normal + 3 * i, lt->eps);
        lrr__shadow_flush(&b);
        for (size_t i = i0; i < i1; i++)
            if (!bin || (bin[i] >= lo && bin[i] < hi)) {
                lrr__source_irradiance(s, acc[i - i0], H + 3 * i);
                vis[i] = acc[i - i0] > 0;
            }
        rays += b.rays;
    }
    lt->rays += rays;
}

/* Σ a ρ_c² H² (H = g · vis) over the receivers of bins [0, T), as traced. */
static void traced_light(const lrr_lighting *lt, size_t l, unsigned T, double S[3])
{
    const lrr_operator *op = lt->op;
    const unsigned char *vis = lt->vis + l * op->n;
    double s0 = 0, s1 = 0, s2 = 0;
    #pragma omp parallel for schedule(static) reduction(+ : s0, s1, s2)
    for (size_t i = 0; i < op->n; i++) {
        if (lt->bin[i] >= T || !vis[i])
            continue;
        const float *rho = op->rho + 3 * i;
        double a = op->area[i] * lt->g[i] * lt->g[i];
        s0 += a * rho[0] * rho[0];
        s1 += a * rho[1] * rho[1];
        s2 += a * rho[2] * rho[2];
    }
    S[0] = s0, S[1] = s1, S[2] = s2;
}

/* A point or spot light within the error budget (budget.c): the receivers with the largest
 * keys first, as many more as the light they were found to carry requires, and the rest
 * with the visibility of their last ray. */
static void trace_budgeted(lrr_lighting *lt, const lrr__source *s, size_t l)
{
    const lrr_operator *op = lt->op;
    lrr__budget_cost cost;
    lrr__budget_weigh(op, s, lt->g, lt->bin, cost);
    unsigned t1 = lrr__budget_cut(cost, lt->tol, NULL);
    trace(lt, s, l, lt->bin, 0, t1);
    double S[3];
    traced_light(lt, l, t1, S);
    unsigned t2 = lrr__budget_cut(cost, lt->tol, S);
    if (t2 > t1)
        trace(lt, s, l, lt->bin, t1, t2);
    else
        t2 = t1;
    float *H = lt->H + l * op->n * 3;
    const unsigned char *vis = lt->vis + l * op->n;
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < op->n; i++)
        if (lt->bin[i] >= t2)
            lrr__source_irradiance(s, lt->bin[i] == LRR__BUDGET_DARK ? 0 : lt->g[i] * vis[i],
                                   H + 3 * i);
}

lrr_status lrr_lighting_direct(lrr_lighting *lt, const lrr_light_source *lights, size_t count,
                               float *emission)
{
    if (count > 0 && !lights)
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG,
                          "lrr_lighting_direct: lights is NULL with count %zu", count);
    lrr__source *src = NULL;
    lrr_status st = LRR_OK;
    if (count && (st = lrr__calloc(lt->ctx, &src, count, sizeof *src, "checked lights")))
        return st;
    for (size_t l = 0; l < count && !st; l++)
        st = lrr__source_check(lt->ctx, &lights[l], l, &src[l]);
    if (st || (st = reserve(lt, count))) {
        lrr_aligned_free(src);
        return st;
    }
    lt->rays = 0;
    for (size_t l = 0; l < count; l++) {
        if (l < lt->count && memcmp(&lt->light[l], &lights[l], sizeof *lights) == 0)
            continue; /* unchanged: its irradiance is still in the cache */
        if (lt->tol > 0 && (src[l].kind == LRR_LIGHT_POINT || src[l].kind == LRR_LIGHT_SPOT))
            trace_budgeted(lt, &src[l], l);
        else
            trace(lt, &src[l], l, NULL, 0, 0);
        lt->light[l] = lights[l];
    }
    lt->count = count;
    st = lrr__bvh_status(lt->ctx, &lt->bvh, "occlusion query");
    lrr_aligned_free(src);
    if (st) {
        lt->count = 0; /* the traced irradiance is not to be trusted */
        return st;
    }
    /* E = rho ∘ Σ_l H_l, summed in light order (float, as lrr_probe_direct_light) */
    const lrr_operator *op = lt->op;
    const size_t n3 = op->n * 3;
    int overflow = 0;
    #pragma omp parallel for schedule(static) reduction(| : overflow)
    for (size_t j = 0; j < n3; j++) {
        float sum = 0.0f;
        for (size_t l = 0; l < count; l++)
            sum += lt->H[l * n3 + j];
        emission[j] = op->rho[j] * sum;
        overflow |= !isfinite(emission[j]);
    }
    if (overflow) {
        memset(emission, 0, n3 * sizeof(float));
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG,
                          "lrr_lighting_direct: the direct light overflows a float");
    }
    return LRR_OK;
}
