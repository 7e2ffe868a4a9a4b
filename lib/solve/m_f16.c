/* M_c as a full frame reads it when F̄ is held in 16 bits (docs/METHOD.md "Real-time step"):
 *     z_c = w_c + s_c ∘ (H_c w_c),   H_c[i][p] = binary16((M_c[i][p] − δ_ip) / s_c[i])
 * with s_c[i] the power of two of a 16-bit F̄ row (lrr__f16_scale). M = Σ_j (Vᵀ diag(ρ) F̄)^j
 * is the identity plus the light of one bounce and more: held apart, the identity stays exact
 * and the row scale fits the bounces, which binary16's 11-bit mantissa then keeps to 2^-12
 * relative. A frame at k = 3456 reads 72 MB of M instead of 143 MB (F̄ in f16: 96 MB).
 *
 * Why only with 16-bit F̄: this M's rounding must stay small beside F̄'s own. Measured on the
 * closed Cornell box (k 600, every patch emitting; B rel L2, tests/solve/test_m_f16.c, which
 * asserts a fifth at most): f16 F̄ 2.3e-5 against the f32 operator, M − I in binary16 adds
 * 2.9e-6; bf16 F̄ 1.6e-4, adds 3.4e-6. With f32 F̄ it would be the larger error. */
#include "config.h"
#include "solve/solve.h"

#include <math.h>
#include <stdlib.h>

void lrr__m_f16_destroy(lrr__m_f16 *m)
{
    if (!m)
        return;
    lrr_aligned_free(m->val);
    lrr_aligned_free(m->scale);
    free(m);
}

/* row i of channel c: its scale, then its codes */
static void encode_row(const float *row, size_t i, size_t k, uint16_t *code, float *scale)
{
    float mx = 0;
    for (size_t p = 0; p < k; p++)
        mx = fmaxf(mx, fabsf(row[p] - (p == i ? 1.0f : 0.0f)));
    const float s = lrr__f16_scale(mx);
    *scale = s;
    for (size_t p = 0; p < k; p++)
        code[p] = lrr__f32_to_f16((row[p] - (p == i ? 1.0f : 0.0f)) / s);
}

lrr_status lrr__m_f16_create(const lrr_operator *op, lrr__m_f16 **out)
{
    lrr_context *ctx = op->ctx;
    const size_t k = op->k, rows = 3 * k;
    *out = NULL;
    lrr__m_f16 *m = lrr__zalloc(ctx, sizeof *m);
    if (!m)
        return lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate M in binary16");
    lrr_status st;
    size_t kk;
    if (!lrr__mul_size(k, k, &kk))
        st = lrr__error(ctx, LRR_ERR_OVERFLOW, "M of k = %zu overflows", k);
    else if (!(st = lrr__calloc(ctx, &m->val, 3 * kk, sizeof(uint16_t),
                                "M − I (3×k×k 16-bit)")))
        st = lrr__calloc(ctx, &m->scale, rows, sizeof(float), "M − I row scales");
    if (st) {
        lrr__m_f16_destroy(m);
        return st;
    }
    m->k = k;
    #pragma omp parallel for schedule(static) if (3 * kk >= LRR__PARALLEL_MIN)
    for (size_t r = 0; r < rows; r++)
        encode_row(op->m + r * k, r % k, k, m->val + r * k, m->scale + r);
    *out = m;
    return LRR_OK;
}

size_t lrr__m_f16_bytes(size_t k)
{
    return 3 * k * k * sizeof(uint16_t) + 3 * k * sizeof(float);
}
