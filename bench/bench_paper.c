/*
 * lrr-bench: the paper's real-time step as the baseline (B_c = E_c - Y_c (Vᵀ E_c), cblas,
 * channels planar) and the row-major copy of F̄ that the OpenBLAS baselines read.
 */
#include <stdint.h>
#include <string.h>

#include "bench.h"

/* ---------------------------------------------------------------- the paper's method */
int bench_paper_step(void *user)
{
    paper_frame *f = user;
    for (int c = 0; c < 3; c++) {
        cblas_sgemv(CblasRowMajor, CblasTrans, f->n, f->k, 1.0f, f->v, f->k, f->e[c], 1, 0.0f,
                    f->w, 1);
        cblas_scopy(f->n, f->e[c], 1, f->b[c], 1);
        cblas_sgemv(CblasRowMajor, CblasNoTrans, f->n, f->k, -1.0f, f->y[c], f->k, f->w, 1, 1.0f,
                    f->b[c], 1);
    }
    return 0;
}

void bench_paper_free(paper_frame *f)
{
    lrr_aligned_free(f->v);
    lrr_aligned_free(f->w);
    for (int c = 0; c < 3; c++) {
        lrr_aligned_free(f->y[c]);
        lrr_aligned_free(f->e[c]);
        lrr_aligned_free(f->b[c]);
    }
    memset(f, 0, sizeof *f);
}

/* F̄ row-major in a new buffer (NULL when it cannot be allocated), whatever the operator's
 * storage and layout: the OpenBLAS baselines read rows, the operator holds panels. */
float *bench_fbar_rows(const lrr_operator *op)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *f = bench_alloc_floats(oi.n, oi.k);
    for (size_t i = 0; f && i < oi.n; i++)
        lrr_operator_fbar_row(op, i, f + i * oi.k);
    return f;
}

float *bench_alloc_floats(size_t a, size_t b)
{
    if (a == 0 || b == 0 || a > SIZE_MAX / sizeof(float) / b)
        return NULL;
    float *p = lrr_aligned_alloc(a * b * sizeof(float));
    if (p)
        memset(p, 0, a * b * sizeof(float));
    return p;
}

/* Builds the paper's Y_c and V from the operator (sgemm, outside any timing). */
int bench_paper_setup(const lrr_operator *op, const float *e, paper_frame *f)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    size_t n = oi.n, k = oi.k, d = oi.d;
    memset(f, 0, sizeof *f);
    f->n = (blasint)n;
    f->k = (blasint)k;
    f->v = bench_alloc_floats(n, k);
    f->w = bench_alloc_floats(k, 1);
    for (int c = 0; c < 3; c++) {
        f->y[c] = bench_alloc_floats(n, k);
        f->e[c] = bench_alloc_floats(n, 1);
        f->b[c] = bench_alloc_floats(n, 1);
    }
    if (!f->v || !f->w || !f->y[0] || !f->y[1] || !f->y[2] || !f->e[0] || !f->e[1] ||
        !f->e[2] || !f->b[0] || !f->b[1] || !f->b[2]) {
        bench_paper_free(f);
        return bench_fail("the paper's method: cannot allocate 4 n×k matrices (%.1f MB)",
                          4.0 * (double)n * (double)k * 4 / MB);
    }
    float *fbar = bench_fbar_rows(op);
    if (!fbar) {
        bench_paper_free(f);
        return bench_fail("the paper's method: cannot allocate a row-major copy of F̄");
    }
    const float *m = lrr_operator_m(op), *rho = lrr_operator_reflectance(op);
    for (size_t i = 0; i < n; i++) {
        f->v[i * k + i / d] = 1.0f;
        for (int c = 0; c < 3; c++)
            f->e[c][i] = e[3 * i + c];
    }
    for (int c = 0; c < 3; c++) {
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, f->n, f->k, f->k, 1.0f, fbar,
                    f->k, m + (size_t)c * k * k, f->k, 0.0f, f->y[c], f->k);
        float *y = f->y[c];
        #pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++) {
            float r = -rho[3 * i + c];
            for (size_t p = 0; p < k; p++)
                y[i * k + p] *= r;
        }
    }
    lrr_aligned_free(fbar);
    return 0;
}
