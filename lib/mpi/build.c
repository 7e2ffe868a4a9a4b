/* The distributed build (lrr_mpi.h lrr_mpi_operator_build): every rank runs the serial
 * build's first stage (options, budget, hierarchy: lib/operator/build.h), computes the
 * hemicubes of its receivers, and the rows are sent to the root, which finishes the
 * operator (weights, factorisation, panels) as the serial build does. Each receiver's
 * hemicube depends on its index alone, so F̄ is the serial one bit for bit, and so are M
 * and everything after it.
 *
 * The receivers are dealt in chunks of 64 rows, chunk c to rank c mod P (chunks.c): a
 * hemicube's cost follows what its receiver sees, which varies across a scene, and
 * neighbouring chunks cost about the same. Equal blocks of whole patches took 206 and
 * 240 s on the two ranks of the bunny room (--clusters 2000, R 128, one thread each). */
#include "config.h"
#include "mpi/mpi_internal.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

#define TAG_FBAR 1
#define TAG_BACK 2

typedef struct dist {
    lrr_context *ctx;
    MPI_Comm comm;        /* a duplicate, MPI_ERRORS_RETURN */
    int rank, size, root;
    lrr__build *b;
    size_t n, k;
    size_t *rows;         /* this rank's receivers, ascending */
    float *fbar;          /* their rows of F̄, rows×k (on the root: the whole F̄) */
    double *back;         /* their back-face shares (on the root: all n) */
    int own;              /* fbar and back are this rank's allocations (not the root's) */
    int *len, *at;        /* the root's: one rank's chunks (rows, first row) at a time */
    lrr_mpi_build_info info;
} dist;

static double now(void) { return MPI_Wtime(); }

/* This rank's receivers and buffers. */
static lrr_status split(dist *d)
{
    if (d->n > INT_MAX)
        return lrr__mpi_error(d->ctx, LRR_ERR_OVERFLOW, "lrr_mpi_operator_build: n = %zu "
                              "subpatches exceeds MPI's int counts", d->n);
    const size_t rows = lrr__mpi_chunk_rows(d->n, d->rank, d->size, NULL);
    d->info.rows = rows;
    if (rows && !(d->rows = calloc(rows, sizeof *d->rows)))
        return lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_build: cannot allocate "
                              "the list of this rank's %zu receivers", rows);
    lrr__mpi_chunk_rows(d->n, d->rank, d->size, d->rows);
    if (d->rank == d->root) {
        /* allocated before the hemicubes: the receives cannot fail for memory while the
         * other ranks wait in their sends */
        const size_t most = lrr__mpi_chunk_most(d->n, d->size);
        d->fbar = lrr__build_fbar(d->b);
        d->back = lrr__build_back(d->b);
        d->len = calloc(most, sizeof(int));
        d->at = calloc(most, sizeof(int));
        return d->len && d->at ? LRR_OK
                               : lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_build: "
                                                "cannot allocate the table of %zu chunks", most);
    }
    d->own = 1;
    if (rows && (rows > SIZE_MAX / sizeof(float) / d->k ||
                 !(d->fbar = lrr_aligned_alloc(rows * d->k * sizeof(float))) ||
                 !(d->back = calloc(rows, sizeof(double)))))
        return lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_build: cannot allocate "
                              "this rank's %zu rows of F̄ (k = %zu)", rows, d->k);
    return LRR_OK;
}

/* The hemicubes of this rank's rows, then every rank's rows to the root; the slowest and
 * fastest rank's times and the transfer's. */
static lrr_status rows_and_gather(dist *d)
{
    double t0 = now();
    const int root = d->rank == d->root;
    lrr_status st = d->info.rows ? lrr__build_rows(d->b, d->rows, d->info.rows, root, d->fbar,
                                                   d->back)
                                 : LRR_OK;
    d->info.rows_seconds = now() - t0;
    if ((st = lrr__mpi_spread(d->ctx, d->comm, st)))
        return st;
    double t[2] = {-d->info.rows_seconds, d->info.rows_seconds}, tr[2];
    int rc = MPI_Allreduce(t, tr, 2, MPI_DOUBLE, MPI_MAX, d->comm);
    d->info.rows_seconds_min = -tr[0];
    d->info.rows_seconds_max = tr[1];
    MPI_Datatype row = MPI_DATATYPE_NULL;
    if (rc == MPI_SUCCESS && (rc = MPI_Type_contiguous((int)d->k, MPI_FLOAT, &row)) ==
                                 MPI_SUCCESS)
        rc = MPI_Type_commit(&row);
    double t1 = now();
    if (rc == MPI_SUCCESS && root) {
        for (int r = 0; r < d->size && rc == MPI_SUCCESS; r++)
            if (r != d->root &&
                (rc = lrr__mpi_chunk_recv(d->comm, d->n, r, d->size, row, d->len, d->at,
                                          d->fbar, TAG_FBAR)) == MPI_SUCCESS)
                rc = lrr__mpi_chunk_recv(d->comm, d->n, r, d->size, MPI_DOUBLE, d->len,
                                         d->at, d->back, TAG_BACK);
    } else if (rc == MPI_SUCCESS && d->info.rows &&
             (rc = MPI_Send(d->fbar, (int)d->info.rows, row, d->root, TAG_FBAR, d->comm)) ==
                 MPI_SUCCESS)
        rc = MPI_Send(d->back, (int)d->info.rows, MPI_DOUBLE, d->root, TAG_BACK, d->comm);
    d->info.gather_seconds = now() - t1;
    if (row != MPI_DATATYPE_NULL)
        MPI_Type_free(&row);
    return lrr__mpi_spread(d->ctx, d->comm,
                           rc == MPI_SUCCESS ? LRR_OK
                                             : lrr__mpi_failed(d->ctx, "sending rows of F̄", rc));
}

static lrr_status build_steps(dist *d, const lrr_scene *scene, const lrr_build_options *opts,
                              lrr_operator **out)
{
    const double t0 = now();
    lrr_status st = lrr__mpi_spread(d->ctx, d->comm,
                                    lrr__build_begin(scene, opts, d->rank == d->root, &d->b));
    if (st || (st = lrr__mpi_same_selection(d->ctx, d->comm, d->rank, d->root, d->b, &d->n,
                                                 &d->k)) ||
        (st = lrr__mpi_spread(d->ctx, d->comm, split(d))) || (st = rows_and_gather(d)))
        return st;
    /* the operator's form-factor time: the hemicubes across the ranks and the gather */
    const double ff = d->info.rows_seconds_max + d->info.gather_seconds;
    st = d->rank == d->root ? lrr__build_finish(d->b, ff, out) : LRR_OK;
    d->info.seconds = now() - t0;
    return lrr__mpi_spread(d->ctx, d->comm, st);
}

lrr_status lrr_mpi_operator_build(const lrr_scene *scene, const lrr_build_options *opts,
                                  MPI_Comm comm, int root, lrr_operator **out,
                                  lrr_mpi_build_info *info, size_t info_size)
{
    *out = NULL;
    dist d;
    memset(&d, 0, sizeof d);
    d.ctx = lrr__build_scene_context(scene);
    d.root = root;
    lrr_status st = lrr__mpi_open(d.ctx, comm, root, "lrr_mpi_operator_build", &d.comm,
                                  &d.rank, &d.size);
    if (d.comm == MPI_COMM_NULL)
        return st;
    d.info.ranks = d.size;
    if (!st)
        st = build_steps(&d, scene, opts, out);
    if (st) {
        lrr_operator_destroy(*out);
        *out = NULL;
    }
    if (info)
        memcpy(info, &d.info, info_size < sizeof d.info ? info_size : sizeof d.info);
    if (d.own) {
        lrr_aligned_free(d.fbar);
        free(d.back);
    }
    free(d.rows);
    free(d.len);
    free(d.at);
    lrr__build_destroy(d.b);
    MPI_Comm_free(&d.comm);
    return st;
}

/* Every rank selected the same hierarchy: n, k and the fingerprint (offsets, subpatch
 * order, triangles) against the root's; all ranks compare the same table. */
lrr_status lrr__mpi_same_selection(lrr_context *ctx, MPI_Comm comm, int rank, int root,
                                   lrr__build *b, size_t *n, size_t *k)
{
    lrr__build_size(b, n, k);
    uint64_t mine[3] = {*n, *k, lrr__build_fingerprint(b)}, theirs[3];
    memcpy(theirs, mine, sizeof mine);
    int rc = MPI_Bcast(theirs, 3, MPI_UINT64_T, root, comm);
    if (rc != MPI_SUCCESS)
        return lrr__mpi_failed(ctx, "MPI_Bcast (selection check)", rc);
    lrr_status st = LRR_OK;
    if (memcmp(mine, theirs, sizeof mine) != 0)
        st = lrr__mpi_error(ctx, LRR_ERR_DIM,
                            "lrr_mpi_operator_build: rank %d selected another operator than the "
                            "root (rank %d): n = %llu, k = %llu against n = %llu, k = %llu%s; "
                            "give every rank the same scene and options", rank, root,
                            (unsigned long long)mine[0], (unsigned long long)mine[1],
                            (unsigned long long)theirs[0], (unsigned long long)theirs[1],
                            mine[0] == theirs[0] && mine[1] == theirs[1]
                                ? " (other patches or triangles)" : "");
    return lrr__mpi_spread(ctx, comm, st);
}
