/*
 * lrr-bench probes: the error of the three light-probe approximations (median cut,
 * irradiance optimisation started from median cut, SH9) against the ground-truth irradiance,
 * for a list of source counts on every probe given, with the time per method; a table per
 * probe, CSV and a log-log plot of the mean and max error against the number of sources.
 */
#include <dirent.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"
#include "plot.h"

#define PROBES_DEFAULT_NORMALS 1024u
#define PROBES_QUICK_NORMALS 256u
#define PROBES_MAX_LIST 64

static const char probes_help[] =
    "Usage: lrr-bench probes [OPTIONS] [PROBE...]\n"
    "Error of the light-probe approximations against the ground-truth irradiance\n"
    "(lrr_probe_irradiance) on M normals of lrr_sphere_points, for each number of sources:\n"
    "  median-cut  lrr_probe_median_cut with N lights\n"
    "  irradiance  lrr_probe_fit_irradiance with N lights (Levenberg-Marquardt, started\n"
    "              from median cut)\n"
    "  sh9         lrr_probe_sh9: one row per probe; its 9 coefficients count as N = 9\n"
    "              sources by convention\n"
    "Errors as in `lrr probe`: mean and max over normals and RGB of |approx - truth| / truth\n"
    "in percent, entries with truth <= 1e-6 × the largest skipped. seconds: building the\n"
    "approximation only (the fit includes its own ground truth on the M normals); the\n"
    "ground truth time is printed once per probe.\n"
    "Without PROBE arguments: the .hdr files in DATA/probes, DATA being $LRR_DATA_DIR, else\n"
    "the installed data directory, else ./data (the line 'probes:' says which).\n"
    "\n"
    "Options:\n"
    "  --sources LIST       comma-separated source counts (default 2,4,8,16,32,64,128,256)\n"
    "  --normals M          normals for the error and the fit (default 1024)\n"
    "  --max-iterations K   cap on the fit's accepted LM steps (default: the library's, 300)\n"
    "  --csv OUT.csv        write the results (rewritten after each probe): columns\n"
    "                       probe,method,sources,mean_error_pct,max_error_pct,iterations,\n"
    "                       seconds,normals,width,height,truth_seconds,converged,path\n"
    "  --plot OUT.png       mean (solid) and max (dashed, lighter) error % against sources,\n"
    "                       log-log, one colour per method, one panel per probe\n"
    "  --quick              sources 2,4,8 and 256 normals (for tests)\n"
    "  -h, --help           show this help\n"
    "\n"
    "After the tables, one line per probe: the smallest N of the list at which irradiance\n"
    "with N sources has a mean error <= median cut's with 2N.\n";

enum { M_MEDIAN_CUT = 0, M_IRRADIANCE = 1, M_SH9 = 2, N_METHODS = 3 };
static const char *const method_names[N_METHODS] = {"median-cut", "irradiance", "sh9"};
static const unsigned char method_rgb[N_METHODS][3] = {
    {31, 119, 180}, {214, 39, 40}, {44, 160, 44}};

typedef struct probe_row {
    int method;
    size_t sources, iterations;
    double mean_pct, max_pct, seconds;
    int converged; /* -1: not applicable */
} probe_row;

typedef struct probe_result {
    const char *path, *name;
    size_t width, height;
    double truth_seconds;
    probe_row *rows;
    size_t n_rows;
} probe_result;

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return x < y ? -1 : x > y;
}

static int cmp_str(const void *a, const void *b)
{
    return strcmp(*(char *const *)a, *(char *const *)b);
}

/* "2,4,8": sorted, duplicates removed; -1 after a usage message */
static int parse_sources(const char *prog, const char *text, size_t *list, size_t *count)
{
    char buf[1024];
    if (strlen(text) >= sizeof buf || !text[0]) {
        cli_usage_error(prog, "--sources: '%s' is not a list of counts", text);
        return -1;
    }
    strcpy(buf, text);
    size_t n = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok;
         tok = strtok_r(NULL, ",", &save)) {
        if (n == PROBES_MAX_LIST) {
            cli_usage_error(prog, "--sources: more than %d counts", PROBES_MAX_LIST);
            return -1;
        }
        if (cli_parse_size(prog, "--sources", tok, 1, (size_t)1 << 20, &list[n]) != 0)
            return -1;
        n++;
    }
    if (n == 0) {
        cli_usage_error(prog, "--sources: '%s' is not a list of counts", text);
        return -1;
    }
    qsort(list, n, sizeof *list, cmp_size);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (m == 0 || list[m - 1] != list[i])
            list[m++] = list[i];
    *count = m;
    return 0;
}

/* The .hdr files of DIR/probes, sorted; CLI_EXIT_OK or a reported failure. */
static int default_probes(char ***paths, size_t *count)
{
    const char *dir = getenv("LRR_DATA_DIR"), *from = "LRR_DATA_DIR";
    if (!dir || !dir[0]) {
#ifdef LRR_PKGDATADIR
        dir = LRR_PKGDATADIR;
        from = "the installed data directory";
        char test[4096];
        snprintf(test, sizeof test, "%s/probes", dir);
        DIR *d0 = opendir(test);
        if (d0)
            closedir(d0);
        else
#endif
        {
            dir = "./data";
            from = "the current directory";
        }
    }
    char probes_dir[4096];
    snprintf(probes_dir, sizeof probes_dir, "%s/probes", dir);
    printf("probes: %s (from %s)\n", probes_dir, from);
    DIR *d = opendir(probes_dir);
    if (!d)
        return bench_fail("cannot open '%s': %s (give PROBE arguments or set LRR_DATA_DIR)",
                          probes_dir, strerror(errno));
    char **list = NULL;
    size_t n = 0, cap = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t len = strlen(e->d_name);
        if (len < 5 || strcmp(e->d_name + len - 4, ".hdr") != 0)
            continue;
        if (n == cap) {
            cap = cap ? 2 * cap : 8;
            char **grown = realloc(list, cap * sizeof *list);
            if (!grown)
                break;
            list = grown;
        }
        size_t plen = strlen(probes_dir) + 1 + len + 1;
        if (!(list[n] = malloc(plen)))
            break;
        snprintf(list[n], plen, "%s/%s", probes_dir, e->d_name);
        n++;
    }
    closedir(d);
    if (n == 0) {
        free(list);
        return bench_fail("no .hdr probe in '%s'", probes_dir);
    }
    qsort(list, n, sizeof *list, cmp_str);
    *paths = list;
    *count = n;
    return CLI_EXIT_OK;
}

static size_t median_cut_passes(size_t n)
{
    size_t p = 0;
    if ((n & (n - 1)) != 0)
        return n - 1;
    while (((size_t)1 << p) < n)
        p++;
    return p;
}

static void csv_field(FILE *f, const char *s)
{
    if (!strpbrk(s, ",\"\n")) {
        fputs(s, f);
        return;
    }
    fputc('"', f);
    for (; *s; s++) {
        if (*s == '"')
            fputc('"', f);
        fputc(*s, f);
    }
    fputc('"', f);
}

static int write_probes_csv(const char *path, const probe_result *res, size_t count,
                            size_t normals)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs("probe,method,sources,mean_error_pct,max_error_pct,iterations,seconds,normals,width,"
          "height,truth_seconds,converged,path\n",
          out.f);
    for (size_t p = 0; p < count; p++)
        for (size_t i = 0; i < res[p].n_rows; i++) {
            const probe_row *r = &res[p].rows[i];
            csv_field(out.f, res[p].name);
            fprintf(out.f, ",%s,%zu,", method_names[r->method], r->sources);
            bench_csv_num(out.f, r->mean_pct, 0);
            bench_csv_num(out.f, r->max_pct, 0);
            fprintf(out.f, "%zu,", r->iterations);
            bench_csv_num(out.f, r->seconds, 0);
            fprintf(out.f, "%zu,%zu,%zu,", normals, res[p].width, res[p].height);
            bench_csv_num(out.f, res[p].truth_seconds, 0);
            if (r->converged >= 0)
                fprintf(out.f, "%d", r->converged);
            fputc(',', out.f);
            csv_field(out.f, res[p].path);
            fputc('\n', out.f);
        }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

/* One panel per probe, two columns. Returns 0 or -1 (reported). */
static int write_probes_plot(const char *path, const probe_result *res, size_t count,
                             size_t normals)
{
    enum { PW = 800, PH = 580 };
    unsigned cols = count > 1 ? 2 : 1, rows = (unsigned)((count + cols - 1) / cols);
    unsigned W = cols * PW, H = rows * PH;
    unsigned char *canvas = malloc((size_t)W * H * 3);
    if (!canvas)
        return bench_fail("cannot allocate the plot");
    memset(canvas, 255, (size_t)W * H * 3);
    int rc = 0;
    for (size_t p = 0; p < count && rc == 0; p++) {
        const probe_result *r = &res[p];
        double *x = calloc(2 * r->n_rows + 1, sizeof *x);
        double *y = calloc(2 * r->n_rows + 1, sizeof *y);
        if (!x || !y) {
            free(x);
            free(y);
            rc = bench_fail("cannot allocate the plot's points");
            break;
        }
        plot_series series[2 * N_METHODS];
        static char names[2 * N_METHODS][48];
        size_t ns = 0, used = 0;
        for (int m = 0; m < N_METHODS; m++)
            for (int k = 0; k < 2; k++) {
                size_t start = used;
                for (size_t i = 0; i < r->n_rows; i++) {
                    if (r->rows[i].method != m)
                        continue;
                    x[used] = (double)r->rows[i].sources;
                    y[used] = k ? r->rows[i].max_pct : r->rows[i].mean_pct;
                    used++;
                }
                if (used == start)
                    continue;
                plot_series *s = &series[ns];
                snprintf(names[ns], sizeof names[ns], "%s %s", method_names[m],
                         k ? "max" : "mean");
                s->name = names[ns];
                s->x = x + start;
                s->y = y + start;
                s->labels = NULL;
                s->count = used - start;
                for (int c = 0; c < 3; c++)
                    s->rgb[c] = (unsigned char)(k ? method_rgb[m][c] + (255 - method_rgb[m][c]) * 0.45
                                                  : method_rgb[m][c]);
                s->marker = k ? PLOT_SQUARE : PLOT_CIRCLE;
                s->line = k ? 2 : 1;
                ns++;
            }
        char title[256];
        snprintf(title, sizeof title, "%s: irradiance error vs sources (%zu normals)", r->name,
                 normals);
        plot_spec spec = {title, "sources (lights; sh9: 9 coefficients)",
                          "error vs ground truth [%]", PW, PH, series, ns, 0};
        unsigned char *px = NULL;
        unsigned w = 0, h = 0;
        if (plot_render(&spec, &px, &w, &h) != 0) {
            rc = bench_fail("cannot render the plot of %s: %s", r->name, strerror(errno));
        } else {
            unsigned ox = (unsigned)(p % cols) * PW, oy = (unsigned)(p / cols) * PH;
            for (unsigned row = 0; row < h && oy + row < H; row++)
                memcpy(canvas + ((size_t)(oy + row) * W + ox) * 3, px + (size_t)row * w * 3,
                       (size_t)(w < PW ? w : PW) * 3);
        }
        free(px);
        free(x);
        free(y);
    }
    if (rc == 0 && plot_write_rgb_png(canvas, W, H, path) != 0)
        rc = bench_fail("cannot write '%s': %s", path, strerror(errno));
    free(canvas);
    return rc ? -1 : 0;
}

/* Runs one probe into *res (rows allocated). CLI_EXIT_OK or a reported failure. */
static int run_probe(lrr_context *ctx, const char *path, const size_t *sources,
                     size_t n_sources, size_t normals, size_t max_iterations,
                     const float *dirs, probe_result *res)
{
    lrr_probe *probe = NULL;
    float *truth = cli_alloc_rgb(normals), *approx = cli_alloc_rgb(normals);
    lrr_light *lights = NULL;
    int rc = CLI_EXIT_FAIL;
    res->rows = calloc(2 * n_sources + 1, sizeof *res->rows);
    lights = calloc(sources[n_sources - 1], sizeof *lights);
    if (!truth || !approx || !res->rows || !lights) {
        rc = bench_fail("out of memory");
        goto done;
    }
    lrr_status st = lrr_probe_load(ctx, path, &probe);
    if (st != LRR_OK) {
        rc = bench_lib_fail(ctx, st, path);
        goto done;
    }
    lrr_probe_size(probe, &res->width, &res->height);
    double t0 = cli_now();
    st = lrr_probe_irradiance(probe, normals, dirs, truth);
    res->truth_seconds = cli_now() - t0;
    if (st != LRR_OK) {
        rc = bench_lib_fail(ctx, st, "lrr_probe_irradiance");
        goto done;
    }
    for (int m = M_MEDIAN_CUT; m <= M_IRRADIANCE; m++)
        for (size_t j = 0; j < n_sources; j++) {
            size_t n = sources[j];
            if (n > res->width * res->height) {
                bench_note("%s: %zu sources is more than the probe's %zu pixels, skipped",
                           res->name, n, res->width * res->height);
                continue;
            }
            probe_row *r = &res->rows[res->n_rows];
            r->method = m;
            r->sources = n;
            r->converged = -1;
            t0 = cli_now();
            if (m == M_MEDIAN_CUT) {
                st = lrr_probe_median_cut(probe, n, lights);
                r->iterations = median_cut_passes(n);
            } else {
                lrr_fit_options fo = {0};
                lrr_fit_stats fs = {0};
                fo.max_iterations = max_iterations;
                st = lrr_probe_fit_irradiance(probe, n, normals, &fo, lights, &fs, sizeof fs);
                r->iterations = fs.iterations;
                r->converged = fs.converged;
            }
            r->seconds = cli_now() - t0;
            if (st == LRR_OK)
                st = lrr_lights_irradiance(lights, n, normals, dirs, approx);
            if (st != LRR_OK) {
                rc = bench_lib_fail(ctx, st, method_names[m]);
                goto done;
            }
            cli_irradiance_error_pct(normals, truth, approx, &r->mean_pct, &r->max_pct);
            res->n_rows++;
            bench_note("%s: %s %zu sources: %.3g%% mean, %.3g s", res->name, method_names[m], n,
                       r->mean_pct, r->seconds);
        }
    {
        probe_row *r = &res->rows[res->n_rows];
        float coeffs[27];
        r->method = M_SH9;
        r->sources = 9;
        r->iterations = 1;
        r->converged = -1;
        t0 = cli_now();
        st = lrr_probe_sh9(probe, coeffs);
        r->seconds = cli_now() - t0;
        if (st == LRR_OK)
            st = lrr_sh9_irradiance(coeffs, normals, dirs, approx);
        if (st != LRR_OK) {
            rc = bench_lib_fail(ctx, st, "sh9");
            goto done;
        }
        cli_irradiance_error_pct(normals, truth, approx, &r->mean_pct, &r->max_pct);
        res->n_rows++;
    }
    rc = CLI_EXIT_OK;
done:
    lrr_probe_destroy(probe);
    free(truth);
    free(approx);
    free(lights);
    return rc;
}

static const probe_row *find_row(const probe_result *r, int method, size_t n)
{
    for (size_t i = 0; i < r->n_rows; i++)
        if (r->rows[i].method == method && r->rows[i].sources == n)
            return &r->rows[i];
    return NULL;
}

static void print_probe_table(const probe_result *r, size_t normals)
{
    printf("\n%s (%zu×%zu), %zu normals, ground truth %.3g s\n", r->name, r->width, r->height,
           normals, r->truth_seconds);
    printf("%-11s %8s %11s %11s %11s %11s\n", "method", "sources", "mean_err_%", "max_err_%",
           "iterations", "seconds");
    for (size_t i = 0; i < r->n_rows; i++) {
        const probe_row *w = &r->rows[i];
        printf("%-11s %8zu %11.4g %11.4g %11zu %11.4g\n", method_names[w->method], w->sources,
               w->mean_pct, w->max_pct, w->iterations, w->seconds);
    }
    fflush(stdout);
}

static void print_crossover(const probe_result *r, const size_t *sources, size_t n_sources)
{
    for (size_t j = 0; j < n_sources; j++) {
        const probe_row *a = find_row(r, M_IRRADIANCE, sources[j]);
        const probe_row *b = find_row(r, M_MEDIAN_CUT, 2 * sources[j]);
        if (a && b && a->mean_pct <= b->mean_pct) {
            printf("%s: irradiance at N reaches median cut's error at 2N from N = %zu "
                   "(irradiance %zu: %.4g%%, median cut %zu: %.4g%%)\n",
                   r->name, sources[j], sources[j], a->mean_pct, 2 * sources[j], b->mean_pct);
            return;
        }
    }
    printf("%s: irradiance at N reaches median cut's error at 2N: not within the list\n",
           r->name);
}

typedef struct probes_args {
    size_t sources[PROBES_MAX_LIST], n_sources;
    size_t normals, max_iterations;
    const char *csv, *plot;
} probes_args;

/* The options into *a (--quick: fewer sources and normals, where not given); the probes are
 * argv[optind..]. Returns BENCH_RUN, or the exit status (CLI_EXIT_OK after --help). */
static int probes_parse(int argc, char *argv[], probes_args *a)
{
    static const char prog[] = "lrr-bench probes";
    static const struct option longopts[] = {
        {"sources", required_argument, NULL, OPT_SOURCES},
        {"normals", required_argument, NULL, OPT_NORMALS},
        {"max-iterations", required_argument, NULL, OPT_MAX_ITERATIONS},
        {"csv", required_argument, NULL, OPT_CSV},
        {"plot", required_argument, NULL, OPT_PLOT},
        {"quick", no_argument, NULL, OPT_QUICK},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    int sources_given = 0, normals_given = 0, quick = 0;
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(probes_help, stdout);
            return CLI_EXIT_OK;
        case OPT_SOURCES:
            if (parse_sources(prog, optarg, a->sources, &a->n_sources) != 0)
                return CLI_EXIT_USAGE;
            sources_given = 1;
            break;
        case OPT_NORMALS:
            if (cli_parse_size(prog, "--normals", optarg, 1, (size_t)1 << 22, &a->normals) != 0)
                return CLI_EXIT_USAGE;
            normals_given = 1;
            break;
        case OPT_MAX_ITERATIONS:
            if (cli_parse_size(prog, "--max-iterations", optarg, 1, (size_t)1 << 24,
                               &a->max_iterations) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_CSV:
            a->csv = optarg;
            break;
        case OPT_PLOT:
            a->plot = optarg;
            break;
        case OPT_QUICK:
            quick = 1;
            break;
        default:
            return bench_bad_option(prog, c, argv);
        }
    }
    if ((a->csv && !a->csv[0]) || (a->plot && !a->plot[0])) {
        cli_usage_error(prog, "--csv/--plot: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (quick) {
        if (!sources_given) {
            a->sources[0] = 2, a->sources[1] = 4, a->sources[2] = 8;
            a->n_sources = 3;
        }
        if (!normals_given)
            a->normals = PROBES_QUICK_NORMALS;
    }
    return BENCH_RUN;
}

int cmd_probes(int argc, char *argv[])
{
    probes_args pa = {{2, 4, 8, 16, 32, 64, 128, 256}, 8, PROBES_DEFAULT_NORMALS, 0, NULL, NULL};
    int rc = probes_parse(argc, argv, &pa);
    if (rc != BENCH_RUN)
        return rc;
    const size_t *sources = pa.sources, n_sources = pa.n_sources;
    const size_t normals = pa.normals, max_iterations = pa.max_iterations;
    const char *csv = pa.csv, *plot = pa.plot;
    char **owned = NULL;
    const char *const *paths = (const char *const *)(argv + optind);
    size_t n_probes = (size_t)(argc - optind);
    if (n_probes == 0) {
        int drc = default_probes(&owned, &n_probes);
        if (drc != CLI_EXIT_OK)
            return drc;
        paths = (const char *const *)owned;
    }

    rc = CLI_EXIT_FAIL;
    lrr_context *ctx = NULL;
    probe_result *res = calloc(n_probes, sizeof *res);
    float *dirs = cli_alloc_rgb(normals);
    if (!res || !dirs) {
        bench_fail("out of memory");
        goto out;
    }
    lrr_status st = lrr_context_create(&ctx);
    if (st != LRR_OK) {
        cli_lib_error(NULL, st);
        goto out;
    }
    lrr_sphere_points(normals, dirs);
    printf("normals: %zu\nsources:", normals);
    for (size_t j = 0; j < n_sources; j++)
        printf("%s%zu", j ? "," : " ", sources[j]);
    printf("\nmax_iterations: %zu%s\n", max_iterations ? max_iterations : 300,
           max_iterations ? "" : " (library default)");
    printf("sh9: one row per probe, its 9 coefficients counted as 9 sources\n");
    size_t done = 0;
    for (size_t p = 0; p < n_probes; p++) {
        res[p].path = paths[p];
        const char *slash = strrchr(paths[p], '/');
        res[p].name = slash ? slash + 1 : paths[p];
        int prc = run_probe(ctx, paths[p], sources, n_sources, normals, max_iterations, dirs,
                            &res[p]);
        if (prc != CLI_EXIT_OK) {
            rc = prc;
            goto out;
        }
        done = p + 1;
        print_probe_table(&res[p], normals);
        if (csv && write_probes_csv(csv, res, done, normals) != 0)
            goto out;
    }
    printf("\n");
    for (size_t p = 0; p < done; p++)
        print_crossover(&res[p], sources, n_sources);
    if (csv)
        printf("csv: %s\n", csv);
    if (plot) {
        if (write_probes_plot(plot, res, done, normals) != 0)
            goto out;
        printf("plot: %s\n", plot);
    }
    rc = CLI_EXIT_OK;
out:
    if (res)
        for (size_t p = 0; p < n_probes; p++)
            free(res[p].rows);
    free(res);
    free(dirs);
    if (owned) {
        for (size_t p = 0; p < n_probes; p++)
            free(owned[p]);
        free(owned);
    }
    lrr_context_destroy(ctx);
    return rc;
}
