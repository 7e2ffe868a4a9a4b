/* Vᵀ's weights for clusters (lib/operator/weights.c, docs/METHOD.md "Clusters"): the power
 * all receivers gather from a cluster, against a closed form on an open scene; the exact
 * limit; the weights through a file, and a version-3 file's area weights. */
#include "testutil.h"

#include "formfactor/formfactor.h"
#include "operator/operator.h"
#include "formfactor/closed_forms.h"

/* Scene values are floats (positions, normals, areas, rho, E) from a few float
 * operations each (a cross product and its normalisation: 5 roundings), k = 2. */
#define FLOAT_TOL TU_TOL_FLT(2, 5)

/* An open scene whose one non-emitting cluster mixes a floor that sees the lamp with a sill
 * that sees only the sky: floor [0,1]² at z = 0 facing up, lamp [0,1]² at z = 0.5 facing
 * down (emits 1, reflects 0.5), sill [1.5,2.5]×[0,1] at z = 0.5 facing up (nothing above
 * it). The operator is built here on the grouping {lamp}, {floor, sill} (grouped), which
 * the cluster selection gives too where the normal rule alone decides. */
#define H 0.5
static lrr_scene *open_scene(lrr_context *ctx)
{
    float v[54], rho[18], em[18];
    const double f0[3] = {0, 0, 0}, f1[3] = {1, 0, 0}, f2[3] = {1, 1, 0}, f3[3] = {0, 1, 0};
    const double l0[3] = {0, 0, H}, l1[3] = {0, 1, H}, l2[3] = {1, 1, H}, l3[3] = {1, 0, H};
    const double s0[3] = {1.5, 0, H}, s1[3] = {2.5, 0, H}, s2[3] = {2.5, 1, H},
                 s3[3] = {1.5, 1, H};
    tu_quad(v, f0, f1, f2, f3);
    tu_quad(v + 18, l0, l1, l2, l3);
    tu_quad(v + 36, s0, s1, s2, s3);
    for (int t = 0; t < 6; t++)
        for (int c = 0; c < 3; c++) {
            rho[3 * t + c] = 0.5f;
            em[3 * t + c] = t == 2 || t == 3 ? 1.0f : 0.0f;
        }
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_create(ctx, 6, v, rho, em, "open scene", &s));
    lrr_subdivision sd = {.max_patch_area = 1.0 / 32};
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &sd));
    return s;
}

static lrr_build_options opts(size_t K)
{
    lrr_build_options o = lrr_build_options_defaults();
    o.hemicube_resolution = 128;
    o.seed = 2;
    o.receiver_sampling = LRR_RECEIVER_AREA; /* the area-averaged F of the closed form */
    o.adaptive_patches = K;
    o.hierarchy = LRR_HIERARCHY_CLUSTER;
    return o;
}

/* The operator on two clusters, the emitters and the rest, with visibility weights: what
 * lrr_operator_build does after the selection. */
static lrr_operator *grouped(lrr_context *ctx, const lrr_scene *s, unsigned R)
{
    const lrr__geometry *sg = &s->geom;
    const size_t n = sg->n;
    float *rho = malloc(n * 3 * sizeof(float)), *em = malloc(n * 3 * sizeof(float));
    size_t *origin = malloc(n * sizeof(size_t)), first[3] = {0, 0, n}, m = 0;
    LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, rho, em));
    for (int pass = 0; pass < 2; pass++)
        for (size_t j = 0; j < n; j++)
            if ((em[3 * j] > 0) == (pass == 0))
                origin[m++] = j;
    for (size_t j = 0; j < n; j++)
        first[1] += em[3 * j] > 0;
    lrr__geometry g;
    LRR_CHECK(ctx, lrr__geometry_clusters(ctx, sg, origin, first, 2, "test", LRR_ERR_INVALID_ARG,
                                          &g));
    lrr_operator *op;
    LRR_CHECK(ctx, lrr__operator_new(ctx, &g, LRR_STORAGE_F32, &op));
    lrr__geometry_free(&g);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            op->rho[3 * i + c] = rho[3 * origin[i] + c];
            op->emission[3 * i + c] = em[3 * origin[i] + c];
        }
    lrr_build_options o = opts(2);
    o.hemicube_resolution = R;
    op->weighting = LRR__WEIGHTS_VISIBILITY;
    op->hemicube_resolution = R;
    LRR_CHECK(ctx, lrr__hemicube_fbar(ctx, &op->geom, &o, op->fbar, NULL));
    LRR_CHECK(ctx, lrr__smw_factor(op));
    free(rho);
    free(em);
    free(origin);
    return op;
}

/* Σ_i A_i (F̄ Vᵀ b)_i restricted to patch p's columns: the power all receivers gather from p
 * in the model for the radiosity b (n), with the weights w. */
static double model_power(const lrr_operator *op, const float *w, size_t p, const double *b)
{
    double bbar = 0, gather = 0;
    for (size_t j = op->geom.first[p]; j < op->geom.first[p + 1]; j++)
        bbar += w[j] * b[j];
    float *row = malloc(op->k * sizeof(float));
    for (size_t i = 0; i < op->n; i++) {
        lrr_operator_fbar_row(op, i, row);
        gather += op->area[i] * row[p];
    }
    free(row);
    return gather * bbar;
}

/* Σ_{j∈p} A_j R_j b_j, R_j = Σ_q F̄_jq d_q: what the receivers gather from p by reciprocity. */
static double exact_power(const lrr_operator *op, size_t p, const double *b)
{
    double sum = 0;
    float *row = malloc(op->k * sizeof(float));
    for (size_t j = op->geom.first[p]; j < op->geom.first[p + 1]; j++) {
        lrr_operator_fbar_row(op, j, row);
        double R = 0;
        for (size_t q = 0; q < op->k; q++)
            R += (double)row[q] * (double)lrr__patch_size(&op->geom, q);
        sum += op->area[j] * R * b[j];
    }
    free(row);
    return sum;
}

static void test_open_scene_power(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = open_scene(ctx);
    lrr_operator *op = grouped(ctx, s, 128);
    const size_t p = 1; /* the floor-and-sill cluster */
    double *b = malloc(op->n * sizeof(double)), floor_area = 0, sill_area = 0;
    float *area_w = malloc(op->n * sizeof(float));
    lrr__patch_weights(&op->geom, area_w);
    srand(7);
    for (size_t j = op->geom.first[p]; j < op->geom.first[p + 1]; j++) {
        const int sill = op->centre[3 * j + 2] > 0.25f;
        (sill ? &sill_area : &floor_area)[0] += op->area[j];
        if (sill) /* nothing above the sill: R_j = 0, and so its weight */
            assert_true(op->weight[j] == 0.0f);
    }
    ASSERT_NEAR(floor_area, 1.0, FLOAT_TOL, "floor\n");
    ASSERT_NEAR(sill_area, 1.0, FLOAT_TOL, "sill\n");
    /* the closed form: the receivers (the lamp) gather A_floor F_floor→lamp B̄_floor from the
     * cluster, for any radiosity of the floor and the sill */
    const double F = parallel_closed_form(1 / H, 1 / H);
    for (int trial = 0; trial < 3; trial++) {
        /* a lit floor and a dark sill (as light would leave them), a random floor and a dark
         * sill, random with the floor brighter: B and R correlate in the cluster */
        for (size_t j = 0; j < op->n; j++) {
            const int sill = op->centre[3 * j + 2] > 0.25f;
            const double r = (double)rand() / RAND_MAX;
            b[j] = trial == 0 ? !sill : trial == 1 ? (sill ? 0 : r) : r + !sill;
        }
        double fsum = 0;
        for (size_t j = op->geom.first[p]; j < op->geom.first[p + 1]; j++)
            if (op->centre[3 * j + 2] < 0.25f)
                fsum += op->area[j] * b[j];
        /* the truth: the closed form where the floor is uniform (trial 0), else by
         * reciprocity Σ_j A_j R_j b_j (R_j varies over the floor: less at its edges) */
        const double truth = trial == 0 ? F * fsum : exact_power(op, p, b);
        const double model = model_power(op, op->weight, p, b);
        const double area_model = model_power(op, area_w, p, b);
        print_message("trial %d: power from the cluster: %s %.5f, visibility weights %.5f "
                      "(%+.1e), area weights %.5f (%+.1e)\n", trial,
                      trial == 0 ? "closed form" : "reciprocity", truth, model,
                      model / truth - 1, area_model, area_model / truth - 1);
        /* the hemicubes' sampling noise (R 128 over 32 receivers a square): 1% */
        ASSERT_NEAR(model, truth, 0.01 * truth, "visibility weights, trial %d\n", trial);
        assert_true(fabs(area_model / truth - 1) > 0.2); /* area weights lose the light */
    }
    free(b);
    free(area_w);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* The lamp's second bounce (the light the floor returns to it) against the direct solve of
 * the full F from the same hemicubes: the model keeps it, area weights halve it. */
static double lamp_reflected(const lrr_operator *op, const float *B)
{
    double sum = 0;
    for (size_t i = 0; i < op->n; i++)
        if (op->emission[3 * i] > 0)
            sum += op->area[i] * (B[3 * i] - op->emission[3 * i]);
    return sum;
}

static void test_open_scene_bounce(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = open_scene(ctx);
    lrr_operator *op = grouped(ctx, s, 128);
    float *B = malloc(op->n * 3 * sizeof(float)), *Bf = malloc(op->n * 3 * sizeof(float));
    lrr_solver *sv;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, B));
    lrr_solver_destroy(sv);
    lrr_build_options fo = opts(2); /* the full F of the same hemicubes, scene order */
    fo.adaptive_patches = 0;
    fo.hierarchy = LRR_HIERARCHY_QUADTREE;
    lrr_reference *ref;
    LRR_CHECK(ctx, lrr_reference_build(s, &fo, 0, &ref));
    float *Bs = malloc(op->n * 3 * sizeof(float));
    LRR_CHECK(ctx, lrr_reference_solve(ref, LRR_METHOD_DIRECT, 0, 0,
                                       lrr_reference_emission(ref), Bs, NULL, 0));
    for (size_t i = 0; i < op->n; i++) /* into the operator's order */
        for (int c = 0; c < 3; c++)
            Bf[3 * i + c] = Bs[3 * op->geom.origin[i] + c];
    const double model = lamp_reflected(op, B), exact = lamp_reflected(op, Bf);
    /* the same operator with area weights */
    op->weighting = LRR__WEIGHTS_AREA;
    lrr__patch_weights(&op->geom, op->weight);
    LRR_CHECK(ctx, lrr__smw_factor(op));
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &sv));
    LRR_CHECK(ctx, lrr_solve(sv, op->emission, B));
    lrr_solver_destroy(sv);
    const double area_model = lamp_reflected(op, B);
    print_message("light the lamp gets back: model %.6f, full F %.6f (%+.2e); with area "
                  "weights %.6f (%+.2e)\n", model, exact, model / exact - 1, area_model,
                  area_model / exact - 1);
    /* the floor's radiosity varies over it (brighter under the lamp's middle): what the
     * model's one mean per cluster still misses; area weights halve it (the dark sill) */
    ASSERT_NEAR(model, exact, 0.05 * exact, "second bounce\n");
    assert_true(area_model < 0.6 * exact);
    lrr_reference_destroy(ref);
    free(B);
    free(Bf);
    free(Bs);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Every subpatch its own cluster: each weight is exactly 1 (and the operator exact). */
static void test_exact_limit(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = open_scene(ctx);
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    lrr_build_options o = opts(si.subpatches);
    o.hemicube_resolution = 32;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    assert_int_equal(op->k, op->n);
    for (size_t i = 0; i < op->n; i++)
        assert_true(op->weight[i] == 1.0f);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

/* Saved and loaded (version 4, or 5 with F̄ as strips), the weights are recomputed bit for bit
 * from the stored F̄; an operator with area weights is written as version 3 (or 5) and loads
 * with them. */
static void test_file_versions(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *s = open_scene(ctx);
    lrr_build_options o = opts(3);
    o.hemicube_resolution = 32;
    lrr_operator *op, *back;
    LRR_CHECK(ctx, lrr_operator_build(s, &o, &op));
    char path[4096];
    tu_tmp_path(path, sizeof path, "test_weights"); /* in the test's scratch directory */
    for (int version = 4; version >= 3; version--) {
        if (version == 3) { /* the area weights and the M they give */
            op->weighting = LRR__WEIGHTS_AREA;
            lrr__patch_weights(&op->geom, op->weight);
            LRR_CHECK(ctx, lrr__smw_factor(op));
        }
        /* F̄ dense: the version says the weights; as strips (version 5): INFO's bit 2 */
        for (int sparse = 0; sparse < 2; sparse++) {
            LRR_CHECK(ctx, lrr_operator_save_fbar(op, path,
                                                  sparse ? LRR_FBAR_SPARSE : LRR_FBAR_DENSE));
            FILE *f = fopen(path, "rb");
            unsigned char h[12];
            assert_int_equal(fread(h, 1, 12, f), 12);
            fclose(f);
            assert_int_equal(h[8], sparse ? 5 : version);
            LRR_CHECK(ctx, lrr_operator_load(ctx, path, &back));
            assert_int_equal(back->weighting, op->weighting);
            assert_memory_equal(back->weight, op->weight, op->n * sizeof(float));
            assert_memory_equal(back->m, op->m, 3 * op->k * op->k * sizeof(float));
            lrr_operator_destroy(back);
        }
    }
    unlink(path);
    lrr_operator_destroy(op);
    lrr_scene_destroy(s);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_open_scene_power),
        cmocka_unit_test(test_open_scene_bounce),
        cmocka_unit_test(test_exact_limit),
        cmocka_unit_test(test_file_versions),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
