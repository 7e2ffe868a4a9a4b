/* The shadow rays' error budget (lrr_lighting_set_tolerance, lib/light/budget.c) as a
 * specification: on the closed Cornell box (coloured walls, two blocks casting shadows) the
 * area-weighted L2 error of rho ∘ H against every ray stays within the tolerance, per light
 * and channel, for lights that appear, move a little and jump across the room; it skips rays
 * (or the budget would be a no-op); tolerance 0 is every ray, bit for bit; area and sun
 * lights are always traced in full; bad tolerances are refused. */
#include "testutil.h"

static lrr_light_source light_at(int kind, double x, double y, double z)
{
    lrr_light_source l = {.kind = kind, .rgb = {1e5f, 2e5f, 3e5f}};
    l.position[0] = (float)x, l.position[1] = (float)y, l.position[2] = (float)z;
    l.direction[1] = -1.0f; /* spot: down; sun: from below the floor (reaches nothing) */
    l.cone_angle = 1.0f;
    l.cone_softness = 0.2f;
    return l;
}

/* max over channels of ‖√a (e − x)‖ / ‖√a x‖ */
static double rel_l2(const lrr_operator *op, size_t n, const float *e, const float *x)
{
    const float *a = lrr_operator_area(op);
    double worst = 0;
    for (int c = 0; c < 3; c++) {
        double num = 0, den = 0;
        for (size_t i = 0; i < n; i++) {
            double d = (double)e[3 * i + c] - x[3 * i + c];
            num += a[i] * d * d;
            den += a[i] * (double)x[3 * i + c] * x[3 * i + c];
        }
        worst = fmax(worst, sqrt(num / den));
    }
    return worst;
}

typedef struct pair {
    lrr_context *ctx;
    lrr_operator *op;
    size_t n;
    lrr_lighting *budget, *exact;
    float *e, *x;
} pair;

static void pair_open(pair *p, double tol)
{
    p->ctx = tu_context();
    p->op = tu_closed_cornell_op(p->ctx, &p->n);
    LRR_CHECK(p->ctx, lrr_lighting_create(p->op, &p->budget));
    LRR_CHECK(p->ctx, lrr_lighting_create(p->op, &p->exact));
    LRR_CHECK(p->ctx, lrr_lighting_set_tolerance(p->budget, tol));
    p->e = malloc(3 * p->n * sizeof(float));
    p->x = malloc(3 * p->n * sizeof(float));
    assert_non_null(p->e);
    assert_non_null(p->x);
}

static void pair_close(pair *p)
{
    lrr_lighting_destroy(p->budget);
    lrr_lighting_destroy(p->exact);
    lrr_operator_destroy(p->op);
    lrr_context_destroy(p->ctx);
    free(p->e);
    free(p->x);
}

/* One frame of lights through both; returns the error, *saved the share of rays skipped. */
static double frame(pair *p, const lrr_light_source *l, size_t count, double *saved)
{
    LRR_CHECK(p->ctx, lrr_lighting_direct(p->budget, l, count, p->e));
    LRR_CHECK(p->ctx, lrr_lighting_direct(p->exact, l, count, p->x));
    *saved = 1.0 - (double)lrr_lighting_rays(p->budget) / (double)lrr_lighting_rays(p->exact);
    return rel_l2(p->op, p->n, p->e, p->x);
}

/* One light at a time: its first frame (visibility guessed visible), ten small steps
 * (guessed from the step before), then a jump to the other side of the room. */
static void test_bound_per_light(void **state)
{
    (void)state;
    const double tols[] = {0.003, 0.01, 0.05};
    /* the least share of rays skipped in some frame: in this small room the light falls off
     * over a factor of ~30 in distance² only (measured: 0.02-0.06, 0.08-0.09, 0.18-0.36) */
    const double skips[] = {0.01, 0.03, 0.1};
    const int kinds[] = {LRR_LIGHT_POINT, LRR_LIGHT_SPOT};
    for (int t = 0; t < 3; t++)
        for (int k = 0; k < 2; k++) {
            pair p;
            pair_open(&p, tols[t]);
            double saved, most = 0;
            lrr_light_source l = light_at(kinds[k], 150, 500, 150);
            for (int step = 0; step < 12; step++) {
                if (step == 11)
                    l.position[0] = 420, l.position[2] = 400, l.position[1] = 250;
                else if (step > 0)
                    l.position[0] += 8, l.position[2] += 5;
                double err = frame(&p, &l, 1, &saved);
                if (!(err <= tols[t]))
                    fail_msg("kind %d, tolerance %g, step %d: error %g", kinds[k], tols[t],
                             step, err);
                most = fmax(most, saved);
            }
            if (!(most >= skips[t]))
                fail_msg("kind %d, tolerance %g: at most %.3f of the rays skipped", kinds[k],
                         tols[t], most);
            pair_close(&p);
        }
}

/* The worst case for the guess: a point light inside a low fence on a wide floor lights only
 * the floor within the fence, and its first frame guesses every skipped receiver visible, so
 * each one skipped is wrong by its whole unshadowed light. The error stays within the
 * tolerance and uses a good part of it (the budget is spent, not hoarded). */
static void test_worst_case(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[5 * 18], rho[30], em[30] = {0};
    const double f0[3] = {-4, 0, -4}, f1[3] = {-4, 0, 4}, f2[3] = {4, 0, 4}, f3[3] = {4, 0, -4};
    tu_quad(v, f0, f1, f2, f3);
    for (int w = 0; w < 4; w++) { /* the fence: |x| or |z| = 1.5, height 0.5, facing in */
        double c = w & 1 ? 1.5 : -1.5, p[4][3];
        for (int q = 0; q < 4; q++) {
            double t = q == 0 || q == 3 ? -1.5 : 1.5, h = q < 2 ? 0 : 0.5;
            int along = w < 2 ? 2 : 0, across = w < 2 ? 0 : 2;
            p[q][across] = c, p[q][along] = t, p[q][1] = h;
        }
        tu_quad(v + 18 * (w + 1), p[0], p[1], p[2], p[3]);
    }
    for (int i = 0; i < 30; i++)
        rho[i] = 0.2f + 0.02f * (float)(i % 7);
    lrr_operator *op = tu_operator(ctx, 10, v, rho, em, 3000, 8);
    pair p = {.ctx = ctx, .op = op};
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    p.n = oi.n;
    p.e = malloc(3 * p.n * sizeof(float));
    p.x = malloc(3 * p.n * sizeof(float));
    const double tols[] = {0.003, 0.01, 0.03};
    for (int t = 0; t < 3; t++) {
        LRR_CHECK(ctx, lrr_lighting_create(op, &p.budget));
        LRR_CHECK(ctx, lrr_lighting_create(op, &p.exact));
        LRR_CHECK(ctx, lrr_lighting_set_tolerance(p.budget, tols[t]));
        lrr_light_source l = light_at(LRR_LIGHT_POINT, 0.1, 0.3, 0.2);
        double saved, err = frame(&p, &l, 1, &saved);
        if (!(err <= tols[t] && err >= 0.3 * tols[t]))
            fail_msg("tolerance %g: error %g (%.3f of the rays skipped)", tols[t], err, saved);
        lrr_lighting_destroy(p.budget);
        lrr_lighting_destroy(p.exact);
    }
    p.budget = p.exact = NULL;
    pair_close(&p);
}

/* Four lights together: within tolerance·√4 of their exact sum. */
static void test_bound_of_the_sum(void **state)
{
    (void)state;
    const double tol = 0.02;
    pair p;
    pair_open(&p, tol);
    lrr_light_source l[4] = {light_at(LRR_LIGHT_POINT, 100, 450, 100),
                             light_at(LRR_LIGHT_POINT, 450, 450, 120),
                             light_at(LRR_LIGHT_SPOT, 280, 540, 280),
                             light_at(LRR_LIGHT_POINT, 300, 60, 500)};
    for (int step = 0; step < 4; step++) {
        double saved, err = frame(&p, l, 4, &saved);
        if (!(err <= 2 * tol))
            fail_msg("step %d: error %g of the four lights' sum", step, err);
        for (int j = 0; j < 4; j++)
            l[j].position[0] += 10.0f;
    }
    pair_close(&p);
}

/* Tolerance 0 is every ray (the same E to the bit); area and sun lights are traced in full
 * under any tolerance; a new tolerance retraces a cached light. */
static void test_exact_cases(void **state)
{
    (void)state;
    pair p;
    pair_open(&p, 0.0);
    lrr_light_source l[3] = {light_at(LRR_LIGHT_POINT, 200, 400, 250),
                             light_at(LRR_LIGHT_AREA, 278, 540, 280),
                             light_at(LRR_LIGHT_SUN, 0, 0, 0)};
    l[1].u[0] = 100, l[1].v[2] = -100, l[1].samples = 4; /* u × v points down */
    l[2].direction[1] = 1, l[2].direction[0] = 0.3f;     /* the sun above the open top */
    double saved;
    assert_true(frame(&p, l, 3, &saved) == 0.0);
    assert_memory_equal(p.e, p.x, 3 * p.n * sizeof(float));
    assert_true(saved == 0.0);
    LRR_CHECK(p.ctx, lrr_lighting_set_tolerance(p.budget, 0.2));
    LRR_CHECK(p.ctx, lrr_lighting_direct(p.budget, l + 1, 2, p.e));
    LRR_CHECK(p.ctx, lrr_lighting_direct(p.exact, l + 1, 2, p.x));
    assert_memory_equal(p.e, p.x, 3 * p.n * sizeof(float));
    assert_int_equal(lrr_lighting_rays(p.budget), lrr_lighting_rays(p.exact));
    pair_close(&p);
}

static void test_bad_tolerance(void **state)
{
    (void)state;
    pair p;
    pair_open(&p, 0.0);
    const double bad[] = {-0.1, 1.0, 2.0, NAN, INFINITY};
    for (int i = 0; i < 5; i++) {
        assert_int_equal(lrr_lighting_set_tolerance(p.budget, bad[i]), LRR_ERR_INVALID_ARG);
        char msg[256];
        lrr_context_last_error(p.ctx, msg, sizeof msg);
        if (!strstr(msg, "tolerance"))
            fail_msg("tolerance %g: %s", bad[i], msg);
    }
    pair_close(&p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_bound_per_light),
        cmocka_unit_test(test_worst_case),
        cmocka_unit_test(test_bound_of_the_sum),
        cmocka_unit_test(test_exact_cases),
        cmocka_unit_test(test_bad_tolerance),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
