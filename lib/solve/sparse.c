/* F̄ as the solver reads it when most of it is zero (docs/METHOD.md "Sparse F̄").
 *
 * A patch sees a few of a real scene's clusters; the rest is behind walls, and those
 * entries of F̄ are exactly 0 (no hemicube pixel landed on the cluster). The solver then
 * keeps only strips: LRR__TILE consecutive rows (a tile) × one column q where any of the
 * tile's rows is nonzero, stored as LRR__TILE values in F̄'s storage (float, or the same
 * 16-bit codes and row scales as the operator) and one 16-bit column index. A step of the
 * kernel is a vertical multiply-add of the strip by the broadcast z_q, as in the dense
 * panels (panel_kernel.c), so no gathers and no horizontal sums; B = E + rho ∘ (F̄ z) skips
 * exactly the zero products, so it equals the dense pass up to the order of the sums.
 *
 * Why strips of 16 rows (fzk_haus and bunny_room at K 2000, R 64: entry density 5.5% and
 * 12.4%): the strips hold 1.50/1.83/2.28/2.91× the nonzeros at 4/8/16/32 rows (fzk) and
 * 1.35/1.54/1.75/1.99× (bunny); with 16-bit values that is 2.5/2.25/2.13/2.06 bytes per
 * strip entry, so 8 and 16 rows read about the same bytes (0.11–0.13× and 0.21–0.23× of
 * dense binary16) and 16 rows fill one AVX-512 register per strip, half the instructions.
 * Per-entry indices (CSR) would read 4 bytes per nonzero (0.11×, 0.25×) and need gathers.
 *
 * The operator keeps F̄ dense: everything else (M's factorisation, the weights, export,
 * verification) reads it there. Files store the same strips where AUTO would read them
 * (lib/file/strips.c; the counting is shared, lib/operator/tiles.c) but load them back into
 * the dense F̄. The solver's copy is made once, when it is created (lrr_solver_set_fbar). */
#include "config.h"
#include "solve/solve.h"

#include <stdlib.h>
#include <string.h>

/* Chunks of about this many strip bytes: the tiles' strip counts vary 100× across a scene
 * (a floor sees everything, a column's back little), so the threads share chunks of equal
 * bytes rather than equal numbers of tiles, each thread a contiguous run of them (OpenMP
 * static: one stream per thread for the prefetchers; realtime_rows.h's SPARSE_AHEAD). */
#define CHUNK_BYTES ((size_t)64 << 10)

void lrr__sparse_destroy(lrr__sparse *sp)
{
    if (!sp)
        return;
    lrr_aligned_free(sp->start);
    lrr_aligned_free(sp->col);
    lrr_aligned_free(sp->val);
    lrr_aligned_free(sp->val16);
    lrr_aligned_free(sp->chunk);
    free(sp);
}

/* Tile t's strips at sp->start[t] (rows past n stay 0, as calloc left them). */
static void fill_tile(const lrr_operator *op, lrr__sparse *sp, size_t t)
{
    const lrr__tile_at a = lrr__fbar_tile(op, t);
    size_t s = sp->start[t];
    for (size_t q = 0; q < op->k; q++) {
        if (!lrr__fbar_tile_nonzeros(op, &a, q))
            continue;
        sp->col[s] = (uint16_t)q;
        const size_t at = a.base + q * a.sq;
        for (size_t r = 0; r < a.rows; r++)
            if (sp->val)
                sp->val[s * LRR__TILE + r] = op->fbar[at + r * a.si];
            else
                sp->val16[s * LRR__TILE + r] = op->fbar16[at + r * a.si];
        s++;
    }
}

/* chunk boundaries: tiles whose strips add up to about CHUNK_BYTES each */
static lrr_status make_chunks(lrr_context *ctx, lrr__sparse *sp)
{
    const size_t per = CHUNK_BYTES / lrr__sparse_strip_bytes(sp->storage) + 1;
    size_t chunks = sp->strips / per + 1;
    if (chunks > sp->tiles)
        chunks = sp->tiles;
    lrr_status st = lrr__calloc(ctx, &sp->chunk, chunks + 1, sizeof(size_t), "sparse F̄ chunks");
    if (st)
        return st;
    size_t t = 0;
    for (size_t c = 1; c < chunks; c++) {
        const size_t want = sp->strips / chunks * c;
        while (t < sp->tiles && sp->start[t] < want)
            t++;
        sp->chunk[c] = t;
    }
    sp->chunk[chunks] = sp->tiles;
    sp->chunks = chunks;
    return LRR_OK;
}

lrr_status lrr__sparse_create(const lrr_operator *op, lrr_fbar_format format,
                              lrr__sparse_stats *stats, lrr__sparse **out)
{
    lrr_context *ctx = op->ctx;
    *out = NULL;
    lrr__sparse *sp = lrr__zalloc(ctx, sizeof *sp);
    if (!sp)
        return lrr__error(ctx, LRR_ERR_NOMEM, "cannot allocate a sparse F̄");
    sp->n = op->n;
    sp->k = op->k;
    sp->storage = op->storage;
    sp->tiles = (op->n + LRR__TILE - 1) / LRR__TILE;
    lrr_status st = lrr__calloc(ctx, &sp->start, sp->tiles + 1, sizeof(size_t), "sparse F̄ tiles");
    if (st) {
        lrr__sparse_destroy(sp);
        return st;
    }
    lrr__strip_count count;
    lrr__fbar_count_strips(op, sp->start + 1, 1, &count); /* start[t + 1]: tile t's strips */
    for (size_t t = 0; t < sp->tiles; t++)
        sp->start[t + 1] += sp->start[t];
    sp->strips = count.strips;
    sp->nonzeros = count.nonzeros;
    sp->bytes = lrr__sparse_bytes(op, sp->strips);
    stats->nonzeros = count.nonzeros;
    stats->strips = sp->strips;
    stats->bytes = sp->bytes;
    /* auto: sparse where it reads at most LRR__SPARSE_AUTO_SHARE of the dense bytes */
    const int want = format == LRR_FBAR_SPARSE ||
                     (format == LRR_FBAR_AUTO && lrr__sparse_pays(op, sp->strips));
    if (!want || op->k > UINT16_MAX) {
        lrr__sparse_destroy(sp);
        if (format == LRR_FBAR_SPARSE)
            return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                              "sparse F̄: k = %zu patches exceeds the 16-bit column index "
                              "(at most %u)", op->k, (unsigned)UINT16_MAX);
        return LRR_OK;
    }
    if (op->storage == LRR_STORAGE_F32)
        st = lrr__calloc(ctx, &sp->val, sp->strips ? sp->strips : 1,
                         LRR__TILE * sizeof(float), "sparse F̄ values");
    else
        st = lrr__calloc(ctx, &sp->val16, sp->strips ? sp->strips : 1,
                         LRR__TILE * sizeof(uint16_t), "sparse F̄ values");
    if (!st)
        st = lrr__calloc(ctx, &sp->col, sp->strips ? sp->strips : 1, sizeof(uint16_t),
                         "sparse F̄ columns");
    if (!st)
        st = make_chunks(ctx, sp);
    if (st) {
        lrr__sparse_destroy(sp);
        return st;
    }
    sp->scale = op->storage == LRR_STORAGE_F32 ? NULL : op->row_scale;
    #pragma omp parallel for schedule(dynamic, 64) if (op->n * op->k >= LRR__PARALLEL_MIN)
    for (size_t t = 0; t < sp->tiles; t++)
        fill_tile(op, sp, t);
    *out = sp;
    return LRR_OK;
}

void lrr__sparse_apply_frames(const lrr__kernel *kn, const lrr__sparse *sp, size_t count,
                              const float *z, const float *E, const float *rho, float *B)
{
    const size_t n = sp->n, k = sp->k;
    #pragma omp parallel for schedule(static) \
        if (sp->strips * LRR__TILE * count >= LRR__PARALLEL_MIN)
    for (size_t c = 0; c < sp->chunks; c++)
        for (size_t f = 0; f < count; f++) /* a chunk's strips serve every frame from cache */
            kn->sparse_tiles(sp, sp->chunk[c], sp->chunk[c + 1], z + 3 * k * f, E + 3 * n * f,
                             rho, B + 3 * n * f);
}

/* ------------------------------------------------------------------ portable tiles */

/* The portable tile kernel (the SIMD ones in realtime_avx2.c, realtime_avx512.c share its
 * epilogue): acc[c][r] = Σ_strips value(r) z_c[q], then the rows' B. */
void lrr__sparse_epilogue(const lrr__sparse *sp, size_t t, float acc[3][LRR__TILE],
                          const float *E, const float *rho, float *B)
{
    const size_t i0 = t * LRR__TILE, i1 = i0 + LRR__TILE < sp->n ? i0 + LRR__TILE : sp->n;
    for (size_t i = i0; i < i1; i++) {
        const float s = sp->scale ? sp->scale[i] : 1.0f;
        for (int c = 0; c < 3; c++)
            B[3 * i + c] = E[3 * i + c] + rho[3 * i + c] * (s * acc[c][i - i0]);
    }
}

void lrr__sparse_tiles_c(const lrr__sparse *sp, size_t t0, size_t t1, const float *z,
                         const float *E, const float *rho, float *B)
{
    const size_t k = sp->k;
    for (size_t t = t0; t < t1; t++) {
        float acc[3][LRR__TILE] = {{0}};
        for (size_t s = sp->start[t]; s < sp->start[t + 1]; s++) {
            const size_t q = sp->col[s];
            float v[LRR__TILE];
            for (int r = 0; r < LRR__TILE; r++)
                v[r] = sp->val ? sp->val[s * LRR__TILE + r]
                       : sp->storage == LRR_STORAGE_F16
                           ? lrr__f16_to_f32(sp->val16[s * LRR__TILE + r])
                           : lrr__bf16_to_f32(sp->val16[s * LRR__TILE + r]);
            for (int c = 0; c < 3; c++) {
                const float zc = z[c * k + q];
                for (int r = 0; r < LRR__TILE; r++)
                    acc[c][r] += v[r] * zc;
            }
        }
        lrr__sparse_epilogue(sp, t, acc, E, rho, B);
    }
}
