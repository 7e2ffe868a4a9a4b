/* The AVX2 variant of the budget's keys (budget.c): a point light's unshadowed weight
 * cos / r² and its key's bin for 8 receivers at a time, where the C loop waits on a square
 * root and a division per receiver. Chosen once per lighting (lib/core/cpu.h). */
#include "config.h"
#include "light/light.h"

#include <immintrin.h>

__attribute__((target("avx2"))) void lrr__budget_point_keys_avx2(const lrr__budget_receivers *r,
                                                                size_t i0, size_t i1,
                                                                const float p[3], float *g,
                                                                uint16_t *bin)
{
    const __m256 px = _mm256_set1_ps(p[0]), py = _mm256_set1_ps(p[1]),
                 pz = _mm256_set1_ps(p[2]), zero = _mm256_setzero_ps(),
                 third = _mm256_set1_ps(1.0f / 3);
    const __m256i last = _mm256_set1_epi32(LRR__BUDGET_BINS - 1),
                  dark = _mm256_set1_epi32(LRR__BUDGET_DARK);
    size_t i = i0;
    for (; i + 8 <= i1; i += 8) {
        __m256 w0 = _mm256_sub_ps(px, _mm256_loadu_ps(r->x + i));
        __m256 w1 = _mm256_sub_ps(py, _mm256_loadu_ps(r->y + i));
        __m256 w2 = _mm256_sub_ps(pz, _mm256_loadu_ps(r->z + i));
        /* no FMA, the C loop's order: both give the same g to the bit */
        __m256 r2 = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(w0, w0), _mm256_mul_ps(w1, w1)),
                                  _mm256_mul_ps(w2, w2));
        __m256 c = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_loadu_ps(r->nx + i), w0),
                                               _mm256_mul_ps(_mm256_loadu_ps(r->ny + i), w1)),
                                 _mm256_mul_ps(_mm256_loadu_ps(r->nz + i), w2));
        __m256 ok = _mm256_and_ps(_mm256_cmp_ps(c, zero, _CMP_GT_OQ),
                                  _mm256_cmp_ps(r2, zero, _CMP_GT_OQ));
        __m256 gi = _mm256_and_ps(_mm256_div_ps(c, _mm256_mul_ps(r2, _mm256_sqrt_ps(r2))), ok);
        _mm256_storeu_ps(g + i, gi);
        __m256 ar = _mm256_add_ps(_mm256_add_ps(_mm256_loadu_ps(r->ar[0] + i),
                                                _mm256_loadu_ps(r->ar[1] + i)),
                                  _mm256_loadu_ps(r->ar[2] + i));
        __m256 key = _mm256_mul_ps(_mm256_mul_ps(_mm256_mul_ps(gi, gi), ar), third);
        __m256i b = _mm256_sub_epi32(last, _mm256_srli_epi32(_mm256_castps_si256(key), 22));
        /* DARK where g is not > 0 (g may be 0 where ok: an underflow) */
        __m256i lit = _mm256_castps_si256(_mm256_cmp_ps(gi, zero, _CMP_GT_OQ));
        b = _mm256_blendv_epi8(dark, b, lit);
        __m128i packed = _mm_packus_epi32(_mm256_castsi256_si128(b), _mm256_extracti128_si256(b, 1));
        _mm_storeu_si128((__m128i *)(bin + i), packed);
    }
    lrr__budget_point_keys(r, i, i1, p, g, bin);
}
