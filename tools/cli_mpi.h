/* `mpirun -np P lrr preprocess [--verify]` and `mpirun -np P lrr reference --method
 * path-trace` (tools/cli_mpi.c: lrr_mpi_operator_build, lrr_mpi_operator_verify,
 * lrr_mpi_reference_path_trace), taken only when
 * an MPI launcher started the process and lrr was built with MPI (LRR_MPI); otherwise these
 * are the serial steps. Every rank opens the scene and computes its share; rank 0 receives
 * the rest, writes and prints. (`mpirun lrr solve` has its own path: solve_mpi.h.) */
#ifndef LRR_CLI_MPI_H
#define LRR_CLI_MPI_H

#include "commands.h"

typedef struct cli_mpi {
    const char *prog; /* for rank 0's messages */
    int on;          /* started by an MPI launcher (MPI initialised here) */
    int rank, ranks;
    int inited;      /* MPI was initialised before (then not finalised here) */
    double rows_seconds_min, rows_seconds_max, gather_seconds; /* of the build */
    int saved;             /* built by cli_mpi_build_save: */
    double save_seconds;   /* its file's save */
    size_t fbar_bytes_max; /* the most F̄ a rank held (rank 0's figure) */
} cli_mpi;

#ifdef LRR_MPI
/* MPI_Init when launched (m->on), else rank 0 of 1: CLI_EXIT_OK or the failure. */
int cli_mpi_init(cli_mpi *m, const char *prog);
/* lrr_mpi_operator_build across MPI_COMM_WORLD (root 0) when m->on, else
 * lrr_operator_build: *op on rank 0 only. */
lrr_status cli_mpi_build(cli_mpi *m, const lrr_scene *scene,
                                const lrr_build_options *bo, lrr_operator **op);
/* lrr_mpi_operator_build_save across MPI_COMM_WORLD (root 0; m->on only): F̄ stays on
 * the ranks, rank 0 writes path and gets the operator without F̄ in *head. */
lrr_status cli_mpi_build_save(cli_mpi *m, const lrr_scene *scene, const lrr_build_options *bo,
                              lrr_storage storage, lrr_fbar_format fbar, const char *path,
                              lrr_operator **head);
/* lrr_mpi_reference_path_trace across MPI_COMM_WORLD (root 0) when m->on, else
 * lrr_reference_path_trace: b and se whole on rank 0. */
lrr_status cli_mpi_trace(const cli_mpi *m, const lrr_scene *scene,
                         const lrr_path_trace_options *o, float *b, float *se);
/* --verify: `before` agreed over the ranks, then lrr_mpi_operator_verify across
 * MPI_COMM_WORLD (root 0, op there) when m->on; else lrr_operator_verify unless `before`
 * failed. */
lrr_status cli_mpi_verify(const cli_mpi *m, lrr_context *ctx, lrr_operator *op,
                          const lrr_scene *scene, const lrr_verify_options *vo,
                          lrr_status before);
/* The worst exit status over the ranks (rc where not m->on); rank 0 names the lowest
 * failing rank when it did not fail itself (that rank printed why). */
int cli_mpi_agree(const cli_mpi *m, int rc);
/* Rank 0's lines for a distributed build: ranks and the balance of the hemicubes. */
void cli_mpi_print(const cli_mpi *m);
void cli_mpi_finalize(const cli_mpi *m);
#else
static inline int cli_mpi_init(cli_mpi *m, const char *prog)
{
    *m = (cli_mpi){.prog = prog, .ranks = 1};
    return CLI_EXIT_OK;
}
static inline lrr_status cli_mpi_build(cli_mpi *m, const lrr_scene *scene,
                                              const lrr_build_options *bo, lrr_operator **op)
{
    (void)m;
    return lrr_operator_build(scene, bo, op);
}
static inline lrr_status cli_mpi_build_save(cli_mpi *m, const lrr_scene *scene,
                                            const lrr_build_options *bo, lrr_storage storage,
                                            lrr_fbar_format fbar, const char *path,
                                            lrr_operator **head)
{
    (void)m, (void)scene, (void)bo, (void)storage, (void)fbar, (void)path;
    *head = NULL;
    return LRR_ERR_UNSUPPORTED; /* never called: m->on is 0 without MPI */
}
static inline lrr_status cli_mpi_trace(const cli_mpi *m, const lrr_scene *scene,
                                       const lrr_path_trace_options *o, float *b, float *se)
{
    (void)m;
    return lrr_reference_path_trace(scene, o, b, se);
}
static inline lrr_status cli_mpi_verify(const cli_mpi *m, lrr_context *ctx, lrr_operator *op,
                                        const lrr_scene *scene, const lrr_verify_options *vo,
                                        lrr_status before)
{
    (void)m;
    (void)ctx;
    return before ? before : lrr_operator_verify(op, scene, vo);
}
static inline int cli_mpi_agree(const cli_mpi *m, int rc)
{
    (void)m;
    return rc;
}
static inline void cli_mpi_print(const cli_mpi *m) { (void)m; }
static inline void cli_mpi_finalize(const cli_mpi *m) { (void)m; }
#endif

#endif
