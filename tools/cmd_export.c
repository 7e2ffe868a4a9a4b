/* lrr export: solve a saved operator for its stored emission and write the lit mesh as
 * binary glTF 2.0 (.glb) or PLY with vertex colours, for other programs to show. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "commands.h"

static const char prog[] = "lrr export";

static const char export_help[] =
    "Usage: lrr export FILE.lrr -o OUT.glb|OUT.ply [OPTIONS]\n"
    "Solves for the stored emission and writes the lit scene as a mesh with a colour per\n"
    "vertex: binary glTF 2.0 (.glb) or binary little-endian PLY.\n"
    "\n"
    "The mesh is the scene's input triangles (or with --subpatches the subpatch mesh). A\n"
    "vertex's colour is the area-weighted mean radiosity B of the subpatches at that corner\n"
    "(what 'lrr render' interpolates), times the exposure, clamped to 1 (viewers show no\n"
    "more than 1). Corners are shared where surfaces meet flat and in one material, and\n"
    "split at creases and material edges, so light does not bleed across them.\n"
    "glTF: COLOR_0 (linear float RGBA) holds that colour and _RADIOSITY (float RGB) the\n"
    "unclamped B; one material per (reflectance, emission), unlit (KHR_materials_unlit) with\n"
    "a white base colour, since the light and the reflectance are already in COLOR_0; each\n"
    "material's reflectance and emission are in its 'extras'. Blender, three.js and the\n"
    "Khronos viewer show the lit scene as is.\n"
    "PLY: per vertex x y z, nx ny nz, red green blue (uchar, the colour sRGB-encoded: what\n"
    "PLY viewers expect) and radiosity_r/_g/_b (float, B unclamped); per face its vertex\n"
    "indices and its material (listed in the header's comments).\n"
    "\n"
    "Options:\n"
    "  -o, --output OUT     where to write (required); the format follows the extension,\n"
    "                       .glb or .ply (any case)\n"
    "  --format F           gltf or ply: wins over the extension (needed for any other one)\n"
    "  --subpatches         the subpatch mesh instead of the input triangles\n"
    "  --exposure X         colour = min(1, B × X): X > 0, or 'auto' (the mean radiosity of\n"
    "                       the surfaces that do not emit maps to 0.18; default 1: B itself)\n"
    "  --emission-scale S   multiply the stored emission by S (finite, >= 0; default 1)\n"
    "  --light SPEC         a light (repeatable, up to 16) whose shadowed direct light is\n"
    "                       added to the emission, as for 'lrr render --light'\n"
    "  --probe PROBE        light the scene with a light probe, as for 'lrr render'\n"
    "                       (with --sources, --probe-method, --probe-scale)\n"
    "  --no-scene-emission  --light, --probe: leave out the stored emission\n"
    "  -h, --help           show this help\n"
    "\n"
    "Prints vertices, triangles, materials, exposure and output as 'key: value' lines.\n";

enum { FORMAT_NONE, FORMAT_GLTF, FORMAT_PLY };

typedef struct export_args {
    const char *file, *output;
    lrr_export_options eo;
    probe_args pa;      /* --light, --probe */
    double scale;
    int format;
} export_args;

/* --exposure X (> 0) or auto (0: the library picks it). */
static int exposure_option(void *target, const char *caller, const char *arg)
{
    export_args *a = target;
    if (strcmp(arg, "auto") == 0) {
        a->eo.exposure = 0;
        return 0;
    }
    return cli_parse_double(caller, "--exposure", arg, 0.0, 1, 1e300, &a->eo.exposure);
}

/* glb: the extension, accepted as the format's name too. */
static const cli_choice formats[] = {
    {"gltf", FORMAT_GLTF}, {"ply", FORMAT_PLY}, {"glb", FORMAT_GLTF}, {NULL, 0}};

/* The options of export alone; the lights' are probe_opts. */
static const cli_opt export_opts[] = {
    {.name = "output", .letter = 'o', .kind = CLI_OPT_STRING,
     .field = CLI_FIELD(export_args, output), .required = "-o OUT.glb (or OUT.ply)"},
    {.name = "format", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(export_args, format),
     .choices = formats},
    {.name = "subpatches", .kind = CLI_OPT_FLAG, .field = CLI_FIELD(export_args, eo.subpatches)},
    {.name = "exposure", .kind = CLI_OPT_CUSTOM, .handle = exposure_option},
    {.name = "emission-scale", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(export_args, scale),
     .min = 0, .max = 1e300},
    {.name = NULL}};

/* The output format: --format, else the extension (.glb, .ply, any case). */
static const cli_choice extensions[] = {{"glb", FORMAT_GLTF}, {"ply", FORMAT_PLY}, {NULL, 0}};

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_export(export_args *a, int argc, char *argv[])
{
    *a = (export_args){.eo = lrr_export_options_defaults(), .scale = 1.0};
    probe_args_init(&a->pa);
    const cli_opt_group groups[] = {{export_opts, a}, {probe_opts, &a->pa}, {NULL, NULL}};
    const cli_command cmd = {prog, export_help, "FILE.lrr", groups};
    int rc = cli_parse_command(&cmd, argc, argv, &a->file);
    if (rc == CLI_RUN &&
        (cli_output_format(prog, a->output, extensions, "mesh", formats, &a->format) != 0 ||
         probe_finish(&a->pa, prog) != 0))
        return CLI_EXIT_USAGE;
    return rc;
}

/* The mesh's sizes, then the file. */
static int write_mesh(lrr_context *ctx, const lrr_operator *op, const float *b,
                      const export_args *a)
{
    lrr_export_info info;
    lrr_status s = lrr_export_get_info(op, b, &a->eo, a->output, &info, sizeof info);
    if (s == LRR_OK)
        s = a->format == FORMAT_PLY ? lrr_export_ply(op, b, &a->eo, a->output)
                                    : lrr_export_gltf(op, b, &a->eo, a->output);
    if (s != LRR_OK)
        return cli_lib_error(ctx, s);
    printf("vertices: %zu\ntriangles: %zu\nmaterials: %zu\nexposure: %.6g\n", info.vertices,
           info.triangles, info.materials, info.exposure);
    printf("format: %s\noutput: %s\n", a->format == FORMAT_PLY ? "ply" : "gltf", a->output);
    return CLI_EXIT_OK;
}

static int run_export(const export_args *a)
{
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_operator *op = NULL;
    float *b = NULL;
    int rc = solve_lit(ctx, a->file, a->scale, &a->pa, &op, &b);
    if (rc == CLI_EXIT_OK)
        rc = write_mesh(ctx, op, b, a);
    free(b);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_export(int argc, char *argv[])
{
    export_args a;
    int rc = parse_export(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_export(&a);
}
