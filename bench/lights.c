/* lrr-bench lights: the direct light of moving point lights (lrr_lighting_direct) per frame,
 * its shadow rays per second, and Embree's own occlusion rate on the same rays as the
 * baseline (plain OpenMP loops of rtcOccluded1 and rtcOccluded16 over a BVH of the subpatch
 * triangles). */
#include "bench.h"

#include "bench_embree.h"
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

static const char lights_help[] =
    "Usage: lrr-bench lights [OPTIONS]\n"
    "The direct light of N moving point lights on an operator's subpatches\n"
    "(lrr_lighting_direct: shadow rays against the operator's input triangles) per frame, in\n"
    "two cases: every light moves each frame (all traced), and one of them moves (the others\n"
    "come from the cache). Reports ms per frame (median, min, max), rays per frame (mean)\n"
    "and rays per second, against Embree's occlusion rate on the same rays (an OpenMP loop\n"
    "of rtcOccluded1, and rtcOccluded16 on 16 neighbouring receivers, over a BVH of the\n"
    "subpatch triangles, nothing else per ray).\n\n"
    "Options:\n"
    "  --operator FILE.lrr  the operator (default: the built-in Cornell box, --patches 216\n"
    "                       --levels 2, hemicube 32, built here)\n"
    "  --lights N           point lights (1..64, default 4)\n"
    "  --tolerance T        lrr_lighting_set_tolerance (default 0: every ray); prints\n"
    "                       each case's error against every ray over 10 more frames (the\n"
    "                       area-weighted relative L2 of E, the worst channel): mean, max\n"
    "  --repeat R           timed frames (default: at least 20 and 0.5 s)\n"
    "  -h, --help           show this help\n"
    "Threads: OMP_NUM_THREADS.\n";

typedef struct lights_run {
    lrr_lighting *lt;
    const lrr_operator *op;
    double tolerance;
    lrr_light_source *light;
    size_t count, moving; /* lights, how many move each frame */
    float lo[3], hi[3];   /* the box the lights move in */
    float *e;
    unsigned long frame;
    double rays, steps; /* rays cast and frames drawn since the last reset */
    lrr_status status;
} lights_run;

/* Light l at frame f: on a slow circle inside the middle of the scene's box. */
static void place(lights_run *r, size_t l, unsigned long f)
{
    double t = 0.05 * (double)f + 2 * M_PI * (double)l / (double)r->count;
    for (int j = 0; j < 3; j++) {
        double mid = 0.5 * (r->lo[j] + r->hi[j]), half = 0.25 * (r->hi[j] - r->lo[j]);
        r->light[l].position[j] = (float)(mid + half * (j == 1 ? 0.5 : j == 0 ? cos(t) : sin(t)));
    }
}

static int lights_step(void *user)
{
    lights_run *r = user;
    r->frame++;
    for (size_t l = 0; l < r->moving; l++)
        place(r, l, r->frame);
    r->status = lrr_lighting_direct(r->lt, r->light, r->count, r->e);
    r->rays += (double)lrr_lighting_rays(r->lt);
    r->steps += 1;
    return r->status != LRR_OK;
}

/* The ray from centre x (normal nv) to light position p, off the surface; 0 when the light is
 * behind the receiver. */
static int light_ray(const float *x, const float *nv, const float *p, float o[3], float d[3],
                     float *len)
{
    float w[3] = {p[0] - x[0], p[1] - x[1], p[2] - x[2]};
    *len = sqrtf(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    if (!(nv[0] * w[0] + nv[1] * w[1] + nv[2] * w[2] > 0))
        return 0;
    for (int j = 0; j < 3; j++) {
        o[j] = x[j] + 1e-4f * nv[j];
        d[j] = w[j] / *len;
    }
    return 1;
}

/* Embree alone on the rays of one frame with every light traced: one rtcOccluded1 per ray
 * (width 1), or per light rtcOccluded16 on 16 consecutive receivers (width 16), nothing else
 * per ray. The best of 5 passes. */
static double embree_pass(RTCScene sc, const float *ce, const float *nr, size_t n,
                          const lights_run *r, int width, double *rays)
{
    double cnt = 0;
    #pragma omp parallel for schedule(dynamic, 4) reduction(+ : cnt)
    for (size_t i0 = 0; i0 < n; i0 += 16) {
        struct RTCIntersectContext ictx;
        rtcInitIntersectContext(&ictx);
        for (size_t l = 0; l < r->count; l++) {
            struct RTCRay16 p16;
            int valid[16], any = 0;
            for (size_t i = i0; i < i0 + 16; i++) {
                unsigned k = (unsigned)(i - i0);
                float o[3], d[3], len;
                valid[k] = 0;
                if (i >= n || !light_ray(ce + 3 * i, nr + 3 * i, r->light[l].position, o, d, &len))
                    continue;
                cnt += 1;
                if (width == 1) {
                    struct RTCRay ray = {.org_x = o[0], .org_y = o[1], .org_z = o[2],
                                         .dir_x = d[0], .dir_y = d[1], .dir_z = d[2],
                                         .tfar = len, .mask = UINT32_MAX};
                    rtcOccluded1(sc, &ictx, &ray);
                    continue;
                }
                valid[k] = -1;
                any = 1;
                p16.org_x[k] = o[0], p16.org_y[k] = o[1], p16.org_z[k] = o[2];
                p16.dir_x[k] = d[0], p16.dir_y[k] = d[1], p16.dir_z[k] = d[2];
                p16.tnear[k] = 0, p16.tfar[k] = len, p16.time[k] = 0;
                p16.mask[k] = UINT32_MAX, p16.flags[k] = 0, p16.id[k] = k;
            }
            if (any)
                rtcOccluded16(valid, sc, &ictx, &p16);
        }
    }
    *rays = cnt;
    return cnt;
}

static double embree_rate(const lrr_operator *op, size_t n, const lights_run *r, int width,
                          double *rays)
{
    RTCDevice dev = rtcNewDevice(NULL);
    RTCScene sc = bench_embree_scene(dev, op, n, 0);
    if (!sc) {
        rtcReleaseDevice(dev);
        return 0;
    }
    const float *ce = lrr_operator_centre(op), *nr = lrr_operator_normal(op);
    double best = 0;
    for (int pass = 0; pass < 5; pass++) {
        double t0 = omp_get_wtime(), cnt = embree_pass(sc, ce, nr, n, r, width, rays);
        double dt = omp_get_wtime() - t0;
        if (cnt / dt > best)
            best = cnt / dt;
    }
    rtcReleaseScene(sc);
    rtcReleaseDevice(dev);
    return best;
}

static int parse_lights(int argc, char *argv[], const char **file, size_t *count, unsigned *repeat,
                        double *tolerance)
{
    static const struct option longopts[] = {{"operator", required_argument, NULL, OPT_SCENE},
                                             {"lights", required_argument, NULL, OPT_SOURCES},
                                             {"tolerance", required_argument, NULL, OPT_TOLERANCE},
                                             {"repeat", required_argument, NULL, OPT_REPEAT},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *prog = "lrr-bench lights";
    size_t rep = 0;
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case OPT_SCENE: *file = optarg; break;
        case OPT_SOURCES:
            if (cli_parse_size(prog, "--lights", optarg, 1, 64, count) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_TOLERANCE:
            if (cli_parse_double(prog, "--tolerance", optarg, 0, 0, 0.5, tolerance) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_REPEAT:
            if (cli_parse_size(prog, "--repeat", optarg, 1, MAX_RUNS, &rep) != 0)
                return CLI_EXIT_USAGE;
            *repeat = (unsigned)rep;
            break;
        case 'h': fputs(lights_help, stdout); return CLI_EXIT_OK;
        default: return bench_bad_option(prog, c, argv);
        }
    }
    return bench_no_positional(prog, argc, argv) ? CLI_EXIT_USAGE : BENCH_RUN;
}

/* The operator: from the file, or the Cornell box built here. */
static int get_operator(lrr_context *ctx, const char *file, lrr_operator **op)
{
    lrr_status s;
    if (file)
        return (s = lrr_operator_load(ctx, file, op)) ? bench_lib_fail(ctx, s, file) : CLI_EXIT_OK;
    lrr_scene *sc;
    if ((s = lrr_scene_builtin(ctx, "cornell", &sc)))
        return bench_lib_fail(ctx, s, "cornell");
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.target_patches = 216;
    sd.levels = 2;
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 32;
    if (!(s = lrr_scene_subdivide(sc, &sd)))
        s = lrr_operator_build(sc, &bo, op);
    lrr_scene_destroy(sc);
    return s ? bench_lib_fail(ctx, s, "building the Cornell box") : CLI_EXIT_OK;
}

static void bounds(const lrr_operator *op, size_t n, float lo[3], float hi[3])
{
    const float *ce = lrr_operator_centre(op);
    for (int j = 0; j < 3; j++)
        lo[j] = hi[j] = ce[j];
    for (size_t i = 0; i < n; i++)
        for (int j = 0; j < 3; j++) {
            lo[j] = fminf(lo[j], ce[3 * i + j]);
            hi[j] = fmaxf(hi[j], ce[3 * i + j]);
        }
}

#define ERROR_FRAMES 10

/* The last frame's E against every ray for the same lights (exact: a lighting without a
 * tolerance, e its n×3 scratch): the area-weighted relative L2 error, the worst of the three
 * channels. */
static int frame_error(const lights_run *r, lrr_lighting *exact, float *e, size_t n, double *err)
{
    if (lrr_lighting_direct(exact, r->light, r->count, e) != LRR_OK)
        return bench_fail("the exact frame failed");
    const float *a = lrr_operator_area(r->op);
    *err = 0;
    for (int c = 0; c < 3; c++) {
        double num = 0, den = 0;
        for (size_t i = 0; i < n; i++) {
            double d = (double)r->e[3 * i + c] - e[3 * i + c];
            num += a[i] * d * d;
            den += a[i] * (double)e[3 * i + c] * e[3 * i + c];
        }
        *err = fmax(*err, den > 0 ? sqrt(num / den) : 0);
    }
    return CLI_EXIT_OK;
}

/* ERROR_FRAMES more frames, each against every ray: the mean and the largest error. */
static int frames_error(lights_run *r, const char *label)
{
    lrr_operator_info oi;
    lrr_operator_get_info(r->op, &oi, sizeof oi);
    lrr_lighting *exact = NULL;
    float *e = calloc(3 * oi.n, sizeof *e);
    int rc = e && lrr_lighting_create(r->op, &exact) == LRR_OK
                 ? CLI_EXIT_OK
                 : bench_fail("%s: cannot set up the exact frames", label);
    double err = 0, sum = 0, most = 0;
    for (int f = 0; rc == CLI_EXIT_OK && f < ERROR_FRAMES; f++) {
        if (lights_step(r) != 0)
            rc = bench_fail("%s: lrr_lighting_direct failed", label);
        else if ((rc = frame_error(r, exact, e, oi.n, &err)) == CLI_EXIT_OK) {
            sum += err;
            most = fmax(most, err);
        }
    }
    if (rc == CLI_EXIT_OK)
        printf("%s_rel_l2: %.3g (max %.3g, %d frames)\n", label, sum / ERROR_FRAMES, most,
               ERROR_FRAMES);
    lrr_lighting_destroy(exact);
    free(e);
    return rc;
}

static int measure(lights_run *r, size_t moving, unsigned repeat, const char *label)
{
    r->moving = moving;
    r->rays = r->steps = 0;
    timing t;
    if (bench_time_frames(lights_step, r, repeat, &t) != 0)
        return bench_fail("%s: lrr_lighting_direct failed (%s)", label, lrr_strerror(r->status));
    double rays = r->rays / r->steps;
    printf("%s_ms: %.4f (min %.4f, max %.4f, %zu frames)\n", label, t.median, t.min, t.max,
           t.runs);
    printf("%s_rays: %.0f\n", label, rays);
    printf("%s_rays_per_s: %.4g\n", label, rays / (t.median * 1e-3));
    if (r->tolerance > 0)
        return frames_error(r, label);
    return CLI_EXIT_OK;
}

int cmd_lights(int argc, char *argv[])
{
    const char *file = NULL;
    size_t count = 4;
    unsigned repeat = 0;
    double tolerance = 0;
    int rc = parse_lights(argc, argv, &file, &count, &repeat, &tolerance);
    if (rc != BENCH_RUN)
        return rc;
    lrr_context *ctx;
    if (lrr_context_create(&ctx) != LRR_OK)
        return bench_fail("cannot create a context");
    lrr_operator *op = NULL;
    lights_run r = {.count = count, .tolerance = tolerance};
    rc = get_operator(ctx, file, &op);
    lrr_operator_info oi = {0};
    if (rc == CLI_EXIT_OK) {
        lrr_operator_get_info(op, &oi, sizeof oi);
        r.light = calloc(count, sizeof *r.light);
        r.e = calloc(3 * oi.n, sizeof(float));
        if (!r.light || !r.e)
            rc = bench_fail("out of memory");
    }
    lrr_status s = LRR_OK;
    r.op = op;
    if (rc == CLI_EXIT_OK && ((s = lrr_lighting_create(op, &r.lt)) ||
                              (s = lrr_lighting_set_tolerance(r.lt, tolerance))))
        rc = bench_lib_fail(ctx, s, "lrr_lighting_create");
    if (rc == CLI_EXIT_OK) {
        bench_print_machine();
        printf("operator: %s\nn: %zu\ntriangles: %zu\nlights: %zu\ntolerance: %g\n",
               file ? file : "cornell (built here)", oi.n, oi.triangles, count, tolerance);
        bounds(op, oi.n, r.lo, r.hi);
        for (size_t l = 0; l < count; l++) {
            r.light[l].kind = LRR_LIGHT_POINT;
            r.light[l].rgb[0] = r.light[l].rgb[1] = r.light[l].rgb[2] = 1.0f;
            place(&r, l, 0);
        }
        rc = measure(&r, count, repeat, "all_moving");
    }
    if (rc == CLI_EXIT_OK)
        rc = measure(&r, 1, repeat, "one_moving");
    if (rc == CLI_EXIT_OK) {
        for (int width = 1; width <= 16; width += 15) {
            double rays = 0, rate = embree_rate(op, oi.n, &r, width, &rays);
            printf("embree_occluded%d_rays: %.0f\nembree_occluded%d_rays_per_s: %.4g\n", width,
                   rays, width, rate);
        }
    }
    lrr_lighting_destroy(r.lt);
    free(r.light);
    free(r.e);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    return rc;
}
