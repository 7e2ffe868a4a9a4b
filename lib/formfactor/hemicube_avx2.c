/* The hemicube rasteriser's per-pixel steps four pixels at a time (AVX2), the table
 * lrr__hemi_simd_avx2 that a form-factor build picks once (hemicube.c, from core/cpu.h's
 * level). Each step is the scalar path's exact sequence of IEEE operations lane by lane (no
 * FMA: the target is AVX2 alone, so gcc contracts no multiply and add), so the leaves, the
 * depth ties and F̄ are bit-identical to it:
 *   - a run's leaves: sx = (x + 0.5) / half − 1 (hemi_ctx.sx); r = 1 / (den·(sx, sy, 1));
 *     b_j = (num_j·(sx, sy, 1)) · r; clamp (lrr__clamp_bary); then the cell table where its
 *     margin allows (hemicube_integrate.c, "leaves of a row"), else `depth` levels of
 *     lrr__child_at as selects;
 *   - a span's depth test: three edge functions, 1/z, the float compare (raster_tri);
 *   - a triangle's rows' spans, and the change masks of a row's items and codes.
 * The measurements behind each step: docs/METHOD.md "Form factors". */
#include "config.h"
#include "formfactor/hemicube_private.h"

#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>

/* AVX2 without FMA: gcc contracts no multiply and add (the scalar path's two roundings) */
#define T256 __attribute__((target("avx2")))
/* round down, no exception: an integer constant expression, as the intrinsics need */
#define FLOOR_NO_EXC (_MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC)

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

/* A triangle's leaf codes, eight pixels at a time in two groups of four (leaves_run4,
 * depth_rows4): codes8_k's constants (p and q times s = 2^depth; a row's k1·sy go by value),
 * those of the fast path also in float */
typedef struct {
    __m256d d0, d2, p0, p2, q0, q2;
    __m256d sv, invs, need, up, down;
    __m256 fsv, fup, m12, m12hi, ulo, uhi;
    double s;
    unsigned depth;
    int table; /* 1: codes with the cell table (lrr__hemi_leaf_of), 0: leaves */
} codes4_k;

T256 static inline void codes4_setup(codes4_k *k, const double b1k[3], const double b2k[3],
                                     const double denk[3], unsigned depth, int table)
{
    const double s = (double)((uint64_t)1 << depth);
    k->d0 = _mm256_set1_pd(denk[0]), k->d2 = _mm256_set1_pd(denk[2]),
    k->p0 = _mm256_set1_pd(b1k[0] * s), k->p2 = _mm256_set1_pd(b1k[2] * s),
    k->q0 = _mm256_set1_pd(b2k[0] * s), k->q2 = _mm256_set1_pd(b2k[2] * s);
    k->s = s;
    k->invs = _mm256_set1_pd(1 / s);
    k->sv = _mm256_set1_pd(s), k->need = _mm256_set1_pd(0x1p-40 * s),
    k->up = _mm256_set1_pd(s - 1), k->down = _mm256_set1_pd(s - 2);
    /* exact in float for s <= 2^LRR__LEAF_TABLE_DEPTH */
    const float fs = (float)s;
    k->fsv = _mm256_set1_ps(fs), k->fup = _mm256_set1_ps(fs - 1),
    k->m12 = _mm256_set1_ps(0x1p-12f * fs), k->m12hi = _mm256_set1_ps(1 - 0x1p-12f * fs),
    k->ulo = _mm256_set1_ps(1 - 0x1p-11f * fs), k->uhi = _mm256_set1_ps(1 + 0x1p-11f * fs);
    k->depth = depth;
    k->table = table;
}

T256 static inline __m256d lin4(__m256d k0, __m256d k1sy, __m256d k2, __m256d sx)
{
    return _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(k0, sx), k1sy), k2);
}

/* two groups of four doubles as eight floats */
T256 static inline __m256 to_ps8(__m256d lo, __m256d hi)
{
    return _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(lo)), _mm256_cvtpd_ps(hi), 1);
}

/* fast_cells8 (see there) for eight pixels in float, from n_j = s·b̃_j·nd and nd (the exact
 * path's, in double) without a division: r̃ = rcpps(float(nd)) (within 1.5·2^-12) and one
 * Newton step r̃·(2 − float(nd)·r̃) in float, then t̃_j = float(n_j)·r̃. Where nd is a
 * normal float, t̃_j is within 2^-20·t_j + 2^-23 of the exact path's t_j = fl(n_j·fl(1/nd))
 * (the square of rcpps's error, a few float roundings, and 2^-149/nd for an n_j that is
 * denormal in float), inside the 2^-13·2^d that fast_cells8's margins allow for rcp14; f_j
 * = t̃_j − floor(t̃_j) is exact in float, u = f1 + f2 off by an ulp (2^-23). Other lanes come
 * out 0, ±inf or NaN (rcpps flushes a denormal input or result), which the compares reject:
 * t = 0 fails f ≥ m12, ±inf and NaN fail every compare. *code gets the cells (0 where a lane
 * does not qualify); returns the lanes that qualify, a movemask. Two 4-lane divides and the
 * same steps in double per eight pixels take twice the time (Cornell LRR_SIMD=avx2 R 128,
 * 1 thread: half of the profile against a quarter). */
T256 static inline int fast_cells4x2(const codes4_k *k, __m256 nd, __m256 n1, __m256 n2,
                                     __m256i *code)
{
    const __m256 one = _mm256_set1_ps(1.0f), zero = _mm256_setzero_ps();
    const __m256 r0 = _mm256_rcp_ps(nd);
    const __m256 r = _mm256_mul_ps(r0, _mm256_sub_ps(_mm256_set1_ps(2.0f), _mm256_mul_ps(nd, r0)));
    const __m256 t1 = _mm256_mul_ps(n1, r), t2 = _mm256_mul_ps(n2, r);
    const __m256 i1 = _mm256_round_ps(t1, FLOOR_NO_EXC), i2 = _mm256_round_ps(t2, FLOOR_NO_EXC);
    const __m256 f1 = _mm256_sub_ps(t1, i1), f2 = _mm256_sub_ps(t2, i2);
    const __m256 u = _mm256_add_ps(f1, f2);
    const __m256 down = _mm256_cmp_ps(u, k->uhi, _CMP_GE_OQ), d = _mm256_and_ps(down, one);
    __m256 ok = _mm256_and_ps(_mm256_cmp_ps(f1, k->m12, _CMP_GE_OQ),
                              _mm256_cmp_ps(f1, k->m12hi, _CMP_LE_OQ));
    ok = _mm256_and_ps(ok, _mm256_and_ps(_mm256_cmp_ps(f2, k->m12, _CMP_GE_OQ),
                                         _mm256_cmp_ps(f2, k->m12hi, _CMP_LE_OQ)));
    ok = _mm256_and_ps(ok, _mm256_or_ps(_mm256_cmp_ps(u, k->ulo, _CMP_LE_OQ), down));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(_mm256_min_ps(i1, i2), zero, _CMP_GE_OQ));
    ok = _mm256_and_ps(ok, _mm256_cmp_ps(_mm256_add_ps(_mm256_add_ps(i1, i2), d), k->fup,
                                         _CMP_LE_OQ));
    /* exact small integers (< 2^13): (i1·2^d + i2)·2 + down */
    const __m256 cell = _mm256_add_ps(
        _mm256_mul_ps(_mm256_add_ps(_mm256_mul_ps(i1, k->fsv), i2), _mm256_set1_ps(2.0f)), d);
    *code = _mm256_cvttps_epi32(_mm256_and_ps(ok, cell));
    return _mm256_movemask_ps(ok);
}

/* The exact path's codes of four pixels from their nd, n1, n2 (scaled by s, see codes8),
 * lane by lane as codes8: b from a division, the table's cell where its margin allows, else
 * the leaf | LRR__LEAF_DESCENT (the leaf alone without a table). */
T256 static inline __m128i exact_codes4(const codes4_k *k, __m256d nd, __m256d n1, __m256d n2)
{
    const __m256d one = _mm256_set1_pd(1.0), zero = _mm256_setzero_pd();
    const __m256d r = _mm256_div_pd(one, nd);
    __m256d b1 = _mm256_mul_pd(_mm256_mul_pd(n1, r), k->invs);
    __m256d b2 = _mm256_mul_pd(_mm256_mul_pd(n2, r), k->invs);
    /* lrr__clamp_bary: !(b > 0) → 0 (NaN too), b > 1 → 1, then b0 < 0 → renormalise */
    b1 = _mm256_and_pd(b1, _mm256_cmp_pd(b1, zero, _CMP_GT_OQ));
    b2 = _mm256_and_pd(b2, _mm256_cmp_pd(b2, zero, _CMP_GT_OQ));
    b1 = _mm256_blendv_pd(b1, one, _mm256_cmp_pd(b1, one, _CMP_GT_OQ));
    b2 = _mm256_blendv_pd(b2, one, _mm256_cmp_pd(b2, one, _CMP_GT_OQ));
    __m256d b0 = _mm256_sub_pd(_mm256_sub_pd(one, b1), b2);
    const __m256d neg = _mm256_cmp_pd(b0, zero, _CMP_LT_OQ);
    if (_mm256_movemask_pd(neg)) {
        const __m256d sum = _mm256_add_pd(b1, b2);
        b1 = _mm256_blendv_pd(b1, _mm256_div_pd(b1, sum), neg);
        b2 = _mm256_blendv_pd(b2, _mm256_div_pd(b2, sum), neg);
        b0 = _mm256_blendv_pd(b0, zero, neg);
    }
    __m256d ok = zero;
    __m128i code = _mm_setzero_si128();
    if (k->table) { /* the cell's leaf from the table, where the margin allows
                       (hemicube_integrate.c) */
        const __m256d sv = k->sv;
        const __m256d t0 = _mm256_mul_pd(b0, sv), t1 = _mm256_mul_pd(b1, sv),
                      t2 = _mm256_mul_pd(b2, sv);
        const __m256d i0 = _mm256_round_pd(t0, FLOOR_NO_EXC), i1 = _mm256_round_pd(t1, FLOOR_NO_EXC),
                      i2 = _mm256_round_pd(t2, FLOOR_NO_EXC);
        const __m256d f0 = _mm256_sub_pd(t0, i0), f1 = _mm256_sub_pd(t1, i1),
                      f2 = _mm256_sub_pd(t2, i2);
        const __m256d m = _mm256_min_pd(
            _mm256_min_pd(_mm256_min_pd(f0, _mm256_sub_pd(one, f0)),
                          _mm256_min_pd(f1, _mm256_sub_pd(one, f1))),
            _mm256_min_pd(f2, _mm256_sub_pd(one, f2)));
        const __m256d sum = _mm256_add_pd(_mm256_add_pd(i0, i1), i2);
        const __m256d isdown = _mm256_cmp_pd(sum, k->down, _CMP_EQ_OQ);
        ok = _mm256_and_pd(
            _mm256_and_pd(_mm256_cmp_pd(m, k->need, _CMP_GE_OQ),
                          _mm256_or_pd(_mm256_cmp_pd(sum, k->up, _CMP_EQ_OQ), isdown)),
            _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(b0, zero, _CMP_GT_OQ),
                                        _mm256_cmp_pd(b1, zero, _CMP_GT_OQ)),
                          _mm256_cmp_pd(b2, zero, _CMP_GT_OQ)));
        const __m256d cell = _mm256_add_pd(
            _mm256_mul_pd(_mm256_add_pd(_mm256_mul_pd(i1, sv), i2), _mm256_set1_pd(2.0)),
            _mm256_and_pd(isdown, one));
        code = _mm256_cvttpd_epi32(_mm256_and_pd(ok, cell)); /* the cells: codes */
    }
    if (_mm256_movemask_pd(ok) != 15) { /* the others descend: their leaves */
        /* leaves < 4^16 = 2^32: shifted by 2^31 into int32 range (exact) and back by the
         * sign bit, as an unsigned conversion would */
        const __m256d bias = _mm256_set1_pd(0x1p31);
        __m128i idx = _mm_xor_si128(
            _mm256_cvttpd_epi32(_mm256_sub_pd(descend4(b0, b1, b2, k->depth), bias)),
            _mm_set1_epi32(INT32_MIN));
        if (k->table)
            idx = _mm_or_si128(idx, _mm_set1_epi32((int)LRR__LEAF_DESCENT));
        const __m128i okd = _mm256_castsi256_si128(_mm256_permutevar8x32_epi32(
            _mm256_castpd_si256(ok), _mm256_setr_epi32(0, 2, 4, 6, 0, 2, 4, 6)));
        code = _mm_blendv_epi8(idx, code, okd);
    }
    return code;
}

/* The codes of eight pixels at columns sx_lo (four), sx_hi (four), lane by lane as codes8
 * (a lane's code does not depend on the others: the fast path gives the cell the exact
 * path's table gives); a group of four that the fast path does not settle takes the exact
 * path. */
T256 __attribute__((always_inline)) static inline __m256i codes4x2(const codes4_k *k, __m256d d1,
                                                                  __m256d p1, __m256d q1,
                                                                  __m256d sx_lo, __m256d sx_hi)
{
    /* k·(sx, sy, 1) = (k0·sx + k1·sy) + k2, n1 and n2 scaled by s (see codes8) */
    const __m256d nd_lo = lin4(k->d0, d1, k->d2, sx_lo), n1_lo = lin4(k->p0, p1, k->p2, sx_lo),
                  n2_lo = lin4(k->q0, q1, k->q2, sx_lo), nd_hi = lin4(k->d0, d1, k->d2, sx_hi),
                  n1_hi = lin4(k->p0, p1, k->p2, sx_hi), n2_hi = lin4(k->q0, q1, k->q2, sx_hi);
    __m256i code = _mm256_setzero_si256();
    int ok = 0;
    if (k->table) {
        ok = fast_cells4x2(k, to_ps8(nd_lo, nd_hi), to_ps8(n1_lo, n1_hi), to_ps8(n2_lo, n2_hi),
                           &code);
        if (ok == 0xFF)
            return code;
    }
    __m128i lo = _mm256_castsi256_si128(code), hi = _mm256_extracti128_si256(code, 1);
    if ((ok & 0x0F) != 0x0F)
        lo = exact_codes4(k, nd_lo, n1_lo, n2_lo);
    if ((ok & 0xF0) != 0xF0)
        hi = exact_codes4(k, nd_hi, n1_hi, n2_hi);
    return _mm256_inserti128_si256(_mm256_castsi128_si256(lo), hi, 1);
}

/* sx of pixels x..x+7, those past last repeating last's (whose codes are dropped) */
T256 static inline void sx8(const double *sxt, int x, int last, __m256d *lo, __m256d *hi)
{
    if (x + 7 <= last) {
        *lo = _mm256_loadu_pd(sxt + x), *hi = _mm256_loadu_pd(sxt + x + 4);
        return;
    }
    /* masked loads (nothing read past last), the other lanes last's */
    const __m256i n = _mm256_set1_epi64x(last - x + 1);
    const __m256i mlo = _mm256_cmpgt_epi64(n, _mm256_setr_epi64x(0, 1, 2, 3)),
                  mhi = _mm256_cmpgt_epi64(n, _mm256_setr_epi64x(4, 5, 6, 7));
    const __m256d l = _mm256_broadcast_sd(sxt + last);
    *lo = _mm256_blendv_pd(l, _mm256_maskload_pd(sxt + x, mlo), _mm256_castsi256_pd(mlo));
    *hi = _mm256_blendv_pd(l, _mm256_maskload_pd(sxt + x + 4, mhi), _mm256_castsi256_pd(mhi));
}

T256 static void leaves_run4(const double b1k[3], const double b2k[3], const double denk[3],
                             const double *sxt, double sy, int a, int b, unsigned depth,
                             const uint16_t *cells, uint32_t *leaf, uint64_t *brk)
{
    /* brk as it goes (put_codes8's way): a lrr__hemi_breaks pass over each run's codes
     * takes 1.5% more instructions in a Cornell R 32 LRR_SIMD=avx2 run (callgrind 1.894G
     * against 1.866G) */
    memset(brk, 0, (size_t)(b - a + 64) / 64 * sizeof *brk);
    __m256i prev = _mm256_setzero_si256(); /* whatever it holds: bit 0 is set at the end */
    codes4_k k;
    codes4_setup(&k, b1k, b2k, denk, depth, cells != NULL);
    const __m256d d1 = _mm256_set1_pd(denk[1] * sy), p1 = _mm256_set1_pd(b1k[1] * sy * k.s),
                  q1 = _mm256_set1_pd(b2k[1] * sy * k.s);
    const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7),
                  rot = _mm256_setr_epi32(7, 0, 1, 2, 3, 4, 5, 6);
    for (int x = a; x <= b; x += 8) {
        const int n = b - x + 1 < 8 ? b - x + 1 : 8;
        __m256d lo, hi;
        sx8(sxt, x, b, &lo, &hi);
        const __m256i code = codes4x2(&k, d1, p1, q1, lo, hi);
        _mm256_maskstore_epi32((int *)(leaf + x - a), _mm256_cmpgt_epi32(_mm256_set1_epi32(n), iota),
                               code);
        /* lane l against lane l − 1, lane 0 against the last of prev; x − a is a multiple of
         * 8, so the eight bits stay in one word */
        const __m256i before = _mm256_blend_epi32(_mm256_permutevar8x32_epi32(code, rot),
                                                  _mm256_permutevar8x32_epi32(prev, rot), 1);
        const uint64_t ne = (uint64_t)(~(unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(
                                           _mm256_cmpeq_epi32(code, before))) &
                                       ((1u << n) - 1));
        brk[(x - a) >> 6] |= ne << ((x - a) & 63);
        prev = code;
    }
    brk[0] |= 1;
}

/* The edge function k at four pixels: (A·px + B·py) + C, B·py hoisted into BC. */
#define EDGE4(k, px) _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(A##k, px), BC##k), C##k)

/* named registers, as DEPTH8_SETUP: with arrays and a loop over the three edges gcc kept
 * them on the stack (a store and three loads per edge and vector in the hot loop) */
#define DEPTH4_SETUP()                                                                        \
    const __m256d A0 = _mm256_set1_pd(abc[0]), C0 = _mm256_set1_pd(abc[2]),                  \
                  A1 = _mm256_set1_pd(abc[3]), C1 = _mm256_set1_pd(abc[5]),                  \
                  A2 = _mm256_set1_pd(abc[6]), C2 = _mm256_set1_pd(abc[8]),                  \
                  Z0 = _mm256_set1_pd(iz[0]), Z1 = _mm256_set1_pd(iz[1]),                    \
                  Z2 = _mm256_set1_pd(iz[2]), ia = _mm256_set1_pd(inv_area),                 \
                  four = _mm256_set1_pd(4.0), step = _mm256_set1_pd(8.0),                    \
                  offs = _mm256_setr_pd(0.5, 1.5, 2.5, 3.5);                                 \
    const __m256i idv = _mm256_set1_epi32(id)

/* 1/z of four pixels at px, as raster_tri's scalar loop lane by lane, in float */
#define DEPTH4_Z(px)                                                                          \
    _mm256_cvtpd_ps(_mm256_mul_pd(                                                            \
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(EDGE4(0, px), Z0),                          \
                                    _mm256_mul_pd(EDGE4(1, px), Z1)),                         \
                      _mm256_mul_pd(EDGE4(2, px), Z2)),                                       \
        ia))

/* Eight pixels x.. (up to R) of a row: the edge functions and 1/z in two groups of four
 * (double), the float compare and the stores of eight at once, as raster_tri's scalar loop
 * lane by lane (ties resolve the same); a row's last pixels load and store no further
 * (masked). Returns the lanes it wrote, as a vector mask. (Against a 4-lane step with its
 * own compare, branch and stores: Cornell LRR_SIMD=avx2, two threads, medians of 5 builds,
 * interleaved: R 64 0.0954-0.0958 s against 0.0983-0.0993 s, R 128 0.2549-0.2561 s against
 * 0.2662-0.2683 s.) */
T256 static inline __m256i depth4x2_step(__m256d A0, __m256d BC0, __m256d C0, __m256d A1,
                                         __m256d BC1, __m256d C1, __m256d A2, __m256d BC2,
                                         __m256d C2, __m256d Z0, __m256d Z1, __m256d Z2,
                                         __m256d ia, __m256d four, __m256i idv, __m256d px,
                                         int x, int R, float *depth, int32_t *item)
{
    const __m256i lane = _mm256_cmpgt_epi32(_mm256_set1_epi32(R - x + 1),
                                            _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
    const __m256d px4 = _mm256_add_pd(px, four);
    const __m256 zf = _mm256_insertf128_ps(_mm256_castps128_ps256(DEPTH4_Z(px)), DEPTH4_Z(px4), 1);
    const __m256 old = _mm256_maskload_ps(depth + x, lane);
    /* ordered: NaN never wins, as in C */
    const __m256i gt = _mm256_castps_si256(
        _mm256_and_ps(_mm256_cmp_ps(zf, old, _CMP_GT_OQ), _mm256_castsi256_ps(lane)));
    if (!_mm256_testz_si256(gt, gt)) {
        _mm256_maskstore_ps(depth + x, gt, zf);
        _mm256_maskstore_epi32(item + x, gt, idv);
    }
    return gt;
}

/* One row's span L..R at py of depth_span4 / depth_rows4 (DEPTH4_SETUP in scope). */
#define DEPTH4_ROW(py, L, R, depth, item)                                                     \
    do {                                                                                      \
        const __m256d BC0 = _mm256_set1_pd(abc[1] * (py)), BC1 = _mm256_set1_pd(abc[4] * (py)), \
                      BC2 = _mm256_set1_pd(abc[7] * (py));                                   \
        __m256d px = _mm256_add_pd(_mm256_set1_pd((double)(L)), offs);                        \
        for (int x = (L); x <= (R); x += 8, px = _mm256_add_pd(px, step))                     \
            depth4x2_step(A0, BC0, C0, A1, BC1, C1, A2, BC2, C2, Z0, Z1, Z2, ia, four, idv,   \
                          px, x, R, depth, item);                                             \
    } while (0)

/* One row's span L..R at py (lrr__hemi_simd.depth_span). */
T256 static void depth_span4(const double abc[9], const double iz[3], double inv_area, double py,
                             int L, int R, float *depth, int32_t *item, int32_t id)
{
    DEPTH4_SETUP();
    DEPTH4_ROW(py, L, R, depth, item);
}

/* depth_rows8 (lrr__hemi_simd.depth_rows) with AVX2: eight pixels a step, their edge
 * functions in two groups of four (double), their codes by codes4x2. The set-up once for all
 * rows (a call per row takes 4.6% more instructions in a Cornell R 32 LRR_SIMD=avx2 run,
 * callgrind 1.986G against 1.894G). */
T256 static void depth_rows4(const double abc[9], const double iz[3], double inv_area, int y0,
                             int y1, const int32_t *span, int W, float *depth, int32_t *item,
                             int32_t id, const lrr__hemi_codes *lc)
{
    DEPTH4_SETUP();
    codes4_k k;
    k.depth = 0, k.table = 0; /* set up below where codes are made */
    double b1s = 0, b2s = 0; /* the row terms' coefficients times 2^depth, as codes4x2 wants */
    if (lc) {
        codes4_setup(&k, lc->b1, lc->b2, lc->den, lc->depth, 1);
        b1s = lc->b1[1] * k.s, b2s = lc->b2[1] * k.s;
    }
    for (int y = y0; y <= y1; y++) {
        const int L = span[2 * (y - y0)], R = span[2 * (y - y0) + 1];
        float *drow = depth + (size_t)y * W;
        int32_t *irow = item + (size_t)y * W;
        if (!lc) {
            DEPTH4_ROW(y + 0.5, L, R, drow, irow);
            continue;
        }
        if (L > R)
            continue;
        /* the row's sy as integrate_face has it */
        const double sy = lc->syt[y], *sxt = lc->sxt;
        const __m256d d1 = _mm256_set1_pd(lc->den[1] * sy), p1 = _mm256_set1_pd(b1s * sy),
                      q1 = _mm256_set1_pd(b2s * sy);
        uint32_t *crow = lc->code + (size_t)y * W;
        const double py = y + 0.5;
        const __m256d BC0 = _mm256_set1_pd(abc[1] * py), BC1 = _mm256_set1_pd(abc[4] * py),
                      BC2 = _mm256_set1_pd(abc[7] * py);
        __m256d px = _mm256_add_pd(_mm256_set1_pd((double)L), offs);
        for (int x = L; x <= R; x += 8, px = _mm256_add_pd(px, step)) {
            const __m256i gt = depth4x2_step(A0, BC0, C0, A1, BC1, C1, A2, BC2, C2, Z0, Z1, Z2,
                                             ia, four, idv, px, x, R, drow, irow);
            if (_mm256_testz_si256(gt, gt))
                continue;
            /* the winners' codes; lanes past the span take its last pixel's column */
            __m256d lo, hi;
            sx8(sxt, x, R, &lo, &hi);
            _mm256_maskstore_epi32((int *)(crow + x), gt, codes4x2(&k, d1, p1, q1, lo, hi));
        }
    }
}
#undef DEPTH4_ROW
#undef DEPTH4_Z
#undef DEPTH4_SETUP
#undef EDGE4

/* lrr__hemi_simd.spans four rows at a time: spans8's steps (see hemicube_avx512.c) with AVX2
 * compares and blends, lane by lane the same IEEE operations (no FMA in target "avx2").
 * Against edge_span per row: Cornell LRR_SIMD=avx2, 1 thread, best of 5, R 32 0.210 s
 * against 0.288 s, R 64 0.613 against 0.654 s, R 128 1.463 against 1.690 s. */
__attribute__((target("avx2"))) static int spans4(const lrr__hemi_edge *e, int x0, int x1,
                                                 int y0, int y1, int32_t *span)
{
    const __m256d offs = _mm256_setr_pd(0.5, 1.5, 2.5, 3.5), big = _mm256_set1_pd(0x1p30),
                  nbig = _mm256_set1_pd(-0x1p30), one = _mm256_set1_pd(1.0),
                  zero = _mm256_setzero_pd(), X0 = _mm256_set1_pd(x0), X1 = _mm256_set1_pd(x1);
    int any = 0;
    for (int y = y0; y <= y1; y += 4) {
        const __m256d py = _mm256_add_pd(_mm256_set1_pd((double)y), offs);
        __m256d L = X0, R = X1;
        int exact = 0, empty = 0;
        for (int k = 0; k < 3; k++) {
            const lrr__hemi_edge *ek = &e[k];
            if (ek->A == 0) { /* (A·px + B·py) + C at any px */
                const __m256d v = _mm256_add_pd(
                    _mm256_add_pd(_mm256_set1_pd(ek->A * (x0 + 0.5)),
                                  _mm256_mul_pd(_mm256_set1_pd(ek->B), py)),
                    _mm256_set1_pd(ek->C));
                int in = _mm256_movemask_pd(_mm256_cmp_pd(v, zero, _CMP_GT_OQ));
                if (ek->owns_ties)
                    in |= _mm256_movemask_pd(_mm256_cmp_pd(v, zero, _CMP_EQ_OQ));
                empty |= ~in & 15;
                continue;
            }
            const __m256d xc = _mm256_add_pd(_mm256_set1_pd(ek->k0),
                                             _mm256_mul_pd(_mm256_set1_pd(ek->k1), py));
            const __m256d hi = _mm256_add_pd(xc, _mm256_set1_pd(ek->tol)),
                          lo = _mm256_sub_pd(xc, _mm256_set1_pd(ek->tol));
            const __m256d n = _mm256_round_pd(hi, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
            const __m256d fast = _mm256_and_pd(
                _mm256_and_pd(_mm256_cmp_pd(lo, nbig, _CMP_GT_OQ), _mm256_cmp_pd(hi, big, _CMP_LT_OQ)),
                _mm256_cmp_pd(n, lo, _CMP_LT_OQ));
            __m256d settled;
            if (ek->A > 0) { /* inside from n + 1 on */
                L = _mm256_blendv_pd(L, _mm256_max_pd(L, _mm256_add_pd(n, one)), fast);
                settled = _mm256_or_pd(fast, _mm256_cmp_pd(X0, hi, _CMP_GT_OQ));
            } else { /* inside up to n */
                R = _mm256_blendv_pd(R, _mm256_min_pd(R, n), fast);
                settled = _mm256_or_pd(fast, _mm256_cmp_pd(X1, lo, _CMP_LT_OQ));
            }
            exact |= ~_mm256_movemask_pd(settled) & 15;
        }
        empty |= _mm256_movemask_pd(_mm256_cmp_pd(L, R, _CMP_GT_OQ));
        /* the rows' (L, R) pairs as spans8 stores them, by blends (the scalar loop over the
         * masks: see spans8) */
        const __m128i bit = _mm_setr_epi32(1, 2, 4, 8);
        const __m128i ev = _mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(empty), bit), bit),
                      xv = _mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(exact), bit), bit);
        __m128i l = _mm_blendv_epi8(_mm256_cvttpd_epi32(L), _mm_set1_epi32(1), ev);
        l = _mm_blendv_epi8(l, _mm_set1_epi32(INT32_MIN), xv);
        const __m128i r = _mm_andnot_si128(ev, _mm256_cvttpd_epi32(R));
        const __m128i lo01 = _mm_unpacklo_epi32(l, r), hi23 = _mm_unpackhi_epi32(l, r);
        int32_t *out = span + 2 * (y - y0);
        const int rows = y1 - y + 1;
        any |= exact & (rows >= 4 ? 15 : (1 << rows) - 1);
        if (rows >= 4) {
            _mm_storeu_si128((__m128i *)out, lo01);
            _mm_storeu_si128((__m128i *)(out + 4), hi23);
        } else {
            const __m128i lane = _mm_setr_epi32(0, 0, 1, 1);
            _mm_maskstore_epi32(out, _mm_cmpgt_epi32(_mm_set1_epi32(rows), lane), lo01);
            _mm_maskstore_epi32(out + 4,
                                _mm_cmpgt_epi32(_mm_set1_epi32(rows - 2), lane), hi23);
        }
    }
    return any != 0;
}

/* breaks16_pair (hemicube_avx512.c) in eight lanes: an item row and its codes in one pass, a
 * word of 64 pixels at a time in registers (two eight-lane passes and an OR take 7% of a
 * Cornell R 64 LRR_SIMD=avx2 profile, against 4% for breaks16_pair in the AVX-512 one) */
T256 static void breaks8_pair(const int32_t *v, const int32_t *u, int n, uint64_t *mv,
                              uint64_t *mu)
{
    const __m256i iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (int w = 0; w * 64 < n; w++) {
        uint64_t wv = 0, wu = 0;
        for (int c = 0; c < 8; c++) {
            const int x = w * 64 + c * 8;
            if (x >= n)
                break;
            __m256i a, b, p, q;
            unsigned valid = 0xFF;
            if (x > 0 && n - x >= 8) {
                a = _mm256_loadu_si256((const __m256i *)(v + x));
                b = _mm256_loadu_si256((const __m256i *)(v + x - 1));
                p = _mm256_loadu_si256((const __m256i *)(u + x));
                q = _mm256_loadu_si256((const __m256i *)(u + x - 1));
            } else { /* lanes x.. below n, and not pixel 0 (no pixel before it): masked */
                __m256i k = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - x), iota);
                if (x == 0)
                    k = _mm256_blend_epi32(k, _mm256_setzero_si256(), 1);
                valid = (unsigned)_mm256_movemask_ps(_mm256_castsi256_ps(k));
                a = _mm256_maskload_epi32(v + x, k), b = _mm256_maskload_epi32(v + x - 1, k);
                p = _mm256_maskload_epi32(u + x, k), q = _mm256_maskload_epi32(u + x - 1, k);
            }
            const uint64_t nv = ~(unsigned)_mm256_movemask_ps(
                                    _mm256_castsi256_ps(_mm256_cmpeq_epi32(a, b))) & valid,
                           nu = ~(unsigned)_mm256_movemask_ps(
                                    _mm256_castsi256_ps(_mm256_cmpeq_epi32(p, q))) & valid;
            wv |= nv << (8 * c);
            wu |= (nv | nu) << (8 * c);
        }
        mv[w] = wv | (w == 0);
        mu[w] = wu | (w == 0);
    }
}

const lrr__hemi_simd lrr__hemi_simd_avx2 = {"avx2", spans4, depth_rows4, depth_span4,
                                            leaves_run4, breaks8_pair};
#endif
