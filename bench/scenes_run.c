/*
 * lrr-bench scenes, one scene (scenes.c has the command, its options and its output).
 * Each heavy step runs in a forked child process that sends its numbers back through a pipe:
 * the operator pipeline (subdivide, build, f32 and f16 frames) in one, so that its peak
 * resident memory (wait4's ru_maxrss) is the pipeline's own and not the path tracer's or
 * another scene's; the path-traced reference in another. The parent runs no OpenMP region
 * (libgomp's thread pool does not survive fork) and only compares per-triangle means.
 */
#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "bench.h"

#define SC_WARMUPS 3u
#define SC_MIN_RUNS 30u
#define SC_MIN_SECONDS 0.5
#define SC_MAX_RUNS 5000u

/* ------------------------------------------------------------------ child processes */
static int write_all(int fd, const void *p, size_t len)
{
    const unsigned char *c = p;
    while (len) {
        ssize_t w = write(fd, c, len);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            return -1;
        c += w;
        len -= (size_t)w;
    }
    return 0;
}

typedef struct sc_buf {
    unsigned char *p;
    size_t len, cap, pos;
} sc_buf;

/* Everything until EOF (the child exited or closed its end). */
static int buf_read_fd(int fd, sc_buf *b)
{
    for (;;) {
        if (b->len == b->cap) {
            size_t cap = b->cap ? 2 * b->cap : 1 << 16;
            unsigned char *p = realloc(b->p, cap);
            if (!p)
                return -1;
            b->p = p;
            b->cap = cap;
        }
        ssize_t r = read(fd, b->p + b->len, b->cap - b->len);
        if (r < 0 && errno == EINTR)
            continue;
        if (r < 0)
            return -1;
        if (r == 0)
            return 0;
        b->len += (size_t)r;
    }
}

/* The next len bytes of what the child sent; -1 when it sent fewer. */
static int buf_take(sc_buf *b, void *dst, size_t len)
{
    if (b->len - b->pos < len)
        return -1;
    memcpy(dst, b->p + b->pos, len);
    b->pos += len;
    return 0;
}

typedef int (*child_fn)(int fd, void *arg);

/* fn in a forked child writing to a pipe: what it wrote into *out, its peak resident memory
 * in MiB. Returns 0 when the child exited 0 (else it has printed why, or we say how it
 * died). */
static int run_child(const char *what, child_fn fn, void *arg, sc_buf *out, double *peak_mib)
{
    int fds[2];
    if (pipe(fds) != 0)
        return bench_fail("%s: pipe: %s", what, strerror(errno));
    fflush(stdout); /* else the child would print the parent's buffered lines again */
    fflush(stderr);
    pid_t pid = fork();
    if (pid < 0) {
        close(fds[0]);
        close(fds[1]);
        return bench_fail("%s: fork: %s", what, strerror(errno));
    }
    if (pid == 0) {
        close(fds[0]);
        int rc = fn(fds[1], arg);
        close(fds[1]);
        fflush(stderr);
        _exit(rc ? CLI_EXIT_FAIL : CLI_EXIT_OK);
    }
    close(fds[1]);
    int rrc = buf_read_fd(fds[0], out);
    close(fds[0]);
    int status = 0;
    struct rusage ru;
    memset(&ru, 0, sizeof ru);
    while (wait4(pid, &status, 0, &ru) < 0)
        if (errno != EINTR)
            return bench_fail("%s: wait4: %s", what, strerror(errno));
    *peak_mib = (double)ru.ru_maxrss / 1024.0; /* Linux: kilobytes */
    if (WIFSIGNALED(status))
        return bench_fail("%s: the child process died of signal %d (%s)", what,
                          WTERMSIG(status), strsignal(WTERMSIG(status)));
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0)
        return CLI_EXIT_FAIL;
    if (rrc != 0)
        return bench_fail("%s: reading the child's results: %s", what, strerror(errno));
    return 0;
}

/* OpenMP (lrr) and OpenBLAS (LAPACK in the SMW step) threads of a child. */
static void child_threads(int threads)
{
    if (threads > 0) {
        omp_set_num_threads(threads);
        openblas_set_num_threads(threads);
    }
}

static int bw_child(int fd, void *arg)
{
    const sc_args *a = arg;
    child_threads(a->threads);
    double bw = measure_bandwidth(bandwidth_buffer_bytes());
    return write_all(fd, &bw, sizeof bw);
}

int sc_measure_bandwidth(const sc_args *a, double *bandwidth)
{
    sc_buf b = {0};
    double peak = 0;
    *bandwidth = 0;
    int rc = run_child("read bandwidth", bw_child, (void *)a, &b, &peak);
    if (rc == 0 && buf_take(&b, bandwidth, sizeof *bandwidth) != 0)
        rc = bench_fail("read bandwidth: the child sent nothing");
    free(b.p);
    return rc;
}

/* ------------------------------------------------------------------ scene and operator */
/* What a child of one scene works with. */
typedef struct sc_child {
    const sc_args *a;
    const char *scene;
    sc_result *r;
    lrr_context *ctx;
    lrr_scene *sc;
    char what[160]; /* "SCENE: step", for messages */
} sc_child;

static int step_fail(sc_child *c, lrr_status s, const char *step)
{
    snprintf(c->what, sizeof c->what, "%s: %s", c->r->label, step);
    return lib_fail(c->ctx, s, c->what);
}

/* Loads and subdivides: levels 0, target T + 16 K patches, so that the scene's patches (the
 * operator's subpatches) are the small triangles and pieces of the big ones. */
static int sc_open(sc_child *c)
{
    lrr_status s = lrr_context_create(&c->ctx);
    if (s != LRR_OK)
        return lib_fail(NULL, s, "context");
    int rc = open_scene(c->ctx, c->scene, &c->sc);
    if (rc)
        return rc;
    lrr_scene_info si;
    lrr_scene_get_info(c->sc, &si, sizeof si);
    c->r->triangles = si.triangles;
    c->r->emitters = si.emitters;
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.levels = 0;
    sd.target_patches = si.triangles + 16 * c->a->patches;
    double t0 = cli_now();
    if ((s = lrr_scene_subdivide(c->sc, &sd)) != LRR_OK)
        return step_fail(c, s, "lrr_scene_subdivide");
    c->r->subdivide_s = cli_now() - t0;
    return 0;
}

static void sc_close(sc_child *c)
{
    lrr_scene_destroy(c->sc);
    lrr_context_destroy(c->ctx);
}

static int sc_build(sc_child *c, lrr_operator **op)
{
    const sc_args *a = c->a;
    lrr_build_options o = lrr_build_options_defaults();
    o.hierarchy = LRR_HIERARCHY_CLUSTER;
    o.adaptive_patches = a->patches;
    o.adaptive_split = a->split;
    o.hemicube_resolution = a->hemicube;
    o.formfactor_method = LRR_FORMFACTOR_AUTO;
    o.seed = a->seed;
    o.threads = a->threads;
    cli_progress bar;
    char label[96];
    snprintf(label, sizeof label, "%s: build", c->r->label);
    progress_begin(&bar, label, &o);
    lrr_status s = lrr_operator_build(c->sc, &o, op);
    cli_progress_finish(&bar);
    if (s != LRR_OK)
        return step_fail(c, s, "lrr_operator_build");
    lrr_operator_info oi;
    lrr_operator_get_info(*op, &oi, sizeof oi);
    sc_result *r = c->r;
    r->n = oi.n;
    r->k = oi.k;
    r->d_min = oi.d_min;
    r->d_max = oi.d_max;
    r->hierarchy = oi.hierarchy;
    r->build_s = oi.build_seconds;
    r->clustering_s = oi.selection_seconds;
    r->formfactor_s = oi.formfactor_seconds;
    r->smw_s = oi.smw_seconds;
    r->preprocess_s = r->subdivide_s + r->build_s;
    r->op_mib = (double)oi.bytes / (1 << 20);
    r->back_face_share = oi.back_face_share;
    return 0;
}

/* ------------------------------------------------------------------ frames */
static int cmp_double(const void *x, const void *y)
{
    double a = *(const double *)x, b = *(const double *)y;
    return a < b ? -1 : a > b;
}

/* Quartiles by linear interpolation between order statistics (v is sorted). */
static void quartiles(double *v, size_t runs, sc_quart *q)
{
    qsort(v, runs, sizeof *v, cmp_double);
    double at[3];
    for (int i = 0; i < 3; i++) {
        double pos = (i + 1) * 0.25 * (double)(runs - 1);
        size_t lo = (size_t)pos;
        size_t hi = lo + 1 < runs ? lo + 1 : lo;
        at[i] = v[lo] + (pos - (double)lo) * (v[hi] - v[lo]);
    }
    q->q1 = at[0];
    q->median = at[1];
    q->q3 = at[2];
    q->runs = runs;
}

/* SC_WARMUPS frames, then `repeat` timed ones (0: at least SC_MIN_RUNS and SC_MIN_SECONDS),
 * the last B in b. */
static lrr_status time_frames_q(lrr_solver *sv, const float *e, float *b, unsigned repeat,
                                sc_quart *q)
{
    lrr_status s = LRR_OK;
    for (unsigned w = 0; w < SC_WARMUPS && s == LRR_OK; w++)
        s = lrr_solve(sv, e, b);
    size_t cap = repeat ? repeat : SC_MAX_RUNS, runs = 0;
    double *v = malloc(cap * sizeof *v), total = 0;
    if (!v)
        return LRR_ERR_NOMEM;
    while (s == LRR_OK && runs < cap &&
           (repeat || runs < SC_MIN_RUNS || total < SC_MIN_SECONDS)) {
        double t0 = cli_now();
        s = lrr_solve(sv, e, b);
        double dt = cli_now() - t0;
        v[runs++] = 1e3 * dt;
        total += dt;
    }
    if (s == LRR_OK)
        quartiles(v, runs, q);
    free(v);
    return s;
}

/* The frames of op in its current storage, forced to one pass over F̄ (LRR_PATH_FULL: with a
 * few emitting patches the automatic choice would serve this fixed emission from cached
 * columns, and we measure the one-pass cost). */
static int time_storage(sc_child *c, const lrr_operator *op, const float *e, float *b,
                        sc_quart *q)
{
    lrr_solver *sv = NULL;
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_CPU, &sv);
    if (s != LRR_OK)
        return step_fail(c, s, "lrr_solver_create");
    snprintf(c->r->kernel, sizeof c->r->kernel, "%s", lrr_solver_kernel(sv));
    s = lrr_solver_set_path(sv, LRR_PATH_FULL);
    if (s == LRR_OK)
        s = time_frames_q(sv, e, b, c->a->repeat, q);
    lrr_solver_destroy(sv);
    return s == LRR_OK ? 0 : step_fail(c, s, "lrr_solve");
}

/* ------------------------------------------------------------------ per-triangle means */
/* Triangle areas without the vertices: x one-hot at one subpatch i of each triangle t gives
 * the triangle mean A_i / A_t, and A_i is the scene's. */
static int triangle_areas(sc_child *c, const float *sub_area, float *tri_area)
{
    size_t n = c->r->n, T = c->r->triangles;
    float *x = calloc(3 * n, sizeof *x), *m = calloc(3 * T, sizeof *m);
    size_t *first = malloc(T * sizeof *first);
    int rc = 0;
    if (!x || !m || !first)
        rc = bench_fail("%s: out of memory", c->r->label);
    for (size_t t = 0; t < T && !rc; t++) {
        first[t] = lrr_scene_subpatch_at(c->sc, t, 1.0 / 3, 1.0 / 3);
        if (first[t] >= n)
            rc = bench_fail("%s: triangle %zu has no subpatch", c->r->label, t);
        else
            x[3 * first[t]] = 1.0f;
    }
    lrr_status s = LRR_OK;
    if (!rc && (s = lrr_reference_triangle_means(c->sc, x, NULL, m, NULL)) != LRR_OK)
        rc = step_fail(c, s, "lrr_reference_triangle_means");
    for (size_t t = 0; t < T && !rc; t++)
        tri_area[t] = m[3 * t] > 0 ? sub_area[first[t]] / m[3 * t] : 0.0f;
    free(x);
    free(m);
    free(first);
    return rc;
}

/* Per-triangle means of B (operator order) into out (T×3). */
static int op_means(sc_child *c, const lrr_operator *op, const float *b, float *tmp, float *out)
{
    lrr_operator_scene_order(op, b, tmp);
    lrr_status s = lrr_reference_triangle_means(c->sc, tmp, NULL, out, NULL);
    return s == LRR_OK ? 0 : step_fail(c, s, "lrr_reference_triangle_means");
}

/* The scene's per-triangle geometry: areas (T) and emission means (T×3). */
static int scene_means(sc_child *c, float *tri_area, float *e_mean)
{
    size_t n = c->r->n;
    float *area = malloc(n * sizeof *area), *em = malloc(3 * n * sizeof *em);
    int rc = 0;
    lrr_status s = LRR_OK;
    if (!area || !em)
        rc = bench_fail("%s: out of memory", c->r->label);
    else if ((s = lrr_scene_subpatches(c->sc, NULL, NULL, area, NULL, em)) != LRR_OK)
        rc = step_fail(c, s, "lrr_scene_subpatches");
    else if ((s = lrr_reference_triangle_means(c->sc, em, NULL, e_mean, NULL)) != LRR_OK)
        rc = step_fail(c, s, "lrr_reference_triangle_means");
    if (!rc)
        rc = triangle_areas(c, area, tri_area);
    free(area);
    free(em);
    return rc;
}

/* ------------------------------------------------------------------ the operator child */
/* sends: the sc_result, then T areas, T×3 emission means, T×3 f32 means, T×3 f16 means */
static int op_send(int fd, sc_child *c, float *const arrays[4])
{
    size_t T = c->r->triangles;
    if (write_all(fd, c->r, sizeof *c->r) != 0)
        return -1;
    for (int i = 0; i < 4; i++)
        if (write_all(fd, arrays[i], (i ? 3 : 1) * T * sizeof(float)) != 0)
            return -1;
    return 0;
}

static int op_pipeline(sc_child *c, lrr_operator **op, float *const arrays[4])
{
    int rc = sc_build(c, op);
    if (rc)
        return rc;
    size_t n = c->r->n;
    float *b = alloc_floats(n, 3), *tmp = alloc_floats(n, 3);
    const float *e = lrr_operator_emission(*op);
    lrr_status s = LRR_OK;
    if (!b || !tmp)
        rc = bench_fail("%s: out of memory for B (n = %zu)", c->r->label, n);
    if (!rc)
        rc = time_storage(c, *op, e, b, &c->r->f32);
    if (!rc)
        rc = op_means(c, *op, b, tmp, arrays[2]);
    if (!rc && (s = lrr_operator_set_storage(*op, LRR_STORAGE_F16)) != LRR_OK)
        rc = step_fail(c, s, "lrr_operator_set_storage f16");
    if (!rc) /* emission again: set_storage may have moved the operator's arrays */
        rc = time_storage(c, *op, lrr_operator_emission(*op), b, &c->r->f16);
    if (!rc)
        rc = op_means(c, *op, b, tmp, arrays[3]);
    if (!rc)
        rc = scene_means(c, arrays[0], arrays[1]);
    lrr_aligned_free(b);
    lrr_aligned_free(tmp);
    return rc;
}

static int op_child(int fd, void *arg)
{
    sc_child *c = arg;
    child_threads(c->a->threads);
    c->r->threads = omp_get_max_threads();
    int rc = sc_open(c);
    lrr_operator *op = NULL;
    float *arrays[4] = {NULL, NULL, NULL, NULL};
    size_t T = c->r->triangles;
    for (int i = 0; i < 4 && !rc; i++)
        if (!(arrays[i] = calloc((i ? 3 : 1) * T, sizeof(float))))
            rc = bench_fail("%s: out of memory", c->r->label);
    if (!rc)
        rc = op_pipeline(c, &op, arrays);
    if (!rc && op_send(fd, c, arrays) != 0)
        rc = bench_fail("%s: sending the results: %s", c->r->label, strerror(errno));
    lrr_operator_destroy(op);
    for (int i = 0; i < 4; i++)
        free(arrays[i]);
    sc_close(c);
    return rc;
}

/* ------------------------------------------------------------------ the reference child */
static int ref_trace(sc_child *c, float *mean, float *mean_se)
{
    lrr_scene_info si;
    lrr_scene_get_info(c->sc, &si, sizeof si);
    const size_t n = si.subpatches;
    float *b = alloc_floats(n, 3), *se = alloc_floats(n, 3);
    if (!b || !se) {
        lrr_aligned_free(b);
        lrr_aligned_free(se);
        return bench_fail("%s: out of memory for the reference (n = %zu)", c->r->label, n);
    }
    lrr_path_trace_options o = lrr_path_trace_options_defaults();
    o.samples = c->a->samples;
    o.seed = c->a->seed;
    o.threads = c->a->threads;
    cli_progress bar;
    char label[96];
    snprintf(label, sizeof label, "%s: path tracing", c->r->label);
    cli_progress_init(&bar, label, isatty(STDERR_FILENO));
    o.progress = cli_progress_cb;
    o.progress_user = &bar;
    double t0 = cli_now();
    lrr_status s = lrr_reference_path_trace(c->sc, &o, b, se);
    cli_progress_finish(&bar);
    c->r->reference_s = cli_now() - t0;
    int rc = s == LRR_OK ? 0 : step_fail(c, s, "lrr_reference_path_trace");
    if (!rc && (s = lrr_reference_triangle_means(c->sc, b, se, mean, mean_se)) != LRR_OK)
        rc = step_fail(c, s, "lrr_reference_triangle_means (reference)");
    lrr_aligned_free(b);
    lrr_aligned_free(se);
    return rc;
}

/* sends: reference_s, T, then T×3 means and T×3 standard errors */
static int ref_child(int fd, void *arg)
{
    sc_child *c = arg;
    child_threads(c->a->threads);
    int rc = sc_open(c);
    size_t T = c->r->triangles;
    float *mean = rc ? NULL : calloc(3 * T, sizeof *mean);
    float *se = rc ? NULL : calloc(3 * T, sizeof *se);
    if (!rc && (!mean || !se))
        rc = bench_fail("%s: out of memory", c->r->label);
    if (!rc)
        rc = ref_trace(c, mean, se);
    if (!rc && (write_all(fd, &c->r->reference_s, sizeof(double)) != 0 ||
                write_all(fd, &T, sizeof T) != 0 ||
                write_all(fd, mean, 3 * T * sizeof *mean) != 0 ||
                write_all(fd, se, 3 * T * sizeof *se) != 0))
        rc = bench_fail("%s: sending the reference: %s", c->r->label, strerror(errno));
    free(mean);
    free(se);
    sc_close(c);
    return rc;
}

/* ------------------------------------------------------------------ comparison */
/* Rec. 709 luminance: the filter on the reference's noise looks at one number per triangle */
static double lum(const float *v)
{
    return 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2];
}

static double dist2(const float *a, const float *b, const float *e)
{
    double s = 0;
    for (int ch = 0; ch < 3; ch++) {
        double d = (double)a[ch] - b[ch] - (e ? e[ch] : 0);
        s += d * d;
    }
    return s;
}

/* Sums over a set of triangles (A the area, d = op - ref, RGB norms). */
typedef struct sc_acc {
    double num, num16, den, den_refl, noise, area, max_rel;
    size_t count;
} sc_acc;

static void acc_add(sc_acc *s, double a, const float *em, const float *op, const float *op16,
                    const float *ref, const float *se)
{
    static const float zero[3] = {0, 0, 0};
    const double d2 = dist2(op, ref, NULL), r2 = dist2(ref, zero, NULL);
    s->num += a * d2;
    s->num16 += a * dist2(op16, ref, NULL);
    s->den += a * r2;
    s->den_refl += a * dist2(ref, zero, em);
    s->noise += a * dist2(se, zero, NULL);
    s->area += a;
    s->max_rel = fmax(s->max_rel, isfinite(d2) ? sqrt(d2 / r2) : INFINITY);
    s->count++;
}

static double ratio_sqrt(double num, double den)
{
    return den > 0 ? sqrt(num / den) : NAN;
}

/* Over triangles with lum(se) < 1% of lum(ref) (lum(se) bounds the luminance's standard
 * error from above whatever the channels' correlation): area-weighted relative L2 of op
 * against ref (RGB), the same for the reflected part (emission taken off both), the
 * reference's own relative error bar (the same formula with se for the difference), the
 * largest per-triangle relative error, the count and area share used; and rel_l2 and the
 * error bar over every lit triangle (lum(ref) > 0), whatever its noise. */
static void compare_tris(size_t T, const float *area, const float *em, const float *op,
                         const float *op16, const float *ref, const float *se, sc_result *r)
{
    sc_acc used = {0}, lit = {0};
    double a_all = 0;
    for (size_t t = 0; t < T; t++) {
        const float *R = ref + 3 * t;
        a_all += area[t];
        if (!(lum(R) > 0) || !(area[t] > 0))
            continue;
        acc_add(&lit, area[t], em + 3 * t, op + 3 * t, op16 + 3 * t, R, se + 3 * t);
        if (lum(se + 3 * t) < SC_SE_LIMIT * lum(R))
            acc_add(&used, area[t], em + 3 * t, op + 3 * t, op16 + 3 * t, R, se + 3 * t);
    }
    r->tris_used = used.count;
    r->area_share = a_all > 0 ? used.area / a_all : NAN;
    r->rel_l2 = ratio_sqrt(used.num, used.den);
    r->rel_l2_f16 = ratio_sqrt(used.num16, used.den);
    r->rel_l2_reflected = ratio_sqrt(used.num, used.den_refl);
    r->ref_se = ratio_sqrt(used.noise, used.den);
    r->ref_se_reflected = ratio_sqrt(used.noise, used.den_refl);
    r->max_rel = used.count ? used.max_rel : NAN;
    r->tris_lit = lit.count;
    r->rel_l2_lit = ratio_sqrt(lit.num, lit.den);
    r->ref_se_lit = ratio_sqrt(lit.noise, lit.den);
}

/* ------------------------------------------------------------------ one scene */
static void result_init(sc_result *r, const char *scene)
{
    memset(r, 0, sizeof *r);
    scene_label(scene, r->label, sizeof r->label);
    double *nan_fields[] = {
        &r->subdivide_s, &r->build_s,   &r->clustering_s, &r->formfactor_s, &r->smw_s,
        &r->preprocess_s, &r->op_mib,   &r->peak_mib,     &r->back_face_share,
        &r->f32.median,  &r->f32.q1,    &r->f32.q3,       &r->f16.median,   &r->f16.q1,
        &r->f16.q3,      &r->bandwidth, &r->floor_f32,    &r->floor_f16,    &r->ratio_f32,
        &r->ratio_f16,   &r->reference_s, &r->reference_peak_mib, &r->rel_l2,
        &r->rel_l2_reflected, &r->rel_l2_f16, &r->max_rel, &r->ref_se, &r->area_share,
        &r->rel_l2_lit, &r->ref_se_lit, &r->ref_se_reflected};
    for (size_t i = 0; i < sizeof nan_fields / sizeof nan_fields[0]; i++)
        *nan_fields[i] = NAN;
    snprintf(r->kernel, sizeof r->kernel, "-");
}

/* The operator child's row and arrays (area, emission, f32 and f16 means) into r and arr. */
static int take_op(sc_buf *b, sc_result *r, float *arr[4])
{
    sc_result got;
    if (buf_take(b, &got, sizeof got) != 0)
        return -1;
    got.peak_mib = r->peak_mib;
    *r = got;
    for (int i = 0; i < 4; i++) {
        size_t len = (i ? 3 : 1) * r->triangles * sizeof(float);
        if (!(arr[i] = malloc(len ? len : 1)) || buf_take(b, arr[i], len) != 0)
            return -1;
    }
    return 0;
}

/* The reference child's arrays (means, standard errors) into ref[0..1]. */
static int take_ref(sc_buf *b, sc_result *r, float *ref[2])
{
    size_t T = 0;
    if (buf_take(b, &r->reference_s, sizeof(double)) != 0 || buf_take(b, &T, sizeof T) != 0 ||
        T != r->triangles)
        return -1;
    for (int i = 0; i < 2; i++)
        if (!(ref[i] = malloc(3 * T * sizeof(float) + 1)) ||
            buf_take(b, ref[i], 3 * T * sizeof(float)) != 0)
            return -1;
    return 0;
}

static int run_reference(const sc_args *a, sc_child *c, sc_result *r, float *ref[2])
{
    sc_buf b = {0};
    sc_result scratch = *r;
    c->r = &scratch;
    note("%s: path-traced reference (%zu samples per subpatch)", r->label, a->samples);
    int rc = run_child(r->label, ref_child, c, &b, &r->reference_peak_mib);
    if (!rc && take_ref(&b, r, ref) != 0)
        rc = bench_fail("%s: the reference child sent too little", r->label);
    free(b.p);
    if (rc)
        snprintf(r->failed, sizeof r->failed, "path-traced reference");
    return rc;
}

int sc_run_scene(const sc_args *a, const char *scene, sc_result *r)
{
    result_init(r, scene);
    sc_child c = {a, scene, r, NULL, NULL, ""};
    sc_buf b = {0};
    float *arr[4] = {NULL, NULL, NULL, NULL}, *ref[2] = {NULL, NULL};
    note("%s: operator (K %zu, hemicube %u)", r->label, a->patches, a->hemicube);
    double peak = NAN;
    int rc = run_child(r->label, op_child, &c, &b, &peak);
    r->peak_mib = peak;
    if (!rc && take_op(&b, r, arr) != 0)
        rc = bench_fail("%s: the operator child sent too little", r->label);
    free(b.p);
    if (rc) {
        snprintf(r->failed, sizeof r->failed, "operator pipeline");
        r->peak_mib = NAN; /* of a pipeline that did not finish */
    } else if (!(rc = run_reference(a, &c, r, ref)))
        compare_tris(r->triangles, arr[0], arr[1], arr[2], arr[3], ref[0], ref[1], r);
    for (int i = 0; i < 4; i++)
        free(arr[i]);
    free(ref[0]);
    free(ref[1]);
    return rc;
}
