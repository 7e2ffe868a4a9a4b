/* The render camera: the Cornell box's published view for the built-in boxes, otherwise
 * one that frames the scene's bounds from the side that shows more front faces. */
#include "config.h"
#include "output/render_internal.h"

#include <math.h>
#include <string.h>

static void camera_orient(lrr__camera *cam, const double fwd[3])
{
    static const double world_up[3] = {0, 1, 0};
    memcpy(cam->fwd, fwd, sizeof cam->fwd);
    lrr__normalize3(cam->fwd);
    /* image right = forward × up: for the Cornell camera this is −x, so the red wall at
     * x ≈ 556 appears on the left, as in the published pictures */
    lrr__cross3(cam->fwd, world_up, cam->right);
    lrr__normalize3(cam->right);
    lrr__cross3(cam->right, cam->fwd, cam->up);
}

void lrr__render_scene_bounds(const lrr__geometry *g, double lo[3], double hi[3])
{
    for (int j = 0; j < 3; j++) {
        lo[j] = INFINITY;
        hi[j] = -INFINITY;
    }
    for (size_t i = 0; i < 9 * g->n_tri; i++) {
        int j = (int)(i % 3);
        double x = g->vert[i];
        if (x < lo[j]) lo[j] = x;
        if (x > hi[j]) hi[j] = x;
    }
    if (g->n_tri == 0)
        for (int j = 0; j < 3; j++)
            lo[j] = hi[j] = 0;
}

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

void lrr__render_camera_setup(lrr__camera *cam, const lrr_operator *op, int cornell,
                              unsigned width, unsigned height)
{
    double aspect = (double)width / height;
    double lo[3], hi[3];
    lrr__render_scene_bounds(&op->geom, lo, hi);
    double diag = sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                       (hi[2] - lo[2]) * (hi[2] - lo[2]));
    if (!(diag > 0) || !isfinite(diag))
        diag = 1;
    if (cornell) {
        /* eye (278,273,-800) looking along +z, 35 mm lens on 25×25 mm film; non-square
         * pictures keep the vertical field of view */
        static const double eye[3] = {278, 273, -800}, fwd[3] = {0, 0, 1};
        memcpy(cam->eye, eye, sizeof eye);
        camera_orient(cam, fwd);
        cam->tan_y = 12.5 / 35.0;
        cam->tan_x = cam->tan_y * aspect;
        cam->near = 1e-4 * diag;
        return;
    }
    /* Frame the bounding sphere in a 40° field of view from slightly above, on the +z side
     * (OpenGL's habit: +x right, looking along −z), unless the −z side shows more front
     * faces (e.g. a Cornell box read from a file, open towards −z). */
    double c[3], r = 0.5 * diag;
    for (int j = 0; j < 3; j++)
        c[j] = 0.5 * (lo[j] + hi[j]);
    cam->tan_y = tan(20.0 * M_PI / 180.0);
    cam->tan_x = cam->tan_y * aspect;
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
    camera_orient(cam, fwd);
    cam->near = fmax(0.5 * (dist - r), 1e-6 * r);
}
