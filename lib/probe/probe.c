/* Light probes: loading (Radiance .hdr through stb_image, OpenEXR through exr.cpp),
 * validation, the ground-truth
 * irradiance sum and the irradiance of a set of directional lights. */
#include "config.h"
#include "probe/probe.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <stb_image.h>

#define PI 3.14159265358979323846

/* Normals per block and pixels per block of the irradiance sum: a pixel block (6 floats per
 * pixel, 96 KiB) stays in L2 while a block of normals runs over it. */
#define NORMAL_BLOCK 32
#define PIXEL_BLOCK 4096

void lrr_probe_destroy(lrr_probe *probe)
{
    if (!probe)
        return;
    lrr_aligned_free(probe->rgb);
    lrr_aligned_free(probe->dir);
    lrr_aligned_free(probe->q);
    lrr_aligned_free(probe->energy);
    lrr__context_release(probe->ctx);
    free(probe);
}

void lrr_probe_size(const lrr_probe *probe, size_t *width, size_t *height)
{
    *width = probe->w;
    *height = probe->h;
}

/* Checks the layout and the pixels; `source` names the origin, bad_pixel is the status of a
 * non-finite or negative pixel. */
static lrr_status check_probe(lrr_context *ctx, size_t w, size_t h, const float *rgb,
                              const char *source, lrr_status bad_pixel)
{
    if (h == 0 || w != 2 * h)
        return lrr__error(ctx, LRR_ERR_DIM,
                          "%s: %zu×%zu pixels is not a latitude–longitude probe (expected "
                          "width = 2 × height, row 0 the zenith, e.g. 1024×512)",
                          source, w, h);
    size_t n;
    if (!lrr__mul_size(w, h, &n) || n > SIZE_MAX / 3)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "%s: %zu×%zu pixels overflow size_t", source,
                          w, h);
    for (size_t i = 0; i < 3 * n; i++) {
        float p = rgb[i];
        if (!isfinite(p) || p < 0) {
            static const char ch[3] = {'r', 'g', 'b'};
            size_t pix = i / 3;
            return lrr__error(ctx, bad_pixel,
                              "%s: pixel x=%zu y=%zu channel %c is %g (radiance must be "
                              "finite and >= 0)",
                              source, pix % w, pix / w, ch[i % 3], (double)p);
        }
    }
    return LRR_OK;
}

/* Takes a copy of validated pixels and precomputes the per-pixel directions and weights. */
static lrr_status probe_new(lrr_context *ctx, size_t w, size_t h, const float *rgb,
                            lrr_probe **out)
{
    lrr_probe *p = lrr__zalloc(ctx, sizeof *p);
    if (!p)
        return lrr__error(ctx, LRR_ERR_NOMEM, "probe: cannot allocate");
    p->ctx = lrr__context_retain(ctx);
    p->w = w;
    p->h = h;
    size_t n = w * h;
    lrr_status st = lrr__calloc(ctx, &p->rgb, n, 3 * sizeof(float), "probe pixels");
    if (st == LRR_OK)
        st = lrr__calloc(ctx, &p->dir, n, 3 * sizeof(float), "probe directions");
    if (st == LRR_OK)
        st = lrr__calloc(ctx, &p->q, n, 3 * sizeof(float), "probe weights");
    if (st == LRR_OK)
        st = lrr__calloc(ctx, &p->energy, n, sizeof(double), "probe energy");
    if (st != LRR_OK) {
        lrr_probe_destroy(p);
        return st;
    }
    memcpy(p->rgb, rgb, n * 3 * sizeof(float));
    double dA = 2 * PI * PI / ((double)w * (double)h);
    for (size_t v = 0; v < h; v++) {
        double theta = PI * (v + 0.5) / (double)h;
        double st_ = sin(theta), ct = cos(theta);
        double q = st_ * dA;
        for (size_t u = 0; u < w; u++) {
            double phi = 2 * PI * (u + 0.5) / (double)w;
            size_t i = v * w + u;
            p->dir[i] = (float)(st_ * cos(phi));
            p->dir[n + i] = (float)ct;
            p->dir[2 * n + i] = (float)(st_ * sin(phi));
            const float *c = rgb + 3 * i;
            p->q[i] = (float)(q * c[0]);
            p->q[n + i] = (float)(q * c[1]);
            p->q[2 * n + i] = (float)(q * c[2]);
            p->energy[i] = q * (0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]);
        }
    }
    *out = p;
    return LRR_OK;
}

lrr_status lrr_probe_create(lrr_context *ctx, size_t width, size_t height, const float *rgb,
                            lrr_probe **out)
{
    *out = NULL;
    lrr_status st = check_probe(ctx, width, height, rgb, "probe", LRR_ERR_INVALID_ARG);
    if (st != LRR_OK)
        return st;
    return probe_new(ctx, width, height, rgb, out);
}

/* True when path ends in ".exr" (any case). */
static bool is_exr_path(const char *path)
{
    size_t n = strlen(path);
    if (n < 4)
        return false;
    const char *e = path + n - 4;
    return e[0] == '.' && (e[1] | 0x20) == 'e' && (e[2] | 0x20) == 'x' && (e[3] | 0x20) == 'r';
}

/* An OpenEXR probe: lossy compressions (DWA, B44) ring slightly below 0 near dark pixels
 * (the shipped probes: up to -0.003); finite negatives are clamped to 0, as the .hdr copies
 * were, while non-finite pixels are an error naming x, y and the channel. */
static lrr_status load_exr(lrr_context *ctx, const char *path, lrr_probe **out)
{
    float *pix;
    size_t w, h;
    lrr_status st = lrr__exr_read_rgb(ctx, path, &pix, &w, &h);
    if (st != LRR_OK)
        return st;
    if (h != 0 && w == 2 * h && w <= SIZE_MAX / 3 / h)
        for (size_t i = 0; i < 3 * w * h; i++)
            if (pix[i] < 0) /* false for NaN */
                pix[i] = 0;
    char source[512];
    snprintf(source, sizeof source, "'%s'", path);
    st = check_probe(ctx, w, h, pix, source, LRR_ERR_FORMAT);
    if (st == LRR_OK)
        st = probe_new(ctx, w, h, pix, out);
    free(pix);
    return st;
}

lrr_status lrr_probe_load(lrr_context *ctx, const char *path, lrr_probe **out)
{
    *out = NULL;
    if (is_exr_path(path))
        return load_exr(ctx, path, out);
    float *pix;
    size_t w, h;
    lrr_status st = lrr__hdr_read_rgb(ctx, path, &pix, &w, &h);
    if (st != LRR_OK)
        return st;
    char source[512];
    snprintf(source, sizeof source, "'%s'", path);
    st = check_probe(ctx, w, h, pix, source, LRR_ERR_FORMAT);
    if (st == LRR_OK)
        st = probe_new(ctx, w, h, pix, out);
    stbi_image_free(pix);
    return st;
}

/* Unit normals from m×3 input; non-finite or zero normals are an error naming the index. */
static lrr_status unit_normals(lrr_context *ctx, size_t m, const float *normals, float *unit)
{
    for (size_t i = 0; i < m; i++) {
        double x = normals[3 * i], y = normals[3 * i + 1], z = normals[3 * i + 2];
        double len = sqrt(x * x + y * y + z * z);
        if (!isfinite(len) || len == 0)
            return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                              "normal %zu is (%g, %g, %g): it must be finite and non-zero", i,
                              x, y, z);
        unit[3 * i] = (float)(x / len);
        unit[3 * i + 1] = (float)(y / len);
        unit[3 * i + 2] = (float)(z / len);
    }
    return LRR_OK;
}

lrr_status lrr_probe_irradiance(const lrr_probe *probe, size_t m, const float *normals,
                                float *out)
{
    lrr_context *ctx = probe->ctx;
    float *unit;
    lrr_status st = lrr__calloc(ctx, &unit, m, 3 * sizeof(float), "irradiance normals");
    if (st != LRR_OK)
        return st;
    st = unit_normals(ctx, m, normals, unit);
    if (st != LRR_OK) {
        lrr_aligned_free(unit);
        return st;
    }
    const size_t n = probe->w * probe->h;
    const float *dx = probe->dir, *dy = probe->dir + n, *dz = probe->dir + 2 * n;
    const float *qr = probe->q, *qg = probe->q + n, *qb = probe->q + 2 * n;
    const size_t nblocks = (m + NORMAL_BLOCK - 1) / NORMAL_BLOCK;
    double work = (double)m * (double)n;
#pragma omp parallel for schedule(dynamic, 1) if (work > (double)LRR__PARALLEL_MIN)
    for (size_t b = 0; b < nblocks; b++) {
        size_t i0 = b * NORMAL_BLOCK, i1 = i0 + NORMAL_BLOCK < m ? i0 + NORMAL_BLOCK : m;
        double acc[NORMAL_BLOCK][3] = {{0}};
        for (size_t p0 = 0; p0 < n; p0 += PIXEL_BLOCK) {
            size_t p1 = p0 + PIXEL_BLOCK < n ? p0 + PIXEL_BLOCK : n;
            for (size_t i = i0; i < i1; i++) {
                const float nx = unit[3 * i], ny = unit[3 * i + 1], nz = unit[3 * i + 2];
                float sr = 0, sg = 0, sb = 0;
#pragma omp simd reduction(+ : sr, sg, sb)
                for (size_t p = p0; p < p1; p++) {
                    float c = nx * dx[p] + ny * dy[p] + nz * dz[p];
                    c = c > 0 ? c : 0;
                    sr += c * qr[p];
                    sg += c * qg[p];
                    sb += c * qb[p];
                }
                acc[i - i0][0] += sr;
                acc[i - i0][1] += sg;
                acc[i - i0][2] += sb;
            }
        }
        for (size_t i = i0; i < i1; i++)
            for (int c = 0; c < 3; c++)
                out[3 * i + c] = (float)acc[i - i0][c];
    }
    lrr_aligned_free(unit);
    return LRR_OK;
}

lrr_status lrr_lights_irradiance(const lrr_light *lights, size_t count, size_t m,
                                 const float *normals, float *out)
{
    for (size_t i = 0; i < m; i++) {
        double x = normals[3 * i], y = normals[3 * i + 1], z = normals[3 * i + 2];
        double len = sqrt(x * x + y * y + z * z);
        if (!isfinite(len) || len == 0)
            return LRR_ERR_INVALID_ARG;
        double e[3] = {0, 0, 0};
        for (size_t l = 0; l < count; l++) {
            const lrr_light *L = lights + l;
            double c = (x * L->dir[0] + y * L->dir[1] + z * L->dir[2]) / len;
            if (c > 0)
                for (int k = 0; k < 3; k++)
                    e[k] += c * L->rgb[k];
        }
        for (int k = 0; k < 3; k++)
            out[3 * i + k] = (float)e[k];
    }
    return LRR_OK;
}

void lrr_sphere_points(size_t m, float *out)
{
    const double golden = PI * (3 - sqrt(5.0));
    for (size_t i = 0; i < m; i++) {
        double y = 1 - (2 * (double)i + 1) / (double)m;
        double r = sqrt(fmax(0, 1 - y * y));
        double phi = golden * (double)i;
        out[3 * i] = (float)(r * cos(phi));
        out[3 * i + 1] = (float)y;
        out[3 * i + 2] = (float)(r * sin(phi));
    }
}
