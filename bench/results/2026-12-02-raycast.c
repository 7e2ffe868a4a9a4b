/* Hemicubes per second, raster against raycast, on the Cornell box tessellated into
 * T = 36·4^L input triangles (each triangle's level-L quadtree cells become triangles).
 * Built by hand against the static library (see 2026-12-02-raycast.md); times 512
 * receivers spread over the scene with lrr__hemicube_sample_rows (full-F columns), best of
 * 3, each method in turn. Arguments: [max L (4)] [min L (0)] [one R (both 64 and 128)]. */
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>

#include "lrr.h"
#include "formfactor/formfactor.h"
#include "scene/scene.h"

static lrr_scene *tessellated(lrr_context *ctx, unsigned L)
{
    lrr_scene *s = NULL;
    lrr_subdivision sd = {.max_patch_area = 1e30, .levels = L};
    if (lrr_scene_cornell_box(ctx, 0, &s) != LRR_OK || lrr_scene_subdivide(s, &sd) != LRR_OK) {
        fprintf(stderr, "rc_bench: cannot subdivide the Cornell box (L = %u)\n", L);
        exit(1);
    }
    const lrr__geometry *g = &s->geom;
    size_t T = g->n;
    float *v = malloc(T * 9 * sizeof(float)), *rho = malloc(T * 3 * sizeof(float)),
          *em = calloc(T * 3, sizeof(float));
    for (size_t i = 0; i < T; i++) {
        double w[9];
        lrr__subpatch_vertices(g, i, w);
        for (int j = 0; j < 9; j++)
            v[9 * i + j] = (float)w[j];
        for (int c = 0; c < 3; c++)
            rho[3 * i + c] = 0.5f;
    }
    lrr_scene *t = NULL;
    lrr_subdivision sd0 = {.max_patch_area = 1e30, .levels = 0};
    if (lrr_scene_create(ctx, T, v, rho, em, "tess", &t) != LRR_OK ||
        lrr_scene_subdivide(t, &sd0) != LRR_OK) {
        fprintf(stderr, "rc_bench: cannot build the tessellated scene (T = %zu)\n", T);
        exit(1);
    }
    lrr_scene_destroy(s);
    free(v);
    free(rho);
    free(em);
    return t;
}

int main(int argc, char **argv)
{
    unsigned maxL = argc > 1 ? (unsigned)atoi(argv[1]) : 4;
    unsigned minL = argc > 2 ? (unsigned)atoi(argv[2]) : 0;
    lrr_context *ctx;
    if (lrr_context_create(&ctx) != LRR_OK)
        return 1;
    printf("T,R,threads,raster_per_s,raycast_per_s,ratio\n");
    for (unsigned L = minL; L <= maxL; L++) {
        lrr_scene *s = tessellated(ctx, L);
        const lrr__geometry *g = &s->geom;
        enum { COUNT = 512 };
        size_t rows[COUNT];
        for (size_t r = 0; r < COUNT; r++)
            rows[r] = (r * 7919) % g->n;
        float *out = malloc((size_t)COUNT * g->n * sizeof(float));
        unsigned Rs[2] = {64, 128};
        if (argc > 3) /* one resolution only */
            Rs[0] = Rs[1] = (unsigned)atoi(argv[3]);
        for (int ri = 0; ri < (argc > 3 ? 1 : 2); ri++)
            for (int th = 1; th <= 2; th++) {
                double rate[2];
                for (int m = 1; m <= 2; m++) {
                    lrr_build_options o = lrr_build_options_defaults();
                    o.hemicube_resolution = Rs[ri];
                    o.threads = th;
                    o.seed = 1;
                    o.formfactor_method = m;
                    double best = 1e30;
                    for (int rep = 0; rep < 3; rep++) {
                        double t0 = omp_get_wtime();
                        if (lrr__hemicube_sample_rows(ctx, g, &o, rows, COUNT, out)) {
                            fprintf(stderr, "failed\n");
                            return 1;
                        }
                        double t = omp_get_wtime() - t0;
                        best = t < best ? t : best;
                    }
                    rate[m - 1] = COUNT / best;
                }
                printf("%zu,%u,%d,%.0f,%.0f,%.2f\n", g->n_tri, Rs[ri], th, rate[0], rate[1],
                       rate[1] / rate[0]);
                fflush(stdout);
            }
        free(out);
        lrr_scene_destroy(s);
    }
    lrr_context_destroy(ctx);
    return 0;
}
