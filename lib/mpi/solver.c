/* The distributed solver (lrr_mpi.h): each rank a block of whole patches' rows of F̄, one
 * allreduce of w = Vᵀ E per frame. The row blocks and both halves of a frame are the serial
 * library's (lib/solve/rows.c); this file splits the rows, moves the data and agrees on
 * errors (agree.c). */
#include "config.h"
#include "mpi/mpi_internal.h"

#include <limits.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

struct lrr_mpi_solver {
    lrr_context *ctx;     /* held by the row block */
    MPI_Comm comm;        /* a duplicate, MPI_ERRORS_RETURN */
    MPI_Datatype rgb;     /* three floats: one subpatch of E or B */
    int rank, size;
    lrr__rows *rows;
    size_t n, k, row0, nrows;
    int *counts, *displs; /* per rank, in subpatches (rgb) */
    uint64_t hash;        /* of the patch offsets this rank loaded */
    float *w, *wsum;      /* 3k + 1: this rank's Vᵀ E and its failure flag; their sums */
    float *b;             /* nrows×3: this rank's B for lrr_mpi_solve_gather */
};

void lrr_mpi_solver_destroy(lrr_mpi_solver *s)
{
    if (!s)
        return;
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized) { /* after MPI_Finalize the handles are gone already */
        if (s->rgb != MPI_DATATYPE_NULL)
            MPI_Type_free(&s->rgb);
        if (s->comm != MPI_COMM_NULL)
            MPI_Comm_free(&s->comm);
    }
    lrr__rows_destroy(s->rows);
    free(s->counts);
    free(s->displs);
    free(s->w);
    free(s->wsum);
    free(s->b);
    free(s);
}

/* FNV-1a over the patch offsets: ranks that loaded different files (or one that changed
 * between the loads) almost surely differ here even with equal n and k. */
static uint64_t offsets_hash(const size_t *first, size_t k)
{
    uint64_t h = 1469598103934665603u;
    for (size_t p = 0; p <= k; p++)
        for (int b = 0; b < 64; b += 8) {
            h ^= (uint64_t)(first[p] >> b) & 0xff;
            h *= 1099511628211u;
        }
    return h;
}

/* Every rank loaded the same operator: n, k and the offsets' hash against rank 0's. All
 * ranks see the same table, so they agree without another step. */
static lrr_status same_operator(lrr_mpi_solver *s, const char *path)
{
    uint64_t mine[3] = {s->n, s->k, s->hash};
    uint64_t *all = calloc((size_t)s->size, sizeof mine);
    int bad = all ? 0 : 1, any = 0, rc;
    /* an allocation failure on one rank must not leave the others in MPI_Allgather */
    if ((rc = MPI_Allreduce(&bad, &any, 1, MPI_INT, MPI_MAX, s->comm)) != MPI_SUCCESS) {
        free(all);
        return lrr__mpi_failed(s->ctx, "MPI_Allreduce (operator check)", rc);
    }
    if (any) {
        free(all);
        return lrr__mpi_error(s->ctx, LRR_ERR_NOMEM,
                              "lrr_mpi_solver_create: cannot allocate %d ranks' operator sizes",
                              s->size);
    }
    if ((rc = MPI_Allgather(mine, 3, MPI_UINT64_T, all, 3, MPI_UINT64_T, s->comm)) !=
        MPI_SUCCESS) {
        free(all);
        return lrr__mpi_failed(s->ctx, "MPI_Allgather (operator check)", rc);
    }
    lrr_status st = LRR_OK;
    for (int r = 1; r < s->size && st == LRR_OK; r++)
        if (memcmp(all + 3 * r, all, sizeof mine) != 0)
            st = lrr__mpi_error(s->ctx, LRR_ERR_DIM,
                                "lrr_mpi_solver_create: the ranks loaded different operators: "
                                "rank %d n = %llu, k = %llu, rank 0 n = %llu, k = %llu%s (this "
                                "rank read %s)", r, (unsigned long long)all[3 * r],
                                (unsigned long long)all[3 * r + 1], (unsigned long long)all[0],
                                (unsigned long long)all[1],
                                all[3 * r + 2] != all[2] ? ", other patch offsets" : "", path);
    free(all);
    return st;
}

/* The first patch of rank r's block: the first patch boundary at or after r·n/size rows,
 * so blocks hold whole patches and about n/size rows each (rank size: k). */
static size_t block_start(const size_t *first, size_t n, size_t k, int r, int size)
{
    const size_t target = (size_t)((unsigned __int128)n * (unsigned)r / (unsigned)size);
    size_t lo = 0, hi = k; /* first[k] = n >= target */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (first[mid] < target)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

/* The loader's pick (lrr__rows_pick_fn), before any F̄ is read: n, k and the offsets'
 * hash, the counts and displacements of every rank's rows (the same table on every rank
 * that loaded the same file), the frame's buffers, and this rank's block. Local: a rank
 * whose load failed earlier never gets here, so the ranks agree only afterwards. */
static lrr_status split(void *user, const lrr_operator *op, size_t *mine0, size_t *mine1)
{
    lrr_mpi_solver *s = user;
    const size_t *first = lrr_operator_patch_offsets(op);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const size_t n = s->n = oi.n, k = s->k = oi.k;
    s->hash = offsets_hash(first, k);
    if (n > INT_MAX || k > (INT_MAX - 1) / 3)
        return lrr__mpi_error(s->ctx, LRR_ERR_OVERFLOW,
                              "lrr_mpi_solver_create: n = %zu or 3k + 1 (k = %zu) exceeds MPI's "
                              "int counts", n, k);
    s->counts = calloc((size_t)s->size, sizeof(int));
    s->displs = calloc((size_t)s->size, sizeof(int));
    s->w = calloc(3 * k + 1, sizeof(float));
    s->wsum = calloc(3 * k + 1, sizeof(float));
    if (!s->counts || !s->displs || !s->w || !s->wsum)
        return lrr__mpi_error(s->ctx, LRR_ERR_NOMEM,
                              "lrr_mpi_solver_create: cannot allocate the frame's buffers "
                              "(k = %zu, %d ranks)", k, s->size);
    size_t p0 = 0;
    for (int r = 0; r < s->size; r++) {
        size_t p1 = r + 1 == s->size ? k : block_start(first, n, k, r + 1, s->size);
        s->displs[r] = (int)first[p0];
        s->counts[r] = (int)(first[p1] - first[p0]);
        if (r == s->rank)
            *mine0 = p0, *mine1 = p1;
        p0 = p1;
    }
    const size_t rows = first[*mine1] - first[*mine0];
    if (rows && !(s->b = calloc(rows, 3 * sizeof(float))))
        return lrr__mpi_error(s->ctx, LRR_ERR_NOMEM,
                              "lrr_mpi_solver_create: cannot allocate B's %zu rows", rows);
    return LRR_OK;
}

/* The steps after the communicator exists; each ends agreed. */
static lrr_status create_steps(lrr_mpi_solver *s, const char *path)
{
    /* this rank's rows of F̄ alone are read into memory (lrr__rows_load); the ranks then
     * agree that they read the same operator */
    lrr_status st = lrr__mpi_spread(s->ctx, s->comm, lrr__rows_load(s->ctx, path, split, s,
                                                                    &s->rows));
    if (st || (st = lrr__mpi_spread(s->ctx, s->comm, same_operator(s, path))))
        return st;
    lrr__rows_range(s->rows, &s->row0, &s->nrows);
    s->ctx = lrr__rows_context(s->rows);
    int rc = MPI_Type_contiguous(3, MPI_FLOAT, &s->rgb);
    if (rc == MPI_SUCCESS && (rc = MPI_Type_commit(&s->rgb)) != MPI_SUCCESS)
        MPI_Type_free(&s->rgb);
    return lrr__mpi_spread(s->ctx, s->comm,
                           rc == MPI_SUCCESS ? LRR_OK
                                             : lrr__mpi_failed(s->ctx, "MPI_Type_commit", rc));
}

lrr_status lrr_mpi_solver_create(lrr_context *ctx, const char *path, MPI_Comm comm,
                                 lrr_mpi_solver **out)
{
    *out = NULL;
    MPI_Comm dup;
    int rc = MPI_Comm_dup(comm, &dup);
    if (rc != MPI_SUCCESS)
        return lrr__mpi_failed(ctx, "MPI_Comm_dup", rc);
    MPI_Comm_set_errhandler(dup, MPI_ERRORS_RETURN);
    lrr_mpi_solver *s = calloc(1, sizeof *s);
    /* every rank enters the same collectives, whatever failed locally */
    lrr_status st = lrr__mpi_spread(ctx, dup, s ? LRR_OK : lrr__mpi_error(ctx, LRR_ERR_NOMEM,
                                    "lrr_mpi_solver_create: cannot allocate a solver"));
    if (st) {
        free(s);
        MPI_Comm_free(&dup);
        return st;
    }
    s->ctx = ctx;
    s->comm = dup;
    s->rgb = MPI_DATATYPE_NULL;
    MPI_Comm_rank(s->comm, &s->rank);
    MPI_Comm_size(s->comm, &s->size);
    if ((st = create_steps(s, path))) {
        lrr_mpi_solver_destroy(s);
        return st;
    }
    *out = s;
    return LRR_OK;
}

void lrr_mpi_solver_rows(const lrr_mpi_solver *s, size_t *n, size_t *row0, size_t *rows)
{
    *n = s->n;
    *row0 = s->row0;
    *rows = s->nrows;
}

const float *lrr_mpi_solver_emission(const lrr_mpi_solver *s)
{
    return lrr__rows_emission(s->rows);
}

void lrr_mpi_solver_get_info(const lrr_mpi_solver *s, lrr_mpi_solver_info *out,
                             size_t out_size)
{
    lrr_mpi_solver_info info;
    memset(&info, 0, sizeof info);
    info.n = s->n;
    info.k = s->k;
    info.row0 = s->row0;
    info.rows = s->nrows;
    info.rank = s->rank;
    info.ranks = s->size;
    lrr__rows_bytes(s->rows, &info.fbar_bytes, &info.m_bytes);
    info.allreduce_bytes = (3 * s->k + 1) * sizeof(float);
    info.kernel = lrr__rows_kernel(s->rows);
    memset(out, 0, out_size);
    memcpy(out, &info, out_size < sizeof info ? out_size : sizeof info);
}

/* [a, a + len) and [b, b + len) overlap */
static int overlap(const float *a, const float *b, size_t len)
{
    return (uintptr_t)a < (uintptr_t)(b + len) && (uintptr_t)b < (uintptr_t)(a + len);
}

/* One frame into B (this rank's rows). pre: a failure the caller found already. The
 * allreduce carries w and, in its last float, how many ranks failed: no other message on
 * the way of a good frame. */
static lrr_status frame(lrr_mpi_solver *s, const float *E, float *B, lrr_status pre,
                        const char *fn)
{
    const size_t k3 = 3 * s->k;
    lrr_status st = pre;
    if (!st && s->nrows && (!E || !B))
        st = lrr__mpi_error(s->ctx, LRR_ERR_INVALID_ARG, "%s: rank %d has %zu rows but no %s",
                            fn, s->rank, s->nrows, !E ? "emission" : "radiosity");
    if (!st && s->nrows && overlap(E, B, 3 * s->nrows))
        st = lrr__mpi_error(s->ctx, LRR_ERR_INVALID_ARG,
                            "%s: emission and radiosity may not alias", fn);
    if (!st && s->nrows)
        st = lrr__rows_vte(s->rows, E, s->w);
    if (st || !s->nrows)
        memset(s->w, 0, k3 * sizeof(float));
    s->w[k3] = st ? 1.0f : 0.0f;
    int rc = MPI_Allreduce(s->w, s->wsum, (int)k3 + 1, MPI_FLOAT, MPI_SUM, s->comm);
    if (rc != MPI_SUCCESS)
        return lrr__mpi_failed(s->ctx, "MPI_Allreduce (Vᵀ E)", rc);
    if (s->wsum[k3] != 0.0f)
        return lrr__mpi_spread(s->ctx, s->comm, st);
    lrr__rows_apply(s->rows, s->wsum, E, B);
    return LRR_OK;
}

lrr_status lrr_mpi_solve(lrr_mpi_solver *s, const float *E, float *B)
{
    return frame(s, E, B, LRR_OK, "lrr_mpi_solve");
}

/* root in range, and the whole array present on it */
static lrr_status check_root(const lrr_mpi_solver *s, int root, const void *whole,
                             const char *fn, const char *what)
{
    if (root < 0 || root >= s->size)
        return lrr__mpi_error(s->ctx, LRR_ERR_INVALID_ARG, "%s: root %d is not a rank (0..%d)",
                              fn, root, s->size - 1);
    if (s->rank == root && !whole)
        return lrr__mpi_error(s->ctx, LRR_ERR_INVALID_ARG, "%s: no %s on the root (rank %d)",
                              fn, what, root);
    return LRR_OK;
}

lrr_status lrr_mpi_solve_gather(lrr_mpi_solver *s, const float *E, int root, float *B)
{
    static const char fn[] = "lrr_mpi_solve_gather";
    lrr_status st = frame(s, E, s->b, check_root(s, root, B, fn, "radiosity (n×3)"), fn);
    if (st)
        return st;
    int rc = MPI_Gatherv(s->b, (int)s->nrows, s->rgb, B, s->counts, s->displs, s->rgb, root,
                         s->comm);
    return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(s->ctx, "MPI_Gatherv (B)", rc);
}

lrr_status lrr_mpi_scatter(lrr_mpi_solver *s, int root, const float *whole, float *rows)
{
    static const char fn[] = "lrr_mpi_scatter";
    lrr_status st = check_root(s, root, whole, fn, "array (n×3)");
    if (!st && s->nrows && !rows)
        st = lrr__mpi_error(s->ctx, LRR_ERR_INVALID_ARG, "%s: rank %d has %zu rows but no "
                            "buffer for them", fn, s->rank, s->nrows);
    if ((st = lrr__mpi_spread(s->ctx, s->comm, st)))
        return st;
    int rc = MPI_Scatterv(whole, s->counts, s->displs, s->rgb, rows, (int)s->nrows, s->rgb,
                          root, s->comm);
    return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(s->ctx, "MPI_Scatterv", rc);
}
