/*
 * lrr-bench: messages, option helpers, scenes, comparison of radiosities and number
 * formatting, which every command uses (bench.h). Only the public API (lrr.h).
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "bench.h"

/* ------------------------------------------------------------------ messages */
/* "lrr-bench: " + the message + a newline on stderr, flushed (bench_fail and bench_note) */
static void vmessage(const char *fmt, va_list ap)
{
    fputs("lrr-bench: ", stderr);
    vfprintf(stderr, fmt, ap);
    fputc('\n', stderr);
    fflush(stderr);
}

int bench_fail(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vmessage(fmt, ap);
    va_end(ap);
    return CLI_EXIT_FAIL;
}

/* "lrr-bench: <what>: <status>: <library message>" */
int bench_lib_fail(lrr_context *ctx, lrr_status s, const char *what)
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

void bench_note(const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vmessage(fmt, ap);
    va_end(ap);
}

int bench_bad_option(const char *prog, int c, char *const argv[])
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

void bench_start_getopt(void)
{
    opterr = 0;
    optind = 0; /* glibc: re-initialise the scanner */
}

int bench_no_positional(const char *prog, int argc, char *const argv[])
{
    if (optind < argc) {
        cli_usage_error(prog, "unexpected argument '%s'", argv[optind]);
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    return 0;
}

/* ------------------------------------------------------------------ scenes */
int bench_open_scene(lrr_context *ctx, const char *name, lrr_scene **scene)
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
        return bench_lib_fail(ctx, s, what);
    }
    return CLI_EXIT_OK;
}

/* levels with 4^levels = d, or -1 */
int bench_levels_of(size_t d)
{
    int l = 0;
    while (d > 1 && d % 4 == 0) {
        d /= 4;
        l++;
    }
    return d == 1 && l <= 10 ? l : -1;
}

/* Progress on stderr: a bar on a terminal, nothing otherwise (phase lines say enough). */
void bench_progress_begin(cli_progress *bar, const char *label, lrr_build_options *bo)
{
    cli_progress_init(bar, label, isatty(STDERR_FILENO));
    bo->progress = cli_progress_cb;
    bo->progress_user = bar;
}

/* ---------------------------------------------------------------- errors */
/* Area-weighted relative L2 over all channels and the largest relative error over entries
 * above 1e-3 of the largest reference value. With `skip_e` the emission is subtracted from
 * both (the reflected part only). */
void bench_compare_b(size_t n, const float *area, const float *b, const float *ref,
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
const char *bench_fmt_bytes(char *buf, size_t len, size_t bytes)
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
const char *bench_fmt_ms(char *buf, size_t len, double v)
{
    if (isnan(v))
        return snprintf(buf, len, "-"), buf;
    snprintf(buf, len, v < 10 ? "%.3f" : v < 100 ? "%.2f" : "%.1f", v);
    return buf;
}

void bench_csv_num(FILE *f, double v, int last)
{
    if (isnan(v))
        fputs("nan", f);
    else if (isinf(v))
        fputs(v > 0 ? "inf" : "-inf", f);
    else
        fprintf(f, "%.6g", v);
    fputc(last ? '\n' : ',', f);
}

double bench_max_rel(size_t m, const float *a, const float *b)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < m; i++) {
        num = fmax(num, fabs((double)a[i] - b[i]));
        den = fmax(den, fabs((double)b[i]));
    }
    return den > 0 ? num / den : num;
}
