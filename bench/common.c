/*
 * lrr-bench: the parts every command shares (see bench.h). Uses only the public API
 * (lrr.h), cblas for the baselines.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "bench.h"

#define BANDWIDTH_MIN_BYTES ((size_t)512 << 20)
#define BANDWIDTH_MAX_BYTES ((size_t)4 << 30)

/* ------------------------------------------------------------------ messages */
int bench_fail(const char *fmt, ...)
{
    va_list ap;
    fputs("lrr-bench: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return CLI_EXIT_FAIL;
}

/* "lrr-bench: <what>: <status>: <library message>" */
int lib_fail(lrr_context *ctx, lrr_status s, const char *what)
{
    char msg[1024] = "";
    if (ctx && lrr_context_last_error(ctx, msg, sizeof msg) == LRR_OK)
        msg[0] = '\0';
    return bench_fail("%s: %s%s%s", what, lrr_strerror(s), msg[0] ? ": " : "", msg);
}

int bench_csv_finish(cli_outfile *out, int rc, const char *path)
{
    if (rc != CLI_EXIT_OK) {
        cli_outfile_abort(out);
        return rc;
    }
    if (cli_outfile_commit(out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    printf("csv: %s\n", path);
    return rc;
}

void note(const char *fmt, ...)
{
    va_list ap;
    fputs("lrr-bench: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    fflush(stderr);
}

int bad_option(const char *prog, int c, char *const argv[])
{
    const char *arg = optind > 0 ? argv[optind - 1] : "";
    if (c == ':')
        cli_usage_error(prog, "%s: a value is required", arg);
    else if (strncmp(arg, "--", 2) == 0 || optopt == 0 || optopt > 255)
        cli_usage_error(prog, "unknown option '%s'", arg);
    else
        cli_usage_error(prog, "unknown option '-%c'", optopt);
    fprintf(stderr, "Try '%s --help'.\n", prog);
    return CLI_EXIT_USAGE;
}

void start_getopt(void)
{
    opterr = 0;
    optind = 0; /* glibc: re-initialise the scanner */
}

int no_positional(const char *prog, int argc, char *const argv[])
{
    if (optind < argc) {
        cli_usage_error(prog, "unexpected argument '%s'", argv[optind]);
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    return 0;
}

/* ------------------------------------------------------------------ machine description */
static void cpu_model(char *buf, size_t len)
{
    snprintf(buf, len, "unknown");
    FILE *f = fopen("/proc/cpuinfo", "r");
    if (!f)
        return;
    char line[512];
    while (fgets(line, sizeof line, f)) {
        if (strncmp(line, "model name", 10) != 0)
            continue;
        char *colon = strchr(line, ':');
        if (!colon)
            continue;
        colon++;
        while (*colon == ' ' || *colon == '\t')
            colon++;
        colon[strcspn(colon, "\n")] = '\0';
        snprintf(buf, len, "%s", colon);
        break;
    }
    fclose(f);
}

/* "caches: L1d 48K, L2 1024K, L3 32768K" from sysfs (cpu0's view; the size a core sees) */
static void print_caches(void)
{
    char line[160] = "", path[96], level[16], type[32], size[32];
    for (int i = 0; i < 8; i++) {
        FILE *f;
        int ok = 1;
        const char *want[3] = {"level", "type", "size"};
        char *out[3] = {level, type, size};
        for (int j = 0; j < 3 && ok; j++) {
            snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/%s", i,
                     want[j]);
            ok = (f = fopen(path, "r")) && fscanf(f, "%15s", out[j]) == 1;
            if (f)
                fclose(f);
        }
        if (!ok)
            break;
        if (strcmp(type, "Instruction") == 0)
            continue;
        size_t len = strlen(line);
        snprintf(line + len, sizeof line - len, "%sL%s%s %s", len ? ", " : "", level,
                 strcmp(type, "Data") == 0 ? "d" : "", size);
    }
    printf("caches: %s\n", line[0] ? line : "unknown");
}

void print_machine(void)
{
    char cpu[256], date[64];
    cpu_model(cpu, sizeof cpu);
    time_t t = time(NULL);
    struct tm tm;
    localtime_r(&t, &tm);
    strftime(date, sizeof date, "%Y-%m-%d %H:%M:%S %z", &tm);
    printf("cpu: %s\n", cpu);
    print_caches();
    printf("cores_online: %ld\n", sysconf(_SC_NPROCESSORS_ONLN));
    printf("threads_openmp: %d\n", omp_get_max_threads());
    printf("threads_openblas: %d\n", openblas_get_num_threads());
    printf("openblas: %s\n", openblas_get_config());
    const char *ct = getenv("OPENBLAS_CORETYPE");
    if (ct)
        printf("openblas_core: %s (OPENBLAS_CORETYPE=%s)\n", openblas_get_corename(), ct);
    else
        printf("openblas_core: %s\n", openblas_get_corename());
    printf("lrr: %s\n", lrr_version_string());
    printf("date: %s\n", date);
    /* timings on a shared machine mean little when it is busy: say how busy it was */
    FILE *f = fopen("/proc/loadavg", "r");
    double l1, l5, l15;
    if (f && fscanf(f, "%lf %lf %lf", &l1, &l5, &l15) == 3)
        printf("load_average: %.2f %.2f %.2f\n", l1, l5, l15);
    if (f)
        fclose(f);
}

/* ------------------------------------------------------------------ scenes */
int open_scene(lrr_context *ctx, const char *name, lrr_scene **scene)
{
    struct stat st;
    lrr_status s;
    if (stat(name, &st) == 0)
        s = lrr_scene_load(ctx, name, scene);
    else if (strcmp(name, "cornell") == 0 || strcmp(name, "cornell-closed") == 0)
        s = lrr_scene_builtin(ctx, name, scene);
    else
        return bench_fail("scene '%s': %s (built-in scenes: cornell, cornell-closed)", name,
                          strerror(errno));
    if (s != LRR_OK) {
        char what[512];
        snprintf(what, sizeof what, "scene '%s'", name);
        return lib_fail(ctx, s, what);
    }
    return CLI_EXIT_OK;
}

/* levels with 4^levels = d, or -1 */
int levels_of(size_t d)
{
    int l = 0;
    while (d > 1 && d % 4 == 0) {
        d /= 4;
        l++;
    }
    return d == 1 && l <= 10 ? l : -1;
}

/* Progress on stderr: a bar on a terminal, nothing otherwise (phase lines say enough). */
void progress_begin(cli_progress *bar, const char *label, lrr_build_options *bo)
{
    cli_progress_init(bar, label, isatty(STDERR_FILENO));
    bo->progress = cli_progress_cb;
    bo->progress_user = bar;
}

/* ------------------------------------------------------------------ timing */
/* Two warm-up runs, then `repeat` timed runs (0: adaptive, at least MIN_RUNS and at least
 * MIN_SECONDS in all). Returns 0 or the frame's non-zero status. */
void timing_from_samples(double *v, size_t runs, timing *t)
{
    t->min = t->max = v[0];
    for (size_t r = 1; r < runs; r++) {
        t->min = fmin(t->min, v[r]);
        t->max = fmax(t->max, v[r]);
    }
    t->median = cli_median(v, runs); /* reorders v */
    t->runs = runs;
}

int time_frames(frame_fn fn, void *user, unsigned repeat, timing *t)
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
    timing_from_samples(v, runs, t);
    free(v);
    return 0;
}

/* Size of the last-level cache in bytes (the highest cache index sysfs lists), 0 if unknown. */
size_t llc_bytes(void)
{
    size_t best = 0;
    for (int i = 0; i < 8; i++) {
        char path[96];
        snprintf(path, sizeof path, "/sys/devices/system/cpu/cpu0/cache/index%d/size", i);
        FILE *f = fopen(path, "r");
        if (!f)
            continue;
        unsigned long long v = 0;
        char unit = 0;
        if (fscanf(f, "%llu%c", &v, &unit) >= 1) {
            if (unit == 'K')
                v <<= 10;
            else if (unit == 'M')
                v <<= 20;
            if (v > best)
                best = (size_t)v;
        }
        fclose(f);
    }
    return best;
}

/* Bytes of the bandwidth buffer: four times the last-level cache (some servers have
 * hundreds of MiB of it), at least 512 MiB, at most 4 GiB. */
size_t bandwidth_buffer_bytes(void)
{
    size_t llc = llc_bytes();
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

double measure_bandwidth(size_t bytes)
{
    size_t count = bytes / sizeof(float) / 128 * 128;
    float *buf = lrr_aligned_alloc(count * sizeof(float));
    if (!buf)
        return 0;
    #pragma omp parallel for schedule(static)
    for (size_t i = 0; i < count; i++)
        buf[i] = 1.0f; /* first touch by the thread that will read it */
    /* Every read loop the CPU runs, the best pass of any: on this project's AMD EPYC the
     * 256-bit loop read 64.8 GB/s where the 512-bit one read 58.5 (medians of 15, one
     * process), so the widest alone would set the floor too low. */
    enum { LOOPS = 5 };
    double (*sums[LOOPS])(const float *, size_t) = {sum_portable, NULL, NULL, NULL, NULL};
#if defined(__x86_64__)
    if (__builtin_cpu_supports("avx2"))
        sums[1] = sum_avx2, sums[3] = sum_avx2_pf;
    if (__builtin_cpu_supports("avx512f"))
        sums[2] = sum_avx512, sums[4] = sum_avx512_pf;
#endif
    const size_t blocks = count / 128;
    double best = 0, check = 0;
    for (int pass = 0; pass < LOOPS * BANDWIDTH_PASSES; pass++) {
        double (*sum)(const float *, size_t) = sums[pass % LOOPS];
        if (!sum)
            continue;
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
        check += total;
        if (s > 0 && (double)(count * sizeof(float)) / s > best)
            best = (double)(count * sizeof(float)) / s;
    }
    lrr_aligned_free(buf);
    /* the sums are used, so no pass can be optimised away */
    return check > 0 ? best : 0;
}

/* ---------------------------------------------------------------- the three real-time steps */
int ours_step(void *user)
{
    ours_frame *f = user;
    const float *e = f->e_alt && (f->frame++ & 1) ? f->e_alt : f->e;
    f->status = lrr_solve(f->solver, e, f->b);
    return f->status != LRR_OK;
}

/* ------------------------------------------------------------------ OpenCL */
int parse_backend(const char *prog, const char *text, int *opencl)
{
    lrr_backend b;
    if (cli_parse_backend(prog, text, &b) != 0)
        return -1;
    *opencl = b == LRR_BACKEND_OPENCL;
    return 0;
}

int opencl_probe(lrr_context *ctx)
{
    const float v[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, rho[3] = {0.5f, 0.5f, 0.5f},
                em[3] = {1, 1, 1};
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    lrr_solver *sv = NULL;
    lrr_subdivision sd = {0};
    lrr_status s = lrr_scene_create(ctx, 1, v, rho, em, "opencl-probe", &scene);
    if (s == LRR_OK)
        s = lrr_scene_subdivide(scene, &sd);
    if (s == LRR_OK)
        s = lrr_operator_build(scene, NULL, &op);
    if (s != LRR_OK) {
        lrr_scene_destroy(scene);
        return lib_fail(ctx, s, "--backend opencl: probe operator");
    }
    lrr_scene_destroy(scene);
    s = lrr_solver_create(op, LRR_BACKEND_OPENCL, &sv);
    int rc = s == LRR_OK ? CLI_EXIT_OK : lib_fail(ctx, s, "--backend opencl");
    lrr_solver_destroy(sv);
    lrr_operator_destroy(op);
    return rc;
}

int bench_start(const char *scene, int opencl, lrr_context **out)
{
    *out = NULL;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return lib_fail(NULL, s, "context");
    /* a scene that cannot be read fails now, not after the bandwidth measurement */
    lrr_scene *probe = NULL;
    int rc = open_scene(ctx, scene, &probe);
    lrr_scene_destroy(probe);
    if (rc == CLI_EXIT_OK && opencl)
        rc = opencl_probe(ctx);
    if (rc != CLI_EXIT_OK) {
        lrr_context_destroy(ctx);
        return rc;
    }
    *out = ctx;
    return CLI_EXIT_OK;
}

int cl_step(void *user)
{
    cl_frame *f = user;
    if (ours_step(&f->of))
        return 1;
    double km = NAN, tm = NAN;
    if ((f->of.status = lrr_solver_timings(f->of.solver, &km, &tm)) != LRR_OK)
        return 1;
    if (f->count < f->cap) {
        f->kernel_ms[f->count] = km;
        f->transfer_ms[f->count] = tm;
        f->count++;
    }
    return 0;
}

void cl_medians(cl_frame *f, size_t runs, double *kernel_ms, double *transfer_ms)
{
    if (runs > f->count)
        runs = f->count;
    if (!runs) {
        *kernel_ms = *transfer_ms = NAN;
        return;
    }
    const size_t first = f->count - runs;
    *kernel_ms = cli_median(f->kernel_ms + first, runs);
    *transfer_ms = cli_median(f->transfer_ms + first, runs);
}

const char *cl_device_name(const lrr_solver *s, char *buf, size_t len)
{
    snprintf(buf, len, "%s", lrr_solver_kernel(s));
    for (char *p = buf; *p; p++)
        if (*p == ',' || *p == '\n' || *p == '"')
            *p = ';';
    return buf;
}

const char *path_name(lrr_path p)
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

int paper_step(void *user)
{
    paper_frame *f = user;
    for (int c = 0; c < 3; c++) {
        cblas_sgemv(CblasRowMajor, CblasTrans, f->n, f->k, 1.0f, f->v, f->k, f->e[c], 1, 0.0f,
                    f->w, 1);
        cblas_scopy(f->n, f->e[c], 1, f->b[c], 1);
        cblas_sgemv(CblasRowMajor, CblasNoTrans, f->n, f->k, -1.0f, f->y[c], f->k, f->w, 1, 1.0f,
                    f->b[c], 1);
    }
    return 0;
}

void paper_free(paper_frame *f)
{
    lrr_aligned_free(f->v);
    lrr_aligned_free(f->w);
    for (int c = 0; c < 3; c++) {
        lrr_aligned_free(f->y[c]);
        lrr_aligned_free(f->e[c]);
        lrr_aligned_free(f->b[c]);
    }
    memset(f, 0, sizeof *f);
}

/* F̄ row-major in a new buffer (NULL when it cannot be allocated), whatever the operator's
 * storage and layout: the OpenBLAS baselines read rows, the operator holds panels. */
float *bench_fbar_rows(const lrr_operator *op)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *f = alloc_floats(oi.n, oi.k);
    for (size_t i = 0; f && i < oi.n; i++)
        lrr_operator_fbar_row(op, i, f + i * oi.k);
    return f;
}

float *alloc_floats(size_t a, size_t b)
{
    if (a == 0 || b == 0 || a > SIZE_MAX / sizeof(float) / b)
        return NULL;
    float *p = lrr_aligned_alloc(a * b * sizeof(float));
    if (p)
        memset(p, 0, a * b * sizeof(float));
    return p;
}

/* Builds the paper's Y_c and V from the operator (sgemm, outside any timing). */
int paper_setup(const lrr_operator *op, const float *e, paper_frame *f)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    size_t n = oi.n, k = oi.k, d = oi.d;
    memset(f, 0, sizeof *f);
    f->n = (blasint)n;
    f->k = (blasint)k;
    f->v = alloc_floats(n, k);
    f->w = alloc_floats(k, 1);
    for (int c = 0; c < 3; c++) {
        f->y[c] = alloc_floats(n, k);
        f->e[c] = alloc_floats(n, 1);
        f->b[c] = alloc_floats(n, 1);
    }
    if (!f->v || !f->w || !f->y[0] || !f->y[1] || !f->y[2] || !f->e[0] || !f->e[1] ||
        !f->e[2] || !f->b[0] || !f->b[1] || !f->b[2]) {
        paper_free(f);
        return bench_fail("the paper's method: cannot allocate 4 n×k matrices (%.1f MB)",
                          4.0 * (double)n * (double)k * 4 / MB);
    }
    float *fbar = bench_fbar_rows(op);
    if (!fbar) {
        paper_free(f);
        return bench_fail("the paper's method: cannot allocate a row-major copy of F̄");
    }
    const float *m = lrr_operator_m(op), *rho = lrr_operator_reflectance(op);
    for (size_t i = 0; i < n; i++) {
        f->v[i * k + i / d] = 1.0f;
        for (int c = 0; c < 3; c++)
            f->e[c][i] = e[3 * i + c];
    }
    for (int c = 0; c < 3; c++) {
        cblas_sgemm(CblasRowMajor, CblasNoTrans, CblasNoTrans, f->n, f->k, f->k, 1.0f, fbar,
                    f->k, m + (size_t)c * k * k, f->k, 0.0f, f->y[c], f->k);
        float *y = f->y[c];
        #pragma omp parallel for schedule(static)
        for (size_t i = 0; i < n; i++) {
            float r = -rho[3 * i + c];
            for (size_t p = 0; p < k; p++)
                y[i * k + p] *= r;
        }
    }
    lrr_aligned_free(fbar);
    return 0;
}

/* Three sgemv over F̄, one per channel, nothing else. */
int sgemv_step(void *user)
{
    sgemv_frame *f = user;
    for (int c = 0; c < 3; c++)
        cblas_sgemv(CblasRowMajor, CblasNoTrans, f->n, f->k, 1.0f, f->fbar, f->k, f->z[c], 1,
                    0.0f, f->out[c], 1);
    return 0;
}

/* ---------------------------------------------------------------- errors */
/* Area-weighted relative L2 over all channels and the largest relative error over entries
 * above 1e-3 of the largest reference value. With `skip_e` the emission is subtracted from
 * both (the reflected part only). */
void compare_b(size_t n, const float *area, const float *b, const float *ref,
                      const float *e, double *rel_l2, double *max_rel)
{
    double num = 0, den = 0, bmax = 0;
    for (size_t i = 0; i < 3 * n; i++)
        bmax = fmax(bmax, fabs((double)ref[i] - (e ? e[i] : 0)));
    double mr = 0;
    for (size_t i = 0; i < n; i++) {
        double a = area ? area[i] : 1.0;
        for (int c = 0; c < 3; c++) {
            double r = (double)ref[3 * i + c] - (e ? e[3 * i + c] : 0);
            double x = (double)b[3 * i + c] - (e ? e[3 * i + c] : 0);
            double dlt = x - r;
            num += a * dlt * dlt;
            den += a * r * r;
            if (fabs(r) > 1e-3 * bmax)
                mr = fmax(mr, fabs(dlt) / fabs(r));
            if (!isfinite(x))
                mr = INFINITY;
        }
    }
    *rel_l2 = den > 0 ? sqrt(num) / sqrt(den) : (num > 0 ? INFINITY : 0);
    if (max_rel)
        *max_rel = mr;
}

/* 12.2 GB, 4.3 GB, 35.4 MB: decimal units, three significant digits or one decimal */
const char *fmt_bytes(char *buf, size_t len, size_t bytes)
{
    double b = (double)bytes;
    if (b >= 1e9)
        snprintf(buf, len, "%.1f GB", b / 1e9);
    else if (b >= 1e6)
        snprintf(buf, len, "%.1f MB", b / 1e6);
    else
        snprintf(buf, len, "%.1f kB", b / 1e3);
    return buf;
}

/* ---------------------------------------------------------------- numbers */
const char *fmt_ms(char *buf, size_t len, double v)
{
    if (isnan(v))
        return snprintf(buf, len, "-"), buf;
    snprintf(buf, len, v < 10 ? "%.3f" : v < 100 ? "%.2f" : "%.1f", v);
    return buf;
}

void csv_num(FILE *f, double v, int last)
{
    if (isnan(v))
        fputs("nan", f);
    else if (isinf(v))
        fputs(v > 0 ? "inf" : "-inf", f);
    else
        fprintf(f, "%.6g", v);
    fputc(last ? '\n' : ',', f);
}
