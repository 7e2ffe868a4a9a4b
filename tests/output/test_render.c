/* lrr_render_png: Gouraud shading, welding, back-face culling, cameras, tone mapping, errors
 * and atomic writing. Pictures are decoded again with stb_image and inspected. */
#include "output/render_util.h"

#include <errno.h>

/* ------------------------------------------------------------------ helpers */

/* The unit square at z = z0 facing +z (front_z = 1) or −z (front_z = 0). */
static void unit_quad(float v[18], double z0, int front_z)
{
    double p0[3] = {0, 0, z0}, p1[3] = {1, 0, z0}, p2[3] = {1, 1, z0}, p3[3] = {0, 1, z0};
    if (front_z)
        tu_quad(v, p0, p1, p2, p3);
    else
        tu_quad(v, p0, p3, p2, p1);
}

/* ------------------------------------------------------------------ tests */

/* Uniform radiosity on a subdivided box seen from outside (its near walls culled): every
 * covered pixel has the same value, the rest is black, and the default size is 512². */
static void test_uniform(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108];
    tu_box_inward(v, 2, 1, 1.5);
    lrr_operator *op = ru_make_op(ctx, 12, v, 2, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 0.3f, 0.3f, 0.3f);
    int w, h;
    unsigned char *img = ru_render(ctx, op, B, NULL, "render-uniform.png", &w, &h);
    assert_int_equal(w, 512);
    assert_int_equal(h, 512);
    size_t lit = 0;
    int ref = -1;
    for (size_t p = 0; p < (size_t)w * h; p++) {
        const unsigned char *c = img + 3 * p;
        if (!c[0] && !c[1] && !c[2])
            continue;
        lit++;
        if (ref < 0)
            ref = c[0];
        if (c[0] != ref || c[1] != ref || c[2] != ref)
            fail_msg("pixel %zu = (%d,%d,%d), expected uniform %d", p, c[0], c[1], c[2], ref);
    }
    /* the box fills a good part of the view, but not all of it */
    assert_true(lit > (size_t)w * h / 8);
    assert_true(lit < (size_t)w * h * 9 / 10);
    /* automatic exposure: mean luminance → 0.18 and x/(1+x): a mid grey, not black/white */
    assert_true(ref > 60 && ref < 200);
    /* corners of the picture are background */
    assert_int_equal(img[0], 0);
    assert_int_equal(img[3 * ((size_t)w * h - 1)], 0);
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* A quad whose radiosity grows from left to right: Gouraud shading gives a smooth ramp along
 * every row (monotone, no steps at the subpatch edges), where flat shading would jump. */
static void test_gouraud_ramp(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    unit_quad(v, 0, 1);
    lrr_operator *op = ru_make_op(ctx, 2, v, 3, LRR__SCENE_FILE); /* 8×8 steps across */
    float *B = ru_uniform(op->n, 0, 0, 0);
    for (size_t i = 0; i < op->n; i++)
        for (int j = 0; j < 3; j++)
            B[3 * i + j] = 0.3f + 1.5f * op->centre[3 * i];
    lrr_render_options o = {.width = 400, .height = 300, .exposure = 1.0, .use_cornell_camera = 0};
    int w, h;
    unsigned char *img = ru_render(ctx, op, B, &o, "render-ramp.png", &w, &h);
    assert_int_equal(w, 400);
    assert_int_equal(h, 300);
    int rows = 0;
    for (int y = h / 4; y < 3 * h / 4; y += 7) {
        const unsigned char *row = img + (size_t)3 * w * y;
        int first = -1, last = -1;
        for (int x = 0; x < w; x++)
            if (row[3 * x]) {
                if (first < 0)
                    first = x;
                last = x;
            }
        if (first < 0 || last - first < w / 4)
            continue;
        rows++;
        int max_step = 0;
        for (int x = first + 1; x <= last; x++) {
            int d = row[3 * x] - row[3 * (x - 1)];
            if (d < 0)
                fail_msg("row %d: pixel %d = %d < pixel %d = %d (not monotone)", y, x,
                         row[3 * x], x - 1, row[3 * (x - 1)]);
            if (d > max_step)
                max_step = d;
            /* watertight: no cracks along the subpatch edges */
            if (row[3 * x] == 0)
                fail_msg("row %d: pixel %d inside the quad is not drawn", y, x);
            /* grey stays grey */
            assert_int_equal(row[3 * x], row[3 * x + 1]);
        }
        /* the ramp spans much of the range but rises by small steps only: 8 flat-shaded
         * subpatches across would jump by ~15-25 levels at each edge */
        assert_true(row[3 * last] - row[3 * first] > 50);
        if (max_step > 3)
            fail_msg("row %d: a step of %d levels between adjacent pixels", y, max_step);
    }
    assert_true(rows >= 5);
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Corners between walls stay sharp: walls of different uniform radiosity meet without any
 * blended pixels, because vertices are only shared by subpatches with the same normal. */
static void test_sharp_corners(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108];
    tu_box_inward(v, 1, 1, 1);
    lrr_operator *op = ru_make_op(ctx, 12, v, 2, LRR__SCENE_FILE);
    /* faces in order x=0, x=1, y=0, y=1, z=0, z=1; each a pure colour */
    static const float face_col[6][3] = {{0.4f, 0, 0}, {0, 0.4f, 0}, {0, 0, 0.4f},
                                         {0.4f, 0.4f, 0}, {0, 0.4f, 0.4f}, {0.4f, 0, 0.4f}};
    float *B = ru_uniform(op->n, 0, 0, 0);
    for (size_t i = 0; i < op->n; i++) {
        size_t face = (i / op->d) / 2; /* one patch per triangle, two triangles per face */
        memcpy(B + 3 * i, face_col[face], sizeof face_col[face]);
    }
    lrr_render_options o = {.width = 256, .height = 256, .exposure = 2.0, .use_cornell_camera = 0};
    int w, h;
    unsigned char *img = ru_render(ctx, op, B, &o, "render-corners.png", &w, &h);
    int seen[6] = {0};
    for (size_t p = 0; p < (size_t)w * h; p++) {
        const unsigned char *c = img + 3 * p;
        if (!c[0] && !c[1] && !c[2])
            continue;
        /* every channel is either off or at the one common "on" level */
        int on = c[0] > c[1] ? (c[0] > c[2] ? c[0] : c[2]) : (c[1] > c[2] ? c[1] : c[2]);
        for (int j = 0; j < 3; j++)
            if (c[j] != 0 && c[j] != on)
                fail_msg("pixel (%zu,%zu) = (%d,%d,%d): a blend of two walls", p % w, p / w,
                         c[0], c[1], c[2]);
        for (int f = 0; f < 6; f++)
            if ((c[0] != 0) == (face_col[f][0] > 0) && (c[1] != 0) == (face_col[f][1] > 0) &&
                (c[2] != 0) == (face_col[f][2] > 0))
                seen[f]++;
    }
    /* seen from +z and above: the far wall (z=0), floor and both side walls, not the near
     * wall (z=1) or the ceiling, which face away */
    assert_true(seen[0] > 100);
    assert_true(seen[1] > 100);
    assert_true(seen[2] > 100);
    assert_int_equal(seen[3], 0);
    assert_true(seen[4] > 100);
    assert_int_equal(seen[5], 0);
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Separate triangles share no vertices: each is drawn flat in its own colour (and the
 * welding table grows past its first guess of n vertices). */
static void test_disjoint_triangles(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    enum { G = 12, T = G * G };
    float v[T * 9];
    for (int t = 0; t < T; t++) {
        double x = t % G, y = t / G;
        double p[3][3] = {{x + 0.1, y + 0.1, 0}, {x + 0.9, y + 0.1, 0}, {x + 0.1, y + 0.9, 0}};
        for (int k = 0; k < 9; k++)
            v[9 * t + k] = (float)p[k / 3][k % 3];
    }
    lrr_operator *op = ru_make_op(ctx, T, v, 0, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 0, 0, 0);
    for (size_t i = 0; i < op->n; i++)
        B[3 * i] = B[3 * i + 1] = B[3 * i + 2] = 0.1f + 0.9f * (float)i / (T - 1);
    lrr_render_options o = {.width = 512, .height = 512, .exposure = 1.0, .use_cornell_camera = 0};
    int w, h;
    unsigned char *img = ru_render(ctx, op, B, &o, "render-disjoint.png", &w, &h);
    size_t hist[256] = {0};
    for (size_t p = 0; p < (size_t)w * h; p++)
        hist[img[3 * p]]++;
    int levels = 0;
    for (int c = 1; c < 256; c++) {
        if (!hist[c])
            continue;
        levels++;
        /* flat triangles of a few hundred pixels each: no level shows on a few pixels only,
         * as blends along shared edges would */
        if (hist[c] < 100)
            fail_msg("grey level %d on %zu pixels only", c, hist[c]);
    }
    assert_true(levels >= 90);
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Triangles are one-sided: with a fixed camera a quad turned away draws nothing. */
static void test_back_face(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    /* a 400 mm square in front of the Cornell camera (eye z = -800, looking along +z) */
    double p0[3] = {78, 73, 100}, p1[3] = {478, 73, 100}, p2[3] = {478, 473, 100},
           p3[3] = {78, 473, 100};
    lrr_render_options o = {.width = 128, .height = 128, .exposure = 1.0, .use_cornell_camera = 1};
    int w, h;
    for (int towards = 0; towards < 2; towards++) {
        if (towards)
            tu_quad(v, p0, p3, p2, p1); /* normal −z: faces the camera */
        else
            tu_quad(v, p0, p1, p2, p3); /* normal +z: faces away */
        lrr_operator *op = ru_make_op(ctx, 2, v, 1, LRR__SCENE_FILE);
        float *B = ru_uniform(op->n, 1, 1, 1);
        unsigned char *img = ru_render(ctx, op, B, &o, "render-backface.png", &w, &h);
        size_t lit = ru_count_lit(img, w, h);
        if (towards) {
            assert_true(lit > (size_t)w * h / 10);
            /* the centre of the picture looks at the square's centre */
            assert_true(img[3 * ((size_t)w * (h / 2) + w / 2)] > 0);
        } else {
            assert_int_equal(lit, 0);
        }
        stbi_image_free(img);
        free(B);
        lrr_operator_destroy(op);
    }
    lrr_context_destroy(ctx);
}

/* Geometry crossing the camera plane is clipped, not mirrored or dropped: a floor passing
 * under and behind the Cornell camera covers the lower half of the picture exactly. */
static void test_near_clipping(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    double p0[3] = {-1e6, 0, -5000}, p1[3] = {-1e6, 0, 1e5}, p2[3] = {1e6, 0, 1e5},
           p3[3] = {1e6, 0, -5000};
    tu_quad(v, p0, p1, p2, p3); /* normal +y */
    lrr_operator *op = ru_make_op(ctx, 2, v, 0, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 1, 1, 1);
    lrr_render_options o = {.width = 64, .height = 64, .exposure = 1.0, .use_cornell_camera = 1};
    int w, h;
    unsigned char *img = ru_render(ctx, op, B, &o, "render-clip.png", &w, &h);
    /* the floor is 273 below the eye; its far edge (z = 1e5) projects 0.24 pixels below the
     * middle of the picture, so exactly the rows from h/2 down are covered */
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            int lit = img[3 * ((size_t)w * y + x)] != 0;
            if (lit != (y >= h / 2))
                fail_msg("pixel (%d,%d) lit = %d", x, y, lit);
        }
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);

    /* inside a subdivided room around the camera: walls cut by the near plane and the guard
     * band on every side still cover every pixel, without cracks along the cuts */
    float room[108];
    tu_box_inward(room, 1, 1, 1);
    for (int i = 0; i < 108; i++) /* [0,1]³ → a 3000-wide room with the eye inside */
        room[i] = room[i] * 3000 - 1500 + (i % 3 == 0 ? 278 : i % 3 == 1 ? 273 : -800);
    op = ru_make_op(ctx, 12, room, 3, LRR__SCENE_FILE);
    B = ru_uniform(op->n, 1, 1, 1);
    lrr_render_options o2 = {.width = 97, .height = 61, .exposure = 1.0, .use_cornell_camera = 1};
    img = ru_render(ctx, op, B, &o2, "render-room.png", &w, &h);
    assert_int_equal(ru_count_lit(img, w, h), (size_t)w * h);
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Direct light only, without occlusion: enough colour for the camera checks. */
static void crude_radiosity(const lrr_operator *op, float *B)
{
    for (size_t i = 0; i < op->n; i++) {
        double in[3] = {0.1, 0.1, 0.1}; /* ambient, so that no visible surface is black */
        for (size_t j = 0; j < op->n; j++) {
            const float *e = op->emission + 3 * j;
            if (!(e[0] > 0) || i == j)
                continue;
            double d[3], r2 = 0, ci = 0, cj = 0;
            for (int c = 0; c < 3; c++) {
                d[c] = op->centre[3 * j + c] - op->centre[3 * i + c];
                r2 += d[c] * d[c];
                ci += d[c] * op->normal[3 * i + c];
                cj -= d[c] * op->normal[3 * j + c];
            }
            if (ci <= 0 || cj <= 0)
                continue;
            double ff = ci * cj / (M_PI * r2 * r2) * op->area[j];
            for (int c = 0; c < 3; c++)
                in[c] += ff * e[c];
        }
        for (int c = 0; c < 3; c++)
            B[3 * i + c] = op->emission[3 * i + c] + op->rho[3 * i + c] * (float)in[c];
    }
}

static lrr_operator *cornell_op(lrr_context *ctx, int closed)
{
    lrr_scene *scene = tu_cornell(ctx, closed, 0, 0);
    lrr_subdivision sub = {0};
    sub.max_patch_area = 4000;
    sub.levels = 0;
    LRR_CHECK(ctx, lrr_scene_subdivide(scene, &sub));
    lrr_operator *op = NULL;
    LRR_CHECK(ctx, lrr__operator_new(ctx, &scene->geom, LRR_STORAGE_F32, &op));
    op->builtin = scene->builtin;
    LRR_CHECK(ctx, lrr_scene_subpatches(scene, NULL, NULL, NULL, op->rho, op->emission));
    lrr_scene_destroy(scene);
    return op;
}

/* Sums of the red and green channels over a column range of the lit pixels. */
static void channel_sums(const unsigned char *img, int w, int h, int x0, int x1, double *r,
                         double *g)
{
    *r = *g = 0;
    for (int y = 0; y < h; y++)
        for (int x = x0; x < x1; x++) {
            *r += img[3 * ((size_t)w * y + x)];
            *g += img[3 * ((size_t)w * y + x) + 1];
        }
}

/* The Cornell camera (chosen automatically for the built-in boxes) shows the red wall on the
 * left and the green one on the right; in the closed box the front wall faces away from the
 * camera and is culled, so the picture is the same room. The light is the brightest part. */
static void test_cornell_camera(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    unsigned char *imgs[2];
    for (int closed = 0; closed < 2; closed++) {
        lrr_operator *op = cornell_op(ctx, closed);
        float *B = ru_uniform(op->n, 0, 0, 0);
        crude_radiosity(op, B);
        lrr_render_options o = {.width = 200, .height = 200, .use_cornell_camera = -1};
        int w, h;
        unsigned char *img = ru_render(ctx, op, B, &o, "render-cornell.png", &w, &h);
        assert_int_equal(w, 200);
        double rl, gl, rr, gr;
        channel_sums(img, w, h, 0, w / 2, &rl, &gl);
        channel_sums(img, w, h, w / 2, w, &rr, &gr);
        assert_true(rl > gl);
        assert_true(gr > rr);
        /* the room fills the view: the box's opening spans most of the 2·atan(12.5/35)
         * field of view */
        assert_true(ru_count_lit(img, w, h) > (size_t)w * h * 3 / 4);
        /* the light, at the top centre, is white */
        int light = 0;
        for (int y = 0; y < h / 6; y++)
            for (int x = w / 3; x < 2 * w / 3; x++)
                if (img[3 * ((size_t)w * y + x)] == 255 && img[3 * ((size_t)w * y + x) + 1] > 200)
                    light++;
        assert_true(light > 20);
        /* pixels off the camera's axis: the red wall spans the left edge */
        const unsigned char *left = img + 3 * ((size_t)w * (h / 2) + w / 10);
        assert_true(left[0] > 2 * left[1]);
        imgs[closed] = img;
        free(B);
        lrr_operator_destroy(op);
    }
    /* the front wall faces away and is culled; the radiosity of the room is the same (the
     * crude model ignores the wall's reflections), so the pictures are identical */
    if (memcmp(imgs[0], imgs[1], 200 * 200 * 3) != 0)
        fail_msg("the closed box's picture differs from the open one's");
    stbi_image_free(imgs[0]);
    stbi_image_free(imgs[1]);

    /* use_cornell_camera = 0 frames the scene instead: a different picture */
    lrr_operator *op = cornell_op(ctx, 0);
    float *B = ru_uniform(op->n, 0, 0, 0);
    crude_radiosity(op, B);
    lrr_render_options o = {.width = 200, .height = 200, .use_cornell_camera = 0};
    int w, h;
    unsigned char *img = ru_render(ctx, op, B, &o, "render-cornell-framed.png", &w, &h);
    size_t lit = ru_count_lit(img, w, h);
    assert_true(lit > 1000 && lit < (size_t)w * h * 3 / 4); /* the whole box, with margins */
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The whole pipeline on the Cornell box: solved radiosity, automatic exposure. Colour
 * bleeding: the white back wall is redder near the red wall than near the green one. */
static void test_cornell_solved(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    lrr_scene *scene = tu_cornell(ctx, 0, 0, 0);
    lrr_subdivision sub = {0};
    sub.max_patch_area = 6000;
    sub.levels = 1;
    LRR_CHECK(ctx, lrr_scene_subdivide(scene, &sub));
    lrr_build_options bo = {0};
    bo.hemicube_resolution = 32;
    bo.seed = 1;
    lrr_operator *op;
    LRR_CHECK(ctx, lrr_operator_build(scene, &bo, &op));
    lrr_scene_destroy(scene);
    lrr_solver *solver;
    LRR_CHECK(ctx, lrr_solver_create(op, LRR_BACKEND_CPU, &solver));
    float *B = ru_uniform(op->n, 0, 0, 0);
    LRR_CHECK(ctx, lrr_solve(solver, lrr_operator_emission(op), B));
    int w, h;
    lrr_render_options o = {.width = 256, .height = 256, .use_cornell_camera = -1};
    unsigned char *img = ru_render(ctx, op, B, &o, "render-cornell-solved.png", &w, &h);
    double rl, gl, rr, gr;
    channel_sums(img, w, h, 0, w / 2, &rl, &gl);
    channel_sums(img, w, h, w / 2, w, &rr, &gr);
    assert_true(rl > gl);
    assert_true(gr > rr);
    /* back wall strips (z = 559.2), 1/4 and 3/4 across, above the blocks */
    double ratio[2];
    for (int s = 0; s < 2; s++) {
        double r = 0, g = 0;
        int x0 = s ? 150 : 90;
        for (int y = 60; y < 80; y++)
            for (int x = x0; x < x0 + 16; x++) {
                r += img[3 * ((size_t)w * y + x)];
                g += img[3 * ((size_t)w * y + x) + 1];
            }
        ratio[s] = r / g;
    }
    assert_true(ratio[0] > ratio[1]);
    stbi_image_free(img);
    free(B);
    lrr_solver_destroy(solver);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Bad sizes, options and radiosity are errors that leave no file behind. */
static void test_invalid(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    unit_quad(v, 0, 1);
    lrr_operator *op = ru_make_op(ctx, 2, v, 1, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 0.5f, 0.5f, 0.5f);
    char path[512], msg[512];
    tu_tmp_path(path, sizeof path, "render-invalid.png");
    remove(path);

    lrr_render_options bad[] = {
        {.width = 16385, .height = 100}, {.width = 100, .height = 100000},
        {.width = 100, .height = 100, .exposure = -1},
        {.width = 100, .height = 100, .exposure = NAN},
        {.width = 100, .height = 100, .exposure = INFINITY},
        {.width = 100, .height = 100, .use_cornell_camera = 2},
        {.width = 100, .height = 100, .use_cornell_camera = -2}};
    for (size_t t = 0; t < sizeof bad / sizeof bad[0]; t++) {
        assert_int_equal(lrr_render_png(op, B, &bad[t], path), LRR_ERR_INVALID_ARG);
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
        assert_true(strlen(msg) > 10);
        assert_false(ru_file_exists(path));
    }
    const float poison[] = {NAN, INFINITY, -INFINITY, -0.25f};
    for (size_t t = 0; t < 4; t++) {
        B[3 * 5 + 1] = poison[t];
        assert_int_equal(lrr_render_png(op, B, NULL, path), LRR_ERR_INVALID_ARG);
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
        if (!strstr(msg, "subpatch 5"))
            fail_msg("message does not name the subpatch: %s", msg);
        assert_false(ru_file_exists(path));
    }
    B[3 * 5 + 1] = 0.5f;
    /* the largest legal size per side is accepted */
    lrr_render_options thin = {.width = 16384, .height = 1, .use_cornell_camera = 0};
    LRR_CHECK(ctx, lrr_render_png(op, B, &thin, path));
    assert_true(ru_file_exists(path));
    remove(path);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Unwritable destinations give LRR_ERR_IO naming the path, and leave no temporary file. */
static void test_io_errors(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    unit_quad(v, 0, 1);
    lrr_operator *op = ru_make_op(ctx, 2, v, 0, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 0.5f, 0.5f, 0.5f);
    lrr_render_options o = {.width = 32, .height = 32, .use_cornell_camera = 0};
    char path[640], msg[512], dir[512];

    /* a directory that does not exist */
    tu_tmp_path(dir, sizeof dir, "render-no-such-dir");
    snprintf(path, sizeof path, "%s/x.png", dir);
    assert_int_equal(lrr_render_png(op, B, &o, path), LRR_ERR_IO);
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_IO);
    if (!strstr(msg, path) || !strstr(msg, strerror(ENOENT)))
        fail_msg("message should name the path and the cause: %s", msg);
    assert_false(ru_file_exists(dir));

    /* the destination is a directory: the rename fails after the temporary file was written,
     * which must then be removed */
    tu_tmp_path(dir, sizeof dir, "render-is-a-dir");
    assert_int_equal(mkdir(dir, 0755), 0);
    char prefix[256];
    snprintf(prefix, sizeof prefix, "%s.tmp.", strrchr(dir, '/') + 1);
    assert_int_equal(lrr_render_png(op, B, &o, dir), LRR_ERR_IO);
    assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_IO);
    assert_non_null(strstr(msg, dir));
    assert_int_equal(ru_count_prefixed(prefix), 0);
    assert_int_equal(rmdir(dir), 0);

    /* an existing file is replaced by a complete new picture */
    tu_tmp_path(path, sizeof path, "render-replace.png");
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs("not a picture", f);
    fclose(f);
    LRR_CHECK(ctx, lrr_render_png(op, B, &o, path));
    int w, h, comp;
    unsigned char *img = stbi_load(path, &w, &h, &comp, 3);
    assert_non_null(img);
    assert_int_equal(w, 32);
    assert_int_equal(h, 32);
    stbi_image_free(img);
    remove(path);
    snprintf(prefix, sizeof prefix, "%s.tmp.", strrchr(path, '/') + 1);
    assert_int_equal(ru_count_prefixed(prefix), 0);

    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Pictures are written through the library's one atomic writer: every step sees the I/O
 * fault hook, a failure at any step leaves neither the picture nor a temporary file, and a
 * failed directory sync (best effort) still gives the picture. */
typedef struct render_fault {
    unsigned long at, steps;
    char names[16][24];
} render_fault;

static int render_inject(void *user, unsigned long step, const char *what)
{
    render_fault *f = user;
    if (step < 16)
        snprintf(f->names[step], sizeof f->names[step], "%s", what);
    f->steps = step;
    return step == f->at ? ENOSPC : 0;
}

static void test_write_faults(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    unit_quad(v, 0, 1);
    lrr_operator *op = ru_make_op(ctx, 2, v, 0, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 0.5f, 0.5f, 0.5f);
    lrr_render_options o = {.width = 32, .height = 32, .use_cornell_camera = 0};
    char path[640], msg[512], prefix[256];
    tu_tmp_path(path, sizeof path, "render-faults.png");
    remove(path);
    snprintf(prefix, sizeof prefix, "%s.tmp.", strrchr(path, '/') + 1);

    render_fault f = {0};
    lrr__context_set_io_hook(ctx, render_inject, &f); /* at = 0: no fault, count the steps */
    LRR_CHECK(ctx, lrr_render_png(op, B, &o, path));
    const unsigned long steps = f.steps;
    assert_true(steps >= 7 && steps < 16);
    assert_string_equal(f.names[1], "create");
    assert_string_equal(f.names[steps - 1], "rename");
    assert_string_equal(f.names[steps], "sync directory");
    assert_int_equal(remove(path), 0);
    for (unsigned long at = 1; at < steps; at++) {
        f = (render_fault){.at = at};
        lrr__context_set_io_hook(ctx, render_inject, &f);
        assert_int_equal(lrr_render_png(op, B, &o, path), LRR_ERR_IO);
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_IO);
        if (!strstr(msg, path) || !strstr(msg, strerror(ENOSPC)))
            fail_msg("step %lu (%s): the message should name the path and the cause: %s", at,
                     f.names[at], msg);
        if (ru_file_exists(path))
            fail_msg("step %lu (%s) failed, yet the picture exists", at, f.names[at]);
        assert_int_equal(ru_count_prefixed(prefix), 0);
    }
    f = (render_fault){.at = steps};
    lrr__context_set_io_hook(ctx, render_inject, &f);
    LRR_CHECK(ctx, lrr_render_png(op, B, &o, path));
    assert_true(ru_file_exists(path));
    remove(path);
    lrr__context_set_io_hook(ctx, NULL, NULL);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Exposure: an explicit multiplier scales the picture; automatic exposure ignores the
 * absolute scale of the radiosity. */
static void test_exposure(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    unit_quad(v, 0, 1);
    lrr_operator *op = ru_make_op(ctx, 2, v, 1, LRR__SCENE_FILE);
    int w, h, centre = 3 * (32 * 16 + 16);
    lrr_render_options o = {.width = 32, .height = 32, .use_cornell_camera = 0};
    float *B = ru_uniform(op->n, 0.01f, 0.01f, 0.01f);
    unsigned char *a = ru_render(ctx, op, B, &o, "render-exp.png", &w, &h);
    for (size_t i = 0; i < 3 * op->n; i++)
        B[i] = 1000;
    unsigned char *b = ru_render(ctx, op, B, &o, "render-exp.png", &w, &h);
    assert_true(a[centre] > 0);
    assert_int_equal(a[centre], b[centre]);
    o.exposure = 1e-3;
    unsigned char *c = ru_render(ctx, op, B, &o, "render-exp.png", &w, &h); /* x = 1 */
    o.exposure = 1e-2;
    unsigned char *d = ru_render(ctx, op, B, &o, "render-exp.png", &w, &h); /* x = 10 */
    assert_true(c[centre] > 100 && c[centre] < 250);
    assert_int_equal(d[centre], 255);
    stbi_image_free(a);
    stbi_image_free(b);
    stbi_image_free(c);
    stbi_image_free(d);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_uniform),       cmocka_unit_test(test_gouraud_ramp),
        cmocka_unit_test(test_sharp_corners), cmocka_unit_test(test_disjoint_triangles),
        cmocka_unit_test(test_back_face),
        cmocka_unit_test(test_near_clipping), cmocka_unit_test(test_cornell_camera),
        cmocka_unit_test(test_cornell_solved), cmocka_unit_test(test_invalid),
        cmocka_unit_test(test_io_errors),     cmocka_unit_test(test_write_faults),
        cmocka_unit_test(test_exposure),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
