/* The picture options that render and animate share: size, exposure and camera (--width,
 * --height, --exposure, --camera, --eye, --target, --up, --fov), checked as lrr_render_png
 * would check them so that a bad camera is a usage error naming the option. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "commands.h"

void view_args_init(view_args *v)
{
    memset(v, 0, sizeof *v);
    v->ro = lrr_render_options_defaults();
    v->ro.width = v->ro.height = 0;
}

static const cli_choice cameras[] = {{"cornell", 1}, {"fit", 0}, {"auto", -1}, {NULL, 0}};

const cli_opt view_opts[] = {
    {.name = "width", .kind = CLI_OPT_UNSIGNED, .field = CLI_FIELD(view_args, ro.width),
     .min = 1, .max = 16384},
    {.name = "height", .kind = CLI_OPT_UNSIGNED, .field = CLI_FIELD(view_args, ro.height),
     .min = 1, .max = 16384},
    {.name = "exposure", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(view_args, ro.exposure),
     .min = 0, .min_open = 1, .max = 1e300},
    {.name = "camera", .kind = CLI_OPT_CHOICE,
     .field = CLI_FIELD(view_args, ro.use_cornell_camera),
     .seen = CLI_FIELD(view_args, have_camera), .choices = cameras},
    {.name = "eye", .kind = CLI_OPT_VEC3, .field = CLI_FIELD(view_args, ro.eye),
     .seen = CLI_FIELD(view_args, have_eye)},
    {.name = "target", .kind = CLI_OPT_VEC3, .field = CLI_FIELD(view_args, ro.target),
     .seen = CLI_FIELD(view_args, have_target)},
    {.name = "up", .kind = CLI_OPT_VEC3, .field = CLI_FIELD(view_args, ro.up),
     .seen = CLI_FIELD(view_args, have_up)},
    {.name = "fov", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(view_args, ro.fov_degrees),
     .min = 0, .min_open = 1, .max = 180, .max_open = 1},
    {.name = NULL}};

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
