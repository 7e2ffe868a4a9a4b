/*
 * `lrr view FILE.lrr`: the interactive viewer (tools/cmd_view.c parses the command line and
 * the script; the GL half, built only with GLFW 3 and libepoxy, is tools/view_*.c):
 *   cli_script.c   the script (shared with lrr animate: cli_script.h)
 *   view_app.c     window, main loop, input, the script stepping, the frame-time split
 *   view_gl.c      shaders, mesh and radiosity upload, drawing, the screenshot
 *   view_worker.c  the relighting thread: direct light + solve, newest B handed over
 *   view_camera.c  orbit and fly camera, picking rays
 *   view_font.c    a tiny built-in bitmap font for the on-screen line
 * Uses only the public API (lrr.h) and the tools' helpers.
 */
#ifndef LRR_VIEW_H
#define LRR_VIEW_H

#include <stddef.h>
#include <stdint.h>

#include "cli_script.h"
#include "commands.h"
#include "lrr.h"

#define VIEW_MAX_LIGHTS CLI_MAX_LIGHTS

/* ------------------------------------------------------------------ the keys */
/* The viewer's keys (lrr view --help), named as a script's `key NAME` names them; the GLFW
 * callback and the script both press them through view_input_key. */
enum view_key {
    VK_NEW, VK_DELETE, VK_TYPE, VK_BRIGHTER, VK_DIMMER, VK_COLOUR, VK_EMITTERS,
    VK_EXPOSURE_DOWN, VK_EXPOSURE_UP, VK_EXPOSURE_AUTO, VK_FLAT, VK_PICTURE, VK_QUIT
};
#define VIEW_KEY_NAMES {"N", "Delete", "T", "+", "-", "C", "L", "[", "]", "0", "F", "P", \
                        "Escape", NULL}

/* ------------------------------------------------------------------ the command line */
typedef struct viewer_args {
    const char *file;        /* the .lrr operator */
    const char *script;      /* --script, or NULL */
    const char *screenshot;  /* --screenshot, or NULL */
    unsigned frames;         /* --frames: frames after the script */
    int have_frames;
    unsigned width, height;
    double exposure;         /* 0 = automatic */
    double shadow_tol;       /* --shadow-tolerance (lrr_lighting_set_tolerance) */
    int emitters;            /* the scene's own emitters on at the start */
    int sync;                /* --sync: every frame waits for its own relight */
    int overlay;             /* --overlay: the split line in headless pictures too */
    int flat;                /* --flat: one colour per subpatch, no smooth shading */
    int have_eye, have_target;
    double eye[3], target[3], fov;
    lrr_light_source light[VIEW_MAX_LIGHTS];
    size_t lights;
} viewer_args;

/* Headless: no window shown, the program ends after the script and --frames. */
static inline int view_headless(const viewer_args *a)
{
    return a->script || a->screenshot || a->have_frames;
}

/* The viewer itself (view_app.c); CLI_EXIT_*. */
int view_run(const viewer_args *a, const cli_script *s);

#endif /* LRR_VIEW_H */
