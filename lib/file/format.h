/* The .lrr layout shared by saving (lrr_file.c, which documents the format at its top and
 * defines the checksum) and loading (load.c). Private to lib/file/. */
#ifndef LRR_FILE_FORMAT_H
#define LRR_FILE_FORMAT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "file/stream.h"
#include "operator/operator.h"

#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) &&                            \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define LRR__FILE_LITTLE_ENDIAN 1
#else
#define LRR__FILE_LITTLE_ENDIAN 0
#endif

#define FILE_VERSION 1u          /* uniform hierarchy */
#define FILE_VERSION_ADAPTIVE 2u /* adds PATCHES */
#define FILE_VERSION_CLUSTER 3u  /* adds CLUSTERS */
#define FILE_VERSION_VISIBILITY 4u /* clusters whose Vᵀ weights follow F̄'s row sums */
#define FILE_VERSION_STRIPS 5u   /* any hierarchy, F̄ as FBAR_STRIPS (INFO bit 2: weights) */
#define INFO_VISIBILITY 4u       /* INFO flags bit 2 (version 5): the weights of version 4 */
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
    SEC_PATCHES, SEC_CLUSTERS, SEC_VERIFY, SEC_FBAR_STRIPS,
    SEC_COUNT = 6,     /* sections every file has (version 5: FBAR_STRIPS for FBAR) */
    SEC_KNOWN = 11     /* sections this reader knows */
};
#define VERIFY_SIZE 48u
#define PATCHES_PREFIX 8u
#define CLUSTERS_PREFIX 8u

/* A payload saved piece by piece rather than held whole (F̄ as rows from panels, or as
 * strips): next() puts the piece at *cursor (0 first; it advances it) into *data and
 * returns its bytes, 0 after the last. Every piece but the last is a multiple of 8 bytes,
 * so the checksum runs over the pieces as over one buffer. */
struct pieces {
    size_t (*next)(struct pieces *p, size_t *cursor, const void **data);
};

/* One entry of the section table; data is the payload being saved (NULL when loading). */
struct section {
    uint32_t id;
    const void *data;
    uint64_t size, offset, checksum;
    struct pieces *pieces; /* saving: the payload comes from here instead of data */
    uint64_t placed;       /* saving: its last bytes, written by others (stream.h); data
                              then holds the size − placed before them */
};

/* The checksum of the format comment in lrr_file.c, over len bytes; and the same over
 * consecutive pieces of a len-byte buffer (every piece but the last a multiple of 8 bytes):
 * h = lrr__checksum_begin(len), h = lrr__checksum_run(h, piece, bytes) per piece, then
 * lrr__checksum_end(h, len). */
uint64_t lrr__file_checksum(const void *data, size_t len);
uint64_t lrr__checksum_begin(uint64_t len);
/* lrr__checksum_run: stream.h */
uint64_t lrr__checksum_end(uint64_t h, uint64_t len);

/* ------------------------------------------------------------ loading (load.c) */
struct reader {
    lrr_context *ctx;
    const char *path;
    int fd;
    uint64_t file_size;
};

/* The header fields the rest of the load uses. */
struct header {
    uint32_t version, count, dtype;
    uint64_t n, k, d;
    bool adaptive;  /* d = 0: version 2 (PATCHES) or 3 (CLUSTERS) */
    bool clusters;  /* version 3 or 4 */
    bool visibility; /* version 4 (5: INFO bit 2): Vᵀ's weights from F̄'s row sums */
    bool strips;     /* version 5: F̄ as FBAR_STRIPS, any hierarchy */
};

/* load.c, in the order a load calls them (lrr_operator_load and lrr_operator_load_head;
 * lrr__operator_load_rows in load_rows.c): open path into r (closed by the caller when
 * r->fd >= 0) and clear lh; the header, the section table, the geometry and hierarchy, INFO,
 * and an operator of it (F̄ allocated when with_fbar; its rho and emission read and checked,
 * its weighting set); the row scales (16-bit F̄) and M, read and checked; INFO's fields into
 * the operator. */
struct load_head {
    struct header hd;
    struct section sec[SEC_KNOWN]; /* indexed by id − 1 */
    unsigned char info[INFO_SIZE];
    int builtin;
    double selection_seconds;
};
lrr_status lrr__load_open(lrr_context *ctx, const char *path, struct reader *r,
                          struct load_head *lh);
lrr_status lrr__load_head(struct reader *r, struct load_head *lh, int with_fbar,
                          lrr_operator **out);
lrr_status lrr__load_row_scales(struct reader *r, const struct load_head *lh, lrr_operator *op);
lrr_status lrr__load_m(struct reader *r, const struct load_head *lh, lrr_operator *op);
void lrr__load_info(const struct load_head *lh, lrr_operator *op);
/* Reads len bytes at offset (checked against the file size by the caller); what names them
 * in errors. */
lrr_status lrr__file_read_at(struct reader *r, uint64_t offset, void *buf, size_t len,
                             const char *what);
/* check.c: RHO and EMISSION in range; ROWSCALE powers of two (1 for bfloat16); F̄ held
 * dense as rows (finite, the row scales, then each entry in [0, FBAR_MAX]); M finite. */
lrr_status lrr__check_materials(struct reader *r, const lrr_operator *op);
lrr_status lrr__check_row_scales(struct reader *r, const lrr_operator *op);
lrr_status lrr__check_fbar(struct reader *r, const lrr_operator *op);
lrr_status lrr__check_m(struct reader *r, const lrr_operator *op);
/* Checks a loaded F̄ entry as every path does: raw its bits in the operator's storage,
 * scale its row's scale (1 for float); false when it is not finite or outside
 * [0, FBAR_MAX], with *value the decoded entry and *finite whether it was finite. */
bool lrr__fbar_entry_ok(lrr_storage storage, uint32_t raw, float scale, float *value,
                        bool *finite);

/* ------------------------------------------------------------ FBAR_STRIPS (strips.c) */
/* Saving: the strips of op as pieces (lrr__strips_out_init counts them; *size the section's
 * bytes), freed by lrr__strips_out_free. *sparse_pays: AUTO would choose them. */
struct strips_out {
    struct pieces base;
    const lrr_operator *op;
    size_t tiles, *count;   /* strips per tile */
    unsigned char *buf;     /* one piece */
    size_t cap;
};
lrr_status lrr__strips_out_init(const lrr_operator *op, struct strips_out *so, uint64_t *size,
                                int *sparse_pays);
void lrr__strips_out_free(struct strips_out *so);
/* Loading: the section s into op's zeroed F̄ (any layout) and its checks (row scales
 * already checked), with the checksum verified over the whole payload. */
lrr_status lrr__strips_load(struct reader *r, const struct section *s, lrr_operator *op);
/* The same, every strip checked and the checksum too, but only rows [row0, row0 + rows)
 * stored, row-major, into win (rows×k in op's storage, zeroed); op (without F̄, rows
 * layout) gives n, k, the storage and the row scales. */
lrr_status lrr__strips_load_rows(struct reader *r, const struct section *s,
                                 const lrr_operator *op, size_t row0, size_t rows, void *win);
/* Bytes of the strip counts at the section's start for n rows (a multiple of 8). */
static inline uint64_t strips_counts_bytes(uint64_t n)
{
    const uint64_t tiles = n / LRR__TILE + (n % LRR__TILE != 0);
    return (tiles + 3) / 4 * 8;
}

/* ------------------------------------------------------------ byte order */
static inline void put32(unsigned char *p, uint32_t v) { memcpy(p, &v, 4); }
static inline void put64(unsigned char *p, uint64_t v) { memcpy(p, &v, 8); }
static inline uint32_t get32(const unsigned char *p) { uint32_t v; memcpy(&v, p, 4); return v; }
static inline uint64_t get64(const unsigned char *p) { uint64_t v; memcpy(&v, p, 8); return v; }

/* Byte size count×elem as u64, false on overflow. */
static inline bool bytes_of(uint64_t count, uint64_t elem, uint64_t *out)
{
    return !__builtin_mul_overflow(count, elem, out);
}

#endif
