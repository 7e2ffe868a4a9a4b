/* The reference stage (lib/reference/): solvers of the full discrete equation to measure the
 * low-rank operator against. What other stages may use of it beyond lrr.h. */
#ifndef LRR_REFERENCE_H
#define LRR_REFERENCE_H

#include "reference/rows.h"
#include "scene/scene.h"

/* The path tracer of lrr_reference_path_trace (path_trace.c) as an object, so that several
 * batches of subpatches share one BVH: the scene's triangles emitting `emission` (n_tri×3,
 * finite, >= 0, kept by pointer for the tracer's life) instead of the scene's own when it
 * is not NULL. lrr__tracer_rows traces the subpatches rows[0..count) of the scene (its
 * order; rows NULL: all n) into radiosity and std_error (count×3; std_error may be NULL),
 * as lrr_reference_path_trace does with opts. */
lrr_status lrr__tracer_create(const lrr_scene *scene, const float *emission, lrr__tracer **out);
/* lrr__tracer_rows and lrr__tracer_destroy: reference/rows.h (exported for liblrr_mpi). */

#endif
