/*
 * lrr — Low-Rank Radiosity.
 *
 * Solves the radiosity equation (I - R F) B = E for diffuse scenes:
 *   n subpatches, R = diag(rho) per colour channel, F the form factors.
 * Preprocess once (hemicube form factors F̄, n×k, and the k×k Sherman–Morrison–Woodbury
 * matrices M_c), then solve for any emission E with one pass over F̄:
 *   B_c = E_c + rho_c ∘ ( F̄ · (M_c · (Vᵀ E_c)) ).
 *
 * Conventions
 *   - Every function returns lrr_status (LRR_OK = 0) unless it is a query or a destroy.
 *   - Handles are opaque. Every create has a destroy; destroy(NULL) does nothing.
 *   - Objects hold a reference to their context; destroy them in any order.
 *   - Colour arrays are row-major n×3 (RGB interleaved, ld = 3) unless stated.
 *   - Radiosity and emission are in W/m² (any consistent unit); lengths in scene units.
 *   - The library never prints, never exits, keeps no mutable global state.
 *   - Structs that may grow (ABI 1 on): an option struct given to lrr starts with
 *     `size_t size`, set by its lrr_*_defaults() (inline below, so it is the caller's
 *     sizeof): lrr reads the fields the size covers, refuses set bytes beyond what it knows
 *     (LRR_ERR_UNSUPPORTED: the caller was built against a newer lrr) and takes size = 0 as
 *     this first layout, so designated initialisers keep working. A struct lrr fills in is
 *     passed with its size (sizeof info): lrr writes what fits and zeroes the rest.
 */
#ifndef LRR_H
#define LRR_H

#include <stddef.h>
#include <stdint.h>
#include <string.h> /* memset in the inline lrr_*_defaults() */
#include "lrr_version.h"

#ifdef __cplusplus
extern "C" {
#endif

#if defined(_WIN32) && defined(LRR_BUILDING_DLL)
#define LRR_API __declspec(dllexport)
#elif defined(__GNUC__) && __GNUC__ >= 4
#define LRR_API __attribute__((visibility("default")))
#else
#define LRR_API
#endif

#if defined(__GNUC__)
#define LRR_NODISCARD __attribute__((warn_unused_result))
#define LRR_NONNULL(...) __attribute__((nonnull(__VA_ARGS__)))
#else
#define LRR_NODISCARD
#define LRR_NONNULL(...)
#endif

/* ---------------------------------------------------------------- status codes */
typedef enum lrr_status {
    LRR_OK = 0,
    LRR_NOT_CONVERGED = 1,   /* an iteration stopped before its tolerance (not a hard error) */
    LRR_ERR_INVALID_ARG = 2, /* NULL pointer, bad option value, wrong name */
    LRR_ERR_NOMEM = 3,       /* allocation failed */
    LRR_ERR_OVERFLOW = 4,    /* a size computation would overflow size_t */
    LRR_ERR_IO = 5,          /* open/read/write/rename failed (errno in the message) */
    LRR_ERR_FORMAT = 6,      /* a scene/image file could not be parsed or imported */
    LRR_ERR_CORRUPT = 7,     /* an .lrr file is truncated or fails a checksum */
    LRR_ERR_VERSION = 8,     /* an .lrr file of another version, endianness or kind */
    LRR_ERR_GEOMETRY = 9,    /* NaN/Inf coordinates, nothing left after removing degenerates */
    LRR_ERR_MATERIAL = 10,   /* reflectance outside [0,1), negative or non-finite emission */
    LRR_ERR_EMPTY = 11,      /* a scene without triangles */
    LRR_ERR_SINGULAR = 12,   /* I - Vᵀ diag(rho) F̄ could not be factorised */
    LRR_ERR_UNSUPPORTED = 13,/* a backend or feature not built into this library */
    LRR_ERR_CANCELLED = 14,  /* the progress callback asked to stop */
    LRR_ERR_DIM = 15,        /* array sizes do not agree */
    LRR_ERR_BUDGET = 16      /* the work needs more memory than the given budget allows */
} lrr_status;

/* A static, human-readable name for a status code. Thread safety: any thread. */
LRR_API const char *lrr_strerror(lrr_status status);

/* ---------------------------------------------------------------- version */
/* The library's version string, e.g. "0.1.0"; compare with LRR_VERSION_STRING to check that
 * header and library agree. Thread safety: any thread. */
LRR_API const char *lrr_version_string(void);
LRR_API unsigned lrr_version(void); /* MAJOR*10000 + MINOR*100 + PATCH */
/* The optional features built into this library (configure --without-X), space-separated
 * in this order: "assimp" (scene files, lrr_scene_load), "cgal" (lrr_scene_check),
 * "openexr" (.exr probes, lrr_render_exr), "opencl" (LRR_BACKEND_OPENCL; a device is still
 * needed at run time); "" when none. A function that needs a feature not built returns
 * LRR_ERR_UNSUPPORTED, "lrr was built without X". Later versions may add names. Static
 * string; thread safety: any thread. */
LRR_API const char *lrr_features(void);

/* ---------------------------------------------------------------- context */
typedef struct lrr_context lrr_context;

/* Called once per error, in the thread that hit it, with the code and a message naming what
 * and where (file, face, value). */
typedef void (*lrr_error_fn)(void *user, lrr_status status, const char *message);

/* Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_context_create(lrr_context **out) LRR_NONNULL(1);
/* Drops the caller's reference; the context lives until its last object is destroyed. */
LRR_API void lrr_context_destroy(lrr_context *ctx);
/* fn = NULL turns the callback off. Thread safety: serialise with other calls on ctx. */
LRR_API void lrr_context_set_error_callback(lrr_context *ctx, lrr_error_fn fn, void *user)
    LRR_NONNULL(1);
/* Returns the first error recorded on ctx since the last call (LRR_OK if none), copies its
 * message into msg (always NUL-terminated when msg_len > 0) and clears it.
 * Thread safety: any thread (the record is shared by the threads using ctx). */
LRR_API lrr_status lrr_context_last_error(lrr_context *ctx, char *msg, size_t msg_len)
    LRR_NONNULL(1);

/* ---------------------------------------------------------------- scene */
typedef struct lrr_scene lrr_scene;

/* Imports OBJ(+MTL: Kd = reflectance, Ke = emission), PLY or glTF 2.0 through assimp
 * (LRR_ERR_UNSUPPORTED naming the file when built without it: lrr_features()).
 * Triangles are one-sided: the front is the side from which the vertices run
 * counter-clockwise. Zero-area triangles are skipped and counted (see lrr_scene_info);
 * NaN/Inf coordinates, reflectance outside [0,1), negative emission and an empty scene are
 * errors naming the file and face. Diffuse and emissive textures (map_Kd, map_Ke;
 * baseColorTexture, emissiveTexture; files relative to the scene, or embedded) multiply
 * the colours: each subpatch gets the texture's mean over it (linear: 8-bit images are
 * sRGB-decoded; reflectance clamped below 1, counted in lrr_scene_info.clamped_texels); a
 * missing or corrupt texture is an error naming the file and material. glTF
 * KHR_materials_emissive_strength multiplies the emission. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_scene_load(lrr_context *ctx, const char *path,
                                                lrr_scene **out) LRR_NONNULL(1, 2, 3);

/* The Cornell box (published measurements, millimetres, 36 triangles, light 0.05 mm below
 * the ceiling). closed != 0 seals the open front with a white wall. */
LRR_API LRR_NODISCARD lrr_status lrr_scene_cornell_box(lrr_context *ctx, int closed,
                                                       lrr_scene **out) LRR_NONNULL(1, 3);

/* "cornell" or "cornell-closed"; LRR_ERR_INVALID_ARG for other names. */
LRR_API LRR_NODISCARD lrr_status lrr_scene_builtin(lrr_context *ctx, const char *name,
                                                   lrr_scene **out) LRR_NONNULL(1, 2, 3);

/* A scene from arrays: vertices n_triangles×9 (x0 y0 z0 x1 … z2, counter-clockwise front),
 * rho and emission n_triangles×3. Same validation as lrr_scene_load; `source` names the
 * origin in error messages (may be NULL). */
LRR_API LRR_NODISCARD lrr_status lrr_scene_create(lrr_context *ctx, size_t n_triangles,
                                                  const float *vertices, const float *rho,
                                                  const float *emission, const char *source,
                                                  lrr_scene **out) LRR_NONNULL(1, 3, 4, 5, 7);
LRR_API void lrr_scene_destroy(lrr_scene *scene);

/* Subdivision: each input triangle is split 4-way at its edge midpoints until every piece
 * (a patch) has area <= max_patch_area; with target_patches > 0 instead, the threshold that
 * gives the patch count closest to it is chosen. Each patch is then split `levels` more times
 * into d = 4^levels subpatches, stored patch-major (subpatch s of patch p is p·d + s). */
typedef struct lrr_subdivision {
    size_t size;             /* sizeof(lrr_subdivision) (lrr_subdivision_defaults) or 0 */
    double max_patch_area;   /* scene units²; 0 = no limit (one patch per triangle) */
    size_t target_patches;   /* if > 0, overrides max_patch_area */
    unsigned levels;         /* 0..10; d = 4^levels */
} lrr_subdivision;
static inline lrr_subdivision lrr_subdivision_defaults(void)
{
    lrr_subdivision s;
    memset(&s, 0, sizeof s);
    s.size = sizeof s;
    return s;
}

/* Thread safety: one thread per object. */
LRR_API LRR_NODISCARD lrr_status lrr_scene_subdivide(lrr_scene *scene,
                                                     const lrr_subdivision *opts)
    LRR_NONNULL(1, 2);

typedef struct lrr_scene_info {
    size_t triangles;        /* input triangles kept */
    size_t skipped;          /* zero-area triangles removed on input */
    size_t patches;          /* k (0 before lrr_scene_subdivide) */
    size_t subpatches;       /* n = k·d */
    size_t d;                /* subpatches per patch */
    size_t emitters;         /* input triangles with non-zero emission */
    double area;             /* total area, scene units² */
    double max_patch_area;   /* the threshold in force */
    double bounds_min[3], bounds_max[3];
    size_t textures;         /* decoded material textures (reflectance and emission) */
    size_t clamped_texels;   /* reflectance texels with a channel × factor >= 1 (clamped
                                just below 1) */
} lrr_scene_info;

/* Thread safety: any thread (read only). */
/* info_size = sizeof *info (see Conventions). */
LRR_API void lrr_scene_get_info(const lrr_scene *scene, lrr_scene_info *info, size_t info_size)
    LRR_NONNULL(1, 2);

/* The scene doctor (`lrr check`), with exact predicates (CGAL). `name` is a scene file (read
 * raw: zero-area triangles included) or a built-in name. Face numbers are the file's
 * (lrr_scene_load's error messages use the same), or triangle indices for a built-in scene.
 * Errors: degenerate triangles, intersecting pairs (both cross each other's plane: surfaces
 * that pierce, light leaks), coplanar overlaps facing the same way (z-fighting), closed
 * components (connected by shared edges, keyed by exact positions) with an edge traversed in
 * the same direction by its two triangles. Warnings: open edges (used by one triangle) and
 * contacts (coplanar overlaps facing opposite ways, e.g. a block standing on a floor), open
 * sheets that look upside down. */
typedef enum lrr_check_kind {
    LRR_CHECK_DEGENERATE = 0,   /* face_a has (exactly) zero area */
    LRR_CHECK_INTERSECT = 1,    /* face_a and face_b pierce each other */
    LRR_CHECK_ZFIGHT = 2,       /* coplanar, interiors overlap, same facing */
    LRR_CHECK_CONTACT = 3,      /* coplanar, interiors overlap, opposite facing (warning) */
    LRR_CHECK_OPEN_EDGE = 4,    /* an edge of face_a used by no other triangle (warning) */
    LRR_CHECK_ORIENTATION = 5,  /* face_a is flipped against its closed component (face_b) */
    LRR_CHECK_UPSIDE_DOWN = 6   /* face_a belongs to an open sheet (first face face_b) that
                                   looks modelled upside down (warning: a ray-cast heuristic,
                                   see check.cpp): rays from its front
                                   mostly meet back faces or nothing while rays from its back
                                   meet front faces (a floor quad facing down into a room) */
} lrr_check_kind;
typedef struct lrr_check_finding {
    lrr_check_kind kind;
    size_t face_a, face_b; /* face_b == face_a for single-face findings */
} lrr_check_finding;
typedef struct lrr_check_report {
    size_t triangles, degenerate, intersecting_pairs, coplanar_overlaps, contacts, open_edges,
        inconsistent_components;
    size_t n_findings;
    lrr_check_finding *findings;
    /* The raw triangles (n = triangles) and the repair: fix[t] 0 keep, 1 drop (degenerate),
     * 2 flip (minority orientation of a closed component). */
    float *vert, *rho, *emission; /* ×9, ×3, ×3 */
    size_t *face;
    unsigned char *fix;
    size_t upside_down_sheets; /* open connected sheets reported as LRR_CHECK_UPSIDE_DOWN */
    /* The file's names (1.1), filled by lrr_check_report_names, else NULL/0:
     * material[t] indexes material_names (n_materials), group[t]
     * group_names (n_groups: the node, OBJ object or group, each triangle came from; ""
     * when unnamed). */
    size_t *material, *group;
    char **material_names, **group_names;
    size_t n_materials, n_groups;
} lrr_check_report;
/* LRR_ERR_UNSUPPORTED when built without CGAL (lrr_features()). */
LRR_API LRR_NODISCARD lrr_status lrr_scene_check(lrr_context *ctx, const char *name,
                                                 lrr_check_report **out) LRR_NONNULL(1, 2, 3);
LRR_API void lrr_check_report_destroy(lrr_check_report *report);
/* Fills report's material, group and their names (left NULL/0 when the scene has none, or
 * is built in) from the scene `name` that lrr_scene_check read: one more read of the file,
 * so that writing the repair can keep them (lrr check --fix). */
LRR_API LRR_NODISCARD lrr_status lrr_check_report_names(lrr_context *ctx, const char *name,
                                                        lrr_check_report *report)
    LRR_NONNULL(1, 2, 3);

/* Maps a point given by barycentric coordinates (b1, b2 of vertices 1 and 2; b0 = 1-b1-b2)
 * inside input triangle `triangle` to its subpatch index; returns (size_t)-1 when out of
 * range. Requires a subdivided scene. */
LRR_API size_t lrr_scene_subpatch_at(const lrr_scene *scene, size_t triangle, double b1,
                                     double b2) LRR_NONNULL(1);

/* Per-subpatch geometry (each array n entries, NULL to skip): centre n×3, normal n×3,
 * area n, reflectance n×3, emission n×3 (a textured material's mean over each subpatch). */
LRR_API LRR_NODISCARD lrr_status lrr_scene_subpatches(const lrr_scene *scene, float *centre,
                                                      float *normal, float *area, float *rho,
                                                      float *emission) LRR_NONNULL(1);

/* ---------------------------------------------------------------- operator */
typedef struct lrr_operator lrr_operator;

/* Progress: called from one thread with done/total receivers; return non-zero to cancel. */
typedef int (*lrr_progress_fn)(void *user, size_t done, size_t total);

typedef struct lrr_build_options {
    size_t size;                  /* sizeof(lrr_build_options) (lrr_build_options_defaults)
                                     or 0 */
    unsigned hemicube_resolution; /* R: top face R×R, sides R×R/2; even, 8..4096; 0 = 128 */
    uint64_t seed;                /* random rotation about the normal per receiver */
    int threads;                  /* OpenMP threads; 0 = OpenMP's default */
    lrr_progress_fn progress;     /* may be NULL */
    void *progress_user;
    int no_rotation;              /* 1: every hemicube in the same tangent frame (for studying
                                     the aliasing the random rotation spreads out) */
    int backend;                  /* where the hemicube pixels are integrated: 0 or
                                     LRR_BACKEND_CPU on the CPU, LRR_BACKEND_OPENCL on an
                                     OpenCL device (rasterisation stays on the CPU; same F̄ to
                                     rounding; LRR_ERR_UNSUPPORTED without OpenCL, and for
                                     lrr_reference_build) */
    size_t memory_budget;         /* bytes the operator may take (F̄, M, per-subpatch arrays
                                     and the build's working buffers); 0 = no limit. Beyond
                                     it the build returns LRR_ERR_BUDGET naming the amount
                                     needed, before allocating anything large (and with
                                     any budget, LRR_ERR_OVERFLOW when those byte counts
                                     overflow size_t). Not counted: allocator overhead and
                                     third-party memory (OpenMP, LAPACK, OpenCL). */
    size_t adaptive_patches;      /* K > 0: adaptive hierarchy. The scene's patches become the
                                     subpatches (levels must be 0) and are regrouped into at
                                     most K patches, nodes of each triangle's quadtree, split
                                     where the sampled form-factor columns vary most (see
                                     lrr_operator_build). 0 = uniform (each patch d subpatches) */
    size_t adaptive_samples;      /* receivers sampled to estimate the within-patch variance;
                                     0 = 2048; their hemicubes are rendered at a
                                     quarter of the resolution (at least 16) */
    int adaptive_split;           /* which patch the adaptive selection splits next:
                                     LRR_SPLIT_VARIANCE (0) or LRR_SPLIT_AREA */
    int formfactor_method;        /* how each hemicube pixel finds what it sees:
                                     LRR_FORMFACTOR_AUTO (0: raycast above R²/4 input
                                     triangles, the measured crossover; raster otherwise),
                                     LRR_FORMFACTOR_RASTER (z-buffer: cost per receiver ∝
                                     triangles) or LRR_FORMFACTOR_RAYCAST (Embree rays
                                     through the same pixel centres: ∝ log triangles). Either
                                     works with both backends; other values
                                     LRR_ERR_INVALID_ARG */
    /* --- appended after ABI 1 (a caller passing ABI 1's size gets 0 here) --- */
    int hierarchy;                /* what a patch may be, with adaptive_patches = K > 0:
                                     LRR_HIERARCHY_QUADTREE (0): a node of one input
                                     triangle's quadtree (so k >= the triangle count);
                                     LRR_HIERARCHY_CLUSTER: a cluster of subpatches across
                                     triangles, for scenes with many triangles: spatially
                                     compact, every normal within 30° of the cluster's mean
                                     (two sides of a wall, or faces at right angles, never
                                     share one), k about K for any K >= 1 (more only where
                                     the normal rule forces splits). adaptive_split chooses
                                     which cluster splits next (variance: where the sampled
                                     form-factor columns differ most from the area-weighted
                                     model; area: the largest). The subpatches are then
                                     renumbered cluster by cluster (patch-major):
                                     lrr_operator_scene_order maps per-subpatch values back
                                     to the scene's order. Other values LRR_ERR_INVALID_ARG */
    int receiver_sampling;        /* where on a receiver its hemicube looks from:
                                     LRR_RECEIVER_AUTO (0): over its area where rays are cast
                                     (formfactor_method resolves to _RAYCAST), its centre for
                                     the rasteriser; LRR_RECEIVER_CENTRE: the centre (one eye
                                     point, the classic hemicube); LRR_RECEIVER_AREA: each
                                     pixel's ray from its own uniform random point of the
                                     receiver, so a row estimates the area-averaged form
                                     factors of the radiosity equation rather than those of
                                     one point (docs/METHOD.md "Form factors"); it needs rays
                                     (with _AUTO they are cast, with _RASTER it is
                                     LRR_ERR_INVALID_ARG). Other values LRR_ERR_INVALID_ARG */
} lrr_build_options;
static inline lrr_build_options lrr_build_options_defaults(void)
{
    lrr_build_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.hemicube_resolution = 128;
    o.adaptive_samples = 2048;
    return o;
}

/* LRR_SPLIT_VARIANCE: the patch whose subpatches' form-factor columns vary most (sampled).
 * LRR_SPLIT_AREA: the largest patch, i.e. uniform subdivision over the same subpatches and
 * at the same patch count: the baseline the adaptive hierarchy is measured against. */
enum { LRR_SPLIT_VARIANCE = 0, LRR_SPLIT_AREA = 1 };

/* lrr_build_options.formfactor_method: the same five faces, pixel centres, multiplier map
 * and per-receiver rotation either way; rows agree to the pixels on triangle edges. */
enum { LRR_FORMFACTOR_AUTO = 0, LRR_FORMFACTOR_RASTER = 1, LRR_FORMFACTOR_RAYCAST = 2 };

/* lrr_build_options.receiver_sampling, lrr_operator_info.receiver_sampling (CENTRE or AREA:
 * what the build used). */
enum { LRR_RECEIVER_AUTO = 0, LRR_RECEIVER_CENTRE = 1, LRR_RECEIVER_AREA = 2 };

/* lrr_build_options.hierarchy, lrr_operator_info.hierarchy. */
enum { LRR_HIERARCHY_QUADTREE = 0, LRR_HIERARCHY_CLUSTER = 1 };

/* Builds F̄ by one hemicube per subpatch, then M_c = (I_k - Vᵀ diag(rho_c) F̄)^{-1} per
 * channel in double precision (LAPACKE dgetrf/dgetri, dgecon condition estimates), stored in
 * float. The scene must be subdivided. opts may be NULL (defaults). The operator keeps a copy
 * of what it needs: the scene may be destroyed afterwards. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_build(const lrr_scene *scene,
                                                    const lrr_build_options *opts,
                                                    lrr_operator **out) LRR_NONNULL(1, 3);
LRR_API void lrr_operator_destroy(lrr_operator *op);

/* Writes the operator, its scene emission and the geometry needed to draw it (F̄ sparse
 * where that is at most half the dense bytes: lrr_operator_save_fbar's AUTO), atomically:
 * to a temporary file "path.tmp.XXXXXX" in the same directory, flushed and fsynced, then
 * renamed onto path. Whatever fails (a full disk, a file-size limit, a read-only directory)
 * or wherever the process dies, path is either untouched (absent, or the previous file byte
 * for byte) or the complete new file. A failure gives LRR_ERR_IO with a message naming path,
 * the step and the system's error, and removes the temporary file; a process killed during
 * the save cannot remove it, so a "path.tmp.XXXXXX" may then remain (never read by
 * lrr_operator_load; delete it once no save is running). Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_save(const lrr_operator *op, const char *path)
    LRR_NONNULL(1, 2);
/* Reads files of any version (1 to 5). Truncated, corrupted or foreign files give
 * LRR_ERR_CORRUPT / LRR_ERR_VERSION. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_load(lrr_context *ctx, const char *path,
                                                   lrr_operator **out) LRR_NONNULL(1, 2, 3);
/* lrr_operator_load without F̄, for a process that solves elsewhere (docs/MPI.md: rank 0
 * of `lrr solve` under mpirun, whose ranks each load their own rows of F̄): everything but
 * the n×k entries of F̄, which is what drawing, exporting, direct light and the radiosity's
 * summaries read (geometry, hierarchy, rho, emission, areas, M, the row scales of 16-bit
 * F̄, lrr_operator_info's figures and the error bar). Every section but F̄ is read and
 * checked as lrr_operator_load checks it, with the same errors; F̄'s table entry (FBAR or
 * FBAR_STRIPS) is checked too (inside the file, its size against n and k), but its bytes and
 * checksum are not read: a damaged F̄ loads here and fails lrr_operator_load. Vᵀ's weights
 * are the area weights (w_j = d_p A_j / A_p) even where the file's clusters use weights from
 * F̄'s row sums (lrr_operator_build's): nothing public reads them without F̄. On such an
 * operator lrr_operator_fbar returns NULL, lrr_operator_fbar_row writes zeros,
 * lrr_operator_info counts no F̄ in its bytes (layout ROWS), and every call that reads or
 * rewrites F̄ (lrr_solver_create, lrr_operator_save and _save_fbar, _set_storage,
 * _set_layout, _set_reflectance, _verify) returns LRR_ERR_INVALID_ARG saying why. Thread
 * safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_load_head(lrr_context *ctx, const char *path,
                                                        lrr_operator **out)
    LRR_NONNULL(1, 2, 3);

/* New reflectances (n×3, each in [0,1)): recomputes M_c from the stored F̄; no new form
 * factors. Thread safety: one thread per object, and no solver may run meanwhile. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_set_reflectance(lrr_operator *op,
                                                              const float *rho)
    LRR_NONNULL(1, 2);

/* How F̄ is stored. F16 and BF16 halve its memory and the bytes each frame reads; the
 * kernels convert to float on the fly and accumulate in float. F16 rows carry a power-of-two
 * scale so that small form factors stay normal numbers; BF16 keeps float's exponent range
 * with an 8-bit mantissa. */
typedef enum lrr_storage {
    LRR_STORAGE_F32 = 0,
    LRR_STORAGE_F16 = 1,
    LRR_STORAGE_BF16 = 2
} lrr_storage;

/* "f32", "f16", "bf16"; NULL for an unknown value. */
LRR_API const char *lrr_storage_name(lrr_storage storage);
/* The inverse of lrr_storage_name; LRR_ERR_INVALID_ARG for an unknown name. */
LRR_API LRR_NODISCARD lrr_status lrr_storage_from_name(const char *name, lrr_storage *out)
    LRR_NONNULL(1, 2);

/* Re-encodes F̄ in the given storage (rounding to nearest even; going back to F32 decodes
 * the rounded values, it does not restore the originals). M is recomputed from the stored
 * F̄, so the operator stays exactly consistent with what the kernels read. Destroy the
 * operator's solvers first. Thread safety: one thread per object. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_set_storage(lrr_operator *op, lrr_storage storage)
    LRR_NONNULL(1);

/* How F̄ is laid out in memory. PANELS (what lrr_operator_build and lrr_operator_load
 * give): blocks of 32 rows, each stored column-major, which the real-time kernels read at
 * the memory bandwidth (docs/METHOD.md "Real-time step"); ROWS: plain n×k row-major, for
 * callers that want lrr_operator_fbar's pointer (BLAS, their own kernels). Files always hold
 * rows; the solvers read either. */
typedef enum lrr_layout {
    LRR_LAYOUT_PANELS = 0,
    LRR_LAYOUT_ROWS = 1
} lrr_layout;

/* Rewrites F̄ in the given layout, in place (one pass; the values do not change). Destroy
 * the operator's solvers first. Thread safety: one thread per object. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_set_layout(lrr_operator *op, lrr_layout layout)
    LRR_NONNULL(1);

/* Row i of F̄ (k floats), decoded from whatever storage and layout the operator uses; k
 * zeros for an operator of lrr_operator_load_head, which holds no F̄. */
LRR_API void lrr_operator_fbar_row(const lrr_operator *op, size_t i, float *out)
    LRR_NONNULL(1, 3);

#define LRR_BACK_FACE_WORST 5 /* entries of lrr_operator_info's worst back-face lists */
typedef struct lrr_operator_info {
    size_t n, k, d, triangles; /* d = 0 for an adaptive hierarchy (patch sizes vary) */
    size_t d_min, d_max;    /* fewest and most subpatches in one patch (both d if uniform) */
    double selection_seconds; /* adaptive selection's share of build_seconds (0 if uniform) */
    lrr_storage storage;    /* how F̄ is held */
    double condition[3];    /* 1-norm condition estimates of G_c (dgecon) */
    double build_seconds;   /* wall time of lrr_operator_build (as stored, after a load) */
    unsigned hemicube_resolution;
    uint64_t seed;
    int no_rotation;        /* built without the random rotation */
    size_t bytes;           /* memory held by F̄ (none after lrr_operator_load_head), M_c
                               and per-subpatch data */
    int formfactor_method;  /* what the build used: LRR_FORMFACTOR_RASTER or _RAYCAST
                               (0 after lrr_operator_load: .lrr files do not record it) */
    /* Light-leak indicator: the mean over receivers (subpatches) of the share of each
     * hemicube (Σ delta form factors, 0..1) whose first hit is the back of a triangle. Light
     * there is lost: a closed scene with consistent inward-facing surfaces gives 0; surfaces
     * modelled the wrong way round, a receiver inside a closed solid (a floor under a box)
     * or behind a one-sided emitter give > 0. The worst input triangles (index as in
     * lrr_scene_subpatch_at; the mean share of their subpatches), largest first; unused
     * entries have share 0 and triangle SIZE_MAX. All 0 (triangles SIZE_MAX) after
     * lrr_operator_load: .lrr files do not record them. */
    double back_face_share;
    size_t worst_back_face_triangle[LRR_BACK_FACE_WORST];
    double worst_back_face_share[LRR_BACK_FACE_WORST];
    /* --- appended after ABI 1 --- */
    int hierarchy;              /* LRR_HIERARCHY_CLUSTER when patches are clusters across
                                   triangles (subpatches renumbered: lrr_operator_scene_order);
                                   else LRR_HIERARCHY_QUADTREE */
    double formfactor_seconds;  /* the hemicubes' share of build_seconds (0 after a load) */
    double smw_seconds;         /* the factorisation's share of build_seconds (0 after a load) */
    int layout;                 /* lrr_layout of F̄ in memory */
    int receiver_sampling;      /* LRR_RECEIVER_CENTRE or _AREA: where the build's hemicubes
                                   looked from (kept in .lrr files) */
    /* The error bar of lrr_operator_verify (kept in .lrr files); verify_subpatches = 0 when
     * the operator was never verified, and then the others are 0 too. */
    double verify_rel_l2;       /* area-weighted relative L2 of the reflected light B − E
                                   against the path tracer, over regions (a fraction) */
    double verify_noise;        /* the path tracer's own error in the same measure */
    size_t verify_subpatches;   /* subpatches path traced */
    size_t verify_samples;      /* paths per subpatch */
    double verify_seconds;      /* the verification's wall time */
    int verify_uniform;         /* 1: verified for E = 1 everywhere (the scene emits
                                   nothing); 0: for the scene's emission */
} lrr_operator_info;
/* info_size = sizeof *info (see Conventions). */
LRR_API void lrr_operator_get_info(const lrr_operator *op, lrr_operator_info *info,
                                   size_t info_size) LRR_NONNULL(1, 2);

/* Read-only views valid for the operator's life: F̄ (n×k row-major, ld = k; NULL unless the
 * storage is LRR_STORAGE_F32 and the layout LRR_LAYOUT_ROWS: use lrr_operator_set_layout or
 * lrr_operator_fbar_row then; NULL too after lrr_operator_load_head), M (3 k×k row-major matrices,
 * channel-major), rho/emission/centre/normal (n×3), area (n). */
LRR_API const float *lrr_operator_fbar(const lrr_operator *op) LRR_NONNULL(1);
LRR_API const float *lrr_operator_m(const lrr_operator *op) LRR_NONNULL(1);
LRR_API const float *lrr_operator_reflectance(const lrr_operator *op) LRR_NONNULL(1);
LRR_API const float *lrr_operator_emission(const lrr_operator *op) LRR_NONNULL(1);
LRR_API const float *lrr_operator_area(const lrr_operator *op) LRR_NONNULL(1);
LRR_API const float *lrr_operator_centre(const lrr_operator *op) LRR_NONNULL(1);
LRR_API const float *lrr_operator_normal(const lrr_operator *op) LRR_NONNULL(1);
/* k+1 offsets: patch p holds subpatches offsets[p] .. offsets[p+1]-1 (p·d in a uniform
 * hierarchy; varying in an adaptive one). Valid for the operator's life. */
LRR_API const size_t *lrr_operator_patch_offsets(const lrr_operator *op) LRR_NONNULL(1);
/* The corners of every subpatch (n×9 floats: x0 y0 z0 x1 … z2, counter-clockwise seen from
 * its front, in the operator's order): what a viewer or an exporter draws with the
 * radiosity of lrr_solve. Thread safety: any thread. */
LRR_API void lrr_operator_subpatch_vertices(const lrr_operator *op, float *out)
    LRR_NONNULL(1, 2);
/* Copies per-subpatch triples (n×3: radiosity, emission, reflectance) from the operator's
 * subpatch order (that of lrr_solve, lrr_operator_area, …) into the scene's (that of
 * lrr_scene_subpatch_at, lrr_scene_subpatches and the reference solvers). The two differ
 * only for LRR_HIERARCHY_CLUSTER, whose subpatches are numbered cluster by cluster; the
 * copy is then a permutation, else a plain copy. in and out must not overlap. Thread
 * safety: any thread. */
LRR_API void lrr_operator_scene_order(const lrr_operator *op, const float *in, float *out)
    LRR_NONNULL(1, 2, 3);
/* The map behind it, for data of other widths: n entries, the scene-order index of each
 * operator subpatch (valid for the operator's life); NULL when the orders coincide (every
 * hierarchy but LRR_HIERARCHY_CLUSTER). */
LRR_API const size_t *lrr_operator_subpatch_origin(const lrr_operator *op) LRR_NONNULL(1);

/* ---------------------------------------------------------------- solver */
typedef enum lrr_backend {
    LRR_BACKEND_CPU = 301,
    LRR_BACKEND_OPENCL = 302
} lrr_backend;

typedef struct lrr_solver lrr_solver;

/* A solver holds one backend's buffers and scratch for an operator; the operator must
 * outlive it. Thread safety: create/destroy any thread; one thread per solver at a time;
 * many solvers may share one operator. */
LRR_API LRR_NODISCARD lrr_status lrr_solver_create(const lrr_operator *op, lrr_backend backend,
                                                   lrr_solver **out) LRR_NONNULL(1, 3);
LRR_API void lrr_solver_destroy(lrr_solver *solver);

/* What runs the frames: for a CPU solver the instruction-set variant, "c", "avx2" or
 * "avx512", the last two with "+prefetch" appended on Intel CPUs (the widest this CPU
 * supports; the environment variable LRR_SIMD, read by lrr_solver_create, forces one by
 * its name); for an OpenCL solver "opencl:<device name>" (the device
 * is the first GPU, else the first CPU device; LRR_OPENCL_DEVICE picks another by a
 * substring of "platform / device" or by "P:D"). The string lives as long as the solver. */
LRR_API const char *lrr_solver_kernel(const lrr_solver *solver) LRR_NONNULL(1);

/* An OpenCL solver's device times for its last lrr_solve, from OpenCL profiling events, in
 * milliseconds: kernel_ms is the sum of the kernels' END - START, transfer_ms that of the E
 * upload and the B download (host overhead and queueing gaps are in neither). Both are 0
 * before the first frame. A CPU solver returns LRR_ERR_UNSUPPORTED. */
LRR_API LRR_NODISCARD lrr_status lrr_solver_timings(const lrr_solver *solver, double *kernel_ms,
                                                    double *transfer_ms) LRR_NONNULL(1, 2, 3);

/* B = E + rho ∘ (F̄ · (M · (Vᵀ E))) per channel. emission and radiosity are n×3 row-major
 * (they may not alias). Emission must be finite and >= 0.
 * Each frame takes the cheapest of three paths (see lrr_solver_set_path): a pass over F̄; or,
 * when few patches emit, a sum of cached columns of F̄ M_c (each new emitting patch costs one
 * extra pass the first time); or, when few patches changed since the previous frame, an
 * update of the previous B. All give the same B up to float rounding. An OpenCL solver
 * always makes the full pass on its device: E goes up, B comes down. */
LRR_API LRR_NODISCARD lrr_status lrr_solve(lrr_solver *solver, const float *emission,
                                           float *radiosity) LRR_NONNULL(1, 2, 3);

/* count frames at once (animation frames, light presets): emission and radiosity are
 * count×n×3, frame after frame. Every frame is validated first (an error names the frame
 * and leaves radiosity untouched). On the CPU, with at least 8 frames and F̄ larger than
 * 32 MiB and than a quarter of the last-level cache, M is applied by sgemm (OpenBLAS) to 64
 * frames at a time and F̄ read once for them, each block of rows serving every frame while
 * it is in cache (n = 55296, k = 864: 1.80 ms per frame for 16 frames against 4.93 ms one
 * at a time); otherwise a loop of lrr_solve. */
LRR_API LRR_NODISCARD lrr_status lrr_solve_batch(lrr_solver *solver, size_t count,
                                                 const float *emission, float *radiosity)
    LRR_NONNULL(1, 3, 4);

typedef enum lrr_path {
    LRR_PATH_AUTO = 0,       /* choose per frame from the number of patches involved */
    LRR_PATH_FULL = 1,       /* one pass over F̄ (and M) */
    LRR_PATH_SPARSE = 2,     /* cached columns of F̄ M_c for the emitting patches */
    LRR_PATH_INCREMENTAL = 3 /* previous B plus the columns of the patches that changed */
} lrr_path;

/* Forces a path (for measurements and tests); a path that cannot serve a frame (nothing to
 * increment from, more columns than the cache holds) falls back to LRR_PATH_FULL. An OpenCL
 * solver accepts only LRR_PATH_AUTO and LRR_PATH_FULL (LRR_ERR_UNSUPPORTED otherwise). */
LRR_API LRR_NODISCARD lrr_status lrr_solver_set_path(lrr_solver *solver, lrr_path path)
    LRR_NONNULL(1);
/* The path the last frame took. */
LRR_API lrr_path lrr_solver_last_path(const lrr_solver *solver) LRR_NONNULL(1);
/* Memory for cached columns (n×3 floats each; default a quarter of the bytes of F̄ a full
 * frame reads, lrr_solver_info.fbar_bytes; 0 disables the sparse and incremental paths).
 * Empties the cache. No effect on an OpenCL solver. */
LRR_API LRR_NODISCARD lrr_status lrr_solver_set_cache(lrr_solver *solver, size_t max_bytes)
    LRR_NONNULL(1);

/* How a CPU solver reads F̄ (docs/METHOD.md "Sparse F̄"). F̄ of a real scene is mostly
 * zeros (a patch sees few of the scene's clusters; the rest is behind walls): SPARSE keeps
 * only the strips of 16 rows × 1 column that hold a nonzero, in F̄'s storage with a 16-bit
 * column index each (k <= 65535), copied once from the operator; B equals the dense pass's
 * up to the order of the sums. AUTO, what lrr_solver_create chooses, is SPARSE where that
 * reads at most half of the dense bytes. The operator keeps F̄ dense; its files store the
 * strips where AUTO would read them (lrr_operator_save_fbar). */
typedef enum lrr_fbar_format {
    LRR_FBAR_AUTO = 0,
    LRR_FBAR_DENSE = 1,
    LRR_FBAR_SPARSE = 2
} lrr_fbar_format;

/* "auto", "dense", "sparse"; NULL for an unknown value. */
LRR_API const char *lrr_fbar_format_name(lrr_fbar_format format);
/* The inverse of lrr_fbar_format_name; LRR_ERR_INVALID_ARG for an unknown name. */
LRR_API LRR_NODISCARD lrr_status lrr_fbar_format_from_name(const char *name,
                                                           lrr_fbar_format *out)
    LRR_NONNULL(1, 2);
/* lrr_operator_save with F̄ stored as chosen: DENSE, all n·k entries (file versions 1 to 4,
 * which every lrr reads); SPARSE, only the strips that hold a nonzero, as the solver's
 * sparse copy (file version 5, which older readers refuse by its version;
 * LRR_ERR_UNSUPPORTED when k > 65535); AUTO, what lrr_operator_save does: SPARSE where a
 * solver's AUTO reads F̄ sparse (at most half the dense bytes), else DENSE. F̄ loads back
 * bit for bit either way. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_save_fbar(const lrr_operator *op,
                                                        const char *path,
                                                        lrr_fbar_format fbar)
    LRR_NONNULL(1, 2);
/* Reads F̄ in the given format from now on (one pass over the operator's F̄ to count and
 * copy its strips); on an error the solver reads F̄ as before. An OpenCL solver holds one
 * of the two on its device and uploads the other in its place (AUTO chooses as on the CPU;
 * the environment variable LRR_OPENCL_STRIP_GROUPS, a power of two, tunes its sparse
 * kernel's work-items per tile). LRR_ERR_UNSUPPORTED for SPARSE with k > 65535. Thread
 * safety: one thread per object. */
LRR_API LRR_NODISCARD lrr_status lrr_solver_set_fbar(lrr_solver *solver, lrr_fbar_format format)
    LRR_NONNULL(1);
/* How a CPU solver reads M_c in a full frame: F32, the operator's M; F16, M_c − I in binary16
 * with a power-of-two scale per row, half the bytes (k = 3456: 72 MB instead of 143 MB a
 * frame). lrr_solver_create chooses F16 when the operator's F̄ is F16 or BF16, where its
 * rounding is a small part of F̄'s own, else F32 (docs/METHOD.md "Real-time step"). BF16 is
 * refused (LRR_ERR_INVALID_ARG). The sparse and incremental paths and lrr_solve_batch read
 * the operator's M whatever this says. An OpenCL solver reads M in F32 (F16:
 * LRR_ERR_UNSUPPORTED). On an error the solver reads M as before. Thread safety: one thread
 * per object. */
LRR_API LRR_NODISCARD lrr_status lrr_solver_set_m(lrr_solver *solver, lrr_storage storage)
    LRR_NONNULL(1);

typedef struct lrr_solver_info {
    lrr_fbar_format fbar;      /* DENSE or SPARSE: what a full frame reads */
    size_t fbar_bytes;         /* bytes of F̄ a full frame reads (the sparse copy's size) */
    size_t fbar_dense_bytes;   /* n·k entries in the operator's storage */
    size_t m_bytes;            /* bytes of M a full frame reads (3·k·k entries, + row scales) */
    double fbar_density;       /* nonzero entries / (n·k) */
    double fbar_strip_density; /* entries of the strips that hold a nonzero / (n·k) */
    lrr_storage m;             /* F32 or F16: how a full frame reads M (lrr_solver_set_m) */
} lrr_solver_info;
/* info_size = sizeof *info (see Conventions). */
LRR_API void lrr_solver_get_info(const lrr_solver *solver, lrr_solver_info *info,
                                 size_t info_size) LRR_NONNULL(1, 2);

/* ---------------------------------------------------------------- verification */
/* The operator's error bar (docs/METHOD.md "Verification"): its radiosity for the scene's
 * emission against the path tracer on every one of its subpatches, compared in regions. */
typedef struct lrr_verify_options {
    size_t size;              /* sizeof(lrr_verify_options) (its _defaults) or 0 */
    size_t samples;           /* S, paths per subpatch, >= 4: two independent estimates of
                                 S/2 each (up to 16·S/2 for the subpatches whose noise would
                                 dominate, found by a scout of 16 paths); 0 = automatic: what
                                 a fifth of the build's time (lrr_operator_info.build_seconds)
                                 leaves after the scout at its speed, between 32 and 1024
                                 (it depends on the timing; a given S and seed give the same
                                 figure) */
    uint64_t seed;            /* the paths */
    int threads;              /* OpenMP threads of the path tracer; 0 = OpenMP's default */
    lrr_progress_fn progress; /* may be NULL; done/total subpatches */
    void *progress_user;
} lrr_verify_options;
static inline lrr_verify_options lrr_verify_options_defaults(void)
{
    lrr_verify_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    return o;
}

/* Path traces every subpatch of scene that reflects and does not emit (the scene,
 * subdivided, the operator was built from: LRR_ERR_INVALID_ARG otherwise), solves with op for
 * the same emission (the scene's; E = 1 on every triangle where it emits nothing) and
 * compares the reflected light in regions (grid cells × facing): the result goes into op
 * (lrr_operator_info.verify_*, lrr_operator_save). opts may be NULL (defaults). Thread
 * safety: one thread per object, and no solver of op may run meanwhile. */
LRR_API LRR_NODISCARD lrr_status lrr_operator_verify(lrr_operator *op, const lrr_scene *scene,
                                                     const lrr_verify_options *opts)
    LRR_NONNULL(1, 2);

/* ---------------------------------------------------------------- reference solvers */
/* The full n×n form-factor matrix F (subpatch to subpatch) and classic solvers of
 * (I − R F) B = E on it, to measure the error of the low-rank operator against. */
typedef struct lrr_reference lrr_reference;

/* Bytes lrr_reference_build needs for n subpatches (the n×n float matrix plus per-subpatch
 * data); SIZE_MAX when that overflows. The direct method needs 8·n² bytes more while it runs. */
LRR_API size_t lrr_reference_bytes(size_t n);

/* Builds F from the same hemicubes as lrr_operator_build with the same scene and options
 * (same centres, resolution and rotations); a pixel's subpatch comes from the barycentric
 * coordinates of the visible point, so F̄ = F V / d holds up to rounding. memory_budget is
 * the most bytes the reference may hold (0 = 4 GiB): larger scenes are refused with
 * LRR_ERR_BUDGET before anything is allocated, the message naming the amount needed.
 * The scene must be subdivided; opts may be NULL. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_reference_build(const lrr_scene *scene,
                                                     const lrr_build_options *opts,
                                                     size_t memory_budget, lrr_reference **out)
    LRR_NONNULL(1, 4);
LRR_API void lrr_reference_destroy(lrr_reference *ref);

/* Read-only views valid for the reference's life: F (n×n row-major), rho and emission
 * (n×3, the scene's), area (n). */
LRR_API size_t lrr_reference_size(const lrr_reference *ref) LRR_NONNULL(1);
LRR_API const float *lrr_reference_f(const lrr_reference *ref) LRR_NONNULL(1);
LRR_API const float *lrr_reference_reflectance(const lrr_reference *ref) LRR_NONNULL(1);
LRR_API const float *lrr_reference_emission(const lrr_reference *ref) LRR_NONNULL(1);
LRR_API const float *lrr_reference_area(const lrr_reference *ref) LRR_NONNULL(1);

typedef enum lrr_method {
    LRR_METHOD_JACOBI = 401,       /* B ← E + R F B, all at once */
    LRR_METHOD_GAUSS_SEIDEL = 402, /* the same, using each new B_i at once */
    LRR_METHOD_SOUTHWELL = 403,    /* progressive refinement: shoot the largest unshot energy */
    LRR_METHOD_DIRECT = 404        /* LU of I − R F per channel (LAPACKE dgesv, 8·n² bytes) */
} lrr_method;

/* "jacobi", "gauss-seidel", "southwell", "direct"; NULL for an unknown value. */
LRR_API const char *lrr_method_name(lrr_method method);
/* The inverse of lrr_method_name; LRR_ERR_INVALID_ARG for an unknown name. */
LRR_API LRR_NODISCARD lrr_status lrr_method_from_name(const char *name, lrr_method *out)
    LRR_NONNULL(1, 2);

typedef struct lrr_reference_stats {
    size_t iterations; /* sweeps (Jacobi, Gauss–Seidel), shots (Southwell), 1 (direct) */
    double residual;   /* max over channels of ||E − (I − R F) B||₂ / ||E||₂, in double */
    double seconds;    /* wall time of the solve */
} lrr_reference_stats;

/* Solves (I − R F) B = E for each channel, accumulating in double. Iterative methods stop
 * when the relative residual is <= tol (0 = 1e-6; otherwise 1e-13 <= tol < 1, since double
 * rounding cannot promise less) or after max_iterations (0 = a default
 * large enough for rho up to 0.999), then return LRR_NOT_CONVERGED with B holding the last
 * iterate. emission and radiosity are n×3 (no aliasing); emission finite and >= 0.
 * stats may be NULL, else stats_size = sizeof *stats. Thread safety: any thread; many solves
 * may share one reference. */
LRR_API LRR_NODISCARD lrr_status lrr_reference_solve(const lrr_reference *ref,
                                                     lrr_method method, double tol,
                                                     size_t max_iterations,
                                                     const float *emission, float *radiosity,
                                                     lrr_reference_stats *stats,
                                                     size_t stats_size)
    LRR_NONNULL(1, 5, 6);

/* Path-traced reference (docs/METHOD.md "Path-traced reference"): a Monte Carlo estimate
 * of the same B as the exact solve of (I − R F) B = E with the exact (area-averaged) F, with
 * no n×n matrix, by Embree rays. For each subpatch i, `samples` paths start at uniform points
 * of i, gather cosine-weighted directions, take emitters by next-event estimation combined
 * with the hits (balance heuristic), move to a uniform point of the subpatch hit (so each
 * bounce is one step of B = E + R F B) and end by Russian roulette after 3 bounces. */
typedef struct lrr_path_trace_options {
    size_t size;              /* sizeof(lrr_path_trace_options) (its _defaults) or 0 */
    size_t samples;           /* paths per subpatch, >= 2 (for a standard error); default
                                 1024 */
    uint64_t seed;            /* path (seed, subpatch, sample) has its own random stream */
    int threads;              /* OpenMP threads; 0 = OpenMP's default; the result does not
                                 depend on it */
    lrr_progress_fn progress; /* may be NULL; done/total subpatches */
    void *progress_user;
} lrr_path_trace_options;
static inline lrr_path_trace_options lrr_path_trace_options_defaults(void)
{
    lrr_path_trace_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.samples = 1024;
    return o;
}

/* radiosity (n×3): the mean of each subpatch's path estimates; std_error (n×3, may be NULL):
 * its standard error, the sample standard deviation / √samples. The scene must be
 * subdivided; opts may be NULL (defaults). Errors (LRR_ERR_INVALID_ARG): samples < 2,
 * threads < 0; LRR_ERR_CANCELLED from progress, LRR_ERR_UNSUPPORTED/NOMEM from Embree.
 * Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_reference_path_trace(const lrr_scene *scene,
                                                          const lrr_path_trace_options *opts,
                                                          float *radiosity, float *std_error)
    LRR_NONNULL(1, 3);

/* Per input triangle t (mean n_triangles×3): Σ_{i∈t} A_i B_i / A_t, and (mean_std_error, may
 * be NULL, needs std_error) √(Σ_{i∈t} A_i² σ_i²) / A_t, the standard error of that mean for
 * independent subpatch estimates. The scene must be subdivided. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_reference_triangle_means(const lrr_scene *scene,
                                                              const float *radiosity,
                                                              const float *std_error,
                                                              float *mean,
                                                              float *mean_std_error)
    LRR_NONNULL(1, 2, 4);

/* ---------------------------------------------------------------- pictures */
typedef struct lrr_render_options {
    size_t size;             /* sizeof(lrr_render_options) (lrr_render_options_defaults) or 0 */
    unsigned width, height;  /* pixels; 0 = 512 */
    double exposure;         /* multiplier before tone mapping; 0 = automatic */
    int use_cornell_camera;  /* 1: the Cornell camera; 0: a camera framing the scene from
                                outside; -1: automatic (the Cornell camera for the built-in
                                boxes; inside a closed scene with light sources, see below;
                                else framing) */
    double eye[3], target[3]; /* use_eye = 1: a pinhole camera at eye looking at target */
    double up[3];            /* the picture's up direction (0, 0, 0 = +y); not parallel to
                                target − eye */
    double fov_degrees;      /* vertical field of view, 0 < fov < 180; 0 = the camera's own
                                (60 for eye and the inside camera, 40 framing, 2·atan(12.5/35)
                                ≈ 39.3 Cornell) */
    int use_eye;             /* 1: the eye/target camera (use_cornell_camera is ignored);
                                0: use_cornell_camera decides */
} lrr_render_options;
static inline lrr_render_options lrr_render_options_defaults(void)
{
    lrr_render_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.width = o.height = 512;
    o.use_cornell_camera = -1;
    o.up[1] = 1;
    return o;
}

/* Draws the operator's geometry with Gouraud-interpolated subpatch radiosity (n×3), tone
 * mapped to sRGB, and writes a PNG atomically. opts may be NULL. Triangles are one-sided
 * (back faces are not drawn) and clipped at a near plane just in front of the eye, so a
 * camera inside a room sees its walls.
 * The automatic camera (use_cornell_camera = -1, use_eye = 0) stands inside a closed scene
 * that emits light: when 98% of 128 rays from a candidate eye (at 60% of the height, 10% of
 * the longest horizontal side from one end, or at the centre) first meet a triangle facing
 * it, it looks from there along that side, towards the end that shows more lit area. A
 * camera framing such a room from outside would see through its near walls and miss a
 * ceiling light. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_render_png(const lrr_operator *op, const float *radiosity,
                                                const lrr_render_options *opts,
                                                const char *path) LRR_NONNULL(1, 2, 4);
/* The same picture as lrr_render_png (same options, camera and rasteriser), written as
 * OpenEXR: linear radiosity (W/m², what the PNG tone maps; no exposure, no curve) in float
 * R, G, B channels (ZIP compression), 0 where no surface is seen. Written atomically: path
 * is never a partial file. LRR_ERR_UNSUPPORTED naming path when built without OpenEXR
 * (lrr_features()). Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_render_exr(const lrr_operator *op, const float *radiosity,
                                                const lrr_render_options *opts,
                                                const char *path) LRR_NONNULL(1, 2, 4);
/* The automatic exposure (what exposure = 0 means) for radiosity (n×3): the area-weighted
 * mean luminance (Rec. 709) of the subpatches that do not emit maps to 0.18 (of all of them
 * when that mean is 0; 1 when it is 0 too). lrr_render_png keys it on the subpatches its
 * picture shows, lrr_export_gltf / _ply ("auto") on all of them, as this function does: a
 * sequence of pictures drawn with this exposure, fixed, does not flicker. Thread safety: any
 * thread. */
LRR_API double lrr_render_auto_exposure(const lrr_operator *op, const float *radiosity)
    LRR_NONNULL(1, 2);

/* ---------------------------------------------------------------- export */
/* The lit scene as a mesh for other programs: glTF 2.0 (binary .glb) or PLY.
 *
 * The mesh: the input triangles (or, with subpatches = 1, the subpatch mesh, T-junctions
 * where neighbouring triangles are split to different depths), with a colour per vertex:
 * the area-weighted mean radiosity of the subpatches touching that corner, the colours the
 * renderer interpolates. Corners are shared where they coincide, face the same way and
 * carry the same material; they are split at creases (normals differing, as in the
 * renderer's weld) and at material edges, where averaging would bleed one surface's light
 * into the other's.
 *
 * What the colour holds: c = min(1, B × exposure), linear, per channel. glTF's COLOR_0 is
 * a multiplier on the base colour that viewers (three.js, Blender, the Khronos sample
 * viewer) bring to the display unchanged, and the Khronos validator rejects COLOR_0 values
 * outside [0, 1] (ACCESSOR_NON_CLAMPED, an error: measured with gltf-validator
 * 2.0.0-dev.3.10 on an emitter's B = 10), so they are clamped. The unclamped radiosity of each vertex is kept
 * beside it (glTF: the custom attribute _RADIOSITY, PLY: float properties): nothing is lost.
 *
 * Materials (glTF): one per distinct (reflectance, emission) of the input triangles (of
 * the subpatches with subpatches = 1), in increasing order of (rho, E), each with
 * KHR_materials_unlit and baseColorFactor (1, 1, 1, 1): the light is baked into COLOR_0,
 * which already contains rho (B = E + rho H); a lit material with baseColorFactor = rho
 * would apply rho a second time and light the scene again with the viewer's lamps. The
 * material's own reflectance and emission are in its extras ("reflectance", "emission"),
 * and its fallback for viewers without the extension is matte (metallic 0, roughness 1).
 * The asset's extras record the exposure. */
typedef struct lrr_export_options {
    size_t size;     /* sizeof(lrr_export_options) (lrr_export_options_defaults) or 0 */
    int subpatches;  /* 1: the subpatch mesh; 0: the input triangles (default) */
    double exposure; /* colour = min(1, B × exposure); > 0, default 1 (B itself); 0 =
                        automatic, as lrr_render_png: the area-weighted mean luminance of the
                        non-emitting subpatches maps to 0.18 */
} lrr_export_options;
static inline lrr_export_options lrr_export_options_defaults(void)
{
    lrr_export_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.exposure = 1;
    return o;
}

/* Writes the lit mesh of op with radiosity (n×3, operator order, finite and >= 0) as binary
 * glTF 2.0 (.glb) to path, atomically (path is never a partial file). One mesh with one
 * triangle primitive per material; attributes POSITION, NORMAL, COLOR_0 (float VEC4, alpha
 * 1) and _RADIOSITY (float VEC3, B unclamped); 32-bit indices. opts may be NULL. Errors:
 * LRR_ERR_INVALID_ARG (a bad option; a negative or non-finite radiosity, naming the
 * subpatch), LRR_ERR_OVERFLOW (more than glTF's 32-bit counts and byte lengths hold),
 * LRR_ERR_IO (naming the path and the step). Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_export_gltf(const lrr_operator *op, const float *radiosity,
                                                 const lrr_export_options *opts,
                                                 const char *path) LRR_NONNULL(1, 2, 4);
/* The same mesh as binary little-endian PLY: per vertex float x, y, z, nx, ny, nz; uchar
 * red, green, blue: the colour above sRGB-encoded, since PLY readers (MeshLab, Blender)
 * take uchar colours as display colours and few read float ones; float radiosity_r,
 * radiosity_g, radiosity_b: B unclamped. Per face a uchar/uint vertex_indices list and a
 * uint material (its reflectance and emission in the header's comments). Same errors and
 * atomicity as lrr_export_gltf. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_export_ply(const lrr_operator *op, const float *radiosity,
                                                const lrr_export_options *opts,
                                                const char *path) LRR_NONNULL(1, 2, 4);

/* What an export holds (info_size = sizeof *info, see Conventions). */
typedef struct lrr_export_info {
    size_t vertices, triangles, materials;
    double exposure;  /* the exposure applied (the automatic one resolved) */
} lrr_export_info;
/* Builds the mesh lrr_export_gltf / _ply would write (same checks and errors; path only
 * names it in messages) and reports its sizes, writing nothing. Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_export_get_info(const lrr_operator *op,
                                                     const float *radiosity,
                                                     const lrr_export_options *opts,
                                                     const char *path, lrr_export_info *info,
                                                     size_t info_size)
    LRR_NONNULL(1, 2, 4, 5);

/* ---------------------------------------------------------------- light probes */
/* An environment map in the latitude–longitude layout: W×H pixels with W = 2H, row 0 at the
 * zenith (theta = 0), column 0 at phi = 0. Pixel (u, v) looks along
 *   theta = π (v + 0.5) / H,  phi = 2π (u + 0.5) / W,
 *   ω = (sin theta cos phi, cos theta, sin theta sin phi)      (+y up)
 * and covers the solid angle sin theta · 2π² / (W·H). Pixels are linear RGB radiance. */
typedef struct lrr_probe lrr_probe;

/* Loads a probe: a path ending in .exr (any case) is read as OpenEXR (R, G, B half/float
 * channels, scanline or tiled, any compression DWA included; finite negative pixels, the
 * ringing of lossy compression, are clamped to 0), anything else as Radiance RGBE (.hdr)
 * through stb_image. Unreadable, truncated or channel-less files and other formats give
 * LRR_ERR_FORMAT naming the file; W != 2H gives LRR_ERR_DIM naming the size and the expected
 * layout; a non-finite pixel (or a negative one in a .hdr) gives LRR_ERR_FORMAT naming its
 * column x, row y and channel. Sizes a header claims are checked against the file before
 * anything is allocated for them: a truncated .hdr is an error (not black rows), and an
 * OpenEXR file whose chunk would unpack to more than 256 MiB is refused (LRR_ERR_FORMAT).
 * Built without OpenEXR (lrr_features()), a .exr path gives LRR_ERR_UNSUPPORTED naming it.
 * Thread safety: any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_probe_load(lrr_context *ctx, const char *path,
                                                lrr_probe **out) LRR_NONNULL(1, 2, 3);
/* A probe from width×height×3 floats (row-major, RGB interleaved), copied; the same checks
 * (LRR_ERR_DIM for the size, LRR_ERR_INVALID_ARG for a bad pixel). */
LRR_API LRR_NODISCARD lrr_status lrr_probe_create(lrr_context *ctx, size_t width, size_t height,
                                                  const float *rgb, lrr_probe **out)
    LRR_NONNULL(1, 4, 5);
LRR_API void lrr_probe_destroy(lrr_probe *probe);
LRR_API void lrr_probe_size(const lrr_probe *probe, size_t *width, size_t *height)
    LRR_NONNULL(1, 2, 3);

/* Ground truth E(n) = Σ_pixels Q(u,v) max(0, n·ω(u,v)), Q = P sin theta · 2π²/(W·H), for m
 * unit normals (m×3) into out (m×3), summed in blocks of normals × pixels with OpenMP and
 * accumulated in double. Normals must be finite and non-zero (they are normalised). */
LRR_API LRR_NODISCARD lrr_status lrr_probe_irradiance(const lrr_probe *probe, size_t m,
                                                      const float *normals, float *out)
    LRR_NONNULL(1, 3, 4);

/* A directional light: dir a unit vector from the scene towards the light, rgb its radiance
 * × solid angle, so that its irradiance on a normal n is rgb · max(0, n·dir). */
typedef struct lrr_light {
    float dir[3];
    float rgb[3];
} lrr_light;

/* Median cut (Debevec 2005) into `count` lights (1 <= count <= W·H). The regions are
 * rectangles of pixels; a region is cut across its longer side (its width measured as
 * width × sin theta at its centre) where the two halves' energies (luminance × solid angle)
 * are closest. A power of two splits every region each pass (log2 count passes); any other
 * count is the adaptive variant: the region with the most energy is split until there are
 * `count`. Each light sits at its region's energy centroid (in pixel coordinates) and carries
 * the region's summed radiance × solid angle. A region of one pixel that must be split again
 * gives a second, black light. */
LRR_API LRR_NODISCARD lrr_status lrr_probe_median_cut(const lrr_probe *probe, size_t count,
                                                      lrr_light *out) LRR_NONNULL(1, 3);

/* Irradiance optimisation: `count` lights fitted by Levenberg–Marquardt to the probe's
 * irradiance on m normals of lrr_sphere_points. Parameters per light: rgb and the angles of
 * its direction; objective Σ over normals and RGB of r², r = w (Σ_l rgb_l max(0, n·dir_l) − E),
 * w = 1 / max(E, 1e-4 · max E) (relative, the default) or 1 (absolute). Each iteration solves
 * (JᵀJ + λ diag JᵀJ) δ = −Jᵀr (analytic J, LAPACKE dposv), clamps radiances at 0 and keeps the
 * step only if the objective decreases, so the objective is monotone and rgb >= 0. */
typedef struct lrr_fit_options {
    size_t size;           /* sizeof(lrr_fit_options) (lrr_fit_options_defaults) or 0 */
    size_t max_iterations; /* accepted steps at most; 0 = 300 */
    double tolerance;      /* stop when a step lowers the objective by less than this fraction;
                              0 = 1e-6 */
    int absolute;          /* nonzero: absolute residuals instead of relative */
    int warm_start;        /* nonzero: start from the lights in out, else from median cut */
    double *history;       /* optional: history[0] the starting objective, history[k] the one
                              after iteration k, for k < history_len */
    size_t history_len;
} lrr_fit_options;
static inline lrr_fit_options lrr_fit_options_defaults(void)
{
    lrr_fit_options o;
    memset(&o, 0, sizeof o);
    o.size = sizeof o;
    o.max_iterations = 300;
    o.tolerance = 1e-6;
    return o;
}

typedef struct lrr_fit_stats {
    size_t iterations;        /* accepted LM steps */
    int converged;            /* 1: tolerance met or no step decreases; 0: hit the cap */
    double initial_objective; /* at the start (median cut or the given lights) */
    double final_objective;
    double seconds;           /* wall clock, ground truth included */
} lrr_fit_stats;

/* opts and stats may be NULL (stats_size = sizeof *stats). 1 <= count <= W·H, m >= 1; LRR_ERR_INVALID_ARG otherwise (and for
 * a bad option or a warm-start light with a zero or non-finite direction). Memory: about
 * 8 · (15 m · count + 50 count²) bytes. Thread safety: distinct probes from any thread. */
LRR_API LRR_NODISCARD lrr_status lrr_probe_fit_irradiance(const lrr_probe *probe, size_t count,
                                                          size_t m, const lrr_fit_options *opts,
                                                          lrr_light *out, lrr_fit_stats *stats,
                                                          size_t stats_size)
    LRR_NONNULL(1, 5);

/* The projection of the probe onto the real spherical harmonics of order 2 (9 basis
 * functions): coeffs is 9×3 (coefficient i of channel c at 3i + c), basis order
 * Y00, Y1-1(y), Y10(z), Y11(x), Y2-2(xy), Y2-1(yz), Y20(3z²-1), Y21(xz), Y22(x²-y²).
 * LRR_ERR_INVALID_ARG (coeffs untouched) when a coefficient exceeds float's range (finite
 * radiances near FLT_MAX). */
LRR_API LRR_NODISCARD lrr_status lrr_probe_sh9(const lrr_probe *probe, float coeffs[27])
    LRR_NONNULL(1, 2);
/* Irradiance of SH9 radiance coefficients (Ramamoorthi–Hanrahan: the bands scaled by π,
 * 2π/3, π/4) for m normals (m×3) into out (m×3). */
LRR_API LRR_NODISCARD lrr_status lrr_sh9_irradiance(const float coeffs[27], size_t m,
                                                    const float *normals, float *out)
    LRR_NONNULL(1, 3, 4);
/* Irradiance of `count` lights for m normals (m×3) into out (m×3). */
LRR_API LRR_NODISCARD lrr_status lrr_lights_irradiance(const lrr_light *lights, size_t count,
                                                       size_t m, const float *normals,
                                                       float *out) LRR_NONNULL(1, 4, 5);
/* m points spread uniformly over the unit sphere (a Fibonacci spiral), m×3. */
LRR_API void lrr_sphere_points(size_t m, float *out) LRR_NONNULL(2);

/* Lighting a scene with directional lights (a fitted probe): the emission vector
 *   E_i,c = rho_i,c Σ_l rgb_l,c · max(0, n_i·dir_l) · visible(x_i, dir_l)
 * into emission (n×3), for the operator's subpatch centres x_i, normals n_i and reflectance
 * rho_i. E is the *reflected* direct light, treated as emission (the first bounce), so
 * B = lrr_solve(E) adds the interreflections (for the scene's own lights as well, add its
 * stored emission to E). The lights are at infinity (the probe is distant): a light is seen
 * from x_i unless an occlusion ray from x_i (moved off the surface by 1e-5 × the scene's
 * bounding-box diagonal along n_i) towards dir_l hits one of the operator's input triangles
 * (Embree 3, a BVH built once per call). Directions are in the scene's coordinates with the
 * probes' convention: +y is up, the probe's row 0 (its zenith) lies along +y (see the
 * latitude–longitude layout above), so a scene must be modelled y-up to be lit the right
 * way round; there is no rotation. Directions need not be unit (they are normalised) but
 * must be finite and non-zero and rgb finite and >= 0 (LRR_ERR_INVALID_ARG otherwise);
 * count 0 (lights may then be NULL) gives E = 0. An Embree failure gives LRR_ERR_NOMEM or
 * LRR_ERR_UNSUPPORTED with Embree's message. OpenMP over subpatches. Thread safety: any
 * thread, distinct outputs. */
LRR_API LRR_NODISCARD lrr_status lrr_probe_direct_light(const lrr_operator *op,
                                                        const lrr_light *lights, size_t count,
                                                        float *emission) LRR_NONNULL(1, 4);

/* ---------------------------------------------------------------- lights */
/* Lights that move: each frame the reflected direct light E_i = rho_i ∘ H_i (H_i the
 * irradiance at subpatch i's centre, one-sided: nothing reaches a subpatch from behind,
 * shadowed by Embree occlusion rays) is computed for any set of lights, then lrr_solve(E)
 * adds the interreflections (the direct-to-indirect pipeline; docs/METHOD.md "Lights").
 * Units follow the scene's emission (radiosity, W/m²-like per channel):
 *   LRR_LIGHT_POINT  at position, radiant intensity rgb (per steradian):
 *                    H = rgb · max(0, n·ω) / r²  (ω towards the light, r its distance)
 *   LRR_LIGHT_SPOT   the same, times a cone factor of the angle θ between −ω and
 *                    direction: 1 for θ <= cone_angle − cone_softness, 0 for θ >=
 *                    cone_angle, smoothstep in θ between
 *   LRR_LIGHT_AREA   a one-sided rectangle, centre position, edges u and v (corners
 *                    position ± u/2 ± v/2), emitting on the side of u × v with radiosity
 *                    rgb (as a scene emitter's E): H = rgb · F(x → rectangle), estimated
 *                    with `samples` stratified, jittered points (rounded up to a square;
 *                    0 = 16, at most 1024), each with its own shadow ray
 *   LRR_LIGHT_SUN    at infinity towards direction (any length), irradiance rgb on a
 *                    surface facing it: H = rgb · max(0, n·ω̂)  (lrr_light's meaning)
 * Lights are not part of the scene: they cast no shadow and receive no light. */
enum { LRR_LIGHT_POINT = 1, LRR_LIGHT_SPOT = 2, LRR_LIGHT_AREA = 3, LRR_LIGHT_SUN = 4 };
typedef struct lrr_light_source {
    int kind;              /* LRR_LIGHT_* */
    float position[3];     /* point, spot, area (its centre) */
    float direction[3];    /* spot: where its axis points; sun: towards the sun */
    float u[3], v[3];      /* area: its edges */
    float rgb[3];          /* finite, >= 0; meaning per kind (above) */
    float cone_angle;      /* spot: half-angle in radians, in (0, π) */
    float cone_softness;   /* spot: width of the soft edge in radians, in [0, cone_angle] */
    unsigned samples;      /* area: points per receiver (0 = 16, at most 1024) */
} lrr_light_source;

/* The plan for lighting one operator (FFTW style): the BVH of its input triangles is built
 * once here and reused by every lrr_lighting_direct. The operator must outlive it. Errors:
 * LRR_ERR_NOMEM / LRR_ERR_UNSUPPORTED from Embree; LRR_SIMD (as lrr_solver_create reads
 * it; it picks the error budget's kernels) naming an unknown instruction set
 * (LRR_ERR_INVALID_ARG) or one this CPU lacks (LRR_ERR_UNSUPPORTED). Thread safety: one thread at a time per
 * lighting; several lightings of one operator may run at once. */
typedef struct lrr_lighting lrr_lighting;
LRR_API LRR_NODISCARD lrr_status lrr_lighting_create(const lrr_operator *op,
                                                     lrr_lighting **out) LRR_NONNULL(1, 2);
LRR_API void lrr_lighting_destroy(lrr_lighting *lighting);
/* emission (n×3, the operator's subpatch order) = Σ over the lights of rho ∘ H (above).
 * A light identical (byte for byte, at the same index) to the one of the previous call is
 * not traced again: its irradiance is kept, so moving one light of many costs one light's
 * rays. Bad lights (unknown kind, non-finite or negative values, a zero direction or
 * rectangle, a cone outside its range, more than 1024 samples) give LRR_ERR_INVALID_ARG
 * naming the light and the field, emission untouched; a direct light beyond float's range
 * gives LRR_ERR_INVALID_ARG with emission zeroed. count 0 gives E = 0. OpenMP over
 * subpatches. */
LRR_API LRR_NODISCARD lrr_status lrr_lighting_direct(lrr_lighting *lighting,
                                                     const lrr_light_source *lights,
                                                     size_t count, float *emission)
    LRR_NONNULL(1, 4);
/* lrr_lighting_direct at the receivers [row0, row0 + rows) alone, for a process that holds
 * those rows of the operator (lrr_mpi_solver_rows): emission (rows×3) is those rows of
 * lrr_lighting_direct's, bit for bit, and only their shadow rays are cast. The cache of
 * unchanged lights holds one range: a call on another range (or lrr_lighting_direct)
 * traces every light again. Errors as lrr_lighting_direct's, and LRR_ERR_INVALID_ARG when
 * the range exceeds n or emission is NULL with rows > 0; LRR_ERR_UNSUPPORTED with a
 * tolerance set (lrr_lighting_set_tolerance > 0 chooses its receivers over the whole
 * scene). rows 0 does nothing. */
LRR_API LRR_NODISCARD lrr_status lrr_lighting_direct_rows(lrr_lighting *lighting,
                                                          const lrr_light_source *lights,
                                                          size_t count, size_t row0,
                                                          size_t rows, float *emission)
    LRR_NONNULL(1);
/* Shadow rays cast by the last lrr_lighting_direct or _rows (unchanged lights cast none). */
LRR_API uint64_t lrr_lighting_rays(const lrr_lighting *lighting) LRR_NONNULL(1);
/* The shadow rays' error budget (docs/METHOD.md "Lights"). 0, the default: every receiver
 * a light reaches gets its shadow rays. tolerance > 0: a point or spot light traces the
 * receivers that carry most of its light and gives the others the visibility of their last
 * ray from that light (visible before the first), so that per light and channel the
 * area-weighted L2 norm of the error in rho ∘ H is at most tolerance × that of the exact
 * rho ∘ H, whatever the scene (for several lights together: at most tolerance·√lights
 * relative to their sum). Area and sun lights trace every receiver. A new tolerance traces
 * every light again on the next call. Errors: LRR_ERR_INVALID_ARG unless
 * 0 <= tolerance < 1; LRR_ERR_NOMEM (about 68 × n bytes of scratch). */
LRR_API LRR_NODISCARD lrr_status lrr_lighting_set_tolerance(lrr_lighting *lighting,
                                                            double tolerance) LRR_NONNULL(1);

/* ---------------------------------------------------------------- memory */
/* 64-byte aligned allocation for SIMD and device buffers; size 0 gives NULL. */
LRR_API void *lrr_aligned_alloc(size_t size);
LRR_API void lrr_aligned_free(void *p);

#ifdef __cplusplus
}
#endif
#endif /* LRR_H */
