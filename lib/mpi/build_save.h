/* lrr_mpi_operator_build_save's state (build_save.c) and its file's save (write.c). */
#ifndef LRR_MPI_BUILD_SAVE_H
#define LRR_MPI_BUILD_SAVE_H

#include "mpi/mpi_internal.h"

typedef struct bs_grid bs_grid; /* invert.c's ScaLAPACK grid */

typedef struct bs_dist {
    lrr_context *ctx;
    MPI_Comm comm;          /* a duplicate, MPI_ERRORS_RETURN */
    int rank, size, root;
    lrr__build *b;
    lrr_operator *head;     /* the root's operator without F̄, once finished */
    size_t n, k, es;        /* es: bytes of an F̄ element in the file's storage */
    const size_t *first;    /* patch offsets (k + 1) */
    size_t *rows, count;    /* this rank's receivers, ascending */
    size_t chunks_mine;     /* its chunks */
    float *block;           /* their rows of F̄, count×k, coded in place (es bytes each) */
    double *back;           /* their back-face shares */
    float *scratch;         /* 2k floats */
    int *len, *at;          /* the root's chunk tables (lrr__mpi_chunk_most entries) */
    /* G's chain (build_save.c): finished rows (ends×k), partial rows to send (one a chunk),
     * the one being continued, the sends, patch indices, each chunk's first finished
     * slot; the root's G (k×k) */
    size_t ends, *slot0;
    double *done, *sendbuf, *partial, *G;
    MPI_Request *req;
    int *idx;
    MPI_Datatype grow;      /* one row of G (k doubles) */
    int dist;               /* G inverted with ScaLAPACK (invert.c): the root has no G */
    bs_grid *grid;
    lrr_mpi_build_info info;
} bs_dist;

/* Chunks of F̄'s rows: their number, rank r's (chunks r, r + P, …), and chunk c's rows
 * [*a, *b). */
size_t lrr__bs_chunks(const bs_dist *d);
size_t lrr__bs_rank_chunks(const bs_dist *d, int r);
void lrr__bs_chunk(const bs_dist *d, size_t c, size_t *a, size_t *b);
/* Patches whose last row lies in rank r's chunks, ascending, into ends (may be NULL);
 * their count. G's finished rows on rank r are theirs, in this order. */
size_t lrr__bs_ending_patches(const bs_dist *d, int r, int *ends);
/* G_c inverted across the ranks (invert.c, HAVE_SCALAPACK; LRR_ERR_UNSUPPORTED without):
 * open makes the grid (nb×nb blocks) and its exchange for every channel, invert takes
 * G_c's finished rows (d->done) and leaves M_c and its condition in the root's operator;
 * close frees the grid (d->grid may be NULL). Collective, agreed. */
lrr_status lrr__bs_grid_open(bs_dist *d, int nb);
lrr_status lrr__bs_invert(bs_dist *d, int c);
void lrr__bs_grid_close(bs_dist *d);
/* The file: the root saves d->head, every rank writing its blocks of F̄ into it (MPI-IO),
 * as fbar chooses (strips from the counts every rank gives); agreed. */
lrr_status lrr__bs_save(bs_dist *d, lrr_fbar_format fbar, const char *path);

#endif
