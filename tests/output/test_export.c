/* lrr_export_gltf and lrr_export_ply: the files are read back (the .glb's header, JSON and
 * BIN chunks with a purpose-made reader; the PLY's header and body) and their vertices,
 * indices, colours and materials checked against a furnace, whose radiosity e/(1 − rho) is
 * known everywhere; material edges split vertices; bad input and failed writes. */
#include "output/render_util.h"

#include <errno.h>

/* The mesh's colours, radiosities and exposures are floats computed from float B with a
 * few operations (5 roundings, k = 2); rho is one float printed and read back (1). */
#define FLOAT_TOL TU_TOL_FLT(2, 5)

/* ------------------------------------------------------------------ helpers */

/* The furnace of tests/testutil.h (a closed box, rho and e on every face) as an operator
 * made by hand (no form factors needed), with its exact radiosity B = e/(1 − rho). */
static const float FURNACE_RHO[3] = {0.5f, 0.4f, 0.25f};
static const float FURNACE_E = 0.2f;

static lrr_operator *furnace_op(lrr_context *ctx, float v[108], float **B)
{
    tu_box_inward(v, 2, 1, 1.5);
    lrr_operator *op = ru_make_op(ctx, 12, v, 1, LRR__SCENE_FILE);
    *B = ru_uniform(op->n, 0, 0, 0);
    for (size_t i = 0; i < op->n; i++)
        for (int c = 0; c < 3; c++) {
            op->rho[3 * i + c] = FURNACE_RHO[c];
            op->emission[3 * i + c] = FURNACE_E;
            (*B)[3 * i + c] = FURNACE_E / (1 - FURNACE_RHO[c]);
        }
    return op;
}

static unsigned char *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        fail_msg("%s: %s", path, strerror(errno));
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *d = malloc((size_t)n + 1);
    assert_non_null(d);
    assert_int_equal(fread(d, 1, (size_t)n, f), (size_t)n);
    fclose(f);
    d[n] = 0;
    *len = (size_t)n;
    return d;
}

static uint32_t le32(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static float lef32(const unsigned char *p)
{
    uint32_t u = le32(p);
    float f;
    memcpy(&f, &u, 4);
    return f;
}

/* A purpose-made JSON reader: enough to walk the arrays of objects of a glTF document. */

/* The end of the value starting at p (an object, array, string or scalar). */
static const char *json_skip(const char *p)
{
    if (*p == '"') {
        for (p++; *p && *p != '"'; p++)
            if (*p == '\\')
                p++;
        return p + 1;
    }
    if (*p != '{' && *p != '[') {
        while (*p && *p != ',' && *p != '}' && *p != ']')
            p++;
        return p;
    }
    int depth = 0;
    do {
        if (*p == '"')
            p = json_skip(p) - 1;
        else if (*p == '{' || *p == '[')
            depth++;
        else if (*p == '}' || *p == ']')
            depth--;
        p++;
    } while (depth > 0 && *p);
    return p;
}

/* The value of key in the object at obj (which starts with '{'), or NULL. */
static const char *json_get(const char *obj, const char *key)
{
    size_t kl = strlen(key);
    const char *p = obj + 1;
    while (*p == '"') {
        const char *k = p + 1, *v = json_skip(p) + 1; /* past the ':' */
        if ((size_t)(v - 2 - k) == kl && strncmp(k, key, kl) == 0)
            return v;
        p = json_skip(v);
        if (*p == ',')
            p++;
    }
    return NULL;
}

/* Element i of the array at arr, or NULL. */
static const char *json_at(const char *arr, size_t i)
{
    const char *p = arr + 1;
    for (size_t k = 0; *p && *p != ']'; k++) {
        if (k == i)
            return p;
        p = json_skip(p);
        if (*p == ',')
            p++;
    }
    return NULL;
}

static size_t json_len(const char *arr)
{
    size_t n = 0;
    while (json_at(arr, n))
        n++;
    return n;
}

static double json_num(const char *obj, const char *key)
{
    const char *v = json_get(obj, key);
    if (!v)
        fail_msg("no key %s", key);
    return strtod(v, NULL);
}

/* A .glb read back: the JSON (NUL-terminated) and the BIN chunk. */
typedef struct glb {
    unsigned char *data;
    char *json;
    const unsigned char *bin;
    size_t bin_len;
} glb;

static void glb_read(const char *path, glb *g)
{
    size_t len;
    g->data = read_all(path, &len);
    const unsigned char *d = g->data;
    assert_true(len >= 28);
    assert_int_equal(le32(d), 0x46546C67u); /* "glTF" */
    assert_int_equal(le32(d + 4), 2);
    assert_int_equal(le32(d + 8), len);
    uint32_t jl = le32(d + 12);
    assert_int_equal(le32(d + 16), 0x4E4F534Au); /* "JSON" */
    assert_int_equal(jl % 4, 0);
    assert_true(20 + (size_t)jl + 8 <= len);
    g->json = malloc(jl + 1);
    assert_non_null(g->json);
    memcpy(g->json, d + 20, jl);
    g->json[jl] = 0;
    g->bin_len = le32(d + 20 + jl);
    assert_int_equal(le32(d + 24 + jl), 0x004E4942u); /* "BIN\0" */
    assert_int_equal(28 + (size_t)jl + g->bin_len, len);
    g->bin = d + 28 + jl;
}

/* Accessor a's data in the BIN chunk, checked against its buffer view; *count elements. */
static const unsigned char *glb_accessor(const glb *g, size_t a, size_t *count)
{
    const char *acc = json_at(json_get(g->json, "accessors"), a);
    assert_non_null(acc);
    const char *view = json_at(json_get(g->json, "bufferViews"), (size_t)json_num(acc, "bufferView"));
    assert_non_null(view);
    size_t off = (size_t)json_num(view, "byteOffset"), vlen = (size_t)json_num(view, "byteLength");
    size_t aoff = json_get(acc, "byteOffset") ? (size_t)json_num(acc, "byteOffset") : 0;
    assert_true(off + vlen <= g->bin_len);
    *count = (size_t)json_num(acc, "count");
    assert_true(*count > 0);
    const char *type = json_get(acc, "type");
    size_t comps = strncmp(type, "\"VEC4\"", 6) == 0 ? 4 : strncmp(type, "\"VEC3\"", 6) == 0 ? 3 : 1;
    assert_true(aoff + 4 * comps * *count <= vlen);
    return g->bin + off + aoff;
}

static void glb_free(glb *g)
{
    free(g->data);
    free(g->json);
}

/* The mesh of a .glb: vertices, their positions (POSITION), colours (COLOR_0) and radiosity
 * (_RADIOSITY); all triangles' indices in primitive order, and each triangle's material. */
typedef struct mesh {
    size_t nv, nt, nm;
    const unsigned char *pos, *col, *rad;
    uint32_t *index, *mat;
} mesh;

static void glb_mesh(const glb *g, mesh *m)
{
    const char *prims = json_get(json_at(json_get(g->json, "meshes"), 0), "primitives");
    size_t np = json_len(prims), n;
    const char *attr = json_get(json_at(prims, 0), "attributes");
    m->pos = glb_accessor(g, (size_t)json_num(attr, "POSITION"), &m->nv);
    m->col = glb_accessor(g, (size_t)json_num(attr, "COLOR_0"), &n);
    assert_int_equal(n, m->nv);
    m->rad = glb_accessor(g, (size_t)json_num(attr, "_RADIOSITY"), &n);
    assert_int_equal(n, m->nv);
    m->nm = json_len(json_get(g->json, "materials"));
    m->index = calloc(g->bin_len, 1);
    m->mat = calloc(g->bin_len, 1);
    m->nt = 0;
    for (size_t p = 0; p < np; p++) {
        const char *prim = json_at(prims, p);
        assert_int_equal((int)json_num(prim, "mode"), 4);
        size_t ni;
        const unsigned char *ix = glb_accessor(g, (size_t)json_num(prim, "indices"), &ni);
        assert_int_equal(ni % 3, 0);
        for (size_t i = 0; i < ni; i++) {
            m->index[3 * m->nt + i] = le32(ix + 4 * i);
            if (m->index[3 * m->nt + i] >= m->nv)
                fail_msg("index %zu of primitive %zu is %u >= %zu vertices", i, p,
                         m->index[3 * m->nt + i], m->nv);
        }
        for (size_t t = 0; t < ni / 3; t++)
            m->mat[m->nt + t] = (uint32_t)json_num(prim, "material");
        m->nt += ni / 3;
    }
}

static void mesh_free(mesh *m)
{
    free(m->index);
    free(m->mat);
}

/* ------------------------------------------------------------------ tests */

/* The furnace's input triangles: positions are the input vertices, triangle by triangle;
 * every colour is B = e/(1 − rho) (alpha 1), the unclamped _RADIOSITY too; the box's 8
 * corners give 24 vertices (3 walls meet at each, split at the creases); one material,
 * unlit and white, with rho and e in its extras. */
static void test_gltf_furnace(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108], *B;
    lrr_operator *op = furnace_op(ctx, v, &B);
    char path[512];
    tu_tmp_path(path, sizeof path, "export-furnace.glb");
    lrr_export_options o = lrr_export_options_defaults();
    LRR_CHECK(ctx, lrr_export_gltf(op, B, &o, path));
    glb g;
    glb_read(path, &g);
    mesh m;
    glb_mesh(&g, &m);
    assert_int_equal(m.nv, 24);
    assert_int_equal(m.nt, 12);
    assert_int_equal(m.nm, 1);
    for (size_t t = 0; t < 12; t++) /* one material: the input order stays */
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < 3; j++)
                assert_true(lef32(m.pos + 12 * m.index[3 * t + k] + 4 * j) == v[9 * t + 3 * k + j]);
    for (size_t i = 0; i < m.nv; i++) {
        for (int c = 0; c < 3; c++) {
            double b = FURNACE_E / (1 - FURNACE_RHO[c]);
            ASSERT_NEAR(lef32(m.col + 16 * i + 4 * c), b, FLOAT_TOL, "vertex %zu colour %d", i, c);
            ASSERT_NEAR(lef32(m.rad + 12 * i + 4 * c), b, FLOAT_TOL, "vertex %zu radiosity", i);
        }
        assert_true(lef32(m.col + 16 * i + 12) == 1.0f);
    }
    const char *mat = json_at(json_get(g.json, "materials"), 0);
    const char *rho = json_get(mat, "extras");
    rho = json_get(rho, "reflectance");
    for (int c = 0; c < 3; c++)
        ASSERT_NEAR(strtod(json_at(rho, (size_t)c), NULL), FURNACE_RHO[c], TU_TOL_FLT(1, 1), "rho");
    const char *base = json_get(json_get(mat, "pbrMetallicRoughness"), "baseColorFactor");
    for (int c = 0; c < 4; c++)
        assert_true(strtod(json_at(base, (size_t)c), NULL) == 1.0);
    assert_non_null(strstr(g.json, "KHR_materials_unlit"));
    mesh_free(&m);
    glb_free(&g);
    remove(path);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The subpatch mesh and the exposure: 4 subpatches per triangle, welded to the box's
 * surface grid; the colour is min(1, B × exposure), _RADIOSITY stays B. */
static void test_gltf_subpatches_exposure(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108], *B;
    lrr_operator *op = furnace_op(ctx, v, &B);
    char path[512];
    tu_tmp_path(path, sizeof path, "export-subpatches.glb");
    lrr_export_options o = lrr_export_options_defaults();
    o.subpatches = 1;
    o.exposure = 3;
    LRR_CHECK(ctx, lrr_export_gltf(op, B, &o, path));
    glb g;
    glb_read(path, &g);
    mesh m;
    glb_mesh(&g, &m);
    assert_int_equal(m.nt, op->n);
    /* per face a 3×3 grid of vertices (its two triangles' midpoints and corners) */
    assert_int_equal(m.nv, 6 * 9);
    for (size_t i = 0; i < m.nv; i++)
        for (int c = 0; c < 3; c++) {
            double b = FURNACE_E / (1 - FURNACE_RHO[c]);
            ASSERT_NEAR(lef32(m.col + 16 * i + 4 * c), fmin(1, 3 * b), FLOAT_TOL, "colour");
            ASSERT_NEAR(lef32(m.rad + 12 * i + 4 * c), b, FLOAT_TOL, "radiosity");
        }
    mesh_free(&m);
    glb_free(&g);
    remove(path);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* A flat quad of two triangles: with one material its diagonal's vertices are shared (4)
 * and average the two sides' radiosity; with two materials they split (6) and each
 * triangle's vertices carry its own. */
static void test_material_edge(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[18];
    double p0[3] = {0, 0, 0}, p1[3] = {1, 0, 0}, p2[3] = {1, 1, 0}, p3[3] = {0, 1, 0};
    tu_quad(v, p0, p1, p2, p3);
    lrr_operator *op = ru_make_op(ctx, 2, v, 1, LRR__SCENE_FILE);
    float *B = ru_uniform(op->n, 0, 0, 0);
    for (size_t j = 0; j < op->n; j++) {
        size_t i = lrr__subpatch_id(&op->geom, j);
        int second = j >= op->geom.sub0[1];
        for (int c = 0; c < 3; c++) {
            B[3 * i + c] = second ? 0.8f : 0.2f;
            op->rho[3 * i + c] = 0.5f;
        }
    }
    char path[512];
    tu_tmp_path(path, sizeof path, "export-edge.glb");
    for (int two = 0; two <= 1; two++) {
        for (size_t j = op->geom.sub0[1]; j < op->n; j++)
            op->rho[3 * lrr__subpatch_id(&op->geom, j)] = two ? 0.7f : 0.5f;
        LRR_CHECK(ctx, lrr_export_gltf(op, B, NULL, path));
        glb g;
        glb_read(path, &g);
        mesh m;
        glb_mesh(&g, &m);
        assert_int_equal(m.nm, two ? 2 : 1);
        assert_int_equal(m.nv, two ? 6 : 4);
        for (size_t t = 0; t < 2; t++)
            for (int k = 0; k < 3; k++) {
                uint32_t vi = m.index[3 * t + k];
                float x = lef32(m.pos + 12 * vi), y = lef32(m.pos + 12 * vi + 4);
                int diagonal = x == y; /* (0,0) and (1,1) */
                /* material order: rho 0.5 first, so t = 0 is the first input triangle */
                double own = t == 0 ? 0.2 : 0.8, want = two || !diagonal ? own : 0.5;
                ASSERT_NEAR(lef32(m.col + 16 * vi), want, FLOAT_TOL, "triangle %zu corner %d", t,
                            k);
            }
        mesh_free(&m);
        glb_free(&g);
    }
    remove(path);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* PLY: a well-formed header with the counts, a body of exactly that size, the furnace's
 * colours (sRGB codes and float radiosity) and faces with valid indices. */
static void test_ply_furnace(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108], *B;
    lrr_operator *op = furnace_op(ctx, v, &B);
    char path[512];
    tu_tmp_path(path, sizeof path, "export-furnace.ply");
    LRR_CHECK(ctx, lrr_export_ply(op, B, NULL, path));
    size_t len;
    unsigned char *d = read_all(path, &len);
    assert_memory_equal(d, "ply\nformat binary_little_endian 1.0\n", 36);
    const char *end = strstr((const char *)d, "end_header\n");
    assert_non_null(end);
    size_t nv = 0, nt = 0;
    const char *ev = strstr((const char *)d, "element vertex "), *ef = strstr((const char *)d, "element face ");
    assert_true(ev && ef && ev < ef && ef < end);
    nv = strtoul(ev + 15, NULL, 10);
    nt = strtoul(ef + 13, NULL, 10);
    assert_int_equal(nv, 24);
    assert_int_equal(nt, 12);
    assert_non_null(strstr((const char *)d, "property uchar red\n"));
    assert_non_null(strstr((const char *)d, "property list uchar uint vertex_indices\n"));
    const unsigned char *body = (const unsigned char *)end + 11;
    assert_int_equal(len - (size_t)(body - d), nv * 39 + nt * 17);
    for (size_t i = 0; i < nv; i++) {
        const unsigned char *p = body + 39 * i;
        for (int c = 0; c < 3; c++) {
            double b = FURNACE_E / (1 - FURNACE_RHO[c]);
            double s = b <= 0.0031308 ? 12.92 * b : 1.055 * pow(b, 1 / 2.4) - 0.055;
            assert_int_equal(p[24 + c], (int)lround(255 * s));
            ASSERT_NEAR(lef32(p + 27 + 4 * c), b, FLOAT_TOL, "vertex %zu radiosity", i);
        }
    }
    for (size_t t = 0; t < nt; t++) {
        const unsigned char *f = body + 39 * nv + 17 * t;
        assert_int_equal(f[0], 3);
        for (int k = 0; k < 3; k++)
            assert_true(le32(f + 1 + 4 * k) < nv);
        assert_int_equal(le32(f + 13), 0);
    }
    free(d);
    remove(path);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Bad input: NaN and negative radiosity are refused naming the subpatch, bad options named,
 * and nothing is written. */
static void test_bad_input(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108], *B;
    lrr_operator *op = furnace_op(ctx, v, &B);
    char path[512], msg[512];
    tu_tmp_path(path, sizeof path, "export-bad.glb");
    remove(path);
    B[3 * 7 + 1] = NAN;
    assert_int_equal(lrr_export_gltf(op, B, NULL, path), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "subpatch 7"));
    B[3 * 7 + 1] = -0.5f;
    assert_int_equal(lrr_export_ply(op, B, NULL, path), LRR_ERR_INVALID_ARG);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, "subpatch 7"));
    B[3 * 7 + 1] = 0.5f;
    lrr_export_options o = lrr_export_options_defaults();
    o.exposure = -1;
    assert_int_equal(lrr_export_gltf(op, B, &o, path), LRR_ERR_INVALID_ARG);
    o = lrr_export_options_defaults();
    o.subpatches = 2;
    assert_int_equal(lrr_export_gltf(op, B, &o, path), LRR_ERR_INVALID_ARG);
    o = lrr_export_options_defaults();
    o.size = 3; /* shorter than any layout */
    assert_int_equal(lrr_export_gltf(op, B, &o, path), LRR_ERR_INVALID_ARG);
    assert_false(ru_file_exists(path));
    /* size 0 = the first layout: accepted */
    o = (lrr_export_options){0};
    o.exposure = 1;
    lrr_export_info info;
    LRR_CHECK(ctx, lrr_export_get_info(op, B, &o, path, &info, sizeof info));
    assert_int_equal(info.vertices, 24);
    assert_int_equal(info.triangles, 12);
    assert_int_equal(info.materials, 1);
    assert_false(ru_file_exists(path));
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* The automatic exposure: in the furnace every subpatch emits, so the mean over all of them,
 * B = e/(1 − ρ) per channel, maps to 0.18; the export's "auto" resolves to the same value,
 * and with one subpatch no longer emitting the key is that subpatch alone. */
static void test_auto_exposure(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108], *B;
    lrr_operator *op = furnace_op(ctx, v, &B);
    double lum = 0;
    const double w[3] = {0.2126, 0.7152, 0.0722};
    for (int c = 0; c < 3; c++)
        lum += w[c] * FURNACE_E / (1 - FURNACE_RHO[c]);
    ASSERT_NEAR(lrr_render_auto_exposure(op, B), 0.18 / lum, 1e-6 * 0.18 / lum, "furnace");
    lrr_export_options o = lrr_export_options_defaults();
    o.exposure = 0;
    lrr_export_info info;
    char path[512];
    tu_tmp_path(path, sizeof path, "export-auto.glb");
    LRR_CHECK(ctx, lrr_export_get_info(op, B, &o, path, &info, sizeof info));
    assert_true(info.exposure == lrr_render_auto_exposure(op, B));
    op->emission[0] = op->emission[1] = op->emission[2] = 0; /* subpatch 0 is lit only */
    B[0] = B[1] = B[2] = 2.0f;
    ASSERT_NEAR(lrr_render_auto_exposure(op, B), 0.09, FLOAT_TOL, "one non-emitter");
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

/* Failed writes: an unwritable path is LRR_ERR_IO naming it; a fault at any step of the
 * atomic writer leaves neither the file nor a temporary one. */
typedef struct export_fault {
    unsigned long at, steps;
} export_fault;

static int export_inject(void *user, unsigned long step, const char *what)
{
    (void)what;
    export_fault *f = user;
    f->steps = step;
    return step == f->at ? ENOSPC : 0;
}

static void test_write_failures(void **state)
{
    (void)state;
    lrr_context *ctx = tu_context();
    float v[108], *B;
    lrr_operator *op = furnace_op(ctx, v, &B);
    char path[640], msg[768], prefix[256];
    snprintf(path, sizeof path, "%s/no-such-dir-%ld/x.glb", ru_tmp_dir(), (long)getpid());
    assert_int_equal(lrr_export_gltf(op, B, NULL, path), LRR_ERR_IO);
    lrr_context_last_error(ctx, msg, sizeof msg);
    assert_non_null(strstr(msg, path));
    tu_tmp_path(path, sizeof path, "export-faults.glb");
    remove(path);
    snprintf(prefix, sizeof prefix, "%s.tmp.", strrchr(path, '/') + 1);
    export_fault f = {0};
    lrr__context_set_io_hook(ctx, export_inject, &f);
    LRR_CHECK(ctx, lrr_export_gltf(op, B, NULL, path));
    unsigned long steps = f.steps;
    assert_true(steps >= 3);
    remove(path);
    for (unsigned long at = 1; at < steps; at++) {
        f = (export_fault){.at = at};
        lrr__context_set_io_hook(ctx, export_inject, &f);
        lrr_status st = at % 2 ? lrr_export_gltf(op, B, NULL, path)
                               : lrr_export_ply(op, B, NULL, path);
        assert_int_equal(st, LRR_ERR_IO);
        lrr_context_last_error(ctx, msg, sizeof msg);
        assert_non_null(strstr(msg, path));
        assert_false(ru_file_exists(path));
        assert_int_equal(ru_count_prefixed(prefix), 0);
    }
    lrr__context_set_io_hook(ctx, NULL, NULL);
    free(B);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_gltf_furnace),
        cmocka_unit_test(test_gltf_subpatches_exposure),
        cmocka_unit_test(test_material_edge),
        cmocka_unit_test(test_ply_furnace),
        cmocka_unit_test(test_bad_input),
        cmocka_unit_test(test_auto_exposure),
        cmocka_unit_test(test_write_failures),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
