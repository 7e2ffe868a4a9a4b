/* lrr animate: lights moving along paths, one picture per frame (direct light with shadows,
 * the solve, the picture), with the time of each step per frame. */
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"

static const char prog[] = "lrr animate";

static const char animate_help[] =
    "Usage: lrr animate FILE.lrr --lights SCRIPT -o DIR [OPTIONS]\n"
    "Moves lights along paths and writes one picture per frame, DIR/frame_0000.png (or\n"
    ".exr), ... Each frame: the direct light of the lights on every subpatch, shadowed\n"
    "(lrr_lighting_direct; lights that did not move are not traced again), the solve\n"
    "(lrr_solve adds the interreflections) and the picture. Prints per frame 'frame: I\n"
    "direct_ms D solve_ms S picture_ms P', then frames, the medians direct_ms, solve_ms,\n"
    "picture_ms, exposure and output.\n"
    "\n"
    "SCRIPT, one statement a line ('#' starts a comment):\n"
    "  light SPEC             a light, as for 'lrr solve --light' (numbered from 0 in\n"
    "                         order): 'point pos=X,Y,Z rgb=R,G,B', 'spot ...', 'area ...',\n"
    "                         'sun dir=X,Y,Z rgb=...'\n"
    "  path I X,Y,Z X,Y,Z ... light I's position over the animation: through these\n"
    "                         points at equal steps, linearly between them (at least 2)\n"
    "  frames N               number of frames (1..100000, default 60)\n"
    "  emitters on|off        the scene's own emitters (default on)\n"
    "\n"
    "Options:\n"
    "  --lights SCRIPT      the script above (required)\n"
    "  -o, --output DIR     where the frames go (created if missing)\n"
    "  --format F           png (default; tone mapped) or exr (linear radiosity)\n"
    "  --exposure X         PNG: multiplier before tone mapping (> 0; default: automatic\n"
    "                       for the first frame, then kept, so the pictures do not flicker)\n"
    "  --width W, --height H, --camera C, --eye X,Y,Z, --target X,Y,Z, --up X,Y,Z,\n"
    "  --fov DEGREES        the picture and its camera, as for 'lrr render'\n"
    "  -h, --help           show this help\n";

#define MAX_PATH_POINTS 64

typedef struct anim_script {
    lrr_light_source light[CLI_MAX_LIGHTS];
    size_t lights;
    float path[CLI_MAX_LIGHTS][MAX_PATH_POINTS][3];
    size_t points[CLI_MAX_LIGHTS]; /* 0: the light stays */
    size_t frames;
    int emitters;
} anim_script;

typedef struct animate_args {
    const char *file, *script, *output;
    view_args view;
    int exr;
    anim_script s;
} animate_args;

/* ------------------------------------------------------------------ the script */
static int script_error(const char *path, size_t line, const char *what)
{
    cli_usage_error(prog, "%s line %zu: %s", path, line, what);
    return -1;
}

/* "path I X,Y,Z X,Y,Z ...": the rest of the line after "path". */
static int parse_path(anim_script *s, char *rest, const char *path, size_t line)
{
    char *save = NULL, *tok = strtok_r(rest, " \t", &save), *end;
    unsigned long i = tok ? strtoul(tok, &end, 10) : 0;
    if (!tok || *end || i >= s->lights)
        return script_error(path, line, "path: the light's index is missing or not a light "
                                        "defined above");
    size_t m = 0;
    while ((tok = strtok_r(NULL, " \t", &save))) {
        float *p = s->path[i][m];
        if (m == MAX_PATH_POINTS || sscanf(tok, "%f,%f,%f", &p[0], &p[1], &p[2]) != 3 ||
            !isfinite(p[0]) || !isfinite(p[1]) || !isfinite(p[2]))
            return script_error(path, line, "path: points are X,Y,Z (finite, at most 64)");
        m++;
    }
    if (m < 2)
        return script_error(path, line, "path: at least two points");
    s->points[i] = m;
    return 0;
}

static int parse_statement(anim_script *s, char *text, const char *path, size_t line)
{
    char *save = NULL, *word = strtok_r(text, " \t", &save);
    char *rest = save ? save + strspn(save, " \t") : "";
    if (!word)
        return 0;
    if (strcmp(word, "light") == 0) {
        if (s->lights == CLI_MAX_LIGHTS)
            return script_error(path, line, "light: at most 16 lights");
        return cli_parse_light(prog, rest, &s->light[s->lights++]);
    }
    if (strcmp(word, "path") == 0)
        return parse_path(s, rest, path, line);
    if (strcmp(word, "frames") == 0) {
        char *end;
        unsigned long f = strtoul(rest, &end, 10);
        if (end == rest || *end || f < 1 || f > 100000)
            return script_error(path, line, "frames: a number in 1..100000");
        s->frames = f;
        return 0;
    }
    if (strcmp(word, "emitters") == 0 && (!strcmp(rest, "on") || !strcmp(rest, "off"))) {
        s->emitters = strcmp(rest, "on") == 0;
        return 0;
    }
    return script_error(path, line, "not one of: light SPEC, path I X,Y,Z ..., frames N, "
                                    "emitters on|off");
}

static int read_script(const char *path, anim_script *s)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        cli_usage_error(prog, "--lights: cannot open the script '%s'", path);
        return -1;
    }
    char buf[4096];
    size_t line = 0;
    int rc = 0;
    while (!rc && fgets(buf, sizeof buf, f)) {
        line++;
        buf[strcspn(buf, "#\r\n")] = '\0';
        rc = parse_statement(s, buf, path, line);
    }
    fclose(f);
    if (!rc && s->lights == 0)
        rc = script_error(path, line, "no light");
    return rc;
}

/* ------------------------------------------------------------------ options */
static int animate_option(animate_args *a, int c, const char *arg)
{
    switch (c) {
    case 'o':
        a->output = arg;
        return 1;
    case OPT_LIGHTS_SCRIPT:
        a->script = arg;
        return 1;
    case OPT_FORMAT:
        if (strcmp(arg, "png") != 0 && strcmp(arg, "exr") != 0) {
            cli_usage_error(prog, "--format: '%s' is not one of png, exr", arg);
            return -1;
        }
        a->exr = strcmp(arg, "exr") == 0;
        return 1;
    default:
        return view_option(&a->view, prog, c, arg);
    }
}

/* CLI_RUN with *a filled in, or the exit status. */
static int parse_animate(animate_args *a, int argc, char *argv[])
{
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'},
        {"lights", required_argument, NULL, OPT_LIGHTS_SCRIPT},
        {"format", required_argument, NULL, OPT_FORMAT},
        VIEW_LONGOPTS,
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    memset(a, 0, sizeof *a);
    view_args_init(&a->view);
    a->s.frames = 60;
    a->s.emitters = 1;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(animate_help, stdout);
            return CLI_EXIT_OK;
        }
        int r = animate_option(a, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r == 0)
            return bad_option(prog, c, argv);
    }
    a->file = one_positional(prog, "FILE.lrr", argc, argv);
    if (!a->file)
        return CLI_EXIT_USAGE;
    if (!a->output || !a->output[0] || !a->script) {
        cli_usage_error(prog, "%s is required", a->script ? "-o DIR" : "--lights SCRIPT");
        return CLI_EXIT_USAGE;
    }
    if (view_finish(&a->view, prog) != 0 || read_script(a->script, &a->s) != 0)
        return CLI_EXIT_USAGE;
    return CLI_RUN;
}

/* ------------------------------------------------------------------ running */
/* Light l's position at frame f of the script's frames. */
static void place(anim_script *s, size_t l, size_t f)
{
    const size_t m = s->points[l];
    if (m == 0)
        return;
    double t = s->frames > 1 ? (double)f / (double)(s->frames - 1) * (double)(m - 1) : 0;
    size_t seg = t >= (double)(m - 1) ? m - 2 : (size_t)t;
    double u = t - (double)seg;
    for (int j = 0; j < 3; j++)
        s->light[l].position[j] =
            (float)((1 - u) * s->path[l][seg][j] + u * s->path[l][seg + 1][j]);
}

typedef struct anim_state {
    lrr_context *ctx;
    lrr_operator *op;
    lrr_lighting *lt;
    lrr_solver *sv;
    float *base, *direct, *e, *b;
    size_t n;
    double *ms[3]; /* per frame: direct, solve, picture */
} anim_state;

static int anim_open(const animate_args *a, anim_state *st)
{
    int rc = load_operator(st->ctx, a->file, &st->op);
    if (rc != CLI_EXIT_OK)
        return rc;
    lrr_operator_info oi;
    lrr_operator_get_info(st->op, &oi, sizeof oi);
    st->n = oi.n;
    lrr_status s;
    if ((s = lrr_lighting_create(st->op, &st->lt)) != LRR_OK ||
        (s = lrr_solver_create(st->op, LRR_BACKEND_CPU, &st->sv)) != LRR_OK)
        return cli_lib_error(st->ctx, s);
    for (int k = 0; k < 3; k++)
        if (!(st->ms[k] = calloc(a->s.frames, sizeof(double))))
            return cli_fail(LRR_ERR_NOMEM, "cannot allocate the timings");
    if (!(st->base = cli_alloc_rgb(oi.n)) || !(st->direct = cli_alloc_rgb(oi.n)) ||
        !(st->e = cli_alloc_rgb(oi.n)) || !(st->b = cli_alloc_rgb(oi.n)))
        return CLI_EXIT_FAIL;
    if (a->s.emitters)
        memcpy(st->base, lrr_operator_emission(st->op), 3 * oi.n * sizeof(float));
    return CLI_EXIT_OK;
}

static void anim_close(anim_state *st)
{
    lrr_solver_destroy(st->sv);
    lrr_lighting_destroy(st->lt);
    lrr_operator_destroy(st->op);
    free(st->base);
    free(st->direct);
    free(st->e);
    free(st->b);
    for (int k = 0; k < 3; k++)
        free(st->ms[k]);
}

/* The exposure of every PNG frame: --exposure, else the automatic one of the first frame,
 * kept (lrr_render_auto_exposure). */
static void fix_exposure(anim_state *st, animate_args *a)
{
    if (!a->exr && !(a->view.ro.exposure > 0))
        a->view.ro.exposure = lrr_render_auto_exposure(st->op, st->b);
}

static int one_frame(anim_state *st, animate_args *a, size_t f)
{
    for (size_t l = 0; l < a->s.lights; l++)
        place(&a->s, l, f);
    double t0 = cli_now();
    lrr_status s = lrr_lighting_direct(st->lt, a->s.light, a->s.lights, st->direct);
    double t1 = cli_now();
    for (size_t i = 0; s == LRR_OK && i < 3 * st->n; i++)
        st->e[i] = st->base[i] + st->direct[i];
    if (s == LRR_OK)
        s = lrr_solve(st->sv, st->e, st->b);
    double t2 = cli_now();
    if (s == LRR_OK && f == 0)
        fix_exposure(st, a);
    int rc = s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(st->ctx, s);
    char path[4096];
    if (rc == CLI_EXIT_OK &&
        snprintf(path, sizeof path, "%s/frame_%04zu.%s", a->output, f, a->exr ? "exr" : "png") >=
            (int)sizeof path)
        rc = cli_fail(LRR_ERR_INVALID_ARG, "-o %s: the path is too long", a->output);
    if (rc == CLI_EXIT_OK) {
        s = a->exr ? lrr_render_exr(st->op, st->b, &a->view.ro, path)
                   : lrr_render_png(st->op, st->b, &a->view.ro, path);
        if (s != LRR_OK)
            rc = cli_lib_error(st->ctx, s);
    }
    double t3 = cli_now();
    st->ms[0][f] = 1e3 * (t1 - t0);
    st->ms[1][f] = 1e3 * (t2 - t1);
    st->ms[2][f] = 1e3 * (t3 - t2);
    if (rc == CLI_EXIT_OK)
        printf("frame: %zu direct_ms %.3f solve_ms %.3f picture_ms %.3f\n", f, st->ms[0][f],
               st->ms[1][f], st->ms[2][f]);
    return rc;
}

static int run_animate(animate_args *a)
{
    if (cli_make_dir(a->output) != 0)
        return CLI_EXIT_FAIL;
    anim_state st = {0};
    lrr_status s = lrr_context_create(&st.ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    int rc = anim_open(a, &st);
    for (size_t f = 0; rc == CLI_EXIT_OK && f < a->s.frames; f++)
        rc = one_frame(&st, a, f);
    if (rc == CLI_EXIT_OK) {
        static const char *const names[3] = {"direct_ms", "solve_ms", "picture_ms"};
        printf("frames: %zu\n", a->s.frames);
        for (int k = 0; k < 3; k++)
            printf("%s: %.3f\n", names[k], cli_median(st.ms[k], a->s.frames));
        if (!a->exr)
            printf("exposure: %.6g\n", a->view.ro.exposure);
        printf("output: %s\n", a->output);
    }
    anim_close(&st);
    lrr_context_destroy(st.ctx);
    return rc;
}

int cmd_animate(int argc, char *argv[])
{
    animate_args a;
    int rc = parse_animate(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_animate(&a);
}
