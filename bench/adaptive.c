/*
 * lrr-bench adaptive: the adaptive patch hierarchy (issue 7) against uniform subdivision at
 * the same patch budget K and over the same subpatches, both measured against the full n×n
 * solution. The command, its options and output are here; the measurements of one scene are
 * in adaptive_scene.c.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "bench.h"
#include "plot.h"

#define DEFAULT_SUBPATCHES 4000u
#define DEFAULT_BUDGET_MIB 4096u
#define TARGET_RATIO 0.5     /* adaptive rel_l2 <= 0.5 × uniform at each budget */
#define TARGET_SELECTION 0.2 /* selection <= 20% of the build */

static const char adaptive_help[] =
    "Usage: lrr-bench adaptive [OPTIONS]\n"
    "The adaptive patch hierarchy against uniform subdivision at the same memory.\n"
    "For each scene: subdivide with {target_patches = N, levels = 0} (n subpatches, the\n"
    "leaves of each input triangle's 4-way quadtree), build the full n×n form factors from\n"
    "the same hemicubes (lrr_reference_build) and solve them by Gauss-Seidel (tol 1e-7) for\n"
    "the scene's emission: the reference. Then for each patch budget K build two operators\n"
    "over these n subpatches with lrr_build_options.adaptive_patches = K:\n"
    "  uniform   adaptive_split = LRR_SPLIT_AREA: the largest patch is split next, i.e.\n"
    "            uniform subdivision (the baseline)\n"
    "  adaptive  adaptive_split = LRR_SPLIT_VARIANCE: the patch whose subpatches' sampled\n"
    "            form-factor columns vary most is split next\n"
    "solve each for the scene's emission and compare with the reference. Both have k <= K\n"
    "patches, so F̄ (n×k) and M (3·k²) take the same memory. A split adds 3 patches, so\n"
    "k = triangles + 3·splits may be up to 2 below K.\n"
    "levels-L rows: the standard uniform operator (target_patches = 0, max_patch_area =\n"
    "4^L × the threshold of the levels-0 subdivision, levels = L, d = 4^L), L = 1..3,\n"
    "included only when its subpatches are exactly the same set (centres, normals, areas);\n"
    "otherwise left out (a 'levels' line says why).\n"
    "\n"
    "Columns (table and CSV):\n"
    "  scene, triangles  the scene and its input triangle count\n"
    "  n                 subpatches (the same for every operator of the scene)\n"
    "  budget            K = adaptive_patches (nan for the levels-L rows)\n"
    "  split             uniform, adaptive or levels-L (see above)\n"
    "  k                 patches of the operator actually built\n"
    "  d_min, d_max      fewest and most subpatches in one patch (lrr_operator_info)\n"
    "  rel_l2            area-weighted relative L2 of B against the reference over all\n"
    "                    channels, emission included (as in lrr-bench table and lrr compare;\n"
    "                    rel_l2_reflected in the CSV leaves E out of both)\n"
    "  max_rel           largest |ΔB|/|B_ref| over entries with |B_ref| > 1e-3·max|B_ref|\n"
    "  ratio             adaptive rel_l2 / uniform rel_l2 at the same budget (the target\n"
    "                    is <= 0.5); 1 on the uniform rows\n"
    "  prep_s            wall time of lrr_operator_build (hemicubes, selection, M_c)\n"
    "  sel_s, sel_%      lrr_operator_info.selection_seconds and its share of the build\n"
    "                    (build_seconds; the target is <= 20%)\n"
    "  rt_ms             one real-time RGB frame, lrr_solve forced to the full path\n"
    "                    (LRR_PATH_FULL): median of many runs after two warm-ups, and in\n"
    "                    brackets the fastest run (max in the CSV too); on a shared machine\n"
    "                    the median can catch other processes' load, the minimum hardly\n"
    "CSV only: build_s (lrr_operator_info.build_seconds), selection_share (sel_% / 100),\n"
    "runs, cond_max (largest condition estimate of the three M_c), mem_mb (F̄ + M in\n"
    "MB = 10^6 bytes: (n·k + 3·k²)·4), the options, reference_s (n×n build and solve)\n"
    "and reference_residual; rel_l2_plain: rel_l2 without the area weights (every\n"
    "subpatch counts alike).\n"
    "Operators keep their own subpatch order; B is matched to the reference's subpatches by\n"
    "centre, normal and area before the comparison.\n"
    "Targets (printed at the end, informational: never an exit failure): adaptive rel_l2\n"
    "<= 0.5 × uniform at each budget K < n (PASS/MISS per cell; at K = n both are exact),\n"
    "selection <= 20% of the build (each adaptive build).\n"
    "\n"
    "Options:\n"
    "  --scene SCENE        a scene file or a built-in name (cornell, cornell-closed);\n"
    "                       repeatable (default: cornell and office.obj from DATA, DATA\n"
    "                       being $LRR_DATA_DIR, else the installed data directory, else\n"
    "                       ./data)\n"
    "  --subpatches N       target subpatch count n (default 4000)\n"
    "  --budgets K1,K2,...  patch budgets (default per scene: those of n/32, n/16,\n"
    "                       n/8, n/4 that are at least twice the triangle count);\n"
    "                       budgets below the triangle count are skipped, those above n\n"
    "                       taken as n (one patch per subpatch: the exact model)\n"
    "  --samples S          adaptive_samples: receivers sampled for the variance\n"
    "                       (default 0 = the library's, 2048)\n"
    "  --hemicube R         hemicube resolution: even, 8..4096 (default 128)\n"
    "  --seed S             seed of the hemicube rotations (default 1)\n"
    "  --repeat N           timed runs per frame measurement (default: adaptive, at least\n"
    "                       20 runs and 0.5 s)\n"
    "  --memory-budget MB   most memory for the n×n reference, in MiB (default 4096); a\n"
    "                       scene over it gets nan errors\n"
    "  --csv OUT.csv        write the results (rewritten after each scene):\n"
    "                       scene,triangles,n,budget,split,k,d_min,d_max,rel_l2,max_rel,\n"
    "                       rel_l2_reflected,ratio,preprocess_s,build_s,selection_s,\n"
    "                       selection_share,rt_ms,rt_ms_min,rt_ms_max,runs,cond_max,\n"
    "                       mem_mb,hemicube,samples,seed,reference_s,reference_residual,\n"
    "                       rel_l2_plain\n"
    "  --plot OUT.png       rel_l2 against k, log-log: uniform (squares, dashed) and\n"
    "                       adaptive (circles, solid), one colour per scene\n"
    "  -h, --help           show this help\n";

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return x < y ? -1 : x > y;
}

/* "126,252,504": sorted, duplicates removed; -1 after a usage message */
static int parse_budgets(const char *prog, const char *text, size_t *list, size_t *count)
{
    char buf[1024];
    if (strlen(text) >= sizeof buf || !text[0]) {
        cli_usage_error(prog, "--budgets: '%s' is not a list of patch counts", text);
        return -1;
    }
    strcpy(buf, text);
    size_t n = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok;
         tok = strtok_r(NULL, ",", &save)) {
        if (n == MAX_BUDGETS) {
            cli_usage_error(prog, "--budgets: more than %d budgets", MAX_BUDGETS);
            return -1;
        }
        if (cli_parse_size(prog, "--budgets", tok, 1, (size_t)1 << 24, &list[n]) != 0)
            return -1;
        n++;
    }
    if (n == 0) {
        cli_usage_error(prog, "--budgets: '%s' is not a list of patch counts", text);
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

/* The office scene: DATA/office.obj with DATA as in `lrr-bench probes`. */
static void default_office(char *buf, size_t len)
{
    const char *dir = getenv("LRR_DATA_DIR");
    struct stat st;
    if (!dir || !dir[0]) {
        dir = "./data";
#ifdef LRR_PKGDATADIR
        snprintf(buf, len, "%s/office.obj", LRR_PKGDATADIR);
        if (stat(buf, &st) == 0)
            dir = LRR_PKGDATADIR;
#endif
    }
    snprintf(buf, len, "%s/office.obj", dir);
}

/* A short name for a scene argument: the file name without directory and extension. */
void scene_label(const char *scene, char *buf, size_t len)
{
    const char *base = strrchr(scene, '/');
    base = base ? base + 1 : scene;
    snprintf(buf, len, "%s", base);
    char *dot = strrchr(buf, '.');
    if (dot && dot != buf)
        *dot = '\0';
}

/* ------------------------------------------------------------------ output */
static const char adaptive_csv_header[] =
    "scene,triangles,n,budget,split,k,d_min,d_max,rel_l2,max_rel,rel_l2_reflected,ratio,"
    "preprocess_s,build_s,selection_s,selection_share,rt_ms,rt_ms_min,rt_ms_max,runs,"
    "cond_max,mem_mb,hemicube,samples,seed,reference_s,reference_residual,rel_l2_plain\n";

static int write_adaptive_csv(const char *path, const adaptive_args *a, const adaptive_row *rows,
                              size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs(adaptive_csv_header, out.f);
    for (size_t i = 0; i < count; i++) {
        const adaptive_row *r = &rows[i];
        fprintf(out.f, "%s,%zu,%zu,", r->scene, r->triangles, r->n);
        if (r->budget)
            fprintf(out.f, "%zu,", r->budget);
        else
            fputs("nan,", out.f);
        fprintf(out.f, "%s,%zu,%zu,%zu,", r->split, r->k, r->d_min, r->d_max);
        const double v[] = {r->rel_l2,     r->max_rel,         r->rel_l2_reflected,
                            r->ratio,      r->preprocess_s,    r->build_s,
                            r->selection_s, r->selection_share, r->rt.median,
                            r->rt.min,     r->rt.max};
        for (size_t j = 0; j < sizeof v / sizeof v[0]; j++)
            bench_csv_num(out.f, v[j], 0);
        fprintf(out.f, "%zu,", r->rt.runs);
        bench_csv_num(out.f, r->cond_max, 0);
        bench_csv_num(out.f, r->mem_mb, 0);
        fprintf(out.f, "%u,%zu,%llu,", a->hemicube, a->samples, (unsigned long long)a->seed);
        bench_csv_num(out.f, r->reference_s, 0);
        bench_csv_num(out.f, r->reference_residual, 0);
        bench_csv_num(out.f, r->rel_l2_plain, 1);
    }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

/* Returns 0, 1 when nothing can be plotted, -1 on failure. */
static int write_adaptive_plot(const char *path, const adaptive_args *a,
                               const adaptive_row *rows, size_t count)
{
    static const unsigned char colours[][3] = {{31, 119, 180}, {214, 39, 40}, {44, 160, 44},
                                               {148, 103, 189}, {255, 127, 14}, {140, 86, 75}};
    const size_t nc = sizeof colours / sizeof colours[0];
    char names[MAX_SCENES][2][96];
    plot_series series[2 * MAX_SCENES];
    double *x = calloc(count + 1, sizeof *x), *y = calloc(count + 1, sizeof *y);
    int rc = -1;
    if (!x || !y) {
        bench_fail("cannot allocate the plot's points");
        goto out;
    }
    size_t m = 0, ns = 0;
    for (size_t sc = 0; sc < a->n_scenes; sc++) {
        char label[64];
        scene_label(a->scenes[sc], label, sizeof label);
        for (int kind = 0; kind < 2; kind++) {
            const char *want = kind ? "adaptive" : "uniform";
            size_t first = m;
            for (size_t i = 0; i < count; i++)
                if (strcmp(rows[i].scene, label) == 0 && strcmp(rows[i].split, want) == 0 &&
                    isfinite(rows[i].rel_l2) && rows[i].rel_l2 > 0) {
                    x[m] = (double)rows[i].k;
                    y[m] = rows[i].rel_l2;
                    m++;
                }
            if (m == first)
                continue;
            snprintf(names[sc][kind], sizeof names[sc][kind], "%s %s", label,
                     kind ? "adaptive (variance)" : "uniform (area)");
            series[ns++] = (plot_series){names[sc][kind],
                                         x + first,
                                         y + first,
                                         NULL,
                                         m - first,
                                         {colours[sc % nc][0], colours[sc % nc][1],
                                          colours[sc % nc][2]},
                                         kind ? PLOT_CIRCLE : PLOT_SQUARE,
                                         kind ? 1 : 2};
        }
    }
    if (ns == 0) {
        rc = 1;
        goto out;
    }
    char title[256];
    snprintf(title, sizeof title,
             "adaptive vs uniform patches: error against k (n about %zu, hemicube %u)",
             a->subpatches, a->hemicube);
    plot_spec spec = {title, "patches k (memory: n*k + 3*k^2 floats)",
                      "relative L2 error vs n×n Gauss-Seidel", 0, 0, series, ns, 0};
    if (plot_write_png(&spec, path) != 0)
        bench_fail("cannot write '%s': %s", path, strerror(errno));
    else
        rc = 0;
out:
    free(x);
    free(y);
    return rc;
}

/* ------------------------------------------------------------------ command */
/* The options into *a. Returns BENCH_RUN, or the exit status (CLI_EXIT_OK after --help). */
static int adaptive_parse(int argc, char *argv[], adaptive_args *a)
{
    static const char prog[] = "lrr-bench adaptive";
    static const struct option longopts[] = {
        {"scene", required_argument, NULL, OPT_SCENE},
        {"subpatches", required_argument, NULL, OPT_SUBPATCHES},
        {"budgets", required_argument, NULL, OPT_BUDGETS},
        {"samples", required_argument, NULL, OPT_SAMPLES},
        {"hemicube", required_argument, NULL, OPT_HEMICUBE},
        {"seed", required_argument, NULL, OPT_SEED},
        {"repeat", required_argument, NULL, OPT_REPEAT},
        {"memory-budget", required_argument, NULL, OPT_MEMORY_BUDGET},
        {"csv", required_argument, NULL, OPT_CSV},
        {"plot", required_argument, NULL, OPT_PLOT},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    size_t mib = DEFAULT_BUDGET_MIB;
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(adaptive_help, stdout);
            return CLI_EXIT_OK;
        case OPT_SCENE:
            if (a->n_scenes == MAX_SCENES) {
                cli_usage_error(prog, "--scene: more than %d scenes", MAX_SCENES);
                return CLI_EXIT_USAGE;
            }
            if (!optarg[0]) {
                cli_usage_error(prog, "--scene: the name is empty");
                return CLI_EXIT_USAGE;
            }
            a->scenes[a->n_scenes++] = optarg;
            break;
        case OPT_SUBPATCHES:
            if (cli_parse_size(prog, "--subpatches", optarg, 1, (size_t)1 << 24,
                               &a->subpatches) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_BUDGETS:
            if (parse_budgets(prog, optarg, a->budgets, &a->n_budgets) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_SAMPLES:
            if (cli_parse_size(prog, "--samples", optarg, 1, (size_t)1 << 24, &a->samples) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &a->hemicube) != 0)
                return CLI_EXIT_USAGE;
            if (a->hemicube % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", a->hemicube);
                return CLI_EXIT_USAGE;
            }
            break;
        case OPT_SEED:
            if (cli_parse_u64(prog, "--seed", optarg, 0, UINT64_MAX, &a->seed) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_REPEAT:
            if (cli_parse_unsigned(prog, "--repeat", optarg, 1, 1000000, &a->repeat) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_MEMORY_BUDGET:
            if (cli_parse_size(prog, "--memory-budget", optarg, 1, SIZE_MAX >> 20, &mib) != 0)
                return CLI_EXIT_USAGE;
            a->memory_budget = mib << 20;
            break;
        case OPT_CSV:
            a->csv = optarg;
            break;
        case OPT_PLOT:
            a->plot = optarg;
            break;
        default:
            return bench_bad_option(prog, c, argv);
        }
    }
    if (bench_no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if ((a->csv && !a->csv[0]) || (a->plot && !a->plot[0])) {
        cli_usage_error(prog, "--csv/--plot: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    return BENCH_RUN;
}

/* The run's configuration. */
static void adaptive_print_setup(const adaptive_args *a)
{
    printf("benchmark: adaptive\n");
    bench_print_machine();
    printf("scenes:");
    for (size_t i = 0; i < a->n_scenes; i++)
        printf(" %s", a->scenes[i]);
    printf("\nsubpatches_target: %zu (levels 0)\n", a->subpatches);
    if (a->n_budgets) {
        printf("budgets:");
        for (size_t i = 0; i < a->n_budgets; i++)
            printf("%s%zu", i ? "," : " ", a->budgets[i]);
        printf("\n");
    } else
        printf("budgets: default (per scene: those of n/32, n/16, n/8, n/4 that "
               "are >= 2 x triangles)\n");
    printf("adaptive_samples: %zu%s\n", a->samples, a->samples ? "" : " (the library's default)");
    printf("hemicube: %u\n", a->hemicube);
    printf("seed: %llu\n", (unsigned long long)a->seed);
    printf("memory_budget_mib: %zu\n", a->memory_budget >> 20);
    printf("reference: lrr_reference_build + Gauss-Seidel, tol %g, same hemicubes and seed\n",
           REFERENCE_TOL);
    printf("error: rel_l2 = area-weighted relative L2 over all channels (emission included, "
           "as in lrr-bench table); ratio = adaptive / uniform rel_l2 at the same budget\n");
    printf("rt_ms: lrr_solve, full path, ms per RGB frame: median (min)\n");
    fflush(stdout);
}

/* targets (informational: never an exit failure) */
static void print_targets(const adaptive_row *rows, size_t count)
{
    printf("\ntarget: adaptive rel_l2 <= %.1f x uniform at each budget (informational)\n",
           TARGET_RATIO);
    size_t pass = 0, cells = 0;
    for (size_t i = 0; i < count; i++) {
        const adaptive_row *r = &rows[i];
        if (strcmp(r->split, "adaptive") != 0)
            continue;
        if (r->budget >= r->n) {
            printf("  %-10s K %5zu = n: one patch per subpatch, both exact (rel_l2 %.3g and "
                   "%.3g): not counted\n",
                   r->scene, r->budget, r->rel_l2, rows[i - 1].rel_l2);
            continue;
        }
        cells++;
        int ok = r->ratio <= TARGET_RATIO;
        pass += ok;
        char verdict[16];
        snprintf(verdict, sizeof verdict, "%s", isnan(r->ratio) ? "n/a" : ok ? "PASS" : "MISS");
        printf("  %-10s K %5zu (k %zu vs %zu): adaptive %.3g / uniform %.3g = %.3f: %s\n",
               r->scene, r->budget, r->k, rows[i - 1].k, r->rel_l2, rows[i - 1].rel_l2,
               r->ratio, verdict);
    }
    printf("target_ratio: %zu of %zu cells PASS\n", pass, cells);
    printf("target: selection <= %.0f%% of the build (adaptive rows)\n", 100 * TARGET_SELECTION);
    size_t spass = 0, sbuilds = 0;
    for (size_t i = 0; i < count; i++) {
        const adaptive_row *r = &rows[i];
        if (strcmp(r->split, "adaptive") != 0)
            continue;
        int ok = r->selection_share <= TARGET_SELECTION;
        spass += ok;
        sbuilds++;
        printf("  %-10s K %5zu: selection %.3f s of %.2f s = %.1f%%: %s\n", r->scene, r->budget,
               r->selection_s, r->build_s, 100 * r->selection_share,
               isnan(r->selection_share) ? "n/a" : ok ? "PASS" : "MISS");
    }
    printf("target_selection: %zu of %zu builds PASS\n", spass, sbuilds);
}

/* Every scene in turn (the CSV rewritten after each), then the targets and the plot. */
static int adaptive_run(const adaptive_args *a)
{
    lrr_context *ctx = NULL;
    lrr_status st = lrr_context_create(&ctx);
    if (st != LRR_OK)
        return bench_lib_fail(NULL, st, "context");
    /* every scene must be readable before the long measurements */
    for (size_t i = 0; i < a->n_scenes; i++) {
        lrr_scene *probe = NULL;
        int rc = bench_open_scene(ctx, a->scenes[i], &probe);
        lrr_scene_destroy(probe);
        if (rc) {
            lrr_context_destroy(ctx);
            return rc;
        }
    }
    /* rows: per scene, 2 per budget (scene_budgets gives at most MAX_BUDGETS) plus up to
     * MAX_LEVELS; sized for the most, since a count of 3 default budgets once overflowed
     * when a scene had 4 (AddressSanitizer, lrr-bench adaptive --scene cornell) */
    size_t cap = a->n_scenes * (2 * MAX_BUDGETS + MAX_LEVELS);
    adaptive_row *rows = calloc(cap, sizeof *rows);
    if (!rows) {
        lrr_context_destroy(ctx);
        return bench_fail("out of memory");
    }
    double t_start = cli_now();
    adaptive_print_setup(a);

    int rc = CLI_EXIT_OK;
    size_t count = 0;
    for (size_t i = 0; i < a->n_scenes && rc == CLI_EXIT_OK; i++) {
        adaptive_scene sc;
        if ((rc = adaptive_scene_open(ctx, a, a->scenes[i], &sc))) {
            adaptive_scene_free(&sc);
            break;
        }
        rc = adaptive_scene_rows(ctx, a, &sc, rows, &count);
        adaptive_scene_free(&sc);
        if (a->csv && count && write_adaptive_csv(a->csv, a, rows, count) != 0)
            rc = CLI_EXIT_FAIL;
    }

    print_targets(rows, count);
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
    if (a->csv && count)
        printf("csv: %s\n", a->csv);
    if (a->plot && count) {
        int prc = write_adaptive_plot(a->plot, a, rows, count);
        if (prc == 0)
            printf("plot: %s\n", a->plot);
        else if (prc == 1)
            printf("plot: nothing to plot (no finite error), '%s' not written\n", a->plot);
        else
            rc = CLI_EXIT_FAIL;
    }
    free(rows);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_adaptive(int argc, char *argv[])
{
    adaptive_args a = {.subpatches = DEFAULT_SUBPATCHES,
                       .hemicube = DEFAULT_HEMICUBE,
                       .seed = DEFAULT_SEED,
                       .memory_budget = (size_t)DEFAULT_BUDGET_MIB << 20};
    int rc = adaptive_parse(argc, argv, &a);
    if (rc != BENCH_RUN)
        return rc;
    char office[4096];
    if (a.n_scenes == 0) {
        default_office(office, sizeof office);
        a.scenes[a.n_scenes++] = "cornell";
        a.scenes[a.n_scenes++] = office;
    }
    return adaptive_run(&a);
}
