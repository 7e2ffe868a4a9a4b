/* The hemicube's per-pixel steps four pixels at once (AVX2, chosen at run time by
 * lrr__hemi_simd), each the scalar path's exact sequence of IEEE operations (no FMA
 * contraction: separate multiply and add intrinsics) lane by lane, so the leaves, the depth
 * ties, and F̄ are bit-identical to it:
 *   - a run's leaves: sx = (x + 0.5) / half − 1 (hemi_ctx.sx); r = 1 / (den·(sx, sy, 1));
 *     b_j = (num_j·(sx, sy, 1)) · r; clamp (lrr__clamp_bary); then the cell table where its
 *     margin allows (hemicube.c, "leaves of a row"), else `depth` levels of lrr__child_at
 *     as selects;
 *   - a span's depth test: three edge functions, 1/z, the float compare (raster_tri).
 * Measured in docs/METHOD.md "Form factors" and the commits that brought each step. */
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

/* lrr__descend's leaves of four lanes of barycentrics, as selects */
__attribute__((target("avx2"))) static inline __m256d descend4(__m256d b0, __m256d b1,
                                                               __m256d b2, unsigned depth)
{
    const __m256d one = _mm256_set1_pd(1.0), halfv = _mm256_set1_pd(0.5);
    /* lrr__child_at per level: the first of u, v, w that is >= 0.5 picks the corner child
     * (that coordinate 2t − 1, the others 2t), none picks the middle one (1 − 2t each) */
    __m256d idx = _mm256_setzero_pd();
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
    return idx;
}

__attribute__((target("avx2"))) void lrr__hemi_leaves_run(const double b1k[3],
                                                         const double b2k[3],
                                                         const double denk[3],
                                                         const double *sxt, double sy, int a,
                                                         int b, unsigned depth,
                                                         const uint16_t *cells, uint32_t *leaf)
{
    const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd();
    /* k·(sx, sy, 1) = (k0·sx + k1·sy) + k2: k1·sy is the same product at every pixel */
    const __m256d d0 = _mm256_set1_pd(denk[0]), d1 = _mm256_set1_pd(denk[1] * sy),
                  d2 = _mm256_set1_pd(denk[2]), p0 = _mm256_set1_pd(b1k[0]),
                  p1 = _mm256_set1_pd(b1k[1] * sy), p2 = _mm256_set1_pd(b1k[2]),
                  q0 = _mm256_set1_pd(b2k[0]), q1 = _mm256_set1_pd(b2k[1] * sy),
                  q2 = _mm256_set1_pd(b2k[2]);
    const double s = (double)((uint64_t)1 << depth);
    const __m256d sv = _mm256_set1_pd(s), need = _mm256_set1_pd(0x1p-40 * s),
                  up = _mm256_set1_pd(s - 1), down = _mm256_set1_pd(s - 2);
    for (int x = a; x <= b; x += 4) {
        __m256d sx;
        if (x + 3 <= b)
            sx = _mm256_loadu_pd(sxt + x);
        else /* past the run: repeat its last pixel, whose leaf is dropped */
            sx = _mm256_setr_pd(sxt[x], sxt[x + 1 <= b ? x + 1 : b], sxt[x + 2 <= b ? x + 2 : b],
                                sxt[b]);
        __m256d r = _mm256_div_pd(one, _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(d0, sx), d1), d2));
        __m256d b1 = _mm256_mul_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(p0, sx), p1), p2), r);
        __m256d b2 = _mm256_mul_pd(_mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(q0, sx), q1), q2), r);
        /* lrr__clamp_bary: !(b > 0) → 0 (NaN too), b > 1 → 1, then b0 < 0 → renormalise */
        b1 = _mm256_and_pd(b1, _mm256_cmp_pd(b1, zero, _CMP_GT_OQ));
        b2 = _mm256_and_pd(b2, _mm256_cmp_pd(b2, zero, _CMP_GT_OQ));
        b1 = _mm256_blendv_pd(b1, one, _mm256_cmp_pd(b1, one, _CMP_GT_OQ));
        b2 = _mm256_blendv_pd(b2, one, _mm256_cmp_pd(b2, one, _CMP_GT_OQ));
        __m256d b0 = _mm256_sub_pd(_mm256_sub_pd(one, b1), b2);
        __m256d neg = _mm256_cmp_pd(b0, zero, _CMP_LT_OQ);
        if (_mm256_movemask_pd(neg)) {
            __m256d sum = _mm256_add_pd(b1, b2);
            b1 = _mm256_blendv_pd(b1, _mm256_div_pd(b1, sum), neg);
            b2 = _mm256_blendv_pd(b2, _mm256_div_pd(b2, sum), neg);
            b0 = _mm256_blendv_pd(b0, zero, neg);
        }
        uint32_t out[4];
        int done = 0;
        if (cells) { /* the cell's leaf from the table, where the margin allows (hemicube.c) */
            __m256d t0 = _mm256_mul_pd(b0, sv), t1 = _mm256_mul_pd(b1, sv),
                    t2 = _mm256_mul_pd(b2, sv);
            __m256d i0 = _mm256_round_pd(t0, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC),
                    i1 = _mm256_round_pd(t1, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC),
                    i2 = _mm256_round_pd(t2, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
            __m256d f0 = _mm256_sub_pd(t0, i0), f1 = _mm256_sub_pd(t1, i1),
                    f2 = _mm256_sub_pd(t2, i2);
            __m256d m = _mm256_min_pd(_mm256_min_pd(_mm256_min_pd(f0, _mm256_sub_pd(one, f0)),
                                                    _mm256_min_pd(f1, _mm256_sub_pd(one, f1))),
                                      _mm256_min_pd(f2, _mm256_sub_pd(one, f2)));
            __m256d sum = _mm256_add_pd(_mm256_add_pd(i0, i1), i2);
            __m256d isdown = _mm256_cmp_pd(sum, down, _CMP_EQ_OQ);
            __m256d ok = _mm256_and_pd(
                _mm256_and_pd(_mm256_cmp_pd(m, need, _CMP_GE_OQ),
                              _mm256_or_pd(_mm256_cmp_pd(sum, up, _CMP_EQ_OQ), isdown)),
                _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(b0, zero, _CMP_GT_OQ),
                                            _mm256_cmp_pd(b1, zero, _CMP_GT_OQ)),
                              _mm256_cmp_pd(b2, zero, _CMP_GT_OQ)));
            if (_mm256_movemask_pd(ok) == 15) {
                __m256d cell = _mm256_add_pd(
                    _mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(i1, sv), i2), _mm256_set1_pd(2.0)),
                    _mm256_and_pd(isdown, one));
                int ci[4];
                _mm_storeu_si128((__m128i *)ci, _mm256_cvttpd_epi32(cell));
                for (int j = 0; j < 4; j++)
                    out[j] = cells[ci[j]];
                done = 1;
            }
        }
        if (!done) {
            double idx[4];
            _mm256_storeu_pd(idx, descend4(b0, b1, b2, depth));
            for (int j = 0; j < 4; j++)
                out[j] = (uint32_t)idx[j];
        }
        for (int j = 0; j < 4 && x + j <= b; j++)
            leaf[x - a + j] = out[j];
    }
}

/* The rasteriser's depth test over pixels L..R of row py, four at a time: the scalar loop's
 * operations lane by lane (hemicube.c's raster_tri), so ties resolve the same. */
__attribute__((target("avx2"))) void lrr__hemi_depth_span(const double abc[9],
                                                         const double iz[3], double inv_area,
                                                         double py, int L, int R, float *depth,
                                                         int32_t *item, int32_t id)
{
    __m256d A[3], BC[3], C[3], Z[3];
    for (int k = 0; k < 3; k++) {
        A[k] = _mm256_set1_pd(abc[3 * k]);
        BC[k] = _mm256_set1_pd(abc[3 * k + 1] * py);
        C[k] = _mm256_set1_pd(abc[3 * k + 2]);
        Z[k] = _mm256_set1_pd(iz[k]);
    }
    const __m256d ia = _mm256_set1_pd(inv_area), step = _mm256_set1_pd(4.0);
    const __m128i idv = _mm_set1_epi32(id);
    __m256d px = _mm256_add_pd(_mm256_set1_pd((double)L), _mm256_setr_pd(0.5, 1.5, 2.5, 3.5));
    for (int x = L; x <= R; x += 4, px = _mm256_add_pd(px, step)) {
        /* the lanes up to R: a row's last pixels load and store no further (masked) */
        const __m128i lane = _mm_cmplt_epi32(_mm_setr_epi32(0, 1, 2, 3), _mm_set1_epi32(R - x + 1));
        __m256d w[3];
        for (int k = 0; k < 3; k++)
            w[k] = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(A[k], px), BC[k]), C[k]);
        __m256d z = _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(w[0], Z[0]),
                                                _mm256_mul_pd(w[1], Z[1])),
                                  _mm256_mul_pd(w[2], Z[2]));
        __m128 zf = _mm256_cvtpd_ps(_mm256_mul_pd(z, ia));
        __m128 old = _mm_maskload_ps(depth + x, lane);
        /* ordered: NaN never wins, as in C */
        __m128 gt = _mm_and_ps(_mm_cmpgt_ps(zf, old), _mm_castsi128_ps(lane));
        if (_mm_movemask_ps(gt) == 0)
            continue;
        const __m128i gti = _mm_castps_si128(gt);
        _mm_maskstore_ps(depth + x, gti, zf);
        _mm_maskstore_ps((float *)(item + x), gti, _mm_castsi128_ps(idv));
    }
}
#else
int lrr__hemi_simd(void) { return 0; }
void lrr__hemi_depth_span(const double abc[9], const double iz[3], double inv_area, double py,
                          int L, int R, float *depth, int32_t *item, int32_t id)
{
    (void)abc, (void)iz, (void)inv_area, (void)py, (void)L, (void)R, (void)depth, (void)item,
        (void)id;
}
void lrr__hemi_leaves_run(const double b1k[3], const double b2k[3], const double denk[3],
                          const double *sxt, double sy, int a, int b, unsigned depth,
                          const uint16_t *cells, uint32_t *leaf)
{
    (void)b1k, (void)b2k, (void)denk, (void)sxt, (void)sy, (void)a, (void)b, (void)depth,
        (void)cells, (void)leaf;
}
#endif
