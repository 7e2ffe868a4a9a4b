/* Hemicube form factors against closed forms (Howell's catalogue of configuration factors;
 * Incropera, Table 13.2; docs/METHOD.md "Form factors"). */
#include "testutil.h"
#include "formfactor/formfactor.h"
#include "formfactor/hemicube_private.h"
#include "core/cpu.h"
#include "operator/operator.h"
#include "closed_forms.h"

/* The multiplier map is normalised by its own double sum, so it sums to 1 but for about
 * sqrt(3 R^2) <= 887 roundings of random sign (R <= 512): n = 1024, k = 8. */
#define MAP_SUM_TOL TU_TOL_DBL(8, 1024)

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static void test_multiplier_map(void **state)
{
    (void)state;
    unsigned res[] = {8, 32, 128, 512};
    for (size_t r = 0; r < sizeof res / sizeof res[0]; r++) {
        lrr__multiplier_map m;
        assert_int_equal(lrr__multiplier_map_create(NULL, res[r], &m), LRR_OK);
        double sum = 0;
        for (size_t i = 0; i < (size_t)res[r] * res[r]; i++)
            sum += m.top[i];
        for (size_t i = 0; i < (size_t)res[r] * res[r] / 2; i++)
            sum += 4 * m.side[i];
        ASSERT_NEAR(sum, 1.0, MAP_SUM_TOL, "R = %u: normalised sum\n", res[r]);
        /* the unnormalised midpoint rule converges to the exact integral 1 like 1/R² */
        ASSERT_NEAR(m.raw_sum, 1.0, 2.0 / ((double)res[r] * res[r]), "R = %u: raw sum\n", res[r]);
        /* the top face's centre pixel carries the largest weight, 1/π · dA before scaling */
        double h = 2.0 / res[r];
        ASSERT_NEAR(m.top[(size_t)(res[r] / 2) * res[r] + res[r] / 2] * m.raw_sum,
                    h * h / (M_PI * pow(1 + 2 * (h / 2) * (h / 2), 2)), 1e-15, "R = %u\n", res[r]);
        lrr__multiplier_map_free(&m);
    }
    lrr__multiplier_map bad;
    assert_int_equal(lrr__multiplier_map_create(NULL, 7, &bad), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr__multiplier_map_create(NULL, 4, &bad), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr__multiplier_map_create(NULL, 8192, &bad), LRR_ERR_INVALID_ARG);
}

/* Builds an operator with levels `levels` and at most max_area per patch. */
static lrr_operator *build(lrr_context *ctx, size_t ntri, const float *v, double max_area,
                           unsigned levels, unsigned R, uint64_t seed)
{
    float *rho = calloc(ntri * 3, sizeof(float)), *em = calloc(ntri * 3, sizeof(float));
    for (size_t i = 0; i < ntri * 3; i++)
        rho[i] = 0.5f;
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, ntri, v, rho, em, "test", &s));
    lrr_subdivision sd = {.max_patch_area = max_area, .levels = levels};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_build_options o = {.hemicube_resolution = R, .seed = seed};
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
    lrr_scene_destroy(s);
    free(rho);
    free(em);
    return op;
}

/* A point facing a coaxial disk of radius r at height h: F = r²/(r²+h²). */
static void test_point_to_disk(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    enum { SEG = 720 };
    const double cases[][2] = {{1, 1}, {1, 0.5}, {1, 3}, {2, 0.7}};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        double r = cases[c][0], h = cases[c][1];
        float v[(SEG + 1) * 9];
        /* receiver: a tiny triangle centred on the origin facing +z */
        const double e = 1e-3;
        float rec[9] = {(float)(-e), (float)(-e), 0, (float)(2 * e), (float)(-e), 0,
                        (float)(-e), (float)(2 * e), 0};
        memcpy(v, rec, sizeof rec);
        /* disk fan at height h facing -z (clockwise seen from above = CCW from below) */
        for (int s = 0; s < SEG; s++) {
            double a0 = 2 * M_PI * s / SEG, a1 = 2 * M_PI * (s + 1) / SEG;
            float *t = v + 9 * (s + 1);
            t[0] = 0; t[1] = 0; t[2] = (float)h;
            t[3] = (float)(r * cos(a1)); t[4] = (float)(r * sin(a1)); t[5] = (float)h;
            t[6] = (float)(r * cos(a0)); t[7] = (float)(r * sin(a0)); t[8] = (float)h;
        }
        /* the polygon's area falls short of the disk's by (1 - sin(2π/N)/(2π/N)) */
        double poly = r * r * SEG * sin(2 * M_PI / SEG) / (2 * M_PI);
        double expect = poly / (poly + h * h);
        /* a centred disk is rotation invariant, so its pixel-lattice error (about a pixel row
         * around the rim) does not average out over seeds: each seed must be within 1% */
        const int seeds = 3;
        for (int sd = 0; sd < seeds; sd++) {
            lrr_operator *op = build(ctx, SEG + 1, v, 0, 0, 128, (uint64_t)sd);
            double sum = 0;
            for (size_t p = 1; p < op->k; p++)
                sum += op->fbar[p];
            print_message("point to disk r = %g, h = %g, seed %d: F = %.6f, closed form %.6f, "
                          "relative error %+.2e\n", r, h, sd, sum, expect, sum / expect - 1);
            ASSERT_NEAR(sum, expect, 0.01 * expect, "r = %g, h = %g, seed %d\n", r, h, sd);
            lrr_operator_destroy(op);
        }
    }
    lrr_context_destroy(ctx);
}

static void test_closed_forms(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    ASSERT_NEAR(parallel_closed_form(1, 1), 0.1998, 1e-4, "published X=Y=1\n");
    ASSERT_NEAR(parallel_closed_form(10, 10), 0.827, 1e-3, "published X=Y=10\n");
    ASSERT_NEAR(parallel_closed_form(1 / 0.5, 1.5 / 0.5), 0.4756, 1e-4, "published 1×1.5 at 0.5\n");
    ASSERT_NEAR(perpendicular_closed_form(1, 1), 0.2000, 1e-4, "published W=H=1\n");

    /* parallel a×b rectangles at distance c: bottom faces +z, top faces -z */
    const double par[][3] = {{1, 1, 1}, {1, 1.5, 0.5}, {2, 1, 1.5}};
    for (size_t i = 0; i < 3; i++) {
        double a = par[i][0], b = par[i][1], c = par[i][2];
        float v[36];
        const double p0[3] = {0, 0, 0}, p1[3] = {a, 0, 0}, p2[3] = {a, b, 0}, p3[3] = {0, b, 0};
        const double q0[3] = {0, 0, c}, q1[3] = {0, b, c}, q2[3] = {a, b, c}, q3[3] = {a, 0, c};
        tu_quad(v, p0, p1, p2, p3);
        tu_quad(v + 18, q0, q1, q2, q3);
        lrr_operator *op = build(ctx, 4, v, a * b / 16, 2, 128, 7);
        double F = area_average(op, 2), ref = parallel_closed_form(a / c, b / c);
        print_message("parallel %g×%g at %g: F = %.6f, closed form %.6f, relative error %+.2e\n",
                      a, b, c, F, ref, F / ref - 1);
        ASSERT_NEAR(F, ref, 0.01 * ref, "parallel %g×%g at %g (n = %zu)\n", a, b, c, op->n);
        lrr_operator_destroy(op);
    }
    /* perpendicular rectangles sharing an edge of length l along y */
    const double perp[][3] = {{1, 1, 1}, {1, 2, 1}, {0.5, 1, 2}}; /* w, h, l */
    for (size_t i = 0; i < 3; i++) {
        double w = perp[i][0], hh = perp[i][1], l = perp[i][2];
        float v[36];
        /* surface 1: x in [0,w], z = 0, facing +z; surface 2: x = 0, z in [0,h], facing +x */
        const double p0[3] = {0, 0, 0}, p1[3] = {w, 0, 0}, p2[3] = {w, l, 0}, p3[3] = {0, l, 0};
        const double q0[3] = {0, 0, 0}, q1[3] = {0, l, 0}, q2[3] = {0, l, hh}, q3[3] = {0, 0, hh};
        tu_quad(v, p0, p1, p2, p3);
        tu_quad(v + 18, q0, q1, q2, q3);
        lrr_operator *op = build(ctx, 4, v, w * l / 16, 2, 128, 11);
        double F = area_average(op, 2), ref = perpendicular_closed_form(w / l, hh / l);
        print_message("perpendicular w = %g, h = %g, l = %g: F = %.6f, closed form %.6f, "
                      "relative error %+.2e\n", w, hh, l, F, ref, F / ref - 1);
        ASSERT_NEAR(F, ref, 0.01 * ref, "perpendicular w=%g h=%g l=%g (n = %zu)\n", w, hh, l,
                    op->n);
        lrr_operator_destroy(op);
    }
    lrr_context_destroy(ctx);
}

/* Same seed → bit-identical F̄ whatever the thread count; another seed → different; no
 * rotation → the seed does not matter. */
static void test_reproducible(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sd = {.target_patches = 30, .levels = 1};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    lrr_operator *a, *b, *c;
    lrr_build_options o1 = {.hemicube_resolution = 32, .seed = 5, .threads = 1},
                      o2 = {.hemicube_resolution = 32, .seed = 5, .threads = 2},
                      o3 = {.hemicube_resolution = 32, .seed = 6, .threads = 2};
    LRR_CHECK(ctx, lrr_operator_build(s, &o1, &a));
    LRR_CHECK(ctx, lrr_operator_set_layout(a, LRR_LAYOUT_ROWS)); /* read as rows below */
    LRR_CHECK(ctx, lrr_operator_build(s, &o2, &b));
    LRR_CHECK(ctx, lrr_operator_set_layout(b, LRR_LAYOUT_ROWS)); /* read as rows below */
    LRR_CHECK(ctx, lrr_operator_build(s, &o3, &c));
    LRR_CHECK(ctx, lrr_operator_set_layout(c, LRR_LAYOUT_ROWS)); /* read as rows below */
    assert_memory_equal(a->fbar, b->fbar, a->n * a->k * sizeof(float));
    assert_true(memcmp(a->fbar, c->fbar, a->n * a->k * sizeof(float)) != 0);
    /* without the rotation the seed changes nothing, and the flag survives a file */
    lrr_operator *d, *e;
    lrr_build_options o4 = {.hemicube_resolution = 32, .seed = 5, .threads = 2, .no_rotation = 1},
                      o5 = {.hemicube_resolution = 32, .seed = 6, .threads = 2, .no_rotation = 1};
    LRR_CHECK(ctx, lrr_operator_build(s, &o4, &d));
    LRR_CHECK(ctx, lrr_operator_set_layout(d, LRR_LAYOUT_ROWS)); /* read as rows below */
    LRR_CHECK(ctx, lrr_operator_build(s, &o5, &e));
    LRR_CHECK(ctx, lrr_operator_set_layout(e, LRR_LAYOUT_ROWS)); /* read as rows below */
    assert_memory_equal(d->fbar, e->fbar, d->n * d->k * sizeof(float));
    assert_true(memcmp(a->fbar, d->fbar, a->n * a->k * sizeof(float)) != 0);
    char path[256];
    tu_tmp_path(path, sizeof path, "norot.lrr");
    LRR_CHECK(ctx, lrr_operator_save(d, path));
    lrr_operator *back;
    LRR_CHECK(ctx, lrr_operator_load(ctx, path, &back));
    LRR_CHECK(ctx, lrr_operator_set_layout(back, LRR_LAYOUT_ROWS)); /* read as rows below */
    lrr_operator_info info;
    lrr_operator_get_info(back, &info, sizeof info);
    assert_int_equal(info.no_rotation, 1);
    lrr_operator_get_info(a, &info, sizeof info);
    assert_int_equal(info.no_rotation, 0);
    unlink(path);
    lrr_operator_destroy(back);
    lrr_operator_destroy(d);
    lrr_operator_destroy(e);
    lrr_operator_destroy(a);
    lrr_operator_destroy(b);
    lrr_operator_destroy(c);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* The light-leak indicator (lrr_operator_info.back_face_share): a unit square facing a unit
 * square at distance 1 (F = 0.1998) whose triangles are flipped, so the receiver's hemicube
 * sees the wall's back. Each receiver triangle's share is its form factor to the wall and
 * the mean over all receivers (half of them on the wall, which sees nothing) is F/2, with
 * either pixel method; unflipped, nothing is a back face; a loaded operator reports none. */
static void test_back_face_share(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    const double F = parallel_closed_form(1, 1);
    const double p0[3] = {0, 0, 0}, p1[3] = {1, 0, 0}, p2[3] = {1, 1, 0}, p3[3] = {0, 1, 0};
    const double q0[3] = {0, 0, 1}, q1[3] = {0, 1, 1}, q2[3] = {1, 1, 1}, q3[3] = {1, 0, 1};
    float rho[12], em[12] = {0};
    for (int i = 0; i < 12; i++)
        rho[i] = 0.5f;
    for (int flipped = 0; flipped < 2; flipped++)
        for (int m = LRR_FORMFACTOR_RASTER; m <= LRR_FORMFACTOR_RAYCAST; m++) {
            float v[36];
            tu_quad(v, p0, p1, p2, p3);
            if (flipped) /* the wall faces +z, away from the receiver */
                tu_quad(v + 18, q0, q3, q2, q1);
            else
                tu_quad(v + 18, q0, q1, q2, q3);
            lrr_scene *s;
            LRR_CHECK(ctx, lrr_scene_create(ctx, 4, v, rho, em, "test", &s));
            lrr_subdivision sd = {.max_patch_area = 1.0 / 16, .levels = 2};
            LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
            lrr_build_options o = {.hemicube_resolution = 128, .seed = 3, .formfactor_method = m};
            lrr_operator *op;
            LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
            LRR_CHECK(ctx, lrr_operator_set_layout(op, LRR_LAYOUT_ROWS)); /* read as rows below */
            lrr_operator_info info;
            lrr_operator_get_info(op, &info, sizeof info);
            print_message("%s wall, %s: back_face_share %.6f (F/2 = %.6f), worst %zu %.6f, "
                          "%zu %.6f\n", flipped ? "flipped" : "facing",
                          m == LRR_FORMFACTOR_RASTER ? "raster" : "raycast",
                          info.back_face_share, F / 2, info.worst_back_face_triangle[0],
                          info.worst_back_face_share[0], info.worst_back_face_triangle[1],
                          info.worst_back_face_share[1]);
            if (!flipped) {
                assert_true(info.back_face_share == 0);
                assert_true(info.worst_back_face_share[0] == 0);
                assert_true(info.worst_back_face_triangle[0] == SIZE_MAX);
            } else {
                ASSERT_NEAR(info.back_face_share, F / 2, 0.01 * F, "method %d\n", m);
                for (int w = 0; w < 2; w++) { /* the two receiver triangles, by symmetry */
                    assert_true(info.worst_back_face_triangle[w] < 2);
                    ASSERT_NEAR(info.worst_back_face_share[w], F, 0.02 * F, "entry %d\n", w);
                }
                assert_true(info.worst_back_face_share[2] == 0); /* the wall sees nothing */
                assert_true(info.worst_back_face_triangle[2] == SIZE_MAX);
                /* the back of the wall carries nothing: no row reaches it */
                for (size_t i = 0; i < op->n * op->k; i++)
                    if (op->geom.first[i % op->k] >= op->n / 2)
                        assert_true(op->fbar[i] == 0);
                char path[256];
                tu_tmp_path(path, sizeof path, "leak.lrr");
                LRR_CHECK(ctx, lrr_operator_save(op, path));
                lrr_operator *back;
                LRR_CHECK(ctx, lrr_operator_load(ctx, path, &back));
                LRR_CHECK(ctx, lrr_operator_set_layout(back, LRR_LAYOUT_ROWS)); /* read as rows below */
                lrr_operator_get_info(back, &info, sizeof info);
                assert_true(info.back_face_share == 0 && info.worst_back_face_share[0] == 0);
                assert_true(info.worst_back_face_triangle[0] == SIZE_MAX);
                unlink(path);
                lrr_operator_destroy(back);
            }
            lrr_operator_destroy(op);
            lrr_scene_destroy(s);
        }
    lrr_context_destroy(ctx);
}


/* The SIMD tables this CPU runs (lrr__hemi_simd_pick), four lanes first; returns how many. */
static int simd_tables(const lrr__hemi_simd *tab[2])
{
    int n = 0;
    if (lrr__cpu_supports(LRR__ISA_AVX2))
        tab[n++] = lrr__hemi_simd_pick(LRR__ISA_AVX2);
    if (lrr__cpu_supports(LRR__ISA_AVX512))
        tab[n++] = lrr__hemi_simd_pick(LRR__ISA_AVX512);
    return n;
}

/* leaves_run (lrr__hemi_simd: four or eight lanes, the cell table where its margin allows) gives
 * every pixel the leaf of the scalar path (clamp, then lrr__descend), also for barycentrics
 * on the grid's lines (dyadic coefficients with den = 1 put whole rows on them), outside the
 * triangle (clamped), with den crossing 0 and over runs whose ends leave lanes unused. The
 * table is built here independently, from the cells' corners' midpoints rather than their
 * centroids. */
static void test_leaves_run_exact(void **state)
{
    (void)state;
    const lrr__hemi_simd *tab[2];
    const int ntab = simd_tables(tab);
    if (!ntab)
        skip();
    enum { W = 64, D = 6 };
    double sxt[W];
    for (int x = 0; x < W; x++)
        sxt[x] = (x + 0.5) / (0.5 * W) - 1;
    uint64_t rng = 12345;
    size_t checked = 0, on_lines = 0;
    /* depths past the table's (D) descend without one, up to 16 (leaves up to 2^32 − 1) */
    for (unsigned d = 0; d <= 16; d += d < D ? 1 : 2) {
        const size_t s = (size_t)1 << d;
        uint16_t *cells = d <= D ? calloc(2 * s * s, sizeof *cells) : NULL;
        assert_true(d > D || cells);
        for (size_t i1 = 0; cells && i1 < s; i1++)
            for (size_t i2 = 0; i1 + i2 < s; i2++)
                for (int down = 0; down < 2 && i1 + i2 + down < s; down++) {
                    /* a point well inside: up cells near their corner (i1, i2), down cells
                     * near their corner (i1 + 1, i2 + 1) */
                    double b1 = (i1 + (down ? 0.8 : 0.2)) / s, b2 = (i2 + (down ? 0.8 : 0.2)) / s;
                    double b0 = 1 - b1 - b2;
                    cells[(i1 * s + i2) * 2 + down] = (uint16_t)lrr__descend(&b0, &b1, &b2, d);
                }
        for (int trial = 0; trial < 400; trial++) {
            double b1k[3], b2k[3], den[3] = {0, 0, 1};
            for (int j = 0; j < 3; j++) {
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                double u1 = (double)(rng >> 11) * 0x1p-53;
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                double u2 = (double)(rng >> 11) * 0x1p-53;
                if (trial % 2) { /* dyadic: many pixels exactly on lines */
                    b1k[j] = floor(u1 * 4 * s) / (4.0 * s) - (j == 2 ? 0 : 0.25);
                    b2k[j] = floor(u2 * 4 * s) / (4.0 * s) - (j == 2 ? 0 : 0.25);
                } else {
                    b1k[j] = u1 - (j == 2 ? 0 : 0.5);
                    b2k[j] = u2 - (j == 2 ? 0 : 0.5);
                }
            }
            if (trial % 4 == 2) { /* perspective: den varies, through 0 for some */
                den[0] = 0.7 * b1k[0];
                den[1] = -0.3;
                den[2] = 1 + 0.2 * b2k[1];
            }
            const double sy = (trial % 7) / 3.5 - 1 + 0.5 / W;
            const lrr__hemi_simd *simd = tab[(trial / 4) % ntab];
            const int a = trial % 5, b = W - 1 - trial % 7;
            uint32_t leaf[W], leaf_nt[W];
            uint64_t brk[(W + 63) / 64], brk_nt[(W + 63) / 64], want_brk[(W + 63) / 64];
            simd->leaves_run(b1k, b2k, den, sxt, sy, a, b, d, cells, leaf, brk);
            simd->leaves_run(b1k, b2k, den, sxt, sy, a, b, d, NULL, leaf_nt, brk_nt);
            /* the change masks: those of the codes as made */
            lrr__hemi_breaks((const int32_t *)leaf, b - a + 1, want_brk);
            assert_memory_equal(brk, want_brk, (size_t)(b - a + 64) / 64 * sizeof *brk);
            lrr__hemi_breaks((const int32_t *)leaf_nt, b - a + 1, want_brk);
            assert_memory_equal(brk_nt, want_brk, (size_t)(b - a + 64) / 64 * sizeof *brk);
            for (int x = a; x <= b; x++) {
                const double sx = sxt[x];
                const double r = 1.0 / (den[0] * sx + den[1] * sy + den[2]);
                double b0, b1 = (b1k[0] * sx + b1k[1] * sy + b1k[2]) * r,
                           b2 = (b2k[0] * sx + b2k[1] * sy + b2k[2]) * r;
                lrr__clamp_bary(&b1, &b2, &b0);
                double t1 = b1 * s, t2 = b2 * s;
                on_lines += t1 == floor(t1) || t2 == floor(t2);
                size_t want = lrr__descend(&b0, &b1, &b2, d);
                assert_int_equal(lrr__hemi_leaf_of(leaf[x - a], cells), want);
                assert_int_equal(leaf_nt[x - a], want);
                checked++;
            }
        }
        free(cells);
    }
    print_message("leaves_run: %zu pixels as the scalar path, %zu on a grid line\n", checked,
                  on_lines);
    assert_true(on_lines > checked / 20); /* the lines were exercised */
}

/* depth_span (four or eight lanes) writes exactly the scalar loop's depths and
 * ids (raster_tri): spans with unused lanes at their ends, pixels outside left alone, and
 * stored depths equal to the span's (a tie keeps the old) or one float below (it wins). One
 * edge function cancels to ~1e-9 of its terms, so a multiply and add fused into one rounding
 * (what gcc does to intrinsics when FMA is on) changes the float depth. */
/* depth_rows with leaf codes (lrr__hemi_codes): where it wins the depth test it
 * writes the code leaves_run gives that pixel (same plane, the face's sx and sy,
 * the cell table), and nothing where it loses; the integration's runs, hence F̄, depend on
 * those codes being the per-pixel ones. Random depths (about half the pixels won), planes
 * with perspective, leaf depths 1..6, top and side faces. */
static void test_depth_codes_exact(void **state)
{
    (void)state;
    const lrr__hemi_simd *tab[2];
    const int ntab = simd_tables(tab);
    if (!ntab)
        skip();
    enum { W = 48, H = 12, D = 6 };
    double sxt[W], syt[2][H];
    for (int x = 0; x < W; x++)
        sxt[x] = (x + 0.5) / (0.5 * W) - 1;
    for (int y = 0; y < H; y++) {
        syt[0][y] = (y + 0.5) / (0.5 * W) - 1;
        syt[1][y] = (y + 0.5) / (0.5 * W);
    }
    uint16_t *cells[D + 1];
    for (unsigned d = 1; d <= D; d++) { /* any table: the codes are its slots */
        const size_t s = (size_t)1 << d;
        cells[d] = calloc(2 * s * s, sizeof *cells[d]);
        assert_non_null(cells[d]);
    }
    uint64_t rng = 4242;
#define NEXT_U() (rng = rng * 6364136223846793005ull + 1442695040888963407ull, \
                  (double)(rng >> 11) * 0x1p-53)
    size_t won = 0, lost = 0, descended = 0;
    for (int trial = 0; trial < 600; trial++) {
        const unsigned d = 1 + trial % D;
        const lrr__hemi_simd *simd = tab[(trial / D) % ntab];
        const int side = trial % 2;
        lrr__hemi_codes lc;
        for (int j = 0; j < 3; j++) {
            const double slope = trial % 3 == 0 ? 1 : 0.1;
            lc.b1[j] = j == 2 ? 0.1 + 0.4 * NEXT_U() : (NEXT_U() - 0.5) * slope;
            lc.b2[j] = j == 2 ? 0.1 + 0.4 * NEXT_U() : (NEXT_U() - 0.5) * slope;
            lc.den[j] = j == 2 ? 1 : trial % 4 == 2 ? 0.6 * (NEXT_U() - 0.5) : 0;
        }
        lc.sxt = sxt;
        lc.syt = syt[side];
        lc.depth = d;
        uint32_t code[W * H];
        lc.code = code;
        double abc[9], iz[3];
        for (int j = 0; j < 9; j++)
            abc[j] = (NEXT_U() - 0.5) * 10;
        for (int j = 0; j < 3; j++)
            iz[j] = 0.2 + NEXT_U();
        float depth[W * H];
        int32_t item[W * H];
        int32_t span[2 * H];
        for (int j = 0; j < W * H; j++) {
            depth[j] = (float)(NEXT_U() * 0.5);
            item[j] = -1;
            code[j] = 0xdeadbeef;
        }
        for (int y = 0; y < H; y++) {
            span[2 * y] = (int)(NEXT_U() * 12);
            span[2 * y + 1] = W - 1 - (int)(NEXT_U() * 12) - (y == 3 ? W : 0); /* an empty row */
        }
        simd->depth_rows(abc, iz, 1.0, 0, H - 1, span, W, depth, item, 7, &lc);
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                const size_t j = (size_t)y * W + x;
                if (item[j] != 7) {
                    assert_int_equal(code[j], 0xdeadbeef);
                    lost += x >= span[2 * y] && x <= span[2 * y + 1];
                    continue;
                }
                uint32_t want;
                uint64_t brk;
                simd->leaves_run(lc.b1, lc.b2, lc.den, sxt, syt[side][y], x, x, d, cells[d],
                                 &want, &brk);
                assert_int_equal(code[j], want);
                descended += (want & LRR__LEAF_DESCENT) != 0;
                won++;
            }
    }
#undef NEXT_U
    for (unsigned d = 1; d <= D; d++)
        free(cells[d]);
    print_message("depth codes: %zu pixels won as leaves_run codes them (%zu "
                  "descended), %zu lost\n", won, descended, lost);
    assert_true(won > 10000 && lost > 10000 && descended > 0);
}

/* lrr__hemi_breaks, and every SIMD table's breaks2, against the definition: lengths
 * across word boundaries, changes at every position (random ids from a small set, so runs of
 * all lengths; codes that change inside runs and across them). */
static void test_breaks_exact(void **state)
{
    (void)state;
    enum { N = 300 };
    const lrr__hemi_simd *tab[2];
    const int ntab = simd_tables(tab);
    int32_t v[N];
    uint64_t rng = 99;
    for (int n = 1; n <= N; n += (n < 140 ? 1 : 37)) {
        for (int trial = 0; trial < 4; trial++) {
            for (int x = 0; x < n; x++) {
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                v[x] = (int32_t)(rng >> 61) - 2; /* -2..5: markers too */
            }
            for (int level = 0; level <= ntab; level++) { /* 0: the scalar loop alone */
                uint64_t mask[(N + 63) / 64 + 1];
                const int words = (n + 63) / 64;
                mask[words] = 0x5a5a; /* must stay: the function writes (n + 63)/64 words */
                lrr__hemi_breaks(v, n, mask);
                assert_int_equal(mask[words], 0x5a5a);
                for (int x = 0; x < words * 64; x++) {
                    const int want = x < n && (x == 0 || v[x] != v[x - 1]);
                    assert_int_equal((int)(mask[x >> 6] >> (x & 63) & 1), want);
                }
                if (level == 0)
                    continue;
                /* breaks2: v's breaks, and where v or u (codes) change */
                int32_t u[N];
                for (int x = 0; x < n; x++)
                    u[x] = (int32_t)((uint32_t)(v[x] * 7 + (x / 3) % 2) * 2654435761u);
                uint64_t mv[(N + 63) / 64 + 1], mu[(N + 63) / 64 + 1];
                mv[words] = mu[words] = 0x5a5a;
                tab[level - 1]->breaks2(v, u, n, mv, mu);
                assert_int_equal(mv[words], 0x5a5a);
                assert_int_equal(mu[words], 0x5a5a);
                for (int x = 0; x < words * 64; x++) {
                    const int bv = x < n && (x == 0 || v[x] != v[x - 1]);
                    const int bu = x < n && (x == 0 || v[x] != v[x - 1] || u[x] != u[x - 1]);
                    assert_int_equal((int)(mv[x >> 6] >> (x & 63) & 1), bv);
                    assert_int_equal((int)(mu[x >> 6] >> (x & 63) & 1), bu);
                }
            }
        }
    }
}

/* hemicube_raster.c's edge_setup (the canonical-order edge of a→b), copied: the edges
 * lrr__hemi_simd.spans gets. */
static void edge_of(const double a[2], const double b[2], int W, int H, lrr__hemi_edge *e)
{
    const int swap = (b[0] < a[0]) || (b[0] == a[0] && b[1] < a[1]);
    const double *p = swap ? b : a, *q = swap ? a : b;
    double A = -(q[1] - p[1]), B = q[0] - p[0];
    double C = -(A * p[0] + B * p[1]);
    if (swap) { A = -A; B = -B; C = -C; }
    e->A = A, e->B = B, e->C = C;
    const double dx = b[0] - a[0], dy = b[1] - a[1];
    e->owns_ties = dy > 0 || (dy == 0 && dx < 0);
    const double S = fabs(A) * W + fabs(B) * H + fabs(C), r = A != 0 ? 1 / A : 0;
    e->k0 = A != 0 ? -C * r - 0.5 : 0;
    e->k1 = A != 0 ? -B * r : 0;
    e->tol = A != 0 ? 16 * 0x1p-53 * S * fabs(r) + 0x1p-30 : INFINITY;
}

/* spans (lrr__hemi_simd) against the per-pixel test (every edge function > 0, or 0 on an edge the
 * triangle owns) at every pixel of the range, on rows it settles: random triangles, some
 * with vertices on the half-pixel grid (pixel centres on edges, horizontal edges: A = 0) and
 * beyond the screen (the guard band). */
static void test_spans_exact(void **state)
{
    (void)state;
    const lrr__hemi_simd *tab[2];
    const int ntab = simd_tables(tab);
    if (!ntab)
        skip();
    enum { W = 64, H = 64 };
    uint64_t rng = 777;
    size_t settled = 0, rows = 0, covered = 0, lefts = 0;
    for (int trial = 0; trial < 3000; trial++) {
        double v[3][2];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 2; j++) {
                rng = rng * 6364136223846793005ull + 1442695040888963407ull;
                const double u = (double)(rng >> 11) * 0x1p-53;
                v[i][j] = trial % 3 == 0 ? floor(u * 2 * W) / 2 : (u * 1.6 - 0.3) * W;
            }
        if (trial % 5 == 1)
            v[1][1] = v[0][1]; /* a horizontal edge */
        double area = (v[1][0] - v[0][0]) * (v[2][1] - v[0][1]) -
                      (v[1][1] - v[0][1]) * (v[2][0] - v[0][0]);
        if (area == 0)
            continue;
        if (area < 0) { /* positively oriented, as raster_tri makes them */
            for (int j = 0; j < 2; j++) {
                const double t = v[1][j];
                v[1][j] = v[2][j], v[2][j] = t;
            }
        }
        lrr__hemi_edge e[3];
        edge_of(v[1], v[2], W, H, &e[0]);
        edge_of(v[2], v[0], W, H, &e[1]);
        edge_of(v[0], v[1], W, H, &e[2]);
        const int x0 = trial % 4, x1 = W - 1 - trial % 3, y0 = trial % 7, y1 = H - 1 - trial % 5;
        int32_t span[2 * H];
        /* every SIMD level: AVX2 four rows at a time, AVX-512 eight */
        const int left = tab[trial % ntab]->spans(e, x0, x1, y0, y1, span);
        int any = 0; /* it says whether it left rows to the caller */
        for (int y = y0; y <= y1; y++)
            any |= span[2 * (y - y0)] == INT32_MIN;
        assert_int_equal(left != 0, any);
        lefts += any;
        for (int y = y0; y <= y1; y++) {
            rows++;
            const int32_t L = span[2 * (y - y0)], R = span[2 * (y - y0) + 1];
            if (L == INT32_MIN)
                continue;
            settled++;
            const double py = y + 0.5;
            for (int x = x0; x <= x1; x++) {
                const double px = x + 0.5;
                int in = 1;
                for (int k = 0; k < 3; k++) {
                    const double f = e[k].A * px + e[k].B * py + e[k].C;
                    in &= f > 0 || (f == 0 && e[k].owns_ties);
                }
                covered += in;
                assert_int_equal(in, x >= L && x <= R);
            }
        }
    }
    print_message("spans: %zu of %zu rows settled, %zu pixels covered, %zu calls left rows\n",
                  settled, rows, covered, lefts);
    assert_true(settled > rows / 2 && covered > 0 && lefts > 0 && lefts < 3000);
}

static void test_depth_span_exact(void **state)
{
    (void)state;
    const lrr__hemi_simd *tab[2];
    const int ntab = simd_tables(tab);
    if (!ntab)
        skip();
    enum { W = 40 };
    uint64_t rng = 777;
    size_t writes = 0, ties = 0;
    for (int trial = 0; trial < 4000; trial++) {
        double u[12];
        for (int j = 0; j < 12; j++) {
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            u[j] = (double)(rng >> 11) * 0x1p-53;
        }
        const double py = trial % 16 + 0.5, px0 = (trial % W) + 0.5;
        double abc[9], iz[3] = {0.5 + u[9], 0, 0};
        for (int j = 0; j < 9; j++)
            abc[j] = (u[j] - 0.5) * 1000;
        abc[2] = -(abc[0] * px0 + abc[1] * py) * (1 + 1e-9 * (u[10] - 0.5));
        if (trial % 2) { /* all three edges */
            iz[1] = 0.3 + u[10];
            iz[2] = 0.2 + u[11];
        }
        const double inv_area = 1 / (0.5 + u[11]);
        const lrr__hemi_simd *simd = tab[(trial / 2) % ntab];
        const int L = trial % 9, R = W - 1 - trial % 11;
        float depth[W], want_d[W];
        int32_t item[W], want_i[W];
        for (int x = 0; x < W; x++) {
            const double px = x + 0.5;
            double w[3];
            for (int k = 0; k < 3; k++)
                w[k] = abc[3 * k] * px + abc[3 * k + 1] * py + abc[3 * k + 2];
            const float z = (float)((w[0] * iz[0] + w[1] * iz[1] + w[2] * iz[2]) * inv_area);
            depth[x] = x % 3 == 0 ? z : x % 3 == 1 ? nextafterf(z, -INFINITY) : -z;
            item[x] = -1;
            want_d[x] = depth[x];
            want_i[x] = -1;
            if (x >= L && x <= R && z > depth[x]) {
                want_d[x] = z;
                want_i[x] = 7;
                writes++;
            }
            ties += x >= L && x <= R && x % 3 == 0;
        }
        /* the same row through depth_rows, at its height in a face, with an empty
         * row after it that must stay as it is */
        const int y = trial % 16;
        float fd[17 * W];
        int32_t fi[17 * W];
        for (int j = 0; j < 17 * W; j++)
            fd[j] = j % W == 0 ? -1.0f : 2.0f, fi[j] = -5;
        memcpy(fd + y * W, depth, sizeof depth);
        memcpy(fi + y * W, item, sizeof item);
        const int32_t span[4] = {L, R, 1, 0};
        simd->depth_rows(abc, iz, inv_area, y, y + 1, span, W, fd, fi, 7, NULL);
        simd->depth_span(abc, iz, inv_area, py, L, R, depth, item, 7);
        assert_memory_equal(depth, want_d, sizeof depth);
        assert_memory_equal(item, want_i, sizeof item);
        assert_memory_equal(fd + y * W, want_d, sizeof depth);
        assert_memory_equal(fi + y * W, want_i, sizeof item);
        for (int j = 0; j < 17 * W; j++)
            if (j / W != y) {
                assert_true(fd[j] == (j % W == 0 ? -1.0f : 2.0f));
                assert_int_equal(fi[j], -5);
            }
    }
    assert_true(writes > 1000 && ties > 1000);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_multiplier_map),
        cmocka_unit_test(test_point_to_disk),
        cmocka_unit_test(test_closed_forms),
        cmocka_unit_test(test_reproducible),
        cmocka_unit_test(test_back_face_share),
        cmocka_unit_test(test_leaves_run_exact),
        cmocka_unit_test(test_depth_span_exact),
        cmocka_unit_test(test_depth_codes_exact),
        cmocka_unit_test(test_breaks_exact),
        cmocka_unit_test(test_spans_exact),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
