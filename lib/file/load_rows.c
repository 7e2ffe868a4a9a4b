/* A block of whole patches' rows of a saved operator (lrr__operator_load_rows, operator.h):
 * what a rank of a distributed solver holds (lib/solve/rows.c, lib/mpi/solver.c), loaded
 * without the rest of F̄. Everything but F̄ is read as lrr_operator_load reads it (load.c);
 * F̄'s section is streamed whole, for its checksum, a piece at a time, and only the block's
 * rows are kept: dense FBAR rows copied as they pass, FBAR_STRIPS through strips.c with a
 * window. Every entry of a strips file is checked, as a whole load checks it; of a dense
 * file the block's entries (each rank checks its own). */
#include "config.h"
#include "file/format.h"

#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

/* Pieces of about this many bytes while streaming a dense FBAR section. */
#define PIECE_BYTES ((size_t)1 << 20)

/* The block's entries of a dense FBAR: finite and in [0, FBAR_MAX] (lrr__fbar_entry_ok). */
static lrr_status check_block(struct reader *r, const lrr_operator *op,
                              const lrr__fbar_block *b)
{
    const size_t k = op->k, es = lrr__fbar_elem_bytes(op);
    const unsigned char *f = b->fbar;
    for (size_t i = 0; i < b->rows; i++)
        for (size_t q = 0; q < k; q++) {
            uint32_t raw = 0;
            memcpy(&raw, f + (i * k + q) * es, es); /* little-endian host */
            const float scale = op->row_scale ? op->row_scale[b->row0 + i] : 1.0f;
            float v;
            bool finite;
            if (lrr__fbar_entry_ok(op->storage, raw, scale, &v, &finite))
                continue;
            if (!finite)
                return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section FBAR: entry "
                                  "(%zu, %zu) is not finite", r->path, b->row0 + i, q);
            return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section FBAR: entry (%zu, %zu) "
                              "is %g (form factors divided by d lie in [0, 1])", r->path,
                              b->row0 + i, q, (double)v);
        }
    return LRR_OK;
}

/* Dense FBAR: the whole section for its checksum, the block's bytes kept. */
static lrr_status dense_rows(struct reader *r, const struct section *s,
                             const lrr_operator *op, lrr__fbar_block *b)
{
    const size_t row_bytes = op->k * lrr__fbar_elem_bytes(op);
    const uint64_t lo = (uint64_t)b->row0 * row_bytes, hi = lo + (uint64_t)b->rows * row_bytes;
    unsigned char *buf = NULL;
    lrr_status st = lrr__calloc(r->ctx, &buf, PIECE_BYTES, 1, "a piece of F̄");
    uint64_t h = lrr__checksum_begin(s->size);
    for (uint64_t pos = 0; !st && pos < s->size;) {
        const size_t len = s->size - pos < PIECE_BYTES ? (size_t)(s->size - pos) : PIECE_BYTES;
        if ((st = lrr__file_read_at(r, s->offset + pos, buf, len, "section FBAR")))
            break;
        h = lrr__checksum_run(h, buf, len);
        const uint64_t a = pos > lo ? pos : lo, z = pos + len < hi ? pos + len : hi;
        if (a < z) /* the piece's part of the block */
            memcpy((unsigned char *)b->fbar + (a - lo), buf + (a - pos), (size_t)(z - a));
        pos += len;
    }
    lrr_aligned_free(buf);
    if (st)
        return st;
    h = lrr__checksum_end(h, s->size);
    if (h != s->checksum)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section FBAR (bytes %" PRIu64 "..%" PRIu64 ") fails its "
                          "checksum (stored %016" PRIx64 ", computed %016" PRIx64 ")",
                          r->path, s->offset, s->offset + s->size, s->checksum, h);
    return check_block(r, op, b);
}

/* The block chosen by pick: patches [p0, p1) of k, rows first[p0] .. first[p1] − 1, and
 * its rows×k entries of F̄ allocated (zeroed). */
static lrr_status block_of(lrr_context *ctx, const lrr_operator *op, lrr__fbar_block *b)
{
    if (b->p0 > b->p1 || b->p1 > op->k)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "row block: patches [%zu, %zu) are not "
                          "within the operator's k = %zu", b->p0, b->p1, op->k);
    b->row0 = op->geom.first[b->p0];
    b->rows = op->geom.first[b->p1] - b->row0;
    return lrr__calloc(ctx, &b->fbar, b->rows ? b->rows : 1, op->k * lrr__fbar_elem_bytes(op),
                       "row block F̄ (rows×k)");
}

lrr_status lrr__operator_load_rows(lrr_context *ctx, const char *path, lrr__pick_fn pick,
                                   void *user, lrr_operator **out, lrr__fbar_block *b)
{
    *out = NULL;
    memset(b, 0, sizeof *b);
    struct reader r;
    struct load_head lh;
    lrr_operator *op = NULL;
    lrr_status st = lrr__load_open(ctx, path, &r, &lh);
    if (st)
        return st;
    if (!(st = lrr__load_head(&r, &lh, 0, &op)) && !(st = lrr__load_row_scales(&r, &lh, op)) &&
        !(st = lrr__load_m(&r, &lh, op)) && !(st = pick(user, op, &b->p0, &b->p1)) &&
        !(st = block_of(ctx, op, b))) {
        st = lh.hd.strips ? lrr__strips_load_rows(&r, &lh.sec[SEC_FBAR_STRIPS - 1], op, b->row0,
                                                  b->rows, b->fbar)
                          : dense_rows(&r, &lh.sec[SEC_FBAR - 1], op, b);
        if (!st) /* the weights M was factorised with, for the block's patches */
            st = lrr__visibility_weights_rows(op, b->p0, b->p1, b->fbar);
    }
    close(r.fd);
    if (st) {
        lrr_operator_destroy(op);
        lrr_aligned_free(b->fbar);
        memset(b, 0, sizeof *b);
        return st;
    }
    lrr__load_info(&lh, op);
    *out = op;
    return LRR_OK;
}
