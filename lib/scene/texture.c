/* Textures → per-subpatch reflectance and emission (docs/METHOD.md "Textures").
 *
 * A texel is the mean reflectance over its square of the surface, so the texture is taken as
 * piecewise constant (box reconstruction, not bilinear) and a subpatch's rho is the exact
 * mean over its UV triangle: the triangle is clipped against every texel square it touches
 * (Sutherland–Hodgman, first to the texel row, then to each column) and the texels are
 * weighted by the clipped areas. That is exact up to rounding (the tests agree with a
 * 2048²-point grid integral to its own error, 2e-3) and costs about the texels covered.
 * Beyond LRR__TEXEL_EXACT_MAX texels in the bounding box (a large subpatch on a large
 * texture, a texture tiled many times) the midpoint rule on 64² equal sub-triangles takes
 * over, so a subpatch never costs more than about 4096 texel visits: 0.97% off the exact mean
 * over a whole 256² texture of white noise (the worst case), 0.16% on a real logo
 * (tests/scene/test_texture.c prints both), exact where the texture is constant over each
 * sub-triangle. */
#include "config.h"
#include "scene/texture.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <stb_image.h>

void lrr__scene_textures_free(lrr__scene_textures *t)
{
    if (!t)
        return;
    for (size_t i = 0; i < t->n_tex; i++)
        lrr_aligned_free(t->tex[i].rgb);
    lrr_aligned_free(t->tex);
    lrr_aligned_free(t->uv);
    lrr_aligned_free(t->rho_tex);
    lrr_aligned_free(t->em_tex);
    free(t);
}

/* ------------------------------------------------------------------ decoding */

static double srgb_to_linear(double c)
{
    return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* rgb[i] = value × factor, clamped when asked; returns whether it was. */
static bool store(float *rgb, double value, float factor, bool clamp)
{
    double v = value * factor;
    bool over = clamp && v >= LRR__RHO_MAX;
    *rgb = (float)(over ? LRR__RHO_MAX : v);
    return over;
}

static lrr_status alloc_texture(lrr_context *ctx, size_t w, size_t h, const char *what,
                                lrr__texture *out)
{
    memset(out, 0, sizeof *out);
    size_t texels;
    if (w == 0 || h == 0 || !lrr__mul_size(w, h, &texels) || texels > LRR__TEXELS_MAX)
        return lrr__error(ctx, LRR_ERR_FORMAT, "%s: image size %zu x %zu is not usable", what,
                          w, h);
    out->w = w;
    out->h = h;
    return lrr__calloc(ctx, &out->rgb, texels, 3 * sizeof(float), what);
}

lrr_status lrr__texture_decode(lrr_context *ctx, const unsigned char *data, size_t len,
                               const float factor[3], bool clamp, const char *what,
                               lrr__texture *out, size_t *clamped)
{
    memset(out, 0, sizeof *out);
    if (len == 0 || len > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_FORMAT, "%s: image of %zu bytes is not usable", what,
                          len);
    int w, h, comp, n = (int)len;
    if (!stbi_info_from_memory(data, n, &w, &h, &comp))
        return lrr__error(ctx, LRR_ERR_FORMAT, "%s: cannot decode the image: %s", what,
                          stbi_failure_reason() ? stbi_failure_reason() : "unknown format");
    /* stb_image allocates w×h×4 bytes unchecked; refuse what could not be addressed. */
    if (w <= 0 || h <= 0 || (uint64_t)w * (uint64_t)h > LRR__TEXELS_MAX)
        return lrr__error(ctx, LRR_ERR_FORMAT, "%s: image size %d x %d is not usable", what, w,
                          h);
    bool hdr = stbi_is_hdr_from_memory(data, n), wide = stbi_is_16_bit_from_memory(data, n);
    void *pix = hdr    ? (void *)stbi_loadf_from_memory(data, n, &w, &h, &comp, 3)
                : wide ? (void *)stbi_load_16_from_memory(data, n, &w, &h, &comp, 3)
                       : (void *)stbi_load_from_memory(data, n, &w, &h, &comp, 3);
    if (!pix)
        return lrr__error(ctx, LRR_ERR_FORMAT, "%s: cannot decode the image: %s", what,
                          stbi_failure_reason() ? stbi_failure_reason() : "unknown reason");
    lrr_status st = alloc_texture(ctx, (size_t)w, (size_t)h, what, out);
    if (st != LRR_OK) {
        stbi_image_free(pix);
        return st;
    }
    double lut[256];
    for (int i = 0; i < 256; i++)
        lut[i] = srgb_to_linear(i / 255.0);
    size_t m = 3 * (size_t)w * (size_t)h;
    bool over = false; /* in the current texel */
    for (size_t i = 0; i < m; i++) {
        double v = hdr    ? (double)((const float *)pix)[i]
                   : wide ? srgb_to_linear(((const uint16_t *)pix)[i] / 65535.0)
                          : lut[((const unsigned char *)pix)[i]];
        if (!(v >= 0) || !isfinite(v)) { /* .hdr may hold anything */
            stbi_image_free(pix);
            lrr_aligned_free(out->rgb);
            out->rgb = NULL;
            return lrr__error(ctx, LRR_ERR_FORMAT, "%s: texel %zu has value %g", what, i / 3,
                              v);
        }
        over |= store(out->rgb + i, v, factor[i % 3], clamp);
        if (i % 3 == 2) {
            *clamped += over;
            over = false;
        }
    }
    stbi_image_free(pix);
    return LRR_OK;
}

lrr_status lrr__texture_from_bgra(lrr_context *ctx, const unsigned char *bgra, size_t w,
                                  size_t h, const float factor[3], bool clamp,
                                  const char *what, lrr__texture *out, size_t *clamped)
{
    lrr_status st = alloc_texture(ctx, w, h, what, out);
    if (st != LRR_OK)
        return st;
    double lut[256];
    for (int i = 0; i < 256; i++)
        lut[i] = srgb_to_linear(i / 255.0);
    for (size_t p = 0; p < w * h; p++) {
        bool over = false;
        for (int c = 0; c < 3; c++)
            over |= store(out->rgb + 3 * p + c, lut[bgra[4 * p + 2 - c]], factor[c], clamp);
        *clamped += over;
    }
    return LRR_OK;
}

/* ------------------------------------------------------------------ integration */

static size_t wrap_index(long long i, size_t n, int mode)
{
    long long m = (long long)n;
    switch (mode) {
    case LRR__WRAP_CLAMP:
        return (size_t)(i < 0 ? 0 : i >= m ? m - 1 : i);
    case LRR__WRAP_MIRROR: {
        long long r = ((i % (2 * m)) + 2 * m) % (2 * m);
        return (size_t)(r < m ? r : 2 * m - 1 - r);
    }
    default:
        return (size_t)(((i % m) + m) % m);
    }
}

/* floor(x) as an index: far-off and non-finite coordinates (a UV of 1e27, times the width)
 * go to a fixed, defined texel instead of overflowing the conversion; that far out a double
 * has no sub-texel precision left, so no texel is more right than another. */
static long long texel_index(double x)
{
    x = floor(x);
    if (!(x > -0x1p62))
        return x < 0 ? -(1LL << 62) : 0; /* NaN: 0 */
    return x < 0x1p62 ? (long long)x : 1LL << 62;
}

static const float *texel(const lrr__texture *t, long long x, long long y)
{
    size_t ix = wrap_index(x, t->w, t->wrap[0]), iy = wrap_index(y, t->h, t->wrap[1]);
    return t->rgb + 3 * (iy * t->w + ix);
}

/* Texel coordinates: x = u·w, y = (1 − v)·h (assimp's v = 0 is the image's bottom row). For
 * repeat and mirror the triangle is moved by whole periods towards the origin, which keeps
 * far-tiled UVs exact and small. */
static void to_texels(const lrr__texture *t, const double uv[6], double p[6])
{
    for (int k = 0; k < 3; k++) {
        p[2 * k] = uv[2 * k] * (double)t->w;
        p[2 * k + 1] = (1.0 - uv[2 * k + 1]) * (double)t->h;
    }
    for (int a = 0; a < 2; a++) {
        if (t->wrap[a] == LRR__WRAP_CLAMP)
            continue;
        double period = (double)(a == 0 ? t->w : t->h) * (t->wrap[a] == LRR__WRAP_MIRROR ? 2 : 1);
        double lo = fmin(p[a], fmin(p[2 + a], p[4 + a]));
        double shift = floor(lo / period) * period;
        if (isfinite(shift))
            for (int k = 0; k < 3; k++)
                p[2 * k + a] -= shift;
    }
}

/* Keeps the part of polygon in[n] (x,y pairs) with sign·(coordinate axis − c) >= 0. */
static int clip(const double *in, int n, int axis, double c, double sign, double *out)
{
    int m = 0;
    for (int i = 0; i < n; i++) {
        const double *a = in + 2 * i, *b = in + 2 * ((i + 1) % n);
        double da = sign * (a[axis] - c), db = sign * (b[axis] - c);
        if (da >= 0) {
            out[2 * m] = a[0];
            out[2 * m + 1] = a[1];
            m++;
        }
        if ((da >= 0) != (db >= 0)) {
            double s = da / (da - db);
            out[2 * m] = a[0] + s * (b[0] - a[0]);
            out[2 * m + 1] = a[1] + s * (b[1] - a[1]);
            out[2 * m + axis] = c; /* exactly on the line */
            m++;
        }
    }
    return m;
}

static double poly_area(const double *p, int n)
{
    double s = 0;
    for (int i = 0; i < n; i++) {
        const double *a = p + 2 * i, *b = p + 2 * ((i + 1) % n);
        s += a[0] * b[1] - a[1] * b[0];
    }
    return 0.5 * fabs(s);
}

static void point_value(const lrr__texture *t, double x, double y, double out[3])
{
    const float *v = texel(t, texel_index(x), texel_index(y));
    for (int c = 0; c < 3; c++)
        out[c] = v[c];
}

static void mean_sampled(const lrr__texture *t, const double *p, unsigned m, double out[3])
{
    double sum[3] = {0, 0, 0};
    /* The midpoint rule on the m² congruent sub-triangles of the regular split: upright ones
     * at barycentric grid cells (i, j), i + j < m, inverted ones at i + j < m − 1. */
    for (unsigned i = 0; i < m; i++)
        for (unsigned j = 0; i + j < m; j++)
            for (int inv = 0; inv < 2; inv++) {
                if (inv && i + j + 1 >= m)
                    continue;
                double b1 = (i + (inv ? 2.0 : 1.0) / 3) / m, b2 = (j + (inv ? 2.0 : 1.0) / 3) / m;
                double b0 = 1 - b1 - b2, v[3];
                point_value(t, b0 * p[0] + b1 * p[2] + b2 * p[4],
                            b0 * p[1] + b1 * p[3] + b2 * p[5], v);
                for (int c = 0; c < 3; c++)
                    sum[c] += v[c];
            }
    for (int c = 0; c < 3; c++)
        out[c] = sum[c] / ((double)m * m);
}

void lrr__texture_mean_sampled(const lrr__texture *t, const double uv[6], unsigned m,
                               double out[3])
{
    double p[6];
    to_texels(t, uv, p);
    mean_sampled(t, p, m ? m : 1, out);
}

/* Exact texel-area integration over the texel-space triangle p, or the midpoint rule when
 * its bounding box holds more than `limit` texels. */
static void mean_of(const lrr__texture *t, const double uv[6], double limit, double out[3])
{
    double p[6];
    to_texels(t, uv, p);
    double x0 = fmin(p[0], fmin(p[2], p[4])), x1 = fmax(p[0], fmax(p[2], p[4]));
    double y0 = fmin(p[1], fmin(p[3], p[5])), y1 = fmax(p[1], fmax(p[3], p[5]));
    double total = poly_area(p, 3);
    if (!isfinite(x0 + x1 + y0 + y1 + total)) {
        out[0] = out[1] = out[2] = 0; /* UVs were checked finite at import; be safe */
        return;
    }
    if (!(total > 0)) { /* all corners on one UV point or line: the texel at the centre */
        point_value(t, (p[0] + p[2] + p[4]) / 3, (p[1] + p[3] + p[5]) / 3, out);
        return;
    }
    if (!(fabs(x0) < 0x1p52 && fabs(x1) < 0x1p52 && fabs(y0) < 0x1p52 && fabs(y1) < 0x1p52)) {
        /* beyond exact integers (clamped far-off UVs): the texel loops below could not
         * count there, and the points the midpoint rule takes are all the same texels */
        mean_sampled(t, p, LRR__TEXEL_SAMPLES, out);
        return;
    }
    double fx0 = floor(x0), fy0 = floor(y0);
    double cols = ceil(x1) - fx0, rows = ceil(y1) - fy0;
    if (!(cols * rows <= limit)) {
        mean_sampled(t, p, LRR__TEXEL_SAMPLES, out);
        return;
    }
    double sum[3] = {0, 0, 0};
    double strip[2 * 8], tmp[2 * 8], cell[2 * 8];
    for (long long r = (long long)fy0; r < (long long)fy0 + (long long)rows; r++) {
        int n = clip(p, 3, 1, (double)r, 1, tmp);
        n = clip(tmp, n, 1, (double)r + 1, -1, strip);
        if (n < 3)
            continue;
        double sx0 = strip[0], sx1 = strip[0];
        for (int i = 1; i < n; i++) {
            sx0 = fmin(sx0, strip[2 * i]);
            sx1 = fmax(sx1, strip[2 * i]);
        }
        for (long long c = (long long)floor(sx0); (double)c < sx1; c++) {
            int m = clip(strip, n, 0, (double)c, 1, tmp);
            m = clip(tmp, m, 0, (double)c + 1, -1, cell);
            if (m < 3)
                continue;
            double a = poly_area(cell, m);
            const float *v = texel(t, c, r);
            for (int k = 0; k < 3; k++)
                sum[k] += a * v[k];
        }
    }
    for (int k = 0; k < 3; k++)
        out[k] = sum[k] / total;
}

void lrr__texture_mean(const lrr__texture *t, const double uv[6], double out[3])
{
    mean_of(t, uv, LRR__TEXEL_EXACT_MAX, out);
}

void lrr__texture_mean_exact(const lrr__texture *t, const double uv[6], double out[3])
{
    mean_of(t, uv, INFINITY, out);
}

/* ------------------------------------------------------------------ quadtree */

void lrr__subtriangle_uv(const float uv[6], unsigned depth, size_t local, double out[6])
{
    double v[6];
    for (int i = 0; i < 6; i++)
        v[i] = uv[i];
    for (unsigned l = depth; l-- > 0;) {
        double r[6];
        lrr__child_corners(v, 2, (unsigned)((local >> (2 * l)) & 3), r);
        memcpy(v, r, sizeof r);
    }
    memcpy(out, v, sizeof v);
}
