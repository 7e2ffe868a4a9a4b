/* lrr reference: the full n×n form factors and a classic solver, to measure the low-rank
 * operator against. */
#include <getopt.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>
#include <stdlib.h>

#include "cli_mpi.h"
#include "commands.h"

static const char prog[] = "lrr reference";

static const char reference_help[] =
    "Usage: lrr reference SCENE --method M [OPTIONS]\n"
    "Builds the full n×n subpatch-to-subpatch form-factor matrix F from the same hemicubes\n"
    "as 'lrr preprocess' with the same options, and solves (I − R F) B = E for the scene's\n"
    "emission with a classic method, to measure the low-rank operator against (see\n"
    "'lrr compare'). Prints 'key: value' lines: n, method, iterations, residual\n"
    "(max over channels of ||E − (I − R F) B|| / ||E||), build_seconds, solve_seconds,\n"
    "mean_b_r, mean_b_g, mean_b_b (area-weighted mean radiosity), max_b.\n"
    "\n" SCENE_HELP "\n"
    "Options:\n"
    "  --method M           jacobi, gauss-seidel, southwell (progressive refinement),\n"
    "                       direct (LU of I − R F per channel) or path-trace (required)\n"
    "  --samples N          path-trace: paths per subpatch, >= 2 (default 1024). Path\n"
    "                       tracing stores no F: it estimates the B of the exact F by Monte\n"
    "                       Carlo with Embree rays (--seed, --threads apply; --hemicube,\n"
    "                       --tol, --max-iterations do not) and prints samples,\n"
    "                       trace_seconds and rel_std_error (area-weighted mean standard\n"
    "                       error / mean B) instead of iterations, residual and the times\n"
    "  --tol T              relative residual at which the iterative methods stop\n"
    "                       (1e-13 <= T < 1, default 1e-6; the direct method ignores it)\n"
    "  --max-iterations N   most sweeps (shots for southwell); 0 = the library's default,\n"
    "                       enough for reflectances up to 0.999 (default 0)\n"
    "  --memory-budget MB   the most memory F may take, in MiB (default 4096); the direct\n"
    "                       method counts its 8·n² bytes of LU too. Larger scenes are\n"
    "                       refused before anything is computed.\n"
    "  --csv OUT.csv        write one row per subpatch, the columns of 'lrr solve --csv':\n"
    "                       " CLI_CSV_HEADER "\n" BUILD_HELP
    "  -h, --help           show this help\n" SUBDIV_HELP
    "\n"
    "Under mpirun (lrr built with MPI), --method path-trace runs across the ranks: each\n"
    "traces chunks of 64 subpatches dealt round-robin (OMP_NUM_THREADS threads each), rank 0\n"
    "receives the rest, writes the CSV and prints, adding ranks; B and the standard errors\n"
    "are the serial ones bit for bit. The other methods are serial.\n"
    "\n"
    "Exit status: 0 success, 1 failure, 2 bad command line, 3 the iterative method stopped\n"
    "at --max-iterations before --tol (a warning names the iterations and the residual; the\n"
    "results, and the CSV, are those of the last iterate).\n";

typedef struct reference_args {
    const char *scene, *csv;
    subdiv_args sa;
    build_args ba;
    lrr_method method;
    int have_method, path_trace;
    size_t samples; /* 0: not given */
    double tol;
    size_t max_iterations, budget_mb;
    cli_mpi mp; /* the ranks under mpirun (tools/cli_mpi.h) */
    int quiet;  /* a rank other than 0: no bars or printout */
} reference_args;

/* What a run holds and measures, from the scene to the solution. */
typedef struct reference_run {
    lrr_scene *scene;
    lrr_reference *ref;
    size_t n, d;
    float *b, *centre, *normal, *area;
    lrr_reference_stats st;
    lrr_status solved;
    float *se; /* path-trace: standard errors n×3 */
    double trace_seconds;
    double build_seconds;
} reference_run;

/* ------------------------------------------------------------------ parsing */
/* The options of reference alone: 1 handled, 0 not one of them, -1 usage error (reported). */
static int reference_option(reference_args *a, int c, const char *arg)
{
    switch (c) {
    case OPT_METHOD:
        a->have_method = 1;
        a->path_trace = strcmp(arg, "path-trace") == 0;
        if (a->path_trace)
            return 1;
        if (lrr_method_from_name(arg, &a->method) != LRR_OK) {
            cli_usage_error(prog,
                            "--method: '%s' is not one of jacobi, gauss-seidel, southwell, "
                            "direct, path-trace",
                            arg);
            return -1;
        }
        return 1;
    case OPT_SAMPLES:
        return cli_parse_size(prog, "--samples", arg, 2, SIZE_MAX, &a->samples) != 0 ? -1 : 1;
    case OPT_TOL:
        /* the library's range: 1e-13 <= tol < 1 */
        if (cli_parse_double(prog, "--tol", arg, 1e-13, 0, 1.0, &a->tol) != 0)
            return -1;
        if (a->tol >= 1.0) {
            cli_usage_error(prog, "--tol: '%s' is out of range (it must be less than 1)", arg);
            return -1;
        }
        return 1;
    case OPT_MAX_ITERATIONS:
        return cli_parse_size(prog, "--max-iterations", arg, 0, SIZE_MAX, &a->max_iterations) !=
                       0 ? -1 : 1;
    case OPT_MEMORY_BUDGET:
        return cli_parse_size(prog, "--memory-budget", arg, 1, SIZE_MAX >> 20, &a->budget_mb) !=
                       0 ? -1 : 1;
    case OPT_CSV:
        a->csv = arg;
        return 1;
    default:
        return 0;
    }
}

/* The checks after getopt: the scene, --method, --csv and the subdivision. */
static int reference_finish(reference_args *a, int argc, char *argv[])
{
    a->scene = one_positional(prog, "SCENE", argc, argv);
    if (!a->scene)
        return CLI_EXIT_USAGE;
    if (!a->have_method) {
        cli_usage_error(prog, "--method is required (jacobi, gauss-seidel, southwell, direct, "
                              "path-trace)");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    if (a->samples && !a->path_trace) {
        cli_usage_error(prog, "--samples applies only to --method path-trace");
        return CLI_EXIT_USAGE;
    }
    if (a->csv && !a->csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    int rc = subdiv_finish(&a->sa, prog);
    if (rc)
        return rc;
    return CLI_RUN;
}

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_reference(reference_args *a, int argc, char *argv[])
{
    static const struct option longopts[] = {
        SUBDIV_LONGOPTS,
        BUILD_LONGOPTS,
        {"method", required_argument, NULL, OPT_METHOD},
        {"tol", required_argument, NULL, OPT_TOL},
        {"max-iterations", required_argument, NULL, OPT_MAX_ITERATIONS},
        {"memory-budget", required_argument, NULL, OPT_MEMORY_BUDGET},
        {"csv", required_argument, NULL, OPT_CSV},
        {"samples", required_argument, NULL, OPT_SAMPLES},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    *a = (reference_args){.method = LRR_METHOD_DIRECT,
                          .tol = DEFAULT_TOL,
                          .budget_mb = DEFAULT_BUDGET_MB};
    subdiv_init(&a->sa);
    build_init(&a->ba);
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        int r = subdiv_option(&a->sa, prog, c, optarg);
        if (r == 0)
            r = build_option(&a->ba, prog, c, optarg);
        if (r == 0)
            r = reference_option(a, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r > 0)
            continue;
        if (c == 'h') {
            fputs(reference_help, stdout);
            return CLI_EXIT_OK;
        }
        return bad_option(prog, c, argv);
    }
    return reference_finish(a, argc, argv);
}

/* ------------------------------------------------------------------ running */
/* n and d of the subdivided scene, and the budget check of the direct method. */
static int check_direct_budget(const reference_args *a, reference_run *r)
{
    size_t budget = a->budget_mb << 20;
    lrr_scene_info si;
    lrr_scene_get_info(r->scene, &si, sizeof si);
    r->n = si.subpatches;
    r->d = si.d ? si.d : 1;
    /* The library checks F against the budget; the LU of the direct method comes on top
     * while it runs, so refuse here, before the hemicubes, when only that breaks it. */
    double f_bytes = (double)lrr_reference_bytes(r->n);
    double lu_bytes = 8.0 * (double)r->n * (double)r->n;
    if (!a->path_trace && a->method == LRR_METHOD_DIRECT && f_bytes <= (double)budget &&
        f_bytes + lu_bytes > (double)budget)
        return cli_fail(LRR_ERR_BUDGET,
                        "the direct method on %zu subpatches needs %.1f MiB (%.1f MiB for F, "
                        "%.1f MiB for the LU of I − R F), more than --memory-budget %zu MiB",
                        r->n, (f_bytes + lu_bytes) / 1048576.0, f_bytes / 1048576.0,
                        lu_bytes / 1048576.0, a->budget_mb);
    return CLI_EXIT_OK;
}

/* The n×n form factors from the hemicubes, timed. */
static int build_reference(lrr_context *ctx, const reference_args *a, reference_run *r)
{
    cli_progress bar;
    lrr_build_options bo = build_start(&a->ba, &bar);
    double t0 = cli_now();
    lrr_status s = lrr_reference_build(r->scene, &bo, a->budget_mb << 20, &r->ref);
    r->build_seconds = cli_now() - t0;
    cli_progress_finish(&bar);
    if (s != LRR_OK) {
        int rc = cli_lib_error(ctx, s);
        if (s == LRR_ERR_BUDGET)
            fprintf(stderr, "%s: --memory-budget is %zu MiB: raise it or use fewer "
                            "subpatches\n", prog, a->budget_mb);
        return rc;
    }
    if (lrr_reference_size(r->ref) != r->n)
        return cli_fail(LRR_ERR_DIM, "the reference has %zu subpatches, the scene %zu",
                        lrr_reference_size(r->ref), r->n);
    return CLI_EXIT_OK;
}

/* The radiosity array and the subpatches' geometry (centre, normal, area) for the CSV. */
static int get_subpatches(lrr_context *ctx, reference_run *r)
{
    size_t n = r->n;
    r->b = cli_alloc_rgb(n);
    r->centre = r->b ? cli_alloc_rgb(n) : NULL;
    r->normal = r->centre ? cli_alloc_rgb(n) : NULL;
    r->area = r->normal ? calloc(n, sizeof *r->area) : NULL; /* n × 3 floats fit: so do n */
    if (!r->area)
        return r->normal ? cli_fail(LRR_ERR_NOMEM, "cannot allocate %zu areas", n)
                         : CLI_EXIT_FAIL;
    lrr_status s = lrr_scene_subpatches(r->scene, r->centre, r->normal, r->area, NULL, NULL);
    return s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, s);
}

/* Solves for the stored emission; a solve that did not converge only warns (r->solved). */
static int solve_reference(lrr_context *ctx, const reference_args *a, reference_run *r)
{
    const float *e = lrr_reference_emission(r->ref);
    r->solved = e ? lrr_reference_solve(r->ref, a->method, a->tol, a->max_iterations, e, r->b,
                                        &r->st, sizeof r->st)
                  : LRR_ERR_INVALID_ARG;
    if (!e)
        return cli_fail(LRR_ERR_INVALID_ARG, "the reference has no emission");
    if (r->solved == LRR_NOT_CONVERGED) {
        fprintf(stderr,
                "lrr: warning: %s did not converge: relative residual %.3g after %zu "
                "iterations (--tol %g); the results are those of the last iterate\n",
                lrr_method_name(a->method), r->st.residual, r->st.iterations, a->tol);
    } else if (r->solved != LRR_OK) {
        return cli_lib_error(ctx, r->solved);
    }
    return CLI_EXIT_OK;
}

/* The path-traced estimate and its standard errors, timed (docs/METHOD.md "Path-traced
 * reference"). */
static int trace_reference(lrr_context *ctx, const reference_args *a, reference_run *r)
{
    r->se = cli_alloc_rgb(r->n);
    if (!r->se)
        return CLI_EXIT_FAIL;
    cli_progress bar;
    cli_progress_init(&bar, "paths", !a->quiet && (a->ba.force_progress || isatty(STDERR_FILENO)));
    lrr_path_trace_options o = lrr_path_trace_options_defaults();
    if (a->samples)
        o.samples = a->samples;
    o.seed = a->ba.seed;
    o.threads = (int)a->ba.threads;
    o.progress = a->quiet ? NULL : cli_progress_cb;
    o.progress_user = &bar;
    double t0 = cli_now();
    lrr_status s = cli_mpi_trace(&a->mp, r->scene, &o, r->b, r->se);
    r->trace_seconds = cli_now() - t0;
    cli_progress_finish(&bar);
    if (a->quiet) /* rank 0 reports the agreed error, naming the rank */
        return s == LRR_OK ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    return s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, s);
}

static void print_path_trace(const reference_args *a, const reference_run *r)
{
    double sum_se = 0, sum_b = 0;
    for (size_t i = 0; i < r->n; i++)
        for (int c = 0; c < 3; c++) {
            sum_se += (double)r->area[i] * r->se[3 * i + c];
            sum_b += (double)r->area[i] * r->b[3 * i + c];
        }
    printf("n: %zu\n", r->n);
    printf("method: path-trace\n");
    printf("samples: %zu\n", a->samples ? a->samples : lrr_path_trace_options_defaults().samples);
    printf("trace_seconds: %.3f\n", r->trace_seconds);
    if (a->mp.on)
        printf("ranks: %d\n", a->mp.ranks);
    printf("rel_std_error: %.6g\n", sum_b > 0 ? sum_se / sum_b : 0.0);
    print_radiosity_summary(r->n, r->area, r->b);
    if (a->csv)
        printf("csv: %s\n", a->csv);
}

static void print_reference(const reference_args *a, const reference_run *r)
{
    printf("n: %zu\n", r->n);
    printf("method: %s\n", lrr_method_name(a->method));
    printf("iterations: %zu\n", r->st.iterations);
    printf("residual: %.6g\n", r->st.residual);
    printf("build_seconds: %.3f\n", r->build_seconds);
    printf("solve_seconds: %.6f\n", r->st.seconds);
    print_radiosity_summary(r->n, r->area, r->b);
    if (a->csv)
        printf("csv: %s\n", a->csv);
}

static int reference_ranks(const reference_args *a)
{
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    reference_run r = {.n = 0, .d = 1, .st = {0, 0.0, 0.0}, .solved = LRR_OK};
    /* Fail before the build, not after it, when the CSV cannot be written. */
    int rc = a->csv && !a->quiet ? check_writable_dir(a->csv) : CLI_EXIT_OK;
    if (rc == CLI_EXIT_OK)
        rc = open_subdivided_scene(ctx, a->scene, &a->sa, &r.scene);
    rc = cli_mpi_agree(&a->mp, rc); /* a rank without the scene stops them all */
    if (rc == CLI_EXIT_OK)
        rc = check_direct_budget(a, &r);
    if (rc == CLI_EXIT_OK && !a->path_trace)
        rc = build_reference(ctx, a, &r);
    if (rc == CLI_EXIT_OK)
        rc = get_subpatches(ctx, &r);
    if (rc == CLI_EXIT_OK)
        rc = a->path_trace ? trace_reference(ctx, a, &r) : solve_reference(ctx, a, &r);
    if (a->quiet) /* rank 0 checks, writes and prints */
        rc = rc == CLI_EXIT_OK ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    else if (rc == CLI_EXIT_OK)
        rc = check_finite(r.b, r.n);
    if (rc == CLI_EXIT_OK && a->csv && !a->quiet)
        rc = cli_write_subpatch_csv(a->csv, r.n, r.d, NULL, r.area, r.centre, r.normal, r.b);
    if (rc == CLI_EXIT_OK && !a->quiet) {
        if (a->path_trace)
            print_path_trace(a, &r);
        else
            print_reference(a, &r);
        if (r.solved == LRR_NOT_CONVERGED)
            rc = CLI_EXIT_NOT_CONVERGED;
    }
    free(r.area);
    free(r.normal);
    free(r.centre);
    free(r.b);
    free(r.se);
    lrr_reference_destroy(r.ref);
    lrr_scene_destroy(r.scene);
    lrr_context_destroy(ctx);
    return rc;
}

/* Under mpirun only the path tracer is distributed: the other methods are a usage error
 * (every rank sees the same options; rank 0 says why). */
static int run_reference(reference_args *a)
{
    int rc = cli_mpi_init(&a->mp, prog);
    if (rc != CLI_EXIT_OK)
        return rc;
    a->quiet = a->mp.rank != 0;
    if (a->mp.on && !a->path_trace) {
        if (!a->quiet)
            cli_usage_error(prog, "--method %s is not available across MPI ranks (only "
                            "path-trace is)", lrr_method_name(a->method));
        rc = CLI_EXIT_USAGE;
    } else
        rc = reference_ranks(a);
    rc = cli_mpi_agree(&a->mp, rc);
    cli_mpi_finalize(&a->mp);
    return rc;
}

int cmd_reference(int argc, char *argv[])
{
    reference_args a;
    int rc = parse_reference(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_reference(&a);
}
