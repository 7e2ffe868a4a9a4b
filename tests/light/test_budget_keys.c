/* The light budget's weighing (lib/light/budget.c, budget_avx2.c) as a specification: a
 * point light's unshadowed weight g = cos / r² and its key's bin against a double-precision
 * evaluation and frexp's octaves; the AVX2 variant equal to the C one to the bit, for spans
 * of every alignment and length and the edge cases (behind the receiver, at its centre,
 * weights that underflow or overflow a float's square); and a budgeted frame the same to
 * the bit on any number of threads (the traced light S is summed in a fixed order). */
#include "testutil.h"
#include "core/cpu.h"
#include "light/light.h"

#include <omp.h>

enum { N = 203 };

/* receivers on a sphere-ish cloud around the origin, normals every way; the last few are
 * the edge cases for a light at p = (0, 0.25, -0.125) */
static void cloud(lrr__budget_receivers *r, float *all, const float p[3])
{
    float **col[9] = {&r->x, &r->y, &r->z, &r->nx, &r->ny, &r->nz, &r->ar[0], &r->ar[1],
                      &r->ar[2]};
    for (int c = 0; c < 9; c++)
        *col[c] = all + c * N;
    uint64_t s = 12345;
    for (int i = 0; i < N; i++) {
        float u[6];
        for (int j = 0; j < 6; j++)
            u[j] = (float)((lrr__splitmix64_next(&s) >> 11) * 0x1.0p-53) * 2 - 1;
        float len = sqrtf(u[3] * u[3] + u[4] * u[4] + u[5] * u[5]) + 1e-3f;
        r->x[i] = 8 * u[0], r->y[i] = 8 * u[1], r->z[i] = 8 * u[2];
        r->nx[i] = u[3] / len, r->ny[i] = u[4] / len, r->nz[i] = u[5] / len;
        for (int c = 0; c < 3; c++)
            r->ar[c][i] = (0.1f + 0.3f * (float)c) * (1 + u[c]) * 0.01f;
    }
    int e = N - 4; /* at the light; just off it (g² overflows); far (g² underflows) */
    r->x[e] = p[0], r->y[e] = p[1], r->z[e] = p[2];
    r->x[e + 1] = p[0] + 1e-12f, r->y[e + 1] = p[1], r->z[e + 1] = p[2]; /* p[0] = 0 */
    r->nx[e + 1] = -1, r->ny[e + 1] = 0, r->nz[e + 1] = 0;
    r->x[e + 2] = p[0] - 1e12f, r->y[e + 2] = p[1], r->z[e + 2] = p[2];
    r->nx[e + 2] = 1, r->ny[e + 2] = 0, r->nz[e + 2] = 0;
    r->nx[e + 3] = -r->nx[e + 3]; /* whichever way it faced, now the other */
}

/* The bin of key > 0 from frexp: key = m 2^e, m in [0.5, 1); a float's biased exponent is
 * e + 126 and its first mantissa bit m >= 0.75; bins count half octaves down from 511. */
static unsigned bin_of(float key)
{
    if (isinf(key))
        return LRR__BUDGET_BINS - 1 - 0x1FE;
    if (key < 0x1p-126f) /* subnormal: biased exponent 0, first bit of the raw mantissa */
        return LRR__BUDGET_BINS - 1 - (key >= 0x1p-127f);
    int e;
    float m = frexpf(key, &e);
    return LRR__BUDGET_BINS - 1 - (unsigned)(2 * (e + 126) + (m >= 0.75f));
}

static void test_point_keys(void **state)
{
    (void)state;
    const float p[3] = {0.0f, 0.25f, -0.125f};
    float all[9 * N], g[N], ga[N];
    uint16_t bin[N], ba[N];
    lrr__budget_receivers r;
    cloud(&r, all, p);
    lrr__budget_point_keys(&r, 0, N, p, g, bin);
    int lit = 0, dark = 0;
    for (int i = 0; i < N; i++) {
        double w[3] = {p[0] - r.x[i], p[1] - r.y[i], p[2] - r.z[i]};
        double r2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2];
        double c = r.nx[i] * w[0] + r.ny[i] * w[1] + r.nz[i] * w[2];
        double want = c > 0 && r2 > 0 ? c / (r2 * sqrt(r2)) : 0;
        if (want == 0 || !isfinite((float)want)) {
            if (want == 0)
                assert_true(g[i] == 0.0f && bin[i] == LRR__BUDGET_DARK);
            dark += want == 0;
            continue;
        }
        /* float's r2, c, sqrt, product and quotient: a few ε of the value, and of |n||w|/r³
         * where the cosine c cancels (a normal almost across w) */
        double nn = sqrt((double)r.nx[i] * r.nx[i] + (double)r.ny[i] * r.ny[i] +
                         (double)r.nz[i] * r.nz[i]);
        if (!(fabs(g[i] - want) <= 8 * FLT_EPSILON * (want + nn / r2)))
            fail_msg("receiver %d: g %.9g, want %.9g", i, g[i], want);
        float key = g[i] * g[i] * (r.ar[0][i] + r.ar[1][i] + r.ar[2][i]) * (1.0f / 3);
        if (key > 0) {
            assert_int_equal(bin[i], bin_of(key));
            lit++;
        }
    }
    assert_true(lit > N / 3 && dark > N / 4); /* both kinds, in numbers */
    assert_int_equal(bin[N - 4], LRR__BUDGET_DARK);          /* at the light */
    assert_int_equal(bin[N - 3], bin_of(INFINITY));          /* g² overflows: first bins */
    assert_true(g[N - 2] > 0 && bin[N - 2] == LRR__BUDGET_BINS - 1); /* key underflows: last */
    if (!lrr__cpu_supports(LRR__ISA_AVX2))
        skip();
    for (size_t i0 = 0; i0 < 9; i0++)
        for (size_t i1 = i0; i1 <= N; i1 += i1 < i0 + 20 ? 1 : 37) {
            memset(ga, 0xAB, sizeof ga);
            memset(ba, 0xAB, sizeof ba);
            lrr__budget_point_keys_avx2(&r, i0, i1, p, ga, ba);
            if (i1 > i0) {
                assert_memory_equal(ga + i0, g + i0, (i1 - i0) * sizeof *g);
                assert_memory_equal(ba + i0, bin + i0, (i1 - i0) * sizeof *bin);
            }
            /* nothing outside the span */
            for (size_t i = 0; i < N; i++)
                if (i < i0 || i >= i1)
                    assert_int_equal(ba[i], 0xABAB);
        }
}

/* A budgeted frame of four lights on the Cornell box: the same E and rays on 1 and 2
 * threads, and with LRR_SIMD=c as with the widest SIMD. */
static void frame_e(lrr_operator *op, size_t n, int threads, const char *simd, float *e,
                    uint64_t *rays)
{
    lrr_context *ctx = tu_context();
    omp_set_num_threads(threads);
    if (simd)
        setenv("LRR_SIMD", simd, 1);
    lrr_lighting *lt;
    LRR_CHECK(ctx, lrr_lighting_create(op, &lt));
    unsetenv("LRR_SIMD");
    LRR_CHECK(ctx, lrr_lighting_set_tolerance(lt, 0.02));
    lrr_light_source l[5] = {{0}};
    for (int j = 0; j < 5; j++) {
        l[j].kind = j == 2 ? LRR_LIGHT_SPOT : LRR_LIGHT_POINT;
        l[j].rgb[0] = 1e5f, l[j].rgb[1] = 2e5f, l[j].rgb[2] = 3e5f;
        l[j].position[0] = 100.0f + 80 * j, l[j].position[1] = 300, l[j].position[2] = 250;
        l[j].direction[1] = -1, l[j].cone_angle = 1.0f, l[j].cone_softness = 0.2f;
    }
    for (int f = 0; f < 3; f++) { /* every light moves; then only the first */
        LRR_CHECK(ctx, lrr_lighting_direct(lt, l, 5, e + 3 * n * f));
        for (int j = 0; j < (f == 0 ? 5 : 1); j++)
            l[j].position[1] += 20;
        rays[f] = lrr_lighting_rays(lt);
    }
    lrr_lighting_destroy(lt);
    (void)op;
    lrr_context_destroy(ctx);
}

static void test_threads_and_simd(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t n;
    lrr_operator *op = tu_closed_cornell_op(ctx, &n);
    float *e1 = malloc(9 * n * sizeof(float)), *e2 = malloc(9 * n * sizeof(float)),
          *ec = malloc(9 * n * sizeof(float));
    uint64_t r1[3], r2[3], rc[3];
    frame_e(op, n, 1, NULL, e1, r1);
    frame_e(op, n, 2, NULL, e2, r2);
    frame_e(op, n, 2, "c", ec, rc);
    assert_memory_equal(e1, e2, 9 * n * sizeof(float));
    assert_memory_equal(e1, ec, 9 * n * sizeof(float));
    assert_memory_equal(r1, r2, sizeof r1);
    assert_memory_equal(r1, rc, sizeof r1);
    assert_true(r1[2] < r1[1]); /* one light moving casts fewer rays than five */
    free(e1);
    free(e2);
    free(ec);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_point_keys),
        cmocka_unit_test(test_threads_and_simd),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
