/* The file of lrr_mpi_operator_build_save (build_save.h): the root saves its operator
 * without F̄ through liblrr's writer (lrr__operator_save_stream), which pulls F̄'s section
 * chunk by chunk; each chunk comes from the rank that holds it, as rows in the file's
 * storage or as the strips of its tiles. The writer makes two passes (the section's
 * checksum runs over its bytes in order, then they are written), so the ranks send their
 * chunks twice, each pass started by a command from the root; the root never holds more
 * than one chunk of F̄. Strips or rows are chosen by the writer from every tile's strip
 * count, which the ranks count first (lrr__strips_encode) and the root gathers. */
#include "config.h"
#include "mpi/build_save.h"

#include <stdlib.h>
#include <string.h>

#include "file/stream.h"

#define TAG_COUNTS 16
#define TAG_STREAM 17
#define TILES_PER_CHUNK (LRR__MPI_CHUNK / 16)
enum { CMD_PASS = 1, CMD_DONE = 2 };

typedef struct bs_stream {
    lrr__fbar_stream s;   /* first: what the writer calls */
    bs_dist *d;
    size_t *tiles;        /* root: every tile's strip count (NULL: rows only) */
    size_t *mine;         /* this rank's chunks' counts, TILES_PER_CHUNK a chunk */
    unsigned char *buf;   /* one chunk's bytes (received, or a chunk's strips) */
    size_t next_chunk;    /* root: the pass's next chunk */
    int pass_open;        /* root: a pass was started and not ended */
} bs_stream;

static size_t tiles_of(const bs_dist *d, size_t c)
{
    size_t a, b;
    lrr__bs_chunk(d, c, &a, &b);
    return (b - a + 15) / 16;
}

/* Chunk c's bytes in the section, from the root's counts. */
static size_t chunk_bytes(const bs_stream *bs, size_t c, int strips)
{
    const bs_dist *d = bs->d;
    size_t a, b, bytes = 0;
    lrr__bs_chunk(d, c, &a, &b);
    if (!strips)
        return (b - a) * d->k * d->es;
    for (size_t t = 0; t < tiles_of(d, c); t++)
        bytes += lrr__strips_tile_bytes(bs->tiles[c * TILES_PER_CHUNK + t], d->es);
    return bytes;
}

/* This rank's s-th chunk as the section stores it: *data and its bytes. */
static size_t own_chunk(bs_stream *bs, size_t s, int strips, const void **data)
{
    const bs_dist *d = bs->d;
    size_t a, b, counts[TILES_PER_CHUNK];
    lrr__bs_chunk(d, (size_t)d->rank + s * (size_t)d->size, &a, &b);
    const unsigned char *rows = (const unsigned char *)d->block + s * LRR__MPI_CHUNK * d->k * d->es;
    if (!strips) {
        *data = rows;
        return (b - a) * d->k * d->es;
    }
    *data = bs->buf;
    return lrr__strips_encode(d->k, d->es, rows, b - a, counts, bs->buf);
}

/* ------------------------------------------------------------ the root */
/* The rest of an open pass, received and dropped (the writer stopped early). */
static void drain(bs_stream *bs)
{
    bs_dist *d = bs->d;
    for (; bs->pass_open && bs->next_chunk < lrr__bs_chunks(d); bs->next_chunk++) {
        const size_t c = bs->next_chunk, bytes = chunk_bytes(bs, c, bs->pass_open == 2);
        if (bytes && (int)(c % (size_t)d->size) != d->root)
            MPI_Recv(bs->buf, (int)bytes, MPI_BYTE, (int)(c % (size_t)d->size), TAG_STREAM,
                     d->comm, MPI_STATUS_IGNORE);
    }
    bs->pass_open = 0;
}

static size_t root_next(lrr__fbar_stream *fs, int strips, size_t *cursor, const void **data)
{
    bs_stream *bs = (bs_stream *)(void *)fs;
    bs_dist *d = bs->d;
    if (*cursor == 0) { /* a pass starts */
        drain(bs);
        int cmd[2] = {CMD_PASS, strips}, rc = MPI_Bcast(cmd, 2, MPI_INT, d->root, d->comm);
        if (rc != MPI_SUCCESS) {
            fs->status = lrr__mpi_failed(d->ctx, "MPI_Bcast (F̄'s pass)", rc);
            return 0;
        }
        bs->pass_open = strips ? 2 : 1;
        bs->next_chunk = 0;
    }
    while (bs->next_chunk < lrr__bs_chunks(d)) {
        const size_t c = bs->next_chunk++, bytes = chunk_bytes(bs, c, strips);
        const int owner = (int)(c % (size_t)d->size);
        if (bytes == 0)
            continue; /* tiles without strips: nothing sent */
        *cursor = c + 1;
        if (owner == d->root)
            return own_chunk(bs, c / (size_t)d->size, strips, data);
        int rc = MPI_Recv(bs->buf, (int)bytes, MPI_BYTE, owner, TAG_STREAM, d->comm,
                          MPI_STATUS_IGNORE);
        if (rc != MPI_SUCCESS) {
            fs->status = lrr__mpi_failed(d->ctx, "receiving F̄'s rows", rc);
            return 0;
        }
        *data = bs->buf;
        return bytes;
    }
    bs->pass_open = 0;
    return 0;
}

/* ------------------------------------------------------------ the others */
static lrr_status serve(bs_stream *bs)
{
    bs_dist *d = bs->d;
    int rc;
    for (;;) {
        int cmd[2];
        if ((rc = MPI_Bcast(cmd, 2, MPI_INT, d->root, d->comm)) != MPI_SUCCESS)
            break;
        if (cmd[0] != CMD_PASS)
            return LRR_OK;
        for (size_t s = 0; s < d->chunks_mine && rc == MPI_SUCCESS; s++) {
            const void *data;
            const size_t bytes = own_chunk(bs, s, cmd[1], &data);
            if (bytes)
                rc = MPI_Send(data, (int)bytes, MPI_BYTE, d->root, TAG_STREAM, d->comm);
        }
        if (rc != MPI_SUCCESS)
            break;
    }
    return lrr__mpi_failed(d->ctx, "sending F̄'s rows", rc);
}

/* ------------------------------------------------------------ counts and buffers */
/* Every tile's strip count to the root (when strips may be chosen). */
static int gather_counts(bs_stream *bs)
{
    bs_dist *d = bs->d;
    for (size_t s = 0; s < d->chunks_mine; s++) {
        size_t a, b;
        lrr__bs_chunk(d, (size_t)d->rank + s * (size_t)d->size, &a, &b);
        lrr__strips_encode(d->k, d->es,
                           (const unsigned char *)d->block + s * LRR__MPI_CHUNK * d->k * d->es,
                           b - a, bs->mine + s * TILES_PER_CHUNK, NULL);
    }
    const int count = (int)(d->chunks_mine * TILES_PER_CHUNK);
    if (d->rank != d->root)
        return count ? MPI_Send(bs->mine, count, MPI_UINT64_T, d->root, TAG_COUNTS, d->comm)
                     : MPI_SUCCESS;
    size_t *got = malloc((lrr__mpi_chunk_most(d->n, d->size) * TILES_PER_CHUNK) * sizeof *got);
    if (!got)
        return MPI_ERR_NO_MEM;
    int rc = MPI_SUCCESS;
    for (int r = 0; r < d->size && rc == MPI_SUCCESS; r++) {
        const size_t m = lrr__bs_rank_chunks(d, r);
        const size_t *from = r == d->root ? bs->mine : got;
        if (r != d->root && m)
            rc = MPI_Recv(got, (int)(m * TILES_PER_CHUNK), MPI_UINT64_T, r, TAG_COUNTS,
                          d->comm, MPI_STATUS_IGNORE);
        for (size_t s = 0; s < m && rc == MPI_SUCCESS; s++) {
            const size_t c = (size_t)r + s * (size_t)d->size;
            for (size_t t = 0; t < tiles_of(d, c); t++)
                bs->tiles[c * TILES_PER_CHUNK + t] = from[s * TILES_PER_CHUNK + t];
        }
    }
    free(got);
    return rc;
}

static lrr_status prepare(bs_stream *bs, int counted)
{
    bs_dist *d = bs->d;
    const size_t tiles = (d->n + 15) / 16;
    /* a chunk's strips: at most k columns a tile, each 2 bytes and 16 values, padded */
    const size_t cap = TILES_PER_CHUNK * (2 * (d->k + 3) + 16 * d->k * d->es) + 64;
    _Static_assert(sizeof(size_t) == sizeof(uint64_t), "counts are sent as MPI_UINT64_T");
    bs->buf = malloc(cap);
    if (counted) {
        bs->mine = calloc((d->chunks_mine + 1) * TILES_PER_CHUNK, sizeof(size_t));
        if (d->rank == d->root)
            bs->tiles = calloc(tiles + TILES_PER_CHUNK, sizeof(size_t));
    }
    const int ok = bs->buf && (!counted || (bs->mine && (d->rank != d->root || bs->tiles)));
    lrr_status st = lrr__mpi_spread(d->ctx, d->comm,
                                    ok ? LRR_OK
                                       : lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "lrr_mpi_"
                                                        "operator_build_save: cannot allocate "
                                                        "a chunk of F̄ (%zu bytes)", cap));
    if (st || !counted)
        return st;
    int rc = gather_counts(bs);
    return lrr__mpi_spread(d->ctx, d->comm, rc == MPI_SUCCESS
                                                ? LRR_OK
                                                : lrr__mpi_failed(d->ctx, "gathering F̄'s "
                                                                  "strip counts", rc));
}

lrr_status lrr__bs_save(bs_dist *d, lrr_fbar_format fbar, const char *path)
{
    bs_stream bs = {{root_next, NULL, LRR_OK}, d, NULL, NULL, NULL, 0, 0};
    /* strips are possible with 16-bit column indices, unless dense is asked for */
    const int counted = fbar != LRR_FBAR_DENSE && d->k <= UINT16_MAX;
    lrr_status st = prepare(&bs, counted);
    if (!st && d->rank == d->root) {
        bs.s.tile_strips = bs.tiles;
        st = lrr__operator_save_stream(d->head, path, fbar, &bs.s);
        drain(&bs);
        int cmd[2] = {CMD_DONE, 0}, rc = MPI_Bcast(cmd, 2, MPI_INT, d->root, d->comm);
        if (!st && rc != MPI_SUCCESS)
            st = lrr__mpi_failed(d->ctx, "MPI_Bcast (F̄'s end)", rc);
    } else if (!st) {
        st = serve(&bs);
    }
    free(bs.buf);
    free(bs.mine);
    free(bs.tiles);
    return lrr__mpi_spread(d->ctx, d->comm, st);
}
