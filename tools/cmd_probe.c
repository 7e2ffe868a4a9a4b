/* lrr probe: fit lights (median cut, or Levenberg-Marquardt on the irradiance) or SH9 to a
 * light probe and measure the fit's irradiance error. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"

static const char prog[] = "lrr probe";

static const char probe_help[] =
    "Usage: lrr probe PROBE.hdr [OPTIONS]\n"
    "Loads a latitude-longitude light probe (Radiance .hdr, width = 2 x height, row 0 the\n"
    "zenith), fits it, and compares the fit's irradiance with the ground truth\n"
    "E(n) = sum Q max(0, n.w) (Q = radiance x pixel solid angle) on M normals of a\n"
    "Fibonacci sphere. Prints 'key: value' lines: probe, width, height, method, sources,\n"
    "normals, iterations, seconds (the fit), truth_seconds (the ground truth),\n"
    "mean_error_pct and max_error_pct (mean and max over normals and RGB of\n"
    "|approx - truth| / truth in percent, over entries with truth > 1e-6 x the largest).\n"
    "\n"
    "Options:\n"
    "  --method M           median-cut (default), sh9 (order-2 spherical harmonics, 9\n"
    "                       coefficients per channel) or irradiance (lights fitted by\n"
    "                       Levenberg-Marquardt to the irradiance on the M normals, started\n"
    "                       from median cut; iterations = accepted LM steps)\n"
    "  --sources N          lights for median-cut and irradiance (default 16; a power of two\n"
    "                       is the classic cut, other counts the adaptive variant)\n"
    "  --max-iterations K   irradiance: most LM steps (0 = the library's default, 300)\n"
    "  --normals M          normals to measure on (default 1024)\n"
    "  --lights OUT.csv     write the lights: x,y,z,r,g,b (direction towards the light,\n"
    "                       radiance x solid angle); median-cut and irradiance\n"
    "  --json               print one JSON object on one line instead\n"
    "  -h, --help           show this help\n";

typedef struct probe_cmd_args {
    const char *path, *method, *lights_path;
    size_t sources, normals, max_iterations;
    int json, sources_given, max_iterations_given;
    int sh9, optimise; /* --method sh9, irradiance (neither: median-cut) */
} probe_cmd_args;

/* What a run measured, for the printout. */
typedef struct probe_result {
    size_t w, h;
    size_t iterations, n_sources;
    double seconds, truth_seconds;
    double mean_pct, max_pct;
    lrr_light *lights; /* the fitted lights (NULL for sh9) */
} probe_result;

/* ------------------------------------------------------------------ parsing */
/* The options: 1 handled, -1 usage error (reported), 0 not one of them. */
static int probe_cmd_option(probe_cmd_args *a, int c, const char *arg)
{
    switch (c) {
    case OPT_METHOD:
        a->method = arg;
        return 1;
    case OPT_SOURCES:
        if (cli_parse_size(prog, "--sources", arg, 1, (size_t)1 << 24, &a->sources) != 0)
            return -1;
        a->sources_given = 1;
        return 1;
    case OPT_NORMALS:
        return cli_parse_size(prog, "--normals", arg, 1, (size_t)1 << 24, &a->normals) != 0
                   ? -1 : 1;
    case OPT_LIGHTS:
        a->lights_path = arg;
        return 1;
    case OPT_MAX_ITERATIONS:
        if (cli_parse_size(prog, "--max-iterations", arg, 0, (size_t)1 << 24,
                           &a->max_iterations) != 0)
            return -1;
        a->max_iterations_given = 1;
        return 1;
    case OPT_JSON:
        a->json = 1;
        return 1;
    default:
        return 0;
    }
}

/* The checks after getopt: the probe, the method and which options it takes. */
static int probe_cmd_finish(probe_cmd_args *a, int argc, char *argv[])
{
    a->path = one_positional(prog, "PROBE", argc, argv);
    if (!a->path)
        return CLI_EXIT_USAGE;
    if (strcmp(a->method, "sh9") == 0) {
        a->sh9 = 1;
    } else if (strcmp(a->method, "irradiance") == 0) {
        a->optimise = 1;
    } else if (strcmp(a->method, "median-cut") != 0) {
        cli_usage_error(prog, "--method: '%s' is not one of median-cut, irradiance, sh9",
                        a->method);
        return CLI_EXIT_USAGE;
    }
    if (a->sh9 && a->sources_given) {
        cli_usage_error(prog, "--sources applies to --method median-cut and irradiance only");
        return CLI_EXIT_USAGE;
    }
    if (a->sh9 && a->lights_path) {
        cli_usage_error(prog, "--lights applies to --method median-cut and irradiance only");
        return CLI_EXIT_USAGE;
    }
    if (!a->optimise && a->max_iterations_given) {
        cli_usage_error(prog, "--max-iterations applies to --method irradiance only");
        return CLI_EXIT_USAGE;
    }
    if (a->lights_path && !*a->lights_path) {
        cli_usage_error(prog, "--lights: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    return CLI_RUN;
}

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_probe(probe_cmd_args *a, int argc, char *argv[])
{
    static const struct option longopts[] = {{"method", required_argument, NULL, OPT_METHOD},
                                             {"sources", required_argument, NULL, OPT_SOURCES},
                                             {"normals", required_argument, NULL, OPT_NORMALS},
                                             {"lights", required_argument, NULL, OPT_LIGHTS},
                                             {"max-iterations", required_argument, NULL,
                                              OPT_MAX_ITERATIONS},
                                             {"json", no_argument, NULL, OPT_JSON},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    *a = (probe_cmd_args){.method = "median-cut",
                          .sources = PROBE_DEFAULT_SOURCES,
                          .normals = PROBE_DEFAULT_NORMALS};
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(probe_help, stdout);
            return CLI_EXIT_OK;
        }
        int r = probe_cmd_option(a, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r == 0)
            return bad_option(prog, c, argv);
    }
    return probe_cmd_finish(a, argc, argv);
}

/* ------------------------------------------------------------------ fitting */
/* Fits a->sources lights into r->lights and sets r->iterations: the accepted LM steps, or
 * for median cut the levels of the cut (log2 of a power of two, else one split per light
 * beyond the first). The fit's irradiance on the normals goes to approx. */
static lrr_status fit_lights(const lrr_probe *probe, const probe_cmd_args *a, const float *dirs,
                             float *approx, probe_result *r)
{
    size_t sources = a->sources;
    lrr_status st;
    if (a->optimise) {
        lrr_fit_options fo = {0};
        lrr_fit_stats fs = {0};
        fo.max_iterations = a->max_iterations;
        st = lrr_probe_fit_irradiance(probe, sources, a->normals, &fo, r->lights, &fs, sizeof fs);
        r->iterations = fs.iterations;
    } else {
        st = lrr_probe_median_cut(probe, sources, r->lights);
    }
    if (st == LRR_OK)
        st = lrr_lights_irradiance(r->lights, sources, a->normals, dirs, approx);
    r->n_sources = sources;
    if (!a->optimise) {
        if ((sources & (sources - 1)) == 0)
            for (r->iterations = 0; ((size_t)1 << r->iterations) < sources; r->iterations++)
                ;
        else
            r->iterations = sources - 1;
    }
    return st;
}

/* The approximation's irradiance on the normals (approx), by SH9 or by lights, timed in
 * r->seconds. */
static int fit_probe(lrr_context *ctx, const lrr_probe *probe, const probe_cmd_args *a,
                     const float *dirs, float *approx, probe_result *r)
{
    lrr_status st;
    r->iterations = 1;
    r->n_sources = 9;
    double t0 = cli_now();
    if (a->sh9) {
        float coeffs[27];
        st = lrr_probe_sh9(probe, coeffs);
        if (st == LRR_OK)
            st = lrr_sh9_irradiance(coeffs, a->normals, dirs, approx);
    } else {
        r->lights = calloc(a->sources, sizeof *r->lights);
        if (!r->lights)
            return cli_fail(LRR_ERR_NOMEM, "cannot allocate %zu lights", a->sources);
        st = fit_lights(probe, a, dirs, approx, r);
    }
    r->seconds = cli_now() - t0;
    return st == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, st);
}

/* The ground truth on the normals of a Fibonacci sphere, the fit, and the error between. */
static int measure_probe(lrr_context *ctx, const lrr_probe *probe, const probe_cmd_args *a,
                         probe_result *r)
{
    float *dirs = cli_alloc_rgb(a->normals);
    float *truth = cli_alloc_rgb(a->normals);
    float *approx = cli_alloc_rgb(a->normals);
    int rc = CLI_EXIT_FAIL;
    if (!dirs || !truth || !approx)
        goto done;
    lrr_sphere_points(a->normals, dirs);
    double t0 = cli_now();
    lrr_status st = lrr_probe_irradiance(probe, a->normals, dirs, truth);
    r->truth_seconds = cli_now() - t0;
    if (st != LRR_OK) {
        rc = cli_lib_error(ctx, st);
        goto done;
    }
    rc = fit_probe(ctx, probe, a, dirs, approx, r);
    if (rc == CLI_EXIT_OK)
        cli_irradiance_error_pct(a->normals, truth, approx, &r->mean_pct, &r->max_pct);
done:
    free(dirs);
    free(truth);
    free(approx);
    return rc;
}

/* ------------------------------------------------------------------ printing */
static int write_lights_csv(const char *path, const lrr_light *lights, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return cli_fail(LRR_ERR_IO, "'%s': cannot create: %s", path, strerror(errno));
    fprintf(out.f, "x,y,z,r,g,b\n");
    for (size_t i = 0; i < count; i++)
        fprintf(out.f, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", lights[i].dir[0], lights[i].dir[1],
                lights[i].dir[2], lights[i].rgb[0], lights[i].rgb[1], lights[i].rgb[2]);
    if (ferror(out.f)) {
        cli_outfile_abort(&out);
        return cli_fail(LRR_ERR_IO, "'%s': write failed", path);
    }
    if (cli_outfile_commit(&out) != 0)
        return cli_fail(LRR_ERR_IO, "'%s': cannot write: %s", path, strerror(errno));
    return CLI_EXIT_OK;
}

/* Prints a string as a JSON string literal. */
static void json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            printf("\\%c", c);
        else if (c < 0x20)
            printf("\\u%04x", c);
        else
            putchar(c);
    }
    putchar('"');
}

static void print_probe(const probe_cmd_args *a, const probe_result *r)
{
    const char *method = a->sh9 ? "sh9" : a->optimise ? "irradiance" : "median-cut";
    if (a->json) {
        printf("{\"probe\": ");
        json_string(a->path);
        printf(", \"width\": %zu, \"height\": %zu, \"method\": \"%s\", \"sources\": %zu, "
               "\"normals\": %zu, \"iterations\": %zu, \"seconds\": %.6g, "
               "\"truth_seconds\": %.6g, \"mean_error_pct\": %.6g, \"max_error_pct\": %.6g}\n",
               r->w, r->h, method, r->n_sources, a->normals, r->iterations, r->seconds,
               r->truth_seconds, isnan(r->mean_pct) ? -1.0 : r->mean_pct,
               isnan(r->max_pct) ? -1.0 : r->max_pct);
    } else {
        printf("probe: %s\nwidth: %zu\nheight: %zu\nmethod: %s\nsources: %zu\nnormals: %zu\n"
               "iterations: %zu\nseconds: %.6g\ntruth_seconds: %.6g\nmean_error_pct: %.6g\n"
               "max_error_pct: %.6g\n",
               a->path, r->w, r->h, method, r->n_sources, a->normals, r->iterations, r->seconds,
               r->truth_seconds, r->mean_pct, r->max_pct);
        if (a->lights_path)
            printf("lights: %s\n", a->lights_path);
    }
}

/* ------------------------------------------------------------------ running */
static int run_probe(const probe_cmd_args *a)
{
    lrr_context *ctx = NULL;
    lrr_probe *probe = NULL;
    probe_result r = {.lights = NULL};
    lrr_status st = lrr_context_create(&ctx);
    if (st != LRR_OK)
        return cli_lib_error(NULL, st);
    int rc = CLI_EXIT_OK;
    st = lrr_probe_load(ctx, a->path, &probe);
    if (st != LRR_OK)
        rc = cli_lib_error(ctx, st);
    if (rc == CLI_EXIT_OK) {
        lrr_probe_size(probe, &r.w, &r.h);
        if (!a->sh9 && a->sources > r.w * r.h) {
            cli_usage_error(prog, "--sources: %zu is more than the probe's %zu pixels",
                            a->sources, r.w * r.h);
            rc = CLI_EXIT_USAGE;
        }
    }
    if (rc == CLI_EXIT_OK)
        rc = measure_probe(ctx, probe, a, &r);
    if (rc == CLI_EXIT_OK && a->lights_path)
        rc = write_lights_csv(a->lights_path, r.lights, a->sources);
    if (rc == CLI_EXIT_OK)
        print_probe(a, &r);
    free(r.lights);
    lrr_probe_destroy(probe);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_probe(int argc, char *argv[])
{
    probe_cmd_args a;
    int rc = parse_probe(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_probe(&a);
}
