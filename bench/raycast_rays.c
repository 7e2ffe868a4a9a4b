/* lrr-bench raycast --rays SCENE: the ray-cast hemicube's rays per second against Embree's
 * own rtcIntersect16 on the same rays over the same triangles — the ceiling of a form-factor
 * build whose every ray is one Embree hit query.
 *
 * lrr: one build of SCENE (subdivided one subpatch per triangle, clustered into 64 patches so
 * that F̄ stays small) at resolution R, its form-factor phase alone (formfactor_seconds), n
 * hemicubes of 3R² rays each, from the receivers' centres and from points spread over their
 * area (lrr_build_options.receiver_sampling). Embree alone: lrr's own centre rays, bit for
 * bit — each receiver's frame with its random rotation about the normal, its faces, its pixel
 * centres and its origin lifted off the surface as lib/formfactor/hemicube.c and raycast.c
 * make them — in lrr's 4×4 packets (coherent) and order, over a BVH of the same triangles in
 * the same (scene) order built alike (medium quality, robust); nothing else per ray: no item
 * buffer, no integration. Both OpenMP over receivers, dynamic, 16 at a time, and the best of
 * RAYS_PASSES interleaved passes each (lrr centre, lrr area, Embree, then again), so that a
 * slow spell of a shared machine slows neither side alone. */
#include "bench.h"

#include "bench_embree.h"

#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define RAYS_PASSES 2

/* lib/core/internal.h's lrr__splitmix64 and lib/scene/scene.h's vector steps, copied so that
 * the rays come out bit for bit as lrr's */
static uint64_t splitmix64(uint64_t x)
{
    x += 0x9e3779b97f4a7c15ULL;
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
    return x ^ (x >> 31);
}
static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
static void normalize3(double v[3])
{
    double len = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (len > 0)
        for (int j = 0; j < 3; j++)
            v[j] /= len;
}

/* What the Embree pass needs: lrr's BVH, and per receiver (the operator's order) its
 * corners, scene-order id and the lift of lrr's ray origins. */
typedef struct {
    RTCScene sc;
    const float *tri; /* n×9, the operator's order */
    size_t n;
    const size_t *origin; /* lrr_operator_subpatch_origin, or NULL */
    double lift;
    unsigned R;
} rays_setup;

/* hemicube.c's receiver_frame (rotation on, seed DEFAULT_SEED) and its five faces as
 * (right, up, forward) rows in float, as raycast.c casts them; *org the lifted centre. */
static void lrr_faces(const rays_setup *rs, size_t i, float org[3], float fr[5][3][3])
{
    double v[9], x[3], N[3], e1[3], e2[3], U[3], Vv[3];
    for (int j = 0; j < 9; j++)
        v[j] = rs->tri[9 * i + j];
    for (int j = 0; j < 3; j++) {
        x[j] = (v[j] + v[3 + j] + v[6 + j]) / 3;
        e1[j] = v[3 + j] - v[j];
        e2[j] = v[6 + j] - v[j];
    }
    cross3(e1, e2, N);
    normalize3(N);
    double helper[3] = {1, 0, 0}, U0[3], V0[3];
    if (fabs(N[0]) > 0.6) { helper[0] = 0; helper[1] = 1; }
    cross3(helper, N, U0);
    normalize3(U0);
    cross3(N, U0, V0);
    const size_t id = rs->origin ? rs->origin[i] : i;
    const double theta =
        2 * M_PI * (double)(splitmix64(DEFAULT_SEED ^ splitmix64(id)) >> 11) * 0x1.0p-53;
    const double ct = cos(theta), st = sin(theta);
    for (int j = 0; j < 3; j++)
        U[j] = ct * U0[j] + st * V0[j];
    cross3(N, U, Vv);
    for (int fi = 0; fi < 5; fi++) {
        double right[3], up[3], fwd[3];
        if (fi == 0) {
            memcpy(fwd, N, sizeof N), memcpy(right, U, sizeof U), memcpy(up, Vv, sizeof Vv);
        } else {
            const double *ax = (fi == 1 || fi == 2) ? U : Vv, sgn = (fi == 1 || fi == 3) ? 1 : -1;
            for (int j = 0; j < 3; j++)
                fwd[j] = sgn * ax[j];
            memcpy(up, N, sizeof N);
            cross3(up, fwd, right);
        }
        for (int j = 0; j < 3; j++)
            fr[fi][0][j] = (float)right[j], fr[fi][1][j] = (float)up[j],
            fr[fi][2][j] = (float)fwd[j];
    }
    for (int j = 0; j < 3; j++)
        org[j] = (float)(x[j] + rs->lift * N[j]);
}

/* rays of one receiver at resolution R: the top face R×R, four sides R×R/2, 4×4 packets */
static double receiver_rays(const rays_setup *rs, size_t i)
{
    float org[3], fr[5][3][3];
    lrr_faces(rs, i, org, fr);
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    ictx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    struct RTCRayHit16 rh;
    for (int l = 0; l < 16; l++) {
        rh.ray.org_x[l] = org[0], rh.ray.org_y[l] = org[1], rh.ray.org_z[l] = org[2];
        rh.ray.tnear[l] = 0.0f, rh.ray.time[l] = 0.0f, rh.ray.mask[l] = UINT32_MAX;
        rh.ray.id[l] = (unsigned)l, rh.ray.flags[l] = 0;
    }
    double rays = 0, hits = 0;
    for (int f = 0; f < 5; f++) {
        const int W = (int)rs->R, H = f ? W / 2 : W;
        const float inv = 2.0f / (float)W, y_off = f ? 0.0f : -1.0f;
        const float *r = fr[f][0], *u = fr[f][1], *w = fr[f][2];
        for (int y0 = 0; y0 < H; y0 += 4)
            for (int x0 = 0; x0 < W; x0 += 4) {
                int valid[16] __attribute__((aligned(64)));
                for (int l = 0; l < 16; l++) {
                    const int xx = x0 + l % 4, yy = y0 + l / 4;
                    valid[l] = xx < W && yy < H ? -1 : 0;
                    const float sx = (xx + 0.5f) * inv - 1.0f, sy = (yy + 0.5f) * inv + y_off;
                    rh.ray.dir_x[l] = sx * r[0] + sy * u[0] + w[0];
                    rh.ray.dir_y[l] = sx * r[1] + sy * u[1] + w[1];
                    rh.ray.dir_z[l] = sx * r[2] + sy * u[2] + w[2];
                    rh.ray.tfar[l] = INFINITY;
                    rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
                }
                rtcIntersect16(valid, rs->sc, &ictx, &rh);
                for (int l = 0; l < 16; l++) {
                    rays += valid[l] != 0;
                    hits += valid[l] && rh.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID;
                }
            }
    }
    return rays + 1e-12 * hits; /* hits read, so no query is optimised away */
}

/* An Embree scene of n triangles whose 9n vertex floats fill() writes, indexed in order;
 * robust and of medium build quality, as lrr's BVHs are, when like_lrr. NULL on failure. */
static RTCScene triangle_scene(RTCDevice dev, size_t n, int like_lrr,
                               void (*fill)(float *vb, const void *user), const void *user)
{
    RTCScene sc = rtcNewScene(dev);
    RTCGeometry g = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    if (!sc || !g)
        return NULL;
    if (like_lrr) {
        rtcSetSceneFlags(sc, RTC_SCENE_FLAG_ROBUST);
        rtcSetSceneBuildQuality(sc, RTC_BUILD_QUALITY_MEDIUM);
    }
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                        3 * sizeof(float), 3 * n);
    unsigned *ib = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           3 * sizeof(unsigned), n);
    if (!vb || !ib) {
        rtcReleaseGeometry(g);
        rtcReleaseScene(sc);
        return NULL;
    }
    fill(vb, user);
    for (size_t i = 0; i < 3 * n; i++)
        ib[i] = (unsigned)i;
    rtcCommitGeometry(g);
    rtcAttachGeometry(sc, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(sc);
    return sc;
}

/* lrr's triangles (rays_setup) back in the scene's order. */
static void fill_scene_order(float *vb, const void *user)
{
    const rays_setup *rs = user;
    for (size_t i = 0; i < rs->n; i++)
        memcpy(vb + 9 * (rs->origin ? rs->origin[i] : i), rs->tri + 9 * i, 9 * sizeof(float));
}

/* Embree's scene of the operator's triangles in the scene's order (lrr's BVH holds the
 * input triangles, primitive = scene index) and lrr's lift (raycast.c: 1e-6 of the bounding
 * box's diagonal, lib/scene/subdivide.c's, plus 8 float ulps of the largest coordinate). */
static RTCScene lrr_scene_bvh(RTCDevice dev, rays_setup *rs, size_t n)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    double maxabs = 0;
    for (size_t k = 0; k < 9 * n; k++) {
        const int j = (int)(k % 3);
        lo[j] = fmin(lo[j], rs->tri[k]), hi[j] = fmax(hi[j], rs->tri[k]);
        maxabs = fmax(maxabs, fabs(rs->tri[k]));
    }
    const double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                             (hi[2] - lo[2]) * (hi[2] - lo[2]));
    rs->lift = 1e-6 * diag + 8 * FLT_EPSILON * maxabs;
    rs->n = n;
    return triangle_scene(dev, n, 1, fill_scene_order, rs);
}

/* One Embree pass over lrr's centre rays: rays per second; *rays gets their count. */
static double embree_pass(const rays_setup *rs, size_t n, double *rays)
{
    double cnt = 0, t0 = omp_get_wtime();
    #pragma omp parallel for schedule(dynamic, 16) reduction(+ : cnt)
    for (size_t i = 0; i < n; i++)
        cnt += receiver_rays(rs, i);
    const double dt = omp_get_wtime() - t0;
    *rays = floor(cnt);
    return floor(cnt) / dt;
}

/* lrr's form-factor phase on scene at R with the given receiver sampling: rays per second,
 * and the operator (for Embree's pass over the same triangles) when keep is not NULL */
static int lrr_rays(lrr_context *ctx, const lrr_scene *scene, unsigned R, int sampling,
                    double *per_s, size_t *n, lrr_operator **keep)
{
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = R;
    bo.seed = DEFAULT_SEED;
    bo.formfactor_method = LRR_FORMFACTOR_RAYCAST;
    bo.receiver_sampling = sampling;
    bo.adaptive_patches = 64;
    bo.hierarchy = LRR_HIERARCHY_CLUSTER;
    bo.adaptive_split = LRR_SPLIT_AREA;
    lrr_operator *op = NULL;
    cli_idle_openblas();
    lrr_status s = lrr_operator_build(scene, &bo, &op);
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "raycast build");
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    *n = oi.n;
    *per_s = oi.formfactor_seconds > 0 ? 3.0 * R * R * (double)oi.n / oi.formfactor_seconds
                                       : NAN;
    if (keep)
        *keep = op;
    else
        lrr_operator_destroy(op);
    return CLI_EXIT_OK;
}

/* RAYS_PASSES rounds of lrr centre, lrr area, Embree; the best of each into best[3]. */
static int rays_passes(lrr_context *ctx, const lrr_scene *scene, const char *name, unsigned R,
                       double best[3], double *rays, size_t *n)
{
    lrr_operator *op = NULL;
    RTCDevice dev = NULL;
    rays_setup rs = {.R = R};
    float *tri = NULL;
    int rc = CLI_EXIT_OK;
    for (int p = 0; p < RAYS_PASSES && !rc; p++) {
        double v[3] = {NAN, NAN, NAN};
        bench_note("%s: pass %d: lrr's ray-cast hemicubes at R %u, receivers' centres", name,
                   p + 1, R);
        rc = lrr_rays(ctx, scene, R, LRR_RECEIVER_CENTRE, &v[0], n, op ? NULL : &op);
        if (!rc) {
            bench_note("%s: lrr's ray-cast hemicubes, points over the receivers' area", name);
            rc = lrr_rays(ctx, scene, R, LRR_RECEIVER_AREA, &v[1], n, NULL);
        }
        if (!rc && !dev) { /* lrr's rays and BVH, once */
            rs.origin = lrr_operator_subpatch_origin(op);
            if (!(tri = malloc(*n * 9 * sizeof(float))))
                rc = bench_fail("%s: out of memory", name);
            else
                lrr_operator_subpatch_vertices(op, tri);
            rs.tri = tri;
            dev = rc ? NULL : rtcNewDevice(NULL);
            if (!rc && (!dev || !(rs.sc = lrr_scene_bvh(dev, &rs, *n))))
                rc = bench_fail("%s: the Embree scene failed", name);
        }
        if (!rc) {
            bench_note("%s: Embree's rtcIntersect16 on the same rays", name);
            v[2] = embree_pass(&rs, *n, rays);
        }
        for (int j = 0; j < 3 && !rc; j++)
            best[j] = p == 0 ? v[j] : fmax(best[j], v[j]);
    }
    if (rs.sc)
        rtcReleaseScene(rs.sc);
    if (dev)
        rtcReleaseDevice(dev);
    free(tri);
    lrr_operator_destroy(op);
    return rc;
}

int bench_raycast_rays(const char *name, unsigned R)
{
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return bench_lib_fail(NULL, s, "context");
    lrr_scene *scene = NULL;
    int rc = bench_open_scene(ctx, name, &scene);
    lrr_subdivision sd = {.max_patch_area = 1e30, .levels = 0}; /* a subpatch per triangle */
    if (!rc && (s = lrr_scene_subdivide(scene, &sd)) != LRR_OK)
        rc = bench_lib_fail(ctx, s, name);
    double best[3] = {NAN, NAN, NAN}, rays = 0; /* centre, area, Embree */
    size_t n = 0;
    if (!rc)
        rc = rays_passes(ctx, scene, name, R, best, &rays, &n);
    if (!rc && !(best[2] > 0))
        rc = bench_fail("%s: the Embree pass failed", name);
    if (!rc) {
        printf("\nscene,triangles,R,threads,rays,lrr_centre_rays_per_s,lrr_area_rays_per_s,"
               "embree_rays_per_s,centre_ratio,area_ratio\n");
        printf("%s,%zu,%u,%d,%.0f,%.4g,%.4g,%.4g,%.3f,%.3f\n", name, n, R, omp_get_max_threads(),
               rays, best[0], best[1], best[2], best[0] / best[2], best[1] / best[2]);
    }
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}

static void fill_subpatches(float *vb, const void *op)
{
    lrr_operator_subpatch_vertices(op, vb);
}

RTCScene bench_embree_scene(RTCDevice dev, const lrr_operator *op, size_t n, int like_lrr)
{
    return triangle_scene(dev, n, like_lrr, fill_subpatches, op);
}
