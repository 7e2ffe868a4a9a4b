/* Option groups of the `lrr` tool's subcommands (subdivision, hemicube build, memory budget,
 * --probe), the table-driven parser of solve, render, export and animate, and the getopt
 * plumbing they share: see commands.h. */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
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

/* ------------------------------------------------------------------ option tables */
/* The most options one command's tables may hold (render has 22). */
#define CLI_MAX_OPTS 48

static void *field_at(void *target, size_t field)
{
    return (char *)target + (field - 1);
}

/* cli_parse_vec3, reported naming opt; 0 or -1. */
static int parse_vec3(const char *prog, const char *opt, const char *arg, double v[3])
{
    if (cli_parse_vec3(arg, v) == 0)
        return 0;
    cli_usage_error(prog, "%s: '%s' is not three finite numbers X,Y,Z", opt, arg);
    return -1;
}

/* The words of ch without its aliases, each after prefix, joined by sep and the last by
 * last_sep ("png|exr", ".glb or .ply"), into list. */
static void choice_list(const cli_choice *ch, const char *prefix, const char *sep,
                        const char *last_sep, char *list, size_t size)
{
    const char *word[CLI_MAX_OPTS];
    size_t n = 0, len = 0;
    for (size_t i = 0; ch[i].word && n < CLI_MAX_OPTS; i++) {
        int alias = 0;
        for (size_t j = 0; j < i; j++)
            alias |= ch[j].value == ch[i].value;
        if (!alias)
            word[n++] = ch[i].word;
    }
    list[0] = '\0';
    for (size_t i = 0; i < n && len < size; i++)
        len += (size_t)snprintf(list + len, size - len, "%s%s%s",
                                i == 0 ? "" : i + 1 == n ? last_sep : sep, prefix, word[i]);
}

/* "--NAME: 'ARG' is not one of a, b, c" lists each value once (aliases are left out). */
static int parse_choice(const char *prog, const char *opt, const cli_choice *ch, const char *arg,
                        int *out)
{
    for (size_t i = 0; ch[i].word; i++)
        if (strcmp(arg, ch[i].word) == 0) {
            *out = ch[i].value;
            return 0;
        }
    char list[256];
    choice_list(ch, "", ", ", ", ", list, sizeof list);
    cli_usage_error(prog, "%s: '%s' is not one of %s", opt, arg, list);
    return -1;
}

int cli_output_format(const char *prog, const char *path, const cli_choice *exts,
                      const char *kind, const cli_choice *formats, int *format)
{
    if (*format != 0)
        return 0;
    for (size_t i = 0; exts[i].word; i++)
        if (lrr__path_has_extension(path, exts[i].word)) {
            *format = exts[i].value;
            return 0;
        }
    char names[256], words[256];
    choice_list(exts, ".", ", ", " or ", names, sizeof names);
    choice_list(formats, "", "|", "|", words, sizeof words);
    cli_usage_error(prog, "-o %s: unknown %s format (name it %s, or give --format %s)", path,
                    kind, names, words);
    return -1;
}

static int parse_double_opt(const cli_opt *o, const char *prog, const char *opt,
                            const char *arg, double *out)
{
    if (cli_parse_double(prog, opt, arg, o->min, o->min_open, o->max, out) != 0)
        return -1;
    if (o->max_open && *out >= o->max) {
        cli_usage_error(prog, "%s: '%s' is out of range (it must be less than %g)", opt, arg,
                        o->max);
        return -1;
    }
    return 0;
}

/* One option's value into its field; 0, or -1 after a usage message naming --NAME. */
static int apply_opt(const cli_opt *o, void *target, const char *prog, const char *arg)
{
    char opt[64];
    snprintf(opt, sizeof opt, "--%s", o->name);
    void *f = o->field ? field_at(target, o->field) : NULL;
    if (o->seen)
        *(int *)field_at(target, o->seen) = 1;
    switch (o->kind) {
    case CLI_OPT_FLAG:
        if (o->handle)
            return o->handle(target, prog, NULL);
        *(int *)f = 1;
        return 0;
    case CLI_OPT_FILE:
        if (!arg[0]) {
            cli_usage_error(prog, "%s: the file name is empty", opt);
            return -1;
        }
        /* fall through */
    case CLI_OPT_STRING:
        *(const char **)f = arg;
        return 0;
    case CLI_OPT_DOUBLE:
        return parse_double_opt(o, prog, opt, arg, f);
    case CLI_OPT_UNSIGNED:
        return cli_parse_unsigned(prog, opt, arg, (unsigned)o->min, (unsigned)o->max, f);
    case CLI_OPT_SIZE:
        return cli_parse_size(prog, opt, arg, (size_t)o->min, (size_t)o->max, f);
    case CLI_OPT_VEC3:
        return parse_vec3(prog, opt, arg, f);
    case CLI_OPT_CHOICE:
        return parse_choice(prog, opt, o->choices, arg, f);
    case CLI_OPT_CUSTOM:
        return o->handle(target, prog, arg);
    }
    return -1;
}

/* The getopt_long tables of the command's options: long option k has val 256 + k. */
typedef struct opt_index {
    struct option longopts[CLI_MAX_OPTS + 2];
    char shortopts[2 * CLI_MAX_OPTS + 4];
    const cli_opt *opt[CLI_MAX_OPTS];
    void *target[CLI_MAX_OPTS];
    int n;
} opt_index;

static void index_options(const cli_command *cmd, opt_index *ix)
{
    size_t sl = 0;
    ix->shortopts[sl++] = ':';
    ix->shortopts[sl++] = 'h';
    ix->n = 0;
    for (const cli_opt_group *g = cmd->groups; g->opts; g++)
        for (const cli_opt *o = g->opts; o->name && ix->n < CLI_MAX_OPTS; o++) {
            int has_arg = o->kind == CLI_OPT_FLAG ? no_argument : required_argument;
            ix->longopts[ix->n] = (struct option){o->name, has_arg, NULL, 256 + ix->n};
            ix->opt[ix->n] = o;
            ix->target[ix->n++] = g->target;
            if (o->letter) {
                ix->shortopts[sl++] = o->letter;
                if (has_arg == required_argument)
                    ix->shortopts[sl++] = ':';
            }
        }
    ix->longopts[ix->n] = (struct option){"help", no_argument, NULL, 'h'};
    ix->longopts[ix->n + 1] = (struct option){NULL, 0, NULL, 0};
    ix->shortopts[sl] = '\0';
}

/* The entry getopt_long's c stands for, or −1. */
static int find_option(const opt_index *ix, int c)
{
    if (c >= 256 && c < 256 + ix->n)
        return c - 256;
    for (int k = 0; k < ix->n; k++)
        if (c > 0 && ix->opt[k]->letter == c)
            return k;
    return -1;
}

/* Every required option given and not empty; 0 or CLI_EXIT_USAGE after a message. */
static int check_required(const cli_command *cmd, const opt_index *ix)
{
    for (int k = 0; k < ix->n; k++) {
        const cli_opt *o = ix->opt[k];
        if (!o->required)
            continue;
        const char *v = *(const char **)field_at(ix->target[k], o->field);
        if (!v || !v[0]) {
            cli_usage_error(cmd->prog, "%s is required", o->required);
            fprintf(stderr, "Try '%s --help'.\n", cmd->prog);
            return CLI_EXIT_USAGE;
        }
    }
    return 0;
}

int cli_parse_command(const cli_command *cmd, int argc, char *argv[], const char **positional)
{
    opt_index ix;
    index_options(cmd, &ix);
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ix.shortopts, ix.longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(cmd->help, stdout);
            return CLI_EXIT_OK;
        }
        int k = find_option(&ix, c);
        if (k < 0)
            return bad_option(cmd->prog, c, argv);
        if (apply_opt(ix.opt[k], ix.target[k], cmd->prog, optarg) != 0)
            return CLI_EXIT_USAGE;
    }
    *positional = one_positional(cmd->prog, cmd->positional, argc, argv);
    if (!*positional)
        return CLI_EXIT_USAGE;
    int rc = check_required(cmd, &ix);
    return rc ? rc : CLI_RUN;
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
    b->receiver = LRR_RECEIVER_AUTO;
    b->hemicube_given = 0;
}

int build_option(build_args *b, const char *prog, int c, const char *arg)
{
    switch (c) {
    case OPT_HEMICUBE:
        if (cli_parse_unsigned(prog, "--hemicube", arg, 8, 4096, &b->hemicube) != 0)
            return -1;
        b->hemicube_given = 1;
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
    case OPT_RECEIVER:
        if (strcmp(arg, "auto") == 0)
            b->receiver = LRR_RECEIVER_AUTO;
        else if (strcmp(arg, "centre") == 0 || strcmp(arg, "center") == 0)
            b->receiver = LRR_RECEIVER_CENTRE;
        else if (strcmp(arg, "area") == 0)
            b->receiver = LRR_RECEIVER_AREA;
        else {
            cli_usage_error(prog, "--receiver: '%s' is not auto, centre or area", arg);
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
    bo.receiver_sampling = b->receiver;
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

/* --light SPEC, repeatable up to CLI_MAX_LIGHTS. */
static int light_option(void *target, const char *prog, const char *arg)
{
    probe_args *p = target;
    if (p->lights == CLI_MAX_LIGHTS) {
        cli_usage_error(prog, "--light: at most %d lights", CLI_MAX_LIGHTS);
        return -1;
    }
    return cli_parse_light(prog, arg, &p->light[p->lights++]);
}

static const cli_choice probe_methods[] = {{"irradiance", 0}, {"median-cut", 1}, {NULL, 0}};

const cli_opt probe_opts[] = {
    {.name = "probe", .kind = CLI_OPT_FILE, .field = CLI_FIELD(probe_args, path)},
    {.name = "sources", .kind = CLI_OPT_SIZE, .field = CLI_FIELD(probe_args, sources),
     .seen = CLI_FIELD(probe_args, probe_only_given), .min = 1, .max = 65536},
    {.name = "probe-method", .kind = CLI_OPT_CHOICE, .field = CLI_FIELD(probe_args, median_cut),
     .seen = CLI_FIELD(probe_args, probe_only_given), .choices = probe_methods},
    {.name = "probe-scale", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(probe_args, scale),
     .seen = CLI_FIELD(probe_args, probe_only_given), .min = 0, .max = 1e300},
    {.name = "no-scene-emission", .kind = CLI_OPT_FLAG,
     .field = CLI_FIELD(probe_args, no_scene_emission)},
    {.name = "light", .kind = CLI_OPT_CUSTOM, .handle = light_option},
    {.name = NULL}};

int probe_finish(const probe_args *p, const char *prog)
{
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
