/* lrr preprocess (and its --verify) and lrr reference across MPI ranks (tools/cli_mpi.h; lrr_mpi.h,
 * docs/MPI.md). */
#ifdef LRR_MPI
#include <mpi.h>
#include <stdio.h>

#include "lrr_mpi.h"
#include "cli_mpi.h"
#include "solve_mpi.h"

int cli_mpi_init(cli_mpi *m, const char *prog)
{
    *m = (cli_mpi){.prog = prog, .ranks = 1};
    if (!solve_mpi_launched())
        return CLI_EXIT_OK;
    int provided;
    MPI_Initialized(&m->inited);
    if (!m->inited && MPI_Init_thread(NULL, NULL, MPI_THREAD_FUNNELED, &provided) != MPI_SUCCESS)
        return cli_fail(LRR_ERR_IO, "MPI_Init_thread failed");
    m->on = 1;
    MPI_Comm_rank(MPI_COMM_WORLD, &m->rank);
    MPI_Comm_size(MPI_COMM_WORLD, &m->ranks);
    return CLI_EXIT_OK;
}

lrr_status cli_mpi_build(cli_mpi *m, const lrr_scene *scene,
                                const lrr_build_options *bo, lrr_operator **op)
{
    if (!m->on)
        return lrr_operator_build(scene, bo, op);
    lrr_mpi_build_info info;
    lrr_status st = lrr_mpi_operator_build(scene, bo, MPI_COMM_WORLD, 0, op, &info,
                                           sizeof info);
    m->rows_seconds_min = info.rows_seconds_min;
    m->rows_seconds_max = info.rows_seconds_max;
    m->gather_seconds = info.gather_seconds;
    return st;
}

lrr_status cli_mpi_build_save(cli_mpi *m, const lrr_scene *scene, const lrr_build_options *bo,
                              lrr_storage storage, lrr_fbar_format fbar, const char *path,
                              lrr_operator **head)
{
    lrr_mpi_build_info info;
    lrr_status st = lrr_mpi_operator_build_save(scene, bo, storage, fbar, path, MPI_COMM_WORLD,
                                                0, head, &info, sizeof info);
    m->rows_seconds_min = info.rows_seconds_min;
    m->rows_seconds_max = info.rows_seconds_max;
    m->gather_seconds = info.gather_seconds;
    m->save_seconds = info.save_seconds;
    m->saved = 1;
    unsigned long long mine = info.fbar_bytes, most = 0;
    MPI_Reduce(&mine, &most, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, 0, MPI_COMM_WORLD);
    m->fbar_bytes_max = (size_t)most;
    return st;
}

lrr_status cli_mpi_trace(const cli_mpi *m, const lrr_scene *scene,
                         const lrr_path_trace_options *o, float *b, float *se)
{
    return m->on ? lrr_mpi_reference_path_trace(scene, o, MPI_COMM_WORLD, 0, b, se)
                 : lrr_reference_path_trace(scene, o, b, se);
}

lrr_status cli_mpi_verify(const cli_mpi *m, lrr_context *ctx, lrr_operator *op,
                          const lrr_scene *scene, const lrr_verify_options *vo,
                          lrr_status before)
{
    if (!m->on)
        return before ? before : lrr_operator_verify(op, scene, vo);
    lrr_status st = lrr_mpi_agree(ctx, MPI_COMM_WORLD, before);
    return st ? st : lrr_mpi_operator_verify(op, scene, vo, MPI_COMM_WORLD, 0);
}

int cli_mpi_agree(const cli_mpi *m, int rc)
{
    if (!m->on)
        return rc;
    int mine[2] = {rc, rc != CLI_EXIT_OK ? m->rank : m->ranks}, worst[2] = {rc, m->rank};
    int got = MPI_Allreduce(&mine[0], &worst[0], 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    if (got == MPI_SUCCESS)
        got = MPI_Allreduce(&mine[1], &worst[1], 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    if (got != MPI_SUCCESS)
        return CLI_EXIT_FAIL;
    if (m->rank == 0 && rc == CLI_EXIT_OK && worst[0] != CLI_EXIT_OK)
        fprintf(stderr, "%s: rank %d of %d failed (its message is above)\n", m->prog, worst[1],
                m->ranks);
    return worst[0];
}

void cli_mpi_print(const cli_mpi *m)
{
    if (!m->on)
        return;
    printf("ranks: %d\n", m->ranks);
    printf("rank_hemicube_seconds: %.3f %.3f\n", m->rows_seconds_min, m->rows_seconds_max);
    printf("gather_seconds: %.3f\n", m->gather_seconds);
    if (m->saved) { /* F̄ stayed on the ranks: the most one held, and the streamed save */
        printf("rank_fbar_mb: %.3f\n", (double)m->fbar_bytes_max / (1024.0 * 1024.0));
        printf("save_seconds: %.3f\n", m->save_seconds);
    }
}

void cli_mpi_finalize(const cli_mpi *m)
{
    if (m->on && !m->inited)
        MPI_Finalize();
}
#else
/* built without MPI: the serial steps are inline in tools/cli_mpi.h */
typedef int lrr_cli_no_mpi;
#endif
