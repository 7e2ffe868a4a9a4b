/* A block of F̄'s rows, solved in the two halves of a distributed frame (lib/solve/rows.c):
 * what liblrr_mpi (lib/mpi/) needs of the serial library, and nothing else.
 *
 * PRIVATE ABI. These functions are exported from liblrr.so under the version node
 * LRR_PRIVATE_0 (lib/liblrr.map) for liblrr_mpi alone: they are not part of lrr.h, may
 * change in any release, and a change renames the node so that a liblrr_mpi built against
 * another liblrr fails to load instead of misbehaving. The header names only lrr.h's types,
 * so lib/mpi/ includes it without the library's internals. */
#ifndef LRR_SOLVE_ROWS_H
#define LRR_SOLVE_ROWS_H

#include "lrr.h"

#include "core/private_api.h"

typedef struct lrr__rows lrr__rows;

/* The rows of patches [p0, p1) of op (p0 <= p1 <= k; rows first[p0] .. first[p1] − 1, see
 * lrr_operator_patch_offsets): their F̄ rows copied in op's storage, held in panels, read
 * dense or as strips as lrr_solver_create's AUTO chooses; their rho, emission and Vᵀ
 * weights; all of M (3×k×k), read as lrr_solver_create reads it (M − I in binary16 when
 * F̄ is 16-bit, else the floats). op may be destroyed afterwards; the block holds a reference to
 * op's context, where its errors are recorded. p0 = p1 gives an empty block (no rows).
 * LRR_SIMD is read as lrr_solver_create reads it. */
LRR__PRIVATE_API lrr_status lrr__rows_create(const lrr_operator *op, size_t p0, size_t p1,
                                             lrr__rows **out);
/* The same block loaded from a .lrr file without the rest of F̄: pick (called once, with
 * the operator's n, k and patch offsets first[0..k]) chooses [*p0, *p1); the file is
 * checked as lrr_operator_load checks it (F̄'s section by its checksum; a dense F̄'s
 * entries within the block), and the block equals lrr__rows_create's of the loaded
 * operator. A rank holds its rows of F̄ (and, while loading, one 1 MiB piece) instead of
 * the whole. */
typedef lrr_status (*lrr__rows_pick_fn)(void *user, const lrr_operator *op, size_t *p0,
                                        size_t *p1);
LRR__PRIVATE_API lrr_status lrr__rows_load(lrr_context *ctx, const char *path,
                                           lrr__rows_pick_fn pick, void *user,
                                           lrr__rows **out);
LRR__PRIVATE_API void lrr__rows_destroy(lrr__rows *r);
/* The block's context (held by it), its first row (global index) and row count. */
LRR__PRIVATE_API lrr_context *lrr__rows_context(const lrr__rows *r);
LRR__PRIVATE_API void lrr__rows_range(const lrr__rows *r, size_t *row0, size_t *rows);
/* The block's rows of the scene's stored emission (rows×3; NULL for an empty block). */
LRR__PRIVATE_API const float *lrr__rows_emission(const lrr__rows *r);
/* The kernel variant the block runs (lrr_solver_kernel's names). */
LRR__PRIVATE_API const char *lrr__rows_kernel(const lrr__rows *r);
/* Bytes of F̄ a frame reads in this block (dense or strips) and of M (as read). */
LRR__PRIVATE_API void lrr__rows_bytes(const lrr__rows *r, size_t *fbar_bytes, size_t *m_bytes);

/* First half of a frame: w (3×k, channel-major) = Vᵀ E over the block's patches, 0 for the
 * others, so that the sum of every block's w is the serial solver's w. E is the block's
 * rows (rows×3), finite and >= 0: otherwise LRR_ERR_INVALID_ARG naming the subpatch by its
 * global index and the channel, as lrr_solve does. */
LRR__PRIVATE_API lrr_status lrr__rows_vte(lrr__rows *r, const float *E, float *w);
/* Second half: B (rows×3) = E + rho ∘ (F̄_rows · (M_c w_c)) with w the sum over the blocks
 * (the serial full path's products: lrr__smw_apply or _f16, and the fused F̄ pass). */
LRR__PRIVATE_API void lrr__rows_apply(lrr__rows *r, const float *w, const float *E, float *B);

/* Records an error on ctx as the library does (first error kept, callback called), the
 * message given whole. Returns status. */
LRR__PRIVATE_API lrr_status lrr__rows_record(lrr_context *ctx, lrr_status status,
                                             const char *message);
/* The first error recorded on ctx and not yet read (LRR_OK if none), its message copied
 * into msg (NUL-terminated, len > 0), without clearing it: for sending to other ranks. */
LRR__PRIVATE_API lrr_status lrr__rows_peek(lrr_context *ctx, char *msg, size_t len);
/* Tests only: lrr__context_fail_after (the n-th allocation counted on ctx fails). */
LRR__PRIVATE_API void lrr__rows_fail_after(lrr_context *ctx, unsigned long n);

#endif
