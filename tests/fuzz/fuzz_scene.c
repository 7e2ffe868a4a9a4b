/*
 * Fuzz target: scene import and validation (lrr_scene_load through assimp), subdivision with
 * small limits (lrr_scene_subdivide), the subpatch geometry, and the scene doctor of
 * `lrr check` (lrr_scene_check) on the same file.
 *
 * The input's first bytes pick the format, as a file's extension would:
 *   "glTF"                    binary glTF  (scene.glb)
 *   '{' after white space     glTF JSON    (scene.gltf; buffers as data: URIs)
 *   "ply"                     PLY          (scene.ply)
 *   anything else             OBJ          (scene.obj); a line "#MTL" splits it: what follows
 *                             is written to scene.mtl, for "mtllib scene.mtl"
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "lrr.h"

/* assimp's parsers are slow on large inputs and the interesting structure is small */
#define MAX_INPUT (64u << 10)
#define MTL_MARK "\n#MTL\n"

static const char *format_of(const uint8_t *data, size_t size)
{
    if (size >= 4 && memcmp(data, "glTF", 4) == 0)
        return "scene.glb";
    if (size >= 3 && memcmp(data, "ply", 3) == 0)
        return "scene.ply";
    size_t i = 0;
    while (i < size && (data[i] == ' ' || data[i] == '\t' || data[i] == '\r' || data[i] == '\n'))
        i++;
    if (i < size && data[i] == '{')
        return "scene.gltf";
    return "scene.obj";
}

static const uint8_t *find_mark(const uint8_t *data, size_t size)
{
    const size_t len = sizeof MTL_MARK - 1;
    for (size_t i = 0; i + len <= size; i++)
        if (memcmp(data + i, MTL_MARK, len) == 0)
            return data + i;
    return NULL;
}

/* Subdivides with a limit that keeps the subpatch count small whatever the scene (at most
 * about 4·32 + n_tri patches, 4 subpatches each) and checks the geometry it gives. */
static void subdivide(lrr_scene *scene)
{
    lrr_scene_info info;
    lrr_scene_get_info(scene, &info, sizeof info);
    if (info.triangles == 0)
        fuzz_fail("a loaded scene with %zu triangles", info.triangles);
    if (!isfinite(info.area) || info.area <= 0)
        fuzz_fail("a loaded scene of area %g", info.area);
    lrr_subdivision sub = {.max_patch_area = 0, .target_patches = 32, .levels = 1};
    lrr_status st = lrr_scene_subdivide(scene, &sub);
    if (st != LRR_OK)
        return; /* an error with a message is fine (e.g. subpatches too small for float) */
    lrr_scene_get_info(scene, &info, sizeof info);
    size_t n = info.subpatches;
    if (n == 0 || n != info.patches * info.d || info.d != 4)
        fuzz_fail("subdivision gave n = %zu, k = %zu, d = %zu", n, info.patches, info.d);
    float *centre = malloc(n * 3 * sizeof *centre), *normal = malloc(n * 3 * sizeof *normal);
    float *area = malloc(n * sizeof *area);
    if (!centre || !normal || !area)
        fuzz_fail("out of memory for %zu subpatches", n);
    if (lrr_scene_subpatches(scene, centre, normal, area, NULL, NULL) != LRR_OK)
        fuzz_fail("lrr_scene_subpatches failed on a subdivided scene");
    for (size_t i = 0; i < n; i++) {
        if (!isfinite(area[i]) || area[i] < 0)
            fuzz_fail("subpatch %zu has area %g", i, (double)area[i]);
        for (int c = 0; c < 3; c++)
            if (!isfinite(centre[3 * i + c]) || !isfinite(normal[3 * i + c]))
                fuzz_fail("subpatch %zu has a non-finite centre or normal", i);
    }
    static const double bary[][2] = {{0, 0}, {1, 0}, {0, 1}, {0.25, 0.25}, {0.5, 0.5}};
    for (size_t t = 0; t < info.triangles; t++)
        for (size_t j = 0; j < sizeof bary / sizeof bary[0]; j++) {
            size_t s = lrr_scene_subpatch_at(scene, t, bary[j][0], bary[j][1]);
            if (s >= n)
                fuzz_fail("triangle %zu, (%g, %g): subpatch %zu of %zu", t, bary[j][0],
                          bary[j][1], s, n);
        }
    free(area);
    free(normal);
    free(centre);
}

static void check(lrr_context *ctx, const char *path)
{
    lrr_check_report *r = NULL;
    lrr_status st = lrr_scene_check(ctx, path, &r);
    if (st != LRR_OK) {
        if (r)
            fuzz_fail("lrr_scene_check failed but returned a report");
        return;
    }
    for (size_t t = 0; t < r->triangles; t++)
        if (r->fix[t] > 2)
            fuzz_fail("repair flag %u of triangle %zu", r->fix[t], t);
    size_t counted = r->degenerate + r->intersecting_pairs + r->coplanar_overlaps +
                     r->contacts + r->open_edges;
    if (r->n_findings < (counted ? 1 : 0))
        fuzz_fail("%zu findings for %zu counted problems", r->n_findings, counted);
    lrr_check_report_destroy(r);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    fuzz_init();
    if (size > MAX_INPUT)
        return 0;
    const char *name = format_of(data, size);
    size_t main_size = size;
    int mtl = 0;
    if (strcmp(name, "scene.obj") == 0) {
        const uint8_t *mark = find_mark(data, size);
        if (mark) {
            main_size = (size_t)(mark - data) + 1;
            const uint8_t *m = mark + sizeof MTL_MARK - 1;
            fuzz_write("scene.mtl", m, size - (size_t)(m - data));
            mtl = 1;
        }
    }
    const char *path = fuzz_write(name, data, main_size);

    lrr_context *ctx = NULL;
    if (lrr_context_create(&ctx) != LRR_OK)
        fuzz_fail("lrr_context_create failed");
    lrr_scene *scene = NULL;
    lrr_status st = lrr_scene_load(ctx, path, &scene);
    char msg[512];
    lrr_status recorded = lrr_context_last_error(ctx, msg, sizeof msg);
    if (st == LRR_OK) {
        if (!scene)
            fuzz_fail("lrr_scene_load returned LRR_OK without a scene");
        subdivide(scene);
    } else if (scene || recorded == LRR_OK || !msg[0]) {
        fuzz_fail("lrr_scene_load failed (%s) %s", lrr_strerror(st),
                  scene ? "but returned a scene" : "without a message");
    }
    lrr_scene_destroy(scene);
    check(ctx, path);
    lrr_context_destroy(ctx);
    fuzz_remove(name);
    if (mtl)
        fuzz_remove("scene.mtl");
    return 0;
}
