/* The MPI tests' allocation-fault loop (test_mpi_build, test_mpi_build_save): each counted
 * allocation of the last rank's context failing in turn (lrr__rows_fail_after), until the
 * collective call needs no more. Needs -I lib (the private hook) and mpi_test.h. */
#ifndef LRR_MPI_FAULTS_H
#define LRR_MPI_FAULTS_H

#include "mpi_test.h"
#include "solve/rows.h" /* lrr__rows_fail_after: the allocation-failure hook */

/* run(user) is one collective call; after each failing allocation it must end every rank
 * with LRR_ERR_NOMEM and clean(user, status) true (clean may be NULL), and in the end succeed
 * everywhere. Checks that (naming what) and returns the number of allocations failed. */
static inline int mt_allocation_faults(lrr_context *ctx, const char *what,
                                       lrr_status (*run)(void *user),
                                       int (*clean)(void *user, lrr_status st), void *user)
{
    const int last = mt_size - 1;
    int failing = 0, done = 0;
    for (unsigned long n = 1; !done && n < 400; n++) {
        if (mt_rank == last)
            lrr__rows_fail_after(ctx, n);
        lrr_status st = run(user);
        if (mt_rank == last)
            lrr__rows_fail_after(ctx, 0);
        int mine = (int)st, lo, hi, ok = !clean || clean(user, st), all_ok;
        MPI_Allreduce(&mine, &lo, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
        MPI_Allreduce(&mine, &hi, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        MPI_Allreduce(&ok, &all_ok, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
        done = lo == LRR_OK && hi == LRR_OK;
        if (!done && !(lo == hi && lo == (int)LRR_ERR_NOMEM && all_ok)) {
            mt_check(0, "%s, allocation %lu failing on rank %d: statuses %d..%d%s", what, n,
                     last, lo, hi, all_ok ? "" : ", not clean");
            return -1;
        }
        failing += !done;
    }
    mt_check(failing > 0 && done, "%s: each of the %d allocations on rank %d failing ends every "
             "rank with LRR_ERR_NOMEM, then the call succeeds", what, failing, last);
    return failing;
}

#endif
