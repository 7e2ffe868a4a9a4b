/* Hemicube form factors: one software z-buffer hemicube at each subpatch centre gives one
 * row of F̄ (F̄_ip = F_{i→p}/d_p), docs/METHOD.md "Form factors".
 *
 * Per receiver i with centre x and unit normal N:
 *   - a frame (U, V, N), rotated about N by a pseudo-random angle drawn from (seed, i), so
 *     aliasing of the pixel grid does not line up across receivers yet results are
 *     reproducible whatever the thread count;
 *   - five faces: the top (R×R, looking along N) and four sides (R wide, R/2 high, above the
 *     tangent plane only);
 *   - the *input triangles* are rasterised (not the subdivision), so a hemicube's cost does
 *     not depend on k or d; the item buffer holds the triangle id, and the visible point's
 *     barycentric coordinates in its triangle give the patch;
 *   - back faces write depth and LRR__ITEM_BACK (they occlude but carry nothing);
 *   - row_p = Σ multiplier(pixel) over pixels showing patch p, and the receiver's back-face
 *     share = Σ multiplier(pixel) over pixels showing a back face (the light-leak indicator
 *     of lrr_operator_info: light that should reach the receiver through a surface modelled
 *     the wrong way round is lost), summed in the same pass over the pixels.
 *
 * Watertightness: triangles are clipped in homogeneous camera space (near plane plus a guard
 * band at ±4 on the sides) so that projected coordinates stay small; edge functions are
 * evaluated in double from a canonical vertex order (so the two triangles sharing an edge
 * compute exactly opposite values) with a top-left tie rule (so a pixel centre on a shared
 * edge belongs to exactly one of them). A closed room's rows then sum to 1 to rounding.
 */
#include "config.h"
#include "formfactor/hemicube_private.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ------------------------------------------------------------------ multiplier map */
lrr_status lrr__multiplier_map_create(lrr_context *ctx, unsigned res, lrr__multiplier_map *m)
{
    memset(m, 0, sizeof *m);
    if (res < 8 || res > 4096 || res % 2)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "hemicube resolution %u: must be even and in 8..4096", res);
    lrr_status st;
    size_t rr = (size_t)res * res;
    if ((st = lrr__calloc(ctx, &m->top, rr, sizeof(double), "hemicube top multipliers")))
        return st;
    if ((st = lrr__calloc(ctx, &m->side, rr / 2, sizeof(double), "hemicube side multipliers"))) {
        lrr_aligned_free(m->top);
        return st;
    }
    m->res = res;
    const double h = 2.0 / res, dA = h * h;
    double sum = 0;
    for (unsigned r = 0; r < res; r++)
        for (unsigned c = 0; c < res; c++) {
            double x = -1 + (c + 0.5) * h, y = -1 + (r + 0.5) * h;
            double q = x * x + y * y + 1;
            m->top[(size_t)r * res + c] = dA / (M_PI * q * q);
            sum += m->top[(size_t)r * res + c];
        }
    for (unsigned r = 0; r < res / 2; r++)
        for (unsigned c = 0; c < res; c++) {
            double a = -1 + (c + 0.5) * h, z = (r + 0.5) * h;
            double q = a * a + z * z + 1;
            m->side[(size_t)r * res + c] = z * dA / (M_PI * q * q);
            sum += 4 * m->side[(size_t)r * res + c];
        }
    /* The midpoint rule misses the exact total by O(1/R²); normalise so that a fully covered
     * hemisphere gives exactly 1 (closed scenes must conserve energy). */
    m->raw_sum = sum;
    for (size_t i = 0; i < rr; i++)
        m->top[i] /= sum;
    for (size_t i = 0; i < rr / 2; i++)
        m->side[i] /= sum;
    return LRR_OK;
}

void lrr__multiplier_map_free(lrr__multiplier_map *m)
{
    lrr_aligned_free(m->top);
    lrr_aligned_free(m->side);
    memset(m, 0, sizeof *m);
}

/* ------------------------------------------------------------------ small vector helpers */

/* ------------------------------------------------------------------ per-triangle data */
typedef lrr__tri_info tri_info;
_Static_assert(sizeof(tri_info) == LRR__HEMICUBE_TRI_BYTES, "budget.c counts tri_info's size");

/* ------------------------------------------------------------------ rasteriser */
typedef struct {
    double x, y, iz;             /* pixel coordinates and 1/depth */
} svert;

typedef struct {
    double x, y, z;              /* camera coordinates: z along the face's forward axis */
} cvert;

#define GUARD 4.0
#define MAX_POLY 16

/* Clips polygon p (n vertices) against a·x + b·y + c·z >= 0. Intersections are computed from
 * the lexicographically smaller endpoint so the two triangles sharing an edge get bit-identical
 * new vertices. */
/* Which side of plane (a, b, c, off) p is on: >= 0 kept (clip_plane's one expression). */
static inline double plane_d(const cvert *p, double a, double b, double c, double off)
{
    return a * p->x + b * p->y + c * p->z - off;
}

static int clip_plane(const cvert *in, int n, cvert *out, double a, double b, double c,
                      double off)
{
    /* each vertex's side once (twice, and a % per vertex, before) */
    double d[MAX_POLY];
    for (int i = 0; i < n; i++)
        d[i] = plane_d(&in[i], a, b, c, off);
    int m = 0;
    for (int i = 0; i < n; i++) {
        const int j = i + 1 == n ? 0 : i + 1;
        const cvert *p = &in[i], *q = &in[j];
        double dp = d[i], dq = d[j];
        if (dp >= 0)
            out[m++] = *p;
        if ((dp >= 0) != (dq >= 0)) {
            const cvert *s = p, *e = q;
            double ds = dp, de = dq;
            if (q->x < p->x || (q->x == p->x && (q->y < p->y || (q->y == p->y && q->z < p->z)))) {
                s = q; e = p; ds = dq; de = dp;
            }
            double t = ds / (ds - de);
            out[m].x = s->x + t * (e->x - s->x);
            out[m].y = s->y + t * (e->y - s->y);
            out[m].z = s->z + t * (e->z - s->z);
            m++;
        }
    }
    return m;
}

/* Edge function coefficients A·px + B·py + C for edge a→b, computed from the canonical
 * (lexicographically ordered) endpoints and negated when reversed: exact antisymmetry. */
typedef lrr__hemi_edge edge_fn;

static void edge_setup(const svert *a, const svert *b, int W, int H, edge_fn *e)
{
    int swap = (b->x < a->x) || (b->x == a->x && b->y < a->y);
    const svert *p = swap ? b : a, *q = swap ? a : b;
    double A = -(q->y - p->y), B = q->x - p->x;
    double C = -(A * p->x + B * p->y);
    if (swap) { A = -A; B = -B; C = -C; }
    e->A = A;
    e->B = B;
    e->C = C;
    /* For a positively oriented triangle, own ties on edges whose direction is (dy > 0) or
     * (dy == 0 and dx < 0); the neighbour traverses the edge the other way and does not. */
    double dx = b->x - a->x, dy = b->y - a->y;
    e->owns_ties = dy > 0 || (dy == 0 && dx < 0);
    /* With px <= W, py <= H: the computed A·px + B·py + C is within 3.1u·S of the exact
     * value, S = |A|·W + |B|·H + |C| (u = 2^-53), so it keeps the exact sign beyond
     * 3.1u·S/|A| pixels of the exact crossing; the estimate k0 + k1·py, from one reciprocal
     * r = 1/A (three divisions were 2.9% of a Cornell R 64 profile with edge_setup's rest),
     * two products, a difference and a product and sum, stays within 4u·S/|A| + u of it.
     * 16u·S/|A| covers both. */
    const double S = fabs(A) * W + fabs(B) * H + fabs(C);
    if (A != 0) {
        const double r = 1 / A;
        e->k0 = -C * r - 0.5;
        e->k1 = -B * r;
        e->tol = 16 * 0x1p-53 * S * fabs(r) + 0x1p-30;
    } else {
        e->k0 = e->k1 = 0;
        e->tol = INFINITY;
    }
}

static inline int inside(const edge_fn *e, double v)
{
    return v > 0 || (v == 0 && e->owns_ties);
}

/* The edge function at pixel centre (px, py): the one expression every test uses. */
static inline double edge_at(const edge_fn *e, double px, double py)
{
    return e->A * px + e->B * py + e->C;
}

/* Narrows the row's pixel range [*L, *R] to the pixels inside edge e; 0 when none is left.
 * The computed edge function is monotone in px (each rounding step is), so the inside pixels
 * of a row form one interval: start from the analytic crossing and settle its ends with the
 * exact per-pixel test, so the covered pixels are exactly those of a test at every pixel
 * (measured: that test was 44% of a Cornell R 64 profile, most of it on the bounding box's
 * empty half). */
static inline __attribute__((always_inline)) int edge_span(const edge_fn *e, double py, int *L,
                                                          int *R)
{
    if (e->A == 0) /* constant along the row */
        return inside(e, edge_at(e, *L + 0.5, py));
    double xc = e->k0 + e->k1 * py; /* the crossing, in pixel indices */
    /* every pixel of [L, R] strictly inside beyond the estimate's tolerance: nothing to test
     * (a third of this function's tests on the Cornell box: rows the edge does not bound) */
    if (e->A > 0 ? *L > xc + e->tol : *R < xc - e->tol)
        return 1;
    /* no pixel index within the tolerance of the estimate: the pixels up to n = floor(xc +
     * tol) < xc − tol are strictly on one side, those from n + 1 > xc + tol strictly on the
     * other, without a test (all but a few rows of a Cornell profile) */
    const double lo = xc - e->tol, hi = xc + e->tol;
    if (lo > -0x1p30 && hi < 0x1p30) {
        double n = (double)(int64_t)hi; /* trunc, then floor: */
        n -= n > hi;
        if (n < lo) {
            if (e->A > 0)
                *L = n + 1 > *L ? (int)n + 1 : *L;
            else
                *R = n < *R ? (int)n : *R;
            return *L <= *R;
        }
    }
    if (e->A > 0) { /* inside from some x on */
        int x = !(xc > *L) ? *L : xc >= *R + 1 ? *R + 1 : (int)ceil(xc);
        while (x > *L && inside(e, edge_at(e, (x - 1) + 0.5, py)))
            x--;
        while (x <= *R && !inside(e, edge_at(e, x + 0.5, py)))
            x++;
        *L = x;
    } else { /* inside up to some x */
        int x = !(xc < *R) ? *R : xc <= *L - 1 ? *L - 1 : (int)floor(xc);
        while (x < *R && inside(e, edge_at(e, (x + 1) + 0.5, py)))
            x++;
        while (x >= *L && !inside(e, edge_at(e, x + 0.5, py)))
            x--;
        *R = x;
    }
    return *L <= *R;
}

#define SPAN_ROWS 64 /* rows per lrr__hemi_depth_rows */
#define MIN2(a, b) ((b) < (a) ? (b) : (a))
#define MAX2(a, b) ((b) > (a) ? (b) : (a))

static void raster_tri(svert a, svert b, svert c, int32_t id, int W, int H, float *depth,
                       int32_t *item, const lrr__hemi_codes *lc, int simd)
{
    double area = (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
    if (area == 0 || !isfinite(area))
        return;
    if (area < 0) {
        svert t = b; b = c; c = t;
        area = -area;
    }
    /* the coordinates are finite here (area is), so compares do what libm's fmin and fmax
     * did, without twelve calls a triangle */
    double minx = MIN2(a.x, MIN2(b.x, c.x)), maxx = MAX2(a.x, MAX2(b.x, c.x));
    double miny = MIN2(a.y, MIN2(b.y, c.y)), maxy = MAX2(a.y, MAX2(b.y, c.y));
    int x0 = (int)MAX2(0.0, floor(minx - 0.5)), x1 = (int)MIN2(W - 1.0, ceil(maxx - 0.5));
    int y0 = (int)MAX2(0.0, floor(miny - 0.5)), y1 = (int)MIN2(H - 1.0, ceil(maxy - 0.5));
    if (x0 > x1 || y0 > y1)
        return;
    edge_fn ee[3];
    edge_setup(&b, &c, W, H, &ee[0]); /* weight of a */
    edge_setup(&c, &a, W, H, &ee[1]); /* weight of b */
    edge_setup(&a, &b, W, H, &ee[2]); /* weight of c */
    const edge_fn e0 = ee[0], e1 = ee[1], e2 = ee[2];
    double inv_area = 1.0 / area;
    const double abc[9] = {e0.A, e0.B, e0.C, e1.A, e1.B, e1.C, e2.A, e2.B, e2.C},
                 vz[3] = {a.iz, b.iz, c.iz};
    if (simd) { /* the rows' spans, then their depth tests in one call (one per row was a
                   fifth of depth_span8's time, its set-up) */
        int32_t span[2 * SPAN_ROWS];
        for (int y = y0; y <= y1; y += SPAN_ROWS) {
            const int ye = y1 - y < SPAN_ROWS ? y1 : y + SPAN_ROWS - 1;
            const int left = lrr__hemi_spans(ee, x0, x1, y, ye, span, simd);
            for (int yy = y; left && yy <= ye; yy++) {
                if (span[2 * (yy - y)] != INT32_MIN)
                    continue; /* settled four or eight rows at a time */
                const double py = yy + 0.5;
                int L = x0, R = x1;
                if (!edge_span(&e0, py, &L, &R) || !edge_span(&e1, py, &L, &R) ||
                    !edge_span(&e2, py, &L, &R))
                    L = 1, R = 0;
                span[2 * (yy - y)] = L;
                span[2 * (yy - y) + 1] = R;
            }
            lrr__hemi_depth_rows(abc, vz, inv_area, y, ye, span, W, depth, item, id, lc, simd);
        }
        return;
    }
    for (int y = y0; y <= y1; y++) {
        double py = y + 0.5;
        int L = x0, R = x1;
        if (!edge_span(&e0, py, &L, &R) || !edge_span(&e1, py, &L, &R) ||
            !edge_span(&e2, py, &L, &R))
            continue;
        for (int x = L; x <= R; x++) {
            double px = x + 0.5;
            double w0 = edge_at(&e0, px, py), w1 = edge_at(&e1, px, py),
                   w2 = edge_at(&e2, px, py);
            float iz = (float)((w0 * a.iz + w1 * b.iz + w2 * c.iz) * inv_area);
            size_t pix = (size_t)y * W + x;
            if (iz > depth[pix]) {
                depth[pix] = iz;
                item[pix] = id;
            }
        }
    }
}

/* ------------------------------------------------------------------ one hemicube */
typedef lrr__hemi_face face;
typedef lrr__hemi_ctx hemi_ctx;

/* The barycentric coordinates of the point that pixel (sx, sy) of a face shows on a
 * triangle's plane, as ratios of linear functions of (sx, sy): with dir = sx·right + sy·up +
 * fwd, w0 = v0 − x, c = n·w0 and α_j the dual basis of (e1, e2) (Gram inverse), the ray
 * x + t·dir meets the plane at t = c / n·dir, so b_j = (c·dir·α_j − (w0·α_j)·n·dir) / n·dir.
 * Set up once per face and triangle (the SIMD depth test) or run of pixels showing it (the
 * scalar path): 9 coefficients instead of a ray-plane intersection per pixel (that was 36%
 * of a Cornell R 64 profile). */
typedef struct {
    double b1[3], b2[3], den[3]; /* coefficients of sx, sy, 1 */
} bary_plane;

static void bary_setup(const tri_info *ti, const double x[3], const face *f, bary_plane *bp)
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

/* The leaves of triangle t: depth[t] levels for patches, depth[t] + levels for subpatches. */
static inline unsigned leaf_depth(const hemi_ctx *h, size_t t)
{
    return h->g->depth[t] + (h->by_subpatch ? h->g->levels : 0);
}

/* The patch (or subpatch) of leaf `leaf` of triangle t; the uniform quadtree's inline. */
static inline size_t leaf_target(const hemi_ctx *h, size_t t, size_t leaf)
{
    const lrr__geometry *g = h->g;
    if (h->by_subpatch)
        return lrr__subpatch_id(g, g->sub0[t] + leaf);
    if (!g->origin && !g->node)
        return g->patch0[t] + leaf;
    return lrr__patch_of_leaf(g, t, leaf);
}

/* Triangle t, its vertices v in the face's camera coordinates (raster_faces), into face f. */
static void render_face(const hemi_ctx *h, const double x[3], face *f, size_t t, int32_t id,
                        const cvert v[3])
{
    cvert poly[MAX_POLY], tmp[MAX_POLY];
    memcpy(poly, v, 3 * sizeof *v);
    int n = 3;
    /* trivial rejects before clipping */
    int all_behind = 1, out_l = 1, out_r = 1, out_b = 1, out_t = 1;
    double bottom = f->side ? 0.0 : -1.0;
    for (int i = 0; i < 3; i++) {
        if (poly[i].z >= h->near) all_behind = 0;
        if (poly[i].x >= -poly[i].z) out_l = 0;
        if (poly[i].x <= poly[i].z) out_r = 0;
        if (poly[i].y >= bottom * poly[i].z) out_b = 0;
        if (poly[i].y <= poly[i].z) out_t = 0;
    }
    if (all_behind || out_l || out_r || out_b || out_t)
        return;
    /* a triangle inside every plane is what the clips would copy (most of them) */
    int inside_all = 1;
    for (int i = 0; i < 3; i++)
        inside_all &= plane_d(&poly[i], 0, 0, 1, h->near) >= 0 &&
                      plane_d(&poly[i], 1, 0, GUARD, 0) >= 0 &&
                      plane_d(&poly[i], -1, 0, GUARD, 0) >= 0 &&
                      plane_d(&poly[i], 0, 1, GUARD, 0) >= 0 &&
                      plane_d(&poly[i], 0, -1, GUARD, 0) >= 0;
    if (inside_all) {
        memcpy(tmp, poly, 3 * sizeof *poly);
    } else {
        n = clip_plane(poly, n, tmp, 0, 0, 1, h->near);
        n = clip_plane(tmp, n, poly, 1, 0, GUARD, 0);   /* x >= -G z */
        n = clip_plane(poly, n, tmp, -1, 0, GUARD, 0);  /* x <=  G z */
        n = clip_plane(tmp, n, poly, 0, 1, GUARD, 0);   /* y >= -G z */
        n = clip_plane(poly, n, tmp, 0, -1, GUARD, 0);  /* y <=  G z */
        if (n < 3)
            return;
    }
    svert s[MAX_POLY];
    double half = 0.5 * f->W;
    for (int i = 0; i < n; i++) {
        double iz = 1.0 / tmp[i].z;
        s[i].x = (tmp[i].x * iz + 1) * half;
        s[i].y = f->side ? tmp[i].y * iz * half : (tmp[i].y * iz + 1) * half;
        s[i].iz = iz;
    }
    /* the SIMD depth test writes the leaf codes of a triangle with a cell table (the
       integration then runs no leaf pass for it) */
    lrr__hemi_codes lc, *lcp = NULL;
    const unsigned depth = leaf_depth(h, t);
    if (h->simd && id >= 0 && depth >= 1 && depth <= LRR__LEAF_TABLE_DEPTH) {
        bary_plane bp;
        bary_setup(&h->tri[t], x, f, &bp);
        memcpy(lc.b1, bp.b1, sizeof lc.b1);
        memcpy(lc.b2, bp.b2, sizeof lc.b2);
        memcpy(lc.den, bp.den, sizeof lc.den);
        lc.sxt = h->sx;
        lc.syt = f->sy;
        lc.depth = depth;
        lc.code = f->code;
        lcp = &lc;
    }
    for (int i = 1; i + 1 < n; i++)
        raster_tri(s[0], s[i], s[i + 1], id, f->W, f->H, f->depth, f->item, lcp, h->simd);
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
static lrr_status cell_table(lrr_context *ctx, uint16_t **out)
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
 * scalar path, and the reference of lrr__hemi_leaves_run. */
static inline size_t leaf_at(const bary_plane *bp, double sx, double sy, unsigned depth)
{
    /* one division: two were a quarter of the per-pixel loop's time */
    const double r = 1.0 / (bp->den[0] * sx + bp->den[1] * sy + bp->den[2]);
    double b0, b1 = (bp->b1[0] * sx + bp->b1[1] * sy + bp->b1[2]) * r,
               b2 = (bp->b2[0] * sx + bp->b2[1] * sy + bp->b2[2]) * r;
    lrr__clamp_bary(&b1, &b2, &b0);
    return lrr__descend(&b0, &b1, &b2, depth);
}

/* The row's accumulation: the face's row being integrated, and leaf_target's last answer
 * (adaptive trees search). */
typedef struct {
    const hemi_ctx *h;
    const face *f;
    double *row;
    const double *pre;   /* the face row's prefix sums of the multipliers */
    size_t row0;         /* the face row's first pixel */
    size_t last_leaf, last_p, last_t;
} integ;

/* Pixels x0..x1 of the face row show leaf `leaf` of triangle t: row[p] += their multipliers
 * as a difference of prefix sums (the pixel-order sum's dependency chain was a tenth of a
 * Cornell R 64 profile; relative rounding ~1e-16 of the row's total, far below F̄'s float),
 * or the item buffer gets p. */
static inline void put(integ *in, size_t t, size_t leaf, int x0, int x1)
{
    if (leaf != in->last_leaf || t != in->last_t) {
        in->last_p = leaf_target(in->h, t, leaf);
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

#define CHUNK 256 /* pixels per lrr__hemi_leaves_run */

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
    const unsigned depth = leaf_depth(in->h, t);
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
        lrr__hemi_leaves_run(bp->b1, bp->b2, bp->den, in->h->sx, sy, c, ce, depth, cells, leaf,
                             brk, in->h->simd);
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

static double integrate_face(const hemi_ctx *h, const double x[3], const face *f, double *row,
                             int clear)
{
    const size_t pixels = (size_t)f->W * f->H;
    double back = 0;
    if (h->rc) { /* the ray caster's item buffer holds patches already */
        for (size_t pix = 0; pix < pixels; pix++) {
            int32_t id = f->item[pix];
            if (id >= 0 && row)
                row[id] += f->weight[pix];
            else if (id == LRR__ITEM_BACK)
                back += f->weight[pix];
        }
        return back;
    }
    integ in = {h, f, row, NULL, 0, SIZE_MAX, 0, SIZE_MAX};
    /* leaf_target is patch0[t] + leaf (and rows are summed, not resolved), and no run is
     * longer than coded_run's chunks */
    const int flat = row && !h->by_subpatch && !h->g->origin && !h->g->node && f->W <= CHUNK;
    /* the face's bary_planes by triangle id mod BARY_CACHE: a row's runs alternate between a
     * few triangles (one set-up per run was 5% of a Cornell R 32 profile) */
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
            lrr__hemi_breaks2(item, (const int32_t *)crow, f->W, brk, cbrk, h->simd);
        else
            lrr__hemi_breaks(item, f->W, brk);
        /* cbrk's set bits after xx: the word cw, what is left of it in cbits (a cursor,
         * not next_break from xx each time, whose chain through xx bound the loop) */
        const int words = (f->W + 63) / 64;
        int cw = 0;
        uint64_t cbits = h->simd ? cbrk[0] & ~(uint64_t)1 : 0;
        for (int xx = 0; xx < f->W;) {
            const int32_t id = item[xx];
            const unsigned depth = id >= 0 ? leaf_depth(h, (size_t)id) : 0;
            const int coded = h->simd && depth >= 1 && depth <= LRR__LEAF_TABLE_DEPTH;
            if (coded && flat) {
                /* one run of one code (cbrk also breaks where the item does): coded_run's sums
                 * in the row's one loop, not a loop per run of the triangle (whose exits were
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
                    bary_setup(&h->tri[id], x, f, &bpc[c]);
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

typedef struct {
    float *depth;
    int32_t *item;
    uint32_t *code;
    double *row;
    int clean; /* depth 0 and item LRR__ITEM_NONE everywhere (integrate_face left them so) */
} scratch;

/* Rasterises every input triangle into the five faces (cost ∝ triangles). */
static void raster_faces(const hemi_ctx *h, const double x[3], const double N[3], face *faces,
                         scratch *sc)
{
    const lrr__geometry *g = h->g;
    size_t total = (size_t)h->mm->res * h->mm->res * 3;
    /* 0.0f is all zero bytes and LRR__ITEM_NONE (−1) all 0xff: memset's wide stores instead of
     * the scalar loop gcc -O2 left (Cornell R 64 one thread 0.371 → 0.359 s user) */
    _Static_assert(LRR__ITEM_NONE == -1, "memset fills the item buffer with 0xff bytes");
    if (!sc->clean) {
        memset(sc->depth, 0, total * sizeof *sc->depth);
        memset(sc->item, 0xff, total * sizeof *sc->item);
    }
    sc->clean = 0;
    /* The faces' axes are the frame's up to sign: top (U, V, N); sides up N, forward ±U or
     * ±V, right N × forward = ±(N × U) or ±(N × V) (a sign commutes with every rounding of
     * cross3 and dot3), so five dot products a vertex give all fifteen coordinates exactly as
     * fifteen would (render_face made them per face). */
    const double *U = faces[0].right, *V = faces[0].up, *RU = faces[1].right,
                 *RV = faces[3].right;
    for (size_t t = 0; t < g->n_tri; t++) {
        const tri_info *ti = &h->tri[t];
        const float *tv = g->vert + 9 * t;
        double du[3], dv[3], dn[3], dru[3], drv[3];
        /* wholly behind (or in) the tangent plane: cannot be seen */
        int any_above = 0;
        for (int c = 0; c < 3; c++) {
            double d[3] = {tv[3 * c] - x[0], tv[3 * c + 1] - x[1], tv[3 * c + 2] - x[2]};
            dn[c] = lrr__dot3(d, N);
            if (dn[c] > h->eps)
                any_above = 1;
            du[c] = lrr__dot3(d, U), dv[c] = lrr__dot3(d, V);
            dru[c] = lrr__dot3(d, RU), drv[c] = lrr__dot3(d, RV);
        }
        if (!any_above)
            continue;
        double w0[3] = {x[0] - ti->v0[0], x[1] - ti->v0[1], x[2] - ti->v0[2]};
        double side = lrr__dot3(w0, ti->n) / sqrt(lrr__dot3(ti->n, ti->n));
        if (fabs(side) <= h->eps)
            continue; /* x lies in the triangle's plane: seen edge-on */
        int32_t id = side > 0 ? (int32_t)t : LRR__ITEM_BACK;
        cvert v[5][3];
        for (int c = 0; c < 3; c++) {
            v[0][c] = (cvert){du[c], dv[c], dn[c]};
            v[1][c] = (cvert){dru[c], dn[c], du[c]};
            v[2][c] = (cvert){-dru[c], dn[c], -du[c]};
            v[3][c] = (cvert){drv[c], dn[c], dv[c]};
            v[4][c] = (cvert){-drv[c], dn[c], -dv[c]};
        }
        for (int fi = 0; fi < 5; fi++)
            render_face(h, x, &faces[fi], t, id, v[fi]);
    }
}

/* Receiver i's centre x, unit normal N and tangent frame (U, V): rotated about N by an angle
 * drawn from (seed, i) when rotate. */
static void receiver_frame(const lrr__geometry *g, size_t i, uint64_t seed, int rotate,
                           double x[3], double N[3], double U[3], double Vv[3])
{
    double v[9];
    lrr__subpatch_vertices(g, i, v);
    double e1[3], e2[3];
    for (int j = 0; j < 3; j++) {
        x[j] = (v[j] + v[3 + j] + v[6 + j]) / 3;
        e1[j] = v[3 + j] - v[j];
        e2[j] = v[6 + j] - v[j];
    }
    lrr__cross3(e1, e2, N);
    lrr__normalize3(N);
    /* tangent frame, then the per-receiver random rotation about N */
    double helper[3] = {1, 0, 0};
    if (fabs(N[0]) > 0.6) { helper[0] = 0; helper[1] = 1; }
    double U0[3], V0[3];
    lrr__cross3(helper, N, U0);
    lrr__normalize3(U0);
    lrr__cross3(N, U0, V0);
    /* drawn from the subpatch's scene-order index, so a cluster hierarchy's renumbering
     * leaves every receiver's hemicube as it was */
    const size_t id = g->origin ? g->origin[i] : i;
    double theta =
        rotate ? 2 * M_PI * (double)(lrr__splitmix64(seed ^ lrr__splitmix64(id)) >> 11) *
                     0x1.0p-53
               : 0;
    double ct = cos(theta), st = sin(theta);
    for (int j = 0; j < 3; j++)
        U[j] = ct * U0[j] + st * V0[j];
    lrr__cross3(N, U, Vv);
}

/* Receiver i's row into out (NULL: patch ids into sc->item for the device); its back-face
 * share into *back when back is not NULL. */
static void hemicube_row(const hemi_ctx *h, size_t i, uint64_t seed, int rotate, scratch *sc,
                         float *out, double *back)
{
    const lrr__geometry *g = h->g;
    unsigned R = h->mm->res;
    double x[3], N[3], U[3], Vv[3];
    receiver_frame(g, i, seed, rotate, x, N, U, Vv);

    size_t rr = (size_t)R * R;
    face faces[5];
    for (int fi = 0; fi < 5; fi++) {
        face *f = &faces[fi];
        f->W = (int)R;
        f->H = fi == 0 ? (int)R : (int)R / 2;
        f->side = fi != 0;
        f->sy = fi == 0 ? h->sy_top : h->sy_side;
        f->weight = fi == 0 ? h->mm->top : h->mm->side;
        f->prefix = fi == 0 ? h->pre_top : h->pre_side;
        f->depth = sc->depth + (fi == 0 ? 0 : rr + (size_t)(fi - 1) * rr / 2);
        f->item = sc->item + (fi == 0 ? 0 : rr + (size_t)(fi - 1) * rr / 2);
        f->code = sc->code + (fi == 0 ? 0 : rr + (size_t)(fi - 1) * rr / 2);
        if (fi == 0) {
            memcpy(f->fwd, N, sizeof N);
            memcpy(f->right, U, sizeof U);
            memcpy(f->up, Vv, sizeof Vv);
        } else {
            const double *ax = (fi == 1 || fi == 2) ? U : Vv;
            double sgn = (fi == 1 || fi == 3) ? 1 : -1;
            for (int j = 0; j < 3; j++)
                f->fwd[j] = sgn * ax[j];
            memcpy(f->up, N, sizeof N);
            lrr__cross3(f->up, f->fwd, f->right);
        }
    }
    if (h->rc) {
        /* area sampling: the points are drawn from (seed, the scene-order id, face, pixel),
         * so a row does not depend on the threads or a cluster renumbering */
        double corners[9];
        if (h->area_origins)
            lrr__subpatch_vertices(g, i, corners);
        const uint64_t key = lrr__splitmix64(seed ^ lrr__splitmix64(
                                 0x5bd1e995u + (g->origin ? g->origin[i] : i)));
        for (int fi = 0; fi < 5; fi++)
            lrr__raycast_face(h, x, N, h->area_origins ? corners : NULL,
                              lrr__splitmix64(key + (uint64_t)fi), &faces[fi]);
    } else {
        raster_faces(h, x, N, faces, sc);
    }
    size_t cols = h->by_subpatch ? g->n : g->k;
    if (out)
        memset(sc->row, 0, cols * sizeof(double));
    double back_sum = 0;
    /* the CPU's own buffers are cleared as they are integrated (a memset of both a hemicube
     * was 2.5% of a Cornell R 64 profile); the device's item buffers are its input */
    const int clear = out && !h->rc;
    for (int fi = 0; fi < 5; fi++)
        back_sum += integrate_face(h, x, &faces[fi], out ? sc->row : NULL, clear);
    sc->clean = clear;
    if (back)
        *back = back_sum;
    if (!out) /* device integration: the item buffer now holds patch ids */
        return;
    if (h->by_subpatch) {
        for (size_t p = 0; p < cols; p++)
            out[p] = (float)sc->row[p];
    } else if (g->d) {
        double scale = 1.0 / (double)g->d;
        for (size_t p = 0; p < cols; p++)
            out[p] = (float)(sc->row[p] * scale);
    } else { /* adaptive: F̄_ip = F_{i→p} / d_p */
        for (size_t p = 0; p < cols; p++)
            out[p] = (float)(sc->row[p] / (double)lrr__patch_size(g, p));
    }
}

lrr_status lrr__build_options_resolve(const lrr_scene *scene, const lrr_build_options *opts,
                                      lrr_build_options *o)
{
    if (!scene->geom.depth)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG,
                          "the scene is not subdivided: call lrr_scene_subdivide first");
    memset(o, 0, sizeof *o);
    o->size = sizeof *o;
    lrr_status st;
    if (opts && (st = lrr__options_read(scene->ctx, opts, sizeof *o,
                                        LRR__FIRST_SIZE(lrr_build_options, formfactor_method), o,
                                        "lrr_build_options")))
        return st;
    if (o->hemicube_resolution == 0)
        o->hemicube_resolution = 128;
    if (o->threads < 0)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG, "threads = %d: must be >= 0",
                          o->threads);
    if (o->hierarchy != LRR_HIERARCHY_QUADTREE && o->hierarchy != LRR_HIERARCHY_CLUSTER)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG,
                          "hierarchy = %d: must be LRR_HIERARCHY_QUADTREE or _CLUSTER",
                          o->hierarchy);
    if (o->hierarchy == LRR_HIERARCHY_CLUSTER && o->adaptive_patches == 0)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG,
                          "hierarchy = LRR_HIERARCHY_CLUSTER needs adaptive_patches (the "
                          "cluster count K) > 0");
    int method = LRR_FORMFACTOR_RASTER;
    return lrr__formfactor_method(scene->ctx, &scene->geom, o, &method);
}

static lrr_status rows_impl(lrr_context *ctx, const lrr__geometry *g,
                            const lrr_build_options *opts, int by_subpatch, const size_t *rows,
                            size_t count, float *out, double *back);

lrr_status lrr__hemicube_fbar(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, float *fbar, double *back)
{
    return rows_impl(ctx, g, opts, 0, NULL, g->n, fbar, back);
}

/* Batches of hemicubes are rasterised and resolved to patch ids on the CPU (OpenMP, each
 * receiver straight into its slice of the batch's id buffer), then integrated on the device.
 * A batch is at most 256 hemicubes and 64 MiB of ids. */
static lrr_status device_rows(lrr_context *ctx, const hemi_ctx *h, const lrr_build_options *opts,
                              float *out, double *back)
{
    const lrr__geometry *g = h->g;
    const unsigned R = h->mm->res;
    const size_t P = 3 * (size_t)R * R;
    if (g->k > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "k = %zu patches: the device integration uses int32 patch ids", g->k);
    size_t batch = ((size_t)64 << 20) / (P * sizeof(int32_t));
    if (batch > 256)
        batch = 256;
    if (batch < 1)
        batch = 1;
    if (batch > g->n)
        batch = g->n ? g->n : 1;
    lrr__cl_hemi *dev;
    /* an adaptive hierarchy's 1/d_p is applied here after the device's sums */
    lrr_status st = lrr__cl_hemi_create(ctx, h->mm, g->k, g->d ? g->d : 1, batch, &dev);
    if (st)
        return st;
    int32_t *ids;
    if ((st = lrr__calloc(ctx, &ids, batch, P * sizeof(int32_t), "hemicube id batch"))) {
        lrr__cl_hemi_destroy(dev);
        return st;
    }
    int nthreads = opts->threads > 0 ? opts->threads : omp_get_max_threads();
    for (size_t i0 = 0; i0 < g->n && !st; i0 += batch) {
        const size_t i1 = i0 + batch < g->n ? i0 + batch : g->n;
        volatile int failed = 0;
        #pragma omp parallel num_threads(nthreads)
        {
            scratch sc = {0};
            if (lrr__calloc(ctx, &sc.depth, P, sizeof(float), "hemicube depth buffer") ||
                lrr__calloc(ctx, &sc.code, P, sizeof(uint32_t), "hemicube code buffer")) {
                #pragma omp atomic write
                failed = 1;
            }
            #pragma omp for schedule(dynamic, 4)
            for (size_t i = i0; i < i1; i++) {
                if (failed)
                    continue;
                sc.item = ids + (i - i0) * P;
                hemicube_row(h, i, opts->seed, !opts->no_rotation, &sc, NULL,
                             back ? back + i : NULL);
            }
            lrr_aligned_free(sc.depth);
            lrr_aligned_free(sc.code);
        }
        if (failed) {
            st = LRR_ERR_NOMEM;
            break;
        }
        if ((st = lrr__cl_hemi_rows(dev, ids, i1 - i0, out + i0 * g->k)))
            break;
        if (!g->d)
            for (size_t i = i0; i < i1; i++)
                for (size_t p = 0; p < g->k; p++)
                    out[i * g->k + p] =
                        (float)((double)out[i * g->k + p] / (double)lrr__patch_size(g, p));
        if (opts->progress && opts->progress(opts->progress_user, i1, g->n))
            st = lrr__error(ctx, LRR_ERR_CANCELLED,
                            "form-factor build cancelled after %zu of %zu receivers", i1, g->n);
    }
    lrr_aligned_free(ids);
    lrr__cl_hemi_destroy(dev);
    return st;
}

lrr_status lrr__hemicube_rows(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, int by_subpatch, float *out)
{
    return rows_impl(ctx, g, opts, by_subpatch, NULL, g->n, out, NULL);
}

lrr_status lrr__hemicube_sample_rows(lrr_context *ctx, const lrr__geometry *g,
                                     const lrr_build_options *opts, const size_t *rows,
                                     size_t count, float *out)
{
    lrr_build_options o = *opts;
    o.backend = LRR_BACKEND_CPU; /* subpatch columns are integrated on the CPU only */
    o.progress = NULL;
    return rows_impl(ctx, g, &o, 1, rows, count, out, NULL);
}

/* The per-triangle table of g and the diagonal of its bounding box. */
static lrr_status tri_table(lrr_context *ctx, const lrr__geometry *g, tri_info **out,
                            double *diag)
{
    tri_info *tri;
    lrr_status st = lrr__calloc(ctx, &tri, g->n_tri, sizeof *tri, "triangle table");
    if (st)
        return st;
    for (size_t t = 0; t < g->n_tri; t++) {
        const float *v = g->vert + 9 * t;
        tri_info *ti = &tri[t];
        for (int j = 0; j < 3; j++) {
            ti->v0[j] = v[j];
            ti->e1[j] = (double)v[3 + j] - v[j];
            ti->e2[j] = (double)v[6 + j] - v[j];
        }
        lrr__cross3(ti->e1, ti->e2, ti->n);
        ti->g11 = lrr__dot3(ti->e1, ti->e1);
        ti->g12 = lrr__dot3(ti->e1, ti->e2);
        ti->g22 = lrr__dot3(ti->e2, ti->e2);
        ti->inv = 1.0 / (ti->g11 * ti->g22 - ti->g12 * ti->g12);
    }
    *diag = lrr__geometry_bounds(g, NULL, NULL);
    *out = tri;
    return LRR_OK;
}

/* The multiplier maps' running sums per row, R + 1 from 0: the top's R rows, then the
 * side's R/2 (integrate_face sums a run of pixels as a difference of two). */
static lrr_status prefix_maps(lrr_context *ctx, const lrr__multiplier_map *mm, double **out)
{
    const size_t R = mm->res, rows = R + R / 2;
    double *pre;
    lrr_status st = lrr__calloc(ctx, &pre, rows, (R + 1) * sizeof *pre, "hemicube prefix sums");
    if (st)
        return st;
    for (size_t y = 0; y < rows; y++) {
        const double *w = y < R ? mm->top + y * R : mm->side + (y - R) * R;
        double *p = pre + y * (R + 1), acc = 0;
        p[0] = 0;
        for (size_t x = 0; x < R; x++)
            p[x + 1] = acc += w[x];
    }
    *out = pre;
    return LRR_OK;
}

/* rows (or 0..count-1 when NULL) on the CPU, OpenMP over receivers. */
static lrr_status cpu_rows(lrr_context *ctx, const hemi_ctx *h, const lrr_build_options *opts,
                           const size_t *rows, size_t count, float *out, double *back)
{
    const size_t rr = (size_t)h->mm->res * h->mm->res;
    const size_t cols = h->by_subpatch ? h->g->n : h->g->k;
    int nthreads = opts->threads > 0 ? opts->threads : omp_get_max_threads();
    volatile int cancelled = 0, failed = 0;
    size_t done = 0;
    double last_report = lrr__now();
    #pragma omp parallel num_threads(nthreads)
    {
        scratch sc = {0};
        int ok = lrr__calloc(ctx, &sc.depth, rr * 3, sizeof(float), "hemicube depth buffer") == 0 &&
                 lrr__calloc(ctx, &sc.item, rr * 3, sizeof(int32_t), "hemicube item buffer") == 0 &&
                 lrr__calloc(ctx, &sc.code, rr * 3, sizeof(uint32_t), "hemicube code buffer") == 0 &&
                 lrr__calloc(ctx, &sc.row, cols, sizeof(double), "hemicube row") == 0;
        if (!ok) {
            #pragma omp atomic write
            failed = 1;
        }
        #pragma omp for schedule(dynamic, 16)
        for (size_t r = 0; r < count; r++) {
            if (cancelled || failed)
                continue;
            hemicube_row(h, rows ? rows[r] : r, opts->seed, !opts->no_rotation, &sc,
                         out + r * cols, back ? back + r : NULL);
            size_t now_done;
            #pragma omp atomic capture
            now_done = ++done;
            if (opts->progress && omp_get_thread_num() == 0) {
                double t = lrr__now();
                if (t - last_report > 0.05 || now_done == count) {
                    last_report = t;
                    if (opts->progress(opts->progress_user, now_done, count)) {
                        #pragma omp atomic write
                        cancelled = 1;
                    }
                }
            }
        }
        lrr_aligned_free(sc.depth);
        lrr_aligned_free(sc.item);
        lrr_aligned_free(sc.code);
        lrr_aligned_free(sc.row);
    }
    if (failed)
        return LRR_ERR_NOMEM;
    if (cancelled)
        return lrr__error(ctx, LRR_ERR_CANCELLED, "form-factor build cancelled after %zu of %zu "
                          "receivers", done, count);
    if (opts->progress)
        opts->progress(opts->progress_user, count, count);
    return LRR_OK;
}

static lrr_status rows_impl(lrr_context *ctx, const lrr__geometry *g,
                            const lrr_build_options *opts, int by_subpatch, const size_t *rows,
                            size_t count, float *out, double *back)
{
    unsigned R = opts->hemicube_resolution ? opts->hemicube_resolution : 128;
    const int on_device = opts->backend == LRR_BACKEND_OPENCL;
    if (opts->backend != 0 && opts->backend != LRR_BACKEND_CPU && !on_device)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "build backend %d: must be 0, LRR_BACKEND_CPU or LRR_BACKEND_OPENCL",
                          opts->backend);
    if (on_device && by_subpatch)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "the full form-factor matrix (lrr_reference_build) is integrated on "
                          "the CPU only: use backend LRR_BACKEND_CPU");
    if (g->n_tri > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "%zu triangles: the item buffer holds int32 ids",
                          g->n_tri);
    int method = LRR_FORMFACTOR_RASTER;
    lrr_status st = lrr__formfactor_method(ctx, g, opts, &method);
    if (st)
        return st;
    if (method == LRR_FORMFACTOR_RAYCAST && (by_subpatch ? g->n : g->k) > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "%zu %s: ray casting keeps int32 ids per pixel",
                          by_subpatch ? g->n : g->k, by_subpatch ? "subpatches" : "patches");
    lrr__multiplier_map mm;
    if ((st = lrr__multiplier_map_create(ctx, R, &mm)))
        return st;
    tri_info *tri;
    double diag;
    if ((st = tri_table(ctx, g, &tri, &diag))) {
        lrr__multiplier_map_free(&mm);
        return st;
    }
    lrr__raycaster *rc = NULL;
    if (method == LRR_FORMFACTOR_RAYCAST && (st = lrr__raycaster_create(ctx, g, diag, &rc))) {
        lrr_aligned_free(tri);
        lrr__multiplier_map_free(&mm);
        return st;
    }
    /* Distances below ~1e-7 of the scene size are float rounding of the input coordinates:
     * treat such points as lying in the plane (edge-on / tangent), and put the near plane
     * there too so touching geometry (a block on the floor) is still seen up close. */
    uint16_t *cells = NULL;
    double *sx = NULL, *pre = NULL;
    if (!rc && ((st = cell_table(ctx, &cells)) ||
                (st = lrr__calloc(ctx, &sx, 3 * (size_t)R, sizeof *sx, "hemicube pixel columns")) ||
                (st = prefix_maps(ctx, &mm, &pre)))) {
        lrr_aligned_free(sx);
        lrr_aligned_free(cells);
        lrr_aligned_free(tri);
        lrr__multiplier_map_free(&mm);
        return st;
    }
    hemi_ctx h = {g, tri, &mm, 1e-7 * diag, 1e-7 * diag, by_subpatch, rc, lrr__hemi_simd(),
                  cells, sx, sx ? sx + R : NULL, sx ? sx + 2 * (size_t)R : NULL, pre,
                  pre ? pre + (size_t)R * (R + 1) : NULL,
                  lrr__receiver_sampling(opts, method) == LRR_RECEIVER_AREA};
    /* pixel column x looks along sx = (x + 0.5)/(R/2) − 1 (every face is R wide), row y
     * along sy = that on the top face, (y + 0.5)/(R/2) on a side (a division per row of each
     * triangle in the depth test, else) */
    for (unsigned c = 0; sx && c < R; c++) {
        const double half = 0.5 * R;
        sx[c] = (c + 0.5) / half - 1;
        sx[R + c] = (c + 0.5) / half - 1;
        sx[2 * (size_t)R + c] = (c + 0.5) / half;
    }
    /* the device integration takes the same item buffers, rasterised or ray cast */
    st = on_device ? device_rows(ctx, &h, opts, out, back)
                   : cpu_rows(ctx, &h, opts, rows, count, out, back);
    if (rc) {
        lrr_status rst = lrr__raycaster_status(ctx, rc);
        if (!st)
            st = rst;
        lrr__raycaster_destroy(rc);
    }
    lrr_aligned_free(pre);
    lrr_aligned_free(sx);
    lrr_aligned_free(cells);
    lrr_aligned_free(tri);
    lrr__multiplier_map_free(&mm);
    return st;
}
