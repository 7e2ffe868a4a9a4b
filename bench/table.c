/*
 * lrr-bench table: the paper's n×k table: memory, preprocessing, real-time step (ours, the
 * paper's two-gemv method, three plain sgemv), a bandwidth floor and the error against the
 * full n×n solution, as a table, CSV and plot. The command, its options and output are here;
 * the measurements of one cell are in table_cell.c.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "plot.h"

#define DEFAULT_BUDGET_MIB 4096u

static const char table_help[] =
    "Usage: lrr-bench table [OPTIONS]\n"
    "For each (n, k, d) cell: subdivide the scene into about k patches of d = 4^levels\n"
    "subpatches, build the operator (preprocess_s), then time one real-time step for the\n"
    "scene's emission (warm-up, then the median, min and max of many runs):\n"
    "  ours     lrr_solve forced to its full path (LRR_PATH_FULL): one pass over F̄ for\n"
    "           B_c = E_c + rho_c ∘ (F̄ (M_c (Vᵀ E_c))), all three channels, which is what\n"
    "           any emission costs (auto_ms: the default LRR_PATH_AUTO with the emission\n"
    "           scaled by 1 and 0.5 on alternate frames, and the path it took)\n"
    "  paper    the paper's method: per channel Y_c = -diag(rho_c) F̄ M_c (n×k, built once\n"
    "           with sgemm, not timed) and a dense V; per frame w = Vᵀ E_c and\n"
    "           B_c = E_c - Y_c w, two cblas_sgemv per channel (six per frame); its B must\n"
    "           match ours (relative L2 < 1e-4, else an error)\n"
    "  3sgemv   three plain cblas_sgemv over F̄ (n×k), no epilogue\n"
    "  opencl   (--backend opencl) ours on an OpenCL solver (LRR_BACKEND_OPENCL, f32, full\n"
    "           path; device from LRR_OPENCL_DEVICE), with the medians of its kernel time\n"
    "           and transfer time (E up, B down) from OpenCL profiling events, and\n"
    "           ratio_to_ours = ours ms / OpenCL ms (above 1: the device is faster)\n"
    "Memory in MB = 10^6 bytes: mem_mb = F̄ (n·k floats) + M (3·k² floats);\n"
    "mem_mb_paper = 2·n·k·4 bytes (U and V dense, as the paper counted; the paper's own\n"
    "column is in MiB, see mem_mib_paper in the CSV).\n"
    "floor_ms = F̄'s bytes (n·k·4) / the read bandwidth measured at the start of the run\n"
    "(OpenMP sums of each vector width over max(512 MiB, 4 × the last-level cache), best\n"
    "of 5 passes each): every implementation reads F̄ (or the paper's Y) once per channel or frame.\n"
    "Our full path also reads M (3·k² floats), which matters when k nears n:\n"
    "floor_ms_full in the CSV\n"
    "counts F̄ + M. A matrix that fits in the last-level cache (llc_mib) can beat both.\n"
    "Error: where lrr_reference_bytes(n) <= the memory budget, the full n×n F is built from\n"
    "the same hemicubes and solved by Gauss-Seidel (tol 1e-7): rel_l2 is the area-weighted\n"
    "relative L2 over all channels, max_rel the largest |ΔB|/|B_ref| over entries with\n"
    "|B_ref| > 1e-3·max|B_ref|; otherwise n/a (nan in the CSV) with the reason.\n"
    "\n"
    "Options:\n"
    "  --scene SCENE        a scene file (OBJ/PLY/glTF) or built-in name 'cornell',\n"
    "                       'cornell-closed' (default cornell; a file wins over a name)\n"
    "  --cells SET          paper (the paper's 9 cells), small (its 4 cheapest, under\n"
    "                       3 minutes on 2 cores), all (paper plus two d = 1 cells), or a\n"
    "                       list N/K/D,... with D a power of 4 (default paper)\n"
    "  --hemicube R         hemicube resolution: even, 8..4096 (default 128)\n"
    "  --seed S             seed of the hemicube rotations (default 1)\n"
    "  --csv OUT.csv        write the results (rewritten after each cell):\n"
    "                       n,k,d,mem_mb,mem_mb_paper,preprocess_s,rt_ms_ours,rt_ms_paper,\n"
    "                       rt_ms_3sgemv,floor_ms,rel_l2,max_rel, then extra columns,\n"
    "                       ending in backend,rt_ms_opencl,kernel_ms,transfer_ms,device,\n"
    "                       opencl_ratio_to_ours (cpu,nan,nan,nan,cpu,nan without\n"
    "                       --backend opencl)\n"
    "  --plot OUT.png       rel_l2 against real-time ms, log-log: ours (labelled n×k) and\n"
    "                       the paper's method (the same operator, so the same error),\n"
    "                       joined per cell; cells with an error only\n"
    "  --memory-budget MB   most memory for the n×n reference, in MiB (2^20 bytes;\n"
    "                       default 4096)\n"
    "  --repeat N           timed runs per implementation (default: adaptive, at least 20\n"
    "                       runs and at least 0.5 s)\n"
    "  --backend B          cpu (default) or opencl (also the opencl columns; fails when\n"
    "                       no OpenCL device or platform is available)\n"
    "  -h, --help           show this help\n";


/* ================================================================== table */
/* The paper's 9 cells (Table 1 of the low-rank radiosity paper: n, k, d). */
static const cell paper_cells[] = {{3456, 216, 16},   {3456, 864, 4},    {13824, 216, 64},
                                   {3456, 3456, 1},   {13824, 864, 16},  {55296, 216, 256},
                                   {13824, 3456, 4},  {55296, 864, 64},  {221184, 216, 1024}};
/* The paper's four cheapest cells (3456×3456 is d = 1, where the model is exact): about a
 * minute and a half on 2 cores with the n×n references. */
static const cell small_cells[] = {{3456, 216, 16}, {3456, 864, 4}, {13824, 216, 64},
                                   {3456, 3456, 1}};
/* 'all' adds d = 1 cells, where the low-rank model is exact (rel_l2 shows the rounding). */
static const cell extra_cells[] = {{216, 216, 1}, {864, 864, 1}};
/* For `make check`: seconds, not minutes. */
static const cell tiny_cells[] = {{576, 36, 16}, {144, 144, 1}};

/* --cells: a named set or "N/K/D,N/K/D,..." */
int parse_cells(const char *prog, const char *text, cell **cells, size_t *n_cells,
                const char **name)
{
    const cell *src = NULL;
    size_t count = 0;
    if (strcmp(text, "paper") == 0) {
        src = paper_cells;
        count = sizeof paper_cells / sizeof paper_cells[0];
    } else if (strcmp(text, "small") == 0) {
        src = small_cells;
        count = sizeof small_cells / sizeof small_cells[0];
    } else if (strcmp(text, "tiny") == 0) {
        src = tiny_cells;
        count = sizeof tiny_cells / sizeof tiny_cells[0];
    }
    free(*cells);
    *cells = NULL;
    *name = text;
    if (src) {
        *cells = malloc(count * sizeof **cells);
        if (!*cells)
            return -1;
        memcpy(*cells, src, count * sizeof *src);
        *n_cells = count;
        return 0;
    }
    if (strcmp(text, "all") == 0) {
        size_t np = sizeof paper_cells / sizeof paper_cells[0];
        size_t ne = sizeof extra_cells / sizeof extra_cells[0];
        *cells = malloc((np + ne) * sizeof **cells);
        if (!*cells)
            return -1;
        memcpy(*cells, extra_cells, ne * sizeof *extra_cells);
        memcpy(*cells + ne, paper_cells, np * sizeof *paper_cells);
        *n_cells = np + ne;
        return 0;
    }
    /* a list */
    size_t cap = 1;
    for (const char *p = text; *p; p++)
        cap += *p == ',';
    *cells = calloc(cap, sizeof **cells);
    if (!*cells)
        return -1;
    *n_cells = 0;
    const char *p = text;
    while (*p) {
        char *end;
        unsigned long long v[3];
        for (int j = 0; j < 3; j++) {
            if (*p < '0' || *p > '9')
                goto bad;
            errno = 0;
            v[j] = strtoull(p, &end, 10);
            if (errno || v[j] == 0 || v[j] > (1ull << 32))
                goto bad;
            p = end;
            if (j < 2) {
                if (*p != '/')
                    goto bad;
                p++;
            }
        }
        if (*p == ',')
            p++;
        else if (*p)
            goto bad;
        if (bench_levels_of((size_t)v[2]) < 0) {
            cli_usage_error(prog, "--cells: d = %llu is not a power of 4 (1, 4, ..., 4^10)",
                            v[2]);
            return -1;
        }
        (*cells)[(*n_cells)++] = (cell){(size_t)v[0], (size_t)v[1], (size_t)v[2]};
    }
    if (*n_cells == 0)
        goto bad;
    return 0;
bad:
    cli_usage_error(prog, "--cells: '%s' is not paper, small, all or a list N/K/D,...", text);
    return -1;
}

/* ---------------------------------------------------------------- output */
static const char table_csv_header[] =
    "n,k,d,mem_mb,mem_mb_paper,preprocess_s,rt_ms_ours,rt_ms_paper,rt_ms_3sgemv,floor_ms,"
    "rel_l2,max_rel,"
    "rt_ms_ours_min,rt_ms_ours_max,rt_ms_paper_min,rt_ms_paper_max,rt_ms_3sgemv_min,"
    "rt_ms_3sgemv_max,runs_ours,runs_paper,runs_3sgemv,n_target,k_target,d_target,"
    "mem_mib_paper,bandwidth_gbs,reference_s,rel_l2_reflected,paper_vs_ours,cond_r,cond_g,"
    "cond_b,threads,rt_ms_ours_auto,rt_ms_ours_auto_min,rt_ms_ours_auto_max,auto_path,kernel,"
    "floor_ms_full,backend,rt_ms_opencl,kernel_ms,transfer_ms,device,opencl_ratio_to_ours\n";

static int write_table_csv(const char *path, const cell_result *res, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs(table_csv_header, out.f);
    for (size_t i = 0; i < count; i++) {
        const cell_result *r = &res[i];
        fprintf(out.f, "%zu,%zu,%zu,", r->n, r->k, r->d);
        const double v[] = {r->mem_mb, r->mem_mb_paper, r->preprocess_s, r->ours.median,
                            r->paper.median, r->sgemv3.median, r->floor_ms, r->rel_l2,
                            r->max_rel, r->ours.min, r->ours.max, r->paper.min, r->paper.max,
                            r->sgemv3.min, r->sgemv3.max};
        for (size_t j = 0; j < sizeof v / sizeof v[0]; j++)
            bench_csv_num(out.f, v[j], 0);
        fprintf(out.f, "%zu,%zu,%zu,%zu,%zu,%zu,", r->ours.runs, r->paper.runs, r->sgemv3.runs,
                r->target.n, r->target.k, r->target.d);
        const double w[] = {r->mem_mib_paper, r->bandwidth_gbs, r->reference_s,
                            r->rel_l2_reflected, r->paper_vs_ours, r->cond[0], r->cond[1],
                            r->cond[2]};
        for (size_t j = 0; j < sizeof w / sizeof w[0]; j++)
            bench_csv_num(out.f, w[j], 0);
        fprintf(out.f, "%d,", r->threads);
        bench_csv_num(out.f, r->ours_auto.median, 0);
        bench_csv_num(out.f, r->ours_auto.min, 0);
        bench_csv_num(out.f, r->ours_auto.max, 0);
        fprintf(out.f, "%s,%s,", r->auto_path, r->kernel);
        bench_csv_num(out.f, r->floor_ms_full, 0);
        fprintf(out.f, "%s,", r->have_cl ? "opencl" : "cpu");
        bench_csv_num(out.f, r->ocl.median, 0);
        bench_csv_num(out.f, r->ocl_kernel_ms, 0);
        bench_csv_num(out.f, r->ocl_transfer_ms, 0);
        fprintf(out.f, "%s,", r->ocl_device);
        bench_csv_num(out.f, r->ocl_ratio, 1);
    }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

/* Returns 0, 1 when no cell has an error to plot (nothing written), -1 on failure. */
static int write_table_plot(const char *path, const table_args *a, const cell_result *res,
                            size_t count)
{
    double *x = calloc(count + 1, sizeof *x), *x2 = calloc(count + 1, sizeof *x2);
    double *y = calloc(count + 1, sizeof *y);
    const char **labels = calloc(count + 1, sizeof *labels);
    int rc = -1;
    if (!x || !x2 || !y || !labels) {
        bench_fail("cannot allocate the plot's points");
        goto out;
    }
    size_t m = 0;
    for (size_t i = 0; i < count; i++) {
        if (!(isfinite(res[i].rel_l2) && res[i].rel_l2 > 0))
            continue;
        x[m] = res[i].ours.median;
        x2[m] = res[i].paper.median;
        y[m] = res[i].rel_l2;
        labels[m] = res[i].label;
        m++;
    }
    if (m == 0) {
        rc = 1;
        goto out;
    }
    char title[256];
    snprintf(title, sizeof title, "%s: error against real-time step (hemicube %u, %d threads)",
             a->scene, a->hemicube, omp_get_max_threads());
    plot_series series[2] = {
        {"ours (lrr_solve, full path)", x, y, labels, m, {31, 119, 180}, PLOT_CIRCLE, 0},
        {"paper's method (6 sgemv)", x2, y, NULL, m, {255, 127, 14}, PLOT_SQUARE, 0}};
    plot_spec spec = {title, "real-time step per frame [ms]",
                      "relative L2 error vs n×n Gauss-Seidel", 0, 0, series, 2, 1};
    if (plot_write_png(&spec, path) != 0)
        bench_fail("cannot write '%s': %s", path, strerror(errno));
    else
        rc = 0;
out:
    free(x);
    free(x2);
    free(y);
    free(labels);
    return rc;
}

static void print_table_header(int opencl)
{
    printf("\n%7s %5s %5s %8s %8s %7s %26s %26s %26s %8s %9s %9s %18s", "n", "k", "d",
           "mem_MB", "paper_MB", "prep_s", "ours_ms (min-max)", "paper_ms (min-max)",
           "3sgemv_ms (min-max)", "floor_ms", "rel_l2", "max_rel", "auto_ms (path)");
    if (opencl)
        printf(" %26s %10s %11s %13s", "opencl_ms (min-max)", "kernel_ms", "transfer_ms",
               "ratio_to_ours");
    printf("  %s\n", "note");
}

static void print_table_row(const cell_result *r, int opencl)
{
    char t[3][128], e1[24], e2[24], fl[32];
    const timing *tm[3] = {&r->ours, &r->paper, &r->sgemv3};
    for (int i = 0; i < 3; i++) {
        char med[32], lo[32], hi[32];
        bench_fmt_ms(med, sizeof med, tm[i]->median);
        bench_fmt_ms(lo, sizeof lo, tm[i]->min);
        bench_fmt_ms(hi, sizeof hi, tm[i]->max);
        snprintf(t[i], sizeof t[i], "%s (%s-%s)", med, lo, hi);
    }
    bench_fmt_ms(fl, sizeof fl, r->floor_ms);
    if (isnan(r->rel_l2)) {
        snprintf(e1, sizeof e1, "n/a");
        snprintf(e2, sizeof e2, "n/a");
    } else {
        snprintf(e1, sizeof e1, "%.3g", r->rel_l2);
        snprintf(e2, sizeof e2, "%.3g", r->max_rel);
    }
    char am[32], au[64];
    bench_fmt_ms(am, sizeof am, r->ours_auto.median);
    snprintf(au, sizeof au, "%s (%s)", am, r->auto_path);
    printf("%7zu %5zu %5zu %8.1f %8.1f %7.2f %26s %26s %26s %8s %9s %9s %18s", r->n, r->k,
           r->d, r->mem_mb, r->mem_mb_paper, r->preprocess_s, t[0], t[1], t[2], fl, e1, e2, au);
    if (opencl) {
        char med[32], lo[32], hi[32], oc[128], km[32], tx[32], ra[32];
        snprintf(oc, sizeof oc, "%s (%s-%s)", bench_fmt_ms(med, sizeof med, r->ocl.median),
                 bench_fmt_ms(lo, sizeof lo, r->ocl.min), bench_fmt_ms(hi, sizeof hi, r->ocl.max));
        if (isnan(r->ocl_ratio))
            snprintf(ra, sizeof ra, "-");
        else
            snprintf(ra, sizeof ra, "%.2f", r->ocl_ratio);
        snprintf(km, sizeof km, "%.3g", r->ocl_kernel_ms);
        snprintf(tx, sizeof tx, "%.3g", r->ocl_transfer_ms);
        printf(" %26s %10s %11s %13s", oc, km, tx, ra);
    }
    printf("  %s\n", r->note);
    fflush(stdout);
}

/* ---------------------------------------------------------------- command */
/* The options into *a. Returns BENCH_RUN, or the exit status (CLI_EXIT_OK after --help). */
static int table_parse(int argc, char *argv[], table_args *a)
{
    static const char prog[] = "lrr-bench table";
    static const struct option longopts[] = {
        {"scene", required_argument, NULL, OPT_SCENE},
        {"cells", required_argument, NULL, OPT_CELLS},
        {"hemicube", required_argument, NULL, OPT_HEMICUBE},
        {"seed", required_argument, NULL, OPT_SEED},
        {"csv", required_argument, NULL, OPT_CSV},
        {"plot", required_argument, NULL, OPT_PLOT},
        {"memory-budget", required_argument, NULL, OPT_MEMORY_BUDGET},
        {"repeat", required_argument, NULL, OPT_REPEAT},
        {"backend", required_argument, NULL, OPT_BACKEND},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    size_t budget_mib = DEFAULT_BUDGET_MIB;
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(table_help, stdout);
            return CLI_EXIT_OK;
        case OPT_SCENE:
            a->scene = optarg;
            break;
        case OPT_CELLS:
            if (parse_cells(prog, optarg, &a->cells, &a->n_cells, &a->cells_name) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &a->hemicube) != 0)
                return CLI_EXIT_USAGE;
            if (a->hemicube % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", a->hemicube);
                return CLI_EXIT_USAGE;
            }
            break;
        case OPT_SEED:
            if (cli_parse_u64(prog, "--seed", optarg, 0, UINT64_MAX, &a->seed) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_CSV:
            a->csv = optarg;
            break;
        case OPT_PLOT:
            a->plot = optarg;
            break;
        case OPT_MEMORY_BUDGET:
            if (cli_parse_size(prog, "--memory-budget", optarg, 1, SIZE_MAX >> 20, &budget_mib) !=
                0)
                return CLI_EXIT_USAGE;
            a->budget = budget_mib << 20;
            break;
        case OPT_REPEAT:
            if (cli_parse_unsigned(prog, "--repeat", optarg, 1, 1000000, &a->repeat) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_BACKEND:
            if (bench_parse_backend(prog, optarg, &a->opencl) != 0)
                return CLI_EXIT_USAGE;
            break;
        default:
            return bench_bad_option(prog, c, argv);
        }
    }
    if (bench_no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if ((a->csv && !a->csv[0]) || (a->plot && !a->plot[0])) {
        cli_usage_error(prog, "--csv/--plot: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (!a->cells && parse_cells(prog, "paper", &a->cells, &a->n_cells, &a->cells_name) != 0)
        return bench_fail("out of memory");
    return BENCH_RUN;
}

/* The run's configuration, then the read bandwidth (returned, bytes per second; 0 when it
 * could not be measured) and the table's header. */
static double table_print_setup(const table_args *a)
{
    printf("benchmark: table\n");
    bench_print_machine();
    printf("scene: %s\n", a->scene);
    printf("cells: %s (%zu)\n", a->cells_name ? a->cells_name : "paper", a->n_cells);
    printf("hemicube: %u\n", a->hemicube);
    printf("seed: %llu\n", (unsigned long long)a->seed);
    printf("memory_budget_mib: %zu\n", a->budget >> 20);
    fflush(stdout);
    size_t llc = bench_llc_bytes(), bw_bytes = bench_bandwidth_buffer_bytes();
    printf("llc_mib: %zu\n", llc >> 20);
    bench_note("measuring the read bandwidth (%d passes over %zu MiB)", BANDWIDTH_PASSES,
               bw_bytes >> 20);
    double bw = bench_measure_bandwidth(bw_bytes);
    if (bw > 0)
        printf("read_bandwidth_gbs: %.2f (OpenMP sum over %zu MiB, best of %d, %d threads)\n",
               bw / 1e9, bw_bytes >> 20, BANDWIDTH_PASSES, omp_get_max_threads());
    else
        printf("read_bandwidth_gbs: nan (cannot allocate %zu MiB)\n", bw_bytes >> 20);
    printf("units: memory in MB = 10^6 bytes; times in ms per frame (median (min-max)); "
           "floor = F̄ bytes / read bandwidth\n");
    print_table_header(a->opencl);
    fflush(stdout);
    return bw;
}

/* Every cell in turn, each printed (and the CSV and plot rewritten) when measured; then the
 * final plot. */
static int table_run(const table_args *a)
{
    lrr_context *ctx = NULL;
    int rc;
    if ((rc = bench_start(a->scene, a->opencl, &ctx)) != CLI_EXIT_OK)
        return rc;
    cell_result *res = calloc(a->n_cells, sizeof *res);
    if (!res) {
        lrr_context_destroy(ctx);
        return bench_fail("out of memory");
    }
    double t_start = cli_now();
    double bw = table_print_setup(a);

    rc = CLI_EXIT_OK;
    size_t done = 0;
    for (size_t i = 0; i < a->n_cells; i++) {
        int crc = run_cell(ctx, a, &a->cells[i], i, bw, &res[done]);
        if (crc && res[done].n == 0) { /* nothing measured: stop */
            rc = crc;
            break;
        }
        if (crc)
            rc = crc; /* a failed check: keep the row, report it, carry on */
        print_table_row(&res[done], a->opencl);
        done++;
        if (a->csv && write_table_csv(a->csv, res, done) != 0) {
            rc = CLI_EXIT_FAIL;
            break;
        }
        if (a->plot && write_table_plot(a->plot, a, res, done) < 0) {
            rc = CLI_EXIT_FAIL;
            break;
        }
    }
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
    if (a->csv && done)
        printf("csv: %s\n", a->csv);
    if (a->plot && done) {
        int prc = write_table_plot(a->plot, a, res, done);
        if (prc == 0)
            printf("plot: %s\n", a->plot);
        else if (prc == 1) {
            bench_fail("--plot %s: no cell has an error estimate (all n/a), nothing plotted",
                       a->plot);
            rc = CLI_EXIT_FAIL;
        } else
            rc = CLI_EXIT_FAIL;
    }
    free(res);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_table(int argc, char *argv[])
{
    table_args a = {.scene = "cornell", .hemicube = DEFAULT_HEMICUBE, .seed = DEFAULT_SEED,
                    .budget = (size_t)DEFAULT_BUDGET_MIB << 20};
    int rc = table_parse(argc, argv, &a);
    if (rc == BENCH_RUN)
        rc = table_run(&a);
    free(a.cells);
    return rc;
}
