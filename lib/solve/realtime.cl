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
 * -DWG= is the work-group size of fbar_groups and smw_groups (a power of two).
 * A sparse F̄ (lib/solve/sparse.c) is read by fbar_strips instead: tiles of TILE rows, tile
 * t's strips [start[t], start[t+1]) each TILE values in the same storage and one column.
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
#ifndef TILE
#define TILE 16
#endif
/* z entries a work-group of fbar_panels holds in local memory at a time */
#define ZCHUNK 256

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

/* B of row i from its three sums t: E + rho * (t times the row's scale in 16 bits) */
static void put_b(__global float *B, __global const float *E, __global const float *rho,
                  __global const float *scale, uint i, const float t[3])
{
    const float s = STORAGE != 0 ? scale[i] : 1.0f;
    const size_t b = 3 * (size_t)i;
    for (int c = 0; c < 3; c++)
        B[b + c] = E[b + c] + rho[b + c] * (t[c] * s);
}

/* A work-group's three partial sums t of item l = g * step + r added up over the `count`
 * items g = 0 .. count - 1 (a power of two) that share r, through local memory red (3 * WG
 * floats): the totals come back in t of the items with g = 0. Every item must call it. */
static void sum3(__local float *red, uint l, uint g, uint count, uint step, float t[3])
{
    for (int c = 0; c < 3; c++)
        red[c * WG + l] = t[c];
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = count / 2; h > 0; h >>= 1) {
        if (g < h)
            for (int c = 0; c < 3; c++)
                red[c * WG + l] += red[c * WG + l + h * step];
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    for (int c = 0; c < 3; c++)
        t[c] = red[c * WG + l];
}

/* GPUs: w as segsum, one work-group of WG items per patch (group id p), item l summing
 * subpatches first[p] + l, + WG, ... (coalesced), then a tree reduction (whose error
 * grows as log WG, so no compensation). segsum's k items, each walking a patch's
 * subpatches alone, are too few to hide a GPU's latency (H200, Sponza: this 0.009 ms;
 * the three item-per-row kernels of the first version 6.2 ms together with B). */
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void segsum_groups(__global const float *E, uint k, __global const uint *first,
                   __global float *w, __global const float *vw)
{
    __local float red[3 * WG];
    const uint p = get_group_id(0), l = get_local_id(0);
    float s[3] = {0, 0, 0};
    for (uint i = first[p] + l; i < first[p + 1]; i += WG) {
        const float v = vw[i];
        s[0] += v * E[3 * i];
        s[1] += v * E[3 * i + 1];
        s[2] += v * E[3 * i + 2];
    }
    sum3(red, l, l, WG, 1, s);
    if (l == 0)
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

/* GPUs: z[c*k + r] with one work-group of WG items per row r and channel c (group id
 * r + k*c), item l reading entries l, l + WG, ... (coalesced), then a tree reduction. The
 * item-per-row smw reads k rows k floats apart from k*3 items, too few to hide a GPU's
 * latency (H200, k 2000: this 0.019 ms, 48 MB of M at 2.5 TB/s). */
__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void smw_groups(__global const float *m, __global const float *w, uint k, __global float *z)
{
    __local float red[WG];
    const uint g = get_group_id(0), l = get_local_id(0), r = g % k, c = g / k;
    __global const float *row = m + ((size_t)c * k + r) * k;
    __global const float *x = w + (size_t)c * k;
    float t = 0;
    for (uint q = l; q < k; q += WG)
        t += row[q] * x[q];
    red[l] = t;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint h = WG / 2; h > 0; h >>= 1) {
        if (l < h)
            red[l] += red[l + h];
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (l == 0)
        z[(size_t)c * k + r] = red[0];
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

/* GPUs, F̄ in panels: fbar_rows's item per row, z read from local memory (ZCHUNK entries
 * of each channel at a time, loaded by the whole group) and UNROLL loads of F̄ in flight per
 * item, so that a GPU's many rows keep its memory busy. Items past n compute row n - 1 and
 * write nothing (every item must reach the barriers). Measured on an H200 (Crytek Sponza,
 * n 293,682, k 2000; bench/results/2026-12-04-opencl-h200.md), ms for this kernel: f16
 * 0.519 / 0.451 / 0.454 at UNROLL 8 / 16 / 32, f32 0.644 / 0.640 / 0.608; two rows per
 * item as one 2-vector load was slower in every storage (f16 0.648, f32 0.853 at 16). */
#ifndef UNROLL
#define UNROLL 16
#endif

__kernel __attribute__((reqd_work_group_size(WG, 1, 1)))
void fbar_panels(__global const FBAR_T *fbar, __global const float *scale,
                 __global const float *z, __global const float *E, __global const float *rho,
                 uint n, uint k, __global float *B, uint np)
{
    __local float zl[3 * ZCHUNK];
    const uint i = get_global_id(0), l = get_local_id(0), ii = i < n ? i : n - 1;
    __global const FBAR_T *row = fbar + ROW_BASE(ii);
    const size_t step = ROW_STEP(ii);
    float t0 = 0, t1 = 0, t2 = 0;
    for (uint j0 = 0; j0 < k; j0 += ZCHUNK) {
        const uint m = k - j0 < ZCHUNK ? k - j0 : ZCHUNK;
        barrier(CLK_LOCAL_MEM_FENCE);
        for (uint q = l; q < 3 * ZCHUNK; q += WG) {
            const uint c = q / ZCHUNK, jj = q % ZCHUNK;
            zl[q] = jj < m ? z[c * k + j0 + jj] : 0.0f;
        }
        barrier(CLK_LOCAL_MEM_FENCE);
        __global const FBAR_T *p = row + (size_t)j0 * step;
        uint jj = 0;
        for (; jj + UNROLL <= m; jj += UNROLL) {
            float f[UNROLL];
            for (int u = 0; u < UNROLL; u++)
                f[u] = LOAD(p, (jj + u) * step);
            for (int u = 0; u < UNROLL; u++) {
                t0 += f[u] * zl[jj + u];
                t1 += f[u] * zl[ZCHUNK + jj + u];
                t2 += f[u] * zl[2 * ZCHUNK + jj + u];
            }
        }
        for (; jj < m; jj++) {
            const float f = LOAD(p, jj * step);
            t0 += f * zl[jj];
            t1 += f * zl[ZCHUNK + jj];
            t2 += f * zl[2 * ZCHUNK + jj];
        }
    }
    if (i >= n)
        return;
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
    float t[3] = {0, 0, 0};
    for (uint j = l; j < k; j += WG) {
        const float f = LOAD(row, j * step);
        t[0] += f * z[j];
        t[1] += f * z[k + j];
        t[2] += f * z[2 * k + j];
    }
    sum3(red, l, l, WG, 1, t);
    if (l == 0 && i < n)
        put_b(B, E, rho, scale, i, t);
}

/* Sparse F̄: one work-group of TILE * sg items per tile (group id t), sg <= WG / TILE
 * strip groups: item l takes row r = l % TILE of strips start[t] + l / TILE, + sg, ..., so
 * the TILE items of a strip read its TILE contiguous values (one 32- or 64-byte run) and
 * share its column; the sg partial sums of a row meet in local memory. */
__kernel void fbar_strips(__global const FBAR_T *val, __global const ushort *col,
                          __global const uint *start, __global const float *scale,
                          __global const float *z, __global const float *E,
                          __global const float *rho, uint n, uint k, __global float *B, uint sg)
{
    __local float red[3 * WG];
    const uint tile = get_group_id(0), l = get_local_id(0), r = l % TILE, g = l / TILE;
    float t[3] = {0, 0, 0};
    for (uint s = start[tile] + g; s < start[tile + 1]; s += sg) {
        const uint q = col[s];
        const float f = LOAD(val, (size_t)s * TILE + r);
        t[0] += f * z[q];
        t[1] += f * z[k + q];
        t[2] += f * z[2 * k + q];
    }
    if (sg > 1)
        sum3(red, l, g, sg, TILE, t);
    const uint i = tile * TILE + r;
    if (g == 0 && i < n)
        put_b(B, E, rho, scale, i, t);
}
