/*
 * lrr-bench: timing a frame function (warm-up, then timed runs), and the real-time steps
 * the tables time besides the paper's (bench_paper.c): lrr_solve and plain sgemv.
 */
#include <math.h>
#include <stdlib.h>

#include "bench.h"

/* ------------------------------------------------------------------ timing */
/* Two warm-up runs, then `repeat` timed runs (0: adaptive, at least MIN_RUNS and at least
 * MIN_SECONDS in all). Returns 0 or the frame's non-zero status. */
void bench_timing_from_samples(double *v, size_t runs, timing *t)
{
    t->min = t->max = v[0];
    for (size_t r = 1; r < runs; r++) {
        t->min = fmin(t->min, v[r]);
        t->max = fmax(t->max, v[r]);
    }
    t->median = cli_median(v, runs); /* reorders v */
    t->runs = runs;
}

int bench_time_frames(frame_fn fn, void *user, unsigned repeat, timing *t)
{
    int rc = fn(user);
    if (rc)
        return rc;
    double t0 = cli_now();
    if ((rc = fn(user)))
        return rc;
    double est = cli_now() - t0;
    size_t runs = repeat;
    if (!runs) {
        double want = est > 0 ? ceil(MIN_SECONDS / est) : (double)MAX_RUNS;
        runs = want < MIN_RUNS ? MIN_RUNS : want > MAX_RUNS ? MAX_RUNS : (size_t)want;
    }
    double *v = malloc(runs * sizeof *v);
    if (!v)
        return bench_fail("cannot allocate %zu timings", runs);
    for (size_t r = 0; r < runs; r++) {
        double a = cli_now();
        if ((rc = fn(user))) {
            free(v);
            return rc;
        }
        v[r] = 1e3 * (cli_now() - a);
    }
    bench_timing_from_samples(v, runs, t);
    free(v);
    return 0;
}

/* ---------------------------------------------------------------- real-time steps */
int bench_ours_step(void *user)
{
    ours_frame *f = user;
    const float *e = f->e_alt && (f->frame++ & 1) ? f->e_alt : f->e;
    f->status = lrr_solve(f->solver, e, f->b);
    return f->status != LRR_OK;
}

const char *bench_path_name(lrr_path p)
{
    switch (p) {
    case LRR_PATH_FULL:
        return "full";
    case LRR_PATH_SPARSE:
        return "sparse";
    case LRR_PATH_INCREMENTAL:
        return "incremental";
    default:
        return "auto";
    }
}

/* Three sgemv over F̄, one per channel, nothing else. */
int bench_sgemv_step(void *user)
{
    sgemv_frame *f = user;
    for (int c = 0; c < 3; c++)
        cblas_sgemv(CblasRowMajor, CblasNoTrans, f->n, f->k, 1.0f, f->fbar, f->k, f->z[c], 1,
                    0.0f, f->out[c], 1);
    return 0;
}
