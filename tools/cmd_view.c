/* lrr view: the interactive viewer (tools/view.h). This file parses the command line and
 * the script and is always compiled; the viewer itself (view_run) only with LRR_VIEWER,
 * i.e. when configure found GLFW 3 and libepoxy. */
#include <stdio.h>

#include "view.h"

static const char prog[] = "lrr view";

static const char view_help[] =
    "Usage: lrr view FILE.lrr [OPTIONS]\n"
    "Draws the scene with its radiosity in a window (GLFW, OpenGL 3.3 core) and relights it\n"
    "as lights move: a worker thread computes the direct light of the lights\n"
    "(lrr_lighting_direct) and the interreflections (lrr_solve); the window shows the\n"
    "newest finished radiosity at the display rate. The scene's own emitters are a light\n"
    "that can be switched on and off.\n"
    "\n"
    "Options:\n"
    "  --light SPEC         a light (repeatable, up to 16), as for lrr render --light:\n"
    "                       'point pos=X,Y,Z rgb=R,G,B', 'spot pos=.. dir=.. angle=DEG\n"
    "                       soft=DEG rgb=..', 'area pos=.. u=.. v=.. rgb=..', 'sun dir=..\n"
    "                       rgb=..'\n"
    "  --no-scene-emission  start with the scene's own emitters switched off\n"
    "  --exposure X         multiplier before the sRGB curve (> 0; default automatic)\n"
    "  --eye X,Y,Z          the camera's position (default: the Cornell camera for a Cornell\n"
    "  --target X,Y,Z       box, else a view framing the scene); needs both\n"
    "  --fov DEGREES        vertical field of view (default 39.3 Cornell, else 50)\n"
    "  --width W, --height H  window or picture size (64..8192, default 800×600)\n"
    "  --shadow-tolerance T the shadow rays' error budget (lrr_lighting_set_tolerance; 0,\n"
    "                       the default: every ray): point and spot lights trace only the\n"
    "                       receivers that carry most of their light, the area-weighted\n"
    "                       L2 error of each light's direct light within T (0..0.5)\n"
    "  --flat               one colour per subpatch (default: smooth, each corner the\n"
    "                       area-weighted mean of the subpatches meeting there in one plane)\n"
    "Headless (no window shown; ends by itself; needs an X display, e.g. xvfb-run):\n"
    "  --script FILE        run the camera and light moves of FILE (below)\n"
    "  --frames N           draw N more frames after the script\n"
    "  --screenshot OUT.png save the last frame, after the newest state's relight, and\n"
    "                       print its luma and the viewer's state (below)\n"
    "  --sync               every frame waits for the relight of its own lights (so frames\n"
    "                       per second = relit frames per second)\n"
    "  --overlay            draw the frame-time line into headless pictures too\n"
    "  -h, --help           show this help\n"
    "\n" CLI_SCRIPT_HELP
    "\n"
    "Headless runs print the frame-time split at the end (frames, relights, fps, direct_ms,\n"
    "solve_ms, upload_ms, draw_ms: means per relight or per frame). A screenshot prints\n"
    "screenshot, left_luma, right_luma, luma (mean sRGB luma 0..255 of the picture's halves\n"
    "and of all of it), then the state it shows: lights, one 'light I: SPEC' each (SPEC as\n"
    "for --light), selected (a light's index or none), emitters, exposure and eye.\n"
    "\n"
    "Interactive keys and mouse:\n"
    "  left drag            orbit around the target; right drag: pan; wheel: zoom\n"
    "  W A S D Q E          fly (forward, left, back, right, down, up); shift: faster\n"
    "  click a light        select it (its marker turns yellow); drag it across the\n"
    "                       surfaces (it stays 5% of the scene's size in front of them)\n"
    "  N                    add a point light where the mouse points (else at the camera's\n"
    "                       target) and select it\n"
    "  Delete, Backspace    remove the selected light\n"
    "  T                    selected light's type: point, spot (pointing along the surface\n"
    "                       normal it was dropped on; straight down until dragged), sun\n"
    "  + / -                selected light's intensity ×1.25 / ÷1.25 (also = and keypad)\n"
    "  C                    selected light's colour: white, warm, cool, red, green, blue\n"
    "  L                    the scene's own emitters on / off\n"
    "  [ / ] / 0            exposure ÷1.25 / ×1.25 / automatic (lrr_render_auto_exposure of\n"
    "                       the radiosity shown, as lrr export's)\n"
    "  F                    flat / smooth shading\n"
    "  P                    save the picture as lrr-view-NNN.png (current directory)\n"
    "  Esc                  quit\n"
    "The line at the top: frames per second and the split in ms (direct light, solve,\n"
    "upload, draw).\n";

/* --light SPEC, repeatable up to VIEW_MAX_LIGHTS. */
static int light_option(void *target, const char *caller, const char *arg)
{
    viewer_args *a = target;
    if (a->lights >= VIEW_MAX_LIGHTS) {
        cli_usage_error(caller, "--light: at most %d lights", VIEW_MAX_LIGHTS);
        return -1;
    }
    return cli_parse_light(caller, arg, &a->light[a->lights++]);
}

static int no_emission_option(void *target, const char *caller, const char *arg)
{
    (void)caller, (void)arg;
    ((viewer_args *)target)->emitters = 0;
    return 0;
}

static const cli_opt viewer_opts[] = {
    {.name = "light", .kind = CLI_OPT_CUSTOM, .handle = light_option},
    {.name = "no-scene-emission", .kind = CLI_OPT_FLAG, .handle = no_emission_option},
    {.name = "exposure", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(viewer_args, exposure),
     .min = 0, .min_open = 1, .max = 1e30},
    {.name = "eye", .kind = CLI_OPT_VEC3, .field = CLI_FIELD(viewer_args, eye),
     .seen = CLI_FIELD(viewer_args, have_eye)},
    {.name = "target", .kind = CLI_OPT_VEC3, .field = CLI_FIELD(viewer_args, target),
     .seen = CLI_FIELD(viewer_args, have_target)},
    {.name = "fov", .kind = CLI_OPT_DOUBLE, .field = CLI_FIELD(viewer_args, fov), .min = 1,
     .max = 170},
    {.name = "width", .kind = CLI_OPT_UNSIGNED, .field = CLI_FIELD(viewer_args, width),
     .min = 64, .max = 8192},
    {.name = "height", .kind = CLI_OPT_UNSIGNED, .field = CLI_FIELD(viewer_args, height),
     .min = 64, .max = 8192},
    {.name = "script", .kind = CLI_OPT_STRING, .field = CLI_FIELD(viewer_args, script)},
    {.name = "shadow-tolerance", .kind = CLI_OPT_DOUBLE,
     .field = CLI_FIELD(viewer_args, shadow_tol), .min = 0, .max = 0.5},
    {.name = "screenshot", .kind = CLI_OPT_STRING, .field = CLI_FIELD(viewer_args, screenshot)},
    {.name = "frames", .kind = CLI_OPT_UNSIGNED, .field = CLI_FIELD(viewer_args, frames),
     .seen = CLI_FIELD(viewer_args, have_frames), .min = 0, .max = 10000000},
    {.name = "sync", .kind = CLI_OPT_FLAG, .field = CLI_FIELD(viewer_args, sync)},
    {.name = "overlay", .kind = CLI_OPT_FLAG, .field = CLI_FIELD(viewer_args, overlay)},
    {.name = "flat", .kind = CLI_OPT_FLAG, .field = CLI_FIELD(viewer_args, flat)},
    {.name = NULL}};

/* CLI_RUN with *a filled in, or the exit status. */
static int parse_view(viewer_args *a, int argc, char *argv[])
{
    *a = (viewer_args){.width = 800, .height = 600, .emitters = 1};
    const cli_opt_group groups[] = {{viewer_opts, a}, {NULL, NULL}};
    const cli_command cmd = {prog, view_help, "FILE.lrr", groups};
    int rc = cli_parse_command(&cmd, argc, argv, &a->file);
    if (rc == CLI_RUN && a->have_eye != a->have_target) {
        cli_usage_error(prog, "%s needs %s", a->have_eye ? "--eye" : "--target",
                        a->have_eye ? "--target" : "--eye");
        return CLI_EXIT_USAGE;
    }
    return rc;
}

int cmd_view(int argc, char *argv[])
{
    viewer_args a;
    int rc = parse_view(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
#ifdef LRR_VIEWER
    static const char *const keys[] = VIEW_KEY_NAMES;
    const cli_script_caps caps = {.lights = a.lights, .keys = keys, .tail_frames = a.frames > 0};
    cli_script s = {0};
    if (a.script && (rc = cli_script_load(prog, a.script, &caps, &s)) != CLI_EXIT_OK)
        return rc;
    rc = view_run(&a, &s);
    cli_script_free(&s);
    return rc;
#else
    fprintf(stderr, "%s: lrr was built without the viewer (configure found no GLFW 3 or "
                    "libepoxy, or was given --disable-viewer). On Debian: apt-get install "
                    "libglfw3-dev libepoxy-dev, then ./configure && make\n",
            prog);
    return CLI_EXIT_FAIL;
#endif
}
