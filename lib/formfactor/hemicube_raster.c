/* The hemicube's rasteriser: the input triangles into a face's depth and item buffers
 * (hemicube.c has the receiver and its faces, hemicube_integrate.c the row).
 *
 * Watertightness: triangles are clipped in homogeneous camera space (near plane plus a guard
 * band at ±4 on the sides) so that projected coordinates stay small; edge functions are
 * evaluated in double from a canonical vertex order (so the two triangles sharing an edge
 * compute exactly opposite values) with a top-left tie rule (so a pixel centre on a shared
 * edge belongs to exactly one of them). A closed room's rows then sum to 1 to rounding.
 *
 * With a SIMD table (hemi_ctx.simd) a triangle's rows are spanned several at a time and
 * their depth tests run several pixels at a time, writing the winners' leaf codes; every
 * step is bit-identical to the scalar loop here.
 */
#include "config.h"
#include "formfactor/hemicube_raster.h"

#include <math.h>
#include <string.h>

typedef lrr__hemi_face face;
typedef lrr__hemi_ctx hemi_ctx;

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
    /* each vertex's side once, into d[] */
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
     * r = 1/A (three divisions make 2.9% of a Cornell R 64 profile with edge_setup's rest),
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
 * (measured: that test at every pixel is 44% of a Cornell R 64 profile, most of it on the
 * bounding box's empty half). */
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

#define SPAN_ROWS 64 /* rows per depth_rows call (lrr__hemi_simd) */
#define MIN2(a, b) ((b) < (a) ? (b) : (a))
#define MAX2(a, b) ((b) > (a) ? (b) : (a))

static void raster_tri(svert a, svert b, svert c, int32_t id, int W, int H, float *depth,
                       int32_t *item, const lrr__hemi_codes *lc, const lrr__hemi_simd *simd)
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
    if (simd) { /* the rows' spans, then their depth tests in one call (one per row costs a
                   fifth of depth_span8's time, its set-up) */
        int32_t span[2 * SPAN_ROWS];
        for (int y = y0; y <= y1; y += SPAN_ROWS) {
            const int ye = y1 - y < SPAN_ROWS ? y1 : y + SPAN_ROWS - 1;
            const int left = simd->spans(ee, x0, x1, y, ye, span);
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
            simd->depth_rows(abc, vz, inv_area, y, ye, span, W, depth, item, id, lc);
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
    const unsigned depth = lrr__hemi_leaf_depth(h, t);
    if (h->simd && id >= 0 && depth >= 1 && depth <= LRR__LEAF_TABLE_DEPTH) {
        lrr__bary_plane bp;
        lrr__hemi_bary_setup(&h->tri[t], x, f, &bp);
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

void lrr__hemi_raster_faces(const hemi_ctx *h, const double x[3], const double N[3], face *faces,
                            lrr__hemi_scratch *sc)
{
    const lrr__geometry *g = h->g;
    size_t total = (size_t)h->mm->res * h->mm->res * 3;
    /* 0.0f is all zero bytes and LRR__ITEM_NONE (−1) all 0xff: memset's wide stores instead of
     * the scalar loop gcc -O2 leaves (Cornell R 64 one thread 0.359 against 0.371 s user) */
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
        const lrr__tri_info *ti = &h->tri[t];
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
