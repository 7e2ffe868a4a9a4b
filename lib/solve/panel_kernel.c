/* The n×k product of the real-time step over F̄ in panels (operator.h: blocks of
 * LRR__PANEL = 32 rows stored column-major):
 *     B_c = E_c + rho_c ∘ (F̄ z_c)   for the rows [i0, i1) of whole panels
 * A panel's column q is LRR__PANEL consecutive entries: one or two vector loads, multiplied
 * by the broadcast z_r[q], z_g[q], z_b[q] into per-row accumulators. No horizontal sums, no
 * tail per row, one sequential stream per thread, and the accumulators of 32 rows × 3
 * channels are the dot products themselves. Panels against rows (AMD EPYC, AVX-512, 2
 * threads, medians of 40, interleaved with a read loop over the same 191 MB): n = 221184,
 * k = 216: panels 3.98 ms (0.84× the read loop), rows 9.3 ms (1.96×); f16 2.2 against
 * 6.4 ms. The row kernels (realtime_kernel.c, realtime_avx2.c, realtime_avx512.c) serve
 * the last n % 32 rows and F̄ held as rows.
 */
#include "config.h"
#include "solve/solve.h"

#if defined(__x86_64__) || defined(__i386__)
#define LRR_X86 1
#include <immintrin.h>
#endif

#define P LRR__PANEL
/* The accumulators must live in registers: gcc -O2 leaves the 2×2×3 array of the AVX-512
 * loop in memory unless the small loops are unrolled (an FMA with a memory operand and a
 * store per step, 5.1 against 4.6 ms for the same loop written out, 191 MB f32). */
#define UNROLL _Pragma("GCC unroll 4")

/* B of one panel from its dot products t[c][r] (scale: per row, or NULL) */
static inline void epilogue_c(const float t[3][P], const float *E, const float *rho,
                              const float *scale, float *B)
{
    for (size_t r = 0; r < P; r++)
        for (int c = 0; c < 3; c++) {
            size_t j = 3 * r + c;
            B[j] = E[j] + rho[j] * (scale ? scale[r] * t[c][r] : t[c][r]);
        }
}

/* ------------------------------------------------------------------ portable C */

/* a panel's dot products; the column is decoded into float first (16-bit storage) */
#define DEFINE_PANELS_C(LINK, NAME, T, DECODE, SCALED)                                        \
    LINK void NAME(const T *fbar, const float *scale, size_t i0, size_t i1, size_t k,              \
              const float *z, const float *E, const float *rho, float *B)                     \
    {                                                                                        \
        for (size_t i = i0; i + P <= i1; i += P) {                                           \
            const T *blk = fbar + i * k;                                                     \
            float t[3][P] = {{0}};                                                           \
            for (size_t q = 0; q < k; q++) {                                                 \
                float col[P];                                                                \
                for (size_t r = 0; r < P; r++)                                               \
                    col[r] = DECODE(blk[q * P + r]);                                         \
                const float zr = z[q], zg = z[k + q], zb = z[2 * k + q];                     \
                for (size_t r = 0; r < P; r++) {                                             \
                    t[0][r] += col[r] * zr;                                                  \
                    t[1][r] += col[r] * zg;                                                  \
                    t[2][r] += col[r] * zb;                                                  \
                }                                                                            \
            }                                                                                \
            epilogue_c((const float(*)[P])t, E + 3 * i, rho + 3 * i, SCALED ? scale + i : NULL,\
                       B + 3 * i);                                                           \
        }                                                                                    \
    }

#define AS_FLOAT(x) (x)
DEFINE_PANELS_C(static, panels_f32_c_, float, AS_FLOAT, 0)
DEFINE_PANELS_C(, lrr__panels_f16_c, uint16_t, lrr__f16_to_f32, 1)
DEFINE_PANELS_C(, lrr__panels_bf16_c, uint16_t, lrr__bf16_to_f32, 1)

void lrr__panels_f32_c(const float *fbar, size_t i0, size_t i1, size_t k, const float *z,
                       const float *E, const float *rho, float *B)
{
    panels_f32_c_(fbar, NULL, i0, i1, k, z, E, rho, B);
}

#ifdef LRR_X86
/* Software prefetch PF bytes ahead of the stream, one per cache line of a step (PF = 0: none;
 * prefetches do not fault, so reading past the end is harmless). The _pf variants serve CPUs
 * whose hardware prefetcher leaves the stream short of lines in flight (core/cpu.c says
 * which: Intel). Measured on an Intel Xeon (Emerald Rapids, 2 threads, AVX-512, medians of
 * 15 interleaved with a read loop over the same 191 MB): n = 221184, k = 216, 4 KiB ahead
 * f32 0.95× the read loop (1.15× without), f16 1.01× its half (1.47× without); 2 KiB ahead
 * 0.96/1.03, 6 KiB 0.94/1.00 (n = 55296, k = 864 alike). An AMD EPYC runs the panels at
 * 0.84× the read loop without it. */
#define PREFETCH_DISTANCE 4096
#define PREFETCH_AHEAD(p, bytes, PF)                                                          \
    do {                                                                                     \
        if (PF)                                                                              \
            for (size_t l_ = 0; l_ < (bytes); l_ += 64)                                      \
                _mm_prefetch((const char *)(p) + (PF) + l_, _MM_HINT_T0);                    \
    } while (0)

/* ------------------------------------------------------------------ AVX2 + FMA */
/* 32 rows = 4 registers; 4 × 3 accumulators, 3 broadcasts and one column load fill the 16
 * registers. The dot products go through memory to the portable epilogue (96 entries per
 * 32·k·3 multiply-adds). */
#define DEFINE_PANELS_AVX2(LINK, NAME, T, LOAD8, SCALED, PF)                                  \
    __attribute__((target("avx2,fma,f16c"))) LINK void NAME(                                       \
        const T *fbar, const float *scale, size_t i0, size_t i1, size_t k, const float *z,    \
        const float *E, const float *rho, float *B)                                          \
    {                                                                                        \
        for (size_t i = i0; i + P <= i1; i += P) {                                           \
            const T *col = fbar + i * k;                                                     \
            __m256 acc[4][3];                                                                \
            UNROLL for (int v = 0; v < 4; v++)                                               \
                acc[v][0] = acc[v][1] = acc[v][2] = _mm256_setzero_ps();                     \
            for (size_t q = 0; q < k; q++, col += P) {                                       \
                PREFETCH_AHEAD(col, P * sizeof(T), PF);                                       \
                const __m256 r = _mm256_broadcast_ss(z + q), g = _mm256_broadcast_ss(z + k + q),\
                             b = _mm256_broadcast_ss(z + 2 * k + q);                         \
                UNROLL for (int v = 0; v < 4; v++) {                                         \
                    const __m256 x = LOAD8(col + 8 * v);                                     \
                    acc[v][0] = _mm256_fmadd_ps(x, r, acc[v][0]);                            \
                    acc[v][1] = _mm256_fmadd_ps(x, g, acc[v][1]);                            \
                    acc[v][2] = _mm256_fmadd_ps(x, b, acc[v][2]);                            \
                }                                                                            \
            }                                                                                \
            float t[3][P] __attribute__((aligned(32)));                                      \
            UNROLL for (int v = 0; v < 4; v++)                                               \
                UNROLL for (int c = 0; c < 3; c++)                                           \
                    _mm256_store_ps(t[c] + 8 * v, acc[v][c]);                                \
            epilogue_c((const float(*)[P])t, E + 3 * i, rho + 3 * i, SCALED ? scale + i : NULL,\
                       B + 3 * i);                                                           \
        }                                                                                    \
    }

__attribute__((target("avx2,fma,f16c"))) static inline __m256 ld8_f32(const float *p)
{
    return _mm256_loadu_ps(p);
}
__attribute__((target("avx2,fma,f16c"))) static inline __m256 ld8_f16(const uint16_t *p)
{
    return _mm256_cvtph_ps(_mm_loadu_si128((const __m128i *)p));
}
/* A widening load and a shift per 8 codes. Two unpacks with zero per 16 codes (rows
 * {0-3, 8-11} and {4-7, 12-15}, put back in order per panel) were slower: 221184 × 216,
 * LRR_SIMD=avx2, Zen 5, 2 rounds interleaved with this: 2.53 and 2.66× the floor against
 * 2.29 and 1.86× (lrr-bench realtime, a busy hour). */
__attribute__((target("avx2,fma,f16c"))) static inline __m256 ld8_bf16(const uint16_t *p)
{
    return _mm256_castsi256_ps(
        _mm256_slli_epi32(_mm256_cvtepu16_epi32(_mm_loadu_si128((const __m128i *)p)), 16));
}

DEFINE_PANELS_AVX2(static, panels_f32_avx2_, float, ld8_f32, 0, 0)
DEFINE_PANELS_AVX2(, lrr__panels_f16_avx2, uint16_t, ld8_f16, 1, 0)
DEFINE_PANELS_AVX2(, lrr__panels_bf16_avx2, uint16_t, ld8_bf16, 1, 0)
DEFINE_PANELS_AVX2(static, panels_f32_avx2_pf_, float, ld8_f32, 0, PREFETCH_DISTANCE)
DEFINE_PANELS_AVX2(, lrr__panels_f16_avx2_pf, uint16_t, ld8_f16, 1, PREFETCH_DISTANCE)
DEFINE_PANELS_AVX2(, lrr__panels_bf16_avx2_pf, uint16_t, ld8_bf16, 1, PREFETCH_DISTANCE)

void lrr__panels_f32_avx2(const float *fbar, size_t i0, size_t i1, size_t k, const float *z,
                          const float *E, const float *rho, float *B)
{
    panels_f32_avx2_(fbar, NULL, i0, i1, k, z, E, rho, B);
}
void lrr__panels_f32_avx2_pf(const float *fbar, size_t i0, size_t i1, size_t k,
                             const float *z, const float *E, const float *rho, float *B)
{
    panels_f32_avx2_pf_(fbar, NULL, i0, i1, k, z, E, rho, B);
}

/* ------------------------------------------------------------------ AVX-512 */
/* B of 16 rows from their dot products r, g, b (one register each): interleaved into
 * r0 g0 b0 r1 … by two two-source permutes per output register, then E + rho ∘ t. */
__attribute__((target("avx512f"))) static inline void epilogue16(__m512 r, __m512 g, __m512 b,
                                                                  const float *E,
                                                                  const float *rho, float *B)
{
    /* first permute: r (0..15) and g (16..31) into place, b's slots 0 for now; second: b */
    static const int32_t ia[3][16] = {{0, 16, 0, 1, 17, 0, 2, 18, 0, 3, 19, 0, 4, 20, 0, 5},
                                      {21, 0, 6, 22, 0, 7, 23, 0, 8, 24, 0, 9, 25, 0, 10, 26},
                                      {0, 11, 27, 0, 12, 28, 0, 13, 29, 0, 14, 30, 0, 15, 31, 0}};
    static const int32_t ib[3][16] = {{0, 1, 16, 3, 4, 17, 6, 7, 18, 9, 10, 19, 12, 13, 20, 15},
                                      {0, 21, 2, 3, 22, 5, 6, 23, 8, 9, 24, 11, 12, 25, 14, 15},
                                      {26, 1, 2, 27, 4, 5, 28, 7, 8, 29, 10, 11, 30, 13, 14, 31}};
    for (int o = 0; o < 3; o++) {
        __m512 t = _mm512_permutex2var_ps(r, _mm512_loadu_si512(ia[o]), g);
        t = _mm512_permutex2var_ps(t, _mm512_loadu_si512(ib[o]), b);
        _mm512_storeu_ps(B + 16 * o, _mm512_fmadd_ps(_mm512_loadu_ps(rho + 16 * o), t,
                                                     _mm512_loadu_ps(E + 16 * o)));
    }
}

/* 32 rows = 2 registers; even and odd columns into separate accumulators (12 chains hide
 * the FMA latency), summed at the end. */
#define DEFINE_PANELS_AVX512(LINK, NAME, T, LOAD16, SCALED, PF)                               \
    __attribute__((target("avx512f"))) LINK void NAME(const T *fbar, const float *scale,           \
                                                 size_t i0, size_t i1, size_t k,              \
                                                 const float *z, const float *E,              \
                                                 const float *rho, float *B)                  \
    {                                                                                        \
        for (size_t i = i0; i + P <= i1; i += P) {                                           \
            const T *col = fbar + i * k;                                                     \
            __m512 acc[2][2][3];                                                             \
            UNROLL for (int u = 0; u < 2; u++)                                               \
                UNROLL for (int v = 0; v < 2; v++)                                           \
                    acc[u][v][0] = acc[u][v][1] = acc[u][v][2] = _mm512_setzero_ps();        \
            size_t q = 0;                                                                    \
            for (; q + 2 <= k; q += 2, col += 2 * P) {                                       \
                PREFETCH_AHEAD(col, 2 * P * sizeof(T), PF);                                   \
                UNROLL for (int u = 0; u < 2; u++) {                                         \
                    const __m512 r = _mm512_set1_ps(z[q + u]),                               \
                                 g = _mm512_set1_ps(z[k + q + u]),                           \
                                 b = _mm512_set1_ps(z[2 * k + q + u]);                       \
                    UNROLL for (int v = 0; v < 2; v++) {                                     \
                        const __m512 x = LOAD16(col + u * P + 16 * v);                       \
                        acc[u][v][0] = _mm512_fmadd_ps(x, r, acc[u][v][0]);                  \
                        acc[u][v][1] = _mm512_fmadd_ps(x, g, acc[u][v][1]);                  \
                        acc[u][v][2] = _mm512_fmadd_ps(x, b, acc[u][v][2]);                  \
                    }                                                                        \
                }                                                                            \
            }                                                                                \
            if (q < k) {                                                                     \
                const __m512 r = _mm512_set1_ps(z[q]), g = _mm512_set1_ps(z[k + q]),         \
                             b = _mm512_set1_ps(z[2 * k + q]);                               \
                UNROLL for (int v = 0; v < 2; v++) {                                         \
                    const __m512 x = LOAD16(col + 16 * v);                                   \
                    acc[0][v][0] = _mm512_fmadd_ps(x, r, acc[0][v][0]);                      \
                    acc[0][v][1] = _mm512_fmadd_ps(x, g, acc[0][v][1]);                      \
                    acc[0][v][2] = _mm512_fmadd_ps(x, b, acc[0][v][2]);                      \
                }                                                                            \
            }                                                                                \
            UNROLL for (int v = 0; v < 2; v++) {                                             \
                __m512 t[3];                                                                 \
                const __m512 s = SCALED ? _mm512_loadu_ps(scale + i + 16 * v)                \
                                        : _mm512_set1_ps(1.0f);                              \
                UNROLL for (int c = 0; c < 3; c++)                                           \
                    t[c] = _mm512_mul_ps(s, _mm512_add_ps(acc[0][v][c], acc[1][v][c]));      \
                epilogue16(t[0], t[1], t[2], E + 3 * (i + 16 * v), rho + 3 * (i + 16 * v),   \
                           B + 3 * (i + 16 * v));                                            \
            }                                                                                \
        }                                                                                    \
    }

__attribute__((target("avx512f"))) static inline __m512 ld16_f32(const float *p)
{
    return _mm512_loadu_ps(p);
}
__attribute__((target("avx512f"))) static inline __m512 ld16_f16(const uint16_t *p)
{
    return _mm512_cvtph_ps(_mm256_loadu_si256((const __m256i *)p));
}
__attribute__((target("avx512f"))) static inline __m512 ld16_bf16(const uint16_t *p)
{
    return _mm512_castsi512_ps(
        _mm512_slli_epi32(_mm512_cvtepu16_epi32(_mm256_loadu_si256((const __m256i *)p)), 16));
}

DEFINE_PANELS_AVX512(static, panels_f32_avx512_, float, ld16_f32, 0, 0)
DEFINE_PANELS_AVX512(, lrr__panels_f16_avx512, uint16_t, ld16_f16, 1, 0)
DEFINE_PANELS_AVX512(, lrr__panels_bf16_avx512, uint16_t, ld16_bf16, 1, 0)
DEFINE_PANELS_AVX512(static, panels_f32_avx512_pf_, float, ld16_f32, 0, PREFETCH_DISTANCE)
DEFINE_PANELS_AVX512(, lrr__panels_f16_avx512_pf, uint16_t, ld16_f16, 1, PREFETCH_DISTANCE)
DEFINE_PANELS_AVX512(, lrr__panels_bf16_avx512_pf, uint16_t, ld16_bf16, 1, PREFETCH_DISTANCE)

void lrr__panels_f32_avx512(const float *fbar, size_t i0, size_t i1, size_t k,
                            const float *z, const float *E, const float *rho, float *B)
{
    panels_f32_avx512_(fbar, NULL, i0, i1, k, z, E, rho, B);
}
void lrr__panels_f32_avx512_pf(const float *fbar, size_t i0, size_t i1, size_t k,
                               const float *z, const float *E, const float *rho, float *B)
{
    panels_f32_avx512_pf_(fbar, NULL, i0, i1, k, z, E, rho, B);
}
#endif /* LRR_X86 */
