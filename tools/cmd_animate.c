/* lrr animate: lights moving along paths, one picture per frame (direct light with shadows,
 * the solve, the picture), with the time of each step per frame. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cli_script.h"
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
    "SCRIPT: the script below; each frame it draws is a picture. Statements that only\n"
    "lrr view has (screenshot, mouse, click, drag, scroll, key) are refused.\n"
    "\n"
    "Options:\n"
    "  --lights SCRIPT      the script (below; required)\n"
    "  -o, --output DIR     where the frames go (created if missing)\n"
    "  --format F           png (default; tone mapped) or exr (linear radiosity)\n"
    "  --shadow-tolerance T the shadow rays' error budget (lrr_lighting_set_tolerance; 0,\n"
    "                       the default: every ray): point and spot lights trace only the\n"
    "                       receivers that carry most of their light, the area-weighted\n"
    "                       L2 error of each light's direct light within T (0..0.5)\n"
    "  --exposure X         PNG: multiplier before tone mapping (> 0; default: automatic\n"
    "                       for the first frame, then kept, so the pictures do not flicker;\n"
    "                       the script's exposure statements change it)\n"
    "  --width W, --height H, --camera C, --eye X,Y,Z, --target X,Y,Z, --up X,Y,Z,\n"
    "  --fov DEGREES        the picture and its camera, as for 'lrr render'\n"
    "  -h, --help           show this help\n"
    "\n" CLI_SCRIPT_HELP;

typedef struct animate_args {
    const char *file, *script, *output;
    view_args view;
    int exr;
    double shadow_tol;
    cli_script s;
} animate_args;

/* ------------------------------------------------------------------ options */
static const cli_choice formats[] = {{"png", 0}, {"exr", 1}, {NULL, 0}};

/* The options of animate alone; the picture's are view_opts. */
static const cli_opt animate_opts[] = {
    {.name = "lights", .kind = CLI_OPT_STRING, .field = CLI_FIELD(animate_args, script),
     .required = "--lights SCRIPT"},
    {.name = "output", .letter = 'o', .kind = CLI_OPT_STRING,
     .field = CLI_FIELD(animate_args, output), .required = "-o DIR"},
    {.name = "format", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(animate_args, exr),
     .choices = formats},
    {.name = "shadow-tolerance", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(animate_args, shadow_tol),
     .min = 0, .max = 0.5},
    {.name = NULL}};

/* CLI_RUN with *a filled in, or the exit status. */
static int parse_animate(animate_args *a, int argc, char *argv[])
{
    memset(a, 0, sizeof *a);
    view_args_init(&a->view);
    const cli_opt_group groups[] = {{animate_opts, a}, {view_opts, &a->view}, {NULL, NULL}};
    const cli_command cmd = {prog, animate_help, "FILE.lrr", groups};
    int rc = cli_parse_command(&cmd, argc, argv, &a->file);
    if (rc != CLI_RUN)
        return rc;
    if (view_finish(&a->view, prog) != 0)
        return CLI_EXIT_USAGE;
    const cli_script_caps caps = {0};
    rc = cli_script_load(prog, a->script, &caps, &a->s);
    if (rc == CLI_EXIT_OK && a->s.frames == 0) {
        cli_usage_error(prog, "'%s': draws no frame (add frames N)", a->script);
        cli_script_free(&a->s);
        rc = CLI_EXIT_USAGE;
    }
    return rc == CLI_EXIT_OK ? CLI_RUN : rc;
}

/* ------------------------------------------------------------------ running */
typedef struct anim_state {
    lrr_context *ctx;
    lrr_operator *op;
    lrr_lighting *lt;
    lrr_solver *sv;
    float *direct, *e, *b;
    size_t n;
    double *ms[3]; /* per frame: direct, solve, picture */
    /* what the script has set */
    cli_lights L;
    int emitters, exposure_pending;
    size_t frame;
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
        (s = lrr_lighting_set_tolerance(st->lt, a->shadow_tol)) != LRR_OK ||
        (s = lrr_solver_create(st->op, LRR_BACKEND_CPU, &st->sv)) != LRR_OK)
        return cli_lib_error(st->ctx, s);
    for (int k = 0; k < 3; k++)
        if (!(st->ms[k] = calloc(a->s.frames, sizeof(double))))
            return cli_fail(LRR_ERR_NOMEM, "cannot allocate the timings");
    if (!(st->direct = cli_alloc_rgb(oi.n)) || !(st->e = cli_alloc_rgb(oi.n)) ||
        !(st->b = cli_alloc_rgb(oi.n)))
        return CLI_EXIT_FAIL;
    st->emitters = 1;
    st->exposure_pending = !a->exr && !(a->view.ro.exposure > 0);
    return CLI_EXIT_OK;
}

static void anim_close(anim_state *st)
{
    lrr_solver_destroy(st->sv);
    lrr_lighting_destroy(st->lt);
    lrr_operator_destroy(st->op);
    free(st->direct);
    free(st->e);
    free(st->b);
    for (int k = 0; k < 3; k++)
        free(st->ms[k]);
}

/* One statement that draws no frame; CLI_EXIT_*. */
static int apply(anim_state *st, animate_args *a, const cli_script_cmd *c)
{
    if (cli_lights_apply(&st->L, c) >= 0) /* indices were checked when it was read */
        switch (c->kind) {
        case CS_EMITTERS: st->emitters = c->on; break;
        case CS_EXPOSURE:
            a->view.ro.exposure = c->value;
            st->exposure_pending = !a->exr && c->value == 0;
            break;
        case CS_CAMERA:
            memcpy(a->view.ro.eye, c->eye, sizeof c->eye);
            memcpy(a->view.ro.target, c->target, sizeof c->target);
            a->view.ro.use_eye = 1;
            break;
        }
    return CLI_EXIT_OK;
}

static int one_frame(anim_state *st, animate_args *a)
{
    const size_t f = st->frame++;
    double t0 = cli_now();
    lrr_status s = lrr_lighting_direct(st->lt, st->L.light, st->L.count, st->direct);
    double t1 = cli_now();
    const float *em = lrr_operator_emission(st->op);
    for (size_t i = 0; s == LRR_OK && i < 3 * st->n; i++)
        st->e[i] = (st->emitters && em ? em[i] : 0.0f) + st->direct[i];
    if (s == LRR_OK)
        s = lrr_solve(st->sv, st->e, st->b);
    double t2 = cli_now();
    if (s == LRR_OK && st->exposure_pending) { /* automatic: keyed on this frame, then kept */
        a->view.ro.exposure = lrr_render_auto_exposure(st->op, st->b);
        st->exposure_pending = 0;
    }
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
    cli_player p = {.s = &a->s};
    const cli_script_cmd *c;
    int step;
    while (rc == CLI_EXIT_OK && (step = cli_player_next(&p, &st.L, &c)) != CLI_PLAY_END)
        rc = step == CLI_PLAY_FRAME ? one_frame(&st, a) : apply(&st, a, c);
    if (rc == CLI_EXIT_OK) {
        static const char *const names[3] = {"direct_ms", "solve_ms", "picture_ms"};
        printf("frames: %zu\n", st.frame);
        for (int k = 0; k < 3; k++)
            printf("%s: %.3f\n", names[k], cli_median(st.ms[k], st.frame));
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
    if (!cli_parse_only)
        rc = run_animate(&a);
    cli_script_free(&a.s);
    return rc;
}
