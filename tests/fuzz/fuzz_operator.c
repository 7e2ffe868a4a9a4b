/*
 * Fuzz target: the .lrr operator loader (lrr_operator_load), then a solve of a loaded
 * operator, whose radiosity must be finite wherever the stored numbers cannot overflow.
 *
 * Every part of the file carries a checksum, so nearly every mutation would stop at the
 * first checksum test. Unless byte 52 (the header's reserved word, which readers ignore) is
 * non-zero, the target therefore recomputes the checksums of the header, of the section
 * table and of every section whose range lies inside the input before writing the file:
 * mutations reach the size, layout and value checks behind them, while inputs with byte 52
 * set still exercise the checksum tests themselves. The checksum is the one lib/file/lrr_file.c
 * documents (FNV-style word loop, MurmurHash3 fmix64).
 *
 * Seeds strips_*.lrr hold F̄ as strips (version 5, section FBAR_STRIPS). Such a file expands
 * to a dense F̄ larger than itself, but RHO and M bound n and k by its size: below MAX_INPUT
 * at most (2^20/12)^1.5 entries, 100 MB of floats, within the smoke's -malloc_limit_mb.
 *
 * Then the middle third of the patches is loaded alone (lrr__rows_load, what each rank of
 * a distributed solver loads: F̄ streamed for its checksum, only the block kept): it fails
 * with a message or succeeds, and where the whole file loaded it succeeds with the same
 * rows of the stored emission.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "lrr.h"
#include "solve/rows.h" /* lrr__rows_load: the row block an MPI rank loads */

#define HEADER_SIZE 64u
#define ENTRY_SIZE 32u
#define MAX_SECTIONS 64u
/* Larger inputs only slow the fuzzer down: the seeds are a few KiB. */
#define MAX_INPUT (1u << 20)

static uint64_t get64(const unsigned char *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; i--)
        v = v << 8 | p[i];
    return v;
}

static uint32_t get32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void put64(unsigned char *p, uint64_t v)
{
    for (int i = 0; i < 8; i++, v >>= 8)
        p[i] = (unsigned char)v;
}

static uint64_t checksum(const unsigned char *p, size_t len)
{
    const uint64_t prime = 0x100000001b3ULL;
    uint64_t h = 0xcbf29ce484222325ULL ^ (uint64_t)len;
    size_t words = len / 8;
    for (size_t i = 0; i < words; i++)
        h = (h ^ get64(p + 8 * i)) * prime;
    if (len % 8) {
        unsigned char last[8] = {0};
        memcpy(last, p + 8 * words, len % 8);
        h = (h ^ get64(last)) * prime;
    }
    h ^= (uint64_t)len;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    h *= 0xc4ceb9fe1a85ec53ULL;
    h ^= h >> 33;
    return h;
}

/* Sections first (their checksums sit in the table), then the table, then the header. */
static void repair_checksums(unsigned char *buf, size_t size)
{
    if (size < HEADER_SIZE || buf[52] != 0)
        return;
    uint32_t count = get32(buf + 20);
    size_t tsize = (size_t)count * ENTRY_SIZE + 8;
    if (count <= MAX_SECTIONS && HEADER_SIZE + tsize <= size) {
        unsigned char *table = buf + HEADER_SIZE;
        for (uint32_t i = 0; i < count; i++) {
            unsigned char *e = table + (size_t)i * ENTRY_SIZE;
            uint64_t off = get64(e + 8), len = get64(e + 16);
            if (off <= size && len <= size - off)
                put64(e + 24, checksum(buf + off, (size_t)len));
        }
        put64(table + tsize - 8, checksum(table, tsize - 8));
    }
    put64(buf + 56, checksum(buf, 56));
}

static double max_abs(const float *v, size_t count)
{
    double m = 0;
    for (size_t i = 0; i < count; i++)
        if (fabs((double)v[i]) > m)
            m = fabs((double)v[i]);
    return m;
}

/* Solves for the stored emission. With E <= e, |F̄| <= f, |M| <= m and rho < 1, every
 * radiosity is at most e + (k f)(k m)(d e), and the intermediate M Vᵀ E at most (k m)(d e):
 * when both are far below FLT_MAX the result must be finite, otherwise a non-finite value
 * is arithmetic, not a bug. (f is taken as at least 1 for the intermediate's sake.) */
static void solve(lrr_operator *op)
{
    lrr_operator_info info;
    lrr_operator_get_info(op, &info, sizeof info);
    size_t n = info.n, k = info.k;
    float *row = malloc(k * sizeof *row);
    float *b = malloc(n * 3 * sizeof *b);
    if (!row || !b)
        fuzz_fail("out of memory for n = %zu, k = %zu", n, k);
    double f = 0;
    for (size_t i = 0; i < n; i++) {
        lrr_operator_fbar_row(op, i, row);
        double r = max_abs(row, k);
        f = r > f ? r : f;
    }
    const float *e_in = lrr_operator_emission(op);
    double e = max_abs(e_in, 3 * n), m = max_abs(lrr_operator_m(op), 3 * k * k);
    double d = (double)(info.d_max ? info.d_max : 1);
    double bound = e + (double)k * (f > 1 ? f : 1) * (double)k * m * d * e;

    lrr_solver *solver = NULL;
    lrr_status st = lrr_solver_create(op, LRR_BACKEND_CPU, &solver);
    if (st == LRR_OK)
        st = lrr_solve(solver, e_in, b);
    if (st != LRR_OK && st != LRR_ERR_NOMEM)
        fuzz_fail("solve of a loaded operator failed: %s", lrr_strerror(st));
    if (st == LRR_OK && bound < 1e30)
        for (size_t i = 0; i < 3 * n; i++)
            if (!isfinite(b[i]))
                fuzz_fail("radiosity %zu (subpatch %zu) is %g although at most %g", i, i / 3,
                          (double)b[i], bound);
    lrr_solver_destroy(solver);
    free(b);
    free(row);
}

static lrr_status middle_third(void *user, const lrr_operator *op, size_t *p0, size_t *p1)
{
    (void)user;
    lrr_operator_info info;
    lrr_operator_get_info(op, &info, sizeof info);
    *p0 = info.k / 3;
    *p1 = 2 * info.k / 3;
    return LRR_OK;
}

/* The row block of the middle third of the patches, against op (NULL: the whole load
 * failed). */
static void row_block(lrr_context *ctx, const char *path, const lrr_operator *op)
{
    lrr__rows *rows = NULL;
    lrr_status st = lrr__rows_load(ctx, path, middle_third, NULL, &rows);
    char msg[512] = "";
    lrr_status recorded = lrr_context_last_error(ctx, msg, sizeof msg);
    if (st != LRR_OK && (rows || recorded == LRR_OK || !msg[0]))
        fuzz_fail("lrr__rows_load failed (%s) %s", lrr_strerror(st),
                  rows ? "but returned a block" : "without a message");
    if (st != LRR_OK && op && st != LRR_ERR_NOMEM)
        fuzz_fail("lrr__rows_load failed (%s: %s) on a file that loads", lrr_strerror(st), msg);
    if (st == LRR_OK && op) {
        size_t row0, count;
        lrr__rows_range(rows, &row0, &count);
        const float *e = lrr__rows_emission(rows);
        if (count && memcmp(e, lrr_operator_emission(op) + 3 * row0, count * 3 * sizeof *e))
            fuzz_fail("the row block's emission differs from the loaded operator's");
    }
    lrr__rows_destroy(rows);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_init();
    if (size > MAX_INPUT)
        return 0;
    unsigned char *buf = malloc(size ? size : 1);
    if (!buf)
        return 0;
    if (size)
        memcpy(buf, data, size);
    repair_checksums(buf, size);
    const char *path = fuzz_write("op.lrr", buf, size);
    free(buf);

    lrr_context *ctx = NULL;
    if (lrr_context_create(&ctx) != LRR_OK)
        fuzz_fail("lrr_context_create failed");
    lrr_operator *op = NULL;
    lrr_status st = lrr_operator_load(ctx, path, &op);
    char msg[512];
    lrr_status recorded = lrr_context_last_error(ctx, msg, sizeof msg);
    if (st == LRR_OK) {
        if (!op)
            fuzz_fail("lrr_operator_load returned LRR_OK without an operator");
        solve(op);
    } else if (op || recorded == LRR_OK || !msg[0]) {
        fuzz_fail("lrr_operator_load failed (%s) %s", lrr_strerror(st),
                  op ? "but returned an operator" : "without a message");
    }
    row_block(ctx, path, st == LRR_OK ? op : NULL);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    fuzz_remove("op.lrr");
    return 0;
}
