/* lrr preprocess: build the low-rank operator (F̄, M_c) of a scene and save it. */
#include <float.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "commands.h"
#include "cli_mpi.h"

/* lrr preprocess warns when cond × FLT_EPSILON exceeds this: M_c is stored in float, so a
 * larger condition number leaves less than ~0.1% of accuracy in the solution. */
#define COND_WARN_ERROR 1e-3

static const char prog[] = "lrr preprocess";

static const char preprocess_help[] =
    "Usage: lrr preprocess SCENE -o FILE.lrr [OPTIONS]\n"
    "Builds the low-rank operator (hemicube form factors F̄ and the k×k matrices M_c) and\n"
    "saves it atomically. Prints 'key: value' lines: n, k, d, hemicube, seed,\n"
    "build_seconds, cond_r, cond_g, cond_b, storage, layout, memory_mb, backend, formfactor\n"
    "(raster or raycast, as used), back_face_share (the light-leak indicator: the mean\n"
    "share of the receivers' hemicubes that sees the back of a triangle; 0 for a closed\n"
    "scene with consistent orientation), up to 5 'worst_back_face: TRIANGLE SHARE' lines\n"
    "(the input triangles whose receivers see most back faces), output. Warns on\n"
    "stderr when a condition estimate is so large (cond × FLT_EPSILON > 1e-3) that M_c,\n"
    "stored in single precision, may not carry the solution to 0.1%.\n"
    "\n" SCENE_HELP "\n"
    "Options:\n"
    "  -o, --output FILE    where to write the operator (required)\n"
    "  --storage S          f32 (default), f16 or bf16: how F̄ is stored. 16-bit halves the\n"
    "                       file, the memory and the bytes each frame reads; f16 rows carry\n"
    "                       a power-of-two scale, and M is recomputed from the rounded F̄\n"
    "  --fbar-file F        auto (default), dense or sparse: how FILE.lrr stores F̄. sparse\n"
    "                       keeps only the strips of 16 rows × 1 column that hold a nonzero\n"
    "                       (file version 5, which older lrr refuse; k <= 65535), dense\n"
    "                       every entry (versions 1 to 4); auto is sparse where that is at\n"
    "                       most half the dense bytes (as 'lrr solve --fbar auto' decides)\n"
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
    "  --clusters K         cluster hierarchy, for scenes with many triangles: patches\n"
    "                       are about K clusters of subpatches across triangles (compact,\n"
    "                       every normal within 30 degrees of the cluster's mean, so the\n"
    "                       two sides of a wall never share one), any K >= 1; more where\n"
    "                       the normal rule forces splits. The subpatches default to\n"
    "                       --levels 0 and about T + 16·K of them (T triangles: one per\n"
    "                       small triangle, large ones split); --adaptive-split and\n"
    "                       --adaptive-samples choose the splits as for --adaptive.\n"
    "                       Prints hierarchy: clusters, d_min, d_max, selection_seconds\n"
    "  --adaptive-samples S receivers sampled to estimate the variance (default 2048,\n"
    "                       rendered at a quarter of the hemicube resolution)\n"
    "  --adaptive-split X   variance (default) or area: area splits the largest patch first,\n"
    "                       i.e. uniform subdivision at the same K (the baseline)\n"
    "  --verify [S]         the operator's error bar: path-trace every subpatch with S paths\n"
    "                       (two independent halves; default: what a fifth of the build's\n"
    "                       time allows, 32..1024) for the scene's emission (E = 1\n"
    "                       everywhere if it has none) and compare the reflected light B − E\n"
    "                       in regions (grid cells × facing), the path tracer's noise taken\n"
    "                       off. Prints\n"
    "                       verify_rel_l2 (a fraction), verify_noise (the path tracer's\n"
    "                       own), verify_subpatches, verify_samples, verify_seconds; stored\n"
    "                       in FILE.lrr ('lrr info FILE.lrr')\n" BUILD_HELP
    OPERATOR_BUDGET_HELP
    "  -h, --help           show this help\n" SUBDIV_HELP
    "With none of --adaptive, --clusters, --patches, --max-patch-area and --levels, a scene\n"
    "of more than 2000 triangles gets --clusters K: K = 2000, or the largest K whose build\n"
    "fits --memory-budget, and --hemicube 64 unless given (a note on stderr says which and\n"
    "why); smaller scenes get --patches 216 --levels 2.\n"
    "Under mpirun (lrr built with MPI: 'lrr --version' lists mpi), every rank opens SCENE\n"
    "and computes its share of the hemicubes (chunks of 64 receivers dealt round-robin,\n"
    "OMP_NUM_THREADS threads each) and keeps those rows of F̄; the ranks sum G's rows,\n"
    "rank 0 factorises and writes FILE.lrr as the rows stream in (the serial file but for\n"
    "its timings) and prints, adding ranks, rank_hemicube_seconds (the fastest and the\n"
    "slowest rank's), gather_seconds, rank_fbar_mb (the most F̄ a rank held) and\n"
    "save_seconds. --memory-budget is then per rank, with its share of F̄. --verify\n"
    "gathers the operator on rank 0 instead, and deals its path tracing across the ranks\n"
    "(the same figures). --backend opencl is serial.\n";

typedef struct preprocess_args {
    const char *scene, *output;
    subdiv_args sa;
    build_args ba;
    lrr_storage storage;
    int on_device;
    size_t adaptive, adaptive_samples, clusters;
    int adaptive_split, adaptive_only;
    size_t budget;
    int auto_hierarchy;    /* no hierarchy or subdivision option: chosen by the scene */
    int fbar_file;         /* --fbar-file: lrr_fbar_format */
    int verify;            /* --verify given */
    size_t verify_samples; /* its S; 0 = automatic */
    cli_mpi mp;            /* the ranks under mpirun (tools/cli_mpi.h) */
    int quiet;             /* a rank other than 0: no notes, bars or printout */
} preprocess_args;

/* ------------------------------------------------------------------ parsing */
/* The options of preprocess alone: 1 handled, 0 not one of them, -1 usage error (reported). */
static int preprocess_option(preprocess_args *a, int c, const char *arg)
{
    switch (c) {
    case OPT_STORAGE:
        if (lrr_storage_from_name(arg, &a->storage) != LRR_OK) {
            cli_usage_error(prog, "--storage: '%s' is not one of f32, f16, bf16", arg);
            return -1;
        }
        return 1;
    case OPT_BACKEND: {
        lrr_backend b;
        if (cli_parse_backend(prog, arg, &b) != 0)
            return -1;
        a->on_device = b == LRR_BACKEND_OPENCL;
        return 1;
    }
    case OPT_ADAPTIVE:
        return cli_parse_size(prog, "--adaptive", arg, 1, SIZE_MAX, &a->adaptive) != 0 ? -1 : 1;
    case OPT_CLUSTERS:
        return cli_parse_size(prog, "--clusters", arg, 1, SIZE_MAX, &a->clusters) != 0 ? -1 : 1;
    case OPT_ADAPTIVE_SAMPLES:
        a->adaptive_only = 1;
        return cli_parse_size(prog, "--adaptive-samples", arg, 1, (size_t)1 << 20,
                              &a->adaptive_samples) != 0 ? -1 : 1;
    case OPT_ADAPTIVE_SPLIT:
        a->adaptive_only = 1;
        if (strcmp(arg, "variance") == 0)
            a->adaptive_split = LRR_SPLIT_VARIANCE;
        else if (strcmp(arg, "area") == 0)
            a->adaptive_split = LRR_SPLIT_AREA;
        else {
            cli_usage_error(prog, "--adaptive-split: '%s' is not variance or area", arg);
            return -1;
        }
        return 1;
    case OPT_FBAR_FILE: {
        lrr_fbar_format f;
        if (lrr_fbar_format_from_name(arg, &f) != LRR_OK) {
            cli_usage_error(prog, "--fbar-file: '%s' is not one of auto, dense, sparse", arg);
            return -1;
        }
        a->fbar_file = (int)f;
        return 1;
    }
    case OPT_MEMORY_BUDGET:
        return parse_operator_budget(prog, arg, &a->budget) != 0 ? -1 : 1;
    case OPT_VERIFY:
        a->verify = 1;
        return !arg || cli_parse_size(prog, "--verify", arg, 4, (size_t)1 << 24,
                                      &a->verify_samples) == 0
                   ? 1 : -1;
    default:
        return 0;
    }
}

/* --verify's optional S may follow as the next word ("--verify 256"): getopt takes an
 * optional argument only as "--verify=256". */
static const char *verify_count(int argc, char *argv[])
{
    if (optind < argc && argv[optind][0] &&
        strspn(argv[optind], "0123456789") == strlen(argv[optind]))
        return argv[optind++];
    return NULL;
}

/* The checks after getopt: the scene, -o, and how the options combine. */
static int preprocess_finish(preprocess_args *a, int argc, char *argv[])
{
    a->scene = one_positional(prog, "SCENE", argc, argv);
    if (!a->scene)
        return CLI_EXIT_USAGE;
    if (!a->output || !a->output[0]) {
        cli_usage_error(prog, "-o FILE.lrr is required");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    if (a->adaptive && a->clusters) {
        cli_usage_error(prog, "--adaptive and --clusters exclude each other");
        return CLI_EXIT_USAGE;
    }
    a->auto_hierarchy = !a->adaptive && !a->clusters && !a->sa.have_area &&
                        !a->sa.have_patches && !a->sa.have_levels;
    a->sa.clusters = a->clusters;
    int rc = subdiv_finish(&a->sa, prog);
    if (rc)
        return rc;
    if (a->clusters)
        a->adaptive = a->clusters; /* K, as lrr_build_options.adaptive_patches */
    if (a->adaptive_only && !a->adaptive) {
        cli_usage_error(prog, "--adaptive-samples and --adaptive-split need --adaptive K or "
                              "--clusters K");
        return CLI_EXIT_USAGE;
    }
    if (a->adaptive && !a->sa.have_levels)
        a->sa.sub.levels = 0;
    if (a->adaptive && a->sa.sub.levels != 0) {
        cli_usage_error(prog, "--%s: the patches become the subpatches, so give "
                              "--levels 0 (not %u)", a->clusters ? "clusters" : "adaptive",
                        a->sa.sub.levels);
        return CLI_EXIT_USAGE;
    }
    return CLI_RUN;
}

/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_preprocess(preprocess_args *a, int argc, char *argv[])
{
    static const struct option longopts[] = {
        {"output", required_argument, NULL, 'o'},
        {"storage", required_argument, NULL, OPT_STORAGE},
        {"fbar-file", required_argument, NULL, OPT_FBAR_FILE},
        {"backend", required_argument, NULL, OPT_BACKEND},
        {"adaptive", required_argument, NULL, OPT_ADAPTIVE},
        {"clusters", required_argument, NULL, OPT_CLUSTERS},
        {"adaptive-samples", required_argument, NULL, OPT_ADAPTIVE_SAMPLES},
        {"adaptive-split", required_argument, NULL, OPT_ADAPTIVE_SPLIT},
        {"memory-budget", required_argument, NULL, OPT_MEMORY_BUDGET},
        {"verify", optional_argument, NULL, OPT_VERIFY},
        SUBDIV_LONGOPTS,
        BUILD_LONGOPTS,
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    *a = (preprocess_args){.storage = LRR_STORAGE_F32,
                           .adaptive_split = LRR_SPLIT_VARIANCE,
                           .budget = physical_memory_bytes()};
    subdiv_init(&a->sa);
    build_init(&a->ba);
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":ho:", longopts, NULL)) != -1) {
        int r = preprocess_option(a, c, c == OPT_VERIFY && !optarg ? verify_count(argc, argv)
                                                                   : optarg);
        if (r == 0)
            r = subdiv_option(&a->sa, prog, c, optarg);
        if (r == 0)
            r = build_option(&a->ba, prog, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r > 0)
            continue;
        switch (c) {
        case 'h':
            fputs(preprocess_help, stdout);
            return CLI_EXIT_OK;
        case 'o':
            a->output = optarg;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    return preprocess_finish(a, argc, argv);
}

/* ------------------------------------------------------------------ running */
/* M_c is stored in float: a condition number κ costs about log10(κ) of its ~7 digits. */
static void warn_condition(const lrr_operator *op)
{
    static const char ch[3] = {'r', 'g', 'b'};
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
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

static void note_skipped(const preprocess_args *a, const lrr_scene *scene)
{
    if (a->quiet)
        return;
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    if (si.skipped)
        fprintf(stderr, "lrr preprocess: note: %zu zero-area triangle(s) skipped; "
                        "'lrr check %s' reports them and more\n", si.skipped, a->scene);
    if (si.clamped_texels)
        fprintf(stderr, "lrr preprocess: warning: %zu texel(s) of reflectance textures (times "
                        "their material's factor) were >= 1 and are clamped just below 1\n",
                si.clamped_texels);
}

/* --verify: the operator's error bar, from the path tracer (lrr_operator_verify), unless
 * `before` failed; under mpirun on every rank (op on rank 0 only), the ranks' `before`
 * agreed first. */
static lrr_status verify(lrr_context *ctx, lrr_operator *op, const preprocess_args *a,
                         const lrr_scene *scene, lrr_status before)
{
    cli_progress bar;
    cli_progress_init(&bar, "verify",
                      !a->quiet && (a->ba.force_progress || isatty(STDERR_FILENO)));
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = a->verify_samples;
    vo.seed = a->ba.seed;
    vo.threads = (int)a->ba.threads;
    vo.progress = a->quiet ? NULL : cli_progress_cb;
    vo.progress_user = &bar;
    lrr_status s = cli_mpi_verify(&a->mp, ctx, op, scene, &vo, before);
    cli_progress_finish(&bar);
    return s;
}

/* Builds the operator (*op, also on some failures: the caller destroys it), stores F̄ as
 * asked and saves it. Returns CLI_EXIT_OK or the failure (reported). */
static int build_and_save(lrr_context *ctx, preprocess_args *a, const lrr_scene *scene,
                          lrr_operator **op)
{
    int rc = CLI_EXIT_OK;
    cli_progress bar;
    lrr_build_options bo = build_start(&a->ba, &bar);
    bo.backend = a->on_device ? LRR_BACKEND_OPENCL : LRR_BACKEND_CPU;
    bo.adaptive_patches = a->adaptive;
    bo.hierarchy = a->clusters ? LRR_HIERARCHY_CLUSTER : LRR_HIERARCHY_QUADTREE;
    bo.adaptive_samples = a->adaptive_samples;
    bo.adaptive_split = a->adaptive_split;
    bo.memory_budget = a->budget;
    if (a->quiet)
        bo.progress = NULL;
    /* under mpirun without --verify, F̄ stays on the ranks and rank 0 writes the file as it
     * streams in (*op without F̄); --verify needs the whole operator on rank 0 */
    const int saved = a->mp.on && !a->verify;
    lrr_status s = saved ? cli_mpi_build_save(&a->mp, scene, &bo, a->storage,
                                              (lrr_fbar_format)a->fbar_file, a->output, op)
                         : cli_mpi_build(&a->mp, scene, &bo, op);
    cli_progress_finish(&bar);
    if (a->quiet) { /* rank 0 reports the agreed error, naming the rank */
        if (s == LRR_OK && a->verify)
            s = verify(ctx, NULL, a, scene, LRR_OK);
        return s == LRR_OK ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    }
    if (s == LRR_ERR_BUDGET) {
        rc = cli_lib_error(ctx, s);
        budget_hint(prog, a->budget, a->clusters);
        s = LRR_OK;
    }
    if (saved) {
        if (s == LRR_OK && *op)
            warn_condition(*op);
        return s == LRR_OK ? rc : cli_lib_error(ctx, s);
    }
    if (s == LRR_OK && *op)
        s = lrr_operator_set_storage(*op, a->storage);
    if (s == LRR_OK && *op)
        warn_condition(*op);
    if (*op && a->verify)
        s = verify(ctx, *op, a, scene, s);
    if (s == LRR_OK && *op)
        s = lrr_operator_save_fbar(*op, a->output, (lrr_fbar_format)a->fbar_file);
    if (s != LRR_OK)
        rc = cli_lib_error(ctx, s);
    return rc;
}

static void print_preprocess(const preprocess_args *a, const lrr_operator *op)
{
    print_operator_info(op);
    printf("backend: %s\n", a->on_device ? "opencl" : "cpu");
    lrr_operator_info info;
    lrr_operator_get_info(op, &info, sizeof info);
    printf("formfactor: %s\n",
           info.formfactor_method == LRR_FORMFACTOR_RAYCAST ? "raycast" : "raster");
    /* the light-leak indicator: hemicube share seeing back faces, and the worst triangles */
    printf("back_face_share: %.6g\n", info.back_face_share);
    for (int w = 0; w < LRR_BACK_FACE_WORST && info.worst_back_face_share[w] > 0; w++)
        printf("worst_back_face: %zu %.6g\n", info.worst_back_face_triangle[w],
               info.worst_back_face_share[w]);
    printf("output: %s\n", a->output);
}

/* The bytes a cluster build of T triangles and K clusters holds, about (lib/operator/
 * budget.c counts them exactly and refuses a build beyond the budget): F̄ (4·n·K), M and
 * the factorisation's G (12 + 8 bytes per K²), the cluster selection's sampled rows (at most
 * 512 MiB) and ~72 bytes per subpatch, n = T + 16·K. */
static double cluster_build_bytes(size_t T, size_t K)
{
    const double n = (double)T + 16.0 * (double)K;
    return 4.0 * n * (double)K + 20.0 * (double)K * (double)K + 72.0 * n + (512.0 * 1048576);
}

/* With no hierarchy option: clusters for a scene of more than AUTO_TRIANGLES triangles (the
 * default --patches 216 --levels 2 would give every triangle a patch, k >= T, and F̄ grows
 * as 16·k²), K = AUTO_CLUSTERS or the largest that fits the memory budget, and hemicubes of
 * AUTO_HEMICUBE unless --hemicube is given: with 2000 clusters R 128 costs 4× the rays of
 * R 64 for little (the atrium of issue 27: 16.6% → 16.2%). */
#define AUTO_TRIANGLES 2000
#define AUTO_CLUSTERS 2000
#define AUTO_HEMICUBE 64u
static void choose_hierarchy(preprocess_args *a, const lrr_scene *scene)
{
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    if (si.triangles <= AUTO_TRIANGLES)
        return;
    size_t K = AUTO_CLUSTERS;
    while (K > 1 && a->budget && cluster_build_bytes(si.triangles, K) > (double)a->budget)
        K = K * 9 / 10;
    a->clusters = a->adaptive = a->sa.clusters = K;
    a->sa.sub.levels = 0;
    a->sa.sub.target_patches = 0;
    if (!a->ba.hemicube_given)
        a->ba.hemicube = AUTO_HEMICUBE;
    if (a->quiet)
        return;
    if (K == AUTO_CLUSTERS)
        fprintf(stderr, "lrr preprocess: note: %zu triangles: --clusters %zu --hemicube %u "
                        "(the default for scenes of more than %d triangles; --patches/--levels "
                        "give the quadtree, --clusters another K)\n", si.triangles, K,
                a->ba.hemicube, AUTO_TRIANGLES);
    else
        fprintf(stderr, "lrr preprocess: note: %zu triangles: --clusters %zu --hemicube %u, "
                        "the most clusters that fit --memory-budget %zu MiB (%d otherwise)\n",
                si.triangles, K, a->ba.hemicube, a->budget >> 20, AUTO_CLUSTERS);
}

static int open_and_subdivide(lrr_context *ctx, preprocess_args *a, lrr_scene **scene)
{
    if (!a->auto_hierarchy)
        return open_subdivided_scene(ctx, a->scene, &a->sa, scene);
    int rc = open_scene(ctx, a->scene, scene);
    if (rc == CLI_EXIT_OK) {
        choose_hierarchy(a, *scene);
        rc = subdivide_scene(ctx, &a->sa, scene);
    }
    return rc;
}

/* What only the serial build offers under mpirun: a usage error (every rank sees the
 * same options, so all stop alike; rank 0 says why). */
static int check_mpi_options(const preprocess_args *a)
{
    if (!a->mp.on || !a->on_device)
        return CLI_EXIT_OK;
    if (!a->quiet)
        cli_usage_error(prog, "--backend opencl is not available across MPI ranks (each rank "
                              "integrates its hemicubes on the CPU)");
    return CLI_EXIT_USAGE;
}

/* Every rank opens the scene and builds its block; rank 0 (the only one without MPI)
 * also checks the output's directory, saves and prints. */
static int preprocess_ranks(preprocess_args *a)
{
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    int rc = a->quiet ? CLI_EXIT_OK : check_writable_dir(a->output);
    if (rc == CLI_EXIT_OK)
        rc = open_and_subdivide(ctx, a, &scene);
    /* a rank that cannot open the scene stops them all before the collective build */
    if ((rc = cli_mpi_agree(&a->mp, rc)) == CLI_EXIT_OK) {
        note_skipped(a, scene);
        rc = build_and_save(ctx, a, scene, &op);
    }
    if (rc == CLI_EXIT_OK && op) {
        print_preprocess(a, op);
        cli_mpi_print(&a->mp);
    }
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}

static int run_preprocess(preprocess_args *a)
{
    int rc = cli_mpi_init(&a->mp, prog);
    if (rc != CLI_EXIT_OK)
        return rc;
    a->quiet = a->mp.rank != 0;
    rc = check_mpi_options(a);
    if (rc == CLI_EXIT_OK)
        rc = preprocess_ranks(a);
    /* every rank ends with the worst status (rank 0's save may fail after the build) */
    rc = cli_mpi_agree(&a->mp, rc);
    cli_mpi_finalize(&a->mp);
    return rc;
}

int cmd_preprocess(int argc, char *argv[])
{
    preprocess_args a;
    int rc = parse_preprocess(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_preprocess(&a);
}
