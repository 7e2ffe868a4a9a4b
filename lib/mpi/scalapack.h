/* The ScaLAPACK and BLACS routines liblrr_mpi calls (lib/mpi/invert.c), declared here since
 * Debian's libscalapack-openmpi-dev ships no C header. Fortran routines take every argument
 * by pointer and, for each CHARACTER argument, a hidden length (size_t with gfortran >= 8)
 * after the others; integers are the default 32-bit INTEGER. The C BLACS interface
 * (Cblacs_*, Csys2blacs_handle) takes values. Only with configure --with-scalapack. */
#ifndef LRR_MPI_SCALAPACK_H
#define LRR_MPI_SCALAPACK_H

#include <mpi.h>
#include <stddef.h>

/* BLACS: a system handle for an MPI communicator (its ranks become the grid's processes),
 * a process grid on it (order "Row": rank r is (r / npcol, r % npcol)), its shape and this
 * process's place, and their release. */
int Csys2blacs_handle(MPI_Comm comm);
void Cfree_blacs_system_handle(int handle);
void Cblacs_get(int context, int what, int *value);
void Cblacs_gridinit(int *context, const char *order, int nprow, int npcol);
void Cblacs_gridinfo(int context, int *nprow, int *npcol, int *myrow, int *mycol);
void Cblacs_gridexit(int context);

/* Descriptors and local sizes of block-cyclic matrices. */
int numroc_(const int *n, const int *nb, const int *iproc, const int *isrcproc,
            const int *nprocs);
void descinit_(int *desc, const int *m, const int *n, const int *mb, const int *nb,
               const int *irsrc, const int *icsrc, const int *ictxt, const int *lld,
               int *info);

/* The distributed norm, LU and the inverse from it (not pdgecon: its estimate is wrong in
 * ScaLAPACK 2.2.1, invert.c). */
double pdlange_(const char *norm, const int *m, const int *n, const double *a, const int *ia,
                const int *ja, const int *desca, double *work, size_t norm_len);
void pdgetrf_(const int *m, const int *n, double *a, const int *ia, const int *ja,
              const int *desca, int *ipiv, int *info);
void pdgetri_(const int *n, double *a, const int *ia, const int *ja, const int *desca,
              const int *ipiv, double *work, const int *lwork, int *iwork, const int *liwork,
              int *info);

#endif
