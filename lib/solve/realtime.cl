/* The real-time step on an OpenCL device (lib/solve/opencl.c), per frame and channel c:
 *     w_c = V^T E_c                     segsum: one work-item per patch (weights vw,
 *                                       1 unless patches are clusters)
 *     z_c = M_c w_c                     smw: one work-item per row of M_c and channel
 *     B_c = E_c + rho_c * (Fbar z_c)    fbar_rows / fbar_groups: Fbar read once for all
 *                                       three channels, the epilogue fused
 * E, rho, B are n x 3 interleaved; w and z 3 x k channel-major; M three k x k row-major
 * blocks. Fbar is n x k in the operator's storage, rows [0, np) in panels of PANEL rows
 * stored column-major and the rest row-major (lib/operator/operator.h; np = 0: all rows),
 * its elements chosen by -DSTORAGE=:
 *     0  float
 *     1  IEEE binary16 (vload_half, which needs no cl_khr_fp16), row i times scale[i]
 *     2  bfloat16 (the high half of a float), row i times scale[i] (all 1)
 * -DWG= is the work-group size of fbar_groups (a power of two).
 * Kept to OpenCL C 1.2 and plain ASCII: it is embedded in the library as a C string.
 */
#ifndef STORAGE
#define STORAGE 0
#endif
#ifndef WG
#define WG 64
#endif
#ifndef PANEL
#define PANEL 32
#endif

/* Row i's first entry and the distance between its entries: in a panel, consecutive rows
 * are adjacent, so the work-items of fbar_rows read contiguous memory (coalesced on a GPU,
 * vectorisable across items on a CPU). */
#define ROW_BASE(i) ((i) < np ? (size_t)((i) / PANEL * PANEL) * k + (i) % PANEL : (size_t)(i) * k)
#define ROW_STEP(i) ((i) < np ? PANEL : 1u)

#if STORAGE == 0
#define FBAR_T float
#define LOAD(p, j) ((p)[j])
#elif STORAGE == 1
#define FBAR_T half
#define LOAD(p, j) vload_half((j), (p))
#elif STORAGE == 2
#define FBAR_T ushort
#define LOAD(p, j) as_float((uint)(p)[j] << 16)
#else
#error "STORAGE must be 0 (float), 1 (binary16) or 2 (bfloat16)"
#endif

/* w[c*k + p] = sum of E over patch p's subpatches first[p] .. first[p+1]-1 (d of them, or
 * d_p in an adaptive hierarchy). The host validated E. Compensated (Kahan) float sums stand
 * in for the CPU's double accumulators: doubles are optional in OpenCL 1.2. */
__kernel void segsum(__global const float *E, uint k, __global const uint *first,
                     __global float *w, __global const float *vw)
{
    const uint p = get_global_id(0);
    if (p >= k)
        return;
    float s[3] = {0, 0, 0}, comp[3] = {0, 0, 0};
    for (uint i = first[p]; i < first[p + 1]; i++)
        for (int c = 0; c < 3; c++) {
            float y = vw[i] * E[3 * i + c] - comp[c];
            float t = s[c] + y;
            comp[c] = (t - s[c]) - y;
            s[c] = t;
        }
    for (int c = 0; c < 3; c++)
        w[c * k + p] = s[c];
}

/* z[c*k + r] = row r of M_c times w_c; global size (k, 3). */
__kernel void smw(__global const float *m, __global const float *w, uint k, __global float *z)
{
    const uint r = get_global_id(0), c = get_global_id(1);
    if (r >= k)
        return;
    __global const float *row = m + ((size_t)c * k + r) * k;
    __global const float *x = w + (size_t)c * k;
    float t = 0;
    for (uint q = 0; q < k; q++)
        t += row[q] * x[q];
    z[(size_t)c * k + r] = t;
}

/* One work-item per row, walking its k entries in order: CPU devices (which get F̄ as rows,
 * opencl.c upload_fbar), and GPUs when F̄ is in panels (neighbouring items then read
 * neighbouring addresses). Measured on PoCL (2 CPU cores), F̄ as rows: 7.7 ms a frame,
 * against 46-150 ms for column-major layouts and 8.7 ms for panels of the same matrix. */
__kernel void fbar_rows(__global const FBAR_T *fbar, __global const float *scale,
                        __global const float *z, __global const float *E,
                        __global const float *rho, uint n, uint k, __global float *B, uint np)
{
    const uint i = get_global_id(0);
    if (i >= n)
        return;
    __global const FBAR_T *row = fbar + ROW_BASE(i);
    const size_t step = ROW_STEP(i);
    float t0 = 0, t1 = 0, t2 = 0;
    for (uint j = 0; j < k; j++) {
        const float f = LOAD(row, j * step);
        t0 += f * z[j];
        t1 += f * z[k + j];
        t2 += f * z[2 * k + j];
    }
#if STORAGE != 0
    const float s = scale[i];
    t0 *= s;
    t1 *= s;
    t2 *= s;
#endif
    const size_t b = 3 * (size_t)i;
    B[b] = E[b] + rho[b] * t0;
    B[b + 1] = E[b + 1] + rho[b + 1] * t1;
    B[b + 2] = E[b + 2] + rho[b + 2] * t2;
}

/* GPUs: one work-group of WG items per row, item l reading entries l, l + WG, ... so that
 * a group's loads are contiguous (coalesced), then a tree reduction in local memory.
 * Unmeasured on a GPU (there was none where this was written); correct on PoCL. */
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void fbar_groups(__global const FBAR_T *fbar, __global const float *scale,
                 __global const float *z, __global const float *E, __global const float *rho,
                 uint n, uint k, __global float *B, uint np)
{
    __local float red[3 * WG];
    const uint i = get_group_id(0), l = get_local_id(0);
    __global const FBAR_T *row = fbar + ROW_BASE(i);
    const size_t step = ROW_STEP(i);
    float t0 = 0, t1 = 0, t2 = 0;
    for (uint j = l; j < k; j += WG) {
        const float f = LOAD(row, j * step);
        t0 += f * z[j];
        t1 += f * z[k + j];
        t2 += f * z[2 * k + j];
    }
    red[l] = t0;
    red[WG + l] = t1;
    red[2 * WG + l] = t2;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = WG / 2; h > 0; h >>= 1) {
        if (l < h) {
            red[l] += red[l + h];
            red[WG + l] += red[WG + l + h];
            red[2 * WG + l] += red[2 * WG + l + h];
        }
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0 && i < n) {
        float s = 1;
#if STORAGE != 0
        s = scale[i];
#endif
        const size_t b = 3 * (size_t)i;
        B[b] = E[b] + rho[b] * (red[0] * s);
        B[b + 1] = E[b + 1] + rho[b + 1] * (red[WG] * s);
        B[b + 2] = E[b + 2] + rho[b + 2] * (red[2 * WG] * s);
    }
}
