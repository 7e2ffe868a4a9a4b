/* Option groups of the `lrr` tool's subcommands (subdivision, hemicube build, memory budget,
 * --probe) and the getopt plumbing they share: see commands.h. */
#include <getopt.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "commands.h"

/* ------------------------------------------------------------------ getopt */
int bad_option(const char *prog, int c, char *const argv[])
{
    const char *arg = optind > 0 ? argv[optind - 1] : "";
    if (c == ':') {
        cli_usage_error(prog, "%s: a value is required", arg);
    } else if (strncmp(arg, "--", 2) == 0 || optopt == 0 || optopt > 255) {
        cli_usage_error(prog, "unknown option '%s'", arg);
    } else {
        cli_usage_error(prog, "unknown option '-%c'", optopt);
    }
    fprintf(stderr, "Try '%s --help'.\n", prog);
    return CLI_EXIT_USAGE;
}

void start_getopt(void)
{
    opterr = 0;
    optind = 0; /* glibc: 0 re-initialises the scanner completely */
}

const char *one_positional(const char *prog, const char *what, int argc, char *const argv[])
{
    if (optind >= argc) {
        cli_usage_error(prog, "missing %s", what);
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return NULL;
    }
    if (optind + 1 < argc) {
        cli_usage_error(prog, "unexpected argument '%s'", argv[optind + 1]);
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return NULL;
    }
    return argv[optind];
}

/* ------------------------------------------------------------------ subdivision */
void subdiv_init(subdiv_args *s)
{
    memset(s, 0, sizeof *s);
    s->sub.levels = DEFAULT_LEVELS;
}

int subdiv_option(subdiv_args *s, const char *prog, int c, const char *arg)
{
    switch (c) {
    case OPT_MAX_PATCH_AREA:
        s->have_area = 1;
        return cli_parse_double(prog, "--max-patch-area", arg, 0.0, 1, 1e300,
                                &s->sub.max_patch_area) == 0 ? 1 : -1;
    case OPT_PATCHES:
        s->have_patches = 1;
        return cli_parse_size(prog, "--patches", arg, 1, SIZE_MAX, &s->sub.target_patches) == 0
                   ? 1 : -1;
    case OPT_LEVELS:
        s->have_levels = 1;
        return cli_parse_unsigned(prog, "--levels", arg, 0, 10, &s->sub.levels) == 0 ? 1 : -1;
    default:
        return 0;
    }
}

int subdiv_finish(subdiv_args *s, const char *prog)
{
    if (s->have_area && s->have_patches) {
        cli_usage_error(prog, "--max-patch-area and --patches exclude each other");
        return CLI_EXIT_USAGE;
    }
    if (!s->have_area && !s->have_patches && !s->clusters)
        s->sub.target_patches = DEFAULT_PATCHES;
    return 0;
}

/* ------------------------------------------------------------------ hemicube build */
void build_init(build_args *b)
{
    b->hemicube = DEFAULT_HEMICUBE;
    b->threads = 0;
    b->seed = DEFAULT_SEED;
    b->force_progress = 0;
    b->no_rotation = 0;
    b->formfactor = LRR_FORMFACTOR_AUTO;
}

int build_option(build_args *b, const char *prog, int c, const char *arg)
{
    switch (c) {
    case OPT_HEMICUBE:
        if (cli_parse_unsigned(prog, "--hemicube", arg, 8, 4096, &b->hemicube) != 0)
            return -1;
        if (b->hemicube % 2 != 0) {
            cli_usage_error(prog, "--hemicube: %u is odd (the side faces are R×R/2)",
                            b->hemicube);
            return -1;
        }
        return 1;
    case OPT_SEED:
        return cli_parse_u64(prog, "--seed", arg, 0, UINT64_MAX, &b->seed) == 0 ? 1 : -1;
    case OPT_THREADS:
        return cli_parse_unsigned(prog, "--threads", arg, 0, 4096, &b->threads) == 0 ? 1 : -1;
    case OPT_PROGRESS:
        b->force_progress = 1;
        return 1;
    case OPT_NO_ROTATION:
        b->no_rotation = 1;
        return 1;
    case OPT_FORMFACTOR:
        if (strcmp(arg, "auto") == 0)
            b->formfactor = LRR_FORMFACTOR_AUTO;
        else if (strcmp(arg, "raster") == 0)
            b->formfactor = LRR_FORMFACTOR_RASTER;
        else if (strcmp(arg, "raycast") == 0)
            b->formfactor = LRR_FORMFACTOR_RAYCAST;
        else {
            cli_usage_error(prog, "--formfactor: '%s' is not auto, raster or raycast", arg);
            return -1;
        }
        return 1;
    default:
        return 0;
    }
}

lrr_build_options build_start(const build_args *b, cli_progress *bar)
{
    cli_progress_init(bar, "hemicubes", b->force_progress || isatty(STDERR_FILENO));
    lrr_build_options bo = {.size = sizeof bo, /* the whole struct: hierarchy came after ABI 1 */
                            .hemicube_resolution = b->hemicube,
                            .seed = b->seed,
                            .threads = (int)b->threads,
                            .progress = cli_progress_cb,
                            .progress_user = bar,
                            .no_rotation = b->no_rotation};
    bo.formfactor_method = b->formfactor;
    return bo;
}

/* ------------------------------------------------------------------ memory budget */
size_t physical_memory_bytes(void)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    size_t bytes;
    if (pages <= 0 || page <= 0 ||
        __builtin_mul_overflow((size_t)pages, (size_t)page, &bytes))
        return 0;
    return bytes;
}

int parse_operator_budget(const char *prog, const char *arg, size_t *bytes)
{
    size_t mb;
    if (cli_parse_size(prog, "--memory-budget", arg, 0, SIZE_MAX >> 20, &mb) != 0)
        return -1;
    *bytes = mb << 20;
    return 0;
}

/* ------------------------------------------------------------------ probe lighting */
void probe_args_init(probe_args *p)
{
    memset(p, 0, sizeof *p);
    p->sources = PROBE_DEFAULT_SOURCES;
    p->scale = 1.0;
}

int probe_option(probe_args *p, const char *prog, int c, const char *arg)
{
    switch (c) {
    case OPT_PROBE:
        p->path = arg;
        return 1;
    case OPT_SOURCES:
        p->probe_only_given = 1;
        return cli_parse_size(prog, "--sources", arg, 1, 65536, &p->sources) != 0 ? -1 : 1;
    case OPT_PROBE_METHOD:
        p->probe_only_given = 1;
        if (strcmp(arg, "median-cut") == 0)
            p->median_cut = 1;
        else if (strcmp(arg, "irradiance") == 0)
            p->median_cut = 0;
        else {
            cli_usage_error(prog, "--probe-method: '%s' is not one of irradiance, median-cut",
                            arg);
            return -1;
        }
        return 1;
    case OPT_PROBE_SCALE:
        p->probe_only_given = 1;
        return cli_parse_double(prog, "--probe-scale", arg, 0.0, 0, 1e300, &p->scale) != 0 ? -1
                                                                                         : 1;
    case OPT_NO_SCENE_EMISSION:
        p->no_scene_emission = 1;
        return 1;
    case OPT_LIGHT:
        if (p->lights == CLI_MAX_LIGHTS) {
            cli_usage_error(prog, "--light: at most %d lights", CLI_MAX_LIGHTS);
            return -1;
        }
        return cli_parse_light(prog, arg, &p->light[p->lights++]) != 0 ? -1 : 1;
    default:
        return 0;
    }
}

int probe_finish(const probe_args *p, const char *prog)
{
    if (p->path && !p->path[0]) {
        cli_usage_error(prog, "--probe: the file name is empty");
        return -1;
    }
    if (!p->path && p->probe_only_given) {
        cli_usage_error(prog, "--sources, --probe-method and --probe-scale need --probe");
        return -1;
    }
    if (!p->path && !p->lights && p->no_scene_emission) {
        cli_usage_error(prog, "--no-scene-emission needs --probe or --light");
        return -1;
    }
    return 0;
}
