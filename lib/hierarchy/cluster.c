/* The cluster hierarchy: patches as groups of subpatches across input triangles, so that k
 * no longer grows with the triangle count (docs/METHOD.md "Clusters").
 *
 * A binary cluster tree over all n subpatches is built top down. A node that mixes the
 * scene's emitters with other surfaces is split into the two (the low-rank model spreads
 * a patch's emission over its whole area, which would turn a small bright lamp into a
 * dim ceiling: measured on the Cornell box, n = 3240, K = 200, rel L2 6.3% with the lamp
 * merged). A node whose normals do not all lie within LRR__CLUSTER_CONE of their
 * area-weighted mean is split by normal (along the axis where the normals' components spread
 * most, at the middle of that spread: the two sides of a wall, or a floor and a wall, part
 * first); any other node is split in space (along its centres' longest extent, at the area
 * median), so nodes stay compact and balanced. The subpatches are kept in the tree's leaf
 * order, so every node is a contiguous run [j0, j1) of that order: the operator's
 * patch-major numbering.
 *
 * The patches are a cut of the tree: the nodes that break a rule are always split (also
 * below a node that keeps them: a part's normals may leave the cone of its own mean); then,
 * until there are K patches, the node with the largest score: its area (LRR_SPLIT_AREA), or
 * (LRR_SPLIT_VARIANCE) the error of the area-weighted model over it,
 *
 *     V_p = Σ_i w_i Σ_{j∈p} (F_ij − F_{i→p} A_j / A_p)²,    w_i = Σ_c rho_ic²,
 *
 * estimated from the same sampled rows of F as the quadtree's adaptive selection
 * (ffsample.c), with (n/S) Σ over the sample. V_p never grows under a split and vanishes
 * for a single subpatch. (The model itself weighs a cluster's subpatches by A_j R_j, R_j
 * their row sums, known only after the form factors; a score with R_j estimated from R 8
 * hemicubes, and a rule keeping subpatches whose R_j differ by more than 0.3 apart, were
 * measured: no better, and the rule worse, bench/results/2026-12-03-accuracy.md.)
 */
#include "config.h"
#include "hierarchy/adaptive_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

/* The normal rule: every normal within 30° of its cluster's mean, so two subpatches in one
 * cluster differ by at most 60°: never the two sides of a wall (180°), never a floor and a
 * wall (90°). */
#define LRR__CLUSTER_CONE_COS 0.8660254037844386
/* The sampled rows hold at most this many bytes (S·n floats); S shrinks beyond it. */
#define LRR__CLUSTER_SAMPLE_BYTES ((size_t)512 << 20)

typedef struct cnode {
    size_t j0, j1;  /* leaf-order run */
    size_t child;   /* left child (right = child + 1); 0 for a leaf */
    double area;
    double score;
    int cone_ok;
} cnode;

typedef struct tree {
    size_t n, count;         /* subpatches, nodes used (≤ 2n − 1) */
    cnode *node;
    size_t *perm;            /* leaf order → scene (triangle-order) subpatch */
    const float *centre, *normal, *area;
    const uint8_t *emits;    /* n: 1 for the scene's emitters */
} tree;

/* ------------------------------------------------------------ building the tree */
/* 1 when the run mixes emitters and non-emitters (a rule as strict as the normals'). */
static int mixes_emitters(const tree *t, size_t j0, size_t j1)
{
    for (size_t j = j0 + 1; j < j1; j++)
        if (t->emits[t->perm[j]] != t->emits[t->perm[j0]])
            return 1;
    return 0;
}

static int cone_check(const tree *t, size_t j0, size_t j1, double *area)
{
    double m[3] = {0, 0, 0}, a = 0;
    for (size_t j = j0; j < j1; j++) {
        const size_t i = t->perm[j];
        for (int c = 0; c < 3; c++)
            m[c] += (double)t->area[i] * t->normal[3 * i + c];
        a += t->area[i];
    }
    *area = a;
    if (mixes_emitters(t, j0, j1))
        return 0;
    lrr__normalize3(m);
    for (size_t j = j0; j < j1; j++) {
        const float *nv = t->normal + 3 * t->perm[j];
        if (m[0] * nv[0] + m[1] * nv[1] + m[2] * nv[2] < LRR__CLUSTER_CONE_COS - 1e-9)
            return 0;
    }
    return 1;
}

typedef struct keyed { double key; size_t idx; } keyed;
static int keyed_cmp(const void *a, const void *b)
{
    const keyed *x = a, *y = b;
    if (x->key != y->key)
        return x->key < y->key ? -1 : 1;
    return (x->idx > y->idx) - (x->idx < y->idx);
}

/* Reorders perm[j0..j1) by key(component `axis` of normal (by_normal) or centre), returns
 * the split position: the middle of the key range (normal) or the area median (space);
 * 0 when the keys do not separate. */
static size_t order_by(tree *t, keyed *buf, size_t j0, size_t j1, int by_normal, int axis)
{
    const size_t m = j1 - j0;
    const float *src = by_normal ? t->normal : t->centre;
    for (size_t j = 0; j < m; j++) {
        buf[j].idx = t->perm[j0 + j];
        buf[j].key = src[3 * buf[j].idx + axis];
    }
    qsort(buf, m, sizeof *buf, keyed_cmp);
    for (size_t j = 0; j < m; j++)
        t->perm[j0 + j] = buf[j].idx;
    if (buf[0].key == buf[m - 1].key)
        return 0;
    size_t s = 1;
    if (by_normal) {
        const double mid = 0.5 * (buf[0].key + buf[m - 1].key);
        while (s < m - 1 && buf[s].key < mid)
            s++;
        return s;
    }
    double total = 0, run = 0;
    for (size_t j = 0; j < m; j++)
        total += t->area[buf[j].idx];
    for (s = 0; s < m - 1; s++) {
        run += t->area[buf[s].idx];
        if (run >= 0.5 * total)
            break;
    }
    return s + 1 < m ? s + 1 : m - 1;
}

/* The axis along which src's (normals or centres) components spread most. */
static int widest_axis(const tree *t, size_t j0, size_t j1, int by_normal)
{
    const float *src = by_normal ? t->normal : t->centre;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t j = j0; j < j1; j++)
        for (int c = 0; c < 3; c++) {
            double v = src[3 * t->perm[j] + c];
            lo[c] = v < lo[c] ? v : lo[c];
            hi[c] = v > hi[c] ? v : hi[c];
        }
    int a = 0;
    for (int c = 1; c < 3; c++)
        if (hi[c] - lo[c] > hi[a] - lo[a])
            a = c;
    return a;
}

/* Emitters first (stable: keeps the order within each side). */
static size_t split_emitters(tree *t, keyed *buf, size_t j0, size_t j1)
{
    const size_t m = j1 - j0;
    for (size_t j = 0; j < m; j++) {
        buf[j].idx = t->perm[j0 + j];
        buf[j].key = t->emits[buf[j].idx] ? 0 : 1;
    }
    qsort(buf, m, sizeof *buf, keyed_cmp);
    size_t s = 0;
    for (size_t j = 0; j < m; j++) {
        t->perm[j0 + j] = buf[j].idx;
        s += buf[j].key == 0;
    }
    return s;
}

/* Splits node x into two children; returns the split position (j0 < s < j1). */
static size_t split_node(tree *t, keyed *buf, const cnode *x)
{
    if (!x->cone_ok && mixes_emitters(t, x->j0, x->j1))
        return x->j0 + split_emitters(t, buf, x->j0, x->j1);
    size_t s = 0;
    if (!x->cone_ok)
        s = order_by(t, buf, x->j0, x->j1, 1, widest_axis(t, x->j0, x->j1, 1));
    if (s == 0)
        s = order_by(t, buf, x->j0, x->j1, 0, widest_axis(t, x->j0, x->j1, 0));
    return s ? x->j0 + s : x->j0 + (x->j1 - x->j0) / 2; /* coincident centres: by count */
}

static lrr_status build_tree(lrr_context *ctx, tree *t)
{
    const size_t n = t->n;
    keyed *buf;
    size_t *stack;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &buf, n, sizeof *buf, "cluster sort keys")))
        return st;
    if ((st = lrr__calloc(ctx, &stack, n, sizeof *stack, "cluster stack"))) {
        lrr_aligned_free(buf);
        return st;
    }
    size_t top = 0;
    t->node[0] = (cnode){.j0 = 0, .j1 = n};
    t->node[0].cone_ok = cone_check(t, 0, n, &t->node[0].area);
    t->count = 1;
    stack[top++] = 0;
    while (top > 0) {
        const size_t x = stack[--top];
        if (t->node[x].j1 - t->node[x].j0 < 2)
            continue;
        const size_t s = split_node(t, buf, &t->node[x]);
        const size_t c = t->count;
        t->count += 2;
        t->node[x].child = c;
        t->node[c] = (cnode){.j0 = t->node[x].j0, .j1 = s};
        t->node[c + 1] = (cnode){.j0 = s, .j1 = t->node[x].j1};
        for (int h = 0; h < 2; h++) {
            cnode *y = &t->node[c + h];
            y->cone_ok = cone_check(t, y->j0, y->j1, &y->area);
            stack[top++] = c + h;
        }
    }
    lrr_aligned_free(buf);
    lrr_aligned_free(stack);
    return LRR_OK;
}

/* ------------------------------------------------------------ scores */
/* The sampled rows with their columns in leaf order, and the modelled areas. */
typedef struct scorer {
    int split;
    lrr__ffsample s;
    double *a;      /* n: area of each leaf-order subpatch */
} scorer;

/* V_p over the sample (see the top of the file). */
static double variance(const scorer *sc, size_t j0, size_t j1)
{
    const lrr__ffsample *s = &sc->s;
    double A = 0, A2 = 0;
    for (size_t j = j0; j < j1; j++) {
        A += sc->a[j];
        A2 += sc->a[j] * sc->a[j];
    }
    double sum = 0, ab[3] = {0, 0, 0};
    for (size_t j = j0; j < j1 && s->b; j++)
        for (int c = 0; c < 3; c++)
            ab[c] += sc->a[j] * s->b[3 * j + c];
    #pragma omp parallel for schedule(static) reduction(+ : sum) if ((j1 - j0) * s->count > 65536)
    for (size_t r = 0; r < s->count; r++) {
        const float *f = s->f + r * s->n;
        double S = 0, F2 = 0, Fa = 0, Fb[3] = {0, 0, 0};
        for (size_t j = j0; j < j1; j++) {
            S += f[j];
            F2 += (double)f[j] * f[j];
            Fa += (double)f[j] * sc->a[j];
            for (int c = 0; c < 3 && s->b; c++)
                Fb[c] += (double)f[j] * s->b[3 * j + c];
        }
        const double q = A > 0 ? S / A : 0;
        if (s->b) { /* Σ_c rho_rc² (Σ_j (F_j − a_j S/A) b_jc)²: the gathered light's error */
            for (int c = 0; c < 3; c++) {
                double e = Fb[c] - q * ab[c];
                sum += s->rho[3 * r + c] * s->rho[3 * r + c] * e * e;
            }
            continue;
        }
        /* Σ_j (F_j − a_j S/A)² = Σ F² − 2 (S/A) Σ F a + (S/A)² Σ a² */
        double v = F2 - 2 * q * Fa + q * q * A2;
        sum += s->weight[r] * (v > 0 ? v : 0);
    }
    return sum * (double)s->n / (double)s->count;
}

static void score_node(const scorer *sc, cnode *x)
{
    x->score = x->j1 - x->j0 < 2 ? -1 /* cannot split */
               : sc->split == LRR_SPLIT_AREA ? x->area : variance(sc, x->j0, x->j1);
}

/* Renders the sample (scene order) and permutes its columns to the tree's leaf order. */
static lrr_status take_sample(lrr_context *ctx, scorer *sc, const lrr__geometry *g,
                              const float *rho, const float *emission, const float *area,
                              const lrr_build_options *opts, lrr__rows_fn render,
                              const tree *t)
{
    lrr_build_options so = *opts;
    unsigned R = opts->hemicube_resolution ? opts->hemicube_resolution : 128;
    so.hemicube_resolution = R / 4 < 16 ? (R < 16 ? R : 16) : (R / 4) & ~1u; /* as adaptive.c */
    const size_t count = lrr__cluster_samples(g->n, opts->adaptive_samples);
    lrr_status st = lrr__ffsample_take(ctx, g, rho, &so, render, count, &sc->s);
    float *row;
    if (st || (emission && (st = lrr__radiosity_weights(ctx, g, rho, emission, area, &so,
                                                        render, &sc->s, &sc->s.b))) ||
        (st = lrr__calloc(ctx, &row, g->n, sizeof(float), "sample row")))
        return st;
    if (sc->s.b) { /* the weights in leaf order too (row holds 3 floats per step) */
        double *b;
        if ((st = lrr__calloc(ctx, &b, g->n, 3 * sizeof(double), "radiosity weights"))) {
            lrr_aligned_free(row);
            return st;
        }
        for (size_t j = 0; j < g->n; j++)
            for (int c = 0; c < 3; c++)
                b[3 * j + c] = sc->s.b[3 * t->perm[j] + c];
        lrr_aligned_free(sc->s.b);
        sc->s.b = b;
    }
    for (size_t r = 0; r < sc->s.count; r++) {
        float *f = sc->s.f + r * g->n;
        for (size_t j = 0; j < g->n; j++)
            row[j] = f[t->perm[j]];
        memcpy(f, row, g->n * sizeof(float));
    }
    lrr_aligned_free(row);
    return LRR_OK;
}

/* ------------------------------------------------------------ the cut */
/* max-heap of node indices by score (ties: lower j0 first) */
static int above(const cnode *nd, size_t a, size_t b)
{
    if (nd[a].score != nd[b].score)
        return nd[a].score > nd[b].score;
    return nd[a].j0 < nd[b].j0;
}

static void heap_push(const cnode *nd, size_t *h, size_t *len, size_t x)
{
    size_t i = (*len)++;
    while (i > 0 && above(nd, x, h[(i - 1) / 2])) {
        h[i] = h[(i - 1) / 2];
        i = (i - 1) / 2;
    }
    h[i] = x;
}

static size_t heap_pop(const cnode *nd, size_t *h, size_t *len)
{
    size_t top = h[0], x = h[--*len], i = 0;
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= *len)
            break;
        if (c + 1 < *len && above(nd, h[c + 1], h[c]))
            c++;
        if (!above(nd, h[c], x))
            break;
        h[i] = h[c];
        i = c;
    }
    if (*len > 0)
        h[i] = x;
    return top;
}

/* The cut: forced splits (normal rule), then the K − (forced) best. Writes the chosen
 * nodes' j0 into first (ascending) and returns their count. */
/* Node x into the heap, or where it breaks a rule its descendants that keep them (forced:
 * depth-first, stack a scratch of up to n entries). */
static void place(cnode *nd, const scorer *sc, size_t x, size_t *heap, size_t *len,
                  size_t *stack)
{
    size_t top = 0;
    stack[top++] = x;
    while (top > 0) {
        x = stack[--top];
        if (!nd[x].cone_ok && nd[x].child) {
            stack[top++] = nd[x].child;
            stack[top++] = nd[x].child + 1;
        } else {
            score_node(sc, &nd[x]);
            heap_push(nd, heap, len, x);
        }
    }
}

static size_t choose_cut(tree *t, const scorer *sc, size_t K, size_t *heap, size_t *first)
{
    cnode *nd = t->node;
    size_t len = 0, cut = 0;
    /* first[] doubles as place's stack until the cut is written into it */
    place(nd, sc, 0, heap, &len, first);
    /* a child of a node that keeps the normal rule may break it around its own mean
     * direction: it is split on too */
    while (len < K && len > 0 && nd[heap[0]].score >= 0) {
        size_t x = heap_pop(nd, heap, &len);
        for (int h = 0; h < 2; h++)
            place(nd, sc, nd[x].child + h, heap, &len, first);
    }
    for (size_t i = 0; i < len; i++)
        first[cut++] = nd[heap[i]].j0;
    return cut;
}

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return (x > y) - (x < y);
}

size_t lrr__cluster_samples(size_t n, size_t samples)
{
    size_t S = samples ? samples : LRR__ADAPTIVE_DEFAULT_SAMPLES;
    const size_t cap = LRR__CLUSTER_SAMPLE_BYTES / (sizeof(float) * (n ? n : 1));
    S = S > cap ? (cap ? cap : 1) : S;
    return S < n ? S : n;
}

bool lrr__cluster_bytes(size_t n, size_t samples, int split, size_t *out)
{
    /* the tree (2n nodes), sort keys, stack, order, heap, offsets, areas, emitter flags */
    const size_t per = 2 * sizeof(cnode) + sizeof(keyed) + 4 * sizeof(size_t) +
                       sizeof(double) + 1;
    size_t b, rows = 0;
    if (!lrr__mul_size(n, per, &b))
        return false;
    if (split == LRR_SPLIT_VARIANCE) { /* the sample, the emitters' rows, the weights ×2 */
        size_t S = lrr__cluster_samples(n, samples) + LRR__ADAPTIVE_MAX_EMITTER_ROWS + 1;
        if (!lrr__mul_size(S, n, &rows) || !lrr__mul_size(rows, sizeof(float), &rows) ||
            __builtin_add_overflow(rows, n * 6 * sizeof(double), &rows))
            return false;
    }
    return !__builtin_add_overflow(b, rows, out);
}

static lrr_status check_args(lrr_context *ctx, const lrr__geometry *g,
                             const lrr_build_options *opts)
{
    if (opts->adaptive_split != LRR_SPLIT_VARIANCE && opts->adaptive_split != LRR_SPLIT_AREA)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "adaptive_split = %d: must be LRR_SPLIT_VARIANCE or LRR_SPLIT_AREA",
                          opts->adaptive_split);
    if (g->levels != 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "cluster hierarchy: the scene's patches become the subpatches, so it "
                          "must be subdivided with levels = 0 (it has levels = %u)", g->levels);
    if (opts->adaptive_patches < 1)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "cluster hierarchy: adaptive_patches (the cluster count K) must be "
                          ">= 1");
    return LRR_OK;
}

lrr_status lrr__cluster_select(lrr_context *ctx, const lrr__geometry *g, const float *rho,
                               const float *emission, const float *centre,
                               const float *normal, const float *area,
                               const lrr_build_options *opts, lrr__rows_fn render,
                               lrr__geometry *out)
{
    memset(out, 0, sizeof *out);
    lrr_status st = check_args(ctx, g, opts);
    if (st)
        return st;
    const size_t n = g->n, K = opts->adaptive_patches < n ? opts->adaptive_patches : n;
    tree t = {.n = n, .centre = centre, .normal = normal, .area = area};
    scorer sc = {.split = opts->adaptive_split};
    size_t *heap = NULL, *first = NULL;
    uint8_t *emits = NULL;
    if ((st = lrr__calloc(ctx, &emits, n, 1, "emitter flags")) ||
        (st = lrr__calloc(ctx, &t.node, 2 * n, sizeof(cnode), "cluster tree")) ||
        (st = lrr__calloc(ctx, &t.perm, n, sizeof(size_t), "cluster order")) ||
        (st = lrr__calloc(ctx, &heap, n, sizeof(size_t), "cluster heap")) ||
        (st = lrr__calloc(ctx, &first, n + 1, sizeof(size_t), "cluster offsets")) ||
        (st = lrr__calloc(ctx, &sc.a, n, sizeof(double), "cluster areas")))
        goto done;
    for (size_t j = 0; j < n; j++) {
        t.perm[j] = j;
        emits[j] = emission && (emission[3 * j] > 0 || emission[3 * j + 1] > 0 ||
                                emission[3 * j + 2] > 0);
    }
    t.emits = emits;
    if ((st = build_tree(ctx, &t)))
        goto done;
    for (size_t j = 0; j < n; j++)
        sc.a[j] = area[t.perm[j]];
    if (sc.split == LRR_SPLIT_VARIANCE &&
        (st = take_sample(ctx, &sc, g, rho, emission, area, opts, render, &t)))
        goto done;
    size_t k = choose_cut(&t, &sc, K, heap, first);
    qsort(first, k, sizeof(size_t), cmp_size);
    first[k] = n;
    st = lrr__geometry_clusters(ctx, g, t.perm, first, k, "cluster hierarchy",
                                LRR_ERR_INVALID_ARG, out);
done:
    lrr_aligned_free(t.node);
    lrr_aligned_free(t.perm);
    lrr_aligned_free(heap);
    lrr_aligned_free(first);
    lrr_aligned_free(sc.a);
    lrr_aligned_free(emits);
    lrr__ffsample_free(&sc.s);
    return st;
}
