/* Vᵀ's weights for clusters (docs/METHOD.md "Clusters"): the share of a cluster's radiosity
 * that each of its subpatches contributes to what the scene gathers from it.
 *
 *     R_j = Σ_q F̄_jq d_q          (row j of F: the share of j's hemisphere that meets the scene)
 *     w_j = d_p A_j R_j / Σ_{i∈p} A_i R_i                     (Σ_{j∈p} w_j = d_p)
 *
 * By reciprocity Σ_i A_i F_ij = A_j R_j, so all receivers together gather Σ_{j∈p} A_j R_j B_j
 * from cluster p, which these weights reproduce for any B; area weights (A_j alone) lose the
 * light wherever B and R correlate inside a cluster (a floor under a roof beside one under
 * the sky): on data/scenes/fzk_haus at K = 2000 the reflected light of faces looking down
 * was 0.91× the path tracer's with area weights and 0.97× with these (bench/results/
 * 2026-12-03-accuracy.md). A cluster none of whose subpatches sees the scene keeps area
 * its area weights (its light reaches nobody either way). Computed from F̄ as stored, in double, in
 * a fixed order: a build, a load and a storage change give the same weights for the same
 * stored F̄. */
#include "config.h"
#include "operator/operator.h"

#include <omp.h>
#include <string.h>

/* Row i's F̄ decoded: from op, or from a block (row-major, op's storage) holding rows from
 * row0 on, as lrr_operator_fbar_row decodes them. */
static void fbar_row(const lrr_operator *op, const void *block, size_t row0, size_t i,
                     float *out)
{
    const size_t k = op->k;
    if (!block) {
        lrr_operator_fbar_row(op, i, out);
    } else if (op->storage == LRR_STORAGE_F32) {
        memcpy(out, (const float *)block + (i - row0) * k, k * sizeof(float));
    } else {
        lrr__fbar_decode_row(op->storage, op->row_scale[i],
                             (const uint16_t *)block + (i - row0) * k, k, out);
    }
}

double lrr__visibility_row_sum(const lrr_operator *op, size_t i, const float *row)
{
    const size_t *first = op->geom.first;
    double r = 0;
    for (size_t q = 0; q < op->k; q++)
        r += (double)row[q] * (double)(first[q + 1] - first[q]);
    return (double)op->area[i] * r;
}

void lrr__visibility_normalise(lrr_operator *op, size_t p0, size_t p1, const double *ar)
{
    const size_t *first = op->geom.first, i0 = first[p0];
    lrr__patch_weights(&op->geom, op->weight);
    #pragma omp parallel for schedule(static)
    for (size_t p = p0; p < p1; p++) {
        double sum = 0;
        for (size_t i = first[p]; i < first[p + 1]; i++)
            sum += ar[i - i0];
        if (!(sum > 0))
            continue; /* the area weights written above */
        const double dp = (double)(first[p + 1] - first[p]);
        for (size_t i = first[p]; i < first[p + 1]; i++)
            op->weight[i] = (float)(dp * ar[i - i0] / sum);
    }
}

/* The weights of patches [p0, p1), from op's F̄ or a block of their rows. */
static lrr_status weights(lrr_operator *op, size_t p0, size_t p1, const void *block)
{
    if (op->weighting != LRR__WEIGHTS_VISIBILITY)
        return LRR_OK; /* quadtree (1) and area-weighted clusters: from the geometry */
    const size_t k = op->k, *first = op->geom.first, i0 = first[p0], rows = first[p1] - i0;
    double *ar;
    float *buf;
    const int threads = omp_get_max_threads();
    lrr_status st = lrr__calloc(op->ctx, &ar, rows ? rows : 1, sizeof(double),
                                "visibility weights");
    if (st)
        return st;
    if ((st = lrr__calloc(op->ctx, &buf, (size_t)threads, k * sizeof(float),
                          "decoded F̄ rows"))) {
        lrr_aligned_free(ar);
        return st;
    }
    #pragma omp parallel for schedule(static) num_threads(threads)
    for (size_t i = i0; i < i0 + rows; i++) {
        float *row = buf + (size_t)omp_get_thread_num() * k;
        fbar_row(op, block, i0, i, row);
        ar[i - i0] = lrr__visibility_row_sum(op, i, row);
    }
    lrr__visibility_normalise(op, p0, p1, ar);
    lrr_aligned_free(ar);
    lrr_aligned_free(buf);
    return LRR_OK;
}

lrr_status lrr__visibility_weights(lrr_operator *op) { return weights(op, 0, op->k, NULL); }

lrr_status lrr__visibility_weights_rows(lrr_operator *op, size_t p0, size_t p1,
                                        const void *fbar)
{
    return weights(op, p0, p1, fbar);
}
