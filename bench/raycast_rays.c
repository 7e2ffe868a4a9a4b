/* lrr-bench raycast --rays SCENE: the ray-cast hemicube's rays per second against Embree's
 * own rtcIntersect16 on the same rays over the same triangles — the ceiling of a form-factor
 * build whose every ray is one Embree hit query.
 *
 * lrr: one build of SCENE (subdivided one subpatch per triangle, clustered into 64 patches so
 * that F̄ stays small) at resolution R, its form-factor phase alone (formfactor_seconds), n
 * hemicubes of 3R² rays each, from the receivers' centres and from points spread over their
 * area (lrr_build_options.receiver_sampling). Embree alone: a BVH of the same triangles built
 * as lrr builds it (medium quality, robust), then per receiver the five faces' rays in 4×4
 * pixel packets (coherent) from the centre lifted off the surface, nothing else per ray: no
 * rotation, no item buffer, no integration. OpenMP over receivers, dynamic. */
#include "bench.h"

#include "bench_embree.h"

#include <float.h>
#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* rays of one receiver at resolution R: the top face R×R, four sides R×R/2, 4×4 packets */
static double receiver_rays(RTCScene sc, const float *x, const float *nv, unsigned R,
                            float lift)
{
    float t[3], b[3], a[3] = {1, 0, 0};
    if (fabsf(nv[0]) > 0.9f)
        a[0] = 0, a[1] = 1;
    t[0] = a[1] * nv[2] - a[2] * nv[1], t[1] = a[2] * nv[0] - a[0] * nv[2],
    t[2] = a[0] * nv[1] - a[1] * nv[0];
    const float tl = sqrtf(t[0] * t[0] + t[1] * t[1] + t[2] * t[2]);
    for (int j = 0; j < 3; j++)
        t[j] /= tl;
    b[0] = nv[1] * t[2] - nv[2] * t[1], b[1] = nv[2] * t[0] - nv[0] * t[2],
    b[2] = nv[0] * t[1] - nv[1] * t[0];
    /* faces as (right, up, forward): the top (t, b, n), the sides (b, n, ±t), (t, n, ±b),
     * of which only the upper half (above the horizon) is cast */
    float fr[5][3][3];
    for (int j = 0; j < 3; j++) {
        fr[0][0][j] = t[j], fr[0][1][j] = b[j], fr[0][2][j] = nv[j];
        for (int f = 1; f < 5; f++) {
            const float *side = f < 3 ? t : b, *across = f < 3 ? b : t;
            fr[f][0][j] = across[j];
            fr[f][1][j] = nv[j];
            fr[f][2][j] = f % 2 ? side[j] : -side[j];
        }
    }
    struct RTCIntersectContext ictx;
    rtcInitIntersectContext(&ictx);
    ictx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    double rays = 0, hits = 0;
    for (int f = 0; f < 5; f++) {
        const int W = (int)R, H = f ? (int)R / 2 : (int)R;
        const float inv = 2.0f / (float)W, y_off = f ? 0.0f : -1.0f;
        for (int y0 = 0; y0 < H; y0 += 4)
            for (int x0 = 0; x0 < W; x0 += 4) {
                struct RTCRayHit16 rh;
                int valid[16] __attribute__((aligned(64)));
                for (int l = 0; l < 16; l++) {
                    const int xx = x0 + l % 4, yy = y0 + l / 4;
                    valid[l] = xx < W && yy < H ? -1 : 0;
                    const float sx = (xx + 0.5f) * inv - 1.0f, sy = (yy + 0.5f) * inv + y_off;
                    const float *r = fr[f][0], *u = fr[f][1], *w = fr[f][2];
                    rh.ray.org_x[l] = x[0] + lift * nv[0];
                    rh.ray.org_y[l] = x[1] + lift * nv[1];
                    rh.ray.org_z[l] = x[2] + lift * nv[2];
                    rh.ray.dir_x[l] = sx * r[0] + sy * u[0] + w[0];
                    rh.ray.dir_y[l] = sx * r[1] + sy * u[1] + w[1];
                    rh.ray.dir_z[l] = sx * r[2] + sy * u[2] + w[2];
                    rh.ray.tnear[l] = 0.0f;
                    rh.ray.tfar[l] = INFINITY;
                    rh.ray.time[l] = 0.0f;
                    rh.ray.mask[l] = UINT32_MAX;
                    rh.ray.id[l] = (unsigned)l;
                    rh.ray.flags[l] = 0;
                    rh.hit.geomID[l] = RTC_INVALID_GEOMETRY_ID;
                    rh.hit.instID[0][l] = RTC_INVALID_GEOMETRY_ID;
                }
                rtcIntersect16(valid, sc, &ictx, &rh);
                for (int l = 0; l < 16; l++) {
                    rays += valid[l] != 0;
                    hits += valid[l] && rh.hit.geomID[l] != RTC_INVALID_GEOMETRY_ID;
                }
            }
    }
    return rays + 1e-12 * hits; /* hits read, so no query is optimised away */
}

/* Embree's rays per second over the operator's triangles from its subpatch centres (the
 * best of `passes`); *rays gets the count of one pass. */
static double embree_rays(const lrr_operator *op, size_t n, unsigned R, int passes,
                          double *rays)
{
    float *tri = malloc(n * 9 * sizeof(float));
    if (!tri)
        return 0;
    lrr_operator_subpatch_vertices(op, tri);
    float lo = INFINITY, hi = -INFINITY, maxabs = 0;
    for (size_t i = 0; i < 9 * n; i++) {
        lo = fminf(lo, tri[i]), hi = fmaxf(hi, tri[i]);
        maxabs = fmaxf(maxabs, fabsf(tri[i]));
    }
    free(tri);
    /* lrr's lift off the surface (lib/formfactor/raycast.c), the box diagonal bounded by
     * √3 × the largest extent */
    const float lift = 1e-6f * sqrtf(3.0f) * (hi - lo) + 8 * FLT_EPSILON * maxabs;
    RTCDevice dev = rtcNewDevice(NULL);
    RTCScene sc = bench_embree_scene(dev, op, n, 1);
    if (!sc) {
        rtcReleaseDevice(dev);
        return 0;
    }
    const float *ce = lrr_operator_centre(op), *nr = lrr_operator_normal(op);
    double best = 0;
    for (int p = 0; p < passes; p++) {
        double cnt = 0, t0 = omp_get_wtime();
        #pragma omp parallel for schedule(dynamic, 16) reduction(+ : cnt)
        for (size_t i = 0; i < n; i++)
            cnt += receiver_rays(sc, ce + 3 * i, nr + 3 * i, R, lift);
        const double dt = omp_get_wtime() - t0;
        best = fmax(best, floor(cnt) / dt);
        *rays = floor(cnt);
    }
    rtcReleaseScene(sc);
    rtcReleaseDevice(dev);
    return best;
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
    double centre = NAN, area = NAN, embree = NAN, rays = 0;
    size_t n = 0;
    lrr_operator *op = NULL;
    if (!rc) {
        bench_note("%s: lrr's ray-cast hemicubes at R %u, receivers' centres", name, R);
        rc = lrr_rays(ctx, scene, R, LRR_RECEIVER_CENTRE, &centre, &n, &op);
    }
    if (!rc) {
        bench_note("%s: lrr's ray-cast hemicubes, points over the receivers' area", name);
        rc = lrr_rays(ctx, scene, R, LRR_RECEIVER_AREA, &area, &n, NULL);
    }
    if (!rc) {
        bench_note("%s: Embree's rtcIntersect16 on the same rays", name);
        embree = embree_rays(op, n, R, 2, &rays);
        if (!(embree > 0))
            rc = bench_fail("%s: the Embree pass failed", name);
    }
    if (!rc) {
        printf("\nscene,triangles,R,threads,rays,lrr_centre_rays_per_s,lrr_area_rays_per_s,"
               "embree_rays_per_s,centre_ratio,area_ratio\n");
        printf("%s,%zu,%u,%d,%.0f,%.4g,%.4g,%.4g,%.3f,%.3f\n", name, n, R, omp_get_max_threads(),
               rays, centre, area, embree, centre / embree, area / embree);
    }
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}

RTCScene bench_embree_scene(RTCDevice dev, const lrr_operator *op, size_t n, int like_lrr)
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
    lrr_operator_subpatch_vertices(op, vb);
    for (size_t i = 0; i < 3 * n; i++)
        ib[i] = (unsigned)i;
    rtcCommitGeometry(g);
    rtcAttachGeometry(sc, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(sc);
    return sc;
}
