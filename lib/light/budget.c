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
 * key and log2, 2.0 in one pass, 1.25 with the point's weight in float (point_g). */
static uint16_t key_bin(double key)
{
    float f = (float)key; /* >= 0; beyond float's range: +inf, the first bin */
    uint32_t bits;
    memcpy(&bits, &f, sizeof bits);
    return (uint16_t)(LRR__BUDGET_BINS - 1 - (bits >> 22));
}

/* A point light's unshadowed weight cos / r² in float, for the key and the guessed
 * receivers (the traced ones get lrr__source_weight's double from their rays). */
static inline float point_g(const float p[3], const float *x, const float *nv)
{
    float w0 = p[0] - x[0], w1 = p[1] - x[1], w2 = p[2] - x[2];
    float r2 = w0 * w0 + w1 * w1 + w2 * w2, c = nv[0] * w0 + nv[1] * w1 + nv[2] * w2;
    return c > 0 && r2 > 0 ? c / (r2 * sqrtf(r2)) : 0.0f;
}

void lrr__budget_weigh(const lrr_operator *op, const lrr__source *s, double *g, uint16_t *bin,
                       lrr__budget_cost cost)
{
    double *flat = &cost[0][0];
    memset(flat, 0, sizeof(lrr__budget_cost));
    const float p[3] = {(float)s->p[0], (float)s->p[1], (float)s->p[2]};
    const int point = s->kind == LRR_LIGHT_POINT;
    #pragma omp parallel for schedule(static) reduction(+ : flat[:LRR__BUDGET_BINS * 3])
    for (size_t i = 0; i < op->n; i++) {
        const float *x = op->centre + 3 * i, *nv = op->normal + 3 * i;
        g[i] = point ? point_g(p, x, nv) : lrr__source_weight(s, x, nv);
        if (!(g[i] > 0)) {
            bin[i] = LRR__BUDGET_DARK;
            continue;
        }
        const float *rho = op->rho + 3 * i;
        double ag2 = op->area[i] * g[i] * g[i], c[3];
        for (int k = 0; k < 3; k++)
            c[k] = ag2 * rho[k] * rho[k];
        uint16_t b = key_bin((c[0] + c[1] + c[2]) / 3);
        bin[i] = b;
        for (int k = 0; k < 3; k++)
            flat[3 * b + k] += c[k];
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
