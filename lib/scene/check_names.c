/* lrr_check_report_names: the names beside the scene check's raw triangles
 * (lrr_check_report's material, group and their names), so that `lrr check --fix` writes the repaired scene with the
 * file's material names and objects instead of numbered stand-ins.
 *
 * The file is read through assimp a second time (same call, no post-processing, as
 * import.c) and its node tree walked in import.c's order (fill_node: a node's meshes, then
 * its children; a face of N >= 3 corners gives N - 2 triangles). Each triangle's face
 * number must agree with the walk's; if anything disagrees the names are left out (NULL),
 * never guessed. Costs one more import (about as long as the first). */
#include "config.h"
#include "core/path.h"
#include "scene/assimp_io.h"
#include "scene/scene.h"

#ifdef LRR_HAVE_ASSIMP
#include <assimp/cimport.h>
#include <assimp/material.h>
#include <assimp/scene.h>
#endif

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifdef LRR_HAVE_ASSIMP
/* assimp's OBJ importer names the object of faces before any 'o'/'g' line so; the file has
 * no such group, so none is reported. */
static const char OBJ_DEFAULT_OBJECT[] = "defaultobject";

typedef struct names_walk {
    const struct aiScene *sc;
    size_t n, t;         /* triangles expected, triangles walked */
    const size_t *face;  /* the import's face numbers */
    size_t *face_base;   /* per mesh: its first face's number */
    size_t *material, *group;
    size_t n_groups;
    bool ok;
} names_walk;

static void walk_node(names_walk *w, const struct aiNode *node, unsigned depth)
{
    if (!w->ok || depth > 1024)
        return;
    const struct aiScene *sc = w->sc;
    size_t group = w->n_groups++;
    for (unsigned i = 0; i < node->mNumMeshes && w->ok; i++) {
        unsigned mi = node->mMeshes[i];
        const struct aiMesh *mesh = mi < sc->mNumMeshes ? sc->mMeshes[mi] : NULL;
        if (!mesh || mesh->mMaterialIndex >= sc->mNumMaterials) {
            w->ok = false;
            return;
        }
        for (unsigned f = 0; f < mesh->mNumFaces; f++) {
            unsigned ni = mesh->mFaces[f].mNumIndices;
            for (unsigned k = 0; k + 2 < ni; k++, w->t++) {
                if (w->t >= w->n || w->face[w->t] != w->face_base[mi] + f) {
                    w->ok = false;
                    return;
                }
                w->material[w->t] = mesh->mMaterialIndex;
                w->group[w->t] = group;
            }
        }
    }
    for (unsigned c = 0; c < node->mNumChildren; c++)
        if (node->mChildren[c])
            walk_node(w, node->mChildren[c], depth + 1);
}

/* The nodes' names in walk order (group numbers), for names_copy. */
static void node_names(const struct aiNode *node, const char **out, size_t *k, unsigned depth)
{
    if (depth > 1024)
        return;
    const char *name = node->mName.data;
    out[(*k)++] = strcmp(name, OBJ_DEFAULT_OBJECT) == 0 ? "" : name;
    for (unsigned c = 0; c < node->mNumChildren; c++)
        if (node->mChildren[c])
            node_names(node->mChildren[c], out, k, depth + 1);
}

/* *names = count pointers into one block holding copies of src (freed together by
 * lrr__check_names_free). */
static lrr_status names_copy(lrr_context *ctx, const char *const *src, size_t count,
                             char ***names)
{
    size_t bytes = 0;
    for (size_t i = 0; i < count; i++)
        bytes += strlen(src[i]) + 1;
    size_t head;
    if (!lrr__mul_size(count + 1, sizeof(char *), &head) || bytes > SIZE_MAX - head)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "scene check: names: size overflows");
    char **out = lrr__alloc(ctx, head + bytes);
    if (!out)
        return lrr__error(ctx, LRR_ERR_NOMEM, "scene check: out of memory for names");
    char *p = (char *)(out + count + 1);
    for (size_t i = 0; i < count; i++) {
        size_t len = strlen(src[i]) + 1;
        memcpy(p, src[i], len);
        out[i] = p;
        p += len;
    }
    out[count] = NULL;
    *names = out;
    return LRR_OK;
}

static size_t count_nodes(const struct aiNode *node, unsigned depth)
{
    size_t k = 1;
    if (depth > 1024)
        return k;
    for (unsigned c = 0; c < node->mNumChildren; c++)
        if (node->mChildren[c])
            k += count_nodes(node->mChildren[c], depth + 1);
    return k;
}

/* Fills the report's names from the scene read as assimp sees it (see the top). */
static lrr_status names_from_scene(lrr_context *ctx, const struct aiScene *sc,
                                   lrr_check_report *r)
{
    names_walk w = {.sc = sc, .n = r->triangles, .face = r->face, .ok = true};
    lrr_status st;
    const char **tmp = NULL;
    struct aiString *strs = NULL;
    if ((st = lrr__calloc(ctx, &w.face_base, sc->mNumMeshes, sizeof(size_t), "check names")) ||
        (st = lrr__calloc(ctx, &w.material, r->triangles, sizeof(size_t), "check names")) ||
        (st = lrr__calloc(ctx, &w.group, r->triangles, sizeof(size_t), "check names")))
        goto done;
    size_t base = 0;
    for (unsigned m = 0; m < sc->mNumMeshes; m++) {
        w.face_base[m] = base;
        base += sc->mMeshes[m] ? sc->mMeshes[m]->mNumFaces : 0;
    }
    walk_node(&w, sc->mRootNode, 0);
    if (!w.ok || w.t != r->triangles)
        goto done; /* not the walk import.c made: no names */
    size_t n_nodes = count_nodes(sc->mRootNode, 0), k = 0;
    size_t n_tmp = n_nodes > sc->mNumMaterials ? n_nodes : sc->mNumMaterials;
    if ((st = lrr__calloc(ctx, &tmp, n_tmp, sizeof(char *), "check names")))
        goto done;
    /* aiString is a fixed buffer inside the material: copied out here */
    if ((st = lrr__calloc(ctx, &strs, sc->mNumMaterials, sizeof *strs, "check names")))
        goto done;
    for (unsigned m = 0; m < sc->mNumMaterials; m++) {
        if (!sc->mMaterials[m] ||
            aiGetMaterialString(sc->mMaterials[m], AI_MATKEY_NAME, &strs[m]) != aiReturn_SUCCESS)
            strs[m].length = 0;
        strs[m].data[strs[m].length < MAXLEN ? strs[m].length : MAXLEN - 1] = '\0';
        tmp[m] = strs[m].data;
    }
    st = names_copy(ctx, tmp, sc->mNumMaterials, &r->material_names);
    if (st)
        goto done;
    node_names(sc->mRootNode, tmp, &k, 0);
    if ((st = names_copy(ctx, tmp, k, &r->group_names)))
        goto done;
    r->n_materials = sc->mNumMaterials;
    r->n_groups = k;
    r->material = w.material;
    r->group = w.group;
    w.material = w.group = NULL;
done:
    free(tmp);
    free(strs);
    free(w.face_base);
    free(w.material);
    free(w.group);
    return st;
}

lrr_status lrr_check_report_names(lrr_context *ctx, const char *path, lrr_check_report *r)
{
    lrr__check_names_free(r);
    if (lrr__stat_regular(path, NULL) != 0)
        return LRR_OK; /* a built-in scene (lrr_scene_check read it): no names; a FIFO or
                          device lrr_scene_check refused would block assimp */
    char refused[512];
    const struct aiScene *sc = lrr__assimp_import(path, 0, refused, sizeof refused);
    if (!sc || !sc->mRootNode || (sc->mNumMaterials && !sc->mMaterials) ||
        (sc->mNumMeshes && !sc->mMeshes)) {
        aiReleaseImport(sc);
        return LRR_OK; /* read once already; without names the repair is still written */
    }
    lrr_status status = names_from_scene(ctx, sc, r);
    aiReleaseImport(sc);
    if (status != LRR_OK)
        lrr__check_names_free(r);
    return status;
}

#else /* !LRR_HAVE_ASSIMP */

/* configure --without-assimp: scene files cannot be read, so there are no names to keep;
 * --fix then writes materials m0… (as for a built-in scene). */
lrr_status lrr_check_report_names(lrr_context *ctx, const char *path, lrr_check_report *r)
{
    (void)ctx, (void)path;
    lrr__check_names_free(r);
    return LRR_OK;
}
#endif

void lrr__check_names_free(lrr_check_report *r)
{
    free(r->material);
    free(r->group);
    free(r->material_names);
    free(r->group_names);
    r->material = r->group = NULL;
    r->material_names = r->group_names = NULL;
    r->n_materials = r->n_groups = 0;
}
