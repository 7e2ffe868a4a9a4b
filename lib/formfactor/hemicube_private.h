/* What the rasteriser (hemicube.c, hemicube_raster.c, hemicube_integrate.c and its SIMD
 * steps) and raycast.c (Embree rays through the same pixels) share: the per-triangle table, a
 * face of one receiver's hemicube and the build's constants. The frame, the per-receiver
 * rotation, the pixel centres and the multiplier map stay in hemicube.c, the turning of an
 * item buffer (triangle ids) into a row in hemicube_integrate.c; raycast.c only fills the item
 * buffer. */
#ifndef LRR_FORMFACTOR_HEMICUBE_PRIVATE_H
#define LRR_FORMFACTOR_HEMICUBE_PRIVATE_H

#include "core/cpu.h"
#include "formfactor/formfactor.h"

typedef struct lrr__tri_info {
    double v0[3], e1[3], e2[3];
    double n[3];                 /* unnormalised geometric normal (v1-v0)×(v2-v0) */
    double g11, g12, g22, inv;   /* Gram matrix of e1, e2 and 1/det for barycentrics */
} lrr__tri_info;

/* One face of a receiver's hemicube: pixel (c, r) looks along right·sx + up·sy + fwd with
 * sx = (c + 0.5)/(W/2) - 1 and sy = (r + 0.5)/(W/2) (side) or that minus 1 (top). */
typedef struct lrr__hemi_face {
    double right[3], up[3], fwd[3];
    int W, H;              /* pixels */
    int side;              /* 0 top: rows span [-1,1]; 1 side: rows span heights [0,1] */
    const double *sy;      /* per row: its sy (hemi_ctx's sy_top or sy_side) */
    const double *weight;  /* multiplier map of this face */
    const double *prefix;  /* per row y, W + 1 running sums of weight from 0 (hemi_ctx's
                              prefix maps; unused by rays) */
    float *depth;          /* the rasteriser's z-buffer (unused by rays) */
    int32_t *item;         /* per pixel, what is seen from the front: the triangle
                              (rasteriser) or already its patch (ray caster); else
                              LRR__ITEM_NONE or LRR__ITEM_BACK */
    uint32_t *code;        /* per pixel where the item is a triangle with codes (SIMD
                              rasteriser, lrr__hemi_simd.depth_rows): its leaf code */
} lrr__hemi_face;

/* Item-buffer markers: nothing seen (or a triangle edge-on), or the back of a triangle,
 * which occludes and carries nothing; the integration skips both (any id < 0) and sums the
 * back faces' delta form factors for the light-leak indicator (lrr_operator_info). */
enum { LRR__ITEM_NONE = -1, LRR__ITEM_BACK = -2 };

/* Triangle v's (9 floats) row of the table (the rasteriser's, and the ray caster's v0, n). */
void lrr__hemi_tri_info(const float v[9], lrr__tri_info *ti);

typedef struct lrr__raycaster lrr__raycaster;
typedef struct lrr__hemi_simd lrr__hemi_simd;

typedef struct lrr__hemi_ctx {
    const lrr__geometry *g;
    const lrr__tri_info *tri;     /* the rasteriser's; NULL when casting rays */
    const lrr__multiplier_map *mm;
    double near, eps;      /* near plane and "on the plane" distance, scene units */
    int by_subpatch;       /* 1: columns are subpatches (full F, n wide); 0: patches (F̄) */
    const lrr__raycaster *rc; /* non-NULL: pixels by ray casting (raycast.c), else raster */
    const lrr__hemi_simd *simd; /* the SIMD steps (lrr__hemi_simd_pick), chosen once per
                                   build; NULL: the scalar path */
    const uint16_t *cells; /* the rasteriser's leaves of the regular grids
                              (lrr__hemi_cell_table, hemicube_integrate.c) */
    const double *sx;      /* per pixel column x: (x + 0.5)/(R/2) − 1, as the faces have it */
    const double *sy_top, *sy_side; /* per pixel row y: sy of the top face and of the sides */
    const double *pre_top, *pre_side; /* the multiplier maps' prefix sums per row (R + 1
                                         per row, from 0): a run's weight in O(1) */
    int area_origins;      /* LRR_RECEIVER_AREA (rays only): each pixel's ray from its own
                              random point of the receiver (raycast.c) */
    const uint32_t *patch_at; /* clusters, patch columns: the patch of each patch-major
                                 position (n), else NULL */
} lrr__hemi_ctx;

/* The column of leaf `leaf` of triangle t (lrr__descend's index at depth[t], or at
 * depth[t] + levels for subpatch columns): uniform quadtrees inline, clusters by table
 * rather than a binary search over the k clusters' first positions per pixel (FZK-Haus,
 * --clusters 2000 --hemicube 32, ray cast, Zen 5: form factors 8.87 -> 8.17 s from the
 * centres, 12.99 -> 12.06 s over the area, F̄ bit for bit the same). */
static inline size_t lrr__hemi_leaf_target(const lrr__hemi_ctx *h, size_t t, size_t leaf)
{
    const lrr__geometry *g = h->g;
    if (h->by_subpatch)
        return lrr__subpatch_id(g, g->sub0[t] + leaf);
    if (h->patch_at)
        return h->patch_at[g->order[g->sub0[t] + leaf]];
    if (!g->origin && !g->node)
        return g->patch0[t] + leaf;
    return lrr__patch_of_leaf(g, t, leaf);
}

/* A SIMD leaf code (lrr__hemi_simd's leaves_run and depth_rows): with the cell table, a
 * pixel's cell (a table slot, the lookup left to the caller: once per run of equal codes) or
 * its leaf | LRR__LEAF_DESCENT (descended; depth <= 6, so leaves < 2^12); without, the leaf.
 * Equal leaves may have two codes. */
#define LRR__LEAF_DESCENT 0x80000000u
static inline uint32_t lrr__hemi_leaf_of(uint32_t code, const uint16_t *cells)
{
    return !cells ? code : code & LRR__LEAF_DESCENT ? code & ~LRR__LEAF_DESCENT : cells[code];
}
/* Where a row changes: bit x of mask ((n + 63)/64 words, all written) is set when x == 0 or
 * v[x] != v[x − 1], for x < n; the scalar path's loop (finding runs pixel by pixel costs a
 * fifth of a Cornell R 64 profile). */
void lrr__hemi_breaks(const int32_t *v, int n, uint64_t *mask);
#define LRR__LEAF_TABLE_DEPTH 6 /* hemicube_integrate.c's cell table: leaf depths 0..6 */
/* Edge function coefficients A·px + B·py + C of one edge of a screen triangle
 * (hemicube_raster.c's edge_setup, edge_span). */
typedef struct {
    double A, B, C;
    int owns_ties;   /* top-left rule: this triangle owns pixel centres exactly on the edge */
    double k0, k1;   /* A ≠ 0: the crossing pixel index k0 + k1·py, an estimate (edge_span) */
    double tol;      /* how far (pixels) that estimate may be from where the computed edge
                        function changes sign (edge_span); +inf for A = 0 */
} lrr__hemi_edge;
/* What depth_rows needs to write a triangle's leaf codes where it wins the depth test: its
 * barycentric plane on the face (hemicube_raster.h's lrr__bary_plane), the face's sx and sy
 * per column and row, its leaf depth (1..LRR__LEAF_TABLE_DEPTH) and the face's code buffer
 * (W a row). */
typedef struct {
    double b1[3], b2[3], den[3];
    const double *sxt, *syt; /* hemi_ctx.sx, the face's sy */
    unsigned depth;
    uint32_t *code;
} lrr__hemi_codes;

/* The rasteriser's SIMD steps of one instruction set: four lanes (hemicube_avx2.c) or eight
 * (hemicube_avx512.c), each bit-identical to the scalar path, chosen once per build
 * (lrr__hemi_simd_pick into hemi_ctx.simd). */
struct lrr__hemi_simd {
    const char *name; /* "avx2", "avx512" */
    /* hemicube_raster.c's edge_span of the three edges for rows y0..y1 (py = y + 0.5) from
     * x0..x1, four or eight rows at a time: span[2(y − y0)], span[2(y − y0) + 1] get the
     * row's pixels (first > last: none) where edge_span's test-free cases settle every edge,
     * else span[2(y − y0)] = INT32_MIN (the caller runs edge_span). Returns whether any row
     * was left to the caller (a row loop per triangle saved: ~1 in 1500 rows of a Cornell
     * R 64 hemicube is one). */
    int (*spans)(const lrr__hemi_edge e[3], int x0, int x1, int y0, int y1, int32_t *span);
    /* depth_span of rows y0..y1 at py = y + 0.5, row y's pixels span[2(y − y0)] ..
     * span[2(y − y0) + 1] (none when the first is greater); depth and item point at the face
     * (W pixels a row). With lc, also code[pixel] for the pixels it wins: the code
     * leaves_run gives that pixel (with the cell table), so the integration needs no per-run
     * leaf pass (a fit of its time at R 64 and 128, Cornell, puts that pass's set-up at ~150
     * cycles a run of a triangle against ~2.6 a pixel). */
    void (*depth_rows)(const double abc[9], const double iz[3], double inv_area, int y0,
                       int y1, const int32_t *span, int W, float *depth, int32_t *item,
                       int32_t id, const lrr__hemi_codes *lc);
    /* The rasteriser's depth test for pixels L..R of the row at py of one triangle
     * (raster_tri's scalar loop): abc holds the edge functions A, B, C of the weights of
     * the three vertices, iz their 1/depth; depth and item point at the row. */
    void (*depth_span)(const double abc[9], const double iz[3], double inv_area, double py,
                       int L, int R, float *depth, int32_t *item, int32_t id);
    /* The leaves (base-4 index after `depth` <= 16 levels of lrr__child_at) of pixels a..b
     * of a row at height sy showing one triangle whose barycentrics are (b1k·(sx,sy,1),
     * b2k·(sx,sy,1)) / denk·(sx,sy,1), sx = sxt[x], into leaf[0..b−a]: codes for
     * lrr__hemi_leaf_of, the leaves of hemicube_integrate.c's leaf_at. cells: the leaf
     * table of this depth, or NULL to descend. brk gets lrr__hemi_breaks of the b − a + 1
     * codes (made as they are: a pass over them per run costs 4% of a Cornell R 64
     * profile). */
    void (*leaves_run)(const double b1k[3], const double b2k[3], const double denk[3],
                       const double *sxt, double sy, int a, int b, unsigned depth,
                       const uint16_t *cells, uint32_t *leaf, uint64_t *brk);
    /* lrr__hemi_breaks of two rows of n in one pass: v's into mv, and where v or u changes
     * into mu (inside a run of one v, u's breaks); 8 or 16 lanes a step, a 64-pixel word in
     * registers. */
    void (*breaks2)(const int32_t *v, const int32_t *u, int n, uint64_t *mv, uint64_t *mu);
};
extern const lrr__hemi_simd lrr__hemi_simd_avx2, lrr__hemi_simd_avx512; /* x86 only */
/* The table of level isa (core/cpu.h), NULL for LRR__ISA_C: the scalar path. */
const lrr__hemi_simd *lrr__hemi_simd_pick(lrr__isa isa);

/* An Embree scene (robust, watertight) of g's triangles, built once per form-factor build;
 * diag is the scene's bounding-box diagonal (for the ray origins' offset). */
lrr_status lrr__raycaster_create(lrr_context *ctx, const lrr__geometry *g, double diag,
                                 lrr__raycaster **out);
/* The ray caster's per-triangle table for the build of h (its columns, h->eps): after
 * create, before the first lrr__raycast_face. */
lrr_status lrr__raycaster_bind(lrr_context *ctx, lrr__raycaster *rc, const lrr__hemi_ctx *h);
/* The error of the first failed Embree call since create (LRR_OK if none): check after the
 * rays of a build, since Embree reports errors from inside the traversal by callback. */
lrr_status lrr__raycaster_status(lrr_context *ctx, const lrr__raycaster *rc);
void lrr__raycaster_destroy(lrr__raycaster *rc);
/* Fills f->item for the receiver at x with unit normal N: the patch (subpatch when
 * h->by_subpatch) each pixel's ray hits first, LRR__ITEM_NONE for a miss (or a triangle whose
 * plane holds the ray's origin), LRR__ITEM_BACK for a hit on a triangle's back (which
 * occludes and carries nothing, as in the rasteriser). The rays start at x, or with area (the
 * receiver's corners, 9 doubles) each at its own uniform point of the receiver, drawn from
 * key and the pixel. Thread-safe. */
void lrr__raycast_face(const lrr__hemi_ctx *h, const double x[3], const double N[3],
                       const double *area, uint64_t key, lrr__hemi_face *f);

/* LRR_FORMFACTOR_AUTO casts rays when triangles T > R² / LRR__RAYCAST_PIXELS_PER_TRIANGLE:
 * a raster hemicube costs ~ R² + c·T (every triangle is set up and clipped), a ray-cast one
 * ~ R² log T with a larger constant per pixel, so the crossover T grows like R². Measured
 * (bench/results/2026-12-02-raycast.md, Cornell box tessellated to T = 36·4^L, AMD EPYC,
 * 2 shared cores): raycast/raster hemicubes per second crosses 1 at T ≈ 150–580 for R = 32,
 * 580–2300 for R = 64 and 2300–9200 for R = 128, i.e. near R²/4 (256, 1024, 4096). */
#define LRR__RAYCAST_PIXELS_PER_TRIANGLE 4

#endif
