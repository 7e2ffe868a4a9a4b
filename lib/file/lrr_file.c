/* The versioned binary operator file (.lrr): lrr_operator_save here, lrr_operator_load in
 * load.c (its value checks in check.c), FBAR_STRIPS both ways in strips.c; the constants and
 * helpers they share are in format.h.
 *
 * Format, versions 1 to 5. All integers and floats are little-endian (IEEE 754); offsets and
 * sizes are in bytes from the start of the file. Version 2 adds the adaptive hierarchy
 * (d = 0 and a PATCHES section), version 3 the cluster hierarchy (d = 0 and a CLUSTERS
 * section), version 4 the same sections as 3 for clusters whose Vᵀ weights follow F̄'s row
 * sums (lib/operator/weights.c; M was factorised with them, so a reader that knows only
 * version 3's area weights must refuse the file); uniform operators are still written as
 * version 1, adaptive ones as version 2 and area-weighted clusters (loaded from version 3)
 * as version 3, so readers that know only those keep reading them. Version 5 is any of these
 * with F̄ stored as strips (FBAR_STRIPS instead of FBAR; lrr_operator_save_fbar, which by
 * default chooses it where the solver's sparse copy would take at most half of FBAR's bytes,
 * lrr_solver_create's AUTO): a reader of versions 1 to 4 refuses it by its version rather
 * than missing FBAR. Files with dense F̄ keep the versions 1 to 4 and their bytes.
 *
 *   Header, 64 bytes at offset 0
 *      0  magic        8 bytes  "LRROPER\0"
 *      8  version      u32      1 (uniform), 2 (adaptive), 3 or 4 (clusters), 5 (any, F̄
 *                               as strips)
 *     12  endianness   u32      0x01020304 (reads 0x04030201 on a byte-swapped file)
 *     16  header_size  u32      64
 *     20  sections     u32      number of entries in the section table (6, plus ROWSCALE,
 *                               PATCHES or CLUSTERS and VERIFY where present)
 *     24  n            u64      subpatches
 *     32  k            u64      patches
 *     40  d            u64      subpatches per patch (n = k·d, d = 4^levels); 0 in
 *                               versions 2 to 4: patch sizes vary, given by PATCHES
 *                               or CLUSTERS; in version 5 either (d = 0: exactly one of
 *                               PATCHES and CLUSTERS says which hierarchy)
 *     48  dtype        u32      storage of F̄ (FBAR or FBAR_STRIPS): 0 = float32,
 *                               1 = binary16, 2 = bfloat16
 *                               (RHO, EMISSION, M and ROWSCALE are float32 always)
 *     52  reserved     u32      0
 *     56  checksum     u64      checksum of bytes 0..55
 *   The first 16 bytes (magic, version, endianness) keep their meaning in every version, so
 *   any reader can tell "another version" apart from "not an lrr file".
 *
 *   Section table at offset 64: `sections` entries of 32 bytes
 *      0  id u32   4  reserved u32 (0)   8  offset u64   16  size u64   24  checksum u64
 *   followed by a u64 checksum of the entries. Readers skip unknown ids; each known id
 *   appears exactly once. Writers list the sections in id order, FBAR_STRIPS in FBAR's place.
 *
 *   Sections, each starting at a multiple of 64 (zero padding in between; padding is covered
 *   by no checksum and readers ignore it). Section checksums cover exactly `size` bytes.
 *     1 GEOMETRY  n_tri u64, levels u32, builtin i32 (LRR__SCENE_*), vertices n_tri×9 float
 *                 (x0 y0 z0 x1 … z2 per input triangle), patch depth n_tri u8:
 *                 size 16 + 37·n_tri. k, n, d follow from depth and levels and must agree
 *                 with the header.
 *     2 RHO       n×3 float, each in [0,1)
 *     3 EMISSION  n×3 float, finite and >= 0
 *     4 FBAR      (versions 1 to 4) n×k elements of dtype, row-major (64-byte aligned so the
 *                 file could be mapped); for dtype 1 and 2 row i holds F̄_i / ROWSCALE_i
 *     5 M         3×k×k float, row-major, channel-major
 *     6 INFO      cond[3] f64, build_seconds f64, hemicube_resolution u32, flags u32
 *                 (bit 0: built without the random rotation; bit 1: hemicubes sampled
 *                 over the receivers' areas, LRR_RECEIVER_AREA; bit 2, version 5 with
 *                 CLUSTERS only: the clusters' Vᵀ weights follow F̄'s row sums, as in
 *                 version 4, else those of version 3; other bits 0), seed u64: size 48
 *     7 ROWSCALE  n float, positive powers of two; present exactly when dtype is 1 or 2
 *     8 PATCHES   (version 2, adaptive hierarchy only) selection_seconds f64, then k u8:
 *                 the quadtree depth of each patch within its triangle, in patch order;
 *                 GEOMETRY then has levels 0 and its depths are the subpatch depths, and
 *                 the nodes must tile every triangle (size 8 + k)
 *     9 CLUSTERS  (versions 3 and 4, cluster hierarchy only) selection_seconds f64, then k+1 u64
 *                 (first: patch p holds the patch-major subpatches first[p] ..
 *                 first[p+1]-1; 0, ascending, n), then n u64 (origin: the triangle-order
 *                 subpatch at each patch-major position, a permutation of 0..n-1); RHO,
 *                 EMISSION and the rows of FBAR are in patch-major order; GEOMETRY has
 *                 levels 0 and its depths are the subpatch depths (size 16 + 8·(k + n))
 *    10 VERIFY    (optional, any version; lrr_operator_verify) rel_l2 f64, noise f64,
 *                 seconds f64, subpatches u64 (1..n), samples u64 (>= 2), flags u32 (bit 0:
 *                 verified for the uniform emission), reserved u32: size 48. Readers that do
 *                 not know it skip it.
 *    11 FBAR_STRIPS  (version 5 only, instead of FBAR) F̄ in tiles of 16 rows, tile t the
 *                 rows 16t .. 16t+15 (T = ⌈n/16⌉ tiles, the last one cut at n), kept as
 *                 strips: the columns q of a tile with a nonzero entry (any bit set, so −0
 *                 counts), in the file's dtype (for dtype 1 and 2 divided by ROWSCALE, as
 *                 FBAR); every other entry is +0. k <= 65535. The section holds
 *                   counts  T u16: tile t's number of strips m_t (at most k), zero-padded
 *                           to a multiple of 4 entries (8 bytes)
 *                 then for each tile t in order a block of
 *                   columns m_t u16, strictly ascending, each < k, zero-padded to a
 *                           multiple of 4 entries
 *                   values  m_t × 16 elements of dtype: strip j's entries of rows 16t .. 16t+15
 *                           in order (rows >= n: 0)
 *                 size 2·⌈T/4⌉·4 + Σ_t (2·⌈m_t/4⌉·4 + 16·m_t·e), e = 4 or 2 the bytes of
 *                 dtype; each part a multiple of 8 bytes. Writers keep only strips with a
 *                 nonzero entry (readers accept others). A reader checks the counts against
 *                 k and the size, then streams the tiles straight into F̄'s dense storage,
 *                 checking every column and value as FBAR's (finite, in [0, 1 + 2^-7]) and
 *                 the checksum on the way: no second copy of F̄.
 *   Centres, normals and areas are not stored: they are recomputed from the geometry.
 *   (dtype 1 and 2 came after the first files: a reader that knows only float32 refuses them
 *   by their dtype, so the version stayed 1.)
 *
 * Checksum: h = 0xcbf29ce484222325 ^ len; for each little-endian 64-bit word w (the last one
 * zero-padded) h = (h ^ w) · 0x100000001b3 mod 2^64; finally the MurmurHash3 fmix64 of
 * h ^ len. One multiply per 8 bytes keeps it memory-bound, and it provably detects any
 * change confined to one 64-bit word (in particular any single bit flip): the words before
 * the changed one give the same state h; x -> (h ^ x)·P is injective because P is odd
 * (invertible mod 2^64), so the state after that word differs; every later step h -> (h ^ w)·P
 * and the final mix (xor-shifts and odd multiplies) are bijections of the state, so the
 * difference survives to the output. It is an integrity check, not a defence against a
 * deliberate forgery.
 *
 * Writing goes to "path.tmp.XXXXXX" in the same directory, is flushed and fsynced, then
 * renamed onto path, so a crash or an error never leaves a half file under the final name.
 * An error removes the temporary file; a process killed while saving cannot, and leaves it
 * (tests/file/test_save_faults.c kills saves at every step).
 * Loading checks every size against the real file size before allocating anything, so a
 * corrupted header cannot make it allocate (or read) more than the file holds; the one
 * exception is version 5's dense F̄, n·k entries expanded from its strips, which RHO (n×3
 * floats) and M (3×k×k floats) still bound by the file size: n·k <= (size/12)^1.5.
 */
#include "config.h"
#include "core/atomic_file.h"
#include "file/format.h"
#include "operator/operator.h"

#include <string.h>

/* ------------------------------------------------------------ checksum */
static uint64_t fmix64(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ULL;
    h ^= h >> 33;
    return h;
}

/* the checksum's running state over the next len bytes (a multiple of 8 except at the end) */
static uint64_t checksum_run(uint64_t h, const void *data, size_t len)
{
    const unsigned char *p = data;
    const uint64_t prime = 0x100000001b3ULL;
    size_t words = len / 8;
    for (size_t i = 0; i < words; i++) {
        uint64_t w;
        memcpy(&w, p + 8 * i, 8); /* host is little-endian (checked before any use) */
        h = (h ^ w) * prime;
    }
    size_t tail = len % 8;
    if (tail) {
        uint64_t w = 0;
        memcpy(&w, p + 8 * words, tail);
        h = (h ^ w) * prime;
    }
    return h;
}

uint64_t lrr__checksum_run(uint64_t h, const void *data, size_t len)
{
    return checksum_run(h, data, len);
}
uint64_t lrr__checksum_begin(uint64_t len) { return 0xcbf29ce484222325ULL ^ len; }
uint64_t lrr__checksum_end(uint64_t h, uint64_t len) { return fmix64(h ^ len); }

uint64_t lrr__file_checksum(const void *data, size_t len)
{
    return lrr__checksum_end(checksum_run(lrr__checksum_begin(len), data, len), len);
}

/* The checksum of a payload given as pieces. */
static uint64_t pieces_checksum(struct pieces *p, uint64_t len)
{
    uint64_t h = lrr__checksum_begin(len);
    size_t cursor = 0, got;
    const void *data;
    while ((got = p->next(p, &cursor, &data)) != 0)
        h = checksum_run(h, data, got);
    return lrr__checksum_end(h, len);
}

/* FBAR is written as rows whatever the operator's layout (operator.h), a block of
 * LRR__PANEL rows at a time through a scratch block: a block's bytes are a multiple of 8
 * (LRR__PANEL·k·2), as pieces need. */
struct rows_out {
    struct pieces base;
    const lrr_operator *op;
    void *blk;     /* LRR__PANEL rows as stored */
    size_t row_bytes;
};

/* The rows of the block from row *cursor into ro->blk; their bytes. */
static size_t rows_next(struct pieces *p, size_t *cursor, const void **data)
{
    struct rows_out *ro = (struct rows_out *)(void *)p;
    const size_t i = *cursor, n = ro->op->n;
    if (i >= n)
        return 0;
    const size_t i1 = i + LRR__PANEL < n ? i + LRR__PANEL : n;
    lrr__fbar_copy_rows(ro->op, i, i1, ro->blk);
    *cursor = i1;
    *data = ro->blk;
    return (i1 - i) * ro->row_bytes;
}

static uint64_t align_up(uint64_t x) { return (x + (ALIGN - 1)) & ~(uint64_t)(ALIGN - 1); }

/* ------------------------------------------------------------ saving */
struct writer {
    lrr__atomic_file file;
    uint64_t pos;
};

static void w_bytes(struct writer *w, const void *p, size_t len)
{
    lrr__atomic_write(&w->file, p, len);
    w->pos += len;
}

static void w_pad_to(struct writer *w, uint64_t offset)
{
    static const unsigned char zeros[ALIGN];
    while (!w->file.err && w->pos < offset) {
        uint64_t gap = offset - w->pos;
        w_bytes(w, zeros, gap < ALIGN ? (size_t)gap : ALIGN);
    }
}

/* The payloads built for saving: GEOMETRY into *geom_out, PATCHES (adaptive = 1) or
 * CLUSTERS (adaptive = 2) into *patches_out, allocated in that order (the caller frees both), and INFO into info. */
static lrr_status build_payloads(const lrr_operator *op, uint64_t geom_size, int adaptive,
                                 unsigned char **geom_out, unsigned char **patches_out,
                                 unsigned char info[INFO_SIZE])
{
    lrr_context *ctx = op->ctx;
    const lrr__geometry *g = &op->geom;
    unsigned char *geom = NULL;
    lrr_status st = lrr__calloc(ctx, &geom, (size_t)geom_size, 1, "GEOMETRY section");
    if (st)
        return st;
    put64(geom, g->n_tri);
    put32(geom + 8, g->levels);
    int32_t builtin = op->builtin;
    memcpy(geom + 12, &builtin, 4);
    memcpy(geom + GEOM_PREFIX, g->vert, g->n_tri * 9 * sizeof(float));
    memcpy(geom + GEOM_PREFIX + g->n_tri * 9 * sizeof(float), g->depth, g->n_tri);

    /* adaptive: PATCHES holds the node depths; clusters: CLUSTERS the offsets and origins;
     * the buffer is freed with geom's by the caller */
    unsigned char *patches = NULL;
    if (adaptive == 1) {
        if ((st = lrr__calloc(ctx, &patches, op->k + PATCHES_PREFIX, 1, "PATCHES section"))) {
            lrr_aligned_free(geom);
            return st;
        }
        memcpy(patches, &op->selection_seconds, 8);
        memcpy(patches + PATCHES_PREFIX, g->node, op->k);
    } else if (adaptive == 2) {
        if ((st = lrr__calloc(ctx, &patches, op->k + 1 + op->n + 1, 8, "CLUSTERS section"))) {
            lrr_aligned_free(geom);
            return st;
        }
        memcpy(patches, &op->selection_seconds, 8);
        for (size_t p = 0; p <= op->k; p++)
            put64(patches + CLUSTERS_PREFIX + 8 * p, g->first[p]);
        for (size_t i = 0; i < op->n; i++)
            put64(patches + CLUSTERS_PREFIX + 8 * (op->k + 1 + i), g->origin[i]);
    }

    for (int c = 0; c < 3; c++)
        memcpy(info + 8 * c, &op->cond[c], 8);
    memcpy(info + 24, &op->build_seconds, 8);
    put32(info + 32, op->hemicube_resolution);
    put32(info + 36, (op->no_rotation ? 1u : 0u) |
                         (op->receiver_sampling == LRR_RECEIVER_AREA ? 2u : 0u));
    put64(info + 40, op->seed);
    *geom_out = geom;
    *patches_out = patches;
    return LRR_OK;
}

/* The version a file of op has: 5 with F̄ as strips, else by its hierarchy (1 to 4). */
static uint32_t file_version(const lrr_operator *op, int adaptive, int strips)
{
    if (strips)
        return FILE_VERSION_STRIPS;
    if (adaptive == 2)
        return op->weighting == LRR__WEIGHTS_VISIBILITY ? FILE_VERSION_VISIBILITY
                                                        : FILE_VERSION_CLUSTER;
    return adaptive ? FILE_VERSION_ADAPTIVE : FILE_VERSION;
}

/* Places the count sections of sec (offsets and checksums) and writes the section table and
 * the header for a file of the given version; returns the size of the table. */
static size_t lay_out(const lrr_operator *op, uint32_t version, struct section *sec, int count,
                      unsigned char *table, unsigned char header[HEADER_SIZE])
{
    const size_t tsize = (size_t)count * ENTRY_SIZE + 8;
    uint64_t pos = HEADER_SIZE + tsize;
    for (int s = 0; s < count; s++) {
        sec[s].offset = align_up(pos);
        sec[s].checksum = sec[s].placed ? 0 /* known once placed: write_file */
                          : sec[s].pieces ? pieces_checksum(sec[s].pieces, sec[s].size)
                                          : lrr__file_checksum(sec[s].data, (size_t)sec[s].size);
        pos = sec[s].offset + sec[s].size; /* below the in-memory sizes: cannot overflow */
        unsigned char *e = table + s * ENTRY_SIZE;
        put32(e, sec[s].id);
        put64(e + 8, sec[s].offset);
        put64(e + 16, sec[s].size);
        put64(e + 24, sec[s].checksum);
    }
    put64(table + (size_t)count * ENTRY_SIZE,
          lrr__file_checksum(table, (size_t)count * ENTRY_SIZE));

    memcpy(header, MAGIC, 8);
    put32(header + 8, version);
    put32(header + 12, ENDIAN_MARK);
    put32(header + 16, HEADER_SIZE);
    put32(header + 20, (uint32_t)count);
    put64(header + 24, op->n);
    put64(header + 32, op->k);
    put64(header + 40, op->d);
    put32(header + 48, (uint32_t)op->storage);
    put64(header + 56, lrr__file_checksum(header, 56));
    return tsize;
}

/* Section s's placed bytes written by p into w's temporary file, after the bytes of data
 * before them (strip counts), its checksum then put in the table (count entries). */
static lrr_status place(lrr__fbar_placer *p, const char *tmp, struct section *sec, int s,
                        int count, unsigned char *table)
{
    const uint64_t head = sec[s].size - sec[s].placed;
    uint64_t h = lrr__checksum_begin(sec[s].size);
    if (head)
        h = checksum_run(h, sec[s].data, (size_t)head);
    lrr_status st = p->place(p, tmp, sec[s].offset + head, sec[s].id == SEC_FBAR_STRIPS, &h);
    if (st)
        return st;
    sec[s].checksum = lrr__checksum_end(h, sec[s].size);
    put64(table + (size_t)s * ENTRY_SIZE + 24, sec[s].checksum);
    put64(table + (size_t)count * ENTRY_SIZE,
          lrr__file_checksum(table, (size_t)count * ENTRY_SIZE));
    return LRR_OK;
}

/* Writes header, table and sections to path; a placed section (at most one) first, by p. */
static lrr_status write_file(lrr_context *ctx, const char *path, const unsigned char *header,
                             unsigned char *table, size_t tsize, struct section *sec,
                             int count, lrr__fbar_placer *p)
{
    /* through the atomic writer (core/atomic_file.c), its steps seen by the fault hook */
    lrr__atomic_io io;
    lrr__context_atomic_io(ctx, &io);
    struct writer w = {{0}, 0};
    lrr_status failed = LRR_OK;
    if (!lrr__atomic_open(&w.file, path, &io)) {
        for (int s = 0; s < count && !failed; s++)
            if (sec[s].placed)
                failed = place(p, w.file.tmp, sec, s, count, table);
        w_bytes(&w, header, HEADER_SIZE);
        w_bytes(&w, table, tsize);
        for (int s = 0; s < count && !failed; s++) {
            w_pad_to(&w, sec[s].offset);
            struct pieces *pc = sec[s].pieces;
            size_t cursor = 0, got;
            const void *data;
            while (pc && !w.file.err && (got = pc->next(pc, &cursor, &data)) != 0)
                w_bytes(&w, data, got);
            if (!pc)
                w_bytes(&w, sec[s].data, (size_t)(sec[s].size - sec[s].placed));
            if (sec[s].placed && !lrr__atomic_skip(&w.file, sec[s].placed))
                w.pos += sec[s].placed; /* the placer's bytes */
        }
        if (failed) /* F̄ was not placed: no file under path */
            lrr__atomic_abort(&w.file);
        else
            lrr__atomic_commit(&w.file);
    }
    lrr_status st = failed ? failed : w.file.err ? lrr__atomic_error(ctx, &w.file) : LRR_OK;
    lrr__atomic_free(&w.file);
    return st;
}

/* Whether F̄ goes into the file as FBAR_STRIPS (*strips; so then holds them) or as FBAR. */
static lrr_status choose_fbar(const lrr_operator *op, const char *path, lrr_fbar_format format,
                              struct strips_out *so, uint64_t *strips_size, int *strips)
{
    *strips = 0;
    if (format == LRR_FBAR_DENSE)
        return LRR_OK;
    if (op->k > UINT16_MAX) /* beyond the 16-bit column index: dense unless forced */
        return format == LRR_FBAR_AUTO
                   ? LRR_OK
                   : lrr__error(op->ctx, LRR_ERR_UNSUPPORTED,
                                "file %s: F̄ as strips: k = %zu patches exceeds the 16-bit "
                                "column index (at most %u)", path, op->k, (unsigned)UINT16_MAX);
    int pays;
    lrr_status st = lrr__strips_out_init(op, so, strips_size, &pays);
    if (st)
        return st;
    *strips = format == LRR_FBAR_SPARSE || pays;
    if (!*strips)
        lrr__strips_out_free(so);
    return LRR_OK;
}

/* choose_fbar for a placed F̄ (lrr__operator_save_placed): strips from the placer's counts
 * as AUTO would choose them (*size their section's bytes, *counts the counts that open it,
 * *counts_bytes of them; freed by the caller). */
static lrr_status choose_placed(const lrr_operator *op, const char *path, lrr_fbar_format format,
                                const lrr__fbar_placer *src, unsigned char **counts,
                                size_t *counts_bytes, uint64_t *size, int *strips)
{
    *strips = 0;
    if (format == LRR_FBAR_DENSE || (format == LRR_FBAR_AUTO && op->k > UINT16_MAX))
        return LRR_OK;
    if (op->k > UINT16_MAX || !src->tile_strips)
        return lrr__error(op->ctx, op->k > UINT16_MAX ? LRR_ERR_UNSUPPORTED : LRR_ERR_INVALID_ARG,
                          "file %s: F̄ as strips: %s", path,
                          op->k > UINT16_MAX ? "k exceeds the 16-bit column index"
                                             : "the placer has no strip counts");
    const size_t es = lrr__fbar_elem_bytes(op), tiles = (op->n + LRR__TILE - 1) / LRR__TILE;
    size_t total = 0;
    uint64_t bytes = strips_counts_bytes(op->n);
    for (size_t t = 0; t < tiles; t++) {
        total += src->tile_strips[t];
        bytes += lrr__strips_tile_bytes(src->tile_strips[t], es);
    }
    if (format == LRR_FBAR_AUTO && !lrr__sparse_pays(op, total))
        return LRR_OK;
    *counts_bytes = (size_t)strips_counts_bytes(op->n);
    lrr_status st = lrr__calloc(op->ctx, counts, *counts_bytes, 1, "F̄ strip counts");
    if (st)
        return st;
    for (size_t t = 0; t < tiles; t++) {
        const uint16_t m = (uint16_t)src->tile_strips[t];
        memcpy(*counts + 2 * t, &m, 2);
    }
    *strips = 1;
    *size = bytes;
    return LRR_OK;
}

/* The table's sections in id order (FBAR's place taken by FBAR_STRIPS in a strips file),
 * those this operator has; their count. */
static int list_sections(const lrr_operator *op, int adaptive, struct section all[SEC_KNOWN],
                         struct section *sec)
{
    int count = SEC_COUNT;
    memcpy(sec, all, SEC_COUNT * sizeof *sec);
    if (op->storage != LRR_STORAGE_F32)
        sec[count++] = all[SEC_ROWSCALE - 1];
    if (adaptive)
        sec[count++] = all[adaptive == 2 ? SEC_CLUSTERS - 1 : SEC_PATCHES - 1];
    if (op->verify.subpatches)
        sec[count++] = all[SEC_VERIFY - 1];
    return count;
}

lrr_status lrr_operator_save(const lrr_operator *op, const char *path)
{
    return lrr_operator_save_fbar(op, path, LRR_FBAR_AUTO);
}

/* lrr_operator_save_fbar, F̄ from op or (src not NULL) from src. */
static lrr_status save(const lrr_operator *op, const char *path, lrr_fbar_format fbar,
                       lrr__fbar_placer *src)
{
    lrr_context *ctx = op->ctx;
    if (!LRR__FILE_LITTLE_ENDIAN)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "file %s: .lrr files are little-endian; this host is not", path);
    if (fbar != LRR_FBAR_AUTO && fbar != LRR_FBAR_DENSE && fbar != LRR_FBAR_SPARSE)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "file %s: unknown F̄ format %d", path,
                          (int)fbar);
    lrr_status need = src ? LRR_OK : lrr__need_fbar(op, "lrr_operator_save");
    if (need)
        return need;
    const lrr__geometry *g = &op->geom;
    const int half = op->storage != LRR_STORAGE_F32;
    if (!g->vert || !g->depth || !op->rho || !op->emission || !op->m ||
        (half && !op->row_scale) || (!src && (half ? !op->fbar16 : !op->fbar)) ||
        g->n != op->n || g->k != op->k || g->d != op->d || op->n == 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "file %s: operator is incomplete (no geometry or arrays)", path);

    uint64_t geom_size, rho_size, fbar_elems, fbar_size, m_elems, m_size;
    if (!bytes_of(g->n_tri, 37, &geom_size) || __builtin_add_overflow(geom_size, GEOM_PREFIX,
                                                                     &geom_size) ||
        !bytes_of(op->n, 3 * sizeof(float), &rho_size) ||
        !bytes_of(op->n, op->k, &fbar_elems) ||
        !bytes_of(fbar_elems, lrr__fbar_elem_bytes(op), &fbar_size) ||
        !bytes_of(op->k, op->k, &m_elems) || !bytes_of(m_elems, 3 * sizeof(float), &m_size))
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "file %s: section sizes overflow 64 bits",
                          path);

    const int adaptive = g->origin ? 2 : g->node != NULL; /* 1: PATCHES, 2: CLUSTERS */
    uint64_t clusters_size = 0;
    if (g->origin && (!bytes_of((uint64_t)op->k + op->n + 1, 8, &clusters_size) ||
                      __builtin_add_overflow(clusters_size, CLUSTERS_PREFIX, &clusters_size)))
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "file %s: section sizes overflow 64 bits",
                          path);
    struct strips_out so = {0};
    unsigned char *counts = NULL; /* a placed F̄'s strip counts */
    size_t counts_bytes = 0;
    uint64_t strips_size = 0;
    int strips = 0;
    lrr_status st = src ? choose_placed(op, path, fbar, src, &counts, &counts_bytes,
                                        &strips_size, &strips)
                        : choose_fbar(op, path, fbar, &so, &strips_size, &strips);
    if (st)
        return st;
    unsigned char *geom = NULL, *patches = NULL;
    unsigned char info[INFO_SIZE] = {0}, verify[VERIFY_SIZE] = {0};
    struct rows_out ro = {{rows_next}, op, NULL, op->k * lrr__fbar_elem_bytes(op)};
    if ((st = build_payloads(op, geom_size, adaptive, &geom, &patches, info)) ||
        (!strips && op->panels && !src &&
         (st = lrr__calloc(ctx, &ro.blk, LRR__PANEL, ro.row_bytes, "a block of F̄ rows"))))
        goto done;
    if (strips && adaptive == 2 && op->weighting == LRR__WEIGHTS_VISIBILITY)
        put32(info + 36, get32(info + 36) | INFO_VISIBILITY); /* version 4's meaning */
    memcpy(verify, &op->verify.rel_l2, 8);
    memcpy(verify + 8, &op->verify.noise, 8);
    memcpy(verify + 16, &op->verify.seconds, 8);
    put64(verify + 24, op->verify.subpatches);
    put64(verify + 32, op->verify.samples);
    put32(verify + 40, op->verify.uniform ? 1u : 0u);

    struct section all[SEC_KNOWN] = {
        {SEC_GEOMETRY, geom, geom_size, 0, 0, NULL, 0},
        {SEC_RHO, op->rho, rho_size, 0, 0, NULL, 0},
        {SEC_EMISSION, op->emission, rho_size, 0, 0, NULL, 0},
        {SEC_FBAR, lrr__fbar_data(op), fbar_size, 0, 0, op->panels ? &ro.base : NULL, 0},
        {SEC_M, op->m, m_size, 0, 0, NULL, 0},
        {SEC_INFO, info, INFO_SIZE, 0, 0, NULL, 0},
        {SEC_ROWSCALE, op->row_scale, (uint64_t)op->n * sizeof(float), 0, 0, NULL, 0},
        {SEC_PATCHES, patches, (uint64_t)op->k + PATCHES_PREFIX, 0, 0, NULL, 0},
        {SEC_CLUSTERS, patches, clusters_size, 0, 0, NULL, 0},
        {SEC_VERIFY, verify, VERIFY_SIZE, 0, 0, NULL, 0},
    };
    if (strips)
        all[SEC_FBAR - 1] = (struct section){SEC_FBAR_STRIPS, counts, strips_size, 0, 0,
                                             src ? NULL : &so.base, 0};
    if (src) { /* all but the counts placed */
        all[SEC_FBAR - 1].pieces = NULL;
        all[SEC_FBAR - 1].placed = all[SEC_FBAR - 1].size - counts_bytes;
    }
    struct section sec[SEC_KNOWN];
    const int count = list_sections(op, adaptive, all, sec);
    unsigned char table[SEC_KNOWN * ENTRY_SIZE + 8] = {0};
    unsigned char header[HEADER_SIZE] = {0};
    const size_t tsize =
        lay_out(op, file_version(op, adaptive, strips), sec, count, table, header);
    st = write_file(ctx, path, header, table, tsize, sec, count, src);
done:
    lrr__strips_out_free(&so);
    lrr_aligned_free(counts);
    lrr_aligned_free(ro.blk);
    lrr_aligned_free(geom);
    lrr_aligned_free(patches);
    return st;
}

lrr_status lrr_operator_save_fbar(const lrr_operator *op, const char *path,
                                  lrr_fbar_format fbar)
{
    return save(op, path, fbar, NULL);
}

lrr_status lrr__operator_save_placed(const lrr_operator *op, const char *path,
                                     lrr_fbar_format fbar, lrr__fbar_placer *src)
{
    return save(op, path, fbar, src);
}
