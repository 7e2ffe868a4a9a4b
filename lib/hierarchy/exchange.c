/* The exchange refinement of the adaptive selection (adaptive.c).
 *
 * The greedy split cannot undo a split that later splits made less useful. Once it has
 * spent the budget, exchange() trades patches: merge the four leaf children of a node x
 * back into x and split a leaf y elsewhere, whenever the pair lowers the objective
 * Σ_r Σ_c rho_rc² T_rc² (+ the mean term), so k stays the same and the objective strictly
 * falls (no cycles).
 * Merging x subtracts exactly the delta its split added, so one pool slot per node serves
 * both. Each round ranks every candidate by its own first-order change, with one matrix-
 * vector product over the pool (lin = pool · (rho² ∘ T)), and evaluates the few best pairs
 * exactly, their cross term included. */
#include "config.h"
#include "hierarchy/adaptive_internal.h"

#include <cblas.h>
#include <stdlib.h>
#include <string.h>

static int splittable(const lrr__geometry *g, const lrr__node *x)
{
    return x->depth < g->depth[x->t];
}

static void slot_fill(lrr__xchg *X, lrr__node *x)
{
    x->slot = X->free_slots[--X->nfree];
    double *d = X->pool + x->slot * X->S3, q = 0;
    lrr__node_delta(X->g, X->s, x, d);
    for (size_t r = 0; r < X->S3; r++)
        q += X->rho2[r] * d[r] * d[r];
    X->quad[x->slot] = q;
    lrr__delta_sum(X->s, d, X->Dsum + 3 * x->slot);
}

/* If the parent of x (a leaf) has four leaf children, it becomes a merge candidate. */
static void parent_check(lrr__xchg *X, const lrr__node *x)
{
    if (x->depth == 0)
        return;
    const size_t size = lrr__node_size(X->g, x), psize = 4 * size, base = X->g->sub0[x->t];
    const size_t pj0 = base + (x->j0 - base) / psize * psize;
    int leaves = 0;
    for (size_t i = 0; i < X->nleaf; i++) {
        const lrr__node *y = &X->leaf[i];
        leaves += y->t == x->t && y->depth == x->depth && y->j0 >= pj0 && y->j0 < pj0 + psize;
    }
    if (leaves != 4)
        return;
    lrr__node p = {.j0 = pj0, .t = x->t, .depth = (uint8_t)(x->depth - 1)};
    slot_fill(X, &p);
    X->par[X->npar++] = p;
}

/* Δ objective of merging x and splitting y, exactly. */
static double pair_change(const lrr__xchg *X, const lrr__node *x, const lrr__node *y)
{
    const double *dx = X->pool + x->slot * X->S3, *dy = X->pool + y->slot * X->S3;
    double change = 0;
    for (size_t r = 0; r < X->S3; r++) {
        double t = X->T[r] - dx[r] + dy[r];
        change += X->rho2[r] * (t * t - X->T[r] * X->T[r]);
    }
    double D[3];
    for (int c = 0; c < 3; c++)
        D[c] = X->Dsum[3 * y->slot + c] - X->Dsum[3 * x->slot + c];
    return change + lrr__mean_change(X->bS, X->M, D);
}

static size_t find_node(const lrr__node *list, size_t len, const lrr__node *x)
{
    for (size_t i = 0; i < len; i++)
        if (list[i].j0 == x->j0 && list[i].depth == x->depth)
            return i;
    return SIZE_MAX;
}

/* Merges x's four leaf children into x and splits the leaf y (neither inside the other). */
static void apply_exchange(lrr__xchg *X, const lrr__node *x, const lrr__node *y)
{
    const lrr__geometry *g = X->g;
    const double *dx = X->pool + x->slot * X->S3, *dy = X->pool + y->slot * X->S3;
    for (size_t r = 0; r < X->S3; r++)
        X->T[r] += dy[r] - dx[r];
    for (int c = 0; c < 3; c++)
        X->M[c] += X->Dsum[3 * y->slot + c] - X->Dsum[3 * x->slot + c];
    /* merge x: its four children leave, it becomes a leaf with its slot */
    const size_t xsize = lrr__node_size(g, x);
    for (size_t i = 0; i < X->nleaf;) {
        lrr__node *c = &X->leaf[i];
        if (c->j0 >= x->j0 && c->j0 < x->j0 + xsize) {
            if (splittable(g, c))
                X->free_slots[X->nfree++] = c->slot;
            *c = X->leaf[--X->nleaf];
        } else {
            i++;
        }
    }
    size_t i = find_node(X->par, X->npar, x);
    X->par[i] = X->par[--X->npar];
    X->leaf[X->nleaf++] = *x;
    parent_check(X, x);
    /* split y: its parent stops being a merge candidate, it becomes one, its children
     * become leaves */
    i = find_node(X->leaf, X->nleaf, y);
    X->leaf[i] = X->leaf[--X->nleaf];
    for (i = 0; i < X->npar; i++) {
        const lrr__node *p = &X->par[i];
        if (p->depth + 1 == y->depth && y->j0 >= p->j0 && y->j0 < p->j0 + lrr__node_size(g, p)) {
            X->free_slots[X->nfree++] = p->slot;
            X->par[i] = X->par[--X->npar];
            break;
        }
    }
    X->par[X->npar++] = *y;
    const size_t quarter = lrr__node_size(g, y) / 4;
    for (size_t c = 0; c < 4; c++) {
        lrr__node ch = {.j0 = y->j0 + c * quarter, .t = y->t, .depth = (uint8_t)(y->depth + 1)};
        if (splittable(g, &ch))
            slot_fill(X, &ch);
        X->leaf[X->nleaf++] = ch;
    }
}

#define EXCHANGE_CANDIDATES 32 /* best splits and best merges ranked per round */
#define EXCHANGES_PER_ROUND 16

/* Inserts (score, node) into the list of the C lowest scores, ascending. */
static void best_insert(double *v, lrr__node *list, size_t *len, double score,
                        const lrr__node *x)
{
    size_t q = *len;
    if (q == EXCHANGE_CANDIDATES) {
        if (score >= v[q - 1])
            return;
        q--;
    } else {
        (*len)++;
    }
    while (q > 0 && v[q - 1] > score) {
        v[q] = v[q - 1];
        list[q] = list[q - 1];
        q--;
    }
    v[q] = score;
    list[q] = *x;
}

typedef struct {
    double estimate;
    unsigned short merge, split;
} pair;

static int by_estimate(const void *a, const void *b)
{
    const pair *x = a, *y = b;
    return (x->estimate > y->estimate) - (x->estimate < y->estimate);
}

/* The merge candidates of the greedy's result: runs of four sibling leaves. */
static void merge_candidates(lrr__xchg *X)
{
    const lrr__geometry *g = X->g;
    qsort(X->leaf, X->nleaf, sizeof *X->leaf, lrr__node_by_first);
    for (size_t i = 0; i + 3 < X->nleaf; i++) {
        const lrr__node *x = &X->leaf[i];
        const size_t size = lrr__node_size(g, x);
        if (x->depth == 0 || (x->j0 - g->sub0[x->t]) % (4 * size) != 0)
            continue;
        int sib = 1;
        for (size_t c = 1; c < 4; c++)
            sib &= X->leaf[i + c].t == x->t && X->leaf[i + c].depth == x->depth;
        if (!sib)
            continue;
        lrr__node p = {.j0 = x->j0, .t = x->t, .depth = (uint8_t)(x->depth - 1)};
        slot_fill(X, &p);
        X->par[X->npar++] = p;
        i += 3;
    }
}

/* One round's ranking: the best splits (sv, sn) and merges (mv, mn) by their own first-order
 * change, and the pairs of them, neither inside the other, whose estimates sum below 0. */
typedef struct {
    double sv[EXCHANGE_CANDIDATES], mv[EXCHANGE_CANDIDATES];
    lrr__node sn[EXCHANGE_CANDIDATES], mn[EXCHANGE_CANDIDATES];
    pair pairs[EXCHANGE_CANDIDATES * EXCHANGE_CANDIDATES];
    size_t ns, nm, np;
} ranking;

static void rank_candidates(lrr__xchg *X, ranking *rk)
{
    const lrr__geometry *g = X->g;
    for (size_t r = 0; r < X->S3; r++)
        X->w[r] = X->rho2[r] * X->T[r];
    cblas_dgemv(CblasRowMajor, CblasNoTrans, (int)X->nslots, (int)X->S3, 1.0, X->pool,
                (int)X->S3, X->w, 1, 0.0, X->lin, 1);
    rk->ns = rk->nm = rk->np = 0;
    for (size_t i = 0; i < X->nleaf; i++)
        if (splittable(g, &X->leaf[i])) {
            const size_t q = X->leaf[i].slot;
            const double mc = lrr__mean_change(X->bS, X->M, X->Dsum + 3 * q);
            best_insert(rk->sv, rk->sn, &rk->ns, 2 * X->lin[q] + X->quad[q] + mc, &X->leaf[i]);
        }
    for (size_t i = 0; i < X->npar; i++) {
        const size_t q = X->par[i].slot;
        double nD[3] = {-X->Dsum[3 * q], -X->Dsum[3 * q + 1], -X->Dsum[3 * q + 2]};
        const double mc = lrr__mean_change(X->bS, X->M, nD);
        best_insert(rk->mv, rk->mn, &rk->nm, -2 * X->lin[q] + X->quad[q] + mc, &X->par[i]);
    }
    for (size_t a = 0; a < rk->nm; a++)
        for (size_t b = 0; b < rk->ns; b++) {
            const lrr__node *m = &rk->mn[a], *s = &rk->sn[b];
            if (!(s->j0 >= m->j0 && s->j0 < m->j0 + lrr__node_size(g, m)) &&
                rk->mv[a] + rk->sv[b] < 0)
                rk->pairs[rk->np++] =
                    (pair){rk->mv[a] + rk->sv[b], (unsigned short)a, (unsigned short)b};
        }
    qsort(rk->pairs, rk->np, sizeof *rk->pairs, by_estimate);
}

/* Walks the ranked pairs by estimated change and makes, up to EXCHANGES_PER_ROUND, those
 * whose exact change (with T as the earlier exchanges of the round left it) is still a
 * decrease; returns how many were made. */
static size_t make_exchanges(lrr__xchg *X, const ranking *rk, double *total)
{
    const lrr__geometry *g = X->g;
    size_t this_round = 0;
    for (size_t q = 0; q < rk->np && this_round < EXCHANGES_PER_ROUND; q++) {
        /* both still what they were: x a merge candidate, y a splittable leaf */
        const size_t xi = find_node(X->par, X->npar, &rk->mn[rk->pairs[q].merge]);
        const size_t yi = find_node(X->leaf, X->nleaf, &rk->sn[rk->pairs[q].split]);
        if (xi == SIZE_MAX || yi == SIZE_MAX)
            continue;
        const lrr__node x = X->par[xi], y = X->leaf[yi];
        if (y.j0 >= x.j0 && y.j0 < x.j0 + lrr__node_size(g, &x))
            continue;
        const double change = pair_change(X, &x, &y);
        if (!(change < -1e-9 * *total))
            continue;
        apply_exchange(X, &x, &y);
        *total += change;
        this_round++;
    }
    return this_round;
}

/* Runs exchanges on X's leaves until none of the ranked pairs lowers *total or max_rounds
 * rankings were made; returns how many exchanges were made. Each round ranks the
 * candidates by their own first-order change (one product with the pool), then walks the
 * pairs by estimated change and makes, up to EXCHANGES_PER_ROUND, those whose exact change
 * (with T as the earlier exchanges of the round left it) is still a decrease. */
static size_t exchange(lrr__xchg *X, double *total, size_t max_rounds)
{
    merge_candidates(X);
    size_t made = 0;
    ranking rk;
    for (size_t round = 0; round < max_rounds && X->npar > 0; round++) {
        rank_candidates(X, &rk);
        const size_t this_round = make_exchanges(X, &rk, total);
        made += this_round;
        if (this_round == 0)
            break;
    }
    return made;
}

lrr_status lrr__exchange(lrr_context *ctx, lrr__xchg *X, double *total, size_t K,
                         size_t *made)
{
    const size_t S3 = X->S3, slots = X->nslots;
    lrr_status st;
    if (!(st = lrr__calloc(ctx, &X->w, 2 * (S3 + slots), sizeof(double),
                           "adaptive exchange rows")) &&
        !(st = lrr__calloc(ctx, &X->par, K / 4 + 2, sizeof(lrr__node),
                           "adaptive exchange candidates"))) {
        X->lin = X->w + S3;
        X->rho2 = X->lin + slots;
        X->quad = X->rho2 + S3;
        for (size_t r = 0; r < S3; r++)
            X->rho2[r] = X->s->rho[r] * X->s->rho[r];
        /* each exchange lowers the objective; measured on the Cornell box (n = 16000,
         * K = 4000): 459 exchanges, the objective 3.2× lower, 1.1 s of a
         * 35 s build */
        *made = exchange(X, total, K);
    }
    lrr_aligned_free(X->w);
    lrr_aligned_free(X->par);
    X->w = X->lin = X->rho2 = X->quad = NULL;
    X->par = NULL;
    return st;
}
