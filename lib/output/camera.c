/* The render camera: an explicit eye/target pinhole, the Cornell box's published view for
 * the built-in boxes, a view from inside a lit closed scene, or one that frames the scene's
 * bounds from the side that shows more front faces. */
#include "config.h"
#include "output/render_internal.h"
#include "scene/bvh.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

/* Default vertical fields of view (degrees) of the eye/inside and the framing cameras. */
#define EYE_FOV 60.0
#define FRAMING_FOV 40.0
/* The closed-scene test: rays from a candidate eye along a spiral of directions, of which
 * this fraction must first meet a triangle facing the eye (2 of 128 may slip through an
 * edge or a crack; an open side of a box lets through far more). */
#define INSIDE_RAYS 128
#define INSIDE_ENCLOSED 0.98

static void camera_orient(lrr__camera *cam, const double fwd[3], const double up[3])
{
    memcpy(cam->fwd, fwd, sizeof cam->fwd);
    lrr__normalize3(cam->fwd);
    /* image right = forward × up: for the Cornell camera this is −x, so the red wall at
     * x ≈ 556 appears on the left, as in the published pictures */
    lrr__cross3(cam->fwd, up, cam->right);
    lrr__normalize3(cam->right);
    lrr__cross3(cam->right, cam->fwd, cam->up);
}

static const double world_up[3] = {0, 1, 0};

/* Projected area of the front faces seen from eye (occlusion ignored): used to decide from
 * which side a scene is meant to be seen. */
static double front_area(const lrr_operator *op, const double eye[3])
{
    double sum = 0;
    #pragma omp parallel for reduction(+ : sum) schedule(static)
    for (size_t i = 0; i < op->n; i++) {
        double d[3], len2 = 0, cosv = 0;
        for (int j = 0; j < 3; j++) {
            d[j] = eye[j] - op->centre[3 * i + j];
            len2 += d[j] * d[j];
            cosv += d[j] * op->normal[3 * i + j];
        }
        if (cosv > 0 && len2 > 0)
            sum += op->area[i] * cosv / sqrt(len2);
    }
    return sum;
}

/* ------------------------------------------------------------------ inside a closed scene */

/* Direction k of n, spread evenly over the sphere (golden-angle spiral): irrational angles,
 * so no ray runs exactly along the edges of an axis-aligned room. */
static void sphere_dir(int k, int n, double d[3])
{
    double z = 1 - (2 * k + 1) / (double)n, r = sqrt(fmax(0, 1 - z * z));
    double phi = k * M_PI * (3 - sqrt(5.0));
    d[0] = r * cos(phi);
    d[1] = z;
    d[2] = r * sin(phi);
}

/* Whether p is enclosed: INSIDE_ENCLOSED of the rays from p first meet a triangle facing p
 * (inside a room, not outside it, in a wall or in a piece of furniture). Rays go through the
 * scene's shared Embree BVH (scene/bvh.c), so the test costs ∝ log T per ray. */
static int enclosed(const lrr__bvh *bvh, const lrr__geometry *g, const double p[3])
{
    int hits = 0; /* 128 rays through a BVH: microseconds, less than waking a thread team */
    for (int k = 0; k < INSIDE_RAYS; k++) {
        double d[3];
        sphere_dir(k, INSIDE_RAYS, d);
        struct RTCIntersectContext ictx;
        rtcInitIntersectContext(&ictx);
        struct RTCRayHit rh;
        memset(&rh, 0, sizeof rh);
        rh.ray.org_x = (float)p[0];
        rh.ray.org_y = (float)p[1];
        rh.ray.org_z = (float)p[2];
        rh.ray.dir_x = (float)d[0];
        rh.ray.dir_y = (float)d[1];
        rh.ray.dir_z = (float)d[2];
        rh.ray.tnear = 0.0f;
        rh.ray.tfar = INFINITY;
        rh.ray.mask = UINT32_MAX;
        rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(bvh->scene, &ictx, &rh);
        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID)
            continue;
        /* the triangle faces p when its normal (v1 − v0) × (v2 − v0) points back along d */
        const float *v = g->vert + 9 * (size_t)rh.hit.primID;
        double e1[3], e2[3], n[3];
        for (int j = 0; j < 3; j++) {
            e1[j] = (double)v[3 + j] - v[j];
            e2[j] = (double)v[6 + j] - v[j];
        }
        lrr__cross3(e1, e2, n);
        hits += lrr__dot3(n, d) < 0;
    }
    return hits >= INSIDE_ENCLOSED * INSIDE_RAYS;
}

static int emits_light(const lrr_operator *op)
{
    if (!op->emission)
        return 0;
    for (size_t i = 0; i < 3 * op->n; i++)
        if (op->emission[i] > 0)
            return 1;
    return 0;
}

/* How much light a camera shows (occlusion ignored): the luminance of the front faces whose
 * centres fall in its view, weighted by the solid angle they cover. */
static double lit_in_view(const lrr_operator *op, const float *radiosity, const lrr__camera *c)
{
    double sum = 0;
    #pragma omp parallel for reduction(+ : sum) schedule(static) \
        if (op->n > LRR__PARALLEL_MIN / 16)
    for (size_t i = 0; i < op->n; i++) {
        double d[3], len2 = 0, cosv = 0;
        for (int j = 0; j < 3; j++) {
            d[j] = op->centre[3 * i + j] - c->eye[j];
            len2 += d[j] * d[j];
            cosv -= d[j] * op->normal[3 * i + j];
        }
        double w = lrr__dot3(d, c->fwd);
        if (!(cosv > 0) || !(w > 0) || fabs(lrr__dot3(d, c->right)) > c->tan_x * w ||
            fabs(lrr__dot3(d, c->up)) > c->tan_y * w)
            continue;
        const float *b = radiosity + 3 * i;
        double lum = 0.2126 * b[0] + 0.7152 * b[1] + 0.0722 * b[2];
        sum += op->area[i] * cosv / (len2 * sqrt(len2)) * lum;
    }
    return sum;
}

/* The automatic camera of a closed scene with light sources (docs/METHOD.md "Cameras"):
 * the eye at 60% of the height, 10% of the longest horizontal side a from one of its ends
 * (else at the centre), looking horizontally along a towards the other end; of the enclosed
 * candidates, the one that shows more lit area. Returns 0 (cam unset) when the scene emits
 * nothing or no candidate is enclosed. */
static lrr_status inside_camera(lrr__camera *cam, const lrr_operator *op,
                                const float *radiosity, const double lo[3], const double hi[3],
                                int *found)
{
    *found = 0;
    if (!emits_light(op))
        return LRR_OK;
    lrr__bvh bvh;
    lrr_status st = lrr__bvh_build(op->ctx, &op->geom, RTC_BUILD_QUALITY_LOW, 1,
                                   "lrr_render (inside camera)", &bvh);
    if (st)
        return st;
    int a = hi[0] - lo[0] >= hi[2] - lo[2] ? 0 : 2;
    static const double back[2] = {0.1, 0.5};
    for (int f = 0; f < 2; f++) {
        lrr__camera cand;
        double best = -1;
        for (int s = 0; s < 2; s++) { /* s = 0: look towards +a from near lo[a] */
            memcpy(&cand, cam, sizeof cand);
            for (int j = 0; j < 3; j++)
                cand.eye[j] = 0.5 * (lo[j] + hi[j]);
            cand.eye[1] = lo[1] + 0.6 * (hi[1] - lo[1]);
            double ext = hi[a] - lo[a];
            cand.eye[a] = s == 0 ? lo[a] + back[f] * ext : hi[a] - back[f] * ext;
            double fwd[3] = {0, 0, 0};
            fwd[a] = s == 0 ? 1 : -1;
            camera_orient(&cand, fwd, world_up);
            if (!enclosed(&bvh, &op->geom, cand.eye))
                continue;
            double lit = lit_in_view(op, radiosity, &cand);
            if (lit > best) {
                best = lit;
                memcpy(cam, &cand, sizeof cand);
            }
        }
        if (best >= 0) {
            *found = 1;
            break;
        }
    }
    st = lrr__bvh_status(op->ctx, &bvh, "ray query");
    lrr__bvh_release(&bvh);
    return st;
}

/* ------------------------------------------------------------------ the camera */

/* A vertical field of view of fov degrees; the horizontal one follows the aspect ratio. */
static void set_fov(lrr__camera *cam, double fov, double aspect)
{
    cam->tan_y = tan(0.5 * fov * M_PI / 180.0);
    cam->tan_x = cam->tan_y * aspect;
}

/* The eye/target camera (lrr_render_options.use_eye; render.c checked its vectors). */
static void eye_camera(lrr__camera *cam, const lrr_render_options *o)
{
    double fwd[3], up[3];
    int zero_up = o->up[0] == 0 && o->up[1] == 0 && o->up[2] == 0;
    for (int j = 0; j < 3; j++) {
        fwd[j] = o->target[j] - o->eye[j];
        up[j] = zero_up ? world_up[j] : o->up[j];
    }
    memcpy(cam->eye, o->eye, sizeof cam->eye);
    camera_orient(cam, fwd, up);
}

/* The camera framing the bounding sphere (centre c, radius r) from slightly above, on the +z
 * side (OpenGL's habit: +x right, looking along −z), unless the −z side shows more front
 * faces (e.g. a Cornell box read from a file, open towards −z). */
static void framing_camera(lrr__camera *cam, const lrr_operator *op, const double c[3],
                           double r)
{
    double half = atan(fmin(cam->tan_x, cam->tan_y));
    double dist = 1.02 * r / sin(half);
    double dir[2][3] = {{0, 0.3, 1}, {0, 0.3, -1}}, eyes[2][3];
    for (int s = 0; s < 2; s++) {
        lrr__normalize3(dir[s]);
        for (int j = 0; j < 3; j++)
            eyes[s][j] = c[j] + dist * dir[s][j];
    }
    int side = front_area(op, eyes[1]) > 1.0001 * front_area(op, eyes[0]) ? 1 : 0;
    memcpy(cam->eye, eyes[side], sizeof cam->eye);
    double fwd[3] = {-dir[side][0], -dir[side][1], -dir[side][2]};
    camera_orient(cam, fwd, world_up);
    cam->near = fmax(0.5 * (dist - r), 1e-6 * r);
}

lrr_status lrr__render_camera_setup(lrr__camera *cam, const lrr_operator *op,
                                    const float *radiosity, const lrr_render_options *o,
                                    unsigned width, unsigned height)
{
    double aspect = (double)width / height;
    double lo[3], hi[3];
    double diag = lrr__geometry_bounds(&op->geom, lo, hi);
    if (!(diag > 0) || !isfinite(diag))
        diag = 1;
    int cornell = !o->use_eye && (o->use_cornell_camera == 1 ||
                                  (o->use_cornell_camera == -1 &&
                                   (op->builtin == LRR__SCENE_CORNELL ||
                                    op->builtin == LRR__SCENE_CORNELL_CLOSED)));
    /* eye, Cornell and inside cameras: a near plane just in front of the eye, so walls
     * around and behind it are clipped (raster.c), never drawn mirrored */
    cam->near = 1e-4 * diag;
    if (cornell) {
        /* eye (278,273,-800) looking along +z, 35 mm lens on 25×25 mm film; non-square
         * pictures keep the vertical field of view */
        static const double eye[3] = {278, 273, -800}, fwd[3] = {0, 0, 1};
        memcpy(cam->eye, eye, sizeof eye);
        camera_orient(cam, fwd, world_up);
        if (o->fov_degrees > 0) {
            set_fov(cam, o->fov_degrees, aspect);
        } else {
            cam->tan_y = 12.5 / 35.0;
            cam->tan_x = cam->tan_y * aspect;
        }
        return LRR_OK;
    }
    if (o->use_eye) {
        set_fov(cam, o->fov_degrees > 0 ? o->fov_degrees : EYE_FOV, aspect);
        eye_camera(cam, o);
        return LRR_OK;
    }
    if (o->use_cornell_camera == -1) {
        set_fov(cam, o->fov_degrees > 0 ? o->fov_degrees : EYE_FOV, aspect);
        int inside;
        lrr_status st = inside_camera(cam, op, radiosity, lo, hi, &inside);
        if (st || inside)
            return st;
    }
    set_fov(cam, o->fov_degrees > 0 ? o->fov_degrees : FRAMING_FOV, aspect);
    double c[3];
    for (int j = 0; j < 3; j++)
        c[j] = 0.5 * (lo[j] + hi[j]);
    framing_camera(cam, op, c, 0.5 * diag);
    return LRR_OK;
}
