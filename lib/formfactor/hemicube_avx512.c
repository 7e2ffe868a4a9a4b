/* The hemicube rasteriser's per-pixel steps eight pixels at a time (AVX-512 F and VL), the
 * table lrr__hemi_simd_avx512 that a form-factor build picks once (hemicube.c, from
 * core/cpu.h's level): hemicube_avx2.c's steps lane by lane, bit-identical to the scalar
 * path, with masks for the selects and a run's or span's last lanes. The measurements behind
 * each step: docs/METHOD.md "Form factors". */
#include "config.h"
#include "formfactor/hemicube_private.h"

#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>

/* round down, no exception: an integer constant expression, as the intrinsics need */
#define FLOOR_NO_EXC (_MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC)

/* ------------------------------------------------------------------ eight lanes (AVX-512)
 * The same steps as leaves_run4 and depth_span4, lane by lane, with masks for the selects and
 * a run's or span's last lanes. A lane the cell table's margin rejects descends alone (four
 * lanes went all or none). AVX-512 brings FMA, which gcc contracts a multiply and an add
 * into (GNU C's -ffp-contract=fast, also for intrinsics): fp-contract=off keeps the scalar
 * path's two roundings. */
#if defined(__clang__)
/* clang has no optimize attribute (the --enable-fuzzing build): contraction off from here */
#pragma clang fp contract(off)
#define T512 __attribute__((target("avx512f,avx512vl")))
#else
#define T512 __attribute__((target("avx512f,avx512vl"), optimize("fp-contract=off")))
#endif

T512 static inline __m512d lin8(__m512d k0, __m512d k1sy, __m512d k2, __m512d sx)
{
    return _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(k0, sx), k1sy), k2);
}

T512 static inline __m512d descend8(__m512d b0, __m512d b1, __m512d b2, unsigned depth)
{
    const __m512d one = _mm512_set1_pd(1.0), halfv = _mm512_set1_pd(0.5),
                  two = _mm512_set1_pd(2.0), four = _mm512_set1_pd(4.0),
                  c2 = _mm512_set1_pd(2.0), c3 = _mm512_set1_pd(3.0);
    __m512d idx = _mm512_setzero_pd();
    for (unsigned l = 0; l < depth; l++) {
        const __mmask8 m0 = _mm512_cmp_pd_mask(b0, halfv, _CMP_GE_OQ);
        const __mmask8 m1 = (__mmask8)(~m0 & _mm512_cmp_pd_mask(b1, halfv, _CMP_GE_OQ));
        const __mmask8 m2 = (__mmask8)(~(m0 | m1) & _mm512_cmp_pd_mask(b2, halfv, _CMP_GE_OQ));
        const __mmask8 m3 = (__mmask8)~(m0 | m1 | m2);
        const __m512d u2 = _mm512_mul_pd(two, b0), v2 = _mm512_mul_pd(two, b1),
                      w2 = _mm512_mul_pd(two, b2);
        b0 = _mm512_mask_mov_pd(_mm512_mask_mov_pd(u2, m0, _mm512_sub_pd(u2, one)), m3,
                                _mm512_sub_pd(one, u2));
        b1 = _mm512_mask_mov_pd(_mm512_mask_mov_pd(v2, m1, _mm512_sub_pd(v2, one)), m3,
                                _mm512_sub_pd(one, v2));
        b2 = _mm512_mask_mov_pd(_mm512_mask_mov_pd(w2, m2, _mm512_sub_pd(w2, one)), m3,
                                _mm512_sub_pd(one, w2));
        __m512d c = _mm512_mask_mov_pd(_mm512_maskz_mov_pd(m1, one), m2, c2);
        c = _mm512_mask_mov_pd(c, m3, c3);
        idx = _mm512_add_pd(_mm512_mul_pd(idx, four), c); /* exact: < 2^53 */
    }
    return idx;
}

/* The cells (i1, i2, down) of t_j = b_j·2^d: table slot and whether every lane is in one
 * with margins m12 (t1, t2) and m0 (t0), sums 2^d − 1 or 2^d − 2 and t_j >= 0. */
T512 static inline __mmask8 cells8(__m512d t0, __m512d t1, __m512d t2, __m512d sv, __m512d up,
                                   __m512d down, __m512d m12, __m512d m0, __m512d *cell)
{
    const __m512d one = _mm512_set1_pd(1.0), zero = _mm512_setzero_pd();
    const __m512d i0 = _mm512_roundscale_pd(t0, FLOOR_NO_EXC),
                  i1 = _mm512_roundscale_pd(t1, FLOOR_NO_EXC),
                  i2 = _mm512_roundscale_pd(t2, FLOOR_NO_EXC);
    const __m512d f0 = _mm512_sub_pd(t0, i0), f1 = _mm512_sub_pd(t1, i1), f2 = _mm512_sub_pd(t2, i2);
    const __m512d g0 = _mm512_min_pd(f0, _mm512_sub_pd(one, f0)),
                  g1 = _mm512_min_pd(f1, _mm512_sub_pd(one, f1)),
                  g2 = _mm512_min_pd(f2, _mm512_sub_pd(one, f2));
    const __m512d sum = _mm512_add_pd(_mm512_add_pd(i0, i1), i2);
    const __mmask8 isdown = _mm512_cmp_pd_mask(sum, down, _CMP_EQ_OQ);
    const __mmask8 ok = _mm512_cmp_pd_mask(g0, m0, _CMP_GE_OQ) &
                        _mm512_cmp_pd_mask(g1, m12, _CMP_GE_OQ) &
                        _mm512_cmp_pd_mask(g2, m12, _CMP_GE_OQ) &
                        (_mm512_cmp_pd_mask(sum, up, _CMP_EQ_OQ) | isdown) &
                        _mm512_cmp_pd_mask(t0, zero, _CMP_GT_OQ) &
                        _mm512_cmp_pd_mask(t1, zero, _CMP_GT_OQ) &
                        _mm512_cmp_pd_mask(t2, zero, _CMP_GT_OQ);
    /* rejected lanes get slot 0 (the caller does not use them) */
    *cell = _mm512_maskz_mov_pd(
        ok, _mm512_add_pd(_mm512_mul_pd(_mm512_add_pd(_mm512_mul_pd(i1, sv), i2),
                                        _mm512_set1_pd(2.0)),
                          _mm512_maskz_mov_pd(isdown, one)));
    return ok;
}

/* Pixels a..b's leaf codes (lrr__hemi_leaf_of): with the table, first from t̃_j =
 * n_j·rcp14(nd)·2^d without the division (a 512-bit divide per eight pixels is the bulk of
 * this loop's time): rcp14 is within 2^-14 of 1/nd relative, so t̃_j is within 2^-13·2^d of the
 * scalar path's t_j = fl(n_j·fl(1/nd))·2^d (same n_j, nd, t_j < 2^d) for j = 1, 2, and t0
 * is bounded through them (fast_cells8): eight lanes that qualify are in the scalar path's
 * cell beyond the table's margin, b_j in (0, 1); their codes are the cells. Otherwise the
 * exact path below. */
/* The fast path's cells (see leaves_run8) from t̃1, t̃2 alone: with f_j = t̃_j − i_j in
 * [m12, 1 − m12] and u = f1 + f2 at least m0 from 1, the scalar t0 is (2^d − i1 − i2) − u
 * within 2^-12·2^d (+ a few ulps), so it lies at least 2^-12·2^d − ε from every integer,
 * its floor 2^d − i1 − i2 − 1 − down with down = [u > 1]: the sum rule holds by itself, and
 * t0 > 0 is i1 + i2 + down <= 2^d − 1 (a third of cells8's operations fewer). *code gets
 * the cell's slot; the mask says which lanes qualify. */
T512 static inline __mmask8 fast_cells8(__m512d t1, __m512d t2, __m512d sv, __m512d smax,
                                        __m512d m12, __m512d m12hi, __m512d ulo, __m512d uhi,
                                        __m256i *code)
{
    const __m512d one = _mm512_set1_pd(1.0), zero = _mm512_setzero_pd();
    const __m512d i1 = _mm512_roundscale_pd(t1, FLOOR_NO_EXC),
                  i2 = _mm512_roundscale_pd(t2, FLOOR_NO_EXC);
    const __m512d f1 = _mm512_sub_pd(t1, i1), f2 = _mm512_sub_pd(t2, i2);
    const __m512d u = _mm512_add_pd(f1, f2);
    const __mmask8 down = _mm512_cmp_pd_mask(u, uhi, _CMP_GE_OQ);
    const __mmask8 ok =
        _mm512_cmp_pd_mask(f1, m12, _CMP_GE_OQ) & _mm512_cmp_pd_mask(f1, m12hi, _CMP_LE_OQ) &
        _mm512_cmp_pd_mask(f2, m12, _CMP_GE_OQ) & _mm512_cmp_pd_mask(f2, m12hi, _CMP_LE_OQ) &
        (_mm512_cmp_pd_mask(u, ulo, _CMP_LE_OQ) | down) &
        _mm512_cmp_pd_mask(_mm512_min_pd(i1, i2), zero, _CMP_GE_OQ) &
        _mm512_cmp_pd_mask(_mm512_mask_add_pd(_mm512_add_pd(i1, i2), down,
                                              _mm512_add_pd(i1, i2), one),
                           smax, _CMP_LE_OQ);
    /* exact small integers: (i1·2^d + i2)·2 + down */
    const __m512d cell = _mm512_mask_add_pd(
        _mm512_mul_pd(_mm512_add_pd(_mm512_mul_pd(i1, sv), i2), _mm512_set1_pd(2.0)), down,
        _mm512_mul_pd(_mm512_add_pd(_mm512_mul_pd(i1, sv), i2), _mm512_set1_pd(2.0)), one);
    *code = _mm512_cvttpd_epi32(_mm512_maskz_mov_pd(ok, cell));
    return ok;
}

/* The codes of lanes `lanes` at leaf[i..] (i % 8 == 0) and their bits of the change mask brk
 * (lrr__hemi_breaks of the codes), *prev the codes of the eight before. */
T512 static inline void put_codes8(__m256i code, __mmask8 lanes, int i, uint32_t *leaf,
                                   uint64_t *brk, __m256i *prev)
{
    _mm256_mask_storeu_epi32(leaf + i, lanes, code);
    /* lane l against lane l − 1, lane 0 against the last of *prev */
    const __m256i before = _mm256_alignr_epi32(code, *prev, 7);
    const uint64_t ne = _mm256_mask_cmpneq_epi32_mask(lanes, code, before);
    brk[i >> 6] |= ne << (i & 63);
    *prev = code;
}

/* A triangle's leaf codes, eight pixels at a time (leaves_run8, depth_rows8): its constants
 * (a row's k1·sy go by value: setting all of these per row of a triangle put a Cornell R 64
 * hemicube's raster at 137k cycles, 129k without) */
typedef struct {
    __m512d d0, d2, p0, p2, q0, q2; /* p and q times s = 2^depth (see codes8) */
    __m512d sv, invs, need, up, down, m12, m12hi, ulo, uhi;
    double s;
    unsigned depth;
    int table; /* 1: codes with the cell table (lrr__hemi_leaf_of), 0: leaves */
} codes8_k;

T512 static inline void codes8_setup(codes8_k *k, const double b1k[3], const double b2k[3],
                                     const double denk[3], unsigned depth, int table)
{
    const double s = (double)((uint64_t)1 << depth);
    k->d0 = _mm512_set1_pd(denk[0]), k->d2 = _mm512_set1_pd(denk[2]),
    k->p0 = _mm512_set1_pd(b1k[0] * s), k->p2 = _mm512_set1_pd(b1k[2] * s),
    k->q0 = _mm512_set1_pd(b2k[0] * s), k->q2 = _mm512_set1_pd(b2k[2] * s);
    k->s = s;
    k->invs = _mm512_set1_pd(1 / s);
    k->sv = _mm512_set1_pd(s), k->need = _mm512_set1_pd(0x1p-40 * s),
    k->up = _mm512_set1_pd(s - 1), k->down = _mm512_set1_pd(s - 2),
    k->m12 = _mm512_set1_pd(0x1p-12 * s), k->m12hi = _mm512_set1_pd(1 - 0x1p-12 * s),
    k->ulo = _mm512_set1_pd(1 - 0x1p-11 * s), k->uhi = _mm512_set1_pd(1 + 0x1p-11 * s);
    k->depth = depth;
    k->table = table;
}

/* The codes of eight pixels at columns sx. Lane by lane: a pixel's code does not depend on
 * the other lanes (the fast path gives the cell the exact path's table gives), so codes made
 * in the depth test (depth_rows8) equal leaves_run8's. */
T512 __attribute__((always_inline)) static inline __m256i codes8(const codes8_k *k, __m512d d1,
                                                                 __m512d p1, __m512d q1,
                                                                 __m512d sx)
{
    /* k·(sx, sy, 1) = (k0·sx + k1·sy) + k2: k1·sy (d1, p1, q1) is the row's one product.
     * n1, n2 come scaled by s = 2^depth (the coefficients and p1, q1 are): a power of two
     * commutes with every rounding, so s·n1 and (s·n1)·rc are exactly n1·s and (n1·rc)·s,
     * one multiply fewer each (and back by 1/s, exactly, where b is). */
    const __m512d one = _mm512_set1_pd(1.0), zero = _mm512_setzero_pd();
    const __m512d nd = lin8(k->d0, d1, k->d2, sx), n1 = lin8(k->p0, p1, k->p2, sx),
                  n2 = lin8(k->q0, q1, k->q2, sx);
    __m512d cell;
    if (k->table) {
        const __m512d rc = _mm512_rcp14_pd(nd);
        const __m512d t1 = _mm512_mul_pd(n1, rc), t2 = _mm512_mul_pd(n2, rc);
        __m256i code;
        if (fast_cells8(t1, t2, k->sv, k->up, k->m12, k->m12hi, k->ulo, k->uhi, &code) == 0xFF)
            return code;
    }
    const __m512d r = _mm512_div_pd(one, nd);
    __m512d b1 = _mm512_mul_pd(_mm512_mul_pd(n1, r), k->invs);
    __m512d b2 = _mm512_mul_pd(_mm512_mul_pd(n2, r), k->invs);
    /* lrr__clamp_bary: !(b > 0) → 0 (NaN too), b > 1 → 1, then b0 < 0 → renormalise */
    b1 = _mm512_maskz_mov_pd(_mm512_cmp_pd_mask(b1, zero, _CMP_GT_OQ), b1);
    b2 = _mm512_maskz_mov_pd(_mm512_cmp_pd_mask(b2, zero, _CMP_GT_OQ), b2);
    b1 = _mm512_mask_mov_pd(b1, _mm512_cmp_pd_mask(b1, one, _CMP_GT_OQ), one);
    b2 = _mm512_mask_mov_pd(b2, _mm512_cmp_pd_mask(b2, one, _CMP_GT_OQ), one);
    __m512d b0 = _mm512_sub_pd(_mm512_sub_pd(one, b1), b2);
    const __mmask8 neg = _mm512_cmp_pd_mask(b0, zero, _CMP_LT_OQ);
    if (neg) {
        const __m512d sum = _mm512_add_pd(b1, b2);
        b1 = _mm512_mask_div_pd(b1, neg, b1, sum);
        b2 = _mm512_mask_div_pd(b2, neg, b2, sum);
        b0 = _mm512_mask_mov_pd(b0, neg, zero);
    }
    __mmask8 ok = 0;
    if (k->table) /* the cell's leaf from the table, where the margin allows
                     (hemicube_integrate.c, "leaves of a row") */
        ok = cells8(_mm512_mul_pd(b0, k->sv), _mm512_mul_pd(b1, k->sv),
                    _mm512_mul_pd(b2, k->sv), k->sv, k->up, k->down, k->need, k->need, &cell);
    __m256i code = k->table ? _mm512_cvttpd_epi32(cell) : _mm256_setzero_si256();
    if (ok != 0xFF) { /* the others descend: their leaves, marked when there is a table */
        __m256i idx = _mm512_cvttpd_epu32(descend8(b0, b1, b2, k->depth));
        if (k->table)
            idx = _mm256_or_si256(idx, _mm256_set1_epi32((int)LRR__LEAF_DESCENT));
        code = _mm256_mask_mov_epi32(idx, ok, code);
    }
    return code;
}

T512 static void leaves_run8(const double b1k[3], const double b2k[3], const double denk[3],
                             const double *sxt, double sy, int a, int b, unsigned depth,
                             const uint16_t *cells, uint32_t *leaf, uint64_t *brk)
{
    memset(brk, 0, (size_t)(b - a + 64) / 64 * sizeof *brk);
    __m256i prev = _mm256_setzero_si256(); /* whatever it holds: bit 0 is set at the end */
    codes8_k k;
    codes8_setup(&k, b1k, b2k, denk, depth, cells != NULL);
    const __m512d d1 = _mm512_set1_pd(denk[1] * sy), p1 = _mm512_set1_pd(b1k[1] * sy * k.s),
                  q1 = _mm512_set1_pd(b2k[1] * sy * k.s);
    const __m512d last = _mm512_set1_pd(sxt[b]);
    for (int x = a; x <= b; x += 8) {
        const int n = b - x + 1 < 8 ? b - x + 1 : 8;
        const __mmask8 lanes = (__mmask8)((1u << n) - 1);
        /* past the run: its last pixel, whose leaf is dropped */
        const __m512d sx = _mm512_mask_loadu_pd(last, lanes, sxt + x);
        put_codes8(codes8(&k, d1, p1, q1, sx), lanes, x - a, leaf, brk, &prev);
    }
    brk[0] |= 1;
}

/* The edge function k at eight pixels: (A·px + B·py) + C, B·py hoisted as in depth_span4. */
#define EDGE8(k) _mm512_add_pd(_mm512_add_pd(_mm512_mul_pd(A##k, px), BC##k), C##k)

/* named registers, not arrays: gcc kept w[3] on the stack (a store and two loads per vector
 * in the hot loop) */
#define DEPTH8_SETUP()                                                                        \
    const __m512d A0 = _mm512_set1_pd(abc[0]), C0 = _mm512_set1_pd(abc[2]),                  \
                  A1 = _mm512_set1_pd(abc[3]), C1 = _mm512_set1_pd(abc[5]),                  \
                  A2 = _mm512_set1_pd(abc[6]), C2 = _mm512_set1_pd(abc[8]),                  \
                  Z0 = _mm512_set1_pd(iz[0]), Z1 = _mm512_set1_pd(iz[1]),                    \
                  Z2 = _mm512_set1_pd(iz[2]), ia = _mm512_set1_pd(inv_area),                 \
                  step = _mm512_set1_pd(8.0),                                                \
                  offs = _mm512_setr_pd(0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5);              \
    const __m256i idv = _mm256_set1_epi32(id)

/* One row's span L..R at py of depth_span8 / depth_rows8 (DEPTH8_SETUP in scope). */
#define DEPTH8_ROW(py, L, R, depth, item)                                                     \
    do {                                                                                      \
        const __m512d BC0 = _mm512_set1_pd(abc[1] * (py)), BC1 = _mm512_set1_pd(abc[4] * (py)), \
                      BC2 = _mm512_set1_pd(abc[7] * (py));                                   \
        __m512d px = _mm512_add_pd(_mm512_set1_pd((double)(L)), offs);                        \
        for (int x = (L); x <= (R); x += 8, px = _mm512_add_pd(px, step))                     \
            depth8_step(A0, BC0, C0, A1, BC1, C1, A2, BC2, C2, Z0, Z1, Z2, ia, idv, px, x, R, \
                        depth, item);                                                         \
    } while (0)

/* Eight pixels x.. (up to R) of a row: the edge functions (B·py hoisted into BC), 1/z and the
 * float compare, as raster_tri's scalar loop lane by lane. Returns the lanes it wrote. */
T512 static inline __mmask8 depth8_step(__m512d A0, __m512d BC0, __m512d C0, __m512d A1,
                                    __m512d BC1, __m512d C1, __m512d A2, __m512d BC2,
                                    __m512d C2, __m512d Z0, __m512d Z1, __m512d Z2, __m512d ia,
                                    __m256i idv, __m512d px, int x, int R, float *depth,
                                    int32_t *item)
{
    const __mmask8 lane = (__mmask8)(R - x + 1 >= 8 ? 0xFF : (1u << (R - x + 1)) - 1);
    const __m512d z = _mm512_add_pd(
        _mm512_add_pd(_mm512_mul_pd(EDGE8(0), Z0), _mm512_mul_pd(EDGE8(1), Z1)),
        _mm512_mul_pd(EDGE8(2), Z2));
    const __m256 zf = _mm512_cvtpd_ps(_mm512_mul_pd(z, ia));
    const __m256 old = _mm256_maskz_loadu_ps(lane, depth + x);
    /* ordered: NaN never wins, as in C */
    const __mmask8 gt = _mm256_mask_cmp_ps_mask(lane, zf, old, _CMP_GT_OQ);
    if (gt) {
        _mm256_mask_storeu_ps(depth + x, gt, zf);
        _mm256_mask_storeu_epi32(item + x, gt, idv);
    }
    return gt;
}

T512 static void depth_span8(const double abc[9], const double iz[3], double inv_area, double py,
                             int L, int R, float *depth, int32_t *item, int32_t id)
{
    DEPTH8_SETUP();
    DEPTH8_ROW(py, L, R, depth, item);
}

T512 static void depth_rows8(const double abc[9], const double iz[3], double inv_area, int y0,
                             int y1, const int32_t *span, int W, float *depth, int32_t *item,
                             int32_t id, const lrr__hemi_codes *lc)
{
    DEPTH8_SETUP();
    codes8_k k;
    k.depth = 0, k.table = 0; /* set up below where codes are made */
    double b1s = 0, b2s = 0; /* the row terms' coefficients times 2^depth, as codes8 wants */
    if (lc) {
        codes8_setup(&k, lc->b1, lc->b2, lc->den, lc->depth, 1);
        b1s = lc->b1[1] * k.s, b2s = lc->b2[1] * k.s;
    }
    for (int y = y0; y <= y1; y++) {
        const int L = span[2 * (y - y0)], R = span[2 * (y - y0) + 1];
        float *drow = depth + (size_t)y * W;
        int32_t *irow = item + (size_t)y * W;
        if (!lc) {
            DEPTH8_ROW(y + 0.5, L, R, drow, irow);
            continue;
        }
        if (L > R)
            continue;
        /* the row's sy as integrate_face has it */
        const double sy = lc->syt[y];
        const __m512d d1 = _mm512_set1_pd(lc->den[1] * sy), p1 = _mm512_set1_pd(b1s * sy),
                      q1 = _mm512_set1_pd(b2s * sy);
        uint32_t *crow = lc->code + (size_t)y * W;
        const __m512d last = _mm512_set1_pd(lc->sxt[R]);
        const double py = y + 0.5;
        const __m512d BC0 = _mm512_set1_pd(abc[1] * py), BC1 = _mm512_set1_pd(abc[4] * py),
                      BC2 = _mm512_set1_pd(abc[7] * py);
        __m512d px = _mm512_add_pd(_mm512_set1_pd((double)L), offs);
        for (int x = L; x <= R; x += 8, px = _mm512_add_pd(px, step)) {
            const __mmask8 gt = depth8_step(A0, BC0, C0, A1, BC1, C1, A2, BC2, C2, Z0, Z1, Z2,
                                            ia, idv, px, x, R, drow, irow);
            if (!gt)
                continue;
            /* the winners' codes; lanes past the span take its last pixel's column */
            const __mmask8 lane = (__mmask8)(R - x + 1 >= 8 ? 0xFF : (1u << (R - x + 1)) - 1);
            const __m512d sx = _mm512_mask_loadu_pd(last, lane, lc->sxt + x);
            _mm256_mask_storeu_epi32(crow + x, gt, codes8(&k, d1, p1, q1, sx));
        }
    }
}
#undef DEPTH8_ROW
#undef DEPTH8_SETUP
#undef EDGE8

/* lrr__hemi_simd.spans: edge_span's cases without a pixel test, lane by lane (its expressions,
 * unfused): an edge with A = 0 is a sign test per row; else a row where no pixel index lies
 * within tol of the crossing estimate xc is cut at n = floor(xc + tol), and one whose start
 * (A > 0) or end (A < 0) lies beyond that tolerance keeps it (checked against x0, x1: the
 * narrower range edge_span would see only moves further inside). Spans a row at a time
 * take 11% of a Cornell R 64 profile. */
T512 static int spans8(const lrr__hemi_edge *e, int x0, int x1, int y0, int y1, int32_t *span)
{
    const __m512d offs = _mm512_setr_pd(0.5, 1.5, 2.5, 3.5, 4.5, 5.5, 6.5, 7.5),
                  big = _mm512_set1_pd(0x1p30), one = _mm512_set1_pd(1.0),
                  X0 = _mm512_set1_pd(x0), X1 = _mm512_set1_pd(x1);
    int any = 0;
    for (int y = y0; y <= y1; y += 8) {
        const __m512d py = _mm512_add_pd(_mm512_set1_pd((double)y), offs);
        __m512d L = X0, R = X1;
        __mmask8 exact = 0, empty = 0;
        for (int k = 0; k < 3; k++) {
            const lrr__hemi_edge *ek = &e[k];
            if (ek->A == 0) { /* (A·px + B·py) + C at any px */
                const __m512d v = _mm512_add_pd(
                    _mm512_add_pd(_mm512_set1_pd(ek->A * (x0 + 0.5)),
                                  _mm512_mul_pd(_mm512_set1_pd(ek->B), py)),
                    _mm512_set1_pd(ek->C));
                const __mmask8 in = _mm512_cmp_pd_mask(v, _mm512_setzero_pd(), _CMP_GT_OQ) |
                                    (ek->owns_ties ? _mm512_cmp_pd_mask(v, _mm512_setzero_pd(),
                                                                        _CMP_EQ_OQ)
                                                   : 0);
                empty |= (__mmask8)~in;
                continue;
            }
            const __m512d xc = _mm512_add_pd(_mm512_set1_pd(ek->k0),
                                             _mm512_mul_pd(_mm512_set1_pd(ek->k1), py));
            const __m512d hi = _mm512_add_pd(xc, _mm512_set1_pd(ek->tol)),
                          lo = _mm512_sub_pd(xc, _mm512_set1_pd(ek->tol));
            const __m512d n = _mm512_roundscale_pd(hi, FLOOR_NO_EXC);
            const __mmask8 fast = _mm512_cmp_pd_mask(lo, _mm512_sub_pd(_mm512_setzero_pd(), big),
                                                     _CMP_GT_OQ) &
                                  _mm512_cmp_pd_mask(hi, big, _CMP_LT_OQ) &
                                  _mm512_cmp_pd_mask(n, lo, _CMP_LT_OQ);
            __mmask8 settled;
            if (ek->A > 0) { /* inside from n + 1 on */
                L = _mm512_mask_max_pd(L, fast, L, _mm512_add_pd(n, one));
                settled = fast | _mm512_cmp_pd_mask(X0, hi, _CMP_GT_OQ);
            } else { /* inside up to n */
                R = _mm512_mask_min_pd(R, fast, R, n);
                settled = fast | _mm512_cmp_pd_mask(X1, lo, _CMP_LT_OQ);
            }
            exact |= (__mmask8)~settled;
        }
        empty |= _mm512_cmp_pd_mask(L, R, _CMP_GT_OQ);
        /* (L, R) pairs of the rows: exact ones (INT32_MIN, R) for the caller, empty (1, 0);
         * one masked store (a scalar loop over the rows' masks costs a third of this) */
        __m256i l = _mm256_mask_mov_epi32(_mm512_cvttpd_epi32(L), empty, _mm256_set1_epi32(1));
        l = _mm256_mask_mov_epi32(l, exact, _mm256_set1_epi32(INT32_MIN));
        const __m256i r = _mm256_maskz_mov_epi32((__mmask8)~empty, _mm512_cvttpd_epi32(R));
        const __m512i pair = _mm512_permutex2var_epi32(
            _mm512_castsi256_si512(l),
            _mm512_setr_epi32(0, 16, 1, 17, 2, 18, 3, 19, 4, 20, 5, 21, 6, 22, 7, 23),
            _mm512_castsi256_si512(r));
        const int rows = y1 - y + 1 < 8 ? y1 - y + 1 : 8;
        any |= exact & ((1 << rows) - 1);
        _mm512_mask_storeu_epi32(span + 2 * (y - y0), (__mmask16)((1u << (2 * rows)) - 1), pair);
    }
    return any != 0;
}

/* lrr__hemi_breaks of two rows at once, sixteen lanes a step (an item row and its codes: one
 * loop instead of two, ~2% of a Cornell R 64 hemicube), a word of 64 pixels at a time in
 * registers (|= into the masks per sixteen makes a chain of loads and stores through each
 * word: 4.6% of a Cornell R 64 profile) */
T512 static void breaks16_pair(const int32_t *v, const int32_t *u, int n, uint64_t *mv,
                               uint64_t *mu)
{
    for (int w = 0; w * 64 < n; w++) {
        uint64_t wv = 0, wu = 0;
        for (int c = 0; c < 4; c++) {
            const int x = w * 64 + c * 16;
            if (x >= n)
                break;
            /* lanes x.. below n, and not pixel 0 (no pixel before it) */
            __mmask16 k = (__mmask16)(n - x >= 16 ? 0xFFFF : (1u << (n - x)) - 1);
            k &= (__mmask16)(x == 0 ? 0xFFFE : 0xFFFF);
            const uint64_t nv = _mm512_mask_cmpneq_epi32_mask(k, _mm512_maskz_loadu_epi32(k, v + x),
                                                              _mm512_maskz_loadu_epi32(k, v + x - 1)),
                           nu = _mm512_mask_cmpneq_epi32_mask(k, _mm512_maskz_loadu_epi32(k, u + x),
                                                              _mm512_maskz_loadu_epi32(k, u + x - 1));
            wv |= nv << (16 * c);
            wu |= (nv | nu) << (16 * c);
        }
        mv[w] = wv | (w == 0);
        mu[w] = wu | (w == 0);
    }
}

const lrr__hemi_simd lrr__hemi_simd_avx512 = {"avx512", spans8, depth_rows8, depth_span8,
                                              leaves_run8, breaks16_pair};
#endif
