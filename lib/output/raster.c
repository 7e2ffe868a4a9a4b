/* The software z-buffer rasteriser: subpatches clipped against a guard-band frustum and
 * projected to fixed-point screen triangles, then drawn band by band with Gouraud-
 * interpolated radiosity. */
#include "config.h"
#include "output/render_internal.h"

#include <math.h>

/* Sub-pixel precision of the fixed-point rasteriser: integer edge functions are exact, so
 * triangles sharing an edge cover every pixel exactly once (no cracks, no double hits). */
#define SUBPIX_BITS 8
#define SUBPIX (1 << SUBPIX_BITS)
/* Clip against a frustum this many times wider than the screen: keeps fixed-point
 * coordinates small while rarely cutting triangles that are only partly off screen. */
#define GUARD_BAND 2.0
#define BAND_ROWS 16
#define MAX_CLIP_VERTS 9

/* A clip-space vertex with its colour; colour is linear in clip space, so clipping may
 * interpolate it linearly. */
typedef struct cvert {
    double x, y, w;
    double c[3];
} cvert;

/* ------------------------------------------------------------------ triangle setup */

/* Sutherland–Hodgman against one plane: keeps d(v) = pl[0]·x + pl[1]·y + pl[2]·w - pl[3]
 * >= 0. */
static int clip_plane(const cvert *in, int m, cvert *out, const double pl[4])
{
    int k = 0;
    for (int i = 0; i < m; i++) {
        const cvert *p = &in[i], *q = &in[(i + 1) % m];
        double dp = pl[0] * p->x + pl[1] * p->y + pl[2] * p->w - pl[3];
        double dq = pl[0] * q->x + pl[1] * q->y + pl[2] * q->w - pl[3];
        if (dp >= 0)
            out[k++] = *p;
        if ((dp >= 0) != (dq >= 0)) {
            /* always from the inside end: the neighbour sharing this edge walks it the other
             * way and must get the bit-identical point, or a crack opens along the cut */
            const cvert *a = dp >= 0 ? p : q, *b = dp >= 0 ? q : p;
            double da = dp >= 0 ? dp : dq, db = dp >= 0 ? dq : dp;
            double t = da / (da - db);
            cvert *r = &out[k++];
            r->x = a->x + t * (b->x - a->x);
            r->y = a->y + t * (b->y - a->y);
            r->w = a->w + t * (b->w - a->w);
            for (int j = 0; j < 3; j++)
                r->c[j] = a->c[j] + t * (b->c[j] - a->c[j]);
        }
    }
    return k;
}

static int inside_all(const cvert *v, double near)
{
    return v->w >= near && fabs(v->x) <= GUARD_BAND * v->w && fabs(v->y) <= GUARD_BAND * v->w;
}

/* Clips, projects and fills up to MAX_CLIP_VERTS-2 screen triangles for subpatch id (out may
 * be NULL to count). Back faces give none. */
int lrr__render_setup_subpatch(const lrr__camera *cam, unsigned width, unsigned height,
                               uint32_t id, const double *pos, const uint32_t *corner_vertex,
                               const float *vcol, lrr__rtri *out)
{
    const double *p = pos + 9 * (size_t)id;
    double e1[3], e2[3], nrm[3], to_eye[3];
    for (int j = 0; j < 3; j++) {
        e1[j] = p[3 + j] - p[j];
        e2[j] = p[6 + j] - p[j];
        to_eye[j] = cam->eye[j] - p[j];
    }
    lrr__cross3(e1, e2, nrm);
    if (!(lrr__dot3(nrm, to_eye) > 0)) /* one-sided: front is counter-clockwise */
        return 0;

    cvert poly[2][MAX_CLIP_VERTS];
    int m = 3, all_in = 1;
    for (int k = 0; k < 3; k++) {
        double d[3] = {p[3 * k] - cam->eye[0], p[3 * k + 1] - cam->eye[1],
                       p[3 * k + 2] - cam->eye[2]};
        cvert *v = &poly[0][k];
        v->x = lrr__dot3(d, cam->right) / cam->tan_x;
        v->y = lrr__dot3(d, cam->up) / cam->tan_y;
        v->w = lrr__dot3(d, cam->fwd);
        const float *c = vcol + 3 * (size_t)corner_vertex[3 * (size_t)id + k];
        for (int j = 0; j < 3; j++)
            v->c[j] = c[j];
        all_in &= inside_all(v, cam->near);
    }
    int cur = 0;
    if (!all_in) {
        /* w >= near, then the guard-band sides -g·w <= x, y <= g·w */
        const double g = GUARD_BAND, planes[5][4] = {{0, 0, 1, cam->near}, {-1, 0, g, 0},
                                                     {1, 0, g, 0}, {0, -1, g, 0}, {0, 1, g, 0}};
        for (int pl = 0; pl < 5 && m >= 3; pl++) {
            m = clip_plane(poly[cur], m, poly[1 - cur], planes[pl]);
            cur = 1 - cur;
        }
        if (m < 3)
            return 0;
    }

    /* project to fixed-point pixels (y down) */
    int64_t sx[MAX_CLIP_VERTS], sy[MAX_CLIP_VERTS];
    float iw[MAX_CLIP_VERTS];
    for (int k = 0; k < m; k++) {
        const cvert *v = &poly[cur][k];
        double inv = 1.0 / v->w;
        sx[k] = llround((0.5 + 0.5 * v->x * inv) * width * SUBPIX);
        sy[k] = llround((0.5 - 0.5 * v->y * inv) * height * SUBPIX);
        iw[k] = (float)inv;
    }
    int count = 0;
    for (int k = 1; k + 1 < m; k++) {
        int idx[3] = {0, k, k + 1};
        int64_t area = (sx[idx[1]] - sx[idx[0]]) * (sy[idx[2]] - sy[idx[0]]) -
                       (sy[idx[1]] - sy[idx[0]]) * (sx[idx[2]] - sx[idx[0]]);
        if (area == 0)
            continue;
        if (area < 0) { /* mirror images and rounding may flip the winding on screen */
            int t = idx[1]; idx[1] = idx[2]; idx[2] = t;
            area = -area;
        }
        int64_t xmin = sx[idx[0]], xmax = xmin, ymin = sy[idx[0]], ymax = ymin;
        for (int a = 1; a < 3; a++) {
            if (sx[idx[a]] < xmin) xmin = sx[idx[a]];
            if (sx[idx[a]] > xmax) xmax = sx[idx[a]];
            if (sy[idx[a]] < ymin) ymin = sy[idx[a]];
            if (sy[idx[a]] > ymax) ymax = sy[idx[a]];
        }
        /* pixels whose centres (px + 1/2) may lie inside */
        double x0 = ceil((double)(xmin - SUBPIX / 2) / SUBPIX);
        double x1 = floor((double)(xmax - SUBPIX / 2) / SUBPIX);
        double y0 = ceil((double)(ymin - SUBPIX / 2) / SUBPIX);
        double y1 = floor((double)(ymax - SUBPIX / 2) / SUBPIX);
        x0 = fmax(x0, 0); y0 = fmax(y0, 0);
        x1 = fmin(x1, width - 1.0); y1 = fmin(y1, height - 1.0);
        if (x0 > x1 || y0 > y1)
            continue;
        if (out) {
            lrr__rtri *t = &out[count];
            for (int a = 0; a < 3; a++) {
                const cvert *v = &poly[cur][idx[a]];
                t->x[a] = sx[idx[a]];
                t->y[a] = sy[idx[a]];
                t->iw[a] = iw[idx[a]];
                for (int j = 0; j < 3; j++)
                    t->c[a][j] = (float)(v->c[j] * iw[idx[a]]);
            }
            t->area = area;
            t->id = id;
            t->x0 = (int32_t)x0; t->x1 = (int32_t)x1;
            t->y0 = (int32_t)y0; t->y1 = (int32_t)y1;
        }
        count++;
    }
    return count;
}

/* ------------------------------------------------------------------ rasterisation */

/* Top-left fill rule for edge a→b of a positively oriented triangle: an edge's points
 * belong to exactly one of the two triangles sharing it. */
static int64_t edge_bias(int64_t ax, int64_t ay, int64_t bx, int64_t by)
{
    int64_t dx = bx - ax, dy = by - ay;
    return (dy > 0 || (dy == 0 && dx < 0)) ? 0 : -1;
}

static void raster_tri(lrr__framebuffer *fb, const lrr__rtri *t, int row0, int row1)
{
    int y0 = t->y0 > row0 ? t->y0 : row0, y1 = t->y1 < row1 ? t->y1 : row1;
    if (y0 > y1)
        return;
    /* edge e is opposite vertex e: its function is that vertex's barycentric weight */
    static const int ea[3] = {1, 2, 0}, eb[3] = {2, 0, 1};
    int64_t ex[3], ey[3], bias[3], e0[3];
    int64_t px0 = (int64_t)t->x0 * SUBPIX + SUBPIX / 2, py0 = (int64_t)y0 * SUBPIX + SUBPIX / 2;
    for (int e = 0; e < 3; e++) {
        int a = ea[e], b = eb[e];
        ex[e] = t->x[b] - t->x[a];
        ey[e] = t->y[b] - t->y[a];
        bias[e] = edge_bias(t->x[a], t->y[a], t->x[b], t->y[b]);
        e0[e] = ex[e] * (py0 - t->y[a]) - ey[e] * (px0 - t->x[a]);
    }
    double inv_area = 1.0 / (double)t->area;
    for (int y = y0; y <= y1; y++) {
        int64_t f[3];
        for (int e = 0; e < 3; e++)
            f[e] = e0[e] + ex[e] * SUBPIX * (y - y0);
        size_t row = (size_t)y * fb->width;
        for (int x = t->x0; x <= t->x1; x++) {
            if (f[0] + bias[0] >= 0 && f[1] + bias[1] >= 0 && f[2] + bias[2] >= 0) {
                double l0 = f[0] * inv_area, l1 = f[1] * inv_area, l2 = f[2] * inv_area;
                double iw = l0 * t->iw[0] + l1 * t->iw[1] + l2 * t->iw[2];
                size_t pix = row + (size_t)x;
                if (iw > fb->depth[pix]) {
                    fb->depth[pix] = (float)iw;
                    double s = 1.0 / iw;
                    for (int j = 0; j < 3; j++) {
                        double c = (l0 * t->c[0][j] + l1 * t->c[1][j] + l2 * t->c[2][j]) * s;
                        fb->rgb[3 * pix + j] = c > 0 ? (float)c : 0.0f;
                    }
                    fb->id[pix] = t->id + 1;
                }
            }
            for (int e = 0; e < 3; e++)
                f[e] -= ey[e] * SUBPIX;
        }
    }
}

/* Bins the triangles by bands of BAND_ROWS rows and rasterises the bands in parallel: each
 * band is written by one thread only. */
lrr_status lrr__render_raster_all(lrr_context *ctx, lrr__framebuffer *fb,
                                  const lrr__rtri *tris, size_t nt)
{
    size_t nb = (fb->height + BAND_ROWS - 1) / BAND_ROWS;
    size_t *start = NULL, *list = NULL, total = 0;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &start, nb + 1, sizeof *start, "render: band index")))
        return st;
    for (size_t i = 0; i < nt; i++)
        for (size_t b = (size_t)tris[i].y0 / BAND_ROWS; b <= (size_t)tris[i].y1 / BAND_ROWS; b++)
            start[b + 1]++;
    for (size_t b = 0; b < nb; b++)
        start[b + 1] += start[b];
    total = start[nb];
    if ((st = lrr__calloc(ctx, &list, total, sizeof *list, "render: band lists"))) {
        lrr_aligned_free(start);
        return st;
    }
    for (size_t i = 0; i < nt; i++)
        for (size_t b = (size_t)tris[i].y0 / BAND_ROWS; b <= (size_t)tris[i].y1 / BAND_ROWS; b++)
            list[start[b]++] = i;
    for (size_t b = nb; b > 0; b--) /* start[b] now holds the end of band b: shift back */
        start[b] = start[b - 1];
    start[0] = 0;

    #pragma omp parallel for schedule(dynamic, 1)
    for (size_t b = 0; b < nb; b++) {
        int row0 = (int)(b * BAND_ROWS), row1 = row0 + BAND_ROWS - 1;
        for (size_t j = start[b]; j < start[b + 1]; j++)
            raster_tri(fb, &tris[list[j]], row0, row1);
    }
    lrr_aligned_free(start);
    lrr_aligned_free(list);
    return LRR_OK;
}
