/* The path tracer over a list of subpatches, for liblrr_mpi's distributed reference
 * (lib/mpi/trace.c). PRIVATE ABI, as lib/solve/rows.h: exported under LRR_PRIVATE_1
 * (lib/liblrr.map) for liblrr_mpi alone; names only lrr.h's types. */
#ifndef LRR_REFERENCE_ROWS_H
#define LRR_REFERENCE_ROWS_H

#include "lrr.h"

#include "core/private_api.h"

/* lrr_reference_path_trace's estimates of subpatches rows[0..count) (the scene's order):
 * radiosity and std_error (count×3 each, std_error may be NULL) row r for subpatch
 * rows[r], bit for bit those lrr_reference_path_trace gives them (each path has its own
 * random stream from (seed, subpatch, sample)). */
LRR__PRIVATE_API lrr_status lrr__trace_rows(const lrr_scene *scene,
                                            const lrr_path_trace_options *opts,
                                            const size_t *rows, size_t count,
                                            float *radiosity, float *std_error);
/* The scene's context (errors are recorded there). */
LRR__PRIVATE_API lrr_context *lrr__trace_context(const lrr_scene *scene);

#endif
