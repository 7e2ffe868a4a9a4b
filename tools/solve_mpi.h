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
} solve_mpi_args;

/* Whether an MPI launcher (Open MPI's mpirun, a PMI or PMIx one) started this process. */
int solve_mpi_launched(void);
/* MPI_Init, the solve across MPI_COMM_WORLD, MPI_Finalize: the exit status. Rank 0 prints
 * and writes; the other ranks print nothing and exit with rank 0's status, except when only
 * rank 0's own output (the CSV, the printout) fails after the solve. */
int solve_mpi_run(const solve_mpi_args *a);

#endif
