/* KHR_materials_emissive_strength, read from the glTF JSON ourselves: assimp 5.2 ignores it,
 * and Blender writes it whenever an emission strength exceeds 1 (emissiveFactor is limited
 * to [0,1]), so without it every such lamp would be dimmer than modelled. The JSON is a
 * .gltf file, or a .glb's first chunk (type JSON, glTF 2.0 binary container). */
#include "config.h"
#include "core/path.h"
#include "scene/gltf_ext.h"

#ifdef LRR_HAVE_ASSIMP /* only assimp's import reads glTF (configure --without-assimp) */
#include <assimp/material.h>
#include <assimp/scene.h>

#include <cJSON.h>

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#define MAX_JSON (256u << 20) /* bytes: far beyond any real scene's JSON */
#define GLB_MAGIC 0x46546C67u /* "glTF" */
#define GLB_JSON 0x4E4F534Au  /* "JSON" */

static uint32_t le32(const unsigned char *p)
{
    return p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

/* The JSON text of path (NUL-terminated, malloc'd) and its length. */
static lrr_status read_json(lrr_context *ctx, const char *path, char **out)
{
    *out = NULL;
    char eb[128];
    FILE *f = NULL;
    int e = lrr__open_regular(path, &f, NULL);
    if (e == LRR__NOT_REGULAR)
        return lrr__error(ctx, LRR_ERR_IO, "file %s: " LRR__NOT_REGULAR_TEXT, path);
    if (e)
        return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot open: %s", path,
                          lrr__errno_text(e, eb, sizeof eb));
    const char *dot = strrchr(path, '.');
    bool glb = dot && strcasecmp(dot, ".glb") == 0;
    long start = 0;
    size_t len;
    if (glb) {
        unsigned char h[20];
        if (fread(h, 1, sizeof h, f) != sizeof h || le32(h) != GLB_MAGIC ||
            le32(h + 16) != GLB_JSON) {
            fclose(f);
            return lrr__error(ctx, LRR_ERR_FORMAT,
                              "file %s: not a binary glTF (no JSON chunk at its start)", path);
        }
        start = 20;
        len = le32(h + 12);
    } else {
        if (fseek(f, 0, SEEK_END) != 0 || (start = ftell(f)) < 0) {
            fclose(f);
            return lrr__error(ctx, LRR_ERR_IO, "file %s: cannot size it", path);
        }
        len = (size_t)start;
        start = 0;
    }
    if (len > MAX_JSON || fseek(f, start, SEEK_SET) != 0) {
        fclose(f);
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: JSON of %zu bytes is not usable", path,
                          len);
    }
    char *text = lrr__alloc(ctx, len + 1);
    if (!text) {
        fclose(f);
        return lrr__error(ctx, LRR_ERR_NOMEM, "file %s: cannot allocate %zu bytes of JSON",
                          path, len + 1);
    }
    size_t got = fread(text, 1, len, f);
    fclose(f);
    if (got != len) {
        free(text);
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: JSON truncated (%zu of %zu bytes)",
                          path, got, len);
    }
    text[len] = '\0';
    *out = text;
    return LRR_OK;
}

/* JSON has no NaN or Infinity, but Python's json module writes them: quote them (outside
 * strings), so that a material holding one is named by the checks below instead of the
 * whole file failing to parse. Returns a new NUL-terminated text (malloc'd) or NULL. */
static char *quote_non_numbers(lrr_context *ctx, const char *in, size_t len)
{
    static const char *const words[3] = {"-Infinity", "Infinity", "NaN"};
    char *out = len <= MAX_JSON ? lrr__alloc(ctx, 2 * len + 1) : NULL;
    if (!out)
        return NULL;
    size_t o = 0;
    bool str = false;
    for (size_t i = 0; i < len;) {
        char c = in[i];
        if (str) {
            out[o++] = in[i++];
            if (c == '\\' && i < len)
                out[o++] = in[i++];
            else if (c == '"')
                str = false;
            continue;
        }
        size_t w = 0;
        for (int k = 0; k < 3 && !w; k++)
            if (strncmp(in + i, words[k], strlen(words[k])) == 0)
                w = strlen(words[k]);
        if (w) {
            out[o++] = '"';
            memcpy(out + o, in + i, w);
            o += w;
            out[o++] = '"';
            i += w;
            continue;
        }
        str = c == '"';
        out[o++] = in[i++];
    }
    out[o] = '\0';
    return out;
}

/* The strength of JSON material j (-1 without the extension), checked. */
static lrr_status strength_of(lrr_context *ctx, const char *path, const cJSON *mat, int j,
                              double *out)
{
    *out = -1;
    const cJSON *ext = cJSON_GetObjectItemCaseSensitive(mat, "extensions");
    const cJSON *k = cJSON_GetObjectItemCaseSensitive(ext, "KHR_materials_emissive_strength");
    if (!k)
        return LRR_OK;
    const cJSON *name = cJSON_GetObjectItemCaseSensitive(mat, "name");
    const char *nm = cJSON_IsString(name) ? name->valuestring : "(unnamed)";
    const cJSON *v = cJSON_GetObjectItemCaseSensitive(k, "emissiveStrength");
    if (!v) { /* the extension's default */
        *out = 1;
        return LRR_OK;
    }
    if (!cJSON_IsNumber(v) || !(v->valuedouble >= 0) || !isfinite(v->valuedouble) ||
        v->valuedouble > 3.4e38) {
        char num[64];
        snprintf(num, sizeof num, "%g", v->valuedouble);
        char *txt = cJSON_IsNumber(v) ? NULL : cJSON_PrintUnformatted(v);
        lrr_status st = lrr__error(
            ctx, LRR_ERR_MATERIAL,
            "file %s: material %d '%s': KHR_materials_emissive_strength emissiveStrength = %s "
            "(must be a finite number >= 0)",
            path, j, nm, txt ? txt : cJSON_IsNumber(v) ? num : "?");
        free(txt);
        return st;
    }
    *out = v->valuedouble;
    return LRR_OK;
}

/* KHR_texture_transform on a texture lrr integrates would move the texture on the surface;
 * assimp 5.2 reads it into a UV transform we do not apply, so refuse rather than place the
 * texture wrongly. */
static lrr_status check_transform(lrr_context *ctx, const char *path, const cJSON *mat, int j)
{
    const cJSON *pbr = cJSON_GetObjectItemCaseSensitive(mat, "pbrMetallicRoughness");
    const cJSON *info[2] = {cJSON_GetObjectItemCaseSensitive(pbr, "baseColorTexture"),
                            cJSON_GetObjectItemCaseSensitive(mat, "emissiveTexture")};
    for (int k = 0; k < 2; k++) {
        const cJSON *ext = cJSON_GetObjectItemCaseSensitive(info[k], "extensions");
        if (!cJSON_GetObjectItemCaseSensitive(ext, "KHR_texture_transform"))
            continue;
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(mat, "name");
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "file %s: material %d '%s': its %s uses KHR_texture_transform, which "
                          "lrr does not apply (the texture would be misplaced)",
                          path, j, cJSON_IsString(name) ? name->valuestring : "(unnamed)",
                          k ? "emissiveTexture" : "baseColorTexture");
    }
    return LRR_OK;
}

lrr_status lrr__gltf_emissive_strength(lrr_context *ctx, const char *path,
                                       const struct aiScene *scene, float **strength)
{
    *strength = NULL;
    char *text;
    lrr_status st = read_json(ctx, path, &text);
    if (st != LRR_OK)
        return st;
    char *quoted = quote_non_numbers(ctx, text, strlen(text));
    free(text);
    if (!quoted)
        return lrr__error(ctx, LRR_ERR_NOMEM, "file %s: cannot allocate a copy of its JSON",
                          path);
    const char *end = NULL;
    cJSON *doc = cJSON_ParseWithOpts(quoted, &end, 0);
    if (!doc) {
        size_t at = end && end >= quoted ? (size_t)(end - quoted) : 0;
        free(quoted);
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: JSON does not parse (near byte %zu)",
                          path, at);
    }
    free(quoted);
    unsigned n_mat = scene ? scene->mNumMaterials : 0;
    float *s = lrr__alloc(ctx, (n_mat + (size_t)1) * sizeof *s);
    if (!s) {
        cJSON_Delete(doc);
        return lrr__error(ctx, LRR_ERR_NOMEM, "file %s: cannot allocate", path);
    }
    for (unsigned i = 0; i < n_mat; i++)
        s[i] = -1;
    const cJSON *mats = cJSON_GetObjectItemCaseSensitive(doc, "materials");
    int n = cJSON_IsArray(mats) ? cJSON_GetArraySize(mats) : 0;
    for (int j = 0; j < n && st == LRR_OK; j++) {
        const cJSON *mat = cJSON_GetArrayItem(mats, j);
        double k;
        if ((st = check_transform(ctx, path, mat, j)) ||
            (st = strength_of(ctx, path, mat, j, &k)) || k < 0)
            continue;
        const cJSON *name = cJSON_GetObjectItemCaseSensitive(mat, "name");
        const char *nm = cJSON_IsString(name) ? name->valuestring : NULL;
        for (int o = 0; nm && o < n; o++) {
            const cJSON *other = cJSON_GetObjectItemCaseSensitive(cJSON_GetArrayItem(mats, o),
                                                                  "name");
            if (o != j && cJSON_IsString(other) && strcmp(other->valuestring, nm) == 0)
                nm = NULL;
        }
        if (!nm) {
            st = lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                            "file %s: material %d has KHR_materials_emissive_strength but no "
                            "unique name, which lrr needs to match it to assimp's materials",
                            path, j);
            break;
        }
        for (unsigned i = 0; i < n_mat; i++) {
            struct aiString an;
            if (scene->mMaterials[i] &&
                aiGetMaterialString(scene->mMaterials[i], AI_MATKEY_NAME, &an) ==
                    aiReturn_SUCCESS &&
                strcmp(an.data, nm) == 0)
                s[i] = (float)k;
        }
    }
    cJSON_Delete(doc);
    if (st != LRR_OK) {
        free(s);
        return st;
    }
    *strength = s;
    return LRR_OK;
}
#endif /* LRR_HAVE_ASSIMP */
