/* Helpers of the `lrr` tool: see cli.h. */
#include "cli.h"

#include <ctype.h>
#include <dlfcn.h>
#include <errno.h>
#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <sys/stat.h>
#include <unistd.h>

/* ------------------------------------------------------------------ messages */
void cli_usage_error(const char *prog, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "%s: ", prog);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
}

int cli_lib_error(lrr_context *ctx, lrr_status status)
{
    char msg[1024] = "";
    if (ctx) {
        /* The first error recorded is the most specific one (later ones are consequences). */
        lrr_status recorded = lrr_context_last_error(ctx, msg, sizeof msg);
        if (recorded == LRR_OK)
            msg[0] = '\0';
    }
    if (msg[0])
        fprintf(stderr, "lrr: %s: %s\n", lrr_strerror(status), msg);
    else
        fprintf(stderr, "lrr: %s\n", lrr_strerror(status));
    return CLI_EXIT_FAIL;
}

int cli_fail(lrr_status status, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "lrr: %s: ", lrr_strerror(status));
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return CLI_EXIT_FAIL;
}

/* ------------------------------------------------------------------ numbers */
int cli_parse_u64(const char *prog, const char *opt, const char *text, uint64_t min,
                  uint64_t max, uint64_t *out)
{
    /* strtoull skips spaces and silently wraps "-1" to 2^64-1: only plain digits pass. */
    if (!isdigit((unsigned char)text[0])) {
        cli_usage_error(prog, "%s: '%s' is not an integer", opt, text);
        return -1;
    }
    char *end = NULL;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    if (*end != '\0') {
        cli_usage_error(prog, "%s: '%s' is not an integer", opt, text);
        return -1;
    }
    if (errno == ERANGE || v < min || v > max) {
        cli_usage_error(prog, "%s: '%s' is out of range (%llu..%llu)", opt, text,
                        (unsigned long long)min, (unsigned long long)max);
        return -1;
    }
    *out = (uint64_t)v;
    return 0;
}

int cli_parse_size(const char *prog, const char *opt, const char *text, size_t min,
                   size_t max, size_t *out)
{
    uint64_t v;
    if (cli_parse_u64(prog, opt, text, min, max, &v) != 0)
        return -1;
    *out = (size_t)v;
    return 0;
}

int cli_parse_backend(const char *prog, const char *text, lrr_backend *out)
{
    if (strcmp(text, "cpu") == 0)
        *out = LRR_BACKEND_CPU;
    else if (strcmp(text, "opencl") == 0)
        *out = LRR_BACKEND_OPENCL;
    else {
        cli_usage_error(prog, "--backend: '%s' is not one of cpu, opencl", text);
        return -1;
    }
    return 0;
}

int cli_parse_unsigned(const char *prog, const char *opt, const char *text, unsigned min,
                       unsigned max, unsigned *out)
{
    uint64_t v;
    if (cli_parse_u64(prog, opt, text, min, max, &v) != 0)
        return -1;
    *out = (unsigned)v;
    return 0;
}

int cli_parse_double(const char *prog, const char *opt, const char *text, double min,
                     int min_open, double max, double *out)
{
    char *end = NULL;
    if (text[0] == '\0' || isspace((unsigned char)text[0])) {
        cli_usage_error(prog, "%s: '%s' is not a number", opt, text);
        return -1;
    }
    errno = 0;
    double v = strtod(text, &end);
    if (*end != '\0') {
        cli_usage_error(prog, "%s: '%s' is not a number", opt, text);
        return -1;
    }
    if (!isfinite(v) || errno == ERANGE) {
        cli_usage_error(prog, "%s: '%s' is not a finite number", opt, text);
        return -1;
    }
    if (v < min || (min_open && v == min)) {
        cli_usage_error(prog, "%s: '%s' is out of range (it must be %s %g)", opt, text,
                        min_open ? "greater than" : "at least", min);
        return -1;
    }
    if (v > max) {
        cli_usage_error(prog, "%s: '%s' is out of range (it must be at most %g)", opt, text,
                        max);
        return -1;
    }
    *out = v;
    return 0;
}

int cli_parse_vec3(const char *text, double v[3])
{
    const char *p = text;
    for (int j = 0; j < 3; j++) {
        char *end = NULL;
        if (*p == '\0' || isspace((unsigned char)*p))
            return -1;
        errno = 0;
        v[j] = strtod(p, &end);
        if (end == p || errno == ERANGE || !isfinite(v[j]) || fabs(v[j]) > FLT_MAX ||
            *end != (j < 2 ? ',' : '\0'))
            return -1;
        p = end + 1;
    }
    return 0;
}

/* ------------------------------------------------------------------ time */
double cli_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* ------------------------------------------------------------------ progress bar */
void cli_progress_init(cli_progress *p, const char *label, int enabled)
{
    p->label = label;
    p->enabled = enabled;
    p->drawn = 0;
    p->start = cli_now();
    p->last_draw = -1.0;
    p->last_done = (size_t)-1;
}

int cli_progress_cb(void *user, size_t done, size_t total)
{
    cli_progress *p = user;
    if (!p || !p->enabled)
        return 0;
    double now = cli_now();
    int last = total > 0 && done >= total;
    /* Redrawing on every receiver would cost more than the hemicubes on small scenes. */
    if (done == p->last_done || (!last && p->last_draw >= 0.0 && now - p->last_draw < 0.1))
        return 0;
    p->last_draw = now;
    p->last_done = done;

    enum { WIDTH = 30 };
    double frac = total > 0 ? (double)done / (double)total : 0.0;
    if (frac > 1.0)
        frac = 1.0;
    int filled = (int)(frac * WIDTH + 0.5);
    char bar[WIDTH + 1];
    for (int i = 0; i < WIDTH; i++)
        bar[i] = i < filled ? '#' : '.';
    bar[WIDTH] = '\0';
    fprintf(stderr, "\r%s [%s] %3d%% %zu/%zu %.1f s", p->label, bar, (int)(frac * 100.0),
            done, total, now - p->start);
    fflush(stderr);
    p->drawn = 1;
    return 0;
}

void cli_progress_finish(cli_progress *p)
{
    if (p->enabled && p->drawn) {
        fputc('\n', stderr);
        fflush(stderr);
    }
    p->drawn = 0;
}

/* ------------------------------------------------------------------ atomic output files */
int cli_outfile_open(cli_outfile *out, const char *path)
{
    memset(out, 0, sizeof *out);
    if (!(out->path = strdup(path))) {
        errno = ENOMEM;
        return -1;
    }
    int e = lrr__atomic_open(&out->w, out->path, NULL);
    if (e) {
        lrr__atomic_free(&out->w);
        free(out->path);
        out->path = NULL;
        errno = e;
        return -1;
    }
    out->f = out->w.f;
    return 0;
}

int cli_outfile_commit(cli_outfile *out)
{
    int e = lrr__atomic_commit(&out->w);
    lrr__atomic_free(&out->w);
    free(out->path);
    out->path = NULL;
    out->f = NULL;
    errno = e;
    return e ? -1 : 0;
}

void cli_outfile_abort(cli_outfile *out)
{
    lrr__atomic_abort(&out->w);
    lrr__atomic_free(&out->w);
    free(out->path);
    out->path = NULL;
    out->f = NULL;
}

static int write_rows(const char *path, size_t n, size_t d, const size_t *first,
                      const size_t *row, const size_t *patch_of, const float *area,
                      const float *centre, const float *normal, const float *radiosity);

int cli_write_subpatch_csv(const char *path, size_t n, size_t d, const size_t *first,
                           const float *area, const float *centre, const float *normal,
                           const float *radiosity)
{
    return cli_write_subpatch_csv_order(path, n, d, first, NULL, area, centre, normal,
                                        radiosity);
}

/* Row j is subpatch j of the scene's order; with origin (clusters), the data are in the
 * operator's order and row origin[i] takes its entry i. */
static size_t *scene_rows(size_t n, const size_t *origin)
{
    size_t *row = malloc((n ? n : 1) * sizeof *row);
    if (!row) {
        cli_fail(LRR_ERR_NOMEM, "cannot allocate %zu row indices", n);
        return NULL;
    }
    for (size_t i = 0; i < n; i++)
        row[origin[i]] = i;
    return row;
}

int cli_write_subpatch_csv_order(const char *path, size_t n, size_t d, const size_t *first,
                                 const size_t *origin, const float *area, const float *centre,
                                 const float *normal, const float *radiosity)
{
    size_t *row = origin ? scene_rows(n, origin) : NULL;
    if (origin && !row)
        return CLI_EXIT_FAIL;
    if (d == 0)
        d = 1;
    size_t *patch = NULL;
    if (origin && first && (patch = malloc((n ? n : 1) * sizeof *patch)))
        for (size_t p = 0; first[p] < n; p++)
            for (size_t i = first[p]; i < first[p + 1]; i++)
                patch[i] = p;
    if (origin && !patch) {
        free(row);
        return cli_fail(LRR_ERR_NOMEM, "cannot allocate %zu patch indices", n);
    }
    int rc = write_rows(path, n, d, first, row, patch, area, centre, normal, radiosity);
    free(row);
    free(patch);
    return rc;
}

static int write_rows(const char *path, size_t n, size_t d, const size_t *first,
                      const size_t *row, const size_t *patch_of, const float *area,
                      const float *centre, const float *normal, const float *radiosity)
{
    if (d == 0)
        d = 1;
    size_t patch = 0; /* with first (adaptive hierarchy): patch of subpatch i, walked along */
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return cli_fail(LRR_ERR_IO, "cannot create a temporary file for '%s': %s", path,
                        strerror(errno));
    fputs(CLI_CSV_HEADER "\n", out.f);
    for (size_t j = 0; j < n; j++) {
        const size_t i = row ? row[j] : j;
        const float *c = centre + 3 * i, *nr = normal + 3 * i, *b = radiosity + 3 * i;
        if (first && !patch_of)
            while (first[patch + 1] <= i)
                patch++;
        if (fprintf(out.f, "%zu,%zu,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", j,
                    patch_of ? patch_of[i] : first ? patch : i / d, (double)area[i], (double)c[0], (double)c[1], (double)c[2],
                    (double)nr[0], (double)nr[1], (double)nr[2], (double)b[0], (double)b[1],
                    (double)b[2]) < 0)
            break; /* the error sticks in ferror(); commit reports it */
    }
    if (cli_outfile_commit(&out) != 0)
        return cli_fail(LRR_ERR_IO, "cannot write '%s': %s", path, strerror(errno));
    return CLI_EXIT_OK;
}

int cli_write_radiosity_csv(const char *path, const lrr_operator *op, const float *radiosity)
{
    lrr_operator_info info;
    lrr_operator_get_info(op, &info, sizeof info);
    const float *area = lrr_operator_area(op);
    const float *centre = lrr_operator_centre(op);
    const float *normal = lrr_operator_normal(op);
    if (!area || !centre || !normal)
        return cli_fail(LRR_ERR_INVALID_ARG, "%s: the operator has no per-subpatch geometry",
                        path);
    return cli_write_subpatch_csv_order(path, info.n, info.d, lrr_operator_patch_offsets(op),
                                        lrr_operator_subpatch_origin(op), area, centre,
                                        normal, radiosity);
}

/* ------------------------------------------------------------------ misc */
float *cli_alloc_rgb(size_t n)
{
    if (n == 0 || n > SIZE_MAX / (3 * sizeof(float))) {
        cli_fail(LRR_ERR_OVERFLOW, "%zu subpatches × 3 colours does not fit in memory", n);
        return NULL;
    }
    float *p = calloc(n * 3, sizeof(float));
    if (!p)
        cli_fail(LRR_ERR_NOMEM, "cannot allocate %zu colours", n * 3);
    return p;
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

double cli_median(double *v, size_t n)
{
    qsort(v, n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

void cli_irradiance_error_pct(size_t m, const float *truth, const float *approx,
                              double *mean_pct, double *max_pct)
{
    double tmax = 0;
    for (size_t i = 0; i < 3 * m; i++)
        tmax = fmax(tmax, truth[i]);
    double sum = 0, emax = 0;
    size_t counted = 0;
    for (size_t i = 0; i < 3 * m; i++) {
        if (!(truth[i] > 1e-6 * tmax))
            continue;
        double e = fabs((double)approx[i] - truth[i]) / truth[i];
        sum += e;
        emax = fmax(emax, e);
        counted++;
    }
    *mean_pct = counted ? 100 * sum / (double)counted : NAN;
    *max_pct = counted ? 100 * emax : NAN;
}

/* ------------------------------------------------------------------ directories */
/* mkdir -p: creates each missing component of dir. */
FILE *cli_open_regular(const char *path, const char **why)
{
    FILE *f = NULL;
    int e = lrr__open_regular(path, &f, NULL);
    *why = e == LRR__NOT_REGULAR ? LRR__NOT_REGULAR_TEXT : e ? strerror(e) : "";
    return f;
}

int cli_make_dir(const char *dir)
{
    char *p = strdup(dir);
    if (!p)
        return cli_fail(LRR_ERR_NOMEM, "cannot copy the path '%s'", dir);
    for (char *q = p + 1;; q++) {
        int end = *q == '\0';
        if (*q == '/' || end) {
            char keep = *q;
            *q = '\0';
            struct stat st;
            if (mkdir(p, 0777) != 0 && errno != EEXIST) {
                int e = errno;
                free(p);
                return cli_fail(LRR_ERR_IO, "cannot create the directory '%s': %s", dir,
                                strerror(e));
            }
            if (stat(p, &st) != 0 || !S_ISDIR(st.st_mode)) {
                free(p);
                return cli_fail(LRR_ERR_IO, "'%s' is not a directory", dir);
            }
            *q = keep;
        }
        if (end)
            break;
    }
    free(p);
    return CLI_EXIT_OK;
}


/* OpenBLAS's pthread pool starts with the library and its workers spin (sched_yield) for
 * 2^28 TSC ticks, 0.1 s at 2.6 GHz, before they sleep: on 2 cores that is one core taken from
 * the first hemicubes, whose OpenMP threads then share it. Ending the pool lets them run; the
 * next BLAS call starts it again. Measured (Intel Xeon, 2 cores, `lrr preprocess cornell
 * --patches 216 --levels 2 --hemicube 64 --threads 2`, formfactor_seconds of 6 runs): with the
 * pool 0.136-0.184 (4 of 6 above 0.17), without 0.136-0.139. */
void cli_idle_openblas(void)
{
#if defined(__x86_64__)
    void (*shutdown)(void) = (void (*)(void))dlsym(RTLD_DEFAULT, "blas_thread_shutdown_");
    if (shutdown)
        shutdown();
#endif
}

void cli_fair_openblas(char *argv[], int say)
{
#if defined(__x86_64__)
    /* looked up, not linked: lrr reaches OpenBLAS only through liblrr */
    const char *(*corename)(void) = (const char *(*)(void))dlsym(RTLD_DEFAULT,
                                                                "openblas_get_corename");
    const char *core = corename ? corename() : NULL;
    if (getenv("OPENBLAS_CORETYPE") || !core || strcmp(core, "Prescott") != 0)
        return;
    const char *want = __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl")
                           ? "SkylakeX"
                       : __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma")
                           ? "Haswell"
                           : NULL;
    if (!want || setenv("OPENBLAS_CORETYPE", want, 1) != 0)
        return;
    if (say) {
        fprintf(stderr, "%s: OpenBLAS chose its Prescott (SSE3) kernels on a CPU with %s; "
                        "running again with OPENBLAS_CORETYPE=%s\n",
                argv[0], strcmp(want, "SkylakeX") == 0 ? "AVX-512" : "AVX2", want);
        fflush(stderr);
    }
    /* the binary's own path, not /proc/self/exe, so ps and top still show its name */
    char self[4096];
    ssize_t len = readlink("/proc/self/exe", self, sizeof self - 1);
    if (len > 0) {
        self[len] = '\0';
        execv(self, argv);
    }
    unsetenv("OPENBLAS_CORETYPE"); /* exec failed: go on with Prescott */
#else
    (void)argv, (void)say;
#endif
}
