/* What the real-time row kernels' files share (realtime_kernel.c: portable C, the table and
 * the products; realtime_avx2.c; realtime_avx512.c): the row kernels of each instruction
 * set, the signatures of lrr__kernel's *_rows, and the tuning the variants have in common. */
#ifndef LRR_SOLVE_REALTIME_ROWS_H
#define LRR_SOLVE_REALTIME_ROWS_H

#include "solve/solve.h"

/* Software prefetch distance in bytes along each row. Measured (n = 55296, k = 864, 2
 * threads, AVX-512, medians of 100): none 9.3 ms, 512 B 8.2 ms, 1 KiB 9.2 ms, 2 KiB 9.5 ms;
 * the floor there is 6.7 ms (200 MB at the 30 GB/s an AVX-512 read loop reaches). */
#define PREFETCH 512

/* Eight rows share each load of x. Measured (z = M w for k = 3456, 3 × 48 MB, 2 threads,
 * AVX-512, medians of 21, one process): 4 rows 3.68 ms, 8 rows 2.63 ms, a read loop over M
 * 2.87 ms; software prefetch makes 8 rows slower (3.28 ms). */
#define GEMV_ROWS 8
#define UNROLL8 _Pragma("GCC unroll 8")

/* The row kernels of one instruction set (lrr__kernel's fbar_rows, f16_rows, bf16_rows,
 * gemv_rows and gemv_f16_rows) */
#define LRR__DECLARE_ROWS(ISA)                                                                \
    void lrr__rows_f32_##ISA(const float *, size_t, size_t, size_t, const float *,           \
                             const float *, const float *, float *);                         \
    void lrr__rows_f16_##ISA(const uint16_t *, const float *, size_t, size_t, size_t,        \
                             const float *, const float *, const float *, float *);          \
    void lrr__rows_bf16_##ISA(const uint16_t *, const float *, size_t, size_t, size_t,       \
                              const float *, const float *, const float *, float *);         \
    void lrr__gemv_rows_##ISA(const float *, size_t, size_t, size_t, const float *, float *); \
    void lrr__gemv_f16_rows_##ISA(const uint16_t *, const float *, size_t, size_t, size_t,   \
                                  const float *, float *);
LRR__DECLARE_ROWS(c)
LRR__DECLARE_ROWS(avx2)
LRR__DECLARE_ROWS(avx512)
/* The portable 16-bit rows, bf16 1 for bfloat16, 0 for binary16: the SIMD variants' rows
 * after their last whole group. */
void lrr__rows_half_c(const uint16_t *fbar, const float *scale, int bf16, size_t i0, size_t i1,
                      size_t k, const float *z, const float *E, const float *rho, float *B);

/* Sparse F̄ (sparse.c): software prefetch SPARSE_AHEAD strips ahead of a thread's stream of
 * strips (their values and column indices). Its bytes per instruction are half the dense
 * panels', so the out-of-order window alone keeps too few lines in flight. Measured (Crytek
 * Sponza f16, K 2000, 2 threads, AVX-512, lrr solve medians of 40, dense in the same run):
 * none 0.26× dense, 32 strips 0.26×, 128 0.19×, 256 0.22×, 512 0.18×; with each thread's
 * chunks contiguous (OpenMP static), where dynamic chunks gave 0.28×. */
#define SPARSE_AHEAD 256
#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#define PREFETCH_STRIPS(sp, s)                                                                  \
    do {                                                                                        \
        const char *p_ = sp->val ? (const char *)(sp->val + (s) * LRR__TILE)                    \
                                 : (const char *)(sp->val16 + (s) * LRR__TILE);                 \
        _mm_prefetch(p_, _MM_HINT_T0);                                                          \
        _mm_prefetch(p_ + 64, _MM_HINT_T0);                                                     \
        if (sp->val) {                                                                          \
            _mm_prefetch(p_ + 128, _MM_HINT_T0);                                                \
            _mm_prefetch(p_ + 192, _MM_HINT_T0);                                                \
        }                                                                                       \
        _mm_prefetch((const char *)(sp->col + (s)), _MM_HINT_T0);                               \
    } while (0)
#endif

#endif
