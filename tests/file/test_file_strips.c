/* .lrr files with F̄ as strips (version 5, section FBAR_STRIPS, lib/file/strips.c): F̄ loads
 * back bit for bit from the sparse and the dense form (float, binary16, bfloat16; panels and
 * rows; n not a multiple of 16), the bytes follow the layout documented in lib/file/lrr_file.c
 * (re-implemented here), dense operators keep the old version and bytes, the format can be
 * forced either way, and every kind of damage to the section is refused with a message
 * naming what and where. */
#include "testutil.h"
#include "file_bytes.h"
#include "operator/operator.h"

/* ------------------------------------------------------------ format, from the docs */
enum { HDR = 64, ENTRY = 32, FBAR = 4, INFO = 6, STRIPS = 11, TILE = 16 };

static size_t pad4(size_t m) { return (m + 3) / 4 * 4; }

/* Every checksum of b (len bytes) valid again after a deliberate edit. */
static void fix_checksums(unsigned char *b, size_t len)
{
    const uint32_t count = rd32(b + 20);
    for (uint32_t i = 0; i < count; i++) {
        unsigned char *e = b + HDR + i * ENTRY;
        if (rd64(e + 8) + rd64(e + 16) <= len)
            wr64(e + 24, doc_checksum(b + rd64(e + 8), rd64(e + 16)));
    }
    wr64(b + HDR + count * ENTRY, doc_checksum(b + HDR, count * ENTRY));
    wr64(b + 56, doc_checksum(b, 56));
}

/* ------------------------------------------------------------ helpers */

static uint64_t lcg(uint64_t *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return *s >> 11;
}
static float unit(uint64_t *s) { return (float)((double)lcg(s) / 9007199254740992.0); }

/* The open Cornell box at K patches of 4^levels subpatches with made-up contents: F̄ sparse
 * (of density `fill`, in strips: tile 0 full, tile 3 empty, one −0) or everywhere nonzero
 * (fill 1), in `storage` (rows). */
static lrr_operator *made_up(lrr_context *ctx, size_t K, unsigned levels, double fill,
                             lrr_storage storage)
{
    lrr_scene *scene = tu_cornell(ctx, 0, K, levels);
    lrr_operator *op;
    LRR_CHECK(ctx, lrr__operator_new(ctx, &scene->geom, LRR_STORAGE_F32, &op));
    lrr_scene_destroy(scene);
    uint64_t s = 99;
    for (size_t i = 0; i < 3 * op->n; i++) {
        op->rho[i] = 0.6f * unit(&s);
        op->emission[i] = i % 11 == 0 ? 5.0f : 0.0f;
    }
    for (size_t t = 0; t * TILE < op->n; t++)
        for (size_t q = 0; q < op->k; q++) {
            const int keep = fill >= 1 || t == 0 || (t != 3 && unit(&s) < fill);
            for (size_t i = t * TILE; keep && i < op->n && i < (t + 1) * TILE; i++)
                op->fbar[i * op->k + q] = unit(&s) < 0.5 ? unit(&s) / (float)op->k : 0.0f;
        }
    if (fill < 1)
        op->fbar[TILE * 2 * op->k + 5] = -0.0f; /* kept as it is: bits, not value */
    for (size_t c = 0; c < 3; c++)
        for (size_t p = 0; p < op->k; p++)
            op->m[c * op->k * op->k + p * op->k + p] = 1.0f;
    op->hemicube_resolution = 16;
    if (storage != LRR_STORAGE_F32)
        LRR_CHECK(ctx, lrr__fbar_convert(op, storage)); /* M is not refactored: unused here */
    return op;
}

/* F̄ of op as rows of raw stored values (n·k·elem bytes, malloc'd). */
static unsigned char *raw_rows(const lrr_operator *op)
{
    unsigned char *r = malloc(op->n * op->k * lrr__fbar_elem_bytes(op));
    assert_non_null(r);
    lrr__fbar_copy_rows(op, 0, op->n, r);
    return r;
}

static void assert_same_fbar(const lrr_operator *a, const lrr_operator *b)
{
    assert_int_equal(a->n, b->n);
    assert_int_equal(a->k, b->k);
    assert_int_equal(a->storage, b->storage);
    unsigned char *ra = raw_rows(a), *rb = raw_rows(b);
    assert_memory_equal(ra, rb, a->n * a->k * lrr__fbar_elem_bytes(a));
    free(ra);
    free(rb);
    if (a->row_scale)
        assert_memory_equal(a->row_scale, b->row_scale, a->n * sizeof(float));
    assert_memory_equal(a->rho, b->rho, a->n * 3 * sizeof(float));
    assert_memory_equal(a->emission, b->emission, a->n * 3 * sizeof(float));
    assert_memory_equal(a->m, b->m, 3 * a->k * a->k * sizeof(float));
    assert_memory_equal(a->weight, b->weight, a->n * sizeof(float));
}

/* The solver's AUTO choice for op: the file's rule is the same. */
static lrr_fbar_format solver_choice(const lrr_operator *op)
{
    lrr_solver *sv;
    LRR_CHECK(op->ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    lrr_solver_info si;
    lrr_solver_get_info(sv, &si, sizeof si);
    lrr_solver_destroy(sv);
    return si.fbar;
}

/* B for the stored emission through a dense CPU solver (malloc'd). */
static float *solve(const lrr_operator *op)
{
    lrr_solver *sv;
    LRR_CHECK(op->ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(op->ctx, lrr_solver_set_fbar(sv, LRR_FBAR_DENSE));
    float *b = malloc(op->n * 3 * sizeof *b);
    assert_non_null(b);
    LRR_CHECK(op->ctx, lrr_solve(sv, lrr_operator_emission(op), b));
    lrr_solver_destroy(sv);
    return b;
}

/* ------------------------------------------------------------ round trips */
static void test_roundtrip(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    char ps[512], pd[512], pa[512];
    tu_tmp_path(ps, sizeof ps, "strips_sparse.lrr");
    tu_tmp_path(pd, sizeof pd, "strips_dense.lrr");
    tu_tmp_path(pa, sizeof pa, "strips_again.lrr");
    for (int s = 0; s < 3; s++)
        for (int layout = 0; layout < 2; layout++) {
            lrr_operator *op = made_up(ctx, 40, 1, 0.15, (lrr_storage)s);
            assert_true(op->n % TILE != 0 && op->n > 2 * LRR__PANEL);
            LRR_CHECK(ctx, lrr_operator_set_layout(op, (lrr_layout)layout));
            assert_int_equal(solver_choice(op), LRR_FBAR_SPARSE);
            LRR_CHECK(ctx, lrr_operator_save(op, ps)); /* AUTO: sparse, as the solver */
            LRR_CHECK(ctx, lrr_operator_save_fbar(op, pd, LRR_FBAR_DENSE));
            assert_int_equal(file_version(ps), 5);
            assert_int_equal(file_version(pd), 1);
            size_t l1, l2;
            unsigned char *b1 = slurp(ps, &l1), *b2 = slurp(pd, &l2);
            assert_true(rd64(table_entry(b1, STRIPS) + 16) * 2 < rd64(table_entry(b2, FBAR) + 16));
            free(b1);
            free(b2);
            lrr_operator *from_s, *from_d;
            LRR_CHECK(ctx, lrr_operator_load(ctx, ps, &from_s));
            LRR_CHECK(ctx, lrr_operator_load(ctx, pd, &from_d));
            assert_int_equal(from_s->panels, 1); /* expanded straight into panels */
            assert_same_fbar(op, from_s);
            assert_same_fbar(op, from_d);
            float *bs = solve(from_s), *bd = solve(from_d);
            assert_memory_equal(bs, bd, op->n * 3 * sizeof(float));
            /* loaded and saved again: the same bytes */
            LRR_CHECK(ctx, lrr_operator_save(from_s, pa));
            b1 = slurp(ps, &l1);
            b2 = slurp(pa, &l2);
            assert_int_equal(l1, l2);
            assert_memory_equal(b1, b2, l1);
            free(b1);
            free(b2);
            free(bs);
            free(bd);
            lrr_operator_destroy(from_s);
            lrr_operator_destroy(from_d);
            lrr_operator_destroy(op);
        }
    remove(ps);
    remove(pd);
    remove(pa);
    lrr_context_destroy(ctx);
}

/* The section's bytes as lib/file/lrr_file.c documents them, decoded here into F̄'s rows. */
static void test_layout(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    char p[512];
    tu_tmp_path(p, sizeof p, "strips_layout.lrr");
    for (int s = 0; s < 2; s++) {
        lrr_operator *op = made_up(ctx, 40, 1, 0.15, s ? LRR_STORAGE_F16 : LRR_STORAGE_F32);
        LRR_CHECK(ctx, lrr_operator_save(op, p));
        size_t len;
        unsigned char *b = slurp(p, &len);
        assert_int_equal(rd32(b + 8), 5);
        assert_null(table_entry(b, FBAR));
        unsigned char *e = table_entry(b, STRIPS);
        assert_ptr_equal(e, b + HDR + 3 * ENTRY); /* in FBAR's place */
        const uint64_t off = rd64(e + 8), size = rd64(e + 16);
        assert_int_equal(off % 64, 0);
        assert_true(rd64(e + 24) == doc_checksum(b + off, size));
        const size_t n = op->n, k = op->k, es = s ? 2 : 4, tiles = (n + TILE - 1) / TILE;
        unsigned char *want = raw_rows(op), *got = calloc(n * k, es);
        assert_non_null(got);
        const unsigned char *c = b + off, *blk = c + 2 * pad4(tiles);
        for (size_t t = tiles; t < pad4(tiles); t++)
            assert_int_equal(rd16(c + 2 * t), 0);
        size_t strips = 0;
        for (size_t t = 0; t < tiles; t++) {
            const size_t m = rd16(c + 2 * t);
            const unsigned char *val = blk + 2 * pad4(m);
            for (size_t j = 0; j < m; j++) {
                const size_t q = rd16(blk + 2 * j);
                assert_true(q < k && (j == 0 || q > rd16(blk + 2 * j - 2)));
                for (size_t r = 0; r < TILE; r++) {
                    const unsigned char *v = val + (j * TILE + r) * es;
                    if (t * TILE + r < n)
                        memcpy(got + ((t * TILE + r) * k + q) * es, v, es);
                    else
                        for (size_t x = 0; x < es; x++)
                            assert_int_equal(v[x], 0);
                }
            }
            for (size_t j = m; j < pad4(m); j++)
                assert_int_equal(rd16(blk + 2 * j), 0);
            blk = val + m * TILE * es;
            strips += m;
        }
        assert_int_equal(blk - c, size); /* the documented size */
        assert_memory_equal(got, want, n * k * es);
        lrr__strip_count sc;
        lrr__fbar_count_strips(op, NULL, 1, &sc);
        assert_int_equal(strips, sc.strips); /* the solver's strips, −0 included */
        free(want);
        free(got);
        free(b);
        lrr_operator_destroy(op);
    }
    remove(p);
    lrr_context_destroy(ctx);
}

/* A dense operator (the closed Cornell box) keeps version 1 and the bytes of FBAR; either
 * format can be forced. */
static void test_dense_and_forced(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *sc = tu_cornell(ctx, 1, 40, 1);
    lrr_build_options bo = {.hemicube_resolution = 32, .seed = 7};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(sc, &bo, &op));
    lrr_scene_destroy(sc);
    assert_int_equal(solver_choice(op), LRR_FBAR_DENSE);
    char pa[512], pd[512], ps[512];
    tu_tmp_path(pa, sizeof pa, "strips_auto.lrr");
    tu_tmp_path(pd, sizeof pd, "strips_forced_dense.lrr");
    tu_tmp_path(ps, sizeof ps, "strips_forced_sparse.lrr");
    LRR_CHECK(ctx, lrr_operator_save(op, pa));
    LRR_CHECK(ctx, lrr_operator_save_fbar(op, pd, LRR_FBAR_DENSE));
    LRR_CHECK(ctx, lrr_operator_save_fbar(op, ps, LRR_FBAR_SPARSE));
    size_t la, ld;
    unsigned char *ba = slurp(pa, &la), *bd = slurp(pd, &ld);
    assert_int_equal(rd32(ba + 8), 1);
    assert_non_null(table_entry(ba, FBAR));
    assert_null(table_entry(ba, STRIPS));
    assert_int_equal(la, ld);
    assert_memory_equal(ba, bd, la);
    assert_int_equal(file_version(ps), 5);
    lrr_operator *back;
    LRR_CHECK(ctx, lrr_operator_load(ctx, ps, &back));
    assert_same_fbar(op, back);
    lrr_operator_destroy(back);
    /* not a format */
    assert_int_equal(lrr_operator_save_fbar(op, pa, (lrr_fbar_format)7), LRR_ERR_INVALID_ARG);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "unknown F̄ format 7"));
    free(ba);
    free(bd);
    remove(pa);
    remove(pd);
    remove(ps);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Clusters with visibility weights: version 4 dense, version 5 with INFO bit 2 sparse. */
static void test_clusters(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *sc = tu_cornell(ctx, 0, 60, 0);
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 32;
    bo.adaptive_patches = 20;
    bo.hierarchy = LRR_HIERARCHY_CLUSTER;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(sc, &bo, &op));
    lrr_scene_destroy(sc);
    assert_int_equal(op->weighting, LRR__WEIGHTS_VISIBILITY);
    char ps[512], pd[512];
    tu_tmp_path(ps, sizeof ps, "strips_clusters_sparse.lrr");
    tu_tmp_path(pd, sizeof pd, "strips_clusters_dense.lrr");
    LRR_CHECK(ctx, lrr_operator_save_fbar(op, ps, LRR_FBAR_SPARSE));
    LRR_CHECK(ctx, lrr_operator_save_fbar(op, pd, LRR_FBAR_DENSE));
    size_t ls, ld;
    unsigned char *bs = slurp(ps, &ls), *bd = slurp(pd, &ld);
    assert_int_equal(rd32(bs + 8), 5);
    assert_int_equal(rd32(bd + 8), 4);
    assert_int_equal(rd64(bs + 40), 0); /* d = 0 */
    assert_int_equal(rd32(bs + rd64(table_entry(bs, INFO) + 8) + 36) & 4u, 4u);
    assert_int_equal(rd32(bd + rd64(table_entry(bd, INFO) + 8) + 36) & 4u, 0u);
    for (int f = 0; f < 2; f++) {
        lrr_operator *back;
        LRR_CHECK(ctx, lrr_operator_load(ctx, f ? pd : ps, &back));
        assert_int_equal(back->weighting, LRR__WEIGHTS_VISIBILITY);
        assert_non_null(back->geom.origin);
        assert_memory_equal(back->geom.origin, op->geom.origin, op->n * sizeof(size_t));
        assert_same_fbar(op, back);
        lrr_operator_destroy(back);
    }
    /* bit 2 cleared: area weights (version 3's), so other weights than M was made with */
    unsigned char *flags = bs + rd64(table_entry(bs, INFO) + 8) + 36;
    wr32(flags, rd32(flags) & ~4u);
    fix_checksums(bs, ls);
    spit(ps, bs, ls);
    lrr_operator *area;
    LRR_CHECK(ctx, lrr_operator_load(ctx, ps, &area));
    assert_int_equal(area->weighting, LRR__WEIGHTS_AREA);
    lrr_operator_destroy(area);
    free(bs);
    free(bd);
    remove(ps);
    remove(pd);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* ------------------------------------------------------------ damage */
typedef struct damage_fx {
    lrr_context *ctx;
    char path[512];
    unsigned char *orig, *b; /* the sparse file as saved, and the copy being damaged */
    size_t len;
    size_t n, k, es, tiles;
    uint64_t off; /* FBAR_STRIPS */
} damage_fx;

static void damage_open(damage_fx *d, lrr_storage storage)
{
    lrr_operator *op = made_up(d->ctx, 40, 1, 0.15, storage);
    LRR_CHECK(d->ctx, lrr_operator_save(op, d->path));
    d->n = op->n, d->k = op->k, d->es = lrr__fbar_elem_bytes(op);
    d->tiles = (d->n + TILE - 1) / TILE;
    lrr_operator_destroy(op);
    free(d->orig);
    free(d->b);
    d->orig = slurp(d->path, &d->len);
    d->b = malloc(d->len);
    assert_non_null(d->b);
    d->off = rd64(table_entry(d->orig, STRIPS) + 8);
}

static unsigned char *count_at(damage_fx *d, size_t t) { return d->b + d->off + 2 * t; }
/* tile t's block; strip j's value of row r */
static unsigned char *block(damage_fx *d, size_t t)
{
    unsigned char *p = d->b + d->off + 2 * pad4(d->tiles);
    for (size_t u = 0; u < t; u++)
        p += 2 * pad4(rd16(count_at(d, u))) + TILE * d->es * rd16(count_at(d, u));
    return p;
}
static unsigned char *value(damage_fx *d, size_t t, size_t j, size_t r)
{
    return block(d, t) + 2 * pad4(rd16(count_at(d, t))) + (j * TILE + r) * d->es;
}

/* The damaged copy (checksums fixed unless raw) must fail with LRR_ERR_CORRUPT, a message
 * naming the file and containing each of the fragments; then the copy is reset. */
static void expect(damage_fx *d, int raw, const char *what, const char *f1, const char *f2)
{
    if (!raw)
        fix_checksums(d->b, d->len);
    spit(d->path, d->b, d->len);
    lrr_operator *op = (lrr_operator *)0x1;
    lrr_status st = lrr_operator_load(d->ctx, d->path, &op);
    char msg[512];
    lrr_context_last_error(d->ctx, msg, sizeof msg);
    if (st != LRR_ERR_CORRUPT || op || !strstr(msg, d->path) || !strstr(msg, f1) ||
        (f2 && !strstr(msg, f2)))
        fail_msg("%s: load gave %s \"%s\", expected corrupt with \"%s\"%s%s", what,
                 lrr_strerror(st), msg, f1, f2 ? " and " : "", f2 ? f2 : "");
    memcpy(d->b, d->orig, d->len);
}

/* A tile of the file with at least 2 strips and a count not a multiple of 4. */
static size_t pick_tile(damage_fx *d)
{
    for (size_t t = 1; t + 1 < d->tiles; t++)
        if (rd16(count_at(d, t)) >= 2 && rd16(count_at(d, t)) % 4 != 0)
            return t;
    fail_msg("no tile with 2 or more strips, not a multiple of 4");
    return 0;
}

static void test_damage(void **state)
{
    (void)state;
    damage_fx d = {tu_context(), "", NULL, NULL, 0, 0, 0, 0, 0, 0};
    tu_tmp_path(d.path, sizeof d.path, "strips_damage.lrr");
    char s1[128], s2[128];
    for (int s = 0; s < 3; s++) {
        damage_open(&d, (lrr_storage)s);
        memcpy(d.b, d.orig, d.len);
        const size_t t = pick_tile(&d), m = rd16(count_at(&d, t)), i0 = t * TILE;
        snprintf(s1, sizeof s1, "tile %zu (rows %zu..%zu)", t, i0, i0 + TILE - 1);
        /* counts */
        wr16(count_at(&d, t), (unsigned)d.k + 1);
        snprintf(s2, sizeof s2, "%zu strips, more than k = %zu", d.k + 1, d.k);
        expect(&d, 0, "count above k", s1, s2);
        wr16(count_at(&d, t), (unsigned)m + 1);
        expect(&d, 0, "count one more", "section FBAR_STRIPS: ", " bytes, its strip counts need");
        assert_true(d.tiles % 4 != 0);
        wr16(count_at(&d, d.tiles), 1);
        expect(&d, 0, "count padding", "padding after the", "strip counts is not zero");
        /* columns */
        unsigned char *col = block(&d, t);
        const unsigned c0 = rd16(col), c1 = rd16(col + 2);
        wr16(col, (unsigned)d.k);
        snprintf(s2, sizeof s2, "strip 0 (column %zu): column %zu is not below k", d.k, d.k);
        expect(&d, 0, "column k", s1, s2);
        wr16(col, c1);
        wr16(col + 2, c0);
        snprintf(s2, sizeof s2, "strip 1 (column %u): column %u after column %u", c0, c0, c1);
        expect(&d, 0, "columns descending", s1, s2);
        wr16(col + 2, c0);
        expect(&d, 0, "column repeated", s1, "ascend strictly");
        wr16(col + 2 * m, 1);
        snprintf(s2, sizeof s2, "padding after its %zu columns is not zero", m);
        expect(&d, 0, "column padding", s1, s2);
        /* values: not finite, negative, above FBAR_MAX, past n */
        unsigned char *v = value(&d, t, 0, 1);
        if (s == LRR_STORAGE_F32)
            wr32(v, 0x7fc00000u);
        else
            wr16(v, s == LRR_STORAGE_F16 ? 0x7e00u : 0x7fc0u);
        snprintf(s2, sizeof s2, "strip 0 (column %u): row %zu is not finite", c0, i0 + 1);
        expect(&d, 0, "NaN", s1, s2);
        if (s == LRR_STORAGE_F32)
            wr32(v, 0xbf000000u); /* -0.5 */
        else
            wr16(v, s == LRR_STORAGE_F16 ? 0xbc00u : 0xbf00u);
        snprintf(s2, sizeof s2, "row %zu is -", i0 + 1);
        expect(&d, 0, "negative", s2, "lie in [0, 1]");
        if (s != LRR_STORAGE_F16) { /* f16 rows are scaled: their codes cannot reach 2 */
            if (s == LRR_STORAGE_F32)
                wr32(v, 0x40000000u);
            else
                wr16(v, 0x4000u);
            snprintf(s2, sizeof s2, "row %zu is 2 (", i0 + 1);
            expect(&d, 0, "above FBAR_MAX", s1, s2);
        }
        const size_t last = d.tiles - 1, past = d.n % TILE + 2;
        assert_true(rd16(count_at(&d, last)) > 0);
        wr16(value(&d, last, 0, past), 0x3c00u);
        snprintf(s2, sizeof s2, "row %zu, past n = %zu, is not 0", last * TILE + past, d.n);
        expect(&d, 0, "row past n", s2, NULL);
        /* the checksum comes first: a flipped value or count reads as damage */
        *value(&d, t, 0, 0) ^= 0x20;
        expect(&d, 1, "flipped value", "section FBAR_STRIPS (bytes", "fails its checksum");
        wr16(count_at(&d, t), (unsigned)d.k + 1);
        expect(&d, 1, "flipped count", "section FBAR_STRIPS (bytes", "fails its checksum");
    }
    /* sizes and kinds (the float file) */
    damage_open(&d, LRR_STORAGE_F32);
    memcpy(d.b, d.orig, d.len);
    unsigned char *e = table_entry(d.b, STRIPS);
    wr64(e + 16, 8);
    expect(&d, 0, "section of 8 bytes", "FBAR_STRIPS has 8 bytes, less than its", NULL);
    const size_t cut = (size_t)d.off + 100;
    spit(d.path, d.orig, cut);
    lrr_operator *op = NULL;
    assert_int_equal(lrr_operator_load(d.ctx, d.path, &op), LRR_ERR_CORRUPT);
    char msg[512];
    lrr_context_last_error(d.ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "truncated: section FBAR_STRIPS needs bytes"));
    wr64(d.b + 32, 70000);
    expect(&d, 0, "k above 65535", "version 5 with k = 70000", "16-bit");
    unsigned char *info = d.b + rd64(table_entry(d.b, INFO) + 8);
    wr32(info + 36, rd32(info + 36) | 4u);
    expect(&d, 0, "INFO bit 2 without clusters", "section INFO: flag bit 2", NULL);
    wr32(d.b + 8, 1); /* version 1 has no strips (it skips them): FBAR is missing */
    expect(&d, 0, "version 1 with strips", "section FBAR is missing", NULL);
    lrr_operator *dense = made_up(d.ctx, 40, 1, 0.15, LRR_STORAGE_F32);
    LRR_CHECK(d.ctx, lrr_operator_save_fbar(dense, d.path, LRR_FBAR_DENSE));
    lrr_operator_destroy(dense);
    size_t len;
    unsigned char *b = slurp(d.path, &len);
    wr32(b + 8, 5); /* version 5 with dense FBAR */
    fix_checksums(b, len);
    spit(d.path, b, len);
    assert_int_equal(lrr_operator_load(d.ctx, d.path, &op), LRR_ERR_CORRUPT);
    lrr_context_last_error(d.ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "section FBAR_STRIPS is missing"));
    free(b);
    free(d.orig);
    free(d.b);
    remove(d.path);
    lrr_context_destroy(d.ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_roundtrip),        cmocka_unit_test(test_layout),
        cmocka_unit_test(test_dense_and_forced), cmocka_unit_test(test_clusters),
        cmocka_unit_test(test_damage),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
