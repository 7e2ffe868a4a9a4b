/* lrr-bench raycast: hemicubes per second of the rasteriser against the ray caster
 * (lrr_build_options.formfactor_method) on the Cornell box tessellated into T = 36·4^L input
 * triangles, the measurement behind LRR_FORMFACTOR_AUTO's crossover at R²/4 triangles
 * (bench/results/2026-12-02-raycast.md). The tessellation: the box subdivided at level L,
 * its subpatch triangles (lrr_operator_subpatch_vertices) made a scene of their own. Each
 * build clusters the T subpatches into 64 patches (LRR_HIERARCHY_CLUSTER, split by area) so
 * that F̄ stays n×64 at any T, renders one hemicube per subpatch from its centre (both
 * methods alike) and reports the form-factor phase alone (formfactor_seconds): the rate is
 * n over the best of three builds. */
#include "bench.h"

#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>

#define RC_PATCHES 64 /* clusters: F̄ is n×64 floats, 9.4 MB at T = 36,864 */
#define RC_BUILDS 3

static const char raycast_help[] =
    "Usage: lrr-bench raycast [OPTIONS]\n"
    "Hemicubes per second of the rasteriser and of the ray caster (formfactor_method) on\n"
    "the Cornell box tessellated into T = 36·4^L triangles, L = MIN..MAX, at R = 64 and\n"
    "128, on 1 thread and on all: the form-factor phase of the best of 3 builds, T\n"
    "receivers each looking from its centre, 64 clustered patches. Prints the machine,\n"
    "then CSV: T,R,threads,raster_per_s,raycast_per_s,ratio (ratio = raycast / raster).\n\n"
    "Options:\n"
    "  --levels MAX       the largest L (0..5, default 4)\n"
    "  --min-levels MIN   the smallest L (0..MAX, default 0)\n"
    "  --hemicube R       one resolution only (8..1024) instead of 64 and 128\n"
    "  --quick            L = 0..1 at R = 16 (a smoke test)\n"
    "  --rays SCENE       instead: the ray caster's rays per second on SCENE (a file or\n"
    "                     'cornell'; one subpatch per triangle, 64 clustered patches, R 64\n"
    "                     or --hemicube R) from the receivers' centres and from points over\n"
    "                     their area, against Embree's rtcIntersect16 alone on lrr's centre\n"
    "                     rays, bit for bit (rotated frames, 4×4 coherent packets, a BVH of\n"
    "                     the same triangles built alike); each the best of 2 passes run in\n"
    "                     turn; CSV: scene,triangles,R,threads,rays,\n"
    "                     lrr_centre_rays_per_s,lrr_area_rays_per_s,embree_rays_per_s,\n"
    "                     centre_ratio,area_ratio (ratio = lrr / Embree)\n"
    "  -h, --help         show this help\n"
    "Threads: OMP_NUM_THREADS (the most threads tried).\n";

typedef struct rc_args {
    unsigned min_l, max_l, res[2];
    size_t n_res;
    const char *rays; /* --rays SCENE */
} rc_args;

static int parse_raycast(int argc, char *argv[], rc_args *a)
{
    static const struct option longopts[] = {
        {"levels", required_argument, NULL, OPT_N},
        {"min-levels", required_argument, NULL, OPT_K},
        {"hemicube", required_argument, NULL, OPT_HEMICUBE},
        {"quick", no_argument, NULL, OPT_QUICK},
        {"rays", required_argument, NULL, OPT_SCENE},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    const char *prog = "lrr-bench raycast";
    *a = (rc_args){.min_l = 0, .max_l = 4, .res = {64, 128}, .n_res = 2};
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case OPT_N:
            if (cli_parse_unsigned(prog, "--levels", optarg, 0, 5, &a->max_l) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_K:
            if (cli_parse_unsigned(prog, "--min-levels", optarg, 0, 5, &a->min_l) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 1024, &a->res[0]) != 0)
                return CLI_EXIT_USAGE;
            a->n_res = 1;
            break;
        case OPT_QUICK:
            *a = (rc_args){.min_l = 0, .max_l = 1, .res = {16, 0}, .n_res = 1, .rays = a->rays};
            break;
        case OPT_SCENE: a->rays = optarg; break;
        case 'h': fputs(raycast_help, stdout); return CLI_EXIT_OK;
        default: return bench_bad_option(prog, c, argv);
        }
    }
    if (a->min_l > a->max_l) {
        cli_usage_error(prog, "--min-levels %u is more than --levels %u", a->min_l, a->max_l);
        return CLI_EXIT_USAGE;
    }
    return bench_no_positional(prog, argc, argv) ? CLI_EXIT_USAGE : BENCH_RUN;
}

/* The Cornell box's subpatch triangles at level L as a scene (ρ 0.5, no emission), subdivided
 * at level 0 (one subpatch per triangle). CLI_EXIT_OK or a reported failure. */
static int tessellated(lrr_context *ctx, unsigned L, lrr_scene **out)
{
    *out = NULL;
    lrr_scene *box = NULL;
    lrr_operator *op = NULL;
    lrr_subdivision sd = {.max_patch_area = 1e30, .levels = L};
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 8; /* only the geometry is used */
    lrr_status s = lrr_scene_cornell_box(ctx, 0, &box);
    if (s == LRR_OK && (s = lrr_scene_subdivide(box, &sd)) == LRR_OK)
        s = lrr_operator_build(box, &bo, &op);
    lrr_scene_destroy(box);
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "the tessellated Cornell box");
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const size_t t = oi.n;
    float *v = bench_alloc_floats(t, 9), *rho = bench_alloc_floats(t, 3),
          *em = bench_alloc_floats(t, 3);
    if (v && rho && em) {
        lrr_operator_subpatch_vertices(op, v);
        for (size_t i = 0; i < 3 * t; i++)
            rho[i] = 0.5f;
        lrr_subdivision sd0 = {.max_patch_area = 1e30, .levels = 0};
        s = lrr_scene_create(ctx, t, v, rho, em, "tessellated", out);
        if (s == LRR_OK && (s = lrr_scene_subdivide(*out, &sd0)) != LRR_OK) {
            lrr_scene_destroy(*out);
            *out = NULL;
        }
    }
    int rc = !v || !rho || !em ? bench_fail("out of memory for %zu triangles", t)
             : s != LRR_OK     ? bench_lib_fail(ctx, s, "the tessellated scene")
                               : CLI_EXIT_OK;
    lrr_aligned_free(v);
    lrr_aligned_free(rho);
    lrr_aligned_free(em);
    lrr_operator_destroy(op);
    return rc;
}

/* Hemicubes per second of one method: n over the best form-factor phase of RC_BUILDS. */
static int rate(lrr_context *ctx, const lrr_scene *scene, unsigned res, int threads,
                int method, double *per_s)
{
    double best = HUGE_VAL;
    size_t n = 0;
    for (int b = 0; b < RC_BUILDS; b++) {
        lrr_build_options bo = lrr_build_options_defaults();
        bo.hemicube_resolution = res;
        bo.threads = threads;
        bo.seed = DEFAULT_SEED;
        bo.formfactor_method = method;
        bo.receiver_sampling = LRR_RECEIVER_CENTRE;
        bo.adaptive_patches = RC_PATCHES;
        bo.hierarchy = LRR_HIERARCHY_CLUSTER;
        bo.adaptive_split = LRR_SPLIT_AREA;
        lrr_operator *op = NULL;
        cli_idle_openblas();
        lrr_status s = lrr_operator_build(scene, &bo, &op);
        if (s != LRR_OK)
            return bench_lib_fail(ctx, s, method == LRR_FORMFACTOR_RAYCAST ? "raycast build"
                                                                            : "raster build");
        lrr_operator_info oi;
        lrr_operator_get_info(op, &oi, sizeof oi);
        n = oi.n;
        best = oi.formfactor_seconds < best ? oi.formfactor_seconds : best;
        lrr_operator_destroy(op);
    }
    *per_s = best > 0 ? (double)n / best : NAN;
    return CLI_EXIT_OK;
}

static int run_level(lrr_context *ctx, const rc_args *a, unsigned L)
{
    lrr_scene *scene = NULL;
    int rc = tessellated(ctx, L, &scene);
    lrr_scene_info si;
    if (rc == CLI_EXIT_OK)
        lrr_scene_get_info(scene, &si, sizeof si);
    const int threads[2] = {1, omp_get_max_threads()};
    const int n_threads = threads[1] > 1 ? 2 : 1;
    for (size_t r = 0; rc == CLI_EXIT_OK && r < a->n_res; r++)
        for (int t = 0; rc == CLI_EXIT_OK && t < n_threads; t++) {
            double raster = NAN, raycast = NAN;
            rc = rate(ctx, scene, a->res[r], threads[t], LRR_FORMFACTOR_RASTER, &raster);
            if (rc == CLI_EXIT_OK)
                rc = rate(ctx, scene, a->res[r], threads[t], LRR_FORMFACTOR_RAYCAST, &raycast);
            if (rc == CLI_EXIT_OK)
                printf("%zu,%u,%d,%.0f,%.0f,%.2f\n", si.triangles, a->res[r], threads[t], raster,
                       raycast, raycast / raster);
            fflush(stdout);
        }
    lrr_scene_destroy(scene);
    return rc;
}

int cmd_raycast(int argc, char *argv[])
{
    rc_args a;
    int rc = parse_raycast(argc, argv, &a);
    if (rc != BENCH_RUN)
        return rc;
    if (a.rays) {
        bench_print_machine();
        return bench_raycast_rays(a.rays, a.n_res == 1 ? a.res[0] : 64);
    }
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return bench_lib_fail(NULL, s, "context");
    bench_print_machine();
    printf("\nT,R,threads,raster_per_s,raycast_per_s,ratio\n");
    rc = CLI_EXIT_OK;
    for (unsigned L = a.min_l; rc == CLI_EXIT_OK && L <= a.max_l; L++) {
        bench_note("T = %u triangles", 36u << (2 * L));
        rc = run_level(ctx, &a, L);
    }
    lrr_context_destroy(ctx);
    return rc;
}
