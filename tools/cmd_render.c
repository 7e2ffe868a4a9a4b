/* lrr render: solve a saved operator for its stored emission (optionally lit by a probe) and
 * draw the scene with its radiosity to a PNG (tone mapped) or an OpenEXR file (linear). */
#include <errno.h>
#include <math.h>
#include <strings.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "solve_mpi.h"

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
    "  --csv FILE           also write the radiosity drawn, as 'lrr solve --csv' does\n"
    PROBE_LIGHT_HELP
    "  -h, --help           show this help\n"
    "\n"
    "Under mpirun (an MPI build), every rank solves its block of rows (as 'mpirun lrr\n"
    "solve') and rank 0 gathers B, draws, writes and prints, adding 'ranks'.\n";

enum { FORMAT_NONE, FORMAT_PNG, FORMAT_EXR };

typedef struct render_args {
    const char *file, *output, *csv;
    probe_args pa;
    view_args view;              /* size, exposure, camera */
    double scale;
    int format;                  /* --format, else FORMAT_NONE */
} render_args;

/* ------------------------------------------------------------------ parsing */
static const cli_choice formats[] = {{"png", FORMAT_PNG}, {"exr", FORMAT_EXR}, {NULL, 0}};

/* The options of render alone; the picture's and the lights' are view_opts and probe_opts. */
static const cli_opt render_opts[] = {
    {.name = "output", .letter = 'o', .kind = CLI_OPT_STRING,
     .field = CLI_FIELD(render_args, output), .required = "-o OUT.png (or OUT.exr)"},
    {.name = "emission-scale", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(render_args, scale),
     .min = 0, .max = 1e300},
    {.name = "format", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(render_args, format),
     .choices = formats},
    {.name = "csv", .kind = CLI_OPT_STRING, .field = CLI_FIELD(render_args, csv)},
    {.name = NULL}};

/* The output format: --format, else the extension (.png, .exr, any case). */
static const cli_choice extensions[] = {{"png", FORMAT_PNG}, {"exr", FORMAT_EXR}, {NULL, 0}};

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_render(render_args *a, int argc, char *argv[])
{
    *a = (render_args){.scale = 1.0};
    view_args_init(&a->view);
    probe_args_init(&a->pa);
    const cli_opt_group groups[] = {
        {render_opts, a}, {view_opts, &a->view}, {probe_opts, &a->pa}, {NULL, NULL}};
    const cli_command cmd = {prog, render_help, "FILE.lrr", groups};
    int rc = cli_parse_command(&cmd, argc, argv, &a->file);
    if (rc == CLI_RUN &&
        (probe_finish(&a->pa, prog) != 0 || view_finish(&a->view, prog) != 0 ||
         cli_output_format(prog, a->output, extensions, "picture", formats, &a->format) != 0))
        return CLI_EXIT_USAGE;
    return rc;
}

/* ------------------------------------------------------------------ running */
/* The picture of B (and the CSV); ranks > 0: drawn by rank 0 of that many (mpirun). */
static int draw(lrr_context *ctx, const lrr_operator *op, const float *b, int ranks,
                const void *arg)
{
    const render_args *a = arg;
    lrr_status s = a->format == FORMAT_EXR ? lrr_render_exr(op, b, &a->view.ro, a->output)
                                           : lrr_render_png(op, b, &a->view.ro, a->output);
    if (s != LRR_OK)
        return cli_lib_error(ctx, s);
    if (a->csv && cli_write_radiosity_csv(a->csv, op, b) != CLI_EXIT_OK)
        return CLI_EXIT_FAIL;
    if (ranks > 0)
        printf("ranks: %d\n", ranks);
    printf("output: %s\n", a->output);
    if (a->csv)
        printf("csv: %s\n", a->csv);
    return CLI_EXIT_OK;
}

static int run_render(const render_args *a)
{
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_operator *op = NULL;
    float *b = NULL;
    int rc = solve_lit(ctx, a->file, a->scale, &a->pa, &op, &b);
    if (rc == CLI_EXIT_OK)
        rc = draw(ctx, op, b, 0, a);
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
#ifdef LRR_MPI
    if (solve_mpi_launched()) /* mpirun -np P lrr render (tools/cmd_solve_mpi.c) */
        return solve_mpi_run(&(solve_mpi_args){.file = a.file, .pa = &a.pa, .scale = a.scale,
                                               .backend = LRR_BACKEND_CPU,
                                               .path = LRR_PATH_AUTO, .fbar = LRR_FBAR_AUTO,
                                               .finish = draw, .finish_arg = &a});
#endif
    return run_render(&a);
}
