/* The picture options that render and animate share: size, exposure and camera (--width,
 * --height, --exposure, --camera, --eye, --target, --up, --fov), checked as lrr_render_png
 * would check them so that a bad camera is a usage error naming the option. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"

void view_args_init(view_args *v)
{
    memset(v, 0, sizeof *v);
    v->ro = lrr_render_options_defaults();
    v->ro.width = v->ro.height = 0;
}

/* "X,Y,Z": three finite numbers; 0 or -1 (reported, naming opt). */
static int parse_vec3(const char *prog, const char *opt, const char *arg, double v[3])
{
    const char *p = arg;
    for (int j = 0; j < 3; j++) {
        char *end = NULL;
        errno = 0;
        v[j] = strtod(p, &end);
        if (end == p || errno == ERANGE || !isfinite(v[j]) || *end != (j < 2 ? ',' : '\0')) {
            cli_usage_error(prog, "%s: '%s' is not three finite numbers X,Y,Z", opt, arg);
            return -1;
        }
        p = end + 1;
    }
    return 0;
}

static int camera_option(view_args *v, const char *prog, const char *arg)
{
    v->have_camera = 1;
    if (strcmp(arg, "cornell") == 0)
        v->ro.use_cornell_camera = 1;
    else if (strcmp(arg, "fit") == 0)
        v->ro.use_cornell_camera = 0;
    else if (strcmp(arg, "auto") == 0)
        v->ro.use_cornell_camera = -1;
    else {
        cli_usage_error(prog, "--camera: '%s' is not one of cornell, fit, auto", arg);
        return -1;
    }
    return 1;
}

int view_option(view_args *v, const char *prog, int c, const char *arg)
{
    switch (c) {
    case OPT_WIDTH:
        return cli_parse_unsigned(prog, "--width", arg, 1, 16384, &v->ro.width) != 0 ? -1 : 1;
    case OPT_HEIGHT:
        return cli_parse_unsigned(prog, "--height", arg, 1, 16384, &v->ro.height) != 0 ? -1 : 1;
    case OPT_EXPOSURE:
        return cli_parse_double(prog, "--exposure", arg, 0.0, 1, 1e300, &v->ro.exposure) != 0
                   ? -1 : 1;
    case OPT_EYE:
        v->have_eye = 1;
        return parse_vec3(prog, "--eye", arg, v->ro.eye) != 0 ? -1 : 1;
    case OPT_TARGET:
        v->have_target = 1;
        return parse_vec3(prog, "--target", arg, v->ro.target) != 0 ? -1 : 1;
    case OPT_UP:
        v->have_up = 1;
        return parse_vec3(prog, "--up", arg, v->ro.up) != 0 ? -1 : 1;
    case OPT_FOV:
        if (cli_parse_double(prog, "--fov", arg, 0.0, 1, 180.0, &v->ro.fov_degrees) != 0)
            return -1;
        if (v->ro.fov_degrees >= 180) {
            cli_usage_error(prog, "--fov: '%s' is out of range (it must be less than 180)", arg);
            return -1;
        }
        return 1;
    case OPT_CAMERA:
        return camera_option(v, prog, arg);
    default:
        return 0;
    }
}

/* --up must not be zero or parallel to target − eye. */
static int check_up(const view_args *v, const char *prog)
{
    double f[3], s[3];
    const double *u = v->ro.up;
    for (int j = 0; j < 3; j++)
        f[j] = v->ro.target[j] - v->ro.eye[j];
    if (f[0] == 0 && f[1] == 0 && f[2] == 0) {
        cli_usage_error(prog, "--target: equals --eye (no view direction)");
        return -1;
    }
    s[0] = f[1] * u[2] - f[2] * u[1];
    s[1] = f[2] * u[0] - f[0] * u[2];
    s[2] = f[0] * u[1] - f[1] * u[0];
    double lf = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    double lu = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (!(sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]) > 1e-6 * lf * lu)) {
        cli_usage_error(prog, "--up: (%g,%g,%g) is zero or parallel to the view direction "
                        "target - eye", u[0], u[1], u[2]);
        return -1;
    }
    return 0;
}

int view_finish(view_args *v, const char *prog)
{
    if (!v->have_eye && (v->have_target || v->have_up)) {
        cli_usage_error(prog, "%s needs --eye", v->have_target ? "--target" : "--up");
        return -1;
    }
    if (!v->have_eye)
        return 0;
    if (!v->have_target) {
        cli_usage_error(prog, "--eye needs --target");
        return -1;
    }
    if (v->have_camera) {
        cli_usage_error(prog, "--eye and --camera exclude each other");
        return -1;
    }
    if (check_up(v, prog) != 0)
        return -1;
    v->ro.use_eye = 1;
    return 0;
}
