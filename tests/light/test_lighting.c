/* Moving lights (lib/light/): the inverse-square and cosine laws, the spot cone, a hard
 * shadow's footprint, an area light against the closed-form point-to-rectangle form
 * factor, a point light in a furnace (energy balance), the cache of unchanged lights, a
 * range of receivers against the whole call, and bad lights. */
#include "testutil.h"

/* Direct light in floats (a cosine, a distance, a product: 5 roundings, k = 2), the same
 * light computed another way or two lights summed in another order. */
#define FLOAT_TOL TU_TOL_FLT(2, 5)

#define PI 3.14159265358979323846
static const float RHO[3] = {0.5f, 0.4f, 0.3f};

/* A floor [-s, s]² at y = 0 facing +y, split into about `patches` subpatches; with
 * occluder, a 0.5×0.5 square at height 1 above (−0.25..0.25)², facing down. */
static lrr_operator *floor_op(lrr_context *ctx, double s, size_t patches, int occluder)
{
    float v[36];
    const double a[3] = {-s, 0, -s}, b[3] = {-s, 0, s}, c[3] = {s, 0, s}, d[3] = {s, 0, -s};
    tu_quad(v, a, b, c, d);
    const double e[3] = {-0.25, 1, -0.25}, f[3] = {0.25, 1, -0.25}, g[3] = {0.25, 1, 0.25},
                 h[3] = {-0.25, 1, 0.25};
    tu_quad(v + 18, e, f, g, h);
    const size_t T = occluder ? 4 : 2;
    float rho[12], em[12] = {0};
    for (size_t t = 0; t < T; t++)
        for (int ch = 0; ch < 3; ch++)
            rho[3 * t + ch] = RHO[ch];
    return tu_operator(ctx, T, v, rho, em, patches, 8);
}

static size_t op_n(const lrr_operator *op)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    return oi.n;
}

static lrr_light_source point_at(double x, double y, double z, float I)
{
    lrr_light_source l = {0};
    l.kind = LRR_LIGHT_POINT;
    l.position[0] = (float)x;
    l.position[1] = (float)y;
    l.position[2] = (float)z;
    l.rgb[0] = l.rgb[1] = l.rgb[2] = I;
    return l;
}

/* E = rho · I cos / r² on every floor subpatch (cos = h / r). */
static void test_point_inverse_square(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = floor_op(ctx, 2, 200, 0);
    const size_t n = op_n(op);
    const float *ce = lrr_operator_centre(op);
    float *E = malloc(3 * n * sizeof(float));
    lrr_lighting *lt;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    const double h = 0.7, px = 0.3, pz = -0.4;
    lrr_light_source l = point_at(px, h, pz, 2.0f);
    LRR_CHECK(ctx, lrr_lighting_direct(lt, &l, 1, E));
    assert_int_equal(lrr_lighting_rays(lt), n);
    for (size_t i = 0; i < n; i++) {
        double dx = px - ce[3 * i], dz = pz - ce[3 * i + 2], r2 = dx * dx + dz * dz + h * h;
        double H = 2.0 * h / (r2 * sqrt(r2));
        for (int ch = 0; ch < 3; ch++)
            ASSERT_NEAR(E[3 * i + ch], RHO[ch] * H, 1e-5 * RHO[ch] * H, "subpatch %zu", i);
    }
    /* below the floor: the light is behind every receiver */
    l = point_at(px, -h, pz, 2.0f);
    LRR_CHECK(ctx, lrr_lighting_direct(lt, &l, 1, E));
    for (size_t i = 0; i < 3 * n; i++)
        assert_true(E[i] == 0.0f);
    lrr_lighting_destroy(lt);
    free(E);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* A spot straight down: inside its inner cone the point light's value, outside the cone
 * nothing, in the soft edge between the two and falling with the angle. */
static void test_spot_cone(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = floor_op(ctx, 2, 400, 0);
    const size_t n = op_n(op);
    const float *ce = lrr_operator_centre(op);
    float *E = malloc(3 * n * sizeof(float)), *P = malloc(3 * n * sizeof(float));
    lrr_lighting *lt;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    const double h = 1.0, angle = 40 * PI / 180, soft = 15 * PI / 180;
    lrr_light_source pt = point_at(0, h, 0, 1.0f), spot = pt;
    spot.kind = LRR_LIGHT_SPOT;
    spot.direction[1] = -1;
    spot.cone_angle = (float)angle;
    spot.cone_softness = (float)soft;
    LRR_CHECK(ctx, lrr_lighting_direct(lt, &pt, 1, P));
    LRR_CHECK(ctx, lrr_lighting_direct(lt, &spot, 1, E));
    size_t inner = 0, outer = 0, edge = 0;
    for (size_t i = 0; i < n; i++) {
        double rr = hypot(ce[3 * i], ce[3 * i + 2]), theta = atan2(rr, h);
        if (theta < angle - soft - 1e-4) {
            ASSERT_NEAR(E[3 * i], P[3 * i], FLOAT_TOL * P[3 * i], "inner cone, subpatch %zu", i);
            inner++;
        } else if (theta > angle + 1e-4) {
            assert_true(E[3 * i] == 0.0f);
            outer++;
        } else {
            double x = (angle - theta) / soft, f = x * x * (3 - 2 * x);
            ASSERT_NEAR(E[3 * i], f * P[3 * i], 1e-3 * P[3 * i], "edge, subpatch %zu", i);
            edge++;
        }
    }
    assert_true(inner > 10 && outer > 10 && edge > 10);
    lrr_lighting_destroy(lt);
    free(E);
    free(P);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* A point light at (0, 2, 0) over a 0.5×0.5 occluder at height 1: the shadow is the
 * occluder projected to the floor, (−0.5, 0.5)²; every subpatch centre inside it is dark,
 * every one outside lit. */
static void test_hard_shadow(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = floor_op(ctx, 1.5, 600, 1);
    const size_t n = op_n(op);
    const float *ce = lrr_operator_centre(op);
    float *E = malloc(3 * n * sizeof(float));
    lrr_lighting *lt;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    lrr_light_source l = point_at(0, 2, 0, 1.0f);
    LRR_CHECK(ctx, lrr_lighting_direct(lt, &l, 1, E));
    size_t dark = 0, lit = 0;
    for (size_t i = 0; i < n; i++) {
        if (ce[3 * i + 1] > 0.5f) { /* the occluder faces down, away from the light */
            assert_true(E[3 * i] == 0.0f);
            continue;
        }
        double x = fabs(ce[3 * i]), z = fabs(ce[3 * i + 2]);
        if (x < 0.49 && z < 0.49) {
            assert_true(E[3 * i] == 0.0f);
            dark++;
        } else if (x > 0.51 || z > 0.51) {
            assert_true(E[3 * i] > 0.0f);
            lit++;
        }
    }
    print_message("shadow: %zu dark, %zu lit subpatches\n", dark, lit);
    assert_true(dark > 20 && lit > 100);
    lrr_lighting_destroy(lt);
    free(E);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The form factor from a point to a parallel rectangle a × b at height c, the point under
 * one corner (Howell's catalogue). */
static double corner_form_factor(double a, double b, double c)
{
    double X = a / c, Y = b / c;
    return (X / sqrt(1 + X * X) * atan(Y / sqrt(1 + X * X)) +
            Y / sqrt(1 + Y * Y) * atan(X / sqrt(1 + Y * Y))) / (2 * PI);
}

/* An area light facing down over the floor: H = M · F(x → rectangle), F from the closed
 * form by four corner rectangles (the receiver's foot splits the light into them). */
static void test_area_light(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = floor_op(ctx, 1, 50, 0);
    const size_t n = op_n(op);
    const float *ce = lrr_operator_centre(op);
    float *E = malloc(3 * n * sizeof(float));
    lrr_lighting *lt;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    const double c = 0.8, w = 0.6, d = 0.4; /* light centred over (0.1, 0): x 0.1 ± 0.3 */
    lrr_light_source l = {0};
    l.kind = LRR_LIGHT_AREA;
    l.position[0] = 0.1f;
    l.position[1] = (float)c;
    l.u[0] = (float)w; /* u × v = (0, −w d, 0): emits downwards */
    l.v[2] = (float)d;
    l.rgb[0] = l.rgb[1] = l.rgb[2] = 3.0f;
    l.samples = 1024;
    LRR_CHECK(ctx, lrr_lighting_direct(lt, &l, 1, E));
    assert_int_equal(lrr_lighting_rays(lt), 1024 * n);
    double worst = 0;
    for (size_t i = 0; i < n; i++) {
        double x0 = 0.1 - w / 2 - ce[3 * i], x1 = 0.1 + w / 2 - ce[3 * i],
               z0 = -d / 2 - ce[3 * i + 2], z1 = d / 2 - ce[3 * i + 2];
        /* inclusion–exclusion over signed corner rectangles G(x, z) from the foot */
        const double xs[2] = {x0, x1}, zs[2] = {z0, z1};
        double F = 0;
        for (int p = 0; p < 2; p++)
            for (int q = 0; q < 2; q++) {
                double G = (xs[p] < 0 ? -1 : 1) * (zs[q] < 0 ? -1 : 1) *
                           corner_form_factor(fabs(xs[p]), fabs(zs[q]), c);
                F += (p == q ? 1 : -1) * G;
            }
        double want = RHO[0] * 3.0 * F;
        worst = fmax(worst, fabs(E[3 * i] - want) / want);
    }
    print_message("area light: worst relative error %.2e over %zu receivers\n", worst, n);
    assert_true(worst < 1e-2);
    lrr_lighting_destroy(lt);
    free(E);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* A point light of intensity I inside a closed furnace box (all rho): every watt reaches a
 * wall, Σ A_i H_i = 4π I, and after the solve Σ A_i B_i = Σ A_i E_i / (1 − rho). */
static void test_point_in_furnace(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const float rho[3] = {0.6f, 0.6f, 0.6f};
    lrr_scene *sc = tu_furnace(ctx, 1, 1, 1, rho, 0.0f);
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.target_patches = 1500;
    LRR_CHECK(ctx, lrr_scene_subdivide(sc, &sd));
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 64;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(sc, &bo, &op));
    const size_t n = op_n(op);
    const float *area = lrr_operator_area(op);
    float *E = malloc(3 * n * sizeof(float)), *B = malloc(3 * n * sizeof(float));
    lrr_lighting *lt;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    lrr_light_source l = point_at(0.45, 0.55, 0.5, 1.0f);
    LRR_CHECK(ctx, lrr_lighting_direct(lt, &l, 1, E));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, E, B));
    double pe = 0, pb = 0;
    for (size_t i = 0; i < n; i++) {
        pe += area[i] * E[3 * i];
        pb += area[i] * B[3 * i];
    }
    print_message("furnace: Σ A E = %.5f (4π I ρ = %.5f), Σ A B = %.5f (%.5f)\n", pe,
                  4 * PI * 0.6, pb, pe / 0.4);
    ASSERT_NEAR(pe, 4 * PI * 0.6, 0.01 * 4 * PI * 0.6, "reflected power of the light");
    ASSERT_NEAR(pb, pe / 0.4, 0.01 * pe / 0.4, "energy balance after the solve");
    lrr_solver_destroy(sv);
    lrr_lighting_destroy(lt);
    free(E);
    free(B);
    lrr_operator_destroy(op);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* Two lights; moving the second re-traces only it, and the sum equals each alone. */
static void test_cache(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = floor_op(ctx, 2, 200, 0);
    const size_t n = op_n(op);
    float *E = malloc(3 * n * sizeof(float)), *A = malloc(3 * n * sizeof(float)),
          *Bm = malloc(3 * n * sizeof(float));
    lrr_lighting *lt, *fresh;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    LRR_CHECK(ctx, lrr_lighting_create(op, &fresh));
    lrr_light_source two[2] = {point_at(0, 1, 0, 1.0f), point_at(1, 1, 1, 2.0f)};
    LRR_CHECK(ctx, lrr_lighting_direct(lt, two, 2, E));
    assert_int_equal(lrr_lighting_rays(lt), 2 * n);
    two[1].position[0] = -1.0f;
    LRR_CHECK(ctx, lrr_lighting_direct(lt, two, 2, E));
    assert_int_equal(lrr_lighting_rays(lt), n); /* only the moved light */
    LRR_CHECK(ctx, lrr_lighting_direct(fresh, two, 1, A));
    LRR_CHECK(ctx, lrr_lighting_direct(fresh, two + 1, 1, Bm));
    for (size_t i = 0; i < 3 * n; i++)
        ASSERT_NEAR(E[i], A[i] + Bm[i], FLOAT_TOL * (A[i] + Bm[i]), "entry %zu", i);
    lrr_lighting_destroy(lt);
    lrr_lighting_destroy(fresh);
    free(E);
    free(A);
    free(Bm);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* On an operator whose subpatches are renumbered cluster by cluster, the direct light comes
 * out in its order: mapped back to the scene's order it equals the quadtree operator's. */
static void test_clustered_operator(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float rho[36], em[36] = {0}, v[108];
    tu_box_inward(v, 2, 1, 2);
    for (int i = 0; i < 36; i++)
        rho[i] = 0.5f;
    lrr_scene *sc;
    LRR_CHECK(ctx, lrr_scene_create(ctx, 12, v, rho, em, "box", &sc));
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.target_patches = 400;
    LRR_CHECK(ctx, lrr_scene_subdivide(sc, &sd));
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 8;
    lrr_operator *quad, *clus;
    LRR_CHECK(ctx, lrr_operator_build(sc, &bo, &quad));
    bo.hierarchy = LRR_HIERARCHY_CLUSTER;
    bo.adaptive_patches = 20;
    bo.adaptive_split = LRR_SPLIT_AREA;
    LRR_CHECK(ctx, lrr_operator_build(sc, &bo, &clus));
    const size_t n = op_n(quad);
    assert_int_equal(op_n(clus), n);
    assert_non_null(lrr_operator_subpatch_origin(clus));
    float *eq = malloc(3 * n * sizeof(float)), *ec = malloc(3 * n * sizeof(float)),
          *back = malloc(3 * n * sizeof(float));
    lrr_light_source l = point_at(0.7, 0.6, 1.1, 1.0f);
    lrr_lighting *lq, *lc;
    LRR_CHECK(ctx, lrr_lighting_create(quad, &lq));
    LRR_CHECK(ctx, lrr_lighting_create(clus, &lc));
    LRR_CHECK(ctx, lrr_lighting_direct(lq, &l, 1, eq));
    LRR_CHECK(ctx, lrr_lighting_direct(lc, &l, 1, ec));
    lrr_operator_scene_order(clus, ec, back);
    assert_memory_equal(back, eq, 3 * n * sizeof(float));
    lrr_lighting_destroy(lq);
    lrr_lighting_destroy(lc);
    free(eq);
    free(ec);
    free(back);
    lrr_operator_destroy(quad);
    lrr_operator_destroy(clus);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* A range of receivers (lrr_lighting_direct_rows) gets the whole call's rows bit for bit
 * for every kind of light, shadows included, and casts only its own rays; the cache holds
 * one range; bad ranges and a tolerance are refused. */
static void test_rows(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = floor_op(ctx, 2, 1200, 1);
    const size_t n = op_n(op);
    assert_true(n > 300);
    lrr_light_source L[4] = {point_at(0.1, 1.5, 0.2, 1.0f), point_at(-0.5, 2, 0.3, 0.5f),
                             {0}, {0}};
    L[1].kind = LRR_LIGHT_SPOT;
    L[1].direction[1] = -1;
    L[1].cone_angle = 0.6f;
    L[1].cone_softness = 0.2f;
    L[2].kind = LRR_LIGHT_AREA;
    L[2].position[1] = 1.8f;
    L[2].u[0] = 0.4f;
    L[2].v[2] = -0.4f; /* u × v points down, at the floor */
    L[2].rgb[0] = L[2].rgb[1] = L[2].rgb[2] = 2.0f;
    L[2].samples = 9;
    L[3].kind = LRR_LIGHT_SUN;
    L[3].direction[0] = 0.3f;
    L[3].direction[1] = 1;
    L[3].rgb[0] = L[3].rgb[1] = L[3].rgb[2] = 0.7f;
    float *whole = malloc(3 * n * sizeof(float)), *part = malloc(3 * n * sizeof(float));
    lrr_lighting *lt, *lr;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    LRR_CHECK(ctx, lrr_lighting_create(op, &lr));
    LRR_CHECK(ctx, lrr_lighting_direct(lt, L, 4, whole));
    const uint64_t all_rays = lrr_lighting_rays(lt);
    const size_t range[][2] = {{0, n}, {0, 1}, {n - 1, 1}, {37, n / 3}, {64, 64}, {n / 2, n - n / 2}};
    for (size_t r = 0; r < sizeof range / sizeof *range; r++) {
        const size_t row0 = range[r][0], rows = range[r][1];
        LRR_CHECK(ctx, lrr_lighting_direct_rows(lr, L, 4, row0, rows, part));
        assert_memory_equal(part, whole + 3 * row0, 3 * rows * sizeof(float));
        const uint64_t rays = lrr_lighting_rays(lr);
        assert_true(rays <= all_rays && (rays > 0 || rows < 64)); /* one may face away */
        if (rows == n)
            assert_int_equal(rays, all_rays);
        LRR_CHECK(ctx, lrr_lighting_direct_rows(lr, L, 4, row0, rows, part));
        assert_int_equal(lrr_lighting_rays(lr), 0); /* the same range: all cached */
        assert_memory_equal(part, whole + 3 * row0, 3 * rows * sizeof(float));
    }
    /* the two halves' rays add up to the whole call's */
    LRR_CHECK(ctx, lrr_lighting_direct_rows(lr, L, 4, 0, n / 2, part));
    uint64_t halves = lrr_lighting_rays(lr);
    LRR_CHECK(ctx, lrr_lighting_direct_rows(lr, L, 4, n / 2, n - n / 2, part + 3 * (n / 2)));
    halves += lrr_lighting_rays(lr);
    assert_int_equal(halves, all_rays);
    assert_memory_equal(part, whole, 3 * n * sizeof(float));
    /* refused: past n, NULL emission, a tolerance; rows 0 does nothing */
    assert_int_equal(lrr_lighting_direct_rows(lr, L, 4, n, 1, part), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_lighting_direct_rows(lr, L, 4, 1, n, part), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_lighting_direct_rows(lr, L, 4, 0, 1, NULL), LRR_ERR_INVALID_ARG);
    LRR_CHECK(ctx, lrr_lighting_direct_rows(lr, L, 4, n, 0, NULL));
    LRR_CHECK(ctx, lrr_lighting_set_tolerance(lr, 0.05));
    assert_int_equal(lrr_lighting_direct_rows(lr, L, 4, 0, n, part), LRR_ERR_UNSUPPORTED);
    lrr_lighting_destroy(lt);
    lrr_lighting_destroy(lr);
    free(whole);
    free(part);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

static void expect_bad(lrr_context *ctx, lrr_lighting *lt, lrr_light_source l, float *E,
                       const char *what)
{
    E[0] = 42.0f;
    assert_int_equal(lrr_lighting_direct(lt, &l, 1, E), LRR_ERR_INVALID_ARG);
    assert_true(E[0] == 42.0f); /* untouched */
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    if (!strstr(msg, what))
        fail_msg("expected '%s' in: %s", what, msg);
}

static void test_bad_lights(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_operator *op = floor_op(ctx, 1, 20, 0);
    float *E = malloc(3 * op_n(op) * sizeof(float));
    lrr_lighting *lt;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    lrr_light_source l = point_at(0, 1, 0, 1.0f);
    l.kind = 9;
    expect_bad(ctx, lt, l, E, "kind 9");
    l = point_at(0, NAN, 0, 1.0f);
    expect_bad(ctx, lt, l, E, "position");
    l = point_at(0, 1, 0, -1.0f);
    expect_bad(ctx, lt, l, E, "rgb");
    l.kind = LRR_LIGHT_SPOT;
    l.rgb[0] = l.rgb[1] = l.rgb[2] = 1;
    expect_bad(ctx, lt, l, E, "direction");
    l.direction[1] = -1;
    l.cone_angle = 4;
    expect_bad(ctx, lt, l, E, "cone_angle");
    l.cone_angle = 0.5f;
    l.cone_softness = 0.6f;
    expect_bad(ctx, lt, l, E, "cone_softness");
    l.kind = LRR_LIGHT_AREA;
    l.u[0] = 1;
    l.v[0] = 2; /* parallel edges */
    expect_bad(ctx, lt, l, E, "parallel");
    l.v[0] = 0;
    l.v[2] = 1;
    l.samples = 5000;
    expect_bad(ctx, lt, l, E, "1024");
    l = point_at(0, 1, 0, 1e38f);
    l.rgb[1] = 3e38f;
    lrr_light_source two[2] = {l, l};
    assert_int_equal(lrr_lighting_direct(lt, two, 2, E), LRR_ERR_INVALID_ARG);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "overflows"));
    assert_int_equal(lrr_lighting_direct(lt, NULL, 1, E), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    LRR_CHECK(ctx, lrr_lighting_direct(lt, NULL, 0, E));
    assert_true(E[0] == 0.0f);
    lrr_lighting_destroy(lt);
    lrr_lighting_destroy(NULL);
    free(E);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_point_inverse_square),
        cmocka_unit_test(test_spot_cone),
        cmocka_unit_test(test_hard_shadow),
        cmocka_unit_test(test_area_light),
        cmocka_unit_test(test_point_in_furnace),
        cmocka_unit_test(test_cache),
        cmocka_unit_test(test_clustered_operator),
        cmocka_unit_test(test_rows),
        cmocka_unit_test(test_bad_lights),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
