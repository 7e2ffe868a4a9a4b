/* lrr_operator_load_head (lib/file/load.c): a .lrr file loaded without F̄. Everything else
 * equals lrr_operator_load's bit for bit, for dense and strips files (versions 1, 4, 5), f32,
 * f16 and bf16, quadtree and clusters; what reads F̄ is refused with LRR_ERR_INVALID_ARG and
 * a message naming why, what does not (drawing, direct light) gives the whole operator's
 * result byte for byte; F̄'s bytes are never read (a damaged F̄ loads) but its table entry
 * and every other section are checked; and every allocation, failed in turn, gives
 * LRR_ERR_NOMEM and no operator. */
#include "testutil.h"
#include "file_bytes.h"
#include "operator/operator.h"

enum { HDR = 64, ENTRY = 32, SEC_FBAR = 4, SEC_M = 5, SEC_STRIPS = 11 };

/* The table's and the header's checksums valid again after an edit of the table. */
static void fix_table(unsigned char *b)
{
    const uint32_t count = rd32(b + 20);
    wr64(b + HDR + count * ENTRY, doc_checksum(b + HDR, count * ENTRY));
    wr64(b + 56, doc_checksum(b, 56));
}

typedef struct fixture {
    lrr_context *ctx;
    lrr_scene *scene;          /* the quadtree operator's scene (lrr_operator_verify) */
    lrr_operator *quad, *clusters;
    char path[512];
} fixture;

static int setup(void **state)
{
    fixture *fx = calloc(1, sizeof *fx);
    if (!fx)
        return -1;
    fx->ctx = tu_context();
    fx->scene = tu_cornell(fx->ctx, 0, 40, 1);
    lrr_build_options bo = {.hemicube_resolution = 16, .seed = 7};
    LRR_CHECK(fx->ctx, lrr_operator_build(fx->scene, &bo, &fx->quad));
    lrr_scene *sc = tu_cornell(fx->ctx, 0, 60, 0);
    lrr_build_options co = lrr_build_options_defaults();
    co.hemicube_resolution = 16;
    co.adaptive_patches = 20;
    co.hierarchy = LRR_HIERARCHY_CLUSTER;
    LRR_CHECK(fx->ctx, lrr_operator_build(sc, &co, &fx->clusters));
    lrr_scene_destroy(sc);
    assert_int_equal(fx->clusters->weighting, LRR__WEIGHTS_VISIBILITY);
    tu_tmp_path(fx->path, sizeof fx->path, "test_load_head.lrr");
    *state = fx;
    return 0;
}

static int teardown(void **state)
{
    fixture *fx = *state;
    remove(fx->path);
    lrr_operator_destroy(fx->quad);
    lrr_operator_destroy(fx->clusters);
    lrr_scene_destroy(fx->scene);
    lrr_context_destroy(fx->ctx);
    free(fx);
    return 0;
}

static lrr_operator *load_head(lrr_context *ctx, const char *path)
{
    lrr_operator *op = NULL;
    LRR_CHECK(ctx, lrr_operator_load_head(ctx, path, &op));
    assert_non_null(op);
    return op;
}

/* head holds everything of full but F̄, bit for bit; its weights are the area weights. */
static void assert_same_head(const lrr_operator *full, const lrr_operator *head)
{
    const size_t n = full->n, k = full->k;
    assert_int_equal(head->n, n);
    assert_int_equal(head->k, k);
    assert_int_equal(head->d, full->d);
    assert_int_equal(head->storage, full->storage);
    assert_int_equal(head->geom.n_tri, full->geom.n_tri);
    assert_int_equal(head->geom.levels, full->geom.levels);
    assert_memory_equal(head->geom.vert, full->geom.vert, full->geom.n_tri * 9 * sizeof(float));
    assert_memory_equal(head->geom.depth, full->geom.depth, full->geom.n_tri);
    assert_memory_equal(head->geom.first, full->geom.first, (k + 1) * sizeof(size_t));
    assert_true(!head->geom.origin == !full->geom.origin);
    if (full->geom.origin)
        assert_memory_equal(head->geom.origin, full->geom.origin, n * sizeof(size_t));
    assert_memory_equal(head->rho, full->rho, n * 3 * sizeof(float));
    assert_memory_equal(head->emission, full->emission, n * 3 * sizeof(float));
    assert_memory_equal(head->area, full->area, n * sizeof(float));
    assert_memory_equal(head->centre, full->centre, n * 3 * sizeof(float));
    assert_memory_equal(head->normal, full->normal, n * 3 * sizeof(float));
    assert_memory_equal(head->m, full->m, 3 * k * k * sizeof(float));
    assert_true(!head->row_scale == !full->row_scale);
    if (full->row_scale)
        assert_memory_equal(head->row_scale, full->row_scale, n * sizeof(float));
    assert_memory_equal(head->cond, full->cond, sizeof full->cond);
    assert_memory_equal(&head->verify, &full->verify, sizeof full->verify);
    assert_int_equal(head->weighting, full->weighting);
    float *area_w = malloc(n * sizeof *area_w);
    assert_non_null(area_w);
    lrr__patch_weights(&head->geom, area_w);
    assert_memory_equal(head->weight, area_w, n * sizeof(float));
    if (full->weighting != LRR__WEIGHTS_VISIBILITY)
        assert_memory_equal(head->weight, full->weight, n * sizeof(float));
    free(area_w);
    /* no F̄ */
    assert_null(head->fbar);
    assert_null(head->fbar16);
    assert_null(lrr_operator_fbar(head));
    /* the public figures: the same, but F̄'s bytes and layout */
    lrr_operator_info a, b;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    lrr_operator_get_info(full, &a, sizeof a);
    lrr_operator_get_info(head, &b, sizeof b);
    assert_int_equal(b.bytes + n * k * lrr__fbar_elem_bytes(full), a.bytes);
    assert_int_equal(b.layout, LRR_LAYOUT_ROWS);
    b.bytes = a.bytes;
    b.layout = a.layout;
    assert_memory_equal(&a, &b, sizeof a);
}

/* path saved from op in fbar's form (version want), then loaded both ways and compared. */
static void check_file(fixture *fx, const lrr_operator *op, lrr_fbar_format fbar, uint32_t want)
{
    LRR_CHECK(fx->ctx, lrr_operator_save_fbar(op, fx->path, fbar));
    assert_int_equal(file_version(fx->path), want);
    lrr_operator *full = NULL, *head = load_head(fx->ctx, fx->path);
    LRR_CHECK(fx->ctx, lrr_operator_load(fx->ctx, fx->path, &full));
    assert_same_head(full, head);
    lrr_operator_destroy(full);
    lrr_operator_destroy(head);
}

static void test_matches_load(void **state)
{
    fixture *fx = *state;
    check_file(fx, fx->quad, LRR_FBAR_DENSE, 1);
    check_file(fx, fx->quad, LRR_FBAR_SPARSE, 5);
    check_file(fx, fx->clusters, LRR_FBAR_DENSE, 4);  /* visibility weights */
    check_file(fx, fx->clusters, LRR_FBAR_SPARSE, 5); /* INFO bit 2 */
    /* 16-bit F̄: ROWSCALE read and checked */
    lrr_operator *f16 = NULL;
    LRR_CHECK(fx->ctx, lrr_operator_save(fx->quad, fx->path));
    LRR_CHECK(fx->ctx, lrr_operator_load(fx->ctx, fx->path, &f16));
    LRR_CHECK(fx->ctx, lrr_operator_set_storage(f16, LRR_STORAGE_F16));
    check_file(fx, f16, LRR_FBAR_DENSE, 1);
    check_file(fx, f16, LRR_FBAR_SPARSE, 5);
    LRR_CHECK(fx->ctx, lrr_operator_set_storage(f16, LRR_STORAGE_BF16));
    check_file(fx, f16, LRR_FBAR_SPARSE, 5);
    lrr_operator_destroy(f16);
}

/* st is LRR_ERR_INVALID_ARG with a message naming call and the missing F̄. */
static void expect_refused(lrr_context *ctx, lrr_status st, const char *call)
{
    char msg[512];
    lrr_status rec = lrr_context_last_error(ctx, msg, sizeof msg);
    if (st != LRR_ERR_INVALID_ARG || rec != st || !strstr(msg, call) ||
        !strstr(msg, "holds no F̄ (loaded without it by lrr_operator_load_head"))
        fail_msg("%s gave %s, recorded %s: \"%s\"", call, lrr_strerror(st), lrr_strerror(rec),
                 msg);
}

static void test_refusals(void **state)
{
    fixture *fx = *state;
    lrr_context *ctx = fx->ctx;
    LRR_CHECK(ctx, lrr_operator_save(fx->quad, fx->path));
    lrr_operator *op = load_head(ctx, fx->path);
    const size_t n = op->n, k = op->k;
    float *rho = malloc(n * 3 * sizeof *rho), *m = malloc(3 * k * k * sizeof *m);
    assert_true(rho && m);
    memcpy(rho, op->rho, n * 3 * sizeof *rho);
    memcpy(m, op->m, 3 * k * k * sizeof *m);

    lrr_solver *solver = (lrr_solver *)0x1;
    expect_refused(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &solver), "lrr_solver_create");
    assert_null(solver);
    solver = (lrr_solver *)0x1;
    expect_refused(ctx, lrr_solver_create(op, LRR_BACKEND_OPENCL, &solver), "lrr_solver_create");
    assert_null(solver);
    expect_refused(ctx, lrr_operator_set_storage(op, LRR_STORAGE_F16), "lrr_operator_set_storage");
    expect_refused(ctx, lrr_operator_set_storage(op, LRR_STORAGE_F32), "lrr_operator_set_storage");
    assert_int_equal(op->storage, LRR_STORAGE_F32);
    expect_refused(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_PANELS), "lrr_operator_set_layout");
    expect_refused(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS), "lrr_operator_set_layout");
    for (size_t i = 0; i < n * 3; i++)
        rho[i] *= 0.5f;
    expect_refused(ctx, lrr_operator_set_reflectance(op, rho), "lrr_operator_set_reflectance");
    for (size_t i = 0; i < n * 3; i++)
        rho[i] *= 2.0f; /* exact: powers of two */
    assert_memory_equal(op->rho, rho, n * 3 * sizeof *rho);
    assert_memory_equal(op->m, m, 3 * k * k * sizeof *m);
    char out[600];
    snprintf(out, sizeof out, "%s.again", fx->path);
    expect_refused(ctx, lrr_operator_save(op, out), "lrr_operator_save");
    expect_refused(ctx, lrr_operator_save_fbar(op, out, LRR_FBAR_SPARSE), "lrr_operator_save");
    assert_int_equal(access(out, F_OK), -1);
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = 4;
    expect_refused(ctx, lrr_operator_verify(op, fx->scene, &vo), "lrr_operator_verify");
    assert_int_equal(op->verify.subpatches, 0);
    /* F̄'s row: zeros, written over whatever out held */
    float *row = malloc(k * sizeof *row);
    assert_non_null(row);
    const size_t rows[2] = {0, n - 1};
    for (int r = 0; r < 2; r++) {
        const size_t i = rows[r];
        for (size_t q = 0; q < k; q++)
            row[q] = NAN;
        lrr_operator_fbar_row(op, i, row);
        for (size_t q = 0; q < k; q++)
            assert_true(row[q] == 0.0f);
    }
    free(row);
    free(rho);
    free(m);
    lrr_operator_destroy(op);
}

/* What rank 0 of `lrr solve` under mpirun does with the operator gives the whole load's
 * result: the direct light of directional and point lights, and the picture. */
static void test_uses_without_fbar(void **state)
{
    fixture *fx = *state;
    lrr_context *ctx = fx->ctx;
    LRR_CHECK(ctx, lrr_operator_save(fx->quad, fx->path));
    lrr_operator *full = NULL, *head = load_head(ctx, fx->path);
    LRR_CHECK(ctx, lrr_operator_load(ctx, fx->path, &full));
    const size_t n = full->n;
    float *a = calloc(n * 3, sizeof *a), *b = calloc(n * 3, sizeof *b);
    assert_true(a && b);
    const lrr_light sun[2] = {{{0.2f, 1.0f, 0.3f}, {1, 2, 3}}, {{-1, 0.5f, 0}, {2, 1, 0.5f}}};
    LRR_CHECK(ctx, lrr_probe_direct_light(full, sun, 2, a));
    LRR_CHECK(ctx, lrr_probe_direct_light(head, sun, 2, b));
    assert_memory_equal(a, b, n * 3 * sizeof *a);
    const lrr_light_source point = {.kind = LRR_LIGHT_POINT, .position = {278, 400, 279},
                                    .rgb = {30000, 30000, 30000}};
    lrr_lighting *la = NULL, *lb = NULL;
    LRR_CHECK(ctx, lrr_lighting_create(full, &la));
    LRR_CHECK(ctx, lrr_lighting_create(head, &lb));
    LRR_CHECK(ctx, lrr_lighting_direct(la, &point, 1, a));
    LRR_CHECK(ctx, lrr_lighting_direct(lb, &point, 1, b));
    assert_memory_equal(a, b, n * 3 * sizeof *a);
    double nonzero = 0;
    for (size_t i = 0; i < n * 3; i++)
        nonzero += a[i];
    assert_true(nonzero > 0); /* the light reached something */
    lrr_lighting_destroy(la);
    lrr_lighting_destroy(lb);
    char pa[600], pb[600];
    snprintf(pa, sizeof pa, "%s.full.png", fx->path);
    snprintf(pb, sizeof pb, "%s.head.png", fx->path);
    lrr_render_options ro = lrr_render_options_defaults();
    ro.width = 40;
    ro.height = 30;
    LRR_CHECK(ctx, lrr_render_png(full, a, &ro, pa));
    LRR_CHECK(ctx, lrr_render_png(head, a, &ro, pb));
    size_t la_len, lb_len;
    unsigned char *ba = slurp(pa, &la_len), *bb = slurp(pb, &lb_len);
    assert_int_equal(la_len, lb_len);
    assert_memory_equal(ba, bb, la_len);
    free(ba);
    free(bb);
    remove(pa);
    remove(pb);
    free(a);
    free(b);
    lrr_operator_destroy(full);
    lrr_operator_destroy(head);
}

/* Loads path with load_head expecting LRR_ERR_CORRUPT and a message holding want. */
static void expect_corrupt(lrr_context *ctx, const char *path, const char *want)
{
    lrr_operator *op = (lrr_operator *)0x1;
    lrr_status st = lrr_operator_load_head(ctx, path, &op);
    char msg[1024];
    lrr_context_last_error(ctx, msg, sizeof msg);
    if (st != LRR_ERR_CORRUPT || !strstr(msg, want)) {
        lrr_operator_destroy(st == LRR_OK ? op : NULL);
        fail_msg("load_head gave %s (\"%s\"), expected LRR_ERR_CORRUPT with \"%s\"",
                 lrr_strerror(st), msg, want);
    }
    assert_null(op);
}

/* A byte of F̄ flipped: lrr_operator_load refuses the file, lrr_operator_load_head reads
 * none of it; a byte of M flipped, or F̄'s entry beyond the file or of the wrong size: both
 * refuse it. For a dense (FBAR) and a strips (FBAR_STRIPS) file. */
static void test_damage(void **state)
{
    fixture *fx = *state;
    lrr_context *ctx = fx->ctx;
    for (int sparse = 0; sparse < 2; sparse++) {
        const uint32_t id = sparse ? SEC_STRIPS : SEC_FBAR;
        const char *name = sparse ? "section FBAR_STRIPS" : "section FBAR";
        LRR_CHECK(ctx, lrr_operator_save_fbar(fx->quad, fx->path,
                                              sparse ? LRR_FBAR_SPARSE : LRR_FBAR_DENSE));
        lrr_operator *clean = NULL; /* the whole load of the undamaged file */
        LRR_CHECK(ctx, lrr_operator_load(ctx, fx->path, &clean));
        size_t len;
        unsigned char *orig = slurp(fx->path, &len), *b = malloc(len);
        assert_non_null(b);
        const unsigned char *fe = table_entry(orig, id), *me = table_entry(orig, SEC_M);
        const uint64_t off = rd64(fe + 8), size = rd64(fe + 16);
        const uint64_t moff = rd64(me + 8), msize = rd64(me + 16);

        memcpy(b, orig, len);
        b[off + size / 2] ^= 0x40;
        spit(fx->path, b, len);
        lrr_operator *full = (lrr_operator *)0x1;
        assert_int_equal(lrr_operator_load(ctx, fx->path, &full), LRR_ERR_CORRUPT);
        assert_null(full);
        char msg[512]; /* read: the next message is the next error's */
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_CORRUPT);
        assert_non_null(strstr(msg, name));
        lrr_operator *head = load_head(ctx, fx->path);
        assert_same_head(clean, head);
        lrr_operator_destroy(head);

        memcpy(b, orig, len);
        b[moff + msize / 2] ^= 0x40;
        spit(fx->path, b, len);
        expect_corrupt(ctx, fx->path, "section M (bytes");

        memcpy(b, orig, len);
        wr64(table_entry(b, id) + 16, len - off + 64); /* ends past the file's end */
        fix_table(b);
        spit(fx->path, b, len);
        expect_corrupt(ctx, fx->path, "truncated");

        if (!sparse) { /* a dense F̄ has n·k entries exactly */
            memcpy(b, orig, len);
            wr64(table_entry(b, id) + 16, size - 4);
            fix_table(b);
            spit(fx->path, b, len);
            expect_corrupt(ctx, fx->path, name);
        }
        free(b);
        free(orig);
        lrr_operator_destroy(clean);
    }
}

/* Every allocation of a head load, failed in turn (a dense f32 quadtree file, and a clusters
 * file of 16-bit strips, which adds CLUSTERS and the row scales): LRR_ERR_NOMEM recorded, no
 * operator, and the load succeeds again once nothing fails. */
static void test_alloc_failures(void **state)
{
    fixture *fx = *state;
    lrr_operator *f16 = NULL;
    LRR_CHECK(fx->ctx, lrr_operator_save(fx->clusters, fx->path));
    LRR_CHECK(fx->ctx, lrr_operator_load(fx->ctx, fx->path, &f16));
    LRR_CHECK(fx->ctx, lrr_operator_set_storage(f16, LRR_STORAGE_F16));
    for (int f = 0; f < 2; f++) {
        LRR_CHECK(fx->ctx, f ? lrr_operator_save_fbar(f16, fx->path, LRR_FBAR_SPARSE)
                             : lrr_operator_save_fbar(fx->quad, fx->path, LRR_FBAR_DENSE));
        lrr_context *ctx = tu_context();
        lrr__context_fail_after(ctx, 0);
        lrr_operator *op = load_head(ctx, fx->path);
        const unsigned long count = lrr__context_alloc_count(ctx);
        lrr_operator_destroy(op);
        assert_true(count >= 10);
        for (unsigned long at = 1; at <= count; at++) {
            lrr__context_fail_after(ctx, at);
            op = (lrr_operator *)0x1;
            lrr_status st = lrr_operator_load_head(ctx, fx->path, &op);
            char msg[512];
            if (st != LRR_ERR_NOMEM || lrr_context_last_error(ctx, msg, sizeof msg) != st)
                fail_msg("allocation %lu of %lu failing: %s", at, count, lrr_strerror(st));
            assert_null(op);
        }
        lrr__context_fail_after(ctx, 0);
        op = load_head(ctx, fx->path); /* and succeeds again */
        lrr_operator_destroy(op);
        lrr_context_destroy(ctx);
    }
    lrr_operator_destroy(f16);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_matches_load),   cmocka_unit_test(test_refusals),
        cmocka_unit_test(test_uses_without_fbar), cmocka_unit_test(test_damage),
        cmocka_unit_test(test_alloc_failures),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
