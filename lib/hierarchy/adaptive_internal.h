/* Shared by the files of the adaptive selection (lib/hierarchy/ only; hierarchy.h declares
 * what later stages use): adaptive.c (the greedy split, lrr__adaptive_select), ffsample.c
 * (the sampled rows of F, the radiosity weights) and exchange.c (the exchange refinement). */
#ifndef LRR_ADAPTIVE_INTERNAL_H
#define LRR_ADAPTIVE_INTERNAL_H

#include "hierarchy/hierarchy.h"

/* A quadtree node of one triangle: a candidate patch. */
typedef struct lrr__node {
    double score;     /* the split's priority: V_p − Σ V_child, the objective it removes
                         (or the area for LRR_SPLIT_AREA) */
    double own;       /* V_p */
    double child[4];  /* V of the four children (computed with the node, reused on split) */
    double area;      /* the first tie-break: nodes no sampled receiver tells apart (score 0)
                         are split largest first, as in uniform subdivision */
    size_t j0;        /* first subpatch: the tie-break and the final order */
    size_t slot;      /* with radiosity weights: its delta rows in the pool */
    uint32_t t;       /* triangle */
    uint8_t depth;    /* quadtree depth within the triangle */
} lrr__node;

/* The node's subpatches: [x->j0, x->j0 + lrr__node_size(g, x)). */
static inline size_t lrr__node_size(const lrr__geometry *g, const lrr__node *x)
{
    return (size_t)1 << (2 * (g->depth[x->t] - x->depth));
}

/* The change of bS Σ_c M_c² when the delta sums D are added to M. */
static inline double lrr__mean_change(double bS, const double M[3], const double D[3])
{
    double ch = 0;
    for (int c = 0; c < 3; c++)
        ch += bS * (2 * M[c] * D[c] + D[c] * D[c]);
    return ch;
}

/* ffsample.c */
/* e[3] = Σ_{j∈[j0,j1)} (F_rj − mean) b_jc: the error the patch's averaging makes in the
 * light row r gathers (s->b required). */
void lrr__ffsample_row_error(const lrr__ffsample *s, size_t r, size_t j0, size_t j1,
                             double e[3]);
/* b (n×3) ≈ the scene's radiosity B, the weights of the selection; *b stays NULL when
 * nothing emits. */
lrr_status lrr__radiosity_weights(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                                  const float *emission, const float *area,
                                  const lrr_build_options *opts, lrr__rows_fn render,
                                  const lrr__ffsample *smp, double **b);

/* adaptive.c */
/* d (3 per sampled row) = Σ_children e − e_x: what splitting x adds to the row errors T
 * (and merging its four children back into x subtracts). */
void lrr__node_delta(const lrr__geometry *g, const lrr__ffsample *s, const lrr__node *x,
                     double *d);
/* D[c] = Σ_r rho_rc d_rc: the delta's change of the mean term's sums M. */
void lrr__delta_sum(const lrr__ffsample *s, const double *d, double D[3]);
/* qsort order of nodes: by first subpatch. */
int lrr__node_by_first(const void *a, const void *b);

/* exchange.c */
/* The exchange refinement's state: the greedy's result (its leaves, the pool of delta rows
 * and the row errors) and the exchange's own rows (lrr__exchange allocates them). */
typedef struct lrr__xchg {
    const lrr__geometry *g;
    const lrr__ffsample *s;
    size_t S3, nslots;
    double *pool, *T, *w, *lin, *quad, *rho2;
    double *M, bS, *Dsum;
    size_t *free_slots, nfree;
    lrr__node *leaf, *par;
    size_t nleaf, npar;
} lrr__xchg;
/* Trades merges for splits on X's leaves (X->leaf, X->nleaf change; up to K rounds) while
 * they lower *total; *made gets the number of exchanges. Fills and frees X->w and X->par. */
lrr_status lrr__exchange(lrr_context *ctx, lrr__xchg *X, double *total, size_t K,
                         size_t *made);

#endif
