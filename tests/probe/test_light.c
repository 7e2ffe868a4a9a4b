/* lrr_probe_direct_light: the cosine law on an open plane, the shadow of an occluder, errors. */
#include "testutil.h"

/* E is rho x rgb x cos in floats: 2 roundings, k = 2 (TU_TOL_FLT(2, 2)), one float
 * epsilon absolute below the horizon, where cos of the float direction is not exactly 0;
 * a normal or a normalised direction takes 5 roundings, k = 2 (FLOAT_TOL). */
#define FLOAT_TOL TU_TOL_FLT(2, 5)

#define PI 3.14159265358979323846

static const float RHO[3] = {0.5f, 0.25f, 0.75f};
static const float RGB[3] = {2.0f, 3.0f, 4.0f};

/* The unit quad [0,1]² in x,z at y = 0 facing +y, plus (occluder) a square
 * [0.3,0.6]² at y = 0.5 facing down; subdivided into small subpatches. */
static lrr_operator *make_operator(lrr_context *ctx, int occluder)
{
    const double a[3] = {0, 0, 0}, b[3] = {0, 0, 1}, c[3] = {1, 0, 1}, d[3] = {1, 0, 0};
    const double e[3] = {0.3, 0.5, 0.3}, f[3] = {0.6, 0.5, 0.3}, g[3] = {0.6, 0.5, 0.6},
                 h[3] = {0.3, 0.5, 0.6};
    size_t nt = occluder ? 4 : 2;
    float v[36], rho[12], em[12] = {0};
    tu_quad(v, a, b, c, d);
    tu_quad(v + 18, e, f, g, h);
    for (size_t t = 0; t < nt; t++)
        for (int k = 0; k < 3; k++)
            rho[3 * t + k] = RHO[k];
    lrr_scene *scene;
    LRR_CHECK(ctx, lrr_scene_create(ctx, nt, v, rho, em, "test", &scene));
    lrr_subdivision sd = {.max_patch_area = 0.01, .target_patches = 0, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(scene, &sd));
    lrr_build_options bo = {.hemicube_resolution = 8};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(scene, &bo, &op));
    lrr_scene_destroy(scene);
    return op;
}

static void test_cosine_law(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = make_operator(ctx, 0);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_true(oi.n >= 100);
    const float *nr = lrr_operator_normal(op);
    float *E = calloc(3 * oi.n, sizeof(float));
    const double elevation[] = {90, 60, 30, -10};
    for (size_t t = 0; t < 4; t++) {
        double el = elevation[t] * PI / 180;
        lrr_light L = {{(float)cos(el), (float)sin(el), 0.0f}, {RGB[0], RGB[1], RGB[2]}};
        LRR_CHECK(ctx, lrr_probe_direct_light(op, &L, 1, E));
        for (size_t i = 0; i < oi.n; i++) {
            ASSERT_NEAR(nr[3 * i + 1], 1.0, FLOAT_TOL, "normal %zu", i);
            double cosine = fmax(0.0, sin(el));
            for (int c = 0; c < 3; c++) {
                double want = (double)RHO[c] * RGB[c] * cosine;
                ASSERT_NEAR(E[3 * i + c], want,
                            TU_TOL_FLT(2, 2) * (want + 1e-30) + TU_TOL_FLT(1, 1) * (t == 3),
                            "elevation %g subpatch %zu channel %d", elevation[t], i, c);
                if (t == 3)
                    assert_true(E[3 * i + c] == 0.0f);
            }
        }
    }
    free(E);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void test_shadow(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = make_operator(ctx, 1);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const float *ce = lrr_operator_centre(op);
    float *E = calloc(3 * oi.n, sizeof(float));
    lrr_light L = {{0.0f, 1.0f, 0.0f}, {RGB[0], RGB[1], RGB[2]}};
    LRR_CHECK(ctx, lrr_probe_direct_light(op, &L, 1, E));
    size_t shadowed = 0, lit = 0, occluder = 0;
    for (size_t i = 0; i < oi.n; i++) {
        const float *x = ce + 3 * i;
        if (x[1] > 0.25f) { /* the occluder faces down: no direct light */
            occluder++;
            for (int c = 0; c < 3; c++)
                assert_true(E[3 * i + c] == 0.0f);
            continue;
        }
        int under = x[0] > 0.3f && x[0] < 0.6f && x[2] > 0.3f && x[2] < 0.6f;
        if (under)
            shadowed++;
        else
            lit++;
        for (int c = 0; c < 3; c++) {
            double want = under ? 0.0 : (double)RHO[c] * RGB[c];
            ASSERT_NEAR(E[3 * i + c], want, TU_TOL_FLT(2, 2) * want,
                        "subpatch %zu (%g, %g) channel %d", i, x[0], x[2], c);
        }
    }
    assert_true(occluder > 0);
    assert_true(shadowed > 0);
    assert_true(lit > shadowed);
    /* the light at 45° towards +x: the shadow moves by 0.5 in x */
    float s = (float)sqrt(0.5);
    lrr_light L45 = {{s, s, 0.0f}, {RGB[0], RGB[1], RGB[2]}};
    LRR_CHECK(ctx, lrr_probe_direct_light(op, &L45, 1, E));
    size_t shadowed45 = 0;
    for (size_t i = 0; i < oi.n; i++) {
        const float *x = ce + 3 * i;
        if (x[1] > 0.25f)
            continue;
        int under = x[0] > -0.2f && x[0] < 0.1f && x[2] > 0.3f && x[2] < 0.6f;
        shadowed45 += under;
        double want = under ? 0.0 : (double)RHO[0] * RGB[0] * s;
        ASSERT_NEAR(E[3 * i], want, FLOAT_TOL * want, "45 degrees: subpatch %zu", i);
    }
    assert_true(shadowed45 > 0);
    free(E);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = make_operator(ctx, 0);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *E = malloc(3 * oi.n * sizeof(float));
    for (size_t i = 0; i < 3 * oi.n; i++)
        E[i] = 7.0f;
    LRR_CHECK(ctx, lrr_probe_direct_light(op, NULL, 0, E));
    for (size_t i = 0; i < 3 * oi.n; i++)
        assert_true(E[i] == 0.0f);
    assert_int_equal(lrr_probe_direct_light(op, NULL, 1, E), LRR_ERR_INVALID_ARG);
    lrr_light bad = {{NAN, 1.0f, 0.0f}, {1.0f, 1.0f, 1.0f}};
    assert_int_equal(lrr_probe_direct_light(op, &bad, 1, E), LRR_ERR_INVALID_ARG);
    lrr_light zero = {{0.0f, 0.0f, 0.0f}, {1.0f, 1.0f, 1.0f}};
    assert_int_equal(lrr_probe_direct_light(op, &zero, 1, E), LRR_ERR_INVALID_ARG);
    lrr_light neg = {{0.0f, 1.0f, 0.0f}, {1.0f, -1.0f, 1.0f}};
    assert_int_equal(lrr_probe_direct_light(op, &neg, 1, E), LRR_ERR_INVALID_ARG);
    char msg[512];
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
    assert_non_null(strstr(msg, "lrr_probe_direct_light"));
    /* a non-unit direction is normalised */
    lrr_light big = {{0.0f, 5.0f, 0.0f}, {1.0f, 1.0f, 1.0f}};
    LRR_CHECK(ctx, lrr_probe_direct_light(op, &big, 1, E));
    ASSERT_NEAR(E[0], RHO[0], FLOAT_TOL, "normalised direction");
    free(E);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cosine_law),
        cmocka_unit_test(test_shadow),
        cmocka_unit_test(test_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
