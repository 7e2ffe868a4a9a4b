/* assimp reading through lrr__open_regular (core/path.h), for import.c and check_names.c:
 * assimp opens the scene file and then the files it names (an OBJ's .mtl, a glTF's .bin
 * buffers) with its own fopen, which blocks on a FIFO (`mkfifo q.mtl` hung
 * `lrr info q.obj`). Internal to lib/scene. */
#ifndef LRR_SCENE_ASSIMP_IO_H
#define LRR_SCENE_ASSIMP_IO_H

#include <stddef.h>

#include "lrr.h"

struct aiScene;

/* Reads path with assimp after the checks assimp lacks: a regular file (its own message for
 * a missing one is vague, and it would block on a FIFO), a strict PLY header
 * (lrr__ply_check) where assimp will read PLY, the glTF emissive-strength extension, then
 * lrr__assimp_import, refusing any FIFO, socket or device it met. LRR_OK with *out
 * (aiReleaseImport it), or the error with *out = NULL. */
lrr_status lrr__assimp_read(lrr_context *ctx, const char *path, const struct aiScene **out);

/* aiImportFile(path, flags) with every file assimp opens checked first. A FIFO, socket or
 * device is not opened: assimp sees it as missing (and may go on without a .mtl), so the
 * first such name is copied into refused (len bytes, "" when none) for the caller to refuse
 * the import. Returns what aiImportFile returns (aiReleaseImport it). */
const struct aiScene *lrr__assimp_import(const char *path, unsigned flags, char *refused,
                                         size_t len);

#endif /* LRR_SCENE_ASSIMP_IO_H */
