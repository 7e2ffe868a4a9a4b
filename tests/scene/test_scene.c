/* Scene validation: every bad input returns its error code with a message naming the face;
 * the built-in Cornell box has the published geometry and faces inwards. */
#include "testutil.h"
#include "scene/scene.h"

/* Scene values are floats (positions, normals, areas, rho, E) from a few float
 * operations each (a cross product and its normalisation: 5 roundings), k = 2. */
#define FLOAT_TOL TU_TOL_FLT(2, 5)

static void unit_triangles(float *v, float *rho, float *em, size_t n)
{
    for (size_t t = 0; t < n; t++) {
        const float tri[9] = {(float)t, 0, 0, (float)t + 1, 0, 0, (float)t, 1, 0};
        memcpy(v + 9 * t, tri, sizeof tri);
        for (int c = 0; c < 3; c++) {
            rho[3 * t + c] = 0.5f;
            em[3 * t + c] = 0.0f;
        }
    }
}

/* Expects `st` and a message that contains each of the given fragments. */
static void expect_error(lrr_context *ctx, lrr_status got, lrr_status want, const char *frag1,
                         const char *frag2)
{
    char msg[512];
    lrr_status rec = lrr_context_last_error(ctx, msg, sizeof msg);
    if (got != want)
        fail_msg("got %s, expected %s (%s)", lrr_strerror(got), lrr_strerror(want), msg);
    assert_int_equal(rec, want);
    if (frag1 && !strstr(msg, frag1))
        fail_msg("message '%s' does not name '%s'", msg, frag1);
    if (frag2 && !strstr(msg, frag2))
        fail_msg("message '%s' does not name '%s'", msg, frag2);
}

static void test_bad_input(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    enum { N = 5 };
    float v[9 * N], rho[3 * N], em[3 * N];
    lrr_scene *s = NULL;

    unit_triangles(v, rho, em, N);
    v[9 * 3 + 4] = NAN;
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "nan.obj", &s), LRR_ERR_GEOMETRY,
                 "nan.obj", "face 3");
    assert_null(s);
    unit_triangles(v, rho, em, N);
    v[9 * 2] = INFINITY;
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "inf", &s), LRR_ERR_GEOMETRY,
                 "face 2", "not finite");

    unit_triangles(v, rho, em, N);
    rho[3 * 4 + 1] = 1.0f;
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "rho1", &s), LRR_ERR_MATERIAL,
                 "face 4", "reflectance");
    rho[3 * 4 + 1] = -0.01f;
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "rho-", &s), LRR_ERR_MATERIAL,
                 "face 4", "reflectance");
    rho[3 * 4 + 1] = NAN;
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "rhonan", &s), LRR_ERR_MATERIAL,
                 "face 4", NULL);

    unit_triangles(v, rho, em, N);
    em[3 * 1 + 2] = -1.0f;
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "em", &s), LRR_ERR_MATERIAL,
                 "face 1", "emission");
    em[3 * 1 + 2] = INFINITY;
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "em", &s), LRR_ERR_MATERIAL,
                 "face 1", "emission");

    expect_error(ctx, lrr_scene_create(ctx, 0, v, rho, em, "empty.obj", &s), LRR_ERR_EMPTY,
                 "empty.obj", NULL);

    /* zero-area triangles: skipped and counted */
    unit_triangles(v, rho, em, N);
    memcpy(v + 9 * 1 + 3, v + 9 * 1, 3 * sizeof(float));       /* repeated vertex */
    for (int j = 0; j < 3; j++)                                   /* collinear vertices */
        v[9 * 2 + 6 + j] = 0.5f * (v[9 * 2 + j] + v[9 * 2 + 3 + j]);
    LRR_CHECK(ctx, lrr_scene_create(ctx, N, v, rho, em, "deg", &s));
    lrr_scene_info info;
    lrr_scene_get_info(s, &info, sizeof info);
    assert_int_equal(info.triangles, 3);
    assert_int_equal(info.skipped, 2);
    lrr_scene_destroy(s);
    /* nothing left */
    for (int t = 0; t < N; t++)
        memcpy(v + 9 * t + 3, v + 9 * t, 3 * sizeof(float));
    expect_error(ctx, lrr_scene_create(ctx, N, v, rho, em, "alldeg", &s), LRR_ERR_GEOMETRY,
                 "alldeg", "zero area");

    expect_error(ctx, lrr_scene_builtin(ctx, "kornell", &s), LRR_ERR_INVALID_ARG, "kornell",
                 "cornell");
    lrr_context_destroy(ctx);
}

static void test_cornell_box(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    for (int closed = 0; closed <= 1; closed++) {
        lrr_scene *s;
        LRR_CHECK(ctx, lrr_scene_builtin(ctx, closed ? "cornell-closed" : "cornell", &s));
        lrr_scene_info info;
        lrr_scene_get_info(s, &info, sizeof info);
        assert_int_equal(info.triangles, closed ? 38 : 36);
        assert_int_equal(info.skipped, 0);
        assert_int_equal(info.emitters, 2);
        ASSERT_NEAR(info.bounds_max[1], 548.8, 1e-4, "height\n");
        ASSERT_NEAR(info.bounds_max[2], 559.2, 1e-4, "depth\n");
        lrr_subdivision sd = {0};
        LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
        float c[38 * 3], nrm[38 * 3], area[38], em[38 * 3];
        LRR_CHECK(ctx, lrr_scene_subpatches(s, c, nrm, area, NULL, em));
        double light_area = 0;
        for (size_t t = 0; t < info.triangles; t++) {
            const float *p = c + 3 * t, *nn = nrm + 3 * t;
            if (em[3 * t] > 0) {
                /* the light faces down, just below the ceiling */
                ASSERT_NEAR(nn[1], -1.0, FLOAT_TOL, "light normal\n");
                assert_true(p[1] < 548.8f && p[1] > 548.7f);
                light_area += area[t];
                continue;
            }
            /* room surfaces face the inside of the room: inside is within a step along the
             * normal from the centre; block faces point out of the blocks, into the room too */
            if (p[1] < 1e-3f && nn[1] < -0.99f)
                continue; /* a block's bottom: faces down onto the floor */
            float q[3] = {p[0] + nn[0], p[1] + nn[1], p[2] + nn[2]};
            assert_true(q[0] > -1 && q[0] < 557 && q[1] > -1 && q[1] < 549.8f && q[2] > -1 &&
                        q[2] < 560.2f);
            if (p[1] < 1e-3f && nn[1] > 0.99f)
                continue; /* floor */
            if (p[1] > 548.7f)
                assert_true(nn[1] < -0.99f); /* ceiling */
        }
        ASSERT_NEAR(light_area, 130.0 * 105.0, 1e-2, "light area\n");
        lrr_scene_destroy(s);
    }
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_cornell_box),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
