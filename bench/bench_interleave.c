/*
 * lrr-bench realtime: the fused pass and its floor measured in alternation, and the
 * multiply-add peak of its roofline.
 *
 * Why alternate: on this project's shared VM the read bandwidth drifts by up to 40% within
 * an hour, so a floor measured once at the start and a pass timed minutes later gave
 * ratio_to_floor anywhere from 0.92 to 1.74 between runs. Here the read loop (over a buffer
 * of exactly the bytes the pass must read) and the pass itself run in pairs, A B A B ...,
 * and each pair gives one ratio pass / floor under the same conditions; the median of the
 * pairs' ratios, with their min and max, is what the targets are judged on.
 */
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

/* Each half of a pair: at least PAIR_MIN_REPS runs and about PAIR_HALF_MS, the fastest
 * run kept. The fastest, not the mean: on this project's 2-core VM beside a CI job, one
 * preempted run took a whole time slice (fused f32 on 221184×216: 24 ms against 3.9) and a
 * mean of one or two runs per half gave pair ratios from 0.5 to 10.9. */
#define PAIR_HALF_MS 20.0
#define PAIR_MIN_REPS 3u
#define PAIR_MAX_REPS 1000u

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* median of v[0..count) (count ≥ 1; v is reordered) */
static double median_of(double *v, size_t count)
{
    qsort(v, count, sizeof *v, cmp_double);
    return count % 2 ? v[count / 2] : 0.5 * (v[count / 2 - 1] + v[count / 2]);
}

int bench_interleave(frame_fn fn, void *user, double bytes, double frame_ms, unsigned pairs,
                     bench_pairs *out)
{
    out->median = out->min = out->max = out->floor_ms = NAN;
    out->pairs = 0;
    if (pairs > BENCH_MAX_PAIRS)
        pairs = BENCH_MAX_PAIRS;
    /* at least the pass's bytes, in whole 128-float blocks; the floor uses the exact bytes */
    const size_t count = ((size_t)ceil(bytes / sizeof(float)) + 127) / 128 * 128;
    float *buf = bench_read_buffer(count);
    if (!buf)
        return bench_fail("cannot allocate %zu floats for the interleaved floor", count);
    unsigned reps = PAIR_MIN_REPS;
    if (frame_ms > 0 && frame_ms < PAIR_HALF_MS / PAIR_MIN_REPS)
        reps = (unsigned)fmin(PAIR_MAX_REPS, ceil(PAIR_HALF_MS / frame_ms));
    double ratio[BENCH_MAX_PAIRS], floor_ms[BENCH_MAX_PAIRS], check = 0;
    int rc = 0;
    for (unsigned p = 0; p < pairs && !rc; p++) {
        /* A: the read loops, after one untimed pass (the pass's frames left the cache to
         * F̄, as the frames will find it after the reads) */
        bench_read_bandwidth(buf, count, 1, &check);
        double bw = bench_read_bandwidth(buf, count, reps, &check) * bytes /
                    ((double)count * sizeof(float));
        /* B: the pass, after one untimed frame */
        if ((rc = fn(user)))
            break;
        double pass_ms = INFINITY;
        for (unsigned r = 0; r < reps && !rc; r++) {
            double t0 = cli_now();
            rc = fn(user);
            pass_ms = fmin(pass_ms, 1e3 * (cli_now() - t0));
        }
        floor_ms[p] = bw > 0 ? 1e3 * bytes / bw : NAN;
        ratio[p] = pass_ms / floor_ms[p];
        out->pairs = p + 1;
    }
    lrr_aligned_free(buf);
    if (rc || out->pairs == 0 || !(check > 0))
        return rc ? rc : bench_fail("the interleaved floor read nothing");
    out->min = out->max = ratio[0];
    for (unsigned p = 1; p < out->pairs; p++) {
        out->min = fmin(out->min, ratio[p]);
        out->max = fmax(out->max, ratio[p]);
    }
    out->median = median_of(ratio, out->pairs);
    out->floor_ms = median_of(floor_ms, out->pairs);
    return 0;
}

/* the fastest of reps runs of fn (after one untimed run), in ms; INFINITY on an error */
static double fastest_ms(frame_fn fn, void *user, unsigned reps, int *rc)
{
    double best = INFINITY;
    if ((*rc = fn(user)))
        return best;
    for (unsigned r = 0; r < reps && !*rc; r++) {
        double t0 = cli_now();
        *rc = fn(user);
        best = fmin(best, 1e3 * (cli_now() - t0));
    }
    return best;
}

int bench_ab(frame_fn a, void *ua, frame_fn b, void *ub, double frame_ms, unsigned pairs,
             bench_pairs *out)
{
    out->median = out->min = out->max = out->floor_ms = NAN;
    out->pairs = 0;
    if (pairs > BENCH_MAX_PAIRS)
        pairs = BENCH_MAX_PAIRS;
    unsigned reps = PAIR_MIN_REPS;
    if (frame_ms > 0 && frame_ms < PAIR_HALF_MS / PAIR_MIN_REPS)
        reps = (unsigned)fmin(PAIR_MAX_REPS, ceil(PAIR_HALF_MS / frame_ms));
    double ratio[BENCH_MAX_PAIRS], b_ms[BENCH_MAX_PAIRS];
    int rc = 0;
    for (unsigned p = 0; p < pairs && !rc; p++) {
        double ta = fastest_ms(a, ua, reps, &rc);
        double tb = rc ? NAN : fastest_ms(b, ub, reps, &rc);
        b_ms[p] = tb;
        ratio[p] = ta / tb;
        out->pairs = rc ? p : p + 1;
    }
    if (rc || out->pairs == 0)
        return rc ? rc : bench_fail("no A/B pair was timed");
    out->min = out->max = ratio[0];
    for (unsigned p = 1; p < out->pairs; p++) {
        out->min = fmin(out->min, ratio[p]);
        out->max = fmax(out->max, ratio[p]);
    }
    out->median = median_of(ratio, out->pairs);
    out->floor_ms = median_of(b_ms, out->pairs);
    return 0;
}

/* ------------------------------------------------------------------ multiply-add peak */
/* FMA_ACC independent accumulator chains per thread: two FMA pipes with a 4-cycle latency
 * need 8 in flight; 12 leave room. Each step is one a = a·m + c per lane (2 flops). */
#define FMA_ACC 12
#define FMA_STEPS 10000000L

#if defined(__x86_64__)
#include <immintrin.h>
__attribute__((target("avx512f"))) static double fma512(long steps, double *sink)
{
    __m512 a[FMA_ACC], m = _mm512_set1_ps(0.9999999f), c = _mm512_set1_ps(1e-7f);
    for (int l = 0; l < FMA_ACC; l++)
        a[l] = _mm512_set1_ps((float)l);
    for (long i = 0; i < steps; i++)
        for (int l = 0; l < FMA_ACC; l++)
            a[l] = _mm512_fmadd_ps(a[l], m, c);
    for (int l = 1; l < FMA_ACC; l++)
        a[0] = _mm512_add_ps(a[0], a[l]);
    *sink += _mm512_reduce_add_ps(a[0]);
    return 2.0 * 16 * FMA_ACC * (double)steps;
}

__attribute__((target("avx2,fma"))) static double fma256(long steps, double *sink)
{
    __m256 a[FMA_ACC], m = _mm256_set1_ps(0.9999999f), c = _mm256_set1_ps(1e-7f);
    for (int l = 0; l < FMA_ACC; l++)
        a[l] = _mm256_set1_ps((float)l);
    for (long i = 0; i < steps; i++)
        for (int l = 0; l < FMA_ACC; l++)
            a[l] = _mm256_fmadd_ps(a[l], m, c);
    float t[8];
    for (int l = 1; l < FMA_ACC; l++)
        a[0] = _mm256_add_ps(a[0], a[l]);
    _mm256_storeu_ps(t, a[0]);
    *sink += t[0] + t[7];
    return 2.0 * 8 * FMA_ACC * (double)steps;
}
#endif

static double fma_portable(long steps, double *sink)
{
    typedef float v4 __attribute__((vector_size(16)));
    v4 a[FMA_ACC], m = {0.9999999f, 0.9999999f, 0.9999999f, 0.9999999f},
                   c = {1e-7f, 1e-7f, 1e-7f, 1e-7f};
    for (int l = 0; l < FMA_ACC; l++)
        a[l] = (v4){(float)l, 0, 0, 0};
    for (long i = 0; i < steps; i++)
        for (int l = 0; l < FMA_ACC; l++)
            a[l] = a[l] * m + c;
    for (int l = 0; l < FMA_ACC; l++)
        *sink += a[l][0];
    return 2.0 * 4 * FMA_ACC * (double)steps;
}

double bench_fma_peak(void)
{
    /* every loop the CPU runs, the best: a 512-bit FMA is not always the faster one */
    double (*loops[3])(long, double *) = {fma_portable, NULL, NULL};
#if defined(__x86_64__)
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma"))
        loops[1] = fma256;
    if (__builtin_cpu_supports("avx512f"))
        loops[2] = fma512;
#endif
    double best = 0, sink = 0;
    for (int pass = 0; pass < 6; pass++) {
        double (*loop)(long, double *) = loops[pass % 3];
        if (!loop)
            continue;
        double flops = 0;
        double t0 = cli_now();
        #pragma omp parallel reduction(+ : flops, sink)
        flops += loop(FMA_STEPS, &sink);
        double s = cli_now() - t0;
        if (s > 0 && flops / s > best)
            best = flops / s;
    }
    return isfinite(sink) ? best : 0;
}
