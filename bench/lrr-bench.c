/*
 * lrr-bench — the benchmark driver of the Low-Rank Radiosity library.
 *
 *   lrr-bench table     the paper's n×k table: memory, preprocessing, real-time step (ours,
 *                       the paper's two-gemv method, three plain sgemv), a bandwidth floor and
 *                       the error against the full n×n solution, as a table, CSV and plot
 *   lrr-bench stress    closed rooms with uniform emission and reflectance up to 0.999, where
 *                       B = E/(1 − rho) exactly: the operator and every reference solver
 *   lrr-bench hemicube  hemicube resolution against closed-form view factors and R = 512
 *
 * Results go to stdout ('key: value' lines and aligned tables), progress to stderr. Exit
 * status: 0 success, 1 a failure (library error, I/O, a check that did not hold), 2 a
 * malformed command line. Uses only the public API (lrr.h), cblas for the baselines.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <cblas.h>

#include "cli.h"
#include "lrr.h"
#include "plot.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define DEFAULT_HEMICUBE 128u
#define DEFAULT_SEED 1u
#define DEFAULT_BUDGET_MIB 4096u
#define MB 1e6 /* memory columns are in MB = 10^6 bytes */
#define MIN_RUNS 20
#define MIN_SECONDS 0.5
#define MAX_RUNS 200000
#define BANDWIDTH_MIN_BYTES ((size_t)512 << 20)
#define BANDWIDTH_MAX_BYTES ((size_t)4 << 30)
#define BANDWIDTH_PASSES 5
#define REFERENCE_TOL 1e-7
#define PAPER_MATCH_TOL 1e-4

enum {
    OPT_SCENE = 256,
    OPT_CELLS,
    OPT_HEMICUBE,
    OPT_CSV,
    OPT_PLOT,
    OPT_MEMORY_BUDGET,
    OPT_REPEAT,
    OPT_SEED,
    OPT_QUICK,
    OPT_SEEDS
};

/* ------------------------------------------------------------------ help texts */
static const char main_help[] =
    "Usage: lrr-bench COMMAND [OPTIONS]\n"
    "Benchmarks of the Low-Rank Radiosity library.\n"
    "\n"
    "Commands:\n"
    "  table      the n×k table of the paper: memory, preprocessing, real-time step of lrr,\n"
    "             of the paper's method and of three plain sgemv, a bandwidth floor and the\n"
    "             error against the full n×n solution\n"
    "  stress     closed empty rooms, uniform emission, rho up to 0.999: the operator and the\n"
    "             reference solvers against the exact B = E/(1 - rho)\n"
    "  hemicube   form-factor error and preprocessing time against hemicube resolution\n"
    "\n"
    "Options:\n"
    "  -h, --help     show this help (COMMAND --help: help on a command)\n"
    "  -V, --version  print the library version\n"
    "\n"
    "Threads: OMP_NUM_THREADS (lrr) and OPENBLAS_NUM_THREADS (the cblas baselines).\n"
    "Exit status: 0 success, 1 failure or a failed check, 2 bad command line.\n";

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
    "Memory in MB = 10^6 bytes: mem_mb = F̄ (n·k floats) + M (3·k² floats);\n"
    "mem_mb_paper = 2·n·k·4 bytes (U and V dense, as the paper counted; the paper's own\n"
    "column is in MiB, see mem_mib_paper in the CSV).\n"
    "floor_ms = F̄'s bytes (n·k·4) / the read bandwidth measured at the start of the run\n"
    "(an OpenMP sum over max(512 MiB, 4 × the last-level cache), best of 5): every\n"
    "implementation reads F̄ (or the paper's Y) once per channel or frame. Our full path\n"
    "also reads M (3·k² floats), which matters when k nears n: floor_ms_full in the CSV\n"
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
    "                       rt_ms_3sgemv,floor_ms,rel_l2,max_rel, then extra columns\n"
    "  --plot OUT.png       rel_l2 against real-time ms, log-log: ours (labelled n×k) and\n"
    "                       the paper's method (the same operator, so the same error),\n"
    "                       joined per cell; cells with an error only\n"
    "  --memory-budget MB   most memory for the n×n reference, in MiB (2^20 bytes;\n"
    "                       default 4096)\n"
    "  --repeat N           timed runs per implementation (default: adaptive, at least 20\n"
    "                       runs and at least 0.5 s)\n"
    "  -h, --help           show this help\n";

static const char stress_help[] =
    "Usage: lrr-bench stress [OPTIONS]\n"
    "Closed rooms with nothing inside, every face pointing inwards: 'box' (a sealed\n"
    "2 × 1.5 × 1 box) and 'l-room' (an L-shaped, non-convex room), built with\n"
    "lrr_scene_create from unit squares (watertight, no T-junctions). Uniform emission\n"
    "E = 1 and reflectance rho in {0.5, 0.9, 0.99, 0.999}, so B = E/(1 - rho) exactly when\n"
    "the rows of F sum to 1. For each room and rho: the operator (lrr_solve) and each\n"
    "reference method (jacobi, gauss-seidel, southwell, direct; tol 1e-6) against the exact\n"
    "answer: max relative error, area-weighted relative L2, iterations, seconds, status,\n"
    "non-finite values, condition estimates and the range of row sums of F̄·d (operator)\n"
    "or F (reference).\n"
    "\n"
    "Options:\n"
    "  --csv OUT.csv        one row per (scene, rho, method): scene,n,k,d,rho,method,\n"
    "                       max_rel_err,rel_l2,iterations,seconds,residual,status,\n"
    "                       nonfinite,cond_max,row_sum_min,row_sum_max\n"
    "  --hemicube R         hemicube resolution (default 128; 64 with --quick)\n"
    "  --quick              smaller rooms (n about 100-200), for tests\n"
    "  -h, --help           show this help\n";

static const char hemicube_help[] =
    "Usage: lrr-bench hemicube [OPTIONS]\n"
    "For R in 16, 32, 64, 128, 256: preprocessing time of the Cornell box (216 patches,\n"
    "d = 4) and form-factor errors of\n"
    "  parallel     unit squares facing each other at distance 1 (closed form 0.19982)\n"
    "  perpendicular unit squares sharing an edge (closed form 0.20004)\n"
    "as relative errors against the closed forms (Howell's catalogue, computed here) and\n"
    "against the exact point-to-polygon form factors (Lambert) averaged over the same\n"
    "subpatch centres (the hemicube's own error, without the quadrature's), and the relative\n"
    "L2 difference of the Cornell F̄ from an R = 512 build.\n"
    "The library always applies its random rotation about the normal (there is no API to\n"
    "turn it off), so every row is 'with rotation'; rows for several seeds show how much\n"
    "the rotation changes the result.\n"
    "\n"
    "Options:\n"
    "  --csv OUT.csv        R,seed,rotation,cornell_preprocess_s,f_parallel,err_parallel,\n"
    "                       err_parallel_quadrature,f_perpendicular,err_perpendicular,\n"
    "                       err_perpendicular_quadrature,cornell_rel_l2,n_cornell,k_cornell\n"
    "  --seeds N            seeds 1..N per resolution (1..10, default 3)\n"
    "  --quick              R in 16, 32 only, one seed, R = 128 as the reference (for tests)\n"
    "  -h, --help           show this help\n";

/* ------------------------------------------------------------------ messages */
static int bench_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static int bench_fail(const char *fmt, ...)
{
    va_list ap;
    fputs("lrr-bench: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return CLI_EXIT_FAIL;
}

/* "lrr-bench: <what>: <status>: <library message>" */
static int lib_fail(lrr_context *ctx, lrr_status s, const char *what)
{
    char msg[1024] = "";
    if (ctx && lrr_context_last_error(ctx, msg, sizeof msg) == LRR_OK)
        msg[0] = '\0';
    return bench_fail("%s: %s%s%s", what, lrr_strerror(s), msg[0] ? ": " : "", msg);
}

static void note(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
static void note(const char *fmt, ...)
{
    va_list ap;
    fputs("lrr-bench: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    fflush(stderr);
}

static int bad_option(const char *prog, int c, char *const argv[])
{
    const char *arg = optind > 0 ? argv[optind - 1] : "";
    if (c == ':')
        cli_usage_error(prog, "%s: a value is required", arg);
    else if (strncmp(arg, "--", 2) == 0 || optopt == 0 || optopt > 255)
        cli_usage_error(prog, "unknown option '%s'", arg);
    else
        cli_usage_error(prog, "unknown option '-%c'", optopt);
    fprintf(stderr, "Try '%s --help'.\n", prog);
    return CLI_EXIT_USAGE;
}

static void start_getopt(void)
{
    opterr = 0;
    optind = 0; /* glibc: re-initialise the scanner */
}

static int no_positional(const char *prog, int argc, char *const argv[])
{
    if (optind < argc) {
        cli_usage_error(prog, "unexpected argument '%s'", argv[optind]);
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    return 0;
}

/* ------------------------------------------------------------------ machine description */
static void cpu_model(char *buf, size_t len)
{
    snprintf(buf, len, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "model name", 10) != 0)
            continue;
        char *colon = strchr(line, ':');
        if (!colon)
            continue;
        colon++;
        while (*colon == ' ' || *colon == '\t')
            colon++;
        colon[strcspn(colon, "\n")] = '\0';
        snprintf(buf, len, "%s", colon);
        break;
    }
    fclose(f);
}

static void print_machine(void)
{
    char cpu[256], date[64];
    cpu_model(cpu, sizeof cpu);
    time_t t = time(NULL);
    struct tm tm;
    localtime_r(&t, &tm);
    strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S %z", &tm);
    printf("cpu: %s\n", cpu);
    printf("cores_online: %ld\n", sysconf(_SC_NPROCESSORS_ONLN));
    printf("threads_openmp: %d\n", omp_get_max_threads());
    printf("threads_openblas: %d\n", openblas_get_num_threads());
    printf("openblas: %s\n", openblas_get_config());
    printf("lrr: %s\n", lrr_version_string());
    printf("date: %s\n", date);
    /* timings on a shared machine mean little when it is busy: say how busy it was */
    FILE *f = fopen("/proc/loadavg", "r");
    double l1, l5, l15;
    if (f && fscanf(f, "%lf %lf %lf", &l1, &l5, &l15) == 3)
        printf("load_average: %.2f %.2f %.2f\n", l1, l5, l15);
    if (f)
        fclose(f);
}

/* ------------------------------------------------------------------ scenes */
static int open_scene(lrr_context *ctx, const char *name, lrr_scene **scene)
{
    struct stat st;
    lrr_status s;
    if (stat(name, &st) == 0)
        s = lrr_scene_load(ctx, name, scene);
    else if (strcmp(name, "cornell") == 0 || strcmp(name, "cornell-closed") == 0)
        s = lrr_scene_builtin(ctx, name, scene);
    else
        return bench_fail("scene '%s': %s (built-in scenes: cornell, cornell-closed)", name,
                          strerror(errno));
    if (s != LRR_OK) {
        char what[512];
        snprintf(what, sizeof what, "scene '%s'", name);
        return lib_fail(ctx, s, what);
    }
    return CLI_EXIT_OK;
}

/* levels with 4^levels = d, or -1 */
static int levels_of(size_t d)
{
    int l = 0;
    while (d > 1 && d % 4 == 0) {
        d /= 4;
        l++;
    }
    return d == 1 && l <= 10 ? l : -1;
}

/* Progress on stderr: a bar on a terminal, nothing otherwise (phase lines say enough). */
static void progress_begin(cli_progress *bar, const char *label, lrr_build_options *bo)
{
    cli_progress_init(bar, label, isatty(STDERR_FILENO));
    bo->progress = cli_progress_cb;
    bo->progress_user = bar;
}

/* ------------------------------------------------------------------ timing */
typedef struct timing {
    double median, min, max; /* milliseconds */
    size_t runs;
} timing;

typedef int (*frame_fn)(void *user);

/* Two warm-up runs, then `repeat` timed runs (0: adaptive, at least MIN_RUNS and at least
 * MIN_SECONDS in all). Returns 0 or the frame's non-zero status. */
static int time_frames(frame_fn fn, void *user, unsigned repeat, timing *t)
{
    int rc = fn(user);
    if (rc)
        return rc;
    double t0 = cli_now();
    if ((rc = fn(user)))
        return rc;
    double est = cli_now() - t0;
    size_t runs = repeat;
    if (!runs) {
        double want = est > 0 ? ceil(MIN_SECONDS / est) : (double)MAX_RUNS;
        runs = want < MIN_RUNS ? MIN_RUNS : want > MAX_RUNS ? MAX_RUNS : (size_t)want;
    }
    double *v = malloc(runs * sizeof *v);
    if (!v)
        return bench_fail("cannot allocate %zu timings", runs);
    for (size_t r = 0; r < runs; r++) {
        double a = cli_now();
        if ((rc = fn(user))) {
            free(v);
            return rc;
        }
        v[r] = 1e3 * (cli_now() - a);
    }
    t->min = t->max = v[0];
    for (size_t r = 1; r < runs; r++) {
        t->min = fmin(t->min, v[r]);
        t->max = fmax(t->max, v[r]);
    }
    t->median = cli_median(v, runs);
    t->runs = runs;
    free(v);
    return 0;
}

/* Size of the last-level cache in bytes (the highest cache index sysfs lists), 0 if unknown. */
static size_t llc_bytes(void)
{
    size_t best = 0;
    for (int i = 0; i < 8; i++) {
        char path[96];
        snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/size", i);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        unsigned long long v = 0;
        char unit = 0;
        if (fscanf(f, "%llu%c", &v, &unit) >= 1) {
            if (unit == 'K')
                v <<= 10;
            else if (unit == 'M')
                v <<= 20;
            if (v > best)
                best = (size_t)v;
        }
        fclose(f);
    }
    return best;
}

/* Bytes of the bandwidth buffer: four times the last-level cache (some servers have
 * hundreds of MiB of it), at least 512 MiB, at most 4 GiB. */
static size_t bandwidth_buffer_bytes(void)
{
    size_t llc = llc_bytes();
    size_t b = llc <= BANDWIDTH_MAX_BYTES / 4 ? 4 * llc : BANDWIDTH_MAX_BYTES;
    return b < BANDWIDTH_MIN_BYTES ? BANDWIDTH_MIN_BYTES : b;
}

/* Read bandwidth: an OpenMP sum over a buffer much larger than the caches, best of several
 * passes, in bytes per second (0 on failure). */
static double measure_bandwidth(size_t bytes)
{
    size_t count = bytes / sizeof(float);
    float *buf = lrr_aligned_alloc(count * sizeof(float));
    if (!buf)
        return 0;
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < count; i++)
        buf[i] = 1.0f; /* first touch by the thread that will read it */
    double best = 0, check = 0;
    /* eight independent 4-wide accumulators: the adds' latency must not be what limits a
     * core (one scalar or one vector chain tops out near 12-24 GB/s per core) */
    typedef float v4 __attribute__((vector_size(16)));
    enum { ACC = 8, STEP = 4 * ACC };
    const size_t blocks = count / STEP;
    for (int pass = 0; pass < BANDWIDTH_PASSES; pass++) {
        double total = 0;
        double a = cli_now();
        #pragma omp parallel reduction(+ : total)
        {
            v4 acc[ACC];
            for (int l = 0; l < ACC; l++)
                acc[l] = (v4){0, 0, 0, 0};
            #pragma omp for schedule(static)
            for (size_t b = 0; b < blocks; b++) {
                const v4 *p = (const v4 *)(const void *)(buf + b * STEP);
                for (int l = 0; l < ACC; l++)
                    acc[l] += p[l];
            }
            for (int l = 0; l < ACC; l++)
                total += (double)acc[l][0] + acc[l][1] + acc[l][2] + acc[l][3];
        }
        double s = cli_now() - a;
        check += total;
        if (s > 0 && (double)(count * sizeof(float)) / s > best)
            best = (double)(count * sizeof(float)) / s;
    }
    lrr_aligned_free(buf);
    /* the sums are used, so no pass can be optimised away */
    return check > 0 ? best : 0;
}

/* ================================================================== table */
typedef struct cell {
    size_t n, k, d;
} cell;

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

typedef struct cell_result {
    cell target;
    size_t n, k, d;
    double mem_mb, mem_mb_paper, mem_mib_paper, preprocess_s;
    timing ours, paper, sgemv3, ours_auto;
    char auto_path[16], kernel[32];
    double floor_ms, floor_ms_full, bandwidth_gbs;
    double rel_l2, max_rel, rel_l2_reflected, reference_s, reference_residual;
    double paper_vs_ours;
    double cond[3];
    int threads;
    char label[64];
    char note[256];
} cell_result;

typedef struct table_args {
    const char *scene, *csv, *plot;
    unsigned hemicube, repeat;
    uint64_t seed;
    size_t budget;
    cell *cells;
    size_t n_cells;
    const char *cells_name;
} table_args;

/* --cells: a named set or "N/K/D,N/K/D,..." */
static int parse_cells(const char *prog, const char *text, table_args *a)
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
    free(a->cells);
    a->cells = NULL;
    a->cells_name = text;
    if (src) {
        a->cells = malloc(count * sizeof *a->cells);
        if (!a->cells)
            return -1;
        memcpy(a->cells, src, count * sizeof *src);
        a->n_cells = count;
        return 0;
    }
    if (strcmp(text, "all") == 0) {
        size_t np = sizeof paper_cells / sizeof paper_cells[0];
        size_t ne = sizeof extra_cells / sizeof extra_cells[0];
        a->cells = malloc((np + ne) * sizeof *a->cells);
        if (!a->cells)
            return -1;
        memcpy(a->cells, extra_cells, ne * sizeof *extra_cells);
        memcpy(a->cells + ne, paper_cells, np * sizeof *paper_cells);
        a->n_cells = np + ne;
        return 0;
    }
    /* a list */
    size_t cap = 1;
    for (const char *p = text; *p; p++)
        cap += *p == ',';
    a->cells = calloc(cap, sizeof *a->cells);
    if (!a->cells)
        return -1;
    a->n_cells = 0;
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
        if (levels_of((size_t)v[2]) < 0) {
            cli_usage_error(prog, "--cells: d = %llu is not a power of 4 (1, 4, ..., 4^10)",
                            v[2]);
            return -1;
        }
        a->cells[a->n_cells++] = (cell){(size_t)v[0], (size_t)v[1], (size_t)v[2]};
    }
    if (a->n_cells == 0)
        goto bad;
    return 0;
bad:
    cli_usage_error(prog, "--cells: '%s' is not paper, small, all or a list N/K/D,...", text);
    return -1;
}

/* ---------------------------------------------------------------- the three real-time steps */
typedef struct ours_frame {
    lrr_solver *solver;
    const float *e, *e_alt; /* e_alt: used on every other frame when not NULL */
    float *b;
    lrr_status status;
    unsigned long frame;
} ours_frame;

static int ours_step(void *user)
{
    ours_frame *f = user;
    const float *e = f->e_alt && (f->frame++ & 1) ? f->e_alt : f->e;
    f->status = lrr_solve(f->solver, e, f->b);
    return f->status != LRR_OK;
}

static const char *path_name(lrr_path p)
{
    switch (p) {
    case LRR_PATH_FULL:
        return "full";
    case LRR_PATH_SPARSE:
        return "sparse";
    case LRR_PATH_INCREMENTAL:
        return "incremental";
    default:
        return "auto";
    }
}

/* The paper's real-time step: B_c = E_c - Y_c (Vᵀ E_c), channels stored planar. */
typedef struct paper_frame {
    blasint n, k;
    float *v;        /* n×k indicator, dense */
    float *y[3];     /* n×k, Y_c = -diag(rho_c) F̄ M_c */
    float *e[3], *b[3];
    float *w;        /* k */
} paper_frame;

static int paper_step(void *user)
{
    paper_frame *f = user;
    for (int c = 0; c < 3; c++) {
        cblas_sgemv(CblasRowMajor, CblasTrans, f->n, f->k, 1.0f, f->v, f->k, f->e[c], 1, 0.0f,
                    f->w, 1);
        cblas_scopy(f->n, f->e[c], 1, f->b[c], 1);
        cblas_sgemv(CblasRowMajor, CblasNoTrans, f->n, f->k, -1.0f, f->y[c], f->k, f->w, 1, 1.0f,
                    f->b[c], 1);
    }
    return 0;
}

static void paper_free(paper_frame *f)
{
    lrr_aligned_free(f->v);
    lrr_aligned_free(f->w);
    for (int c = 0; c < 3; c++) {
        lrr_aligned_free(f->y[c]);
        lrr_aligned_free(f->e[c]);
        lrr_aligned_free(f->b[c]);
    }
    memset(f, 0, sizeof *f);
}

static float *alloc_floats(size_t a, size_t b)
{
    if (a == 0 || b == 0 || a > SIZE_MAX / sizeof(float) / b)
        return NULL;
    float *p = lrr_aligned_alloc(a * b * sizeof(float));
    if (p)
        memset(p, 0, a * b * sizeof(float));
    return p;
}

/* Builds the paper's Y_c and V from the operator (sgemm, outside any timing). */
static int paper_setup(const lrr_operator *op, const float *e, paper_frame *f)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    size_t n = oi.n, k = oi.k, d = oi.d;
    memset(f, 0, sizeof *f);
    f->n = (blasint)n;
    f->k = (blasint)k;
    f->v = alloc_floats(n, k);
    f->w = alloc_floats(k, 1);
    for (int c = 0; c < 3; c++) {
        f->y[c] = alloc_floats(n, k);
        f->e[c] = alloc_floats(n, 1);
        f->b[c] = alloc_floats(n, 1);
    }
    if (!f->v || !f->w || !f->y[0] || !f->y[1] || !f->y[2] || !f->e[0] || !f->e[1] ||
        !f->e[2] || !f->b[0] || !f->b[1] || !f->b[2]) {
        paper_free(f);
        return bench_fail("the paper's method: cannot allocate 4 n×k matrices (%.1f MB)",
                          4.0 * (double)n * (double)k * 4 / MB);
    }
    const float *fbar = lrr_operator_fbar(op), *m = lrr_operator_m(op);
    const float *rho = lrr_operator_reflectance(op);
    for (size_t i = 0; i < n; i++) {
        f->v[i * k + i / d] = 1.0f;
        for (int c = 0; c < 3; c++)
            f->e[c][i] = e[3 * i + c];
    }
    for (int c = 0; c < 3; c++) {
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, f->n, f->k, f->k, 1.0f, fbar,
                    f->k, m + (size_t)c * k * k, f->k, 0.0f, f->y[c], f->k);
        float *y = f->y[c];
        #pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++) {
            float r = -rho[3 * i + c];
            for (size_t p = 0; p < k; p++)
                y[i * k + p] *= r;
        }
    }
    return 0;
}

/* Three sgemv over F̄, one per channel, nothing else. */
typedef struct sgemv_frame {
    blasint n, k;
    const float *fbar;
    float *z[3], *out[3];
} sgemv_frame;

static int sgemv_step(void *user)
{
    sgemv_frame *f = user;
    for (int c = 0; c < 3; c++)
        cblas_sgemv(CblasRowMajor, CblasNoTrans, f->n, f->k, 1.0f, f->fbar, f->k, f->z[c], 1,
                    0.0f, f->out[c], 1);
    return 0;
}

/* ---------------------------------------------------------------- errors */
/* Area-weighted relative L2 over all channels and the largest relative error over entries
 * above 1e-3 of the largest reference value. With `skip_e` the emission is subtracted from
 * both (the reflected part only). */
static void compare_b(size_t n, const float *area, const float *b, const float *ref,
                      const float *e, double *rel_l2, double *max_rel)
{
    double num = 0, den = 0, bmax = 0;
    for (size_t i = 0; i < 3 * n; i++)
        bmax = fmax(bmax, fabs((double)ref[i] - (e ? e[i] : 0)));
    double mr = 0;
    for (size_t i = 0; i < n; i++) {
        double a = area ? area[i] : 1.0;
        for (int c = 0; c < 3; c++) {
            double r = (double)ref[3 * i + c] - (e ? e[3 * i + c] : 0);
            double x = (double)b[3 * i + c] - (e ? e[3 * i + c] : 0);
            double dlt = x - r;
            num += a * dlt * dlt;
            den += a * r * r;
            if (fabs(r) > 1e-3 * bmax)
                mr = fmax(mr, fabs(dlt) / fabs(r));
            if (!isfinite(x))
                mr = INFINITY;
        }
    }
    *rel_l2 = den > 0 ? sqrt(num) / sqrt(den) : (num > 0 ? INFINITY : 0);
    if (max_rel)
        *max_rel = mr;
}

/* 12.2 GB, 4.3 GB, 35.4 MB: decimal units, three significant digits or one decimal */
static const char *fmt_bytes(char *buf, size_t len, size_t bytes)
{
    double b = (double)bytes;
    if (b >= 1e9)
        snprintf(buf, len, "%.1f GB", b / 1e9);
    else if (b >= 1e6)
        snprintf(buf, len, "%.1f MB", b / 1e6);
    else
        snprintf(buf, len, "%.1f kB", b / 1e3);
    return buf;
}

static int reference_error(lrr_context *ctx, const lrr_scene *scene,
                           const lrr_build_options *bo, size_t budget, const float *b,
                           cell_result *r, const char *label)
{
    size_t need = lrr_reference_bytes(r->n);
    if (need == SIZE_MAX || need > budget) {
        char nb[32], bb[32];
        snprintf(r->note, sizeof r->note, "n×n needs %s > budget %s",
                 need == SIZE_MAX ? "more than SIZE_MAX bytes" : fmt_bytes(nb, sizeof nb, need),
                 fmt_bytes(bb, sizeof bb, budget));
        return 0;
    }
    lrr_reference *ref = NULL;
    cli_progress bar;
    lrr_build_options o = *bo;
    note("%s: reference: n×n form factors (%.1f MB)", label, (double)need / MB);
    progress_begin(&bar, "n×n hemicubes", &o);
    double t0 = cli_now();
    lrr_status s = lrr_reference_build(scene, &o, budget, &ref);
    cli_progress_finish(&bar);
    if (s == LRR_ERR_BUDGET) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        snprintf(r->note, sizeof r->note, "reference refused: %s", msg);
        return 0;
    }
    if (s != LRR_OK)
        return lib_fail(ctx, s, "reference build");
    float *bref = cli_alloc_rgb(r->n);
    if (!bref) {
        lrr_reference_destroy(ref);
        return CLI_EXIT_FAIL;
    }
    lrr_reference_stats st = {0};
    s = lrr_reference_solve(ref, LRR_METHOD_GAUSS_SEIDEL, REFERENCE_TOL, 0,
                            lrr_reference_emission(ref), bref, &st);
    r->reference_s = cli_now() - t0;
    r->reference_residual = st.residual;
    if (s != LRR_OK && s != LRR_NOT_CONVERGED) {
        free(bref);
        lrr_reference_destroy(ref);
        return lib_fail(ctx, s, "Gauss-Seidel reference solve");
    }
    if (s == LRR_NOT_CONVERGED) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        snprintf(r->note, sizeof r->note, "Gauss-Seidel stopped at residual %.2g after %zu",
                 st.residual, st.iterations);
    }
    note("%s: reference: Gauss-Seidel %zu sweeps, residual %.2g, %.2f s (%.1f s with F)",
         label, st.iterations, st.residual, st.seconds, r->reference_s);
    const float *area = lrr_reference_area(ref);
    compare_b(r->n, area, b, bref, NULL, &r->rel_l2, &r->max_rel);
    compare_b(r->n, area, b, bref, lrr_reference_emission(ref), &r->rel_l2_reflected, NULL);
    free(bref);
    lrr_reference_destroy(ref);
    return 0;
}

/* ---------------------------------------------------------------- one cell */
static int run_cell(lrr_context *ctx, const table_args *a, const cell *c, size_t index,
                    double bandwidth, cell_result *r)
{
    memset(r, 0, sizeof *r);
    r->target = *c;
    r->rel_l2 = r->max_rel = r->rel_l2_reflected = r->reference_s = NAN;
    r->reference_residual = r->paper_vs_ours = r->floor_ms = r->floor_ms_full = NAN;
    r->threads = omp_get_max_threads();
    r->bandwidth_gbs = bandwidth / 1e9;
    char label[96];
    snprintf(label, sizeof label, "[%zu/%zu] %zu×%zu (d %zu)", index + 1, a->n_cells, c->n, c->k,
             c->d);

    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    lrr_solver *solver = NULL;
    float *b = NULL;
    paper_frame pf = {0};
    sgemv_frame sf = {0};
    int rc = open_scene(ctx, a->scene, &scene);
    if (rc)
        return rc;
    lrr_subdivision sub = {0.0, c->k, (unsigned)levels_of(c->d)};
    lrr_status s = lrr_scene_subdivide(scene, &sub);
    if (s != LRR_OK) {
        rc = lib_fail(ctx, s, "subdivision");
        goto done;
    }
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si);
    r->n = si.subpatches;
    r->k = si.patches;
    r->d = si.d;
    snprintf(r->label, sizeof r->label, "%zu×%zu", r->n, r->k);
    note("%s: %zu patches, %zu subpatches; building the operator (hemicube %u)", label, r->k,
         r->n, a->hemicube);

    lrr_build_options bo = {.hemicube_resolution = a->hemicube, .seed = a->seed};
    cli_progress bar;
    progress_begin(&bar, "hemicubes", &bo);
    double t0 = cli_now();
    s = lrr_operator_build(scene, &bo, &op);
    r->preprocess_s = cli_now() - t0;
    cli_progress_finish(&bar);
    bo.progress = NULL;
    bo.progress_user = NULL;
    if (s != LRR_OK) {
        rc = lib_fail(ctx, s, "operator build");
        goto done;
    }
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    memcpy(r->cond, oi.condition, sizeof r->cond);
    if (!lrr_operator_fbar(op)) { /* a fresh build is float; the baselines need that view */
        rc = bench_fail("%s: F̄ is not stored as float (storage %s)", label,
                        lrr_storage_name(oi.storage));
        goto done;
    }
    double nk = (double)r->n * (double)r->k;
    r->mem_mb = (nk + 3.0 * (double)r->k * (double)r->k) * sizeof(float) / MB;
    r->mem_mb_paper = 2.0 * nk * sizeof(float) / MB;
    r->mem_mib_paper = 2.0 * nk * sizeof(float) / (1024.0 * 1024.0);
    /* every method reads F̄ (or Y) once; our full path also reads the three M_c */
    r->floor_ms = bandwidth > 0 ? 1e3 * nk * sizeof(float) / bandwidth : NAN;
    r->floor_ms_full = bandwidth > 0 ? 1e3 * r->mem_mb * MB / bandwidth : NAN;
    note("%s: operator built in %.2f s; timing the real-time step", label, r->preprocess_s);

    /* ours */
    const float *e = lrr_operator_emission(op);
    b = cli_alloc_rgb(r->n);
    if (!b) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    if ((s = lrr_solver_create(op, LRR_BACKEND_CPU, &solver)) != LRR_OK) {
        rc = lib_fail(ctx, s, "solver");
        goto done;
    }
    snprintf(r->kernel, sizeof r->kernel, "%s", lrr_solver_kernel(solver));
    if ((s = lrr_solver_set_path(solver, LRR_PATH_FULL)) != LRR_OK) {
        rc = lib_fail(ctx, s, "solver path");
        goto done;
    }
    ours_frame of = {solver, e, NULL, b, LRR_OK, 0};
    if (time_frames(ours_step, &of, a->repeat, &r->ours)) {
        rc = of.status != LRR_OK ? lib_fail(ctx, of.status, "lrr_solve") : CLI_EXIT_FAIL;
        goto done;
    }
    if (lrr_solver_last_path(solver) != LRR_PATH_FULL) {
        rc = bench_fail("%s: lrr_solve took the %s path, not the full one it was told to",
                        label, path_name(lrr_solver_last_path(solver)));
        goto done;
    }
    /* the default path, for an emission that changes every frame (into its own buffer) */
    {
        float *e_half = cli_alloc_rgb(r->n), *b_auto = cli_alloc_rgb(r->n);
        if (!e_half || !b_auto) {
            free(e_half);
            free(b_auto);
            rc = CLI_EXIT_FAIL;
            goto done;
        }
        for (size_t i = 0; i < 3 * r->n; i++)
            e_half[i] = 0.5f * e[i];
        ours_frame af = {solver, e, e_half, b_auto, LRR_OK, 0};
        if ((s = lrr_solver_set_path(solver, LRR_PATH_AUTO)) != LRR_OK)
            af.status = s;
        int arc = s != LRR_OK || time_frames(ours_step, &af, a->repeat, &r->ours_auto);
        snprintf(r->auto_path, sizeof r->auto_path, "%s",
                 path_name(lrr_solver_last_path(solver)));
        free(e_half);
        free(b_auto);
        if (arc) {
            rc = lib_fail(ctx, af.status, "lrr_solve (auto path)");
            goto done;
        }
    }
    for (size_t i = 0; i < 3 * r->n; i++)
        if (!isfinite(b[i])) {
            rc = bench_fail("%s: lrr_solve gave a non-finite value at subpatch %zu", label,
                            i / 3);
            goto done;
        }

    /* the paper's method */
    if ((rc = paper_setup(op, e, &pf)))
        goto done;
    if ((rc = time_frames(paper_step, &pf, a->repeat, &r->paper)))
        goto done;
    {
        double num = 0, den = 0;
        for (size_t i = 0; i < r->n; i++)
            for (int ch = 0; ch < 3; ch++) {
                double dlt = (double)pf.b[ch][i] - b[3 * i + ch];
                num += dlt * dlt;
                den += (double)b[3 * i + ch] * b[3 * i + ch];
            }
        r->paper_vs_ours = den > 0 ? sqrt(num / den) : sqrt(num);
        if (!(r->paper_vs_ours < PAPER_MATCH_TOL))
            rc = bench_fail("error: %s: the paper's method and lrr_solve disagree: relative "
                            "L2 %.3g >= %g (they are the same operator)",
                            label, r->paper_vs_ours, PAPER_MATCH_TOL);
    }
    /* three plain sgemv, with z_c = M_c Vᵀ E_c as the vectors */
    sf.n = pf.n;
    sf.k = pf.k;
    sf.fbar = lrr_operator_fbar(op);
    for (int ch = 0; ch < 3; ch++) {
        sf.z[ch] = alloc_floats(r->k, 1);
        sf.out[ch] = pf.b[ch]; /* reuse: the paper's check is done */
        if (!sf.z[ch]) {
            rc = bench_fail("cannot allocate z");
            goto done;
        }
        cblas_sgemv(CblasRowMajor, CblasTrans, pf.n, pf.k, 1.0f, pf.v, pf.k, pf.e[ch], 1, 0.0f,
                    pf.w, 1);
        cblas_sgemv(CblasRowMajor, CblasNoTrans, pf.k, pf.k, 1.0f,
                    lrr_operator_m(op) + (size_t)ch * r->k * r->k, pf.k, pf.w, 1, 0.0f, sf.z[ch],
                    1);
    }
    lrr_aligned_free(pf.v); /* V and Y are not needed any more */
    pf.v = NULL;
    for (int ch = 0; ch < 3; ch++) {
        lrr_aligned_free(pf.y[ch]);
        pf.y[ch] = NULL;
    }
    int rc3 = time_frames(sgemv_step, &sf, a->repeat, &r->sgemv3);
    if (rc3) {
        rc = rc3;
        goto done;
    }
    note("%s: ms ours %.3f (auto %.3f, %s), paper %.3f, 3 sgemv %.3f", label, r->ours.median,
         r->ours_auto.median, r->auto_path, r->paper.median, r->sgemv3.median);

    /* error against the n×n reference (the paper arrays are freed first) */
    for (int ch = 0; ch < 3; ch++) {
        lrr_aligned_free(sf.z[ch]);
        sf.z[ch] = NULL;
    }
    paper_free(&pf);
    lrr_solver_destroy(solver);
    solver = NULL;
    int rce = reference_error(ctx, scene, &bo, a->budget, b, r, label);
    if (rce)
        rc = rce;
done:
    for (int ch = 0; ch < 3; ch++)
        lrr_aligned_free(sf.z[ch]);
    paper_free(&pf);
    lrr_solver_destroy(solver);
    free(b);
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    return rc;
}

/* ---------------------------------------------------------------- output */
static const char table_csv_header[] =
    "n,k,d,mem_mb,mem_mb_paper,preprocess_s,rt_ms_ours,rt_ms_paper,rt_ms_3sgemv,floor_ms,"
    "rel_l2,max_rel,"
    "rt_ms_ours_min,rt_ms_ours_max,rt_ms_paper_min,rt_ms_paper_max,rt_ms_3sgemv_min,"
    "rt_ms_3sgemv_max,runs_ours,runs_paper,runs_3sgemv,n_target,k_target,d_target,"
    "mem_mib_paper,bandwidth_gbs,reference_s,rel_l2_reflected,paper_vs_ours,cond_r,cond_g,"
    "cond_b,threads,rt_ms_ours_auto,rt_ms_ours_auto_min,rt_ms_ours_auto_max,auto_path,kernel,"
    "floor_ms_full\n";

static void csv_num(FILE *f, double v, int last)
{
    if (isnan(v))
        fputs("nan", f);
    else if (isinf(v))
        fputs(v > 0 ? "inf" : "-inf", f);
    else
        fprintf(f, "%.6g", v);
    fputc(last ? '\n' : ',', f);
}

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
            csv_num(out.f, v[j], 0);
        fprintf(out.f, "%zu,%zu,%zu,%zu,%zu,%zu,", r->ours.runs, r->paper.runs, r->sgemv3.runs,
                r->target.n, r->target.k, r->target.d);
        const double w[] = {r->mem_mib_paper, r->bandwidth_gbs, r->reference_s,
                            r->rel_l2_reflected, r->paper_vs_ours, r->cond[0], r->cond[1],
                            r->cond[2]};
        for (size_t j = 0; j < sizeof w / sizeof w[0]; j++)
            csv_num(out.f, w[j], 0);
        fprintf(out.f, "%d,", r->threads);
        csv_num(out.f, r->ours_auto.median, 0);
        csv_num(out.f, r->ours_auto.min, 0);
        csv_num(out.f, r->ours_auto.max, 0);
        fprintf(out.f, "%s,%s,", r->auto_path, r->kernel);
        csv_num(out.f, r->floor_ms_full, 1);
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
        {"ours (lrr_solve, full path)", x, y, labels, m, {31, 119, 180}, PLOT_CIRCLE},
        {"paper's method (6 sgemv)", x2, y, NULL, m, {255, 127, 14}, PLOT_SQUARE}};
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

static const char *fmt_ms(char *buf, size_t len, double v)
{
    if (isnan(v))
        return snprintf(buf, len, "-"), buf;
    snprintf(buf, len, v < 10 ? "%.3f" : v < 100 ? "%.2f" : "%.1f", v);
    return buf;
}

static void print_table_header(void)
{
    printf("\n%7s %5s %5s %8s %8s %7s %26s %26s %26s %8s %9s %9s %18s  %s\n", "n", "k", "d",
           "mem_MB", "paper_MB", "prep_s", "ours_ms (min-max)", "paper_ms (min-max)",
           "3sgemv_ms (min-max)", "floor_ms", "rel_l2", "max_rel", "auto_ms (path)", "note");
}

static void print_table_row(const cell_result *r)
{
    char t[3][128], e1[24], e2[24], fl[32];
    const timing *tm[3] = {&r->ours, &r->paper, &r->sgemv3};
    for (int i = 0; i < 3; i++) {
        char med[32], lo[32], hi[32];
        fmt_ms(med, sizeof med, tm[i]->median);
        fmt_ms(lo, sizeof lo, tm[i]->min);
        fmt_ms(hi, sizeof hi, tm[i]->max);
        snprintf(t[i], sizeof t[i], "%s (%s-%s)", med, lo, hi);
    }
    fmt_ms(fl, sizeof fl, r->floor_ms);
    if (isnan(r->rel_l2)) {
        snprintf(e1, sizeof e1, "n/a");
        snprintf(e2, sizeof e2, "n/a");
    } else {
        snprintf(e1, sizeof e1, "%.3g", r->rel_l2);
        snprintf(e2, sizeof e2, "%.3g", r->max_rel);
    }
    char am[32], au[64];
    fmt_ms(am, sizeof am, r->ours_auto.median);
    snprintf(au, sizeof au, "%s (%s)", am, r->auto_path);
    printf("%7zu %5zu %5zu %8.1f %8.1f %7.2f %26s %26s %26s %8s %9s %9s %18s  %s\n", r->n, r->k,
           r->d, r->mem_mb, r->mem_mb_paper, r->preprocess_s, t[0], t[1], t[2], fl, e1, e2, au,
           r->note);
    fflush(stdout);
}

static int cmd_table(int argc, char *argv[])
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
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    table_args a = {.scene = "cornell", .hemicube = DEFAULT_HEMICUBE, .seed = DEFAULT_SEED,
                    .budget = (size_t)DEFAULT_BUDGET_MIB << 20};
    int rc = CLI_EXIT_USAGE;
    size_t budget_mib = DEFAULT_BUDGET_MIB;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(table_help, stdout);
            free(a.cells);
            return CLI_EXIT_OK;
        case OPT_SCENE:
            a.scene = optarg;
            break;
        case OPT_CELLS:
            if (parse_cells(prog, optarg, &a) != 0)
                goto out;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &a.hemicube) != 0)
                goto out;
            if (a.hemicube % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", a.hemicube);
                goto out;
            }
            break;
        case OPT_SEED:
            if (cli_parse_u64(prog, "--seed", optarg, 0, UINT64_MAX, &a.seed) != 0)
                goto out;
            break;
        case OPT_CSV:
            a.csv = optarg;
            break;
        case OPT_PLOT:
            a.plot = optarg;
            break;
        case OPT_MEMORY_BUDGET:
            if (cli_parse_size(prog, "--memory-budget", optarg, 1, SIZE_MAX >> 20, &budget_mib) !=
                0)
                goto out;
            a.budget = budget_mib << 20;
            break;
        case OPT_REPEAT:
            if (cli_parse_unsigned(prog, "--repeat", optarg, 1, 1000000, &a.repeat) != 0)
                goto out;
            break;
        default:
            rc = bad_option(prog, c, argv);
            goto out;
        }
    }
    if (no_positional(prog, argc, argv))
        goto out;
    if ((a.csv && !a.csv[0]) || (a.plot && !a.plot[0])) {
        cli_usage_error(prog, "--csv/--plot: the file name is empty");
        goto out;
    }
    if (!a.cells && parse_cells(prog, "paper", &a) != 0) {
        rc = bench_fail("out of memory");
        goto out;
    }

    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK) {
        rc = lib_fail(NULL, s, "context");
        goto out;
    }
    /* a scene that cannot be read fails now, not after the bandwidth measurement */
    lrr_scene *probe = NULL;
    if ((rc = open_scene(ctx, a.scene, &probe)) != CLI_EXIT_OK) {
        lrr_context_destroy(ctx);
        goto out;
    }
    lrr_scene_destroy(probe);
    cell_result *res = calloc(a.n_cells, sizeof *res);
    if (!res) {
        lrr_context_destroy(ctx);
        rc = bench_fail("out of memory");
        goto out;
    }
    double t_start = cli_now();
    printf("benchmark: table\n");
    print_machine();
    printf("scene: %s\n", a.scene);
    printf("cells: %s (%zu)\n", a.cells_name ? a.cells_name : "paper", a.n_cells);
    printf("hemicube: %u\n", a.hemicube);
    printf("seed: %llu\n", (unsigned long long)a.seed);
    printf("memory_budget_mib: %zu\n", a.budget >> 20);
    fflush(stdout);
    size_t llc = llc_bytes(), bw_bytes = bandwidth_buffer_bytes();
    printf("llc_mib: %zu\n", llc >> 20);
    note("measuring the read bandwidth (%d passes over %zu MiB)", BANDWIDTH_PASSES,
         bw_bytes >> 20);
    double bw = measure_bandwidth(bw_bytes);
    if (bw > 0)
        printf("read_bandwidth_gbs: %.2f (OpenMP sum over %zu MiB, best of %d, %d threads)\n",
               bw / 1e9, bw_bytes >> 20, BANDWIDTH_PASSES, omp_get_max_threads());
    else
        printf("read_bandwidth_gbs: nan (cannot allocate %zu MiB)\n", bw_bytes >> 20);
    printf("units: memory in MB = 10^6 bytes; times in ms per frame (median (min-max)); "
           "floor = F̄ bytes / read bandwidth\n");
    print_table_header();
    fflush(stdout);

    rc = CLI_EXIT_OK;
    size_t done = 0;
    for (size_t i = 0; i < a.n_cells; i++) {
        int crc = run_cell(ctx, &a, &a.cells[i], i, bw, &res[done]);
        if (crc && res[done].n == 0) { /* nothing measured: stop */
            rc = crc;
            break;
        }
        if (crc)
            rc = crc; /* a failed check: keep the row, report it, carry on */
        print_table_row(&res[done]);
        done++;
        if (a.csv && write_table_csv(a.csv, res, done) != 0) {
            rc = CLI_EXIT_FAIL;
            break;
        }
        if (a.plot && write_table_plot(a.plot, &a, res, done) < 0) {
            rc = CLI_EXIT_FAIL;
            break;
        }
    }
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
    if (a.csv && done)
        printf("csv: %s\n", a.csv);
    if (a.plot && done) {
        int prc = write_table_plot(a.plot, &a, res, done);
        if (prc == 0)
            printf("plot: %s\n", a.plot);
        else if (prc == 1) {
            bench_fail("--plot %s: no cell has an error estimate (all n/a), nothing plotted",
                       a.plot);
            rc = CLI_EXIT_FAIL;
        } else
            rc = CLI_EXIT_FAIL;
    }
    free(res);
    lrr_context_destroy(ctx);
out:
    free(a.cells);
    return rc;
}

/* ================================================================== stress */
/* A room as a union of unit voxels: one unit square per voxel face that borders the
 * outside, its normal pointing into the voxel, each split into two triangles. All vertices
 * lie on the integer grid (scaled per axis), so neighbouring squares share whole edges: the
 * room is watertight without T-junctions. */
typedef struct voxel_room {
    const char *name;
    const int (*vox)[3];
    size_t n_vox;
    double scale[3];
    size_t target_patches, quick_patches;
    unsigned levels, quick_levels;
} voxel_room;

static const int box_voxels[][3] = {{0, 0, 0}};
static const int l_voxels[][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};

static const voxel_room stress_rooms[] = {
    {"box", box_voxels, 1, {2.0, 1.5, 1.0}, 24, 12, 2, 2},
    {"l-room", l_voxels, 3, {1.0, 1.0, 0.8}, 28, 28, 2, 1},
};

static int voxel_at(const voxel_room *r, int x, int y, int z)
{
    for (size_t i = 0; i < r->n_vox; i++)
        if (r->vox[i][0] == x && r->vox[i][1] == y && r->vox[i][2] == z)
            return 1;
    return 0;
}

/* Writes the triangles (9 floats each) to v, or only counts them when v is NULL. */
static size_t voxel_triangles(const voxel_room *r, float *v)
{
    size_t t = 0;
    for (size_t i = 0; i < r->n_vox; i++)
        for (int ax = 0; ax < 3; ax++)
            for (int s = -1; s <= 1; s += 2) {
                int nb[3] = {r->vox[i][0], r->vox[i][1], r->vox[i][2]};
                nb[ax] += s;
                if (voxel_at(r, nb[0], nb[1], nb[2]))
                    continue;
                int bx = (ax + 1) % 3, cx = (ax + 2) % 3;
                double o[3] = {r->vox[i][0], r->vox[i][1], r->vox[i][2]};
                if (s > 0)
                    o[ax] += 1;
                double q[4][3];
                for (int j = 0; j < 4; j++)
                    memcpy(q[j], o, sizeof o);
                q[1][bx] += 1;
                q[2][bx] += 1;
                q[2][cx] += 1;
                q[3][cx] += 1;
                /* (q0, q1, q2) has normal e_bx × e_cx = +e_ax; the inward normal is -s·e_ax */
                int order[4] = {0, 1, 2, 3};
                if (s > 0) {
                    order[1] = 3;
                    order[3] = 1;
                }
                const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
                for (int h = 0; h < 2; h++, t++)
                    if (v)
                        for (int j = 0; j < 3; j++)
                            for (int k = 0; k < 3; k++)
                                v[9 * t + 3 * j + k] =
                                    (float)(q[order[tri[h][j]]][k] * r->scale[k]);
            }
    return t;
}

typedef struct stress_row {
    const char *scene;
    size_t n, k, d;
    double rho;
    const char *method;
    double max_rel, rel_l2;
    size_t iterations;
    double seconds, residual;
    char status[40];
    size_t nonfinite;
    double cond_max, row_min, row_max;
} stress_row;

/* max relative error and area-weighted relative L2 of b against the constant `exact` */
static void compare_exact(size_t n, const float *area, const float *b, double exact,
                          double *max_rel, double *rel_l2, size_t *nonfinite)
{
    double mr = 0, num = 0, den = 0;
    size_t bad = 0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            double x = b[3 * i + c];
            if (!isfinite(x)) {
                bad++;
                continue;
            }
            double dlt = x - exact;
            mr = fmax(mr, fabs(dlt) / exact);
            num += area[i] * dlt * dlt;
            den += area[i] * exact * exact;
        }
    *max_rel = bad ? INFINITY : mr;
    *rel_l2 = bad ? INFINITY : sqrt(num / den);
    *nonfinite = bad;
}

static void print_stress_row(const stress_row *r)
{
    char it[32], cond[32];
    if (r->iterations)
        snprintf(it, sizeof it, "%zu", r->iterations);
    else
        snprintf(it, sizeof it, "-");
    if (isnan(r->cond_max))
        snprintf(cond, sizeof cond, "-");
    else
        snprintf(cond, sizeof cond, "%.3g", r->cond_max);
    printf("%-7s %5zu %4zu %3zu %6g %-13s %10.3g %10.3g %9s %9.4f %-14s %4zu %9s %.7f..%.7f\n",
           r->scene, r->n, r->k, r->d, r->rho, r->method, r->max_rel, r->rel_l2, it, r->seconds,
           r->status, r->nonfinite, cond, r->row_min, r->row_max);
    fflush(stdout);
}

static int write_stress_csv(const char *path, const stress_row *rows, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs("scene,n,k,d,rho,method,max_rel_err,rel_l2,iterations,seconds,residual,status,"
          "nonfinite,cond_max,row_sum_min,row_sum_max\n",
          out.f);
    for (size_t i = 0; i < count; i++) {
        const stress_row *r = &rows[i];
        fprintf(out.f, "%s,%zu,%zu,%zu,%g,%s,", r->scene, r->n, r->k, r->d, r->rho, r->method);
        csv_num(out.f, r->max_rel, 0);
        csv_num(out.f, r->rel_l2, 0);
        fprintf(out.f, "%zu,", r->iterations);
        csv_num(out.f, r->seconds, 0);
        csv_num(out.f, r->residual, 0);
        fprintf(out.f, "%s,%zu,", r->status, r->nonfinite);
        csv_num(out.f, r->cond_max, 0);
        fprintf(out.f, "%.9g,%.9g\n", r->row_min, r->row_max);
    }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

static const char *status_word(lrr_status s)
{
    return s == LRR_OK ? "ok" : s == LRR_NOT_CONVERGED ? "not-converged" : lrr_strerror(s);
}

/* One room at one rho: the operator and the four reference methods. Appends 5 rows. */
static int stress_case(lrr_context *ctx, const voxel_room *room, int quick, unsigned R,
                       double rho, stress_row *rows, size_t *count)
{
    size_t ntri = voxel_triangles(room, NULL);
    float *v = calloc(ntri * 9, sizeof *v), *rh = calloc(ntri * 3, sizeof *rh);
    float *em = calloc(ntri * 3, sizeof *em);
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    lrr_solver *solver = NULL;
    lrr_reference *ref = NULL;
    float *e = NULL, *b = NULL;
    int rc = CLI_EXIT_OK;
    lrr_status s;
    if (!v || !rh || !em) {
        rc = bench_fail("out of memory");
        goto done;
    }
    voxel_triangles(room, v);
    for (size_t i = 0; i < ntri * 3; i++) {
        rh[i] = (float)rho;
        em[i] = 1.0f;
    }
    if ((s = lrr_scene_create(ctx, ntri, v, rh, em, room->name, &scene)) != LRR_OK) {
        rc = lib_fail(ctx, s, room->name);
        goto done;
    }
    lrr_subdivision sub = {0.0, quick ? room->quick_patches : room->target_patches,
                           quick ? room->quick_levels : room->levels};
    if ((s = lrr_scene_subdivide(scene, &sub)) != LRR_OK) {
        rc = lib_fail(ctx, s, "subdivision");
        goto done;
    }
    lrr_build_options bo = {.hemicube_resolution = R, .seed = DEFAULT_SEED};
    double t0 = cli_now();
    if ((s = lrr_operator_build(scene, &bo, &op)) != LRR_OK) {
        rc = lib_fail(ctx, s, "operator build");
        goto done;
    }
    double build_s = cli_now() - t0;
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    size_t n = oi.n, k = oi.k, d = oi.d;
    e = cli_alloc_rgb(n);
    b = cli_alloc_rgb(n);
    if (!e || !b) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    for (size_t i = 0; i < 3 * n; i++)
        e[i] = 1.0f;
    const double exact = 1.0 / (1.0 - rho);
    const float *area = lrr_operator_area(op);

    /* the operator: rows of F̄·d are the form factors to whole patches */
    stress_row r = {room->name, n, k, d, rho, "lrr", 0, 0, 0, 0, NAN, "", 0, 0, INFINITY,
                    -INFINITY};
    const float *fbar = lrr_operator_fbar(op);
    for (size_t i = 0; i < n; i++) {
        double sum = 0;
        for (size_t p = 0; p < k; p++)
            sum += fbar[i * k + p];
        sum *= (double)d;
        r.row_min = fmin(r.row_min, sum);
        r.row_max = fmax(r.row_max, sum);
    }
    r.cond_max = fmax(oi.condition[0], fmax(oi.condition[1], oi.condition[2]));
    if ((s = lrr_solver_create(op, LRR_BACKEND_CPU, &solver)) != LRR_OK ||
        (s = lrr_solver_set_path(solver, LRR_PATH_FULL)) != LRR_OK) {
        rc = lib_fail(ctx, s, "solver");
        goto done;
    }
    t0 = cli_now();
    s = lrr_solve(solver, e, b);
    r.seconds = cli_now() - t0;
    snprintf(r.status, sizeof r.status, "%s", status_word(s));
    if (s != LRR_OK) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        note("%s rho %g lrr_solve: %s%s%s", room->name, rho, lrr_strerror(s), msg[0] ? ": " : "",
             msg);
        r.max_rel = r.rel_l2 = NAN;
    } else {
        compare_exact(n, area, b, exact, &r.max_rel, &r.rel_l2, &r.nonfinite);
    }
    rows[(*count)++] = r;
    print_stress_row(&r);
    note("%s rho %g: operator n %zu built in %.2f s; reference solvers", room->name, rho, n,
         build_s);

    /* the reference: full F from the same hemicubes */
    if ((s = lrr_reference_build(scene, &bo, 0, &ref)) != LRR_OK) {
        rc = lib_fail(ctx, s, "reference build");
        goto done;
    }
    const float *F = lrr_reference_f(ref);
    double fmin_ = INFINITY, fmax_ = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        double sum = 0;
        for (size_t j = 0; j < n; j++)
            sum += F[i * n + j];
        fmin_ = fmin(fmin_, sum);
        fmax_ = fmax(fmax_, sum);
    }
    static const lrr_method methods[] = {LRR_METHOD_JACOBI, LRR_METHOD_GAUSS_SEIDEL,
                                         LRR_METHOD_SOUTHWELL, LRR_METHOD_DIRECT};
    for (size_t m = 0; m < sizeof methods / sizeof methods[0]; m++) {
        stress_row q = {room->name, n, k, d, rho, lrr_method_name(methods[m]), NAN, NAN, 0, 0,
                        NAN, "", 0, NAN, fmin_, fmax_};
        lrr_reference_stats st = {0};
        memset(b, 0, 3 * n * sizeof *b);
        s = lrr_reference_solve(ref, methods[m], 1e-6, 0, e, b, &st);
        snprintf(q.status, sizeof q.status, "%s", status_word(s));
        q.iterations = st.iterations;
        q.seconds = st.seconds;
        q.residual = st.residual;
        if (s == LRR_OK || s == LRR_NOT_CONVERGED)
            compare_exact(n, area, b, exact, &q.max_rel, &q.rel_l2, &q.nonfinite);
        if (s != LRR_OK) {
            char msg[256] = "";
            lrr_context_last_error(ctx, msg, sizeof msg);
            if (msg[0])
                note("%s rho %g %s: %s", room->name, rho, q.method, msg);
        }
        rows[(*count)++] = q;
        print_stress_row(&q);
    }
done:
    lrr_reference_destroy(ref);
    lrr_solver_destroy(solver);
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    free(e);
    free(b);
    free(v);
    free(rh);
    free(em);
    return rc;
}

static int cmd_stress(int argc, char *argv[])
{
    static const char prog[] = "lrr-bench stress";
    static const struct option longopts[] = {{"csv", required_argument, NULL, OPT_CSV},
                                             {"hemicube", required_argument, NULL, OPT_HEMICUBE},
                                             {"quick", no_argument, NULL, OPT_QUICK},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *csv = NULL;
    unsigned R = 0;
    int quick = 0;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(stress_help, stdout);
            return CLI_EXIT_OK;
        case OPT_CSV:
            csv = optarg;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &R) != 0)
                return CLI_EXIT_USAGE;
            if (R % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", R);
                return CLI_EXIT_USAGE;
            }
            break;
        case OPT_QUICK:
            quick = 1;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    if (no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if (csv && !csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (R == 0)
        R = quick ? 64 : DEFAULT_HEMICUBE;

    static const double rhos[] = {0.5, 0.9, 0.99, 0.999};
    const size_t n_rooms = sizeof stress_rooms / sizeof stress_rooms[0];
    const size_t n_rho = sizeof rhos / sizeof rhos[0];
    stress_row *rows = calloc(n_rooms * n_rho * 5, sizeof *rows);
    if (!rows)
        return bench_fail("out of memory");
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK) {
        free(rows);
        return lib_fail(NULL, s, "context");
    }
    double t_start = cli_now();
    printf("benchmark: stress\n");
    print_machine();
    printf("hemicube: %u\n", R);
    printf("exact: B = E/(1 - rho) with E = 1 (valid when the rows of F sum to 1)\n");
    printf("reference_tol: 1e-6\n");
    printf("\n%-7s %5s %4s %3s %6s %-13s %10s %10s %9s %9s %-14s %4s %9s %s\n", "scene", "n",
           "k", "d", "rho", "method", "max_rel", "rel_l2", "iters", "seconds", "status", "nan",
           "cond", "row sums (F̄·d or F)");
    fflush(stdout);
    int rc = CLI_EXIT_OK;
    size_t count = 0;
    for (size_t r = 0; r < n_rooms && rc == CLI_EXIT_OK; r++)
        for (size_t j = 0; j < n_rho && rc == CLI_EXIT_OK; j++)
            rc = stress_case(ctx, &stress_rooms[r], quick, R, rhos[j], rows, &count);
    /* summary: the worst of each kind */
    double worst_op[2] = {0, 0}, worst_ref = 0;
    size_t nonfinite = 0;
    for (size_t i = 0; i < count; i++) {
        const stress_row *q = &rows[i];
        nonfinite += q->nonfinite;
        double err = isnan(q->max_rel) ? INFINITY : q->max_rel;
        if (strcmp(q->method, "lrr") == 0)
            worst_op[q->rho > 0.995] = fmax(worst_op[q->rho > 0.995], err);
        else
            worst_ref = fmax(worst_ref, err);
    }
    printf("\nworst_operator_max_rel_rho_le_0.99: %.3g\n", worst_op[0]);
    printf("worst_operator_max_rel_rho_0.999: %.3g\n", worst_op[1]);
    printf("worst_reference_max_rel: %.3g\n", worst_ref);
    printf("nonfinite_values: %zu\n", nonfinite);
    printf("total_seconds: %.1f\n", cli_now() - t_start);
    if (csv && count) {
        if (write_stress_csv(csv, rows, count) != 0)
            rc = CLI_EXIT_FAIL;
        else
            printf("csv: %s\n", csv);
    }
    free(rows);
    lrr_context_destroy(ctx);
    return rc;
}

/* ================================================================== hemicube */
static double parallel_closed_form(double X, double Y)
{
    /* Howell C-11: parallel, directly opposed rectangles a×b at distance c, X = a/c, Y = b/c */
    double a = log(sqrt((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y)));
    double b = X * sqrt(1 + Y * Y) * atan(X / sqrt(1 + Y * Y));
    double c = Y * sqrt(1 + X * X) * atan(Y / sqrt(1 + X * X));
    return 2 / (M_PI * X * Y) * (a + b + c - X * atan(X) - Y * atan(Y));
}

static double perpendicular_closed_form(double W, double H)
{
    /* Howell C-14: perpendicular rectangles with a common edge l, W = w/l, H = h/l */
    double s = sqrt(H * H + W * W);
    double l1 = (1 + W * W) * (1 + H * H) / (1 + W * W + H * H);
    double l2 = pow(W * W * (1 + W * W + H * H) / ((1 + W * W) * (W * W + H * H)), W * W);
    double l3 = pow(H * H * (1 + W * W + H * H) / ((1 + H * H) * (W * W + H * H)), H * H);
    return 1 / (M_PI * W) *
           (W * atan(1 / W) + H * atan(1 / H) - s * atan(1 / s) + 0.25 * log(l1 * l2 * l3));
}

/* Lambert's formula: the exact form factor from a differential area at x (unit normal nr)
 * to a polygon wholly in front of it. */
static double point_to_polygon(const double x[3], const float nr[3], const double (*poly)[3],
                               int nv)
{
    double sum = 0;
    for (int i = 0; i < nv; i++) {
        double a[3], b[3];
        for (int j = 0; j < 3; j++) {
            a[j] = poly[i][j] - x[j];
            b[j] = poly[(i + 1) % nv][j] - x[j];
        }
        double cr[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                        a[0] * b[1] - a[1] * b[0]};
        double len = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
        if (len < 1e-300)
            continue;
        double gamma = atan2(len, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
        sum += gamma * (nr[0] * cr[0] + nr[1] * cr[1] + nr[2] * cr[2]) / len;
    }
    return fabs(sum) / (2 * M_PI);
}

static void quad_triangles(float *v, const double q[4][3])
{
    const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int h = 0; h < 2; h++)
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                v[9 * h + 3 * j + k] = (float)q[tri[h][j]][k];
}

/* Two unit squares (4 triangles): the receiver on z = 0 facing +z, and the other. */
typedef struct square_pair {
    double recv[4][3], other[4][3];
} square_pair;

static const square_pair parallel_pair = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, /* normal +z */
    {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}}, /* normal -z */
};
static const square_pair perpendicular_pair = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, /* normal +z */
    {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}}, /* x = 0, normal +x */
};

typedef struct ff_result {
    double f;      /* area-averaged F from the hemicubes */
    double quad;   /* the same average of the exact point-to-square form factors */
    double build_s;
} ff_result;

/* Area-averaged form factor from the receiver square to the other, from F̄·d, with the exact
 * point-to-polygon value at the same subpatch centres. */
static int square_form_factor(lrr_context *ctx, const square_pair *sp, unsigned levels,
                              unsigned R, uint64_t seed, ff_result *out)
{
    float v[36], rho[12], em[12] = {0};
    for (int i = 0; i < 12; i++)
        rho[i] = 0.5f;
    for (int i = 0; i < 2; i++)
        quad_triangles(v + 18 * i, i == 0 ? sp->recv : sp->other);
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    lrr_status s = lrr_scene_create(ctx, 4, v, rho, em, "squares", &scene);
    if (s == LRR_OK)
        s = lrr_scene_subdivide(scene, &(lrr_subdivision){0.0, 0, levels});
    lrr_build_options bo = {.hemicube_resolution = R, .seed = seed};
    double t0 = cli_now();
    if (s == LRR_OK)
        s = lrr_operator_build(scene, &bo, &op);
    out->build_s = cli_now() - t0;
    lrr_scene_destroy(scene);
    if (s != LRR_OK)
        return lib_fail(ctx, s, "squares");
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    const float *fbar = lrr_operator_fbar(op), *area = lrr_operator_area(op);
    const float *centre = lrr_operator_centre(op), *normal = lrr_operator_normal(op);
    /* the receiver square's subpatches face +z and lie on z = 0; a patch belongs to the other
     * square when its first subpatch does not */
    double num = 0, qnum = 0, den = 0;
    for (size_t i = 0; i < oi.n; i++) {
        const float *c = centre + 3 * i, *nr = normal + 3 * i;
        if (!(nr[2] > 0.99f && fabsf(c[2]) < 1e-6f))
            continue;
        double row = 0;
        for (size_t p = 0; p < oi.k; p++) {
            const float *cp = centre + 3 * p * oi.d, *np = normal + 3 * p * oi.d;
            if (np[2] > 0.99f && fabsf(cp[2]) < 1e-6f)
                continue;
            row += fbar[i * oi.k + p];
        }
        double x[3] = {c[0], c[1], c[2]};
        num += area[i] * row * (double)oi.d;
        qnum += area[i] * point_to_polygon(x, nr, sp->other, 4);
        den += area[i];
    }
    out->f = num / den;
    out->quad = qnum / den;
    lrr_operator_destroy(op);
    return 0;
}

static int cornell_fbar(lrr_context *ctx, unsigned R, uint64_t seed, lrr_operator **op,
                        double *seconds)
{
    lrr_scene *scene = NULL;
    lrr_status s = lrr_scene_builtin(ctx, "cornell", &scene);
    if (s == LRR_OK)
        s = lrr_scene_subdivide(scene, &(lrr_subdivision){0.0, 216, 1});
    lrr_build_options bo = {.hemicube_resolution = R, .seed = seed};
    cli_progress bar;
    progress_begin(&bar, "hemicubes", &bo);
    double t0 = cli_now();
    if (s == LRR_OK)
        s = lrr_operator_build(scene, &bo, op);
    *seconds = cli_now() - t0;
    cli_progress_finish(&bar);
    lrr_scene_destroy(scene);
    return s == LRR_OK ? 0 : lib_fail(ctx, s, "Cornell box");
}

static int cmd_hemicube(int argc, char *argv[])
{
    static const char prog[] = "lrr-bench hemicube";
    static const struct option longopts[] = {{"csv", required_argument, NULL, OPT_CSV},
                                             {"seeds", required_argument, NULL, OPT_SEEDS},
                                             {"quick", no_argument, NULL, OPT_QUICK},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *csv = NULL;
    unsigned seeds = 3;
    int quick = 0, have_seeds = 0;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(hemicube_help, stdout);
            return CLI_EXIT_OK;
        case OPT_CSV:
            csv = optarg;
            break;
        case OPT_SEEDS:
            if (cli_parse_unsigned(prog, "--seeds", optarg, 1, 10, &seeds) != 0)
                return CLI_EXIT_USAGE;
            have_seeds = 1;
            break;
        case OPT_QUICK:
            quick = 1;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    if (no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if (csv && !csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    static const unsigned full_res[] = {16, 32, 64, 128, 256}, quick_res[] = {16, 32};
    const unsigned *res = quick ? quick_res : full_res;
    size_t n_res = quick ? 2 : 5;
    unsigned ref_res = quick ? 128 : 512;
    unsigned levels = quick ? 3 : 4;
    if (quick && !have_seeds)
        seeds = 1;

    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return lib_fail(NULL, s, "context");
    double t_start = cli_now();
    const double par_exact = parallel_closed_form(1, 1);
    const double perp_exact = perpendicular_closed_form(1, 1);
    printf("benchmark: hemicube\n");
    print_machine();
    printf("rotation: always on (the library has no switch); rows differ by seed\n");
    printf("closed_form_parallel: %.6f\n", par_exact);
    printf("closed_form_perpendicular: %.6f\n", perp_exact);
    printf("square_subpatches: %u per triangle (levels %u)\n", 1u << (2 * levels), levels);
    note("Cornell box reference build at R = %u", ref_res);
    lrr_operator *ref = NULL;
    double ref_s = 0;
    if (cornell_fbar(ctx, ref_res, 1, &ref, &ref_s)) {
        lrr_context_destroy(ctx);
        return CLI_EXIT_FAIL;
    }
    lrr_operator_info ri;
    lrr_operator_get_info(ref, &ri);
    printf("cornell: n %zu, k %zu, d %zu; reference R = %u seed 1 built in %.2f s\n", ri.n, ri.k,
           ri.d, ref_res, ref_s);

    cli_outfile out;
    int have_out = 0, rc = CLI_EXIT_OK;
    if (csv) {
        if (cli_outfile_open(&out, csv) != 0) {
            rc = bench_fail("cannot create a temporary file for '%s': %s", csv, strerror(errno));
            goto done;
        }
        have_out = 1;
        fputs("R,seed,rotation,cornell_preprocess_s,f_parallel,err_parallel,"
              "err_parallel_quadrature,f_perpendicular,err_perpendicular,"
              "err_perpendicular_quadrature,cornell_rel_l2,n_cornell,k_cornell\n",
              out.f);
    }
    int printed_quad = 0;
    printf("\n%5s %5s %8s %9s %10s %10s %10s %10s %10s %10s %12s\n", "R", "seed", "rotation",
           "prep_s", "F_par", "err_par", "err_par_q", "F_perp", "err_perp", "err_perp_q",
           "cornell_L2");
    for (size_t i = 0; i < n_res && rc == CLI_EXIT_OK; i++)
        for (unsigned sd = 1; sd <= seeds && rc == CLI_EXIT_OK; sd++) {
            unsigned R = res[i];
            note("R = %u, seed %u", R, sd);
            ff_result par, perp;
            if ((rc = square_form_factor(ctx, &parallel_pair, levels, R, sd, &par)) ||
                (rc = square_form_factor(ctx, &perpendicular_pair, levels, R, sd, &perp)))
                break;
            if (!printed_quad) {
                printf("# quadrature (exact point form factors at the receivers' centres): "
                       "parallel %.6f, perpendicular %.6f\n",
                       par.quad, perp.quad);
                printed_quad = 1;
            }
            lrr_operator *op = NULL;
            double prep = 0;
            if ((rc = cornell_fbar(ctx, R, sd, &op, &prep)))
                break;
            const float *a = lrr_operator_fbar(op), *bref = lrr_operator_fbar(ref);
            double num = 0, den = 0;
            for (size_t j = 0; j < ri.n * ri.k; j++) {
                double dlt = (double)a[j] - bref[j];
                num += dlt * dlt;
                den += (double)bref[j] * bref[j];
            }
            lrr_operator_destroy(op);
            double l2 = sqrt(num / den);
            double ep = par.f / par_exact - 1, epq = par.f / par.quad - 1;
            double er = perp.f / perp_exact - 1, erq = perp.f / perp.quad - 1;
            printf("%5u %5u %8s %9.3f %10.6f %+10.2e %+10.2e %10.6f %+10.2e %+10.2e %12.3e\n", R,
                   sd, "yes", prep, par.f, ep, epq, perp.f, er, erq, l2);
            fflush(stdout);
            if (have_out)
                fprintf(out.f, "%u,%u,yes,%.6g,%.9g,%.6g,%.6g,%.9g,%.6g,%.6g,%.6g,%zu,%zu\n", R, sd,
                        prep, par.f, ep, epq, perp.f, er, erq, l2, ri.n, ri.k);
        }
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
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
    lrr_operator_destroy(ref);
    lrr_context_destroy(ctx);
    return rc;
}

/* ================================================================== main */
int main(int argc, char *argv[])
{
    static const struct {
        const char *name;
        int (*run)(int, char *[]);
    } commands[] = {{"table", cmd_table}, {"stress", cmd_stress}, {"hemicube", cmd_hemicube}};
    if (argc < 2) {
        fputs(main_help, stderr);
        return CLI_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "-h") == 0 || strcmp(cmd, "--help") == 0 || strcmp(cmd, "help") == 0) {
        fputs(main_help, stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(cmd, "-V") == 0 || strcmp(cmd, "--version") == 0) {
        printf("lrr-bench %s\n", lrr_version_string());
        return CLI_EXIT_OK;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(cmd, commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    cli_usage_error("lrr-bench", "unknown %s '%s'", cmd[0] == '-' ? "option" : "command", cmd);
    fprintf(stderr, "Try 'lrr-bench --help'.\n");
    return CLI_EXIT_USAGE;
}
