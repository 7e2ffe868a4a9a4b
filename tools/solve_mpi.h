/* `mpirun -np P lrr solve`: the distributed path of lrr solve (tools/cmd_solve_mpi.c),
 * built with configure --with-mpi (LRR_MPI) and taken only when an MPI launcher started
 * the process, so a plain `lrr solve` never initialises MPI. */
#ifndef LRR_SOLVE_MPI_H
#define LRR_SOLVE_MPI_H

#include "commands.h"

typedef struct solve_mpi_args {
    const char *file, *csv;
    const probe_args *pa;
    double scale;
    unsigned repeat;
    int path, backend, fbar; /* lrr_path, lrr_backend, lrr_fbar_format as parsed */
    int m_given;             /* --m was given */
    /* lrr render (and any command that draws or writes what it solved): when set, rank 0
     * calls it with the operator (without F̄: lrr_operator_load_head) and the gathered B
     * instead of printing the solve's summary and CSV; its return is rank 0's exit status */
    int (*finish)(lrr_context *ctx, const lrr_operator *op, const float *b, int ranks,
                  const void *arg);
    const void *finish_arg;
} solve_mpi_args;

/* Whether an MPI launcher (Open MPI's mpirun, a PMI or PMIx one) started this process. */
int solve_mpi_launched(void);
/* MPI_Init, the solve across MPI_COMM_WORLD, MPI_Finalize: the exit status. Rank 0 prints
 * and writes; the other ranks print nothing and exit with rank 0's status, except when only
 * rank 0's own output (the CSV, the printout) fails after the solve. */
int solve_mpi_run(const solve_mpi_args *a);

#endif
