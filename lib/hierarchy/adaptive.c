/* The adaptive patch hierarchy: which quadtree nodes become patches (docs/METHOD.md
 * "Adaptive patches" and "Adaptive selection"; issue 7).
 *
 * The low-rank model replaces the columns F_ij of the subpatches j of patch p by their mean
 * F_{i→p}/d_p, so the light row i gathers from p is off by
 *
 *     e_ip = Σ_{j∈p} (F_ij − F_{i→p}/d_p) B_j                      (per channel)
 *
 * which vanishes where F or B is constant over p and is large at shadow edges, contacts
 * and corners. Patches start as whole input triangles; the split (into the four children)
 * that most reduces Σ_i Σ_c rho_ic² (Σ_p e_ip)², the first-order error of B (its mean over
 * the receivers counted more, as the bounces amplify it), is taken until
 * the budget K is reached (LRR_SPLIT_VARIANCE), then pairs of merge and split are
 * exchanged while they lower it (exchange.c). Without emission (no B to weight with) the
 * score is the within-patch column variance V_p = Σ_i w_i Σ_{j∈p} (F_ij − mean)²,
 * w_i = Σ_c rho_ic², whose total never grows under a split. LRR_SPLIT_AREA splits the
 * largest patch: uniform subdivision at the same K, the baseline.
 *
 * Both are estimated from S receivers, one drawn from each of S equal runs of subpatch
 * indices: their full rows of F at subpatch resolution come from the same hemicube code
 * (same per-receiver rotation) and the estimate (n/S) Σ_{sampled i} is unbiased. B is
 * estimated from the emitters' rows (direct light, by reciprocity) and one bounce over the
 * sample (ffsample.c). A node's terms are computed when it is created, by passes
 * over its columns of the S rows, so the selection costs a few S·n per tree level on top
 * of the S hemicubes.
 */
#include "config.h"
#include "hierarchy/adaptive_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define DEFAULT_SAMPLES LRR__ADAPTIVE_DEFAULT_SAMPLES

/* ------------------------------------------------------------ the greedy split */
/* max-heap on (score, then area, then lower j0 first) */
static int above(const lrr__node *a, const lrr__node *b)
{
    if (a->score != b->score)
        return a->score > b->score;
    if (a->area != b->area)
        return a->area > b->area;
    return a->j0 < b->j0;
}

static void heap_push(lrr__node *h, size_t *len, lrr__node x)
{
    size_t i = (*len)++;
    while (i > 0 && above(&x, &h[(i - 1) / 2])) {
        h[i] = h[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    h[i] = x;
}

static lrr__node heap_pop(lrr__node *h, size_t *len)
{
    lrr__node top = h[0], x = h[--*len];
    size_t i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= *len)
            break;
        if (c + 1 < *len && above(&h[c + 1], &h[c]))
            c++;
        if (!above(&h[c], &x))
            break;
        h[i] = h[c];
        i = c;
    }
    if (*len)
        h[i] = x;
    return top;
}

static double node_area(const lrr__geometry *g, const lrr__node *x)
{
    return ldexp(lrr__tri_area(g->vert + 9 * (size_t)x->t), -2 * (int)x->depth);
}

/* x->own must be set; computes the children's V and the priority. */
static void score(const lrr__geometry *g, const lrr__ffsample *s, int split, lrr__node *x)
{
    x->area = node_area(g, x);
    if (split == LRR_SPLIT_AREA) {
        x->score = x->area;
        return;
    }
    x->score = x->own;
    if (x->depth >= g->depth[x->t])
        return; /* a subpatch: never split */
    const size_t quarter = lrr__node_size(g, x) / 4;
    for (size_t c = 0; c < 4; c++) {
        x->child[c] = lrr__ffsample_variance(s, x->j0 + c * quarter, x->j0 + (c + 1) * quarter,
                                             NULL);
        x->score -= x->child[c];
    }
}

/* d (3 per sampled row) = Σ_children e − e_x: what splitting x adds to the row errors T
 * (and merging its four children back into x subtracts). */
void lrr__node_delta(const lrr__geometry *g, const lrr__ffsample *s, const lrr__node *x,
                     double *d)
{
    const size_t size = lrr__node_size(g, x), quarter = size / 4;
    for (size_t r = 0; r < s->count; r++) {
        double e[3], ec[3];
        lrr__ffsample_row_error(s, r, x->j0, x->j0 + size, e);
        for (int c = 0; c < 3; c++)
            d[3 * r + c] = -e[c];
        for (size_t ch = 0; ch < 4; ch++) {
            lrr__ffsample_row_error(s, r, x->j0 + ch * quarter, x->j0 + (ch + 1) * quarter, ec);
            for (int c = 0; c < 3; c++)
                d[3 * r + c] += ec[c];
        }
    }
}

void lrr__delta_sum(const lrr__ffsample *s, const double *d, double D[3])
{
    D[0] = D[1] = D[2] = 0;
    for (size_t r = 0; r < s->count; r++)
        for (int c = 0; c < 3; c++)
            D[c] += s->rho[3 * r + c] * d[3 * r + c];
}

/* How much adding the delta d (sums D) to the row errors T lowers the objective
 * Σ rho² T² + bS Σ_c M_c²: the gain of a split. */
static double split_gain(const lrr__ffsample *s, const double *T, const double *d, double bS,
                         const double M[3], const double D[3])
{
    double gain = -lrr__mean_change(bS, M, D);
    for (size_t r = 0; r < 3 * s->count; r++)
        gain -= s->rho[r] * s->rho[r] * (2 * T[r] * d[r] + d[r] * d[r]);
    return gain;
}

int lrr__node_by_first(const void *a, const void *b)
{
    const lrr__node *x = a, *y = b;
    return (x->j0 > y->j0) - (x->j0 < y->j0);
}

/* The objective of the patches p[0..len) summed anew (tests: the exchanges' bookkeeping);
 * T (3 per sampled row, with radiosity weights) is overwritten. */
static double recompute(const lrr__geometry *g, const lrr__ffsample *s, int split,
                        const lrr__node *p, size_t len, double *T, double bS)
{
    double total = 0;
    if (split == LRR_SPLIT_AREA)
        return 0;
    if (!s->b) {
        for (size_t q = 0; q < len; q++)
            total +=
                lrr__ffsample_variance(s, p[q].j0, p[q].j0 + lrr__node_size(g, &p[q]), NULL);
        return total;
    }
    memset(T, 0, 3 * s->count * sizeof *T);
    for (size_t q = 0; q < len; q++)
        for (size_t r = 0; r < s->count; r++) {
            double e[3];
            lrr__ffsample_row_error(s, r, p[q].j0, p[q].j0 + lrr__node_size(g, &p[q]), e);
            for (int c = 0; c < 3; c++)
                T[3 * r + c] += e[c];
        }
    double M[3] = {0, 0, 0};
    for (size_t r = 0; r < 3 * s->count; r++) {
        total += s->rho[r] * s->rho[r] * T[r] * T[r];
        M[r % 3] += s->rho[r] * T[r];
    }
    for (int c = 0; c < 3; c++)
        total += bS * M[c] * M[c];
    return total;
}

/* ------------------------------------------------------------ the selection, step by step */
typedef struct {
    const lrr__geometry *g;
    int split;              /* LRR_SPLIT_VARIANCE or LRR_SPLIT_AREA */
    size_t K;               /* the budget of patches */
    lrr__ffsample s;        /* the sampled rows (LRR_SPLIT_VARIANCE), s.b the weights */
    int err_mode;           /* with radiosity weights: s.b != NULL */
    lrr__node *heap, *done; /* the nodes that may still split (a max-heap), the patches */
    size_t hl, dl, k;       /* their counts; k: the patches so far */
    uint8_t *depths;        /* the patches' depths in subpatch order */
    double total;           /* the objective over the current patches */
    /* with radiosity weights: 3 per sampled row, pool slots, the delta rows of the nodes
     * (a slot each), the row errors T, the delta sums, the mean term's sums M and weight */
    size_t S3, slots;
    double *pool, *T, *Dsum, M[3], bS;
    size_t *free_slots, nfree;
} selection;

static void selection_free(selection *sel)
{
    lrr_aligned_free(sel->heap);
    lrr_aligned_free(sel->done);
    lrr_aligned_free(sel->depths);
    lrr_aligned_free(sel->pool);
    lrr_aligned_free(sel->T);
    lrr_aligned_free(sel->Dsum);
    lrr_aligned_free(sel->free_slots);
    lrr__ffsample_free(&sel->s);
}

static lrr_status check_args(lrr_context *ctx, const lrr__geometry *g,
                             const lrr_build_options *opts)
{
    const size_t K = opts->adaptive_patches;
    const int split = opts->adaptive_split;
    if (split != LRR_SPLIT_VARIANCE && split != LRR_SPLIT_AREA)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "adaptive_split = %d: must be LRR_SPLIT_VARIANCE or LRR_SPLIT_AREA",
                          split);
    if (g->levels != 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "adaptive hierarchy: the scene's patches become the subpatches, so "
                          "it must be subdivided with levels = 0 (it has levels = %u)",
                          g->levels);
    if (K < g->n_tri || K > g->n)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "adaptive hierarchy: %zu patches requested; with %zu triangles and "
                          "%zu subpatches it must be between %zu and %zu",
                          K, g->n_tri, g->n, g->n_tri, g->n);
    if (g->n_tri > UINT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "adaptive hierarchy: %zu triangles (at most "
                          "2^32)", g->n_tri);
    return LRR_OK;
}

/* LRR_SPLIT_VARIANCE: the sampled rows of F, and the radiosity weights (the caller's, or
 * estimated when there is emission). */
static lrr_status take_sample(lrr_context *ctx, selection *sel, const float *rho,
                              const float *emission, const float *area, const double *weights,
                              const lrr_build_options *opts, lrr__rows_fn render)
{
    const lrr__geometry *g = sel->g;
    if (sel->split != LRR_SPLIT_VARIANCE)
        return LRR_OK;
    /* The sampled rows are rendered at a quarter of the resolution (at least 16): ranking
     * splits needs many rows more than exact ones. Measured on the Cornell box, n = 3456,
     * K = 864 (error of B against the n×n direct solve; uniform 7.6e-4): 256 rows at R =
     * 128 gave 7.3e-4, 512 rows 6.8e-4, 1024 rows at R = 64 3.4e-4, 1024 at R = 32 3.5e-4,
     * 2048 at R = 32 3.0e-4, for the cost of 64 to 128 full-resolution hemicubes. On the
     * office scene (n = 3908, K = 489 / 977) 1024 rows gave 0.57 / 0.48 of the uniform error,
     * 2048 rows 0.53 / 0.41 and all rows 0.54 / 0.40: 2048 is about as good as every row,
     * for about 9% of the build. Weighting the rows by area made it worse (0.66), a second
     * Monte Carlo bounce in the radiosity estimate changed nothing (0.524). */
    lrr_build_options so = *opts;
    unsigned R = opts->hemicube_resolution ? opts->hemicube_resolution : 128;
    so.hemicube_resolution = R / 4 < 16 ? (R < 16 ? R : 16) : (R / 4) & ~1u;
    lrr_status st;
    if ((st = lrr__ffsample_take(ctx, g, rho, &so, render,
                                 opts->adaptive_samples ? opts->adaptive_samples
                                                        : DEFAULT_SAMPLES, &sel->s)))
        return st;
    if (weights) {
        if ((st = lrr__calloc(ctx, &sel->s.b, g->n, 3 * sizeof(double), "radiosity weights")))
            return st;
        memcpy(sel->s.b, weights, g->n * 3 * sizeof(double));
    } else if (emission) {
        st = lrr__radiosity_weights(ctx, g, rho, emission, area, opts, render, &sel->s,
                                    &sel->s.b);
    }
    return st;
}

/* The heap and the patches; with radiosity weights the pool, T, the sums and the free
 * slots (all of them, the lowest on top). */
static lrr_status alloc_state(lrr_context *ctx, selection *sel)
{
    const size_t K = sel->K;
    /* With radiosity weights the split that most reduces Σ_r Σ_c rho_rc² T_rc² is taken,
     * T_r = Σ_p e_rp the first-order error of sampled row r over the current patches (errors
     * of different patches add or cancel in a row, so the gain of a split depends on T:
     * gains are re-evaluated lazily when they reach the top of the heap), plus
     * bS Σ_c M_c², M_c = Σ_r rho_rc T_rc (below). Each node keeps delta = Σ_children e −
     * e_node per sampled row in a pool slot, and Dsum_c = Σ_r rho_rc delta_rc. */
    sel->err_mode = sel->s.b != NULL;
    /* slots: the nodes in the heap, then the exchange's leaves and merge candidates */
    sel->S3 = 3 * sel->s.count;
    sel->slots = K + K / 4 + 8;
    const size_t S3 = sel->S3, slots = sel->slots;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &sel->heap, K, sizeof(lrr__node), "adaptive selection heap")) ||
        (st = lrr__calloc(ctx, &sel->done, K, sizeof(lrr__node),
                          "adaptive selection patches")) ||
        (st = lrr__calloc(ctx, &sel->depths, K, 1, "adaptive patch depths")))
        return st;
    if (sel->err_mode &&
        ((st = lrr__calloc(ctx, &sel->pool, slots, S3 * sizeof(double),
                           "adaptive error rows")) ||
         (st = lrr__calloc(ctx, &sel->T, S3, sizeof(double), "adaptive row errors")) ||
         (st = lrr__calloc(ctx, &sel->Dsum, slots, 3 * sizeof(double), "adaptive sums")) ||
         (st = lrr__calloc(ctx, &sel->free_slots, slots, sizeof(size_t), "adaptive slots"))))
        return st;
    for (size_t q = 0; q < slots && sel->err_mode; q++)
        sel->free_slots[sel->nfree++] = slots - 1 - q;
    return LRR_OK;
}

/* bS, the weight of the mean term. The first-order error R e of a row is propagated by
 * (I − R F̃)⁻¹: its mean over the receivers comes back about a = 1/(1 − q) times, q the
 * mean of ρ_i Σ_j F_ij (the light a row sends on in one bounce), while its fluctuations
 * largely average out in the next bounce. So the objective counts the per-channel mean of
 * the sampled ρ T a² times: Σ ρ² T² + (a² − 1)/S Σ_c (Σ_r ρ_rc T_rc)². Measured with
 * `lrr-bench adaptive` (n ≈ 4000; error / uniform error at K = 126, 252, 504, 1008 on
 * cornell and 244, 489, 977 on the office): without it 0.689 0.676 0.449 0.340 and 0.785
 * 0.516 0.353; with it (a² − 1 = 2.09 on cornell, 3.54 on the office) 0.697 0.641 0.445
 * 0.328 and 0.750 0.481 0.344; a fixed a² − 1 = 6 gave 0.693 0.622 0.430 0.330 and 0.750
 * 0.476 0.345. */
static double mean_amplification(const lrr__ffsample *s)
{
    double q = 0;
    for (size_t r = 0; r < s->count; r++) {
        double rowsum = 0;
        const float *f = s->f + r * s->n;
        for (size_t j = 0; j < s->n; j++)
            rowsum += f[j];
        q += rowsum * (s->rho[3 * r] + s->rho[3 * r + 1] + s->rho[3 * r + 2]) / 3;
    }
    q = fmin(q / (double)s->count, 0.99); /* rho < 1 and row sums <= 1 keep q below 1 */
    return (1 / ((1 - q) * (1 - q)) - 1) / (double)s->count;
}

/* Takes a pool slot for x (splittable), fills its delta and sums, and scores it by its
 * gain. */
static void node_gain(selection *sel, lrr__node *x)
{
    x->slot = sel->free_slots[--sel->nfree];
    double *dx = sel->pool + x->slot * sel->S3;
    lrr__node_delta(sel->g, &sel->s, x, dx);
    lrr__delta_sum(&sel->s, dx, sel->Dsum + 3 * x->slot);
    x->score = split_gain(&sel->s, sel->T, dx, sel->bS, sel->M, sel->Dsum + 3 * x->slot);
}

/* With radiosity weights: the roots' deltas and gains, now that T is complete, and the
 * objective. */
static void root_gains(selection *sel)
{
    const size_t S3 = sel->S3;
    for (size_t r = 0; r < S3; r++)
        sel->M[r % 3] += sel->s.rho[r] * sel->T[r];
    for (size_t q = 0; q < sel->hl; q++)
        node_gain(sel, &sel->heap[q]);
    /* re-heapify after the in-place score changes */
    size_t n0 = sel->hl;
    sel->hl = 0;
    for (size_t q = 0; q < n0; q++)
        heap_push(sel->heap, &sel->hl, sel->heap[q]);
    for (size_t r = 0; r < S3; r++)
        sel->total += sel->s.rho[r] * sel->s.rho[r] * sel->T[r] * sel->T[r];
    for (int c = 0; c < 3; c++)
        sel->total += sel->bS * sel->M[c] * sel->M[c];
}

/* The whole input triangles, the first patches: those with subpatches to split go into the
 * heap. */
static void seed_roots(selection *sel)
{
    const lrr__geometry *g = sel->g;
    sel->k = g->n_tri;
    for (size_t t = 0; t < g->n_tri; t++) {
        lrr__node x = {.j0 = g->sub0[t], .t = (uint32_t)t};
        if (sel->err_mode) {
            const size_t size = lrr__node_size(g, &x);
            for (size_t r = 0; r < sel->s.count; r++) {
                double e[3];
                lrr__ffsample_row_error(&sel->s, r, x.j0, x.j0 + size, e);
                for (int c = 0; c < 3; c++)
                    sel->T[3 * r + c] += e[c];
            }
        } else if (sel->split != LRR_SPLIT_AREA) {
            x.own = lrr__ffsample_variance(&sel->s, x.j0, x.j0 + lrr__node_size(g, &x), NULL);
        }
        if (!sel->err_mode) {
            score(g, &sel->s, sel->split, &x);
            sel->total += x.own;
        } else {
            x.area = node_area(g, &x);
        }
        if (g->depth[t] > 0)
            heap_push(sel->heap, &sel->hl, x);
        else
            sel->done[sel->dl++] = x;
    }
    if (sel->err_mode)
        root_gains(sel);
}

/* With radiosity weights, x just popped: returns 0 when its gain anew puts it back into the
 * heap; else takes the split into T, M and the objective and frees x's slot. */
static int take_split(selection *sel, lrr__node *x, size_t *reevaluations)
{
    /* lazy re-evaluation: T changed since x's gain was computed */
    const double *dx = sel->pool + x->slot * sel->S3;
    double gain = split_gain(&sel->s, sel->T, dx, sel->bS, sel->M, sel->Dsum + 3 * x->slot);
    if (sel->hl > 0 && gain < sel->heap[0].score && gain != x->score &&
        *reevaluations < 64 * sel->K) {
        x->score = gain;
        heap_push(sel->heap, &sel->hl, *x);
        (*reevaluations)++;
        return 0;
    }
    for (size_t r = 0; r < sel->S3; r++)
        sel->T[r] += dx[r];
    for (int c = 0; c < 3; c++)
        sel->M[c] += sel->Dsum[3 * x->slot + c];
    sel->total -= gain;
    sel->free_slots[sel->nfree++] = x->slot;
    return 1;
}

/* x's four children: scored, into the heap, or patches when they are subpatches. */
static void add_children(selection *sel, const lrr__node *x)
{
    const lrr__geometry *g = sel->g;
    size_t quarter = lrr__node_size(g, x) / 4;
    for (size_t c = 0; c < 4; c++) {
        lrr__node y = {.own = x->child[c], .j0 = x->j0 + c * quarter, .t = x->t,
                       .depth = (uint8_t)(x->depth + 1)};
        if (!sel->err_mode) {
            score(g, &sel->s, sel->split, &y);
            sel->total += y.own;
        } else {
            y.area = node_area(g, &y);
            if (y.depth < g->depth[y.t])
                node_gain(sel, &y);
        }
        if (y.depth < g->depth[y.t])
            heap_push(sel->heap, &sel->hl, y);
        else
            sel->done[sel->dl++] = y;
    }
}

/* Splits the best node until the budget K is spent (a split adds 3 patches) or nothing is
 * left to split; objective (may be NULL) gets the objective after each split. */
static void greedy(selection *sel, double *objective)
{
    size_t reevaluations = 0;
    while (sel->k + 3 <= sel->K && sel->hl > 0) {
        lrr__node x = heap_pop(sel->heap, &sel->hl);
        if (!sel->err_mode)
            sel->total -= x.own;
        else if (!take_split(sel, &x, &reevaluations))
            continue;
        add_children(sel, &x);
        sel->k += 3;
        if (objective)
            objective[(sel->k - sel->g->n_tri) / 3] = sel->total;
    }
    while (sel->hl > 0)
        sel->done[sel->dl++] = heap_pop(sel->heap, &sel->hl);
}

/* With radiosity weights: the exchange refinement of the greedy's patches (exchange.c). */
static lrr_status exchange_phase(lrr_context *ctx, selection *sel, lrr__adaptive_trace *trace)
{
    lrr__xchg X = {.g = sel->g, .s = &sel->s, .S3 = sel->S3, .nslots = sel->slots,
                   .pool = sel->pool, .T = sel->T, .free_slots = sel->free_slots,
                   .nfree = sel->nfree, .leaf = sel->done, .nleaf = sel->dl, .M = sel->M,
                   .bS = sel->bS, .Dsum = sel->Dsum};
    size_t made;
    lrr_status st = lrr__exchange(ctx, &X, &sel->total, sel->K, &made);
    if (st)
        return st;
    if (trace)
        trace->exchanges = made;
    sel->dl = X.nleaf;
    return LRR_OK;
}

/* The patches in subpatch order, their geometry. */
static lrr_status build_result(lrr_context *ctx, selection *sel, lrr__adaptive_trace *trace,
                               lrr__geometry *out)
{
    qsort(sel->done, sel->dl, sizeof *sel->done, lrr__node_by_first);
    for (size_t p = 0; p < sel->dl; p++)
        sel->depths[p] = sel->done[p].depth;
    if (trace) {
        trace->exchanged = sel->total;
        trace->recomputed =
            recompute(sel->g, &sel->s, sel->split, sel->done, sel->dl, sel->T, sel->bS);
    }
    return lrr__geometry_adaptive(ctx, sel->g, sel->depths, sel->dl, "adaptive hierarchy",
                                  LRR_ERR_INVALID_ARG, out);
}

lrr_status lrr__adaptive_select(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                                const float *emission, const float *area,
                                const double *weights, const lrr_build_options *opts,
                                lrr__rows_fn render, lrr__geometry *out,
                                lrr__adaptive_trace *trace)
{
    double *objective = trace ? trace->objective : NULL;
    memset(out, 0, sizeof *out);
    lrr_status st = check_args(ctx, g, opts);
    if (st)
        return st;
    selection sel = {.g = g, .split = opts->adaptive_split, .K = opts->adaptive_patches};
    if (!(st = take_sample(ctx, &sel, rho, emission, area, weights, opts, render)) &&
        !(st = alloc_state(ctx, &sel))) {
        if (sel.err_mode)
            sel.bS = mean_amplification(&sel.s);
        seed_roots(&sel);
        if (objective)
            objective[0] = sel.total;
        greedy(&sel, objective);
        if (trace)
            trace->greedy = sel.total;
        if (!sel.err_mode || !(st = exchange_phase(ctx, &sel, trace)))
            st = build_result(ctx, &sel, trace, out);
    }
    selection_free(&sel);
    return st;
}
