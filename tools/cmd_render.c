/* lrr render: solve a saved operator for its stored emission (optionally lit by a probe) and
 * draw the scene with its radiosity to a PNG. */
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"

static const char prog[] = "lrr render";

static const char render_help[] =
    "Usage: lrr render FILE.lrr -o OUT.png [OPTIONS]\n"
    "Solves for the stored emission and draws the scene with its radiosity to a PNG.\n"
    "\n"
    "Options:\n"
    "  -o, --output OUT.png where to write the picture (required)\n"
    "  --width W            picture width in pixels (1..16384, default 512)\n"
    "  --height H           picture height in pixels (1..16384, default 512)\n"
    "  --exposure X         multiplier before tone mapping (> 0; default automatic)\n"
    "  --emission-scale S   multiply the stored emission by S (finite, >= 0; default 1)\n"
    "  --camera C           'cornell', 'fit' (frame the scene) or 'auto' (default: the\n"
    "                       Cornell camera for the built-in boxes)\n"
    "  --probe PROBE        light the scene with a latitude-longitude probe (.hdr, +y up,\n"
    "                       at infinity): its fitted directional lights give the reflected\n"
    "                       direct light E_i = rho_i sum_l I_l max(0, n_i.w_l) visible(x_i, w_l)\n"
    "                       (shadows by Embree occlusion rays), added to the stored emission\n"
    "  --sources N          --probe: number of lights (1..65536, default 16)\n"
    "  --probe-method M     --probe: irradiance (default; fitted by Levenberg-Marquardt) or\n"
    "                       median-cut\n"
    "  --probe-scale S      --probe: multiply the lights by S (finite, >= 0; default 1)\n"
    "  --no-scene-emission  --probe: leave out the stored emission (probe light only)\n"
    "  -h, --help           show this help\n";

typedef struct render_args {
    const char *file, *output;
    probe_args pa;
    lrr_render_options ro;
    double scale;
} render_args;

/* ------------------------------------------------------------------ parsing */
/* The options of render alone: 1 handled, 0 not one of them, -1 usage error (reported). */
static int render_option(render_args *a, int c, const char *arg)
{
    switch (c) {
    case 'o':
        a->output = arg;
        return 1;
    case OPT_WIDTH:
        return cli_parse_unsigned(prog, "--width", arg, 1, 16384, &a->ro.width) != 0 ? -1 : 1;
    case OPT_HEIGHT:
        return cli_parse_unsigned(prog, "--height", arg, 1, 16384, &a->ro.height) != 0 ? -1 : 1;
    case OPT_EXPOSURE:
        return cli_parse_double(prog, "--exposure", arg, 0.0, 1, 1e300, &a->ro.exposure) != 0
                   ? -1 : 1;
    case OPT_EMISSION_SCALE:
        return cli_parse_double(prog, "--emission-scale", arg, 0.0, 0, 1e300, &a->scale) != 0
                   ? -1 : 1;
    case OPT_CAMERA:
        if (strcmp(arg, "cornell") == 0)
            a->ro.use_cornell_camera = 1;
        else if (strcmp(arg, "fit") == 0)
            a->ro.use_cornell_camera = 0;
        else if (strcmp(arg, "auto") == 0)
            a->ro.use_cornell_camera = -1;
        else {
            cli_usage_error(prog, "--camera: '%s' is not one of cornell, fit, auto", arg);
            return -1;
        }
        return 1;
    default:
        return probe_option(&a->pa, prog, c, arg);
    }
}

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_render(render_args *a, int argc, char *argv[])
{
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'},
        {"width", required_argument, NULL, OPT_WIDTH},
        {"height", required_argument, NULL, OPT_HEIGHT},
        {"exposure", required_argument, NULL, OPT_EXPOSURE},
        {"emission-scale", required_argument, NULL, OPT_EMISSION_SCALE},
        {"camera", required_argument, NULL, OPT_CAMERA},
        PROBE_LONGOPTS,
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    *a = (render_args){
        .ro = {.width = 0, .height = 0, .exposure = 0.0, .use_cornell_camera = -1},
        .scale = 1.0};
    probe_args_init(&a->pa);
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(render_help, stdout);
            return CLI_EXIT_OK;
        }
        int r = render_option(a, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r == 0)
            return bad_option(prog, c, argv);
    }
    a->file = one_positional(prog, "FILE.lrr", argc, argv);
    if (!a->file)
        return CLI_EXIT_USAGE;
    if (!a->output || !a->output[0]) {
        cli_usage_error(prog, "-o OUT.png is required");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    if (probe_finish(&a->pa, prog) != 0)
        return CLI_EXIT_USAGE;
    return CLI_RUN;
}

/* ------------------------------------------------------------------ running */
static int run_render(const render_args *a)
{
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_operator *op = NULL;
    float *e = NULL, *b = NULL;
    double ms = 0.0, direct_s = 0.0;
    int rc = load_operator(ctx, a->file, &op);
    if (rc == CLI_EXIT_OK)
        rc = scaled_emission(op, a->scale, &e);
    if (rc == CLI_EXIT_OK && a->pa.path)
        rc = add_probe_light(ctx, op, &a->pa, e, &direct_s);
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        b = cli_alloc_rgb(oi.n);
        rc = b ? timed_solve(ctx, op, LRR_BACKEND_CPU, e, b, 0, LRR_PATH_AUTO, &ms, NULL, NULL)
               : CLI_EXIT_FAIL;
    }
    if (rc == CLI_EXIT_OK) {
        s = lrr_render_png(op, b, &a->ro, a->output);
        if (s != LRR_OK)
            rc = cli_lib_error(ctx, s);
    }
    if (rc == CLI_EXIT_OK)
        printf("output: %s\n", a->output);
    free(b);
    free(e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_render(int argc, char *argv[])
{
    render_args a;
    int rc = parse_render(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_render(&a);
}
