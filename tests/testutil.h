/* Shared helpers for the unit tests (cmocka). */
#ifndef LRR_TESTUTIL_H
#define LRR_TESTUTIL_H

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <float.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "lrr.h"

/* Fails the test with the context's error message when st != LRR_OK. */
#define LRR_CHECK(ctx, call)                                                                  \
    do {                                                                                      \
        lrr_status st__ = (call);                                                             \
        if (st__ != LRR_OK) {                                                                 \
            char msg__[512];                                                                  \
            lrr_context_last_error((ctx), msg__, sizeof msg__);                               \
            fail_msg("%s -> %s: %s", #call, lrr_strerror(st__), msg__);                       \
        }                                                                                     \
    } while (0)

/* Asserts |a - b| <= tol with a message naming the values. */
#define ASSERT_NEAR(a, b, tol, ...)                                                           \
    do {                                                                                      \
        double a__ = (a), b__ = (b), t__ = (tol);                                             \
        if (!(fabs(a__ - b__) <= t__)) {                                                      \
            print_error(__VA_ARGS__);                                                         \
            fail_msg("%s = %.10g, expected %.10g (tolerance %.3g)", #a, a__, b__, t__);       \
        }                                                                                     \
    } while (0)

/* Tolerances (as in GSL's tests): a difference that comes from rounding alone gets
 * k·n·ε, with ε the machine epsilon of the precision the value is computed or stored in
 * (DBL_EPSILON, FLT_EPSILON), n the number of roundings that add up (terms of a sum,
 * operations in a chain) and k a small safety factor; each use says why. Statistical and
 * modelling errors (Monte Carlo noise, a hemicube's aliasing, the low-rank model, a solver's
 * stopping tolerance, a condition number) are not rounding: those tolerances stay literal,
 * with their reason beside them. */
#define TU_TOL_DBL(k, n) ((double)(k) * (double)(n) * DBL_EPSILON)
#define TU_TOL_FLT(k, n) ((double)(k) * (double)(n) * FLT_EPSILON)

/* max over entries of |a − b| relative to max |b| (m entries each) */
static inline double tu_max_rel(size_t m, const float *a, const float *b)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < m; i++) {
        num = fmax(num, fabs((double)a[i] - b[i]));
        den = fmax(den, fabs((double)b[i]));
    }
    return den > 0 ? num / den : num;
}

/* ‖a − b‖₂ / ‖b‖₂ over m entries */
static inline double tu_rel_l2(size_t m, const float *a, const float *b)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < m; i++) {
        num += ((double)a[i] - b[i]) * ((double)a[i] - b[i]);
        den += (double)b[i] * b[i];
    }
    return sqrt(num / den);
}

/* Writes the two triangles of quad (p0,p1,p2,p3) (counter-clockwise seen from the front)
 * into v (18 floats). */
static inline void tu_quad(float *v, const double p0[3], const double p1[3], const double p2[3],
                           const double p3[3])
{
    const double *q[6] = {p0, p1, p2, p0, p2, p3};
    for (int i = 0; i < 6; i++)
        for (int j = 0; j < 3; j++)
            v[3 * i + j] = (float)q[i][j];
}

/* An axis-aligned box [0,sx]×[0,sy]×[0,sz] with faces pointing inwards (12 triangles).
 * Faces in order: x=0, x=sx, y=0, y=sy, z=0, z=sz. */
static inline void tu_box_inward(float v[108], double sx, double sy, double sz)
{
    double c[8][3];
    for (int i = 0; i < 8; i++) {
        c[i][0] = (i & 1) ? sx : 0;
        c[i][1] = (i & 2) ? sy : 0;
        c[i][2] = (i & 4) ? sz : 0;
    }
    /* each face listed counter-clockwise as seen from inside the box */
    static const int f[6][4] = {{0, 2, 6, 4}, {1, 5, 7, 3}, {0, 4, 5, 1},
                                {2, 3, 7, 6}, {0, 1, 3, 2}, {4, 6, 7, 5}};
    for (int i = 0; i < 6; i++)
        tu_quad(v + 18 * i, c[f[i][0]], c[f[i][1]], c[f[i][2]], c[f[i][3]]);
}

/* The set-up most tests share (a fixture): a context, failing the test when it cannot be
 * made; lrr_context_destroy(ctx) at the end. */
static inline lrr_context *tu_context(void)
{
    lrr_context *ctx = NULL;
    assert_int_equal(lrr_context_create(&ctx), LRR_OK);
    return ctx;
}

/* The built-in Cornell box (closed: the closed variant), subdivided into about K patches of
 * 4^levels subpatches when K > 0; lrr_scene_destroy() it. */
static inline lrr_scene *tu_cornell(lrr_context *ctx, int closed, size_t K, unsigned levels)
{
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_cornell_box(ctx, closed, &s));
    if (K > 0) {
        lrr_subdivision sd = {.target_patches = K, .levels = levels};
        LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    }
    return s;
}

/* The closed Cornell box at about 600 patches (1 level), built at hemicube resolution 8;
 * *n its subpatches. */
static inline lrr_operator *tu_closed_cornell_op(lrr_context *ctx, size_t *n)
{
    lrr_scene *sc = tu_cornell(ctx, 1, 600, 1);
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 8;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(sc, &bo, &op));
    lrr_scene_destroy(sc);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    *n = oi.n;
    return op;
}

/* T triangles v (T×9, counter-clockwise fronts) with reflectance rho and emission em (T×3)
 * subdivided into about `patches` patches and built at hemicube resolution R, the other
 * options the defaults; lrr_operator_destroy() it. */
static inline lrr_operator *tu_operator(lrr_context *ctx, size_t T, const float *v,
                                        const float *rho, const float *em, size_t patches,
                                        unsigned R)
{
    lrr_scene *sc;
    LRR_CHECK(ctx, lrr_scene_create(ctx, T, v, rho, em, "test scene", &sc));
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.target_patches = patches;
    LRR_CHECK(ctx, lrr_scene_subdivide(sc, &sd));
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = R;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(sc, &bo, &op));
    lrr_scene_destroy(sc);
    return op;
}

/* Four closed rooms side by side, each 1 × 1 × 1 and 0.5 apart: a patch sees its own room
 * only, so at most a quarter of F̄ is nonzero (a sparse F̄, lib/solve/sparse.c). The first
 * room's floor emits. */
static inline lrr_operator *tu_rooms_op(lrr_context *ctx, size_t K)
{
    enum { ROOMS = 4, T = 12 * ROOMS };
    float v[9 * T], rho[3 * T], e[3 * T];
    for (int r = 0; r < ROOMS; r++) {
        tu_box_inward(v + 108 * r, 1, 1, 1);
        for (int j = 0; j < 36; j++)
            v[108 * r + 3 * j] += 1.5f * (float)r;
    }
    for (int t = 0; t < T; t++)
        for (int c = 0; c < 3; c++) {
            rho[3 * t + c] = 0.3f + 0.2f * (float)c;
            e[3 * t + c] = t == 8 || t == 9 ? 1.0f : 0.0f; /* room 0, z = 0 */
        }
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, T, v, rho, e, "rooms", &s));
    lrr_subdivision sd = {.target_patches = K, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_build_options o = {.hemicube_resolution = 32, .seed = 3};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    lrr_scene_destroy(s);
    return op;
}

/* The furnace (docs/METHOD.md "Exact cases"): tu_box_inward(sx, sy, sz) with reflectance rho
 * and emission e (every channel) on every face, so B = e/(1 − rho) everywhere. */
static inline lrr_scene *tu_furnace(lrr_context *ctx, double sx, double sy, double sz,
                                    const float rho[3], float e)
{
    float v[108], r[36], em[36];
    tu_box_inward(v, sx, sy, sz);
    for (int t = 0; t < 12; t++)
        for (int c = 0; c < 3; c++) {
            r[3 * t + c] = rho[c];
            em[3 * t + c] = e;
        }
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, 12, v, r, em, "furnace", &s));
    return s;
}

/* The open Cornell box subdivided into about K patches of 4^levels subpatches and built with
 * hemicube resolution R and rotation seed `seed`. */
static inline lrr_operator *tu_cornell_op(lrr_context *ctx, size_t K, unsigned levels,
                                          unsigned R, uint64_t seed)
{
    lrr_scene *s = tu_cornell(ctx, 0, K, levels);
    lrr_build_options o = {.hemicube_resolution = R, .seed = seed};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    lrr_scene_destroy(s);
    return op;
}

/* The test's scratch directory: $LRR_TEST_TMP (make check gives each test its own under
 * the build tree's tests/tmp, tests/scratch-driver.sh), else /tmp. */
static inline const char *tu_tmp_dir(void)
{
    const char *dir = getenv("LRR_TEST_TMP");
    return dir && *dir ? dir : "/tmp";
}

/* Temporary file path in tu_tmp_dir(), unique per process. */
static inline void tu_tmp_path(char *buf, size_t len, const char *name)
{
    snprintf(buf, len, "%s/%s.%ld", tu_tmp_dir(), name, (long)getpid());
}

/* True when the library was built with the optional feature name ("assimp", "cgal",
 * "openexr", "opencl": lrr_features(), configure --without-X). */
static inline int tu_has_feature(const char *name)
{
    size_t n = strlen(name);
    for (const char *p = lrr_features(); (p = strstr(p, name)) != NULL; p += n)
        if ((p == lrr_features() || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0'))
            return 1;
    return 0;
}

/* Skips the current cmocka test, saying why, when the library lacks the feature. */
#define TU_REQUIRE(feature)                                                                   \
    do {                                                                                      \
        if (!tu_has_feature(feature)) {                                                       \
            print_message("skipped: lrr was built without %s\n", (feature));                  \
            skip();                                                                           \
        }                                                                                     \
    } while (0)

/* For main: a whole test program that needs the feature exits 77 (automake: SKIP). */
#define TU_REQUIRE_PROGRAM(prog, feature)                                                     \
    do {                                                                                      \
        if (!tu_has_feature(feature)) {                                                       \
            printf("%s: skipped: lrr was built without %s\n", (prog), (feature));            \
            return 77;                                                                        \
        }                                                                                     \
    } while (0)

#endif
