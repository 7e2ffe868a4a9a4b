/* lrr-bench fbar: dense against sparse F̄ (lib/solve/sparse.c) on saved operators — the
 * bytes a frame reads, ms per frame, each pass against its own floor measured in
 * alternation with it (bench_interleave.c), the two passes against each other in
 * alternation, and the difference of their B. */
#include "bench.h"

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char fbar_help[] =
    "Usage: lrr-bench fbar [OPTIONS] FILE.lrr...\n"
    "Dense against sparse F̄ on saved operators (lrr preprocess; real scenes, whose F̄ is\n"
    "mostly zeros). For each file and storage, two CPU solvers on the full path, one reading\n"
    "F̄ dense and one sparse (lrr_solver_set_fbar), for the file's emission (E = 1 on every\n"
    "subpatch if it has none). Prints one row each:\n"
    "  density              nonzero entries of F̄ / (n·k); strips: entries of the stored\n"
    "                       16-row strips / (n·k)\n"
    "  dense_mb, sparse_mb  bytes of F̄ a frame reads (M: m_mb more for both)\n"
    "  dense_ms, sparse_ms  ms per frame: the median of PAIRS pairs, each pass timed in\n"
    "                       alternation with a read loop over exactly the bytes it must\n"
    "                       read (F̄ as read, M, E, B: the floor)\n"
    "  *_floor              the median of the pairs' ratios pass / floor [min, max]\n"
    "  sparse/dense         ms sparse / ms dense, median of PAIRS pairs timed in\n"
    "                       alternation [min, max]\n"
    "  b_diff               max |B_sparse − B_dense| / max |B_dense| (summation order only)\n\n"
    "Options:\n"
    "  --storage LIST       storages to measure, comma-separated: f32, f16, bf16 (default:\n"
    "                       the file's); other storages are converted (M recomputed)\n"
    "  --pairs P            pairs of each alternation (1..31, default 11)\n"
    "  --csv OUT.csv        also write the rows: file,storage,n,k,density,strip_density,\n"
    "                       dense_mb,sparse_mb,m_mb,dense_ms,sparse_ms,dense_floor_ms,\n"
    "                       sparse_floor_ms,dense_ratio,dense_ratio_min,dense_ratio_max,\n"
    "                       sparse_ratio,sparse_ratio_min,sparse_ratio_max,speedup_median,\n"
    "                       speedup_min,speedup_max,b_diff,kernel\n"
    "  -h, --help           show this help\n"
    "  --backend B          cpu (default: the rows above) or opencl: instead, an OpenCL\n"
    "                       solver (device from LRR_OPENCL_DEVICE) reading F̄ dense and as\n"
    "                       strips, each row: the bytes its kernels read (F̄ as held, M, E,\n"
    "                       rho, B), the median kernel time of FRAMES frames (profiling\n"
    "                       events), that against the device's read floor (a plain read\n"
    "                       kernel over a buffer of the same bytes, best of 5, measured in\n"
    "                       the same run), transfer and whole-frame medians, and b_diff\n"
    "                       against the CPU's dense B\n"
    "  --strip-groups LIST  opencl: the sparse kernel's strip groups to measure, each a\n"
    "                       power of two (LRR_OPENCL_STRIP_GROUPS; default 1,2,4,8)\n"
    "                       (CSV impl dense or sparse_gG)\n"
    "  --frames N           opencl: timed frames per solver (default 50)\n"
    "Threads: OMP_NUM_THREADS. LRR_SIMD forces a kernel (e.g. avx2).\n";

enum { OPT_FBAR_STORAGE = 1024, OPT_FBAR_PAIRS, OPT_FBAR_BACKEND, OPT_FBAR_GROUPS,
       OPT_FBAR_FRAMES };

typedef struct fbar_args {
    int storages[3], n_storages; /* lrr_storage; n_storages 0: the file's */
    unsigned pairs, frames;
    const char *csv;
    int opencl;
    unsigned groups[8];
    int n_groups;
} fbar_args;

typedef struct fbar_row {
    lrr_solver_info dense, sparse;
    bench_pairs dense_floor, sparse_floor;
    double dense_ms, sparse_ms, speed[3], b_diff; /* speed: median, min, max */
    char kernel[64];
} fbar_row;

static int parse_storages(const char *prog, const char *text, fbar_args *a)
{
    char buf[64];
    snprintf(buf, sizeof buf, "%s", text);
    a->n_storages = 0;
    for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        lrr_storage st;
        if (a->n_storages == 3 || lrr_storage_from_name(t, &st) != LRR_OK) {
            fprintf(stderr, "%s: --storage: '%s' is not a list of f32, f16, bf16\n", prog, text);
            return CLI_EXIT_USAGE;
        }
        a->storages[a->n_storages++] = (int)st;
    }
    return a->n_storages ? 0 : CLI_EXIT_USAGE;
}

static int parse_groups(const char *prog, const char *text, fbar_args *a)
{
    char buf[64], *end;
    snprintf(buf, sizeof buf, "%s", text);
    a->n_groups = 0;
    for (char *save = NULL, *t = strtok_r(buf, ",", &save); t; t = strtok_r(NULL, ",", &save)) {
        unsigned long g = strtoul(t, &end, 10);
        if (a->n_groups == 8 || *end || g == 0 || g > 64 || (g & (g - 1))) {
            fprintf(stderr, "%s: --strip-groups: '%s' is not a list of powers of two <= 64\n",
                    prog, text);
            return CLI_EXIT_USAGE;
        }
        a->groups[a->n_groups++] = (unsigned)g;
    }
    return a->n_groups ? 0 : CLI_EXIT_USAGE;
}

static int parse_fbar(int argc, char *argv[], fbar_args *a)
{
    static const struct option longopts[] = {{"storage", required_argument, NULL, OPT_FBAR_STORAGE},
                                             {"pairs", required_argument, NULL, OPT_FBAR_PAIRS},
                                             {"backend", required_argument, NULL, OPT_FBAR_BACKEND},
                                             {"strip-groups", required_argument, NULL, OPT_FBAR_GROUPS},
                                             {"frames", required_argument, NULL, OPT_FBAR_FRAMES},
                                             {"csv", required_argument, NULL, OPT_CSV},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *prog = "lrr-bench fbar";
    *a = (fbar_args){.pairs = 11, .frames = 50, .groups = {1, 2, 4, 8}, .n_groups = 4};
    bench_start_getopt();
    int c;
    size_t v;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case OPT_FBAR_STORAGE:
            if (parse_storages(prog, optarg, a))
                return CLI_EXIT_USAGE;
            break;
        case OPT_FBAR_PAIRS:
            if (cli_parse_size(prog, "--pairs", optarg, 1, BENCH_MAX_PAIRS, &v) != 0)
                return CLI_EXIT_USAGE;
            a->pairs = (unsigned)v;
            break;
        case OPT_FBAR_BACKEND:
            if (bench_parse_backend(prog, optarg, &a->opencl) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_FBAR_GROUPS:
            if (parse_groups(prog, optarg, a))
                return CLI_EXIT_USAGE;
            break;
        case OPT_FBAR_FRAMES:
            if (cli_parse_size(prog, "--frames", optarg, 1, 100000, &v) != 0)
                return CLI_EXIT_USAGE;
            a->frames = (unsigned)v;
            break;
        case OPT_CSV: a->csv = optarg; break;
        case 'h': fputs(fbar_help, stdout); return CLI_EXIT_OK;
        default: return bench_bad_option(prog, c, argv);
        }
    }
    if (optind >= argc) {
        fprintf(stderr, "%s: no FILE.lrr given (lrr-bench fbar --help)\n", prog);
        return CLI_EXIT_USAGE;
    }
    return BENCH_RUN;
}

static int solver_as(lrr_context *ctx, const lrr_operator *op, lrr_fbar_format f,
                     lrr_solver **out)
{
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_CPU, out);
    if (!s)
        s = lrr_solver_set_fbar(*out, f);
    if (!s)
        s = lrr_solver_set_path(*out, LRR_PATH_FULL);
    return s ? bench_lib_fail(ctx, s, "solver") : 0;
}

/* the best of `reps` frames, in ms */
static int best_ms(ours_frame *f, unsigned reps, double *ms)
{
    *ms = INFINITY;
    for (unsigned r = 0; r < reps; r++) {
        double t0 = cli_now();
        if (bench_ours_step(f))
            return 1;
        *ms = fmin(*ms, 1e3 * (cli_now() - t0));
    }
    return 0;
}

/* sparse against dense in alternation: `pairs` ratios of the best of a few frames each */
static int alternate(ours_frame f[2], unsigned pairs, double frame_ms, double out[3])
{
    double r[BENCH_MAX_PAIRS];
    unsigned reps = frame_ms > 0 && frame_ms < 5 ? (unsigned)ceil(20 / frame_ms) : 3;
    for (unsigned p = 0; p < pairs; p++) {
        double d, s;
        if (best_ms(&f[0], reps, &d) || best_ms(&f[1], reps, &s))
            return 1;
        r[p] = s / d;
    }
    timing t;
    bench_timing_from_samples(r, pairs, &t);
    out[0] = t.median, out[1] = t.min, out[2] = t.max;
    return 0;
}

/* One storage of one operator: both solvers, their B, the floors and the alternation. */
static int measure(lrr_context *ctx, const lrr_operator *op, const float *e, unsigned pairs,
                   fbar_row *row)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const size_t n = oi.n, k = oi.k;
    lrr_solver *sv[2] = {NULL, NULL};
    float *b[2] = {bench_alloc_floats(n, 3), bench_alloc_floats(n, 3)};
    int rc = !b[0] || !b[1] ? bench_fail("out of memory for B (n = %zu)", n) : 0;
    if (!rc)
        rc = solver_as(ctx, op, LRR_FBAR_DENSE, &sv[0]);
    if (!rc)
        rc = solver_as(ctx, op, LRR_FBAR_SPARSE, &sv[1]);
    ours_frame f[2];
    for (int i = 0; i < 2 && !rc; i++) {
        f[i] = (ours_frame){.solver = sv[i], .e = e, .b = b[i]};
        rc = bench_ours_step(&f[i]);
    }
    if (!rc) {
        lrr_solver_get_info(sv[0], &row->dense, sizeof row->dense);
        lrr_solver_get_info(sv[1], &row->sparse, sizeof row->sparse);
        snprintf(row->kernel, sizeof row->kernel, "%s", lrr_solver_kernel(sv[0]));
        row->b_diff = bench_max_rel(3 * n, b[1], b[0]);
        const double io = 24.0 * n + 12.0 * k; /* E and B, n×3 floats each; w and z */
        rc = bench_interleave(bench_ours_step, &f[0],
                              row->dense.fbar_bytes + row->dense.m_bytes + io, 0, pairs,
                              &row->dense_floor);
        if (!rc)
            rc = bench_interleave(bench_ours_step, &f[1],
                                  row->sparse.fbar_bytes + row->sparse.m_bytes + io, 0, pairs,
                                  &row->sparse_floor);
    }
    if (!rc) {
        row->dense_ms = row->dense_floor.median * row->dense_floor.floor_ms;
        row->sparse_ms = row->sparse_floor.median * row->sparse_floor.floor_ms;
        rc = alternate(f, pairs, row->sparse_ms, row->speed);
    }
    lrr_solver_destroy(sv[0]);
    lrr_solver_destroy(sv[1]);
    lrr_aligned_free(b[0]);
    lrr_aligned_free(b[1]);
    return rc;
}

static void print_row(const char *file, lrr_storage st, size_t n, size_t k, const fbar_row *r)
{
    printf("%s %s (n %zu, k %zu, %s): density %.4f (strips %.4f), F̄ dense %.1f MB, sparse "
           "%.1f MB, M %.1f MB\n",
           file, lrr_storage_name(st), n, k, r->kernel, r->dense.fbar_density,
           r->dense.fbar_strip_density, r->dense.fbar_bytes / 1e6, r->sparse.fbar_bytes / 1e6,
           r->dense.m_bytes / 1e6);
    printf("  dense  %8.3f ms, %.2f× its floor [%.2f, %.2f] (floor %.3f ms)\n", r->dense_ms,
           r->dense_floor.median, r->dense_floor.min, r->dense_floor.max, r->dense_floor.floor_ms);
    printf("  sparse %8.3f ms, %.2f× its floor [%.2f, %.2f] (floor %.3f ms)\n", r->sparse_ms,
           r->sparse_floor.median, r->sparse_floor.min, r->sparse_floor.max,
           r->sparse_floor.floor_ms);
    printf("  sparse/dense %.3f [%.3f, %.3f], b_diff %.2e\n", r->speed[0], r->speed[1],
           r->speed[2], r->b_diff);
}

static void csv_row(FILE *f, const char *file, lrr_storage st, size_t n, size_t k,
                    const fbar_row *r)
{
    fprintf(f, "%s,%s,%zu,%zu,", file, lrr_storage_name(st), n, k);
    const double v[] = {r->dense.fbar_density, r->dense.fbar_strip_density,
                        r->dense.fbar_bytes / 1e6, r->sparse.fbar_bytes / 1e6,
                        r->dense.m_bytes / 1e6, r->dense_ms, r->sparse_ms,
                        r->dense_floor.floor_ms, r->sparse_floor.floor_ms,
                        r->dense_floor.median, r->dense_floor.min, r->dense_floor.max,
                        r->sparse_floor.median, r->sparse_floor.min, r->sparse_floor.max,
                        r->speed[0], r->speed[1], r->speed[2], r->b_diff};
    for (size_t i = 0; i < sizeof v / sizeof v[0]; i++)
        bench_csv_num(f, v[i], 0);
    fprintf(f, "%s\n", r->kernel);
}

/* E: the file's emission, or 1 everywhere when it has none */
static float *emission_of(const lrr_operator *op, size_t n)
{
    float *e = bench_alloc_floats(n, 3);
    if (!e)
        return NULL;
    const float *own = lrr_operator_emission(op);
    int any = 0;
    for (size_t j = 0; j < 3 * n; j++)
        any |= own[j] > 0;
    for (size_t j = 0; j < 3 * n; j++)
        e[j] = any ? own[j] : 1.0f;
    return e;
}

static int run_file(lrr_context *ctx, const fbar_args *a, const char *file, FILE *csv)
{
    lrr_operator *op;
    lrr_status s = lrr_operator_load(ctx, file, &op);
    if (s)
        return bench_lib_fail(ctx, s, file);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const int own[1] = {(int)oi.storage};
    const int *list = a->n_storages ? a->storages : own;
    const int count = a->n_storages ? a->n_storages : 1;
    int rc = 0;
    for (int i = 0; i < count && !rc; i++) {
        if ((s = lrr_operator_set_storage(op, (lrr_storage)list[i])))
            rc = bench_lib_fail(ctx, s, "lrr_operator_set_storage");
        float *e = rc ? NULL : emission_of(op, oi.n);
        if (!rc && !e)
            rc = bench_fail("out of memory for E (n = %zu)", oi.n);
        fbar_row row;
        if (!rc && a->opencl) {
            rc = bench_fbar_opencl(ctx, op, e, file, (lrr_storage)list[i], a->groups,
                                   a->n_groups, a->frames, csv);
        } else if (!rc && !(rc = measure(ctx, op, e, a->pairs, &row))) {
            print_row(file, (lrr_storage)list[i], oi.n, oi.k, &row);
            if (csv)
                csv_row(csv, file, (lrr_storage)list[i], oi.n, oi.k, &row);
            fflush(stdout);
        }
        lrr_aligned_free(e);
    }
    lrr_operator_destroy(op);
    return rc;
}

int cmd_fbar(int argc, char *argv[])
{
    fbar_args a;
    int rc = parse_fbar(argc, argv, &a);
    if (rc != BENCH_RUN)
        return rc;
    rc = 0;
    bench_print_machine();
    cli_outfile out = {0};
    if (a.csv && cli_outfile_open(&out, a.csv) != 0)
        return bench_fail("cannot write %s", a.csv);
    if (a.csv && a.opencl)
        fputs("file,storage,impl,mb,kernel_ms,floor_ms,ratio_to_floor,transfer_ms,frame_ms,"
              "b_diff,device\n",
              out.f);
    else if (a.csv)
        fputs("file,storage,n,k,density,strip_density,dense_mb,sparse_mb,m_mb,dense_ms,"
              "sparse_ms,dense_floor_ms,sparse_floor_ms,dense_ratio,dense_ratio_min,"
              "dense_ratio_max,sparse_ratio,sparse_ratio_min,sparse_ratio_max,speedup_median,"
              "speedup_min,speedup_max,b_diff,kernel\n",
              out.f);
    lrr_context *ctx = NULL;
    if (a.opencl)
        rc = bench_start("cornell", 1, &ctx); /* fails early without a device */
    else if (lrr_context_create(&ctx) != LRR_OK)
        rc = bench_fail("cannot create a context");
    for (int i = optind; i < argc && !rc; i++)
        rc = run_file(ctx, &a, argv[i], a.csv ? out.f : NULL);
    lrr_context_destroy(ctx);
    return a.csv ? bench_csv_finish(&out, rc, a.csv) : rc;
}
