/* lrr solve and lrr render across MPI ranks (tools/solve_mpi.h; lrr_mpi.h, docs/MPI.md): rank 0
 * loads the operator without F̄ (lrr_operator_load_head: the emission, the probe, the
 * printout, the CSV and the drawing read none of it, and the whole F̄ is what would not fit
 * one rank), every rank holds its block of rows in an lrr_mpi_solver, rank 0 scatters E
 * (and the probe's direct light), every rank adds the --light sources' direct light over its
 * own rows (lrr_lighting_direct_rows, from its own operator without F̄), the frames run on
 * every rank, and B is gathered back to rank 0, which prints the serial command's summary
 * and writes the same CSV, or draws (lrr render: the args' finish callback). E is the serial
 * command's bit for bit: emission + (probe + lights), summed in its order. The distributed
 * frame always takes the full path on the CPU. */
#ifdef LRR_MPI
#include <mpi.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "lrr_mpi.h"
#include "solve_mpi.h"

static const char prog[] = "lrr solve";

int solve_mpi_launched(void)
{
    return getenv("OMPI_COMM_WORLD_SIZE") || getenv("PMI_SIZE") || getenv("PMIX_RANK");
}

/* What only the serial solve offers: a usage error (every rank sees the same options, so
 * all stop alike; rank 0 says why). */
static int check_options(const solve_mpi_args *a, int rank)
{
    const char *bad = a->backend != LRR_BACKEND_CPU                          ? "--backend opencl"
                      : a->path != LRR_PATH_FULL && a->path != LRR_PATH_AUTO ? "--path sparse|incremental"
                      : a->fbar != LRR_FBAR_AUTO                             ? "--fbar dense|sparse"
                      : a->m_given                                           ? "--m"
                                                                             : NULL;
    if (bad && rank == 0)
        cli_usage_error(prog, "%s is not available across MPI ranks (every rank reads its "
                        "rows of F̄ and M as lrr_solver_create chooses, on the CPU, full path)",
                        bad);
    return bad ? CLI_EXIT_USAGE : CLI_EXIT_OK;
}

/* Rank 0: the operator without F̄, the emission (scaled, with the probe; without --light,
 * which the ranks add over their rows, the probe's direct light apart in *p) and B's
 * buffer. */
static int root_prepare(lrr_context *ctx, const solve_mpi_args *a, lrr_operator **op,
                        float **e, float **p, float **b, double *direct_s)
{
    int rc = load_operator_head(ctx, a->file, op);
    if (rc == CLI_EXIT_OK)
        rc = scaled_emission(*op, a->scale, e);
    if (rc == CLI_EXIT_OK && a->pa->path && a->pa->lights) {
        probe_args probe = *a->pa; /* the probe alone, onto zeros: its direct light exactly */
        probe.lights = 0;
        probe.no_scene_emission = 0;
        lrr_operator_info oi;
        lrr_operator_get_info(*op, &oi, sizeof oi);
        *p = cli_alloc_rgb(oi.n);
        rc = *p ? add_probe_light(ctx, *op, &probe, *p, direct_s) : CLI_EXIT_FAIL;
    } else if (rc == CLI_EXIT_OK && a->pa->path) {
        rc = add_probe_light(ctx, *op, a->pa, *e, direct_s);
    }
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(*op, &oi, sizeof oi);
        *b = cli_alloc_rgb(oi.n);
        rc = *b ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    }
    return rc;
}

/* One warm-up frame, then `repeat` timed ones; a frame's time is the slowest rank's, and
 * *median_ms (rank 0) their median. */
static lrr_status timed_frames(lrr_context *ctx, lrr_mpi_solver *s, const float *e, float *b,
                               unsigned repeat, int rank, double *median_ms)
{
    /* repeat 0 (lrr render): the warm-up frame alone */
    double *t = calloc(repeat ? repeat : 1, sizeof *t),
           *tmax = calloc(repeat ? repeat : 1, sizeof *tmax);
    lrr_status st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, t && tmax ? LRR_OK : LRR_ERR_NOMEM);
    if (st == LRR_OK)
        st = lrr_mpi_solve(s, e, b);
    for (unsigned r = 0; st == LRR_OK && r < repeat; r++) {
        MPI_Barrier(MPI_COMM_WORLD);
        double t0 = cli_now();
        st = lrr_mpi_solve(s, e, b);
        t[r] = 1e3 * (cli_now() - t0);
    }
    if (st == LRR_OK && repeat) {
        MPI_Reduce(t, tmax, (int)repeat, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
        if (rank == 0)
            *median_ms = cli_median(tmax, repeat);
    }
    free(t);
    free(tmax);
    return st;
}

static void print_mpi_solve(const solve_mpi_args *a, const lrr_operator *op, const float *b,
                            const lrr_mpi_solver_info *si, size_t fbar_bytes, double ms,
                            double direct_s)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    printf("n: %zu\n", oi.n);
    printf("k: %zu\n", oi.k);
    printf("d: %zu\n", oi.d);
    printf("storage: %s\n", lrr_storage_name(oi.storage));
    printf("ranks: %d\n", si->ranks);
    printf("fbar_bytes: %zu\n", fbar_bytes);
    printf("m_bytes: %zu\n", si->m_bytes);
    printf("allreduce_bytes: %zu\n", si->allreduce_bytes);
    printf("backend: cpu\n");
    printf("path: full\n");
    printf("kernel: %s\n", si->kernel);
    printf("solve_ms: %.4f\n", ms);
    if (a->pa->path) {
        printf("probe: %s\n", a->pa->path);
        printf("probe_method: %s\n", a->pa->median_cut ? "median-cut" : "irradiance");
        printf("sources: %zu\n", a->pa->sources);
    }
    if (a->pa->lights)
        printf("lights: %zu\n", a->pa->lights);
    if (a->pa->path || a->pa->lights)
        printf("direct_light_seconds: %.6f\n", direct_s);
    print_solution_summary(op, b);
    if (a->csv)
        printf("csv: %s\n", a->csv);
}

/* This rank's rows of E with the --light sources (lrr_lighting_direct_rows) from its own
 * operator without F̄ (rank 0's is op): e_rows = emission + (probe + lights) as the serial
 * command sums them (add_probe_light), the probe's rows from rank 0 (p, NULL without a
 * probe). *seconds: the slowest rank's lighting plan and rays. Agreed; *bad the first subpatch whose E
 * overflows (n when none: then rank 0 reports it as the serial command does). */
static lrr_status rank_lights(lrr_context *ctx, lrr_mpi_solver *s, const solve_mpi_args *a,
                              const lrr_operator *op, const float *p, float *e_rows,
                              double *seconds, unsigned long long *bad)
{
    size_t n, row0, rows;
    lrr_mpi_solver_rows(s, &n, &row0, &rows);
    lrr_operator *mine = NULL;
    lrr_lighting *lt = NULL;
    float *d = rows ? cli_alloc_rgb(rows) : NULL, *l = rows ? cli_alloc_rgb(rows) : NULL;
    lrr_status st = rows && (!d || !l) ? LRR_ERR_NOMEM : LRR_OK;
    int probe = p != NULL; /* rank 0's: every rank takes part in the scatter */
    MPI_Bcast(&probe, 1, MPI_INT, 0, MPI_COMM_WORLD);
    st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, st);
    if (st == LRR_OK && probe)
        st = lrr_mpi_scatter(s, 0, p, d);
    if (st == LRR_OK && !op && rows)
        st = lrr_operator_load_head(ctx, a->file, &mine);
    double t0 = cli_now(), t; /* the plan and the rays, as the serial direct_light_seconds */
    if (st == LRR_OK && rows)
        st = lrr_lighting_create(op ? op : mine, &lt);
    if (st == LRR_OK && rows)
        st = lrr_lighting_direct_rows(lt, a->pa->light, a->pa->lights, row0, rows, l);
    unsigned long long first = n;
    if (st == LRR_OK && rows) {
        for (size_t i = 0; i < 3 * rows; i++)
            d[i] = probe ? d[i] + l[i] : l[i]; /* the serial direct: 0 + probe, += lights */
        const size_t at = cli_add_direct(e_rows, d, rows, a->pa->no_scene_emission);
        if (at < rows)
            first = row0 + at;
    }
    t = cli_now() - t0;
    lrr_lighting_destroy(lt);
    lrr_operator_destroy(mine);
    free(d);
    free(l);
    st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, st);
    MPI_Reduce(&t, seconds, 1, MPI_DOUBLE, MPI_MAX, 0, MPI_COMM_WORLD);
    MPI_Allreduce(&first, bad, 1, MPI_UNSIGNED_LONG_LONG, MPI_MIN, MPI_COMM_WORLD);
    return st;
}

/* The distributed part, after rank 0 prepared: solver, scatter, frames, gather; then rank 0
 * checks, writes and prints. */
static int solve_ranks(lrr_context *ctx, const solve_mpi_args *a, int rank,
                       const lrr_operator *op, const float *e, const float *p, float *b,
                       double direct_s)
{
    lrr_mpi_solver *s = NULL;
    float *e_rows = NULL, *b_rows = NULL;
    size_t n = 0, row0, rows = 0;
    unsigned long long fbar_mine = 0, fbar_total = 0;
    double ms = 0;
    lrr_mpi_solver_info si;
    int printed = 0; /* rank 0 reported the failure itself */
    char kernel[KERNEL_NAME_MAX] = "";
    lrr_status st = lrr_mpi_solver_create(ctx, a->file, MPI_COMM_WORLD, &s);
    if (st == LRR_OK) {
        lrr_mpi_solver_rows(s, &n, &row0, &rows);
        lrr_mpi_solver_get_info(s, &si, sizeof si);
        fbar_mine = si.fbar_bytes;
        snprintf(kernel, sizeof kernel, "%s", si.kernel); /* si.kernel is the solver's */
        si.kernel = kernel;
        if (rows) {
            e_rows = cli_alloc_rgb(rows);
            b_rows = cli_alloc_rgb(rows);
        }
        st = lrr_mpi_agree(ctx, MPI_COMM_WORLD,
                           rows && (!e_rows || !b_rows) ? LRR_ERR_NOMEM : LRR_OK);
    }
    if (st == LRR_OK)
        st = lrr_mpi_scatter(s, 0, e, e_rows);
    double lights_s = 0;
    unsigned long long bad = n;
    if (st == LRR_OK && a->pa->lights)
        st = rank_lights(ctx, s, a, op, p, e_rows, &lights_s, &bad);
    direct_s += lights_s;
    if (st == LRR_OK && bad < n) { /* add_probe_light's error, from rank 0 */
        if (rank == 0)
            cli_fail(LRR_ERR_INVALID_ARG, "the emission of subpatch %llu overflows "
                     "(--probe-scale %g, --light)", bad, a->pa->scale);
        st = LRR_ERR_INVALID_ARG;
        printed = 1;
    }
    if (st == LRR_OK)
        st = timed_frames(ctx, s, e_rows, b_rows, a->repeat, rank, &ms);
    if (st == LRR_OK)
        st = lrr_mpi_solve_gather(s, e_rows, 0, b);
    if (st == LRR_OK)
        MPI_Reduce(&fbar_mine, &fbar_total, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, 0,
                   MPI_COMM_WORLD);
    lrr_mpi_solver_destroy(s);
    free(e_rows);
    free(b_rows);
    if (st != LRR_OK)
        return rank == 0 && !printed ? cli_lib_error(ctx, st) : CLI_EXIT_FAIL;
    if (rank != 0)
        return CLI_EXIT_OK;
    int rc = check_finite(b, n);
    if (rc == CLI_EXIT_OK && a->finish)
        return a->finish(ctx, op, b, si.ranks, a->finish_arg);
    if (rc == CLI_EXIT_OK && a->csv)
        rc = cli_write_radiosity_csv(a->csv, op, b);
    if (rc == CLI_EXIT_OK)
        print_mpi_solve(a, op, b, &si, (size_t)fbar_total, ms, direct_s);
    return rc;
}

int solve_mpi_run(const solve_mpi_args *a)
{
    int inited = 0, provided, rank = 0;
    MPI_Initialized(&inited);
    if (!inited && MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
        return cli_fail(LRR_ERR_IO, "MPI_Init_thread failed");
    MPI_Comm_rank(MPI_COMM_WORLD, &rank);
    int rc = check_options(a, rank);
    lrr_context *ctx = NULL;
    lrr_operator *op = NULL;
    float *e = NULL, *p = NULL, *b = NULL;
    double direct_s = 0;
    if (rc == CLI_EXIT_OK && lrr_context_create(&ctx) != LRR_OK)
        rc = cli_fail(LRR_ERR_NOMEM, "cannot create a context");
    if (rc == CLI_EXIT_OK && rank == 0)
        rc = root_prepare(ctx, a, &op, &e, &p, &b, &direct_s);
    /* rank 0's preparation decides for all (it printed why it failed) */
    MPI_Bcast(&rc, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (rc == CLI_EXIT_OK)
        rc = solve_ranks(ctx, a, rank, op, e, p, b, direct_s);
    free(b);
    free(p);
    free(e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    if (!inited)
        MPI_Finalize();
    return rc;
}
#else
/* built without MPI: nothing here (tools/solve_mpi.h) */
typedef int lrr_cli_no_mpi;
#endif
