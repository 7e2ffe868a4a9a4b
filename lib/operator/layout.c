/* F̄'s layout in memory: rows, or panels of LRR__PANEL rows stored column-major (operator.h).
 * The real-time kernel reads panels: each column of a panel is one or two vector registers,
 * multiplied by the broadcast z_r, z_g, z_b with no horizontal sums and no tail per row.
 * Measured on this project's AMD EPYC VM (AVX-512, 2 threads, n = 221184, k = 216, 191 MB,
 * medians of 40 in one process): the 8-row AVX-512 row kernel 9.3 ms, panels of 32 rows
 * 3.98 ms, a read loop over the same bytes 4.75 ms; f16 6.4 ms against 2.2 ms.
 * The .lrr file keeps rows (lrr_file.c converts while writing, load.c after reading). */
#include "config.h"
#include "operator/operator.h"

#include <omp.h>
#include <string.h>

/* one block of LRR__PANEL rows (k columns, elements of type T) from rows to columns or back */
#define DEFINE_TRANSPOSE(NAME, T)                                                           \
    static void NAME(T *blk, T *tmp, size_t k, int to_panels)                              \
    {                                                                                      \
        memcpy(tmp, blk, LRR__PANEL * k * sizeof(T));                                      \
        for (size_t r = 0; r < LRR__PANEL; r++)                                            \
            for (size_t q = 0; q < k; q++) {                                               \
                if (to_panels)                                                             \
                    blk[q * LRR__PANEL + r] = tmp[r * k + q];                              \
                else                                                                       \
                    blk[r * k + q] = tmp[q * LRR__PANEL + r];                              \
            }                                                                              \
    }
DEFINE_TRANSPOSE(transpose32, float)
DEFINE_TRANSPOSE(transpose16, uint16_t)

lrr_status lrr__fbar_set_panels(lrr_operator *op, int panels)
{
    panels = panels != 0;
    if (op->panels == panels)
        return LRR_OK;
    const size_t k = op->k, es = lrr__fbar_elem_bytes(op), blocks = op->n / LRR__PANEL;
    const int threads = omp_get_max_threads();
    unsigned char *tmp;
    /* n×k elements are held already, so one block's LRR__PANEL·k·es bytes cannot overflow */
    lrr_status st = lrr__calloc(op->ctx, &tmp, (size_t)threads, LRR__PANEL * k * es,
                                "F̄ layout scratch (one block of rows per thread)");
    if (st)
        return st;
    const size_t bs = LRR__PANEL * k; /* elements per block */
    #pragma omp parallel for schedule(static) num_threads(threads)
    for (size_t b = 0; b < blocks; b++) {
        unsigned char *t = tmp + (size_t)omp_get_thread_num() * bs * es;
        if (op->storage == LRR_STORAGE_F32)
            transpose32(op->fbar + b * bs, (float *)(void *)t, k, panels);
        else
            transpose16(op->fbar16 + b * bs, (uint16_t *)(void *)t, k, panels);
    }
    lrr_aligned_free(tmp);
    op->panels = panels;
    return LRR_OK;
}

void lrr__fbar_copy_rows(const lrr_operator *op, size_t i0, size_t i1, void *out)
{
    const size_t k = op->k, es = lrr__fbar_elem_bytes(op);
    const unsigned char *f = lrr__fbar_data(op);
    unsigned char *o = out;
    const size_t p = lrr__fbar_panel_rows(op);
    for (size_t i = i0; i < i1; i++) {
        if (i >= p) {
            memcpy(o + (i - i0) * k * es, f + i * k * es, (i1 - i) * k * es);
            return;
        }
        size_t r = i % LRR__PANEL, base = (i - r) * k + r;
        if (es == sizeof(float))
            for (size_t q = 0; q < k; q++)
                ((float *)out)[(i - i0) * k + q] = op->fbar[base + LRR__PANEL * q];
        else
            for (size_t q = 0; q < k; q++)
                ((uint16_t *)out)[(i - i0) * k + q] = op->fbar16[base + LRR__PANEL * q];
    }
}

lrr_status lrr_operator_set_layout(lrr_operator *op, lrr_layout layout)
{
    if (layout != LRR_LAYOUT_PANELS && layout != LRR_LAYOUT_ROWS)
        return lrr__error(op->ctx, LRR_ERR_INVALID_ARG, "unknown layout %d", (int)layout);
    lrr_status st = lrr__need_fbar(op, "lrr_operator_set_layout");
    return st ? st : lrr__fbar_set_panels(op, layout == LRR_LAYOUT_PANELS);
}

const float *lrr_operator_fbar(const lrr_operator *op)
{
    return op->panels ? NULL : op->fbar;
}
