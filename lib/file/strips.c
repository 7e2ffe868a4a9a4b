/* Section FBAR_STRIPS of .lrr files (version 5; the layout is specified at the top of
 * lrr_file.c): F̄ as the strips of 16 rows × 1 column that hold a nonzero, the same strips
 * the sparse solver reads (operator.h, tiles.c). Saving produces the section as pieces of
 * whole tiles from the operator's F̄ in any layout; loading streams it back a piece at a
 * time into the operator's zeroed dense F̄ (panels or rows), checking every strip and the
 * checksum in the same pass, so no second copy of F̄ is ever held. */
#include "config.h"
#include "file/format.h"

#include <inttypes.h>
#include <stdarg.h>
#include <stdio.h>

/* Pieces of about this many bytes (or one whole tile, if larger) when saving and loading. */
#define PIECE_BYTES ((size_t)1 << 20)

/* u16 entries padded to a multiple of 4 (8 bytes), and a tile block's bytes for m strips of
 * es-byte values; m <= 65535, so neither overflows. */
static uint64_t pad4(uint64_t m) { return (m + 3) & ~(uint64_t)3; }
static uint64_t tile_bytes(uint64_t m, size_t es) { return 2 * pad4(m) + LRR__TILE * es * m; }
static uint16_t get16(const unsigned char *p) { uint16_t v; memcpy(&v, p, 2); return v; }

/* ------------------------------------------------------------ saving */
/* Tile t's block into out (zeroed by the caller): its columns, then 16 values per strip. */
static void put_tile(const struct strips_out *so, size_t t, unsigned char *out)
{
    const lrr_operator *op = so->op;
    const lrr__tile_at a = lrr__fbar_tile(op, t);
    const size_t es = lrr__fbar_elem_bytes(op);
    const unsigned char *f = lrr__fbar_data(op);
    unsigned char *val = out + 2 * pad4(so->count[t]);
    size_t j = 0;
    for (size_t q = 0; q < op->k; q++) {
        if (!lrr__fbar_tile_nonzeros(op, &a, q))
            continue;
        const uint16_t col = (uint16_t)q;
        memcpy(out + 2 * j, &col, 2);
        for (size_t r = 0; r < a.rows; r++) /* rows past n stay 0 */
            memcpy(val + (j * LRR__TILE + r) * es, f + (a.base + q * a.sq + r * a.si) * es, es);
        j++;
    }
}

/* Piece 0: the strip counts; then runs of whole tiles up to the buffer's size. */
static size_t strips_next(struct pieces *p, size_t *cursor, const void **data)
{
    struct strips_out *so = (struct strips_out *)(void *)p;
    const size_t es = lrr__fbar_elem_bytes(so->op);
    *data = so->buf;
    if (*cursor == 0) {
        const size_t bytes = (size_t)strips_counts_bytes(so->op->n);
        memset(so->buf, 0, bytes);
        for (size_t t = 0; t < so->tiles; t++) {
            const uint16_t m = (uint16_t)so->count[t];
            memcpy(so->buf + 2 * t, &m, 2);
        }
        *cursor = 1;
        return bytes;
    }
    size_t t = *cursor - 1, used = 0;
    while (t < so->tiles && used + tile_bytes(so->count[t], es) <= so->cap) {
        const size_t b = (size_t)tile_bytes(so->count[t], es);
        memset(so->buf + used, 0, b);
        put_tile(so, t++, so->buf + used);
        used += b;
    }
    *cursor = t + 1;
    return used;
}

/* Whether column q of the tile at block (rows × k elements of es bytes, row-major) has an
 * entry whose bits are not all zero, as lrr__fbar_tile_nonzeros counts. */
static int column_set(const unsigned char *block, size_t rows, size_t k, size_t es, size_t q)
{
    for (size_t r = 0; r < rows; r++) {
        const unsigned char *e = block + (r * k + q) * es;
        for (size_t b = 0; b < es; b++)
            if (e[b])
                return 1;
    }
    return 0;
}

size_t lrr__strips_encode(size_t k, size_t es, const void *rows, size_t nrows, size_t *counts,
                          unsigned char *out)
{
    const unsigned char *f = rows;
    size_t bytes = 0;
    for (size_t t = 0; t * LRR__TILE < nrows; t++) {
        const size_t r0 = t * LRR__TILE, tr = nrows - r0 < LRR__TILE ? nrows - r0 : LRR__TILE;
        const unsigned char *tile = f + r0 * k * es;
        size_t m = 0;
        for (size_t q = 0; q < k; q++)
            m += (size_t)column_set(tile, tr, k, es, q);
        counts[t] = m;
        const size_t tb = (size_t)tile_bytes(m, es);
        if (out) { /* as put_tile writes it */
            unsigned char *blk = out + bytes, *val = blk + 2 * pad4(m);
            memset(blk, 0, tb);
            size_t j = 0;
            for (size_t q = 0; q < k; q++) {
                if (!column_set(tile, tr, k, es, q))
                    continue;
                const uint16_t col = (uint16_t)q;
                memcpy(blk + 2 * j, &col, 2);
                for (size_t r = 0; r < tr; r++)
                    memcpy(val + (j * LRR__TILE + r) * es, tile + (r * k + q) * es, es);
                j++;
            }
        }
        bytes += tb;
    }
    return bytes;
}

size_t lrr__strips_tile_bytes(size_t m, size_t es) { return (size_t)tile_bytes(m, es); }

lrr_status lrr__strips_out_init(const lrr_operator *op, struct strips_out *so, uint64_t *size,
                                int *sparse_pays)
{
    const size_t es = lrr__fbar_elem_bytes(op);
    *so = (struct strips_out){{strips_next}, op, (op->n + LRR__TILE - 1) / LRR__TILE, NULL,
                              NULL, 0};
    lrr_status st = lrr__calloc(op->ctx, &so->count, so->tiles, sizeof(size_t),
                                "F̄ strip counts");
    if (st)
        return st;
    lrr__strip_count c;
    lrr__fbar_count_strips(op, so->count, 0, &c); /* serial: see operator.h */
    *sparse_pays = lrr__sparse_pays(op, c.strips);
    /* the strips hold at most n·k entries plus 2 bytes of column each: below twice F̄'s
     * bytes, which fit in memory */
    uint64_t total = strips_counts_bytes(op->n), widest = total;
    for (size_t t = 0; t < so->tiles; t++) {
        const uint64_t b = tile_bytes(so->count[t], es);
        total += b;
        widest = b > widest ? b : widest;
    }
    *size = total;
    so->cap = widest > PIECE_BYTES ? (size_t)widest : PIECE_BYTES;
    if ((st = lrr__calloc(op->ctx, &so->buf, so->cap, 1, "a piece of F̄'s strips")))
        lrr__strips_out_free(so); /* the caller frees nothing on an error */
    return st;
}

void lrr__strips_out_free(struct strips_out *so)
{
    lrr_aligned_free(so->count);
    lrr_aligned_free(so->buf);
    so->count = NULL;
    so->buf = NULL;
}

/* ------------------------------------------------------------ loading */
struct strips_in {
    struct reader *r;
    const struct section *s;
    lrr_operator *op;
    const unsigned char *counts; /* the section's strip counts */
    size_t tiles, es;
    char msg[512]; /* the first fault found, reported only if the checksum holds */
    unsigned char *win; /* NULL: into op's F̄; else rows [row0, row0 + rows) only, row-major */
    size_t row0, rows;
};

/* Records a fault of the section (the message after "section FBAR_STRIPS: ") without
 * reporting it yet: the context keeps the first error it is told. */
static lrr_status defer(struct strips_in *in, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));
static lrr_status defer(struct strips_in *in, const char *fmt, ...)
{
    char what[384];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    snprintf(in->msg, sizeof in->msg, "file %s: section FBAR_STRIPS: %s", in->r->path, what);
    return LRR_ERR_CORRUPT;
}

/* LRR_ERR_CORRUPT naming the section, tile t and, below SIZE_MAX, strip j (column q). */
static lrr_status tile_error(struct strips_in *in, size_t t, size_t j, unsigned q,
                             const char *fmt, ...) __attribute__((format(printf, 5, 6)));
static lrr_status tile_error(struct strips_in *in, size_t t, size_t j, unsigned q,
                             const char *fmt, ...)
{
    const size_t i0 = t * LRR__TILE, n = in->op->n;
    const size_t last = (i0 + LRR__TILE < n ? i0 + LRR__TILE : n) - 1;
    char what[256], strip[64] = "";
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    if (j != SIZE_MAX)
        snprintf(strip, sizeof strip, " strip %zu (column %u)", j, q);
    return defer(in, "tile %zu (rows %zu..%zu)%s: %s", t, i0, last, strip, what);
}

/* Checks the strip counts (each at most k, zero padding) and that they give the section's
 * size; *widest is the largest tile block. */
static lrr_status check_counts(struct strips_in *in, uint64_t *widest)
{
    const size_t k = in->op->k;
    uint64_t total = strips_counts_bytes(in->op->n);
    *widest = 0;
    for (size_t t = 0; t < in->tiles; t++) {
        const unsigned m = get16(in->counts + 2 * t);
        if (m > k)
            return tile_error(in, t, SIZE_MAX, 0, "%u strips, more than k = %zu", m, k);
        const uint64_t b = tile_bytes(m, in->es);
        total += b; /* at most 2^16 tiles' bytes per tile, tiles < 2^60: no overflow */
        *widest = b > *widest ? b : *widest;
    }
    for (size_t t = in->tiles; t < pad4(in->tiles); t++)
        if (get16(in->counts + 2 * t) != 0)
            return defer(in, "the padding after the %zu strip counts is not zero", in->tiles);
    if (total != in->s->size)
        return defer(in, "%" PRIu64 " bytes, its strip counts need %" PRIu64, in->s->size,
                     total);
    return LRR_OK;
}

/* Strip j of tile t at val (16 values), column q: checked entry by entry as the dense path
 * checks F̄, and stored into the operator's F̄ at a. */
static lrr_status put_strip(struct strips_in *in, size_t t, size_t j, unsigned q,
                            const unsigned char *val, const lrr__tile_at *a)
{
    lrr_operator *op = in->op;
    unsigned char *f = in->win                          ? in->win
                       : op->storage == LRR_STORAGE_F32 ? (unsigned char *)op->fbar
                                                        : (unsigned char *)op->fbar16;
    /* a window's op holds rows (a.base = i0·k): its entry (i, q) at (i − row0)·k + q */
    const size_t off = in->win ? in->row0 * op->k : 0;
    for (size_t r = 0; r < LRR__TILE; r++) {
        uint32_t raw = 0;
        memcpy(&raw, val + r * in->es, in->es); /* little-endian host */
        const size_t i = t * LRR__TILE + r;
        if (r >= a->rows) {
            if (raw != 0)
                return tile_error(in, t, j, q, "row %zu, past n = %zu, is not 0", i, op->n);
            continue;
        }
        float v;
        bool finite;
        if (!lrr__fbar_entry_ok(op->storage, raw, op->row_scale ? op->row_scale[i] : 1.0f, &v,
                                &finite))
            return finite ? tile_error(in, t, j, q, "row %zu is %g (form factors divided by d "
                                       "lie in [0, 1])", i, (double)v)
                          : tile_error(in, t, j, q, "row %zu is not finite", i);
        if (!in->win || (i >= in->row0 && i - in->row0 < in->rows))
            memcpy(f + (a->base + q * a->sq + r * a->si - off) * in->es, &raw, in->es);
    }
    return LRR_OK;
}

/* Tile t's block at p: its columns (below k, strictly ascending, zero padding) and values. */
static lrr_status put_tile_in(struct strips_in *in, size_t t, const unsigned char *p)
{
    const size_t m = get16(in->counts + 2 * t), k = in->op->k;
    const lrr__tile_at a = lrr__fbar_tile(in->op, t);
    const unsigned char *val = p + 2 * pad4(m);
    lrr_status st;
    for (size_t j = 0; j < m; j++) {
        const unsigned q = get16(p + 2 * j), prev = j ? get16(p + 2 * j - 2) : 0;
        if (q >= k)
            return tile_error(in, t, j, q, "column %u is not below k = %zu", q, k);
        if (j && q <= prev)
            return tile_error(in, t, j, q, "column %u after column %u (columns ascend "
                              "strictly within a tile)", q, prev);
        if ((st = put_strip(in, t, j, q, val + j * LRR__TILE * in->es, &a)))
            return st;
    }
    for (size_t j = m; j < pad4(m); j++)
        if (get16(p + 2 * j) != 0)
            return tile_error(in, t, SIZE_MAX, 0, "the padding after its %zu columns is not "
                              "zero", m);
    return LRR_OK;
}

/* Reads the rest of the section from byte pos into buf (cap bytes) for the checksum h; while
 * *bad is LRR_OK, its tiles from *t are also checked and stored (the first error in *bad). */
static lrr_status stream_tiles(struct strips_in *in, uint64_t pos, unsigned char *buf,
                               size_t cap, uint64_t *h, lrr_status *bad)
{
    size_t t = 0;
    while (pos < in->s->size) {
        size_t used = 0, t1 = t;
        if (*bad) /* no tiles to place: whole buffers for the checksum */
            used = in->s->size - pos < cap ? (size_t)(in->s->size - pos) : cap;
        else
            while (t1 < in->tiles &&
                   used + tile_bytes(get16(in->counts + 2 * t1), in->es) <= cap)
                used += (size_t)tile_bytes(get16(in->counts + 2 * t1++), in->es);
        if (used == 0) /* only empty tiles left: the counts gave the size, so none */
            break;
        lrr_status st = lrr__file_read_at(in->r, in->s->offset + pos, buf, used,
                                          "section FBAR_STRIPS");
        if (st)
            return st;
        *h = lrr__checksum_run(*h, buf, used);
        for (size_t off = 0; !*bad && t < t1; t++) {
            *bad = put_tile_in(in, t, buf + off);
            off += (size_t)tile_bytes(get16(in->counts + 2 * t), in->es);
        }
        pos += used;
    }
    return LRR_OK;
}

static lrr_status strips_in(struct reader *r, const struct section *s, lrr_operator *op,
                            unsigned char *win, size_t row0, size_t rows)
{
    struct strips_in in = {r, s, op, NULL, (op->n + LRR__TILE - 1) / LRR__TILE,
                           lrr__fbar_elem_bytes(op), "", win, row0, rows};
    const size_t cbytes = (size_t)strips_counts_bytes(op->n); /* <= s->size, checked */
    unsigned char *counts = NULL, *buf = NULL;
    uint64_t widest = 0, h = lrr__checksum_begin(s->size);
    lrr_status st = lrr__calloc(r->ctx, &counts, cbytes, 1, "FBAR_STRIPS strip counts");
    if (st || (st = lrr__file_read_at(r, s->offset, counts, cbytes, "section FBAR_STRIPS")))
        goto done;
    h = lrr__checksum_run(h, counts, cbytes);
    in.counts = counts;
    /* a bad count or column is reported only once the checksum holds: a damaged file is
     * named as such, one written wrong by what went wrong */
    lrr_status bad = check_counts(&in, &widest);
    const size_t cap = !bad && widest > PIECE_BYTES ? (size_t)widest : PIECE_BYTES;
    if ((st = lrr__calloc(r->ctx, &buf, cap, 1, "a piece of F̄'s strips")) ||
        (st = stream_tiles(&in, cbytes, buf, cap, &h, &bad)))
        goto done;
    h = lrr__checksum_end(h, s->size);
    if (h != s->checksum)
        st = lrr__error(r->ctx, LRR_ERR_CORRUPT,
                        "file %s: section FBAR_STRIPS (bytes %" PRIu64 "..%" PRIu64
                        ") fails its checksum (stored %016" PRIx64 ", computed %016" PRIx64 ")",
                        r->path, s->offset, s->offset + s->size, s->checksum, h);
    else if (bad)
        st = lrr__error(r->ctx, bad, "%s", in.msg);
done:
    lrr_aligned_free(counts);
    lrr_aligned_free(buf);
    return st;
}

lrr_status lrr__strips_load(struct reader *r, const struct section *s, lrr_operator *op)
{
    return strips_in(r, s, op, NULL, 0, 0);
}

lrr_status lrr__strips_load_rows(struct reader *r, const struct section *s,
                                 const lrr_operator *op, size_t row0, size_t rows, void *win)
{
    /* op is only read: its F̄ is not touched with a window, and its row layout (panels 0)
     * places the window's entries */
    return strips_in(r, s, (lrr_operator *)(uintptr_t)op, win, row0, rows);
}
