/* The file of lrr_mpi_operator_build_save (build_save.h), written by every rank: the root
 * saves its operator without F̄ through liblrr's writer (lrr__operator_save_placed), which
 * creates the temporary file and calls root_place() before anything else; the ranks then
 * open that file with MPI-IO and each writes its own chunks of F̄'s section (rows in the
 * file's storage, or the strips of their tiles) at their offsets, so no rank sends F̄ to
 * another and the section is written in parallel.
 *
 * The section's checksum runs over its bytes in order (lrr_file.c's format), so the ranks
 * run it as a chain in chunk order: chunk c's rank receives the state from chunk c − 1's
 * rank (8 bytes), runs it over its chunk and passes it on; the last chunk's rank sends it to
 * the root, which puts it in the table. The hashing is sequential (as it is serially), the
 * writes are not. Strips or rows are chosen by the writer from every tile's strip count,
 * which the ranks count first (lrr__strips_encode) and the root gathers; with strips the
 * root broadcasts every chunk's offset, which follows from the counts. The file is the
 * serial one byte for byte but for its timings; it needs a file system every rank sees
 * (MPI-IO's premise). */
#include "config.h"
#include "mpi/build_save.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "file/stream.h"

#define TAG_COUNTS 16
#define TAG_HASH 17
#define TAG_HASH_END 18
#define TILES_PER_CHUNK (LRR__MPI_CHUNK / 16)
#define TMP_MAX_BYTES 4096 /* the temporary file's name, with its NUL (PATH_MAX) */
enum { CMD_PLACE = 1, CMD_DONE = 2 };

typedef struct bs_writer {
    lrr__fbar_placer p;   /* first: what the writer calls */
    bs_dist *d;
    size_t *tiles;        /* root: every tile's strip count (NULL: rows only) */
    size_t *mine;         /* this rank's chunks' counts, TILES_PER_CHUNK a chunk */
    unsigned char *buf;   /* a chunk's strips */
    uint64_t *at;         /* every chunk's first byte in F̄'s placed bytes (chunks + 1) */
} bs_writer;

static size_t tiles_of(const bs_dist *d, size_t c)
{
    size_t a, b;
    lrr__bs_chunk(d, c, &a, &b);
    return (b - a + 15) / 16;
}

/* Chunk c's bytes in the section, from the root's counts. */
static size_t chunk_bytes(const bs_writer *bs, size_t c, int strips)
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
static size_t own_chunk(bs_writer *bs, size_t s, int strips, const void **data)
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

/* ------------------------------------------------------------ the placed section */
/* Every chunk's offset in the placed bytes: from the rows, or (strips) the root's counts,
 * broadcast. */
static lrr_status offsets(bs_writer *bs, int strips)
{
    bs_dist *d = bs->d;
    const size_t chunks = lrr__bs_chunks(d);
    if (!strips || d->rank == d->root) {
        bs->at[0] = 0;
        for (size_t c = 0; c < chunks; c++)
            bs->at[c + 1] = bs->at[c] + chunk_bytes(bs, c, strips);
    }
    int rc = strips ? MPI_Bcast(bs->at, (int)(chunks + 1), MPI_UINT64_T, d->root, d->comm)
                    : MPI_SUCCESS;
    return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(d->ctx, "MPI_Bcast (F̄'s offsets)", rc);
}

/* Chunk c's bytes at `at` of the file. */
static lrr_status write_at(bs_writer *bs, MPI_File fh, const char *tmp, size_t c, uint64_t at,
                           const void *data, size_t bytes)
{
    bs_dist *d = bs->d;
    MPI_Status ms;
    int got = 0, rc = MPI_File_write_at(fh, (MPI_Offset)at, data, (int)bytes, MPI_BYTE, &ms);
    if (rc == MPI_SUCCESS && MPI_Get_count(&ms, MPI_BYTE, &got) == MPI_SUCCESS &&
        got == (int)bytes)
        return LRR_OK;
    char text[MPI_MAX_ERROR_STRING] = "";
    int len = 0;
    if (rc != MPI_SUCCESS)
        MPI_Error_string(rc, text, &len);
    else
        snprintf(text, sizeof text, "%d of %zu bytes written", got, bytes);
    size_t a, b;
    lrr__bs_chunk(d, c, &a, &b);
    return lrr__mpi_error(d->ctx, LRR_ERR_IO, "file %s: cannot write F̄'s rows %zu to %zu "
                          "(MPI_File_write_at: %s)", tmp, a, b - 1, text);
}

/* This rank's chunks at offset + at[c], the checksum's state *h passed along the chain
 * (*h: the state before chunk 0 on entry, the root's after the last chunk on return). A
 * failed write stops this rank's writes, not the chain. */
static lrr_status write_chunks(bs_writer *bs, MPI_File fh, const char *tmp, uint64_t offset,
                               int strips, uint64_t *h)
{
    bs_dist *d = bs->d;
    const size_t chunks = lrr__bs_chunks(d), P = (size_t)d->size;
    const int next = (d->rank + 1) % d->size, prev = (d->rank + d->size - 1) % d->size;
    lrr_status st = LRR_OK;
    int rc = MPI_SUCCESS;
    for (size_t s = 0; s < d->chunks_mine && rc == MPI_SUCCESS; s++) {
        const size_t c = (size_t)d->rank + s * P;
        if (c > 0 && P > 1 &&
            (rc = MPI_Recv(h, 1, MPI_UINT64_T, prev, TAG_HASH, d->comm, MPI_STATUS_IGNORE)))
            break;
        const void *data;
        const size_t bytes = own_chunk(bs, s, strips, &data);
        *h = lrr__checksum_run(*h, data, bytes);
        if (c + 1 < chunks && P > 1)
            rc = MPI_Send(h, 1, MPI_UINT64_T, next, TAG_HASH, d->comm);
        else if (c + 1 == chunks && d->rank != d->root)
            rc = MPI_Send(h, 1, MPI_UINT64_T, d->root, TAG_HASH_END, d->comm);
        if (!st && bytes)
            st = write_at(bs, fh, tmp, c, offset + bs->at[c], data, bytes);
    }
    const int last = (int)((chunks - 1) % P);
    if (rc == MPI_SUCCESS && d->rank == d->root && last != d->root)
        rc = MPI_Recv(h, 1, MPI_UINT64_T, last, TAG_HASH_END, d->comm, MPI_STATUS_IGNORE);
    return rc == MPI_SUCCESS ? st : lrr__mpi_failed(d->ctx, "passing F̄'s checksum", rc);
}

/* Every rank: the temporary file opened with MPI-IO, the chunks written, synced, closed;
 * agreed. */
static lrr_status place_all(bs_writer *bs, const char *tmp, uint64_t offset, int strips,
                            uint64_t *h)
{
    bs_dist *d = bs->d;
    lrr_status st = lrr__mpi_spread(d->ctx, d->comm, offsets(bs, strips));
    if (st)
        return st;
    MPI_File fh;
    int rc = MPI_File_open(d->comm, (char *)tmp, MPI_MODE_WRONLY, MPI_INFO_NULL, &fh);
    if (rc != MPI_SUCCESS) {
        char text[MPI_MAX_ERROR_STRING] = "";
        int len = 0;
        MPI_Error_string(rc, text, &len);
        st = lrr__mpi_error(d->ctx, LRR_ERR_IO, "file %s: cannot open it to write this rank's "
                            "rows of F̄ (MPI_File_open: %s); every rank must see the root's "
                            "file system", tmp, text);
    }
    /* MPI_File_open is collective and fails alike on every rank for a bad name; a rank
     * alone that cannot open leaves the others' handles unclosed */
    if ((st = lrr__mpi_spread(d->ctx, d->comm, st)))
        return st;
    st = write_chunks(bs, fh, tmp, offset, strips, h);
    /* the other ranks' bytes on disk before the root renames the file into place */
    if ((rc = MPI_File_sync(fh)) != MPI_SUCCESS && !st)
        st = lrr__mpi_failed(d->ctx, "MPI_File_sync", rc);
    if ((rc = MPI_File_close(&fh)) != MPI_SUCCESS && !st)
        st = lrr__mpi_failed(d->ctx, "MPI_File_close", rc);
    return lrr__mpi_spread(d->ctx, d->comm, st);
}

/* The writer's call on the root: the command, offset and state to the others, then its
 * own part. */
static lrr_status root_place(lrr__fbar_placer *fp, const char *tmp, uint64_t offset,
                             int strips, uint64_t *h)
{
    bs_writer *bs = (bs_writer *)(void *)fp;
    bs_dist *d = bs->d;
    const size_t len = strlen(tmp) + 1;
    if (len > TMP_MAX_BYTES)
        return lrr__mpi_error(d->ctx, LRR_ERR_INVALID_ARG, "file %s: the name is longer than "
                              "%d bytes", tmp, TMP_MAX_BYTES);
    uint64_t cmd[5] = {CMD_PLACE, (uint64_t)strips, offset, *h, len};
    int rc = MPI_Bcast(cmd, 5, MPI_UINT64_T, d->root, d->comm);
    if (rc == MPI_SUCCESS)
        rc = MPI_Bcast((char *)tmp, (int)len, MPI_CHAR, d->root, d->comm);
    if (rc != MPI_SUCCESS)
        return lrr__mpi_failed(d->ctx, "MPI_Bcast (F̄'s file)", rc);
    return place_all(bs, tmp, offset, strips, h);
}

/* The other ranks: each place command joined, until the root's end. */
static lrr_status serve(bs_writer *bs)
{
    bs_dist *d = bs->d;
    char tmp[TMP_MAX_BYTES];
    int rc;
    for (;;) {
        uint64_t cmd[5];
        if ((rc = MPI_Bcast(cmd, 5, MPI_UINT64_T, d->root, d->comm)) != MPI_SUCCESS)
            break;
        if (cmd[0] != CMD_PLACE)
            return LRR_OK;
        if ((rc = MPI_Bcast(tmp, (int)cmd[4], MPI_CHAR, d->root, d->comm)) != MPI_SUCCESS)
            break;
        tmp[cmd[4] - 1] = '\0';
        uint64_t h = cmd[3];
        (void)place_all(bs, tmp, cmd[2], (int)cmd[1], &h); /* agreed: the root's save ends */
    }
    return lrr__mpi_failed(d->ctx, "receiving F̄'s file", rc);
}

/* ------------------------------------------------------------ counts and buffers */
/* Every tile's strip count to the root (when strips may be chosen). */
static int gather_counts(bs_writer *bs)
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

static lrr_status prepare(bs_writer *bs, int counted)
{
    bs_dist *d = bs->d;
    const size_t tiles = (d->n + 15) / 16;
    /* a chunk's strips: at most k columns a tile, each 2 bytes and 16 values, padded */
    const size_t cap = TILES_PER_CHUNK * (2 * (d->k + 3) + 16 * d->k * d->es) + 64;
    _Static_assert(sizeof(size_t) == sizeof(uint64_t), "counts are sent as MPI_UINT64_T");
    bs->buf = malloc(cap);
    bs->at = malloc((lrr__bs_chunks(d) + 1) * sizeof *bs->at);
    if (counted) {
        bs->mine = calloc((d->chunks_mine + 1) * TILES_PER_CHUNK, sizeof(size_t));
        if (d->rank == d->root)
            bs->tiles = calloc(tiles + TILES_PER_CHUNK, sizeof(size_t));
    }
    const int ok = bs->buf && bs->at &&
                   (!counted || (bs->mine && (d->rank != d->root || bs->tiles)));
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
    bs_writer bs = {{root_place, NULL}, d, NULL, NULL, NULL, NULL};
    /* strips are possible with 16-bit column indices, unless dense is asked for */
    const int counted = fbar != LRR_FBAR_DENSE && d->k <= UINT16_MAX;
    lrr_status st = prepare(&bs, counted);
    if (!st && d->rank == d->root) {
        bs.p.tile_strips = bs.tiles;
        st = lrr__operator_save_placed(d->head, path, fbar, &bs.p);
        uint64_t cmd[5] = {CMD_DONE, 0, 0, 0, 0};
        int rc = MPI_Bcast(cmd, 5, MPI_UINT64_T, d->root, d->comm);
        if (!st && rc != MPI_SUCCESS)
            st = lrr__mpi_failed(d->ctx, "MPI_Bcast (F̄'s end)", rc);
    } else if (!st) {
        st = serve(&bs);
    }
    free(bs.buf);
    free(bs.at);
    free(bs.mine);
    free(bs.tiles);
    return lrr__mpi_spread(d->ctx, d->comm, st);
}
