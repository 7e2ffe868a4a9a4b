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
 * AVX2 and AVX-512 variants (realtime_avx2.c, realtime_avx512.c), chosen at run time
 * (lrr__kernel_select): at n = 55296, k = 864 they run 10.0 (AVX2) and 8.2 ms (AVX-512)
 * against 20.1 ms for the portable loop.
 *
 * Layout: the row kernels here read F̄ row-major: an operator's last n % 32 rows, and all
 * of F̄ after lrr_operator_set_layout(op, LRR_LAYOUT_ROWS). A row is a contiguous stream,
 * and its dot products with z_r, z_g, z_b reuse the three short vectors from L1; several
 * rows share each z load (realtime_avx2.c's ROWS_AVX2, realtime_avx512.c's ROWS_AVX512). The rest of F̄ is held in panels and
 * read by panel_kernel.c, which needs no horizontal sums (why: see there).
 */
#include "config.h"
#include "solve/realtime_rows.h"

#include <stdlib.h>
#include <string.h>

#define LANES 8

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

void lrr__rows_f32_c(const float *fbar, size_t i0, size_t i1, size_t k, const float *z,
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
void lrr__rows_half_c(const uint16_t *fbar, const float *scale, int bf16, size_t i0, size_t i1,
                      size_t k, const float *z, const float *E, const float *rho, float *B)
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

void lrr__rows_f16_c(const uint16_t *fbar, const float *scale, size_t i0, size_t i1, size_t k,
                     const float *z, const float *E, const float *rho, float *B)
{
    lrr__rows_half_c(fbar, scale, 0, i0, i1, k, z, E, rho, B);
}

void lrr__rows_bf16_c(const uint16_t *fbar, const float *scale, size_t i0, size_t i1, size_t k,
                      const float *z, const float *E, const float *rho, float *B)
{
    lrr__rows_half_c(fbar, scale, 1, i0, i1, k, z, E, rho, B);
}

void lrr__gemv_rows_c(const float *a, size_t i0, size_t i1, size_t k, const float *x, float *y)
{
    for (size_t i = i0; i < i1; i++)
        y[i] = dot1(a + i * k, x, k);
}

/* binary16 rows in blocks decoded to float, as lrr__rows_half_c */
void lrr__gemv_f16_rows_c(const uint16_t *a, const float *scale, size_t i0, size_t i1,
                          size_t k, const float *x, float *y)
{
    enum { BLK = 256 };
    float buf[BLK];
    for (size_t i = i0; i < i1; i++) {
        const uint16_t *row = a + i * k;
        float t = 0;
        for (size_t p0 = 0; p0 < k; p0 += BLK) {
            size_t m = k - p0 < BLK ? k - p0 : BLK;
            for (size_t q = 0; q < m; q++)
                buf[q] = lrr__f16_to_f32(row[p0 + q]);
            t += dot1(buf, x + p0, m);
        }
        y[i] = scale[i] * t;
    }
}

/* ------------------------------------------------------------------ dispatch */

/* Each ISA twice: with the hardware prefetcher alone (AMD) and with the panels' software
 * prefetch (panel_kernel.c's PREFETCH_AHEAD, measured on an Intel Xeon); core/cpu.c picks
 * the level and the twin. */
static const lrr__kernel kernels[] = {
    {"c", LRR__ISA_C, 0, lrr__rows_f32_c, lrr__rows_f16_c, lrr__rows_bf16_c, lrr__gemv_rows_c,
     lrr__gemv_f16_rows_c, lrr__panels_f32_c, lrr__panels_f16_c, lrr__panels_bf16_c,
     lrr__sparse_tiles_c},
#if defined(__x86_64__) || defined(__i386__)
#define ROWS(ISA)                                                                            \
    lrr__rows_f32_##ISA, lrr__rows_f16_##ISA, lrr__rows_bf16_##ISA, lrr__gemv_rows_##ISA,       \
        lrr__gemv_f16_rows_##ISA
    {"avx2", LRR__ISA_AVX2, 0, ROWS(avx2), lrr__panels_f32_avx2, lrr__panels_f16_avx2,
     lrr__panels_bf16_avx2, lrr__sparse_tiles_avx2},
    {"avx2+prefetch", LRR__ISA_AVX2, 1, ROWS(avx2), lrr__panels_f32_avx2_pf,
     lrr__panels_f16_avx2_pf, lrr__panels_bf16_avx2_pf, lrr__sparse_tiles_avx2},
    {"avx512", LRR__ISA_AVX512, 0, ROWS(avx512), lrr__panels_f32_avx512,
     lrr__panels_f16_avx512, lrr__panels_bf16_avx512, lrr__sparse_tiles_avx512},
    {"avx512+prefetch", LRR__ISA_AVX512, 1, ROWS(avx512), lrr__panels_f32_avx512_pf,
     lrr__panels_f16_avx512_pf, lrr__panels_bf16_avx512_pf, lrr__sparse_tiles_avx512},
#undef ROWS
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

void lrr__smw_apply_f16(const lrr__kernel *kn, const uint16_t *m16, const float *scale, size_t k,
                        const float *w, float *z)
{
    const size_t blocks = (k + ROW_BLOCK - 1) / ROW_BLOCK;
    #pragma omp parallel for schedule(static) if (3 * k * k >= LRR__PARALLEL_MIN)
    for (size_t b = 0; b < 3 * blocks; b++) {
        size_t c = b / blocks, i0 = (b % blocks) * ROW_BLOCK;
        size_t i1 = i0 + ROW_BLOCK < k ? i0 + ROW_BLOCK : k;
        kn->gemv_f16_rows(m16 + c * k * k, scale + c * k, i0, i1, k, w + c * k, z + c * k);
        for (size_t i = i0; i < i1; i++) /* the identity M − I left out */
            z[c * k + i] += w[c * k + i];
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
