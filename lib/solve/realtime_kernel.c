/* The two dense products of the real-time step, written for one pass over each matrix with
 * all three colour channels at once (docs/METHOD.md "Real-time step"):
 *     z_c = M_c w_c                 (three k×k matrices)
 *     B_c = E_c + rho_c ∘ (F̄ z_c)   (n×k, read once for r, g and b; epilogue fused)
 *
 * Why not OpenBLAS here: sgemm with 3 right-hand sides repacks F̄, three sgemv read F̄
 * three times, and OpenBLAS's pthreads fight the OpenMP threads of the rest of the solve
 * for the cores (spinning GOMP workers: `lrr demo` measured 3.9 ms per frame that way and
 * 0.25 ms with OMP_WAIT_POLICY=passive). Measured in one process on 2 cores, medians of 200
 * (the portable loops here vs 3 sgemv k×k + sgemm n×k×3 vs 3 sgemv n×k, the last without
 * the epilogue): Cornell n = 3456, k = 216: 0.158 / 0.353 / 0.274 ms; n = 55296, k = 864:
 * 20.0 / 28.3 / 20.4 ms. The portable loop is compute-bound at the larger size, hence the
 * AVX2 and AVX-512 variants below, chosen at run time (lrr__kernel_select): at n = 55296,
 * k = 864 they run 10.0 (AVX2) and 8.2 ms (AVX-512) against 20.1 ms for the portable loop.
 *
 * Layout: the row kernels here read F̄ row-major: an operator's last n % 32 rows, and all
 * of F̄ after lrr_operator_set_layout(op, LRR_LAYOUT_ROWS). A row is a contiguous stream,
 * and its dot products with z_r, z_g, z_b reuse the three short vectors from L1; several
 * rows share each z load (ROWS_AVX2, ROWS_AVX512). The rest of F̄ is held in panels and
 * read by panel_kernel.c, which needs no horizontal sums (why: see there).
 */
#include "config.h"
#include "solve/solve.h"

#include <stdlib.h>
#include <string.h>

#if defined(__x86_64__) || defined(__i386__)
#define LRR_X86 1
#include <immintrin.h>
#endif

#define LANES 8
/* Software prefetch distance in bytes along each row. Measured (n = 55296, k = 864, 2
 * threads, AVX-512, medians of 100): none 9.3 ms, 512 B 8.2 ms, 1 KiB 9.2 ms, 2 KiB 9.5 ms;
 * the floor there is 6.7 ms (200 MB at the 30 GB/s an AVX-512 read loop reaches). */
#define PREFETCH 512

/* Rows sharing each load of z. Measured interleaved in one process (2 threads, f32, medians
 * of 60): n = 55296, k = 864: AVX2 2 rows 11.0, 4 rows 8.5; AVX-512 4 rows 7.8, 8 rows
 * 7.1 ms. n = 221184, k = 216: AVX2 11.9 / 11.4, AVX-512 11.4 / 10.7 ms. 8 rows × 3 channels
 * fill 24 of AVX-512's 32 registers; 4 × 3 fill AVX2's 16 with z and the row load. */
#define ROWS_AVX2 4
#define ROWS_AVX512 8
_Static_assert(3 * ROWS_AVX512 % 4 == 0, "epilogue8 sums four dot products per hadd round");

/* ------------------------------------------------------------------ portable C */

/* dot products of one row (length k) with three vectors; eight independent partial sums
 * per channel let the compiler vectorise without reassociating one running sum */
static inline void dot3(const float *restrict row, const float *restrict zr,
                        const float *restrict zg, const float *restrict zb, size_t k,
                        float out[3])
{
    float ar[LANES] = {0}, ag[LANES] = {0}, ab[LANES] = {0};
    size_t p = 0;
    for (; p + LANES <= k; p += LANES)
        for (int l = 0; l < LANES; l++) {
            float f = row[p + l];
            ar[l] += f * zr[p + l];
            ag[l] += f * zg[p + l];
            ab[l] += f * zb[p + l];
        }
    float sr = 0, sg = 0, sb = 0;
    for (int l = 0; l < LANES; l++) {
        sr += ar[l];
        sg += ag[l];
        sb += ab[l];
    }
    for (; p < k; p++) {
        sr += row[p] * zr[p];
        sg += row[p] * zg[p];
        sb += row[p] * zb[p];
    }
    out[0] = sr;
    out[1] = sg;
    out[2] = sb;
}

static float dot1(const float *restrict row, const float *restrict x, size_t k)
{
    float acc[LANES] = {0};
    size_t q = 0;
    for (; q + LANES <= k; q += LANES)
        for (int l = 0; l < LANES; l++)
            acc[l] += row[q + l] * x[q + l];
    float s = 0;
    for (int l = 0; l < LANES; l++)
        s += acc[l];
    for (; q < k; q++)
        s += row[q] * x[q];
    return s;
}

static void fbar_rows_c(const float *fbar, size_t i0, size_t i1, size_t k, const float *z,
                        const float *E, const float *rho, float *B)
{
    for (size_t i = i0; i < i1; i++) {
        float t[3];
        dot3(fbar + i * k, z, z + k, z + 2 * k, k, t);
        for (int c = 0; c < 3; c++)
            B[3 * i + c] = E[3 * i + c] + rho[3 * i + c] * t[c];
    }
}

/* 16-bit rows, one at a time: decode into a short float block, then the float dot product */
static void half_rows_c(const uint16_t *fbar, const float *scale, int bf16, size_t i0,
                        size_t i1, size_t k, const float *z, const float *E, const float *rho,
                        float *B)
{
    enum { BLK = 256 };
    float buf[BLK];
    for (size_t i = i0; i < i1; i++) {
        const uint16_t *row = fbar + i * k;
        float t[3] = {0, 0, 0};
        for (size_t p0 = 0; p0 < k; p0 += BLK) {
            size_t m = k - p0 < BLK ? k - p0 : BLK;
            for (size_t q = 0; q < m; q++)
                buf[q] = bf16 ? lrr__bf16_to_f32(row[p0 + q]) : lrr__f16_to_f32(row[p0 + q]);
            float u[3];
            dot3(buf, z + p0, z + k + p0, z + 2 * k + p0, m, u);
            t[0] += u[0];
            t[1] += u[1];
            t[2] += u[2];
        }
        for (int c = 0; c < 3; c++)
            B[3 * i + c] = E[3 * i + c] + rho[3 * i + c] * (scale[i] * t[c]);
    }
}

static void f16_rows_c(const uint16_t *fbar, const float *scale, size_t i0, size_t i1,
                       size_t k, const float *z, const float *E, const float *rho, float *B)
{
    half_rows_c(fbar, scale, 0, i0, i1, k, z, E, rho, B);
}

static void bf16_rows_c(const uint16_t *fbar, const float *scale, size_t i0, size_t i1,
                        size_t k, const float *z, const float *E, const float *rho, float *B)
{
    half_rows_c(fbar, scale, 1, i0, i1, k, z, E, rho, B);
}

static void gemv_rows_c(const float *a, size_t i0, size_t i1, size_t k, const float *x,
                        float *y)
{
    for (size_t i = i0; i < i1; i++)
        y[i] = dot1(a + i * k, x, k);
}

#ifdef LRR_X86
/* ------------------------------------------------------------------ AVX2 + FMA */

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

__attribute__((target("avx2,fma"))) static void fbar_rows_avx2(const float *fbar, size_t i0,
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
        fbar_rows_c(fbar, i, i1, k, z, E, rho, B);
}

/* 16-bit F̄: 8 entries per step are widened to float (F16C for binary16, a 16-bit shift for
 * bfloat16); four rows share each z load; the k % 8 tail is decoded in C. */
#define DEFINE_HALF_ROWS_AVX2(NAME, LOAD8, BF16)                                                \
    __attribute__((target("avx2,fma,f16c"))) static void NAME(                                  \
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
            half_rows_c(fbar, scale, BF16, i, i1, k, z, E, rho, B);                             \
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

DEFINE_HALF_ROWS_AVX2(f16_rows_avx2, load8_f16, 0)
DEFINE_HALF_ROWS_AVX2(bf16_rows_avx2, load8_bf16, 1)

/* Eight rows share each load of x. Measured (z = M w for k = 3456, 3 × 48 MB, 2 threads,
 * AVX-512, medians of 21, one process): 4 rows 3.68 ms, 8 rows 2.63 ms, a read loop over M
 * 2.87 ms; software prefetch made 8 rows slower (3.28 ms). */
#define GEMV_ROWS 8
#define UNROLL8 _Pragma("GCC unroll 8")

__attribute__((target("avx2,fma"))) static void gemv_rows_avx2(const float *a, size_t i0,
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
        gemv_rows_c(a, i, i1, k, x, y);
}

/* ------------------------------------------------------------------ AVX-512 */

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

__attribute__((target("avx512f"))) static void fbar_rows_avx512(const float *fbar, size_t i0,
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
        fbar_rows_c(fbar, i, i1, k, z, E, rho, B);
}

/* 16-bit F̄ with AVX-512: 16 entries per step widened to float, eight rows per z load. */
#define DEFINE_HALF_ROWS_AVX512(NAME, LOAD16, BF16)                                             \
    __attribute__((target("avx512f"))) static void NAME(                                        \
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
            half_rows_c(fbar, scale, BF16, i, i1, k, z, E, rho, B);                             \
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

DEFINE_HALF_ROWS_AVX512(f16_rows_avx512, load16_f16, 0)
DEFINE_HALF_ROWS_AVX512(bf16_rows_avx512, load16_bf16, 1)

__attribute__((target("avx512f"))) static void gemv_rows_avx512(const float *a, size_t i0,
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
        gemv_rows_c(a, i, i1, k, x, y);
}
#endif /* LRR_X86 */

/* ------------------------------------------------------------------ dispatch */

/* Each ISA twice: with the hardware prefetcher alone (AMD) and with the panels' software
 * prefetch (panel_kernel.c's PREFETCH_AHEAD, measured on an Intel Xeon); core/cpu.c picks
 * the level and the twin. */
static const lrr__kernel kernels[] = {
    {"c", LRR__ISA_C, 0, fbar_rows_c, f16_rows_c, bf16_rows_c, gemv_rows_c, lrr__panels_f32_c,
     lrr__panels_f16_c, lrr__panels_bf16_c},
#ifdef LRR_X86
    {"avx2", LRR__ISA_AVX2, 0, fbar_rows_avx2, f16_rows_avx2, bf16_rows_avx2, gemv_rows_avx2,
     lrr__panels_f32_avx2, lrr__panels_f16_avx2, lrr__panels_bf16_avx2},
    {"avx2+prefetch", LRR__ISA_AVX2, 1, fbar_rows_avx2, f16_rows_avx2, bf16_rows_avx2,
     gemv_rows_avx2, lrr__panels_f32_avx2_pf, lrr__panels_f16_avx2_pf,
     lrr__panels_bf16_avx2_pf},
    {"avx512", LRR__ISA_AVX512, 0, fbar_rows_avx512, f16_rows_avx512, bf16_rows_avx512,
     gemv_rows_avx512, lrr__panels_f32_avx512, lrr__panels_f16_avx512,
     lrr__panels_bf16_avx512},
    {"avx512+prefetch", LRR__ISA_AVX512, 1, fbar_rows_avx512, f16_rows_avx512,
     bf16_rows_avx512, gemv_rows_avx512, lrr__panels_f32_avx512_pf, lrr__panels_f16_avx512_pf,
     lrr__panels_bf16_avx512_pf},
#endif
};

const lrr__kernel *lrr__kernel_select(const lrr__cpu_choice *choice, size_t k)
{
    /* the level alone decides: AVX-512 with 8-row groups beats AVX2 at every size measured
     * (k = 216 and 864; ROWS_AVX512). k stays a parameter for rules a future variant may
     * need. */
    (void)k;
    for (size_t i = 0; i < sizeof kernels / sizeof kernels[0]; i++)
        if (kernels[i].isa == choice->isa &&
            (choice->isa == LRR__ISA_C || kernels[i].prefetch == !!choice->prefetch))
            return &kernels[i];
    return &kernels[0]; /* a level this build has no kernels for (not x86) */
}

/* Rows per OpenMP chunk: a multiple of the panel height (and of the row kernels' groups). */
#define ROW_BLOCK 64

void lrr__smw_apply(const lrr__kernel *kn, const float *m, size_t k, const float *w, float *z)
{
    const size_t blocks = (k + ROW_BLOCK - 1) / ROW_BLOCK;
    #pragma omp parallel for schedule(static) if (3 * k * k >= LRR__PARALLEL_MIN)
    for (size_t b = 0; b < 3 * blocks; b++) {
        size_t c = b / blocks, i0 = (b % blocks) * ROW_BLOCK;
        size_t i1 = i0 + ROW_BLOCK < k ? i0 + ROW_BLOCK : k;
        kn->gemv_rows(m + c * k * k, i0, i1, k, w + c * k, z + c * k);
    }
}

/* rows [i0, i1) of one frame, panels where F̄ has them and rows after */
static void apply_block(const lrr__kernel *kn, const lrr_operator *op, size_t i0, size_t i1,
                        size_t np, const float *z, const float *E, const float *rho, float *B)
{
    const size_t k = op->k;
    size_t im = i1 < np ? i1 : i0 > np ? i0 : np; /* [i0, im) panels, [im, i1) rows */
    if (op->storage == LRR_STORAGE_F16) {
        kn->f16_panels(op->fbar16, op->row_scale, i0, im, k, z, E, rho, B);
        kn->f16_rows(op->fbar16, op->row_scale, im, i1, k, z, E, rho, B);
    } else if (op->storage == LRR_STORAGE_BF16) {
        kn->bf16_panels(op->fbar16, op->row_scale, i0, im, k, z, E, rho, B);
        kn->bf16_rows(op->fbar16, op->row_scale, im, i1, k, z, E, rho, B);
    } else {
        kn->fbar_panels(op->fbar, i0, im, k, z, E, rho, B);
        kn->fbar_rows(op->fbar, im, i1, k, z, E, rho, B);
    }
}

_Static_assert(ROW_BLOCK % LRR__PANEL == 0, "blocks of whole panels");

void lrr__fbar_apply_frames(const lrr__kernel *kn, const lrr_operator *op, size_t count,
                            const float *z, const float *E, const float *rho, float *B)
{
    const size_t n = op->n, k = op->k, np = lrr__fbar_panel_rows(op);
    const size_t blocks = (n + ROW_BLOCK - 1) / ROW_BLOCK;
    #pragma omp parallel for schedule(static) if (n * k * count >= LRR__PARALLEL_MIN)
    for (size_t b = 0; b < blocks; b++) {
        size_t i0 = b * ROW_BLOCK, i1 = i0 + ROW_BLOCK < n ? i0 + ROW_BLOCK : n;
        /* black subpatches reflect nothing: a block of them needs no pass over its rows */
        int black = 1;
        for (size_t j = 3 * i0; j < 3 * i1 && black; j++)
            black = rho[j] == 0.0f;
        for (size_t f = 0; f < count; f++) {
            if (black)
                memcpy(B + 3 * n * f + 3 * i0, E + 3 * n * f + 3 * i0,
                       3 * (i1 - i0) * sizeof(float));
            else
                apply_block(kn, op, i0, i1, np, z + 3 * k * f, E + 3 * n * f, rho,
                            B + 3 * n * f);
        }
    }
}

void lrr__fbar_apply(const lrr__kernel *kn, const lrr_operator *op, const float *z,
                     const float *E, const float *rho, float *B)
{
    lrr__fbar_apply_frames(kn, op, 1, z, E, rho, B);
}
