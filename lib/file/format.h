/* The .lrr layout shared by saving (lrr_file.c, which documents the format at its top and
 * defines the checksum) and loading (load.c). Private to lib/file/. */
#ifndef LRR_FILE_FORMAT_H
#define LRR_FILE_FORMAT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

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
    SEC_PATCHES, SEC_CLUSTERS, SEC_VERIFY,
    SEC_COUNT = 6,     /* sections every file has */
    SEC_KNOWN = 10     /* sections this reader knows */
};
#define VERIFY_SIZE 48u
#define PATCHES_PREFIX 8u
#define CLUSTERS_PREFIX 8u

/* One entry of the section table; data is the payload being saved (NULL when loading). */
struct section {
    uint32_t id;
    const void *data;
    uint64_t size, offset, checksum;
    struct rows_out *rows; /* saving FBAR held in panels: written as rows from here */
};

/* The checksum of the format comment in lrr_file.c, over len bytes. */
uint64_t lrr__file_checksum(const void *data, size_t len);

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
