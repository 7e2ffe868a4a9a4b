/* Scene import through assimp's C API (OBJ+MTL, PLY, glTF 2.0): flattens the node hierarchy
 * into world-space triangles with per-triangle reflectance and emission, then hands them to
 * lrr__scene_from_arrays (which validates coordinates and materials and drops zero-area
 * triangles).
 *
 * Orientation: triangles are one-sided, front = counter-clockwise as stored in the file. We
 * therefore run no assimp post-processing that touches winding or normals, and triangulate
 * polygons ourselves (ear clipping in the polygon's own orientation). Doing our own
 * triangulation also keeps the polygon's index, so errors name the face of the file rather
 * than a triangle that assimp invented.
 *
 * Materials (checked against Debian 12's assimp 5.2.5):
 *   rho      = glTF base colour factor (AI_MATKEY_BASE_COLOR), otherwise the diffuse colour
 *              (AI_MATKEY_COLOR_DIFFUSE = Kd in MTL).
 *   emission = AI_MATKEY_COLOR_EMISSIVE (Ke in MTL, emissiveFactor in glTF), times
 *              AI_MATKEY_EMISSIVE_INTENSITY where assimp provides it (newer assimp maps
 *              KHR_materials_emissive_strength to it). assimp 5.2 reads MTL's Ke correctly,
 *              including negative values, so no MTL parser of our own is needed.
 *   Faces without a material colour of their own get DEFAULT_RHO grey and no emission:
 *   assimp's stand-in materials (OBJ faces without usemtl: "DefaultMaterial", diffuse 0.6;
 *   every PLY, for which assimp invents a white material; glTF primitives without a material,
 *   for which assimp appends the spec's white default) would otherwise give rho = 1 or an
 *   arbitrary grey. Textures and vertex colours are ignored.
 *
 * assimp keeps its last error string in a global; with several threads importing at once the
 * message may belong to another import. That is assimp's, and only affects message text. */
#include "config.h"
#include "scene/scene.h"
#ifdef LRR_HAVE_ASSIMP

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/scene.h>
#include <assimp/version.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define DEFAULT_RHO 0.5f
/* Deeper hierarchies than this are treated as malformed rather than risking the stack. */
#define MAX_NODE_DEPTH 1024
/* Ear clipping is cubic in the polygon size; larger polygons are fanned (correct for convex
 * ones, which is what huge polygons in practice are) so a hostile file cannot stall us. */
#define MAX_EAR_CLIP 256

typedef struct import_state {
    lrr_context *ctx;
    const char *path;
    const struct aiScene *scene;
    float *mat_rho, *mat_em;       /* per material ×3 */
    size_t *face_base;             /* per mesh: global index of its first face */
    /* output */
    size_t n_tri;
    float *vert, *rho, *em;
    size_t *face_ids;
    /* scratch for one polygon */
    double *poly;  /* max_poly×3 */
    unsigned *idx; /* max_poly */
    unsigned *tri; /* (max_poly-2)×3 */
} import_state;

/* ------------------------------------------------------------------ file checks */

static bool has_extension(const char *path, const char *ext)
{
    const char *dot = strrchr(path, '.');
    const char *slash = strrchr(path, '/');
    return dot && (!slash || dot > slash) && strcasecmp(dot + 1, ext) == 0;
}

/* assimp's own message for a missing file is vague ("Unable to open file"), so check first. */
static lrr_status check_readable(lrr_context *ctx, const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        char eb[128];
        return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot open: %s", path,
                          lrr__errno_text(errno, eb, sizeof eb));
    }
    if (S_ISDIR(st.st_mode))
        return lrr__error(ctx, LRR_ERR_IO, "file %s: is a directory, not a scene file", path);
    FILE *f = fopen(path, "rb");
    if (!f) {
        char eb[128];
        return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot open: %s", path,
                          lrr__errno_text(errno, eb, sizeof eb));
    }
    fclose(f);
    return LRR_OK;
}

/* Whether the first `limit` bytes of the file contain `needle` (streamed; needle shorter
 * than 64 bytes). */
static bool file_contains(const char *path, const char *needle, uint64_t limit)
{
    size_t len = strlen(needle);
    FILE *f = fopen(path, "rb");
    if (!f || len == 0 || len >= 64) {
        if (f)
            fclose(f);
        return false;
    }
    char buf[4096 + 64];
    size_t keep = 0;
    bool found = false;
    while (limit > 0 && !found) {
        size_t want = limit < 4096 ? (size_t)limit : 4096;
        size_t got = fread(buf + keep, 1, want, f);
        if (got == 0)
            break;
        limit -= got;
        size_t have = keep + got;
        for (size_t i = 0; i + len <= have && !found; i++)
            found = memcmp(buf + i, needle, len) == 0;
        keep = have < len - 1 ? have : len - 1;
        memmove(buf, buf + have - keep, keep);
    }
    fclose(f);
    return found;
}

/* How much of a glTF file holds its JSON: all of a .gltf, the header and first chunk of a
 * .glb (so that a large binary buffer is not scanned). */
static uint64_t gltf_json_extent(const char *path)
{
    if (!has_extension(path, "glb"))
        return UINT64_MAX;
    unsigned char h[20];
    FILE *f = fopen(path, "rb");
    if (!f)
        return 0;
    size_t got = fread(h, 1, sizeof h, f);
    fclose(f);
    if (got != sizeof h)
        return 0;
    uint64_t chunk = h[12] | (uint64_t)h[13] << 8 | (uint64_t)h[14] << 16 | (uint64_t)h[15] << 24;
    return 20 + chunk;
}

/* ------------------------------------------------------------------ PLY check */
/* lrr__ply_check (scene/ply.c), when assimp will read path as PLY: by the extension, or by
 * the "ply" signature when the extension is not one of the other formats. */
static lrr_status check_if_ply(lrr_context *ctx, const char *path)
{
    bool other = has_extension(path, "obj") || has_extension(path, "gltf") ||
                 has_extension(path, "glb");
    if (other)
        return LRR_OK;
    FILE *f = fopen(path, "rb");
    if (!f)
        return LRR_OK; /* check_readable has reported it */
    char magic[4] = "";
    size_t got = fread(magic, 1, 4, f);
    struct stat st;
    lrr_status status = LRR_OK;
    if ((has_extension(path, "ply") ||
         (got == 4 && memcmp(magic, "ply", 3) == 0 && (magic[3] == '\n' || magic[3] == '\r'))) &&
        fstat(fileno(f), &st) == 0 && st.st_size >= 0) {
        rewind(f);
        status = lrr__ply_check(ctx, path, f, (uint64_t)st.st_size);
    }
    fclose(f);
    return status;
}

/* ------------------------------------------------------------------ materials */

static bool get_colour(const struct aiMaterial *m, const char *key, unsigned type,
                       unsigned index, float out[3])
{
    struct aiColor4D c;
    if (aiGetMaterialColor(m, key, type, index, &c) != aiReturn_SUCCESS)
        return false;
    out[0] = c.r;
    out[1] = c.g;
    out[2] = c.b;
    return true;
}

/* Fills rho and emission (×3 per material) following the rules in the header comment. */
static lrr_status read_materials(lrr_context *ctx, const char *path,
                                 const struct aiScene *scene, float *rho, float *em)
{
    bool ply = has_extension(path, "ply");
    bool gltf = has_extension(path, "gltf") || has_extension(path, "glb");
    bool any_intensity = false;
    for (unsigned i = 0; i < scene->mNumMaterials; i++) {
        const struct aiMaterial *m = scene->mMaterials[i];
        float *r = rho + 3 * (size_t)i, *e = em + 3 * (size_t)i;
        r[0] = r[1] = r[2] = DEFAULT_RHO;
        e[0] = e[1] = e[2] = 0.0f;
        if (!m || ply)
            continue;
        struct aiString name;
        bool named = aiGetMaterialString(m, AI_MATKEY_NAME, &name) == aiReturn_SUCCESS &&
                     name.length > 0;
        if (named && strcmp(name.data, AI_DEFAULT_MATERIAL_NAME) == 0)
            continue;
        float c[3], ke[3] = {0, 0, 0};
        bool have_rho = (gltf && get_colour(m, AI_MATKEY_BASE_COLOR, c)) ||
                        get_colour(m, AI_MATKEY_COLOR_DIFFUSE, c) ||
                        get_colour(m, AI_MATKEY_BASE_COLOR, c);
        bool have_em = get_colour(m, AI_MATKEY_COLOR_EMISSIVE, ke);
        /* assimp appends the glTF spec's default material (white, unnamed) last; a file's
         * own unnamed white non-emitting material would be rejected (rho = 1) anyway. */
        if (gltf && i + 1 == scene->mNumMaterials && !named && have_rho && c[0] == 1.0f &&
            c[1] == 1.0f && c[2] == 1.0f && ke[0] == 0.0f && ke[1] == 0.0f && ke[2] == 0.0f)
            continue;
        if (have_rho)
            memcpy(r, c, sizeof c);
        if (have_em) {
            float s = 1.0f;
            if (aiGetMaterialFloatArray(m, AI_MATKEY_EMISSIVE_INTENSITY, &s, NULL) ==
                aiReturn_SUCCESS)
                any_intensity = true;
            else
                s = 1.0f;
            for (int k = 0; k < 3; k++)
                e[k] = ke[k] * s;
        }
    }
    /* emissiveFactor is limited to [0,1] in glTF; brighter lights need the strength
     * extension. Silently dropping it would give wrong radiosity, so refuse instead. */
    if (gltf && !any_intensity &&
        file_contains(path, "KHR_materials_emissive_strength", gltf_json_extent(path)))
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "file %s: uses KHR_materials_emissive_strength, which the installed "
                          "assimp %u.%u does not read; emission would be wrong",
                          path, aiGetVersionMajor(), aiGetVersionMinor());
    return LRR_OK;
}

/* ------------------------------------------------------------------ geometry */

static void mat_mul(struct aiMatrix4x4 *out, const struct aiMatrix4x4 *a,
                    const struct aiMatrix4x4 *b)
{
    const float *x = &a->a1, *y = &b->a1; /* row-major a1..a4, b1..b4, … */
    float r[16];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            double s = 0;
            for (int k = 0; k < 4; k++)
                s += (double)x[4 * i + k] * y[4 * k + j];
            r[4 * i + j] = (float)s;
        }
    memcpy(&out->a1, r, sizeof r);
}

static double det3(const struct aiMatrix4x4 *m)
{
    return (double)m->a1 * ((double)m->b2 * m->c3 - (double)m->b3 * m->c2) -
           (double)m->a2 * ((double)m->b1 * m->c3 - (double)m->b3 * m->c1) +
           (double)m->a3 * ((double)m->b1 * m->c2 - (double)m->b2 * m->c1);
}

static void transform(const struct aiMatrix4x4 *m, struct aiVector3D v, double out[3])
{
    double x = v.x, y = v.y, z = v.z;
    out[0] = m->a1 * x + m->a2 * y + m->a3 * z + m->a4;
    out[1] = m->b1 * x + m->b2 * y + m->b3 * z + m->b4;
    out[2] = m->c1 * x + m->c2 * y + m->c3 * z + m->c4;
}

static double cross2(const double *a, const double *b, const double *c, int u, int v)
{
    return (b[u] - a[u]) * (c[v] - a[v]) - (b[v] - a[v]) * (c[u] - a[u]);
}

/* Splits polygon p (n >= 3 points) into n-2 triangles tri[3t..3t+2] (indices into p) with the
 * polygon's own orientation: ear clipping in the plane of its Newell normal. Degenerate,
 * non-planar or self-intersecting polygons fall back to a fan over what is left (their
 * triangles may then be zero-area, which the scene counts and skips). */
static void triangulate(size_t n, const double *p, unsigned *idx, unsigned *tri)
{
    double nrm[3] = {0, 0, 0};
    for (size_t i = 0; i < n; i++) {
        const double *a = p + 3 * i, *b = p + 3 * ((i + 1) % n);
        nrm[0] += (a[1] - b[1]) * (a[2] + b[2]);
        nrm[1] += (a[2] - b[2]) * (a[0] + b[0]);
        nrm[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    int k = fabs(nrm[0]) >= fabs(nrm[1]) ? 0 : 1;
    if (fabs(nrm[2]) > fabs(nrm[k]))
        k = 2;
    int u = (k + 1) % 3, v = (k + 2) % 3; /* (u, v, k) is right-handed */
    double sign = nrm[k] >= 0 ? 1.0 : -1.0;
    for (size_t i = 0; i < n; i++)
        idx[i] = (unsigned)i;
    size_t m = n, out = 0;
    bool clip = n <= MAX_EAR_CLIP && isfinite(nrm[0] + nrm[1] + nrm[2]);
    while (m > 3 && clip) {
        bool found = false;
        for (size_t i = 0; i < m && !found; i++) {
            unsigned ia = idx[(i + m - 1) % m], ib = idx[i], ic = idx[(i + 1) % m];
            const double *a = p + 3 * ia, *b = p + 3 * ib, *c = p + 3 * ic;
            if (sign * cross2(a, b, c, u, v) <= 0)
                continue; /* reflex or flat corner */
            bool empty = true;
            for (size_t j = 0; j < m && empty; j++) {
                unsigned q = idx[j];
                if (q == ia || q == ib || q == ic)
                    continue;
                const double *x = p + 3 * q;
                if (sign * cross2(a, b, x, u, v) >= 0 && sign * cross2(b, c, x, u, v) >= 0 &&
                    sign * cross2(c, a, x, u, v) >= 0)
                    empty = false;
            }
            if (!empty)
                continue;
            tri[3 * out] = ia;
            tri[3 * out + 1] = ib;
            tri[3 * out + 2] = ic;
            out++;
            memmove(idx + i, idx + i + 1, (m - i - 1) * sizeof *idx);
            m--;
            found = true;
        }
        clip = found;
    }
    for (size_t i = 1; i + 1 < m; i++) {
        tri[3 * out] = idx[0];
        tri[3 * out + 1] = idx[i];
        tri[3 * out + 2] = idx[i + 1];
        out++;
    }
}

/* Counts the triangles the node tree yields (points and lines are ignored) and the largest
 * polygon, with overflow and depth checks. */
static lrr_status count_node(import_state *s, const struct aiNode *node, unsigned depth,
                             size_t *n_tri, size_t *max_poly)
{
    const struct aiScene *sc = s->scene;
    if (depth > MAX_NODE_DEPTH)
        return lrr__error(s->ctx, LRR_ERR_FORMAT,
                          "file %s: node hierarchy deeper than %d levels", s->path,
                          MAX_NODE_DEPTH);
    for (unsigned i = 0; i < node->mNumMeshes; i++) {
        unsigned mi = node->mMeshes[i];
        if (mi >= sc->mNumMeshes || !sc->mMeshes[mi])
            return lrr__error(s->ctx, LRR_ERR_FORMAT,
                              "file %s: node '%s' refers to mesh %u of %u", s->path,
                              node->mName.data, mi, sc->mNumMeshes);
        const struct aiMesh *mesh = sc->mMeshes[mi];
        if (mesh->mNumFaces > 0 && (!mesh->mFaces || !mesh->mVertices))
            return lrr__error(s->ctx, LRR_ERR_FORMAT, "file %s: mesh %u has no vertex data",
                              s->path, mi);
        for (unsigned f = 0; f < mesh->mNumFaces; f++) {
            unsigned ni = mesh->mFaces[f].mNumIndices;
            if (ni < 3)
                continue;
            if (__builtin_add_overflow(*n_tri, (size_t)ni - 2, n_tri))
                return lrr__error(s->ctx, LRR_ERR_OVERFLOW,
                                  "file %s: triangle count overflows size_t", s->path);
            if (ni > *max_poly)
                *max_poly = ni;
        }
    }
    for (unsigned c = 0; c < node->mNumChildren; c++) {
        if (!node->mChildren[c])
            continue;
        lrr_status st = count_node(s, node->mChildren[c], depth + 1, n_tri, max_poly);
        if (st != LRR_OK)
            return st;
    }
    return LRR_OK;
}

static void emit(import_state *s, const double *a, const double *b, const double *c,
                 const float *rho, const float *em, size_t face)
{
    size_t t = s->n_tri++;
    const double *q[3] = {a, b, c};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            s->vert[9 * t + 3 * i + j] = (float)q[i][j];
    memcpy(s->rho + 3 * t, rho, 3 * sizeof *rho);
    memcpy(s->em + 3 * t, em, 3 * sizeof *em);
    s->face_ids[t] = face;
}

static lrr_status fill_node(import_state *s, const struct aiNode *node,
                            const struct aiMatrix4x4 *parent)
{
    const struct aiScene *sc = s->scene;
    struct aiMatrix4x4 world;
    mat_mul(&world, parent, &node->mTransformation);
    /* A mirroring transform turns counter-clockwise into clockwise; swap two vertices so the
     * front stays the side the file's winding defines (glTF's rule for negative
     * determinants). */
    bool flip = det3(&world) < 0;
    for (unsigned i = 0; i < node->mNumMeshes; i++) {
        unsigned mi = node->mMeshes[i];
        const struct aiMesh *mesh = sc->mMeshes[mi];
        if (mesh->mMaterialIndex >= sc->mNumMaterials)
            return lrr__error(s->ctx, LRR_ERR_FORMAT,
                              "file %s: mesh %u uses material %u of %u", s->path, mi,
                              mesh->mMaterialIndex, sc->mNumMaterials);
        const float *rho = s->mat_rho + 3 * (size_t)mesh->mMaterialIndex;
        const float *em = s->mat_em + 3 * (size_t)mesh->mMaterialIndex;
        for (unsigned f = 0; f < mesh->mNumFaces; f++) {
            const struct aiFace *face = &mesh->mFaces[f];
            unsigned ni = face->mNumIndices;
            if (ni < 3)
                continue;
            size_t id = s->face_base[mi] + f;
            for (unsigned j = 0; j < ni; j++) {
                unsigned vi = face->mIndices[j];
                if (vi >= mesh->mNumVertices)
                    return lrr__error(s->ctx, LRR_ERR_FORMAT,
                                      "file %s: face %zu refers to vertex %u of %u", s->path,
                                      id, vi, mesh->mNumVertices);
                transform(&world, mesh->mVertices[vi], s->poly + 3 * (size_t)j);
            }
            triangulate(ni, s->poly, s->idx, s->tri);
            for (unsigned t = 0; t + 2 < ni; t++) {
                const double *a = s->poly + 3 * (size_t)s->tri[3 * t];
                const double *b = s->poly + 3 * (size_t)s->tri[3 * t + 1];
                const double *c = s->poly + 3 * (size_t)s->tri[3 * t + 2];
                if (flip)
                    emit(s, a, c, b, rho, em, id);
                else
                    emit(s, a, b, c, rho, em, id);
            }
        }
    }
    for (unsigned c = 0; c < node->mNumChildren; c++) {
        if (!node->mChildren[c])
            continue;
        lrr_status st = fill_node(s, node->mChildren[c], &world);
        if (st != LRR_OK)
            return st;
    }
    return LRR_OK;
}

static void free_state(import_state *s)
{
    lrr_aligned_free(s->mat_rho);
    lrr_aligned_free(s->mat_em);
    lrr_aligned_free(s->face_base);
    lrr_aligned_free(s->vert);
    lrr_aligned_free(s->rho);
    lrr_aligned_free(s->em);
    lrr_aligned_free(s->face_ids);
    lrr_aligned_free(s->poly);
    lrr_aligned_free(s->idx);
    lrr_aligned_free(s->tri);
}

static lrr_status convert(import_state *s)
{
    const struct aiScene *sc = s->scene;
    lrr_context *ctx = s->ctx;
    lrr_status st;
    if (!sc->mRootNode)
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: assimp returned no node hierarchy",
                          s->path);
    if (sc->mNumMeshes == 0 || !sc->mMeshes)
        return lrr__error(ctx, LRR_ERR_EMPTY, "file %s: no meshes (nothing to import)",
                          s->path);
    if (sc->mNumMaterials > 0 && !sc->mMaterials)
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: material table missing", s->path);

    if ((st = lrr__calloc(ctx, &s->mat_rho, sc->mNumMaterials, 3 * sizeof(float),
                          "material reflectance")) ||
        (st = lrr__calloc(ctx, &s->mat_em, sc->mNumMaterials, 3 * sizeof(float),
                          "material emission")) ||
        (st = read_materials(ctx, s->path, sc, s->mat_rho, s->mat_em)))
        return st;

    /* face_ids: a polygon's index counted over assimp's meshes in order (mesh 0's faces
     * first), 0-based, points and lines included. For an OBJ with one material this is the
     * index of the f/l/p line; for glTF, the triangle's index over the primitives in order.
     * A mesh instanced by several nodes repeats its ids. */
    if ((st = lrr__calloc(ctx, &s->face_base, sc->mNumMeshes, sizeof(size_t), "face index")))
        return st;
    size_t base = 0;
    for (unsigned m = 0; m < sc->mNumMeshes; m++) {
        s->face_base[m] = base;
        if (sc->mMeshes[m])
            base += sc->mMeshes[m]->mNumFaces;
    }

    size_t n_tri = 0, max_poly = 3;
    if ((st = count_node(s, sc->mRootNode, 0, &n_tri, &max_poly)))
        return st;
    if (n_tri == 0)
        return lrr__error(ctx, LRR_ERR_EMPTY,
                          "file %s: no triangles or polygons (points and lines are ignored)",
                          s->path);
    if ((st = lrr__calloc(ctx, &s->vert, n_tri, 9 * sizeof(float), "imported vertices")) ||
        (st = lrr__calloc(ctx, &s->rho, n_tri, 3 * sizeof(float), "imported reflectance")) ||
        (st = lrr__calloc(ctx, &s->em, n_tri, 3 * sizeof(float), "imported emission")) ||
        (st = lrr__calloc(ctx, &s->face_ids, n_tri, sizeof(size_t), "imported face ids")) ||
        (st = lrr__calloc(ctx, &s->poly, max_poly, 3 * sizeof(double), "polygon scratch")) ||
        (st = lrr__calloc(ctx, &s->idx, max_poly, sizeof(unsigned), "polygon scratch")) ||
        (st = lrr__calloc(ctx, &s->tri, max_poly - 2, 3 * sizeof(unsigned),
                          "polygon scratch")))
        return st;
    struct aiMatrix4x4 identity;
    aiIdentityMatrix4(&identity);
    if ((st = fill_node(s, sc->mRootNode, &identity)))
        return st;
    return LRR_OK;
}

/* Reads path through assimp into s (arrays owned by s; free_state frees them). */
static lrr_status import_file(lrr_context *ctx, const char *path, import_state *s)
{
    memset(s, 0, sizeof *s);
    lrr_status st = check_readable(ctx, path);
    if (st == LRR_OK)
        st = check_if_ply(ctx, path);
    if (st != LRR_OK)
        return st;
    /* No post-processing: triangulation, normals and winding are ours (see the top). */
    const struct aiScene *scene = aiImportFile(path, 0);
    if (!scene) {
        const char *why = aiGetErrorString();
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: cannot import: %s", path,
                          why && *why ? why : "assimp gave no reason");
    }
    s->ctx = ctx;
    s->path = path;
    s->scene = scene;
    st = convert(s);
    aiReleaseImport(scene);
    s->scene = NULL;
    return st;
}

lrr_status lrr_scene_load(lrr_context *ctx, const char *path, lrr_scene **out)
{
    *out = NULL;
    import_state s;
    lrr_status st = import_file(ctx, path, &s);
    if (st == LRR_OK)
        st = lrr__scene_from_arrays(ctx, s.n_tri, s.vert, s.rho, s.em, s.face_ids, path,
                                    LRR__SCENE_FILE, out);
    free_state(&s);
    return st;
}

/* For `lrr check`: every triangle as imported, degenerate ones included, with its face number;
 * nothing is validated. The caller frees the four arrays with lrr_aligned_free. */
lrr_status lrr__scene_import_raw(lrr_context *ctx, const char *path, size_t *n_tri,
                                 float **vert, float **rho, float **emission,
                                 size_t **face_ids)
{
    *n_tri = 0;
    *vert = *rho = *emission = NULL;
    *face_ids = NULL;
    import_state s;
    lrr_status st = import_file(ctx, path, &s);
    if (st == LRR_OK) {
        *n_tri = s.n_tri;
        *vert = s.vert;
        *rho = s.rho;
        *emission = s.em;
        *face_ids = s.face_ids;
        s.vert = s.rho = s.em = NULL;
        s.face_ids = NULL;
    }
    free_state(&s);
    return st;
}
#else /* !LRR_HAVE_ASSIMP */

/* configure --without-assimp: no scene files, only the built-in scenes. */
static lrr_status no_assimp(lrr_context *ctx, const char *path)
{
    return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                      "%s: lrr was built without assimp: cannot read scene files "
                      "(built-in scenes: cornell, cornell-closed)",
                      path);
}

lrr_status lrr_scene_load(lrr_context *ctx, const char *path, lrr_scene **out)
{
    *out = NULL;
    return no_assimp(ctx, path);
}

lrr_status lrr__scene_import_raw(lrr_context *ctx, const char *path, size_t *n_tri,
                                 float **vert, float **rho, float **emission,
                                 size_t **face_ids)
{
    *n_tri = 0;
    *vert = *rho = *emission = NULL;
    *face_ids = NULL;
    return no_assimp(ctx, path);
}
#endif
