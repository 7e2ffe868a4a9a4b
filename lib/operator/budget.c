/* The memory an operator build takes (lrr_build_options.memory_budget), computed from the
 * sizes alone with overflow-checked arithmetic, so that a build that cannot fit, or whose
 * sizes do not even fit in size_t, is refused before anything large is allocated.
 *
 * What lrr_operator_build holds at its peak:
 *   kept       F̄ (n×k in its storage; 16-bit storage adds n row scales), M (3×k×k floats),
 *              14 floats per subpatch (rho, emission, centre, normal n×3 each, area and Vᵀ
 *              weight n), the copied geometry (36 + 1 bytes per input triangle, n_tri+1
 *              patch offsets) and for clusters the renumbering (2 size_t per subpatch);
 *   working    the larger of the two phases, which never overlap:
 *                hemicubes  multiplier map (R² + R²/2 doubles) and its per-row prefix
 *                           sums ((R + R/2)·(R + 1) doubles, rasteriser only), triangle table
 *                           (LRR__HEMICUBE_TRI_BYTES per triangle) and per thread a depth,
 *                           an item and a leaf-code buffer (3R² floats, int32 and uint32)
 *                           and one row (k doubles);
 *                           each receiver's back-face share (n doubles);
 *                           on an OpenCL device the host holds a batch of patch ids instead
 *                           of the per-thread item buffers (see device_rows in hemicube.c)
 *                factor     G (k×k doubles) and k pivots (plus one decoded row of F̄ per
 *                           thread with 16-bit storage);
 *                selection  (adaptive hierarchy) the sampled and emitters' rows of F, the
 *                           radiosity weights and the greedy split's error rows; (clusters)
 *                           the tree and the sample (lrr__cluster_bytes) and the scene's
 *                           per-subpatch copies (13 floats per subpatch).
 * Allocator overhead (64-byte alignment, headers) and third-party memory (OpenMP stacks,
 * LAPACK workspace, the OpenCL runtime) are not counted. */
#include "config.h"
#include "formfactor/formfactor.h"
#include "hierarchy/hierarchy.h"
#include "operator/operator.h"

#include <lapacke.h>
#include <omp.h>
#include <string.h>

/* *acc += a·b·c; false on overflow. */
static bool add3(size_t *acc, size_t a, size_t b, size_t c)
{
    size_t t;
    return lrr__mul_size(a, b, &t) && lrr__mul_size(t, c, &t) &&
           !__builtin_add_overflow(*acc, t, acc);
}

/* Ids of one device batch of hemicubes (hemicube.c, device_rows): at most 256 hemicubes and
 * 64 MiB, at least one. */
static size_t device_batch(size_t n, size_t pixels)
{
    size_t batch = ((size_t)64 << 20) / (pixels * sizeof(int32_t));
    if (batch > 256)
        batch = 256;
    if (batch < 1)
        batch = 1;
    if (batch > n)
        batch = n ? n : 1;
    return batch;
}

lrr_status lrr__operator_bytes(lrr_context *ctx, size_t n_tri, size_t n, size_t k,
                               lrr_storage storage, const lrr_build_options *o,
                               lrr__operator_bytes_t *out)
{
    memset(out, 0, sizeof *out);
    const unsigned R = o->hemicube_resolution ? o->hemicube_resolution : 128;
    if (R < 8 || R > 4096 || R % 2)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "hemicube resolution %u: must be even and in 8..4096", R);
    const int threads = o->threads > 0 ? o->threads : omp_get_max_threads();
    out->threads = threads > 0 ? threads : 1;
    const size_t T = (size_t)out->threads, rr = (size_t)R * R, half = storage != LRR_STORAGE_F32;
    size_t hemi = 0, factor = 0;
    bool ok = add3(&out->fbar, n, k, half ? sizeof(uint16_t) : sizeof(float)) &&
              (!half || add3(&out->fbar, n, 1, sizeof(float))) &&
              add3(&out->m, 3 * sizeof(float), k, k) &&
              add3(&out->per_subpatch, n, 14, sizeof(float)) &&
              (o->hierarchy != LRR_HIERARCHY_CLUSTER ||
               add3(&out->per_subpatch, n, 2, sizeof(size_t))) &&
              add3(&out->per_subpatch, n_tri, 1, 9 * sizeof(float) + 1) &&
              add3(&out->per_subpatch, n_tri, 1, sizeof(size_t)) &&
              add3(&out->per_subpatch, 1, 1, sizeof(size_t)) &&
              /* hemicube phase */
              add3(&hemi, rr + rr / 2, 1, sizeof(double)) &&
              add3(&hemi, (size_t)R + R / 2, (size_t)R + 1, sizeof(double)) && /* its prefix sums */
              add3(&hemi, n_tri, 1, LRR__HEMICUBE_TRI_BYTES) &&
              (o->hierarchy != LRR_HIERARCHY_CLUSTER ||
               add3(&hemi, n, 1, sizeof(uint32_t))) && /* each subpatch's cluster */
              add3(&hemi, T, 3 * rr, sizeof(float)) && add3(&hemi, T, k, sizeof(double)) &&
              add3(&hemi, T, 3 * rr, sizeof(uint32_t)) && /* the leaf codes (rasteriser) */
              add3(&hemi, n, 1, sizeof(double)); /* back-face shares (leak indicator) */
    if (ok && o->backend == LRR_BACKEND_OPENCL)
        ok = add3(&hemi, device_batch(n, 3 * rr), 3 * rr, sizeof(int32_t)) &&
             add3(&hemi, 3 * rr, 1, sizeof(double)); /* the multiplier map's upload */
    else if (ok)
        ok = add3(&hemi, T, 3 * rr, sizeof(int32_t));
    /* factor phase */
    ok = ok && add3(&factor, k, k, sizeof(double)) && add3(&factor, k, 1, sizeof(lapack_int)) &&
         (!half || add3(&factor, T, k, sizeof(float)));
    /* adaptive selection phase (adaptive.c), before the hemicubes: the sampled rows of F
     * (S×n floats) and the emitters' rows, the radiosity weights and the scene's
     * per-subpatch copies, and per sampled row 3 doubles for every node in the heap and
     * every merge candidate of the exchanges (and 3 more per node), 3 more such rows */
    size_t select = 0;
    if (ok && o->adaptive_patches && o->hierarchy == LRR_HIERARCHY_CLUSTER) {
        ok = lrr__cluster_bytes(n, o->adaptive_samples, o->adaptive_split, &select) &&
             add3(&select, n, 13, sizeof(float));
    } else if (ok && o->adaptive_patches) {
        size_t S = o->adaptive_samples ? o->adaptive_samples : LRR__ADAPTIVE_DEFAULT_SAMPLES;
        S = S < n ? S : n;
        size_t em = n < LRR__ADAPTIVE_MAX_EMITTER_ROWS ? n : LRR__ADAPTIVE_MAX_EMITTER_ROWS;
        ok = add3(&select, S, n, sizeof(float)) && add3(&select, em, n, sizeof(float)) &&
             add3(&select, n, 3, 2 * sizeof(double)) && add3(&select, n, 7, sizeof(float)) &&
             add3(&select, k + k / 4 + 8, 3 * S + 6, sizeof(double)) &&
             add3(&select, 3, 3 * S, sizeof(double)) && add3(&select, 2 * k + k / 4 + 2, 1, 96) &&
             add3(&select, T, 3 * rr / 16, sizeof(float) + sizeof(int32_t));
    }
    out->working = hemi > factor ? hemi : factor;
    out->working = select > out->working ? select : out->working;
    ok = ok && !__builtin_add_overflow(out->fbar, out->m, &out->total) &&
         !__builtin_add_overflow(out->total, out->per_subpatch, &out->total) &&
         !__builtin_add_overflow(out->total, out->working, &out->total);
    if (!ok)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "an operator of n = %zu subpatches and k = %zu patches: its size in "
                          "bytes (F̄ alone is n×k×%zu) overflows size_t",
                          n, k, half ? sizeof(uint16_t) : sizeof(float));
    return LRR_OK;
}

lrr_status lrr__operator_budget_check(lrr_context *ctx, size_t n_tri, size_t n, size_t k,
                                      lrr_storage storage, const lrr_build_options *o)
{
    return lrr__operator_budget_check_rows(ctx, n_tri, n, n, k, storage, 1, o);
}

lrr_status lrr__operator_budget_check_rows(lrr_context *ctx, size_t n_tri, size_t n,
                                           size_t fbar_rows, size_t k, lrr_storage storage,
                                           int with_m, const lrr_build_options *o)
{
    lrr__operator_bytes_t b;
    lrr_status st = lrr__operator_bytes(ctx, n_tri, n, k, storage, o, &b);
    if (st)
        return st;
    if (fbar_rows < n) { /* F̄'s other rows are held elsewhere: n·k already fitted */
        const size_t held = b.fbar / n * fbar_rows;
        b.total -= b.fbar - held;
        b.fbar = held;
    }
    if (!with_m) { /* M is held elsewhere (the root's) */
        b.total -= b.m;
        b.m = 0;
    }
    if (o->memory_budget == 0 || b.total <= o->memory_budget)
        return LRR_OK;
    const double MiB = 1048576.0;
    return lrr__error(ctx, LRR_ERR_BUDGET,
                      "an operator of n = %zu subpatches and k = %zu patches needs %.1f MiB "
                      "(F̄ %.1f MiB%s, M %.1f MiB, per-subpatch data %.1f MiB, build buffers "
                      "%.1f MiB for %d threads), more than the memory budget of %.1f MiB%s",
                      n, k, b.total / MiB, b.fbar / MiB,
                      fbar_rows < n ? " for this rank's rows" : "", b.m / MiB,
                      b.per_subpatch / MiB, b.working / MiB, b.threads,
                      o->memory_budget / MiB,
                      o->hierarchy == LRR_HIERARCHY_CLUSTER
                          ? " (fewer clusters, adaptive_patches, shrink F̄ and M)"
                          : " (quadtree patches give k >= the triangle count; the cluster "
                            "hierarchy, LRR_HIERARCHY_CLUSTER with adaptive_patches = K, "
                            "gives k = K whatever the triangle count)");
}
