/*
 * lrr-bench scenes: the output of a run (scenes.c runs it): the CSV, the Markdown table and
 * targets (stdout and --md) and the plot of ms per frame against n·k. What each column
 * means is in the command's help (scenes.c); the judgement's figures come from judge.c.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench.h"
#include "plot.h"

/* targets (reported, never an exit failure): issue item 6's of time and memory, issue 27's
 * of accuracy, and issue 27's honesty of lrr_operator_verify (within a factor of 2) */
#define SC_TARGET_PREP_S 300.0
#define SC_TARGET_PEAK_MIB 4096.0
#define SC_TARGET_F16_MS 20.0
#define SC_TARGET_FLOOR 1.3
#define SC_TARGET_REL_L2 0.03
#define SC_TARGET_NOISE 0.01
#define SC_TARGET_RATIO_LO 0.97
#define SC_TARGET_RATIO_HI 1.03
#define SC_TARGET_VERIFY 2.0
/* ------------------------------------------------------------------ output */
static const char sc_csv_header[] =
    "scene,cpu,threads,T,n,k,R,clustering_s,formfactor_s,smw_s,preprocess_s,peak_mib,ms_f32,"
    "ms_f32_iqr,ms_f16,ms_f16_iqr,floor_ms_f16,ratio_f16_to_floor,bandwidth_gbs,nk,rel_l2,"
    "noise,ratio_up,ratio_side,ratio_down,rel_l2_subpatch,noise_subpatch,verify_rel_l2,"
    "verify_noise,verify_seconds,samples,floor_ms_f32,ratio_f32_to_floor,rel_l2_debiased,"
    "rel_l2_f16,regions,subpatches_judged,ratio_up_noise,ratio_side_noise,ratio_down_noise,"
    "verify_to_bench,rel_l2_verify_grid,verify_subpatches,verify_samples,peak_mib_build,"
    "subdivide_s,build_s,reference_s,reference_peak_mib,op_mib,runs_f32,runs_f16,kernel,"
    "emitters,d_min,d_max,back_face_share,split,receiver,failed\n";

static void csv_nums(FILE *f, const double *v, size_t count)
{
    for (size_t i = 0; i < count; i++)
        bench_csv_num(f, v[i], 0);
}

static void csv_row(FILE *f, const sc_args *a, const char *cpu, const sc_result *r)
{
    const sc_judgement *j = &r->judge;
    fprintf(f, "%s,%s,%d,%zu,%zu,%zu,%u,", r->label, cpu, r->threads, r->triangles, r->n, r->k,
            a->hemicube);
    const double v1[] = {r->clustering_s, r->formfactor_s, r->smw_s, r->preprocess_s,
                         r->peak_mib, r->f32.median, r->f32.q3 - r->f32.q1, r->f16.median,
                         r->f16.q3 - r->f16.q1, r->floor_f16, r->ratio_f16,
                         r->bandwidth / 1e9, (double)r->n * (double)r->k, j->rel_l2,
                         j->noise, j->ratio[SC_UP], j->ratio[SC_SIDE], j->ratio[SC_DOWN],
                         j->rel_l2_subpatch, j->noise_subpatch, r->verify_rel_l2,
                         r->verify_noise, r->verify_seconds};
    csv_nums(f, v1, sizeof v1 / sizeof v1[0]);
    fprintf(f, "%zu,", a->samples);
    const double v2[] = {r->floor_f32, r->ratio_f32, j->rel_l2_debiased, j->rel_l2_f16};
    csv_nums(f, v2, sizeof v2 / sizeof v2[0]);
    fprintf(f, "%zu,%zu,", j->regions, j->subpatches);
    const double v3[] = {j->ratio_noise[SC_UP], j->ratio_noise[SC_SIDE],
                         j->ratio_noise[SC_DOWN], r->verify_rel_l2 / j->rel_l2,
                         j->rel_l2_verify_grid};
    csv_nums(f, v3, sizeof v3 / sizeof v3[0]);
    fprintf(f, "%zu,%zu,", r->verify_subpatches, r->verify_samples);
    const double v4[] = {r->peak_mib_build, r->subdivide_s, r->build_s, r->reference_s,
                         r->reference_peak_mib, r->op_mib};
    csv_nums(f, v4, sizeof v4 / sizeof v4[0]);
    fprintf(f, "%zu,%zu,%s,%zu,%zu,%zu,", r->f32.runs, r->f16.runs, r->kernel, r->emitters,
            r->d_min, r->d_max);
    bench_csv_num(f, r->back_face_share, 0);
    fprintf(f, "%s,%s,%s\n", a->split == LRR_SPLIT_AREA ? "area" : "variance",
            r->receiver_sampling == LRR_RECEIVER_AREA     ? "area"
            : r->receiver_sampling == LRR_RECEIVER_CENTRE ? "centre"
                                                          : "-",
            r->failed[0] ? r->failed : "-");
}

int sc_write_csv(const sc_args *a, const char *cpu, const sc_result *rows, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, a->csv) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", a->csv,
                          strerror(errno));
    fputs(sc_csv_header, out.f);
    for (size_t i = 0; i < count; i++)
        csv_row(out.f, a, cpu, &rows[i]);
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", a->csv, strerror(errno));
    return 0;
}

/* "12.3 (±0.4)": a median with its interquartile range */
static const char *fmt_q(char *buf, size_t len, const sc_quart *q)
{
    char m[32], w[32];
    if (isnan(q->median))
        return snprintf(buf, len, "-"), buf;
    snprintf(buf, len, "%s (IQR %s)", bench_fmt_ms(m, sizeof m, q->median),
             bench_fmt_ms(w, sizeof w, q->q3 - q->q1));
    return buf;
}

static const char *fmt_g(char *buf, size_t len, const char *fmt, double v)
{
    if (isnan(v))
        snprintf(buf, len, "-");
    else
        snprintf(buf, len, fmt, v);
    return buf;
}

/* "1.23% (0.45%)": a figure with its noise, both fractions */
static const char *fmt_pct2(char *buf, size_t len, double v, double noise)
{
    char a[24], b[24];
    snprintf(buf, len, "%s (%s)", fmt_g(a, sizeof a, "%.2f%%", 100 * v),
             fmt_g(b, sizeof b, "%.2f%%", 100 * noise));
    return buf;
}

/* "0.99 / 1.01 / 0.97": up, side, down */
static const char *fmt_ratios(char *buf, size_t len, const double r[SC_FACINGS])
{
    char u[16], s[16], d[16];
    snprintf(buf, len, "%s / %s / %s", fmt_g(u, sizeof u, "%.3f", r[SC_UP]),
             fmt_g(s, sizeof s, "%.3f", r[SC_SIDE]), fmt_g(d, sizeof d, "%.3f", r[SC_DOWN]));
    return buf;
}

static void md_table(FILE *f, const sc_result *rows, size_t count)
{
    fputs("| scene | T | n | k | clustering s | form factors s | SMW s | preprocess s | "
          "peak MiB | ms f32 | ms f16 | f16 floor ms | f16 / floor | rel L2 regions (noise) | "
          "ratio up / side / down | rel L2 subpatches (noise) | verify rel L2 (noise) | "
          "verify s |\n",
          f);
    fputs("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|\n", f);
    for (size_t i = 0; i < count; i++) {
        const sc_result *r = &rows[i];
        const sc_judgement *j = &r->judge;
        char b[14][64], name[160];
        snprintf(name, sizeof name, "%s%s%s%s", r->label, r->failed[0] ? " (failed: " : "",
                 r->failed, r->failed[0] ? ")" : "");
        fprintf(f, "| %s | %zu | %zu | %zu | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | "
                   "%s | %s | %s | %s |\n",
                name, r->triangles, r->n, r->k, fmt_g(b[0], 64, "%.1f", r->clustering_s),
                fmt_g(b[1], 64, "%.1f", r->formfactor_s), fmt_g(b[2], 64, "%.1f", r->smw_s),
                fmt_g(b[3], 64, "%.1f", r->preprocess_s), fmt_g(b[4], 64, "%.0f", r->peak_mib),
                fmt_q(b[5], 64, &r->f32), fmt_q(b[6], 64, &r->f16),
                fmt_g(b[7], 64, "%.2f", r->floor_f16), fmt_g(b[8], 64, "%.2f", r->ratio_f16),
                fmt_pct2(b[9], 64, j->rel_l2, j->noise), fmt_ratios(b[10], 64, j->ratio),
                fmt_pct2(b[11], 64, j->rel_l2_subpatch, j->noise_subpatch),
                fmt_pct2(b[12], 64, r->verify_rel_l2, r->verify_noise),
                fmt_g(b[13], 64, "%.1f", r->verify_seconds));
    }
}

static const char *verdict(double v, double limit)
{
    return isnan(v) ? "n/a" : v <= limit ? "PASS" : "MISS";
}

static const char *verdict_in(double v, double lo, double hi)
{
    return isnan(v) ? "n/a" : v >= lo && v <= hi ? "PASS" : "MISS";
}

/* The accuracy targets of issue 27 and the honesty of lrr_operator_verify. */
static void md_accuracy(FILE *f, const sc_result *r)
{
    const sc_judgement *j = &r->judge;
    const double factor = r->verify_rel_l2 / j->rel_l2;
    fprintf(f, "; rel L2 %.2f%% <= %.0f%%: %s (noise taken off: %.2f%%); noise %.2f%% <= "
               "%.0f%%: %s; ratios up %.3f: %s, side %.3f: %s, down %.3f: %s (within "
               "%.2f-%.2f; reference noise %.2f%%, %.2f%%, %.2f%%); verify %.2f%% (noise "
               "%.2f%%) against %.2f%%: x%.2f, within a factor of %.0f: %s (the bench over "
               "verify's regions: %.2f%%)\n",
            100 * j->rel_l2, 100 * SC_TARGET_REL_L2, verdict(j->rel_l2, SC_TARGET_REL_L2),
            100 * j->rel_l2_debiased, 100 * j->noise, 100 * SC_TARGET_NOISE,
            verdict(j->noise, SC_TARGET_NOISE), j->ratio[SC_UP],
            verdict_in(j->ratio[SC_UP], SC_TARGET_RATIO_LO, SC_TARGET_RATIO_HI),
            j->ratio[SC_SIDE],
            verdict_in(j->ratio[SC_SIDE], SC_TARGET_RATIO_LO, SC_TARGET_RATIO_HI),
            j->ratio[SC_DOWN],
            verdict_in(j->ratio[SC_DOWN], SC_TARGET_RATIO_LO, SC_TARGET_RATIO_HI),
            SC_TARGET_RATIO_LO, SC_TARGET_RATIO_HI, 100 * j->ratio_noise[SC_UP],
            100 * j->ratio_noise[SC_SIDE], 100 * j->ratio_noise[SC_DOWN],
            100 * r->verify_rel_l2, 100 * r->verify_noise, 100 * j->rel_l2, factor,
            SC_TARGET_VERIFY,
            verdict_in(factor, 1 / SC_TARGET_VERIFY, SC_TARGET_VERIFY),
            100 * j->rel_l2_verify_grid);
}

static void md_targets(FILE *f, const sc_result *rows, size_t count)
{
    fprintf(f, "\nTargets (issue item 6: time and memory; issue 27: accuracy and verify's "
               "honesty; informational):\n\n");
    for (size_t i = 0; i < count; i++) {
        const sc_result *r = &rows[i];
        if (r->failed[0]) {
            fprintf(f, "- %s: failed in the %s (the message is on stderr)\n", r->label,
                    r->failed);
            continue;
        }
        fprintf(f,
                "- %s: preprocess %.1f s <= %.0f s: %s; peak %.0f MiB <= %.0f MiB: %s; f16 "
                "%.2f ms <= %.0f ms: %s; f16 / floor %.2f <= %.1f: %s",
                r->label, r->preprocess_s, SC_TARGET_PREP_S,
                verdict(r->preprocess_s, SC_TARGET_PREP_S), r->peak_mib, SC_TARGET_PEAK_MIB,
                verdict(r->peak_mib, SC_TARGET_PEAK_MIB), r->f16.median, SC_TARGET_F16_MS,
                verdict(r->f16.median, SC_TARGET_F16_MS), r->ratio_f16, SC_TARGET_FLOOR,
                verdict(r->ratio_f16, SC_TARGET_FLOOR));
        md_accuracy(f, r);
        if (r->ratio_f32 < 1 || r->ratio_f16 < 1) /* a frame cannot read F̄ faster */
            fprintf(f, "- warning: %s ran below its floor (f32 %.2f, f16 %.2f x the floor): "
                       "the bandwidth measured first (%.2f GB/s) was too low, e.g. the "
                       "machine was busier then\n",
                    r->label, r->ratio_f32, r->ratio_f16, r->bandwidth / 1e9);
    }
}

/* The Markdown report: what ran, where, with what; the table; the targets. */
static int write_md(const sc_args *a, const char *cmdline, const char *cpu, double bw,
                    const sc_result *rows, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, a->md) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", a->md, strerror(errno));
    FILE *f = out.f;
    char date[64];
    time_t t = time(NULL);
    strftime(date, sizeof date, "%Y-%m-%d %H:%M %Z", gmtime(&t));
    double l1 = NAN, l5 = NAN, l15 = NAN; /* a busy machine slows the frames: say how busy */
    FILE *la = fopen("/proc/loadavg", "r");
    if (!la || fscanf(la, "%lf %lf %lf", &l1, &l5, &l15) != 3)
        l1 = l5 = l15 = NAN;
    if (la)
        fclose(la);
    fprintf(f, "# lrr-bench scenes\n\nCommand: `%s`\n\n", cmdline);
    fprintf(f, "CPU: %s; threads %d; read bandwidth %.2f GB/s (measured in this run); "
               "lrr %s; %s; load average at the end %.2f %.2f %.2f.\n\n",
            cpu, count ? rows[0].threads : 0, bw / 1e9, lrr_version_string(), date, l1, l5,
            l15);
    fprintf(f, "Settings: K = %zu (cluster hierarchy, %s split), hemicube %u, %zu path-traced "
               "samples per subpatch, seed %llu; frames forced to one pass over F̄; ms = "
               "median (IQR) per RGB frame; floor = n·k·bytes / bandwidth; accuracy: the "
               "reflected light B − E of the subpatches that emit nothing, regions = "
               "material × cell of an 8³ grid, ratios = operator / reference per facing "
               "(area-weighted luminance; 'lrr-bench scenes --help' defines each column).\n\n",
            a->patches, a->split == LRR_SPLIT_AREA ? "area" : "variance", a->hemicube,
            a->samples, (unsigned long long)a->seed);
    md_table(f, rows, count);
    md_targets(f, rows, count);
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", a->md, strerror(errno));
    return 0;
}

/* ------------------------------------------------------------------ plot */
typedef struct sc_plot_data {
    double x[SC_MAX_SCENES], y32[SC_MAX_SCENES], y16[SC_MAX_SCENES];
    double xq[2 * SC_MAX_SCENES], yq[2 * SC_MAX_SCENES];
    double xf[SC_MAX_SCENES], yf32[SC_MAX_SCENES], yf16[SC_MAX_SCENES];
    const char *labels[SC_MAX_SCENES];
    size_t m;
} sc_plot_data;

/* The floors at each measured n·k, in increasing n·k so that their dashed line is the
 * floor's straight line (the plot has no line without markers). */
static void plot_floors(sc_plot_data *d, double bw)
{
    memcpy(d->xf, d->x, d->m * sizeof *d->xf);
    for (size_t i = 1; i < d->m; i++)
        for (size_t j = i; j > 0 && d->xf[j - 1] > d->xf[j]; j--) {
            double t = d->xf[j];
            d->xf[j] = d->xf[j - 1];
            d->xf[j - 1] = t;
        }
    for (size_t j = 0; j < d->m; j++) {
        d->yf32[j] = 1e3 * d->xf[j] * 4 / bw;
        d->yf16[j] = 1e3 * d->xf[j] * 2 / bw;
    }
}

/* Returns 0 when there are points to plot. */
static int plot_points(const sc_result *rows, size_t count, double bw, sc_plot_data *d)
{
    d->m = 0;
    for (size_t i = 0; i < count; i++) {
        const sc_result *r = &rows[i];
        double nk = (double)r->n * (double)r->k;
        if (!(nk > 0) || isnan(r->f16.median))
            continue;
        d->x[d->m] = d->xq[2 * d->m] = d->xq[2 * d->m + 1] = nk;
        d->y32[d->m] = r->f32.median;
        d->y16[d->m] = r->f16.median;
        d->yq[2 * d->m] = r->f16.q1;
        d->yq[2 * d->m + 1] = r->f16.q3;
        d->labels[d->m++] = r->label;
    }
    if (!d->m || !(bw > 0))
        return -1;
    plot_floors(d, bw);
    return 0;
}

static int write_sc_plot(const sc_args *a, const sc_result *rows, size_t count, double bw)
{
    static sc_plot_data d;
    if (plot_points(rows, count, bw, &d) != 0)
        return 1;
    const plot_series s[] = {
        /* the quartiles first, so that the medians are drawn over them */
        {"f16 quartiles (q1, q3)", d.xq, d.yq, NULL, 2 * d.m, {110, 110, 110}, PLOT_DIAMOND, 0},
        {"f32 median", d.x, d.y32, NULL, d.m, {31, 119, 180}, PLOT_CIRCLE, 0},
        {"f16 median", d.x, d.y16, d.labels, d.m, {214, 39, 40}, PLOT_SQUARE, 0},
        {"f32 floor: n*k*4 B / bandwidth", d.xf, d.yf32, NULL, d.m, {158, 202, 225},
         PLOT_TRIANGLE, 2},
        {"f16 floor: n*k*2 B / bandwidth", d.xf, d.yf16, NULL, d.m, {252, 146, 114},
         PLOT_TRIANGLE, 2}};
    char title[160];
    snprintf(title, sizeof title, "lrr-bench scenes: ms per frame against n*k (K %zu, %.1f GB/s)",
             a->patches, bw / 1e9);
    plot_spec spec = {title, "n*k (subpatches x patches)", "ms per RGB frame (one pass)", 0, 0,
                      s, sizeof s / sizeof s[0], 0};
    if (plot_write_png(&spec, a->plot) != 0)
        return bench_fail("cannot write '%s': %s", a->plot, strerror(errno));
    return 0;
}

int sc_outputs(const sc_args *a, const char *cmdline, const char *cpu, double bw,
                      const sc_result *rows, size_t count)
{
    int rc = CLI_EXIT_OK;
    printf("\n");
    md_table(stdout, rows, count);
    md_targets(stdout, rows, count);
    if (a->md && write_md(a, cmdline, cpu, bw, rows, count) != 0)
        rc = CLI_EXIT_FAIL;
    else if (a->md)
        printf("md: %s\n", a->md);
    if (a->plot) {
        int prc = write_sc_plot(a, rows, count, bw);
        if (prc == 0)
            printf("plot: %s\n", a->plot);
        else if (prc == 1)
            printf("plot: nothing to plot (no frame time or no bandwidth), '%s' not written\n",
                   a->plot);
        else
            rc = CLI_EXIT_FAIL;
    }
    return rc;
}
