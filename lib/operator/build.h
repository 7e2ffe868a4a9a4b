/* The build of an operator in three stages (lib/operator/build.c): begin (options, memory
 * budget, the hierarchy's selection), rows (the hemicubes of a block of receivers: their rows
 * of F̄ and back-face shares), finish (Vᵀ weights, the SMW factorisation, panels, the leak
 * indicator). lrr_operator_build runs them over every row; liblrr_mpi's distributed build
 * (lib/mpi/build.c) runs begin on every rank, rows over each rank's block and finish on one
 * rank with the gathered rows: the same code, so the same F̄ bit for bit.
 *
 * PRIVATE ABI, as lib/solve/rows.h: exported under LRR_PRIVATE_0 (lib/liblrr.map) for
 * liblrr_mpi alone; names only lrr.h's types. */
#ifndef LRR_OPERATOR_BUILD_H
#define LRR_OPERATOR_BUILD_H

#include "lrr.h"

#include "core/private_api.h"

typedef struct lrr__build lrr__build;

/* Options (lrr_build_options, defaults filled in), the memory budget, the hierarchy (the
 * adaptive or cluster selection, replicated wherever begin runs) and, when whole, the
 * operator whose F̄ (n×k floats) and n back-face shares rows then fill in place. */
LRR__PRIVATE_API lrr_status lrr__build_begin(const lrr_scene *scene,
                                             const lrr_build_options *opts, int whole,
                                             lrr__build **out);
LRR__PRIVATE_API void lrr__build_destroy(lrr__build *b);
/* A scene's context (errors are recorded there). */
LRR__PRIVATE_API lrr_context *lrr__build_scene_context(const lrr_scene *scene);
/* The selected hierarchy's subpatches n and patches k. */
LRR__PRIVATE_API void lrr__build_size(const lrr__build *b, size_t *n, size_t *k);
/* A 64-bit checksum of the selected hierarchy (n, k, the offsets, the subpatch order and
 * the triangles): equal on two ranks when they selected the same operator. */
LRR__PRIVATE_API uint64_t lrr__build_fingerprint(const lrr__build *b);
/* A whole build's F̄ (n×k floats, row-major) and back-face shares (n doubles), to be
 * filled (by rows or received); NULL otherwise. */
LRR__PRIVATE_API float *lrr__build_fbar(lrr__build *b);
LRR__PRIVATE_API double *lrr__build_back(lrr__build *b);
/* The hemicubes of receivers rows[0..count−1]: their rows of F̄ (k floats each) and
 * back-face shares at fbar's row r and back[r], or when placed at row rows[r] (fbar n×k,
 * back n), on the CPU; with rows NULL, every receiver's into the whole build's arrays (on
 * the backend the options ask for). The options' threads and progress (count receivers). */
LRR__PRIVATE_API lrr_status lrr__build_rows(lrr__build *b, const size_t *rows, size_t count,
                                            int placed, float *fbar, double *back);
/* A whole build with every row filled: weights, factorisation, panels and the leak
 * indicator; formfactor_seconds as the operator reports it. *out takes the operator (the
 * build keeps nothing of it). */
LRR__PRIVATE_API lrr_status lrr__build_finish(lrr__build *b, double formfactor_seconds,
                                              lrr_operator **out);

#endif
