/* The distributed path-traced reference (lrr_mpi.h lrr_mpi_reference_path_trace): every
 * rank traces the subpatches of its chunks (chunks.c) with the serial tracer
 * (lib/reference/rows.h) and the root receives them in place. Each path has its own random
 * stream from (seed, subpatch, sample), so the result is the serial one bit for bit. */
#include "config.h"
#include "mpi/mpi_internal.h"
#include "reference/rows.h"

#include <stdlib.h>
#include <string.h>

#define TAG_B 3
#define TAG_SE 4

typedef struct trace {
    lrr_context *ctx;
    MPI_Comm comm;
    int rank, size, root, want_se;
    size_t n, count;
    size_t *rows;
    float *b, *se;         /* this rank's count×3 */
    int *len, *at;         /* the root's chunk table */
} trace;

/* The subpatch count, whether the root wants standard errors, and this rank's buffers. */
static lrr_status prepare(trace *t, const lrr_scene *scene, const float *std_error)
{
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    t->n = si.subpatches;
    unsigned long long mine[2] = {t->n, std_error != NULL}, root[2] = {mine[0], mine[1]};
    int rc = MPI_Bcast(root, 2, MPI_UNSIGNED_LONG_LONG, t->root, t->comm);
    if (rc != MPI_SUCCESS)
        return lrr__mpi_failed(t->ctx, "MPI_Bcast (subpatch count)", rc);
    t->want_se = (int)root[1];
    if (root[0] != mine[0])
        return lrr__mpi_error(t->ctx, LRR_ERR_DIM, "lrr_mpi_reference_path_trace: rank %d's "
                              "scene has %zu subpatches, the root's (rank %d) %llu", t->rank,
                              t->n, t->root, root[0]);
    if (t->n > INT32_MAX / 3)
        return lrr__mpi_error(t->ctx, LRR_ERR_OVERFLOW, "lrr_mpi_reference_path_trace: n = "
                              "%zu subpatches exceeds MPI's int counts", t->n);
    t->count = lrr__mpi_chunk_rows(t->n, t->rank, t->size, NULL);
    const size_t most = lrr__mpi_chunk_most(t->n, t->size);
    int ok = !t->count || ((t->rows = calloc(t->count, sizeof *t->rows)) &&
                           (t->b = calloc(3 * t->count, sizeof(float))) &&
                           (!t->want_se || (t->se = calloc(3 * t->count, sizeof(float)))));
    if (ok && t->rank == t->root)
        ok = (t->len = calloc(most, sizeof(int))) && (t->at = calloc(most, sizeof(int)));
    if (!ok)
        return lrr__mpi_error(t->ctx, LRR_ERR_NOMEM, "lrr_mpi_reference_path_trace: cannot "
                              "allocate this rank's %zu subpatches", t->count);
    lrr__mpi_chunk_rows(t->n, t->rank, t->size, t->rows);
    return LRR_OK;
}

static lrr_status trace_steps(trace *t, const lrr_scene *scene,
                              const lrr_path_trace_options *opts, float *radiosity,
                              float *std_error)
{
    lrr_status st = lrr__mpi_spread(t->ctx, t->comm, prepare(t, scene, std_error));
    if (st)
        return st;
    /* every rank checks the options (a rank with no subpatches too) */
    st = lrr__trace_rows(scene, opts, t->rows, t->count, t->b, t->want_se ? t->se : NULL);
    if ((st = lrr__mpi_spread(t->ctx, t->comm, st)))
        return st;
    int rc = lrr__mpi_chunk_gather(t->comm, t->root, t->n, t->rows, t->count, t->b, radiosity,
                                   t->len, t->at, TAG_B);
    if (rc == MPI_SUCCESS && t->want_se)
        rc = lrr__mpi_chunk_gather(t->comm, t->root, t->n, t->rows, t->count, t->se, std_error,
                                   t->len, t->at, TAG_SE);
    return lrr__mpi_spread(t->ctx, t->comm,
                           rc == MPI_SUCCESS
                               ? LRR_OK
                               : lrr__mpi_failed(t->ctx, "sending path-traced estimates", rc));
}

lrr_status lrr_mpi_reference_path_trace(const lrr_scene *scene,
                                        const lrr_path_trace_options *opts, MPI_Comm comm,
                                        int root, float *radiosity, float *std_error)
{
    trace t;
    memset(&t, 0, sizeof t);
    t.ctx = lrr__trace_context(scene);
    t.root = root;
    lrr_status st = lrr__mpi_open(t.ctx, comm, root, "lrr_mpi_reference_path_trace", &t.comm,
                                  &t.rank, &t.size);
    if (t.comm == MPI_COMM_NULL)
        return st;
    if (!st) {
        st = t.rank == root && !radiosity
                 ? lrr__mpi_error(t.ctx, LRR_ERR_INVALID_ARG, "lrr_mpi_reference_path_trace: "
                                  "the root's radiosity is NULL")
                 : LRR_OK;
        if (!(st = lrr__mpi_spread(t.ctx, t.comm, st)))
            st = trace_steps(&t, scene, opts, radiosity, std_error);
    }
    free(t.rows);
    free(t.b);
    free(t.se);
    free(t.len);
    free(t.at);
    MPI_Comm_free(&t.comm);
    return st;
}
