/*
 * lrr-bench: the read bandwidth that sets the real-time step's floor (F̄ read once per
 * frame): an OpenMP sum over a buffer much larger than the caches.
 */
#include <omp.h>
#include <stdlib.h>

#include "bench.h"

#define BANDWIDTH_MIN_BYTES ((size_t)512 << 20)
#define BANDWIDTH_MAX_BYTES ((size_t)4 << 30)

/* Bytes of the bandwidth buffer: four times the last-level cache (some servers have
 * hundreds of MiB of it), at least 512 MiB, at most 4 GiB. */
size_t bench_bandwidth_buffer_bytes(void)
{
    size_t llc = bench_llc_bytes();
    size_t b = llc <= BANDWIDTH_MAX_BYTES / 4 ? 4 * llc : BANDWIDTH_MAX_BYTES;
    return b < BANDWIDTH_MIN_BYTES ? BANDWIDTH_MIN_BYTES : b;
}

/* Read bandwidth: an OpenMP sum over a buffer much larger than the caches, best of several
 * passes, in bytes per second (0 on failure). */
/* Sum of count floats (a multiple of 64, 64-byte aligned) with eight independent vector
 * accumulators of the widest width the CPU has: one chain's add latency, or 16-byte loads,
 * would cap a core below what memory delivers (measured here: 4-wide SSE 22.7 GB/s,
 * 16-wide AVX-512 29-31 GB/s on 2 threads). */
#if defined(__x86_64__)
#include <immintrin.h>
/* pf: a software prefetch 4 KiB ahead, one per line (as the real-time kernels' "+prefetch"
 * variants): on this project's Intel Xeon (Emerald Rapids, 2 threads) the plain loops kept
 * too few lines in flight and read a 96 MB matrix more slowly than the prefetching kernel
 * computed on it (20.4 GB/s against the kernel's 0.82× that time). */
__attribute__((target("avx512f"), always_inline)) static inline double
sum512(const float *p, size_t count, int pf)
{
    __m512 a[8];
    for (int l = 0; l < 8; l++)
        a[l] = _mm512_setzero_ps();
    for (size_t i = 0; i < count; i += 128) {
        for (int l = 0; pf && l < 8; l += 2)
            _mm_prefetch((const char *)(p + i + 16 * l) + 4096, _MM_HINT_T0);
        for (int l = 0; l < 8; l++)
            a[l] = _mm512_add_ps(a[l], _mm512_load_ps(p + i + 16 * l));
    }
    for (int l = 1; l < 8; l++)
        a[0] = _mm512_add_ps(a[0], a[l]);
    return _mm512_reduce_add_ps(a[0]);
}

__attribute__((target("avx2"), always_inline)) static inline double sum256(const float *p,
                                                                           size_t count, int pf)
{
    __m256 a[8];
    for (int l = 0; l < 8; l++)
        a[l] = _mm256_setzero_ps();
    for (size_t i = 0; i < count; i += 64) {
        for (int l = 0; pf && l < 8; l += 2)
            _mm_prefetch((const char *)(p + i + 8 * l) + 4096, _MM_HINT_T0);
        for (int l = 0; l < 8; l++)
            a[l] = _mm256_add_ps(a[l], _mm256_load_ps(p + i + 8 * l));
    }
    for (int l = 1; l < 8; l++)
        a[0] = _mm256_add_ps(a[0], a[l]);
    float t[8];
    _mm256_storeu_ps(t, a[0]);
    return (double)t[0] + t[1] + t[2] + t[3] + t[4] + t[5] + t[6] + t[7];
}

__attribute__((target("avx512f"))) static double sum_avx512(const float *p, size_t count)
{
    return sum512(p, count, 0);
}
__attribute__((target("avx512f"))) static double sum_avx512_pf(const float *p, size_t count)
{
    return sum512(p, count, 1);
}
__attribute__((target("avx2"))) static double sum_avx2(const float *p, size_t count)
{
    return sum256(p, count, 0);
}
__attribute__((target("avx2"))) static double sum_avx2_pf(const float *p, size_t count)
{
    return sum256(p, count, 1);
}
#endif

static double sum_portable(const float *p, size_t count)
{
    typedef float v4 __attribute__((vector_size(16)));
    v4 a[8];
    for (int l = 0; l < 8; l++)
        a[l] = (v4){0, 0, 0, 0};
    for (size_t i = 0; i < count; i += 32)
        for (int l = 0; l < 8; l++)
            a[l] += *(const v4 *)(const void *)(p + i + 4 * l);
    double t = 0;
    for (int l = 0; l < 8; l++)
        t += (double)a[l][0] + a[l][1] + a[l][2] + a[l][3];
    return t;
}

/* Every read loop the CPU runs, into sums[BENCH_READ_LOOPS] (NULL where it does not). */
static void read_loops(double (*sums[BENCH_READ_LOOPS])(const float *, size_t))
{
    sums[0] = sum_portable;
    sums[1] = sums[2] = sums[3] = sums[4] = NULL;
#if defined(__x86_64__)
    if (__builtin_cpu_supports("avx2"))
        sums[1] = sum_avx2, sums[3] = sum_avx2_pf;
    if (__builtin_cpu_supports("avx512f"))
        sums[2] = sum_avx512, sums[4] = sum_avx512_pf;
#endif
}

/* Seconds of one OpenMP pass of `sum` over count floats; the sum is added to *check. */
static double read_pass(double (*sum)(const float *, size_t), const float *buf, size_t count,
                        double *check)
{
    const size_t blocks = count / 128;
    double total = 0;
    double a = cli_now();
    #pragma omp parallel reduction(+ : total)
    {
        /* each thread one contiguous range of whole 128-float blocks */
        int t = omp_get_thread_num(), nt = omp_get_num_threads();
        size_t b0 = blocks * (size_t)t / (size_t)nt, b1 = blocks * (size_t)(t + 1) / (size_t)nt;
        total += sum(buf + b0 * 128, (b1 - b0) * 128);
    }
    double s = cli_now() - a;
    *check += total;
    return s;
}

double bench_read_bandwidth(const float *buf, size_t count, unsigned reps, double *check)
{
    double (*sums[BENCH_READ_LOOPS])(const float *, size_t);
    read_loops(sums);
    double best = 0;
    for (int l = 0; l < BENCH_READ_LOOPS; l++)
        for (unsigned r = 0; sums[l] && r < reps; r++) {
            double s = read_pass(sums[l], buf, count, check);
            if (s > 0 && (double)count * sizeof(float) / s > best)
                best = (double)count * sizeof(float) / s;
        }
    return best;
}

float *bench_read_buffer(size_t count)
{
    float *buf = lrr_aligned_alloc(count * sizeof(float));
    if (!buf)
        return NULL;
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < count; i++)
        buf[i] = 1.0f; /* first touch by the thread that will read it */
    return buf;
}

double bench_measure_bandwidth(size_t bytes)
{
    size_t count = bytes / sizeof(float) / 128 * 128;
    float *buf = bench_read_buffer(count);
    if (!buf)
        return 0;
    /* Every read loop the CPU runs, the best pass of any: on this project's AMD EPYC the
     * 256-bit loop read 64.8 GB/s where the 512-bit one read 58.5 (medians of 15, one
     * process), so the widest alone would set the floor too low. */
    double best = 0, check = 0;
    for (int pass = 0; pass < BANDWIDTH_PASSES; pass++) {
        double bw = bench_read_bandwidth(buf, count, 1, &check);
        if (bw > best)
            best = bw;
    }
    lrr_aligned_free(buf);
    /* the sums are used, so no pass can be optimised away */
    return check > 0 ? best : 0;
}
