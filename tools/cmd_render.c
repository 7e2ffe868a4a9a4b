/* lrr render: solve a saved operator for its stored emission (optionally lit by a probe) and
 * draw the scene with its radiosity to a PNG (tone mapped) or an OpenEXR file (linear). */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <strings.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"

static const char prog[] = "lrr render";

static const char render_help[] =
    "Usage: lrr render FILE.lrr -o OUT.png|OUT.exr [OPTIONS]\n"
    "Solves for the stored emission and draws the scene with its radiosity: a PNG (tone\n"
    "mapped sRGB) or an OpenEXR file (linear radiosity, float RGB, 0 = background).\n"
    "\n"
    "Options:\n"
    "  -o, --output OUT     where to write the picture (required); the format follows the\n"
    "                       extension, .png or .exr (any case)\n"
    "  --format F           png or exr: wins over the extension (needed for any other one)\n"
    "  --width W            picture width in pixels (1..16384, default 512)\n"
    "  --height H           picture height in pixels (1..16384, default 512)\n"
    "  --exposure X         PNG: multiplier before tone mapping (> 0; default automatic)\n"
    "  --emission-scale S   multiply the stored emission by S (finite, >= 0; default 1)\n"
    "  --camera C           'cornell', 'fit' (frame the scene from outside) or 'auto'\n"
    "                       (default: the Cornell camera for the built-in boxes, a view\n"
    "                       from inside for a closed scene with lights, else 'fit')\n"
    "  --eye X,Y,Z          a pinhole camera at this point (scene units) ...\n"
    "  --target X,Y,Z       ... looking at this one (required with --eye)\n"
    "  --up X,Y,Z           --eye: the picture's up direction (default 0,1,0; not parallel\n"
    "                       to target - eye)\n"
    "  --fov DEGREES        vertical field of view, 0 < fov < 180 (default 60 for --eye and\n"
    "                       the inside view, 40 for 'fit', 39.3 for 'cornell')\n"
    PROBE_LIGHT_HELP
    "  -h, --help           show this help\n";

enum { FORMAT_NONE, FORMAT_PNG, FORMAT_EXR };

typedef struct render_args {
    const char *file, *output;
    probe_args pa;
    view_args view;              /* size, exposure, camera */
    double scale;
    int format;                  /* --format, else FORMAT_NONE */
} render_args;

/* ------------------------------------------------------------------ parsing */
/* The options of render alone: 1 handled, 0 not one of them, -1 usage error (reported). */
static int render_option(render_args *a, int c, const char *arg)
{
    switch (c) {
    case 'o':
        a->output = arg;
        return 1;
    case OPT_FORMAT:
        if (strcmp(arg, "png") == 0)
            a->format = FORMAT_PNG;
        else if (strcmp(arg, "exr") == 0)
            a->format = FORMAT_EXR;
        else {
            cli_usage_error(prog, "--format: '%s' is not one of png, exr", arg);
            return -1;
        }
        return 1;
    default: {
        int r = view_option(&a->view, prog, c, arg);
        return r ? r : probe_option(&a->pa, prog, c, arg);
    }
    }
}

/* The output format: --format, else the extension (.png, .exr, any case). */
static int format_finish(render_args *a)
{
    if (a->format != FORMAT_NONE)
        return 0;
    const char *dot = strrchr(a->output, '.');
    if (dot && strchr(dot, '/') == NULL) {
        if (strcasecmp(dot, ".png") == 0)
            a->format = FORMAT_PNG;
        else if (strcasecmp(dot, ".exr") == 0)
            a->format = FORMAT_EXR;
    }
    if (a->format == FORMAT_NONE) {
        cli_usage_error(prog, "-o %s: unknown picture format (name it .png or .exr, or give "
                        "--format png|exr)",
                        a->output);
        return -1;
    }
    return 0;
}

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_render(render_args *a, int argc, char *argv[])
{
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'},
        VIEW_LONGOPTS,
        {"emission-scale", required_argument, NULL, OPT_EMISSION_SCALE},
        {"format", required_argument, NULL, OPT_FORMAT},
        PROBE_LONGOPTS,
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    *a = (render_args){.scale = 1.0};
    view_args_init(&a->view);
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
        cli_usage_error(prog, "-o OUT.png (or OUT.exr) is required");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    if (probe_finish(&a->pa, prog) != 0 || view_finish(&a->view, prog) != 0 || format_finish(a) != 0)
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
    float *b = NULL;
    int rc = solve_lit(ctx, a->file, a->scale, &a->pa, &op, &b);
    if (rc == CLI_EXIT_OK) {
        s = a->format == FORMAT_EXR ? lrr_render_exr(op, b, &a->view.ro, a->output)
                                    : lrr_render_png(op, b, &a->view.ro, a->output);
        if (s != LRR_OK)
            rc = cli_lib_error(ctx, s);
    }
    if (rc == CLI_EXIT_OK)
        printf("output: %s\n", a->output);
    free(b);
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
