/* lrr_export_ply: the lit mesh (export.c) as binary little-endian PLY, assembled in memory
 * and written atomically. What the file holds: lrr.h "export". */
#include "config.h"
#include "output/render_internal.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Bytes per vertex (x y z nx ny nz: 24; red green blue: 3; radiosity: 12) and per face
 * (the list count, three uint indices, the uint material). */
#define PLY_VERTEX_BYTES 39u
#define PLY_FACE_BYTES 17u
#define PLY_HEADER_MAX 1024u /* the header's fixed lines (about 600 bytes); materials add
                             * PLY_MATERIAL_LINE each */
#define PLY_MATERIAL_LINE 200u

/* The 8-bit sRGB code of a linear value in [0, 1] (IEC 61966-2-1), rounded. */
static unsigned char srgb8(double x)
{
    double s = x <= 0.0031308 ? 12.92 * x : 1.055 * pow(x, 1 / 2.4) - 0.055;
    s = s < 0 ? 0 : s > 1 ? 1 : s;
    return (unsigned char)lround(255 * s);
}

static unsigned char *put_u32(unsigned char *p, uint32_t x)
{
    for (int k = 0; k < 4; k++)
        p[k] = (unsigned char)(x >> (8 * k));
    return p + 4;
}

static unsigned char *put_f32(unsigned char *p, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    return put_u32(p, u);
}

/* The header into h (cap bytes); returns its length, 0 if it did not fit. */
static size_t ply_header(char *h, size_t cap, const lrr__export_mesh *m)
{
    size_t len = 0;
    int k = snprintf(h, cap,
                     "ply\nformat binary_little_endian 1.0\ncomment lrr %s: %s with per-vertex "
                     "radiosity\ncomment red green blue: sRGB of min(1, radiosity x exposure), "
                     "exposure %.17g\n",
                     LRR_VERSION_STRING, m->subpatches ? "subpatches" : "input triangles",
                     m->exposure);
    for (size_t i = 0; k >= 0 && (size_t)k < cap - len && i < m->nm; i++) {
        len += (size_t)k;
        const float *r = m->rho + 3 * i, *e = m->emission + 3 * i;
        k = snprintf(h + len, cap - len,
                     "comment material %zu reflectance %.9g %.9g %.9g emission %.9g %.9g %.9g\n",
                     i, r[0], r[1], r[2], e[0], e[1], e[2]);
    }
    if (k >= 0 && (size_t)k < cap - len) {
        len += (size_t)k;
        k = snprintf(h + len, cap - len,
                     "element vertex %zu\nproperty float x\nproperty float y\nproperty float "
                     "z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty "
                     "uchar red\nproperty uchar green\nproperty uchar blue\nproperty float "
                     "radiosity_r\nproperty float radiosity_g\nproperty float radiosity_b\n"
                     "element face %zu\nproperty list uchar uint vertex_indices\nproperty "
                     "uint material\nend_header\n",
                     m->nv, m->nt);
    }
    return k >= 0 && (size_t)k < cap - len ? len + (size_t)k : 0;
}

static unsigned char *put_vertex(unsigned char *p, const lrr__export_mesh *m, size_t v)
{
    for (int j = 0; j < 3; j++)
        p = put_f32(p, m->pos[3 * v + j]);
    for (int j = 0; j < 3; j++)
        p = put_f32(p, m->normal[3 * v + j]);
    for (int j = 0; j < 3; j++)
        *p++ = srgb8(m->colour[3 * v + j]);
    for (int j = 0; j < 3; j++)
        p = put_f32(p, m->radiosity[3 * v + j]);
    return p;
}

/* The file in memory: header, vertices, faces (each with its material). */
static lrr_status ply_bytes(lrr_context *ctx, const char *path, const lrr__export_mesh *m,
                            unsigned char **out, size_t *len)
{
    size_t hcap = PLY_HEADER_MAX, nm = m->nm;
    if (nm > (SIZE_MAX - hcap) / PLY_MATERIAL_LINE || m->nv > SIZE_MAX / 64 / PLY_VERTEX_BYTES ||
        m->nt > SIZE_MAX / 64 / PLY_FACE_BYTES)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "export %s: %zu vertices, %zu faces: the "
                          "file size overflows", path, m->nv, m->nt);
    hcap += nm * PLY_MATERIAL_LINE;
    size_t body = m->nv * PLY_VERTEX_BYTES + m->nt * PLY_FACE_BYTES;
    unsigned char *f;
    lrr_status st = lrr__calloc(ctx, &f, hcap + body, 1, "export: PLY file");
    if (st)
        return st;
    size_t hlen = ply_header((char *)f, hcap, m);
    if (hlen == 0) { /* cannot happen: hcap holds the fixed lines and nm material lines */
        lrr_aligned_free(f);
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "export %s: PLY header too long", path);
    }
    unsigned char *p = f + hlen;
    for (size_t v = 0; v < m->nv; v++)
        p = put_vertex(p, m, v);
    for (size_t k = 0; k < nm; k++)
        for (size_t t = m->tri_start[k]; t < m->tri_start[k + 1]; t++) {
            *p++ = 3;
            for (int j = 0; j < 3; j++)
                p = put_u32(p, m->index[3 * t + (size_t)j]);
            p = put_u32(p, (uint32_t)k);
        }
    *out = f;
    *len = (size_t)(p - f);
    return LRR_OK;
}

lrr_status lrr_export_ply(const lrr_operator *op, const float *radiosity,
                          const lrr_export_options *opts, const char *path)
{
    lrr__export_mesh m;
    lrr_status st = lrr__export_mesh_build(op, radiosity, opts, "export", path, &m);
    unsigned char *data = NULL;
    size_t len = 0;
    if (!st)
        st = ply_bytes(op->ctx, path, &m, &data, &len);
    if (!st)
        st = lrr__output_write_atomic(op->ctx, path, data, len);
    lrr_aligned_free(data);
    lrr__export_mesh_free(&m);
    return st;
}
