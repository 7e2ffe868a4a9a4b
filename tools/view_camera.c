/* The viewer's camera: a target, a distance and two angles (orbit), moved as a whole for
 * flying; its matrices for GL (column-major) and the rays through pixels for picking. */
#include "view_internal.h"

#include <math.h>
#include <string.h>

static void cam_forward(const view_camera *c, double f[3])
{
    f[0] = cos(c->pitch) * sin(c->yaw);
    f[1] = sin(c->pitch);
    f[2] = cos(c->pitch) * cos(c->yaw);
}

static void cross3(const double a[3], const double b[3], double o[3])
{
    o[0] = a[1] * b[2] - a[2] * b[1];
    o[1] = a[2] * b[0] - a[0] * b[2];
    o[2] = a[0] * b[1] - a[1] * b[0];
}

static void normalize3(double v[3])
{
    double l = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
    if (l > 0)
        for (int j = 0; j < 3; j++)
            v[j] /= l;
}

void view_camera_look(view_camera *c, const double eye[3], const double target[3])
{
    double d[3];
    for (int j = 0; j < 3; j++)
        d[j] = target[j] - eye[j];
    c->dist = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(c->dist > 0))
        c->dist = 1;
    normalize3(d);
    c->pitch = asin(fmax(-1.0, fmin(1.0, d[1])));
    c->yaw = atan2(d[0], d[2]);
    memcpy(c->target, target, sizeof c->target);
}

void view_camera_eye(const view_camera *c, double eye[3])
{
    double f[3];
    cam_forward(c, f);
    for (int j = 0; j < 3; j++)
        eye[j] = c->target[j] - c->dist * f[j];
}

/* The camera frame: forward, right (forward × up, as the renderer's camera) and up. */
void view_camera_frame(const view_camera *c, double f[3], double r[3], double u[3])
{
    static const double world_up[3] = {0, 1, 0};
    cam_forward(c, f);
    cross3(f, world_up, r);
    normalize3(r);
    cross3(r, f, u);
}

void view_camera_orbit(view_camera *c, double dyaw, double dpitch)
{
    c->yaw += dyaw;
    c->pitch = fmax(-1.55, fmin(1.55, c->pitch + dpitch)); /* never straight up: up is +y */
}

/* Moves eye and target together by (right, up, forward) amounts in scene units. */
void view_camera_move(view_camera *c, double right, double up, double fwd)
{
    double f[3], r[3], u[3];
    view_camera_frame(c, f, r, u);
    for (int j = 0; j < 3; j++)
        c->target[j] += right * r[j] + up * u[j] + fwd * f[j];
}

/* proj · view, column-major, for a width/height picture. */
void view_camera_matrix(const view_camera *c, double aspect, float m[16])
{
    double f[3], r[3], u[3], eye[3];
    view_camera_frame(c, f, r, u);
    view_camera_eye(c, eye);
    double t = tan(c->fov_y * M_PI / 360), n = c->near_z, fa = c->far_z;
    double p00 = 1 / (t * aspect), p11 = 1 / t, p22 = -(fa + n) / (fa - n),
           p23 = -2 * fa * n / (fa - n);
    double v[3][4]; /* rows of the view matrix: right, up, −forward */
    for (int j = 0; j < 3; j++) {
        v[0][j] = r[j];
        v[1][j] = u[j];
        v[2][j] = -f[j];
    }
    v[0][3] = -(r[0] * eye[0] + r[1] * eye[1] + r[2] * eye[2]);
    v[1][3] = -(u[0] * eye[0] + u[1] * eye[1] + u[2] * eye[2]);
    v[2][3] = f[0] * eye[0] + f[1] * eye[1] + f[2] * eye[2];
    for (int col = 0; col < 4; col++) {
        m[4 * col + 0] = (float)(p00 * v[0][col]);
        m[4 * col + 1] = (float)(p11 * v[1][col]);
        m[4 * col + 2] = (float)(p22 * v[2][col] + (col == 3 ? p23 : 0));
        m[4 * col + 3] = (float)-v[2][col];
    }
}

/* The ray through pixel (x, y) (origin top left) of a w×h picture. */
void view_camera_ray(const view_camera *c, double x, double y, int w, int h, double org[3],
                     double dir[3])
{
    double f[3], r[3], u[3];
    view_camera_frame(c, f, r, u);
    view_camera_eye(c, org);
    double t = tan(c->fov_y * M_PI / 360);
    double sx = (2 * (x + 0.5) / w - 1) * t * w / h, sy = (1 - 2 * (y + 0.5) / h) * t;
    for (int j = 0; j < 3; j++)
        dir[j] = f[j] + sx * r[j] + sy * u[j];
    normalize3(dir);
}

/* Where p lands on a w×h picture (origin top left); 0 behind the camera. */
int view_camera_project(const view_camera *c, const float p[3], int w, int h, double *x,
                        double *y)
{
    double f[3], r[3], u[3], eye[3], d[3];
    view_camera_frame(c, f, r, u);
    view_camera_eye(c, eye);
    for (int j = 0; j < 3; j++)
        d[j] = p[j] - eye[j];
    double z = d[0] * f[0] + d[1] * f[1] + d[2] * f[2];
    if (z <= 0)
        return 0;
    double t = tan(c->fov_y * M_PI / 360);
    double sx = (d[0] * r[0] + d[1] * r[1] + d[2] * r[2]) / (z * t * w / h);
    double sy = (d[0] * u[0] + d[1] * u[1] + d[2] * u[2]) / (z * t);
    *x = (sx + 1) * w / 2 - 0.5;
    *y = (1 - sy) * h / 2 - 0.5;
    return 1;
}
