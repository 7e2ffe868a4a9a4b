/* Scene import through assimp's C API (OBJ+MTL, PLY, glTF 2.0): flattens the node hierarchy
 * into world-space triangles with per-triangle reflectance and emission, then hands them to
 * lrr__scene_from_arrays (which validates coordinates and materials and drops zero-area
 * triangles).
 *
 * Orientation: triangles are one-sided, front = counter-clockwise as stored in the file. We
 * therefore run no assimp post-processing that touches winding or normals, and triangulate
 * polygons ourselves (ear clipping in the polygon's own orientation, triangulate.c). Doing
 * our own triangulation also keeps the polygon's index, so errors name the face of the file
 * rather than a triangle that assimp invented. What assimp opens is checked first
 * (assimp_io.c).
 *
 * Materials (checked against Debian 12's assimp 5.2.5):
 *   rho      = glTF base colour factor (AI_MATKEY_BASE_COLOR), otherwise the diffuse colour
 *              (AI_MATKEY_COLOR_DIFFUSE = Kd in MTL).
 *   emission = AI_MATKEY_COLOR_EMISSIVE (Ke in MTL, emissiveFactor in glTF), times the
 *              glTF KHR_materials_emissive_strength, which we read from the JSON ourselves
 *              (gltf_ext.c: assimp 5.2 ignores it), else AI_MATKEY_EMISSIVE_INTENSITY where
 *              assimp provides it. assimp 5.2 reads MTL's Ke correctly, including negative
 *              values, so no MTL parser of our own is needed.
 *   textures = the diffuse / base colour and the emissive texture (map_Kd, map_Ke;
 *              baseColorTexture, emissiveTexture), decoded into linear RGB times the colour
 *              above (texture.c); each triangle keeps its corner UVs and lrr_scene_subpatches
 *              integrates the texture over each subpatch (docs/METHOD.md "Textures").
 *   Faces without a material colour of their own get DEFAULT_RHO grey and no emission:
 *   assimp's stand-in materials (OBJ faces without usemtl: "DefaultMaterial", diffuse 0.6;
 *   every PLY, for which assimp invents a white material; glTF primitives without a material,
 *   for which assimp appends the spec's white default) would otherwise give rho = 1 or an
 *   arbitrary grey. Vertex colours are ignored.
 *
 * assimp keeps its last error string in a global; with several threads importing at once the
 * message may belong to another import. That is assimp's, and only affects message text. */
#include "config.h"
#include "core/path.h"
#include "scene/scene.h"
#include "scene/assimp_io.h"
#include "scene/gltf_ext.h"
#include "scene/texture.h"
#ifdef LRR_HAVE_ASSIMP

#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/scene.h>
#include <assimp/texture.h>
#include <assimp/version.h>

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#define DEFAULT_RHO 0.5f
/* Deeper hierarchies than this are treated as malformed rather than risking the stack. */
#define MAX_NODE_DEPTH 1024

typedef struct import_state {
    lrr_context *ctx;
    const char *path;
    const struct aiScene *scene;
    float *mat_rho, *mat_em;       /* per material ×3 */
    uint32_t *mat_rho_tex, *mat_em_tex; /* per material: texture index or LRR__NO_TEXTURE */
    unsigned *mat_uv;              /* per material: the UV channel its textures use */
    lrr__scene_textures *tx;       /* NULL until a material has a texture */
    size_t *face_base;             /* per mesh: global index of its first face */
    /* output */
    size_t n_tri;
    float *vert, *rho, *em;
    size_t *face_ids;
    /* scratch for one polygon */
    double *poly;  /* max_poly×3 */
    double *poly_uv; /* max_poly×2 */
    unsigned *idx; /* max_poly */
    unsigned *tri; /* (max_poly-2)×3 */
} import_state;

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

/* ------------------------------------------------------------------ textures */

#define MAX_TEXTURE_FILE (1u << 30) /* bytes; stb_image takes an int length */

static const char *material_name(const struct aiMaterial *m, struct aiString *buf)
{
    if (m && aiGetMaterialString(m, AI_MATKEY_NAME, buf) == aiReturn_SUCCESS && buf->length > 0)
        return buf->data;
    return "(unnamed)";
}

/* Reads file `name` into *data (caller frees). Errors name `what`. */
static lrr_status read_whole(lrr_context *ctx, const char *name, const char *what,
                             unsigned char **data, size_t *len)
{
    *data = NULL;
    *len = 0;
    char eb[128];
    FILE *f = NULL;
    struct stat st;
    int e = lrr__open_regular(name, &f, &st);
    if (e)
        return lrr__error(ctx, LRR_ERR_IO, "%s: cannot open %s: %s", what, name,
                          e == LRR__NOT_REGULAR ? LRR__NOT_REGULAR_TEXT
                                                : lrr__errno_text(e, eb, sizeof eb));
    if (st.st_size <= 0 || (uint64_t)st.st_size > MAX_TEXTURE_FILE) {
        fclose(f);
        return lrr__error(ctx, LRR_ERR_FORMAT, "%s: %s has %lld bytes (not an image)", what,
                          name, (long long)st.st_size);
    }
    *len = (size_t)st.st_size;
    lrr_status rc = lrr__calloc(ctx, data, *len, 1, what);
    if (rc == LRR_OK && fread(*data, 1, *len, f) != *len) {
        lrr_aligned_free(*data);
        *data = NULL;
        rc = lrr__error(ctx, LRR_ERR_IO, "%s: cannot read %s", what, name);
    }
    fclose(f);
    return rc;
}

/* The texture of `type` on material i, decoded into s->tx (times factor; clamped below 1
 * for reflectance), or *index = LRR__NO_TEXTURE when it has none. A missing or corrupt
 * texture is an error naming the file and the material: a flat colour instead would change
 * the radiosity without anyone noticing. */
static lrr_status material_texture(import_state *s, unsigned i, enum aiTextureType type,
                                   const float factor[3], bool clamp, uint32_t *index)
{
    const struct aiMaterial *m = s->scene->mMaterials[i];
    *index = LRR__NO_TEXTURE;
    if (type == aiTextureType_DIFFUSE && aiGetMaterialTextureCount(m, type) == 0)
        type = aiTextureType_BASE_COLOR;
    if (aiGetMaterialTextureCount(m, type) == 0)
        return LRR_OK;
    struct aiString tp, mn;
    unsigned uv = 0;
    if (aiGetMaterialTexture(m, type, 0, &tp, NULL, &uv, NULL, NULL, NULL, NULL) !=
        aiReturn_SUCCESS)
        return LRR_OK;
    char what[1024 + 512];
    if (snprintf(what, sizeof what, "file %s: material '%s': %s texture '%s'", s->path,
             material_name(m, &mn), type == aiTextureType_EMISSIVE ? "emissive" : "diffuse",
             tp.data) >= (int)sizeof what)
        what[sizeof what - 1] = '\0'; /* a shortened message still names the file first */
    for (int c = 0; c < 3; c++)
        if (!(factor[c] >= 0) || !isfinite(factor[c]))
            return lrr__error(s->ctx, LRR_ERR_MATERIAL, "%s: its factor[%d] is %g", what, c,
                              (double)factor[c]);
    /* MTL -o/-s options; glTF KHR_texture_transform is refused earlier (gltf_ext.c) */
    struct aiUVTransform tr;
    if (aiGetMaterialUVTransform(m, _AI_MATKEY_UVTRANSFORM_BASE, type, 0, &tr) ==
            aiReturn_SUCCESS &&
        (tr.mTranslation.x != 0 || tr.mTranslation.y != 0 || tr.mScaling.x != 1 ||
         tr.mScaling.y != 1 || tr.mRotation != 0))
        return lrr__error(s->ctx, LRR_ERR_UNSUPPORTED,
                          "%s: has a UV transform (offset, scale or rotation), which lrr does "
                          "not apply (the texture would be misplaced)", what);
    if (s->mat_uv[i] != UINT_MAX && s->mat_uv[i] != uv)
        return lrr__error(s->ctx, LRR_ERR_UNSUPPORTED,
                          "%s: uses UV set %u, the material's other texture set %u (lrr "
                          "supports one per material)", what, uv, s->mat_uv[i]);
    s->mat_uv[i] = uv;
    if (!s->tx) {
        s->tx = lrr__zalloc(s->ctx, sizeof *s->tx);
        if (!s->tx)
            return lrr__error(s->ctx, LRR_ERR_NOMEM, "%s: cannot allocate", what);
    }
    lrr__scene_textures *tx = s->tx;
    /* at most two textures per material: the table never needs more than 2·materials */
    if (!tx->tex && (lrr__calloc(s->ctx, &tx->tex, s->scene->mNumMaterials, 2 * sizeof *tx->tex,
                                 "texture table")))
        return LRR_ERR_NOMEM;
    lrr__texture *t = &tx->tex[tx->n_tex];
    lrr_status st;
    const struct aiTexture *emb = NULL;
    if (tp.data[0] == '*') { /* embedded (GLB, data URIs): "*N" */
        char *end;
        unsigned long k = strtoul(tp.data + 1, &end, 10);
        if (*end || k >= s->scene->mNumTextures || !s->scene->mTextures ||
            !s->scene->mTextures[k] || !s->scene->mTextures[k]->pcData)
            return lrr__error(s->ctx, LRR_ERR_FORMAT, "%s: no such embedded texture (%u)",
                              what, s->scene->mNumTextures);
        emb = s->scene->mTextures[k];
    }
    if (emb && emb->mHeight == 0)
        st = lrr__texture_decode(s->ctx, (const unsigned char *)emb->pcData, emb->mWidth,
                                 factor, clamp, what, t, &tx->clamped_texels);
    else if (emb)
        st = lrr__texture_from_bgra(s->ctx, (const unsigned char *)emb->pcData, emb->mWidth,
                                    emb->mHeight, factor, clamp, what, t, &tx->clamped_texels);
    else {
        /* relative to the model's folder; MTL files written on Windows use '\' */
        char name[4096];
        const char *slash = strrchr(s->path, '/');
        int dir = tp.data[0] == '/' || !slash ? 0 : (int)(slash - s->path + 1);
        if (snprintf(name, sizeof name, "%.*s%s", dir, s->path, tp.data) >= (int)sizeof name)
            return lrr__error(s->ctx, LRR_ERR_IO, "%s: path too long", what);
        for (char *q = name + dir; *q; q++)
            if (*q == '\\')
                *q = '/';
        unsigned char *data;
        size_t len;
        if ((st = read_whole(s->ctx, name, what, &data, &len)))
            return st;
        st = lrr__texture_decode(s->ctx, data, len, factor, clamp, what, t,
                                 &tx->clamped_texels);
        lrr_aligned_free(data);
    }
    if (st != LRR_OK)
        return st;
    for (int a = 0; a < 2; a++) {
        int mode = aiTextureMapMode_Wrap;
        if (aiGetMaterialIntegerArray(m, a ? _AI_MATKEY_MAPPINGMODE_V_BASE
                                           : _AI_MATKEY_MAPPINGMODE_U_BASE,
                                      type, 0, &mode, NULL) != aiReturn_SUCCESS)
            mode = aiTextureMapMode_Wrap;
        t->wrap[a] = mode == aiTextureMapMode_Clamp    ? LRR__WRAP_CLAMP
                     : mode == aiTextureMapMode_Mirror ? LRR__WRAP_MIRROR
                                                       : LRR__WRAP_REPEAT;
    }
    *index = (uint32_t)tx->n_tex++;
    return LRR_OK;
}

/* Fills s->mat_rho and s->mat_em (×3 per material) following the rules in the header
 * comment, and the textures. */
static lrr_status read_materials(import_state *s)
{
    lrr_context *ctx = s->ctx;
    const char *path = s->path;
    const struct aiScene *scene = s->scene;
    bool ply = lrr__path_has_extension(path, "ply");
    bool gltf = lrr__path_has_extension(path, "gltf") || lrr__path_has_extension(path, "glb");
    float *strength = NULL;
    lrr_status st = LRR_OK;
    if (gltf && (st = lrr__gltf_emissive_strength(ctx, path, scene, &strength)))
        return st;
    for (unsigned i = 0; i < scene->mNumMaterials && st == LRR_OK; i++) {
        const struct aiMaterial *m = scene->mMaterials[i];
        float *r = s->mat_rho + 3 * (size_t)i, *e = s->mat_em + 3 * (size_t)i;
        r[0] = r[1] = r[2] = DEFAULT_RHO;
        e[0] = e[1] = e[2] = 0.0f;
        s->mat_rho_tex[i] = s->mat_em_tex[i] = LRR__NO_TEXTURE;
        s->mat_uv[i] = UINT_MAX;
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
        bool textured = aiGetMaterialTextureCount(m, aiTextureType_DIFFUSE) > 0 ||
                        aiGetMaterialTextureCount(m, aiTextureType_BASE_COLOR) > 0 ||
                        aiGetMaterialTextureCount(m, aiTextureType_EMISSIVE) > 0;
        /* assimp appends the glTF spec's default material (white, unnamed) last; a file's
         * own unnamed white non-emitting material would be rejected (rho = 1) anyway. */
        if (gltf && i + 1 == scene->mNumMaterials && !named && have_rho && !textured &&
            c[0] == 1.0f && c[1] == 1.0f && c[2] == 1.0f && ke[0] == 0.0f && ke[1] == 0.0f &&
            ke[2] == 0.0f)
            continue;
        if (have_rho)
            memcpy(r, c, sizeof c);
        float k = 1.0f;
        if (strength && strength[i] >= 0) /* KHR_materials_emissive_strength (gltf_ext.c) */
            k = strength[i];
        else if (aiGetMaterialFloatArray(m, AI_MATKEY_EMISSIVE_INTENSITY, &k, NULL) !=
                 aiReturn_SUCCESS)
            k = 1.0f;
        if (have_em)
            for (int j = 0; j < 3; j++)
                e[j] = ke[j] * k;
        float ef[3] = {e[0], e[1], e[2]};
        if (!have_em) /* OBJ map_Ke without Ke: the texture alone, times the strength */
            ef[0] = ef[1] = ef[2] = k;
        if ((st = material_texture(s, i, aiTextureType_DIFFUSE, r, true, &s->mat_rho_tex[i])) ||
            (st = material_texture(s, i, aiTextureType_EMISSIVE, ef, false,
                                   &s->mat_em_tex[i])))
            break;
    }
    free(strength);
    if (st != LRR_OK)
        return st;
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

/* Appends one triangle; uv (3 corners × 2, or NULL) places it in its material's textures,
 * whose mean over the triangle is its flat rho and E (what `lrr check` and the validation
 * see; lrr_scene_subpatches integrates each subpatch). */
static void emit(import_state *s, const double *a, const double *b, const double *c,
                 const double *const uv[3], unsigned mat, size_t face)
{
    size_t t = s->n_tri++;
    const double *q[3] = {a, b, c};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            s->vert[9 * t + 3 * i + j] = (float)q[i][j];
    memcpy(s->rho + 3 * t, s->mat_rho + 3 * (size_t)mat, 3 * sizeof *s->rho);
    memcpy(s->em + 3 * t, s->mat_em + 3 * (size_t)mat, 3 * sizeof *s->em);
    s->face_ids[t] = face;
    lrr__scene_textures *tx = s->tx;
    if (!tx)
        return;
    uint32_t rt = uv ? s->mat_rho_tex[mat] : LRR__NO_TEXTURE;
    uint32_t et = uv ? s->mat_em_tex[mat] : LRR__NO_TEXTURE;
    tx->rho_tex[t] = rt;
    tx->em_tex[t] = et;
    double u[6] = {0};
    for (int i = 0; i < 3 && uv; i++)
        for (int j = 0; j < 2; j++)
            u[2 * i + j] = uv[i][j];
    for (int i = 0; i < 6; i++)
        tx->uv[6 * t + i] = (float)u[i];
    double m[3];
    if (rt != LRR__NO_TEXTURE) {
        lrr__texture_mean(&tx->tex[rt], u, m);
        for (int k = 0; k < 3; k++)
            s->rho[3 * t + k] = fminf((float)m[k], LRR__RHO_MAX);
    }
    if (et != LRR__NO_TEXTURE) {
        lrr__texture_mean(&tx->tex[et], u, m);
        for (int k = 0; k < 3; k++)
            s->em[3 * t + k] = (float)m[k];
    }
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
        unsigned mat = mesh->mMaterialIndex;
        if (mat >= sc->mNumMaterials)
            return lrr__error(s->ctx, LRR_ERR_FORMAT,
                              "file %s: mesh %u uses material %u of %u", s->path, mi,
                              mat, sc->mNumMaterials);
        const struct aiVector3D *tc = NULL;
        if (s->mat_rho_tex[mat] != LRR__NO_TEXTURE || s->mat_em_tex[mat] != LRR__NO_TEXTURE) {
            unsigned ch = s->mat_uv[mat];
            tc = ch < AI_MAX_NUMBER_OF_TEXTURECOORDS ? mesh->mTextureCoords[ch] : NULL;
            if (!tc) {
                struct aiString mn;
                return lrr__error(s->ctx, LRR_ERR_FORMAT,
                                  "file %s: mesh %u has no texture coordinates (UV set %u) "
                                  "for the texture of its material '%s'",
                                  s->path, mi, ch, material_name(sc->mMaterials[mat], &mn));
            }
        }
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
                if (!tc)
                    continue;
                s->poly_uv[2 * (size_t)j] = tc[vi].x;
                s->poly_uv[2 * (size_t)j + 1] = tc[vi].y;
                if (!isfinite(s->poly_uv[2 * (size_t)j] + s->poly_uv[2 * (size_t)j + 1]))
                    return lrr__error(s->ctx, LRR_ERR_FORMAT,
                                      "file %s: face %zu: texture coordinate of vertex %u is "
                                      "not finite", s->path, id, vi);
            }
            lrr__triangulate(ni, s->poly, s->idx, s->tri);
            for (unsigned t = 0; t + 2 < ni; t++) {
                unsigned k[3] = {s->tri[3 * t], s->tri[3 * t + 1], s->tri[3 * t + 2]};
                if (flip) {
                    unsigned x = k[1];
                    k[1] = k[2];
                    k[2] = x;
                }
                const double *uv[3] = {s->poly_uv + 2 * (size_t)k[0],
                                       s->poly_uv + 2 * (size_t)k[1],
                                       s->poly_uv + 2 * (size_t)k[2]};
                emit(s, s->poly + 3 * (size_t)k[0], s->poly + 3 * (size_t)k[1],
                     s->poly + 3 * (size_t)k[2], tc ? uv : NULL, mat, id);
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
    lrr_aligned_free(s->mat_rho_tex);
    lrr_aligned_free(s->mat_em_tex);
    lrr_aligned_free(s->mat_uv);
    lrr__scene_textures_free(s->tx);
    lrr_aligned_free(s->face_base);
    lrr_aligned_free(s->vert);
    lrr_aligned_free(s->rho);
    lrr_aligned_free(s->em);
    lrr_aligned_free(s->face_ids);
    lrr_aligned_free(s->poly);
    lrr_aligned_free(s->poly_uv);
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
        (st = lrr__calloc(ctx, &s->mat_rho_tex, sc->mNumMaterials, sizeof(uint32_t),
                          "material textures")) ||
        (st = lrr__calloc(ctx, &s->mat_em_tex, sc->mNumMaterials, sizeof(uint32_t),
                          "material textures")) ||
        (st = lrr__calloc(ctx, &s->mat_uv, sc->mNumMaterials, sizeof(unsigned),
                          "material UV sets")) ||
        (st = read_materials(s)))
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
        (st = lrr__calloc(ctx, &s->poly_uv, max_poly, 2 * sizeof(double), "polygon scratch")) ||
        (st = lrr__calloc(ctx, &s->idx, max_poly, sizeof(unsigned), "polygon scratch")) ||
        (st = lrr__calloc(ctx, &s->tri, max_poly - 2, 3 * sizeof(unsigned),
                          "polygon scratch")))
        return st;
    if (s->tx && ((st = lrr__calloc(ctx, &s->tx->uv, n_tri, 6 * sizeof(float),
                                    "texture coordinates")) ||
                  (st = lrr__calloc(ctx, &s->tx->rho_tex, n_tri, sizeof(uint32_t),
                                    "triangle textures")) ||
                  (st = lrr__calloc(ctx, &s->tx->em_tex, n_tri, sizeof(uint32_t),
                                    "triangle textures"))))
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
    const struct aiScene *scene = NULL;
    lrr_status st = lrr__assimp_read(ctx, path, &scene);
    if (st != LRR_OK)
        return st;
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
    if (st == LRR_OK && s.tx) {
        lrr__scene_textures *tx = s.tx;
        s.tx = NULL;
        if ((st = lrr__scene_attach_textures(*out, s.n_tri, s.vert, tx))) {
            lrr_scene_destroy(*out);
            *out = NULL;
        }
    }
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
