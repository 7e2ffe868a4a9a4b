/* The operator stage (lib/operator/): the low-rank operator (F̄, M_c), its storage formats
 * and the memory a build needs. Used by the solvers, the file format, probes and output. */
#ifndef LRR_OPERATOR_H
#define LRR_OPERATOR_H

#include "scene/scene.h"

#include <string.h>

struct lrr_operator {
    lrr_context *ctx;
    int builtin;               /* LRR__SCENE_* of the source scene */
    lrr__geometry geom;
    size_t n, k, d;
    float *rho;                /* n×3 */
    float *emission;           /* n×3, the scene's own emission */
    float *area;               /* n */
    float *weight;             /* n: Vᵀ's weights, 1 unless clusters (weights.c) */
    int weighting;             /* LRR__WEIGHTS_*: how a cluster's weights are derived */
    float *centre, *normal;    /* n×3, derived from geom (not stored in files) */
    lrr_storage storage;       /* which of fbar / fbar16 holds F̄ */
    int panels;                /* F̄ in panels (layout.c, lrr__fbar_index) rather than rows */
    float *fbar;               /* n×k, 64-byte aligned: F̄_ip = F_{i→p}/d (F32) */
    uint16_t *fbar16;          /* n×k binary16 or bfloat16 (F16, BF16), F̄_ip / row_scale_i */
    float *row_scale;          /* n powers of two (F16, BF16; all 1 for BF16) */
    float *m;                  /* 3×k×k row-major: M_c = G_c^{-1} */
    unsigned long m_epoch;     /* +1 whenever M is written (smw.c): solvers' copies of it
                                  (M − I in binary16, cached columns F̄ M_c) compare it */
    double cond[3];            /* dgecon estimates (1-norm) of G_c */
    double build_seconds;
    double selection_seconds;  /* adaptive selection's (clustering's) part of build_seconds */
    double formfactor_seconds, smw_seconds; /* the hemicubes' and the factorisation's */
    unsigned hemicube_resolution;
    uint64_t seed;
    int no_rotation;           /* built with lrr_build_options.no_rotation */
    int formfactor_method;     /* LRR_FORMFACTOR_RASTER or _RAYCAST; 0 after a load */
    int receiver_sampling;     /* LRR_RECEIVER_CENTRE or _AREA (INFO flags bit 1 in files) */
    struct {                   /* lrr_operator_verify's result (VERIFY section in files) */
        double rel_l2, noise, seconds;
        size_t subpatches, samples; /* subpatches = 0: not verified */
        int uniform;
    } verify;
    double back_face_share;    /* lrr_operator_info's leak indicator; 0 after a load */
    size_t worst_tri[LRR_BACK_FACE_WORST];   /* SIZE_MAX where unused */
    double worst_share[LRR_BACK_FACE_WORST];
};

/* Clusters' Vᵀ weights: from areas alone (w_j = d_p A_j / A_p, lrr__patch_weights; files of
 * version 3) or from areas and F̄'s row sums (lrr__visibility_weights, what builds use). */
enum { LRR__WEIGHTS_AREA = 0, LRR__WEIGHTS_VISIBILITY = 1 };
/* weights.c: with LRR__WEIGHTS_VISIBILITY, w_j = d_p A_j R_j / Σ_{i∈p} A_i R_i from the stored
 * F̄ (R_j = Σ_q F̄_jq d_q); otherwise nothing to do (the area weights stay). */
lrr_status lrr__visibility_weights(lrr_operator *op);
/* The same for the patches [p0, p1) alone, from their rows of F̄ held apart in fbar
 * (first[p0] .. first[p1] − 1, row-major in op's storage, op's row scales): what a row
 * block loaded alone needs (lrr__operator_load_rows). */
lrr_status lrr__visibility_weights_rows(lrr_operator *op, size_t p0, size_t p1,
                                        const void *fbar);
/* The two steps of the weights, for rows held apart (liblrr_mpi's build): row i's A_i R_i
 * from its decoded row; then patches [p0, p1)'s weights from ar (indexed from first[p0]),
 * area weights where a patch sees nothing. */
double lrr__visibility_row_sum(const lrr_operator *op, size_t i, const float *row);
void lrr__visibility_normalise(lrr_operator *op, size_t p0, size_t p1, const double *ar);

/* file/load_rows.c: a block of whole patches' rows of a saved operator, without the rest of
 * F̄. pick (called once, after the geometry, M and the row scales are read; op has no F̄)
 * chooses patches [*p0, *p1); *out is the operator without F̄ (rho, emission, weights, M,
 * row scales for all n; the block's Vᵀ weights as a whole load gives them) and b its rows
 * (b->fbar: rows×k in op's storage, row-major, lrr_aligned_free). Every check of
 * lrr_operator_load but those of F̄'s entries outside the block of a dense file. */
typedef struct lrr__fbar_block {
    size_t p0, p1, row0, rows;
    void *fbar;
} lrr__fbar_block;
typedef lrr_status (*lrr__pick_fn)(void *user, const lrr_operator *op, size_t *p0, size_t *p1);
lrr_status lrr__operator_load_rows(lrr_context *ctx, const char *path, lrr__pick_fn pick,
                                   void *user, lrr_operator **out, lrr__fbar_block *b);

/* Allocates an operator for geometry g (copied): rho, emission, area, centre, normal, m and
 * F̄ in the given storage (fbar, or fbar16 + row_scale) are allocated (zeroed);
 * area/centre/normal/weight are filled from the geometry. */
lrr_status lrr__operator_new(lrr_context *ctx, const lrr__geometry *g, lrr_storage storage,
                             lrr_operator **out);
/* The same, without F̄ unless parts has LRR__ALLOC_FBAR (fbar and fbar16 NULL; 16-bit
 * storage keeps its n row scales): the rest of an operator whose rows of F̄ are held
 * elsewhere (a row block loaded alone, lrr__operator_load_rows); with LRR__ALLOC_NO_M also
 * without M (m NULL: a rank of liblrr_mpi's build_save other than the root). */
enum { LRR__ALLOC_FBAR = 1, LRR__ALLOC_NO_M = 2 };
lrr_status lrr__operator_alloc(lrr_context *ctx, const lrr__geometry *g, lrr_storage storage,
                               int parts, lrr_operator **out);
/* LRR_OK when op holds F̄; else LRR_ERR_INVALID_ARG naming the public call `what`: op came
 * from lrr_operator_load_head, which leaves F̄ (and the visibility weights derived from it)
 * unread. Every public call that reads or rewrites F̄ asks this first. */
lrr_status lrr__need_fbar(const lrr_operator *op, const char *what);

/* Round-to-nearest-even conversions (storage.c). */
uint16_t lrr__f32_to_f16(float f);
/* The power of two s with max_abs/s in [2^14, 2^15) (1 when max_abs is 0): the row scale of
 * 16-bit F̄ and of M − I in binary16, which keeps a row's small entries normal numbers. */
float lrr__f16_scale(float max_abs);
/* Row `row` (k floats) coded in 16-bit `storage` into out, as lrr_operator_set_storage codes
 * F̄; its row scale (1 for bfloat16). */
float lrr__fbar_encode_row(lrr_storage storage, const float *row, size_t k, uint16_t *out);
/* A row of 16-bit codes held row-major (k of them) decoded with its row scale, as
 * lrr_operator_fbar_row decodes the operator's own. */
void lrr__fbar_decode_row(lrr_storage storage, float scale, const uint16_t *codes, size_t k,
                          float *out);
float lrr__f16_to_f32(uint16_t h);
uint16_t lrr__f32_to_bf16(float f);
float lrr__bf16_to_f32(uint16_t b);
/* Rewrites F̄ in `storage` (storage.c), as rows whatever the layout was; M is then stale:
 * lrr_operator_set_storage refactors and restores the layout. */
lrr_status lrr__fbar_convert(lrr_operator *op, lrr_storage storage);

/* layout.c: F̄ in panels. Rows [0, n − n % LRR__PANEL) are held in blocks of LRR__PANEL
 * rows, each block column-major (entry (i, q) at i0·k + LRR__PANEL·q + (i − i0), i0 the
 * block's first row), so that the real-time kernel multiplies a block's column by the
 * broadcast z_q with vertical FMAs and no horizontal sums; the last n % LRR__PANEL rows stay
 * row-major behind them. Each block occupies the bytes its rows occupy row-major, so the
 * two layouts convert in place, block by block. */
#define LRR__PANEL 32
/* bytes of one stored entry of F̄, and where the entries are */
static inline size_t lrr__fbar_elem_bytes(const lrr_operator *op)
{
    return op->storage == LRR_STORAGE_F32 ? sizeof(float) : sizeof(uint16_t);
}
static inline const void *lrr__fbar_data(const lrr_operator *op)
{
    return op->storage == LRR_STORAGE_F32 ? (const void *)op->fbar : (const void *)op->fbar16;
}
static inline size_t lrr__fbar_panel_rows(const lrr_operator *op)
{
    return op->panels ? op->n - op->n % LRR__PANEL : 0;
}
/* the element index of F̄_iq in fbar / fbar16 */
static inline size_t lrr__fbar_index(const lrr_operator *op, size_t i, size_t q)
{
    if (i >= lrr__fbar_panel_rows(op))
        return i * op->k + q;
    size_t r = i % LRR__PANEL;
    return (i - r) * op->k + LRR__PANEL * q + r;
}
/* Rewrites F̄ in place into panels (1) or rows (0); a no-op when it already is. Needs one
 * block of scratch per thread (LRR_ERR_NOMEM leaves F̄ as it was). */
lrr_status lrr__fbar_set_panels(lrr_operator *op, int panels);
/* Rows [i0, i1) of F̄ as stored (float, or the 16-bit codes), row-major into out. */
void lrr__fbar_copy_rows(const lrr_operator *op, size_t i0, size_t i1, void *out);

/* tiles.c: F̄ in tiles of LRR__TILE consecutive rows, and a tile's strips (one column of
 * it that holds a nonzero): what the sparse solver reads (lib/solve/sparse.c) and what
 * sparse .lrr files store (section FBAR_STRIPS, lib/file/). A tile lies in one panel
 * (LRR__PANEL is a multiple of LRR__TILE) or in the rows behind the panels. */
#define LRR__TILE 16
/* LRR_FBAR_AUTO keeps strips where they take at most this share of the dense bytes
 * (docs/METHOD.md "Sparse F̄": measured per-byte speeds of the two passes). */
#define LRR__SPARSE_AUTO_SHARE 0.5
/* Where tile t's entries are: entry (LRR__TILE·t + r, q) at element base + r·si + q·sq of
 * the stored F̄ (a panel's tile column is 16 contiguous elements); rows of them below n. */
typedef struct lrr__tile_at {
    size_t base, si, sq, rows;
} lrr__tile_at;
static inline lrr__tile_at lrr__fbar_tile(const lrr_operator *op, size_t t)
{
    const size_t i0 = t * LRR__TILE, k = op->k;
    lrr__tile_at a = {0, k, 1, op->n - i0 < LRR__TILE ? op->n - i0 : LRR__TILE};
    if (i0 < lrr__fbar_panel_rows(op)) {
        const size_t p0 = i0 - i0 % LRR__PANEL;
        a.base = p0 * k + (i0 - p0), a.si = 1, a.sq = LRR__PANEL;
    } else {
        a.base = i0 * k;
    }
    return a;
}
/* Entries of tile column q whose bits are not all zero (a −0 counts: its strip is kept, so
 * a file's F̄ loads back bit for bit; its products add nothing to a sum). */
static inline size_t lrr__fbar_tile_nonzeros(const lrr_operator *op, const lrr__tile_at *a,
                                             size_t q)
{
    size_t c = 0, at = a->base + q * a->sq;
    if (op->storage == LRR_STORAGE_F32) {
        for (size_t r = 0; r < a->rows; r++) {
            uint32_t bits;
            memcpy(&bits, &op->fbar[at + r * a->si], sizeof bits);
            c += bits != 0;
        }
    } else {
        for (size_t r = 0; r < a->rows; r++)
            c += op->fbar16[at + r * a->si] != 0;
    }
    return c;
}
typedef struct lrr__strip_count {
    size_t tiles, strips, nonzeros;
} lrr__strip_count;
/* Counts every tile's strips into count_at[t] (tiles entries; NULL: totals only) and the
 * totals; with parallel, in OpenMP threads for large F̄ (not while saving: a process that
 * forked after using OpenMP must not start threads, and lrr_operator_save used none). */
void lrr__fbar_count_strips(const lrr_operator *op, size_t *count_at, int parallel,
                            lrr__strip_count *out);
/* Bytes of one strip in memory (LRR__TILE values in `storage`, a u16 column) and of the
 * solver's sparse copy of `strips` strips (with its start array), and whether AUTO prefers
 * that copy: at most LRR__SPARSE_AUTO_SHARE of the dense bytes, and k within the u16 index. */
size_t lrr__sparse_strip_bytes(lrr_storage storage);
size_t lrr__sparse_bytes(const lrr_operator *op, size_t strips);
int lrr__sparse_pays(const lrr_operator *op, size_t strips);

/* budget.c: the bytes an operator build holds at its peak (the layout is described there),
 * for n_tri input triangles, n subpatches, k patches, F̄ in `storage` and the resolved build
 * options o (hemicube resolution, threads, backend). Overflow-checked: LRR_ERR_OVERFLOW,
 * naming n and k, when a byte count does not fit in size_t; LRR_ERR_INVALID_ARG for a bad
 * hemicube resolution. Allocates nothing. */
typedef struct lrr__operator_bytes_t {
    size_t fbar;          /* F̄ (and its row scales) */
    size_t m;             /* M_c, 3×k×k floats */
    size_t per_subpatch;  /* 13 floats per subpatch and the geometry */
    size_t working;       /* the build's largest working set (hemicubes or factorisation) */
    size_t total;
    int threads;          /* the thread count the working set was computed for */
} lrr__operator_bytes_t;
lrr_status lrr__operator_bytes(lrr_context *ctx, size_t n_tri, size_t n, size_t k,
                               lrr_storage storage, const lrr_build_options *o,
                               lrr__operator_bytes_t *out);
/* lrr__operator_bytes, then LRR_ERR_BUDGET naming the need (in MiB, with its parts) when it
 * exceeds o->memory_budget (0: no limit). */
lrr_status lrr__operator_budget_check(lrr_context *ctx, size_t n_tri, size_t n, size_t k,
                                      lrr_storage storage, const lrr_build_options *o);
/* The same for a build that holds only fbar_rows of F̄'s n rows, and M unless !with_m
 * (liblrr_mpi's rank). */
lrr_status lrr__operator_budget_check_rows(lrr_context *ctx, size_t n_tri, size_t n,
                                           size_t fbar_rows, size_t k, lrr_storage storage,
                                           int with_m, const lrr_build_options *o);

/* smw.c: recomputes M_c = (I − Vᵀ diag(rho_c) F̄)⁻¹ and cond from F̄ (in any storage) and
 * rho, in double precision (LAPACKE). */
lrr_status lrr__smw_factor(lrr_operator *op);
/* G's row p gathers row i of F̄ (fi, decoded) for channel c: gp −= w_i rho_ic fi, in the
 * order lrr__smw_factor adds a patch's rows (rows first[p] .. first[p+1]−1, then gp[p] += 1),
 * so that G assembled elsewhere (liblrr_mpi's ranks) is the same bit for bit. */
void lrr__smw_g_add(const lrr_operator *op, int c, size_t i, const float *fi, double *gp);
/* M_c = G⁻¹ and cond[c] from an assembled G (k×k doubles, row-major; overwritten). */
lrr_status lrr__smw_invert(lrr_operator *op, int c, double *G);

#endif
