/* lrr demo: the Cornell box from scene to picture (statistics, preprocessing, a timed solve,
 * a table of the walls' mean radiosity and a PNG). */
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "commands.h"

static const char prog[] = "lrr demo";

static const char demo_help[] =
    "Usage: lrr demo [OPTIONS]\n"
    "The Cornell box from start to picture: scene statistics, preprocessing (216 patches,\n"
    "2 levels, hemicube 128) with a progress bar, a timed solve, a table of the mean\n"
    "radiosity of each wall, and a PNG.\n"
    "\n"
    "Options:\n"
    "  --out DIR            where to write cornell.lrr and cornell.png (default ./out)\n"
    OPERATOR_BUDGET_HELP
    "  -h, --help           show this help\n";

/* ------------------------------------------------------------------ parsing */
/* CLI_RUN with *dir and *budget, or the exit status (after --help or a usage message). */
static int parse_demo(int argc, char *argv[], const char **dir, size_t *budget)
{
    static const struct option longopts[] = {{"out", required_argument, NULL, OPT_OUT},
                                             {"memory-budget", required_argument, NULL,
                                              OPT_MEMORY_BUDGET},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    *dir = "./out";
    *budget = physical_memory_bytes();
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(demo_help, stdout);
            return CLI_EXIT_OK;
        case OPT_OUT:
            *dir = optarg;
            break;
        case OPT_MEMORY_BUDGET:
            if (parse_operator_budget(prog, optarg, budget) != 0)
                return CLI_EXIT_USAGE;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    if (optind < argc) {
        cli_usage_error(prog, "unexpected argument '%s'", argv[optind]);
        return CLI_EXIT_USAGE;
    }
    if (!(*dir)[0]) {
        cli_usage_error(prog, "--out: the directory name is empty");
        return CLI_EXIT_USAGE;
    }
    return CLI_RUN;
}

/* ------------------------------------------------------------------ output paths */
static char *join_path(const char *dir, const char *file)
{
    size_t a = strlen(dir), b = strlen(file);
    char *p = malloc(a + b + 2);
    if (p) {
        memcpy(p, dir, a);
        p[a] = '/';
        memcpy(p + a + 1, file, b + 1);
    }
    return p;
}

/* ------------------------------------------------------------------ the walls' table */
/* Groups of the demo's table: the Cornell box's walls seen from its camera (x = max is the
 * red wall on the left), the light, and everything else (the two blocks). */
enum { G_LIGHT, G_CEILING, G_FLOOR, G_BACK, G_LEFT, G_RIGHT, G_FRONT, G_OTHER, G_COUNT };
static const char *const group_names[G_COUNT] = {"light", "ceiling", "floor", "back wall",
                                                 "left wall", "right wall", "front wall",
                                                 "blocks"};

static int classify(const float *c, const float *nr, const float *em, const double lo[3],
                    const double hi[3])
{
    if (em[0] > 0 || em[1] > 0 || em[2] > 0)
        return G_LIGHT;
    for (int a = 0; a < 3; a++) {
        /* A wall faces the room's inside and lies within 3% of the bounding box's face. */
        double tol = 0.03 * (hi[a] - lo[a]);
        if (nr[a] > 0.99 && c[a] <= lo[a] + tol)
            return a == 0 ? G_RIGHT : a == 1 ? G_FLOOR : G_FRONT;
        if (nr[a] < -0.99 && c[a] >= hi[a] - tol)
            return a == 0 ? G_LEFT : a == 1 ? G_CEILING : G_BACK;
    }
    return G_OTHER;
}

static void print_wall_table(const lrr_operator *op, const float *b)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const float *centre = lrr_operator_centre(op), *normal = lrr_operator_normal(op);
    const float *area = lrr_operator_area(op), *em = lrr_operator_emission(op);
    if (!centre || !normal || !area || !em || oi.n == 0)
        return;
    double lo[3], hi[3];
    for (int a = 0; a < 3; a++)
        lo[a] = hi[a] = centre[a];
    for (size_t i = 0; i < oi.n; i++)
        for (int a = 0; a < 3; a++) {
            if (centre[3 * i + a] < lo[a])
                lo[a] = centre[3 * i + a];
            if (centre[3 * i + a] > hi[a])
                hi[a] = centre[3 * i + a];
        }
    double sum[G_COUNT][3] = {{0}}, garea[G_COUNT] = {0};
    size_t count[G_COUNT] = {0};
    for (size_t i = 0; i < oi.n; i++) {
        int g = classify(centre + 3 * i, normal + 3 * i, em + 3 * i, lo, hi);
        count[g]++;
        garea[g] += area[i];
        for (int ch = 0; ch < 3; ch++)
            sum[g][ch] += (double)area[i] * (double)b[3 * i + ch];
    }
    printf("\n%-12s %10s %12s %12s %12s\n", "surface", "subpatches", "mean B r", "mean B g",
           "mean B b");
    for (int g = 0; g < G_COUNT; g++) {
        if (count[g] == 0)
            continue;
        printf("%-12s %10zu", group_names[g], count[g]);
        for (int ch = 0; ch < 3; ch++)
            printf(" %12.5g", garea[g] > 0 ? sum[g][ch] / garea[g] : 0.0);
        printf("\n");
    }
}

/* ------------------------------------------------------------------ the four steps */
/* What the steps share; run_demo frees it. */
typedef struct demo_run {
    size_t budget;
    char *op_path, *png_path;
    lrr_context *ctx;
    lrr_scene *scene;
    lrr_operator *op;
    float *b;
    lrr_operator_info built; /* of the operator as built, before the save */
    double ms;               /* the full-path solve */
} demo_run;

static int demo_scene(demo_run *d)
{
    printf("== 1. scene\n");
    subdiv_args sa;
    subdiv_init(&sa);
    subdiv_finish(&sa, prog);
    int rc = open_subdivided_scene(d->ctx, "cornell", &sa, &d->scene);
    if (rc)
        return rc;
    print_scene_info("cornell", d->scene);
    fflush(stdout);
    return CLI_EXIT_OK;
}

static int demo_preprocess(demo_run *d)
{
    cli_progress bar;
    lrr_build_options bo = {.hemicube_resolution = DEFAULT_HEMICUBE,
                            .seed = DEFAULT_SEED,
                            .progress = cli_progress_cb,
                            .progress_user = &bar,
                            .memory_budget = d->budget};
    printf("\n== 2. preprocess (one hemicube per subpatch)\n");
    fflush(stdout);
    cli_progress_init(&bar, "hemicubes", 1);
    lrr_status s = lrr_operator_build(d->scene, &bo, &d->op);
    cli_progress_finish(&bar);
    if (s == LRR_OK)
        s = lrr_operator_save(d->op, d->op_path);
    if (s != LRR_OK) {
        int rc = cli_lib_error(d->ctx, s);
        if (s == LRR_ERR_BUDGET)
            budget_hint(prog, d->budget, 0);
        return rc;
    }
    print_operator_info(d->op);
    printf("output: %s\n", d->op_path);
    return CLI_EXIT_OK;
}

static int demo_solve(demo_run *d)
{
    /* Solve from the saved file, as `lrr solve` would: the demo checks the round trip too. */
    lrr_operator_get_info(d->op, &d->built, sizeof d->built);
    lrr_operator_destroy(d->op);
    d->op = NULL;
    printf("\n== 3. solve (CPU)\n");
    int rc = load_operator(d->ctx, d->op_path, &d->op);
    if (rc)
        return rc;
    d->b = cli_alloc_rgb(d->built.n);
    if (!d->b)
        return CLI_EXIT_FAIL;
    solver_report rep;
    double sparse_ms = 0;
    const float *e = lrr_operator_emission(d->op);
    rc = timed_solve(d->ctx, d->op, LRR_BACKEND_CPU, LRR_FBAR_AUTO, SOLVE_M_AUTO, e, d->b,
                     DEFAULT_REPEAT, LRR_PATH_SPARSE, &sparse_ms, NULL, NULL);
    if (rc == CLI_EXIT_OK)
        rc = timed_solve(d->ctx, d->op, LRR_BACKEND_CPU, LRR_FBAR_AUTO, SOLVE_M_AUTO, e, d->b,
                         DEFAULT_REPEAT, LRR_PATH_FULL, &d->ms, NULL, &rep);
    if (rc)
        return rc;
    printf("solve_ms: %.4f (one pass over %s F̄, %s kernel, median of %u)\n", d->ms,
           lrr_fbar_format_name(rep.info.fbar), rep.kernel, DEFAULT_REPEAT);
    printf("solve_ms_sparse: %.4f (only the light's patches emit: cached columns)\n",
           sparse_ms);
    print_solution_summary(d->op, d->b);
    print_wall_table(d->op, d->b);
    return CLI_EXIT_OK;
}

static int demo_render(demo_run *d)
{
    lrr_render_options ro = {.width = 512, .height = 512, .exposure = 0.0,
                             .use_cornell_camera = 1};
    printf("\n== 4. render\n");
    lrr_status s = lrr_render_png(d->op, d->b, &ro, d->png_path);
    if (s != LRR_OK)
        return cli_lib_error(d->ctx, s);
    const lrr_operator_info *bi = &d->built;
    printf("\nn = %zu, k = %zu, d = %zu, build %.2f s, solve %.3f ms, cond %.3g/%.3g/%.3g\n",
           bi->n, bi->k, bi->d, bi->build_seconds, d->ms, bi->condition[0], bi->condition[1],
           bi->condition[2]);
    printf("png: %s\n", d->png_path);
    return CLI_EXIT_OK;
}

static int run_demo(const char *dir, size_t budget)
{
    int rc = cli_make_dir(dir);
    if (rc)
        return rc;
    demo_run d = {.budget = budget,
                  .op_path = join_path(dir, "cornell.lrr"),
                  .png_path = join_path(dir, "cornell.png")};
    if (!d.op_path || !d.png_path) {
        rc = cli_fail(LRR_ERR_NOMEM, "cannot build the output paths");
    } else {
        lrr_status s = lrr_context_create(&d.ctx);
        if (s != LRR_OK)
            rc = cli_lib_error(NULL, s);
    }
    if (rc == CLI_EXIT_OK)
        rc = demo_scene(&d);
    if (rc == CLI_EXIT_OK)
        rc = demo_preprocess(&d);
    if (rc == CLI_EXIT_OK)
        rc = demo_solve(&d);
    if (rc == CLI_EXIT_OK)
        rc = demo_render(&d);
    free(d.b);
    lrr_operator_destroy(d.op);
    lrr_scene_destroy(d.scene);
    lrr_context_destroy(d.ctx);
    free(d.op_path);
    free(d.png_path);
    return rc;
}

int cmd_demo(int argc, char *argv[])
{
    const char *dir;
    size_t budget;
    int rc = parse_demo(argc, argv, &dir, &budget);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_demo(dir, budget);
}
