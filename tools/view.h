/*
 * `lrr view FILE.lrr`: the interactive viewer (tools/cmd_view.c parses the command line and
 * the script; the GL half, built only with GLFW 3 and libepoxy, is tools/view_*.c):
 *   view_script.c  the headless script (camera and light moves)
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

#include "commands.h"
#include "lrr.h"

#define VIEW_MAX_LIGHTS CLI_MAX_LIGHTS

/* ------------------------------------------------------------------ the script */
enum {
    VS_LIGHT = 1,  /* add a light (its spec as --light) */
    VS_MOVE,       /* move light `index` to pos over `frames` frames (linearly) */
    VS_REMOVE,     /* remove light `index` */
    VS_CAMERA,     /* eye= target= */
    VS_EMITTERS,   /* the scene's own emitters on or off */
    VS_EXPOSURE,   /* exposure (0 = automatic) */
    VS_FRAMES,     /* draw `frames` frames with nothing changed */
    VS_SCREENSHOT  /* wait for the newest state's relight, draw, write a PNG */
};

typedef struct view_cmd {
    int kind, line;
    lrr_light_source light;  /* VS_LIGHT */
    size_t index;            /* VS_MOVE, VS_REMOVE */
    float pos[3];            /* VS_MOVE */
    unsigned frames;         /* VS_MOVE, VS_FRAMES */
    double eye[3], target[3]; /* VS_CAMERA */
    int on;                  /* VS_EMITTERS */
    double exposure;         /* VS_EXPOSURE */
    char *path;              /* VS_SCREENSHOT */
} view_cmd;

typedef struct view_script {
    view_cmd *cmd;
    size_t count;
} view_script;

#define VIEW_SCRIPT_HELP                                                                      \
    "Script (--script FILE): one command a line, '#' starts a comment; light indices count\n" \
    "from 0 in the order the lights were added (--light first):\n"                            \
    "  light SPEC                  add a light, SPEC as for --light\n"                          \
    "  move I pos=X,Y,Z [frames=N] move light I to X,Y,Z over N frames (default 1)\n"          \
    "  remove I                    remove light I\n"                                              \
    "  camera eye=X,Y,Z target=X,Y,Z\n"                                                         \
    "  emitters on|off             the scene's own emitters\n"                                   \
    "  exposure X                  exposure (0 = automatic)\n"                                   \
    "  frames N                    draw N frames\n"                                              \
    "  screenshot FILE.png         wait for the newest relight, then save the picture\n"

/* Reads and checks the script; CLI_EXIT_OK, or CLI_EXIT_USAGE / CLI_EXIT_FAIL after a
 * message "PROG: 'PATH' line L: what". Light indices are checked against `lights` lights
 * given before the script. */
int view_script_load(const char *prog, const char *path, size_t lights, view_script *s);
void view_script_free(view_script *s);

/* ------------------------------------------------------------------ the command line */
typedef struct viewer_args {
    const char *file;        /* the .lrr operator */
    const char *script;      /* --script, or NULL */
    const char *screenshot;  /* --screenshot, or NULL */
    unsigned frames;         /* --frames: frames after the script */
    int have_frames;
    int width, height;
    double exposure;         /* 0 = automatic */
    int emitters;            /* the scene's own emitters on at the start */
    int sync;                /* --sync: every frame waits for its own relight */
    int overlay;             /* --overlay: the split line in headless pictures too */
    int flat;                /* --flat: one colour per subpatch, no smooth shading */
    int have_eye;
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
int view_run(const viewer_args *a, const view_script *s);

#endif /* LRR_VIEW_H */
