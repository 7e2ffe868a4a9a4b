/* Shared by the OpenCL parts of lrr (solve/opencl.c, formfactor/hemicube_opencl.c): the OpenCL
 * headers at the version lrr uses, error reporting and device selection. Only included
 * when the library is built with OpenCL. */
#ifndef LRR_OPENCL_UTIL_H
#define LRR_OPENCL_UTIL_H

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include "core/internal.h"

/* The name of a CL error code ("CL_OUT_OF_RESOURCES"). */
const char *lrr__cl_code_name(cl_int err);

/* Records a failed OpenCL call: which call, on what, and the CL error code (NOMEM for the
 * out-of-memory codes, UNSUPPORTED otherwise). */
lrr_status lrr__cl_fail(lrr_context *ctx, cl_int err, const char *call, const char *what);

/* The device to use: LRR_OPENCL_DEVICE (a case-insensitive substring of "platform /
 * device", or an index P:D) when set, else the first GPU, else the first CPU device. */
lrr_status lrr__cl_pick_device(lrr_context *ctx, cl_device_id *out);

#endif
