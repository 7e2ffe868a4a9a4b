/* The error budget of a point or spot light's shadow rays (docs/METHOD.md "Lights"): which
 * receivers carry so little of the light that a guessed visibility keeps the frame within
 * the tolerance. The bound: a receiver whose ray is skipped is wrong by at most its
 * unshadowed ρ_c g (visible when occluded or the reverse), so over the skipped set the
 * area-weighted squared error of ρ_c∘H is at most Σ a ρ_c² g², and it is held below tol²
 * times the traced receivers' exact Σ a ρ_c² H², a part of the whole. */
#include "config.h"
#include "light/light.h"

#include <math.h>
#include <string.h>

/* The key's bin: the top 9 bits of its float below the sign (exponent and first mantissa
 * bit: half octaves), largest first. A float's bits grow with its value, so a larger key
 * never gets a later bin, in one pass with neither a logarithm nor the largest key first.
 * Weighing Sponza's 265k receivers for one point light: 2.2 ms with a pass for the largest
 * key and log2, 2.0 in one pass, 1.25 with the point's weight in float. */
static uint16_t key_bin(float f) /* f >= 0; beyond float's range: +inf, the first bin */
{
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    return (uint16_t)(LRR__BUDGET_BINS - 1 - (bits >> 22));
}

lrr_status lrr__budget_receivers_init(lrr_context *ctx, const lrr_operator *op,
                                      lrr__budget_receivers *r)
{
    const size_t n = op->n;
    float *all;
    lrr_status st = lrr__calloc(ctx, &all, 9 * (n > 0 ? n : 1), sizeof *all,
                                "the light budget's receivers (9 floats each)");
    if (st)
        return st;
    float **col[9] = {&r->x, &r->y, &r->z, &r->nx, &r->ny, &r->nz, &r->ar[0], &r->ar[1],
                      &r->ar[2]};
    for (int c = 0; c < 9; c++)
        *col[c] = all + c * n;
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        for (int j = 0; j < 3; j++) {
            (*col[j])[i] = op->centre[3 * i + j];
            (*col[3 + j])[i] = op->normal[3 * i + j];
            r->ar[j][i] = op->area[i] * op->rho[3 * i + j] * op->rho[3 * i + j];
        }
    return LRR_OK;
}

void lrr__budget_receivers_free(lrr__budget_receivers *r)
{
    lrr_aligned_free(r->x);
    memset(r, 0, sizeof *r);
}

void lrr__budget_point_keys(const lrr__budget_receivers *r, size_t i0, size_t i1,
                            const float p[3], float *g, uint16_t *bin)
{
    for (size_t i = i0; i < i1; i++) {
        const float w0 = p[0] - r->x[i], w1 = p[1] - r->y[i], w2 = p[2] - r->z[i];
        const float r2 = w0 * w0 + w1 * w1 + w2 * w2;
        const float c = r->nx[i] * w0 + r->ny[i] * w1 + r->nz[i] * w2;
        const float gi = c > 0 && r2 > 0 ? c / (r2 * sqrtf(r2)) : 0.0f;
        g[i] = gi;
        bin[i] = gi > 0 ? key_bin(gi * gi * (r->ar[0][i] + r->ar[1][i] + r->ar[2][i]) *
                                  (1.0f / 3))
                        : LRR__BUDGET_DARK;
    }
}

/* A spot light (cone and all) on receivers [i0, i1), as lrr__budget_point_keys. */
static void spot_keys(const lrr_operator *op, const lrr__budget_receivers *r,
                      const lrr__source *s, size_t i0, size_t i1, float *g, uint16_t *bin)
{
    for (size_t i = i0; i < i1; i++) {
        const float gi = (float)lrr__source_weight(s, op->centre + 3 * i, op->normal + 3 * i);
        g[i] = gi;
        bin[i] = gi > 0 ? key_bin(gi * gi * (r->ar[0][i] + r->ar[1][i] + r->ar[2][i]) *
                                  (1.0f / 3))
                        : LRR__BUDGET_DARK;
    }
}

/* The costs of receivers [i0, i1) added to cost (a flattened lrr__budget_cost): a receiver
 * may be wrong by ρ_c g, a ρ_c² g² squared and weighed. */
static void add_costs(const lrr__budget_receivers *r, size_t i0, size_t i1, const float *g,
                      const uint16_t *bin, double *cost)
{
    for (size_t i = i0; i < i1; i++)
        if (bin[i] != LRR__BUDGET_DARK) {
            const float g2 = g[i] * g[i];
            double *c = cost + 3 * bin[i];
            c[0] += g2 * r->ar[0][i];
            c[1] += g2 * r->ar[1][i];
            c[2] += g2 * r->ar[2][i];
        }
}

/* One pass over the receivers, in spans that stay in the cache, for up to
 * LRR__BUDGET_GROUP lights. Sponza, 265k receivers, 4 point lights, one Zen 5 core, ms a
 * frame: 14 with each light weighed alone, in double, from the operator's n×3 arrays; 4.6
 * in one pass over lrr__budget_receivers in C; 2.3 with AVX2 (best of 30). */
#define WEIGH_SPAN 512
void lrr__budget_weigh(const lrr_operator *op, const lrr__budget_receivers *r,
                       const lrr__source *s, size_t m, float *const *g, uint16_t *const *bin,
                       lrr__budget_cost *cost, int avx2)
{
    double *flat = &cost[0][0][0];
    const size_t len = m * LRR__BUDGET_BINS * 3, spans = (op->n + WEIGH_SPAN - 1) / WEIGH_SPAN;
    float p[LRR__BUDGET_GROUP][3];
    for (size_t l = 0; l < m; l++)
        for (int j = 0; j < 3; j++)
            p[l][j] = (float)s[l].p[j];
    memset(flat, 0, len * sizeof *flat);
    #pragma omp parallel for schedule(static) reduction(+ : flat[:len])
    for (size_t sp = 0; sp < spans; sp++) {
        const size_t i0 = sp * WEIGH_SPAN, i1 = i0 + WEIGH_SPAN < op->n ? i0 + WEIGH_SPAN : op->n;
        for (size_t l = 0; l < m; l++) {
            if (s[l].kind != LRR_LIGHT_POINT)
                spot_keys(op, r, &s[l], i0, i1, g[l], bin[l]);
            else if (avx2)
                lrr__budget_point_keys_avx2(r, i0, i1, p[l], g[l], bin[l]);
            else
                lrr__budget_point_keys(r, i0, i1, p[l], g[l], bin[l]);
            add_costs(r, i0, i1, g[l], bin[l], flat + l * LRR__BUDGET_BINS * 3);
        }
    }
}

unsigned lrr__budget_cut(const lrr__budget_cost cost, double tol, const double *S)
{
    /* from the smallest keys up: the tail that may be guessed grows while it fits */
    double tail[3] = {0, 0, 0}, head[3] = {0, 0, 0};
    for (unsigned b = 0; b < LRR__BUDGET_BINS; b++)
        for (int c = 0; c < 3; c++)
            head[c] += cost[b][c];
    unsigned T = LRR__BUDGET_BINS;
    while (T > 0) {
        int fits = 1;
        for (int c = 0; c < 3; c++) {
            double t = tail[c] + cost[T - 1][c], h = S ? S[c] : head[c] - cost[T - 1][c];
            fits &= t <= tol * tol * h;
        }
        if (!fits)
            break;
        T--;
        for (int c = 0; c < 3; c++) {
            tail[c] += cost[T][c];
            head[c] -= cost[T][c];
        }
    }
    return T;
}
