/* The real-time row kernels with AVX-512 F (realtime_kernel.c has the portable ones, the
 * table that picks a variant and why these products are written out): eight rows share each
 * load of z, 16 floats a step, the k % 16 tail masked. */
#include "config.h"
#include "solve/realtime_rows.h"

#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>

/* Rows sharing each load of z: realtime_avx2.c's ROWS_AVX2 says why eight here. */
#define ROWS_AVX512 8
_Static_assert(3 * ROWS_AVX512 % 4 == 0, "epilogue8 sums four dot products per hadd round");

/* The epilogue of an 8-row group: the 24 accumulators (row-major r, g, b) are summed by a
 * halving tree (512 → 128 bits, then two rounds of hadd), which leaves the 24 dot products
 * in the order of B itself, so B = E + rho ∘ (scale ∘ t) is six 4-wide multiply-adds. Twenty-four
 * separate _mm512_reduce_add_ps cost about twice the instructions, which short rows
 * (k = 216: 14 vector steps per row) do not amortise. scale: one per row, or NULL. */
__attribute__((target("avx512f"))) static inline void epilogue8(__m512 acc[ROWS_AVX512][3],
                                                                const float *E,
                                                                const float *rho,
                                                                const float *scale, float *B)
{
    __m128 v[3 * ROWS_AVX512];
    for (int q = 0; q < ROWS_AVX512; q++)
        for (int c = 0; c < 3; c++) {
            __m512 a = acc[q][c];
            __m256 hi = _mm256_castpd_ps(_mm512_extractf64x4_pd(_mm512_castps_pd(a), 1));
            __m256 h = _mm256_add_ps(_mm512_castps512_ps256(a), hi);
            v[3 * q + c] = _mm_add_ps(_mm256_castps256_ps128(h), _mm256_extractf128_ps(h, 1));
        }
    for (int j = 0; j < 3 * ROWS_AVX512 / 4; j++) {
        __m128 t = _mm_hadd_ps(_mm_hadd_ps(v[4 * j], v[4 * j + 1]),
                               _mm_hadd_ps(v[4 * j + 2], v[4 * j + 3]));
        if (scale)
            t = _mm_mul_ps(t, _mm_set_ps(scale[(4 * j + 3) / 3], scale[(4 * j + 2) / 3],
                                         scale[(4 * j + 1) / 3], scale[(4 * j) / 3]));
        _mm_storeu_ps(B + 4 * j, _mm_add_ps(_mm_loadu_ps(E + 4 * j),
                                            _mm_mul_ps(_mm_loadu_ps(rho + 4 * j), t)));
    }
}

__attribute__((target("avx512f"))) void lrr__rows_f32_avx512(const float *fbar, size_t i0,
                                                             size_t i1, size_t k,
                                                             const float *z, const float *E,
                                                             const float *rho, float *B)
{
    const float *zr = z, *zg = z + k, *zb = z + 2 * k;
    const size_t kv = k & ~(size_t)15;
    const __mmask16 tm = (__mmask16)((1u << (k - kv)) - 1);
    size_t i = i0;
    for (; i + ROWS_AVX512 <= i1; i += ROWS_AVX512) {
        const float *f0 = fbar + i * k;
        __m512 acc[ROWS_AVX512][3];
        for (int r = 0; r < ROWS_AVX512; r++)
            acc[r][0] = acc[r][1] = acc[r][2] = _mm512_setzero_ps();
        for (size_t p = 0; p < kv; p += 16) {
            __m512 r = _mm512_loadu_ps(zr + p), g = _mm512_loadu_ps(zg + p),
                   b = _mm512_loadu_ps(zb + p);
            for (int q = 0; q < ROWS_AVX512; q++) {
                _mm_prefetch((const char *)(f0 + q * k + p) + PREFETCH, _MM_HINT_T0);
                __m512 x = _mm512_loadu_ps(f0 + q * k + p);
                acc[q][0] = _mm512_fmadd_ps(x, r, acc[q][0]);
                acc[q][1] = _mm512_fmadd_ps(x, g, acc[q][1]);
                acc[q][2] = _mm512_fmadd_ps(x, b, acc[q][2]);
            }
        }
        if (kv < k) {
            __m512 r = _mm512_maskz_loadu_ps(tm, zr + kv), g = _mm512_maskz_loadu_ps(tm, zg + kv),
                   b = _mm512_maskz_loadu_ps(tm, zb + kv);
            for (int q = 0; q < ROWS_AVX512; q++) {
                __m512 x = _mm512_maskz_loadu_ps(tm, f0 + q * k + kv);
                acc[q][0] = _mm512_fmadd_ps(x, r, acc[q][0]);
                acc[q][1] = _mm512_fmadd_ps(x, g, acc[q][1]);
                acc[q][2] = _mm512_fmadd_ps(x, b, acc[q][2]);
            }
        }
        epilogue8(acc, E + 3 * i, rho + 3 * i, NULL, B + 3 * i);
    }
    if (i < i1)
        lrr__rows_f32_c(fbar, i, i1, k, z, E, rho, B);
}

/* 16-bit F̄ with AVX-512: 16 entries per step widened to float, eight rows per z load. */
#define DEFINE_HALF_ROWS_AVX512(NAME, LOAD16, BF16)                                             \
    __attribute__((target("avx512f"))) void NAME(                                        \
        const uint16_t *fbar, const float *scale, size_t i0, size_t i1, size_t k,               \
        const float *z, const float *E, const float *rho, float *B)                              \
    {                                                                                           \
        const float *zr = z, *zg = z + k, *zb = z + 2 * k;                                      \
        const size_t kv = k & ~(size_t)15;                                                      \
        const __mmask16 tm = (__mmask16)((1u << (k - kv)) - 1);                                 \
        size_t i = i0;                                                                          \
        for (; i + ROWS_AVX512 <= i1; i += ROWS_AVX512) {                                       \
            const uint16_t *f0 = fbar + i * k;                                                  \
            __m512 acc[ROWS_AVX512][3];                                                         \
            for (int q = 0; q < ROWS_AVX512; q++)                                               \
                acc[q][0] = acc[q][1] = acc[q][2] = _mm512_setzero_ps();                        \
            for (size_t p = 0; p < kv; p += 16) {                                               \
                __m512 r = _mm512_loadu_ps(zr + p), g = _mm512_loadu_ps(zg + p),               \
                       b = _mm512_loadu_ps(zb + p);                                             \
                for (int q = 0; q < ROWS_AVX512; q++) {                                         \
                    _mm_prefetch((const char *)(f0 + q * k + p) + PREFETCH, _MM_HINT_T0);       \
                    __m512 x = LOAD16(f0 + q * k + p);                                          \
                    acc[q][0] = _mm512_fmadd_ps(x, r, acc[q][0]);                               \
                    acc[q][1] = _mm512_fmadd_ps(x, g, acc[q][1]);                               \
                    acc[q][2] = _mm512_fmadd_ps(x, b, acc[q][2]);                               \
                }                                                                               \
            }                                                                                   \
            if (kv < k) { /* the tail through a zero-padded copy: no scalar decoding */         \
                __m512 r = _mm512_maskz_loadu_ps(tm, zr + kv),                                  \
                       g = _mm512_maskz_loadu_ps(tm, zg + kv),                                  \
                       b = _mm512_maskz_loadu_ps(tm, zb + kv);                                  \
                for (int q = 0; q < ROWS_AVX512; q++) {                                         \
                    uint16_t pad[16] = {0};                                                     \
                    memcpy(pad, f0 + q * k + kv, (k - kv) * sizeof(uint16_t));                  \
                    __m512 x = LOAD16(pad);                                                     \
                    acc[q][0] = _mm512_fmadd_ps(x, r, acc[q][0]);                               \
                    acc[q][1] = _mm512_fmadd_ps(x, g, acc[q][1]);                               \
                    acc[q][2] = _mm512_fmadd_ps(x, b, acc[q][2]);                               \
                }                                                                               \
            }                                                                                   \
            epilogue8(acc, E + 3 * i, rho + 3 * i, scale + i, B + 3 * i);                      \
        }                                                                                       \
        if (i < i1)                                                                             \
            lrr__rows_half_c(fbar, scale, BF16, i, i1, k, z, E, rho, B);                             \
    }

__attribute__((target("avx512f"))) static inline __m512 load16_f16(const uint16_t *p)
{
    return _mm512_cvtph_ps(_mm256_loadu_si256((const __m256i *)p));
}

__attribute__((target("avx512f"))) static inline __m512 load16_bf16(const uint16_t *p)
{
    return _mm512_castsi512_ps(
        _mm512_slli_epi32(_mm512_cvtepu16_epi32(_mm256_loadu_si256((const __m256i *)p)), 16));
}

DEFINE_HALF_ROWS_AVX512(lrr__rows_f16_avx512, load16_f16, 0)
DEFINE_HALF_ROWS_AVX512(lrr__rows_bf16_avx512, load16_bf16, 1)

__attribute__((target("avx512f"))) void lrr__gemv_rows_avx512(const float *a, size_t i0,
                                                              size_t i1, size_t k,
                                                              const float *x, float *y)
{
    const size_t kv = k & ~(size_t)15;
    const __mmask16 tm = (__mmask16)((1u << (k - kv)) - 1);
    size_t i = i0;
    for (; i + GEMV_ROWS <= i1; i += GEMV_ROWS) {
        const float *r0 = a + i * k;
        __m512 s[GEMV_ROWS];
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            s[q] = _mm512_setzero_ps();
        for (size_t p = 0; p < kv; p += 16) {
            __m512 v = _mm512_loadu_ps(x + p);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
                s[q] = _mm512_fmadd_ps(_mm512_loadu_ps(r0 + q * k + p), v, s[q]);
        }
        if (kv < k) {
            __m512 v = _mm512_maskz_loadu_ps(tm, x + kv);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
                s[q] = _mm512_fmadd_ps(_mm512_maskz_loadu_ps(tm, r0 + q * k + kv), v, s[q]);
        }
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            y[i + q] = _mm512_reduce_add_ps(s[q]);
    }
    if (i < i1)
        lrr__gemv_rows_c(a, i, i1, k, x, y);
}

/* M − I in binary16 (m_f16.c): gemv_rows with each 16 entries widened (vcvtph2ps) and the
 * row's scale applied to its sum; the k % 16 tail through a zero-padded copy */
__attribute__((target("avx512f"))) void lrr__gemv_f16_rows_avx512(const uint16_t *a,
                                                                  const float *scale, size_t i0,
                                                                  size_t i1, size_t k,
                                                                  const float *x, float *y)
{
    const size_t kv = k & ~(size_t)15;
    const __mmask16 tm = (__mmask16)((1u << (k - kv)) - 1);
    size_t i = i0;
    for (; i + GEMV_ROWS <= i1; i += GEMV_ROWS) {
        const uint16_t *r0 = a + i * k;
        __m512 s[GEMV_ROWS];
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            s[q] = _mm512_setzero_ps();
        for (size_t p = 0; p < kv; p += 16) {
            __m512 v = _mm512_loadu_ps(x + p);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
                s[q] = _mm512_fmadd_ps(load16_f16(r0 + q * k + p), v, s[q]);
        }
        if (kv < k) {
            __m512 v = _mm512_maskz_loadu_ps(tm, x + kv);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++) {
                uint16_t pad[16] = {0}; /* the tail through a zero-padded copy (no AVX512BW) */
                memcpy(pad, r0 + q * k + kv, (k - kv) * sizeof(uint16_t));
                s[q] = _mm512_fmadd_ps(load16_f16(pad), v, s[q]);
            }
        }
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            y[i + q] = scale[i + q] * _mm512_reduce_add_ps(s[q]);
    }
    if (i < i1)
        lrr__gemv_f16_rows_c(a, scale, i, i1, k, x, y);
}
/* Sparse F̄ (sparse.c): one strip of 16 rows is one register; four strips in flight, each
 * into its own three accumulators (named: GCC keeps an array of them on the stack, and the
 * store-to-load chain then cost 9–17 cycles a strip on Zen 5), hide the multiply-add
 * latency; z_q comes as an embedded broadcast; the stream is prefetched (realtime_rows.h's
 * SPARSE_AHEAD says why and how far). */
#define SPARSE_STEP512(LOAD16, S, R, G, B)                                                      \
    do {                                                                                        \
        const size_t q_ = sp->col[S];                                                           \
        const __m512 v_ = LOAD16(sp, S);                                                        \
        R = _mm512_fmadd_ps(v_, _mm512_set1_ps(zr[q_]), R);                                     \
        G = _mm512_fmadd_ps(v_, _mm512_set1_ps(zg[q_]), G);                                     \
        B = _mm512_fmadd_ps(v_, _mm512_set1_ps(zb[q_]), B);                                     \
    } while (0)
#define DEFINE_SPARSE_AVX512(NAME, LOAD16)                                                      \
    __attribute__((target("avx512f"))) static void NAME(const lrr__sparse *sp, size_t t,        \
                                                        const float *z, const float *E,         \
                                                        const float *rho, float *B)             \
    {                                                                                           \
        const float *zr = z, *zg = z + sp->k, *zb = z + 2 * sp->k;                              \
        __m512 r0 = _mm512_setzero_ps(), g0 = r0, b0 = r0, r1 = r0, g1 = r0, b1 = r0,           \
               r2 = r0, g2 = r0, b2 = r0, r3 = r0, g3 = r0, b3 = r0;                            \
        size_t s = sp->start[t];                                                                \
        const size_t s1 = sp->start[t + 1];                                                     \
        for (; s + 4 <= s1; s += 4) {                                                           \
            PREFETCH_STRIPS(sp, s + SPARSE_AHEAD);                                              \
            SPARSE_STEP512(LOAD16, s, r0, g0, b0);                                              \
            SPARSE_STEP512(LOAD16, s + 1, r1, g1, b1);                                          \
            SPARSE_STEP512(LOAD16, s + 2, r2, g2, b2);                                          \
            SPARSE_STEP512(LOAD16, s + 3, r3, g3, b3);                                          \
        }                                                                                       \
        for (; s < s1; s++)                                                                     \
            SPARSE_STEP512(LOAD16, s, r0, g0, b0);                                              \
        float acc[3][LRR__TILE];                                                                \
        _mm512_storeu_ps(acc[0], _mm512_add_ps(_mm512_add_ps(r0, r1), _mm512_add_ps(r2, r3)));  \
        _mm512_storeu_ps(acc[1], _mm512_add_ps(_mm512_add_ps(g0, g1), _mm512_add_ps(g2, g3)));  \
        _mm512_storeu_ps(acc[2], _mm512_add_ps(_mm512_add_ps(b0, b1), _mm512_add_ps(b2, b3)));  \
        lrr__sparse_epilogue(sp, t, acc, E, rho, B);                                            \
    }

_Static_assert(LRR__TILE == 16, "one AVX-512 register per strip");

__attribute__((target("avx512f"))) static inline __m512 strip_f32(const lrr__sparse *sp, size_t s)
{
    return _mm512_loadu_ps(sp->val + s * LRR__TILE);
}
__attribute__((target("avx512f"))) static inline __m512 strip_f16(const lrr__sparse *sp, size_t s)
{
    return _mm512_cvtph_ps(_mm256_loadu_si256((const __m256i *)(sp->val16 + s * LRR__TILE)));
}
__attribute__((target("avx512f"))) static inline __m512 strip_bf16(const lrr__sparse *sp,
                                                                   size_t s)
{
    __m256i h = _mm256_loadu_si256((const __m256i *)(sp->val16 + s * LRR__TILE));
    return _mm512_castsi512_ps(_mm512_slli_epi32(_mm512_cvtepu16_epi32(h), 16));
}
DEFINE_SPARSE_AVX512(tile_f32_avx512, strip_f32)
DEFINE_SPARSE_AVX512(tile_f16_avx512, strip_f16)
DEFINE_SPARSE_AVX512(tile_bf16_avx512, strip_bf16)

void lrr__sparse_tiles_avx512(const lrr__sparse *sp, size_t t0, size_t t1, const float *z,
                              const float *E, const float *rho, float *B)
{
    for (size_t t = t0; t < t1; t++)
        if (sp->storage == LRR_STORAGE_F32)
            tile_f32_avx512(sp, t, z, E, rho, B);
        else if (sp->storage == LRR_STORAGE_F16)
            tile_f16_avx512(sp, t, z, E, rho, B);
        else
            tile_bf16_avx512(sp, t, z, E, rho, B);
}
#endif
