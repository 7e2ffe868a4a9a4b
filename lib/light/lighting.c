/* The lighting plan: the operator's triangles as an Embree BVH built once, and per light the
 * irradiance of the previous call, so that only lights that changed cast new shadow rays
 * (docs/METHOD.md "Lights"). */
#include "config.h"
#include "light/light.h"
#include "core/cpu.h"
#include "scene/bvh.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* SSE2 through GCC's vector extensions, unaligned (solve/cpu.c's segment sums do the same) */
typedef float v4f __attribute__((vector_size(16), aligned(4)));
typedef int32_t v4i __attribute__((vector_size(16), aligned(4)));

struct lrr_lighting {
    const lrr_operator *op;
    lrr_context *ctx;
    lrr__bvh bvh;
    float eps;                /* ray offset: 1e-5 × the scene's bounding-box diagonal */
    size_t count, cap;        /* lights cached, slots allocated */
    lrr_light_source *light;  /* cap: the lights of the previous call */
    float *H;                 /* cap × n × 3: their irradiance; for a light traced within
                                 the budget (scalar), its first n floats hold H / rgb */
    unsigned char *scalar;    /* cap: 1 where the slot holds H / rgb */
    unsigned char *vis;       /* cap × n: 1 where the receiver's last ray was unoccluded */
    double tol;               /* the error budget (0: every receiver traced) */
    float *g;                 /* LRR__BUDGET_GROUP × n: the unshadowed weights of a group */
    uint16_t *bin;            /* LRR__BUDGET_GROUP × n: their budget bins */
    size_t *list;             /* n: the receivers to trace next */
    double (*part)[3];        /* n / LRR__SHADOW_RAYS + 1: their light, a chunk each */
    lrr__budget_cost *cost;   /* LRR__BUDGET_GROUP */
    lrr__budget_receivers rcv; /* the receivers as the budget reads them */
    int avx2;                 /* the budget's keys with AVX2 (lib/core/cpu.h) */
    uint64_t rays;            /* shadow rays of the last call */
    size_t r0, r1;            /* the receivers [r0, r1) the cache holds */
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
    lrr__cpu_choice cpu;
    lrr_status st = lrr__cpu_choose(ctx, &cpu);
    lt->avx2 = !st && cpu.isa >= LRR__ISA_AVX2;
    if (!st)
        st = lrr__bvh_build(ctx, &op->geom, RTC_BUILD_QUALITY_MEDIUM, 0, "lrr_lighting_create",
                            &lt->bvh);
    if (st) {
        lrr__context_release(lt->ctx);
        free(lt);
        return st;
    }
    *out = lt;
    return LRR_OK;
}

/* The budget's working arrays, allocated once a tolerance is set. */
static void budget_free(lrr_lighting *lt)
{
    lrr_aligned_free(lt->g);
    lrr_aligned_free(lt->bin);
    lrr_aligned_free(lt->list);
    lrr_aligned_free(lt->part);
    lrr_aligned_free(lt->cost);
    lrr__budget_receivers_free(&lt->rcv);
    lt->g = NULL;
    lt->bin = NULL;
    lt->list = NULL;
    lt->part = NULL;
    lt->cost = NULL;
}

void lrr_lighting_destroy(lrr_lighting *lt)
{
    if (!lt)
        return;
    lrr__bvh_release(&lt->bvh);
    lrr_aligned_free(lt->light);
    lrr_aligned_free(lt->H);
    lrr_aligned_free(lt->vis);
    lrr_aligned_free(lt->scalar);
    budget_free(lt);
    lrr__context_release(lt->ctx);
    free(lt);
}

static lrr_status budget_alloc(lrr_lighting *lt)
{
    const size_t n = lt->op->n, m = LRR__BUDGET_GROUP, chunks = n / LRR__SHADOW_RAYS + 1;
    lrr_status st;
    if ((st = lrr__calloc(lt->ctx, &lt->g, m * n, sizeof *lt->g, "light weights")) ||
        (st = lrr__calloc(lt->ctx, &lt->bin, m * n, sizeof *lt->bin, "budget bins")) ||
        (st = lrr__calloc(lt->ctx, &lt->list, n, sizeof *lt->list, "receivers to trace")) ||
        (st = lrr__calloc(lt->ctx, &lt->part, chunks, sizeof *lt->part, "traced light")) ||
        (st = lrr__calloc(lt->ctx, &lt->cost, m, sizeof *lt->cost, "budget costs")) ||
        (st = lrr__budget_receivers_init(lt->ctx, lt->op, &lt->rcv)))
        budget_free(lt);
    return st;
}

lrr_status lrr_lighting_set_tolerance(lrr_lighting *lt, double tolerance)
{
    if (!(tolerance >= 0 && tolerance < 1))
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG,
                          "lrr_lighting_set_tolerance: tolerance %g is not in [0, 1)", tolerance);
    lrr_status st;
    if (tolerance > 0 && !lt->g && (st = budget_alloc(lt)))
        return st;
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
    unsigned char *vis = NULL, *scalar = NULL;
    lrr_status st;
    if ((st = lrr__calloc(lt->ctx, &light, count, sizeof *light, "cached lights")) ||
        (st = lrr__calloc(lt->ctx, &scalar, count, 1, "cached lights")) ||
        (st = lrr__calloc(lt->ctx, &H, count, n3 * sizeof(float),
                          "per-light irradiance (lights × n × 3 floats)")) ||
        (st = lrr__calloc(lt->ctx, &vis, count, lt->op->n, "per-light visibility"))) {
        lrr_aligned_free(light);
        lrr_aligned_free(scalar);
        lrr_aligned_free(H);
        return st;
    }
    memset(vis, 1, count * lt->op->n); /* visible until a ray says otherwise */
    lrr_aligned_free(lt->light);
    lrr_aligned_free(lt->H);
    lrr_aligned_free(lt->vis);
    lrr_aligned_free(lt->scalar);
    lt->scalar = scalar;
    lt->light = light;
    lt->H = H;
    lt->vis = vis;
    lt->cap = count;
    lt->count = 0;
    return LRR_OK;
}

/* Traces light l (checked as s) at every receiver into its cache slot: blocks of receivers,
 * each with one batch of shadow rays (lrr__shadow_batch: its rays go to Embree as packets). */
#define BLOCK 64
static void trace(lrr_lighting *lt, const lrr__source *s, size_t l)
{
    const lrr_operator *op = lt->op;
    lt->scalar[l] = 0;
    float *H = lt->H + l * op->n * 3;
    unsigned char *vis = lt->vis + l * op->n;
    /* the whole call's blocks, clipped to [r0, r1): a receiver's rays and sums are its own,
     * so a range gets the whole call's rows bit for bit */
    const size_t b0 = lt->r0 / BLOCK, b1 = (lt->r1 + BLOCK - 1) / BLOCK;
    uint64_t rays = 0;
    #pragma omp parallel for schedule(dynamic, 1) reduction(+ : rays)
    for (size_t blk = b0; blk < b1; blk++) {
        const size_t i0 = blk * BLOCK > lt->r0 ? blk * BLOCK : lt->r0;
        const size_t i1 = blk * BLOCK + BLOCK < lt->r1 ? blk * BLOCK + BLOCK : lt->r1;
        double acc[BLOCK] = {0};
        lrr__shadow_batch b;
        lrr__shadow_init(&b, lt->bvh.scene, acc);
        for (size_t i = i0; i < i1; i++)
            lrr__source_rays(s, &b, i, (unsigned)(i - i0), op->centre + 3 * i,
                                 op->normal + 3 * i, lt->eps);
        lrr__shadow_flush(&b);
        for (size_t i = i0; i < i1; i++) {
            lrr__source_irradiance(s, acc[i - i0], H + 3 * i);
            vis[i] = acc[i - i0] > 0;
        }
        rays += b.rays;
    }
    lt->rays += rays;
}

/* The receivers whose bin is in [lo, hi), in order, into list; their count. Spans counted,
 * then written, in parallel. */
#define SPANS 64
static size_t select_bins(const uint16_t *bin, size_t n, unsigned lo, unsigned hi, size_t *list)
{
    size_t start[SPANS + 1] = {0};
    #pragma omp parallel for schedule(static)
    for (size_t sp = 0; sp < SPANS; sp++) {
        size_t c = 0;
        const size_t i1 = n * (sp + 1) / SPANS;
        #pragma omp simd reduction(+ : c)
        for (size_t i = n * sp / SPANS; i < i1; i++)
            c += bin[i] >= lo && bin[i] < hi;
        start[sp + 1] = c;
    }
    for (size_t sp = 0; sp < SPANS; sp++)
        start[sp + 1] += start[sp];
    #pragma omp parallel for schedule(static)
    for (size_t sp = 0; sp < SPANS; sp++) {
        size_t c = start[sp];
        const size_t end = start[sp + 1];
        for (size_t i = n * sp / SPANS; i < n * (sp + 1) / SPANS && c < end; i++) {
            list[c] = i; /* kept only when selected: the next one overwrites it otherwise */
            c += bin[i] >= lo && bin[i] < hi;
        }
    }
    return start[SPANS];
}

/* Traces point or spot light l (checked as s) at the receivers list[0, count): one shadow
 * batch per LRR__SHADOW_RAYS of them (one ray each), so that every packet but the last is
 * full; fills their H / rgb and vis, and S with Σ a ρ_c² g² over those found visible,
 * summed in a fixed order whatever the threads. */
static void trace_list(lrr_lighting *lt, const lrr__source *s, size_t l, const float *g,
                       size_t count, double S[3])
{
    const lrr_operator *op = lt->op;
    float *f = lt->H + l * op->n * 3;
    unsigned char *vis = lt->vis + l * op->n;
    const size_t *list = lt->list, chunks = (count + LRR__SHADOW_RAYS - 1) / LRR__SHADOW_RAYS;
    uint64_t rays = 0;
    #pragma omp parallel for schedule(dynamic, 1) reduction(+ : rays)
    for (size_t c = 0; c < chunks; c++) {
        const size_t j0 = c * LRR__SHADOW_RAYS;
        const size_t j1 = j0 + LRR__SHADOW_RAYS < count ? j0 + LRR__SHADOW_RAYS : count;
        double acc[LRR__SHADOW_RAYS] = {0}, *part = lt->part[c];
        lrr__shadow_batch b;
        lrr__shadow_init(&b, lt->bvh.scene, acc);
        for (size_t j = j0; j < j1; j++)
            lrr__source_rays(s, &b, list[j], (unsigned)(j - j0), op->centre + 3 * list[j],
                             op->normal + 3 * list[j], lt->eps);
        lrr__shadow_flush(&b);
        part[0] = part[1] = part[2] = 0;
        for (size_t j = j0; j < j1; j++) {
            const size_t i = list[j];
            f[i] = (float)acc[j - j0];
            vis[i] = acc[j - j0] > 0;
            for (int k = 0; k < 3 && vis[i]; k++)
                part[k] += g[i] * g[i] * lt->rcv.ar[k][i];
        }
        rays += b.rays;
    }
    lt->rays += rays;
    S[0] = S[1] = S[2] = 0;
    for (size_t c = 0; c < chunks; c++)
        for (int k = 0; k < 3; k++)
            S[k] += lt->part[c][k];
}

/* The receivers not traced (bin >= t) keep the visibility of their last ray (or, never
 * traced, visible). Guessing it instead from this frame's rays measured worse on Sponza
 * (4 moving lights, τ 0.03, 20 frames, error of E mean / max): last ray 1.21 / 1.95 %; the
 * nearest ray within 4 places 1.24 / 1.87 %, within 64 1.34 / 1.96 %; the patch's share
 * of visible rays 1.34 / 1.92 %, by weight 1.71 / 2.15 %: the untraced receivers are far
 * from the traced ones, and their visibility is theirs. */
#define GUESS_SPAN 4096
static void guess(lrr_lighting *lt, size_t l, const float *g, const uint16_t *bin, unsigned t)
{
    const lrr_operator *op = lt->op;
    float *f = lt->H + l * op->n * 3; /* H / rgb (scalar) */
    const unsigned char *vis = lt->vis + l * op->n;
    const size_t spans = (op->n + GUESS_SPAN - 1) / GUESS_SPAN;
    const v4i dark = {LRR__BUDGET_DARK, LRR__BUDGET_DARK, LRR__BUDGET_DARK, LRR__BUDGET_DARK};
    const v4i cut = {(int32_t)t - 1, (int32_t)t - 1, (int32_t)t - 1, (int32_t)t - 1};
    /* masks, not branches: kept and guessed receivers interleave. With this and the sums'
     * vectors (add_light, scale_block): Sponza, 4 moving point lights, τ 0.0175, 2 threads,
     * mean of 50 frames, old and new library in turn 3 times: 10.2 → 8.7 ms a frame, the
     * same E bit for bit */
    #pragma omp parallel for schedule(static)
    for (size_t sp = 0; sp < spans; sp++) {
        size_t i = sp * GUESS_SPAN;
        const size_t i1 = i + GUESS_SPAN < op->n ? i + GUESS_SPAN : op->n;
        for (; i + 4 <= i1; i += 4) {
            const v4i b = {bin[i], bin[i + 1], bin[i + 2], bin[i + 3]};
            const v4f v = {(float)vis[i], (float)vis[i + 1], (float)vis[i + 2], (float)vis[i + 3]};
            const v4i gv = (v4i)(*(const v4f *)(const void *)(g + i) * v) & ~(b == dark);
            const v4i take = b > cut, kept = *(const v4i *)(const void *)(f + i);
            *(v4i *)(void *)(f + i) = (gv & take) | (kept & ~take);
        }
        for (; i < i1; i++)
            if (bin[i] >= t)
                f[i] = bin[i] == LRR__BUDGET_DARK ? 0.0f : g[i] * vis[i];
    }
}

/* A point or spot light within the error budget (budget.c), weighed (g, bin, cost): the
 * receivers with the largest keys first, as many more as the light they were found to carry
 * requires, and the rest with the visibility of their last ray. */
static void trace_budgeted(lrr_lighting *lt, const lrr__source *s, size_t l, const float *g,
                           const uint16_t *bin, const lrr__budget_cost cost)
{
    const lrr_operator *op = lt->op;
    unsigned t1 = lrr__budget_cut(cost, lt->tol, NULL);
    double S[3], S2[3];
    size_t cnt = select_bins(bin, op->n, 0, t1, lt->list);
    trace_list(lt, s, l, g, cnt, S);
    unsigned t2 = lrr__budget_cut(cost, lt->tol, S);
    if (t2 > t1)
        trace_list(lt, s, l, g, select_bins(bin, op->n, t1, t2, lt->list), S2);
    else
        t2 = t1;
    guess(lt, l, g, bin, t2);
    lt->scalar[l] = 1;
}

/* The m lights which[] (changed, budgeted), weighed together, then traced one by one. */
static void trace_group(lrr_lighting *lt, const lrr__source *src, const size_t *which, size_t m)
{
    const size_t n = lt->op->n;
    lrr__source s[LRR__BUDGET_GROUP] = {0};
    float *g[LRR__BUDGET_GROUP] = {0};
    uint16_t *bin[LRR__BUDGET_GROUP] = {0};
    for (size_t j = 0; j < m; j++) {
        s[j] = src[which[j]];
        g[j] = lt->g + j * n;
        bin[j] = lt->bin + j * n;
    }
    lrr__budget_weigh(lt->op, &lt->rcv, s, m, g, bin, lt->cost, lt->avx2);
    for (size_t j = 0; j < m; j++)
        trace_budgeted(lt, &s[j], which[j], g[j], bin[j], lt->cost[j]);
}

/* sum[0, m) += light l's irradiance H at entries [j0, j0 + m) of the n×3 array (j0 and m
 * multiples of 3): from its slot, or rgb times its scalar slot. */
#define SUM_BLOCK 1536
static void add_light(const lrr_lighting *lt, const lrr__source *s, size_t l, size_t j0,
                      size_t m, float *sum)
{
    const float *H = lt->H + l * lt->op->n * 3;
    if (!lt->scalar[l]) {
        for (size_t j = 0; j < m; j++)
            sum[j] += H[j0 + j];
        return;
    }
    const float rgb[3] = {(float)s->rgb[0], (float)s->rgb[1], (float)s->rgb[2]}, *f = H + j0 / 3;
    /* four receivers (12 sums) a step in three vectors, each entry's product and sum as in
     * the scalar loop after it: gcc -O2 leaves the stride-3 loop scalar, and a frame whose 4
     * budgeted lights were all cached took 1.88 ms on one core for this sum (Sponza, n
     * 265,203), 0.39 ms now */
    const v4f ka = {rgb[0], rgb[1], rgb[2], rgb[0]}, kb = {rgb[1], rgb[2], rgb[0], rgb[1]},
              kc = {rgb[2], rgb[0], rgb[1], rgb[2]};
    size_t r = 0;
    for (; r + 4 <= m / 3; r += 4) {
        const v4f x = *(const v4f *)(const void *)(f + r);
        v4f *o = (v4f *)(void *)(sum + 3 * r);
        o[0] += __builtin_shufflevector(x, x, 0, 0, 0, 1) * ka;
        o[1] += __builtin_shufflevector(x, x, 1, 1, 2, 2) * kb;
        o[2] += __builtin_shufflevector(x, x, 2, 3, 3, 3) * kc;
    }
    for (; r < m / 3; r++)
        for (int c = 0; c < 3; c++)
            sum[3 * r + c] += rgb[c] * f[r];
}

/* emission[j] = rho[j] · sum[j] for m entries; nonzero when one is not finite (its bits
 * without the sign above FLT_MAX's: infinity or NaN), four a step */
static int scale_block(const float *rho, const float *sum, size_t m, float *emission)
{
    v4i bad = {0, 0, 0, 0};
    const v4i magnitude = {0x7fffffff, 0x7fffffff, 0x7fffffff, 0x7fffffff},
              finite_max = {0x7f7fffff, 0x7f7fffff, 0x7f7fffff, 0x7f7fffff};
    size_t j = 0;
    for (; j + 4 <= m; j += 4) {
        const v4f e = *(const v4f *)(const void *)(rho + j) * *(const v4f *)(const void *)(sum + j);
        *(v4f *)(void *)(emission + j) = e;
        bad |= ((v4i)e & magnitude) > finite_max;
    }
    int any = bad[0] | bad[1] | bad[2] | bad[3];
    for (; j < m; j++) {
        emission[j] = rho[j] * sum[j];
        any |= !isfinite(emission[j]);
    }
    return any != 0;
}

/* E = rho ∘ Σ_l H_l over the receivers [r0, r1) into emission (their rows), summed in
 * light order (float, as lrr_probe_direct_light), in blocks whose sums stay in the cache,
 * so that each light's slot is read as one stream; 1 where an entry overflows. */
static int sum_lights(const lrr_lighting *lt, const lrr__source *src, size_t count,
                      float *emission)
{
    const lrr_operator *op = lt->op;
    const size_t e0 = 3 * lt->r0, n3 = 3 * lt->r1 - e0;
    const size_t blocks = (n3 + SUM_BLOCK - 1) / SUM_BLOCK;
    int overflow = 0;
    #pragma omp parallel for schedule(static) reduction(| : overflow)
    for (size_t b = 0; b < blocks; b++) {
        const size_t j = b * SUM_BLOCK, m = j + SUM_BLOCK < n3 ? SUM_BLOCK : n3 - j;
        float sum[SUM_BLOCK];
        for (size_t i = 0; i < m; i++)
            sum[i] = 0.0f;
        for (size_t l = 0; l < count; l++)
            add_light(lt, &src[l], l, e0 + j, m, sum);
        overflow |= scale_block(op->rho + e0 + j, sum, m, emission + j);
    }
    return overflow;
}

/* The lights traced at the receivers [r0, r1) (those unchanged since the last call on the
 * same range kept) and their E into emission, (r1 − r0)×3. */
static lrr_status direct(lrr_lighting *lt, const lrr_light_source *lights, size_t count,
                         size_t r0, size_t r1, float *emission, const char *fn)
{
    if (count > 0 && !lights)
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG, "%s: lights is NULL with count %zu",
                          fn, count);
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
    if (r0 != lt->r0 || r1 != lt->r1) { /* the cache holds other receivers */
        lt->count = 0;
        lt->r0 = r0;
        lt->r1 = r1;
    }
    lt->rays = 0;
    size_t group[LRR__BUDGET_GROUP], m = 0;
    for (size_t l = 0; l < count; l++) {
        if (l < lt->count && memcmp(&lt->light[l], &lights[l], sizeof *lights) == 0)
            continue; /* unchanged: its irradiance is still in the cache */
        if (lt->tol > 0 && (src[l].kind == LRR_LIGHT_POINT || src[l].kind == LRR_LIGHT_SPOT)) {
            group[m++] = l; /* over the whole scene (lrr_lighting_direct alone) */
            if (m == LRR__BUDGET_GROUP) {
                trace_group(lt, src, group, m);
                m = 0;
            }
        } else
            trace(lt, &src[l], l);
        lt->light[l] = lights[l];
    }
    if (m)
        trace_group(lt, src, group, m);
    lt->count = count;
    if ((st = lrr__bvh_status(lt->ctx, &lt->bvh, "occlusion query"))) {
        lt->count = 0; /* the traced irradiance is not to be trusted */
        lrr_aligned_free(src);
        return st;
    }
    int overflow = sum_lights(lt, src, count, emission);
    lrr_aligned_free(src);
    if (overflow) {
        memset(emission, 0, 3 * (r1 - r0) * sizeof(float));
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG, "%s: the direct light overflows a "
                          "float", fn);
    }
    return LRR_OK;
}

lrr_status lrr_lighting_direct(lrr_lighting *lt, const lrr_light_source *lights, size_t count,
                               float *emission)
{
    return direct(lt, lights, count, 0, lt->op->n, emission, "lrr_lighting_direct");
}

lrr_status lrr_lighting_direct_rows(lrr_lighting *lt, const lrr_light_source *lights,
                                    size_t count, size_t row0, size_t rows, float *emission)
{
    static const char fn[] = "lrr_lighting_direct_rows";
    const size_t n = lt->op->n;
    if (row0 > n || rows > n - row0)
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG, "%s: rows [%zu, %zu + %zu) exceed the "
                          "operator's %zu subpatches", fn, row0, row0, rows, n);
    if (rows > 0 && !emission)
        return lrr__error(lt->ctx, LRR_ERR_INVALID_ARG, "%s: emission is NULL for %zu rows", fn,
                          rows);
    if (lt->tol > 0)
        return lrr__error(lt->ctx, LRR_ERR_UNSUPPORTED, "%s: the shadow rays' error budget "
                          "(lrr_lighting_set_tolerance %g) chooses its receivers over the "
                          "whole scene; set it to 0 for a range of rows", fn, lt->tol);
    return rows ? direct(lt, lights, count, row0, row0 + rows, emission, fn) : LRR_OK;
}
