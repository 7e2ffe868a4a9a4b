/*
 * lrr-bench scenes, one scene (scenes.c has the command, its options and its output;
 * judge.c the accuracy judgement). Each heavy step runs in a forked child process that sends
 * its numbers back through a pipe: the operator pipeline (subdivide, build,
 * lrr_operator_verify, f32 and f16 frames) in one, so that its peak resident memory
 * (wait4's ru_maxrss) is the pipeline's own and not the reference's or another scene's, and
 * so that lrr_operator_verify sees the operator it judges; the path-traced reference in
 * another. The parent runs no OpenMP region (libgomp's thread pool does not survive fork):
 * it only judges the per-subpatch values the children sent.
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
    double bw = bench_measure_bandwidth(bench_bandwidth_buffer_bytes());
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
    return bench_lib_fail(c->ctx, s, c->what);
}

/* Loads and subdivides: levels 0, target T + 16 K patches, so that the scene's patches (the
 * operator's subpatches) are the small triangles and pieces of the big ones. */
static int sc_open(sc_child *c)
{
    lrr_status s = lrr_context_create(&c->ctx);
    if (s != LRR_OK)
        return bench_lib_fail(NULL, s, "context");
    int rc = bench_open_scene(c->ctx, c->scene, &c->sc);
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

/* --operator: the file instead of a build; its subpatches must be the scene's as opened. */
static int sc_load(sc_child *c, lrr_operator **op)
{
    lrr_status s = lrr_operator_load(c->ctx, c->a->operator_file, op);
    if (s != LRR_OK)
        return step_fail(c, s, "lrr_operator_load");
    lrr_operator_info oi;
    lrr_scene_info si;
    lrr_operator_get_info(*op, &oi, sizeof oi);
    lrr_scene_get_info(c->sc, &si, sizeof si);
    if (oi.n != si.subpatches)
        return bench_fail("%s: %s has %zu subpatches, the scene subdivided for K = %zu has "
                          "%zu: build it with the same --clusters", c->r->label,
                          c->a->operator_file, oi.n, c->a->patches, si.subpatches);
    return 0;
}

/* The build's figures into the result. */
static void sc_record(sc_child *c, const lrr_operator *op)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    sc_result *r = c->r;
    r->n = oi.n;
    r->receiver_sampling = oi.receiver_sampling;
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
}

/* lrr_operator_build of the opened scene with the bench's options. */
static int sc_make(sc_child *c, lrr_operator **op)
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
    bench_progress_begin(&bar, label, &o);
    lrr_status s = lrr_operator_build(c->sc, &o, op);
    cli_progress_finish(&bar);
    return s == LRR_OK ? 0 : step_fail(c, s, "lrr_operator_build");
}

/* The operator, built or (--operator) loaded, and its figures. */
static int sc_build(sc_child *c, lrr_operator **op)
{
    int rc = c->a->operator_file ? sc_load(c, op) : sc_make(c, op);
    if (!rc)
        sc_record(c, *op);
    return rc;
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
    if (s == LRR_OK) /* dense: the floors here are n·k entries (lrr-bench fbar: sparse) */
        s = lrr_solver_set_fbar(sv, LRR_FBAR_DENSE);
    if (s != LRR_OK) {
        lrr_solver_destroy(sv);
        return step_fail(c, s, "lrr_solver_create");
    }
    snprintf(c->r->kernel, sizeof c->r->kernel, "%s", lrr_solver_kernel(sv));
    s = lrr_solver_set_path(sv, LRR_PATH_FULL);
    if (s == LRR_OK)
        s = time_frames_q(sv, e, b, c->a->repeat, q);
    lrr_solver_destroy(sv);
    return s == LRR_OK ? 0 : step_fail(c, s, "lrr_solve");
}

/* ------------------------------------------------------------------ verification */
/* lrr_operator_verify as `lrr preprocess --verify` runs it (the library's defaults, the
 * bench's seed and threads), on the f32 operator just built, so that its figure stands
 * beside the bench's judgement of the same operator. peak_mib_build is read first: the
 * path tracer's scene copy and buffers count in peak_mib, not in the build's own peak. */
/* A progress bar "SCENE: STEP" on stderr, drawn when it is a terminal. */
static void step_bar(cli_progress *bar, const sc_child *c, const char *step)
{
    char label[96];
    snprintf(label, sizeof label, "%s: %s", c->r->label, step);
    cli_progress_init(bar, label, isatty(STDERR_FILENO));
}

static int sc_verify(sc_child *c, lrr_operator *op)
{
    struct rusage ru;
    memset(&ru, 0, sizeof ru);
    if (getrusage(RUSAGE_SELF, &ru) == 0)
        c->r->peak_mib_build = (double)ru.ru_maxrss / 1024.0; /* Linux: kilobytes */
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = c->a->verify_samples;
    vo.seed = c->a->seed;
    vo.threads = c->a->threads;
    cli_progress bar;
    step_bar(&bar, c, "verify");
    vo.progress = cli_progress_cb;
    vo.progress_user = &bar;
    lrr_status s = lrr_operator_verify(op, c->sc, &vo);
    cli_progress_finish(&bar);
    if (s != LRR_OK)
        return step_fail(c, s, "lrr_operator_verify");
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    c->r->verify_rel_l2 = oi.verify_rel_l2;
    c->r->verify_noise = oi.verify_noise;
    c->r->verify_seconds = oi.verify_seconds;
    c->r->verify_subpatches = oi.verify_subpatches;
    c->r->verify_samples = oi.verify_samples;
    return 0;
}

/* ------------------------------------------------------------------ the operator child */
/* sends: the sc_result, n, then the f32 and the f16 B (n×3 each, the scene's order) */
static int op_send(int fd, sc_child *c, float *const b[2])
{
    size_t n = c->r->n;
    if (write_all(fd, c->r, sizeof *c->r) != 0 || write_all(fd, &n, sizeof n) != 0)
        return -1;
    for (int i = 0; i < 2; i++)
        if (write_all(fd, b[i], 3 * n * sizeof(float)) != 0)
            return -1;
    return 0;
}

/* The frames in f32, then in f16; each storage's last B into out[0], out[1] (scene order). */
static int op_frames(sc_child *c, lrr_operator *op, float *b, float *const out[2])
{
    int rc = time_storage(c, op, lrr_operator_emission(op), b, &c->r->f32);
    lrr_status s = LRR_OK;
    if (!rc)
        lrr_operator_scene_order(op, b, out[0]);
    if (!rc && (s = lrr_operator_set_storage(op, LRR_STORAGE_F16)) != LRR_OK)
        rc = step_fail(c, s, "lrr_operator_set_storage f16");
    if (!rc) /* emission again: set_storage may have moved the operator's arrays */
        rc = time_storage(c, op, lrr_operator_emission(op), b, &c->r->f16);
    if (!rc)
        lrr_operator_scene_order(op, b, out[1]);
    return rc;
}

static int op_child(int fd, void *arg)
{
    sc_child *c = arg;
    child_threads(c->a->threads);
    c->r->threads = omp_get_max_threads();
    lrr_operator *op = NULL;
    float *b = NULL, *out[2] = {NULL, NULL};
    int rc = sc_open(c);
    if (!rc)
        rc = sc_build(c, &op);
    if (!rc)
        rc = sc_verify(c, op);
    size_t n = c->r->n;
    if (!rc && (!(b = bench_alloc_floats(n, 3)) || !(out[0] = bench_alloc_floats(n, 3)) ||
                !(out[1] = bench_alloc_floats(n, 3))))
        rc = bench_fail("%s: out of memory for B (n = %zu)", c->r->label, n);
    if (!rc)
        rc = op_frames(c, op, b, out);
    if (!rc && op_send(fd, c, out) != 0)
        rc = bench_fail("%s: sending the results: %s", c->r->label, strerror(errno));
    lrr_operator_destroy(op);
    lrr_aligned_free(b);
    lrr_aligned_free(out[0]);
    lrr_aligned_free(out[1]);
    sc_close(c);
    return rc;
}

/* ------------------------------------------------------------------ the reference child */
/* The judge's per-subpatch geometry (SC_GEO floats each, the scene's order). */
static int ref_geometry(sc_child *c, size_t n, float *geo)
{
    float *f = bench_alloc_floats(n, SC_GEO); /* planar: centre 3, normal 3, area 1, ρ 3, E 3 */
    if (!f)
        return bench_fail("%s: out of memory for the geometry (n = %zu)", c->r->label, n);
    float *centre = f, *normal = f + 3 * n, *area = f + 6 * n, *rho = f + 7 * n,
          *em = f + 10 * n;
    lrr_status s = lrr_scene_subpatches(c->sc, centre, normal, area, rho, em);
    for (size_t i = 0; i < n && s == LRR_OK; i++) {
        float *g = geo + SC_GEO * i;
        memcpy(g + SC_GEO_CENTRE, centre + 3 * i, 3 * sizeof *g);
        memcpy(g + SC_GEO_NORMAL, normal + 3 * i, 3 * sizeof *g);
        g[SC_GEO_AREA] = area[i];
        memcpy(g + SC_GEO_RHO, rho + 3 * i, 3 * sizeof *g);
        memcpy(g + SC_GEO_EMISSION, em + 3 * i, 3 * sizeof *g);
    }
    lrr_aligned_free(f);
    return s == LRR_OK ? 0 : step_fail(c, s, "lrr_scene_subpatches");
}

/* The path tracer on every subpatch: B into p, its standard errors into se (n×3). */
static int ref_trace(sc_child *c, float *p, float *se)
{
    lrr_path_trace_options o = lrr_path_trace_options_defaults();
    o.samples = c->a->samples;
    o.seed = c->a->seed;
    o.threads = c->a->threads;
    cli_progress bar;
    step_bar(&bar, c, "path tracing");
    o.progress = cli_progress_cb;
    o.progress_user = &bar;
    double t0 = cli_now();
    lrr_status s = lrr_reference_path_trace(c->sc, &o, p, se);
    cli_progress_finish(&bar);
    c->r->reference_s = cli_now() - t0;
    return s == LRR_OK ? 0 : step_fail(c, s, "lrr_reference_path_trace");
}

/* sends: reference_s, n, then the geometry (n×SC_GEO), B and standard errors (n×3 each) */
static int ref_child(int fd, void *arg)
{
    sc_child *c = arg;
    child_threads(c->a->threads);
    int rc = sc_open(c);
    lrr_scene_info si;
    size_t n = 0;
    if (!rc) {
        lrr_scene_get_info(c->sc, &si, sizeof si);
        n = si.subpatches;
    }
    float *geo = rc ? NULL : bench_alloc_floats(n, SC_GEO);
    float *p = rc ? NULL : bench_alloc_floats(n, 3);
    float *se = rc ? NULL : bench_alloc_floats(n, 3);
    if (!rc && (!geo || !p || !se))
        rc = bench_fail("%s: out of memory for the reference (n = %zu)", c->r->label, n);
    if (!rc)
        rc = ref_geometry(c, n, geo);
    if (!rc)
        rc = ref_trace(c, p, se);
    if (!rc && (write_all(fd, &c->r->reference_s, sizeof(double)) != 0 ||
                write_all(fd, &n, sizeof n) != 0 ||
                write_all(fd, geo, SC_GEO * n * sizeof *geo) != 0 ||
                write_all(fd, p, 3 * n * sizeof *p) != 0 ||
                write_all(fd, se, 3 * n * sizeof *se) != 0))
        rc = bench_fail("%s: sending the reference: %s", c->r->label, strerror(errno));
    lrr_aligned_free(geo);
    lrr_aligned_free(p);
    lrr_aligned_free(se);
    sc_close(c);
    return rc;
}

/* ------------------------------------------------------------------ one scene */
static void result_init(sc_result *r, const char *scene)
{
    memset(r, 0, sizeof *r);
    scene_label(scene, r->label, sizeof r->label);
    double *nan_fields[] = {
        &r->subdivide_s, &r->build_s,   &r->clustering_s, &r->formfactor_s, &r->smw_s,
        &r->preprocess_s, &r->op_mib,   &r->peak_mib,     &r->peak_mib_build,
        &r->back_face_share, &r->f32.median, &r->f32.q1,  &r->f32.q3,       &r->f16.median,
        &r->f16.q1,      &r->f16.q3,    &r->bandwidth,    &r->floor_f32,    &r->floor_f16,
        &r->ratio_f32,   &r->ratio_f16, &r->reference_s,  &r->reference_peak_mib,
        &r->verify_rel_l2, &r->verify_noise, &r->verify_seconds};
    for (size_t i = 0; i < sizeof nan_fields / sizeof nan_fields[0]; i++)
        *nan_fields[i] = NAN;
    sc_judgement_init(&r->judge);
    snprintf(r->kernel, sizeof r->kernel, "-");
}

/* n×w floats of what a child sent into a fresh *out. */
static int take_floats(sc_buf *b, size_t n, size_t w, float **out)
{
    size_t len = n * w * sizeof(float);
    return (*out = malloc(len ? len : 1)) && buf_take(b, *out, len) == 0 ? 0 : -1;
}

/* The operator child's row and its f32 and f16 B into r and op. */
static int take_op(sc_buf *b, sc_result *r, float *op[2])
{
    sc_result got;
    size_t n = 0;
    if (buf_take(b, &got, sizeof got) != 0 || buf_take(b, &n, sizeof n) != 0 || n != got.n)
        return -1;
    got.peak_mib = r->peak_mib;
    *r = got;
    return take_floats(b, n, 3, &op[0]) || take_floats(b, n, 3, &op[1]) ? -1 : 0;
}

/* The reference child's geometry, B and standard errors into ref[0..2]; n must be the
 * operator's (both children subdivided the same scene the same way). */
static int take_ref(sc_buf *b, sc_result *r, float *ref[3])
{
    size_t n = 0;
    if (buf_take(b, &r->reference_s, sizeof(double)) != 0 || buf_take(b, &n, sizeof n) != 0 ||
        n != r->n)
        return -1;
    return take_floats(b, n, SC_GEO, &ref[0]) || take_floats(b, n, 3, &ref[1]) ||
                   take_floats(b, n, 3, &ref[2])
               ? -1
               : 0;
}

static int run_reference(const sc_args *a, sc_child *c, sc_result *r, float *ref[3])
{
    sc_buf b = {0};
    sc_result scratch = *r;
    c->r = &scratch;
    bench_note("%s: path-traced reference (%zu samples per subpatch)", r->label, a->samples);
    int rc = run_child(r->label, ref_child, c, &b, &r->reference_peak_mib);
    if (!rc && take_ref(&b, r, ref) != 0)
        rc = bench_fail("%s: the reference child sent too little, or for another n than "
                        "the operator's %zu", r->label, r->n);
    free(b.p);
    if (rc)
        snprintf(r->failed, sizeof r->failed, "path-traced reference");
    return rc;
}

static int judge(sc_result *r, float *const op[2], float *const ref[3])
{
    /* lrr_operator_verify's regions: the same 8³ cells, × facing (lib/verify/verify.c) */
    sc_judge_input in = {r->n, ref[0], op[0], op[1], ref[1], ref[2],
                         r->verify_subpatches ? SC_GRID : 0};
    if (sc_judge(&in, &r->judge) == 0)
        return 0;
    snprintf(r->failed, sizeof r->failed, "judgement");
    return bench_fail("%s: the judgement: out of memory (n = %zu)", r->label, r->n);
}

int sc_run_scene(const sc_args *a, const char *scene, sc_result *r)
{
    result_init(r, scene);
    sc_child c = {a, scene, r, NULL, NULL, ""};
    sc_buf b = {0};
    float *op[2] = {NULL, NULL}, *ref[3] = {NULL, NULL, NULL};
    bench_note("%s: operator (K %zu, hemicube %u), verify, frames", r->label, a->patches,
               a->hemicube);
    double peak = NAN;
    int rc = run_child(r->label, op_child, &c, &b, &peak);
    r->peak_mib = peak;
    if (!rc && take_op(&b, r, op) != 0)
        rc = bench_fail("%s: the operator child sent too little", r->label);
    free(b.p);
    if (rc) {
        snprintf(r->failed, sizeof r->failed, "operator pipeline");
        r->peak_mib = NAN; /* of a pipeline that did not finish */
    } else if (!(rc = run_reference(a, &c, r, ref)))
        rc = judge(r, op, ref);
    for (int i = 0; i < 2; i++)
        free(op[i]);
    for (int i = 0; i < 3; i++)
        free(ref[i]);
    return rc;
}
