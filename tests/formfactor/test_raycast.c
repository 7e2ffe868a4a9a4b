/* Ray-cast hemicubes (lib/formfactor/raycast.c) against the rasteriser (same pixels, frames
 * and rotations), conservation in a closed room, a closed form, back faces and the option. */
#include "testutil.h"
#include "formfactor/formfactor.h"
#include "formfactor/hemicube_private.h"
#include "operator/operator.h"
#include "closed_forms.h"

/* OpenCL against the CPU: the device rounds the same float terms in another order;
 * 9 float roundings of the largest value (k = 1, n = 9). */
#define DEVICE_TOL TU_TOL_FLT(1, 9)

static lrr_operator *build_receiver(lrr_context *ctx, const lrr_scene *s, unsigned R,
                                    int method, int threads, int receiver)
{
    lrr_build_options o = lrr_build_options_defaults();
    o.hemicube_resolution = R;
    o.seed = 3;
    o.threads = threads;
    o.formfactor_method = method;
    o.receiver_sampling = receiver;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
    return op;
}

/* Rays from the receivers' centres, as the rasteriser looks: the two methods' like. */
static lrr_operator *build_scene(lrr_context *ctx, const lrr_scene *s, unsigned R, int method,
                                 int threads)
{
    return build_receiver(ctx, s, R, method, threads, LRR_RECEIVER_CENTRE);
}

/* A scene of ntri triangles (reflectance 0.5, no emission) subdivided as asked. */
static lrr_scene *make_scene(lrr_context *ctx, size_t ntri, const float *v, double max_area,
                             unsigned levels)
{
    float *rho = calloc(ntri * 3, sizeof(float)), *em = calloc(ntri * 3, sizeof(float));
    for (size_t i = 0; i < ntri * 3; i++)
        rho[i] = 0.5f;
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, ntri, v, rho, em, "test", &s));
    lrr_subdivision sd = {.max_patch_area = max_area, .levels = levels};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    free(rho);
    free(em);
    return s;
}

static double rel_l2(const float *a, const float *b, size_t len)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < len; i++) {
        num += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
        den += (double)b[i] * b[i];
    }
    return sqrt(num / den);
}

/* The same pixels give the same rows up to the pixels on triangle edges (each method's own
 * watertight tie rule) and float ray origins; the method is recorded. */
static void test_cornell_agrees(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sd = {.target_patches = 60, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_operator *ras = build_scene(ctx, s, 128, LRR_FORMFACTOR_RASTER, 0);
    lrr_operator *ray = build_scene(ctx, s, 128, LRR_FORMFACTOR_RAYCAST, 0);
    double e = rel_l2(ray->fbar, ras->fbar, ras->n * ras->k);
    print_message("Cornell n = %zu, k = %zu, R = 128: raycast vs raster relative L2 %.3e\n",
                  ras->n, ras->k, e);
    assert_true(e < 2e-3);
    assert_true(e > 0); /* a different method really ran */
    lrr_operator_info info;
    lrr_operator_get_info(ray, &info, sizeof info);
    assert_int_equal(info.formfactor_method, LRR_FORMFACTOR_RAYCAST);
    lrr_operator_get_info(ras, &info, sizeof info);
    assert_int_equal(info.formfactor_method, LRR_FORMFACTOR_RASTER);
    /* same seed, any thread count: bit-identical */
    lrr_operator *ray1 = build_scene(ctx, s, 128, LRR_FORMFACTOR_RAYCAST, 1);
    assert_memory_equal(ray->fbar, ray1->fbar, ray->n * ray->k * sizeof(float));
    lrr_operator_destroy(ray1);
    lrr_operator_destroy(ray);
    lrr_operator_destroy(ras);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* No ray leaks out of a closed room through a shared edge: every row sums to 1 (an empty
 * box; and in the closed Cornell box every row the rasteriser finds closed, i.e. all but
 * the floor under the blocks, which sees only their insides). */
static double worst_row_sum(const lrr_operator *op, const lrr_operator *mask)
{
    double worst = 0;
    for (size_t i = 0; i < op->n; i++) {
        double sum = 0, msum = 0;
        for (size_t p = 0; p < op->k; p++) {
            sum += op->fbar[i * op->k + p];
            msum += mask ? mask->fbar[i * op->k + p] : 1;
        }
        if (msum > 0)
            worst = fmax(worst, fabs(sum * (double)op->d - 1));
    }
    return worst;
}

static void test_closed_rows_sum_to_one(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108];
    tu_box_inward(v, 1, 1.5, 2);
    lrr_scene *s = make_scene(ctx, 12, v, 0.25, 1);
    for (int area = 0; area < 2; area++) { /* rays from the centres, and from the areas */
        lrr_operator *op = build_receiver(ctx, s, 64, LRR_FORMFACTOR_RAYCAST, 0,
                                          area ? LRR_RECEIVER_AREA : LRR_RECEIVER_CENTRE);
        double worst = worst_row_sum(op, NULL);
        print_message("box n = %zu, %s: worst |row sum - 1| = %.2e\n", op->n,
                      area ? "area" : "centre", worst);
        assert_true(worst <= 1e-5);
        lrr_operator_destroy(op);
    }
    lrr_scene_destroy(s);

    LRR_CHECK(ctx, lrr_scene_cornell_box(ctx, 1, &s));
    lrr_subdivision sd = {.target_patches = 60, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_operator *op = build_scene(ctx, s, 64, LRR_FORMFACTOR_RAYCAST, 0);
    lrr_operator *ras = build_scene(ctx, s, 64, LRR_FORMFACTOR_RASTER, 0);
    double worst = worst_row_sum(op, ras);
    print_message("closed Cornell n = %zu: worst |row sum - 1| = %.2e (raster %.2e)\n", op->n,
                  worst, worst_row_sum(ras, ras));
    assert_true(worst <= 1e-5);
    lrr_operator_destroy(ras);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Parallel rectangles: the closed form within 1% and within 2e-3 of the rasteriser. */
static void test_parallel_closed_form(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const double par[][3] = {{1, 1, 1}, {1, 1.5, 0.5}, {2, 1, 1.5}};
    for (size_t i = 0; i < 3; i++) {
        double a = par[i][0], b = par[i][1], c = par[i][2];
        float v[36];
        const double p0[3] = {0, 0, 0}, p1[3] = {a, 0, 0}, p2[3] = {a, b, 0}, p3[3] = {0, b, 0};
        const double q0[3] = {0, 0, c}, q1[3] = {0, b, c}, q2[3] = {a, b, c}, q3[3] = {a, 0, c};
        tu_quad(v, p0, p1, p2, p3);
        tu_quad(v + 18, q0, q1, q2, q3);
        lrr_scene *s = make_scene(ctx, 4, v, a * b / 16, 2);
        lrr_operator *ray = build_scene(ctx, s, 128, LRR_FORMFACTOR_RAYCAST, 0);
        lrr_operator *ras = build_scene(ctx, s, 128, LRR_FORMFACTOR_RASTER, 0);
        double ref = parallel_closed_form(a / c, b / c);
        double Fy = area_average(ray, 2), Fr = area_average(ras, 2);
        print_message("parallel %g×%g at %g: raycast %.6f (%+.2e), raster %.6f (%+.2e)\n", a,
                      b, c, Fy, Fy / ref - 1, Fr, Fr / ref - 1);
        ASSERT_NEAR(Fy, ref, 0.01 * ref, "parallel %g×%g at %g\n", a, b, c);
        ASSERT_NEAR(Fy, Fr, 2e-3 * ref, "raycast vs raster, parallel %g×%g at %g\n", a, b, c);
        lrr_operator_destroy(ray);
        lrr_operator_destroy(ras);
        lrr_scene_destroy(s);
    }
    lrr_context_destroy(ctx);
}

/* Each receiver one whole triangle of a unit square under a parallel unit square at 0.5:
 * from the centres the rows are the point form factors of two points, 22% above the
 * area-averaged closed form; sampled over the receivers' areas they are that closed form to
 * the sampling noise (R 128: 12,288 rays a receiver, 1%). */
static void test_area_sampling_closed_form(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[36];
    const double p0[3] = {0, 0, 0}, p1[3] = {1, 0, 0}, p2[3] = {1, 1, 0}, p3[3] = {0, 1, 0};
    const double q0[3] = {0, 0, .5}, q1[3] = {0, 1, .5}, q2[3] = {1, 1, .5}, q3[3] = {1, 0, .5};
    tu_quad(v, p0, p1, p2, p3);
    tu_quad(v + 18, q0, q1, q2, q3);
    lrr_scene *s = make_scene(ctx, 4, v, 1, 0); /* one subpatch per triangle */
    const double ref = parallel_closed_form(2, 2);
    double F[2];
    for (int area = 0; area < 2; area++) {
        lrr_operator *op = build_receiver(ctx, s, 128, LRR_FORMFACTOR_RAYCAST, 0,
                                          area ? LRR_RECEIVER_AREA : LRR_RECEIVER_CENTRE);
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        assert_int_equal(oi.receiver_sampling, area ? LRR_RECEIVER_AREA : LRR_RECEIVER_CENTRE);
        F[area] = area_average(op, 2);
        print_message("unit squares at 0.5, two receivers: %s %.5f, closed form %.5f (%+.2e)\n",
                      area ? "area" : "centre", F[area], ref, F[area] / ref - 1);
        lrr_operator_destroy(op);
    }
    ASSERT_NEAR(F[1], ref, 0.01 * ref, "area-sampled receivers\n");
    assert_true(fabs(F[0] / ref - 1) > 0.05); /* the centres see something else */
    /* AUTO samples the areas where rays are cast; AREA with the rasteriser is refused */
    lrr_build_options o = lrr_build_options_defaults();
    o.hemicube_resolution = 16;
    o.formfactor_method = LRR_FORMFACTOR_RASTER;
    o.receiver_sampling = LRR_RECEIVER_AREA;
    lrr_operator *op = NULL;
    assert_int_equal(lrr_operator_build(s, &o, &op), LRR_ERR_INVALID_ARG);
    o.receiver_sampling = 7;
    o.formfactor_method = LRR_FORMFACTOR_AUTO;
    assert_int_equal(lrr_operator_build(s, &o, &op), LRR_ERR_INVALID_ARG);
    o.receiver_sampling = LRR_RECEIVER_AREA; /* casts rays though 4 triangles are few */
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    assert_int_equal(oi.formfactor_method, LRR_FORMFACTOR_RAYCAST);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* A receiver square (z = 0, facing +z) under the back of an equal square (z = 1, facing +z)
 * that hides a third (z = 2, facing -z): the receiver's rows are zero; without the middle
 * square the top one is seen (F = 0.0686 at distance 2: it was blocked, not missed). */
static void test_back_faces(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[54];
    const double r0[3] = {0, 0, 0}, r1[3] = {1, 0, 0}, r2[3] = {1, 1, 0}, r3[3] = {0, 1, 0};
    const double m0[3] = {0, 0, 1}, m1[3] = {1, 0, 1}, m2[3] = {1, 1, 1}, m3[3] = {0, 1, 1};
    const double t0[3] = {0, 0, 2}, t1[3] = {0, 1, 2}, t2[3] = {1, 1, 2}, t3[3] = {1, 0, 2};
    tu_quad(v, r0, r1, r2, r3);
    tu_quad(v + 18, t0, t1, t2, t3);
    tu_quad(v + 36, m0, m1, m2, m3);
    for (int with_middle = 0; with_middle < 2; with_middle++) {
        for (int method = LRR_FORMFACTOR_RASTER; method <= LRR_FORMFACTOR_RAYCAST; method++) {
            lrr_scene *s = make_scene(ctx, with_middle ? 6 : 4, v, 1.0 / 16, 1);
            lrr_operator *op = build_scene(ctx, s, 64, method, 0);
            size_t k1 = op->geom.patch0[2], k2 = op->geom.patch0[4];
            double top = 0, middle = 0;
            for (size_t i = 0; i < k1 * op->d; i++)
                for (size_t p = k1; p < op->k; p++) {
                    if (p < k2)
                        top += op->fbar[i * op->k + p];
                    else
                        middle += op->fbar[i * op->k + p];
                }
            top /= (double)k1; /* mean over the receiver's subpatches of F·(1/d)·d */
            print_message("%s, middle %s: receiver sees top %.5f, middle %.5f\n",
                          method == LRR_FORMFACTOR_RAYCAST ? "raycast" : "raster",
                          with_middle ? "present" : "absent", top, middle);
            if (with_middle) {
                assert_true(top == 0);
                assert_true(middle == 0);
            } else {
                ASSERT_NEAR(top, parallel_closed_form(0.5, 0.5), 0.01, "unoccluded top\n");
            }
            lrr_operator_destroy(op);
            lrr_scene_destroy(s);
        }
    }
    lrr_context_destroy(ctx);
}

/* The OpenCL integration takes the ray caster's item buffers as it takes the rasteriser's:
 * the same F̄ to rounding (skipped without an OpenCL device). */
static void test_device_integration(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sd = {.target_patches = 30, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    /* area sampling: the device integrates the item buffers of the CPU's own rays */
    lrr_operator *cpu = build_receiver(ctx, s, 32, LRR_FORMFACTOR_RAYCAST, 0,
                                       LRR_RECEIVER_AREA), *dev = NULL;
    lrr_build_options o = lrr_build_options_defaults();
    o.hemicube_resolution = 32;
    o.seed = 3;
    o.formfactor_method = LRR_FORMFACTOR_RAYCAST;
    o.receiver_sampling = LRR_RECEIVER_AREA;
    o.backend = LRR_BACKEND_OPENCL;
    lrr_status st = lrr_operator_build(s, &o, &dev);
    if (st == LRR_ERR_UNSUPPORTED) {
        print_message("no OpenCL device: device integration not checked\n");
    } else {
        LRR_CHECK(ctx, st);
        LRR_CHECK(ctx, lrr_operator_set_layout(dev, LRR_LAYOUT_ROWS)); /* read as rows below */
        double worst = 0;
        for (size_t j = 0; j < cpu->n * cpu->k; j++)
            worst = fmax(worst, fabs((double)cpu->fbar[j] - dev->fbar[j]));
        print_message("raycast: max |F̄_cpu - F̄_cl| = %.3g\n", worst);
        assert_true(worst <= DEVICE_TOL);
    }
    lrr_operator_destroy(dev);
    lrr_operator_destroy(cpu);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* AUTO: raster on a small scene, raycast above the crossover; unknown values refused. */
static void test_method_option(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sd = {.target_patches = 30, .levels = 0};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_operator *op = build_scene(ctx, s, 16, LRR_FORMFACTOR_AUTO, 0);
    lrr_operator_info info;
    lrr_operator_get_info(op, &info, sizeof info);
    assert_int_equal(info.formfactor_method, LRR_FORMFACTOR_RASTER);
    lrr_operator_destroy(op);
    /* the crossover R²/4 triangles, at the default R = 128 and at R = 64 */
    lrr__geometry big = {0};
    lrr_build_options o = lrr_build_options_defaults();
    const unsigned res[] = {128, 64};
    for (int r = 0; r < 2; r++) {
        int m = -1;
        o.hemicube_resolution = res[r];
        big.n_tri = (size_t)res[r] * res[r] / LRR__RAYCAST_PIXELS_PER_TRIANGLE + 1;
        assert_int_equal(lrr__formfactor_method(NULL, &big, &o, &m), LRR_OK);
        assert_int_equal(m, LRR_FORMFACTOR_RAYCAST);
        big.n_tri--;
        assert_int_equal(lrr__formfactor_method(NULL, &big, &o, &m), LRR_OK);
        assert_int_equal(m, LRR_FORMFACTOR_RASTER);
        o.formfactor_method = LRR_FORMFACTOR_RAYCAST; /* an explicit choice is kept */
        assert_int_equal(lrr__formfactor_method(NULL, &big, &o, &m), LRR_OK);
        assert_int_equal(m, LRR_FORMFACTOR_RAYCAST);
        o.formfactor_method = LRR_FORMFACTOR_AUTO;
    }
    o.hemicube_resolution = 16;
    const int bad[] = {-1, 3, 301};
    for (size_t b = 0; b < 3; b++) {
        o.formfactor_method = bad[b];
        op = NULL;
        assert_int_equal(lrr_operator_build(s, &o, &op), LRR_ERR_INVALID_ARG);
        assert_null(op);
        char msg[512];
        lrr_context_last_error(ctx, msg, sizeof msg);
        assert_non_null(strstr(msg, "formfactor_method"));
        lrr_reference *ref = NULL;
        assert_int_equal(lrr_reference_build(s, &o, 0, &ref), LRR_ERR_INVALID_ARG);
        assert_null(ref);
    }
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cornell_agrees),
        cmocka_unit_test(test_closed_rows_sum_to_one),
        cmocka_unit_test(test_parallel_closed_form),
        cmocka_unit_test(test_back_faces),
        cmocka_unit_test(test_area_sampling_closed_form),
        cmocka_unit_test(test_device_integration),
        cmocka_unit_test(test_method_option),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
