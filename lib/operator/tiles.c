/* Counting F̄'s strips (operator.h): shared by the sparse solver's copy (lib/solve/sparse.c)
 * and the sparse section of .lrr files (lib/file/), so that a file is written sparse exactly
 * where `lrr solve --fbar auto` reads it sparse. */
#include "config.h"
#include "operator/operator.h"

_Static_assert(LRR__PANEL % LRR__TILE == 0, "a tile lies within one panel");

/* Strips and nonzeros of tile t. */
static void count_tile(const lrr_operator *op, size_t t, size_t *strips, size_t *nonzeros)
{
    const lrr__tile_at a = lrr__fbar_tile(op, t);
    size_t s = 0, nz = 0;
    for (size_t q = 0; q < op->k; q++) {
        const size_t c = lrr__fbar_tile_nonzeros(op, &a, q);
        nz += c;
        s += c != 0;
    }
    *strips = s;
    *nonzeros = nz;
}

void lrr__fbar_count_strips(const lrr_operator *op, size_t *count_at, int parallel,
                            lrr__strip_count *out)
{
    const size_t tiles = (op->n + LRR__TILE - 1) / LRR__TILE;
    size_t strips = 0, nonzeros = 0;
    #pragma omp parallel for schedule(dynamic, 64) reduction(+ : strips, nonzeros) \
        if (parallel && op->n * op->k >= LRR__PARALLEL_MIN)
    for (size_t t = 0; t < tiles; t++) {
        size_t s, nz;
        count_tile(op, t, &s, &nz);
        if (count_at)
            count_at[t] = s;
        strips += s;
        nonzeros += nz;
    }
    *out = (lrr__strip_count){tiles, strips, nonzeros};
}

size_t lrr__sparse_strip_bytes(lrr_storage storage)
{
    size_t elem = storage == LRR_STORAGE_F32 ? sizeof(float) : sizeof(uint16_t);
    return LRR__TILE * elem + sizeof(uint16_t);
}

/* strips × strip bytes ≤ n·k·4 bytes + small: no overflow once F̄ itself fits */
size_t lrr__sparse_bytes(const lrr_operator *op, size_t strips)
{
    const size_t tiles = (op->n + LRR__TILE - 1) / LRR__TILE;
    return strips * lrr__sparse_strip_bytes(op->storage) + (tiles + 1) * sizeof(size_t);
}

int lrr__sparse_pays(const lrr_operator *op, size_t strips)
{
    const size_t dense = op->n * op->k * lrr__fbar_elem_bytes(op);
    return op->k <= UINT16_MAX &&
           (double)lrr__sparse_bytes(op, strips) <= LRR__SPARSE_AUTO_SHARE * (double)dense;
}
