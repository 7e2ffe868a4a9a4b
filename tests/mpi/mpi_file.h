/* The MPI tests' comparison of two .lrr files (test_mpi_build, test_mpi_build_save): the
 * same sections byte for byte but for the timings. */
#ifndef LRR_MPI_FILE_H
#define LRR_MPI_FILE_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The file's sections as (id, offset, size); 0 when the table cannot be read. */
static inline int sections(const unsigned char *f, size_t len, unsigned id[16], size_t off[16],
                    size_t size[16])
{
    if (len < 64)
        return 0;
    unsigned count;
    memcpy(&count, f + 20, 4);
    if (count > 16 || 64 + 32 * (size_t)count + 8 > len)
        return 0;
    for (unsigned s = 0; s < count; s++) {
        uint64_t o, z;
        memcpy(&id[s], f + 64 + 32 * s, 4);
        memcpy(&o, f + 64 + 32 * s + 8, 8);
        memcpy(&z, f + 64 + 32 * s + 16, 8);
        if (o > len || z > len - o)
            return 0;
        off[s] = (size_t)o;
        size[s] = (size_t)z;
    }
    return (int)count;
}

static inline unsigned char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    unsigned char *b = NULL;
    if (f && fseek(f, 0, SEEK_END) == 0) {
        long l = ftell(f);
        rewind(f);
        if (l > 0 && (b = malloc((size_t)l)) && fread(b, 1, (size_t)l, f) != (size_t)l) {
            free(b);
            b = NULL;
        }
        *len = l > 0 ? (size_t)l : 0;
    }
    if (f)
        fclose(f);
    return b;
}

/* The two files hold the same sections, byte for byte but for the timings: INFO's
 * build_seconds (bytes 24..31 of section 6), the selection_seconds that PATCHES and
 * CLUSTERS (8 and 9) begin with, and VERIFY's seconds (bytes 16..23 of section 10). */
static inline int same_files_but(const char *a, const char *b, unsigned skip);
static inline int same_files(const char *a, const char *b) { return same_files_but(a, b, 0); }

/* same_files, the sections whose bit (1 << id) is set in skip only of the same size (M and
 * INFO's condition estimates, from another inversion). */
static inline int same_files_but(const char *a, const char *b, unsigned skip)
{
    size_t la = 0, lb = 0;
    unsigned char *fa = slurp(a, &la), *fb = slurp(b, &lb);
    unsigned ia[16], ib[16];
    size_t oa[16], ob[16], za[16], zb[16];
    int na = fa ? sections(fa, la, ia, oa, za) : 0, nb = fb ? sections(fb, lb, ib, ob, zb) : 0;
    int same = la == lb && na > 0 && na == nb && memcmp(fa, fb, 24) == 0;
    for (int s = 0; same && s < na; s++) {
        same = ia[s] == ib[s] && oa[s] == ob[s] && za[s] == zb[s];
        const size_t at = ia[s] == 6 ? 24 : ia[s] == 10 ? 16 : 0;
        if (same && (ia[s] == 6 || ia[s] == 8 || ia[s] == 9 || ia[s] == 10) &&
            za[s] >= at + 8) {
            memset(fa + oa[s] + at, 0, 8);
            memset(fb + ob[s] + at, 0, 8);
        }
        same = same && (skip >> ia[s] & 1u || memcmp(fa + oa[s], fb + ob[s], za[s]) == 0);
    }
    free(fa);
    free(fb);
    return same;
}

#endif
