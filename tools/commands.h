/*
 * The subcommands of the `lrr` tool (tools/cmd_*.c, dispatched by lrr_cli_main in
 * tools/lrr.c) and what several of them share: defaults, option codes, help fragments, the
 * option groups (cli_options.c) and the common steps (cli_steps.c). Uses only the public API
 * (lrr.h).
 */
#ifndef LRR_COMMANDS_H
#define LRR_COMMANDS_H

#include <getopt.h>
#include <stddef.h>
#include <stdint.h>

#include "cli.h"
#include "lrr.h"

/* ------------------------------------------------------------------ the subcommands */
/* Each takes the command line from the subcommand's name on (argv[0] = "info", ...) and
 * returns the exit status. */
int cmd_info(int argc, char *argv[]);
int cmd_check(int argc, char *argv[]);
int cmd_preprocess(int argc, char *argv[]);
int cmd_solve(int argc, char *argv[]);
int cmd_render(int argc, char *argv[]);
int cmd_animate(int argc, char *argv[]);
int cmd_export(int argc, char *argv[]);
int cmd_reference(int argc, char *argv[]);
int cmd_compare(int argc, char *argv[]);
int cmd_demo(int argc, char *argv[]);
int cmd_probe(int argc, char *argv[]);
int cmd_view(int argc, char *argv[]);
/* check_fix.c: lrr check --fix's OBJ + MTL writer; returns the exit status. */
int check_write_fixed(const lrr_check_report *r, const char *path);

/* Set by lrr_cli_main: each command returns CLI_EXIT_OK right after its command line has
 * been parsed and checked, before it touches a file or does any work (see cli.h). */
extern int cli_parse_only;

/* What a command's parse function returns when the command line is good and the command is
 * to run; otherwise it returns the exit status (CLI_EXIT_OK after --help). */
enum { CLI_RUN = -1 };

/* Defaults when no subdivision option is given (documented in the help texts). */
#define DEFAULT_PATCHES 216
#define DEFAULT_LEVELS 2u
#define DEFAULT_HEMICUBE 128u
#define DEFAULT_SEED 1u
#define DEFAULT_REPEAT 10u
#define DEFAULT_TOL 1e-6
#define DEFAULT_BUDGET_MB 4096u

#define PROBE_DEFAULT_SOURCES 16u
#define PROBE_DEFAULT_NORMALS 1024u

/* Long-only options get codes above the char range. */
enum {
    OPT_MAX_PATCH_AREA = 256,
    OPT_PATCHES,
    OPT_LEVELS,
    OPT_HEMICUBE,
    OPT_SEED,
    OPT_THREADS,
    OPT_PROGRESS,
    OPT_NO_ROTATION,
    OPT_CSV,
    OPT_BACKEND,
    OPT_STORAGE,
    OPT_WIDTH,
    OPT_HEIGHT,
    OPT_EXPOSURE,
    OPT_EYE,
    OPT_TARGET,
    OPT_FOV,
    OPT_OUT,
    OPT_METHOD,
    OPT_TOL,
    OPT_MAX_ITERATIONS,
    OPT_MEMORY_BUDGET,
    OPT_SOURCES,
    OPT_NORMALS,
    OPT_JSON,
    OPT_LIGHTS,
    OPT_NO_SCENE_EMISSION,
    OPT_LIGHT,
    OPT_ADAPTIVE,
    OPT_CLUSTERS,
    OPT_ADAPTIVE_SAMPLES,
    OPT_ADAPTIVE_SPLIT,
    OPT_SAMPLES,
    OPT_FORMFACTOR,
    OPT_RECEIVER,
    OPT_VERIFY,
    OPT_FBAR_FILE
};

/* ------------------------------------------------------------------ help fragments */
#define SUBDIV_HELP                                                                           \
    "Subdivision (default when neither --max-patch-area nor --patches is given:\n"           \
    "--patches 216 --levels 2):\n"                                                            \
    "  --max-patch-area A   split input triangles until every patch has area <= A\n"          \
    "  --patches K          choose the area threshold giving about K patches\n"               \
    "  --levels L           split each patch L more times: d = 4^L subpatches (0..10,\n"      \
    "                       default 2)\n"

#define SCENE_HELP                                                                            \
    "SCENE is an OBJ/PLY/glTF file, or a built-in scene: 'cornell' or 'cornell-closed'.\n"  \
    "A built-in name is used only when no file of that name exists.\n"

#define BUILD_HELP                                                                            \
    "  --hemicube R         hemicube resolution: even, 8..4096 (default 128)\n"                \
    "  --seed S             seed of the random hemicube rotations (default 1)\n"               \
    "  --no-rotation        no random rotation: every hemicube in the same tangent frame\n"     \
    "  --formfactor M       auto (default), raster or raycast: how each hemicube pixel finds\n" \
    "                       what it sees (z-buffer, cost per hemicube grows with the\n"       \
    "                       triangles; or Embree rays, grows with their log); auto casts\n"  \
    "                       rays above a measured triangle count\n"                         \
    "  --receiver S         auto (default), centre or area: where each hemicube looks\n"     \
    "                       from. area: every ray from its own random point of the\n"       \
    "                       subpatch, so F̄ holds the area-averaged form factors of the\n"   \
    "                       radiosity equation (the centre's differ most on large\n"        \
    "                       subpatches near a light); needs rays (casts them with\n"        \
    "                       --formfactor auto). auto: area where rays are cast, else\n"     \
    "                       centre\n"                                                       \
    "  --threads T          OpenMP threads, 0 = OpenMP's default (default 0)\n"                \
    "  --progress           draw a progress bar on stderr even when it is not a terminal\n"

#define OPERATOR_BUDGET_HELP                                                                  \
    "  --memory-budget MB   the most memory the build may hold, in MiB: F̄, M, the\n"          \
    "                       per-subpatch data and the hemicube buffers of every thread\n"     \
    "                       (default: the machine's physical memory; 0 = no limit). A larger\n" \
    "                       build is refused before it starts, naming the MiB it needs\n"

/* ------------------------------------------------------------------ option tables (cli_options.c) */
/* solve, render, export and animate describe their options as tables: one parser
 * (cli_parse_command) reads the command line against them with getopt_long, so every option
 * is parsed, range-checked and reported with the same messages ("PROG: --NAME: ..."). */
typedef enum cli_opt_kind {
    CLI_OPT_FLAG,     /* no value: the int at field = 1, or handle(target, prog, NULL) */
    CLI_OPT_STRING,   /* the const char * at field */
    CLI_OPT_FILE,     /* the same, refused when empty ("--NAME: the file name is empty") */
    CLI_OPT_DOUBLE,   /* the double at field: finite, in [min, max] (open ends: *_open) */
    CLI_OPT_UNSIGNED, /* the unsigned at field, in [min, max] */
    CLI_OPT_SIZE,     /* the size_t at field, in [min, max] */
    CLI_OPT_VEC3,     /* the double[3] at field: "X,Y,Z", three finite numbers */
    CLI_OPT_CHOICE,   /* the int at field = the value of the word in choices */
    CLI_OPT_CUSTOM    /* handle(target, prog, arg): 0, or -1 after a usage message */
} cli_opt_kind;

/* A word of a CLI_OPT_CHOICE and its value. A later word with an earlier word's value is an
 * alias: accepted, not listed in the message. */
typedef struct cli_choice {
    const char *word;
    int value;
} cli_choice;

/* The format of an output file (render, export): *format when --format gave one (!= 0),
 * else the value of path's extension in exts (words without the dot, any case; the last
 * '.' after the last '/'). 0, or -1 after "PROG: -o PATH: unknown KIND format (name it .a
 * or .b, or give --format x|y)", which lists exts and formats without their aliases. */
int cli_output_format(const char *prog, const char *path, const cli_choice *exts,
                      const char *kind, const cli_choice *formats, int *format);

/* Where a field is in the group's struct, 0 meaning none (so that a table entry may leave
 * it out). */
#define CLI_FIELD(type, member) (offsetof(type, member) + 1)

typedef struct cli_opt {
    const char *name;           /* the long name without "--"; NULL ends a table */
    char letter;                /* a short form (-o), or 0 */
    cli_opt_kind kind;
    size_t field;               /* CLI_FIELD of the value */
    size_t seen;                /* CLI_FIELD of an int set to 1 when the option is given */
    double min, max;            /* DOUBLE, UNSIGNED, SIZE */
    int min_open, max_open;     /* DOUBLE: min (max) itself is refused */
    const cli_choice *choices;  /* CHOICE: ends with a NULL word */
    int (*handle)(void *target, const char *prog, const char *arg); /* CUSTOM, FLAG */
    const char *required;       /* "-o DIR": the option must be given, and not empty */
} cli_opt;

/* A table and the struct its fields are in. */
typedef struct cli_opt_group {
    const cli_opt *opts;
    void *target;
} cli_opt_group;

typedef struct cli_command {
    const char *prog;             /* "lrr solve" */
    const char *help;             /* printed on stdout by -h, --help */
    const char *positional;       /* what the one positional argument is ("FILE.lrr") */
    const cli_opt_group *groups;  /* ends with a NULL table */
} cli_command;

/* Parses argv (from the command's name on) against the groups' tables: CLI_RUN with
 * *positional set, CLI_EXIT_OK after --help, or CLI_EXIT_USAGE after a message (an unknown
 * option, a missing or bad value, a required option left out, not one positional). The
 * targets keep what their init put there for the options not given. */
int cli_parse_command(const cli_command *cmd, int argc, char *argv[], const char **positional);

/* ------------------------------------------------------------------ getopt (cli_options.c) */
/* Reports the option getopt_long rejected (it is told to stay quiet: the optstring starts
 * with ':' and opterr = 0) and returns the usage exit status. */
int bad_option(const char *prog, int c, char *const argv[]);

/* getopt_long entries of the shared option groups, for the commands' longopts tables. */
#define SUBDIV_LONGOPTS                                                                       \
    {"max-patch-area", required_argument, NULL, OPT_MAX_PATCH_AREA},                          \
    {"patches", required_argument, NULL, OPT_PATCHES},                                        \
    {"levels", required_argument, NULL, OPT_LEVELS}
#define BUILD_LONGOPTS                                                                        \
    {"hemicube", required_argument, NULL, OPT_HEMICUBE},                                      \
    {"seed", required_argument, NULL, OPT_SEED},                                              \
    {"threads", required_argument, NULL, OPT_THREADS},                                        \
    {"progress", no_argument, NULL, OPT_PROGRESS},                                            \
    {"no-rotation", no_argument, NULL, OPT_NO_ROTATION},                                      \
    {"formfactor", required_argument, NULL, OPT_FORMFACTOR},                                  \
    {"receiver", required_argument, NULL, OPT_RECEIVER}
void start_getopt(void);

/* Takes exactly one positional argument; returns it or NULL after a usage message. */
const char *one_positional(const char *prog, const char *what, int argc, char *const argv[]);

typedef struct subdiv_args {
    lrr_subdivision sub;
    int have_area, have_patches, have_levels;
    size_t clusters;  /* --clusters K: without --patches / --max-patch-area, the subpatches
                         default to about T + 16·K (T triangles): open_subdivided_scene */
} subdiv_args;

void subdiv_init(subdiv_args *s);
/* Returns 1 if c was a subdivision option, 0 if not, -1 on a bad value. */
int subdiv_option(subdiv_args *s, const char *prog, int c, const char *arg);
/* Checks the combination and fills in the default. Returns 0 or the usage exit status. */
int subdiv_finish(subdiv_args *s, const char *prog);

/* Options of the hemicube build, shared by preprocess and reference. */
typedef struct build_args {
    unsigned hemicube, threads;
    uint64_t seed;
    int force_progress;
    int no_rotation;
    int formfactor;   /* LRR_FORMFACTOR_* */
    int receiver;     /* LRR_RECEIVER_* */
    int hemicube_given; /* --hemicube was given */
} build_args;

void build_init(build_args *b);
/* Returns 1 if c was a build option, 0 if not, -1 on a bad value. */
int build_option(build_args *b, const char *prog, int c, const char *arg);
/* The library's options, with a progress bar (drawn on a terminal or with --progress). */
lrr_build_options build_start(const build_args *b, cli_progress *bar);

/* The default of --memory-budget for operator builds: the machine's physical memory (a build
 * beyond it would only swap or be killed), 0 (no limit) where sysconf cannot tell. */
size_t physical_memory_bytes(void);
/* --memory-budget MB of preprocess and demo: 0 = no limit. */
int parse_operator_budget(const char *prog, const char *arg, size_t *bytes);

/* The --probe and --light options of solve and render. */
#define CLI_MAX_LIGHTS 16
typedef struct probe_args {
    const char *path;        /* --probe; NULL: none */
    size_t sources;
    int median_cut;          /* --probe-method median-cut */
    double scale;            /* --probe-scale */
    int no_scene_emission;
    int probe_only_given;    /* an option that needs --probe was given */
    lrr_light_source light[CLI_MAX_LIGHTS]; /* --light SPEC, repeatable */
    size_t lights;
} probe_args;
/* The picture options of render and animate (tools/cli_view.c). */
typedef struct view_args {
    lrr_render_options ro;
    int have_eye, have_target, have_up, have_camera;
} view_args;
void view_args_init(view_args *v);
/* --width, --height, --exposure, --camera, --eye, --target, --up, --fov into a view_args. */
extern const cli_opt view_opts[];
/* --eye needs --target and excludes --camera, --up only with --eye; sets ro.use_eye. 0 or
 * -1 after a usage message. */
int view_finish(view_args *v, const char *prog);

/* The --help lines of the probe and light options, shared by solve and render. */
#define PROBE_LIGHT_HELP                                                                      \
    "  --probe PROBE        light the scene with a latitude-longitude probe (.hdr, +y up,\n"  \
    "                       at infinity): its fitted directional lights give the reflected\n" \
    "                       direct light E_i = rho_i sum_l I_l max(0, n_i.w_l) visible(x_i, w_l)\n" \
    "                       (shadows by Embree occlusion rays), added to the stored emission\n" \
    "  --sources N          --probe: number of lights (1..65536, default 16)\n"              \
    "  --probe-method M     --probe: irradiance (default; fitted by Levenberg-Marquardt) or\n" \
    "                       median-cut\n"                                                     \
    "  --probe-scale S      --probe: multiply the lights by S (finite, >= 0; default 1)\n"    \
    "  --light SPEC         a light (repeatable, up to 16): its direct light on every\n"      \
    "                       subpatch, shadowed by Embree occlusion rays, is added to the\n"   \
    "                       emission (lrr_lighting_direct). SPEC: a kind and fields,\n"       \
    "                         'point pos=X,Y,Z rgb=R,G,B'    (rgb: intensity per sr)\n"      \
    "                         'spot pos=.. dir=X,Y,Z angle=DEG soft=DEG rgb=..'\n"           \
    "                         'area pos=.. u=X,Y,Z v=X,Y,Z samples=N rgb=..' (a rectangle\n" \
    "                           pos ± u/2 ± v/2 emitting on the side of u × v; rgb: its\n"   \
    "                           radiosity)\n"                                                 \
    "                         'sun dir=X,Y,Z rgb=..'        (dir: towards the sun)\n"         \
    "                       rgb=V sets all three channels\n"                                  \
    "  --no-scene-emission  --probe, --light: leave out the stored emission\n"

/* --light SPEC (tools/cli_lights.c) into l; 0, or -1 after a usage message. */
int cli_parse_light(const char *prog, const char *spec, lrr_light_source *l);

void probe_args_init(probe_args *p);
/* --probe, --sources, --probe-method, --probe-scale, --no-scene-emission, --light into a
 * probe_args. */
extern const cli_opt probe_opts[];
/* 0, or -1 after a usage message. */
int probe_finish(const probe_args *p, const char *prog);

/* ------------------------------------------------------------------ shared steps (cli_steps.c) */
int is_builtin(const char *name);
/* A file wins over a built-in name, so a scene file called "cornell" stays reachable. */
int open_scene(lrr_context *ctx, const char *name, lrr_scene **scene);
int open_subdivided_scene(lrr_context *ctx, const char *name, const subdiv_args *sa,
                          lrr_scene **scene);
/* lrr_scene_subdivide of an opened scene as sa asks (T + 16·K subpatches for --clusters
 * without --patches or --max-patch-area); destroys the scene (*scene = NULL) on failure. */
int subdivide_scene(lrr_context *ctx, const subdiv_args *sa, lrr_scene **scene);
void print_scene_info(const char *name, const lrr_scene *scene);

/* After lrr_operator_build refused with LRR_ERR_BUDGET: how to get past it. */
void budget_hint(const char *prog, size_t budget, size_t clusters);
void print_operator_info(const lrr_operator *op);
/* Fails early when the directory of an output file cannot be written, so a long build is
 * not thrown away at the save. */
int check_writable_dir(const char *path);

int load_operator(lrr_context *ctx, const char *path, lrr_operator **op);
/* The operator without F̄ (lrr_operator_load_head): for a process that does not solve. */
int load_operator_head(lrr_context *ctx, const char *path, lrr_operator **op);
/* E = S × (stored emission); fails if scaling makes a value overflow to infinity. */
int scaled_emission(const lrr_operator *op, double scale, float **out);
/* e (n×3, the scaled stored emission) += the direct light of the probe and of the --light
 * sources, or = it with --no-scene-emission; *seconds the time of lrr_probe_direct_light and
 * lrr_lighting_direct. */
/* e[i] = replace ? direct[i] : e[i] + direct[i] over n subpatches (n×3 floats): the
 * subpatch of the first entry that is not finite, n when none (add_probe_light's sum, and
 * each rank's under mpirun). */
size_t cli_add_direct(float *e, const float *direct, size_t n, int replace);
int add_probe_light(lrr_context *ctx, const lrr_operator *op, const probe_args *p, float *e,
                    double *seconds);

/* A solve must never hand back NaN or Inf silently; the tool double-checks. */
int check_finite(const float *b, size_t n);

/* Room for lrr_solver_kernel's name, copied before the solver goes ("opencl:<device>"). */
#define KERNEL_NAME_MAX 160

/* What timed_solve's solver was: its kernel variant and how it read F̄. */
typedef struct solver_report {
    char kernel[KERNEL_NAME_MAX];
    lrr_solver_info info;
} solver_report;
/* Times `repeat` solves of the same emission on the given backend and path, F̄ read as fbar
 * says and M as m says (an lrr_storage, or SOLVE_M_AUTO: the solver's choice), after one
 * warm-up, and reports the path the last one took and the solver (report may be NULL). */
#define SOLVE_M_AUTO (-1)
int timed_solve(lrr_context *ctx, const lrr_operator *op, lrr_backend backend,
                lrr_fbar_format fbar, int m, const float *e, float *b, unsigned repeat,
                lrr_path path, double *median_ms, lrr_path *used, solver_report *report);
/* render's and export's solve: loads *op from file and solves once on the CPU for its stored
 * emission × scale plus the direct light of pa's probe and --light sources (or that light
 * alone with --no-scene-emission) into *b (n×3, freed by the caller; also on failure). */
int solve_lit(lrr_context *ctx, const char *file, double scale, const probe_args *pa,
              lrr_operator **op, float **b);

/* mean_b_r/g/b (area-weighted; plain means without areas) and max_b of n subpatches. */
void print_radiosity_summary(size_t n, const float *area, const float *b);
void print_solution_summary(const lrr_operator *op, const float *b);

#endif /* LRR_COMMANDS_H */
