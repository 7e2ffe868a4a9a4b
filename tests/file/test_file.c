/* The .lrr operator file (lib/file/lrr_file.c): bit-exact round trips, the documented layout, and
 * clear errors (never a crash or a huge allocation) for corrupted, truncated and foreign
 * files. The checksum and layout are re-implemented here from the format comment in lib/file/lrr_file.c,
 * so the test also pins the documented format. */
#include <dirent.h>
#include <errno.h>
#include <sys/stat.h>
#include <unistd.h>

#include "testutil.h"
#include "file_bytes.h"
#include "operator/operator.h"

/* ------------------------------------------------------------ format, from the docs */
enum { HDR = 64, ENTRY = 32, NSEC = 6 };
enum { GEOMETRY = 1, RHO, EMISSION, FBAR, M, INFO };
static const char *const sec_names[] = {"", "GEOMETRY", "RHO", "EMISSION", "FBAR", "M", "INFO"};

/* Entry of section `id` in the table of file bytes b (the writer lists them in id order). */
static unsigned char *entry(unsigned char *b, int id)
{
    unsigned char *e = b + HDR + (size_t)(id - 1) * ENTRY;
    assert_int_equal(rd32(e), id);
    return e;
}
static uint64_t sec_off(unsigned char *b, int id) { return rd64(entry(b, id) + 8); }
static uint64_t sec_size(unsigned char *b, int id) { return rd64(entry(b, id) + 16); }

/* Makes every checksum of b valid again after a deliberate edit. */
static void fix_checksums(unsigned char *b)
{
    for (int id = 1; id <= NSEC; id++)
        wr64(entry(b, id) + 24, doc_checksum(b + sec_off(b, id), sec_size(b, id)));
    wr64(b + HDR + NSEC * ENTRY, doc_checksum(b + HDR, NSEC * ENTRY));
    wr64(b + 56, doc_checksum(b, 56));
}

/* ------------------------------------------------------------ file helpers */
/* Loads path expecting failure with `want` (or, when want2 != LRR_OK, either code); checks
 * that *out stays NULL and that the context's message names the file. */
static void expect_load_error(lrr_context *ctx, const char *path, lrr_status want,
                              lrr_status want2, const char *what)
{
    lrr_operator *op = (lrr_operator *)0x1;
    lrr_status st = lrr_operator_load(ctx, path, &op);
    char msg[512];
    lrr_status rec = lrr_context_last_error(ctx, msg, sizeof msg);
    if (st != want && (want2 == LRR_OK || st != want2)) {
        lrr_operator_destroy(st == LRR_OK ? op : NULL);
        fail_msg("%s: load gave %s (%s), expected %s", what, lrr_strerror(st), msg,
                 lrr_strerror(want));
    }
    assert_null(op);
    assert_int_equal(rec, st);
    if (!strstr(msg, path))
        fail_msg("%s: message \"%s\" does not name %s", what, msg, path);
}

/* No "<base>.tmp.*" left next to path. */
static void assert_no_temp_files(const char *path)
{
    char dir[512];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    assert_non_null(slash);
    *slash = '\0';
    char prefix[512];
    snprintf(prefix, sizeof prefix, "%s.tmp.", slash + 1);
    DIR *dh = opendir(dir);
    assert_non_null(dh);
    struct dirent *de;
    while ((de = readdir(dh)))
        if (strncmp(de->d_name, prefix, strlen(prefix)) == 0)
            fail_msg("temporary file %s/%s left behind", dir, de->d_name);
    closedir(dh);
}

/* ------------------------------------------------------------ fixtures */
typedef struct {
    lrr_context *ctx;
    lrr_operator *op;
    char path[512];
    unsigned char *bytes; /* the saved file */
    size_t len;
} fixture;

static uint64_t lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return *s >> 11;
}
static float unit(uint64_t *s) { return (float)((double)lcg(s) / 9007199254740992.0); }

/* A hand-made operator on an inward box: 12 triangles of patch depths 0, 1, 2 (k = 84),
 * levels = 1 (d = 4, n = 336), with arbitrary but valid contents. Independent of the
 * hemicube, so every value is under the test's control. */
static lrr_operator *handmade_operator(lrr_context *ctx)
{
    lrr__geometry g;
    memset(&g, 0, sizeof g);
    g.n_tri = 12;
    g.levels = 1;
    LRR_CHECK(ctx, lrr__calloc(ctx, &g.vert, 12, 9 * sizeof(float), "vert"));
    LRR_CHECK(ctx, lrr__calloc(ctx, &g.depth, 12, 1, "depth"));
    LRR_CHECK(ctx, lrr__calloc(ctx, &g.patch0, 13, sizeof(size_t), "patch0"));
    tu_box_inward(g.vert, 1.0, 2.0, 0.7);
    for (int t = 0; t < 12; t++)
        g.depth[t] = (uint8_t)(t % 3);
    LRR_CHECK(ctx, lrr__geometry_index(ctx, &g, SIZE_MAX));
    assert_int_equal(g.k, 84);
    assert_int_equal(g.n, 336);
    lrr_operator *op;
    LRR_CHECK(ctx, lrr__operator_new(ctx, &g, LRR_STORAGE_F32, &op));
    lrr__geometry_free(&g);
    uint64_t s = 12345;
    for (size_t i = 0; i < op->n * 3; i++) {
        op->rho[i] = 0.95f * unit(&s);
        op->emission[i] = (i % 7 == 0) ? 10.0f * unit(&s) : 0.0f;
    }
    for (size_t i = 0; i < op->n * op->k; i++)
        op->fbar[i] = unit(&s) / (float)(op->k * op->d);
    for (size_t i = 0; i < 3 * op->k * op->k; i++)
        op->m[i] = unit(&s) - 0.25f;
    op->cond[0] = 1.5;
    op->cond[1] = 2.25;
    op->cond[2] = 19.0 / 7.0;
    op->build_seconds = 0.123456789;
    op->hemicube_resolution = 64;
    op->seed = 0xfedcba9876543210ULL;
    op->builtin = LRR__SCENE_CORNELL;
    return op;
}

static int setup(void **state)
{
    fixture *fx = calloc(1, sizeof *fx);
    if (!fx || lrr_context_create(&fx->ctx) != LRR_OK)
        return -1;
    fx->op = handmade_operator(fx->ctx);
    tu_tmp_path(fx->path, sizeof fx->path, "test_file.lrr");
    if (lrr_operator_save(fx->op, fx->path) != LRR_OK)
        return -1;
    fx->bytes = slurp(fx->path, &fx->len);
    *state = fx;
    return 0;
}

static int teardown(void **state)
{
    fixture *fx = *state;
    remove(fx->path);
    free(fx->bytes);
    lrr_operator_destroy(fx->op);
    lrr_context_destroy(fx->ctx);
    free(fx);
    return 0;
}

/* ------------------------------------------------------------ round trips */
static void assert_same_operator(const lrr_operator *a, const lrr_operator *b)
{
    assert_int_equal(a->n, b->n);
    assert_int_equal(a->k, b->k);
    assert_int_equal(a->d, b->d);
    assert_int_equal(a->geom.n_tri, b->geom.n_tri);
    assert_int_equal(a->geom.levels, b->geom.levels);
    assert_memory_equal(a->geom.vert, b->geom.vert, a->geom.n_tri * 9 * sizeof(float));
    assert_memory_equal(a->geom.depth, b->geom.depth, a->geom.n_tri);
    assert_memory_equal(a->geom.patch0, b->geom.patch0, (a->geom.n_tri + 1) * sizeof(size_t));
    assert_memory_equal(a->rho, b->rho, a->n * 3 * sizeof(float));
    assert_memory_equal(a->emission, b->emission, a->n * 3 * sizeof(float));
    assert_memory_equal(a->area, b->area, a->n * sizeof(float));
    assert_memory_equal(a->centre, b->centre, a->n * 3 * sizeof(float));
    assert_memory_equal(a->normal, b->normal, a->n * 3 * sizeof(float));
    assert_memory_equal(a->fbar, b->fbar, a->n * a->k * sizeof(float));
    assert_memory_equal(a->m, b->m, 3 * a->k * a->k * sizeof(float));
    assert_memory_equal(a->cond, b->cond, sizeof a->cond);
    assert_memory_equal(&a->build_seconds, &b->build_seconds, sizeof(double));
    assert_int_equal(a->hemicube_resolution, b->hemicube_resolution);
    assert_true(a->seed == b->seed);
    assert_int_equal(a->builtin, b->builtin);
    assert_true(((uintptr_t)b->fbar & 63) == 0);
}

/* save → load → save: every array bit for bit, and identical bytes. */
static void roundtrip(lrr_context *ctx, const lrr_operator *op, const char *name)
{
    char p1[512], p2[600];
    tu_tmp_path(p1, sizeof p1, name);
    snprintf(p2, sizeof p2, "%s.again", p1);
    LRR_CHECK(ctx, lrr_operator_save(op, p1));
    lrr_operator *back = NULL;
    LRR_CHECK(ctx, lrr_operator_load(ctx, p1, &back));
    LRR_CHECK(ctx, lrr_operator_set_layout(back, LRR_LAYOUT_ROWS)); /* read as rows below */
    assert_non_null(back);
    assert_same_operator(op, back);
    LRR_CHECK(ctx, lrr_operator_save(back, p2));
    size_t l1, l2;
    unsigned char *b1 = slurp(p1, &l1), *b2 = slurp(p2, &l2);
    assert_int_equal(l1, l2);
    assert_memory_equal(b1, b2, l1);
    free(b1);
    free(b2);
    lrr_operator_destroy(back);
    assert_no_temp_files(p1);
    remove(p1);
    remove(p2);
}

static void test_roundtrip_handmade(void **state)
{
    fixture *fx = *state;
    roundtrip(fx->ctx, fx->op, "test_file_rt.lrr");
}

static void test_roundtrip_cornell(void **state)
{
    fixture *fx = *state;
    lrr_scene *scene;
    LRR_CHECK(fx->ctx, lrr_scene_cornell_box(fx->ctx, 0, &scene));
    lrr_subdivision sub = {.target_patches = 40, .levels = 1};
    LRR_CHECK(fx->ctx, lrr_scene_subdivide(scene, &sub));
    lrr_build_options opts = {.hemicube_resolution = 32, .seed = 7};
    lrr_operator *op;
    LRR_CHECK(fx->ctx, lrr_operator_build(scene, &opts, &op));
    LRR_CHECK(fx->ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
    lrr_scene_destroy(scene);
    roundtrip(fx->ctx, op, "test_file_cornell.lrr");

    /* The loaded operator reports the same information. */
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_cornell_info.lrr");
    LRR_CHECK(fx->ctx, lrr_operator_save(op, p));
    lrr_operator *back;
    LRR_CHECK(fx->ctx, lrr_operator_load(fx->ctx, p, &back));
    LRR_CHECK(fx->ctx, lrr_operator_set_layout(back, LRR_LAYOUT_ROWS)); /* read as rows below */
    lrr_operator_info a, b;
    lrr_operator_get_info(op, &a, sizeof a);
    lrr_operator_get_info(back, &b, sizeof b);
    assert_int_equal(a.n, b.n);
    assert_int_equal(a.k, b.k);
    assert_int_equal(a.triangles, b.triangles);
    assert_int_equal(b.hemicube_resolution, 32);
    assert_true(b.seed == 7);
    for (int c = 0; c < 3; c++)
        assert_true(a.condition[c] == b.condition[c]);
    lrr_operator_destroy(back);
    lrr_operator_destroy(op);
    remove(p);
}

/* The bytes follow the layout documented in lib/file/lrr_file.c. */
static void test_layout(void **state)
{
    fixture *fx = *state;
    unsigned char *b = fx->bytes;
    const lrr_operator *op = fx->op;
    assert_memory_equal(b, "LRROPER\0", 8);
    assert_int_equal(rd32(b + 8), 1);
    assert_int_equal(rd32(b + 12), 0x01020304);
    assert_int_equal(rd32(b + 16), HDR);
    assert_int_equal(rd32(b + 20), NSEC);
    assert_int_equal(rd64(b + 24), op->n);
    assert_int_equal(rd64(b + 32), op->k);
    assert_int_equal(rd64(b + 40), op->d);
    assert_int_equal(rd32(b + 48), 0);
    assert_true(rd64(b + 56) == doc_checksum(b, 56));
    assert_true(rd64(b + HDR + NSEC * ENTRY) == doc_checksum(b + HDR, NSEC * ENTRY));
    const uint64_t sizes[NSEC + 1] = {0, 16 + 37 * op->geom.n_tri, op->n * 12, op->n * 12,
                                      op->n * op->k * 4, 3 * op->k * op->k * 4, 48};
    uint64_t end = HDR + NSEC * ENTRY + 8;
    for (int id = 1; id <= NSEC; id++) {
        uint64_t off = sec_off(b, id), size = sec_size(b, id);
        assert_int_equal(off % 64, 0);
        assert_true(off >= end && off - end < 64);
        for (uint64_t i = end; i < off; i++)
            assert_int_equal(b[i], 0); /* deterministic padding */
        assert_int_equal(size, sizes[id]);
        assert_true(rd64(entry(b, id) + 24) == doc_checksum(b + off, size));
        end = off + size;
    }
    assert_int_equal(end, fx->len);
    assert_memory_equal(b + sec_off(b, FBAR), op->fbar, sizes[FBAR]);
    assert_memory_equal(b + sec_off(b, M), op->m, sizes[M]);
    assert_int_equal(rd64(b + sec_off(b, GEOMETRY)), 12);
    assert_true(rd64(b + sec_off(b, INFO) + 40) == op->seed);

    /* Saving the same operator again gives the same bytes (nothing time-dependent). */
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_again.lrr");
    LRR_CHECK(fx->ctx, lrr_operator_save(fx->op, p));
    size_t len;
    unsigned char *again = slurp(p, &len);
    assert_int_equal(len, fx->len);
    assert_memory_equal(again, b, len);
    free(again);
    remove(p);
}

/* ------------------------------------------------------------ corruption */
static void flip_and_expect(fixture *fx, const char *p, size_t pos, unsigned char mask,
                            lrr_status want, lrr_status want2, const char *where)
{
    unsigned char *b = malloc(fx->len);
    assert_non_null(b);
    memcpy(b, fx->bytes, fx->len);
    b[pos] ^= mask;
    spit(p, b, fx->len);
    char what[128];
    snprintf(what, sizeof what, "%s byte %zu ^ 0x%02x", where, pos, mask);
    expect_load_error(fx->ctx, p, want, want2, what);
    free(b);
}

static void test_bit_flips(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_flip.lrr");
    /* every header byte: magic, version and byte order are "another kind of file", the rest
     * fails the header checksum */
    for (size_t i = 0; i < HDR; i++)
        for (int m = 0; m < 2; m++)
            flip_and_expect(fx, p, i, m ? 0x80 : 0x01, LRR_ERR_CORRUPT, i < 16 ? LRR_ERR_VERSION : LRR_OK,
                            "header");
    for (size_t i = HDR; i < HDR + NSEC * ENTRY + 8; i++)
        flip_and_expect(fx, p, i, 0x01, LRR_ERR_CORRUPT, LRR_OK, "section table");
    for (int id = 1; id <= NSEC; id++) {
        uint64_t off = sec_off(fx->bytes, id), size = sec_size(fx->bytes, id);
        const uint64_t at[] = {0, 1, size / 3, size / 2, size - 2, size - 1};
        for (size_t j = 0; j < sizeof at / sizeof at[0]; j++)
            for (int bit = 0; bit < 8; bit += 3)
                flip_and_expect(fx, p, (size_t)(off + at[j]), (unsigned char)(1u << bit),
                                LRR_ERR_CORRUPT, LRR_OK, sec_names[id]);
    }
    /* the message names the failing section */
    flip_and_expect(fx, p, (size_t)sec_off(fx->bytes, FBAR) + 5, 0x10, LRR_ERR_CORRUPT, LRR_OK,
                    "FBAR");
    unsigned char *b = malloc(fx->len);
    memcpy(b, fx->bytes, fx->len);
    b[sec_off(b, M) + 3] ^= 0x40;
    spit(p, b, fx->len);
    lrr_operator *op = NULL;
    assert_int_equal(lrr_operator_load(fx->ctx, p, &op), LRR_ERR_CORRUPT);
    char msg[512];
    lrr_context_last_error(fx->ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "section M "));
    free(b);
    remove(p);
}

static void test_truncation(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_trunc.lrr");
    size_t fbar = (size_t)(sec_off(fx->bytes, FBAR) + sec_size(fx->bytes, FBAR) / 2);
    const size_t lens[] = {0, 1, 7, 8, 15, 16, HDR - 1, HDR, HDR + 3 * ENTRY + 5,
                           HDR + NSEC * ENTRY + 7, (size_t)sec_off(fx->bytes, GEOMETRY),
                           (size_t)sec_off(fx->bytes, RHO) + 1, fbar, fx->len - 1};
    for (size_t i = 0; i < sizeof lens / sizeof lens[0]; i++) {
        spit(p, fx->bytes, lens[i]);
        char what[64];
        snprintf(what, sizeof what, "truncated to %zu bytes", lens[i]);
        expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, what);
    }
    /* a sweep over the whole file */
    for (size_t len = 0; len < fx->len; len += fx->len / 97 + 1) {
        spit(p, fx->bytes, len);
        expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "truncated (sweep)");
    }
    /* the message says which section and how much is missing */
    spit(p, fx->bytes, fbar);
    lrr_operator *op = NULL;
    assert_int_equal(lrr_operator_load(fx->ctx, p, &op), LRR_ERR_CORRUPT);
    char msg[512];
    lrr_context_last_error(fx->ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "truncated"));
    assert_non_null(strstr(msg, "FBAR"));
    remove(p);
}

static void test_foreign_files(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_foreign.lrr");
    static const unsigned char png[] = {0x89, 'P',  'N',  'G',  '\r', '\n', 0x1a, '\n', 0,
                                        0,    0,    13,   'I',  'H',  'D',  'R',  0,    0,
                                        0,    1,    0,    0,    0,    1,    8,    2,    0,
                                        0,    0,    0x90, 0x77, 0x53, 0xde};
    spit(p, png, sizeof png);
    expect_load_error(fx->ctx, p, LRR_ERR_VERSION, LRR_OK, "PNG file");
    const char *text = "# Wavefront OBJ\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
                       "padding so that the file is longer than the header....\n";
    spit(p, text, strlen(text));
    expect_load_error(fx->ctx, p, LRR_ERR_VERSION, LRR_OK, "text file");
    spit(p, "hi\n", 3);
    expect_load_error(fx->ctx, p, LRR_ERR_VERSION, LRR_OK, "short text file");
    unsigned char zeros[4096] = {0};
    spit(p, zeros, sizeof zeros);
    expect_load_error(fx->ctx, p, LRR_ERR_VERSION, LRR_OK, "zero-filled file");

    /* A genuine other version or byte order (valid checksums): LRR_ERR_VERSION. */
    unsigned char *b = malloc(fx->len);
    memcpy(b, fx->bytes, fx->len);
    wr32(b + 8, 6);
    fix_checksums(b);
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_VERSION, LRR_OK, "version 6");
    char msg[512];
    lrr_operator *op = NULL;
    assert_int_equal(lrr_operator_load(fx->ctx, p, &op), LRR_ERR_VERSION);
    lrr_context_last_error(fx->ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "version 6, this library reads versions 1 to 5"));
    /* version 3 is the cluster hierarchy: it must have d = 0 and CLUSTERS */
    memcpy(b, fx->bytes, fx->len);
    wr32(b + 8, 3);
    fix_checksums(b);
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "version 3 with d > 0");
    /* version 2 is the adaptive hierarchy: it must have d = 0 and PATCHES */
    memcpy(b, fx->bytes, fx->len);
    wr32(b + 8, 2);
    fix_checksums(b);
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "version 2 with d > 0");
    memcpy(b, fx->bytes, fx->len);
    wr32(b + 12, 0x04030201);
    fix_checksums(b);
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_VERSION, LRR_OK, "big-endian file");
    memcpy(b, fx->bytes, fx->len);
    wr32(b + 48, 3); /* dtype 3: no such element type */
    fix_checksums(b);
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_VERSION, LRR_OK, "dtype 3");
    free(b);
    remove(p);
}

/* Headers with absurd sizes but valid checksums: an error from the size checks, never an
 * attempt to allocate (LRR_ERR_NOMEM / LRR_ERR_OVERFLOW would mean it tried). */
static void test_absurd_sizes(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_absurd.lrr");
    const uint64_t cases[][3] = {
        {1ULL << 60, 1ULL << 30, 1ULL << 30}, /* consistent n = k·d, far beyond the file */
        {1ULL << 60, 1ULL << 60, 1},          /* n·k and k·k overflow */
        {1ULL << 60, 84, 4},                  /* n != k·d */
        {UINT64_MAX, UINT64_MAX, 1},
        {336, 84, 0},
        {0, 0, 4},
        {336 * 2, 84 * 2, 4}, /* plausible but disagrees with the sections */
    };
    unsigned char *b = malloc(fx->len);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        memcpy(b, fx->bytes, fx->len);
        wr64(b + 24, cases[c][0]);
        wr64(b + 32, cases[c][1]);
        wr64(b + 40, cases[c][2]);
        fix_checksums(b);
        spit(p, b, fx->len);
        expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "absurd n/k/d");
    }
    /* a section table claiming a huge FBAR */
    memcpy(b, fx->bytes, fx->len);
    wr64(entry(b, FBAR) + 16, 1ULL << 62);
    wr64(b + HDR + NSEC * ENTRY, doc_checksum(b + HDR, NSEC * ENTRY));
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "huge FBAR size");
    /* a section offset near 2^64 (offset + size overflows) */
    memcpy(b, fx->bytes, fx->len);
    wr64(entry(b, RHO) + 8, UINT64_MAX - 63);
    wr64(b + HDR + NSEC * ENTRY, doc_checksum(b + HDR, NSEC * ENTRY));
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "offset overflow");
    /* an absurd section count */
    memcpy(b, fx->bytes, fx->len);
    wr32(b + 20, 0xffffffffu);
    fix_checksums(b);
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "section count");
    /* a GEOMETRY claiming 2^58 triangles */
    memcpy(b, fx->bytes, fx->len);
    wr64(b + sec_off(b, GEOMETRY), 1ULL << 58);
    fix_checksums(b);
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "triangle count");
    free(b);
    remove(p);
}

/* Contents that pass the checksums but are invalid (a buggy or hostile writer). */
static void test_invalid_contents(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_values.lrr");
    unsigned char *b = malloc(fx->len);
    struct {
        int id;
        size_t at;
        float value;
        const char *what;
    } cases[] = {
        {RHO, 4 * 17, 1.0f, "rho = 1"},          {RHO, 0, -0.1f, "rho < 0"},
        {RHO, 4 * 5, NAN, "rho NaN"},            {EMISSION, 4 * 9, -1.0f, "emission < 0"},
        {EMISSION, 0, INFINITY, "emission inf"}, {EMISSION, 4, NAN, "emission NaN"},
        {FBAR, 4 * 1000, NAN, "F̄ NaN"},          {M, 4 * 77, INFINITY, "M inf"},
        {GEOMETRY, 16 + 4 * 7, NAN, "vertex NaN"},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        memcpy(b, fx->bytes, fx->len);
        memcpy(b + sec_off(b, cases[c].id) + cases[c].at, &cases[c].value, 4);
        fix_checksums(b);
        spit(p, b, fx->len);
        expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, cases[c].what);
    }
    /* geometry that implies another k (a depth changed), levels out of range, unknown scene
     * kind */
    size_t depth0 = (size_t)sec_off(fx->bytes, GEOMETRY) + 16 + 12 * 36;
    const struct {
        size_t pos;
        unsigned char v;
        const char *what;
    } edits[] = {
        {depth0, 1, "depth changed"},
        {depth0 + 11, 200, "depth 200"},
        {(size_t)sec_off(fx->bytes, GEOMETRY) + 8, 11, "levels 11"},
        {(size_t)sec_off(fx->bytes, GEOMETRY) + 12, 9, "scene kind 9"},
    };
    for (size_t c = 0; c < sizeof edits / sizeof edits[0]; c++) {
        memcpy(b, fx->bytes, fx->len);
        b[edits[c].pos] = edits[c].v;
        fix_checksums(b);
        spit(p, b, fx->len);
        expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, edits[c].what);
    }
    /* a duplicated section id */
    memcpy(b, fx->bytes, fx->len);
    wr32(b + HDR + (RHO - 1) * ENTRY, EMISSION);
    wr64(b + HDR + NSEC * ENTRY, doc_checksum(b + HDR, NSEC * ENTRY));
    spit(p, b, fx->len);
    expect_load_error(fx->ctx, p, LRR_ERR_CORRUPT, LRR_OK, "duplicate section");
    /* the control: fix_checksums on an unmodified copy loads */
    memcpy(b, fx->bytes, fx->len);
    fix_checksums(b);
    assert_memory_equal(b, fx->bytes, fx->len);
    free(b);
    remove(p);
}

/* ------------------------------------------------------------ I/O errors */
static void test_missing_file(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_does_not_exist.lrr");
    remove(p);
    expect_load_error(fx->ctx, p, LRR_ERR_IO, LRR_OK, "missing file");
    /* a directory is not an operator file */
    char dir[512];
    tu_tmp_path(dir, sizeof dir, "test_file_dir");
    assert_int_equal(mkdir(dir, 0700), 0);
    expect_load_error(fx->ctx, dir, LRR_ERR_IO, LRR_OK, "directory");
    rmdir(dir);
    /* a FIFO without a writer: an error, not a hang in open() */
    tu_tmp_path(dir, sizeof dir, "test_file_fifo");
    remove(dir);
    assert_int_equal(mkfifo(dir, 0600), 0);
    expect_load_error(fx->ctx, dir, LRR_ERR_IO, LRR_OK, "FIFO");
    remove(dir);
}

static void test_save_errors(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_no_such_dir");
    strncat(p, "/op.lrr", sizeof p - strlen(p) - 1);
    assert_int_equal(lrr_operator_save(fx->op, p), LRR_ERR_IO);
    char msg[512];
    assert_int_equal(lrr_context_last_error(fx->ctx, msg, sizeof msg), LRR_ERR_IO);
    assert_non_null(strstr(msg, p));
    assert_non_null(strstr(msg, strerror(ENOENT)));
    assert_int_equal(access(p, F_OK), -1);

    /* rename onto a non-empty directory fails after the data was written: the temporary
     * file must be gone and the directory untouched */
    char dir[512], inside[600];
    tu_tmp_path(dir, sizeof dir, "test_file_target_dir");
    assert_int_equal(mkdir(dir, 0700), 0);
    snprintf(inside, sizeof inside, "%s/keep", dir);
    spit(inside, "x", 1);
    assert_int_equal(lrr_operator_save(fx->op, dir), LRR_ERR_IO);
    assert_int_equal(lrr_context_last_error(fx->ctx, msg, sizeof msg), LRR_ERR_IO);
    assert_non_null(strstr(msg, dir));
    struct stat sb;
    assert_int_equal(stat(dir, &sb), 0);
    assert_true(S_ISDIR(sb.st_mode));
    assert_no_temp_files(dir);
    remove(inside);
    rmdir(dir);
}

/* Saving over an existing file replaces it whole, leaves no temporary file and gives an
 * ordinary file mode (mkstemp's 0600 would surprise). */
static void test_overwrite(void **state)
{
    fixture *fx = *state;
    char p[512];
    tu_tmp_path(p, sizeof p, "test_file_overwrite.lrr");
    spit(p, "old contents", 12);
    assert_int_equal(chmod(p, 0640), 0);
    LRR_CHECK(fx->ctx, lrr_operator_save(fx->op, p));
    struct stat sb;
    assert_int_equal(stat(p, &sb), 0);
    assert_int_equal(sb.st_mode & 0777, 0640); /* the replaced file's mode */
    size_t len;
    unsigned char *b = slurp(p, &len);
    assert_int_equal(len, fx->len);
    assert_memory_equal(b, fx->bytes, len);
    free(b);
    assert_no_temp_files(p);
    remove(p);

    mode_t mask = umask(022);
    umask(mask);
    LRR_CHECK(fx->ctx, lrr_operator_save(fx->op, p));
    assert_int_equal(stat(p, &sb), 0);
    assert_int_equal(sb.st_mode & 0777, 0666 & ~mask);
    remove(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip_handmade), cmocka_unit_test(test_roundtrip_cornell),
        cmocka_unit_test(test_layout),             cmocka_unit_test(test_bit_flips),
        cmocka_unit_test(test_truncation),         cmocka_unit_test(test_foreign_files),
        cmocka_unit_test(test_absurd_sizes),       cmocka_unit_test(test_invalid_contents),
        cmocka_unit_test(test_missing_file),       cmocka_unit_test(test_save_errors),
        cmocka_unit_test(test_overwrite),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
