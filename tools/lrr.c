/*
 * lrr — command-line front end of the Low-Rank Radiosity library.
 *
 *   lrr info SCENE        scene statistics after subdivision
 *   lrr preprocess SCENE  build and save the operator (F̄, M_c)
 *   lrr solve FILE.lrr    solve for the stored emission, time it, write a CSV
 *   lrr render FILE.lrr   solve and draw a PNG
 *   lrr reference SCENE   the full n×n form factors and a classic solver, for comparison
 *   lrr compare A B       error measures of one radiosity CSV against another
 *   lrr demo              the Cornell box from start to picture
 *   lrr probe PROBE       fit lights or SH9 to a light probe and measure the irradiance error
 *
 * Exit status: 0 success, 1 a failure while working (library error, I/O), 2 a malformed
 * command line, 3 a reference solve that did not converge. Uses only the public API (lrr.h).
 */
#include <errno.h>
#include <float.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "cli.h"
#include "lrr.h"

/* Defaults when no subdivision option is given (documented in the help texts). */
#define DEFAULT_PATCHES 216
#define DEFAULT_LEVELS 2u
#define DEFAULT_HEMICUBE 128u
#define DEFAULT_SEED 1u
#define DEFAULT_REPEAT 10u
#define DEFAULT_TOL 1e-6
#define DEFAULT_BUDGET_MB 4096u

/* lrr preprocess warns when cond × FLT_EPSILON exceeds this: M_c is stored in float, so a
 * larger condition number leaves less than ~0.1% of accuracy in the solution. */
#define COND_WARN_ERROR 1e-3

/* Set by lrr_cli_main: each command returns CLI_EXIT_OK right after its command line has
 * been parsed and checked, before it touches a file or does any work (see cli.h). */
static int parse_only;

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
    OPT_EMISSION_SCALE,
    OPT_REPEAT,
    OPT_PATH,
    OPT_BACKEND,
    OPT_STORAGE,
    OPT_WIDTH,
    OPT_HEIGHT,
    OPT_EXPOSURE,
    OPT_CAMERA,
    OPT_OUT,
    OPT_METHOD,
    OPT_TOL,
    OPT_MAX_ITERATIONS,
    OPT_MEMORY_BUDGET,
    OPT_SOURCES,
    OPT_NORMALS,
    OPT_JSON,
    OPT_LIGHTS,
    OPT_PROBE,
    OPT_PROBE_METHOD,
    OPT_PROBE_SCALE,
    OPT_NO_SCENE_EMISSION,
    OPT_ADAPTIVE,
    OPT_ADAPTIVE_SAMPLES,
    OPT_ADAPTIVE_SPLIT
};

/* ------------------------------------------------------------------ help texts */
static const char main_help[] =
    "Usage: lrr COMMAND [OPTIONS]\n"
    "Low-Rank Radiosity: preprocess a diffuse scene once, then solve for any emission.\n"
    "\n"
    "Commands:\n"
    "  info SCENE           scene statistics after subdivision\n"
    "  check SCENE          the scene doctor: degenerate, intersecting, z-fighting, flipped faces\n"
    "  preprocess SCENE     build the operator and save it to an .lrr file\n"
    "  solve FILE.lrr       solve for the stored emission, time it, optionally write a CSV\n"
    "  render FILE.lrr      solve and draw a PNG\n"
    "  reference SCENE      full n×n form factors and a classic solver, to measure against\n"
    "  compare A.csv B.csv  errors of the radiosity in A against the reference B\n"
    "  demo                 the Cornell box from scene to picture\n"
    "  probe PROBE.hdr      fit lights (median cut) or SH9 to a light probe, measure errors\n"
    "\n"
    "Options:\n"
    "  -h, --help           show this help (COMMAND --help: help on a command)\n"
    "  -V, --version        print the library version\n"
    "\n"
    "Exit status: 0 success, 1 failure, 2 bad command line, 3 a reference solve that did\n"
    "not converge.\n";

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

static const char info_help[] =
    "Usage: lrr info SCENE [OPTIONS]\n"
    "Prints scene statistics as 'key: value' lines (scene, triangles, skipped, patches,\n"
    "subpatches, d, area, emitters, max_patch_area, bounds_min, bounds_max).\n"
    "\n" SCENE_HELP "\n" SUBDIV_HELP "  -h, --help           show this help\n";

#define BUILD_HELP                                                                            \
    "  --hemicube R         hemicube resolution: even, 8..4096 (default 128)\n"                \
    "  --seed S             seed of the random hemicube rotations (default 1)\n"               \
    "  --no-rotation        no random rotation: every hemicube in the same tangent frame\n"     \
    "  --threads T          OpenMP threads, 0 = OpenMP's default (default 0)\n"                \
    "  --progress           draw a progress bar on stderr even when it is not a terminal\n"

#define OPERATOR_BUDGET_HELP                                                                  \
    "  --memory-budget MB   the most memory the build may hold, in MiB: F̄, M, the\n"          \
    "                       per-subpatch data and the hemicube buffers of every thread\n"     \
    "                       (default: the machine's physical memory; 0 = no limit). A larger\n" \
    "                       build is refused before it starts, naming the MiB it needs\n"

static const char preprocess_help[] =
    "Usage: lrr preprocess SCENE -o FILE.lrr [OPTIONS]\n"
    "Builds the low-rank operator (hemicube form factors F̄ and the k×k matrices M_c) and\n"
    "saves it atomically. Prints 'key: value' lines: n, k, d, hemicube, seed,\n"
    "build_seconds, cond_r, cond_g, cond_b, storage, memory_mb, backend, output. Warns on\n"
    "stderr when a condition estimate is so large (cond × FLT_EPSILON > 1e-3) that M_c,\n"
    "stored in single precision, may not carry the solution to 0.1%.\n"
    "\n" SCENE_HELP "\n"
    "Options:\n"
    "  -o, --output FILE    where to write the operator (required)\n"
    "  --storage S          f32 (default), f16 or bf16: how F̄ is stored. 16-bit halves the\n"
    "                       file, the memory and the bytes each frame reads; f16 rows carry\n"
    "                       a power-of-two scale, and M is recomputed from the rounded F̄\n"
    "  --backend B          cpu (default) or opencl: where the hemicube pixels are integrated\n"
    "                       into F̄ (rasterisation stays on the CPU; LRR_OPENCL_DEVICE picks\n"
    "                       the device as for 'lrr solve'; the same F̄ to rounding)\n"
    "  --adaptive K         adaptive hierarchy: the scene's patches (--levels 0, the default\n"
    "                       with --adaptive) become\n"
    "                       the subpatches and are regrouped into at most K patches, nodes\n"
    "                       of each triangle's quadtree, splitting first where the sampled\n"
    "                       form-factor columns vary most (shadow edges, contacts, corners).\n"
    "                       K is between the triangle count and the subpatch count; the\n"
    "                       count reached can be up to 2 less (a split adds 3). Prints\n"
    "                       d_min, d_max and selection_seconds (part of build_seconds)\n"
    "  --adaptive-samples S receivers sampled to estimate the variance (default 2048,\n"
    "                       rendered at a quarter of the hemicube resolution)\n"
    "  --adaptive-split X   variance (default) or area: area splits the largest patch first,\n"
    "                       i.e. uniform subdivision at the same K (the baseline)\n" BUILD_HELP
    OPERATOR_BUDGET_HELP
    "  -h, --help           show this help\n" SUBDIV_HELP;

static const char solve_help[] =
    "Usage: lrr solve FILE.lrr [OPTIONS]\n"
    "Solves B = E + rho ∘ (F̄ (M (Vᵀ E))) on the CPU (or an OpenCL device, --backend) for\n"
    "the emission stored in the file and prints n, k, d, solve_ms (median of the timed runs,\n"
    "after one warm-up run), mean_b_r, mean_b_g, mean_b_b (area-weighted mean radiosity)\n"
    "and max_b.\n"
    "\n"
    "Options:\n"
    "  --csv OUT.csv        write one row per subpatch:\n"
    "                       subpatch,patch,area,cx,cy,cz,nx,ny,nz,b_r,b_g,b_b\n"
    "  --emission-scale S   multiply the stored emission by S (finite, >= 0; default 1)\n"
    "  --repeat N           number of timed runs (1..1000000, default 10)\n"
    "  --path P             auto, full (default), sparse or incremental: which real-time\n"
    "                       path to time (see lrr_solver_set_path). auto picks per frame;\n"
    "                       repeating one emission then takes the incremental path with\n"
    "                       nothing changed, so its time is bookkeeping only\n"
    "  --backend B          cpu (default) or opencl: solve on an OpenCL device (the first\n"
    "                       GPU, else the first CPU device; the environment variable\n"
    "                       LRR_OPENCL_DEVICE picks another, by index P:D or by a part of\n"
    "                       \"platform / device\" name). Every OpenCL frame is a full pass\n"
    "  --probe PROBE        light the scene with a latitude-longitude probe (.hdr, +y up,\n"
    "                       at infinity): its fitted directional lights give the reflected\n"
    "                       direct light E_i = rho_i sum_l I_l max(0, n_i.w_l) visible(x_i, w_l)\n"
    "                       (shadows by Embree occlusion rays), added to the stored emission\n"
    "  --sources N          --probe: number of lights (1..65536, default 16)\n"
    "  --probe-method M     --probe: irradiance (default; fitted by Levenberg-Marquardt) or\n"
    "                       median-cut\n"
    "  --probe-scale S      --probe: multiply the lights by S (finite, >= 0; default 1)\n"
    "  --no-scene-emission  --probe: leave out the stored emission (probe light only)\n"
    "  -h, --help           show this help\n"
    "Also prints storage (of F̄), backend, path (that the last run took) and kernel (the\n"
    "SIMD variant, whose choice the environment variable LRR_SIMD=c|avx2|avx512 forces, or\n"
    "opencl:<device name>); with --probe also probe, sources and direct_light_seconds (the\n"
    "shadow rays).\n";

static const char reference_help[] =
    "Usage: lrr reference SCENE --method M [OPTIONS]\n"
    "Builds the full n×n subpatch-to-subpatch form-factor matrix F from the same hemicubes\n"
    "as 'lrr preprocess' with the same options, and solves (I − R F) B = E for the scene's\n"
    "emission with a classic method, to measure the low-rank operator against (see\n"
    "'lrr compare'). Prints 'key: value' lines: n, method, iterations, residual\n"
    "(max over channels of ||E − (I − R F) B|| / ||E||), build_seconds, solve_seconds,\n"
    "mean_b_r, mean_b_g, mean_b_b (area-weighted mean radiosity), max_b.\n"
    "\n" SCENE_HELP "\n"
    "Options:\n"
    "  --method M           jacobi, gauss-seidel, southwell (progressive refinement) or\n"
    "                       direct (LU of I − R F per channel) (required)\n"
    "  --tol T              relative residual at which the iterative methods stop\n"
    "                       (1e-13 <= T < 1, default 1e-6; the direct method ignores it)\n"
    "  --max-iterations N   most sweeps (shots for southwell); 0 = the library's default,\n"
    "                       enough for reflectances up to 0.999 (default 0)\n"
    "  --memory-budget MB   the most memory F may take, in MiB (default 4096); the direct\n"
    "                       method counts its 8·n² bytes of LU too. Larger scenes are\n"
    "                       refused before anything is computed.\n"
    "  --csv OUT.csv        write one row per subpatch, the columns of 'lrr solve --csv':\n"
    "                       " CLI_CSV_HEADER "\n" BUILD_HELP
    "  -h, --help           show this help\n" SUBDIV_HELP
    "\n"
    "Exit status: 0 success, 1 failure, 2 bad command line, 3 the iterative method stopped\n"
    "at --max-iterations before --tol (a warning names the iterations and the residual; the\n"
    "results, and the CSV, are those of the last iterate).\n";

static const char compare_help[] =
    "Usage: lrr compare A.csv B.csv\n"
    "Compares the radiosity in A with the reference B, both written by 'lrr solve --csv' or\n"
    "'lrr reference --csv' for the same subdivision (same rows, same order, same areas).\n"
    "Prints 'key: value' lines, area-weighted with B's areas a_i, ΔB = B_A − B_B:\n"
    "  n                    subpatches\n"
    "  rel_l2               sqrt(Σ_i a_i Σ_c ΔB_ic²) / sqrt(Σ_i a_i Σ_c B_ic²)\n"
    "  max_rel              max |ΔB_ic| / |B_ic| over the entries with |B_ic| > 1e-3 max |B|\n"
    "  max_rel_subpatch     the subpatch where max_rel occurs ('none' if B is all zero)\n"
    "  mean_abs             Σ_i a_i Σ_c |ΔB_ic| / (3 Σ_i a_i)\n"
    "  rel_l2_r, rel_l2_g, rel_l2_b, max_rel_r, max_rel_g, max_rel_b, mean_abs_r,\n"
    "  mean_abs_g, mean_abs_b  the same per channel (max_rel_c with the same threshold)\n"
    "\n"
    "Options:\n"
    "  -h, --help           show this help\n"
    "\n"
    "Exit status: 0 success, 1 a file that cannot be read or parsed (the message names the\n"
    "file and line) or files of different subdivisions, 2 bad command line.\n";

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

static const char probe_help[] =
    "Usage: lrr probe PROBE.hdr [OPTIONS]\n"
    "Loads a latitude-longitude light probe (Radiance .hdr, width = 2 x height, row 0 the\n"
    "zenith), fits it, and compares the fit's irradiance with the ground truth\n"
    "E(n) = sum Q max(0, n.w) (Q = radiance x pixel solid angle) on M normals of a\n"
    "Fibonacci sphere. Prints 'key: value' lines: probe, width, height, method, sources,\n"
    "normals, iterations, seconds (the fit), truth_seconds (the ground truth),\n"
    "mean_error_pct and max_error_pct (mean and max over normals and RGB of\n"
    "|approx - truth| / truth in percent, over entries with truth > 1e-6 x the largest).\n"
    "\n"
    "Options:\n"
    "  --method M           median-cut (default), sh9 (order-2 spherical harmonics, 9\n"
    "                       coefficients per channel) or irradiance (lights fitted by\n"
    "                       Levenberg-Marquardt to the irradiance on the M normals, started\n"
    "                       from median cut; iterations = accepted LM steps)\n"
    "  --sources N          lights for median-cut and irradiance (default 16; a power of two\n"
    "                       is the classic cut, other counts the adaptive variant)\n"
    "  --max-iterations K   irradiance: most LM steps (0 = the library's default, 300)\n"
    "  --normals M          normals to measure on (default 1024)\n"
    "  --lights OUT.csv     write the lights: x,y,z,r,g,b (direction towards the light,\n"
    "                       radiance x solid angle); median-cut and irradiance\n"
    "  --json               print one JSON object on one line instead\n"
    "  -h, --help           show this help\n";

/* ------------------------------------------------------------------ option parsing */
/* Reports the option getopt_long rejected (it is told to stay quiet: the optstring starts
 * with ':' and opterr = 0) and returns the usage exit status. */
static int bad_option(const char *prog, int c, char *const argv[])
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
    {"no-rotation", no_argument, NULL, OPT_NO_ROTATION}

static void start_getopt(void)
{
    opterr = 0;
    optind = 0; /* glibc: 0 re-initialises the scanner completely */
}

typedef struct subdiv_args {
    lrr_subdivision sub;
    int have_area, have_patches, have_levels;
} subdiv_args;

static void subdiv_init(subdiv_args *s)
{
    memset(s, 0, sizeof *s);
    s->sub.levels = DEFAULT_LEVELS;
}

/* Returns 1 if c was a subdivision option, 0 if not, -1 on a bad value. */
static int subdiv_option(subdiv_args *s, const char *prog, int c, const char *arg)
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

/* Checks the combination and fills in the default. Returns 0 or the usage exit status. */
static int subdiv_finish(subdiv_args *s, const char *prog)
{
    if (s->have_area && s->have_patches) {
        cli_usage_error(prog, "--max-patch-area and --patches exclude each other");
        return CLI_EXIT_USAGE;
    }
    if (!s->have_area && !s->have_patches)
        s->sub.target_patches = DEFAULT_PATCHES;
    return 0;
}

/* Options of the hemicube build, shared by preprocess and reference. */
typedef struct build_args {
    unsigned hemicube, threads;
    uint64_t seed;
    int force_progress;
    int no_rotation;
} build_args;

static void build_init(build_args *b)
{
    b->hemicube = DEFAULT_HEMICUBE;
    b->threads = 0;
    b->seed = DEFAULT_SEED;
    b->force_progress = 0;
    b->no_rotation = 0;
}

/* Returns 1 if c was a build option, 0 if not, -1 on a bad value. */
static int build_option(build_args *b, const char *prog, int c, const char *arg)
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
    default:
        return 0;
    }
}

/* The library's options, with a progress bar (drawn on a terminal or with --progress). */
static lrr_build_options build_start(const build_args *b, cli_progress *bar)
{
    cli_progress_init(bar, "hemicubes", b->force_progress || isatty(STDERR_FILENO));
    lrr_build_options bo = {.hemicube_resolution = b->hemicube,
                            .seed = b->seed,
                            .threads = (int)b->threads,
                            .progress = cli_progress_cb,
                            .progress_user = bar,
                            .no_rotation = b->no_rotation};
    return bo;
}

/* Takes exactly one positional argument; returns it or NULL after a usage message. */
static const char *one_positional(const char *prog, const char *what, int argc,
                                  char *const argv[])
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

/* ------------------------------------------------------------------ shared steps */
static int is_builtin(const char *name)
{
    return strcmp(name, "cornell") == 0 || strcmp(name, "cornell-closed") == 0;
}

/* A file wins over a built-in name, so a scene file called "cornell" stays reachable. */
static int open_scene(lrr_context *ctx, const char *name, lrr_scene **scene)
{
    struct stat st;
    lrr_status s;
    if (stat(name, &st) == 0) {
        s = lrr_scene_load(ctx, name, scene);
    } else if (is_builtin(name)) {
        s = lrr_scene_builtin(ctx, name, scene);
    } else {
        return cli_fail(LRR_ERR_IO, "scene '%s': %s (built-in scenes: cornell, cornell-closed)",
                        name, strerror(errno));
    }
    return s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, s);
}

static int open_subdivided_scene(lrr_context *ctx, const char *name, const subdiv_args *sa,
                                 lrr_scene **scene)
{
    int rc = open_scene(ctx, name, scene);
    if (rc != CLI_EXIT_OK)
        return rc;
    lrr_status s = lrr_scene_subdivide(*scene, &sa->sub);
    if (s != LRR_OK) {
        rc = cli_lib_error(ctx, s);
        lrr_scene_destroy(*scene);
        *scene = NULL;
        return rc;
    }
    return CLI_EXIT_OK;
}

static void print_scene_info(const char *name, const lrr_scene *scene)
{
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si);
    printf("scene: %s\n", name);
    printf("triangles: %zu\n", si.triangles);
    printf("skipped: %zu\n", si.skipped);
    printf("patches: %zu\n", si.patches);
    printf("subpatches: %zu\n", si.subpatches);
    printf("d: %zu\n", si.d);
    printf("area: %.9g\n", si.area);
    printf("emitters: %zu\n", si.emitters);
    printf("max_patch_area: %.9g\n", si.max_patch_area);
    printf("bounds_min: %.9g %.9g %.9g\n", si.bounds_min[0], si.bounds_min[1],
           si.bounds_min[2]);
    printf("bounds_max: %.9g %.9g %.9g\n", si.bounds_max[0], si.bounds_max[1],
           si.bounds_max[2]);
}

/* The default of --memory-budget for operator builds: the machine's physical memory (a build
 * beyond it would only swap or be killed), 0 (no limit) where sysconf cannot tell. */
static size_t physical_memory_bytes(void)
{
    long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    size_t bytes;
    if (pages <= 0 || page <= 0 ||
        __builtin_mul_overflow((size_t)pages, (size_t)page, &bytes))
        return 0;
    return bytes;
}

/* --memory-budget MB of preprocess and demo: 0 = no limit. */
static int parse_operator_budget(const char *prog, const char *arg, size_t *bytes)
{
    size_t mb;
    if (cli_parse_size(prog, "--memory-budget", arg, 0, SIZE_MAX >> 20, &mb) != 0)
        return -1;
    *bytes = mb << 20;
    return 0;
}

/* After lrr_operator_build refused with LRR_ERR_BUDGET: how to get past it. */
static void budget_hint(const char *prog, size_t budget)
{
    fprintf(stderr, "%s: --memory-budget is %zu MiB (default: physical memory): raise it, "
                    "or use fewer patches, levels or threads\n", prog, budget >> 20);
}

static void print_operator_info(const lrr_operator *op)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    printf("n: %zu\n", oi.n);
    printf("k: %zu\n", oi.k);
    printf("d: %zu\n", oi.d);
    if (oi.d == 0) { /* adaptive hierarchy */
        printf("d_min: %zu\n", oi.d_min);
        printf("d_max: %zu\n", oi.d_max);
        printf("selection_seconds: %.3f\n", oi.selection_seconds);
    }
    printf("hemicube: %u\n", oi.hemicube_resolution);
    printf("seed: %llu\n", (unsigned long long)oi.seed);
    printf("build_seconds: %.3f\n", oi.build_seconds);
    printf("cond_r: %.6g\n", oi.condition[0]);
    printf("cond_g: %.6g\n", oi.condition[1]);
    printf("cond_b: %.6g\n", oi.condition[2]);
    printf("storage: %s\n", lrr_storage_name(oi.storage));
    printf("memory_mb: %.3f\n", (double)oi.bytes / (1024.0 * 1024.0));
}

/* Fails early when the directory of an output file cannot be written, so a long build is
 * not thrown away at the save. */
static int check_writable_dir(const char *path)
{
    const char *slash = strrchr(path, '/');
    char *dir = slash ? strndup(path, slash == path ? 1 : (size_t)(slash - path)) : strdup(".");
    if (!dir)
        return cli_fail(LRR_ERR_NOMEM, "cannot copy the path '%s'", path);
    int rc = CLI_EXIT_OK;
    if (access(dir, W_OK | X_OK) != 0)
        rc = cli_fail(LRR_ERR_IO, "cannot write '%s': directory '%s': %s", path, dir,
                      strerror(errno));
    free(dir);
    return rc;
}

static int load_operator(lrr_context *ctx, const char *path, lrr_operator **op)
{
    lrr_status s = lrr_operator_load(ctx, path, op);
    return s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, s);
}

/* E = S × (stored emission); fails if scaling makes a value overflow to infinity. */
static int scaled_emission(const lrr_operator *op, double scale, float **out)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    const float *e0 = lrr_operator_emission(op);
    if (!e0)
        return cli_fail(LRR_ERR_INVALID_ARG, "the operator has no stored emission");
    float *e = cli_alloc_rgb(oi.n);
    if (!e)
        return CLI_EXIT_FAIL;
    for (size_t i = 0; i < 3 * oi.n; i++) {
        e[i] = (float)((double)e0[i] * scale);
        if (!isfinite(e[i])) {
            free(e);
            return cli_fail(LRR_ERR_INVALID_ARG,
                            "--emission-scale %g: the emission of subpatch %zu overflows", scale,
                            i / 3);
        }
    }
    *out = e;
    return CLI_EXIT_OK;
}

/* A solve must never hand back NaN or Inf silently; the tool double-checks. */
static int check_finite(const float *b, size_t n)
{
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(b[i])) {
            fprintf(stderr, "lrr: the radiosity of subpatch %zu is not finite (%g)\n", i / 3,
                    (double)b[i]);
            return CLI_EXIT_FAIL;
        }
    return CLI_EXIT_OK;
}

/* Solves once to warm up, then `repeat` timed runs; *median_ms gets their median. */
static const char *const path_names[] = {"auto", "full", "sparse", "incremental"};

static int parse_path(const char *prog, const char *arg, lrr_path *out)
{
    for (int i = 0; i < 4; i++)
        if (strcmp(arg, path_names[i]) == 0) {
            *out = (lrr_path)i;
            return 0;
        }
    cli_usage_error(prog, "--path: '%s' is not one of auto, full, sparse, incremental", arg);
    return -1;
}

/* Room for lrr_solver_kernel's name, copied before the solver goes ("opencl:<device>"). */
#define KERNEL_NAME_MAX 160

/* Times `repeat` solves of the same emission on the given backend and path after one
 * warm-up, and reports the path the last one took and the kernel variant (kernel has
 * KERNEL_NAME_MAX bytes, or is NULL). */
static int timed_solve(lrr_context *ctx, const lrr_operator *op, lrr_backend backend,
                       const float *e, float *b, unsigned repeat, lrr_path path,
                       double *median_ms, lrr_path *used, char *kernel)
{
    lrr_solver *solver = NULL;
    lrr_status s = lrr_solver_create(op, backend, &solver);
    if (s == LRR_OK)
        s = lrr_solver_set_path(solver, path);
    if (s != LRR_OK) {
        lrr_solver_destroy(solver);
        return cli_lib_error(ctx, s);
    }
    double *t = calloc(repeat ? repeat : 1, sizeof *t);
    if (!t) {
        lrr_solver_destroy(solver);
        return cli_fail(LRR_ERR_NOMEM, "cannot allocate %u timings", repeat);
    }
    s = lrr_solve(solver, e, b);
    for (unsigned r = 0; s == LRR_OK && r < repeat; r++) {
        double t0 = cli_now();
        s = lrr_solve(solver, e, b);
        t[r] = 1e3 * (cli_now() - t0);
    }
    if (used)
        *used = lrr_solver_last_path(solver);
    if (kernel)
        snprintf(kernel, KERNEL_NAME_MAX, "%s", lrr_solver_kernel(solver));
    lrr_solver_destroy(solver);
    if (s != LRR_OK) {
        free(t);
        return cli_lib_error(ctx, s);
    }
    *median_ms = repeat ? cli_median(t, repeat) : 0.0;
    free(t);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    return check_finite(b, oi.n);
}

/* mean_b_r/g/b (area-weighted; plain means without areas) and max_b of n subpatches. */
static void print_radiosity_summary(size_t n, const float *area, const float *b)
{
    double sum[3] = {0, 0, 0}, total = 0.0, maxb = 0.0;
    for (size_t i = 0; i < n; i++) {
        double a = area ? (double)area[i] : 1.0;
        total += a;
        for (int c = 0; c < 3; c++) {
            sum[c] += a * (double)b[3 * i + c];
            if (b[3 * i + c] > maxb)
                maxb = b[3 * i + c];
        }
    }
    static const char ch[3] = {'r', 'g', 'b'};
    for (int c = 0; c < 3; c++)
        printf("mean_b_%c: %.9g\n", ch[c], total > 0 ? sum[c] / total : 0.0);
    printf("max_b: %.9g\n", maxb);
}

static void print_solution_summary(const lrr_operator *op, const float *b)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    print_radiosity_summary(oi.n, lrr_operator_area(op), b);
}

/* M_c is stored in float: a condition number κ costs about log10(κ) of its ~7 digits. */
static void warn_condition(const lrr_operator *op)
{
    static const char ch[3] = {'r', 'g', 'b'};
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    for (int c = 0; c < 3; c++) {
        double cond = oi.condition[c];
        if (!(cond * FLT_EPSILON > COND_WARN_ERROR))
            continue;
        fprintf(stderr,
                "lrr: warning: condition estimate %.3g of channel %c: single-precision M_%c may "
                "lose about %.1f of its %.1f significant digits (relative error up to ~%.2g)\n",
                cond, ch[c], ch[c], log10(cond), -log10((double)FLT_EPSILON),
                cond * FLT_EPSILON);
    }
}

/* ------------------------------------------------------------------ lrr info */
static int cmd_info(int argc, char *argv[])
{
    static const char prog[] = "lrr info";
    static const struct option longopts[] = {SUBDIV_LONGOPTS,
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    subdiv_args sa;
    subdiv_init(&sa);
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        int r = subdiv_option(&sa, prog, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r > 0)
            continue;
        if (c == 'h') {
            fputs(info_help, stdout);
            return CLI_EXIT_OK;
        }
        return bad_option(prog, c, argv);
    }
    const char *name = one_positional(prog, "SCENE", argc, argv);
    if (!name)
        return CLI_EXIT_USAGE;
    int rc = subdiv_finish(&sa, prog);
    if (rc)
        return rc;

    if (parse_only)
        return CLI_EXIT_OK;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_scene *scene = NULL;
    rc = open_subdivided_scene(ctx, name, &sa, &scene);
    if (rc == CLI_EXIT_OK)
        print_scene_info(name, scene);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}

/* ------------------------------------------------------------------ lrr preprocess */
static int cmd_preprocess(int argc, char *argv[])
{
    static const char prog[] = "lrr preprocess";
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'},
        {"storage", required_argument, NULL, OPT_STORAGE},
        {"backend", required_argument, NULL, OPT_BACKEND},
        {"adaptive", required_argument, NULL, OPT_ADAPTIVE},
        {"adaptive-samples", required_argument, NULL, OPT_ADAPTIVE_SAMPLES},
        {"adaptive-split", required_argument, NULL, OPT_ADAPTIVE_SPLIT},
        {"memory-budget", required_argument, NULL, OPT_MEMORY_BUDGET},
        SUBDIV_LONGOPTS,
        BUILD_LONGOPTS,
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    int on_device = 0;
    size_t adaptive = 0, adaptive_samples = 0;
    int adaptive_split = LRR_SPLIT_VARIANCE, adaptive_only = 0;
    size_t budget = physical_memory_bytes();
    subdiv_args sa;
    subdiv_init(&sa);
    build_args ba;
    build_init(&ba);
    const char *output = NULL;
    lrr_storage storage = LRR_STORAGE_F32;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        if (c == OPT_STORAGE) {
            if (lrr_storage_from_name(optarg, &storage) != LRR_OK) {
                cli_usage_error(prog, "--storage: '%s' is not one of f32, f16, bf16", optarg);
                return CLI_EXIT_USAGE;
            }
            continue;
        }
        if (c == OPT_BACKEND) {
            lrr_backend b;
            if (cli_parse_backend(prog, optarg, &b) != 0)
                return CLI_EXIT_USAGE;
            on_device = b == LRR_BACKEND_OPENCL;
            continue;
        }
        if (c == OPT_ADAPTIVE) {
            if (cli_parse_size(prog, "--adaptive", optarg, 1, SIZE_MAX, &adaptive) != 0)
                return CLI_EXIT_USAGE;
            continue;
        }
        if (c == OPT_ADAPTIVE_SAMPLES) {
            adaptive_only = 1;
            if (cli_parse_size(prog, "--adaptive-samples", optarg, 1, (size_t)1 << 20,
                               &adaptive_samples) != 0)
                return CLI_EXIT_USAGE;
            continue;
        }
        if (c == OPT_ADAPTIVE_SPLIT) {
            adaptive_only = 1;
            if (strcmp(optarg, "variance") == 0)
                adaptive_split = LRR_SPLIT_VARIANCE;
            else if (strcmp(optarg, "area") == 0)
                adaptive_split = LRR_SPLIT_AREA;
            else {
                cli_usage_error(prog, "--adaptive-split: '%s' is not variance or area", optarg);
                return CLI_EXIT_USAGE;
            }
            continue;
        }
        if (c == OPT_MEMORY_BUDGET) {
            if (parse_operator_budget(prog, optarg, &budget) != 0)
                return CLI_EXIT_USAGE;
            continue;
        }
        int r = subdiv_option(&sa, prog, c, optarg);
        if (r == 0)
            r = build_option(&ba, prog, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r > 0)
            continue;
        switch (c) {
        case 'h':
            fputs(preprocess_help, stdout);
            return CLI_EXIT_OK;
        case 'o':
            output = optarg;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    const char *name = one_positional(prog, "SCENE", argc, argv);
    if (!name)
        return CLI_EXIT_USAGE;
    if (!output || !output[0]) {
        cli_usage_error(prog, "-o FILE.lrr is required");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    int rc = subdiv_finish(&sa, prog);
    if (rc)
        return rc;
    if (adaptive_only && !adaptive) {
        cli_usage_error(prog, "--adaptive-samples and --adaptive-split need --adaptive K");
        return CLI_EXIT_USAGE;
    }
    if (adaptive && !sa.have_levels)
        sa.sub.levels = 0;
    if (adaptive && sa.sub.levels != 0) {
        cli_usage_error(prog, "--adaptive: the patches become the subpatches, so give "
                              "--levels 0 (not %u)", sa.sub.levels);
        return CLI_EXIT_USAGE;
    }

    if (parse_only)
        return CLI_EXIT_OK;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    rc = check_writable_dir(output);
    if (rc == CLI_EXIT_OK)
        rc = open_subdivided_scene(ctx, name, &sa, &scene);
    if (rc == CLI_EXIT_OK) {
        lrr_scene_info si;
        lrr_scene_get_info(scene, &si);
        if (si.skipped)
            fprintf(stderr, "lrr preprocess: note: %zu zero-area triangle(s) skipped; "
                            "'lrr check %s' reports them and more\n", si.skipped, name);
    }
    if (rc == CLI_EXIT_OK) {
        cli_progress bar;
        lrr_build_options bo = build_start(&ba, &bar);
        bo.backend = on_device ? LRR_BACKEND_OPENCL : LRR_BACKEND_CPU;
        bo.adaptive_patches = adaptive;
        bo.adaptive_samples = adaptive_samples;
        bo.adaptive_split = adaptive_split;
        bo.memory_budget = budget;
        s = lrr_operator_build(scene, &bo, &op);
        cli_progress_finish(&bar);
        if (s == LRR_ERR_BUDGET) {
            rc = cli_lib_error(ctx, s);
            budget_hint(prog, budget);
            s = LRR_OK;
        }
        if (s == LRR_OK && op)
            s = lrr_operator_set_storage(op, storage);
        if (s == LRR_OK && op) {
            warn_condition(op);
            s = lrr_operator_save(op, output);
        }
        if (s != LRR_OK)
            rc = cli_lib_error(ctx, s);
    }
    if (rc == CLI_EXIT_OK) {
        print_operator_info(op);
        printf("backend: %s\n", on_device ? "opencl" : "cpu");
        printf("output: %s\n", output);
    }
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}

/* ------------------------------------------------------------------ probe lighting */
#define PROBE_DEFAULT_SOURCES 16u
#define PROBE_DEFAULT_NORMALS 1024u

typedef struct probe_args {
    const char *path;        /* --probe; NULL: none */
    size_t sources;
    int median_cut;          /* --probe-method median-cut */
    double scale;            /* --probe-scale */
    int no_scene_emission;
    int probe_only_given;    /* an option that needs --probe was given */
} probe_args;

#define PROBE_LONGOPTS                                                                         \
    {"probe", required_argument, NULL, OPT_PROBE},                                            \
    {"sources", required_argument, NULL, OPT_SOURCES},                                        \
    {"probe-method", required_argument, NULL, OPT_PROBE_METHOD},                              \
    {"probe-scale", required_argument, NULL, OPT_PROBE_SCALE},                                \
    {"no-scene-emission", no_argument, NULL, OPT_NO_SCENE_EMISSION}

static void probe_args_init(probe_args *p)
{
    *p = (probe_args){NULL, PROBE_DEFAULT_SOURCES, 0, 1.0, 0, 0};
}

/* 1: handled, 0: not a probe option, -1: usage error (reported). */
static int probe_option(probe_args *p, const char *prog, int c, const char *arg)
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
        p->probe_only_given = 1;
        p->no_scene_emission = 1;
        return 1;
    default:
        return 0;
    }
}

static int probe_finish(const probe_args *p, const char *prog)
{
    if (p->path && !p->path[0]) {
        cli_usage_error(prog, "--probe: the file name is empty");
        return -1;
    }
    if (!p->path && p->probe_only_given) {
        cli_usage_error(prog,
                        "--sources, --probe-method, --probe-scale and --no-scene-emission "
                        "need --probe");
        return -1;
    }
    return 0;
}

/* e (n×3, the scaled stored emission) += the probe's direct light, or = it with
 * --no-scene-emission; *seconds the time of lrr_probe_direct_light. */
static int add_probe_light(lrr_context *ctx, const lrr_operator *op, const probe_args *p,
                           float *e, double *seconds)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
    lrr_probe *probe = NULL;
    lrr_light *lights = calloc(p->sources, sizeof *lights);
    float *direct = cli_alloc_rgb(oi.n);
    int rc = CLI_EXIT_OK;
    lrr_status st = lights && direct ? lrr_probe_load(ctx, p->path, &probe) : LRR_ERR_NOMEM;
    if (st == LRR_OK) {
        if (p->median_cut) {
            st = lrr_probe_median_cut(probe, p->sources, lights);
        } else {
            lrr_fit_stats fs;
            st = lrr_probe_fit_irradiance(probe, p->sources, PROBE_DEFAULT_NORMALS, NULL, lights,
                                          &fs);
        }
    }
    if (st == LRR_OK) {
        for (size_t l = 0; l < p->sources; l++)
            for (int c = 0; c < 3; c++)
                lights[l].rgb[c] = (float)(lights[l].rgb[c] * p->scale);
        double t0 = cli_now();
        st = lrr_probe_direct_light(op, lights, p->sources, direct);
        *seconds = cli_now() - t0;
    }
    if (st != LRR_OK) {
        rc = cli_lib_error(st == LRR_ERR_NOMEM && !probe ? NULL : ctx, st);
    } else {
        for (size_t i = 0; i < 3 * oi.n; i++) {
            e[i] = p->no_scene_emission ? direct[i] : e[i] + direct[i];
            if (!isfinite(e[i])) {
                rc = cli_fail(LRR_ERR_INVALID_ARG,
                              "--probe-scale %g: the emission of subpatch %zu overflows",
                              p->scale, i / 3);
                break;
            }
        }
    }
    free(direct);
    free(lights);
    lrr_probe_destroy(probe);
    return rc;
}

/* ------------------------------------------------------------------ lrr solve */
static int cmd_solve(int argc, char *argv[])
{
    static const char prog[] = "lrr solve";
    static const struct option longopts[] = {
        {"csv", required_argument, NULL, OPT_CSV},
        {"emission-scale", required_argument, NULL, OPT_EMISSION_SCALE},
        {"repeat", required_argument, NULL, OPT_REPEAT},
        {"path", required_argument, NULL, OPT_PATH},
        {"backend", required_argument, NULL, OPT_BACKEND},
        PROBE_LONGOPTS,
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    const char *csv = NULL;
    probe_args pa;
    probe_args_init(&pa);
    double scale = 1.0;
    unsigned repeat = DEFAULT_REPEAT;
    lrr_path path = LRR_PATH_FULL;
    lrr_backend backend = LRR_BACKEND_CPU;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(solve_help, stdout);
            return CLI_EXIT_OK;
        case OPT_CSV:
            csv = optarg;
            break;
        case OPT_EMISSION_SCALE:
            if (cli_parse_double(prog, "--emission-scale", optarg, 0.0, 0, 1e300, &scale) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_REPEAT:
            if (cli_parse_unsigned(prog, "--repeat", optarg, 1, 1000000, &repeat) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_PATH:
            if (parse_path(prog, optarg, &path) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_BACKEND:
            if (cli_parse_backend(prog, optarg, &backend) != 0)
                return CLI_EXIT_USAGE;
            break;
        default: {
            int r = probe_option(&pa, prog, c, optarg);
            if (r < 0)
                return CLI_EXIT_USAGE;
            if (r == 0)
                return bad_option(prog, c, argv);
        }
        }
    }
    const char *file = one_positional(prog, "FILE.lrr", argc, argv);
    if (!file)
        return CLI_EXIT_USAGE;
    if (csv && !csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (probe_finish(&pa, prog) != 0)
        return CLI_EXIT_USAGE;

    if (parse_only)
        return CLI_EXIT_OK;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_operator *op = NULL;
    float *e = NULL, *b = NULL;
    double ms = 0.0, direct_s = 0.0;
    lrr_path used = LRR_PATH_FULL;
    char kernel[KERNEL_NAME_MAX] = "";
    int rc = load_operator(ctx, file, &op);
    if (rc == CLI_EXIT_OK)
        rc = scaled_emission(op, scale, &e);
    if (rc == CLI_EXIT_OK && pa.path)
        rc = add_probe_light(ctx, op, &pa, e, &direct_s);
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi);
        b = cli_alloc_rgb(oi.n);
        rc = b ? timed_solve(ctx, op, backend, e, b, repeat, path, &ms, &used, kernel)
               : CLI_EXIT_FAIL;
    }
    if (rc == CLI_EXIT_OK && csv)
        rc = cli_write_radiosity_csv(csv, op, b);
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi);
        printf("n: %zu\n", oi.n);
        printf("k: %zu\n", oi.k);
        printf("d: %zu\n", oi.d);
        printf("storage: %s\n", lrr_storage_name(oi.storage));
        printf("backend: %s\n", backend == LRR_BACKEND_OPENCL ? "opencl" : "cpu");
        printf("path: %s\n", path_names[used]);
        printf("kernel: %s\n", kernel);
        printf("solve_ms: %.4f\n", ms);
        if (pa.path) {
            printf("probe: %s\n", pa.path);
            printf("probe_method: %s\n", pa.median_cut ? "median-cut" : "irradiance");
            printf("sources: %zu\n", pa.sources);
            printf("direct_light_seconds: %.6f\n", direct_s);
        }
        print_solution_summary(op, b);
        if (csv)
            printf("csv: %s\n", csv);
    }
    free(b);
    free(e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    return rc;
}

/* ------------------------------------------------------------------ lrr render */
static int cmd_render(int argc, char *argv[])
{
    static const char prog[] = "lrr render";
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
    const char *output = NULL;
    probe_args pa;
    probe_args_init(&pa);
    lrr_render_options ro = {.width = 0, .height = 0, .exposure = 0.0, .use_cornell_camera = -1};
    double scale = 1.0;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(render_help, stdout);
            return CLI_EXIT_OK;
        case 'o':
            output = optarg;
            break;
        case OPT_WIDTH:
            if (cli_parse_unsigned(prog, "--width", optarg, 1, 16384, &ro.width) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_HEIGHT:
            if (cli_parse_unsigned(prog, "--height", optarg, 1, 16384, &ro.height) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_EXPOSURE:
            if (cli_parse_double(prog, "--exposure", optarg, 0.0, 1, 1e300, &ro.exposure) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_EMISSION_SCALE:
            if (cli_parse_double(prog, "--emission-scale", optarg, 0.0, 0, 1e300, &scale) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_CAMERA:
            if (strcmp(optarg, "cornell") == 0)
                ro.use_cornell_camera = 1;
            else if (strcmp(optarg, "fit") == 0)
                ro.use_cornell_camera = 0;
            else if (strcmp(optarg, "auto") == 0)
                ro.use_cornell_camera = -1;
            else {
                cli_usage_error(prog, "--camera: '%s' is not one of cornell, fit, auto", optarg);
                return CLI_EXIT_USAGE;
            }
            break;
        default: {
            int r = probe_option(&pa, prog, c, optarg);
            if (r < 0)
                return CLI_EXIT_USAGE;
            if (r == 0)
                return bad_option(prog, c, argv);
        }
        }
    }
    const char *path = one_positional(prog, "FILE.lrr", argc, argv);
    if (!path)
        return CLI_EXIT_USAGE;
    if (!output || !output[0]) {
        cli_usage_error(prog, "-o OUT.png is required");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    if (probe_finish(&pa, prog) != 0)
        return CLI_EXIT_USAGE;

    if (parse_only)
        return CLI_EXIT_OK;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_operator *op = NULL;
    float *e = NULL, *b = NULL;
    double ms = 0.0, direct_s = 0.0;
    int rc = load_operator(ctx, path, &op);
    if (rc == CLI_EXIT_OK)
        rc = scaled_emission(op, scale, &e);
    if (rc == CLI_EXIT_OK && pa.path)
        rc = add_probe_light(ctx, op, &pa, e, &direct_s);
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi);
        b = cli_alloc_rgb(oi.n);
        rc = b ? timed_solve(ctx, op, LRR_BACKEND_CPU, e, b, 0, LRR_PATH_AUTO, &ms, NULL, NULL)
               : CLI_EXIT_FAIL;
    }
    if (rc == CLI_EXIT_OK) {
        s = lrr_render_png(op, b, &ro, output);
        if (s != LRR_OK)
            rc = cli_lib_error(ctx, s);
    }
    if (rc == CLI_EXIT_OK)
        printf("output: %s\n", output);
    free(b);
    free(e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    return rc;
}

/* ------------------------------------------------------------------ lrr reference */
static int cmd_reference(int argc, char *argv[])
{
    static const char prog[] = "lrr reference";
    static const struct option longopts[] = {
        SUBDIV_LONGOPTS,
        BUILD_LONGOPTS,
        {"method", required_argument, NULL, OPT_METHOD},
        {"tol", required_argument, NULL, OPT_TOL},
        {"max-iterations", required_argument, NULL, OPT_MAX_ITERATIONS},
        {"memory-budget", required_argument, NULL, OPT_MEMORY_BUDGET},
        {"csv", required_argument, NULL, OPT_CSV},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    subdiv_args sa;
    subdiv_init(&sa);
    build_args ba;
    build_init(&ba);
    const char *csv = NULL;
    lrr_method method = LRR_METHOD_DIRECT;
    int have_method = 0;
    double tol = DEFAULT_TOL;
    size_t max_iterations = 0, budget_mb = DEFAULT_BUDGET_MB;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        int r = subdiv_option(&sa, prog, c, optarg);
        if (r == 0)
            r = build_option(&ba, prog, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r > 0)
            continue;
        switch (c) {
        case 'h':
            fputs(reference_help, stdout);
            return CLI_EXIT_OK;
        case OPT_METHOD:
            if (lrr_method_from_name(optarg, &method) != LRR_OK) {
                cli_usage_error(prog,
                                "--method: '%s' is not one of jacobi, gauss-seidel, southwell, "
                                "direct",
                                optarg);
                return CLI_EXIT_USAGE;
            }
            have_method = 1;
            break;
        case OPT_TOL:
            /* the library's range: 1e-13 <= tol < 1 */
            if (cli_parse_double(prog, "--tol", optarg, 1e-13, 0, 1.0, &tol) != 0)
                return CLI_EXIT_USAGE;
            if (tol >= 1.0) {
                cli_usage_error(prog, "--tol: '%s' is out of range (it must be less than 1)",
                                optarg);
                return CLI_EXIT_USAGE;
            }
            break;
        case OPT_MAX_ITERATIONS:
            if (cli_parse_size(prog, "--max-iterations", optarg, 0, SIZE_MAX, &max_iterations) !=
                0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_MEMORY_BUDGET:
            if (cli_parse_size(prog, "--memory-budget", optarg, 1, SIZE_MAX >> 20, &budget_mb) !=
                0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_CSV:
            csv = optarg;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    const char *name = one_positional(prog, "SCENE", argc, argv);
    if (!name)
        return CLI_EXIT_USAGE;
    if (!have_method) {
        cli_usage_error(prog, "--method is required (jacobi, gauss-seidel, southwell, direct)");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    if (csv && !csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    int rc = subdiv_finish(&sa, prog);
    if (rc)
        return rc;

    if (parse_only)
        return CLI_EXIT_OK;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_scene *scene = NULL;
    lrr_reference *ref = NULL;
    float *b = NULL, *centre = NULL, *normal = NULL, *area = NULL;
    size_t budget = budget_mb << 20, n = 0, d = 1;
    lrr_reference_stats st = {0, 0.0, 0.0};
    lrr_status solved = LRR_OK;
    double build_seconds = 0.0;
    /* Fail before the build, not after it, when the CSV cannot be written. */
    rc = csv ? check_writable_dir(csv) : CLI_EXIT_OK;
    if (rc == CLI_EXIT_OK)
        rc = open_subdivided_scene(ctx, name, &sa, &scene);
    if (rc == CLI_EXIT_OK) {
        lrr_scene_info si;
        lrr_scene_get_info(scene, &si);
        n = si.subpatches;
        d = si.d ? si.d : 1;
        /* The library checks F against the budget; the LU of the direct method comes on top
         * while it runs, so refuse here, before the hemicubes, when only that breaks it. */
        double f_bytes = (double)lrr_reference_bytes(n);
        double lu_bytes = 8.0 * (double)n * (double)n;
        if (method == LRR_METHOD_DIRECT && f_bytes <= (double)budget &&
            f_bytes + lu_bytes > (double)budget)
            rc = cli_fail(LRR_ERR_BUDGET,
                          "the direct method on %zu subpatches needs %.1f MiB (%.1f MiB for F, "
                          "%.1f MiB for the LU of I − R F), more than --memory-budget %zu MiB",
                          n, (f_bytes + lu_bytes) / 1048576.0, f_bytes / 1048576.0,
                          lu_bytes / 1048576.0, budget_mb);
    }
    if (rc == CLI_EXIT_OK) {
        cli_progress bar;
        lrr_build_options bo = build_start(&ba, &bar);
        double t0 = cli_now();
        s = lrr_reference_build(scene, &bo, budget, &ref);
        build_seconds = cli_now() - t0;
        cli_progress_finish(&bar);
        if (s != LRR_OK) {
            rc = cli_lib_error(ctx, s);
            if (s == LRR_ERR_BUDGET)
                fprintf(stderr, "%s: --memory-budget is %zu MiB: raise it or use fewer "
                                "subpatches\n", prog, budget_mb);
        } else if (lrr_reference_size(ref) != n) {
            rc = cli_fail(LRR_ERR_DIM, "the reference has %zu subpatches, the scene %zu",
                          lrr_reference_size(ref), n);
        }
    }
    if (rc == CLI_EXIT_OK) {
        b = cli_alloc_rgb(n);
        centre = b ? cli_alloc_rgb(n) : NULL;
        normal = centre ? cli_alloc_rgb(n) : NULL;
        area = normal ? calloc(n, sizeof *area) : NULL; /* n × 3 floats fit: so do n */
        if (!area)
            rc = normal ? cli_fail(LRR_ERR_NOMEM, "cannot allocate %zu areas", n)
                        : CLI_EXIT_FAIL;
    }
    if (rc == CLI_EXIT_OK) {
        s = lrr_scene_subpatches(scene, centre, normal, area, NULL, NULL);
        if (s != LRR_OK)
            rc = cli_lib_error(ctx, s);
    }
    if (rc == CLI_EXIT_OK) {
        const float *e = lrr_reference_emission(ref);
        solved = e ? lrr_reference_solve(ref, method, tol, max_iterations, e, b, &st)
                   : LRR_ERR_INVALID_ARG;
        if (!e) {
            rc = cli_fail(LRR_ERR_INVALID_ARG, "the reference has no emission");
        } else if (solved == LRR_NOT_CONVERGED) {
            fprintf(stderr,
                    "lrr: warning: %s did not converge: relative residual %.3g after %zu "
                    "iterations (--tol %g); the results are those of the last iterate\n",
                    lrr_method_name(method), st.residual, st.iterations, tol);
        } else if (solved != LRR_OK) {
            rc = cli_lib_error(ctx, solved);
        }
    }
    if (rc == CLI_EXIT_OK)
        rc = check_finite(b, n);
    if (rc == CLI_EXIT_OK && csv)
        rc = cli_write_subpatch_csv(csv, n, d, NULL, area, centre, normal, b);
    if (rc == CLI_EXIT_OK) {
        printf("n: %zu\n", n);
        printf("method: %s\n", lrr_method_name(method));
        printf("iterations: %zu\n", st.iterations);
        printf("residual: %.6g\n", st.residual);
        printf("build_seconds: %.3f\n", build_seconds);
        printf("solve_seconds: %.6f\n", st.seconds);
        print_radiosity_summary(n, area, b);
        if (csv)
            printf("csv: %s\n", csv);
        if (solved == LRR_NOT_CONVERGED)
            rc = CLI_EXIT_NOT_CONVERGED;
    }
    free(area);
    free(normal);
    free(centre);
    free(b);
    lrr_reference_destroy(ref);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}

/* ------------------------------------------------------------------ lrr compare */
static int cmd_compare(int argc, char *argv[])
{
    static const char prog[] = "lrr compare";
    static const struct option longopts[] = {{"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(compare_help, stdout);
            return CLI_EXIT_OK;
        }
        return bad_option(prog, c, argv);
    }
    if (argc - optind != 2) {
        if (argc - optind > 2)
            cli_usage_error(prog, "unexpected argument '%s'", argv[optind + 2]);
        else
            cli_usage_error(prog, "missing %s", optind == argc ? "A.csv and B.csv" : "B.csv");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    const char *path_a = argv[optind], *path_b = argv[optind + 1];
    cli_csv_table a = {0, NULL}, b = {0, NULL};
    cli_comparison cmp;
    if (parse_only)
        return CLI_EXIT_OK;
    int rc = cli_read_radiosity_csv(path_a, &a);
    if (rc == CLI_EXIT_OK)
        rc = cli_read_radiosity_csv(path_b, &b);
    if (rc == CLI_EXIT_OK)
        rc = cli_compare_radiosity(&a, path_a, &b, path_b, &cmp);
    if (rc == CLI_EXIT_OK) {
        static const char ch[3] = {'r', 'g', 'b'};
        printf("n: %zu\n", cmp.n);
        printf("rel_l2: %.9g\n", cmp.rel_l2);
        printf("max_rel: %.9g\n", cmp.max_rel);
        if (cmp.have_max_rel)
            printf("max_rel_subpatch: %zu\n", cmp.max_rel_subpatch);
        else
            printf("max_rel_subpatch: none\n");
        printf("mean_abs: %.9g\n", cmp.mean_abs);
        for (int k = 0; k < 3; k++)
            printf("rel_l2_%c: %.9g\n", ch[k], cmp.rel_l2_c[k]);
        for (int k = 0; k < 3; k++)
            printf("max_rel_%c: %.9g\n", ch[k], cmp.max_rel_c[k]);
        for (int k = 0; k < 3; k++)
            printf("mean_abs_%c: %.9g\n", ch[k], cmp.mean_abs_c[k]);
    }
    cli_csv_table_free(&a);
    cli_csv_table_free(&b);
    return rc;
}

/* ------------------------------------------------------------------ lrr demo */
/* mkdir -p: creates each missing component of dir. */
static int make_dirs(const char *dir)
{
    char *p = strdup(dir);
    if (!p)
        return cli_fail(LRR_ERR_NOMEM, "cannot copy the path '%s'", dir);
    for (char *q = p + 1;; q++) {
        int end = *q == '\0';
        if (*q == '/' || end) {
            char keep = *q;
            *q = '\0';
            struct stat st;
            if (mkdir(p, 0777) != 0 && errno != EEXIST) {
                int e = errno;
                free(p);
                return cli_fail(LRR_ERR_IO, "cannot create the directory '%s': %s", dir,
                                strerror(e));
            }
            if (stat(p, &st) != 0 || !S_ISDIR(st.st_mode)) {
                free(p);
                return cli_fail(LRR_ERR_IO, "'%s' is not a directory", dir);
            }
            *q = keep;
        }
        if (end)
            break;
    }
    free(p);
    return CLI_EXIT_OK;
}

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
    lrr_operator_get_info(op, &oi);
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

static int cmd_demo(int argc, char *argv[])
{
    static const char prog[] = "lrr demo";
    static const struct option longopts[] = {{"out", required_argument, NULL, OPT_OUT},
                                             {"memory-budget", required_argument, NULL,
                                              OPT_MEMORY_BUDGET},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *dir = "./out";
    size_t budget = physical_memory_bytes();
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(demo_help, stdout);
            return CLI_EXIT_OK;
        case OPT_OUT:
            dir = optarg;
            break;
        case OPT_MEMORY_BUDGET:
            if (parse_operator_budget(prog, optarg, &budget) != 0)
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
    if (!dir[0]) {
        cli_usage_error(prog, "--out: the directory name is empty");
        return CLI_EXIT_USAGE;
    }
    if (parse_only)
        return CLI_EXIT_OK;
    int rc = make_dirs(dir);
    if (rc)
        return rc;
    char *op_path = join_path(dir, "cornell.lrr"), *png_path = join_path(dir, "cornell.png");
    lrr_context *ctx = NULL;
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    float *b = NULL;
    lrr_status s = LRR_OK;
    /* Declared up front: the error paths jump to the single clean-up below. */
    subdiv_args sa;
    cli_progress bar;
    lrr_build_options bo = {.hemicube_resolution = DEFAULT_HEMICUBE,
                            .seed = DEFAULT_SEED,
                            .progress = cli_progress_cb,
                            .progress_user = &bar,
                            .memory_budget = budget};
    lrr_operator_info built;
    double ms = 0.0;
    lrr_render_options ro = {.width = 512, .height = 512, .exposure = 0.0,
                             .use_cornell_camera = 1};
    if (!op_path || !png_path) {
        rc = cli_fail(LRR_ERR_NOMEM, "cannot build the output paths");
        goto done;
    }
    s = lrr_context_create(&ctx);
    if (s != LRR_OK) {
        rc = cli_lib_error(NULL, s);
        goto done;
    }

    printf("== 1. scene\n");
    subdiv_init(&sa);
    subdiv_finish(&sa, prog);
    rc = open_subdivided_scene(ctx, "cornell", &sa, &scene);
    if (rc)
        goto done;
    print_scene_info("cornell", scene);
    fflush(stdout);

    printf("\n== 2. preprocess (one hemicube per subpatch)\n");
    fflush(stdout);
    cli_progress_init(&bar, "hemicubes", 1);
    s = lrr_operator_build(scene, &bo, &op);
    cli_progress_finish(&bar);
    if (s == LRR_OK)
        s = lrr_operator_save(op, op_path);
    if (s != LRR_OK) {
        rc = cli_lib_error(ctx, s);
        if (s == LRR_ERR_BUDGET)
            budget_hint(prog, budget);
        goto done;
    }
    print_operator_info(op);
    printf("output: %s\n", op_path);

    /* Solve from the saved file, as `lrr solve` would: the demo checks the round trip too. */
    lrr_operator_get_info(op, &built);
    lrr_operator_destroy(op);
    op = NULL;
    printf("\n== 3. solve (CPU)\n");
    rc = load_operator(ctx, op_path, &op);
    if (rc)
        goto done;
    b = cli_alloc_rgb(built.n);
    if (!b) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    char kernel[KERNEL_NAME_MAX] = "";
    double sparse_ms = 0;
    rc = timed_solve(ctx, op, LRR_BACKEND_CPU, lrr_operator_emission(op), b, DEFAULT_REPEAT,
                     LRR_PATH_SPARSE, &sparse_ms, NULL, NULL);
    if (rc == CLI_EXIT_OK)
        rc = timed_solve(ctx, op, LRR_BACKEND_CPU, lrr_operator_emission(op), b,
                         DEFAULT_REPEAT, LRR_PATH_FULL, &ms, NULL, kernel);
    if (rc)
        goto done;
    printf("solve_ms: %.4f (one pass over F̄, %s kernel, median of %u)\n", ms, kernel,
           DEFAULT_REPEAT);
    printf("solve_ms_sparse: %.4f (only the light's patches emit: cached columns)\n",
           sparse_ms);
    print_solution_summary(op, b);
    print_wall_table(op, b);

    printf("\n== 4. render\n");
    s = lrr_render_png(op, b, &ro, png_path);
    if (s != LRR_OK) {
        rc = cli_lib_error(ctx, s);
        goto done;
    }
    printf("\nn = %zu, k = %zu, d = %zu, build %.2f s, solve %.3f ms, cond %.3g/%.3g/%.3g\n",
           built.n, built.k, built.d, built.build_seconds, ms, built.condition[0],
           built.condition[1], built.condition[2]);
    printf("png: %s\n", png_path);
done:
    free(b);
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    free(op_path);
    free(png_path);
    return rc;
}

/* ------------------------------------------------------------------ lrr probe */

static int write_lights_csv(const char *path, const lrr_light *lights, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return cli_fail(LRR_ERR_IO, "'%s': cannot create: %s", path, strerror(errno));
    fprintf(out.f, "x,y,z,r,g,b\n");
    for (size_t i = 0; i < count; i++)
        fprintf(out.f, "%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n", lights[i].dir[0], lights[i].dir[1],
                lights[i].dir[2], lights[i].rgb[0], lights[i].rgb[1], lights[i].rgb[2]);
    if (ferror(out.f)) {
        cli_outfile_abort(&out);
        return cli_fail(LRR_ERR_IO, "'%s': write failed", path);
    }
    if (cli_outfile_commit(&out) != 0)
        return cli_fail(LRR_ERR_IO, "'%s': cannot write: %s", path, strerror(errno));
    return CLI_EXIT_OK;
}

/* Prints a string as a JSON string literal. */
static void json_string(const char *s)
{
    putchar('"');
    for (; *s; s++) {
        unsigned char c = (unsigned char)*s;
        if (c == '"' || c == '\\')
            printf("\\%c", c);
        else if (c < 0x20)
            printf("\\u%04x", c);
        else
            putchar(c);
    }
    putchar('"');
}

static int cmd_probe(int argc, char *argv[])
{
    static const char prog[] = "lrr probe";
    static const struct option longopts[] = {{"method", required_argument, NULL, OPT_METHOD},
                                             {"sources", required_argument, NULL, OPT_SOURCES},
                                             {"normals", required_argument, NULL, OPT_NORMALS},
                                             {"lights", required_argument, NULL, OPT_LIGHTS},
                                             {"max-iterations", required_argument, NULL,
                                              OPT_MAX_ITERATIONS},
                                             {"json", no_argument, NULL, OPT_JSON},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *method = "median-cut", *lights_path = NULL;
    size_t sources = PROBE_DEFAULT_SOURCES, normals = PROBE_DEFAULT_NORMALS;
    size_t max_iterations = 0;
    int json = 0, sources_given = 0, max_iterations_given = 0;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(probe_help, stdout);
            return CLI_EXIT_OK;
        case OPT_METHOD:
            method = optarg;
            break;
        case OPT_SOURCES:
            if (cli_parse_size(prog, "--sources", optarg, 1, (size_t)1 << 24, &sources) != 0)
                return CLI_EXIT_USAGE;
            sources_given = 1;
            break;
        case OPT_NORMALS:
            if (cli_parse_size(prog, "--normals", optarg, 1, (size_t)1 << 24, &normals) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_LIGHTS:
            lights_path = optarg;
            break;
        case OPT_MAX_ITERATIONS:
            if (cli_parse_size(prog, "--max-iterations", optarg, 0, (size_t)1 << 24,
                               &max_iterations) != 0)
                return CLI_EXIT_USAGE;
            max_iterations_given = 1;
            break;
        case OPT_JSON:
            json = 1;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    const char *path = one_positional(prog, "PROBE", argc, argv);
    if (!path)
        return CLI_EXIT_USAGE;
    int sh9 = 0, optimise = 0;
    if (strcmp(method, "sh9") == 0) {
        sh9 = 1;
    } else if (strcmp(method, "irradiance") == 0) {
        optimise = 1;
    } else if (strcmp(method, "median-cut") != 0) {
        cli_usage_error(prog, "--method: '%s' is not one of median-cut, irradiance, sh9",
                        method);
        return CLI_EXIT_USAGE;
    }
    if (sh9 && sources_given) {
        cli_usage_error(prog, "--sources applies to --method median-cut and irradiance only");
        return CLI_EXIT_USAGE;
    }
    if (sh9 && lights_path) {
        cli_usage_error(prog, "--lights applies to --method median-cut and irradiance only");
        return CLI_EXIT_USAGE;
    }
    if (!optimise && max_iterations_given) {
        cli_usage_error(prog, "--max-iterations applies to --method irradiance only");
        return CLI_EXIT_USAGE;
    }
    if (lights_path && !*lights_path) {
        cli_usage_error(prog, "--lights: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (parse_only)
        return CLI_EXIT_OK;

    lrr_context *ctx = NULL;
    lrr_probe *probe = NULL;
    lrr_light *lights = NULL;
    float *dirs = NULL, *truth = NULL, *approx = NULL;
    int rc = CLI_EXIT_FAIL;
    lrr_status st = lrr_context_create(&ctx);
    if (st != LRR_OK)
        return cli_lib_error(NULL, st);
    st = lrr_probe_load(ctx, path, &probe);
    if (st != LRR_OK) {
        rc = cli_lib_error(ctx, st);
        goto done;
    }
    size_t w, h;
    lrr_probe_size(probe, &w, &h);
    if (!sh9 && sources > w * h) {
        cli_usage_error(prog, "--sources: %zu is more than the probe's %zu pixels", sources,
                        w * h);
        rc = CLI_EXIT_USAGE;
        goto done;
    }
    dirs = cli_alloc_rgb(normals);
    truth = cli_alloc_rgb(normals);
    approx = cli_alloc_rgb(normals);
    if (!dirs || !truth || !approx)
        goto done;
    lrr_sphere_points(normals, dirs);
    double t0 = cli_now();
    st = lrr_probe_irradiance(probe, normals, dirs, truth);
    double truth_seconds = cli_now() - t0;
    if (st != LRR_OK) {
        rc = cli_lib_error(ctx, st);
        goto done;
    }
    size_t iterations = 1, n_sources = 9;
    t0 = cli_now();
    if (sh9) {
        float coeffs[27];
        st = lrr_probe_sh9(probe, coeffs);
        if (st == LRR_OK)
            st = lrr_sh9_irradiance(coeffs, normals, dirs, approx);
    } else {
        lights = calloc(sources, sizeof *lights);
        if (!lights) {
            rc = cli_fail(LRR_ERR_NOMEM, "cannot allocate %zu lights", sources);
            goto done;
        }
        if (optimise) {
            lrr_fit_options fo = {0};
            lrr_fit_stats fs = {0};
            fo.max_iterations = max_iterations;
            st = lrr_probe_fit_irradiance(probe, sources, normals, &fo, lights, &fs);
            iterations = fs.iterations;
        } else {
            st = lrr_probe_median_cut(probe, sources, lights);
        }
        if (st == LRR_OK)
            st = lrr_lights_irradiance(lights, sources, normals, dirs, approx);
        n_sources = sources;
        if (!optimise) {
            if ((sources & (sources - 1)) == 0)
                for (iterations = 0; ((size_t)1 << iterations) < sources; iterations++)
                    ;
            else
                iterations = sources - 1;
        }
    }
    double seconds = cli_now() - t0;
    if (st != LRR_OK) {
        rc = cli_lib_error(ctx, st);
        goto done;
    }
    double mean_pct, max_pct;
    cli_irradiance_error_pct(normals, truth, approx, &mean_pct, &max_pct);
    if (lights_path && (rc = write_lights_csv(lights_path, lights, sources)) != CLI_EXIT_OK)
        goto done;
    if (json) {
        printf("{\"probe\": ");
        json_string(path);
        printf(", \"width\": %zu, \"height\": %zu, \"method\": \"%s\", \"sources\": %zu, "
               "\"normals\": %zu, \"iterations\": %zu, \"seconds\": %.6g, "
               "\"truth_seconds\": %.6g, \"mean_error_pct\": %.6g, \"max_error_pct\": %.6g}\n",
               w, h, sh9 ? "sh9" : optimise ? "irradiance" : "median-cut", n_sources, normals, iterations, seconds,
               truth_seconds, isnan(mean_pct) ? -1.0 : mean_pct, isnan(max_pct) ? -1.0 : max_pct);
    } else {
        printf("probe: %s\nwidth: %zu\nheight: %zu\nmethod: %s\nsources: %zu\nnormals: %zu\n"
               "iterations: %zu\nseconds: %.6g\ntruth_seconds: %.6g\nmean_error_pct: %.6g\n"
               "max_error_pct: %.6g\n",
               path, w, h, sh9 ? "sh9" : optimise ? "irradiance" : "median-cut", n_sources, normals, iterations, seconds,
               truth_seconds, mean_pct, max_pct);
        if (lights_path)
            printf("lights: %s\n", lights_path);
    }
    rc = CLI_EXIT_OK;
done:
    free(lights);
    free(dirs);
    free(truth);
    free(approx);
    lrr_probe_destroy(probe);
    lrr_context_destroy(ctx);
    return rc;
}

/* ------------------------------------------------------------------ main */
static int print_version(void)
{
    const char *lib = lrr_version_string();
    if (!lib || strcmp(lib, LRR_VERSION_STRING) != 0) {
        fprintf(stderr, "lrr: the library is version %s but lrr was built with header %s\n",
                lib ? lib : "(null)", LRR_VERSION_STRING);
        return CLI_EXIT_FAIL;
    }
    printf("lrr %s\n", lib);
    return CLI_EXIT_OK;
}

/* ------------------------------------------------------------------ lrr check */
static const char check_help[] =
    "Usage: lrr check SCENE [--fix OUT.obj] [--max-report N] [--strict]\n"
    "The scene doctor (exact predicates, CGAL). Reads the raw triangles (zero-area ones\n"
    "included) and prints 'key: value' lines (triangles, degenerate, intersecting_pairs,\n"
    "coplanar_overlaps, contacts, open_edges, inconsistent_components), then one line per\n"
    "finding naming the file's face numbers (for a built-in scene, triangle indices).\n"
    "Errors: degenerate (zero-area) triangles; intersecting pairs (each crosses the other's\n"
    "plane: light leaks); coplanar overlaps facing the same way (z-fighting); closed\n"
    "components whose faces disagree on orientation (the minority is named).\n"
    "Warnings: open edges (boundaries; the Cornell box's front is open) and contacts\n"
    "(coplanar overlaps facing opposite ways, e.g. a block standing on the floor).\n"
    "\n" SCENE_HELP "\n"
    "  --fix OUT.obj        write the scene without degenerates and with each closed\n"
    "                       component oriented like its majority (OBJ + OUT.mtl with Kd/Ke,\n"
    "                       written atomically); intersections are not repaired\n"
    "  --max-report N       print at most N finding lines (default 50; 0 = none)\n"
    "  --strict             warnings count as errors\n"
    "  -h, --help           show this help\n"
    "Exit status: 0 no errors, 1 errors found (about the input, also with --fix) or the scene\n"
    "cannot be read, 2 usage error.\n";

static void print_finding(const lrr_check_finding *f)
{
    switch (f->kind) {
    case LRR_CHECK_DEGENERATE:
        printf("error: face %zu is degenerate (zero area)\n", f->face_a);
        break;
    case LRR_CHECK_INTERSECT:
        printf("error: face %zu and face %zu intersect\n", f->face_a, f->face_b);
        break;
    case LRR_CHECK_ZFIGHT:
        printf("error: face %zu and face %zu are coplanar and overlap, facing the same way "
               "(z-fighting)\n", f->face_a, f->face_b);
        break;
    case LRR_CHECK_CONTACT:
        printf("warning: face %zu and face %zu are coplanar and overlap, facing opposite ways "
               "(contact)\n", f->face_a, f->face_b);
        break;
    case LRR_CHECK_OPEN_EDGE:
        printf("warning: face %zu has an open edge (boundary)\n", f->face_a);
        break;
    case LRR_CHECK_ORIENTATION:
        printf("error: face %zu is oriented against its closed component (e.g. face %zu)\n",
               f->face_a, f->face_b);
        break;
    }
}

/* OUT.obj + OUT.mtl (the extension replaced, or appended), each written atomically. */
static int write_fixed_obj(const lrr_check_report *r, const char *path)
{
    size_t len = strlen(path);
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    size_t stem = dot && (!slash || dot > slash) ? (size_t)(dot - path) : len;
    char *mtl = malloc(stem + 5);
    size_t *mat = malloc((r->triangles ? r->triangles : 1) * sizeof *mat);
    if (!mtl || !mat) {
        free(mtl);
        free(mat);
        return cli_fail(LRR_ERR_NOMEM, "--fix: out of memory");
    }
    memcpy(mtl, path, stem);
    memcpy(mtl + stem, ".mtl", 5);
    const char *mtl_base = strrchr(mtl, '/') ? strrchr(mtl, '/') + 1 : mtl;
    /* materials: distinct (rho, emission) pairs, numbered by first use */
    size_t n_mat = 0;
    for (size_t t = 0; t < r->triangles; t++) {
        mat[t] = n_mat;
        for (size_t u = 0; u < t; u++)
            if (memcmp(r->rho + 3 * u, r->rho + 3 * t, 3 * sizeof(float)) == 0 &&
                memcmp(r->emission + 3 * u, r->emission + 3 * t, 3 * sizeof(float)) == 0) {
                mat[t] = mat[u];
                break;
            }
        if (mat[t] == n_mat)
            n_mat++;
    }
    int rc = CLI_EXIT_OK;
    cli_outfile out;
    if (cli_outfile_open(&out, mtl) != 0) {
        rc = cli_fail(LRR_ERR_IO, "'%s': cannot create: %s", mtl, strerror(errno));
        goto done;
    }
    fprintf(out.f, "# written by lrr check --fix\n");
    for (size_t m = 0, t = 0; m < n_mat; m++) {
        while (mat[t] != m)
            t++;
        fprintf(out.f, "newmtl m%zu\nKd %.9g %.9g %.9g\nKe %.9g %.9g %.9g\n", m,
                (double)r->rho[3 * t], (double)r->rho[3 * t + 1], (double)r->rho[3 * t + 2],
                (double)r->emission[3 * t], (double)r->emission[3 * t + 1],
                (double)r->emission[3 * t + 2]);
    }
    if (ferror(out.f)) {
        cli_outfile_abort(&out);
        rc = cli_fail(LRR_ERR_IO, "'%s': write failed", mtl);
        goto done;
    }
    if (cli_outfile_commit(&out) != 0) {
        rc = cli_fail(LRR_ERR_IO, "'%s': cannot write: %s", mtl, strerror(errno));
        goto done;
    }
    if (cli_outfile_open(&out, path) != 0) {
        rc = cli_fail(LRR_ERR_IO, "'%s': cannot create: %s", path, strerror(errno));
        goto done;
    }
    fprintf(out.f, "# written by lrr check --fix\nmtllib %s\n", mtl_base);
    size_t v = 0;
    for (size_t t = 0; t < r->triangles; t++) {
        if (r->fix[t] == 1)
            continue;
        static const int order[2][3] = {{0, 1, 2}, {0, 2, 1}};
        const int *o = order[r->fix[t] == 2];
        for (int i = 0; i < 3; i++) {
            const float *p = r->vert + 9 * t + 3 * o[i];
            fprintf(out.f, "v %.9g %.9g %.9g\n", (double)p[0], (double)p[1], (double)p[2]);
        }
        fprintf(out.f, "usemtl m%zu\nf %zu %zu %zu\n", mat[t], v + 1, v + 2, v + 3);
        v += 3;
    }
    if (ferror(out.f)) {
        cli_outfile_abort(&out);
        rc = cli_fail(LRR_ERR_IO, "'%s': write failed", path);
        goto done;
    }
    if (cli_outfile_commit(&out) != 0)
        rc = cli_fail(LRR_ERR_IO, "'%s': cannot write: %s", path, strerror(errno));
done:
    free(mtl);
    free(mat);
    return rc;
}

static int cmd_check(int argc, char *argv[])
{
    static const char prog[] = "lrr check";
    enum { OPT_FIX = 1024, OPT_MAX_REPORT, OPT_STRICT };
    static const struct option longopts[] = {{"fix", required_argument, NULL, OPT_FIX},
                                             {"max-report", required_argument, NULL, OPT_MAX_REPORT},
                                             {"strict", no_argument, NULL, OPT_STRICT},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *fix = NULL;
    size_t max_report = 50;
    int strict = 0;
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(check_help, stdout);
            return CLI_EXIT_OK;
        } else if (c == OPT_FIX) {
            if (!*optarg) {
                cli_usage_error(prog, "--fix: the file name is empty");
                return CLI_EXIT_USAGE;
            }
            fix = optarg;
        } else if (c == OPT_MAX_REPORT) {
            if (cli_parse_size(prog, "--max-report", optarg, 0, SIZE_MAX, &max_report) != 0)
                return CLI_EXIT_USAGE;
        } else if (c == OPT_STRICT) {
            strict = 1;
        } else {
            return bad_option(prog, c, argv);
        }
    }
    const char *name = one_positional(prog, "SCENE", argc, argv);
    if (!name)
        return CLI_EXIT_USAGE;
    if (parse_only)
        return CLI_EXIT_OK;
    struct stat st;
    if (stat(name, &st) != 0 && !is_builtin(name))
        return cli_fail(LRR_ERR_IO, "scene '%s': %s (built-in scenes: cornell, cornell-closed)",
                        name, strerror(errno));
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_check_report *r = NULL;
    s = lrr_scene_check(ctx, name, &r);
    if (s != LRR_OK) {
        int rc = cli_lib_error(ctx, s);
        lrr_context_destroy(ctx);
        return rc;
    }
    printf("scene: %s\ntriangles: %zu\ndegenerate: %zu\nintersecting_pairs: %zu\n"
           "coplanar_overlaps: %zu\ncontacts: %zu\nopen_edges: %zu\n"
           "inconsistent_components: %zu\n",
           name, r->triangles, r->degenerate, r->intersecting_pairs, r->coplanar_overlaps,
           r->contacts, r->open_edges, r->inconsistent_components);
    for (size_t i = 0; i < r->n_findings && i < max_report; i++)
        print_finding(&r->findings[i]);
    if (r->n_findings > max_report)
        printf("(%zu more findings not shown; see --max-report)\n", r->n_findings - max_report);
    size_t errors = r->degenerate + r->intersecting_pairs + r->coplanar_overlaps +
                    r->inconsistent_components;
    size_t warnings = r->contacts + r->open_edges;
    int rc = errors || (strict && warnings) ? CLI_EXIT_FAIL : CLI_EXIT_OK;
    printf("result: %s\n", errors ? "errors" : warnings ? (strict ? "warnings (strict)" : "warnings only") : "clean");
    if (fix) {
        int frc = write_fixed_obj(r, fix);
        if (frc != CLI_EXIT_OK)
            rc = frc;
    }
    lrr_check_report_destroy(r);
    lrr_context_destroy(ctx);
    return rc;
}

int lrr_cli_main(int argc, char *argv[], int parse_only_)
{
    parse_only = parse_only_;
    static const struct {
        const char *name;
        int (*run)(int, char *[]);
    } commands[] = {{"info", cmd_info},
                    {"check", cmd_check},
                    {"preprocess", cmd_preprocess},
                    {"solve", cmd_solve},
                    {"render", cmd_render},
                    {"reference", cmd_reference},
                    {"compare", cmd_compare},
                    {"demo", cmd_demo},
                    {"probe", cmd_probe}};
    if (argc < 2) {
        fputs(main_help, stderr);
        return CLI_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "-h") == 0 || strcmp(cmd, "--help") == 0 || strcmp(cmd, "help") == 0) {
        fputs(main_help, stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(cmd, "-V") == 0 || strcmp(cmd, "--version") == 0)
        return print_version();
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(cmd, commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    if (cmd[0] == '-')
        cli_usage_error("lrr", "unknown option '%s'", cmd);
    else
        cli_usage_error("lrr", "unknown command '%s'", cmd);
    fprintf(stderr, "Try 'lrr --help'.\n");
    return CLI_EXIT_USAGE;
}

#ifndef LRR_CLI_NO_MAIN
int main(int argc, char *argv[])
{
    return lrr_cli_main(argc, argv, 0);
}
#endif
