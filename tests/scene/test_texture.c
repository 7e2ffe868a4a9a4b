/* Textured materials (lib/scene/texture.c, the texture part of lib/scene/import.c) and glTF
 * KHR_materials_emissive_strength (lib/scene/gltf_ext.c).
 *
 * Closed forms: a 2×2-texel texture with four colours on the unit quad (UV = position), so
 * every subpatch at depth >= 1 lies in one texel (its mean is that texel × Kd, and which
 * texel checks the image's orientation), a whole triangle straddles three texels in known
 * proportions; an independent numerical integral for non-aligned triangles in every wrap
 * mode; the sRGB decode; the clamp and its count; embedded (GLB, data URI) against external
 * textures; the emissive strength in .gltf and .glb and its malformed values. */
#include "testutil.h"

#include "scene/texture.h"

#include <stb_image_write.h>
#include <sys/stat.h>

/* Scene values are floats (positions, normals, areas, rho, E) from a few float
 * operations each (a cross product and its normalisation: 5 roundings), k = 2. */
#define FLOAT_TOL TU_TOL_FLT(2, 5)
/* A bilinear texel mean with weights exact in binary: one float rounding. */
#define TEXEL_TOL TU_TOL_FLT(1, 1)

static int setup(void **state)
{
    lrr_context *ctx;
    if (lrr_context_create(&ctx) != LRR_OK)
        return -1;
    *state = ctx;
    return 0;
}

static int teardown(void **state)
{
    lrr_context_destroy(*state);
    return 0;
}

static void tmp_path(char *buf, size_t len, const char *stem, const char *ext)
{
    const char *dir = getenv("LRR_TEST_TMP");
    snprintf(buf, len, "%s/%s_%ld.%s", dir && *dir ? dir : "/tmp", stem, (long)getpid(), ext);
}

static void write_text(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, strlen(text), f), strlen(text));
    assert_int_equal(fclose(f), 0);
}

static double srgb(unsigned char c)
{
    double x = c / 255.0;
    return x <= 0.04045 ? x / 12.92 : pow((x + 0.055) / 1.055, 2.4);
}

/* The four texels of the 2×2 test image, row 0 at the top: top-left, top-right,
 * bottom-left, bottom-right, all different in every channel. */
static const unsigned char quad_px[12] = {200, 30, 90,  60, 220, 10,
                                          120, 80, 250, 20, 140, 170};

/* ------------------------------------------------------------------ integration */

/* A texture of w×h texels from a generator (values in [0,1)). */
static lrr__texture make_texture(size_t w, size_t h, unsigned seed, int wrap_u, int wrap_v)
{
    lrr__texture t = {.w = w, .h = h, .wrap = {wrap_u, wrap_v}};
    t.rgb = malloc(w * h * 3 * sizeof(float));
    assert_non_null(t.rgb);
    uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
    for (size_t i = 0; i < w * h * 3; i++) {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        t.rgb[i] = (float)((x >> 11) * 0x1.0p-53);
    }
    return t;
}

/* The texture at UV (u, v), written independently of texture.c: the texel whose square
 * holds the point, wrapped by fmod on the continuous coordinate. */
static void lookup(const lrr__texture *t, double u, double v, double out[3])
{
    double c[2] = {u * t->w, (1 - v) * t->h};
    size_t n[2] = {t->w, t->h}, idx[2];
    for (int a = 0; a < 2; a++) {
        double p = (double)n[a], x = c[a];
        if (t->wrap[a] == LRR__WRAP_CLAMP)
            x = fmin(fmax(x, 0), p - 0.5);
        else if (t->wrap[a] == LRR__WRAP_MIRROR) {
            x = fmod(x, 2 * p);
            if (x < 0)
                x += 2 * p;
            if (x >= p)
                x = 2 * p - x - 1e-9;
        } else {
            x = fmod(x, p);
            if (x < 0)
                x += p;
        }
        idx[a] = (size_t)floor(x);
        if (idx[a] >= n[a])
            idx[a] = n[a] - 1;
    }
    for (int k = 0; k < 3; k++)
        out[k] = t->rgb[3 * (idx[1] * t->w + idx[0]) + k];
}

/* The mean over the UV triangle by an N×N grid over its bounding box (points inside
 * only): error about (texel edges crossed)/N. */
static void numeric_mean(const lrr__texture *t, const double uv[6], int N, double out[3])
{
    double lo[2] = {fmin(uv[0], fmin(uv[2], uv[4])), fmin(uv[1], fmin(uv[3], uv[5]))};
    double hi[2] = {fmax(uv[0], fmax(uv[2], uv[4])), fmax(uv[1], fmax(uv[3], uv[5]))};
    double sum[3] = {0, 0, 0};
    long count = 0;
    double det = (uv[2] - uv[0]) * (uv[5] - uv[1]) - (uv[4] - uv[0]) * (uv[3] - uv[1]);
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) {
            double u = lo[0] + (i + 0.5) * (hi[0] - lo[0]) / N;
            double v = lo[1] + (j + 0.5) * (hi[1] - lo[1]) / N;
            double b1 = ((u - uv[0]) * (uv[5] - uv[1]) - (uv[4] - uv[0]) * (v - uv[1])) / det;
            double b2 = ((uv[2] - uv[0]) * (v - uv[1]) - (u - uv[0]) * (uv[3] - uv[1])) / det;
            if (b1 < 0 || b2 < 0 || b1 + b2 > 1)
                continue;
            double x[3];
            lookup(t, u, v, x);
            for (int k = 0; k < 3; k++)
                sum[k] += x[k];
            count++;
        }
    for (int k = 0; k < 3; k++)
        out[k] = sum[k] / count;
}

/* Exact texel-area integration against the numerical integral: non-aligned triangles, in
 * and beyond [0,1], in each wrap mode. */
static void test_mean_against_numeric(void **state)
{
    (void)state;
    static const double tris[][6] = {
        {0.13, 0.07, 0.91, 0.22, 0.37, 0.83},    /* inside the image */
        {-0.61, 0.35, 1.42, -0.18, 0.55, 1.77},  /* beyond it on every side */
        {3.21, -2.05, 3.64, -1.62, 3.02, -1.21}, /* far tiles */
        {0.41, 0.43, 0.44, 0.47, 0.40, 0.49},    /* within a few texels */
    };
    static const int modes[][2] = {{LRR__WRAP_REPEAT, LRR__WRAP_REPEAT},
                                   {LRR__WRAP_CLAMP, LRR__WRAP_MIRROR},
                                   {LRR__WRAP_MIRROR, LRR__WRAP_CLAMP}};
    for (size_t m = 0; m < sizeof modes / sizeof *modes; m++) {
        lrr__texture t = make_texture(7, 5, (unsigned)m + 1, modes[m][0], modes[m][1]);
        for (size_t k = 0; k < sizeof tris / sizeof *tris; k++) {
            double a[3], b[3];
            lrr__texture_mean(&t, tris[k], a);
            numeric_mean(&t, tris[k], 2048, b);
            for (int c = 0; c < 3; c++)
                ASSERT_NEAR(a[c], b[c], 2e-3, "wrap %zu, triangle %zu, channel %d\n", m, k, c);
        }
        free(t.rgb);
    }
}

/* Closed forms on the 2×2 texture: a triangle inside one texel is that texel; one split by
 * a texel edge into mirror halves is the mean of the two; the lower-right half of the image
 * holds bottom-left/4 + bottom-right/2 + top-right/4. The midpoint rule agrees where each
 * of its sub-triangles lies in one texel. */
static void test_mean_closed_forms(void **state)
{
    (void)state;
    lrr__texture t = {.w = 2, .h = 2, .wrap = {LRR__WRAP_REPEAT, LRR__WRAP_REPEAT}};
    float px[12];
    for (int i = 0; i < 12; i++)
        px[i] = quad_px[i] / 255.0f;
    t.rgb = px;
    const float *tl = px, *tr = px + 3, *bl = px + 6, *br = px + 9;
    double m[3];
    lrr__texture_mean(&t, (const double[]){0.05, 0.6, 0.45, 0.6, 0.2, 0.95}, m); /* top-left */
    for (int c = 0; c < 3; c++)
        ASSERT_NEAR(m[c], tl[c], TEXEL_TOL, "inside a texel, channel %d\n", c);
    lrr__texture_mean(&t, (const double[]){0.25, 0.1, 0.75, 0.1, 0.5, 0.4}, m); /* straddles */
    for (int c = 0; c < 3; c++)
        ASSERT_NEAR(m[c], 0.5 * (bl[c] + br[c]), TEXEL_TOL, "straddling, channel %d\n", c);
    lrr__texture_mean(&t, (const double[]){0, 0, 1, 0, 1, 1}, m);
    for (int c = 0; c < 3; c++)
        ASSERT_NEAR(m[c], 0.25 * bl[c] + 0.5 * br[c] + 0.25 * tr[c], TEXEL_TOL, "half, %d\n", c);
    lrr__texture_mean_sampled(&t, (const double[]){0, 0, 1, 0, 1, 1}, 2, m);
    for (int c = 0; c < 3; c++)
        ASSERT_NEAR(m[c], 0.25 * bl[c] + 0.5 * br[c] + 0.25 * tr[c], TEXEL_TOL, "rule, %d\n", c);
    /* a triangle tiled 1000 times over: the mean of the whole image, by the midpoint rule */
    lrr__texture_mean(&t, (const double[]){0, 0, 1000, 0, 0, 1000}, m);
    for (int c = 0; c < 3; c++)
        ASSERT_NEAR(m[c], 0.25 * (tl[c] + tr[c] + bl[c] + br[c]), 2e-2, "tiled, %d\n", c);
}

/* UVs far beyond any exact texel index (a fuzzed glTF had one of 1e27): every wrap mode
 * gives a defined mean that is a mix of the image's texels (each channel within the image's
 * range), and a clamped triangle far off to the right is the right column's colour. Under
 * UBSan (the sanitizer pass) the conversions themselves are checked too. */
static void test_far_uvs(void **state)
{
    (void)state;
    float px[12];
    for (int i = 0; i < 12; i++)
        px[i] = quad_px[i] / 255.0f;
    const float *br = px + 9;
    for (int mode = 0; mode < 3; mode++) {
        int wrap = mode == 0 ? LRR__WRAP_REPEAT : mode == 1 ? LRR__WRAP_MIRROR : LRR__WRAP_CLAMP;
        lrr__texture t = {.w = 2, .h = 2, .wrap = {wrap, wrap}, .rgb = px};
        const double far[3][6] = {{0, 0, 4e27, 0, 0, 1}, {1e27, 0.2, 1e27, 0.4, 1e27, 0.3},
                                  {-3e300, 0, 3e300, 0.5, 0, 1}};
        for (int k = 0; k < 3; k++) {
            double m[3];
            lrr__texture_mean(&t, far[k], m);
            for (int c = 0; c < 3; c++) {
                double lo = 1, hi = 0;
                for (int q = 0; q < 4; q++) {
                    lo = fmin(lo, px[3 * q + c]);
                    hi = fmax(hi, px[3 * q + c]);
                }
                assert_true(isfinite(m[c]) && m[c] >= lo - TEXEL_TOL && m[c] <= hi + TEXEL_TOL);
            }
            if (wrap == LRR__WRAP_CLAMP && k == 1) /* u far right, v in the lower half */
                for (int c = 0; c < 3; c++)
                    ASSERT_NEAR(m[c], br[c], TEXEL_TOL, "clamped far right, channel %d\n", c);
        }
    }
}

/* The accuracy of the midpoint rule that takes over beyond LRR__TEXEL_EXACT_MAX texels:
 * white noise of 256² texels under one triangle (the documented figure). */
static void test_sampled_accuracy(void **state)
{
    lrr__texture t = make_texture(256, 256, 7, LRR__WRAP_REPEAT, LRR__WRAP_REPEAT);
    const double uv[6] = {0.02, 0.01, 0.99, 0.03, 0.4, 0.98};
    double exact[3], rule[3], worst = 0;
    lrr__texture_mean_exact(&t, uv, exact);
    lrr__texture_mean_sampled(&t, uv, LRR__TEXEL_SAMPLES, rule);
    for (int c = 0; c < 3; c++)
        worst = fmax(worst, fabs(rule[c] - exact[c]) / exact[c]);
    print_message("midpoint rule (%d² sub-triangles) vs exact on 256² noise: %.2e relative\n",
                  LRR__TEXEL_SAMPLES, worst);
    assert_true(worst < 1.5e-2);
    free(t.rgb);
    /* a real texture: the Cesium logo of data/textured (211², sRGB-decoded) */
    lrr_context *ctx = *state;
    size_t len, clamped = 0;
    FILE *f = fopen(LRR_DATA_DIR "/textured/CesiumLogoFlat.png", "rb");
    assert_non_null(f);
    unsigned char png[8192];
    len = fread(png, 1, sizeof png, f);
    fclose(f);
    LRR_CHECK(ctx, lrr__texture_decode(ctx, png, len, (const float[]){1, 1, 1}, false, "logo",
                                       &t, &clamped));
    assert_int_equal(t.w, 211);
    worst = 0;
    lrr__texture_mean_exact(&t, uv, exact);
    lrr__texture_mean_sampled(&t, uv, LRR__TEXEL_SAMPLES, rule);
    for (int c = 0; c < 3; c++)
        worst = fmax(worst, fabs(rule[c] - exact[c]) / exact[c]);
    print_message("midpoint rule vs exact on the 211² logo: %.2e relative\n", worst);
    assert_true(worst < 1e-2);
    free(t.rgb);
}

/* ------------------------------------------------------------------ import */

/* Writes the 2×2 image as PNG (8-bit sRGB) into `png`. */
static void write_quad_png(const char *png)
{
    assert_true(stbi_write_png(png, 2, 2, 3, quad_px, 6) != 0);
}

static const char *base_name(const char *path)
{
    const char *s = strrchr(path, '/');
    return s ? s + 1 : path;
}

/* The unit quad in the z = 0 plane, UV = (x, y), with material `mat` from `mtl`. */
static void write_quad_obj(const char *obj, const char *mtl, const char *mtl_text)
{
    char text[1024];
    snprintf(text, sizeof text,
             "mtllib %s\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
             "usemtl m\nf 1/1 2/2 3/3 4/4\n",
             base_name(mtl));
    write_text(obj, text);
    write_text(mtl, mtl_text);
}

/* Subdivides to depth >= 1 and checks every subpatch against the texel under its centre
 * (row 0 of the image is v = 1) times kd, linear. */
static void check_texel_per_subpatch(lrr_context *ctx, lrr_scene *s, const float kd[3],
                                     bool emission)
{
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.levels = 2}));
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    assert_int_equal(si.subpatches, 2 * 16);
    float centre[3 * 32], rho[3 * 32], em[3 * 32];
    LRR_CHECK(ctx, lrr_scene_subpatches(s, centre, NULL, NULL, rho, em));
    for (size_t i = 0; i < si.subpatches; i++) {
        int col = centre[3 * i] >= 0.5f, row = centre[3 * i + 1] < 0.5f;
        const unsigned char *p = quad_px + 3 * (2 * row + col);
        for (int c = 0; c < 3; c++)
            ASSERT_NEAR(emission ? em[3 * i + c] : rho[3 * i + c], srgb(p[c]) * kd[c], FLOAT_TOL,
                        "subpatch %zu channel %d\n", i, c);
    }
}

static void test_obj_map_kd(void **state)
{
    TU_REQUIRE("assimp"); /* scene files */
    lrr_context *ctx = *state;
    char png[512], obj[512], mtl[512], mtext[1024];
    tmp_path(png, sizeof png, "tex_quad", "png");
    tmp_path(obj, sizeof obj, "tex_quad", "obj");
    tmp_path(mtl, sizeof mtl, "tex_quad", "mtl");
    write_quad_png(png);
    snprintf(mtext, sizeof mtext, "newmtl m\nKd 0.5 0.8 0.9\nmap_Kd %s\n", base_name(png));
    write_quad_obj(obj, mtl, mtext);
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_load(ctx, obj, &s));
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    assert_int_equal(si.textures, 1);
    assert_int_equal(si.clamped_texels, 0);
    check_texel_per_subpatch(ctx, s, (const float[]){0.5f, 0.8f, 0.9f}, false);
    /* a whole triangle straddles three texels: it is one half of the quad, cut along a
     * diagonal (which one is the triangulation's); its centroid says which half, and the
     * half holds 1/2 of one texel and 1/4 of two others */
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.levels = 0}));
    float rho[6], centre[6];
    LRR_CHECK(ctx, lrr_scene_subpatches(s, centre, NULL, NULL, rho, NULL));
    for (int t = 0; t < 2; t++) {
        /* the texel the half holds whole, by its centroid: (col, row), row 0 at the top */
        int col = centre[3 * t] > 0.5f, row = centre[3 * t + 1] < 0.5f;
        for (int c = 0; c < 3; c++) {
            double kd = c == 0 ? 0.5 : c == 1 ? 0.8 : 0.9;
            double whole = srgb(quad_px[3 * (2 * row + col) + c]);
            double side1 = srgb(quad_px[3 * (2 * row + !col) + c]);
            double side2 = srgb(quad_px[3 * (2 * !row + col) + c]);
            ASSERT_NEAR(rho[3 * t + c], (0.5 * whole + 0.25 * side1 + 0.25 * side2) * kd, FLOAT_TOL,
                        "triangle %d channel %d\n", t, c);
        }
    }
    lrr_scene_destroy(s);
    /* Ke × map_Ke gives the emission the same way */
    snprintf(mtext, sizeof mtext, "newmtl m\nKd 0.5 0.5 0.5\nKe 2 3 4\nmap_Ke %s\n",
             base_name(png));
    write_quad_obj(obj, mtl, mtext);
    LRR_CHECK(ctx, lrr_scene_load(ctx, obj, &s));
    check_texel_per_subpatch(ctx, s, (const float[]){2, 3, 4}, true);
    lrr_scene_destroy(s);
    remove(png);
    remove(obj);
    remove(mtl);
}

/* White texels × Kd 1 are clamped just below 1 and counted; a missing or corrupt texture
 * is an error naming the file and the material. */
static void test_obj_clamp_and_errors(void **state)
{
    TU_REQUIRE("assimp"); /* scene files */
    lrr_context *ctx = *state;
    char png[512], obj[512], mtl[512], mtext[1024], msg[512];
    tmp_path(png, sizeof png, "tex_white", "png");
    tmp_path(obj, sizeof obj, "tex_white", "obj");
    tmp_path(mtl, sizeof mtl, "tex_white", "mtl");
    const unsigned char white[12] = {255, 255, 255, 255, 255, 255, 255, 255, 255, 0, 0, 0};
    assert_true(stbi_write_png(png, 2, 2, 3, white, 6) != 0);
    snprintf(mtext, sizeof mtext, "newmtl bright\nKd 1 1 1\nmap_Kd %s\n", base_name(png));
    write_quad_obj(obj, mtl, mtext);
    lrr_scene *s;
    LRR_CHECK(ctx, lrr_scene_load(ctx, obj, &s));
    lrr_scene_info si;
    lrr_scene_get_info(s, &si, sizeof si);
    assert_int_equal(si.clamped_texels, 3); /* the three white texels, not the black one */
    LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.levels = 1}));
    float rho[3 * 8];
    LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, rho, NULL));
    for (int i = 0; i < 24; i++)
        assert_true(rho[i] >= 0 && rho[i] < 1);
    lrr_scene_destroy(s);

    snprintf(mtext, sizeof mtext, "newmtl bright\nKd 1 1 1\nmap_Kd no_such_%s\n",
             base_name(png));
    write_quad_obj(obj, mtl, mtext);
    assert_int_equal(lrr_scene_load(ctx, obj, &s), LRR_ERR_IO);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, obj));
    assert_non_null(strstr(msg, "'bright'"));
    assert_non_null(strstr(msg, "no_such_"));

    write_text(png, "\x89PNG\r\n\x1a\n not really");
    snprintf(mtext, sizeof mtext, "newmtl bright\nKd 1 1 1\nmap_Kd %s\n", base_name(png));
    write_quad_obj(obj, mtl, mtext);
    assert_int_equal(lrr_scene_load(ctx, obj, &s), LRR_ERR_FORMAT);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "'bright'"));
    assert_non_null(strstr(msg, base_name(png)));
    remove(png);
    remove(obj);
    remove(mtl);
}

static void base64(const unsigned char *in, size_t n, char *out)
{
    static const char tab[] =
        "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)in[i] << 16 | (i + 1 < n ? (uint32_t)in[i + 1] << 8 : 0) |
                     (i + 2 < n ? in[i + 2] : 0);
        out[o++] = tab[v >> 18];
        out[o++] = tab[(v >> 12) & 63];
        out[o++] = i + 1 < n ? tab[(v >> 6) & 63] : '=';
        out[o++] = i + 2 < n ? tab[v & 63] : '=';
    }
    out[o] = '\0';
}

/* The quad's glTF buffer: positions, UVs (glTF's v runs down the image: v_gltf = 1 − y)
 * and indices. */
static size_t gltf_quad_buffer(unsigned char *b)
{
    static const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const float uv[8] = {0, 1, 1, 1, 1, 0, 0, 0};
    static const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    memcpy(b, pos, sizeof pos);
    memcpy(b + 48, uv, sizeof uv);
    memcpy(b + 80, idx, sizeof idx);
    return 92;
}

/* A glTF quad with `material` (JSON) and, when png_b64 is given, the image as a data URI;
 * as .gltf (the buffer a data URI too) or, with glb, as binary glTF (the buffer in the BIN
 * chunk, the JSON chunk padded with spaces). */
static void write_gltf(const char *path, const char *material, const char *png_b64, bool glb)
{
    unsigned char buf[96];
    size_t nb = gltf_quad_buffer(buf);
    char b64[256], uri[320] = "", *text = malloc(8192);
    assert_non_null(text);
    base64(buf, nb, b64);
    if (!glb)
        snprintf(uri, sizeof uri, ", \"uri\": \"data:application/octet-stream;base64,%s\"", b64);
    char images[2048] = "";
    if (png_b64)
        snprintf(images, sizeof images,
                 "\"images\": [{\"uri\": \"data:image/png;base64,%s\"}], "
                 "\"samplers\": [{\"wrapS\": 10497, \"wrapT\": 10497}], "
                 "\"textures\": [{\"source\": 0, \"sampler\": 0}],",
                 png_b64);
    int n = snprintf(text, 8192,
             "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
             " \"nodes\": [{\"mesh\": 0}], %s \"materials\": [%s],"
             " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0, "
             "\"TEXCOORD_0\": 1}, \"indices\": 2, \"material\": 0}]}],"
             " \"buffers\": [{\"byteLength\": 92%s}],"
             " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},"
             " {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 32},"
             " {\"buffer\": 0, \"byteOffset\": 80, \"byteLength\": 12}],"
             " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, "
             "\"type\": \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 0]},"
             " {\"bufferView\": 1, \"componentType\": 5126, \"count\": 4, \"type\": \"VEC2\"},"
             " {\"bufferView\": 2, \"componentType\": 5123, \"count\": 6, "
             "\"type\": \"SCALAR\"}]}",
             images, material, uri);
    assert_true(n > 0 && n < 8000);
    if (!glb) {
        write_text(path, text);
        free(text);
        return;
    }
    while (n % 4)
        text[n++] = ' ';
    uint32_t h[5] = {0x46546C67u, 2, (uint32_t)(20 + n + 8 + 92), (uint32_t)n, 0x4E4F534Au};
    uint32_t bin[2] = {92, 0x004E4942u}; /* "BIN" */
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(h, 4, 5, f), 5);
    assert_int_equal(fwrite(text, 1, (size_t)n, f), (size_t)n);
    assert_int_equal(fwrite(bin, 4, 2, f), 2);
    assert_int_equal(fwrite(buf, 1, 92, f), 92);
    assert_int_equal(fclose(f), 0);
    free(text);
}

typedef struct bytes {
    unsigned char b[1024];
    size_t n;
} bytes;

static void append(void *ctx, void *data, int size)
{
    bytes *o = ctx;
    assert_true(o->n + (size_t)size <= sizeof o->b);
    memcpy(o->b + o->n, data, (size_t)size);
    o->n += (size_t)size;
}

static void png_base64(char *out)
{
    bytes png = {.n = 0};
    assert_true(stbi_write_png_to_func(append, &png, 2, 2, 3, quad_px, 6) != 0);
    base64(png.b, png.n, out);
}

/* baseColorTexture × baseColorFactor from a data URI, in a .gltf and the same JSON in a
 * .glb: the same closed forms as the OBJ. */
static void test_gltf_base_color_texture(void **state)
{
    TU_REQUIRE("assimp"); /* scene files */
    lrr_context *ctx = *state;
    char gltf[512], glb[512], b64[1024];
    tmp_path(gltf, sizeof gltf, "tex_quad", "gltf");
    tmp_path(glb, sizeof glb, "tex_quad", "glb");
    png_base64(b64);
    const char *painted = "{\"name\": \"painted\", \"pbrMetallicRoughness\": "
                          "{\"baseColorFactor\": [0.5, 0.8, 0.9, 1], \"baseColorTexture\": "
                          "{\"index\": 0}}}";
    write_gltf(gltf, painted, b64, false);
    write_gltf(glb, painted, b64, true);
    const char *paths[2] = {gltf, glb};
    for (int k = 0; k < 2; k++) {
        lrr_scene *s;
        LRR_CHECK(ctx, lrr_scene_load(ctx, paths[k], &s));
        check_texel_per_subpatch(ctx, s, (const float[]){0.5f, 0.8f, 0.9f}, false);
        lrr_scene_destroy(s);
    }
    /* a texture transform lrr does not apply is refused, naming the material */
    write_gltf(gltf,
               "{\"name\": \"moved\", \"pbrMetallicRoughness\": {\"baseColorTexture\": "
               "{\"index\": 0, \"extensions\": {\"KHR_texture_transform\": "
               "{\"offset\": [0.5, 0]}}}}}",
               b64, false);
    lrr_scene *s = NULL;
    assert_int_equal(lrr_scene_load(ctx, gltf, &s), LRR_ERR_UNSUPPORTED);
    assert_null(s);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "'moved'"));
    assert_non_null(strstr(msg, "KHR_texture_transform"));
    remove(gltf);
    remove(glb);
}

/* Reads a whole (small) file; the caller frees. */
static char *slurp(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    assert_non_null(f);
    char *b = malloc(1 << 16);
    assert_non_null(b);
    *len = fread(b, 1, (1 << 16) - 1, f);
    b[*len] = '\0';
    fclose(f);
    return b;
}

/* Replaces every `from` in text (in place; to has the same length). */
static void replace_all(char *text, const char *from, const char *to)
{
    assert_int_equal(strlen(from), strlen(to));
    for (char *p = strstr(text, from); p; p = strstr(p, from))
        memcpy(p, to, strlen(to));
}

/* The shipped real scene: its .glb embeds the PNG that its .gltf names, with repeat wrap
 * modes where the .gltf has mirrored-repeat along u and clamp along v (u runs over 4..6).
 * The .gltf rewritten to repeat, beside copies of its .bin and .png, gives the .glb's
 * reflectance exactly on every subpatch; the original differs where u is mirrored. */
static void test_embedded_equals_external(void **state)
{
    TU_REQUIRE("assimp"); /* scene files */
    lrr_context *ctx = *state;
    static const char *files[3] = {"BoxTextured.gltf", "BoxTextured0.bin",
                                   "CesiumLogoFlat.png"};
    char dir[512], path[1024], src[1024];
    tmp_path(dir, sizeof dir, "boxtex", "d");
    assert_int_equal(mkdir(dir, 0700), 0);
    for (int k = 0; k < 3; k++) {
        size_t len;
        snprintf(src, sizeof src, "%s/textured/%s", LRR_DATA_DIR, files[k]);
        char *b = slurp(src, &len);
        if (k == 0) {
            replace_all(b, "\"wrapS\": 33648", "\"wrapS\": 10497");
            replace_all(b, "\"wrapT\": 33071", "\"wrapT\": 10497");
        }
        snprintf(path, sizeof path, "%s/%s", dir, files[k]);
        FILE *f = fopen(path, "wb");
        assert_non_null(f);
        assert_int_equal(fwrite(b, 1, len, f), len);
        assert_int_equal(fclose(f), 0);
        free(b);
    }
    char repeat[1024];
    snprintf(repeat, sizeof repeat, "%s/%s", dir, files[0]);
    const char *names[3] = {repeat, LRR_DATA_DIR "/textured/BoxTextured.glb",
                            LRR_DATA_DIR "/textured/BoxTextured.gltf"};
    float rho[3][3 * 12 * 16];
    for (int k = 0; k < 3; k++) {
        lrr_scene *s;
        LRR_CHECK(ctx, lrr_scene_load(ctx, names[k], &s));
        LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.levels = 2}));
        lrr_scene_info si;
        lrr_scene_get_info(s, &si, sizeof si);
        assert_int_equal(si.subpatches, 12 * 16);
        assert_int_equal(si.textures, 1);
        LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, rho[k], NULL));
        lrr_scene_destroy(s);
    }
    double spread = 0, mirrored = 0;
    for (size_t i = 0; i < 3 * 12 * 16; i++) {
        assert_true(rho[0][i] == rho[1][i]);
        spread = fmax(spread, fabs(rho[0][i] - rho[0][0]));
        mirrored = fmax(mirrored, fabs(rho[2][i] - rho[0][i]));
    }
    assert_true(spread > 0.1);   /* the texture is not flat */
    assert_true(mirrored > 0.1); /* and the wrap mode matters */
    for (int k = 0; k < 3; k++) {
        snprintf(path, sizeof path, "%s/%s", dir, files[k]);
        remove(path);
    }
    rmdir(dir);
}

/* The operator takes the textured reflectance per subpatch, also when clusters renumber the
 * subpatches: mapped back to the scene's order it is lrr_scene_subpatches' exactly. */
static void test_operator_keeps_textures(void **state)
{
    TU_REQUIRE("assimp"); /* scene files */
    lrr_context *ctx = *state;
    for (int cluster = 0; cluster < 2; cluster++) {
        lrr_scene *s;
        LRR_CHECK(ctx, lrr_scene_load(ctx, LRR_DATA_DIR "/textured/BoxTextured.glb", &s));
        LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.levels = cluster ? 0 : 1,
                                                                  .target_patches = 48}));
        lrr_scene_info si;
        lrr_scene_get_info(s, &si, sizeof si);
        size_t n = si.subpatches;
        float *want = malloc(n * 3 * sizeof *want), *got = malloc(n * 3 * sizeof *got);
        assert_true(want && got);
        LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, want, NULL));
        lrr_build_options bo = lrr_build_options_defaults();
        bo.hemicube_resolution = 16;
        bo.seed = 1;
        bo.threads = 1;
        if (cluster) {
            bo.hierarchy = LRR_HIERARCHY_CLUSTER;
            bo.adaptive_patches = 6;
        }
        lrr_operator *op;
        LRR_CHECK(ctx, lrr_operator_build(s, &bo, &op));
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        assert_int_equal(oi.n, n);
        lrr_operator_scene_order(op, lrr_operator_reflectance(op), got);
        for (size_t i = 0; i < 3 * n; i++)
            assert_true(got[i] == want[i]);
        if (cluster) /* the clusters did renumber them */
            assert_true(memcmp(lrr_operator_reflectance(op), want, 3 * n * sizeof *want) != 0);
        lrr_operator_destroy(op);
        lrr_scene_destroy(s);
        free(want);
        free(got);
    }
}

/* ------------------------------------------------------------------ emissive strength */

static void test_emissive_strength(void **state)
{
    TU_REQUIRE("assimp"); /* scene files */
    lrr_context *ctx = *state;
    char gltf[512], glb[512], msg[512];
    tmp_path(gltf, sizeof gltf, "strength", "gltf");
    tmp_path(glb, sizeof glb, "strength", "glb");
    /* what Blender writes for an emission strength of 5 */
    const char *lamp = "{\"name\": \"Lamp\", \"emissiveFactor\": [1, 1, 1], \"extensions\": "
                       "{\"KHR_materials_emissive_strength\": {\"emissiveStrength\": 5}}, "
                       "\"pbrMetallicRoughness\": {\"baseColorFactor\": [0.5, 0.5, 0.5, 1]}}";
    write_gltf(gltf, lamp, NULL, false);
    write_gltf(glb, lamp, NULL, true);
    const char *paths[2] = {gltf, glb};
    for (int k = 0; k < 2; k++) {
        lrr_scene *s;
        LRR_CHECK(ctx, lrr_scene_load(ctx, paths[k], &s));
        LRR_CHECK(ctx, lrr_scene_subdivide(s, &(lrr_subdivision){.levels = 0}));
        float em[6];
        LRR_CHECK(ctx, lrr_scene_subpatches(s, NULL, NULL, NULL, NULL, em));
        for (int i = 0; i < 6; i++)
            ASSERT_NEAR(em[i], 5.0, 0, "%s: emission %d\n", paths[k], i);
        lrr_scene_destroy(s);
    }
    /* NaN is not JSON, but Python's json module writes it */
    static const char *bad[] = {"-2", "\"bright\"", "NaN", "1e999"};
    for (size_t b = 0; b < sizeof bad / sizeof *bad; b++) {
        char mat[512];
        snprintf(mat, sizeof mat,
                 "{\"name\": \"Lamp\", \"emissiveFactor\": [1, 1, 1], \"extensions\": "
                 "{\"KHR_materials_emissive_strength\": {\"emissiveStrength\": %s}}}",
                 bad[b]);
        write_gltf(gltf, mat, NULL, false);
        write_gltf(glb, mat, NULL, true);
        for (int k = 0; k < 2; k++) {
            lrr_scene *s = NULL;
            lrr_status st = lrr_scene_load(ctx, paths[k], &s);
            assert_int_not_equal(st, LRR_OK);
            assert_null(s);
            lrr_context_last_error(ctx, msg, sizeof msg);
            assert_non_null(strstr(msg, paths[k]));
            assert_int_equal(st, LRR_ERR_MATERIAL);
            assert_non_null(strstr(msg, "material 0 'Lamp'"));
            assert_non_null(strstr(msg, "emissiveStrength"));
        }
    }
    remove(gltf);
    remove(glb);
}

/* Every allocation of a textured import failed in turn (lib/core/error.c's injection): the
 * load returns LRR_ERR_NOMEM and nothing else, and leaves no scene (the leak checks of the
 * sanitizer pass see the rest). External texture, embedded texture, emissive strength. */
static void test_allocation_failures(void **state)
{
    TU_REQUIRE("assimp"); /* scene files */
    (void)state;
    const char *files[3] = {LRR_DATA_DIR "/textured/BoxTextured.gltf",
                            LRR_DATA_DIR "/textured/BoxTextured.glb",
                            LRR_TEST_DATA "/quad_strength.gltf"};
    for (int k = 0; k < 3; k++) {
        unsigned long total = 0;
        for (unsigned long n = 1;; n++) {
            lrr_context *ctx = tu_context();
            lrr__context_fail_after(ctx, n);
            lrr_scene *s = NULL;
            lrr_status st = lrr_scene_load(ctx, files[k], &s);
            if (st == LRR_OK) {
                st = lrr_scene_subdivide(s, &(lrr_subdivision){.levels = 1});
                float rho[3 * 12 * 4];
                if (st == LRR_OK)
                    st = lrr_scene_subpatches(s, NULL, NULL, NULL, rho, NULL);
            } else
                assert_null(s);
            unsigned long made = lrr__context_alloc_count(ctx);
            lrr_scene_destroy(s);
            lrr_context_destroy(ctx);
            if (st == LRR_OK) { /* the n-th allocation was never made: all were tried */
                assert_true(made < n);
                total = made;
                break;
            }
            assert_int_equal(made, n); /* the failure stopped the load at once */
            if (st != LRR_ERR_NOMEM)
                fail_msg("%s: allocation %lu failed gives %s", files[k], n, lrr_strerror(st));
        }
        assert_true(total > 5);
        print_message("%s: each of %lu allocations failed in turn: LRR_ERR_NOMEM\n",
                      files[k], total);
    }
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_mean_against_numeric, setup, teardown),
        cmocka_unit_test_setup_teardown(test_mean_closed_forms, setup, teardown),
        cmocka_unit_test(test_far_uvs),
        cmocka_unit_test_setup_teardown(test_sampled_accuracy, setup, teardown),
        cmocka_unit_test_setup_teardown(test_obj_map_kd, setup, teardown),
        cmocka_unit_test_setup_teardown(test_obj_clamp_and_errors, setup, teardown),
        cmocka_unit_test_setup_teardown(test_gltf_base_color_texture, setup, teardown),
        cmocka_unit_test_setup_teardown(test_embedded_equals_external, setup, teardown),
        cmocka_unit_test_setup_teardown(test_emissive_strength, setup, teardown),
        cmocka_unit_test(test_allocation_failures),
        cmocka_unit_test_setup_teardown(test_operator_keeps_textures, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
