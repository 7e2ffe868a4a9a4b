/* lrr-bench mpi: the real-time step across MPI ranks (lrr_mpi.h, docs/MPI.md) against one
 * process — per-frame time with P ranks against the serial lrr_solve, the frame's one
 * allreduce timed alone, and the bytes each rank reads and sends. Run under mpirun; the
 * serial frames run on rank 0 while the others wait, so both use the same cores. */
#include "bench.h"

#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

static const char mpi_help[] =
    "Usage: mpirun -np P lrr-bench mpi [OPTIONS] FILE.lrr\n"
    "The real-time step across P MPI ranks (lrr_mpi_solver; lrr built with configure\n"
    "--with-mpi) against one process, for the file's emission (E = 1 everywhere if it has\n"
    "none), full path. Prints (rank 0):\n"
    "  ranks, n, k          the run and the operator\n"
    "  serial_ms            lrr_solve on rank 0 alone, median of FRAMES frames\n"
    "  mpi_ms               lrr_mpi_solve on every rank, median of FRAMES frames of the\n"
    "                       slowest rank's time (the ranks start each frame together)\n"
    "  speedup              serial_ms / mpi_ms\n"
    "  allreduce_us         the frame's MPI_Allreduce of 3k + 1 floats alone, median of\n"
    "                       FRAMES of the slowest rank's time\n"
    "  allreduce_bytes      what each rank sends into it\n"
    "  rows_min, rows_max   rows (subpatches) per rank\n"
    "  fbar_bytes_min, fbar_bytes_max  bytes of F̄ a rank reads per frame (dense or strips)\n"
    "  m_bytes              M on every rank (replicated)\n"
    "  b_diff               max |B_mpi − B_serial| / max |B_serial|\n\n"
    "Options:\n"
    "  --frames N           timed frames of each kind (1..100000, default 100)\n"
    "  -h, --help           show this help\n"
    "Threads: OMP_NUM_THREADS per rank (P ranks × threads should not exceed the cores).\n";

enum { OPT_MPI_FRAMES = 1024 };

static int parse_mpi(int argc, char *argv[], unsigned *frames)
{
    static const struct option longopts[] = {{"frames", required_argument, NULL, OPT_MPI_FRAMES},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *prog = "lrr-bench mpi";
    *frames = 100;
    bench_start_getopt();
    int c;
    size_t v;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case OPT_MPI_FRAMES:
            if (cli_parse_size(prog, "--frames", optarg, 1, 100000, &v) != 0)
                return CLI_EXIT_USAGE;
            *frames = (unsigned)v;
            break;
        case 'h': fputs(mpi_help, stdout); return CLI_EXIT_OK;
        default: return bench_bad_option(prog, c, argv);
        }
    }
    if (optind + 1 != argc) {
        fprintf(stderr, "%s: give one FILE.lrr (lrr-bench mpi --help)\n", prog);
        return CLI_EXIT_USAGE;
    }
    return BENCH_RUN;
}

#ifdef LRR_MPI
#include "lrr_mpi.h"

/* What one run measured (rank 0's view). */
typedef struct mpi_result {
    double serial_ms, mpi_ms, allreduce_us, b_diff;
    unsigned long long rows[2], fbar[2]; /* min, max over ranks */
} mpi_result;

/* median over frames of the slowest rank's time t[f] (rank 0 gets it) */
static double slowest_median(double *t, unsigned frames)
{
    double *tmax = calloc(frames, sizeof *tmax);
    if (!tmax)
        return NAN;
    MPI_Reduce(t, tmax, (int)frames, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    double m = cli_median(tmax, frames);
    free(tmax);
    return m;
}

/* The serial frames on rank 0 (E whole, B whole), the others waiting at the barrier. */
static lrr_status serial_frames(lrr_context *ctx, const char *file, const float *E, float *B,
                                unsigned frames, double *ms)
{
    lrr_operator *op = NULL;
    lrr_solver *s = NULL;
    double *t = calloc(frames, sizeof *t);
    lrr_status st = t ? lrr_operator_load(ctx, file, &op) : LRR_ERR_NOMEM;
    if (!st && !(st = lrr_solver_create(op, LRR_BACKEND_CPU, &s)) &&
        !(st = lrr_solver_set_path(s, LRR_PATH_FULL)))
        st = lrr_solve(s, E, B); /* warm-up */
    for (unsigned f = 0; !st && f < frames; f++) {
        double t0 = cli_now();
        st = lrr_solve(s, E, B);
        t[f] = 1e3 * (cli_now() - t0);
    }
    if (!st)
        *ms = cli_median(t, frames);
    free(t);
    lrr_solver_destroy(s);
    lrr_operator_destroy(op);
    return st;
}

/* The distributed frames and the allreduce alone; B (rows) of the last frame. */
static lrr_status mpi_frames(lrr_context *ctx, lrr_mpi_solver *s, const float *E, float *B,
                             unsigned frames, mpi_result *r)
{
    lrr_mpi_solver_info si;
    lrr_mpi_solver_get_info(s, &si, sizeof si);
    double *t = calloc(frames, sizeof *t);
    float *w = calloc(3 * si.k + 1, sizeof *w), *sum = calloc(3 * si.k + 1, sizeof *sum);
    lrr_status st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, t && w && sum ? LRR_OK : LRR_ERR_NOMEM);
    if (!st)
        st = lrr_mpi_solve(s, E, B); /* warm-up */
    for (unsigned f = 0; !st && f < frames; f++) {
        MPI_Barrier(MPI_COMM_WORLD);
        double t0 = cli_now();
        st = lrr_mpi_solve(s, E, B);
        t[f] = 1e3 * (cli_now() - t0);
    }
    if (!st) {
        r->mpi_ms = slowest_median(t, frames);
        for (unsigned f = 0; f < frames; f++) {
            MPI_Barrier(MPI_COMM_WORLD);
            double t0 = cli_now();
            MPI_Allreduce(w, sum, (int)(3 * si.k + 1), MPI_FLOAT, MPI_SUM, MPI_COMM_WORLD);
            t[f] = 1e6 * (cli_now() - t0);
        }
        r->allreduce_us = slowest_median(t, frames);
    }
    free(t), free(w), free(sum);
    return st;
}

static void print_mpi(const lrr_mpi_solver_info *si, const mpi_result *r)
{
    printf("ranks: %d\nn: %zu\nk: %zu\n", si->ranks, si->n, si->k);
    printf("serial_ms: %.4f\nmpi_ms: %.4f\nspeedup: %.3f\n", r->serial_ms, r->mpi_ms,
           r->serial_ms / r->mpi_ms);
    printf("allreduce_us: %.2f\nallreduce_bytes: %zu\n", r->allreduce_us, si->allreduce_bytes);
    printf("rows_min: %llu\nrows_max: %llu\n", r->rows[0], r->rows[1]);
    printf("fbar_bytes_min: %llu\nfbar_bytes_max: %llu\n", r->fbar[0], r->fbar[1]);
    printf("m_bytes: %zu\nb_diff: %.3g\nkernel: %s\n", si->m_bytes, r->b_diff, si->kernel);
}

/* Both runs on the solver's rows and rank 0's whole arrays (E, B_serial, B_mpi: n×3). */
static lrr_status run_ranks(lrr_context *ctx, const char *file, lrr_mpi_solver *s,
                            unsigned frames, int rank, float *E, float *Bs, float *Bm)
{
    lrr_mpi_solver_info si;
    lrr_mpi_solver_get_info(s, &si, sizeof si);
    mpi_result r = {0};
    lrr_status st = rank == 0 ? serial_frames(ctx, file, E, Bs, frames, &r.serial_ms) : LRR_OK;
    if ((st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, st)))
        return st;
    float *e = si.rows ? calloc(3 * si.rows, sizeof *e) : NULL;
    float *b = si.rows ? calloc(3 * si.rows, sizeof *b) : NULL;
    st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, si.rows && !(e && b) ? LRR_ERR_NOMEM : LRR_OK);
    if (!st)
        st = lrr_mpi_scatter(s, 0, E, e);
    if (!st)
        st = mpi_frames(ctx, s, e, b, frames, &r);
    if (!st)
        st = lrr_mpi_solve_gather(s, e, 0, Bm);
    free(e), free(b);
    if (st)
        return st;
    unsigned long long mine[2] = {si.rows, si.fbar_bytes}, lo[2], hi[2];
    MPI_Reduce(mine, lo, 2, MPI_UNSIGNED_LONG_LONG, MPI_MIN, 0, MPI_COMM_WORLD);
    MPI_Reduce(mine, hi, 2, MPI_UNSIGNED_LONG_LONG, MPI_MAX, 0, MPI_COMM_WORLD);
    if (rank == 0) {
        r.rows[0] = lo[0], r.rows[1] = hi[0], r.fbar[0] = lo[1], r.fbar[1] = hi[1];
        double num = 0, den = 0;
        for (size_t j = 0; j < 3 * si.n; j++) {
            num = fmax(num, fabs((double)Bm[j] - Bs[j]));
            den = fmax(den, fabs((double)Bs[j]));
        }
        r.b_diff = den > 0 ? num / den : num;
        print_mpi(&si, &r);
    }
    return LRR_OK;
}

/* rank 0's E (the file's emission, or 1 everywhere) and both B */
static lrr_status root_arrays(lrr_mpi_solver *s, float **E, float **Bs, float **Bm)
{
    size_t n, row0, rows;
    lrr_mpi_solver_rows(s, &n, &row0, &rows);
    *E = calloc(3 * n, sizeof **E), *Bs = calloc(3 * n, sizeof **Bs),
    *Bm = calloc(3 * n, sizeof **Bm);
    if (!*E || !*Bs || !*Bm)
        return LRR_ERR_NOMEM;
    return LRR_OK;
}

static int run_mpi(const char *file, unsigned frames)
{
    int inited = 0, provided, rank;
    MPI_Initialized(&inited);
    if (!inited && MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
        return bench_fail("MPI_Init_thread failed");
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    lrr_context *ctx = NULL;
    lrr_mpi_solver *s = NULL;
    float *E = NULL, *Bs = NULL, *Bm = NULL;
    lrr_status st = lrr_context_create(&ctx);
    if (!st)
        st = lrr_mpi_solver_create(ctx, file, MPI_COMM_WORLD, &s);
    if (!st)
        st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, rank == 0 ? root_arrays(s, &E, &Bs, &Bm) : LRR_OK);
    if (!st && rank == 0) {
        lrr_operator *op = NULL; /* the stored emission, or 1 where the file has none */
        size_t n, row0, rows;
        lrr_mpi_solver_rows(s, &n, &row0, &rows);
        int any = 0;
        if (lrr_operator_load(ctx, file, &op) == LRR_OK) {
            memcpy(E, lrr_operator_emission(op), 3 * n * sizeof *E);
            for (size_t j = 0; j < 3 * n; j++)
                any |= E[j] > 0;
        }
        for (size_t j = 0; !any && j < 3 * n; j++)
            E[j] = 1.0f;
        lrr_operator_destroy(op);
    }
    if (!st)
        st = run_ranks(ctx, file, s, frames, rank, E, Bs, Bm);
    int rc = st ? (rank == 0 ? bench_lib_fail(ctx, st, "lrr-bench mpi") : CLI_EXIT_FAIL)
                : CLI_EXIT_OK;
    lrr_mpi_solver_destroy(s);
    free(E), free(Bs), free(Bm);
    lrr_context_destroy(ctx);
    if (!inited)
        MPI_Finalize();
    return rc;
}
#endif

int cmd_mpi(int argc, char *argv[])
{
    unsigned frames;
    int rc = parse_mpi(argc, argv, &frames);
    if (rc != BENCH_RUN)
        return rc;
#ifdef LRR_MPI
    return run_mpi(argv[optind], frames);
#else
    return bench_fail("mpi: lrr-bench was built without MPI (configure --with-mpi)");
#endif
}
