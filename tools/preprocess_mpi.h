/* `mpirun -np P lrr preprocess`: the distributed build of lrr preprocess
 * (tools/cmd_preprocess_mpi.c, lrr_mpi_operator_build), taken only when an MPI launcher
 * started the process and lrr was built with MPI (LRR_MPI); otherwise these are the serial
 * steps. Every rank opens the scene and computes its block of hemicubes; rank 0 gathers
 * them, factorises, writes the file and prints. */
#ifndef LRR_PREPROCESS_MPI_H
#define LRR_PREPROCESS_MPI_H

#include "commands.h"

typedef struct preprocess_mpi {
    int on;          /* started by an MPI launcher (MPI initialised here) */
    int rank, ranks;
    int inited;      /* MPI was initialised before (then not finalised here) */
    double rows_seconds_min, rows_seconds_max, gather_seconds; /* of the build */
} preprocess_mpi;

#ifdef LRR_MPI
/* MPI_Init when launched (m->on), else rank 0 of 1: CLI_EXIT_OK or the failure. */
int preprocess_mpi_init(preprocess_mpi *m);
/* lrr_mpi_operator_build across MPI_COMM_WORLD (root 0) when m->on, else
 * lrr_operator_build: *op on rank 0 only. */
lrr_status preprocess_mpi_build(preprocess_mpi *m, const lrr_scene *scene,
                                const lrr_build_options *bo, lrr_operator **op);
/* The worst exit status over the ranks (rc where not m->on); rank 0 names the lowest
 * failing rank when it did not fail itself (that rank printed why). */
int preprocess_mpi_agree(const preprocess_mpi *m, int rc);
/* Rank 0's lines for a distributed build: ranks and the balance of the hemicubes. */
void preprocess_mpi_print(const preprocess_mpi *m);
void preprocess_mpi_finalize(const preprocess_mpi *m);
#else
static inline int preprocess_mpi_init(preprocess_mpi *m)
{
    *m = (preprocess_mpi){.ranks = 1};
    return CLI_EXIT_OK;
}
static inline lrr_status preprocess_mpi_build(preprocess_mpi *m, const lrr_scene *scene,
                                              const lrr_build_options *bo, lrr_operator **op)
{
    (void)m;
    return lrr_operator_build(scene, bo, op);
}
static inline int preprocess_mpi_agree(const preprocess_mpi *m, int rc)
{
    (void)m;
    return rc;
}
static inline void preprocess_mpi_print(const preprocess_mpi *m) { (void)m; }
static inline void preprocess_mpi_finalize(const preprocess_mpi *m) { (void)m; }
#endif

#endif
