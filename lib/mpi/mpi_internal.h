/* liblrr_mpi's internals (lib/mpi/): the collective agreement on errors (agree.c) shared by
 * the solver (solver.c). Only lrr.h, lrr_mpi.h and the serial library's private row-block
 * entry points (solve/rows.h) are used: liblrr's other internals are hidden in liblrr.so. */
#ifndef LRR_MPI_INTERNAL_H
#define LRR_MPI_INTERNAL_H

#include "lrr_mpi.h"
#include "operator/build.h"
#include "solve/rows.h"

/* Records a printf-style error on ctx (first error kept, callback called) and returns
 * status. */
lrr_status lrr__mpi_error(lrr_context *ctx, lrr_status status, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
/* An MPI call that returned rc (not MPI_SUCCESS): LRR_ERR_IO naming call and MPI's text. */
lrr_status lrr__mpi_failed(lrr_context *ctx, const char *call, int rc);
/* The agreement (lrr_mpi.h "Collective calls and faults"): one MPI_Allreduce (MIN) finds
 * the lowest failing rank, which broadcasts its status and message only when there is one.
 * Returns LRR_OK on every rank when mine was LRR_OK everywhere. */
lrr_status lrr__mpi_spread(lrr_context *ctx, MPI_Comm comm, lrr_status mine);

/* The start of a collective call rooted at root (agree.c): *dup a duplicate of comm with
 * MPI_ERRORS_RETURN (MPI_COMM_NULL when that fails; free it otherwise), this rank and the
 * size; LRR_ERR_INVALID_ARG, on every rank alike, when root is not a rank (fn names the
 * call in the message). */
lrr_status lrr__mpi_open(lrr_context *ctx, MPI_Comm comm, int root, const char *fn,
                         MPI_Comm *dup, int *rank, int *size);

/* Chunks (chunks.c): rows 64c .. 64c+63 are chunk c, and chunk c goes to rank c mod P.
 * 64 hemicubes are about 0.2 s at R 128 on one core. */
#define LRR__MPI_CHUNK 64
/* Rank r's rows (ascending) into rows (may be NULL); their count. */
size_t lrr__mpi_chunk_rows(size_t n, int r, int size, size_t *rows);
/* The most chunks any rank gets: the size of lrr__mpi_chunk_recv's len and at. */
size_t lrr__mpi_chunk_most(size_t n, int size);
/* The root's receive of rank r's rows (one message with tag, as rank r sends its rows
 * packed, row after row) into their places in buf, an array of n rows of type row; len and
 * at are scratch of lrr__mpi_chunk_most entries. Nothing when rank r has no rows. An MPI
 * error code. */
int lrr__mpi_chunk_recv(MPI_Comm comm, size_t n, int r, int size, MPI_Datatype row,
                        int *len, int *at, void *buf, int tag);
/* Every rank's estimates (3 floats a row) of its chunks of n rows to the root: a rank sends
 * its `count` rows, packed in chunk order; the root places its own, packed[j] at row
 * mine[j] of whole (n×3), and receives every other rank's in place (len and at: scratch of
 * lrr__mpi_chunk_most entries). whole is the root's alone. An MPI error code. */
int lrr__mpi_chunk_gather(MPI_Comm comm, int root, size_t n, const size_t *mine, size_t count,
                          const float *packed, float *whole, int *len, int *at, int tag);

/* The distributed builds' check that every rank selected the root's hierarchy (n, k and
 * lrr__build_fingerprint; build.c): *n and *k, LRR_ERR_DIM agreed when one differs. */
lrr_status lrr__mpi_same_selection(lrr_context *ctx, MPI_Comm comm, int rank, int root,
                                   lrr__build *b, size_t *n, size_t *k);

#endif
