/* The hemicube's pixel → leaf step for four pixels at once (AVX2, chosen at run time by
 * lrr__hemi_simd). Four consecutive pixels of a row that show the same triangle go through
 * the scalar path's exact sequence of IEEE operations (no FMA contraction: separate multiply
 * and add intrinsics), lane by lane, so the leaves, and F̄, are bit-identical to it:
 *   sx = (x + 0.5) / half − 1;  r = 1 / (den·(sx, sy, 1));  b_j = (num_j·(sx, sy, 1)) · r;
 *   clamp (lrr__clamp_bary), then `depth` levels of lrr__child_at as selects.
 * Measured on the Cornell box (R 64, one thread): see hemicube.c's integrate_face. */
#include "config.h"
#include "formfactor/hemicube_private.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>

int lrr__hemi_simd(void)
{
    const char *force = getenv("LRR_SIMD"); /* "c": the scalar path, as for the solver */
    if (force && strcmp(force, "c") == 0)
        return 0;
    __builtin_cpu_init();
    return __builtin_cpu_supports("avx2");
}

/* a·sx + b·sy + c, multiplied and added in the scalar path's order */
__attribute__((target("avx2"))) static inline __m256d lin(const double k[3], __m256d sx,
                                                          __m256d sy)
{
    return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(_mm256_set1_pd(k[0]), sx),
                                       _mm256_mul_pd(_mm256_set1_pd(k[1]), sy)),
                         _mm256_set1_pd(k[2]));
}

__attribute__((target("avx2"))) void lrr__hemi_leaves4(const double b1k[3],
                                                       const double b2k[3],
                                                       const double denk[3], double half,
                                                       double sy_, int xx, unsigned depth,
                                                       size_t leaf[4])
{
    const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd(),
                  halfv = _mm256_set1_pd(0.5);
    __m256d x = _mm256_cvtepi32_pd(_mm_add_epi32(_mm_set1_epi32(xx), _mm_setr_epi32(0, 1, 2, 3)));
    __m256d sx = _mm256_sub_pd(_mm256_div_pd(_mm256_add_pd(x, halfv), _mm256_set1_pd(half)), one);
    __m256d sy = _mm256_set1_pd(sy_);
    __m256d r = _mm256_div_pd(one, lin(denk, sx, sy));
    __m256d b1 = _mm256_mul_pd(lin(b1k, sx, sy), r), b2 = _mm256_mul_pd(lin(b2k, sx, sy), r);
    /* lrr__clamp_bary: !(b > 0) → 0 (NaN too), b > 1 → 1, then b0 < 0 → renormalise */
    b1 = _mm256_and_pd(b1, _mm256_cmp_pd(b1, zero, _CMP_GT_OQ));
    b2 = _mm256_and_pd(b2, _mm256_cmp_pd(b2, zero, _CMP_GT_OQ));
    b1 = _mm256_blendv_pd(b1, one, _mm256_cmp_pd(b1, one, _CMP_GT_OQ));
    b2 = _mm256_blendv_pd(b2, one, _mm256_cmp_pd(b2, one, _CMP_GT_OQ));
    __m256d b0 = _mm256_sub_pd(_mm256_sub_pd(one, b1), b2);
    __m256d neg = _mm256_cmp_pd(b0, zero, _CMP_LT_OQ);
    if (_mm256_movemask_pd(neg)) {
        __m256d s = _mm256_add_pd(b1, b2);
        b1 = _mm256_blendv_pd(b1, _mm256_div_pd(b1, s), neg);
        b2 = _mm256_blendv_pd(b2, _mm256_div_pd(b2, s), neg);
        b0 = _mm256_blendv_pd(b0, zero, neg);
    }
    /* lrr__child_at per level: the first of u, v, w that is >= 0.5 picks the corner child
     * (that coordinate 2t − 1, the others 2t), none picks the middle one (1 − 2t each) */
    __m256d idx = zero;
    const __m256d four = _mm256_set1_pd(4.0), two = _mm256_set1_pd(2.0),
                  c1 = one, c2 = _mm256_set1_pd(2.0), c3 = _mm256_set1_pd(3.0);
    for (unsigned l = 0; l < depth; l++) {
        __m256d m0 = _mm256_cmp_pd(b0, halfv, _CMP_GE_OQ);
        __m256d m1 = _mm256_andnot_pd(m0, _mm256_cmp_pd(b1, halfv, _CMP_GE_OQ));
        __m256d m2 = _mm256_andnot_pd(_mm256_or_pd(m0, m1), _mm256_cmp_pd(b2, halfv, _CMP_GE_OQ));
        __m256d m3 = _mm256_andnot_pd(_mm256_or_pd(_mm256_or_pd(m0, m1), m2),
                                      _mm256_castsi256_pd(_mm256_set1_epi64x(-1)));
        __m256d u2 = _mm256_mul_pd(two, b0), v2 = _mm256_mul_pd(two, b1),
                w2 = _mm256_mul_pd(two, b2);
        b0 = _mm256_blendv_pd(_mm256_blendv_pd(u2, _mm256_sub_pd(u2, one), m0),
                              _mm256_sub_pd(one, u2), m3);
        b1 = _mm256_blendv_pd(_mm256_blendv_pd(v2, _mm256_sub_pd(v2, one), m1),
                              _mm256_sub_pd(one, v2), m3);
        b2 = _mm256_blendv_pd(_mm256_blendv_pd(w2, _mm256_sub_pd(w2, one), m2),
                              _mm256_sub_pd(one, w2), m3);
        __m256d c = _mm256_or_pd(_mm256_and_pd(m1, c1),
                                 _mm256_or_pd(_mm256_and_pd(m2, c2), _mm256_and_pd(m3, c3)));
        idx = _mm256_add_pd(_mm256_mul_pd(idx, four), c); /* exact: < 2^53 */
    }
    double out[4];
    _mm256_storeu_pd(out, idx);
    for (int j = 0; j < 4; j++)
        leaf[j] = (size_t)out[j];
}
#else
int lrr__hemi_simd(void) { return 0; }
void lrr__hemi_leaves4(const double b1k[3], const double b2k[3], const double denk[3],
                       double half, double sy, int xx, unsigned depth, size_t leaf[4])
{
    (void)b1k, (void)b2k, (void)denk, (void)half, (void)sy, (void)xx, (void)depth, (void)leaf;
}
#endif
