/* The versioned binary operator file (.lrr): lrr_operator_save / lrr_operator_load.
 *
 * Format, versions 1 and 2. All integers and floats are little-endian (IEEE 754); offsets and
 * sizes are in bytes from the start of the file. Version 2 adds the adaptive hierarchy
 * (d = 0 and a PATCHES section); uniform operators are still written as version 1, so
 * readers that know only version 1 keep reading them.
 *
 *   Header, 64 bytes at offset 0
 *      0  magic        8 bytes  "LRROPER\0"
 *      8  version      u32      1 (uniform) or 2 (adaptive)
 *     12  endianness   u32      0x01020304 (reads 0x04030201 on a byte-swapped file)
 *     16  header_size  u32      64
 *     20  sections     u32      number of entries in the section table (6, plus ROWSCALE
 *                               and PATCHES where present)
 *     24  n            u64      subpatches
 *     32  k            u64      patches
 *     40  d            u64      subpatches per patch (n = k·d, d = 4^levels); 0 in
 *                               version 2: patch sizes vary, given by PATCHES
 *     48  dtype        u32      storage of FBAR: 0 = float32, 1 = binary16, 2 = bfloat16
 *                               (RHO, EMISSION, M and ROWSCALE are float32 always)
 *     52  reserved     u32      0
 *     56  checksum     u64      checksum of bytes 0..55
 *   The first 16 bytes (magic, version, endianness) keep their meaning in every version, so
 *   any reader can tell "another version" apart from "not an lrr file".
 *
 *   Section table at offset 64: `sections` entries of 32 bytes
 *      0  id u32   4  reserved u32 (0)   8  offset u64   16  size u64   24  checksum u64
 *   followed by a u64 checksum of the entries. Readers skip unknown ids; each known id
 *   appears exactly once.
 *
 *   Sections, each starting at a multiple of 64 (zero padding in between; padding is covered
 *   by no checksum and readers ignore it). Section checksums cover exactly `size` bytes.
 *     1 GEOMETRY  n_tri u64, levels u32, builtin i32 (LRR__SCENE_*), vertices n_tri×9 float
 *                 (x0 y0 z0 x1 … z2 per input triangle), patch depth n_tri u8:
 *                 size 16 + 37·n_tri. k, n, d follow from depth and levels and must agree
 *                 with the header.
 *     2 RHO       n×3 float, each in [0,1)
 *     3 EMISSION  n×3 float, finite and >= 0
 *     4 FBAR      n×k elements of dtype, row-major (64-byte aligned so the file could be
 *                 mapped); for dtype 1 and 2 row i holds F̄_i / ROWSCALE_i
 *     5 M         3×k×k float, row-major, channel-major
 *     6 INFO      cond[3] f64, build_seconds f64, hemicube_resolution u32, flags u32
 *                 (bit 0: built without the random rotation; other bits 0), seed u64:
 *                 size 48
 *     7 ROWSCALE  n float, positive powers of two; present exactly when dtype is 1 or 2
 *     8 PATCHES   (version 2, adaptive hierarchy only) selection_seconds f64, then k u8:
 *                 the quadtree depth of each patch within its triangle, in patch order;
 *                 GEOMETRY then has levels 0 and its depths are the subpatch depths, and
 *                 the nodes must tile every triangle (size 8 + k)
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
 * corrupted header cannot make it allocate (or read) more than the file holds.
 */
#include "config.h"
#include "core/atomic_file.h"
#include "operator/operator.h"

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) &&                            \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define LRR__FILE_LITTLE_ENDIAN 1
#else
#define LRR__FILE_LITTLE_ENDIAN 0
#endif

#define FILE_VERSION 1u          /* uniform hierarchy */
#define FILE_VERSION_ADAPTIVE 2u /* adds PATCHES */
#define ENDIAN_MARK 0x01020304u
#define HEADER_SIZE 64u
#define ENTRY_SIZE 32u
#define MAX_SECTIONS 64u   /* bounds the table read from a corrupted count */
#define ALIGN 64u
#define DTYPE_F32 0u /* equal to LRR_STORAGE_F32; 1 and 2 are LRR_STORAGE_F16 / _BF16 */
#define INFO_SIZE 48u
#define GEOM_PREFIX 16u
/* Largest F̄ entry a reader accepts: 1 plus the rounding of bfloat16 (8 significant bits). */
#define FBAR_MAX (1.0f + 1.0f / 128)

static const char MAGIC[8] = {'L', 'R', 'R', 'O', 'P', 'E', 'R', '\0'};

enum {
    SEC_GEOMETRY = 1, SEC_RHO, SEC_EMISSION, SEC_FBAR, SEC_M, SEC_INFO, SEC_ROWSCALE,
    SEC_PATCHES,
    SEC_COUNT = 6,     /* sections every file has */
    SEC_KNOWN = 8      /* sections this reader knows */
};
#define PATCHES_PREFIX 8u

static const char *section_name(uint32_t id)
{
    static const char *const names[] = {"?",    "GEOMETRY", "RHO",      "EMISSION", "FBAR",
                                        "M",    "INFO",     "ROWSCALE", "PATCHES"};
    return id >= 1 && id <= SEC_KNOWN ? names[id] : "unknown";
}

/* ------------------------------------------------------------ checksum and byte order */
static uint64_t fmix64(uint64_t h)
{
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ULL;
    h ^= h >> 33;
    return h;
}

static uint64_t checksum(const void *data, size_t len)
{
    const unsigned char *p = data;
    const uint64_t prime = 0x100000001b3ULL;
    uint64_t h = 0xcbf29ce484222325ULL ^ (uint64_t)len;
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
    return fmix64(h ^ (uint64_t)len);
}

static void put32(unsigned char *p, uint32_t v) { memcpy(p, &v, 4); }
static void put64(unsigned char *p, uint64_t v) { memcpy(p, &v, 8); }
static uint32_t get32(const unsigned char *p) { uint32_t v; memcpy(&v, p, 4); return v; }
static uint64_t get64(const unsigned char *p) { uint64_t v; memcpy(&v, p, 8); return v; }

static uint64_t align_up(uint64_t x) { return (x + (ALIGN - 1)) & ~(uint64_t)(ALIGN - 1); }

/* ------------------------------------------------------------ saving */
struct section {
    uint32_t id;
    const void *data;
    uint64_t size, offset, checksum;
};

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

/* Byte size count×elem as u64, false on overflow. */
static bool bytes_of(uint64_t count, uint64_t elem, uint64_t *out)
{
    return !__builtin_mul_overflow(count, elem, out);
}

lrr_status lrr_operator_save(const lrr_operator *op, const char *path)
{
    lrr_context *ctx = op->ctx;
    if (!LRR__FILE_LITTLE_ENDIAN)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "file %s: .lrr files are little-endian; this host is not", path);
    const lrr__geometry *g = &op->geom;
    const int half = op->storage != LRR_STORAGE_F32;
    if (!g->vert || !g->depth || !op->rho || !op->emission || !op->m ||
        (half ? !op->fbar16 || !op->row_scale : !op->fbar) ||
        g->n != op->n || g->k != op->k || g->d != op->d || op->n == 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "file %s: operator is incomplete (no geometry or arrays)", path);

    uint64_t geom_size, rho_size, fbar_elems, fbar_size, m_elems, m_size;
    if (!bytes_of(g->n_tri, 37, &geom_size) || __builtin_add_overflow(geom_size, GEOM_PREFIX,
                                                                     &geom_size) ||
        !bytes_of(op->n, 3 * sizeof(float), &rho_size) ||
        !bytes_of(op->n, op->k, &fbar_elems) ||
        !bytes_of(fbar_elems, half ? sizeof(uint16_t) : sizeof(float), &fbar_size) ||
        !bytes_of(op->k, op->k, &m_elems) || !bytes_of(m_elems, 3 * sizeof(float), &m_size))
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "file %s: section sizes overflow 64 bits",
                          path);

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

    /* adaptive: PATCHES holds the node depths; its buffer is freed with geom's below */
    const int adaptive = g->node != NULL;
    unsigned char *patches = NULL;
    if (adaptive) {
        if ((st = lrr__calloc(ctx, &patches, op->k + PATCHES_PREFIX, 1, "PATCHES section"))) {
            lrr_aligned_free(geom);
            return st;
        }
        memcpy(patches, &op->selection_seconds, 8);
        memcpy(patches + PATCHES_PREFIX, g->node, op->k);
    }

    unsigned char info[INFO_SIZE] = {0};
    for (int c = 0; c < 3; c++)
        memcpy(info + 8 * c, &op->cond[c], 8);
    memcpy(info + 24, &op->build_seconds, 8);
    put32(info + 32, op->hemicube_resolution);
    put32(info + 36, op->no_rotation ? 1u : 0u);
    put64(info + 40, op->seed);

    const void *fbar_data = half ? (const void *)op->fbar16 : (const void *)op->fbar;
    struct section sec[SEC_KNOWN] = {
        {SEC_GEOMETRY, geom, geom_size, 0, 0},  {SEC_RHO, op->rho, rho_size, 0, 0},
        {SEC_EMISSION, op->emission, rho_size, 0, 0}, {SEC_FBAR, fbar_data, fbar_size, 0, 0},
        {SEC_M, op->m, m_size, 0, 0},           {SEC_INFO, info, INFO_SIZE, 0, 0},
        {SEC_ROWSCALE, op->row_scale, (uint64_t)op->n * sizeof(float), 0, 0},
        {SEC_PATCHES, patches, (uint64_t)op->k + PATCHES_PREFIX, 0, 0},
    };
    int count = SEC_COUNT;
    if (half)
        count++;
    if (adaptive)
        sec[count++] = sec[SEC_PATCHES - 1];
    unsigned char table[SEC_KNOWN * ENTRY_SIZE + 8] = {0};
    const size_t tsize = (size_t)count * ENTRY_SIZE + 8;
    uint64_t pos = HEADER_SIZE + tsize;
    for (int s = 0; s < count; s++) {
        sec[s].offset = align_up(pos);
        sec[s].checksum = checksum(sec[s].data, (size_t)sec[s].size);
        pos = sec[s].offset + sec[s].size; /* below the in-memory sizes: cannot overflow */
        unsigned char *e = table + s * ENTRY_SIZE;
        put32(e, sec[s].id);
        put64(e + 8, sec[s].offset);
        put64(e + 16, sec[s].size);
        put64(e + 24, sec[s].checksum);
    }
    put64(table + (size_t)count * ENTRY_SIZE, checksum(table, (size_t)count * ENTRY_SIZE));

    unsigned char header[HEADER_SIZE] = {0};
    memcpy(header, MAGIC, 8);
    put32(header + 8, adaptive ? FILE_VERSION_ADAPTIVE : FILE_VERSION);
    put32(header + 12, ENDIAN_MARK);
    put32(header + 16, HEADER_SIZE);
    put32(header + 20, (uint32_t)count);
    put64(header + 24, op->n);
    put64(header + 32, op->k);
    put64(header + 40, op->d);
    put32(header + 48, (uint32_t)op->storage);
    put64(header + 56, checksum(header, 56));

    /* through the atomic writer (core/atomic_file.c), its steps seen by the fault hook */
    lrr__atomic_io io;
    lrr__context_atomic_io(ctx, &io);
    struct writer w = {{0}, 0};
    if (!lrr__atomic_open(&w.file, path, &io)) {
        w_bytes(&w, header, sizeof header);
        w_bytes(&w, table, tsize);
        for (int s = 0; s < count; s++) {
            w_pad_to(&w, sec[s].offset);
            w_bytes(&w, sec[s].data, (size_t)sec[s].size);
        }
        lrr__atomic_commit(&w.file);
    }
    st = w.file.err ? lrr__atomic_error(ctx, &w.file) : LRR_OK;
    lrr__atomic_free(&w.file);
    lrr_aligned_free(geom);
    lrr_aligned_free(patches);
    return st;
}

/* ------------------------------------------------------------ loading */
struct reader {
    lrr_context *ctx;
    const char *path;
    int fd;
    uint64_t file_size;
};

/* Reads len bytes at offset. The ranges were checked against the size fstat reported, so a
 * short read means the file shrank underneath us: report it as truncation. */
static lrr_status read_at(struct reader *r, uint64_t offset, void *buf, size_t len,
                          const char *what)
{
    unsigned char *p = buf;
    while (len > 0) {
        size_t chunk = len < ((size_t)1 << 30) ? len : ((size_t)1 << 30);
        ssize_t got = pread(r->fd, p, chunk, (off_t)offset);
        if (got < 0) {
            if (errno == EINTR)
                continue;
            char eb[128];
            return lrr__error(r->ctx, LRR_ERR_IO, "file %s: cannot read %s: %s", r->path, what,
                              lrr__errno_text(errno, eb, sizeof eb));
        }
        if (got == 0)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: truncated while reading %s (file changed size?)",
                              r->path, what);
        p += got;
        len -= (size_t)got;
        offset += (uint64_t)got;
    }
    return LRR_OK;
}

/* Reads a section into buf and verifies its checksum. */
static lrr_status read_section(struct reader *r, const struct section *s, void *buf)
{
    lrr_status st = read_at(r, s->offset, buf, (size_t)s->size, section_name(s->id));
    if (st)
        return st;
    uint64_t h = checksum(buf, (size_t)s->size);
    if (h != s->checksum)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section %s (bytes %" PRIu64 "..%" PRIu64
                          ") fails its checksum (stored %016" PRIx64 ", computed %016" PRIx64 ")",
                          r->path, section_name(s->id), s->offset, s->offset + s->size,
                          s->checksum, h);
    return LRR_OK;
}

static lrr_status expect_size(struct reader *r, const struct section *s, uint64_t count,
                              uint64_t elem, const char *formula)
{
    uint64_t want;
    if (!bytes_of(count, elem, &want))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section %s: %s = %" PRIu64 "×%" PRIu64
                          " bytes overflows (absurd header sizes)",
                          r->path, section_name(s->id), formula, count, elem);
    if (want != s->size)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section %s has %" PRIu64 " bytes, expected %s = %" PRIu64,
                          r->path, section_name(s->id), s->size, formula, want);
    return LRR_OK;
}

/* Reads and validates header and section table into sec[SEC_KNOWN] (indexed by id-1). */
static lrr_status read_layout(struct reader *r, uint64_t *n, uint64_t *k, uint64_t *d,
                              uint32_t *dtype_out, struct section sec[SEC_KNOWN])
{
    unsigned char h[HEADER_SIZE];
    size_t have = r->file_size < HEADER_SIZE ? (size_t)r->file_size : HEADER_SIZE;
    lrr_status st = read_at(r, 0, h, have, "header");
    if (st)
        return st;
    if (memcmp(h, MAGIC, have < 8 ? have : 8) != 0)
        return lrr__error(r->ctx, LRR_ERR_VERSION,
                          "file %s: not an lrr operator file (no \"LRROPER\" magic)", r->path);
    if (have < 16)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: truncated: the header needs bytes 0..%u, file has %" PRIu64,
                          r->path, HEADER_SIZE, r->file_size);
    uint32_t version = get32(h + 8), mark = get32(h + 12);
    if (version != FILE_VERSION && version != FILE_VERSION_ADAPTIVE)
        return lrr__error(r->ctx, LRR_ERR_VERSION,
                          "file %s: format version %" PRIu32 ", this library reads versions "
                          "%u and %u",
                          r->path, version, FILE_VERSION, FILE_VERSION_ADAPTIVE);
    if (mark == 0x04030201u)
        return lrr__error(r->ctx, LRR_ERR_VERSION,
                          "file %s: written with the other byte order (big-endian)", r->path);
    if (mark != ENDIAN_MARK)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: endianness marker %08" PRIx32 " is not %08x", r->path, mark,
                          ENDIAN_MARK);
    if (have < HEADER_SIZE)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: truncated: the header needs bytes 0..%u, file has %" PRIu64,
                          r->path, HEADER_SIZE, r->file_size);
    if (checksum(h, 56) != get64(h + 56))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: header fails its checksum",
                          r->path);
    uint32_t hsize = get32(h + 16), count = get32(h + 20), dtype = get32(h + 48);
    *n = get64(h + 24);
    *k = get64(h + 32);
    *d = get64(h + 40);
    if (hsize != HEADER_SIZE)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: header size %" PRIu32 ", not %u",
                          r->path, hsize, HEADER_SIZE);
    if (dtype > LRR_STORAGE_BF16)
        return lrr__error(r->ctx, LRR_ERR_VERSION,
                          "file %s: element type %" PRIu32 " (this library reads 0 = float32, "
                          "1 = binary16, 2 = bfloat16)",
                          r->path, dtype);
    *dtype_out = dtype;
    /* version 2: the adaptive hierarchy, d = 0 and patch sizes from PATCHES */
    const bool adaptive = version == FILE_VERSION_ADAPTIVE;
    if (adaptive != (*d == 0))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: version %" PRIu32 " with d = %" PRIu64 " (version 1 has "
                          "d > 0, version 2 d = 0)", r->path, version, *d);
    if (count < SEC_COUNT || count > MAX_SECTIONS)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: %" PRIu32 " sections (expected %d..%u)", r->path, count,
                          SEC_COUNT, MAX_SECTIONS);
    uint64_t nk;
    if (adaptive ? *k == 0 || *k > *n || *n > SIZE_MAX
                 : *k == 0 || *d == 0 || __builtin_mul_overflow(*k, *d, &nk) || nk != *n ||
                       *n > SIZE_MAX)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: implausible sizes n = %" PRIu64 ", k = %" PRIu64
                          ", d = %" PRIu64 " (need n = k·d > 0, or 0 < k <= n with d = 0 in "
                          "version 2)",
                          r->path, *n, *k, *d);

    unsigned char table[MAX_SECTIONS * ENTRY_SIZE + 8];
    size_t tsize = count * ENTRY_SIZE + 8;
    if (HEADER_SIZE + tsize > r->file_size)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: truncated: the section table needs bytes %u..%zu, file has "
                          "%" PRIu64,
                          r->path, HEADER_SIZE, HEADER_SIZE + tsize, r->file_size);
    if ((st = read_at(r, HEADER_SIZE, table, tsize, "section table")))
        return st;
    if (checksum(table, tsize - 8) != get64(table + tsize - 8))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section table fails its checksum",
                          r->path);

    bool seen[SEC_KNOWN] = {false};
    for (uint32_t i = 0; i < count; i++) {
        const unsigned char *e = table + i * ENTRY_SIZE;
        struct section s = {get32(e), NULL, get64(e + 16), get64(e + 8), get64(e + 24)};
        if (s.id < 1 || s.id > SEC_KNOWN || (s.id == SEC_ROWSCALE && dtype == DTYPE_F32) ||
            (s.id == SEC_PATCHES && !adaptive))
            continue; /* a later minor addition, or a section this file's kind ignores */
        if (seen[s.id - 1])
            return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section %s appears twice",
                              r->path, section_name(s.id));
        uint64_t end;
        if (__builtin_add_overflow(s.offset, s.size, &end) || end > r->file_size)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: truncated: section %s needs bytes %" PRIu64 "..%" PRIu64
                              ", file has %" PRIu64,
                              r->path, section_name(s.id), s.offset,
                              end < s.offset ? UINT64_MAX : end, r->file_size);
        if (s.offset % ALIGN != 0 || s.offset < HEADER_SIZE + tsize || s.size > SIZE_MAX)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section %s at offset %" PRIu64
                              " is misplaced (must be 64-byte aligned, after the table)",
                              r->path, section_name(s.id), s.offset);
        seen[s.id - 1] = true;
        sec[s.id - 1] = s;
    }
    for (int i = 0; i < SEC_KNOWN; i++)
        if (!seen[i] && (i < SEC_COUNT || (i == SEC_ROWSCALE - 1 && dtype != DTYPE_F32) ||
                         (i == SEC_PATCHES - 1 && adaptive)))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section %s is missing",
                              r->path, section_name((uint32_t)i + 1));

    /* Every size below is bounded by the file size (checked above), so once these agree
     * with n and k, allocating them cannot exceed what the file holds. */
    if ((st = expect_size(r, &sec[SEC_RHO - 1], *n, 3 * sizeof(float), "n×3 floats")) ||
        (st = expect_size(r, &sec[SEC_EMISSION - 1], *n, 3 * sizeof(float), "n×3 floats")) ||
        (st = expect_size(r, &sec[SEC_INFO - 1], 1, INFO_SIZE, "the INFO record")))
        return st;
    uint64_t nk_elems, kk_elems;
    if (__builtin_mul_overflow(*n, *k, &nk_elems) || __builtin_mul_overflow(*k, *k, &kk_elems))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: implausible sizes n = %" PRIu64 ", k = %" PRIu64
                          " (n·k overflows)",
                          r->path, *n, *k);
    if ((st = expect_size(r, &sec[SEC_FBAR - 1], nk_elems,
                          dtype == DTYPE_F32 ? sizeof(float) : sizeof(uint16_t),
                          dtype == DTYPE_F32 ? "n·k floats" : "n·k 16-bit values")) ||
        (dtype != DTYPE_F32 &&
         (st = expect_size(r, &sec[SEC_ROWSCALE - 1], *n, sizeof(float), "n floats"))) ||
        (st = expect_size(r, &sec[SEC_M - 1], kk_elems, 3 * sizeof(float), "3·k·k floats")) ||
        (adaptive && (st = expect_size(r, &sec[SEC_PATCHES - 1], *k + PATCHES_PREFIX, 1,
                                       "8 + k bytes"))))
        return st;
    if (sec[SEC_GEOMETRY - 1].size < GEOM_PREFIX)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section GEOMETRY has %" PRIu64 " bytes (at least %u)",
                          r->path, sec[SEC_GEOMETRY - 1].size, GEOM_PREFIX);
    return LRR_OK;
}

/* Parses the GEOMETRY payload into g (allocated; freed by the caller) and checks that the
 * hierarchy it implies has the header's n, k and d. */
static lrr_status parse_geometry(struct reader *r, const unsigned char *buf, uint64_t size,
                                 uint64_t n, uint64_t k, uint64_t d, lrr__geometry *g,
                                 int *builtin)
{
    uint64_t n_tri = get64(buf), want;
    uint32_t levels = get32(buf + 8);
    int32_t b;
    memcpy(&b, buf + 12, 4);
    if (n_tri == 0 || __builtin_mul_overflow(n_tri, 37, &want) ||
        __builtin_add_overflow(want, GEOM_PREFIX, &want) || want != size)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section GEOMETRY has %" PRIu64
                          " bytes, inconsistent with %" PRIu64 " triangles",
                          r->path, size, n_tri);
    if (b != LRR__SCENE_FILE && b != LRR__SCENE_CORNELL && b != LRR__SCENE_CORNELL_CLOSED)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: unknown scene kind %" PRId32,
                          r->path, b);
    *builtin = b;
    lrr_status st;
    size_t nt = (size_t)n_tri; /* <= file size / 37: fits */
    if ((st = lrr__calloc(r->ctx, &g->vert, nt, 9 * sizeof(float), "triangle vertices")) ||
        (st = lrr__calloc(r->ctx, &g->depth, nt, 1, "patch depths")) ||
        (st = lrr__calloc(r->ctx, &g->patch0, nt + 1, sizeof(size_t), "patch index")))
        return st;
    g->n_tri = nt;
    g->levels = levels;
    memcpy(g->vert, buf + GEOM_PREFIX, nt * 9 * sizeof(float));
    memcpy(g->depth, buf + GEOM_PREFIX + nt * 9 * sizeof(float), nt);
    for (size_t i = 0; i < nt * 9; i++)
        if (!isfinite(g->vert[i]))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section GEOMETRY: triangle %zu has a non-finite "
                              "coordinate",
                              r->path, i / 9);
    /* NULL context: an out-of-range level or depth here is corruption, reported below. */
    if (lrr__geometry_index(NULL, g, (size_t)n) != LRR_OK || g->n != n ||
        (d ? g->k != k || g->d != d : levels != 0))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section GEOMETRY (levels %u, %zu triangles) does not give "
                          "the header's n = %" PRIu64 ", k = %" PRIu64 ", d = %" PRIu64,
                          r->path, levels, nt, n, k, d);
    return LRR_OK;
}

/* Version 2: replaces the uniform g by the adaptive hierarchy the PATCHES payload gives. */
static lrr_status parse_patches(struct reader *r, const struct section *ps, uint64_t k,
                                lrr__geometry *g, double *selection_seconds)
{
    unsigned char *buf;
    lrr_status st = lrr__calloc(r->ctx, &buf, (size_t)ps->size, 1, "PATCHES section");
    if (st)
        return st;
    if ((st = read_section(r, ps, buf))) {
        lrr_aligned_free(buf);
        return st;
    }
    memcpy(selection_seconds, buf, 8);
    if (!(*selection_seconds >= 0) || isinf(*selection_seconds)) {
        lrr_aligned_free(buf);
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section PATCHES: selection time %g s", r->path,
                          *selection_seconds);
    }
    char where[64 + 4096];
    snprintf(where, sizeof where, "file %s: section PATCHES", r->path);
    lrr__geometry a;
    st = lrr__geometry_adaptive(r->ctx, g, buf + PATCHES_PREFIX, (size_t)k, where,
                                LRR_ERR_CORRUPT, &a);
    lrr_aligned_free(buf);
    if (st)
        return st;
    lrr__geometry_free(g);
    *g = a;
    return LRR_OK;
}

static lrr_status check_values(struct reader *r, const lrr_operator *op)
{
    size_t n3 = op->n * 3;
    for (size_t i = 0; i < n3; i++) {
        float v = op->rho[i];
        if (!(v >= 0.0f && v < 1.0f))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section RHO: subpatch %zu channel %zu has reflectance "
                              "%g outside [0,1)",
                              r->path, i / 3, i % 3, (double)v);
        float e = op->emission[i];
        if (!(e >= 0.0f) || isinf(e))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section EMISSION: subpatch %zu channel %zu has emission "
                              "%g (must be finite and >= 0)",
                              r->path, i / 3, i % 3, (double)e);
    }
    /* A non-finite F̄ or M would turn every solve into silent NaN. */
    size_t nk = op->n * op->k;
    /* binary16 and bfloat16 mark Inf/NaN by an all-ones exponent */
    const uint16_t expmask = op->storage == LRR_STORAGE_F16 ? 0x7c00u : 0x7f80u;
    for (size_t i = 0; i < nk; i++)
        if (op->fbar ? !isfinite(op->fbar[i]) : (op->fbar16[i] & expmask) == expmask)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section FBAR: entry (%zu, %zu) is not finite", r->path,
                              i / op->k, i % op->k);
    for (size_t i = 0; op->row_scale && i < op->n; i++) {
        int e;
        if (!(op->row_scale[i] > 0) || !isfinite(op->row_scale[i]) ||
            frexpf(op->row_scale[i], &e) != 0.5f)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section ROWSCALE: row %zu has scale %g (must be a "
                              "positive power of two)",
                              r->path, i, (double)op->row_scale[i]);
        /* bfloat16 has float's range and is stored unscaled (storage.c). The kernels fold
         * the scale in after the dot product, so huge stored values under a tiny scale
         * would overflow there although the decoded F̄ is small. */
        if (op->storage == LRR_STORAGE_BF16 && op->row_scale[i] != 1.0f)
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section ROWSCALE: row %zu has scale %g (bfloat16 rows "
                              "are stored unscaled: 1)",
                              r->path, i, (double)op->row_scale[i]);
    }
    /* F̄ holds form factors divided by d: each in [0, 1] (FBAR_MAX allows for the rounding
     * of 16-bit storage). Anything else is corruption, and could make a solve overflow. */
    float *row = NULL;
    lrr_status st = lrr__calloc(r->ctx, &row, op->k, sizeof(float), "F̄ row");
    if (st)
        return st;
    for (size_t i = 0; i < op->n && st == LRR_OK; i++) {
        lrr_operator_fbar_row(op, i, row);
        for (size_t j = 0; j < op->k; j++)
            if (!(row[j] >= 0.0f && row[j] <= FBAR_MAX)) {
                st = lrr__error(r->ctx, LRR_ERR_CORRUPT,
                                "file %s: section FBAR: entry (%zu, %zu) is %g (form factors "
                                "divided by d lie in [0, 1])",
                                r->path, i, j, (double)row[j]);
                break;
            }
    }
    lrr_aligned_free(row);
    if (st)
        return st;
    size_t kk = op->k * op->k;
    for (size_t i = 0; i < 3 * kk; i++)
        if (!isfinite(op->m[i]))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                              "file %s: section M: channel %zu entry (%zu, %zu) is not finite",
                              r->path, i / kk, i % kk / op->k, i % op->k);
    return LRR_OK;
}

lrr_status lrr_operator_load(lrr_context *ctx, const char *path, lrr_operator **out)
{
    *out = NULL;
    if (!LRR__FILE_LITTLE_ENDIAN)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "file %s: .lrr files are little-endian; this host is not", path);
    struct reader r = {ctx, path, -1, 0};
    /* O_NONBLOCK: opening a FIFO without a writer would otherwise hang; it changes nothing
     * for the regular files accepted below. */
    r.fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (r.fd < 0) {
        char eb[128];
        return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot open: %s", path,
                          lrr__errno_text(errno, eb, sizeof eb));
    }
    struct stat sb;
    if (fstat(r.fd, &sb) != 0) {
        int err = errno;
        close(r.fd);
        char eb[128];
        return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot stat: %s", path,
                          lrr__errno_text(err, eb, sizeof eb));
    }
    if (!S_ISREG(sb.st_mode)) {
        close(r.fd);
        return lrr__error(ctx, LRR_ERR_IO, "file %s: not a regular file", path);
    }
    r.file_size = (uint64_t)sb.st_size;

    uint64_t n = 0, k = 0, d = 0;
    struct section sec[SEC_KNOWN];
    uint32_t dtype = 0;
    unsigned char *geom_buf = NULL;
    lrr__geometry g;
    memset(&g, 0, sizeof g);
    lrr_operator *op = NULL;
    unsigned char info[INFO_SIZE];
    int builtin = 0;
    double selection_seconds = 0;

    lrr_status st = read_layout(&r, &n, &k, &d, &dtype, sec);
    if (st)
        goto done;
    const struct section *gs = &sec[SEC_GEOMETRY - 1];
    if ((st = lrr__calloc(ctx, &geom_buf, (size_t)gs->size, 1, "GEOMETRY section")) ||
        (st = read_section(&r, gs, geom_buf)) ||
        (st = parse_geometry(&r, geom_buf, gs->size, n, k, d, &g, &builtin)) ||
        (d == 0 && (st = parse_patches(&r, &sec[SEC_PATCHES - 1], k, &g, &selection_seconds))) ||
        (st = read_section(&r, &sec[SEC_INFO - 1], info)))
        goto done;
    if ((st = lrr__operator_new(ctx, &g, (lrr_storage)dtype, &op)))
        goto done;
    if ((st = read_section(&r, &sec[SEC_RHO - 1], op->rho)) ||
        (st = read_section(&r, &sec[SEC_EMISSION - 1], op->emission)) ||
        (st = read_section(&r, &sec[SEC_FBAR - 1],
                           dtype == DTYPE_F32 ? (void *)op->fbar : (void *)op->fbar16)) ||
        (dtype != DTYPE_F32 && (st = read_section(&r, &sec[SEC_ROWSCALE - 1], op->row_scale))) ||
        (st = read_section(&r, &sec[SEC_M - 1], op->m)) || (st = check_values(&r, op)))
        goto done;
    for (int c = 0; c < 3; c++)
        memcpy(&op->cond[c], info + 8 * c, 8);
    memcpy(&op->build_seconds, info + 24, 8);
    op->hemicube_resolution = get32(info + 32);
    op->no_rotation = (get32(info + 36) & 1u) != 0;
    op->seed = get64(info + 40);
    op->builtin = builtin;
    op->selection_seconds = selection_seconds;

done:
    close(r.fd);
    lrr_aligned_free(geom_buf);
    lrr__geometry_free(&g);
    if (st) {
        lrr_operator_destroy(op);
        return st;
    }
    *out = op;
    return LRR_OK;
}
