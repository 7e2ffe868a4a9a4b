/* The render cameras (lib/output/camera.c): the eye/target pinhole (orientation, up, the near
 * plane inside a room), the automatic camera inside a lit closed scene (and not elsewhere),
 * and the checks of the camera options. */
#include "output/render_util.h"

/* A 2×1×1.5 box with inward faces (x=0, x=2, y=0, y=1, z=0, z=1.5), each in a pure colour
 * whose on-channels name it; the ceiling (y=1) emits when lit is set. With open set the
 * z=1.5 wall is left out. */
static const float face_col[6][3] = {{0.4f, 0, 0},    {0, 0.4f, 0},    {0, 0, 0.4f},
                                     {0.4f, 0.4f, 0}, {0, 0.4f, 0.4f}, {0.4f, 0, 0.4f}};
enum { RED_X0, GREEN_X2, BLUE_FLOOR, YELLOW_CEILING, CYAN_Z0, MAGENTA_Z15 };

static lrr_operator *box_op(lrr_context *ctx, int lit, int open, float **B)
{
    float v[108];
    tu_box_inward(v, 2, 1, 1.5);
    lrr_operator *op = ru_make_op(ctx, open ? 10 : 12, v, 1, LRR__SCENE_FILE);
    *B = ru_uniform(op->n, 0, 0, 0);
    for (size_t i = 0; i < op->n; i++) {
        size_t face = (i / op->d) / 2; /* one patch per triangle, two triangles per face */
        memcpy(*B + 3 * i, face_col[face], sizeof face_col[face]);
        if (lit && face == YELLOW_CEILING)
            for (int j = 0; j < 3; j++)
                op->emission[3 * i + j] = 1;
    }
    return op;
}

/* The face whose colour pixel (x, y) shows, or -1 (background or a blend). */
static int face_at(const unsigned char *img, int w, int x, int y)
{
    const unsigned char *c = img + 3 * ((size_t)w * y + x);
    for (int f = 0; f < 6; f++)
        if ((c[0] != 0) == (face_col[f][0] > 0) && (c[1] != 0) == (face_col[f][1] > 0) &&
            (c[2] != 0) == (face_col[f][2] > 0))
            return f;
    return -1;
}

static size_t count_face(const unsigned char *img, int w, int h, int face)
{
    size_t k = 0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            k += face_at(img, w, x, y) == face;
    return k;
}

/* A closed box with a light in its ceiling: the automatic camera stands inside (every pixel
 * a wall, the ceiling light at the top, the floor at the bottom), looking along the longest
 * side (x) towards the brighter (green) end; the framing camera, outside and above, sees the
 * box cut open (background around it) and never the ceiling, which faces away from it. */
static void test_inside_closed_lit(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float *B;
    lrr_operator *op = box_op(ctx, 1, 0, &B);
    lrr_render_options o = lrr_render_options_defaults();
    o.width = 96;
    o.height = 64;
    o.exposure = 2;
    int w, h;
    unsigned char *img = ru_render(ctx, op, B, &o, "camera-inside.png", &w, &h);
    assert_int_equal(ru_count_lit(img, w, h), (size_t)w * h);
    assert_int_equal(face_at(img, w, w / 2, h / 2), GREEN_X2);
    assert_int_equal(face_at(img, w, w / 2, 1), YELLOW_CEILING);
    assert_int_equal(face_at(img, w, w / 2, h - 2), BLUE_FLOOR);
    /* looking along +x with +y up, +z is on the right */
    assert_int_equal(face_at(img, w, 1, h / 2), CYAN_Z0);
    assert_int_equal(face_at(img, w, w - 2, h / 2), MAGENTA_Z15);
    assert_int_equal(count_face(img, w, h, RED_X0), 0); /* behind the eye */
    stbi_image_free(img);

    o.use_cornell_camera = 0; /* the framing camera, as before */
    img = ru_render(ctx, op, B, &o, "camera-outside.png", &w, &h);
    size_t lit = ru_count_lit(img, w, h);
    assert_true(lit > (size_t)w * h / 8 && lit < (size_t)w * h * 9 / 10);
    assert_int_equal(count_face(img, w, h, YELLOW_CEILING), 0);
    assert_int_equal(img[0], 0);
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The automatic camera stays the framing one (bit-identical pictures) for a closed box that
 * emits nothing and for an open box with a light. */
static void test_outside_otherwise(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    for (int open = 0; open < 2; open++) {
        float *B;
        lrr_operator *op = box_op(ctx, open, open, &B);
        lrr_render_options o = lrr_render_options_defaults();
        o.width = 80;
        o.height = 60;
        int w, h;
        unsigned char *a = ru_render(ctx, op, B, &o, "camera-auto.png", &w, &h);
        o.use_cornell_camera = 0;
        unsigned char *b = ru_render(ctx, op, B, &o, "camera-fit.png", &w, &h);
        if (memcmp(a, b, (size_t)3 * w * h) != 0)
            fail_msg("%s box: the automatic camera is not the framing one",
                     open ? "open lit" : "closed unlit");
        assert_true(ru_count_lit(a, w, h) < (size_t)w * h * 9 / 10);
        stbi_image_free(a);
        stbi_image_free(b);
        free(B);
        lrr_operator_destroy(op);
    }
    lrr_context_destroy(ctx);
}

/* The eye/target camera: from near the x = 0 wall towards +x the green wall is in the middle,
 * +z on the right with +y up and on the left with −y up (the floor then at the top); walls
 * around and behind the eye are clipped, so every pixel is a wall. A narrower field of view
 * shows only the far wall. */
static void test_eye_target(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float *B;
    lrr_operator *op = box_op(ctx, 0, 0, &B);
    lrr_render_options o = lrr_render_options_defaults();
    o.width = o.height = 64;
    o.exposure = 2;
    o.use_eye = 1;
    o.use_cornell_camera = 1; /* ignored with use_eye */
    const double eye[3] = {0.3, 0.5, 0.75}, target[3] = {2, 0.5, 0.75};
    memcpy(o.eye, eye, sizeof eye);
    memcpy(o.target, target, sizeof target);
    int w, h;
    for (int flip = 0; flip < 2; flip++) {
        o.up[1] = flip ? -1 : 1;
        unsigned char *img = ru_render(ctx, op, B, &o, "camera-eye.png", &w, &h);
        assert_int_equal(ru_count_lit(img, w, h), (size_t)w * h);
        assert_int_equal(face_at(img, w, w / 2, h / 2), GREEN_X2);
        assert_int_equal(face_at(img, w, w - 2, h / 2), flip ? CYAN_Z0 : MAGENTA_Z15);
        assert_int_equal(face_at(img, w, 1, h / 2), flip ? MAGENTA_Z15 : CYAN_Z0);
        assert_int_equal(face_at(img, w, w / 2, 1), flip ? BLUE_FLOOR : YELLOW_CEILING);
        stbi_image_free(img);
    }
    /* up (0, 0, 0) means +y */
    o.up[0] = o.up[1] = o.up[2] = 0;
    o.fov_degrees = 20; /* the far wall 1.7 away: ±0.3 of it in view */
    unsigned char *img = ru_render(ctx, op, B, &o, "camera-eye.png", &w, &h);
    assert_int_equal(count_face(img, w, h, GREEN_X2), (size_t)w * h);
    stbi_image_free(img);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The camera fields are part of ABI 1's layout: with size = 0 (designated initialisers)
 * they are read, and the picture is the one the defaults plus the same fields give. */
static void test_first_layout_reads_eye(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float *B;
    lrr_operator *op = box_op(ctx, 0, 0, &B);
    lrr_render_options o0 = {.width = 48, .height = 48, .use_cornell_camera = 0,
                             .use_eye = 1, .eye = {1, 0.5, 0.75}, .target = {2, 0.5, 0.75}};
    lrr_render_options sized = lrr_render_options_defaults();
    sized.width = sized.height = 48;
    sized.use_cornell_camera = 0;
    sized.use_eye = 1;
    memcpy(sized.eye, o0.eye, sizeof o0.eye);
    memcpy(sized.target, o0.target, sizeof o0.target);
    lrr_render_options plain = {.width = 48, .height = 48, .use_cornell_camera = 0};
    int w, h;
    unsigned char *a = ru_render(ctx, op, B, &o0, "camera-size0.png", &w, &h);
    unsigned char *b = ru_render(ctx, op, B, &sized, "camera-sized.png", &w, &h);
    unsigned char *c = ru_render(ctx, op, B, &plain, "camera-plain.png", &w, &h);
    assert_memory_equal(a, b, (size_t)3 * w * h);
    assert_true(memcmp(a, c, (size_t)3 * w * h) != 0); /* the eye did move the camera */
    stbi_image_free(a);
    stbi_image_free(b);
    stbi_image_free(c);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Bad camera options are LRR_ERR_INVALID_ARG naming the field, and write nothing. */
static void test_invalid_camera(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float *B;
    lrr_operator *op = box_op(ctx, 0, 0, &B);
    char path[512], msg[512];
    tu_tmp_path(path, sizeof path, "camera-invalid.png");
    remove(path);
    static const struct {
        double eye[3], target[3], up[3], fov;
        int use_eye;
        const char *names;
    } bad[] = {
        {{1, 1, 1}, {1, 1, 1}, {0, 1, 0}, 0, 1, "no view direction"},
        {{1, 0, 1}, {1, 5, 1}, {0, 1, 0}, 0, 1, "parallel"},
        {{1, 1, 1}, {1, 0, 1}, {0, 0, 0}, 0, 1, "parallel"}, /* the default up, +y */
        {{NAN, 1, 1}, {1, 0, 0}, {0, 1, 0}, 0, 1, "eye"},
        {{1, 1, 1}, {INFINITY, 0, 0}, {0, 1, 0}, 0, 1, "target"},
        {{1, 1, 1}, {2, 1, 1}, {0, NAN, 0}, 0, 1, "up"},
        {{1, 1, 1}, {2, 1, 1}, {0, 1, 0}, 180, 1, "fov_degrees"},
        {{1, 1, 1}, {2, 1, 1}, {0, 1, 0}, -5, 0, "fov_degrees"},
        {{1, 1, 1}, {2, 1, 1}, {0, 1, 0}, NAN, 0, "fov_degrees"},
        {{1, 1, 1}, {2, 1, 1}, {0, 1, 0}, 0, 2, "use_eye"},
    };
    for (size_t t = 0; t < sizeof bad / sizeof bad[0]; t++) {
        lrr_render_options o = lrr_render_options_defaults();
        o.width = o.height = 16;
        memcpy(o.eye, bad[t].eye, sizeof o.eye);
        memcpy(o.target, bad[t].target, sizeof o.target);
        memcpy(o.up, bad[t].up, sizeof o.up);
        o.fov_degrees = bad[t].fov;
        o.use_eye = bad[t].use_eye;
        assert_int_equal(lrr_render_png(op, B, &o, path), LRR_ERR_INVALID_ARG);
        assert_int_equal(lrr_context_last_error(ctx, msg, sizeof msg), LRR_ERR_INVALID_ARG);
        if (!strstr(msg, bad[t].names))
            fail_msg("case %zu: the message should say '%s': %s", t, bad[t].names, msg);
        assert_false(ru_file_exists(path));
    }
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_inside_closed_lit), cmocka_unit_test(test_outside_otherwise),
        cmocka_unit_test(test_eye_target), cmocka_unit_test(test_first_layout_reads_eye),
        cmocka_unit_test(test_invalid_camera),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
