/* Light probes: loading, ground-truth irradiance, median cut, SH9, errors. */
#include "testutil.h"
#include "probe/probe.h" /* the pixels, to compare .exr with .hdr */

/* A light's float direction and colour from sin, cos and a product (5 roundings, k = 2);
 * a value that is 0 in exact arithmetic is within one float epsilon (TU_TOL_FLT(1, 1)). */
#define FLOAT_TOL TU_TOL_FLT(2, 5)

#define PI 3.14159265358979323846

static float *probe_pixels(size_t w, size_t h) { return calloc(w * h * 3, sizeof(float)); }

/* max |a - b| over 3m entries */
static double max_abs_diff(const float *a, const float *b, size_t m)
{
    double d = 0;
    for (size_t i = 0; i < 3 * m; i++)
        d = fmax(d, fabs((double)a[i] - b[i]));
    return d;
}

/* A probe that is black except one pixel is reproduced exactly by one light. */
static void test_single_pixel(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t w = 64, h = 32, u = 10, v = 7;
    float *pix = probe_pixels(w, h);
    pix[3 * (v * w + u)] = 3;
    pix[3 * (v * w + u) + 1] = 2;
    pix[3 * (v * w + u) + 2] = 1;
    lrr_probe *p;
    LRR_CHECK(ctx, lrr_probe_create(ctx, w, h, pix, &p));
    lrr_light L;
    LRR_CHECK(ctx, lrr_probe_median_cut(p, 1, &L));
    double theta = PI * (v + 0.5) / h, phi = 2 * PI * (u + 0.5) / w;
    double q = sin(theta) * 2 * PI * PI / (double)(w * h);
    ASSERT_NEAR(L.dir[0], sin(theta) * cos(phi), FLOAT_TOL, "dir x");
    ASSERT_NEAR(L.dir[1], cos(theta), FLOAT_TOL, "dir y");
    ASSERT_NEAR(L.dir[2], sin(theta) * sin(phi), FLOAT_TOL, "dir z");
    for (int c = 0; c < 3; c++)
        ASSERT_NEAR(L.rgb[c], q * (3 - c), FLOAT_TOL * q, "rgb %d", c);
    size_t m = 500;
    float *n = calloc(3 * m, sizeof(float)), *truth = calloc(3 * m, sizeof(float)),
          *approx = calloc(3 * m, sizeof(float));
    lrr_sphere_points(m, n);
    LRR_CHECK(ctx, lrr_probe_irradiance(p, m, n, truth));
    LRR_CHECK(ctx, lrr_lights_irradiance(&L, 1, m, n, approx));
    ASSERT_NEAR(max_abs_diff(truth, approx, m), 0, FLOAT_TOL * 3 * q, "one light vs truth");
    free(n);
    free(truth);
    free(approx);
    free(pix);
    lrr_probe_destroy(p);
    lrr_context_destroy(ctx);
}

/* A constant probe: E = π L for every normal; SH9 reproduces it. */
static void test_constant(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t w = 256, h = 128;
    float *pix = probe_pixels(w, h);
    const float L[3] = {1, 2, 0.5f};
    for (size_t i = 0; i < w * h; i++)
        for (int c = 0; c < 3; c++)
            pix[3 * i + c] = L[c];
    lrr_probe *p;
    LRR_CHECK(ctx, lrr_probe_create(ctx, w, h, pix, &p));
    size_t m = 1000;
    float *n = calloc(3 * m, sizeof(float)), *truth = calloc(3 * m, sizeof(float)),
          *sh = calloc(3 * m, sizeof(float));
    lrr_sphere_points(m, n);
    LRR_CHECK(ctx, lrr_probe_irradiance(p, m, n, truth));
    float coeffs[27];
    LRR_CHECK(ctx, lrr_probe_sh9(p, coeffs));
    LRR_CHECK(ctx, lrr_sh9_irradiance(coeffs, m, n, sh));
    /* midpoint rule on 256×128 pixels: measured max relative error 6.0e-5 (truth), 5.6e-5
     * (SH9) over the 1000 normals */
    for (size_t i = 0; i < m; i++)
        for (int c = 0; c < 3; c++) {
            ASSERT_NEAR(truth[3 * i + c], PI * L[c], 5e-4 * PI * L[c], "truth normal %zu", i);
            ASSERT_NEAR(sh[3 * i + c], PI * L[c], 5e-4 * PI * L[c], "sh9 normal %zu", i);
        }
    /* the higher bands vanish up to the discretisation (measured 1.7e-4 at most, against
     * L00 = 4π L Y00 ≈ 7 for the green channel) */
    for (int k = 3; k < 27; k++)
        ASSERT_NEAR(coeffs[k], 0, 1e-3, "coefficient %d", k);
    free(n);
    free(truth);
    free(sh);
    free(pix);
    lrr_probe_destroy(p);
    lrr_context_destroy(ctx);
}

/* Constant upper hemisphere, black lower: E(up) = π L, E(down) = 0, E(horizontal) = π L / 2. */
static void test_hemisphere(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t w = 512, h = 256;
    float *pix = probe_pixels(w, h);
    for (size_t i = 0; i < w * h / 2; i++)
        for (int c = 0; c < 3; c++)
            pix[3 * i + c] = 1;
    lrr_probe *p;
    LRR_CHECK(ctx, lrr_probe_create(ctx, w, h, pix, &p));
    const float n[12] = {0, 1, 0, 0, -1, 0, 1, 0, 0, 0, 0, 1};
    float e[12];
    LRR_CHECK(ctx, lrr_probe_irradiance(p, 4, n, e));
    /* measured relative discretisation errors at 512×256: up 2.5e-5, horizontal 6.4e-6,
     * down exactly 0 */
    ASSERT_NEAR(e[1], PI, 1e-4 * PI, "up");
    ASSERT_NEAR(e[4], 0, TU_TOL_FLT(1, 1), "down");
    ASSERT_NEAR(e[7], PI / 2, 2e-4 * PI, "horizontal x");
    ASSERT_NEAR(e[10], PI / 2, 2e-4 * PI, "horizontal z");
    free(pix);
    lrr_probe_destroy(p);
    lrr_context_destroy(ctx);
}

static double luminance(const float *rgb)
{
    return 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2];
}

/* Median cut splits into equal-energy regions (within one row or column's energy); energy is
 * conserved for the classic and the adaptive variant. */
static void test_median_cut_equal(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t w = 128, h = 64;
    float *pix = probe_pixels(w, h);
    uint32_t s = 12345;
    for (size_t i = 0; i < 3 * w * h; i++) {
        s = s * 1664525u + 1013904223u;
        pix[i] = (float)(s >> 8) / (float)(1u << 24) + ((i / 3) % 97 == 0 ? 50.0f : 0.0f);
    }
    lrr_probe *p;
    LRR_CHECK(ctx, lrr_probe_create(ctx, w, h, pix, &p));
    /* the largest energy of one whole row or column bounds that of any part of one */
    double dA = 2 * PI * PI / (double)(w * h), maxline = 0, total = 0;
    for (size_t v = 0; v < h; v++) {
        double row = 0;
        for (size_t u = 0; u < w; u++) {
            double e = luminance(pix + 3 * (v * w + u)) * sin(PI * (v + 0.5) / h) * dA;
            row += e;
            total += e;
        }
        maxline = fmax(maxline, row);
    }
    for (size_t u = 0; u < w; u++) {
        double col = 0;
        for (size_t v = 0; v < h; v++)
            col += luminance(pix + 3 * (v * w + u)) * sin(PI * (v + 0.5) / h) * dA;
        maxline = fmax(maxline, col);
    }
    lrr_light lights[8];
    LRR_CHECK(ctx, lrr_probe_median_cut(p, 2, lights));
    ASSERT_NEAR(luminance(lights[0].rgb), luminance(lights[1].rgb), maxline, "2 regions");
    LRR_CHECK(ctx, lrr_probe_median_cut(p, 4, lights));
    /* siblings of the second pass: regions r and r + 2 */
    ASSERT_NEAR(luminance(lights[0].rgb), luminance(lights[2].rgb), maxline, "4 regions a");
    ASSERT_NEAR(luminance(lights[1].rgb), luminance(lights[3].rgb), maxline, "4 regions b");
    LRR_CHECK(ctx, lrr_probe_median_cut(p, 8, lights));
    double sum = 0;
    for (int i = 0; i < 8; i++) {
        sum += luminance(lights[i].rgb);
        ASSERT_NEAR(luminance(lights[i].rgb), total / 8, 4 * maxline, "8 regions %d", i);
    }
    ASSERT_NEAR(sum, total, 1e-5 * total, "8 regions conserve energy");
    LRR_CHECK(ctx, lrr_probe_median_cut(p, 5, lights));
    sum = 0;
    for (int i = 0; i < 5; i++)
        sum += luminance(lights[i].rgb);
    ASSERT_NEAR(sum, total, 1e-5 * total, "adaptive 5 regions conserve energy");
    free(pix);
    lrr_probe_destroy(p);
    lrr_context_destroy(ctx);
}

static void expect_error(lrr_context *ctx, lrr_status got, lrr_status want, const char *needle)
{
    char msg[512];
    lrr_status st = lrr_context_last_error(ctx, msg, sizeof msg);
    if (got != want || st != want || !strstr(msg, needle))
        fail_msg("got %s (%s), expected %s with '%s'", lrr_strerror(got), msg,
                 lrr_strerror(want), needle);
}

/* Writes a flat (uncompressed) Radiance file of w×h pixels, all with RGBE (r, g, b, e). */
static void write_hdr(const char *path, int w, int h, const unsigned char rgbe[4])
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fprintf(f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n", h, w);
    for (int i = 0; i < w * h; i++)
        fwrite(rgbe, 1, 4, f);
    fclose(f);
}

/* Writes a Radiance header for w×h pixels followed by the given pixel bytes. */
static void write_raw_hdr(char *path, size_t path_size, const char *name, int w, int h,
                          const unsigned char *data, size_t size)
{
    tu_tmp_path(path, path_size, name);
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fprintf(f, "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n", h, w);
    fwrite(data, 1, size, f);
    fclose(f);
}

static void test_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_probe *p = NULL;
    float *pix = probe_pixels(64, 64);
    expect_error(ctx, lrr_probe_create(ctx, 64, 64, pix, &p), LRR_ERR_DIM, "64×64");
    expect_error(ctx, lrr_probe_create(ctx, 0, 0, pix, &p), LRR_ERR_DIM, "width = 2 × height");
    pix[3 * (3 * 16 + 5) + 1] = NAN;
    expect_error(ctx, lrr_probe_create(ctx, 16, 8, pix, &p), LRR_ERR_INVALID_ARG, "x=5 y=3");
    pix[3 * (3 * 16 + 5) + 1] = -1;
    expect_error(ctx, lrr_probe_create(ctx, 16, 8, pix, &p), LRR_ERR_INVALID_ARG, "x=5 y=3");
    pix[3 * (3 * 16 + 5) + 1] = INFINITY;
    expect_error(ctx, lrr_probe_create(ctx, 16, 8, pix, &p), LRR_ERR_INVALID_ARG, "is inf");
    assert_null(p);
    pix[3 * (3 * 16 + 5) + 1] = 1;
    LRR_CHECK(ctx, lrr_probe_create(ctx, 16, 8, pix, &p));
    lrr_light lights[2];
    expect_error(ctx, lrr_probe_median_cut(p, 0, lights), LRR_ERR_INVALID_ARG, "0 lights");
    expect_error(ctx, lrr_probe_median_cut(p, 129, lights), LRR_ERR_INVALID_ARG, "1 to 128");
    float bad_n[3] = {0, 0, 0}, out[3];
    expect_error(ctx, lrr_probe_irradiance(p, 1, bad_n, out), LRR_ERR_INVALID_ARG, "normal 0");
    assert_int_equal(lrr_lights_irradiance(lights, 0, 1, bad_n, out), LRR_ERR_INVALID_ARG);
    float coeffs[27] = {0};
    assert_int_equal(lrr_sh9_irradiance(coeffs, 1, bad_n, out), LRR_ERR_INVALID_ARG);
    lrr_probe_destroy(p);
    p = NULL;

    char path[512];
    expect_error(ctx, lrr_probe_load(ctx, "/nonexistent/probe.hdr", &p), LRR_ERR_IO,
                 "cannot open");
    tu_tmp_path(path, sizeof path, "probe-text.hdr");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("not an image\n", f);
    fclose(f);
    expect_error(ctx, lrr_probe_load(ctx, path, &p), LRR_ERR_FORMAT, "Radiance");
    unlink(path);
    /* a real .hdr of the wrong shape, and one of the right shape */
    const unsigned char one[4] = {128, 64, 32, 129}; /* (1, 0.5, 0.25) */
    tu_tmp_path(path, sizeof path, "probe-square.hdr");
    write_hdr(path, 4, 4, one);
    expect_error(ctx, lrr_probe_load(ctx, path, &p), LRR_ERR_DIM, "4×4");
    unlink(path);
    /* run-length encoded scanlines stb_image would refuse only after allocating the whole
     * image (1.5 GB for the first): refused before decoding, by our own reading */
    static const unsigned char wrong_length[] = {2, 2, 0x40, 0x46, 0x80 + 3, 1, 2, 3};
    write_raw_hdr(path, sizeof path, "probe-rle-length.hdr", 16384, 8192, wrong_length,
                  sizeof wrong_length);
    expect_error(ctx, lrr_probe_load(ctx, path, &p), LRR_ERR_FORMAT, "not the image width");
    unlink(path);
    static const unsigned char long_run[] = {2, 2, 0, 16, 0x80 + 17, 7};
    write_raw_hdr(path, sizeof path, "probe-rle-run.hdr", 16, 8, long_run, sizeof long_run);
    expect_error(ctx, lrr_probe_load(ctx, path, &p), LRR_ERR_FORMAT, "longer than the rest");
    unlink(path);
    tu_tmp_path(path, sizeof path, "probe-ok.hdr");
    write_hdr(path, 8, 4, one);
    LRR_CHECK(ctx, lrr_probe_load(ctx, path, &p));
    unlink(path);
    size_t w, h;
    lrr_probe_size(p, &w, &h);
    assert_int_equal(w, 8);
    assert_int_equal(h, 4);
    const float up[3] = {0, 1, 0};
    float e[3];
    LRR_CHECK(ctx, lrr_probe_irradiance(p, 1, up, e));
    /* 4 rows, the upper two lit: the midpoint rule gives 2π·(π/4)·(sin cos 22.5° + sin cos
     * 67.5°) = π²/(2√2) per unit radiance (11% above π at this size), exactly what the
     * decoded pixels (1, 0.5, 0.25) must give */
    double e1 = PI * PI / (2 * sqrt(2.0));
    ASSERT_NEAR(e[0], e1, 1e-5 * e1, "loaded probe, red");
    ASSERT_NEAR(e[1], e1 / 2, 1e-5 * e1, "loaded probe, green");
    ASSERT_NEAR(e[2], e1 / 4, 1e-5 * e1, "loaded probe, blue");
    lrr_probe_destroy(p);
    free(pix);
    lrr_context_destroy(ctx);
}

/* The shipped probes load as 1024×512. */
static void test_shipped(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_probe *p;
    LRR_CHECK(ctx, lrr_probe_load(ctx, LRR_DATA_DIR "/probes/studio.hdr", &p));
    size_t w, h;
    lrr_probe_size(p, &w, &h);
    assert_int_equal(w, 1024);
    assert_int_equal(h, 512);
    lrr_probe_destroy(p);
    lrr_context_destroy(ctx);
}

/* Copies the first `keep` bytes of src to dst. */
static void copy_prefix(const char *src, const char *dst, long keep)
{
    FILE *in = fopen(src, "rb"), *out = fopen(dst, "wb");
    assert_non_null(in);
    assert_non_null(out);
    char buf[4096];
    long left = keep;
    while (left > 0) {
        size_t got = fread(buf, 1, left < (long)sizeof buf ? (size_t)left : sizeof buf, in);
        if (got == 0)
            break;
        assert_int_equal(fwrite(buf, 1, got, out), got);
        left -= (long)got;
    }
    fclose(in);
    fclose(out);
}

/* The shipped OpenEXR probes (DWAB-compressed) load as W = 2H and agree with their .hdr
 * copies: pixels to the RGBE quantisation, irradiance closely. */
static void test_exr_shipped(void **state)
{
    (void)state;
    TU_REQUIRE("openexr");
    lrr_context *ctx = tu_context();
    static const char *const names[] = {"courtyard", "forest", "studio", "sunset"};
    const size_t m = 256;
    float *dirs = calloc(3 * m, sizeof(float)), *ex = calloc(3 * m, sizeof(float)),
          *eh = calloc(3 * m, sizeof(float));
    assert_non_null(dirs);
    assert_non_null(ex);
    assert_non_null(eh);
    lrr_sphere_points(m, dirs);
    for (size_t k = 0; k < 4; k++) {
        char path[512];
        lrr_probe *pe, *ph;
        snprintf(path, sizeof path, "%s/probes/%s.exr", LRR_DATA_DIR, names[k]);
        LRR_CHECK(ctx, lrr_probe_load(ctx, path, &pe));
        snprintf(path, sizeof path, "%s/probes/%s.hdr", LRR_DATA_DIR, names[k]);
        LRR_CHECK(ctx, lrr_probe_load(ctx, path, &ph));
        size_t w, h, wh, hh;
        lrr_probe_size(pe, &w, &h);
        lrr_probe_size(ph, &wh, &hh);
        assert_int_equal(w, 2 * h);
        assert_int_equal(w, wh);
        assert_int_equal(h, hh);
        double d2 = 0, n2 = 0;
        for (size_t i = 0; i < 3 * w * h; i++) {
            double d = (double)pe->rgb[i] - ph->rgb[i];
            d2 += d * d;
            n2 += (double)pe->rgb[i] * pe->rgb[i];
        }
        double rel = sqrt(d2 / n2);
        LRR_CHECK(ctx, lrr_probe_irradiance(pe, m, dirs, ex));
        LRR_CHECK(ctx, lrr_probe_irradiance(ph, m, dirs, eh));
        double emax = 0, dmax = 0;
        for (size_t i = 0; i < 3 * m; i++) {
            emax = fmax(emax, ex[i]);
            dmax = fmax(dmax, fabs((double)ex[i] - eh[i]));
        }
        printf("# %s: %zux%zu, pixel relative L2 %.3g, irradiance max diff / max %.3g\n",
               names[k], w, h, rel, dmax / emax);
        /* RGBE keeps 8-bit mantissas (a rounding of up to 2^-8 of a pixel's largest channel,
         * relatively more for the smaller ones) and the .hdr copies clamp the DWA ringing
         * below 0. Measured pixel relative L2: courtyard 4.1e-3, forest 3.4e-3, studio
         * 2.5e-3, sunset 5.2e-3; irradiance max |E_exr - E_hdr| / max E over 256 normals:
         * 3.4e-3, 3.0e-3, 2.2e-3, 3.3e-3. Asserted: 2^-7 = 7.8e-3 and 6e-3. */
        assert_true(rel < 1.0 / 128);
        assert_true(dmax < 6e-3 * emax);
        lrr_probe_destroy(pe);
        lrr_probe_destroy(ph);
    }
    free(dirs);
    free(ex);
    free(eh);
    lrr_context_destroy(ctx);
}

/* Broken .exr files: a clear error naming the file, no crash. */
static void test_exr_errors(void **state)
{
    (void)state;
    TU_REQUIRE("openexr");
    lrr_context *ctx = tu_context();
    lrr_probe *p = NULL;
    char path[512];
    expect_error(ctx, lrr_probe_load(ctx, "/nonexistent/probe.exr", &p), LRR_ERR_IO,
                 "/nonexistent/probe.exr");
    tu_tmp_path(path, sizeof path, "x.exr");
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("not an image\n", f);
    fclose(f);
    expect_error(ctx, lrr_probe_load(ctx, path, &p), LRR_ERR_FORMAT, path);
    assert_null(p);
    unlink(path);
    /* truncated: the header survives, the pixel data does not */
    static const long keep[] = {100, 20000, 90000};
    tu_tmp_path(path, sizeof path, "probe-truncated.exr");
    for (size_t i = 0; i < 3; i++) {
        copy_prefix(LRR_DATA_DIR "/probes/studio.exr", path, keep[i]);
        expect_error(ctx, lrr_probe_load(ctx, path, &p), LRR_ERR_FORMAT, path);
        assert_null(p);
    }
    unlink(path);
    lrr_context_destroy(ctx);
}

/* mean relative error (%) of lights against the truth on m sphere points */
static double lights_mean_error(const lrr_light *L, size_t n, size_t m, const float *dirs,
                                const float *truth)
{
    float *approx = calloc(3 * m, sizeof(float));
    assert_non_null(approx);
    assert_int_equal(lrr_lights_irradiance(L, n, m, dirs, approx), LRR_OK);
    double tmax = 0, sum = 0;
    size_t counted = 0;
    for (size_t i = 0; i < 3 * m; i++)
        tmax = fmax(tmax, truth[i]);
    for (size_t i = 0; i < 3 * m; i++)
        if (truth[i] > 1e-6 * tmax) {
            sum += fabs((double)approx[i] - truth[i]) / truth[i];
            counted++;
        }
    free(approx);
    return 100 * sum / (double)counted;
}

/* Irradiance optimisation on the studio probe: monotone objective, rgb >= 0, unit directions,
 * lower error than median cut at the same count, and no NaN at 128 lights. */
static void test_fit_irradiance(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_probe *p;
    LRR_CHECK(ctx, lrr_probe_load(ctx, LRR_DATA_DIR "/probes/studio.hdr", &p));
    const size_t m = 256;
    float *dirs = calloc(3 * m, sizeof(float)), *truth = calloc(3 * m, sizeof(float));
    assert_non_null(dirs);
    assert_non_null(truth);
    lrr_sphere_points(m, dirs);
    LRR_CHECK(ctx, lrr_probe_irradiance(p, m, dirs, truth));
    const size_t counts[] = {8, 64, 128}, caps[] = {100, 30, 8};
    for (size_t k = 0; k < 3; k++) {
        size_t n = counts[k];
        lrr_light *mc = calloc(n, sizeof *mc), *fit = calloc(n, sizeof *fit);
        assert_non_null(mc);
        assert_non_null(fit);
        LRR_CHECK(ctx, lrr_probe_median_cut(p, n, mc));
        double hist[101];
        lrr_fit_options o = {0};
        o.max_iterations = caps[k];
        o.history = hist;
        o.history_len = 101;
        lrr_fit_stats fs;
        LRR_CHECK(ctx, lrr_probe_fit_irradiance(p, n, m, &o, fit, &fs, sizeof fs));
        assert_true(fs.iterations >= 1 && fs.iterations <= caps[k]);
        assert_true(isfinite(fs.final_objective));
        assert_true(fs.final_objective < fs.initial_objective);
        assert_true(hist[0] == fs.initial_objective);
        for (size_t i = 1; i <= fs.iterations; i++)
            assert_true(hist[i] <= hist[i - 1]);
        assert_true(hist[fs.iterations] == fs.final_objective);
        for (size_t l = 0; l < n; l++) {
            double len = 0;
            for (int c = 0; c < 3; c++) {
                assert_true(fit[l].rgb[c] >= 0 && isfinite(fit[l].rgb[c]));
                len += (double)fit[l].dir[c] * fit[l].dir[c];
            }
            assert_true(fabs(sqrt(len) - 1) < 1e-5);
        }
        double e_mc = lights_mean_error(mc, n, m, dirs, truth);
        double e_fit = lights_mean_error(fit, n, m, dirs, truth);
        assert_true(isfinite(e_fit));
        assert_true(e_fit < e_mc);
        free(mc);
        free(fit);
    }
    /* bad arguments name themselves */
    lrr_light L;
    assert_int_equal(lrr_probe_fit_irradiance(p, 0, m, NULL, &L, NULL, 0), LRR_ERR_INVALID_ARG);
    assert_int_equal(lrr_probe_fit_irradiance(p, 1, 0, NULL, &L, NULL, 0), LRR_ERR_INVALID_ARG);
    free(dirs);
    free(truth);
    lrr_probe_destroy(p);
    lrr_context_destroy(ctx);
}

/* One bright pixel and one light: median cut is exact and the optimiser keeps it so. */
static void test_fit_single_pixel(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    size_t w = 64, h = 32, u = 10, v = 7, m = 128;
    float *pix = probe_pixels(w, h);
    pix[3 * (v * w + u)] = 3;
    pix[3 * (v * w + u) + 1] = 2;
    pix[3 * (v * w + u) + 2] = 1;
    lrr_probe *p;
    LRR_CHECK(ctx, lrr_probe_create(ctx, w, h, pix, &p));
    lrr_light L;
    lrr_fit_stats fs;
    LRR_CHECK(ctx, lrr_probe_fit_irradiance(p, 1, m, NULL, &L, &fs, sizeof fs));
    float *dirs = calloc(3 * m, sizeof(float)), *truth = calloc(3 * m, sizeof(float)),
          *approx = calloc(3 * m, sizeof(float));
    assert_non_null(approx);
    lrr_sphere_points(m, dirs);
    LRR_CHECK(ctx, lrr_probe_irradiance(p, m, dirs, truth));
    assert_int_equal(lrr_lights_irradiance(&L, 1, m, dirs, approx), LRR_OK);
    double tmax = 0;
    for (size_t i = 0; i < 3 * m; i++)
        tmax = fmax(tmax, truth[i]);
    assert_true(max_abs_diff(approx, truth, m) <= 1e-5 * tmax);
    assert_true(fs.final_objective <= fs.initial_objective);
    free(dirs);
    free(truth);
    free(approx);
    free(pix);
    lrr_probe_destroy(p);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_single_pixel), cmocka_unit_test(test_constant),
        cmocka_unit_test(test_hemisphere),   cmocka_unit_test(test_median_cut_equal),
        cmocka_unit_test(test_errors),       cmocka_unit_test(test_shipped),
        cmocka_unit_test(test_fit_irradiance), cmocka_unit_test(test_fit_single_pixel),
        cmocka_unit_test(test_exr_shipped), cmocka_unit_test(test_exr_errors),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
