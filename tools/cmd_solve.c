/* lrr solve: solve a saved operator for its stored emission (optionally lit by a probe),
 * time it and write the radiosity CSV. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"

static const char prog[] = "lrr solve";

static const char solve_help[] =
    "Usage: lrr solve FILE.lrr [OPTIONS]\n"
    "Solves B = E + rho ∘ (F̄ (M (Vᵀ E))) on the CPU (or an OpenCL device, --backend) for\n"
    "the emission stored in the file and prints n, k, d, solve_ms (median of the timed runs,\n"
    "after one warm-up run), mean_b_r, mean_b_g, mean_b_b (area-weighted mean radiosity)\n"
    "and max_b.\n"
    "\n"
    "Options:\n"
    "  --csv OUT.csv        write one row per subpatch:\n"
    "                       subpatch,patch,area,cx,cy,cz,nx,ny,nz,b_r,b_g,b_b\n"
    "  --emission-scale S   multiply the stored emission by S (finite, >= 0; default 1)\n"
    "  --repeat N           number of timed runs (1..1000000, default 10)\n"
    "  --path P             auto, full (default), sparse or incremental: which real-time\n"
    "                       path to time (see lrr_solver_set_path). auto picks per frame;\n"
    "                       repeating one emission then takes the incremental path with\n"
    "                       nothing changed, so its time is bookkeeping only\n"
    "  --backend B          cpu (default) or opencl: solve on an OpenCL device (the first\n"
    "                       GPU, else the first CPU device; the environment variable\n"
    "                       LRR_OPENCL_DEVICE picks another, by index P:D or by a part of\n"
    "                       \"platform / device\" name). Every OpenCL frame is a full pass\n"
    PROBE_LIGHT_HELP
    "  -h, --help           show this help\n"
    "Also prints storage (of F̄), backend, path (that the last run took) and kernel (the\n"
    "SIMD variant, whose choice the environment variable LRR_SIMD=c|avx2|avx512 forces, or\n"
    "opencl:<device name>); with --probe also probe, probe_method and sources, with --light\n"
    "lights, and with either direct_light_seconds (the shadow rays).\n";

static const char *const path_names[] = {"auto", "full", "sparse", "incremental"};

static int parse_path(const char *arg, lrr_path *out)
{
    for (int i = 0; i < 4; i++)
        if (strcmp(arg, path_names[i]) == 0) {
            *out = (lrr_path)i;
            return 0;
        }
    cli_usage_error(prog, "--path: '%s' is not one of auto, full, sparse, incremental", arg);
    return -1;
}

typedef struct solve_args {
    const char *file, *csv;
    probe_args pa;
    double scale;
    unsigned repeat;
    lrr_path path;
    lrr_backend backend;
} solve_args;

/* What the run measured, for the printout. */
typedef struct solve_result {
    double ms, direct_s;
    lrr_path used;
    char kernel[KERNEL_NAME_MAX];
} solve_result;

/* ------------------------------------------------------------------ parsing */
/* The options of solve: 1 handled, 0 not one of them, -1 usage error (reported). */
static int solve_option(solve_args *a, int c, const char *arg)
{
    switch (c) {
    case OPT_CSV:
        a->csv = arg;
        return 1;
    case OPT_EMISSION_SCALE:
        return cli_parse_double(prog, "--emission-scale", arg, 0.0, 0, 1e300, &a->scale) != 0
                   ? -1 : 1;
    case OPT_REPEAT:
        return cli_parse_unsigned(prog, "--repeat", arg, 1, 1000000, &a->repeat) != 0 ? -1 : 1;
    case OPT_PATH:
        return parse_path(arg, &a->path) != 0 ? -1 : 1;
    case OPT_BACKEND:
        return cli_parse_backend(prog, arg, &a->backend) != 0 ? -1 : 1;
    default:
        return probe_option(&a->pa, prog, c, arg);
    }
}

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_solve(solve_args *a, int argc, char *argv[])
{
    static const struct option longopts[] = {
        {"csv", required_argument, NULL, OPT_CSV},
        {"emission-scale", required_argument, NULL, OPT_EMISSION_SCALE},
        {"repeat", required_argument, NULL, OPT_REPEAT},
        {"path", required_argument, NULL, OPT_PATH},
        {"backend", required_argument, NULL, OPT_BACKEND},
        PROBE_LONGOPTS,
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    *a = (solve_args){.scale = 1.0,
                      .repeat = DEFAULT_REPEAT,
                      .path = LRR_PATH_FULL,
                      .backend = LRR_BACKEND_CPU};
    probe_args_init(&a->pa);
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(solve_help, stdout);
            return CLI_EXIT_OK;
        }
        int r = solve_option(a, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r == 0)
            return bad_option(prog, c, argv);
    }
    a->file = one_positional(prog, "FILE.lrr", argc, argv);
    if (!a->file)
        return CLI_EXIT_USAGE;
    if (a->csv && !a->csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (probe_finish(&a->pa, prog) != 0)
        return CLI_EXIT_USAGE;
    return CLI_RUN;
}

/* ------------------------------------------------------------------ printing */
static void print_solve(const solve_args *a, const lrr_operator *op, const float *b,
                        const solve_result *r)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    printf("n: %zu\n", oi.n);
    printf("k: %zu\n", oi.k);
    printf("d: %zu\n", oi.d);
    printf("storage: %s\n", lrr_storage_name(oi.storage));
    printf("backend: %s\n", a->backend == LRR_BACKEND_OPENCL ? "opencl" : "cpu");
    printf("path: %s\n", path_names[r->used]);
    printf("kernel: %s\n", r->kernel);
    printf("solve_ms: %.4f\n", r->ms);
    if (a->pa.path) {
        printf("probe: %s\n", a->pa.path);
        printf("probe_method: %s\n", a->pa.median_cut ? "median-cut" : "irradiance");
        printf("sources: %zu\n", a->pa.sources);
    }
    if (a->pa.lights)
        printf("lights: %zu\n", a->pa.lights);
    if (a->pa.path || a->pa.lights)
        printf("direct_light_seconds: %.6f\n", r->direct_s);
    print_solution_summary(op, b);
    if (a->csv)
        printf("csv: %s\n", a->csv);
}

/* ------------------------------------------------------------------ running */
static int run_solve(const solve_args *a)
{
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_operator *op = NULL;
    float *e = NULL, *b = NULL;
    solve_result r = {.ms = 0.0, .direct_s = 0.0, .used = LRR_PATH_FULL, .kernel = ""};
    int rc = load_operator(ctx, a->file, &op);
    if (rc == CLI_EXIT_OK)
        rc = scaled_emission(op, a->scale, &e);
    if (rc == CLI_EXIT_OK && (a->pa.path || a->pa.lights))
        rc = add_probe_light(ctx, op, &a->pa, e, &r.direct_s);
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        b = cli_alloc_rgb(oi.n);
        rc = b ? timed_solve(ctx, op, a->backend, e, b, a->repeat, a->path, &r.ms, &r.used,
                             r.kernel)
               : CLI_EXIT_FAIL;
    }
    if (rc == CLI_EXIT_OK && a->csv)
        rc = cli_write_radiosity_csv(a->csv, op, b);
    if (rc == CLI_EXIT_OK)
        print_solve(a, op, b, &r);
    free(b);
    free(e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_solve(int argc, char *argv[])
{
    solve_args a;
    int rc = parse_solve(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_solve(&a);
}
