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

/* ---- A build whose rows of F̄ stay on the ranks that computed them (liblrr_mpi's
 * lrr_mpi_operator_build_save, lib/mpi/build_save.c): every rank begins with the operator
 * without F̄ (storage `storage`, its 16-bit row scales allocated; without M unless with_m:
 * the root's alone; the budget counts fbar_rows of F̄'s rows, and M with_m), computes its rows (lrr__build_rows, not placed), codes them
 * (lrr__build_encode), gives their sums for the Vᵀ weights and adds them into G's rows;
 * one rank inverts each G and finishes. The same arithmetic in the same order as
 * lrr_operator_build followed by lrr_operator_set_storage, so F̄, the weights, G and M are
 * theirs bit for bit. */
LRR__PRIVATE_API lrr_status lrr__build_begin_rows(const lrr_scene *scene,
                                                  const lrr_build_options *opts,
                                                  lrr_storage storage, size_t fbar_rows,
                                                  int with_m, lrr__build **out);
/* The build's operator (no F̄): n, k, offsets, storage through lrr.h's getters. */
LRR__PRIVATE_API lrr_operator *lrr__build_operator(lrr__build *b);
/* Its n row scales (16-bit storage; NULL for floats): a rank's own are written by
 * lrr__build_encode, the others' may be received there. */
LRR__PRIVATE_API float *lrr__build_row_scales(lrr__build *b);
/* Receivers rows[0..count−1]'s rows (block, count×k floats) coded in place in the
 * operator's storage (row j at element j·k of the block's uint16_t), their row scales set;
 * nothing for floats. scratch: 2k floats. */
LRR__PRIVATE_API void lrr__build_encode(lrr__build *b, const size_t *rows, size_t count,
                                        float *block, float *scratch);
/* Whether the patches' Vᵀ weights follow F̄'s row sums (clusters): then ar[j] = A_i R_i of
 * receiver i = rows[j] from its coded row in block, and lrr__build_set_weights sets every
 * weight from all n sums (ar in the operator's order). scratch: k floats. */
LRR__PRIVATE_API int lrr__build_visibility(const lrr__build *b);
LRR__PRIVATE_API void lrr__build_row_sums(lrr__build *b, const size_t *rows, size_t count,
                                          const void *block, float *scratch, double *ar);
LRR__PRIVATE_API void lrr__build_set_weights(lrr__build *b, const double *ar);
/* G_c's row p gathers receiver i's coded row (i in patch p; rows first[p] .. first[p+1]−1
 * in order, starting from zeros, then gp[p] += 1): gp −= w_i rho_ic F̄_i. scratch: k
 * floats. */
LRR__PRIVATE_API void lrr__build_g_add(lrr__build *b, int c, size_t i, const void *row,
                                       float *scratch, double *gp);
/* M_c = G⁻¹ and its condition from the assembled G (k×k doubles, overwritten). */
LRR__PRIVATE_API lrr_status lrr__build_invert(lrr__build *b, int c, double *G);
/* M_c's k×k floats (row-major) in the operator, for an inversion done elsewhere (liblrr_mpi's
 * ScaLAPACK one, lib/mpi/invert.c); NULL when the build has no M. Then its condition
 * estimate (INFINITY when rcond was 0), which also marks M as written. */
LRR__PRIVATE_API float *lrr__build_m(lrr__build *b, int c);
LRR__PRIVATE_API void lrr__build_set_cond(lrr__build *b, int c, double cond);
/* The operator (no F̄) with its timings and the leak indicator from the n back-face
 * shares at lrr__build_back; *out takes it. */
LRR__PRIVATE_API lrr_status lrr__build_finish_rows(lrr__build *b, double formfactor_seconds,
                                                   double smw_seconds, lrr_operator **out);

#endif
