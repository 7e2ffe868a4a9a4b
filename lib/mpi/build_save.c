/* The distributed build that writes its file without gathering F̄ (lrr_mpi.h
 * lrr_mpi_operator_build_save): every rank computes the hemicubes of its chunks (64 rows
 * dealt round-robin, as lrr_mpi_operator_build's) and keeps those rows; the root holds
 * the operator without F̄ (geometry, materials, M), so that no rank holds more than its
 * share of F̄ plus a chunk.
 *
 * What needs more than a rank's rows, and how it stays the serial result bit for bit:
 *   row scales and back-face shares  one number a row, gathered to the root;
 *   Vᵀ weights (clusters)            each rank sums its rows (A_i R_i); the n sums are
 *                                    gathered and broadcast, every rank normalises them
 *                                    as lrr__visibility_weights does;
 *   G_c = I − Vᵀ diag(ρ_c) F̄         row p sums patch p's rows in order. A patch within a
 *                                    chunk is summed by its rank; one that continues past
 *                                    a chunk's end passes its partial row (k doubles) to
 *                                    the next chunk's rank, which goes on adding in order
 *                                    (phase 2 below), so the sums are the serial ones;
 *                                    finished rows go to the root, which inverts G_c;
 *   the file                         the root writes it through lrr_operator_save_fbar's
 *                                    writer, every rank its chunks of F̄'s section (rows
 *                                    or strips) with MPI-IO, the section's checksum passed
 *                                    from chunk to chunk in order (write.c). */
#include "config.h"
#include "mpi/mpi_internal.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "mpi/build_save.h"

#define TAG_BACK 11
#define TAG_SCALE 12
#define TAG_SUMS 13
#define TAG_G 14
#define TAG_GROWS 15

static double now(void) { return MPI_Wtime(); }

/* ------------------------------------------------------------ chunks and patches */
size_t lrr__bs_chunks(const bs_dist *d) { return (d->n + LRR__MPI_CHUNK - 1) / LRR__MPI_CHUNK; }

size_t lrr__bs_rank_chunks(const bs_dist *d, int r)
{
    const size_t chunks = lrr__bs_chunks(d);
    return chunks > (size_t)r ? (chunks - (size_t)r - 1) / (size_t)d->size + 1 : 0;
}

/* Chunk c's rows [*a, *b). */
void lrr__bs_chunk(const bs_dist *d, size_t c, size_t *a, size_t *b)
{
    *a = c * LRR__MPI_CHUNK;
    *b = *a + LRR__MPI_CHUNK < d->n ? *a + LRR__MPI_CHUNK : d->n;
}

/* The patch that holds row i (the last p with first[p] <= i: empty patches are skipped). */
static size_t patch_of(const bs_dist *d, size_t i)
{
    size_t lo = 0, hi = d->k; /* first[lo] <= i < first[hi] */
    while (hi - lo > 1) {
        size_t mid = lo + (hi - lo) / 2;
        if (d->first[mid] <= i)
            lo = mid;
        else
            hi = mid;
    }
    return lo;
}

size_t lrr__bs_ending_patches(const bs_dist *d, int r, int *ends)
{
    size_t m = 0;
    for (size_t c = (size_t)r; c < lrr__bs_chunks(d); c += (size_t)d->size) {
        size_t a, b;
        lrr__bs_chunk(d, c, &a, &b);
        for (size_t p = patch_of(d, a); p < d->k && d->first[p] < b; p++)
            if (d->first[p + 1] > d->first[p] && d->first[p + 1] <= b) {
                if (ends)
                    ends[m] = (int)p;
                m++;
            }
    }
    return m;
}

/* ------------------------------------------------------------ one number a row */
/* The ranks' values of their rows (one of type `type` a row, packed) to whole (n) on the
 * root, placed; the root's own copied from mine. */
static lrr_status gather_rows(bs_dist *d, const void *mine, size_t elem, MPI_Datatype type,
                              void *whole, int tag, const char *what)
{
    int rc = MPI_SUCCESS;
    if (d->rank != d->root) {
        if (d->count)
            rc = MPI_Send(mine, (int)d->count, type, d->root, tag, d->comm);
    } else {
        for (size_t j = 0; j < d->count; j++)
            memcpy((char *)whole + d->rows[j] * elem, (const char *)mine + j * elem, elem);
        for (int r = 0; r < d->size && rc == MPI_SUCCESS; r++)
            if (r != d->root)
                rc = lrr__mpi_chunk_recv(d->comm, d->n, r, d->size, type, d->len, d->at,
                                         whole, tag);
    }
    return lrr__mpi_spread(d->ctx, d->comm,
                           rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(d->ctx, what, rc));
}

/* Back-face shares and 16-bit row scales to the root. */
static lrr_status gather_scalars(bs_dist *d)
{
    lrr_status st = gather_rows(d, d->back, sizeof(double), MPI_DOUBLE, lrr__build_back(d->b),
                                TAG_BACK, "gathering the back-face shares");
    float *scales = lrr__build_row_scales(d->b);
    if (st || !scales)
        return st;
    float *mine = d->count ? malloc(d->count * sizeof(float)) : NULL;
    st = lrr__mpi_spread(d->ctx, d->comm,
                         d->count && !mine ? lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "cannot "
                                                            "allocate %zu row scales", d->count)
                                           : LRR_OK);
    for (size_t j = 0; !st && j < d->count; j++)
        mine[j] = scales[d->rows[j]];
    if (!st)
        st = gather_rows(d, mine, sizeof(float), MPI_FLOAT, scales, TAG_SCALE,
                         "gathering the row scales");
    free(mine);
    return st;
}

/* Vᵀ's weights (clusters): every rank's row sums to all, then every rank normalises. */
static lrr_status weights(bs_dist *d)
{
    if (!lrr__build_visibility(d->b))
        return LRR_OK;
    double *all = malloc(d->n * sizeof(double)), *mine = malloc((d->count + 1) * sizeof(double));
    lrr_status st = lrr__mpi_spread(d->ctx, d->comm,
                                    all && mine ? LRR_OK
                                                : lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "cannot "
                                                                 "allocate the %zu row sums "
                                                                 "of the Vᵀ weights", d->n));
    if (!st) {
        lrr__build_row_sums(d->b, d->rows, d->count, d->block, d->scratch, mine);
        st = gather_rows(d, mine, sizeof(double), MPI_DOUBLE, all, TAG_SUMS,
                         "gathering the row sums of the Vᵀ weights");
    }
    if (!st) {
        int rc = MPI_Bcast(all, (int)d->n, MPI_DOUBLE, d->root, d->comm);
        st = lrr__mpi_spread(d->ctx, d->comm, rc == MPI_SUCCESS ? LRR_OK
                                              : lrr__mpi_failed(d->ctx, "MPI_Bcast (row sums)",
                                                                rc));
    }
    if (!st)
        lrr__build_set_weights(d->b, all);
    free(all);
    free(mine);
    return st;
}

/* ------------------------------------------------------------ G_c */
/* Row i's coded row in this rank's block (local row j). */
static const void *row_at(const bs_dist *d, size_t j)
{
    return (const unsigned char *)d->block + j * d->k * d->es;
}

/* Adds rows [i0, i1) of chunk slot s (its first row a) into gp. */
static void add_rows(bs_dist *d, int c, size_t s, size_t a, size_t i0, size_t i1, double *gp)
{
    for (size_t i = i0; i < i1; i++)
        lrr__build_g_add(d->b, c, i, row_at(d, s * LRR__MPI_CHUNK + (i - a)), d->scratch, gp);
}

/* G_c's rows of the patches that end in this rank's chunks into d->done (ascending), the
 * partial rows of those that go on sent to the next chunk's rank. Phase 1 sums every
 * patch that starts in a chunk; phase 2 walks the chunks in order, receives the partial row
 * of the patch a chunk starts within and goes on with it. A rank's messages to the next
 * rank are sent in chunk order and received in it, so one tag matches them. */
static int chain(bs_dist *d, int c)
{
    const size_t k = d->k, *first = d->first, mine = d->chunks_mine;
    const int next = (d->rank + 1) % d->size, prev = (d->rank + d->size - 1) % d->size;
    for (size_t s = 0; s < mine; s++) { /* phase 1 */
        size_t a, b, ch = (size_t)d->rank + s * (size_t)d->size, e = d->slot0[s];
        lrr__bs_chunk(d, ch, &a, &b);
        for (size_t p = patch_of(d, a); p < d->k && first[p] < b; p++) {
            if (first[p + 1] == first[p])
                continue; /* empty: the root's */
            const int ends = first[p + 1] <= b;
            if (first[p] < a) { /* the head, from an earlier chunk: phase 2 */
                e += (size_t)ends;
                continue;
            }
            double *gp = ends ? d->done + e++ * k : d->sendbuf + s * k;
            memset(gp, 0, k * sizeof(double));
            add_rows(d, c, s, a, first[p], ends ? first[p + 1] : b, gp);
            if (ends)
                gp[p] += 1;
        }
    }
    int rc = MPI_SUCCESS;
    size_t sends = 0;
    for (size_t s = 0; s < mine && rc == MPI_SUCCESS; s++) { /* phase 2 */
        size_t a, b, ch = (size_t)d->rank + s * (size_t)d->size;
        lrr__bs_chunk(d, ch, &a, &b);
        const size_t h = patch_of(d, a), last = patch_of(d, b - 1);
        if (first[h] < a) {
            double *gp = d->partial;
            rc = MPI_Recv(gp, (int)k, MPI_DOUBLE, prev, TAG_G, d->comm, MPI_STATUS_IGNORE);
            if (rc != MPI_SUCCESS)
                break;
            const int ends = first[h + 1] <= b;
            add_rows(d, c, s, a, a, ends ? first[h + 1] : b, gp);
            if (ends) {
                gp[h] += 1;
                memcpy(d->done + d->slot0[s] * k, gp, k * sizeof(double));
            } else {
                memcpy(d->sendbuf + s * k, gp, k * sizeof(double));
            }
        }
        if (first[last + 1] > b)
            rc = MPI_Isend(d->sendbuf + s * k, (int)k, MPI_DOUBLE, next, TAG_G, d->comm,
                           &d->req[sends++]);
    }
    int rw = MPI_Waitall((int)sends, d->req, MPI_STATUSES_IGNORE);
    return rc != MPI_SUCCESS ? rc : rw;
}

/* The root's G_c: its own finished rows, every other rank's into their rows (one message
 * of an indexed type each), the identity's rows for empty patches. */
static int gather_g(bs_dist *d, double *G)
{
    const size_t k = d->k;
    int rc = MPI_SUCCESS;
    if (d->rank != d->root)
        return d->ends ? MPI_Send(d->done, (int)d->ends, d->grow, d->root, TAG_GROWS, d->comm)
                       : MPI_SUCCESS;
    memset(G, 0, k * k * sizeof(double));
    for (size_t p = 0; p < k; p++)
        if (d->first[p + 1] == d->first[p])
            G[p * k + p] = 1; /* no rows: gp[p] += 1 alone */
    for (int r = 0; r < d->size && rc == MPI_SUCCESS; r++) {
        size_t m = lrr__bs_ending_patches(d, r, d->idx);
        if (r == d->root) {
            for (size_t j = 0; j < m; j++)
                memcpy(G + (size_t)d->idx[j] * k, d->done + j * k, k * sizeof(double));
            continue;
        }
        if (m == 0)
            continue;
        MPI_Datatype rows;
        if ((rc = MPI_Type_create_indexed_block((int)m, 1, d->idx, d->grow, &rows)) ==
            MPI_SUCCESS) {
            if ((rc = MPI_Type_commit(&rows)) == MPI_SUCCESS)
                rc = MPI_Recv(G, 1, rows, r, TAG_GROWS, d->comm, MPI_STATUS_IGNORE);
            MPI_Type_free(&rows);
        }
    }
    return rc;
}

/* The chain's buffers: finished rows, partial rows to send, the requests, the root's G. */
static lrr_status g_buffers(bs_dist *d)
{
    const size_t k = d->k;
    d->ends = lrr__bs_ending_patches(d, d->rank, NULL);
    d->slot0 = calloc(d->chunks_mine + 1, sizeof *d->slot0);
    size_t slot = 0;
    for (size_t s = 0; d->slot0 && s < d->chunks_mine; s++) {
        size_t a, b, ch = (size_t)d->rank + s * (size_t)d->size;
        lrr__bs_chunk(d, ch, &a, &b);
        d->slot0[s] = slot;
        for (size_t p = patch_of(d, a); p < k && d->first[p] < b; p++)
            slot += d->first[p + 1] > d->first[p] && d->first[p + 1] <= b;
    }
    d->done = malloc((d->ends ? d->ends : 1) * k * sizeof(double));
    d->sendbuf = malloc((d->chunks_mine ? d->chunks_mine : 1) * k * sizeof(double));
    d->partial = malloc(k * sizeof(double));
    d->req = malloc((d->chunks_mine ? d->chunks_mine : 1) * sizeof(MPI_Request));
    d->idx = malloc(k * sizeof(int));
    if (d->rank == d->root && !d->dist && k <= SIZE_MAX / sizeof(double) / k)
        d->G = lrr_aligned_alloc(k * k * sizeof(double));
    int ok = d->slot0 && d->done && d->sendbuf && d->partial && d->req && d->idx &&
             (d->rank != d->root || d->dist || d->G);
    if (ok && MPI_Type_contiguous((int)k, MPI_DOUBLE, &d->grow) == MPI_SUCCESS)
        ok = MPI_Type_commit(&d->grow) == MPI_SUCCESS;
    else
        ok = 0;
    return lrr__mpi_spread(d->ctx, d->comm,
                           ok ? LRR_OK
                              : lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_build_"
                                               "save: cannot allocate G's rows (k = %zu)", k));
}

/* Where the replicated inversion (the root's LAPACK) gives way to ScaLAPACK's when
 * LRR_MPI_FACTOR is auto (docs/MPI.md "The factorisation"). smw_seconds of `mpirun -np 2 lrr
 * preprocess cornell --patches K --levels 0 --hemicube 16`, OMP_NUM_THREADS=1, replicated
 * against ScaLAPACK: k 1032 0.29 / 0.21 s, k 1992 1.60 / 0.98 s, k 4128 15.9 / 7.2 s. Below
 * 2048 the gain is a fraction of a second, and the replicated file is the serial one byte for
 * byte. */
#define SCALAPACK_FROM_K 2048
#define SCALAPACK_NB 64

/* The root's LRR_MPI_FACTOR (and LRR_MPI_SCALAPACK_NB, the block size: small in the tests
 * so that blocks cycle) into d->dist and *nb; an unknown value is the root's error. */
static lrr_status read_choice(bs_dist *d, int *nb)
{
    const char *v = getenv("LRR_MPI_FACTOR"), *b = getenv("LRR_MPI_SCALAPACK_NB");
#ifdef HAVE_SCALAPACK
    const int have = 1;
#else
    const int have = 0;
#endif
    if (b && *b) {
        char *end;
        long n = strtol(b, &end, 10);
        if (*end || n < 1 || n > 4096)
            return lrr__mpi_error(d->ctx, LRR_ERR_INVALID_ARG, "lrr_mpi_operator_build_save: "
                                  "LRR_MPI_SCALAPACK_NB=%s: expected 1 to 4096", b);
        *nb = (int)n;
    }
    if (!v || !*v || strcmp(v, "auto") == 0)
        d->dist = have && d->size > 1 && d->k >= SCALAPACK_FROM_K;
    else if (strcmp(v, "replicated") == 0)
        d->dist = 0;
    else if (strcmp(v, "scalapack") == 0 && have)
        d->dist = 1;
    else if (strcmp(v, "scalapack") == 0)
        return lrr__mpi_error(d->ctx, LRR_ERR_UNSUPPORTED, "lrr_mpi_operator_build_save: "
                              "LRR_MPI_FACTOR=scalapack: built without ScaLAPACK");
    else
        return lrr__mpi_error(d->ctx, LRR_ERR_INVALID_ARG, "lrr_mpi_operator_build_save: "
                              "LRR_MPI_FACTOR=%s: expected replicated, scalapack or auto", v);
    return LRR_OK;
}

/* The root's choice, agreed and broadcast, so that every rank takes the same path. */
static lrr_status choose(bs_dist *d, int *nb)
{
    *nb = SCALAPACK_NB;
    lrr_status st = lrr__mpi_spread(d->ctx, d->comm,
                                    d->rank == d->root ? read_choice(d, nb) : LRR_OK);
    int both[2] = {d->dist, *nb};
    int rc = st ? MPI_SUCCESS : MPI_Bcast(both, 2, MPI_INT, d->root, d->comm);
    if (!st)
        st = lrr__mpi_spread(d->ctx, d->comm, rc == MPI_SUCCESS ? LRR_OK
                                              : lrr__mpi_failed(d->ctx, "MPI_Bcast (factor)",
                                                                rc));
    d->dist = both[0];
    *nb = both[1];
    return st;
}

/* M_c for c = 0, 1, 2: the chain, then the gather and the root's inversion, or ScaLAPACK's
 * across the ranks; agreed each time. */
static lrr_status factorise(bs_dist *d)
{
    int nb;
    lrr_status st = choose(d, &nb);
    if (!st)
        st = g_buffers(d);
    if (!st && d->dist)
        st = lrr__bs_grid_open(d, nb);
    for (int c = 0; c < 3 && !st; c++) {
        int rc = chain(d, c);
        if (d->dist) {
            st = lrr__mpi_spread(d->ctx, d->comm, rc == MPI_SUCCESS ? LRR_OK
                                 : lrr__mpi_failed(d->ctx, "assembling G", rc));
            if (!st)
                st = lrr__bs_invert(d, c);
            continue;
        }
        if (rc == MPI_SUCCESS)
            rc = gather_g(d, d->G);
        st = rc != MPI_SUCCESS ? lrr__mpi_failed(d->ctx, "assembling G", rc)
             : d->rank == d->root ? lrr__build_invert(d->b, c, d->G)
                                  : LRR_OK;
        st = lrr__mpi_spread(d->ctx, d->comm, st);
    }
    return st;
}

/* ------------------------------------------------------------ the steps */
/* This rank's receivers and their buffers. */
static lrr_status split(bs_dist *d)
{
    if (d->n > INT_MAX || d->k > INT_MAX / (4 * LRR__MPI_CHUNK + 64)) /* a chunk's bytes */
        return lrr__mpi_error(d->ctx, LRR_ERR_OVERFLOW, "lrr_mpi_operator_build_save: n = %zu "
                              "or k = %zu exceeds MPI's int counts", d->n, d->k);
    const size_t rows = lrr__mpi_chunk_rows(d->n, d->rank, d->size, NULL), k = d->k;
    d->count = d->info.rows = rows;
    d->chunks_mine = lrr__bs_rank_chunks(d, d->rank);
    const size_t most = lrr__mpi_chunk_most(d->n, d->size);
    d->rows = calloc(rows ? rows : 1, sizeof *d->rows);
    d->back = calloc(rows ? rows : 1, sizeof(double));
    d->scratch = malloc(2 * k * sizeof(float) + 64);
    d->len = calloc(most, sizeof(int));
    d->at = calloc(most, sizeof(int));
    if (rows <= SIZE_MAX / sizeof(float) / k)
        d->block = lrr_aligned_alloc((rows ? rows : 1) * k * sizeof(float));
    if (!d->rows || !d->back || !d->scratch || !d->len || !d->at || !d->block)
        return lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_build_save: cannot "
                              "allocate this rank's %zu rows of F̄ (k = %zu)", rows, k);
    lrr__mpi_chunk_rows(d->n, d->rank, d->size, d->rows);
    d->info.fbar_bytes = rows * k * d->es;
    return LRR_OK;
}

/* The hemicubes of this rank's rows, coded in the file's storage; the balance. */
static lrr_status hemicubes(bs_dist *d)
{
    double t0 = now();
    lrr_status st = d->count ? lrr__build_rows(d->b, d->rows, d->count, 0, d->block, d->back)
                             : LRR_OK;
    d->info.rows_seconds = now() - t0;
    if ((st = lrr__mpi_spread(d->ctx, d->comm, st)))
        return st;
    lrr__build_encode(d->b, d->rows, d->count, d->block, d->scratch);
    double t[2] = {-d->info.rows_seconds, d->info.rows_seconds}, tr[2];
    int rc = MPI_Allreduce(t, tr, 2, MPI_DOUBLE, MPI_MAX, d->comm);
    d->info.rows_seconds_min = -tr[0];
    d->info.rows_seconds_max = tr[1];
    return lrr__mpi_spread(d->ctx, d->comm,
                           rc == MPI_SUCCESS ? LRR_OK
                                             : lrr__mpi_failed(d->ctx, "MPI_Allreduce", rc));
}

static lrr_status steps(bs_dist *d, const lrr_scene *scene, const lrr_build_options *opts,
                        lrr_storage storage, lrr_fbar_format fbar, const char *path,
                        lrr_operator **head)
{
    const double t0 = now();
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    size_t share = lrr__mpi_chunk_most(si.subpatches, d->size) * LRR__MPI_CHUNK;
    /* M is the root's alone */
    lrr_status st = lrr__build_begin_rows(scene, opts, storage, share, d->rank == d->root,
                                          &d->b);
    st = lrr__mpi_spread(d->ctx, d->comm, st);
    if (st || (st = lrr__mpi_same_selection(d->ctx, d->comm, d->rank, d->root, d->b, &d->n,
                                            &d->k)))
        return st;
    lrr_operator *op = lrr__build_operator(d->b);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    d->es = oi.storage == LRR_STORAGE_F32 ? sizeof(float) : sizeof(uint16_t);
    d->first = lrr_operator_patch_offsets(op);
    if ((st = lrr__mpi_spread(d->ctx, d->comm, split(d))) || (st = hemicubes(d)))
        return st;
    double t1 = now();
    if ((st = gather_scalars(d)) || (st = weights(d)))
        return st;
    double t2 = now();
    if ((st = factorise(d)))
        return st;
    double t3 = now();
    if (d->rank == d->root)
        st = lrr__build_finish_rows(d->b, d->info.rows_seconds_max + (t2 - t1), t3 - t2,
                                    &d->head);
    if ((st = lrr__mpi_spread(d->ctx, d->comm, st)) ||
        (st = lrr__bs_save(d, fbar, path)))
        return st;
    d->info.save_seconds = now() - t3;
    d->info.gather_seconds = t2 - t1;
    d->info.seconds = now() - t0;
    if (head) {
        *head = d->head;
        d->head = NULL;
    }
    return LRR_OK;
}

lrr_status lrr_mpi_operator_build_save(const lrr_scene *scene, const lrr_build_options *opts,
                                       lrr_storage storage, lrr_fbar_format fbar,
                                       const char *path, MPI_Comm comm, int root,
                                       lrr_operator **head, lrr_mpi_build_info *info,
                                       size_t info_size)
{
    if (head)
        *head = NULL;
    bs_dist d;
    memset(&d, 0, sizeof d);
    d.grow = MPI_DATATYPE_NULL;
    d.ctx = lrr__build_scene_context(scene);
    d.root = root;
    lrr_status st = lrr__mpi_open(d.ctx, comm, root, "lrr_mpi_operator_build_save", &d.comm,
                                  &d.rank, &d.size);
    if (d.comm == MPI_COMM_NULL)
        return st;
    d.info.ranks = d.size;
    int so[2] = {(int)storage, (int)fbar}; /* the root's */
    int rc = st ? MPI_SUCCESS : MPI_Bcast(so, 2, MPI_INT, root, d.comm);
    if (rc != MPI_SUCCESS)
        st = lrr__mpi_failed(d.ctx, "MPI_Bcast (storage)", rc);
    storage = (lrr_storage)so[0];
    fbar = (lrr_fbar_format)so[1];
    if (!st && d.rank == root && !path)
        st = lrr__mpi_error(d.ctx, LRR_ERR_INVALID_ARG, "lrr_mpi_operator_build_save: the "
                            "root's path is NULL");
    st = lrr__mpi_spread(d.ctx, d.comm, st);
    if (!st)
        st = steps(&d, scene, opts, storage, fbar, path, head);
    if (info)
        memcpy(info, &d.info, info_size < sizeof d.info ? info_size : sizeof d.info);
    lrr_operator_destroy(d.head);
    lrr_aligned_free(d.block);
    lrr_aligned_free(d.G);
    lrr__bs_grid_close(&d);
    free(d.rows);
    free(d.back);
    free(d.scratch);
    free(d.len);
    free(d.at);
    free(d.slot0);
    free(d.done);
    free(d.sendbuf);
    free(d.partial);
    free(d.req);
    free(d.idx);
    if (d.grow != MPI_DATATYPE_NULL)
        MPI_Type_free(&d.grow);
    lrr__build_destroy(d.b);
    MPI_Comm_free(&d.comm);
    return st;
}
