/* lrr solve: solve a saved operator for its stored emission (optionally lit by a probe),
 * time it and write the radiosity CSV. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "solve_mpi.h"

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
    "  --fbar F             auto (default), dense or sparse: how the solver reads F̄:\n"
    "                       sparse keeps the strips of 16 rows x 1 column that hold a\n"
    "                       nonzero (a real scene's F̄ is mostly zeros), auto does so\n"
    "                       where that reads at most half the dense bytes; the same B up\n"
    "                       to the order of the sums, on the CPU and on an OpenCL device\n"
    "  --m M                auto (default), f32 or f16: how a full frame reads M_c: f16\n"
    "                       holds M_c - I in binary16 with a scale per row (half the\n"
    "                       bytes), what auto chooses when F̄ is 16-bit (CPU only)\n"
    PROBE_LIGHT_HELP
    "  -h, --help           show this help\n"
    "Also prints storage (of F̄), fbar (dense or sparse, as read), fbar_bytes (read per full\n"
    "frame), fbar_density (nonzero entries / n·k), m (f32 or f16) and m_bytes (read per full\n"
    "frame), backend, path (that the last\n"
    "run took) and kernel (the\n"
    "SIMD variant, c, avx2 or avx512, with +prefetch on Intel CPUs; the environment\n"
    "variable LRR_SIMD forces one by that name, or\n"
    "opencl:<device name>); with --probe also probe, probe_method and sources, with --light\n"
    "lights, and with either direct_light_seconds (the shadow rays).\n";

static const char *const path_names[] = {"auto", "full", "sparse", "incremental"};

typedef struct solve_args {
    const char *file, *csv;
    probe_args pa;
    double scale;
    unsigned repeat;
    int path;     /* lrr_path */
    int backend;  /* lrr_backend */
    int fbar;     /* lrr_fbar_format */
    int m;        /* lrr_storage of M, or SOLVE_M_AUTO */
} solve_args;

/* What the run measured, for the printout. */
typedef struct solve_result {
    double ms, direct_s;
    lrr_path used;
    solver_report solver;
} solve_result;

/* ------------------------------------------------------------------ parsing */
static const cli_choice paths[] = {{"auto", LRR_PATH_AUTO},
                                   {"full", LRR_PATH_FULL},
                                   {"sparse", LRR_PATH_SPARSE},
                                   {"incremental", LRR_PATH_INCREMENTAL},
                                   {NULL, 0}};
static const cli_choice fbars[] = {{"auto", LRR_FBAR_AUTO},
                                   {"dense", LRR_FBAR_DENSE},
                                   {"sparse", LRR_FBAR_SPARSE},
                                   {NULL, 0}};
static const cli_choice ms[] = {{"auto", SOLVE_M_AUTO},
                                {"f32", LRR_STORAGE_F32},
                                {"f16", LRR_STORAGE_F16},
                                {NULL, 0}};
static const cli_choice backends[] = {{"cpu", LRR_BACKEND_CPU},
                                      {"opencl", LRR_BACKEND_OPENCL},
                                      {NULL, 0}};

static const cli_opt solve_opts[] = {
    {.name = "csv", .kind = CLI_OPT_FILE, .field = CLI_FIELD(solve_args, csv)},
    {.name = "emission-scale", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(solve_args, scale),
     .min = 0, .max = 1e300},
    {.name = "repeat", .kind = CLI_OPT_UNSIGNED, .field = CLI_FIELD(solve_args, repeat),
     .min = 1, .max = 1000000},
    {.name = "path", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(solve_args, path),
     .choices = paths},
    {.name = "backend", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(solve_args, backend),
     .choices = backends},
    {.name = "fbar", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(solve_args, fbar),
     .choices = fbars},
    {.name = "m", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(solve_args, m), .choices = ms},
    {.name = NULL}};

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_solve(solve_args *a, int argc, char *argv[])
{
    *a = (solve_args){.scale = 1.0,
                      .repeat = DEFAULT_REPEAT,
                      .path = LRR_PATH_FULL,
                      .backend = LRR_BACKEND_CPU,
                      .fbar = LRR_FBAR_AUTO,
                      .m = SOLVE_M_AUTO};
    probe_args_init(&a->pa);
    const cli_opt_group groups[] = {{solve_opts, a}, {probe_opts, &a->pa}, {NULL, NULL}};
    const cli_command cmd = {prog, solve_help, "FILE.lrr", groups};
    int rc = cli_parse_command(&cmd, argc, argv, &a->file);
    if (rc == CLI_RUN && probe_finish(&a->pa, prog) != 0)
        return CLI_EXIT_USAGE;
    return rc;
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
    const lrr_solver_info *si = &r->solver.info;
    printf("fbar: %s\n", lrr_fbar_format_name(si->fbar));
    printf("fbar_bytes: %zu\n", si->fbar_bytes);
    printf("fbar_density: %.4f\n", si->fbar_density);
    printf("m: %s\n", lrr_storage_name(si->m));
    printf("m_bytes: %zu\n", si->m_bytes);
    printf("backend: %s\n", a->backend == LRR_BACKEND_OPENCL ? "opencl" : "cpu");
    printf("path: %s\n", path_names[r->used]);
    printf("kernel: %s\n", r->solver.kernel);
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
    solve_result r = {.ms = 0.0, .direct_s = 0.0, .used = LRR_PATH_FULL};
    int rc = load_operator(ctx, a->file, &op);
    if (rc == CLI_EXIT_OK)
        rc = scaled_emission(op, a->scale, &e);
    if (rc == CLI_EXIT_OK && (a->pa.path || a->pa.lights))
        rc = add_probe_light(ctx, op, &a->pa, e, &r.direct_s);
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        b = cli_alloc_rgb(oi.n);
        rc = b ? timed_solve(ctx, op, (lrr_backend)a->backend, (lrr_fbar_format)a->fbar, a->m, e, b,
                             a->repeat, (lrr_path)a->path, &r.ms, &r.used, &r.solver)
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
#ifdef LRR_MPI
    if (solve_mpi_launched()) /* mpirun -np P lrr solve (tools/cmd_solve_mpi.c) */
        return solve_mpi_run(&(solve_mpi_args){.file = a.file, .csv = a.csv, .pa = &a.pa,
                                               .scale = a.scale, .repeat = a.repeat,
                                               .path = a.path, .backend = a.backend,
                                               .fbar = a.fbar, .m_given = a.m != SOLVE_M_AUTO});
#endif
    return run_solve(&a);
}
