/*
 * A minimal lrr program: preprocess the Cornell box, save the operator, load it back,
 * solve for the box's own light and sanity-check the result.
 *
 *   cc cornell_example.c $(pkg-config --cflags --libs lrr) -o cornell_example
 *   ./cornell_example cornell.lrr
 *
 * Exits 0 when the radiosity is finite and B >= E everywhere (light only adds up).
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <lrr.h>

/* Prints the failed call with the library's message and returns 1. */
static int fail(lrr_context *ctx, const char *what, lrr_status s)
{
    char msg[512] = "";
    lrr_context_last_error(ctx, msg, sizeof msg);
    fprintf(stderr, "cornell_example: %s: %s: %s\n", what, lrr_strerror(s), msg);
    return 1;
}

/* Finite everywhere, and B >= E up to float rounding: reflection only adds light
 * (M = (I - A)^-1 with A >= 0 has no negative entries). Prints a summary; returns 0 or 1. */
static int check(const lrr_operator_info *info, const float *e, const float *area,
                 const float *b)
{
    double emax = 0.0;
    for (size_t i = 0; i < 3 * info->n; i++)
        if (e[i] > emax)
            emax = e[i];
    double tol = 1e-5 * (emax > 1.0 ? emax : 1.0);
    double mean[3] = {0, 0, 0}, total = 0.0;
    for (size_t i = 0; i < info->n; i++) {
        for (int c = 0; c < 3; c++) {
            double bi = b[3 * i + c], ei = e[3 * i + c];
            if (!isfinite(bi) || bi < ei - tol) {
                fprintf(stderr, "cornell_example: subpatch %zu channel %d: B = %g < E = %g\n",
                        i, c, bi, ei);
                return 1;
            }
            mean[c] += area[i] * bi;
        }
        total += area[i];
    }
    printf("cornell_example: n = %zu, k = %zu, d = %zu, mean B = (%.4g, %.4g, %.4g): ok\n",
           info->n, info->k, info->d, mean[0] / total, mean[1] / total, mean[2] / total);
    return 0;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: %s OUTPUT.lrr\n", argv[0]);
        return 2;
    }
    if (lrr_version() != LRR_VERSION) {
        fprintf(stderr, "cornell_example: header %s, library %s\n", LRR_VERSION_STRING,
                lrr_version_string());
        return 1;
    }

    lrr_context *ctx = NULL;
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL, *loaded = NULL;
    lrr_solver *solver = NULL;
    float *b = NULL;
    int rc = 1;
    lrr_status s;
    lrr_operator_info info;
    /* ~60 patches, each split once (d = 4); a 64×64 hemicube: small enough for a test. */
    lrr_subdivision sub = {.max_patch_area = 0.0, .target_patches = 60, .levels = 1};
    /* option structs carry their size: start from the defaults (or designated initialisers) */
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 64;
    bo.seed = 1;

    if ((s = lrr_context_create(&ctx)) != LRR_OK) {
        fprintf(stderr, "cornell_example: %s\n", lrr_strerror(s));
        return 1;
    }

    /* 1. Geometry: the built-in Cornell box, subdivided into patches and subpatches. */
    if ((s = lrr_scene_cornell_box(ctx, 0, &scene)) != LRR_OK) {
        rc = fail(ctx, "lrr_scene_cornell_box", s);
        goto done;
    }
    if ((s = lrr_scene_subdivide(scene, &sub)) != LRR_OK) {
        rc = fail(ctx, "lrr_scene_subdivide", s);
        goto done;
    }

    /* 2. Preprocess once: hemicube form factors and the k×k matrices; save to a file. */
    if ((s = lrr_operator_build(scene, &bo, &op)) != LRR_OK) {
        rc = fail(ctx, "lrr_operator_build", s);
        goto done;
    }
    if ((s = lrr_operator_save(op, argv[1])) != LRR_OK) {
        rc = fail(ctx, "lrr_operator_save", s);
        goto done;
    }

    /* 3. Later (another run, another program): load and solve for any emission. */
    if ((s = lrr_operator_load(ctx, argv[1], &loaded)) != LRR_OK) {
        rc = fail(ctx, "lrr_operator_load", s);
        goto done;
    }
    lrr_operator_get_info(loaded, &info, sizeof info);
    if (info.n == 0 || info.n > SIZE_MAX / (3 * sizeof *b) ||
        !(b = malloc(info.n * 3 * sizeof *b))) {
        fprintf(stderr, "cornell_example: cannot allocate %zu radiosities\n", info.n);
        goto done;
    }
    if ((s = lrr_solver_create(loaded, LRR_BACKEND_CPU, &solver)) != LRR_OK) {
        rc = fail(ctx, "lrr_solver_create", s);
        goto done;
    }
    /* The emission saved with the operator: the Cornell light. Any E >= 0 would do. */
    if ((s = lrr_solve(solver, lrr_operator_emission(loaded), b)) != LRR_OK) {
        rc = fail(ctx, "lrr_solve", s);
        goto done;
    }

    /* 4. Check and summarise. */
    rc = check(&info, lrr_operator_emission(loaded), lrr_operator_area(loaded), b);

done:
    free(b);
    lrr_solver_destroy(solver);
    lrr_operator_destroy(loaded);
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}
