/* The scene doctor (lib/scene/check.cpp, lrr_scene_check): degenerates, intersections,
 * coplanar overlaps (z-fighting vs contact), open edges, inconsistent orientation and open
 * sheets modelled upside down. */
#include <unistd.h> /* getpid, used by testutil.h */

#include "testutil.h"
#include "core/internal.h" /* lrr__context_fail_after */

static lrr_check_report *check(lrr_context *ctx, const char *name)
{
    lrr_check_report *r = NULL;
    LRR_CHECK(ctx, lrr_scene_check(ctx, name, &r));
    assert_non_null(r);
    return r;
}

static size_t count_kind(const lrr_check_report *r, lrr_check_kind k)
{
    size_t n = 0;
    for (size_t i = 0; i < r->n_findings; i++)
        n += r->findings[i].kind == k;
    return n;
}

static void test_closed_box_clean(void **state)
{
    lrr_check_report *r = check(*state, LRR_TEST_DATA "/check_box.obj");
    assert_int_equal(r->triangles, 12);
    assert_int_equal(r->degenerate, 0);
    assert_int_equal(r->intersecting_pairs, 0);
    assert_int_equal(r->coplanar_overlaps, 0);
    assert_int_equal(r->contacts, 0);
    assert_int_equal(r->open_edges, 0);
    assert_int_equal(r->inconsistent_components, 0);
    assert_int_equal(r->n_findings, 0);
    lrr_check_report_destroy(r);
}

static void test_flipped_face_named(void **state)
{
    lrr_check_report *r = check(*state, LRR_TEST_DATA "/check_box_flipped.obj");
    assert_int_equal(r->inconsistent_components, 1);
    assert_int_equal(r->open_edges, 0);
    assert_int_equal(r->intersecting_pairs, 0);
    assert_int_equal(count_kind(r, LRR_CHECK_ORIENTATION), 1);
    assert_int_equal(r->findings[0].kind, LRR_CHECK_ORIENTATION);
    assert_int_equal(r->findings[0].face_a, 5);
    for (size_t t = 0; t < r->triangles; t++)
        assert_int_equal(r->fix[t], r->face[t] == 5 ? 2 : 0);
    lrr_check_report_destroy(r);
}

static void test_crossing_pair(void **state)
{
    lrr_check_report *r = check(*state, LRR_TEST_DATA "/check_crossing.obj");
    assert_int_equal(r->intersecting_pairs, 1);
    assert_int_equal(r->coplanar_overlaps, 0);
    assert_int_equal(count_kind(r, LRR_CHECK_INTERSECT), 1);
    for (size_t i = 0; i < r->n_findings; i++)
        if (r->findings[i].kind == LRR_CHECK_INTERSECT) {
            assert_int_equal(r->findings[i].face_a, 0);
            assert_int_equal(r->findings[i].face_b, 1);
        }
    lrr_check_report_destroy(r);
}

static void test_coplanar_overlap(void **state)
{
    lrr_check_report *r = check(*state, LRR_TEST_DATA "/check_coplanar.obj");
    assert_int_equal(r->coplanar_overlaps, 1);
    assert_int_equal(r->contacts, 0);
    assert_int_equal(r->intersecting_pairs, 0);
    assert_int_equal(r->findings[0].kind, LRR_CHECK_ZFIGHT);
    assert_int_equal(r->findings[0].face_a, 0);
    assert_int_equal(r->findings[0].face_b, 1);
    lrr_check_report_destroy(r);
}

static void test_degenerate_named(void **state)
{
    lrr_check_report *r = check(*state, LRR_TEST_DATA "/degenerate.obj");
    assert_int_equal(r->triangles, 2);
    assert_int_equal(r->degenerate, 1);
    assert_int_equal(r->findings[0].kind, LRR_CHECK_DEGENERATE);
    assert_int_equal(r->findings[0].face_a, 1);
    assert_int_equal(r->fix[1], 1);
    assert_int_equal(r->fix[0], 0);
    lrr_check_report_destroy(r);
}

/* The blocks stand on the floor: their side faces touch it (not an intersection) and their
 * bottoms lie on it facing down (contacts, warnings); the open front gives open edges. */
static void test_cornell_contacts_only(void **state)
{
    lrr_check_report *r = check(*state, "cornell");
    assert_int_equal(r->triangles, 36);
    assert_int_equal(r->degenerate, 0);
    assert_int_equal(r->intersecting_pairs, 0);
    assert_int_equal(r->coplanar_overlaps, 0);
    assert_int_equal(r->inconsistent_components, 0);
    assert_int_equal(r->contacts, 4);
    assert_true(r->open_edges > 0);
    lrr_check_report_destroy(r);
}

static void test_missing_file(void **state)
{
    lrr_check_report *r = NULL;
    assert_int_not_equal(lrr_scene_check(*state, "no-such-scene", &r), LRR_OK);
    assert_null(r);
}

/* lrr_check_report_names (what lrr check --fix writes): office.obj's 'g'/'usemtl' blocks in
 * file order, each triangle with its block's group and material name; a built-in scene and
 * a scene read without it have none; every allocation failing in turn gives LRR_ERR_NOMEM
 * and leaves no names (nor leaks: the sanitizer pass). */
static void test_report_names(void **state)
{
    static const char *const blocks[][3] = {
        /* group, material, triangles: counted from data/office.obj's f lines per block */
        {"floor", "floor", "2"},         {"ceiling", "ceiling", "2"}, {"right_wall", "wall_blue", "2"},
        {"walls", "wall", "6"},          {"light", "light", "2"},     {"table_top", "wood", "12"},
        {"table_legs", "wood", "48"},    {"box", "red", "12"},        {"cabinet", "grey", "12"},
        {"chair", "green", "24"}};
    lrr_context *ctx = *state;
    lrr_check_report *r = check(ctx, LRR_DATA_DIR "/office.obj");
    assert_null(r->material);
    assert_null(r->material_names);
    LRR_CHECK(ctx, lrr_check_report_names(ctx, LRR_DATA_DIR "/office.obj", r));
    assert_non_null(r->material);
    assert_non_null(r->group);
    size_t t = 0;
    for (size_t b = 0; b < sizeof blocks / sizeof blocks[0]; b++)
        for (int k = 0; k < atoi(blocks[b][2]); k++, t++) {
            assert_true(r->material[t] < r->n_materials);
            assert_true(r->group[t] < r->n_groups);
            assert_string_equal(r->group_names[r->group[t]], blocks[b][0]);
            assert_string_equal(r->material_names[r->material[t]], blocks[b][1]);
        }
    assert_int_equal(t, r->triangles);
    /* all allocation failures in turn: NOMEM and no names, until the call succeeds */
    unsigned long fail_at = 1;
    for (;; fail_at++) {
        lrr__context_fail_after(ctx, fail_at);
        lrr_status st = lrr_check_report_names(ctx, LRR_DATA_DIR "/office.obj", r);
        lrr__context_fail_after(ctx, 0);
        if (st == LRR_OK)
            break;
        assert_int_equal(st, LRR_ERR_NOMEM);
        assert_null(r->material);
        assert_null(r->group_names);
        assert_true(fail_at < 100);
    }
    assert_true(fail_at > 3);
    assert_string_equal(r->material_names[r->material[0]], "floor");
    lrr_check_report_destroy(r);
    r = check(ctx, "cornell");
    LRR_CHECK(ctx, lrr_check_report_names(ctx, "cornell", r));
    assert_null(r->material);
    assert_null(r->group_names);
    assert_int_equal(r->n_materials, 0);
    lrr_check_report_destroy(r);
}

static int setup(void **state)
{
    lrr_context *ctx = NULL;
    if (lrr_context_create(&ctx) != LRR_OK)
        return -1;
    *state = ctx;
    return 0;
}

static int teardown(void **state)
{
    lrr_context_destroy(*state);
    return 0;
}

/* An open room (walls and ceiling inwards) over a separate floor quad: facing up, nothing is
 * flagged; upside down (its front sees nothing, its back the room's fronts), both floor
 * triangles (10, 11) are named as one sheet, and the room's sheet (whose rays from the front
 * now meet the floor's back too) is not. The built-in scenes have no such sheet (the Cornell
 * box's light quad sees its ceiling's front from behind, but as many fronts from its front). */
static void test_upside_down_sheet(void **state)
{
    lrr_check_report *r = check(*state, LRR_TEST_DATA "/room_floor.obj");
    assert_int_equal(r->open_edges, 8);
    assert_int_equal(r->upside_down_sheets, 0);
    assert_int_equal(count_kind(r, LRR_CHECK_UPSIDE_DOWN), 0);
    lrr_check_report_destroy(r);
    r = check(*state, LRR_TEST_DATA "/room_floor_flipped.obj");
    assert_int_equal(r->open_edges, 8);
    assert_int_equal(r->inconsistent_components, 0);
    assert_int_equal(r->upside_down_sheets, 1);
    assert_int_equal(count_kind(r, LRR_CHECK_UPSIDE_DOWN), 2);
    size_t named = 0;
    for (size_t i = 0; i < r->n_findings; i++)
        if (r->findings[i].kind == LRR_CHECK_UPSIDE_DOWN) {
            assert_true(r->findings[i].face_a == 10 || r->findings[i].face_a == 11);
            assert_int_equal(r->findings[i].face_b, 10);
            named += r->findings[i].face_a;
        }
    assert_int_equal(named, 21);
    for (size_t t = 0; t < r->triangles; t++)
        assert_int_equal(r->fix[t], 0); /* reported, not repaired */
    lrr_check_report_destroy(r);
    const char *builtin[] = {"cornell", "cornell-closed"};
    for (int b = 0; b < 2; b++) {
        r = check(*state, builtin[b]);
        assert_int_equal(r->upside_down_sheets, 0);
        lrr_check_report_destroy(r);
    }
}

int main(void)
{
    TU_REQUIRE_PROGRAM("test_check", "cgal");
    TU_REQUIRE_PROGRAM("test_check", "assimp"); /* the cases are .obj files */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_closed_box_clean, setup, teardown),
        cmocka_unit_test_setup_teardown(test_flipped_face_named, setup, teardown),
        cmocka_unit_test_setup_teardown(test_crossing_pair, setup, teardown),
        cmocka_unit_test_setup_teardown(test_coplanar_overlap, setup, teardown),
        cmocka_unit_test_setup_teardown(test_degenerate_named, setup, teardown),
        cmocka_unit_test_setup_teardown(test_cornell_contacts_only, setup, teardown),
        cmocka_unit_test_setup_teardown(test_missing_file, setup, teardown),
        cmocka_unit_test_setup_teardown(test_upside_down_sheet, setup, teardown),
        cmocka_unit_test_setup_teardown(test_report_names, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
