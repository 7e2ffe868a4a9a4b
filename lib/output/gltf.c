/* lrr_export_gltf: the lit mesh (export.c) as binary glTF 2.0 (.glb): a 12-byte header, a
 * JSON chunk describing one mesh, a BIN chunk with the vertex arrays and the indices,
 * assembled in memory and written atomically. What the file holds: lrr.h "export". */
#include "config.h"
#include "output/render_internal.h"

#include <stdarg.h>
#include <stdlib.h>
#include <stdio.h>
#include <string.h>

/* glTF's numbers (glTF 2.0 specification, "accessor.componentType", "bufferView.target"). */
#define GL_FLOAT 5126
#define GL_UNSIGNED_INT 5125
#define GL_TRIANGLES 4
#define GL_ARRAY_BUFFER 34962
#define GL_ELEMENT_ARRAY_BUFFER 34963
#define GLB_MAGIC 0x46546C67u /* "glTF" */
#define GLB_JSON 0x4E4F534Au  /* "JSON" */
#define GLB_BIN 0x004E4942u   /* "BIN\0" */

/* The JSON text, grown as it is printed; a failed allocation is remembered. */
typedef struct jbuf {
    lrr_context *ctx;
    char *s;
    size_t len, cap;
    int failed;
} jbuf;

static void jprintf(jbuf *j, const char *fmt, ...)
{
    if (j->failed)
        return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int k = vsnprintf(j->s ? j->s + j->len : NULL, j->s ? j->cap - j->len : 0, fmt, ap);
        va_end(ap);
        if (k < 0) {
            j->failed = 1;
            return;
        }
        if (j->s && (size_t)k < j->cap - j->len) {
            j->len += (size_t)k;
            return;
        }
        size_t cap = j->cap ? 2 * j->cap : 4096;
        while (cap - j->len <= (size_t)k)
            cap *= 2;
        char *p = lrr__realloc(j->ctx, j->s, cap);
        if (!p) {
            j->failed = 1;
            return;
        }
        j->s = p;
        j->cap = cap;
    }
}

/* The BIN chunk's parts, in this order; each a multiple of 4 bytes long. */
enum { VIEW_POS, VIEW_NORMAL, VIEW_COLOUR, VIEW_RADIOSITY, VIEW_INDEX, N_VIEWS };

typedef struct bin_layout {
    uint64_t offset[N_VIEWS + 1];
} bin_layout;

static void layout(const lrr__export_mesh *m, bin_layout *b)
{
    uint64_t nv = m->nv, len[N_VIEWS] = {12 * nv, 12 * nv, 16 * nv, 12 * nv, 12 * (uint64_t)m->nt};
    b->offset[0] = 0;
    for (int k = 0; k < N_VIEWS; k++)
        b->offset[k + 1] = b->offset[k] + len[k];
}

static void json_vec3(jbuf *j, const float *v)
{
    jprintf(j, "[%.9g,%.9g,%.9g]", (double)v[0], (double)v[1], (double)v[2]);
}

/* One material per (rho, E): unlit, white base colour (COLOR_0 holds the light, rho
 * included), matte for viewers without KHR_materials_unlit; rho and E in extras. */
static void json_materials(jbuf *j, const lrr__export_mesh *m)
{
    jprintf(j, "\"materials\":[");
    for (size_t k = 0; k < m->nm; k++) {
        jprintf(j, "%s{\"name\":\"material %zu\",\"pbrMetallicRoughness\":{\"baseColorFactor\":"
                   "[1,1,1,1],\"metallicFactor\":0,\"roughnessFactor\":1},\"extensions\":"
                   "{\"KHR_materials_unlit\":{}},\"extras\":{\"reflectance\":",
                k ? "," : "", k);
        json_vec3(j, m->rho + 3 * k);
        jprintf(j, ",\"emission\":");
        json_vec3(j, m->emission + 3 * k);
        jprintf(j, "}}");
    }
    jprintf(j, "],");
}

static void json_mesh(jbuf *j, const lrr__export_mesh *m)
{
    jprintf(j, "\"meshes\":[{\"name\":\"%s\",\"primitives\":[",
            m->subpatches ? "subpatches" : "triangles");
    for (size_t k = 0; k < m->nm; k++)
        jprintf(j, "%s{\"attributes\":{\"POSITION\":0,\"NORMAL\":1,\"COLOR_0\":2,"
                   "\"_RADIOSITY\":3},\"indices\":%zu,\"material\":%zu,\"mode\":%d}",
                k ? "," : "", 4 + k, k, GL_TRIANGLES);
    jprintf(j, "]}],");
}

/* The bounds glTF requires of POSITION. */
static void position_bounds(const lrr__export_mesh *m, float lo[3], float hi[3])
{
    for (int c = 0; c < 3; c++)
        lo[c] = hi[c] = m->pos[c];
    for (size_t v = 1; v < m->nv; v++)
        for (int c = 0; c < 3; c++) {
            float x = m->pos[3 * v + c];
            lo[c] = x < lo[c] ? x : lo[c];
            hi[c] = x > hi[c] ? x : hi[c];
        }
}

static void json_accessors(jbuf *j, const lrr__export_mesh *m)
{
    float lo[3], hi[3];
    position_bounds(m, lo, hi);
    jprintf(j, "\"accessors\":[{\"bufferView\":%d,\"componentType\":%d,\"count\":%zu,"
               "\"type\":\"VEC3\",\"min\":",
            VIEW_POS, GL_FLOAT, m->nv);
    json_vec3(j, lo);
    jprintf(j, ",\"max\":");
    json_vec3(j, hi);
    jprintf(j, "},{\"bufferView\":%d,\"componentType\":%d,\"count\":%zu,\"type\":\"VEC3\"},"
               "{\"bufferView\":%d,\"componentType\":%d,\"count\":%zu,\"type\":\"VEC4\"},"
               "{\"bufferView\":%d,\"componentType\":%d,\"count\":%zu,\"type\":\"VEC3\"}",
            VIEW_NORMAL, GL_FLOAT, m->nv, VIEW_COLOUR, GL_FLOAT, m->nv, VIEW_RADIOSITY,
            GL_FLOAT, m->nv);
    for (size_t k = 0; k < m->nm; k++)
        jprintf(j, ",{\"bufferView\":%d,\"byteOffset\":%zu,\"componentType\":%d,"
                   "\"count\":%zu,\"type\":\"SCALAR\"}",
                VIEW_INDEX, 12 * m->tri_start[k], GL_UNSIGNED_INT,
                3 * (m->tri_start[k + 1] - m->tri_start[k]));
    jprintf(j, "],");
}

static void json_views(jbuf *j, const bin_layout *b)
{
    jprintf(j, "\"bufferViews\":[");
    for (int k = 0; k < N_VIEWS; k++)
        jprintf(j, "%s{\"buffer\":0,\"byteOffset\":%llu,\"byteLength\":%llu,\"target\":%d}",
                k ? "," : "", (unsigned long long)b->offset[k],
                (unsigned long long)(b->offset[k + 1] - b->offset[k]),
                k == VIEW_INDEX ? GL_ELEMENT_ARRAY_BUFFER : GL_ARRAY_BUFFER);
    jprintf(j, "],\"buffers\":[{\"byteLength\":%llu}]}",
            (unsigned long long)b->offset[N_VIEWS]);
}

/* The JSON chunk's text. */
static void json_document(jbuf *j, const lrr__export_mesh *m, const bin_layout *b)
{
    jprintf(j, "{\"asset\":{\"version\":\"2.0\",\"generator\":\"lrr %s\",\"extras\":"
               "{\"COLOR_0\":\"min(1, radiosity x exposure), linear\",\"_RADIOSITY\":"
               "\"radiosity B, linear, unscaled\",\"exposure\":%.17g,\"mesh\":\"%s\"}},",
            LRR_VERSION_STRING, m->exposure, m->subpatches ? "subpatches" : "input triangles");
    jprintf(j, "\"extensionsUsed\":[\"KHR_materials_unlit\"],\"scene\":0,\"scenes\":"
               "[{\"nodes\":[0]}],\"nodes\":[{\"name\":\"lrr\",\"mesh\":0}],");
    json_mesh(j, m);
    json_materials(j, m);
    json_accessors(j, m);
    json_views(j, b);
}

static void put_u32(unsigned char *p, uint32_t x)
{
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)(x >> (8 * k));
}

/* Little-endian copies of count floats / uint32s (the file's byte order on any host). */
static unsigned char *put_floats(unsigned char *p, const float *x, size_t count)
{
    for (size_t i = 0; i < count; i++, p += 4) {
        uint32_t u;
        memcpy(&u, &x[i], 4);
        put_u32(p, u);
    }
    return p;
}

/* The BIN chunk's data (b->offset[N_VIEWS] bytes) at p. */
static void fill_bin(unsigned char *p, const lrr__export_mesh *m)
{
    p = put_floats(p, m->pos, 3 * m->nv);
    p = put_floats(p, m->normal, 3 * m->nv);
    for (size_t v = 0; v < m->nv; v++) {
        const float rgba[4] = {m->colour[3 * v], m->colour[3 * v + 1], m->colour[3 * v + 2], 1};
        p = put_floats(p, rgba, 4);
    }
    p = put_floats(p, m->radiosity, 3 * m->nv);
    for (size_t i = 0; i < 3 * m->nt; i++, p += 4)
        put_u32(p, m->index[i]);
}

/* The whole .glb in memory: header, JSON chunk (padded with spaces), BIN chunk. */
static lrr_status assemble(lrr_context *ctx, const char *path, const jbuf *j,
                           const lrr__export_mesh *m, const bin_layout *b,
                           unsigned char **out, size_t *len)
{
    uint64_t jlen = (j->len + 3) / 4 * 4, blen = b->offset[N_VIEWS];
    uint64_t total = 12 + 8 + jlen + 8 + blen;
    if (total > UINT32_MAX || m->nv > UINT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "export %s: %zu vertices and %zu triangles need %llu bytes; a .glb "
                          "holds at most %u",
                          path, m->nv, m->nt, (unsigned long long)total, UINT32_MAX);
    unsigned char *g;
    lrr_status st = lrr__calloc(ctx, &g, (size_t)total, 1, "export: glTF file");
    if (st)
        return st;
    put_u32(g, GLB_MAGIC);
    put_u32(g + 4, 2);
    put_u32(g + 8, (uint32_t)total);
    put_u32(g + 12, (uint32_t)jlen);
    put_u32(g + 16, GLB_JSON);
    memcpy(g + 20, j->s, j->len);
    memset(g + 20 + j->len, ' ', (size_t)(jlen - j->len));
    put_u32(g + 20 + jlen, (uint32_t)blen);
    put_u32(g + 24 + jlen, GLB_BIN);
    fill_bin(g + 28 + jlen, m);
    *out = g;
    *len = (size_t)total;
    return LRR_OK;
}

lrr_status lrr_export_gltf(const lrr_operator *op, const float *radiosity,
                           const lrr_export_options *opts, const char *path)
{
    lrr__export_mesh m;
    lrr_status st = lrr__export_mesh_build(op, radiosity, opts, "export", path, &m);
    jbuf j = {op->ctx, NULL, 0, 0, 0};
    unsigned char *glb = NULL;
    size_t len = 0;
    bin_layout b;
    if (!st) {
        layout(&m, &b);
        json_document(&j, &m, &b);
        if (j.failed)
            st = lrr__error(op->ctx, LRR_ERR_NOMEM, "export %s: out of memory for the JSON "
                                                    "chunk",
                            path);
    }
    if (!st)
        st = assemble(op->ctx, path, &j, &m, &b, &glb, &len);
    if (!st)
        st = lrr__output_write_atomic(op->ctx, path, glb, len);
    lrr_aligned_free(glb);
    free(j.s);
    lrr__export_mesh_free(&m);
    return st;
}
