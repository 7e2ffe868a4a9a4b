/* The hemicube's integration: a face's item buffer (triangle ids, or patches from the ray
 * caster) into the receiver's row, row_p = Σ multiplier(pixel) over the pixels showing
 * patch p, and the back faces' share beside it (hemicube.c has the receiver and its faces,
 * hemicube_raster.c the item buffer). A pixel's patch is the leaf its visible point falls in:
 * its barycentric coordinates in its triangle, then the triangle's quadtree. */
#include "config.h"
#include "formfactor/hemicube_raster.h"

#include <string.h>

typedef lrr__hemi_face face;
typedef lrr__hemi_ctx hemi_ctx;
typedef lrr__bary_plane bary_plane;

void lrr__hemi_bary_setup(const lrr__tri_info *ti, const double x[3], const face *f,
                          bary_plane *bp)
{
    double w0[3] = {ti->v0[0] - x[0], ti->v0[1] - x[1], ti->v0[2] - x[2]}, a1[3], a2[3];
    for (int j = 0; j < 3; j++) {
        a1[j] = (ti->g22 * ti->e1[j] - ti->g12 * ti->e2[j]) * ti->inv;
        a2[j] = (ti->g11 * ti->e2[j] - ti->g12 * ti->e1[j]) * ti->inv;
    }
    const double c = lrr__dot3(ti->n, w0), w1 = lrr__dot3(w0, a1), w2 = lrr__dot3(w0, a2);
    const double *basis[3] = {f->right, f->up, f->fwd};
    for (int m = 0; m < 3; m++) {
        double nd = lrr__dot3(ti->n, basis[m]);
        bp->den[m] = nd;
        bp->b1[m] = c * lrr__dot3(basis[m], a1) - w1 * nd;
        bp->b2[m] = c * lrr__dot3(basis[m], a2) - w2 * nd;
    }
}

/* ------------------------------------------------------------------ leaves of a row
 * Leaf depths (a triangle's patch or subpatch levels) up to LRR__LEAF_TABLE_DEPTH take the SIMD
 * path's leaf from a table of the regular grid's cells (2·4^depth entries; deeper ones
 * descend): the leaves of a uniform quadtree of depth d are the cells of the grid of lines
 * b_j = m/2^d, so with t_j = b_j·2^d and i_j = floor(t_j) the leaf is that of cell
 * (i1, i2, down = (i0 + i1 + i2 == 2^d − 2)). lrr__descend on the same b finds the same one
 * whenever every t_j is at least 2^-40·2^d from an integer and i0 + i1 + i2 is 2^d − 1 or
 * 2^d − 2: its first test (b_j >= 0.5) is the top bit of i_j, a corner child (2t − 1, 2t,
 * exact) drops that bit, and the middle child's 1 − 2t moves a value by at most 2^-54 per
 * level, which that margin (doubled per level like the values) cannot cross; the sum rules
 * out rounded values on no cell (two coordinates >= 0.5). Other pixels descend. */

/* Where depth's table starts in hemi_ctx.cells: depths 0..depth−1 hold 2·4^d entries each. */
static size_t cell_offset(unsigned depth) { return 2 * (((size_t)1 << (2 * depth)) - 1) / 3; }

/* The leaves of the grids of depth 0..LRR__LEAF_TABLE_DEPTH: lrr__descend at each cell's centroid
 * (a third of a cell from its lines, far beyond rounding). Slots of no cell stay 0. */
lrr_status lrr__hemi_cell_table(lrr_context *ctx, uint16_t **out)
{
    uint16_t *c;
    lrr_status st = lrr__calloc(ctx, &c, cell_offset(LRR__LEAF_TABLE_DEPTH + 1), sizeof *c,
                                "hemicube leaf table");
    if (st)
        return st;
    for (unsigned d = 0; d <= LRR__LEAF_TABLE_DEPTH; d++) {
        const size_t s = (size_t)1 << d;
        uint16_t *t = c + cell_offset(d);
        for (size_t i1 = 0; i1 < s; i1++)
            for (size_t i2 = 0; i1 + i2 < s; i2++)
                for (int down = 0; down < 2 && i1 + i2 + down < s; down++) {
                    double o = down ? 2.0 / 3 : 1.0 / 3;
                    double b1 = (i1 + o) / s, b2 = (i2 + o) / s, b0 = 1 - b1 - b2;
                    t[(i1 * s + i2) * 2 + down] = (uint16_t)lrr__descend(&b0, &b1, &b2, d);
                }
    }
    *out = c;
    return LRR_OK;
}

/* The leaf that pixel column sx of a row at height sy shows on the triangle of bp: the
 * scalar path, and the reference of lrr__hemi_simd.leaves_run. */
static inline size_t leaf_at(const bary_plane *bp, double sx, double sy, unsigned depth)
{
    /* one division: two take a quarter of the per-pixel loop's time */
    const double r = 1.0 / (bp->den[0] * sx + bp->den[1] * sy + bp->den[2]);
    double b0, b1 = (bp->b1[0] * sx + bp->b1[1] * sy + bp->b1[2]) * r,
               b2 = (bp->b2[0] * sx + bp->b2[1] * sy + bp->b2[2]) * r;
    lrr__clamp_bary(&b1, &b2, &b0);
    return lrr__descend(&b0, &b1, &b2, depth);
}

/* The row's accumulation: the face's row being integrated, and lrr__hemi_leaf_target's last
 * answer (adaptive trees search). */
typedef struct {
    const hemi_ctx *h;
    const face *f;
    double *row;
    const double *pre;   /* the face row's prefix sums of the multipliers */
    size_t row0;         /* the face row's first pixel */
    size_t last_leaf, last_p, last_t;
} integ;

/* Pixels x0..x1 of the face row show leaf `leaf` of triangle t: row[p] += their multipliers
 * as a difference of prefix sums (the pixel-order sum's dependency chain takes a tenth of a
 * Cornell R 64 profile; relative rounding ~1e-16 of the row's total, far below F̄'s float),
 * or the item buffer gets p. */
static inline void put(integ *in, size_t t, size_t leaf, int x0, int x1)
{
    if (leaf != in->last_leaf || t != in->last_t) {
        in->last_p = lrr__hemi_leaf_target(in->h, t, leaf);
        in->last_leaf = leaf;
        in->last_t = t;
    }
    const size_t p = in->last_p;
    if (!in->row) {
        for (int x = x0; x <= x1; x++)
            in->f->item[in->row0 + x] = (int32_t)p;
        return;
    }
    in->row[p] += in->pre[x1 + 1] - in->pre[x0];
}

#define CHUNK 256 /* pixels per leaves_run call (lrr__hemi_simd) */

/* The first set bit of mask at or after `from`, else n (lrr__hemi_breaks' mask of n bits). */
static inline int next_break(const uint64_t *mask, int from, int n)
{
    if (from >= n)
        return n;
    int w = from >> 6;
    uint64_t bits = mask[w] & (~(uint64_t)0 << (from & 63));
    while (!bits) {
        if (++w * 64 >= n)
            return n;
        bits = mask[w];
    }
    return w * 64 + __builtin_ctzll(bits);
}

/* Pixels a..b of the face row show triangle t, whose codes the depth test wrote (crow, their
 * change mask cbrk): runs of one code, split as integrate_run splits them. */
static void coded_run(integ *in, size_t t, unsigned depth, const uint32_t *crow,
                      const uint64_t *cbrk, int a, int b)
{
    const uint16_t *cells = in->h->cells + cell_offset(depth);
    for (int c = a; c <= b; c += CHUNK) {
        const int ce = b - c < CHUNK ? b : c + CHUNK - 1;
        for (int x = c; x <= ce;) {
            int e = next_break(cbrk, x + 1, ce + 1);
            e = e > ce + 1 ? ce + 1 : e;
            put(in, t, lrr__hemi_leaf_of(crow[x], cells), x, e - 1);
            x = e;
        }
    }
}

/* Pixels a..b of the face row (height sy) all show triangle t. */
static void integrate_run(integ *in, const bary_plane *bp, size_t t, double sy, int a, int b)
{
    const unsigned depth = lrr__hemi_leaf_depth(in->h, t);
    if (depth == 0) { /* one leaf: lrr__descend returns 0 whatever the barycentrics */
        put(in, t, 0, a, b);
        return;
    }
    uint32_t leaf[CHUNK];
    if (!in->h->simd || depth > 16) {
        for (int x = a; x <= b; x++)
            put(in, t, leaf_at(bp, in->h->sx[x], sy, depth), x, x);
        return;
    }
    const uint16_t *cells = depth <= LRR__LEAF_TABLE_DEPTH ? in->h->cells + cell_offset(depth) : NULL;
    for (int c = a; c <= b; c += CHUNK) {
        const int ce = b - c < CHUNK ? b : c + CHUNK - 1;
        uint64_t brk[CHUNK / 64];
        in->h->simd->leaves_run(bp->b1, bp->b2, bp->den, in->h->sx, sy, c, ce, depth, cells,
                                leaf, brk);
        const int n = ce - c + 1;
        for (int x = 0; x < n;) { /* runs of one leaf */
            const int e = next_break(brk, x + 1, n);
            put(in, t, lrr__hemi_leaf_of(leaf[x], cells), c + x, c + e - 1);
            x = e;
        }
    }
}

/* Accumulates the visible patches (or subpatches) of face f into row (k or n doubles), or
 * only resolves the item buffer to patch ids when row is NULL (the device integration then
 * sums the multiplier map per patch; markers stay). Returns the delta form factors of the
 * pixels showing back faces. */
#define BARY_CACHE 16

double lrr__hemi_integrate_face(const hemi_ctx *h, const double x[3], const face *f,
                                double *row, int clear)
{
    const size_t pixels = (size_t)f->W * f->H;
    double back = 0;
    if (h->rc) { /* the ray caster's item buffer holds patches already */
        for (size_t pix = 0; pix < pixels;) {
            const int32_t id = f->item[pix];
            if (id >= 0 && row) {
                /* a run of one patch summed in a register, in pixel order as before: the
                 * chain through row[id]'s store and reload took 3% of a FZK-Haus R 64 ray
                 * profile (Zen 5) */
                double acc = row[id];
                do
                    acc += f->weight[pix];
                while (++pix < pixels && f->item[pix] == id);
                row[id] = acc;
                continue;
            }
            if (id == LRR__ITEM_BACK)
                back += f->weight[pix];
            pix++;
        }
        return back;
    }
    integ in = {h, f, row, NULL, 0, SIZE_MAX, 0, SIZE_MAX};
    /* lrr__hemi_leaf_target is patch0[t] + leaf (and rows are summed, not resolved), and no
     * run is longer than coded_run's chunks */
    const int flat = row && !h->by_subpatch && !h->g->origin && !h->g->node && f->W <= CHUNK;
    /* the face's bary_planes by triangle id mod BARY_CACHE: a row's runs alternate between a
     * few triangles (a set-up per run takes 5% of a Cornell R 32 profile) */
    bary_plane bpc[BARY_CACHE];
    int32_t set_for[BARY_CACHE]; /* the triangle each is set up for */
    for (int c = 0; c < BARY_CACHE; c++)
        set_for[c] = -1;
    uint64_t brk[4096 / 64], cbrk[4096 / 64]; /* W <= 4096 (lrr__multiplier_map_create) */
    for (int y = 0; y < f->H; y++) {
        const double sy = f->sy[y];
        in.row0 = (size_t)y * f->W;
        in.pre = f->prefix + (size_t)y * (f->W + 1);
        const int32_t *item = f->item + in.row0;
        const uint32_t *crow = f->code + in.row0;
        if (h->simd) /* and where the depth test's codes change (render_face) */
            h->simd->breaks2(item, (const int32_t *)crow, f->W, brk, cbrk);
        else
            lrr__hemi_breaks(item, f->W, brk);
        /* cbrk's set bits after xx: the word cw, what is left of it in cbits (a cursor,
         * not next_break from xx each time, whose chain through xx bound the loop) */
        const int words = (f->W + 63) / 64;
        int cw = 0;
        uint64_t cbits = h->simd ? cbrk[0] & ~(uint64_t)1 : 0;
        for (int xx = 0; xx < f->W;) {
            const int32_t id = item[xx];
            const unsigned depth = id >= 0 ? lrr__hemi_leaf_depth(h, (size_t)id) : 0;
            const int coded = h->simd && depth >= 1 && depth <= LRR__LEAF_TABLE_DEPTH;
            if (coded && flat) {
                /* one run of one code (cbrk also breaks where the item does): coded_run's sums
                 * in the row's one loop, not a loop per run of the triangle (whose exits are
                 * mispredicted) */
                while (!cbits && ++cw < words)
                    cbits = cbrk[cw];
                const int n = cbits ? cw * 64 + __builtin_ctzll(cbits) : f->W;
                cbits &= cbits - 1;
                row[h->g->patch0[id] + lrr__hemi_leaf_of(crow[xx], h->cells + cell_offset(depth))] +=
                    in.pre[n] - in.pre[xx];
                xx = n;
                continue;
            }
            const int end = next_break(brk, xx + 1, f->W);
            if (h->simd && end < f->W) { /* the cursor past end (a break of both masks) */
                cw = end >> 6;
                cbits = cbrk[cw] & ~((2ull << (end & 63)) - 1);
            } else if (h->simd) {
                cw = words, cbits = 0;
            }
            if (coded) {
                coded_run(&in, (size_t)id, depth, crow, cbrk, xx, end - 1);
            } else if (id >= 0) {
                const int c = id % BARY_CACHE;
                if (id != set_for[c]) {
                    lrr__hemi_bary_setup(&h->tri[id], x, f, &bpc[c]);
                    set_for[c] = id;
                }
                integrate_run(&in, &bpc[c], (size_t)id, sy, xx, end - 1);
            } else if (id == LRR__ITEM_BACK) {
                back += in.pre[end] - in.pre[xx];
            }
            xx = end;
        }
        if (clear) { /* for the next hemicube, while the row is in cache (raster_faces) */
            memset(f->item + in.row0, 0xff, (size_t)f->W * sizeof *f->item);
            memset(f->depth + in.row0, 0, (size_t)f->W * sizeof *f->depth);
        }
    }
    return back;
}

/* The scalar path's change masks (with a SIMD table, its breaks2 makes them) */
void lrr__hemi_breaks(const int32_t *v, int n, uint64_t *mask)
{
    memset(mask, 0, (size_t)(n + 63) / 64 * sizeof *mask);
    for (int x = 0; x < n; x++)
        mask[x >> 6] |= (uint64_t)(x == 0 || v[x] != v[x - 1]) << (x & 63);
}
