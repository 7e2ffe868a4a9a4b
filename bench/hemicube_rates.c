/*
 * lrr-bench hemicube --rates: hemicubes per second of the Cornell build that issue-level
 * goals are stated on (216 patches, d = 16, n = 3456), per resolution and thread count, the
 * form-factor phase alone (lrr_operator_info.formfactor_seconds) over repeated builds.
 */
#include <errno.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

static int cmp_double(const void *a, const void *b)
{
    const double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* builds builds at (R, threads) into seconds[] (sorted); 0 or a reported failure */
static int rate_runs(lrr_context *ctx, lrr_scene *scene, unsigned R, int threads,
                     unsigned builds, double *seconds, size_t *n)
{
    for (unsigned b = 0; b < builds; b++) {
        lrr_build_options bo = {.hemicube_resolution = R, .threads = threads};
        lrr_operator *op = NULL;
        cli_idle_openblas(); /* the last build's SMW left OpenBLAS's workers spinning */
        lrr_status s = lrr_operator_build(scene, &bo, &op);
        if (s != LRR_OK)
            return bench_lib_fail(ctx, s, "Cornell box build");
        lrr_operator_info info;
        lrr_operator_get_info(op, &info, sizeof info);
        seconds[b] = info.formfactor_seconds;
        *n = info.n;
        lrr_operator_destroy(op);
    }
    qsort(seconds, builds, sizeof *seconds, cmp_double);
    return 0;
}

/* The table's rows (R, then 1 and all threads), also into csv when it is not NULL. */
static int rates_table(lrr_context *ctx, lrr_scene *scene, unsigned builds, int quick,
                       FILE *csv)
{
    static const unsigned full_res[] = {32, 64, 128}, quick_res[] = {16, 32};
    const unsigned *res = quick ? quick_res : full_res;
    const size_t n_res = 3 - (size_t)quick;
    const int max_threads = omp_get_max_threads();
    const int threads[2] = {1, max_threads};
    const int n_threads = max_threads > 1 ? 2 : 1;
    double sec[99]; /* --builds <= 99 */
    if (csv)
        fputs("R,threads,n,builds,seconds_min,seconds_median,seconds_max,"
              "hemicubes_per_s_median,hemicubes_per_s_best\n",
              csv);
    printf("\n%5s %7s %7s %10s %10s %10s %14s %12s\n", "R", "threads", "n", "s_min", "s_median",
           "s_max", "per_s_median", "per_s_best");
    for (size_t i = 0; i < n_res; i++)
        for (int t = 0; t < n_threads; t++) {
            size_t n = 0;
            bench_note("R = %u, %d thread%s, %u builds", res[i], threads[t],
                       threads[t] > 1 ? "s" : "", builds);
            int rc = rate_runs(ctx, scene, res[i], threads[t], builds, sec, &n);
            if (rc)
                return rc;
            const double med = sec[builds / 2];
            printf("%5u %7d %7zu %10.4f %10.4f %10.4f %14.0f %12.0f\n", res[i], threads[t], n,
                   sec[0], med, sec[builds - 1], (double)n / med, (double)n / sec[0]);
            fflush(stdout);
            if (csv)
                fprintf(csv, "%u,%d,%zu,%u,%.6g,%.6g,%.6g,%.6g,%.6g\n", res[i], threads[t], n,
                        builds, sec[0], med, sec[builds - 1], (double)n / med,
                        (double)n / sec[0]);
        }
    return CLI_EXIT_OK;
}

int hemicube_rates(const char *csv, unsigned builds, int quick)
{
    if (builds < 1 || builds > 99)
        return bench_fail("--builds %u: must be 1..99", builds);
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return bench_lib_fail(NULL, s, "context");
    lrr_scene *scene = NULL;
    if ((s = lrr_scene_builtin(ctx, "cornell", &scene)) == LRR_OK)
        s = lrr_scene_subdivide(scene, &(lrr_subdivision){.target_patches = 216, .levels = 2});
    int rc = s == LRR_OK ? CLI_EXIT_OK : bench_lib_fail(ctx, s, "Cornell box");
    cli_outfile out;
    if (rc == CLI_EXIT_OK && csv && cli_outfile_open(&out, csv) != 0)
        rc = bench_fail("cannot create a temporary file for '%s': %s", csv, strerror(errno));
    if (rc == CLI_EXIT_OK) {
        printf("benchmark: hemicube rates\n");
        bench_print_machine();
        printf("scene: cornell, 216 patches, levels 2 (as 'lrr preprocess cornell --patches "
               "216 --levels 2 --hemicube R --threads T')\n");
        printf("builds: %u per row; seconds = formfactor_seconds (the hemicubes alone)\n",
               builds);
        rc = rates_table(ctx, scene, builds, quick, csv ? out.f : NULL);
        if (csv)
            rc = bench_csv_finish(&out, rc, csv);
    }
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}
