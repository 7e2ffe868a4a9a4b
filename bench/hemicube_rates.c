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
            return lib_fail(ctx, s, "Cornell box build");
        lrr_operator_info info;
        lrr_operator_get_info(op, &info, sizeof info);
        seconds[b] = info.formfactor_seconds;
        *n = info.n;
        lrr_operator_destroy(op);
    }
    qsort(seconds, builds, sizeof *seconds, cmp_double);
    return 0;
}

int hemicube_rates(const char *csv, unsigned builds, int quick)
{
    static const unsigned full_res[] = {32, 64, 128}, quick_res[] = {16, 32};
    const unsigned *res = quick ? quick_res : full_res;
    const size_t n_res = 3 - (size_t)quick;
    const int max_threads = omp_get_max_threads();
    const int threads[2] = {1, max_threads};
    const int n_threads = max_threads > 1 ? 2 : 1;

    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return lib_fail(NULL, s, "context");
    lrr_scene *scene = NULL;
    if ((s = lrr_scene_builtin(ctx, "cornell", &scene)) == LRR_OK)
        s = lrr_scene_subdivide(scene, &(lrr_subdivision){.target_patches = 216, .levels = 2});
    if (s != LRR_OK) {
        int rc = lib_fail(ctx, s, "Cornell box");
        lrr_scene_destroy(scene);
        lrr_context_destroy(ctx);
        return rc;
    }
    printf("benchmark: hemicube rates\n");
    print_machine();
    printf("scene: cornell, 216 patches, levels 2 (as 'lrr preprocess cornell --patches 216 "
           "--levels 2 --hemicube R --threads T')\n");
    printf("builds: %u per row; seconds = formfactor_seconds (the hemicubes alone)\n", builds);
    cli_outfile out;
    int have_out = 0, rc = CLI_EXIT_OK;
    if (csv) {
        if (cli_outfile_open(&out, csv) != 0) {
            rc = bench_fail("cannot create a temporary file for '%s': %s", csv,
                            strerror(errno));
            goto done;
        }
        have_out = 1;
        fputs("R,threads,n,builds,seconds_min,seconds_median,seconds_max,"
              "hemicubes_per_s_median,hemicubes_per_s_best\n",
              out.f);
    }
    printf("\n%5s %7s %7s %10s %10s %10s %14s %12s\n", "R", "threads", "n", "s_min", "s_median",
           "s_max", "per_s_median", "per_s_best");
    double *sec = malloc(builds * sizeof *sec);
    if (!sec) {
        rc = bench_fail("out of memory");
        goto done;
    }
    for (size_t i = 0; i < n_res && rc == CLI_EXIT_OK; i++)
        for (int t = 0; t < n_threads && rc == CLI_EXIT_OK; t++) {
            size_t n = 0;
            note("R = %u, %d thread%s, %u builds", res[i], threads[t], threads[t] > 1 ? "s" : "",
                 builds);
            if ((rc = rate_runs(ctx, scene, res[i], threads[t], builds, sec, &n)))
                break;
            const double med = sec[builds / 2];
            printf("%5u %7d %7zu %10.4f %10.4f %10.4f %14.0f %12.0f\n", res[i], threads[t], n,
                   sec[0], med, sec[builds - 1], (double)n / med, (double)n / sec[0]);
            fflush(stdout);
            if (have_out)
                fprintf(out.f, "%u,%d,%zu,%u,%.6g,%.6g,%.6g,%.6g,%.6g\n", res[i], threads[t], n,
                        builds, sec[0], med, sec[builds - 1], (double)n / med,
                        (double)n / sec[0]);
        }
    free(sec);
    if (have_out) {
        have_out = 0;
        if (rc == CLI_EXIT_OK && cli_outfile_commit(&out) != 0)
            rc = bench_fail("cannot write '%s': %s", csv, strerror(errno));
        else if (rc != CLI_EXIT_OK)
            cli_outfile_abort(&out);
        else
            printf("csv: %s\n", csv);
    }
done:
    if (have_out)
        cli_outfile_abort(&out);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}
