/* The real scenes shipped in data/scenes/ (data/README.md): the FZK-Haus IFC model
 * tessellated by assimp, and the Stanford bunny in a closed room. Their counts are those of
 * the SOURCE.md that came with them: a change in the importer (assimp's OBJ reader, the
 * zero-area filter, the MTL mapping) that drops, adds or re-materials triangles shows here. */
#include "testutil.h"

typedef struct expect {
    const char *file;
    size_t triangles, skipped, emitters;
    double area;               /* lrr info's total area (kept triangles) */
} expect;

static void check_scene(lrr_context *ctx, const expect *e)
{
    char path[512];
    snprintf(path, sizeof path, "%s/scenes/%s", LRR_DATA_DIR, e->file);
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_load(ctx, path, &s));
    lrr_subdivision sd = {.levels = 0}; /* one subpatch per triangle */
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_scene_info info;
    lrr_scene_get_info(s, &info, sizeof info);
    print_message("%s: %zu triangles (+%zu zero-area skipped), %zu emitters, area %.6f\n",
                  e->file, info.triangles, info.skipped, info.emitters, info.area);
    assert_int_equal(info.triangles, e->triangles);
    assert_int_equal(info.skipped, e->skipped);
    assert_int_equal(info.emitters, e->emitters);
    /* not rounding: the expected areas are printed values (%.6f, 7 digits or more) */
    ASSERT_NEAR(info.area, e->area, 1e-6 * e->area, "%s area\n", e->file);
    assert_int_equal(info.subpatches, info.triangles);
    float *rho = calloc(3 * info.triangles, sizeof(float));
    float *em = calloc(3 * info.triangles, sizeof(float));
    assert_non_null(rho);
    assert_non_null(em);
    LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, rho, em));
    size_t lit = 0;
    float rho_max = 0;
    for (size_t t = 0; t < info.triangles; t++) {
        for (int c = 0; c < 3; c++) {
            assert_true(rho[3 * t + c] >= 0 && rho[3 * t + c] < 1);
            rho_max = rho[3 * t + c] > rho_max ? rho[3 * t + c] : rho_max;
        }
        lit += em[3 * t] > 0 || em[3 * t + 1] > 0 || em[3 * t + 2] > 0;
    }
    print_message("%s: max reflectance %.3f, %zu emitting triangles\n", e->file, rho_max, lit);
    assert_int_equal(lit, e->emitters);
    free(rho);
    free(em);
    lrr_scene_destroy(s);
}

static void test_fzk_haus(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    /* SOURCE.md: 35,906 assimp triangles + 4 of the added lights = 35,910 written, 3 of
     * them zero-area; lrr info: area 2203.86186, 4 emitters */
    const expect e = {"fzk_haus.obj", 35907, 3, 4, 2203.86186};
    check_scene(ctx, &e);
    lrr_context_destroy(ctx);
}

static void test_bunny_room(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    /* SOURCE.md: bunny 69,451 + room 3,072 + light 2 = 72,525, none zero-area; area
     * 1.75962897 */
    const expect e = {"bunny_room.obj", 72525, 0, 2, 1.75962897};
    check_scene(ctx, &e);
    lrr_context_destroy(ctx);
}

int main(void)
{
    TU_REQUIRE_PROGRAM("test_real", "assimp");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_fzk_haus),
        cmocka_unit_test(test_bunny_room),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
