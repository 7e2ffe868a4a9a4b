/* G_c inverted across the ranks with ScaLAPACK (lrr_mpi_operator_build_save when k is large,
 * docs/MPI.md "The factorisation"), so that the root neither holds G_c (k² doubles) nor
 * inverts it alone.
 *
 * ScaLAPACK is column-major: our row-major G is A = Gᵀ there, so G's row p (a patch's
 * finished row, on the rank whose chunk ends the patch) is A's column p. A is dealt
 * block-cyclically (nb×nb blocks) over a pr×pc grid, pr ≤ pc as square as P allows; one
 * MPI_Alltoallw moves every finished row into the local blocks with derived types on both
 * sides (nothing packed: a rank holds its finished rows and its local block, no more).
 * Inverting A gives A⁻¹ = (G⁻¹)ᵀ = M_cᵀ, i.e. M_c row-major; G's 1-norm condition (the
 * serial dgecon '1') is A's infinity-norm one (pdlange 'I', see inverse()). Each rank
 * converts its block to float in place and sends it to the root, whose types place it in
 * M_c. */
#include "config.h"
#include "mpi/mpi_internal.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "mpi/build_save.h"

#ifdef HAVE_SCALAPACK
#include "mpi/scalapack.h"

#define TAG_M 16

struct bs_grid {
    int handle, ctxt, gridded;  /* BLACS system handle (-1: none) and grid (when gridded) */
    int pr, pc, myrow, mycol, nb, k;
    int mloc, nloc, lld;        /* the local block: lld × nloc, column-major */
    int desc[9];
    int *coord;                 /* every rank's (row, column) in the grid */
    double *a, *work;
    int *ipiv, *iwork, lwork, liwork;
    MPI_Datatype *stype, *rtype, *mtype; /* Alltoallw's (P each); the root's M (P) */
    int *scount, *rcount, *disp;
};

static int owner(int i, int nb, int procs) { return (i / nb) % procs; }
static int local(int i, int nb, int procs) { return (i / (nb * procs)) * nb + i % nb; }

/* ------------------------------------------------------------ the grid */
static lrr_status nomem(bs_dist *d, const char *what)
{
    return lrr__mpi_error(d->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_build_save: cannot allocate "
                          "%s for ScaLAPACK (k = %zu)", what, d->k);
}

/* The grid on d->comm, this rank's block and every rank's place. */
static lrr_status grid_open(bs_dist *d, bs_grid *g)
{
    const int P = d->size, zero = 0;
    for (g->pr = 1; (g->pr + 1) * (g->pr + 1) <= P; g->pr++)
        ;
    while (P % g->pr)
        g->pr--; /* the largest divisor of P up to √P */
    g->pc = P / g->pr;
    g->handle = Csys2blacs_handle(d->comm);
    g->ctxt = g->handle;
    Cblacs_gridinit(&g->ctxt, "Row", g->pr, g->pc);
    g->gridded = 1; /* a context's number may equal a handle's: they are apart */
    int pr, pc;
    Cblacs_gridinfo(g->ctxt, &pr, &pc, &g->myrow, &g->mycol);
    if (pr != g->pr || pc != g->pc || g->myrow < 0)
        return lrr__mpi_error(d->ctx, LRR_ERR_IO, "lrr_mpi_operator_build_save: BLACS gave a "
                              "%d×%d grid for %d×%d", pr, pc, g->pr, g->pc);
    g->mloc = numroc_(&g->k, &g->nb, &g->myrow, &zero, &g->pr);
    g->nloc = numroc_(&g->k, &g->nb, &g->mycol, &zero, &g->pc);
    g->lld = g->mloc > 1 ? g->mloc : 1;
    int info;
    descinit_(g->desc, &g->k, &g->k, &g->nb, &g->nb, &zero, &zero, &g->ctxt, &g->lld, &info);
    if (info)
        return lrr__mpi_error(d->ctx, LRR_ERR_INVALID_ARG, "lrr_mpi_operator_build_save: "
                              "descinit failed (info = %d)", info);
    if ((double)g->lld * g->nloc * sizeof(double) > (double)INT_MAX * 8)
        return lrr__mpi_error(d->ctx, LRR_ERR_OVERFLOW, "lrr_mpi_operator_build_save: a "
                              "local block of %d×%d exceeds MPI's counts", g->lld, g->nloc);
    g->a = malloc((size_t)g->lld * (size_t)g->nloc * sizeof(double) + sizeof(double));
    g->ipiv = malloc(((size_t)g->mloc + (size_t)g->nb) * sizeof(int));
    g->coord = malloc(2 * (size_t)P * sizeof(int));
    if (!g->a || !g->ipiv || !g->coord)
        return nomem(d, "the local block of G");
    int mine[2] = {g->myrow, g->mycol};
    int rc = MPI_Allgather(mine, 2, MPI_INT, g->coord, 2, MPI_INT, d->comm);
    return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(d->ctx, "MPI_Allgather (grid)", rc);
}

/* pdlange's and pdgetri's work arrays, pdgetri's sized by its query. */
static lrr_status grid_work(bs_dist *d, bs_grid *g)
{
    const int one = 1, query = -1;
    double w = 0;
    int iw = 0, info = 0;
    memset(g->a, 0, (size_t)g->lld * (size_t)g->nloc * sizeof(double));
    pdgetri_(&g->k, g->a, &one, &one, g->desc, g->ipiv, &w, &query, &iw, &query, &info);
    int lange = g->mloc + g->nloc + g->nb; /* 'I': the local rows' sums */
    g->lwork = ((int)w > lange ? (int)w : lange) + 64;
    g->liwork = iw + 64;
    g->work = malloc((size_t)g->lwork * sizeof(double));
    g->iwork = malloc((size_t)g->liwork * sizeof(int));
    return g->work && g->iwork ? LRR_OK : nomem(d, "the work arrays");
}

/* A k-vector's elements that process row (or column) r owns, blocks of nb `type`s, as one
 * type of extent k elements. */
static int owned_of_vector(const bs_grid *g, int r, int procs, MPI_Datatype type,
                           int *len, int *at, MPI_Datatype *out)
{
    int m = 0;
    for (int b = r; b * g->nb < g->k; b += procs) {
        at[m] = b * g->nb;
        len[m] = g->k - at[m] < g->nb ? g->k - at[m] : g->nb;
        m++;
    }
    MPI_Datatype t;
    MPI_Aint lb, ext;
    int rc = MPI_Type_indexed(m, len, at, type, &t);
    if (rc == MPI_SUCCESS && (rc = MPI_Type_get_extent(type, &lb, &ext)) == MPI_SUCCESS) {
        rc = MPI_Type_create_resized(t, 0, (MPI_Aint)g->k * ext, out);
        MPI_Type_free(&t);
    }
    return rc;
}

/* Rank q's Alltoallw types: what this rank sends q (its finished rows in q's grid column,
 * the elements of q's grid row) and receives from q (q's finished rows in this rank's grid
 * column, whole local columns). idx: k ints; len, at: k ints of scratch; disp: k MPI_Aint. */
static int exchange_types(bs_dist *d, bs_grid *g, int q, int *idx, int *len, int *at,
                          MPI_Aint *disp)
{
    const int qr = g->coord[2 * q], qc = g->coord[2 * q + 1];
    int rc = MPI_SUCCESS, m = 0, n = (int)lrr__bs_ending_patches(d, d->rank, idx);
    for (int j = 0; j < n; j++)
        if (owner(idx[j], g->nb, g->pc) == qc)
            at[m++] = j;
    const int zero = 0, qm = numroc_(&g->k, &g->nb, &qr, &zero, &g->pr);
    if (m > 0 && qm > 0) {
        MPI_Datatype row;
        if ((rc = owned_of_vector(g, qr, g->pr, MPI_DOUBLE, len, idx, &row)) != MPI_SUCCESS)
            return rc;
        rc = MPI_Type_create_indexed_block(m, 1, at, row, &g->stype[q]);
        MPI_Type_free(&row);
        if (rc == MPI_SUCCESS && (rc = MPI_Type_commit(&g->stype[q])) == MPI_SUCCESS)
            g->scount[q] = 1;
    }
    n = (int)lrr__bs_ending_patches(d, q, idx);
    m = 0;
    for (int j = 0; j < n; j++)
        if (owner(idx[j], g->nb, g->pc) == g->mycol)
            disp[m++] = (MPI_Aint)local(idx[j], g->nb, g->pc) * g->lld * (MPI_Aint)sizeof(double);
    if (rc == MPI_SUCCESS && m > 0 && g->mloc > 0 &&
        (rc = MPI_Type_create_hindexed_block(m, g->mloc, disp, MPI_DOUBLE, &g->rtype[q])) ==
            MPI_SUCCESS &&
        (rc = MPI_Type_commit(&g->rtype[q])) == MPI_SUCCESS)
        g->rcount[q] = 1;
    return rc;
}

/* The root's type for rank q's block of M_cᵀ (floats, packed): local column j is row j of
 * M_c, its elements the runs of q's grid row. */
static int m_type(bs_grid *g, int q, int *len, int *at, MPI_Aint *disp)
{
    const int qr = g->coord[2 * q], qc = g->coord[2 * q + 1], zero = 0;
    const int qm = numroc_(&g->k, &g->nb, &qr, &zero, &g->pr);
    int n = 0;
    for (int j = qc * g->nb; j < g->k; j++)
        if (owner(j, g->nb, g->pc) == qc)
            disp[n++] = (MPI_Aint)j * g->k * (MPI_Aint)sizeof(float);
    if (n == 0 || qm == 0)
        return MPI_SUCCESS;
    MPI_Datatype row;
    int rc = owned_of_vector(g, qr, g->pr, MPI_FLOAT, len, at, &row);
    if (rc == MPI_SUCCESS) {
        rc = MPI_Type_create_hindexed_block(n, 1, disp, row, &g->mtype[q]);
        MPI_Type_free(&row);
    }
    return rc == MPI_SUCCESS ? MPI_Type_commit(&g->mtype[q]) : rc;
}

static lrr_status grid_types(bs_dist *d, bs_grid *g)
{
    const size_t P = (size_t)d->size, k = d->k;
    g->stype = malloc(P * sizeof *g->stype);
    g->rtype = malloc(P * sizeof *g->rtype);
    g->mtype = malloc(P * sizeof *g->mtype);
    g->scount = calloc(P, sizeof(int));
    g->rcount = calloc(P, sizeof(int));
    g->disp = calloc(P, sizeof(int));
    int *len = malloc(k * sizeof(int)), *at = malloc(k * sizeof(int));
    MPI_Aint *disp = malloc(k * sizeof(MPI_Aint));
    lrr_status st = LRR_OK;
    if (!g->stype || !g->rtype || !g->mtype || !g->scount || !g->rcount || !g->disp || !len ||
        !at || !disp)
        st = nomem(d, "the exchange's types");
    for (size_t q = 0; !st && q < P; q++) /* MPI_DATATYPE_NULL until made: freed apart */
        g->stype[q] = g->rtype[q] = g->mtype[q] = MPI_DATATYPE_NULL;
    int rc = MPI_SUCCESS;
    for (int q = 0; !st && rc == MPI_SUCCESS && q < d->size; q++) {
        rc = exchange_types(d, g, q, d->idx, len, at, disp);
        if (rc == MPI_SUCCESS && d->rank == d->root)
            rc = m_type(g, q, len, at, disp);
    }
    if (!st && rc != MPI_SUCCESS)
        st = lrr__mpi_failed(d->ctx, "making ScaLAPACK's exchange types", rc);
    free(len);
    free(at);
    free(disp);
    return st;
}

lrr_status lrr__bs_grid_open(bs_dist *d, int nb)
{
    bs_grid *g = calloc(1, sizeof *g);
    d->grid = g;
    if (!g)
        return lrr__mpi_spread(d->ctx, d->comm, nomem(d, "the grid"));
    g->handle = g->ctxt = -1;
    g->nb = nb;
    g->k = (int)d->k;
    lrr_status st = lrr__mpi_spread(d->ctx, d->comm, grid_open(d, g));
    if (!st)
        st = lrr__mpi_spread(d->ctx, d->comm, grid_work(d, g));
    return st ? st : lrr__mpi_spread(d->ctx, d->comm, grid_types(d, g));
}

static void free_types(MPI_Datatype *t, int n)
{
    for (int q = 0; t && q < n; q++)
        if (t[q] != MPI_DATATYPE_NULL)
            MPI_Type_free(&t[q]);
    free(t);
}

void lrr__bs_grid_close(bs_dist *d)
{
    bs_grid *g = d->grid;
    if (!g)
        return;
    if (g->stype) { /* every entry set once all three are allocated */
        free_types(g->stype, g->rtype && g->mtype ? d->size : 0);
        free_types(g->rtype, g->mtype ? d->size : 0);
        free_types(g->mtype, d->size);
    } else {
        free(g->rtype);
        free(g->mtype);
    }
    if (g->gridded)
        Cblacs_gridexit(g->ctxt);
    if (g->handle >= 0)
        Cfree_blacs_system_handle(g->handle);
    free(g->scount);
    free(g->rcount);
    free(g->disp);
    free(g->coord);
    free(g->a);
    free(g->work);
    free(g->ipiv);
    free(g->iwork);
    free(g);
    d->grid = NULL;
}

/* ------------------------------------------------------------ one channel */
/* The finished rows into the local block; the rows of empty patches are the identity's. */
static lrr_status scatter(bs_dist *d, bs_grid *g)
{
    memset(g->a, 0, (size_t)g->lld * (size_t)g->nloc * sizeof(double));
    for (size_t p = 0; p < d->k; p++)
        if (d->first[p + 1] == d->first[p] && owner((int)p, g->nb, g->pc) == g->mycol &&
            owner((int)p, g->nb, g->pr) == g->myrow)
            g->a[local((int)p, g->nb, g->pr) +
                 (size_t)local((int)p, g->nb, g->pc) * (size_t)g->lld] = 1;
    MPI_Datatype *st = g->stype, *rt = g->rtype;
    for (int q = 0; q < d->size; q++) { /* a count of 0 still needs a valid type */
        if (!g->scount[q])
            st[q] = MPI_DOUBLE;
        if (!g->rcount[q])
            rt[q] = MPI_DOUBLE;
    }
    int rc = MPI_Alltoallw(d->done, g->scount, g->disp, st, g->a, g->rcount, g->disp, rt,
                           d->comm);
    for (int q = 0; q < d->size; q++) {
        if (!g->scount[q])
            st[q] = MPI_DATATYPE_NULL;
        if (!g->rcount[q])
            rt[q] = MPI_DATATYPE_NULL;
    }
    return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(d->ctx, "MPI_Alltoallw (G)", rc);
}

/* The LU, agreed: singular G is LRR_ERR_SINGULAR as the serial inversion names it. */
static lrr_status factor(bs_dist *d, bs_grid *g, int c, double *anorm)
{
    const int one = 1;
    int info = 0;
    *anorm = pdlange_("I", &g->k, &g->k, g->a, &one, &one, g->desc, g->work, 1);
    pdgetrf_(&g->k, &g->k, g->a, &one, &one, g->desc, g->ipiv, &info);
    if (info > 0)
        return lrr__mpi_error(d->ctx, LRR_ERR_SINGULAR, "channel %d: G = I - Vᵀ diag(rho) F̄ "
                              "is singular (U[%d][%d] = 0)", c, info, info);
    return info ? lrr__mpi_error(d->ctx, LRR_ERR_INVALID_ARG, "channel %d: ScaLAPACK failed "
                                 "(pdgetrf info = %d)", c, info)
                : LRR_OK;
}

/* The inverse in place and G's 1-norm condition ||G||₁ ||M||₁ = ||A||∞ ||A⁻¹||∞, exact: not
 * pdgecon's estimate, which ScaLAPACK 2.2.1 (Debian 12) returns wrong, its pdlacon leaving
 * EST uninitialised (fixed upstream by Reference-ScaLAPACK PR #122, 2025): 4.1 for an exact
 * 24.9 in test_mpi_build_save. The serial dgecon estimate is a lower bound of it, equal to
 * it in every test case. */
static lrr_status inverse(bs_dist *d, bs_grid *g, int c, double anorm, double *cond)
{
    const int one = 1;
    int info = 0;
    pdgetri_(&g->k, g->a, &one, &one, g->desc, g->ipiv, g->work, &g->lwork, g->iwork,
             &g->liwork, &info);
    *cond = anorm * pdlange_("I", &g->k, &g->k, g->a, &one, &one, g->desc, g->work, 1);
    return info ? lrr__mpi_error(d->ctx, info < 0 ? LRR_ERR_INVALID_ARG : LRR_ERR_SINGULAR,
                                 "channel %d: ScaLAPACK failed (pdgetri info = %d)", c, info)
                : LRR_OK;
}

/* The local block of M_cᵀ to floats in place (packed: lld = mloc), every entry finite. */
static lrr_status to_float(bs_dist *d, bs_grid *g, int c)
{
    unsigned char *bytes = (unsigned char *)g->a;
    for (int lj = 0; lj < g->nloc; lj++)
        for (int li = 0; li < g->mloc; li++) {
            size_t at = (size_t)li + (size_t)lj * (size_t)g->mloc;
            double v;
            memcpy(&v, bytes + at * sizeof v, sizeof v); /* ascending: float at ≤ double at */
            if (!isfinite(v)) {
                size_t i = (size_t)(li / g->nb * g->pr + g->myrow) * g->nb + li % g->nb;
                size_t j = (size_t)(lj / g->nb * g->pc + g->mycol) * g->nb + lj % g->nb;
                return lrr__mpi_error(d->ctx, LRR_ERR_SINGULAR, "channel %d: M has a "
                                      "non-finite entry at (%zu, %zu)", c, j, i);
            }
            float f = (float)v;
            memcpy(bytes + at * sizeof f, &f, sizeof f);
        }
    return LRR_OK;
}

/* Every rank's block of M_c to its place in the root's M. */
static lrr_status gather_m(bs_dist *d, bs_grid *g, int c)
{
    const int count = g->mloc * g->nloc;
    int rc = MPI_SUCCESS;
    if (d->rank != d->root) {
        if (count)
            rc = MPI_Send(g->a, count, MPI_FLOAT, d->root, TAG_M, d->comm);
        return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(d->ctx, "sending M's block", rc);
    }
    float *m = lrr__build_m(d->b, c);
    int n = 0;
    for (int q = 0; q < d->size && rc == MPI_SUCCESS; q++)
        if (g->mtype[q] != MPI_DATATYPE_NULL)
            rc = q == d->root ? MPI_Irecv(m, 1, g->mtype[q], q, TAG_M, d->comm, &d->req[n++])
                              : MPI_Recv(m, 1, g->mtype[q], q, TAG_M, d->comm,
                                         MPI_STATUS_IGNORE);
    /* the root's own: posted first, sent to itself last */
    if (rc == MPI_SUCCESS && count)
        rc = MPI_Send(g->a, count, MPI_FLOAT, d->root, TAG_M, d->comm);
    int rw = MPI_Waitall(n, d->req, MPI_STATUSES_IGNORE);
    rc = rc != MPI_SUCCESS ? rc : rw;
    return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(d->ctx, "gathering M", rc);
}

lrr_status lrr__bs_invert(bs_dist *d, int c)
{
    bs_grid *g = d->grid;
    double anorm = 0, cond = 0;
    lrr_status st = lrr__mpi_spread(d->ctx, d->comm, scatter(d, g));
    if (!st)
        st = lrr__mpi_spread(d->ctx, d->comm, factor(d, g, c, &anorm));
    if (!st)
        st = lrr__mpi_spread(d->ctx, d->comm, inverse(d, g, c, anorm, &cond));
    if (!st)
        st = lrr__mpi_spread(d->ctx, d->comm, to_float(d, g, c));
    if (!st)
        st = lrr__mpi_spread(d->ctx, d->comm, gather_m(d, g, c));
    if (!st && d->rank == d->root)
        lrr__build_set_cond(d->b, c, isfinite(cond) ? cond : INFINITY);
    return st;
}

#else /* without ScaLAPACK build_save.c never asks for it */

lrr_status lrr__bs_grid_open(bs_dist *d, int nb)
{
    (void)nb;
    return lrr__mpi_error(d->ctx, LRR_ERR_UNSUPPORTED, "lrr_mpi_operator_build_save: built "
                          "without ScaLAPACK");
}

void lrr__bs_grid_close(bs_dist *d) { (void)d; }

lrr_status lrr__bs_invert(bs_dist *d, int c)
{
    (void)c;
    return lrr__mpi_error(d->ctx, LRR_ERR_UNSUPPORTED, "lrr_mpi_operator_build_save: built "
                          "without ScaLAPACK");
}

#endif
