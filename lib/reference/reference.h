/* The reference stage (lib/reference/): solvers of the full discrete equation to measure the
 * low-rank operator against. What other stages may use of it beyond lrr.h. */
#ifndef LRR_REFERENCE_H
#define LRR_REFERENCE_H

#include "scene/scene.h"

/* lrr_reference_path_trace for the subpatches rows[0..count) of the scene (its order) only,
 * into radiosity and std_error (count×3; std_error may be NULL); rows NULL: all n, as
 * lrr_reference_path_trace. The triangles emit `emission` (n_tri×3, finite, >= 0) instead
 * of the scene's own when it is not NULL. */
lrr_status lrr__path_trace_rows(const lrr_scene *scene, const lrr_path_trace_options *opts,
                                const size_t *rows, size_t count, const float *emission,
                                float *radiosity, float *std_error);

#endif
