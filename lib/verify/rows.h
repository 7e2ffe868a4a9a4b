/* lrr_operator_verify with its path tracing handed to the caller, for liblrr_mpi's
 * distributed verify (lib/mpi/verify.c). PRIVATE ABI, as lib/solve/rows.h: exported under
 * LRR_PRIVATE_2 (lib/liblrr.map) for liblrr_mpi alone; names only lrr.h's types. */
#ifndef LRR_VERIFY_ROWS_H
#define LRR_VERIFY_ROWS_H

#include "lrr.h"

#include "core/private_api.h"

typedef struct lrr__tracer lrr__tracer;

/* Traces the subpatches rows[0..count) (the scene's order) with o into radiosity and
 * std_error (count×3; std_error may be NULL), as lrr__tracer_rows does with `tracer`, the
 * verify's own; uniform: the verify's emission is 1 on every triangle (the scene emits
 * nothing), else the scene's (lrr__trace_start's argument). */
typedef lrr_status (*lrr__verify_trace_fn)(void *user, const lrr__tracer *tracer, int uniform,
                                           const lrr_path_trace_options *o, const size_t *rows,
                                           size_t count, float *radiosity, float *std_error);

/* lrr_operator_verify, every path tracing done by fn (NULL: the verify's own tracer). Each
 * path has its own random stream from (seed, subpatch, sample), so a fn that returns what
 * the tracer would gives the serial figures bit for bit. */
LRR__PRIVATE_API lrr_status lrr__verify_with(lrr_operator *op, const lrr_scene *scene,
                                             const lrr_verify_options *opts,
                                             lrr__verify_trace_fn fn, void *user);

#endif
