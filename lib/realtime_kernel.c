/* The two dense products of the real-time step, written for one pass over each matrix with
 * all three colour channels at once (DESIGN.md "Low-rank model"):
 *     z = M_c w_c               (k×k, three matrices)
 *     B_c = E_c + rho_c ∘ (F̄ z_c) (n×k, read once for r, g and b; epilogue fused)
 * Why not OpenBLAS here: sgemm with 3 right-hand sides repacks F̄, three sgemv read F̄
 * three times, and OpenBLAS's pthreads fight the OpenMP threads of the rest of the solve
 * for the cores (spinning GOMP workers: `lrr demo` measured 3.9 ms per frame that way and
 * 0.25 ms with OMP_WAIT_POLICY=passive). Measured in one process on 2 cores, medians of 200
 * (the kernels here vs 3 sgemv k×k + sgemm n×k×3 vs 3 sgemv n×k, the last without the
 * epilogue): Cornell n = 3456, k = 216: 0.158 / 0.353 / 0.274 ms; n = 55296, k = 864:
 * 20.0 / 28.3 / 20.4 ms. At the larger size this portable loop is compute-bound (F̄ is
 * 191 MB, ~6.5 ms at this machine's ~30 GB/s); wider SIMD is issue 4's work.
 * The inner loops keep eight independent partial sums per channel so the compiler can
 * vectorise them without reassociating a single running sum. */
#include "config.h"
#include "internal.h"

#define LANES 8

/* dot products of one row (length k) with three vectors */
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

void lrr__smw_apply(const float *m, size_t k, const float *w, float *z)
{
    /* z (3×k, channel-major) = M_c w_c; M is three k×k row-major blocks */
    #pragma omp parallel for schedule(static) if (k >= 64)
    for (size_t p = 0; p < k; p++)
        for (int c = 0; c < 3; c++) {
            const float *row = m + ((size_t)c * k + p) * k;
            const float *wc = w + (size_t)c * k;
            float acc[LANES] = {0};
            size_t q = 0;
            for (; q + LANES <= k; q += LANES)
                for (int l = 0; l < LANES; l++)
                    acc[l] += row[q + l] * wc[q + l];
            float s = 0;
            for (int l = 0; l < LANES; l++)
                s += acc[l];
            for (; q < k; q++)
                s += row[q] * wc[q];
            z[(size_t)c * k + p] = s;
        }
}

void lrr__fbar_apply(const float *fbar, size_t n, size_t k, const float *z, const float *E,
                     const float *rho, float *B)
{
    const float *zr = z, *zg = z + k, *zb = z + 2 * k;
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++) {
        float t[3];
        dot3(fbar + i * k, zr, zg, zb, k, t);
        for (int c = 0; c < 3; c++)
            B[3 * i + c] = E[3 * i + c] + rho[3 * i + c] * t[c];
    }
}
