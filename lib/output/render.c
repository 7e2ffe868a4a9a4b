/* Pictures: a software z-buffer rasteriser that draws the subpatch mesh with Gouraud-
 * interpolated radiosity, tone maps it and writes a PNG atomically, or writes the linear
 * radiosity as OpenEXR (exr.cpp encodes it). Here the entry points, tone mapping and PNG
 * output; the camera (camera.c), the vertex welding (weld.c) and the
 * rasteriser (raster.c) beside it, render_internal.h what they share. */
#include "config.h"
#include "output/render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stb_image_write.h>

#define RENDER_DEFAULT_SIZE 512u
#define RENDER_MAX_SIZE 16384u
/* Target of the automatic exposure: the mean visible non-emitting luminance maps to this. */
#define EXPOSURE_KEY 0.18
/* Exposed values at or above this map to white (extended Reinhard curve). */
#define TONE_WHITE 6.0

/* ------------------------------------------------------------------ tone mapping */

static double luminance(const float *c)
{
    return 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
}

/* The area-weighted mean luminance of the non-emitting subpatches (those with seen[i], when
 * seen is given) maps to EXPOSURE_KEY; the light sources then burn out to white, as in
 * photographs of the box. With no such light, the mean over all of them. */
static double exposure_for(const lrr_operator *op, const float *radiosity, const uint8_t *seen)
{
    double sum[2] = {0, 0}, area[2] = {0, 0}; /* [0] non-emitters, [1] all */
    for (size_t i = 0; i < op->n; i++) {
        if (seen && !seen[i])
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
    double mean = area[0] > 0 && sum[0] > 0 ? sum[0] / area[0]
                  : area[1] > 0            ? sum[1] / area[1]
                                           : 0;
    return mean > 0 && isfinite(mean) ? EXPOSURE_KEY / mean : 1.0;
}

/* The picture's automatic exposure: keyed on the subpatches it shows. */
static lrr_status auto_exposure(const lrr_operator *op, const float *radiosity,
                                const lrr__framebuffer *fb, double *exposure)
{
    uint8_t *seen;
    lrr_status st = lrr__calloc(op->ctx, &seen, op->n, 1, "render: visibility flags");
    if (st)
        return st;
    size_t npix = (size_t)fb->width * fb->height;
    for (size_t p = 0; p < npix; p++)
        if (fb->id[p])
            seen[fb->id[p] - 1] = 1;
    *exposure = exposure_for(op, radiosity, seen);
    lrr_aligned_free(seen);
    return LRR_OK;
}

double lrr_render_auto_exposure(const lrr_operator *op, const float *radiosity)
{
    return exposure_for(op, radiosity, NULL);
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
 * holds a partial file; its steps go through the context's I/O fault hook. */
lrr_status lrr__output_write_atomic(lrr_context *ctx, const char *path,
                                    const unsigned char *data, size_t len)
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

static int finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

/* The field of view and the eye/target camera's vectors: finite, eye != target, up not
 * parallel to the view direction (the picture's orientation would be undefined). */
static lrr_status check_camera(lrr_context *ctx, const lrr_render_options *o, const char *path)
{
    if (!isfinite(o->fov_degrees) || o->fov_degrees < 0 || o->fov_degrees >= 180)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: fov_degrees = %g: expected 0 < fov < 180 (0 = default)",
                          path, o->fov_degrees);
    if (o->use_eye < 0 || o->use_eye > 1)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "render %s: use_eye = %d: expected 0 or 1",
                          path, o->use_eye);
    if (!o->use_eye)
        return LRR_OK;
    const char *bad = !finite3(o->eye) ? "eye" : !finite3(o->target) ? "target"
                      : !finite3(o->up) ? "up" : NULL;
    if (bad)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG, "render %s: camera %s is not finite", path,
                          bad);
    double fwd[3], side[3], up[3] = {o->up[0], o->up[1], o->up[2]};
    for (int j = 0; j < 3; j++)
        fwd[j] = o->target[j] - o->eye[j];
    if (up[0] == 0 && up[1] == 0 && up[2] == 0)
        up[1] = 1;
    double lf = sqrt(lrr__dot3(fwd, fwd)), lu = sqrt(lrr__dot3(up, up));
    if (!(lf > 0) || !isfinite(lf))
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: camera eye = target = (%g, %g, %g): no view direction",
                          path, o->eye[0], o->eye[1], o->eye[2]);
    lrr__cross3(fwd, up, side);
    if (!(sqrt(lrr__dot3(side, side)) > 1e-6 * lf * lu))
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: camera up (%g, %g, %g) is parallel to the view direction "
                          "target - eye (%g, %g, %g)",
                          path, up[0], up[1], up[2], fwd[0], fwd[1], fwd[2]);
    return LRR_OK;
}

/* o = the options (defaults when opts is NULL), width × height the picture's size, after
 * checking them, the path and the operator's radiosity: errors name the path. */
static lrr_status check_request(const lrr_operator *op, const float *radiosity,
                                const lrr_render_options *opts, const char *path,
                                lrr_render_options *o, unsigned *width, unsigned *height)
{
    lrr_context *ctx = op->ctx;
    *o = lrr_render_options_defaults();
    lrr_status st;
    if (opts && (st = lrr__options_read(ctx, opts, sizeof *o,
                                        LRR__FIRST_SIZE(lrr_render_options, use_eye),
                                        o, "lrr_render_options")))
        return st;
    *width = o->width ? o->width : RENDER_DEFAULT_SIZE;
    *height = o->height ? o->height : RENDER_DEFAULT_SIZE;
    if (*width > RENDER_MAX_SIZE || *height > RENDER_MAX_SIZE)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: picture size %u×%u exceeds %u pixels per side", path,
                          *width, *height, RENDER_MAX_SIZE);
    if (!isfinite(o->exposure) || o->exposure < 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: exposure %g must be finite and >= 0 (0 = automatic)", path,
                          o->exposure);
    if (o->use_cornell_camera < -1 || o->use_cornell_camera > 1)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "render %s: use_cornell_camera = %d: expected -1, 0 or 1", path,
                          o->use_cornell_camera);
    if ((st = check_camera(ctx, o, path)))
        return st;
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
    return LRR_OK;
}

/* The buffers of one picture (render_free frees them). */
typedef struct render_buffers {
    double *pos;              /* per subpatch its three corners (9 doubles) */
    uint32_t *corner_vertex;  /* per corner its welded vertex */
    float *vcol;              /* per welded vertex its colour */
    int *tri_count;           /* per subpatch its screen triangles */
    size_t *tri_start;        /* n + 1: where a subpatch's triangles start in tris */
    lrr__rtri *tris;
    size_t nt;
    lrr__framebuffer fb;
    uint8_t *pixels;          /* the picture: 8-bit sRGB, 3 per pixel (PNG only) */
    int want_pixels;
} render_buffers;

/* All but the welded vertices' colours and the screen triangles, whose sizes come later. */
static lrr_status render_alloc(lrr_context *ctx, size_t n, render_buffers *b)
{
    size_t npix = (size_t)b->fb.width * b->fb.height;
    lrr_status st;
    if ((st = lrr__calloc(ctx, &b->pos, n, 9 * sizeof *b->pos, "render: subpatch vertices")) ||
        (st = lrr__calloc(ctx, &b->corner_vertex, n, 3 * sizeof *b->corner_vertex,
                          "render: corner vertices")) ||
        (st = lrr__calloc(ctx, &b->tri_count, n, sizeof *b->tri_count,
                          "render: triangle counts")) ||
        (st = lrr__calloc(ctx, &b->tri_start, n + 1, sizeof *b->tri_start,
                          "render: triangle index")) ||
        (st = lrr__calloc(ctx, &b->fb.depth, npix, sizeof *b->fb.depth, "render: depth buffer")) ||
        (st = lrr__calloc(ctx, &b->fb.rgb, npix, 3 * sizeof *b->fb.rgb,
                          "render: colour buffer")) ||
        (st = lrr__calloc(ctx, &b->fb.id, npix, sizeof *b->fb.id, "render: id buffer")) ||
        (b->want_pixels && (st = lrr__calloc(ctx, &b->pixels, npix, 3, "render: picture"))))
        return st;
    return LRR_OK;
}

static void render_free(render_buffers *b)
{
    lrr_aligned_free(b->pos);
    lrr_aligned_free(b->corner_vertex);
    lrr_aligned_free(b->vcol);
    lrr_aligned_free(b->tri_count);
    lrr_aligned_free(b->tri_start);
    lrr_aligned_free(b->tris);
    lrr_aligned_free(b->fb.depth);
    lrr_aligned_free(b->fb.rgb);
    lrr_aligned_free(b->fb.id);
    lrr_aligned_free(b->pixels);
}

/* The subpatches' corners, welded into vertices coloured by the radiosity around them. */
static lrr_status shade_vertices(const lrr_operator *op, const float *radiosity,
                                 render_buffers *b)
{
    size_t n = op->n;
    double *pos = b->pos;
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < n; i++)
        lrr__subpatch_vertices(&op->geom, i, pos + 9 * i);
    return lrr__render_weld_vertices(op, pos, radiosity, NULL, b->corner_vertex, &b->vcol,
                                     NULL);
}

/* b->tris: the clipped screen triangles of every subpatch, in subpatch order. */
static lrr_status screen_triangles(const lrr_operator *op, const lrr__camera *cam,
                                   render_buffers *b)
{
    size_t n = op->n;
    unsigned width = b->fb.width, height = b->fb.height;
    const double *pos = b->pos;
    const uint32_t *corner_vertex = b->corner_vertex;
    const float *vcol = b->vcol;
    int *tri_count = b->tri_count;
    size_t *tri_start = b->tri_start;
    /* two passes over the subpatches: count the clipped screen triangles, then fill them */
    #pragma omp parallel for schedule(dynamic, 256)
    for (size_t i = 0; i < n; i++)
        tri_count[i] = lrr__render_setup_subpatch(cam, width, height, (uint32_t)i, pos,
                                                  corner_vertex, vcol, NULL);
    for (size_t i = 0; i < n; i++)
        tri_start[i + 1] = tri_start[i] + (size_t)tri_count[i];
    b->nt = tri_start[n];
    lrr_status st = lrr__calloc(op->ctx, &b->tris, b->nt, sizeof *b->tris,
                                "render: screen triangles");
    if (st)
        return st;
    lrr__rtri *tris = b->tris;
    #pragma omp parallel for schedule(dynamic, 256)
    for (size_t i = 0; i < n; i++)
        if (tri_count[i])
            lrr__render_setup_subpatch(cam, width, height, (uint32_t)i, pos, corner_vertex,
                                       vcol, tris + tri_start[i]);
    return LRR_OK;
}

/* b->pixels: the framebuffer's radiosity times the exposure (0 = automatic), tone mapped to
 * sRGB; the background stays black. */
static lrr_status tone_map(const lrr_operator *op, const float *radiosity, double exposure,
                           render_buffers *b)
{
    const lrr__framebuffer *fb = &b->fb;
    lrr_status st;
    if (exposure == 0 && (st = auto_exposure(op, radiosity, fb, &exposure)))
        return st;
    srgb_table srgb;
    srgb_table_init(&srgb);
    size_t npix = (size_t)fb->width * fb->height;
    uint8_t *pixels = b->pixels;
    #pragma omp parallel for schedule(static)
    for (size_t p = 0; p < npix; p++)
        for (int j = 0; j < 3; j++)
            pixels[3 * p + j] = fb->id[p] ? tone(&srgb, exposure * fb->rgb[3 * p + j]) : 0;
    return LRR_OK;
}

/* The picture encoded as a PNG in memory, then written to path atomically. */
static lrr_status write_png(lrr_context *ctx, const char *path, unsigned width,
                            unsigned height, const uint8_t *pixels)
{
    membuf png = {ctx, NULL, 0, 0, 0};
    lrr_status st;
    if (!stbi_write_png_to_func(membuf_write, &png, (int)width, (int)height, 3, pixels,
                                (int)(3 * width)) ||
        png.failed)
        st = lrr__error(ctx, LRR_ERR_NOMEM, "render %s: PNG encoding of %u×%u pixels failed",
                        path, width, height);
    else
        st = lrr__output_write_atomic(ctx, path, png.data, png.len);
    free(png.data);
    return st;
}

/* b->fb: the picture of op under options o (checked), its radiosity before tone mapping. */
static lrr_status render_framebuffer(const lrr_operator *op, const float *radiosity,
                                     const lrr_render_options *o, render_buffers *b)
{
    lrr__camera cam;
    lrr_status st = lrr__render_camera_setup(&cam, op, radiosity, o, b->fb.width,
                                             b->fb.height);
    if (!st)
        st = render_alloc(op->ctx, op->n, b);
    if (!st)
        st = shade_vertices(op, radiosity, b);
    if (!st)
        st = screen_triangles(op, &cam, b);
    if (!st)
        st = lrr__render_raster_all(op->ctx, &b->fb, b->tris, b->nt);
    return st;
}

lrr_status lrr_render_png(const lrr_operator *op, const float *radiosity,
                          const lrr_render_options *opts, const char *path)
{
    lrr_render_options o;
    unsigned width, height;
    lrr_status st = check_request(op, radiosity, opts, path, &o, &width, &height);
    if (st)
        return st;
    render_buffers b = {.fb = {width, height, NULL, NULL, NULL}, .want_pixels = 1};
    st = render_framebuffer(op, radiosity, &o, &b);
    if (!st)
        st = tone_map(op, radiosity, o.exposure, &b);
    if (!st)
        st = write_png(op->ctx, path, width, height, b.pixels);
    render_free(&b);
    return st;
}

lrr_status lrr_render_exr(const lrr_operator *op, const float *radiosity,
                          const lrr_render_options *opts, const char *path)
{
    lrr_render_options o;
    unsigned width, height;
    lrr_status st = check_request(op, radiosity, opts, path, &o, &width, &height);
    if (st)
        return st;
    render_buffers b = {.fb = {width, height, NULL, NULL, NULL}};
    st = render_framebuffer(op, radiosity, &o, &b);
    unsigned char *data = NULL;
    size_t len = 0;
    if (!st)
        st = lrr__render_encode_exr(op->ctx, path, width, height, b.fb.rgb, &data, &len);
    if (!st)
        st = lrr__output_write_atomic(op->ctx, path, data, len);
    lrr_aligned_free(data);
    render_free(&b);
    return st;
}
