/* The real-time row kernels with AVX2 and FMA (realtime_kernel.c has the portable ones, the
 * table that picks a variant and why these products are written out): several rows share
 * each load of z, 8 floats a step, the k % 8 tail masked. */
#include "config.h"
#include "solve/realtime_rows.h"

#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>

/* Rows sharing each load of z. Measured interleaved in one process (2 threads, f32, medians
 * of 60): n = 55296, k = 864: AVX2 2 rows 11.0, 4 rows 8.5; AVX-512 4 rows 7.8, 8 rows
 * 7.1 ms. n = 221184, k = 216: AVX2 11.9 / 11.4, AVX-512 11.4 / 10.7 ms. 8 rows × 3 channels
 * fill 24 of AVX-512's 32 registers; 4 × 3 fill AVX2's 16 with z and the row load. */
#define ROWS_AVX2 4

__attribute__((target("avx2,fma"))) static inline float hsum256(__m256 v)
{
    __m128 s = _mm_add_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps(v, 1));
    s = _mm_add_ps(s, _mm_movehl_ps(s, s));
    s = _mm_add_ss(s, _mm_movehdup_ps(s));
    return _mm_cvtss_f32(s);
}

/* lanes [0, r) set, for the k % 8 tail */
__attribute__((target("avx2,fma"))) static inline __m256i tail_mask256(size_t r)
{
    static const int32_t m[16] = {-1, -1, -1, -1, -1, -1, -1, -1, 0, 0, 0, 0, 0, 0, 0, 0};
    return _mm256_loadu_si256((const __m256i *)(m + 8 - r));
}

__attribute__((target("avx2,fma"))) void lrr__rows_f32_avx2(const float *fbar, size_t i0,
                                                            size_t i1, size_t k,
                                                            const float *z, const float *E,
                                                            const float *rho, float *B)
{
    const float *zr = z, *zg = z + k, *zb = z + 2 * k;
    const size_t kv = k & ~(size_t)7;
    const __m256i tm = tail_mask256(k - kv);
    size_t i = i0;
    for (; i + ROWS_AVX2 <= i1; i += ROWS_AVX2) {
        const float *f0 = fbar + i * k;
        __m256 acc[ROWS_AVX2][3];
        for (int q = 0; q < ROWS_AVX2; q++)
            acc[q][0] = acc[q][1] = acc[q][2] = _mm256_setzero_ps();
        for (size_t p = 0; p < kv; p += 8) {
            __m256 r = _mm256_loadu_ps(zr + p), g = _mm256_loadu_ps(zg + p),
                   b = _mm256_loadu_ps(zb + p);
            for (int q = 0; q < ROWS_AVX2; q++) {
                _mm_prefetch((const char *)(f0 + q * k + p) + PREFETCH, _MM_HINT_T0);
                __m256 x = _mm256_loadu_ps(f0 + q * k + p);
                acc[q][0] = _mm256_fmadd_ps(x, r, acc[q][0]);
                acc[q][1] = _mm256_fmadd_ps(x, g, acc[q][1]);
                acc[q][2] = _mm256_fmadd_ps(x, b, acc[q][2]);
            }
        }
        if (kv < k) {
            __m256 r = _mm256_maskload_ps(zr + kv, tm), g = _mm256_maskload_ps(zg + kv, tm),
                   b = _mm256_maskload_ps(zb + kv, tm);
            for (int q = 0; q < ROWS_AVX2; q++) {
                __m256 x = _mm256_maskload_ps(f0 + q * k + kv, tm);
                acc[q][0] = _mm256_fmadd_ps(x, r, acc[q][0]);
                acc[q][1] = _mm256_fmadd_ps(x, g, acc[q][1]);
                acc[q][2] = _mm256_fmadd_ps(x, b, acc[q][2]);
            }
        }
        for (int q = 0; q < ROWS_AVX2; q++)
            for (int c = 0; c < 3; c++) {
                size_t j = 3 * (i + q) + c;
                B[j] = E[j] + rho[j] * hsum256(acc[q][c]);
            }
    }
    if (i < i1)
        lrr__rows_f32_c(fbar, i, i1, k, z, E, rho, B);
}

/* 16-bit F̄: 8 entries per step are widened to float (F16C for binary16, a 16-bit shift for
 * bfloat16); four rows share each z load; the k % 8 tail is decoded in C. */
#define DEFINE_HALF_ROWS_AVX2(NAME, LOAD8, BF16)                                                \
    __attribute__((target("avx2,fma,f16c"))) void NAME(                                  \
        const uint16_t *fbar, const float *scale, size_t i0, size_t i1, size_t k,               \
        const float *z, const float *E, const float *rho, float *B)                              \
    {                                                                                           \
        const float *zr = z, *zg = z + k, *zb = z + 2 * k;                                      \
        const size_t kv = k & ~(size_t)7;                                                       \
        const __m256i tm = tail_mask256(k - kv);                                                \
        size_t i = i0;                                                                          \
        for (; i + ROWS_AVX2 <= i1; i += ROWS_AVX2) {                                           \
            const uint16_t *f0 = fbar + i * k;                                                  \
            __m256 acc[ROWS_AVX2][3];                                                           \
            for (int q = 0; q < ROWS_AVX2; q++)                                                 \
                acc[q][0] = acc[q][1] = acc[q][2] = _mm256_setzero_ps();                        \
            for (size_t p = 0; p < kv; p += 8) {                                                \
                __m256 r = _mm256_loadu_ps(zr + p), g = _mm256_loadu_ps(zg + p),                \
                       b = _mm256_loadu_ps(zb + p);                                             \
                for (int q = 0; q < ROWS_AVX2; q++) {                                           \
                    _mm_prefetch((const char *)(f0 + q * k + p) + PREFETCH, _MM_HINT_T0);       \
                    __m256 x = LOAD8(f0 + q * k + p);                                           \
                    acc[q][0] = _mm256_fmadd_ps(x, r, acc[q][0]);                               \
                    acc[q][1] = _mm256_fmadd_ps(x, g, acc[q][1]);                               \
                    acc[q][2] = _mm256_fmadd_ps(x, b, acc[q][2]);                               \
                }                                                                               \
            }                                                                                   \
            if (kv < k) { /* the tail through a zero-padded copy: no scalar decoding */         \
                __m256 r = _mm256_maskload_ps(zr + kv, tm), g = _mm256_maskload_ps(zg + kv, tm), \
                       b = _mm256_maskload_ps(zb + kv, tm);                                     \
                for (int q = 0; q < ROWS_AVX2; q++) {                                           \
                    uint16_t pad[8] = {0};                                                      \
                    memcpy(pad, f0 + q * k + kv, (k - kv) * sizeof(uint16_t));                  \
                    __m256 x = LOAD8(pad);                                                      \
                    acc[q][0] = _mm256_fmadd_ps(x, r, acc[q][0]);                               \
                    acc[q][1] = _mm256_fmadd_ps(x, g, acc[q][1]);                               \
                    acc[q][2] = _mm256_fmadd_ps(x, b, acc[q][2]);                               \
                }                                                                               \
            }                                                                                   \
            for (int q = 0; q < ROWS_AVX2; q++)                                                 \
                for (int c = 0; c < 3; c++) {                                                   \
                    size_t j = 3 * (i + q) + c;                                                 \
                    B[j] = E[j] + rho[j] * (scale[i + q] * hsum256(acc[q][c]));                 \
                }                                                                               \
        }                                                                                       \
        if (i < i1)                                                                             \
            lrr__rows_half_c(fbar, scale, BF16, i, i1, k, z, E, rho, B);                             \
    }

__attribute__((target("avx2,fma,f16c"))) static inline __m256 load8_f16(const uint16_t *p)
{
    return _mm256_cvtph_ps(_mm_loadu_si128((const __m128i *)p));
}

__attribute__((target("avx2,fma,f16c"))) static inline __m256 load8_bf16(const uint16_t *p)
{
    return _mm256_castsi256_ps(
        _mm256_slli_epi32(_mm256_cvtepu16_epi32(_mm_loadu_si128((const __m128i *)p)), 16));
}

DEFINE_HALF_ROWS_AVX2(lrr__rows_f16_avx2, load8_f16, 0)
DEFINE_HALF_ROWS_AVX2(lrr__rows_bf16_avx2, load8_bf16, 1)

__attribute__((target("avx2,fma"))) void lrr__gemv_rows_avx2(const float *a, size_t i0,
                                                             size_t i1, size_t k,
                                                             const float *x, float *y)
{
    const size_t kv = k & ~(size_t)7;
    const __m256i tm = tail_mask256(k - kv);
    size_t i = i0;
    for (; i + GEMV_ROWS <= i1; i += GEMV_ROWS) {
        const float *r0 = a + i * k;
        __m256 s[GEMV_ROWS];
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            s[q] = _mm256_setzero_ps();
        for (size_t p = 0; p < kv; p += 8) {
            __m256 v = _mm256_loadu_ps(x + p);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
                s[q] = _mm256_fmadd_ps(_mm256_loadu_ps(r0 + q * k + p), v, s[q]);
        }
        if (kv < k) {
            __m256 v = _mm256_maskload_ps(x + kv, tm);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
                s[q] = _mm256_fmadd_ps(_mm256_maskload_ps(r0 + q * k + kv, tm), v, s[q]);
        }
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            y[i + q] = hsum256(s[q]);
    }
    if (i < i1)
        lrr__gemv_rows_c(a, i, i1, k, x, y);
}

/* M − I in binary16 (m_f16.c): gemv_rows with each 8 entries widened by F16C and the row's
 * scale applied to its sum; the k % 8 tail through a zero-padded copy */
__attribute__((target("avx2,fma,f16c"))) void lrr__gemv_f16_rows_avx2(const uint16_t *a,
                                                                      const float *scale,
                                                                      size_t i0, size_t i1,
                                                                      size_t k, const float *x,
                                                                      float *y)
{
    const size_t kv = k & ~(size_t)7;
    const __m256i tm = tail_mask256(k - kv);
    size_t i = i0;
    for (; i + GEMV_ROWS <= i1; i += GEMV_ROWS) {
        const uint16_t *r0 = a + i * k;
        __m256 s[GEMV_ROWS];
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            s[q] = _mm256_setzero_ps();
        for (size_t p = 0; p < kv; p += 8) {
            __m256 v = _mm256_loadu_ps(x + p);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
                s[q] = _mm256_fmadd_ps(load8_f16(r0 + q * k + p), v, s[q]);
        }
        if (kv < k) {
            __m256 v = _mm256_maskload_ps(x + kv, tm);
            UNROLL8 for (int q = 0; q < GEMV_ROWS; q++) {
                uint16_t pad[8] = {0};
                memcpy(pad, r0 + q * k + kv, (k - kv) * sizeof(uint16_t));
                s[q] = _mm256_fmadd_ps(load8_f16(pad), v, s[q]);
            }
        }
        UNROLL8 for (int q = 0; q < GEMV_ROWS; q++)
            y[i + q] = scale[i + q] * hsum256(s[q]);
    }
    if (i < i1)
        lrr__gemv_f16_rows_c(a, scale, i, i1, k, x, y);
}
/* Sparse F̄ (sparse.c): a strip of 16 rows is two registers; two strips in flight (12
 * named accumulators of the 16 registers: realtime_avx512.c says why named) hide the
 * multiply-add latency; the stream is prefetched as there. */
#define SPARSE_STEP256(LOAD8, S, R0, R1, G0, G1, B0, B1)                                        \
    do {                                                                                        \
        const size_t q_ = sp->col[S];                                                           \
        const __m256 v0_ = LOAD8(sp, S, 0), v1_ = LOAD8(sp, S, 8);                              \
        const __m256 r_ = _mm256_broadcast_ss(zr + q_);                                         \
        R0 = _mm256_fmadd_ps(v0_, r_, R0);                                                      \
        R1 = _mm256_fmadd_ps(v1_, r_, R1);                                                      \
        const __m256 g_ = _mm256_broadcast_ss(zg + q_);                                         \
        G0 = _mm256_fmadd_ps(v0_, g_, G0);                                                      \
        G1 = _mm256_fmadd_ps(v1_, g_, G1);                                                      \
        const __m256 b_ = _mm256_broadcast_ss(zb + q_);                                         \
        B0 = _mm256_fmadd_ps(v0_, b_, B0);                                                      \
        B1 = _mm256_fmadd_ps(v1_, b_, B1);                                                      \
    } while (0)
#define DEFINE_SPARSE_AVX2(NAME, LOAD8)                                                         \
    __attribute__((target("avx2,fma,f16c"))) static void NAME(                                  \
        const lrr__sparse *sp, size_t t, const float *z, const float *E, const float *rho,      \
        float *B)                                                                               \
    {                                                                                           \
        const float *zr = z, *zg = z + sp->k, *zb = z + 2 * sp->k;                              \
        __m256 r0 = _mm256_setzero_ps(), r1 = r0, g0 = r0, g1 = r0, b0 = r0, b1 = r0;           \
        __m256 r2 = r0, r3 = r0, g2 = r0, g3 = r0, b2 = r0, b3 = r0;                            \
        size_t s = sp->start[t];                                                                \
        const size_t s1 = sp->start[t + 1];                                                     \
        for (; s + 2 <= s1; s += 2) {                                                           \
            PREFETCH_STRIPS(sp, s + SPARSE_AHEAD); /* four strips: half of them again */    \
            SPARSE_STEP256(LOAD8, s, r0, r1, g0, g1, b0, b1);                                   \
            SPARSE_STEP256(LOAD8, s + 1, r2, r3, g2, g3, b2, b3);                               \
        }                                                                                       \
        if (s < s1)                                                                             \
            SPARSE_STEP256(LOAD8, s, r0, r1, g0, g1, b0, b1);                                   \
        float acc[3][LRR__TILE];                                                                \
        _mm256_storeu_ps(acc[0], _mm256_add_ps(r0, r2));                                        \
        _mm256_storeu_ps(acc[0] + 8, _mm256_add_ps(r1, r3));                                    \
        _mm256_storeu_ps(acc[1], _mm256_add_ps(g0, g2));                                        \
        _mm256_storeu_ps(acc[1] + 8, _mm256_add_ps(g1, g3));                                    \
        _mm256_storeu_ps(acc[2], _mm256_add_ps(b0, b2));                                        \
        _mm256_storeu_ps(acc[2] + 8, _mm256_add_ps(b1, b3));                                    \
        lrr__sparse_epilogue(sp, t, acc, E, rho, B);                                            \
    }

_Static_assert(LRR__TILE == 16, "two AVX2 registers per strip");

__attribute__((target("avx2,fma,f16c"))) static inline __m256 strip8_f32(const lrr__sparse *sp,
                                                                         size_t s, int h)
{
    return _mm256_loadu_ps(sp->val + s * LRR__TILE + h);
}
__attribute__((target("avx2,fma,f16c"))) static inline __m256 strip8_f16(const lrr__sparse *sp,
                                                                         size_t s, int h)
{
    return load8_f16(sp->val16 + s * LRR__TILE + h);
}
__attribute__((target("avx2,fma,f16c"))) static inline __m256 strip8_bf16(const lrr__sparse *sp,
                                                                          size_t s, int h)
{
    return load8_bf16(sp->val16 + s * LRR__TILE + h);
}
DEFINE_SPARSE_AVX2(tile_f32_avx2, strip8_f32)
DEFINE_SPARSE_AVX2(tile_f16_avx2, strip8_f16)
DEFINE_SPARSE_AVX2(tile_bf16_avx2, strip8_bf16)

void lrr__sparse_tiles_avx2(const lrr__sparse *sp, size_t t0, size_t t1, const float *z,
                            const float *E, const float *rho, float *B)
{
    for (size_t t = t0; t < t1; t++)
        if (sp->storage == LRR_STORAGE_F32)
            tile_f32_avx2(sp, t, z, E, rho, B);
        else if (sp->storage == LRR_STORAGE_F16)
            tile_f16_avx2(sp, t, z, E, rho, B);
        else
            tile_bf16_avx2(sp, t, z, E, rho, B);
}
#endif
