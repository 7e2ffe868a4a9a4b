/* Scene import (lib/scene/import.c): OBJ+MTL, PLY, glTF (embedded, external .bin, .glb),
 * materials, winding and node transforms, and the errors for bad files. */
#include <unistd.h> /* getpid, used by testutil.h */

#include "testutil.h"

#include <stdbool.h>

/* Scene values are floats (positions, normals, areas, rho, E) from a few float
 * operations each (a cross product and its normalisation: 5 roundings), k = 2. */
#define FLOAT_TOL TU_TOL_FLT(2, 5)

#define MAX_SUB 64

typedef struct loaded {
    lrr_scene *scene;
    lrr_scene_info info;
    size_t n;
    float centre[3 * MAX_SUB], normal[3 * MAX_SUB], area[MAX_SUB];
    float rho[3 * MAX_SUB], emission[3 * MAX_SUB];
} loaded;

static void data_path(char *buf, size_t len, const char *name)
{
    snprintf(buf, len, "%s/%s", LRR_TEST_DATA, name);
}

/* Like tu_tmp_path, but keeps the extension last: assimp picks its reader by it. */
static void tmp_path(char *buf, size_t len, const char *stem, const char *ext)
{
    const char *dir = getenv("LRR_TEST_TMP");
    snprintf(buf, len, "%s/%s_%ld.%s", dir && *dir ? dir : "/tmp", stem, (long)getpid(), ext);
}

/* Loads `path`, subdivides with one patch per triangle and d = 1, and reads the subpatches
 * (which are then the input triangles). */
static void load_path(lrr_context *ctx, const char *path, loaded *l)
{
    memset(l, 0, sizeof *l);
    LRR_CHECK(ctx, lrr_scene_load(ctx, path, &l->scene));
    lrr_subdivision opts = {.max_patch_area = 0, .target_patches = 0, .levels = 0};
    LRR_CHECK(ctx, lrr_scene_subdivide(l->scene, &opts));
    lrr_scene_get_info(l->scene, &l->info, sizeof l->info);
    assert_int_equal(l->info.subpatches, l->info.triangles);
    assert_true(l->info.subpatches <= MAX_SUB);
    l->n = l->info.subpatches;
    LRR_CHECK(ctx, lrr_scene_subpatches(l->scene, l->centre, l->normal, l->area, l->rho,
                                        l->emission));
}

/* As load_path, for a scene already made. */
static void read_scene(lrr_context *ctx, lrr_scene *scene, loaded *l)
{
    memset(l, 0, sizeof *l);
    l->scene = scene;
    lrr_subdivision opts = {.max_patch_area = 0, .target_patches = 0, .levels = 0};
    LRR_CHECK(ctx, lrr_scene_subdivide(l->scene, &opts));
    lrr_scene_get_info(l->scene, &l->info, sizeof l->info);
    assert_true(l->info.subpatches <= MAX_SUB);
    l->n = l->info.subpatches;
    LRR_CHECK(ctx, lrr_scene_subpatches(l->scene, l->centre, l->normal, l->area, l->rho,
                                        l->emission));
}

static void load_data(lrr_context *ctx, const char *name, loaded *l)
{
    char path[1024];
    data_path(path, sizeof path, name);
    load_path(ctx, path, l);
}

static double total_area(const loaded *l)
{
    double a = 0;
    for (size_t i = 0; i < l->n; i++)
        a += l->area[i];
    return a;
}

static void assert_all_normals(const loaded *l, double nx, double ny, double nz)
{
    for (size_t i = 0; i < l->n; i++) {
        ASSERT_NEAR(l->normal[3 * i], nx, FLOAT_TOL, "subpatch %zu\n", i);
        ASSERT_NEAR(l->normal[3 * i + 1], ny, FLOAT_TOL, "subpatch %zu\n", i);
        ASSERT_NEAR(l->normal[3 * i + 2], nz, FLOAT_TOL, "subpatch %zu\n", i);
    }
}

static void assert_all_materials(const loaded *l, const float rho[3], const float em[3])
{
    for (size_t i = 0; i < l->n; i++)
        for (int c = 0; c < 3; c++) {
            ASSERT_NEAR(l->rho[3 * i + c], rho[c], FLOAT_TOL, "subpatch %zu channel %d\n", i, c);
            ASSERT_NEAR(l->emission[3 * i + c], em[c], FLOAT_TOL, "subpatch %zu channel %d\n", i,
                        c);
        }
}

/* The unit square z = 0, front +z, as two triangles. */
static void assert_unit_square(const loaded *l)
{
    assert_int_equal(l->info.triangles, 2);
    assert_int_equal(l->info.skipped, 0);
    ASSERT_NEAR(l->info.area, 1.0, FLOAT_TOL, "scene area\n");
    ASSERT_NEAR(total_area(l), 1.0, FLOAT_TOL, "sum of subpatch areas\n");
    for (int j = 0; j < 3; j++) {
        ASSERT_NEAR(l->info.bounds_min[j], 0.0, FLOAT_TOL, "bounds_min[%d]\n", j);
        ASSERT_NEAR(l->info.bounds_max[j], j < 2 ? 1.0 : 0.0, FLOAT_TOL, "bounds_max[%d]\n", j);
    }
    assert_all_normals(l, 0, 0, 1);
}

/* Loading fails with `want` (or, when want2 != LRR_OK, either code) and the message names
 * the file (and `also`, when given). */
static void expect_error(lrr_context *ctx, const char *path, lrr_status want,
                         lrr_status want2, const char *also)
{
    lrr_scene *s = (lrr_scene *)0x1;
    lrr_status st = lrr_scene_load(ctx, path, &s);
    char msg[512];
    lrr_status rec = lrr_context_last_error(ctx, msg, sizeof msg);
    if (!(st == want || (want2 != LRR_OK && st == want2)))
        fail_msg("%s: got %s (%s), expected %s", path, lrr_strerror(st), msg,
                 lrr_strerror(want));
    assert_null(s);
    assert_int_equal(rec, st);
    if (!strstr(msg, path))
        fail_msg("message does not name the file %s: %s", path, msg);
    if (also && !strstr(msg, also))
        fail_msg("message does not mention '%s': %s", also, msg);
}

static void expect_data_error(lrr_context *ctx, const char *name, lrr_status want,
                              lrr_status want2, const char *also)
{
    char path[1024];
    data_path(path, sizeof path, name);
    expect_error(ctx, path, want, want2, also);
}

/* ------------------------------------------------------------------ formats and materials */

static void test_obj_mtl(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    load_data(ctx, "quad.obj", &l);
    assert_unit_square(&l);
    assert_int_equal(l.info.emitters, 2);
    assert_all_materials(&l, (const float[]){0.5f, 0.6f, 0.7f}, (const float[]){1, 2, 3});
    lrr_scene_destroy(l.scene);
}

static void test_ply_default_material(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    load_data(ctx, "quad.ply", &l);
    assert_unit_square(&l);
    assert_int_equal(l.info.emitters, 0);
    /* PLY carries no material: the documented default grey, no emission */
    assert_all_materials(&l, (const float[]){0.5f, 0.5f, 0.5f}, (const float[]){0, 0, 0});
    lrr_scene_destroy(l.scene);
}

static void test_gltf_embedded(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    load_data(ctx, "quad.gltf", &l);
    assert_unit_square(&l);
    assert_int_equal(l.info.emitters, 2);
    assert_all_materials(&l, (const float[]){0.5f, 0.6f, 0.7f},
                         (const float[]){0.25f, 0.5f, 0.75f});
    lrr_scene_destroy(l.scene);
}

static void test_gltf_without_material(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    /* glTF's default material is white (rho = 1, invalid here): we use the default grey */
    load_data(ctx, "no_material.gltf", &l);
    assert_unit_square(&l);
    assert_all_materials(&l, (const float[]){0.5f, 0.5f, 0.5f}, (const float[]){0, 0, 0});
    lrr_scene_destroy(l.scene);
}

static void test_gltf_emissive_strength(void **state)
{
    lrr_context *ctx = *state;
    char path[1024];
    data_path(path, sizeof path, "quad_strength.gltf");
    /* KHR_materials_emissive_strength, read by lrr itself (assimp 5.2 drops it):
     * emission = factor × strength */
    loaded l;
    load_path(ctx, path, &l);
    assert_all_materials(&l, (const float[]){0.5f, 0.6f, 0.7f}, (const float[]){1, 2, 3});
    lrr_scene_destroy(l.scene);
}

/* The quad's buffer: 4 positions (float) then 6 indices (uint16), little-endian. */
static size_t quad_buffer(unsigned char *b)
{
    static const float pos[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    static const uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
    size_t n = 0;
    for (int i = 0; i < 12; i++) {
        uint32_t u;
        memcpy(&u, &pos[i], 4);
        for (int k = 0; k < 4; k++)
            b[n++] = (unsigned char)(u >> (8 * k));
    }
    for (int i = 0; i < 6; i++) {
        b[n++] = (unsigned char)(idx[i] & 0xff);
        b[n++] = (unsigned char)(idx[i] >> 8);
    }
    return n; /* 60 */
}

static const char *quad_json_fmt =
    "{\"asset\": {\"version\": \"2.0\"}, \"scene\": 0, \"scenes\": [{\"nodes\": [0]}],"
    " \"nodes\": [{\"mesh\": 0}],"
    " \"materials\": [{\"name\": \"lamp\", \"pbrMetallicRoughness\": {\"baseColorFactor\":"
    " [0.5, 0.6, 0.7, 1.0]}, \"emissiveFactor\": [0.25, 0.5, 0.75]}],"
    " \"meshes\": [{\"primitives\": [{\"attributes\": {\"POSITION\": 0}, \"indices\": 1,"
    " \"material\": 0}]}],"
    " \"buffers\": [{\"byteLength\": 60%s}],"
    " \"bufferViews\": [{\"buffer\": 0, \"byteOffset\": 0, \"byteLength\": 48},"
    " {\"buffer\": 0, \"byteOffset\": 48, \"byteLength\": 12}],"
    " \"accessors\": [{\"bufferView\": 0, \"componentType\": 5126, \"count\": 4, \"type\":"
    " \"VEC3\", \"min\": [0, 0, 0], \"max\": [1, 1, 0]}, {\"bufferView\": 1, \"componentType\":"
    " 5123, \"count\": 6, \"type\": \"SCALAR\"}]}";

static void write_file(const char *path, const void *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(data, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

static void test_gltf_external_bin(void **state)
{
    lrr_context *ctx = *state;
    char gltf[1024], bin[1024], uri[1100], json[4096];
    tmp_path(gltf, sizeof gltf, "import_ext", "gltf");
    tmp_path(bin, sizeof bin, "import_ext", "bin");
    unsigned char buf[64];
    size_t n = quad_buffer(buf);
    assert_int_equal(n, 60);
    write_file(bin, buf, n);
    const char *base = strrchr(bin, '/');
    snprintf(uri, sizeof uri, ", \"uri\": \"%s\"", base ? base + 1 : bin);
    int len = snprintf(json, sizeof json, quad_json_fmt, uri);
    assert_true(len > 0 && (size_t)len < sizeof json);
    write_file(gltf, json, (size_t)len);

    loaded l;
    load_path(ctx, gltf, &l);
    assert_unit_square(&l);
    assert_all_materials(&l, (const float[]){0.5f, 0.6f, 0.7f},
                         (const float[]){0.25f, 0.5f, 0.75f});
    lrr_scene_destroy(l.scene);
    remove(gltf);
    remove(bin);
}

static void put_u32(unsigned char *p, uint32_t v)
{
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)(v >> (8 * k));
}

static void test_glb(void **state)
{
    lrr_context *ctx = *state;
    char path[1024], json[4096];
    tmp_path(path, sizeof path, "import", "glb");
    int jl = snprintf(json, sizeof json, quad_json_fmt, "");
    assert_true(jl > 0 && (size_t)jl < sizeof json - 4);
    while (jl % 4)
        json[jl++] = ' '; /* chunks are 4-byte aligned, JSON padded with spaces */
    unsigned char bin[64] = {0};
    size_t bl = quad_buffer(bin); /* 60, already a multiple of 4 */
    size_t total = 12 + 8 + (size_t)jl + 8 + bl;
    unsigned char *glb = calloc(1, total);
    assert_non_null(glb);
    memcpy(glb, "glTF", 4);
    put_u32(glb + 4, 2);
    put_u32(glb + 8, (uint32_t)total);
    put_u32(glb + 12, (uint32_t)jl);
    put_u32(glb + 16, 0x4E4F534Au); /* "JSON" */
    memcpy(glb + 20, json, (size_t)jl);
    put_u32(glb + 20 + jl, (uint32_t)bl);
    put_u32(glb + 24 + jl, 0x004E4942u); /* "BIN\0" */
    memcpy(glb + 28 + jl, bin, bl);
    write_file(path, glb, total);
    free(glb);

    loaded l;
    load_path(ctx, path, &l);
    assert_unit_square(&l);
    assert_all_materials(&l, (const float[]){0.5f, 0.6f, 0.7f},
                         (const float[]){0.25f, 0.5f, 0.75f});
    lrr_scene_destroy(l.scene);
    remove(path);
}

/* ------------------------------------------------------------------ orientation */

static void test_ccw_front(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    load_data(ctx, "ccw_triangle.obj", &l);
    assert_int_equal(l.info.triangles, 1);
    ASSERT_NEAR(l.area[0], 2.0, FLOAT_TOL, "triangle area\n");
    assert_all_normals(&l, 0, 0, 1);
    /* no usemtl: assimp's stand-in "DefaultMaterial" (diffuse 0.6) becomes the default grey */
    assert_all_materials(&l, (const float[]){0.5f, 0.5f, 0.5f}, (const float[]){0, 0, 0});
    lrr_scene_destroy(l.scene);
}

static void test_concave_polygon(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    /* a fan from the first vertex would fold a triangle over; ear clipping does not */
    load_data(ctx, "concave.obj", &l);
    assert_int_equal(l.info.triangles, 4); /* the line and the point are ignored */
    assert_int_equal(l.info.skipped, 0);
    ASSERT_NEAR(total_area(&l), 3.0, FLOAT_TOL, "L-shape area\n");
    assert_all_normals(&l, 0, 0, 1);
    for (size_t i = 0; i < l.n; i++) /* no triangle covers the missing corner (1..2, 1..2) */
        assert_false(l.centre[3 * i] > 1.0f && l.centre[3 * i + 1] > 1.0f);
    lrr_scene_destroy(l.scene);
}

static void test_node_transforms(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    /* node 0: translate z+5 with a child scaled x by -1 (a mirror); node 2: rotated 180°
     * about x and moved to z = -5 */
    load_data(ctx, "mirror.gltf", &l);
    assert_int_equal(l.info.triangles, 4);
    ASSERT_NEAR(total_area(&l), 2.0, FLOAT_TOL, "area\n");
    ASSERT_NEAR(l.info.bounds_min[0], -1.0, FLOAT_TOL, "mirrored x\n");
    ASSERT_NEAR(l.info.bounds_max[0], 1.0, FLOAT_TOL, "x\n");
    ASSERT_NEAR(l.info.bounds_min[1], -1.0, FLOAT_TOL, "rotated y\n");
    ASSERT_NEAR(l.info.bounds_min[2], -5.0, FLOAT_TOL, "z\n");
    ASSERT_NEAR(l.info.bounds_max[2], 5.0, FLOAT_TOL, "z\n");
    size_t top = 0, bottom = 0;
    for (size_t i = 0; i < l.n; i++) {
        const float *c = l.centre + 3 * i, *nm = l.normal + 3 * i;
        if (c[2] > 0) {
            /* mirrored: the front stays +z (the geometric front of the transformed file),
             * not the -z that the stored order would give after the mirror */
            top++;
            assert_true(c[0] < 0);
            ASSERT_NEAR(nm[2], 1.0, FLOAT_TOL, "mirrored subpatch %zu\n", i);
        } else {
            bottom++;
            assert_true(c[1] < 0);
            ASSERT_NEAR(nm[2], -1.0, FLOAT_TOL, "rotated subpatch %zu\n", i);
        }
        ASSERT_NEAR(l.rho[3 * i], 0.3, FLOAT_TOL, "rho\n");
    }
    assert_int_equal(top, 2);
    assert_int_equal(bottom, 2);
    lrr_scene_destroy(l.scene);
}

/* ------------------------------------------------------------------ degenerate input */

static void test_zero_area_skipped(void **state)
{
    lrr_context *ctx = *state;
    loaded l;
    load_data(ctx, "degenerate.obj", &l);
    assert_int_equal(l.info.triangles, 1);
    assert_int_equal(l.info.skipped, 1);
    ASSERT_NEAR(l.info.area, 0.5, FLOAT_TOL, "area of the good triangle\n");
    lrr_scene_destroy(l.scene);
}

static void test_only_zero_area(void **state)
{
    lrr_context *ctx = *state;
    expect_data_error(ctx, "all_degenerate.obj", LRR_ERR_GEOMETRY, LRR_ERR_EMPTY, NULL);
}

static void test_nan_vertex(void **state)
{
    lrr_context *ctx = *state;
    /* assimp passes "nan" through; the scene names the face (0-based f line) */
    expect_data_error(ctx, "nan_vertex.obj", LRR_ERR_GEOMETRY, LRR_ERR_FORMAT, "face 1");
}

static void test_bad_materials(void **state)
{
    lrr_context *ctx = *state;
    expect_data_error(ctx, "bad_kd.obj", LRR_ERR_MATERIAL, LRR_OK, "face 0");
    expect_data_error(ctx, "bad_ke.obj", LRR_ERR_MATERIAL, LRR_OK, "emission");
}

/* ------------------------------------------------------------------ unreadable files */

static void test_empty_and_garbage(void **state)
{
    lrr_context *ctx = *state;
    expect_data_error(ctx, "empty.obj", LRR_ERR_EMPTY, LRR_ERR_FORMAT, NULL);
    /* assimp's OBJ reader skips lines it does not know: junk reads as an empty scene */
    expect_data_error(ctx, "garbage.obj", LRR_ERR_EMPTY, LRR_ERR_FORMAT, NULL);
    expect_data_error(ctx, "garbage.glb", LRR_ERR_FORMAT, LRR_OK, NULL);
    expect_data_error(ctx, "truncated.gltf", LRR_ERR_FORMAT, LRR_OK, NULL);
    expect_data_error(ctx, "missing_bin.gltf", LRR_ERR_FORMAT, LRR_OK, "no_such_buffer.bin");
}

/* Writes a PLY file: header text, then size bytes of body. */
static void write_ply(const char *path, const char *header, const void *body, size_t size)
{
    FILE *f = fopen(path, "wb");
    assert_non_null(f);
    fputs(header, f);
    fwrite(body, 1, size, f);
    fclose(f);
}

#define PLY_TRIANGLE_HEADER(format, count_type)                                              \
    "ply\nformat " format " 1.0\ncomment one triangle\nelement vertex 3\n"                    \
    "property float x\nproperty float y\nproperty float z\nelement face 1\n"                  \
    "property list " count_type " int vertex_indices\nend_header\n"

/* PLY files are checked before assimp reads them (lib/scene/ply.c): a standard header, and
 * a body holding what it declares. A list count larger than the file made assimp 5.2
 * allocate that many items first (14.6 GB for an 830-byte file found by the fuzzer). */
static void test_ply_checked(void **state)
{
    lrr_context *ctx = *state;
    char path[1024];
    tmp_path(path, sizeof path, "ply_check", "ply");
    /* binary, both byte orders: one triangle */
    const float v_le[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
    unsigned char body[64];
    memcpy(body, v_le, sizeof v_le);
    const uint32_t n3 = 3, idx[3] = {0, 1, 2};
    memcpy(body + 36, &n3, 4);
    memcpy(body + 40, idx, 12);
    write_ply(path, PLY_TRIANGLE_HEADER("binary_little_endian", "uint"), body, 52);
    loaded l;
    load_path(ctx, path, &l);
    assert_int_equal(l.n, 1);
    ASSERT_NEAR(l.area[0], 0.5, FLOAT_TOL, "little-endian triangle area");
    lrr_scene_destroy(l.scene);
    unsigned char be[52];
    for (size_t i = 0; i < 52; i += 4)
        for (int b = 0; b < 4; b++)
            be[i + b] = body[i + 3 - b];
    write_ply(path, PLY_TRIANGLE_HEADER("binary_big_endian", "uint"), be, 52);
    load_path(ctx, path, &l);
    assert_int_equal(l.n, 1);
    ASSERT_NEAR(l.area[0], 0.5, FLOAT_TOL, "big-endian triangle area");
    lrr_scene_destroy(l.scene);
    /* a list count of 4 billion in a 52-byte body; and one item short */
    const uint32_t huge = 0xfffffff0u;
    memcpy(body + 36, &huge, 4);
    write_ply(path, PLY_TRIANGLE_HEADER("binary_little_endian", "uint"), body, 52);
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "face 0 of 1: a list longer than the rest");
    memcpy(body + 36, &n3, 4);
    write_ply(path, PLY_TRIANGLE_HEADER("binary_little_endian", "uint"), body, 48);
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "a list longer than the rest");
    write_ply(path, PLY_TRIANGLE_HEADER("binary_little_endian", "uint"), body, 30);
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "vertex 0 of 3: the elements need more");
    /* ASCII: the same triangle, then a huge list count and a huge element count */
    const char *tri = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    write_ply(path, PLY_TRIANGLE_HEADER("ascii", "uchar"), tri, strlen(tri));
    load_path(ctx, path, &l);
    assert_int_equal(l.n, 1);
    lrr_scene_destroy(l.scene);
    const char *huge_list = "0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n";
    write_ply(path, PLY_TRIANGLE_HEADER("ascii", "uint"), huge_list, strlen(huge_list));
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "face 0 of 1: a list count");
    write_ply(path,
              "ply\nformat ascii 1.0\nelement vertex 4000000000\nproperty float x\n"
              "property float y\nproperty float z\nend_header\n",
              tri, strlen(tri));
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "vertex 4 of 4000000000: the file ends");
    /* header lines outside the specification, named by number */
    write_ply(path, "ply\nformat binary_little_endianx 1.0\nend_header\n", "", 0);
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "line 2");
    write_ply(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float\nend_header\n",
              "0\n", 2);
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "line 4: expected 'property TYPE NAME'");
    write_ply(path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "", 0);
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "without an end_header");
    write_ply(path, "ply\nformat ascii 1.0\nelement vertex 5\nend_header\n", "", 0);
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "no properties");
    /* a second element of one name (assimp merged it into the first and corrupted its heap:
     * the scene fuzzer under ASan); names that only share a prefix are fine */
    const char *twice = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n";
    write_ply(path,
              "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
              "property float z\nelement vertex 1\nproperty float x\nproperty float y\n"
              "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
              "end_header\n",
              twice, strlen(twice));
    expect_error(ctx, path, LRR_ERR_FORMAT, LRR_OK, "line 7: an element name declared twice");
    /* two extra elements whose long names share their first 38 characters (the check keeps
     * 31 of them and a hash of the whole) */
    unsigned char extra[9 * 4 + 1 + 3 * 4 + 2 * 4] = {0};
    const float xyz[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, w[2] = {5, 6};
    const int32_t tri_idx[3] = {0, 1, 2};
    memcpy(extra, xyz, sizeof xyz);
    extra[36] = 3;
    memcpy(extra + 37, tri_idx, sizeof tri_idx);
    memcpy(extra + 49, w, sizeof w);
    write_ply(path,
              "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
              "property float y\nproperty float z\nelement face 1\n"
              "property list uchar int vertex_indices\n"
              "element extra_element_with_a_long_name_number_1 1\nproperty float w\n"
              "element extra_element_with_a_long_name_number_2 1\nproperty float w\n"
              "end_header\n",
              (const char *)extra, sizeof extra);
    load_path(ctx, path, &l);
    assert_int_equal(l.n, 1);
    lrr_scene_destroy(l.scene);
    unlink(path);
}

static void test_missing_file(void **state)
{
    lrr_context *ctx = *state;
    expect_data_error(ctx, "no_such_scene.obj", LRR_ERR_IO, LRR_OK, "No such file");
    expect_error(ctx, LRR_TEST_DATA, LRR_ERR_IO, LRR_OK, "directory");
}

typedef struct cb_record {
    int calls;
    lrr_status status;
    char message[512];
} cb_record;

static void record_error(void *user, lrr_status status, const char *message)
{
    cb_record *r = user;
    r->calls++;
    r->status = status;
    snprintf(r->message, sizeof r->message, "%s", message);
}

/* Each failed load reports exactly one error (no cascade of follow-up messages). */
static void test_error_reported_once(void **state)
{
    lrr_context *ctx = *state;
    cb_record rec = {0};
    lrr_context_set_error_callback(ctx, record_error, &rec);
    char path[1024];
    data_path(path, sizeof path, "bad_kd.obj");
    lrr_scene *s = NULL;
    assert_int_equal(lrr_scene_load(ctx, path, &s), LRR_ERR_MATERIAL);
    assert_int_equal(rec.calls, 1);
    assert_int_equal(rec.status, LRR_ERR_MATERIAL);
    assert_non_null(strstr(rec.message, path));
    data_path(path, sizeof path, "garbage.glb");
    assert_int_equal(lrr_scene_load(ctx, path, &s), LRR_ERR_FORMAT);
    assert_int_equal(rec.calls, 2);
    lrr_context_set_error_callback(ctx, NULL, NULL);
    /* the first error is kept until read, then cleared */
    assert_int_equal(lrr_context_last_error(ctx, NULL, 0), LRR_ERR_MATERIAL);
    assert_int_equal(lrr_context_last_error(ctx, NULL, 0), LRR_OK);
}

static int setup(void **state)
{
    lrr_context *ctx = NULL;
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

/* data/cornell-box.obj, shipped for users, holds the same triangles and materials as the
 * built-in `cornell` (assimp may regroup faces by material, so match them by centre). */
static void test_shipped_cornell_matches_builtin(void **state)
{
    lrr_context *ctx = *state;
    static loaded file, builtin;
    load_path(ctx, LRR_DATA_DIR "/cornell-box.obj", &file);
    lrr_scene *s = NULL;
    LRR_CHECK(ctx, lrr_scene_cornell_box(ctx, 0, &s));
    read_scene(ctx, s, &builtin);
    assert_int_equal(file.n, 36);
    assert_int_equal(builtin.n, 36);
    for (size_t i = 0; i < builtin.n; i++) {
        size_t hits = 0;
        for (size_t j = 0; j < file.n; j++) {
            double d2 = 0;
            for (int c = 0; c < 3; c++) {
                double dc = builtin.centre[3 * i + c] - file.centre[3 * j + c];
                d2 += dc * dc;
            }
            if (d2 > 1e-6)
                continue;
            hits++;
            ASSERT_NEAR(file.area[j], builtin.area[i], 1e-3, "triangle %zu area\n", i);
            for (int c = 0; c < 3; c++) {
                ASSERT_NEAR(file.normal[3 * j + c], builtin.normal[3 * i + c], FLOAT_TOL,
                            "triangle %zu normal\n", i);
                ASSERT_NEAR(file.rho[3 * j + c], builtin.rho[3 * i + c], FLOAT_TOL,
                            "triangle %zu reflectance\n", i);
                ASSERT_NEAR(file.emission[3 * j + c], builtin.emission[3 * i + c], FLOAT_TOL,
                            "triangle %zu emission\n", i);
            }
        }
        if (hits != 1)
            fail_msg("built-in triangle %zu has %zu matches in cornell-box.obj", i, hits);
    }
    lrr_scene_destroy(builtin.scene);
    lrr_scene_destroy(file.scene);
}

int main(void)
{
    TU_REQUIRE_PROGRAM("test_import", "assimp");
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_obj_mtl, setup, teardown),
        cmocka_unit_test_setup_teardown(test_ply_default_material, setup, teardown),
        cmocka_unit_test_setup_teardown(test_ply_checked, setup, teardown),
        cmocka_unit_test_setup_teardown(test_gltf_embedded, setup, teardown),
        cmocka_unit_test_setup_teardown(test_gltf_without_material, setup, teardown),
        cmocka_unit_test_setup_teardown(test_gltf_emissive_strength, setup, teardown),
        cmocka_unit_test_setup_teardown(test_gltf_external_bin, setup, teardown),
        cmocka_unit_test_setup_teardown(test_glb, setup, teardown),
        cmocka_unit_test_setup_teardown(test_ccw_front, setup, teardown),
        cmocka_unit_test_setup_teardown(test_concave_polygon, setup, teardown),
        cmocka_unit_test_setup_teardown(test_node_transforms, setup, teardown),
        cmocka_unit_test_setup_teardown(test_zero_area_skipped, setup, teardown),
        cmocka_unit_test_setup_teardown(test_only_zero_area, setup, teardown),
        cmocka_unit_test_setup_teardown(test_nan_vertex, setup, teardown),
        cmocka_unit_test_setup_teardown(test_bad_materials, setup, teardown),
        cmocka_unit_test_setup_teardown(test_empty_and_garbage, setup, teardown),
        cmocka_unit_test_setup_teardown(test_missing_file, setup, teardown),
        cmocka_unit_test_setup_teardown(test_error_reported_once, setup, teardown),
        cmocka_unit_test_setup_teardown(test_shipped_cornell_matches_builtin, setup, teardown),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
