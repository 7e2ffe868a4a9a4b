/* The scene stage (lib/scene/): input triangles with their materials, and each triangle's
 * quadtree of patches and subpatches (subdivide.c). Used by every later stage. */
#ifndef LRR_SCENE_H
#define LRR_SCENE_H

#include "core/internal.h"

#include <math.h>

/* ------------------------------------------------------------ geometry and hierarchy */
/* Input triangles and their subdivision; shared by scenes and operators.
 * Triangle t is split into 4^depth[t] patches, numbered patch0[t] .. patch0[t+1]-1, and each
 * patch into d = 4^levels subpatches. Children of a split (a,b,c) are, in order:
 *   0 (a, ab, ca)   1 (ab, b, bc)   2 (ca, bc, c)   3 (bc, ca, ab)
 * where ab is the midpoint of a and b. A patch/subpatch's local index is its sequence of
 * child digits, most significant first (base 4), so every node of a triangle's quadtree
 * covers a contiguous, aligned range of its subpatches.
 *
 * Adaptive hierarchy (node != NULL): depth[t] is then the subpatch depth of triangle t,
 * levels = 0 and d = 0, and the patches are quadtree nodes of varying depth node[p] <=
 * depth[t]: patch p holds the 4^(depth[t] - node[p]) subpatches first[p] .. first[p+1]-1.
 * first and sub0 exist in both cases (uniform: first[p] = p·d, sub0[t] = patch0[t]·d), so
 * code that walks patches' subpatches need not know which hierarchy it has.
 *
 * Cluster hierarchy (origin != NULL, hierarchy/cluster.c): depth[t] is the subpatch depth,
 * levels = 0, d = 0, node = patch0 = NULL, and a patch is any group of subpatches, across
 * triangles. Subpatches are numbered patch-major (patch p holds first[p] .. first[p+1]-1);
 * the triangle order j (sub0[t] + the quadtree index, the scene's order) maps to it by
 * order[j], and back by origin[i]. Code that walks a triangle's subpatches goes through
 * lrr__subpatch_id. */
typedef struct lrr__geometry {
    size_t n_tri;
    float *vert;        /* n_tri×9 */
    uint8_t *depth;     /* n_tri, patch depth (adaptive: subpatch depth); NULL until subdivided */
    size_t *patch0;     /* n_tri+1: first patch of each triangle; NULL until subdivided */
    size_t *sub0;       /* n_tri+1: first subpatch of each triangle */
    size_t *first;      /* k+1: first subpatch of each patch */
    uint8_t *node;      /* k: quadtree depth of each patch (adaptive only, else NULL) */
    size_t *order;      /* n: triangle order → patch-major index (clusters only, else NULL) */
    size_t *origin;     /* n: patch-major → triangle order (clusters only, else NULL) */
    unsigned levels;
    size_t d, k, n;     /* d = 4^levels (0 if adaptive), k patches, n subpatches */
} lrr__geometry;

void lrr__geometry_free(lrr__geometry *g);
/* Deep copy (dst is overwritten). */
lrr_status lrr__geometry_copy(lrr_context *ctx, lrr__geometry *dst, const lrr__geometry *src);
/* Computes patch0/sub0/first/k/n/d from depth and levels (uniform hierarchy); checks for
 * overflow, and refuses (before allocating the offsets) more than max_subpatches
 * subpatches: a file's depths must not make the loader allocate beyond what its header
 * and size allow. */
lrr_status lrr__geometry_index(lrr_context *ctx, lrr__geometry *g, size_t max_subpatches);
/* dst = the adaptive hierarchy over src's subpatches (src uniform with levels = 0) whose
 * patches are the k quadtree nodes of depth node[0..k-1], in index order. Checks that they
 * tile every triangle (each node aligned, inside its triangle, no gaps); errors (status
 * `bad`) name `where` and the patch. */
lrr_status lrr__geometry_adaptive(lrr_context *ctx, const lrr__geometry *src,
                                  const uint8_t *node, size_t k, const char *where,
                                  lrr_status bad, lrr__geometry *dst);
/* dst = src's subpatches (src with levels = 0 and no clusters) grouped into the k clusters
 * given by origin (n: the triangle-order subpatch at each patch-major position; a
 * permutation) and first (k+1: each cluster's first position, first[0] = 0, first[k] = n,
 * ascending). Both are copied and checked; errors (status `bad`) name `where`. */
lrr_status lrr__geometry_clusters(lrr_context *ctx, const lrr__geometry *src,
                                 const size_t *origin, const size_t *first, size_t k,
                                 const char *where, lrr_status bad, lrr__geometry *dst);
/* The patch-major index of the subpatch at triangle order j (sub0[t] + local index). */
static inline size_t lrr__subpatch_id(const lrr__geometry *g, size_t j)
{
    return g->order ? g->order[j] : j;
}
/* Vᵀ's weights w (n floats, patch-major): patch p's radiosity is the area-weighted mean
 * Σ_{j∈p} (A_j / A_p) B_j = Σ_{j∈p} w_j B_j / d_p, so w_j = d_p A_j / A_p, exactly 1 where a
 * patch's subpatches have equal areas (every quadtree patch; docs/METHOD.md "Clusters"). */
void lrr__patch_weights(const lrr__geometry *g, float *w);
/* Subpatches in patch p. */
static inline size_t lrr__patch_size(const lrr__geometry *g, size_t p)
{
    return g->first[p + 1] - g->first[p];
}
/* Patch holding subpatch i. */
size_t lrr__patch_of(const lrr__geometry *g, size_t i);

/* Index of the child containing barycentric (b0,b1,b2), rewriting them to the child's. */
static inline unsigned lrr__child_at(double *b0, double *b1, double *b2)
{
    double u = *b0, v = *b1, w = *b2;
    if (u >= 0.5) { *b0 = 2 * u - 1; *b1 = 2 * v; *b2 = 2 * w; return 0; }
    if (v >= 0.5) { *b0 = 2 * u; *b1 = 2 * v - 1; *b2 = 2 * w; return 1; }
    if (w >= 0.5) { *b0 = 2 * u; *b1 = 2 * v; *b2 = 2 * w - 1; return 2; }
    *b0 = 1 - 2 * u; *b1 = 1 - 2 * v; *b2 = 1 - 2 * w; return 3;
}
/* Descends `depth` levels, returning the base-4 digits as an index. Inline: the hemicube
 * resolves every pixel through it. */
static inline size_t lrr__descend(double *b0, double *b1, double *b2, unsigned depth)
{
    size_t idx = 0;
    for (unsigned l = 0; l < depth; l++)
        idx = idx * 4 + lrr__child_at(b0, b1, b2);
    return idx;
}
/* Clamps (b1, b2) into the triangle and sets b0 = 1 - b1 - b2. */
static inline void lrr__clamp_bary(double *b1, double *b2, double *b0)
{
    if (!(*b1 > 0)) *b1 = 0;
    if (!(*b2 > 0)) *b2 = 0;
    if (*b1 > 1) *b1 = 1;
    if (*b2 > 1) *b2 = 1;
    *b0 = 1 - *b1 - *b2;
    if (*b0 < 0) {
        double s = *b1 + *b2;
        *b1 /= s;
        *b2 /= s;
        *b0 = 0;
    }
}
/* Subpatch index of barycentric point (b1, b2) (b0 = 1-b1-b2) of triangle t. */
size_t lrr__subpatch_at(const lrr__geometry *g, size_t t, double b1, double b2);
/* The corners of child c (lrr__child_at's numbering) of the triangle v (3 corners of dim
 * doubles each, dim 2 or 3: positions or texture coordinates) into out. */
void lrr__child_corners(const double *v, int dim, unsigned c, double *out);
/* The patch of leaf `leaf` (lrr__descend's index, depth[t] levels) of triangle t. */
size_t lrr__patch_of_leaf(const lrr__geometry *g, size_t t, size_t leaf);
/* Triangle that owns subpatch i (binary search on sub0). */
size_t lrr__subpatch_triangle(const lrr__geometry *g, size_t i);
/* Vertices (9 doubles) of subpatch i, in the triangle's orientation. */
void lrr__subpatch_vertices(const lrr__geometry *g, size_t i, double v[9]);
/* Per-subpatch centre (n×3), unit normal (n×3) and area (n); any may be NULL. */
void lrr__subpatch_frames(const lrr__geometry *g, float *centre, float *normal, float *area);
/* The bounding box lo, hi of g's input triangles (all 0 when it has none); returns its
 * diagonal, the length scale of ray offsets and tolerances. lo and hi may be NULL. */
double lrr__geometry_bounds(const lrr__geometry *g, double lo[3], double hi[3]);

/* Area of triangle v (9 floats), in double. */
static inline double lrr__tri_area(const float *v)
{
    double e1[3], e2[3];
    for (int j = 0; j < 3; j++) {
        e1[j] = (double)v[3 + j] - v[j];
        e2[j] = (double)v[6 + j] - v[j];
    }
    double c0 = e1[1] * e2[2] - e1[2] * e2[1], c1 = e1[2] * e2[0] - e1[0] * e2[2],
           c2 = e1[0] * e2[1] - e1[1] * e2[0];
    return 0.5 * sqrt(c0 * c0 + c1 * c1 + c2 * c2);
}
static inline double lrr__dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void lrr__cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
/* v /= |v| (unchanged when |v| = 0). */
static inline void lrr__normalize3(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (len > 0)
        for (int j = 0; j < 3; j++)
            v[j] /= len;
}

/* ------------------------------------------------------------ scene */
enum { LRR__SCENE_FILE = 0, LRR__SCENE_CORNELL = 1, LRR__SCENE_CORNELL_CLOSED = 2 };
typedef struct lrr__scene_textures lrr__scene_textures; /* scene/texture.h */

struct lrr_scene {
    lrr_context *ctx;
    int builtin;          /* LRR__SCENE_* : chooses the render camera */
    size_t skipped;       /* zero-area triangles removed */
    lrr__geometry geom;
    float *rho;           /* n_tri×3 */
    float *emission;      /* n_tri×3 */
    double max_patch_area;
    lrr__scene_textures *textures; /* NULL: every material is flat (texture.h) */
};

/* Splits polygon p (n >= 3 points, n×3 doubles) into n-2 triangles tri[3t..3t+2] (indices
 * into p) with the polygon's own orientation; idx is n scratch entries (triangulate.c). */
void lrr__triangulate(size_t n, const double *p, unsigned *idx, unsigned *tri);
/* Checks a PLY file (f at its start, file_size bytes) before assimp reads it: a strict
 * header, and a body that holds what the header declares (scene_ply.c). */
lrr_status lrr__ply_check(lrr_context *ctx, const char *path, FILE *f, uint64_t file_size);
/* Validates and takes a copy of the arrays: NaN/Inf coordinates and bad materials are errors
 * naming `source` and the face index face_ids[t] (or t when face_ids is NULL); zero-area
 * triangles are skipped and counted. */
lrr_status lrr__scene_from_arrays(lrr_context *ctx, size_t n_tri, const float *vert,
                                  const float *rho, const float *emission,
                                  const size_t *face_ids, const char *source, int builtin,
                                  lrr_scene **out);

/* scene_import.c: every imported triangle, degenerate ones included, with its face number
 * (nothing validated); free the arrays with lrr_aligned_free. For the scene check. */
lrr_status lrr__scene_import_raw(lrr_context *ctx, const char *path, size_t *n_tri,
                                 float **vert, float **rho, float **emission,
                                 size_t **face_ids);
/* check_names.c: releases what lrr_check_report_names filled in (for
 * lrr_check_report_destroy). */
void lrr__check_names_free(lrr_check_report *r);
#endif
