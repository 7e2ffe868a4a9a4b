/* Loading .lrr operator files: lrr_operator_load, and lrr_operator_load_head (everything but
 * F̄). The format is documented at the top of lrr_file.c. Every size is checked against the
 * real file size before anything is allocated, so a corrupted header cannot make the load
 * allocate (or read) more than the file holds. */
#include "config.h"
#include "core/path.h"
#include "file/format.h"
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

static const char *section_name(uint32_t id)
{
    static const char *const names[] = {"?",    "GEOMETRY", "RHO",      "EMISSION", "FBAR",
                                        "M",    "INFO",     "ROWSCALE", "PATCHES",
                                        "CLUSTERS", "VERIFY", "FBAR_STRIPS"};
    return id >= 1 && id <= SEC_KNOWN ? names[id] : "unknown";
}

/* ------------------------------------------------------------ loading */
/* The ranges were checked against the size fstat reported, so a short read means the file
 * shrank underneath us: report it as truncation. */
lrr_status lrr__file_read_at(struct reader *r, uint64_t offset, void *buf, size_t len,
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
    lrr_status st = lrr__file_read_at(r, s->offset, buf, (size_t)s->size, section_name(s->id));
    if (st)
        return st;
    uint64_t h = lrr__file_checksum(buf, (size_t)s->size);
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


/* Reads the header into h and checks that it is one this library reads: magic, version and
 * byte order (the first 16 bytes, which keep their meaning in every version), then its
 * length and checksum. */
static lrr_status read_header(struct reader *r, unsigned char h[HEADER_SIZE])
{
    size_t have = r->file_size < HEADER_SIZE ? (size_t)r->file_size : HEADER_SIZE;
    lrr_status st = lrr__file_read_at(r, 0, h, have, "header");
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
    if (version < FILE_VERSION || version > FILE_VERSION_STRIPS)
        return lrr__error(r->ctx, LRR_ERR_VERSION,
                          "file %s: format version %" PRIu32 ", this library reads versions "
                          "%u to %u",
                          r->path, version, FILE_VERSION, FILE_VERSION_STRIPS);
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
    if (lrr__file_checksum(h, 56) != get64(h + 56))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: header fails its checksum",
                          r->path);
    return LRR_OK;
}

/* Decodes the checked header h into hd and checks its fields: header size, element type,
 * version against d, the section count and the sizes n, k, d. */
static lrr_status check_header(struct reader *r, const unsigned char h[HEADER_SIZE],
                               struct header *hd)
{
    uint32_t hsize = get32(h + 16);
    hd->version = get32(h + 8);
    hd->count = get32(h + 20);
    hd->dtype = get32(h + 48);
    hd->n = get64(h + 24);
    hd->k = get64(h + 32);
    hd->d = get64(h + 40);
    if (hsize != HEADER_SIZE)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: header size %" PRIu32 ", not %u",
                          r->path, hsize, HEADER_SIZE);
    if (hd->dtype > LRR_STORAGE_BF16)
        return lrr__error(r->ctx, LRR_ERR_VERSION,
                          "file %s: element type %" PRIu32 " (this library reads 0 = float32, "
                          "1 = binary16, 2 = bfloat16)",
                          r->path, hd->dtype);
    /* versions 2 to 4: adaptive or cluster hierarchy, d = 0, patch sizes from PATCHES or
     * CLUSTERS; version 5 any of them (find_sections tells which, info_weights the
     * weights) */
    hd->strips = hd->version == FILE_VERSION_STRIPS;
    hd->adaptive = hd->strips ? hd->d == 0 : hd->version != FILE_VERSION;
    hd->clusters = !hd->strips && hd->version >= FILE_VERSION_CLUSTER;
    hd->visibility = hd->version == FILE_VERSION_VISIBILITY;
    if (hd->strips && hd->k > UINT16_MAX)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: version 5 with k = %" PRIu64 " (its strips' columns are "
                          "16-bit: k <= %u)", r->path, hd->k, (unsigned)UINT16_MAX);
    if (hd->adaptive != (hd->d == 0))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: version %" PRIu32 " with d = %" PRIu64 " (version 1 has "
                          "d > 0, versions 2 to 4 d = 0)", r->path, hd->version, hd->d);
    if (hd->count < SEC_COUNT || hd->count > MAX_SECTIONS)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: %" PRIu32 " sections (expected %d..%u)", r->path, hd->count,
                          SEC_COUNT, MAX_SECTIONS);
    uint64_t nk;
    if (hd->adaptive ? hd->k == 0 || hd->k > hd->n || hd->n > SIZE_MAX
                     : hd->k == 0 || hd->d == 0 || __builtin_mul_overflow(hd->k, hd->d, &nk) ||
                           nk != hd->n || hd->n > SIZE_MAX)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: implausible sizes n = %" PRIu64 ", k = %" PRIu64
                          ", d = %" PRIu64 " (need n = k·d > 0, or 0 < k <= n with d = 0 in "
                          "versions 2 to 4)",
                          r->path, hd->n, hd->k, hd->d);
    return LRR_OK;
}

/* Reads the table of count sections (and its checksum) into table; *tsize is its size. */
static lrr_status read_table(struct reader *r, uint32_t count,
                             unsigned char table[MAX_SECTIONS * ENTRY_SIZE + 8], size_t *tsize)
{
    *tsize = count * ENTRY_SIZE + 8;
    if (HEADER_SIZE + *tsize > r->file_size)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: truncated: the section table needs bytes %u..%zu, file has "
                          "%" PRIu64,
                          r->path, HEADER_SIZE, HEADER_SIZE + *tsize, r->file_size);
    lrr_status st = lrr__file_read_at(r, HEADER_SIZE, table, *tsize, "section table");
    if (st)
        return st;
    if (lrr__file_checksum(table, *tsize - 8) != get64(table + *tsize - 8))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section table fails its checksum",
                          r->path);
    return LRR_OK;
}

/* Whether a file of this kind reads section id; it skips the others (a later minor addition,
 * or a section its kind ignores). */
static bool wanted(const struct header *hd, uint32_t id)
{
    switch (id) {
    case SEC_ROWSCALE:
        return hd->dtype != DTYPE_F32;
    case SEC_PATCHES:
        return hd->adaptive && (hd->strips || !hd->clusters);
    case SEC_CLUSTERS:
        return hd->strips ? hd->adaptive : hd->clusters;
    case SEC_FBAR_STRIPS:
        return hd->strips;
    default:
        return id >= 1 && id <= SEC_KNOWN;
    }
}

/* Whether a file of this kind must have section id (version 5's hierarchy is checked after). */
static bool required(const struct header *hd, uint32_t id)
{
    if (id == SEC_FBAR || id == SEC_FBAR_STRIPS)
        return (id == SEC_FBAR_STRIPS) == hd->strips;
    return id <= SEC_COUNT || (id == SEC_ROWSCALE && hd->dtype != DTYPE_F32) ||
           (!hd->strips && ((id == SEC_PATCHES && hd->adaptive && !hd->clusters) ||
                            (id == SEC_CLUSTERS && hd->clusters)));
}

/* Version 5: F̄ only as strips, and with d = 0 exactly one of PATCHES and CLUSTERS, which
 * says the hierarchy (hd->clusters). */
static lrr_status strips_kind(struct reader *r, struct header *hd, const bool seen[SEC_KNOWN])
{
    if (seen[SEC_FBAR - 1])
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: version 5 holds F̄ as FBAR_STRIPS, yet has a section FBAR",
                          r->path);
    if (hd->adaptive && seen[SEC_PATCHES - 1] == seen[SEC_CLUSTERS - 1])
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: version 5 with d = 0 has %s of PATCHES and CLUSTERS "
                          "(needs exactly one)", r->path,
                          seen[SEC_PATCHES - 1] ? "both" : "neither");
    hd->clusters = seen[SEC_CLUSTERS - 1];
    return LRR_OK;
}

/* Collects the known sections of the table into sec (indexed by id-1), each once, inside the
 * file and after the table, and checks that none this file's kind needs is missing. */
static lrr_status find_sections(struct reader *r, struct header *hd,
                                const unsigned char *table, size_t tsize,
                                struct section sec[SEC_KNOWN])
{
    bool seen[SEC_KNOWN] = {false};
    for (uint32_t i = 0; i < hd->count; i++) {
        const unsigned char *e = table + i * ENTRY_SIZE;
        struct section s = {get32(e), NULL, get64(e + 16), get64(e + 8), get64(e + 24), NULL, 0};
        if (!wanted(hd, s.id))
            continue;
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
    for (uint32_t id = 1; id <= SEC_KNOWN; id++)
        if (!seen[id - 1] && required(hd, id))
            return lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section %s is missing",
                              r->path, section_name(id));
    return hd->strips ? strips_kind(r, hd, seen) : LRR_OK;
}

/* Checks each section's size against n and k (GEOMETRY's against its triangle count comes
 * with parse_geometry). */
static lrr_status check_section_sizes(struct reader *r, const struct header *hd,
                                      const struct section sec[SEC_KNOWN])
{
    const uint64_t n = hd->n, k = hd->k;
    const uint32_t dtype = hd->dtype;
    lrr_status st;
    /* Every size below is bounded by the file size (checked by find_sections), so once these
     * agree with n and k, allocating them cannot exceed what the file holds. */
    if ((st = expect_size(r, &sec[SEC_RHO - 1], n, 3 * sizeof(float), "n×3 floats")) ||
        (st = expect_size(r, &sec[SEC_EMISSION - 1], n, 3 * sizeof(float), "n×3 floats")) ||
        (st = expect_size(r, &sec[SEC_INFO - 1], 1, INFO_SIZE, "the INFO record")))
        return st;
    uint64_t nk_elems, kk_elems;
    if (__builtin_mul_overflow(n, k, &nk_elems) || __builtin_mul_overflow(k, k, &kk_elems))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: implausible sizes n = %" PRIu64 ", k = %" PRIu64
                          " (n·k overflows)",
                          r->path, n, k);
    if ((!hd->strips && (st = expect_size(r, &sec[SEC_FBAR - 1], nk_elems,
                                          dtype == DTYPE_F32 ? sizeof(float) : sizeof(uint16_t),
                                          dtype == DTYPE_F32 ? "n·k floats"
                                                             : "n·k 16-bit values"))) ||
        (dtype != DTYPE_F32 &&
         (st = expect_size(r, &sec[SEC_ROWSCALE - 1], n, sizeof(float), "n floats"))) ||
        (st = expect_size(r, &sec[SEC_M - 1], kk_elems, 3 * sizeof(float), "3·k·k floats")) ||
        (hd->adaptive && !hd->clusters &&
         (st = expect_size(r, &sec[SEC_PATCHES - 1], k + PATCHES_PREFIX, 1, "8 + k bytes"))) ||
        (hd->clusters && (st = expect_size(r, &sec[SEC_CLUSTERS - 1], k + n + 2, 8,
                                           "8 + 8·(k + 1 + n) bytes"))) ||
        (sec[SEC_VERIFY - 1].id &&
         (st = expect_size(r, &sec[SEC_VERIFY - 1], 1, VERIFY_SIZE, "the VERIFY record"))))
        return st;
    /* the strip counts are read first: at least their bytes (the rest follows from them) */
    if (hd->strips && sec[SEC_FBAR_STRIPS - 1].size < strips_counts_bytes(n))
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section FBAR_STRIPS has %" PRIu64 " bytes, less than its "
                          "%" PRIu64 " bytes of strip counts",
                          r->path, sec[SEC_FBAR_STRIPS - 1].size, strips_counts_bytes(n));
    if (sec[SEC_GEOMETRY - 1].size < GEOM_PREFIX)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section GEOMETRY has %" PRIu64 " bytes (at least %u)",
                          r->path, sec[SEC_GEOMETRY - 1].size, GEOM_PREFIX);
    return LRR_OK;
}

/* Reads and validates header (into hd) and section table into sec[SEC_KNOWN] (indexed by
 * id-1). */
static lrr_status read_layout(struct reader *r, struct header *hd, struct section sec[SEC_KNOWN])
{
    unsigned char h[HEADER_SIZE];
    unsigned char table[MAX_SECTIONS * ENTRY_SIZE + 8];
    size_t tsize;
    lrr_status st;
    if ((st = read_header(r, h)) || (st = check_header(r, h, hd)) ||
        (st = read_table(r, hd->count, table, &tsize)) ||
        (st = find_sections(r, hd, table, tsize, sec)) ||
        (st = check_section_sizes(r, hd, sec)))
        return st;
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

/* Version 3: replaces the uniform g by the cluster hierarchy the CLUSTERS payload gives. */
static lrr_status parse_clusters(struct reader *r, const struct section *cs, uint64_t k,
                                 lrr__geometry *g, double *selection_seconds)
{
    const size_t n = g->n, kk = (size_t)k; /* k <= n, checked with the header */
    unsigned char *buf;
    size_t *first = NULL, *origin = NULL;
    lrr_status st = lrr__calloc(r->ctx, &buf, (size_t)cs->size, 1, "CLUSTERS section");
    if (st || (st = read_section(r, cs, buf)) ||
        (st = lrr__calloc(r->ctx, &first, kk + 1, sizeof(size_t), "cluster offsets")) ||
        (st = lrr__calloc(r->ctx, &origin, n ? n : 1, sizeof(size_t), "cluster origin")))
        goto done;
    memcpy(selection_seconds, buf, 8);
    if (!(*selection_seconds >= 0) || isinf(*selection_seconds)) {
        st = lrr__error(r->ctx, LRR_ERR_CORRUPT, "file %s: section CLUSTERS: selection time "
                        "%g s", r->path, *selection_seconds);
        goto done;
    }
    for (size_t p = 0; p <= kk; p++) {
        uint64_t v = get64(buf + CLUSTERS_PREFIX + 8 * p);
        first[p] = v > n ? SIZE_MAX : (size_t)v; /* out of range: refused below */
    }
    for (size_t i = 0; i < n; i++) {
        uint64_t v = get64(buf + CLUSTERS_PREFIX + 8 * (kk + 1 + i));
        origin[i] = v >= n ? SIZE_MAX : (size_t)v;
    }
    char where[64 + 4096];
    snprintf(where, sizeof where, "file %s: section CLUSTERS", r->path);
    lrr__geometry c;
    if ((st = lrr__geometry_clusters(r->ctx, g, origin, first, kk, where, LRR_ERR_CORRUPT, &c)))
        goto done;
    lrr__geometry_free(g);
    *g = c;
done:
    lrr_aligned_free(buf);
    lrr_aligned_free(first);
    lrr_aligned_free(origin);
    return st;
}

/* The optional VERIFY record (lrr_file.c) into op->verify, its values checked. */
static lrr_status read_verify(struct reader *r, const struct section *s, lrr_operator *op)
{
    unsigned char v[VERIFY_SIZE];
    lrr_status st = read_section(r, s, v);
    if (st)
        return st;
    double rel, noise, seconds;
    memcpy(&rel, v, 8);
    memcpy(&noise, v + 8, 8);
    memcpy(&seconds, v + 16, 8);
    const uint64_t subpatches = get64(v + 24), samples = get64(v + 32);
    const uint32_t flags = get32(v + 40);
    if (!(rel >= 0) || !isfinite(rel) || !(noise >= 0) || !isfinite(noise) ||
        !(seconds >= 0) || !isfinite(seconds) || subpatches == 0 || subpatches > op->n ||
        samples < 2 || samples > SIZE_MAX || (flags & ~1u) != 0)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section VERIFY holds implausible values (rel_l2 %g, noise "
                          "%g, %" PRIu64 " subpatches of %zu, %" PRIu64 " samples, flags %"
                          PRIu32 ")", r->path, rel, noise, subpatches, op->n, samples, flags);
    op->verify.rel_l2 = rel;
    op->verify.noise = noise;
    op->verify.seconds = seconds;
    op->verify.subpatches = (size_t)subpatches;
    op->verify.samples = (size_t)samples;
    op->verify.uniform = (int)(flags & 1u);
    return LRR_OK;
}

/* Version 5 keeps version 4's weights in INFO flags bit 2 (clusters only); versions 1 to 4
 * say them by their number and never set it. */
static lrr_status info_weights(struct reader *r, struct header *hd, uint32_t flags)
{
    if (!hd->strips)
        return LRR_OK;
    if ((flags & INFO_VISIBILITY) && !hd->clusters)
        return lrr__error(r->ctx, LRR_ERR_CORRUPT,
                          "file %s: section INFO: flag bit 2 (clusters' weights from F̄'s row "
                          "sums) on a file without clusters", r->path);
    hd->visibility = (flags & INFO_VISIBILITY) != 0;
    return LRR_OK;
}

/* F̄ (and its row scales) into op: dense FBAR as rows, checked after reading; or FBAR_STRIPS
 * expanded straight into panels (the zeroed F̄ is valid in any layout), the row scales
 * checked first since the strips' checks decode with them. */
static lrr_status read_fbar(struct reader *r, const struct header *hd,
                            const struct section sec[SEC_KNOWN], lrr_operator *op)
{
    lrr_status st;
    if (hd->dtype != DTYPE_F32 && (st = read_section(r, &sec[SEC_ROWSCALE - 1], op->row_scale)))
        return st;
    if (hd->strips) {
        if ((st = lrr__check_row_scales(r, op)))
            return st;
        op->panels = 1;
        return lrr__strips_load(r, &sec[SEC_FBAR_STRIPS - 1], op);
    }
    if ((st = read_section(r, &sec[SEC_FBAR - 1],
                           hd->dtype == DTYPE_F32 ? (void *)op->fbar : (void *)op->fbar16)))
        return st;
    return lrr__check_fbar(r, op);
}

lrr_status lrr__load_open(lrr_context *ctx, const char *path, struct reader *r,
                          struct load_head *lh)
{
    *r = (struct reader){ctx, path, -1, 0};
    memset(lh, 0, sizeof *lh);
    if (!LRR__FILE_LITTLE_ENDIAN)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "file %s: .lrr files are little-endian; this host is not", path);
    struct stat sb;
    int e = lrr__open_regular_fd(path, &r->fd, &sb); /* a FIFO would block open() */
    if (e == LRR__NOT_REGULAR || e == EISDIR)
        return lrr__error(ctx, LRR_ERR_IO, "file %s: " LRR__NOT_REGULAR_TEXT, path);
    if (e) {
        char eb[128];
        return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot open: %s", path,
                          lrr__errno_text(e, eb, sizeof eb));
    }
    r->file_size = (uint64_t)sb.st_size;
    return LRR_OK;
}

lrr_status lrr__load_head(struct reader *r, struct load_head *lh, int with_fbar,
                          lrr_operator **out)
{
    lrr_context *ctx = r->ctx;
    struct header *hd = &lh->hd;
    unsigned char *geom_buf = NULL;
    lrr__geometry g;
    memset(&g, 0, sizeof g);
    lrr_operator *op = NULL;
    *out = NULL;
    lrr_status st = read_layout(r, hd, lh->sec);
    if (st)
        return st;
    const struct section *gs = &lh->sec[SEC_GEOMETRY - 1];
    if ((st = lrr__calloc(ctx, &geom_buf, (size_t)gs->size, 1, "GEOMETRY section")) ||
        (st = read_section(r, gs, geom_buf)) ||
        (st = parse_geometry(r, geom_buf, gs->size, hd->n, hd->k, hd->d, &g, &lh->builtin)) ||
        (hd->adaptive && !hd->clusters &&
         (st = parse_patches(r, &lh->sec[SEC_PATCHES - 1], hd->k, &g,
                             &lh->selection_seconds))) ||
        (hd->clusters &&
         (st = parse_clusters(r, &lh->sec[SEC_CLUSTERS - 1], hd->k, &g,
                              &lh->selection_seconds))) ||
        (st = read_section(r, &lh->sec[SEC_INFO - 1], lh->info)) ||
        (st = info_weights(r, hd, get32(lh->info + 36))) ||
        (st = lrr__operator_alloc(ctx, &g, (lrr_storage)hd->dtype, with_fbar, &op)) ||
        (st = read_section(r, &lh->sec[SEC_RHO - 1], op->rho)) ||
        (st = read_section(r, &lh->sec[SEC_EMISSION - 1], op->emission)) ||
        (st = lrr__check_materials(r, op)))
        lrr_operator_destroy(op);
    else {
        op->weighting = hd->visibility ? LRR__WEIGHTS_VISIBILITY : LRR__WEIGHTS_AREA;
        *out = op;
    }
    lrr_aligned_free(geom_buf);
    lrr__geometry_free(&g);
    return st;
}

lrr_status lrr__load_m(struct reader *r, const struct load_head *lh, lrr_operator *op)
{
    lrr_status st = read_section(r, &lh->sec[SEC_M - 1], op->m);
    return st ? st : lrr__check_m(r, op);
}

lrr_status lrr__load_row_scales(struct reader *r, const struct load_head *lh, lrr_operator *op)
{
    if (lh->hd.dtype == DTYPE_F32)
        return LRR_OK;
    lrr_status st = read_section(r, &lh->sec[SEC_ROWSCALE - 1], op->row_scale);
    return st ? st : lrr__check_row_scales(r, op);
}

void lrr__load_info(const struct load_head *lh, lrr_operator *op)
{
    const unsigned char *info = lh->info;
    for (int c = 0; c < 3; c++)
        memcpy(&op->cond[c], info + 8 * c, 8);
    memcpy(&op->build_seconds, info + 24, 8);
    op->hemicube_resolution = get32(info + 32);
    op->no_rotation = (get32(info + 36) & 1u) != 0;
    op->receiver_sampling = get32(info + 36) & 2u ? LRR_RECEIVER_AREA : LRR_RECEIVER_CENTRE;
    op->seed = get64(info + 40);
    op->builtin = lh->builtin;
    op->selection_seconds = lh->selection_seconds;
}

/* lrr_operator_load with F̄ (read, checked, the visibility weights from it, panels), or
 * lrr_operator_load_head without: the row scales read and checked alone, F̄'s section
 * checked by the table only (read_layout), and the area weights left in place. */
static lrr_status load(lrr_context *ctx, const char *path, int with_fbar, lrr_operator **out)
{
    *out = NULL;
    struct reader r;
    struct load_head lh;
    lrr_operator *op = NULL;
    lrr_status st = lrr__load_open(ctx, path, &r, &lh);
    if (st)
        return st;
    if ((st = lrr__load_head(&r, &lh, with_fbar, &op)) ||
        (st = with_fbar ? read_fbar(&r, &lh.hd, lh.sec, op) : lrr__load_row_scales(&r, &lh, op)) ||
        (st = lrr__load_m(&r, &lh, op)))
        goto done;
    if (with_fbar &&
        ((st = lrr__visibility_weights(op)) || /* the weights M was factorised with */
         (st = lrr__fbar_set_panels(op, 1)))) /* the kernels read panels (no-op for strips) */
        goto done;
    lrr__load_info(&lh, op);
    if (lh.sec[SEC_VERIFY - 1].id)
        st = read_verify(&r, &lh.sec[SEC_VERIFY - 1], op);
done:
    close(r.fd);
    if (st) {
        lrr_operator_destroy(op);
        return st;
    }
    *out = op;
    return LRR_OK;
}

lrr_status lrr_operator_load(lrr_context *ctx, const char *path, lrr_operator **out)
{
    return load(ctx, path, 1, out);
}

lrr_status lrr_operator_load_head(lrr_context *ctx, const char *path, lrr_operator **out)
{
    return load(ctx, path, 0, out);
}
