/* Pictures: a software z-buffer rasteriser that draws the subpatch mesh with Gouraud-
 * interpolated radiosity, tone maps it and writes a PNG atomically. */
#include "config.h"
#include "operator/operator.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <stb_image_write.h>

#define RENDER_DEFAULT_SIZE 512u
#define RENDER_MAX_SIZE 16384u
/* Welding tolerances: positions relative to the scene's bounding-box diagonal; normals per
 * component, so that corners between walls keep one vertex per wall and stay sharp. */
#define WELD_POS_TOL 1e-5
#define WELD_NORMAL_TOL 1e-3f
/* Sub-pixel precision of the fixed-point rasteriser: integer edge functions are exact, so
 * triangles sharing an edge cover every pixel exactly once (no cracks, no double hits). */
#define SUBPIX_BITS 8
#define SUBPIX (1 << SUBPIX_BITS)
/* Clip against a frustum this many times wider than the screen: keeps fixed-point
 * coordinates small while rarely cutting triangles that are only partly off screen. */
#define GUARD_BAND 2.0
#define BAND_ROWS 16
#define MAX_CLIP_VERTS 9
/* Target of the automatic exposure: the mean visible non-emitting luminance maps to this. */
#define EXPOSURE_KEY 0.18
/* Exposed values at or above this map to white (extended Reinhard curve). */
#define TONE_WHITE 6.0

typedef struct camera {
    double eye[3], right[3], up[3], fwd[3];
    double tan_x, tan_y; /* tangents of the half fields of view */
    double near;         /* view-space depth of the near clipping plane */
} camera;

/* A clip-space vertex with its colour; colour is linear in clip space, so clipping may
 * interpolate it linearly. */
typedef struct cvert {
    double x, y, w;
    double c[3];
} cvert;

/* A screen triangle, positively oriented, in fixed-point pixels. */
typedef struct rtri {
    int64_t x[3], y[3];
    int64_t area;         /* twice the signed area, > 0 */
    float iw[3];          /* 1/w, interpolated linearly in screen space */
    float c[3][3];        /* colour/w */
    uint32_t id;          /* subpatch */
    int32_t x0, x1, y0, y1; /* pixel bounding box on screen, inclusive */
} rtri;

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}


static void camera_orient(camera *cam, const double fwd[3])
{
    static const double world_up[3] = {0, 1, 0};
    memcpy(cam->fwd, fwd, sizeof cam->fwd);
    lrr__normalize3(cam->fwd);
    /* image right = forward × up: for the Cornell camera this is −x, so the red wall at
     * x ≈ 556 appears on the left, as in the published pictures */
    cross3(cam->fwd, world_up, cam->right);
    lrr__normalize3(cam->right);
    cross3(cam->right, cam->fwd, cam->up);
}

static void scene_bounds(const lrr__geometry *g, double lo[3], double hi[3])
{
    for (int j = 0; j < 3; j++) {
        lo[j] = INFINITY;
        hi[j] = -INFINITY;
    }
    for (size_t i = 0; i < 9 * g->n_tri; i++) {
        int j = (int)(i % 3);
        double x = g->vert[i];
        if (x < lo[j]) lo[j] = x;
        if (x > hi[j]) hi[j] = x;
    }
    if (g->n_tri == 0)
        for (int j = 0; j < 3; j++)
            lo[j] = hi[j] = 0;
}

/* Projected area of the front faces seen from eye (occlusion ignored): used to decide from
 * which side a scene is meant to be seen. */
static double front_area(const lrr_operator *op, const double eye[3])
{
    double sum = 0;
    #pragma omp parallel for reduction(+ : sum) schedule(static)
    for (size_t i = 0; i < op->n; i++) {
        double d[3], len2 = 0, cosv = 0;
        for (int j = 0; j < 3; j++) {
            d[j] = eye[j] - op->centre[3 * i + j];
            len2 += d[j] * d[j];
            cosv += d[j] * op->normal[3 * i + j];
        }
        if (cosv > 0 && len2 > 0)
            sum += op->area[i] * cosv / sqrt(len2);
    }
    return sum;
}

static void camera_setup(camera *cam, const lrr_operator *op, int cornell, unsigned width,
                         unsigned height)
{
    double aspect = (double)width / height;
    double lo[3], hi[3];
    scene_bounds(&op->geom, lo, hi);
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    if (!(diag > 0) || !isfinite(diag))
        diag = 1;
    if (cornell) {
        /* eye (278,273,-800) looking along +z, 35 mm lens on 25×25 mm film; non-square
         * pictures keep the vertical field of view */
        static const double eye[3] = {278, 273, -800}, fwd[3] = {0, 0, 1};
        memcpy(cam->eye, eye, sizeof eye);
        camera_orient(cam, fwd);
        cam->tan_y = 12.5 / 35.0;
        cam->tan_x = cam->tan_y * aspect;
        cam->near = 1e-4 * diag;
        return;
    }
    /* Frame the bounding sphere in a 40° field of view from slightly above, on the +z side
     * (OpenGL's habit: +x right, looking along −z), unless the −z side shows more front
     * faces (e.g. a Cornell box read from a file, open towards −z). */
    double c[3], r = 0.5 * diag;
    for (int j = 0; j < 3; j++)
        c[j] = 0.5 * (lo[j] + hi[j]);
    cam->tan_y = tan(20.0 * M_PI / 180.0);
    cam->tan_x = cam->tan_y * aspect;
    double half = atan(fmin(cam->tan_x, cam->tan_y));
    double dist = 1.02 * r / sin(half);
    double dir[2][3] = {{0, 0.3, 1}, {0, 0.3, -1}}, eyes[2][3];
    for (int s = 0; s < 2; s++) {
        lrr__normalize3(dir[s]);
        for (int j = 0; j < 3; j++)
            eyes[s][j] = c[j] + dist * dir[s][j];
    }
    int side = front_area(op, eyes[1]) > 1.0001 * front_area(op, eyes[0]) ? 1 : 0;
    memcpy(cam->eye, eyes[side], sizeof cam->eye);
    double fwd[3] = {-dir[side][0], -dir[side][1], -dir[side][2]};
    camera_orient(cam, fwd);
    cam->near = fmax(0.5 * (dist - r), 1e-6 * r);
}

/* ------------------------------------------------------------------ vertex welding */

/* A welded vertex: quantised position and the normal of the first subpatch that made it. */
typedef struct wvert {
    int32_t key[3];
    float normal[3];
} wvert;

typedef struct weld {
    lrr_context *ctx;
    size_t cap;           /* hash slots, a power of two */
    uint32_t *slot;       /* vertex id + 1; 0 = empty */
    size_t nv, vcap;
    wvert *vert;          /* nv used, vcap allocated */
} weld;

static uint64_t hash_key(const int32_t k[3])
{
    /* splitmix64's finaliser over the packed key: neighbouring grid cells spread out, which
     * linear probing needs */
    uint64_t h = ((uint64_t)(uint32_t)k[0] * 0x9E3779B97F4A7C15ull) ^
                 ((uint64_t)(uint32_t)k[1] << 21) ^ ((uint64_t)(uint32_t)k[2] << 42) ^
                 (uint64_t)(uint32_t)k[2];
    return lrr__mix64(h);
}

static int normals_agree(const float *a, const float *b)
{
    return fabsf(a[0] - b[0]) <= WELD_NORMAL_TOL && fabsf(a[1] - b[1]) <= WELD_NORMAL_TOL &&
           fabsf(a[2] - b[2]) <= WELD_NORMAL_TOL;
}

/* *id = the vertex at key k with a normal agreeing with nrm, added if there is none. */
static lrr_status weld_insert(weld *w, const int32_t k[3], const float nrm[3], uint32_t *id)
{
    /* the table has at least twice as many slots as corners: probing finds an empty one */
    size_t mask = w->cap - 1, h = hash_key(k) & mask;
    for (; w->slot[h] != 0; h = (h + 1) & mask) {
        const wvert *v = &w->vert[w->slot[h] - 1];
        if (v->key[0] == k[0] && v->key[1] == k[1] && v->key[2] == k[2] &&
            normals_agree(v->normal, nrm)) {
            *id = w->slot[h] - 1;
            return LRR_OK;
        }
    }
    if (w->nv == w->vcap) {
        /* meshes have fewer vertices than corners: grow on demand, touching less memory */
        size_t vcap = 2 * w->vcap;
        wvert *grown;
        lrr_status st = lrr__calloc(w->ctx, &grown, vcap, sizeof *grown, "render: vertices");
        if (st)
            return st;
        memcpy(grown, w->vert, w->nv * sizeof *grown);
        lrr_aligned_free(w->vert);
        w->vert = grown;
        w->vcap = vcap;
    }
    uint32_t v = (uint32_t)w->nv++;
    memcpy(w->vert[v].key, k, sizeof w->vert[v].key);
    memcpy(w->vert[v].normal, nrm, sizeof w->vert[v].normal);
    w->slot[h] = v + 1;
    *id = v;
    return LRR_OK;
}

/* Per corner (3n) a welded vertex, and per vertex the area-weighted mean radiosity of the
 * subpatches that touch it. */
static lrr_status weld_vertices(const lrr_operator *op, const double *pos, const float *radiosity,
                                uint32_t *corner_vertex, float **vertex_colour)
{
    lrr_context *ctx = op->ctx;
    size_t n = op->n, nc = 3 * n;
    weld w = {0};
    w.ctx = ctx;
    double *acc = NULL;
    lrr_status st;
    size_t cap = 16;
    while (cap < 2 * nc)
        cap *= 2;
    w.cap = cap;
    w.vcap = n + 64;
    if ((st = lrr__calloc(ctx, &w.slot, cap, sizeof *w.slot, "render: vertex hash")) ||
        (st = lrr__calloc(ctx, &w.vert, w.vcap, sizeof *w.vert, "render: vertices")))
        goto done;

    double lo[3], hi[3];
    scene_bounds(&op->geom, lo, hi);
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    double q = WELD_POS_TOL * diag;
    if (!(q > 0) || !isfinite(q))
        q = 1;
    /* relative to the minimum corner, keys stay within ±1e5 whatever the scene's offset */
    for (size_t c = 0; c < nc; c++) {
        int32_t k[3];
        for (int j = 0; j < 3; j++)
            k[j] = (int32_t)lround((pos[3 * c + j] - lo[j]) / q);
        if ((st = weld_insert(&w, k, op->normal + 3 * (c / 3), &corner_vertex[c])))
            goto done;
    }
    /* per vertex: area-weighted sums of r, g, b and the weight */
    if ((st = lrr__calloc(ctx, &acc, w.nv, 4 * sizeof *acc, "render: vertex sums")))
        goto done;
    for (size_t i = 0; i < n; i++) {
        /* zero-area slivers still count, a little, so no vertex is left without a value */
        double a = op->area[i] > 0 ? op->area[i] : 1e-30;
        for (int k = 0; k < 3; k++) {
            double *s = acc + 4 * (size_t)corner_vertex[3 * i + k];
            for (int j = 0; j < 3; j++)
                s[j] += a * radiosity[3 * i + j];
            s[3] += a;
        }
    }
    float *col;
    if ((st = lrr__calloc(ctx, &col, w.nv, 3 * sizeof *col, "render: vertex colours")))
        goto done;
    for (size_t v = 0; v < w.nv; v++)
        for (int j = 0; j < 3; j++)
            col[3 * v + j] = (float)(acc[4 * v + j] / acc[4 * v + 3]);
    *vertex_colour = col;
done:
    lrr_aligned_free(w.slot);
    lrr_aligned_free(w.vert);
    lrr_aligned_free(acc);
    return st;
}

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
static int setup_subpatch(const camera *cam, unsigned width, unsigned height, uint32_t id,
                          const double *pos, const uint32_t *corner_vertex, const float *vcol,
                          rtri *out)
{
    const double *p = pos + 9 * (size_t)id;
    double e1[3], e2[3], nrm[3], to_eye[3];
    for (int j = 0; j < 3; j++) {
        e1[j] = p[3 + j] - p[j];
        e2[j] = p[6 + j] - p[j];
        to_eye[j] = cam->eye[j] - p[j];
    }
    cross3(e1, e2, nrm);
    if (!(dot3(nrm, to_eye) > 0)) /* one-sided: front is counter-clockwise */
        return 0;

    cvert poly[2][MAX_CLIP_VERTS];
    int m = 3, all_in = 1;
    for (int k = 0; k < 3; k++) {
        double d[3] = {p[3 * k] - cam->eye[0], p[3 * k + 1] - cam->eye[1],
                       p[3 * k + 2] - cam->eye[2]};
        cvert *v = &poly[0][k];
        v->x = dot3(d, cam->right) / cam->tan_x;
        v->y = dot3(d, cam->up) / cam->tan_y;
        v->w = dot3(d, cam->fwd);
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
            rtri *t = &out[count];
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

typedef struct framebuffer {
    unsigned width, height;
    float *depth;    /* 1/w; 0 = background */
    float *rgb;      /* interpolated radiosity */
    uint32_t *id;    /* subpatch + 1; 0 = background */
} framebuffer;

/* Top-left fill rule for edge a→b of a positively oriented triangle: an edge's points
 * belong to exactly one of the two triangles sharing it. */
static int64_t edge_bias(int64_t ax, int64_t ay, int64_t bx, int64_t by)
{
    int64_t dx = bx - ax, dy = by - ay;
    return (dy > 0 || (dy == 0 && dx < 0)) ? 0 : -1;
}

static void raster_tri(framebuffer *fb, const rtri *t, int row0, int row1)
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
static lrr_status raster_all(lrr_context *ctx, framebuffer *fb, const rtri *tris, size_t nt)
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

/* ------------------------------------------------------------------ tone mapping */

static double luminance(const float *c)
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

/* The area-weighted mean luminance of the visible non-emitting subpatches maps to
 * EXPOSURE_KEY; the light sources then burn out to white, as in photographs of the box. */
static lrr_status auto_exposure(const lrr_operator *op, const float *radiosity,
                                const framebuffer *fb, double *exposure)
{
    uint8_t *seen;
    lrr_status st = lrr__calloc(op->ctx, &seen, op->n, 1, "render: visibility flags");
    if (st)
        return st;
    size_t npix = (size_t)fb->width * fb->height;
    for (size_t p = 0; p < npix; p++)
        if (fb->id[p])
            seen[fb->id[p] - 1] = 1;
    double sum[2] = {0, 0}, area[2] = {0, 0}; /* [0] non-emitters, [1] all visible */
    for (size_t i = 0; i < op->n; i++) {
        if (!seen[i])
            continue;
        const float *e = op->emission ? op->emission + 3 * i : NULL;
        int emits = e && (e[0] > 0 || e[1] > 0 || e[2] > 0);
        double a = op->area[i], l = luminance(radiosity + 3 * i);
        if (!emits) {
            sum[0] += a * l;
            area[0] += a;
        }
        sum[1] += a * l;
        area[1] += a;
    }
    lrr_aligned_free(seen);
    double mean = area[0] > 0 && sum[0] > 0 ? sum[0] / area[0]
                  : area[1] > 0            ? sum[1] / area[1]
                                           : 0;
    *exposure = mean > 0 && isfinite(mean) ? EXPOSURE_KEY / mean : 1.0;
    return LRR_OK;
}

/* sRGB 8-bit encoding by thresholds: code k is the first whose lower bound (the linear
 * value that encodes to k - 1/2) exceeds y. Exact rounding, with no pow() per pixel. */
typedef struct srgb_table {
    double lower[256]; /* lower[k]: smallest linear value that rounds to code k (k >= 1) */
} srgb_table;

static void srgb_table_init(srgb_table *t)
{
    t->lower[0] = -INFINITY;
    for (int k = 1; k < 256; k++) {
        double s = (k - 0.5) / 255;
        t->lower[k] = s <= 0.04045 ? s / 12.92 : pow((s + 0.055) / 1.055, 2.4);
    }
}

static uint8_t tone(const srgb_table *t, double x)
{
    /* extended Reinhard: x/(1+x) near black, reaching 1 at TONE_WHITE */
    double y = x * (1 + x / (TONE_WHITE * TONE_WHITE)) / (1 + x);
    if (!(y > 0))
        return 0;
    int lo = 0, hi = 255; /* lower[lo] <= y; answer in [lo, hi] */
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (t->lower[mid] <= y)
            lo = mid;
        else
            hi = mid - 1;
    }
    return (uint8_t)lo;
}

/* ------------------------------------------------------------------ PNG output */

typedef struct membuf {
    lrr_context *ctx;
    unsigned char *data;
    size_t len, cap;
    int failed;
} membuf;

static void membuf_write(void *user, void *data, int size)
{
    membuf *m = user;
    if (m->failed || size <= 0)
        return;
    if ((size_t)size > m->cap - m->len) {
        size_t cap = m->cap ? m->cap : 1 << 16;
        while (cap - m->len < (size_t)size) {
            if (cap > SIZE_MAX / 2) {
                m->failed = 1;
                return;
            }
            cap *= 2;
        }
        unsigned char *p = lrr__realloc(m->ctx, m->data, cap);
        if (!p) {
            m->failed = 1;
            return;
        }
        m->data = p;
        m->cap = cap;
    }
    memcpy(m->data + m->len, data, (size_t)size);
    m->len += (size_t)size;
}

/* Writes data to path through the atomic writer (core/atomic_file.c), so that path never
 * holds a partial picture; its steps go through the context's I/O fault hook. */
static lrr_status write_atomic(lrr_context *ctx, const char *path, const unsigned char *data,
                               size_t len)
{
    lrr__atomic_io io;
    lrr__context_atomic_io(ctx, &io);
    lrr__atomic_file w;
    if (!lrr__atomic_open(&w, path, &io)) {
        lrr__atomic_write(&w, data, len);
        lrr__atomic_commit(&w);
    }
    lrr_status st = w.err ? lrr__atomic_error(ctx, &w) : LRR_OK;
    lrr__atomic_free(&w);
    return st;
}

/* ------------------------------------------------------------------ the entry point */

lrr_status lrr_render_png(const lrr_operator *op, const float *radiosity,
                          const lrr_render_options *opts, const char *path)
{
    lrr_context *ctx = op->ctx;
    lrr_render_options o = lrr_render_options_defaults();
    lrr_status st0;
    if (opts && (st0 = lrr__options_read(ctx, opts, sizeof o, &o, "lrr_render_options")))
        return st0;
    unsigned width = o.width ? o.width : RENDER_DEFAULT_SIZE;
    unsigned height = o.height ? o.height : RENDER_DEFAULT_SIZE;
    if (width > RENDER_MAX_SIZE || height > RENDER_MAX_SIZE)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: picture size %u×%u exceeds %u pixels per side", path,
                          width, height, RENDER_MAX_SIZE);
    if (!isfinite(o.exposure) || o.exposure < 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: exposure %g must be finite and >= 0 (0 = automatic)", path,
                          o.exposure);
    if (o.use_cornell_camera < -1 || o.use_cornell_camera > 1)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: use_cornell_camera = %d: expected -1, 0 or 1", path,
                          o.use_cornell_camera);
    if (!*path)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "render: empty output path");
    if (op->n >= UINT32_MAX)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "render %s: %zu subpatches; at most %u can be drawn", path, op->n,
                          UINT32_MAX - 1);
    if (op->n > 0 && (!op->area || !op->centre || !op->normal || op->geom.n != op->n))
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: operator without subpatch geometry", path);
    for (size_t i = 0; i < op->n; i++)
        for (int j = 0; j < 3; j++) {
            float b = radiosity[3 * i + j];
            if (!isfinite(b) || b < 0)
                return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                                  "render %s: radiosity of subpatch %zu, channel %d is %g: "
                                  "must be finite and >= 0",
                                  path, i, j, (double)b);
        }

    int cornell = o.use_cornell_camera == 1 ||
                  (o.use_cornell_camera == -1 && (op->builtin == LRR__SCENE_CORNELL ||
                                                  op->builtin == LRR__SCENE_CORNELL_CLOSED));
    camera cam;
    camera_setup(&cam, op, cornell, width, height);

    size_t n = op->n, npix = (size_t)width * height;
    double *pos = NULL;
    uint32_t *corner_vertex = NULL;
    float *vcol = NULL;
    int *tri_count = NULL;
    size_t *tri_start = NULL;
    rtri *tris = NULL;
    framebuffer fb = {width, height, NULL, NULL, NULL};
    uint8_t *pixels = NULL;
    membuf png = {ctx, NULL, 0, 0, 0};
    lrr_status st;
    if ((st = lrr__calloc(ctx, &pos, n, 9 * sizeof *pos, "render: subpatch vertices")) ||
        (st = lrr__calloc(ctx, &corner_vertex, n, 3 * sizeof *corner_vertex,
                          "render: corner vertices")) ||
        (st = lrr__calloc(ctx, &tri_count, n, sizeof *tri_count, "render: triangle counts")) ||
        (st = lrr__calloc(ctx, &tri_start, n + 1, sizeof *tri_start, "render: triangle index")) ||
        (st = lrr__calloc(ctx, &fb.depth, npix, sizeof *fb.depth, "render: depth buffer")) ||
        (st = lrr__calloc(ctx, &fb.rgb, npix, 3 * sizeof *fb.rgb, "render: colour buffer")) ||
        (st = lrr__calloc(ctx, &fb.id, npix, sizeof *fb.id, "render: id buffer")) ||
        (st = lrr__calloc(ctx, &pixels, npix, 3, "render: picture")))
        goto done;

    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        lrr__subpatch_vertices(&op->geom, i, pos + 9 * i);
    if ((st = weld_vertices(op, pos, radiosity, corner_vertex, &vcol)))
        goto done;

    /* two passes over the subpatches: count the clipped screen triangles, then fill them */
    #pragma omp parallel for schedule(dynamic, 256)
    for (size_t i = 0; i < n; i++)
        tri_count[i] = setup_subpatch(&cam, width, height, (uint32_t)i, pos, corner_vertex,
                                      vcol, NULL);
    for (size_t i = 0; i < n; i++)
        tri_start[i + 1] = tri_start[i] + (size_t)tri_count[i];
    size_t nt = tri_start[n];
    if ((st = lrr__calloc(ctx, &tris, nt, sizeof *tris, "render: screen triangles")))
        goto done;
    #pragma omp parallel for schedule(dynamic, 256)
    for (size_t i = 0; i < n; i++)
        if (tri_count[i])
            setup_subpatch(&cam, width, height, (uint32_t)i, pos, corner_vertex, vcol,
                           tris + tri_start[i]);
    if ((st = raster_all(ctx, &fb, tris, nt)))
        goto done;

    double exposure = o.exposure;
    if (exposure == 0 && (st = auto_exposure(op, radiosity, &fb, &exposure)))
        goto done;
    srgb_table srgb;
    srgb_table_init(&srgb);
    #pragma omp parallel for schedule(static)
    for (size_t p = 0; p < npix; p++)
        for (int j = 0; j < 3; j++)
            pixels[3 * p + j] = fb.id[p] ? tone(&srgb, exposure * fb.rgb[3 * p + j]) : 0;

    if (!stbi_write_png_to_func(membuf_write, &png, (int)width, (int)height, 3, pixels,
                                (int)(3 * width)) ||
        png.failed) {
        st = lrr__error(ctx, LRR_ERR_NOMEM, "render %s: PNG encoding of %u×%u pixels failed",
                        path, width, height);
        goto done;
    }
    st = write_atomic(ctx, path, png.data, png.len);
done:
    free(png.data);
    lrr_aligned_free(pos);
    lrr_aligned_free(corner_vertex);
    lrr_aligned_free(vcol);
    lrr_aligned_free(tri_count);
    lrr_aligned_free(tri_start);
    lrr_aligned_free(tris);
    lrr_aligned_free(fb.depth);
    lrr_aligned_free(fb.rgb);
    lrr_aligned_free(fb.id);
    lrr_aligned_free(pixels);
    return st;
}
