/* OpenCL error reporting and device selection, shared by the solver and the hemicube
 * integration (see opencl_util.h). */
#include "config.h"

#ifdef LRR_HAVE_OPENCL
#include "core/opencl_util.h"

#include <ctype.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *lrr__cl_code_name(cl_int e)
{
    switch (e) {
#define C(x) case x: return #x;
    C(CL_DEVICE_NOT_FOUND) C(CL_DEVICE_NOT_AVAILABLE) C(CL_COMPILER_NOT_AVAILABLE)
    C(CL_MEM_OBJECT_ALLOCATION_FAILURE) C(CL_OUT_OF_RESOURCES) C(CL_OUT_OF_HOST_MEMORY)
    C(CL_BUILD_PROGRAM_FAILURE) C(CL_INVALID_VALUE) C(CL_INVALID_DEVICE_TYPE)
    C(CL_INVALID_PLATFORM) C(CL_INVALID_DEVICE) C(CL_INVALID_CONTEXT)
    C(CL_INVALID_COMMAND_QUEUE) C(CL_INVALID_MEM_OBJECT) C(CL_INVALID_BUILD_OPTIONS)
    C(CL_INVALID_PROGRAM) C(CL_INVALID_PROGRAM_EXECUTABLE) C(CL_INVALID_KERNEL_NAME)
    C(CL_INVALID_KERNEL) C(CL_INVALID_ARG_INDEX) C(CL_INVALID_ARG_VALUE)
    C(CL_INVALID_ARG_SIZE) C(CL_INVALID_KERNEL_ARGS) C(CL_INVALID_WORK_DIMENSION)
    C(CL_INVALID_WORK_GROUP_SIZE) C(CL_INVALID_WORK_ITEM_SIZE) C(CL_INVALID_GLOBAL_OFFSET)
    C(CL_INVALID_EVENT_WAIT_LIST) C(CL_INVALID_OPERATION) C(CL_INVALID_BUFFER_SIZE)
    C(CL_INVALID_GLOBAL_WORK_SIZE) C(CL_MISALIGNED_SUB_BUFFER_OFFSET)
    C(CL_EXEC_STATUS_ERROR_FOR_EVENTS_IN_WAIT_LIST)
#undef C
    case -1001: return "CL_PLATFORM_NOT_FOUND_KHR";
    default: return "an unknown OpenCL error";
    }
}

/* Records a failed OpenCL call: which call, on what, and the CL error code. */
lrr_status lrr__cl_fail(lrr_context *ctx, cl_int err, const char *call, const char *what)
{
    lrr_status st = err == CL_OUT_OF_HOST_MEMORY || err == CL_MEM_OBJECT_ALLOCATION_FAILURE
                        ? LRR_ERR_NOMEM
                        : LRR_ERR_UNSUPPORTED;
    return lrr__error(ctx, st, "OpenCL: %s (%s) failed: %s (%d)", call, what, lrr__cl_code_name(err),
                      (int)err);
}

/* "platform name / device name" of one device, as LRR_OPENCL_DEVICE is matched against. */
static void device_label(cl_platform_id p, cl_device_id d, char *label, size_t size)
{
    char pn[128] = "", dn[128] = "";
    clGetPlatformInfo(p, CL_PLATFORM_NAME, sizeof pn - 1, pn, NULL);
    clGetDeviceInfo(d, CL_DEVICE_NAME, sizeof dn - 1, dn, NULL);
    snprintf(label, size, "%s / %s", pn, dn);
}

static int contains_nocase(const char *hay, const char *needle)
{
    size_t nl = strlen(needle);
    for (; *hay; hay++) {
        size_t i = 0;
        while (i < nl && hay[i] &&
               tolower((unsigned char)hay[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (i == nl)
            return 1;
    }
    return nl == 0;
}

lrr_status lrr__cl_pick_device(lrr_context *ctx, cl_device_id *out)
{
    enum { MAX_PLATFORMS = 16, MAX_DEVICES = 32 };
    cl_platform_id plat[MAX_PLATFORMS];
    cl_uint np = 0;
    cl_int err = clGetPlatformIDs(MAX_PLATFORMS, plat, &np);
    if (err == -1001 /* CL_PLATFORM_NOT_FOUND_KHR: the ICD loader found no driver */ ||
        (err == CL_SUCCESS && np == 0))
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "no OpenCL platform found (no driver registered with the ICD loader; "
                          "on Debian: apt-get install pocl-opencl-icd, or a GPU vendor's ICD)");
    if (err != CL_SUCCESS)
        return lrr__cl_fail(ctx, err, "clGetPlatformIDs", "listing platforms");
    if (np > MAX_PLATFORMS)
        np = MAX_PLATFORMS;
    const char *want = getenv("LRR_OPENCL_DEVICE");
    if (want && !want[0])
        want = NULL;
    unsigned wp = 0, wd = 0;
    char tail;
    const int by_index = want && sscanf(want, "%u:%u%c", &wp, &wd, &tail) == 2;
    cl_device_id gpu = NULL, cpu = NULL;
    char seen[200] = ""; /* the devices there are, for the error messages */
    for (cl_uint p = 0; p < np; p++) {
        cl_device_id dev[MAX_DEVICES];
        cl_uint nd = 0;
        err = clGetDeviceIDs(plat[p], CL_DEVICE_TYPE_ALL, MAX_DEVICES, dev, &nd);
        if (err == CL_DEVICE_NOT_FOUND)
            continue;
        if (err != CL_SUCCESS)
            return lrr__cl_fail(ctx, err, "clGetDeviceIDs", "listing a platform's devices");
        if (nd > MAX_DEVICES)
            nd = MAX_DEVICES;
        for (cl_uint d = 0; d < nd; d++) {
            char label[260];
            device_label(plat[p], dev[d], label, sizeof label);
            char entry[300];
            size_t used = strlen(seen);
            snprintf(entry, sizeof entry, "%s%u:%u %s", used ? "; " : "", (unsigned)p,
                     (unsigned)d, label);
            size_t len = strlen(entry), room = sizeof seen - 1 - used;
            memcpy(seen + used, entry, len < room ? len : room); /* truncated when long */
            seen[used + (len < room ? len : room)] = '\0';
            if (want) {
                if (by_index ? (p == wp && d == wd) : contains_nocase(label, want)) {
                    *out = dev[d];
                    return LRR_OK;
                }
                continue;
            }
            cl_device_type type = 0;
            clGetDeviceInfo(dev[d], CL_DEVICE_TYPE, sizeof type, &type, NULL);
            if ((type & CL_DEVICE_TYPE_GPU) && !gpu)
                gpu = dev[d];
            if ((type & CL_DEVICE_TYPE_CPU) && !cpu)
                cpu = dev[d];
        }
    }
    if (want)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "LRR_OPENCL_DEVICE='%s' matches no OpenCL device (have: %s)", want,
                          seen[0] ? seen : "none");
    if (!gpu && !cpu)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED, "no OpenCL GPU or CPU device found (have: %s)",
                          seen[0] ? seen : "none");
    *out = gpu ? gpu : cpu;
    return LRR_OK;
}

#else
/* built without OpenCL: nothing here (ISO C wants a translation unit to declare something) */
typedef int lrr__no_opencl;
#endif
