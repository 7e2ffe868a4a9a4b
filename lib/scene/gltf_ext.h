/* glTF extensions that the installed assimp (5.2) does not read, read from the file's JSON
 * with cJSON (gltf_ext.c). Used by import.c only. */
#ifndef LRR_SCENE_GLTF_EXT_H
#define LRR_SCENE_GLTF_EXT_H

#include "scene/scene.h"

struct aiScene;

/* KHR_materials_emissive_strength of a .gltf or .glb file: *strength (malloc'd, free())
 * gets one float per assimp material of `scene`, the material's emissiveStrength, or -1
 * where it has none. Every material of the JSON is checked (a strength that is not a finite
 * number >= 0 is an error naming the material); assimp's materials are matched to the
 * JSON's by name (assimp 5.2 numbers them in the order meshes first use them, not the
 * file's), and a material with the extension whose name is missing or not unique is an
 * error. A base colour or emissive texture with KHR_texture_transform is refused
 * (LRR_ERR_UNSUPPORTED, naming the material). With scene = NULL the JSON is only checked (before assimp reads the file, so
 * that a bad value is reported by material, not as a file assimp cannot read). */
lrr_status lrr__gltf_emissive_strength(lrr_context *ctx, const char *path,
                                       const struct aiScene *scene, float **strength);
#endif
