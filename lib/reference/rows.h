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
/* One tracer for many lists (the BVH built once): the scene's emission, or with uniform 1
 * on every triangle (lrr_operator_verify's, for a scene that emits nothing).
 * lrr__tracer_rows traces rows[0..count) (NULL: all n) as lrr__trace_rows does. */
typedef struct lrr__tracer lrr__tracer;
LRR__PRIVATE_API lrr_status lrr__trace_start(const lrr_scene *scene, int uniform,
                                             lrr__tracer **out);
LRR__PRIVATE_API lrr_status lrr__tracer_rows(const lrr__tracer *t,
                                             const lrr_path_trace_options *opts,
                                             const size_t *rows, size_t count,
                                             float *radiosity, float *std_error);
LRR__PRIVATE_API void lrr__tracer_destroy(lrr__tracer *t);
/* The scene's context (errors are recorded there). */
LRR__PRIVATE_API lrr_context *lrr__trace_context(const lrr_scene *scene);

#endif
