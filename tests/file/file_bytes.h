/* The .lrr bytes as the format comment of lib/file/lrr_file.c documents them, written again
 * here (not taken from lib/file/) so that the file tests check the library against its
 * specification: little-endian integers, the documented checksum, and whole files read and
 * written. Shared by tests/file/test_file.c and test_file_strips.c. */
#ifndef LRR_TESTS_FILE_BYTES_H
#define LRR_TESTS_FILE_BYTES_H

#include "testutil.h"

static inline uint64_t rd64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}
static inline uint32_t rd32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}
static inline unsigned rd16(const unsigned char *p) { return (unsigned)p[0] | (unsigned)p[1] << 8; }
static inline void wr64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}
static inline void wr32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (unsigned char)(v >> (8 * i));
}
static inline void wr16(unsigned char *p, unsigned v)
{
    p[0] = (unsigned char)v;
    p[1] = (unsigned char)(v >> 8);
}

/* The checksum of the format comment, over len bytes. */
static inline uint64_t doc_checksum(const unsigned char *p, size_t len)
{
    uint64_t h = 0xcbf29ce484222325ULL ^ (uint64_t)len;
    size_t i = 0;
    for (; i + 8 <= len; i += 8)
        h = (h ^ rd64(p + i)) * 0x100000001b3ULL;
    if (i < len) {
        unsigned char tail[8] = {0};
        memcpy(tail, p + i, len - i);
        h = (h ^ rd64(tail)) * 0x100000001b3ULL;
    }
    h ^= (uint64_t)len;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ULL;
    h ^= h >> 33;
    return h;
}

/* The whole file at path (len bytes; free() it). */
static inline unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    fseek(f, 0, SEEK_END);
    long sz = ftell(f);
    assert_true(sz >= 0);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc((size_t)sz + 1);
    assert_non_null(b);
    assert_int_equal(fread(b, 1, (size_t)sz, f), (size_t)sz);
    fclose(f);
    *len = (size_t)sz;
    return b;
}

static inline void spit(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

/* The table entry of section id in file bytes b (after the 64-byte header, 32 bytes each,
 * as many as the header's count), NULL if absent. */
static inline unsigned char *table_entry(unsigned char *b, uint32_t id)
{
    for (uint32_t i = 0; i < rd32(b + 20); i++)
        if (rd32(b + 64 + i * 32) == id)
            return b + 64 + i * 32;
    return NULL;
}

/* The format version of the file at path. */
static inline uint32_t file_version(const char *path)
{
    size_t len;
    unsigned char *b = slurp(path, &len);
    uint32_t v = rd32(b + 8);
    free(b);
    return v;
}

#endif
