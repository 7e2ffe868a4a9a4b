/* Growable structs (lib/core/options.c, include/lrr.h "Conventions"): option structs read
 * by their size (0 = this layout, the defaults the same as NULL, a newer caller's unknown
 * fields refused), info structs written up to the caller's size. */
#include "testutil.h"

#include "core/internal.h"


static lrr_scene *cornell(lrr_context *ctx)
{
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_builtin(ctx, "cornell", &s));
    return s;
}

/* A caller built against a newer lrr: the struct is longer, its first bytes ours. */
typedef struct {
    lrr_subdivision v1;
    double newer_field;
} newer_subdivision;

static void test_option_sizes(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx);
    lrr_scene_info a, b;

    /* size 0 (designated initialisers) and the defaults' size read the same fields */
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.target_patches = 54, .levels = 1}));
    lrr_scene_get_info(s, &a, sizeof a);
    lrr_subdivision sd = lrr_subdivision_defaults();
    assert_int_equal(sd.size, sizeof sd);
    sd.target_patches = 54;
    sd.levels = 1;
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_scene_get_info(s, &b, sizeof b);
    assert_int_equal(a.patches, b.patches);
    assert_int_equal(a.subpatches, b.subpatches);
    assert_int_equal(b.d, 4);

    /* a size below this layout, or not a whole number of words, is refused by name */
    char msg[512];
    const size_t bad[] = {8, sizeof sd - sizeof(size_t), sizeof sd + 1};
    for (int t = 0; t < 3; t++) {
        lrr_subdivision x = sd;
        x.size = bad[t];
        assert_int_equal(lrr_scene_subdivide(s, &x), LRR_ERR_INVALID_ARG);
        lrr_context_last_error(ctx, msg, sizeof msg);
        assert_non_null(strstr(msg, "lrr_subdivision.size"));
        assert_non_null(strstr(msg, "lrr_subdivision_defaults"));
    }

    /* a newer caller: accepted while its unknown field is zero, refused once it is set */
    newer_subdivision nw;
    memset(&nw, 0, sizeof nw);
    nw.v1 = sd;
    nw.v1.size = sizeof nw;
    nw.v1.levels = 0;
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &nw.v1));
    lrr_scene_get_info(s, &a, sizeof a);
    assert_int_equal(a.d, 1);
    nw.newer_field = 1.0;
    assert_int_equal(lrr_scene_subdivide(s, &nw.v1), LRR_ERR_UNSUPPORTED);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "newer lrr"));
    lrr_scene_get_info(s, &b, sizeof b); /* the refused call changed nothing */
    assert_int_equal(a.subpatches, b.subpatches);

    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* The defaults are what NULL options mean: the same operator bit for bit, the same picture
 * byte for byte. */
static void test_defaults_equal_null(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx);
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.target_patches = 36}));
    lrr_operator *a, *b;
    lrr_build_options o = lrr_build_options_defaults();
    assert_int_equal(o.size, sizeof o);
    LRR_CHECK(ctx, lrr_operator_build(s, NULL, &a));
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &b));
    lrr_operator_info ia, ib;
    lrr_operator_get_info(a, &ia, sizeof ia);
    lrr_operator_get_info(b, &ib, sizeof ib);
    assert_int_equal(ia.hemicube_resolution, ib.hemicube_resolution);
    assert_int_equal(ia.n, ib.n);
    assert_int_equal(ia.layout, LRR_LAYOUT_PANELS);
    LRR_CHECK(ctx, lrr_operator_set_layout(a, LRR_LAYOUT_ROWS));
    LRR_CHECK(ctx, lrr_operator_set_layout(b, LRR_LAYOUT_ROWS));
    assert_memory_equal(lrr_operator_fbar(a), lrr_operator_fbar(b),
                        ia.n * ia.k * sizeof(float));
    assert_memory_equal(lrr_operator_m(a), lrr_operator_m(b), 3 * ia.k * ia.k * sizeof(float));

    char p1[512], p2[512];
    tu_tmp_path(p1, sizeof p1, "options-null.png");
    tu_tmp_path(p2, sizeof p2, "options-defaults.png");
    lrr_render_options r = lrr_render_options_defaults();
    LRR_CHECK(ctx, lrr_render_png(a, lrr_operator_emission(a), NULL, p1));
    LRR_CHECK(ctx, lrr_render_png(a, lrr_operator_emission(a), &r, p2));
    FILE *f1 = fopen(p1, "rb"), *f2 = fopen(p2, "rb");
    assert_non_null(f1);
    assert_non_null(f2);
    int c1, c2;
    long bytes = 0;
    do {
        c1 = fgetc(f1);
        c2 = fgetc(f2);
        assert_int_equal(c1, c2);
        bytes++;
    } while (c1 != EOF);
    assert_true(bytes > 1000);
    fclose(f1);
    fclose(f2);
    remove(p1);
    remove(p2);

    /* the fit options' defaults are the documented ones */
    lrr_fit_options fo = lrr_fit_options_defaults();
    assert_int_equal(fo.max_iterations, 300);
    assert_true(fo.tolerance == 1e-6);

    lrr_operator_destroy(a);
    lrr_operator_destroy(b);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* ABI 1's layouts (this release's, camera, form-factor method and path-trace options
 * included): what size = 0 means is the whole of today's structs. A field added later must
 * be appended past them, and these lines keep naming ABI 1's last fields. */
static void test_first_sizes(void **state)
{
    (void)state;
    assert_int_equal(LRR__FIRST_SIZE(lrr_subdivision, levels), sizeof(lrr_subdivision));
    /* lrr_build_options: ABI 1 ends at formfactor_method; hierarchy was appended after */
    assert_true(LRR__FIRST_SIZE(lrr_build_options, formfactor_method) <
                sizeof(lrr_build_options));
    assert_true(offsetof(lrr_build_options, hierarchy) >=
                LRR__FIRST_SIZE(lrr_build_options, formfactor_method));
    assert_int_equal(LRR__FIRST_SIZE(lrr_build_options, hierarchy), sizeof(lrr_build_options));
    assert_int_equal(LRR__FIRST_SIZE(lrr_render_options, use_eye), sizeof(lrr_render_options));
    assert_int_equal(LRR__FIRST_SIZE(lrr_fit_options, history_len), sizeof(lrr_fit_options));
    assert_int_equal(LRR__FIRST_SIZE(lrr_path_trace_options, progress_user),
                     sizeof(lrr_path_trace_options));
    assert_int_equal(offsetof(lrr_path_trace_options, size), 0);
    assert_int_equal(offsetof(lrr_subdivision, size), 0);
    assert_int_equal(offsetof(lrr_build_options, size), 0);
    assert_int_equal(offsetof(lrr_render_options, size), 0);
    assert_int_equal(offsetof(lrr_fit_options, size), 0);
}

/* Info structs: an older caller's shorter struct gets what fits and nothing beyond it; a
 * newer caller's longer one gets zeros where this lrr has no field. */
static void test_info_sizes(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = cornell(ctx);
    lrr_scene_info full;
    lrr_scene_get_info(s, &full, sizeof full);
    assert_int_equal(full.triangles, 36);

    unsigned char buf[sizeof full + 64];
    const size_t part = offsetof(lrr_scene_info, patches);
    memset(buf, 0xAB, sizeof buf);
    lrr_scene_get_info(s, (lrr_scene_info *)(void *)buf, part);
    assert_memory_equal(buf, &full, part);
    for (size_t i = part; i < sizeof buf; i++)
        assert_int_equal(buf[i], 0xAB);

    memset(buf, 0xAB, sizeof buf);
    lrr_scene_get_info(s, (lrr_scene_info *)(void *)buf, sizeof buf);
    assert_memory_equal(buf, &full, sizeof full);
    for (size_t i = sizeof full; i < sizeof buf; i++)
        assert_int_equal(buf[i], 0);

    /* the same rule for a solve's statistics */
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.target_patches = 36}));
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_reference_build(s, NULL, 0, &ref));
    const size_t n = lrr_reference_size(ref);
    float *B = calloc(3 * n, sizeof(float));
    assert_non_null(B);
    unsigned char st[sizeof(lrr_reference_stats) + 16];
    memset(st, 0xAB, sizeof st);
    LRR_CHECK(ctx, lrr_reference_solve(ref, LRR_METHOD_DIRECT, 0, 0, lrr_reference_emission(ref),
                                       B, (lrr_reference_stats *)(void *)st, sizeof(size_t)));
    size_t iterations;
    memcpy(&iterations, st, sizeof iterations);
    assert_int_equal(iterations, 1);
    for (size_t i = sizeof(size_t); i < sizeof st; i++)
        assert_int_equal(st[i], 0xAB);
    free(B);
    lrr_reference_destroy(ref);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_option_sizes),
        cmocka_unit_test(test_defaults_equal_null),
        cmocka_unit_test(test_info_sizes),
        cmocka_unit_test(test_first_sizes),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
