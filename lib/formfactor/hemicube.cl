/* Hemicube integration on an OpenCL device (lib/formfactor/hemicube_opencl.c).
 *
 * A batch of `count` hemicubes arrives as patch ids, P = 3R² per hemicube (top face R×R,
 * then the four (R/2)×R side faces, exactly the CPU's item-buffer layout), -1 where nothing
 * (or a back face) is seen. `multiply` applies the multiplier map; `reduce` sums per patch
 * into one row of F̄ per hemicube, in the CPU's pixel order, then scales by 1/d.
 * REAL is double where the device has cl_khr_fp64 (then the rows equal the CPU's bit for
 * bit), float otherwise. */
#if USE_FP64
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef double real;
#else
typedef float real;
#endif

/* w[g] = weight[g mod P] where a patch is seen, else 0; one work-item per pixel. */
__kernel void multiply(__global const int *ids, __global const real *weight,
                       __global real *w, ulong P, ulong total)
{
    ulong g = get_global_id(0);
    if (g >= total)
        return;
    w[g] = ids[g] >= 0 ? weight[g % P] : (real)0;
}

/* One work-item per hemicube: its k-wide row (acc, zeroed here) gathers the weights of its
 * P pixels in pixel order — deterministic, no atomics — and is written out as float. */
__kernel void reduce(__global const int *ids, __global const real *w, __global real *acc,
                     __global float *out, ulong P, uint k, real scale, uint count)
{
    uint r = (uint)get_global_id(0);
    if (r >= count)
        return;
    __global real *row = acc + (ulong)r * k;
    __global const int *id = ids + (ulong)r * P;
    __global const real *wr = w + (ulong)r * P;
    for (uint p = 0; p < k; p++)
        row[p] = 0;
    for (ulong q = 0; q < P; q++) {
        int p = id[q];
        if (p >= 0)
            row[p] += wr[q];
    }
    __global float *o = out + (ulong)r * k;
    for (uint p = 0; p < k; p++)
        o[p] = (float)(row[p] * scale);
}
