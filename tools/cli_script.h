/*
 * The light script of `lrr view --script` and `lrr animate --lights` (tools/cli_script.c):
 * one grammar, one parser and one player for both. A script is a timeline: statements run
 * in order, only `frames` (and the frames= of move, path and drag) draws frames, and the
 * lights given a move or path since the previous frames follow it during the next ones.
 * lrr view draws each frame in its window (and may also replay the mouse and keys); lrr
 * animate writes each frame as a picture.
 */
#ifndef LRR_CLI_SCRIPT_H
#define LRR_CLI_SCRIPT_H

#include <stddef.h>

#include "commands.h"

#define CLI_SCRIPT_MAX_POINTS 64      /* of a path */
#define CLI_SCRIPT_MAX_FRAMES 10000000 /* of a whole script */

#define CLI_SCRIPT_HELP                                                                        \
    "Script (lrr view --script, lrr animate --lights): one statement a line, '#' starts a\n" \
    "comment. Statements run in order; only frames (and the frames=N of move, path and\n"    \
    "drag) draw frames (lrr animate writes one picture each), the others act between two\n"  \
    "frames. Lights count from 0 in the order they were added (lrr view's --light first);\n" \
    "removing one renumbers those after it.\n"                                                 \
    "  light SPEC                  add a light, SPEC as for --light\n"                          \
    "  remove I                    remove light I\n"                                             \
    "  move I pos=X,Y,Z [frames=N] light I goes from where it is to X,Y,Z during the next\n"   \
    "                              frames statement, the last of its frames at X,Y,Z\n"         \
    "  path I X,Y,Z X,Y,Z ... [frames=N]\n"                                                     \
    "                              light I goes through these points (2..64) at equal steps\n" \
    "                              during the next frames statement, its first frame at the\n" \
    "                              first point and its last at the last\n"                     \
    "                              (frames=N on move and path: frames N follows at once)\n"    \
    "  frames N                    draw N frames (0..1000000); several moves and paths before\n" \
    "                              one frames statement move their lights together\n"          \
    "  emitters on|off             the scene's own emitters\n"                                   \
    "  exposure X                  exposure (> 0; 0 = automatic: keyed on the next frame's\n"  \
    "                              radiosity, then kept)\n"                                     \
    "  camera eye=X,Y,Z target=X,Y,Z\n"                                                         \
    "lrr view only (a user's session, replayed through the handlers of the mouse and keys;\n" \
    "X, Y: pixels of the window from its top-left corner):\n"                                  \
    "  screenshot FILE.png         wait for the newest relight, save the picture, print its\n" \
    "                              luma and the viewer's state (as --screenshot)\n"            \
    "  mouse X Y                   move the mouse (no button)\n"                                \
    "  click X Y                   left click at X,Y: selects the light whose marker is there\n" \
    "  drag X0 Y0 X1 Y1 [frames=N] left button down at X0,Y0, moved to X1,Y1 in N steps\n"    \
    "                              (default 8), one frame each, then up\n"                     \
    "  scroll D                    the wheel, D notches (> 0 zooms in)\n"                       \
    "  key NAME                    press one of lrr view's keys: N, Delete, T, +, -, C, L,\n" \
    "                              [, ], 0, F, P, Escape\n"                                     \
    "  fly KEYS SECONDS [shift]    hold the fly keys KEYS (some of W A S D Q E, e.g. WD) for\n" \
    "                              SECONDS (0..60) of frame time, as in one frame\n"

enum {
    CS_LIGHT = 1, /* add a light */
    CS_REMOVE,    /* remove light `index` */
    CS_MOVE,      /* light `index` to pts[0] over the next frames */
    CS_PATH,      /* light `index` through pts[0..points-1] over the next frames */
    CS_FRAMES,    /* draw `frames` frames */
    CS_EMITTERS,  /* on */
    CS_EXPOSURE,  /* value (0 = automatic) */
    CS_CAMERA,    /* eye, target */
    CS_SCREENSHOT, /* path */
    CS_MOUSE,     /* xy[0..1] */
    CS_CLICK,     /* xy[0..1] */
    CS_DRAG,      /* xy[0..3], over `frames` frames */
    CS_SCROLL,    /* value */
    CS_KEY,       /* key: the index into the caller's key names */
    CS_FLY        /* key: the held fly keys, bit k for CLI_SCRIPT_FLY_KEYS[k]; value:
                     seconds; on: shift */
};

/* The viewer's fly keys in the bit order of CS_FLY: forward, back, left, right, down, up. */
#define CLI_SCRIPT_FLY_KEYS "WSADQE"

typedef struct cli_script_cmd {
    int kind, line;
    lrr_light_source light;                /* CS_LIGHT */
    size_t index;                          /* CS_REMOVE, CS_MOVE, CS_PATH */
    float pts[CLI_SCRIPT_MAX_POINTS][3];   /* CS_MOVE (one), CS_PATH */
    size_t points;
    unsigned frames;                       /* CS_FRAMES, CS_DRAG; frames=N of CS_MOVE, CS_PATH */
    int on;                                /* CS_EMITTERS; CS_FLY: shift */
    double value;                          /* CS_EXPOSURE, CS_SCROLL, CS_FLY */
    double eye[3], target[3];              /* CS_CAMERA */
    double xy[4];                          /* CS_MOUSE, CS_CLICK, CS_DRAG */
    int key;                               /* CS_KEY, CS_FLY */
    char *path;                            /* CS_SCREENSHOT */
} cli_script_cmd;

typedef struct cli_script {
    cli_script_cmd *cmd;
    size_t count;
    size_t frames; /* all frames it draws */
} cli_script;

/* What the command offers beyond the common statements. */
typedef struct cli_script_caps {
    size_t lights;           /* lights there before the script (lrr view --light) */
    const char *const *keys; /* names for `key` (NULL-terminated); NULL: no screenshot and
                                no input statements (lrr animate) */
    int tail_frames;         /* frames follow the script (lrr view --frames) */
} cli_script_caps;

/* Reads and checks the whole script; CLI_EXIT_OK, or CLI_EXIT_USAGE / CLI_EXIT_FAIL after
 * "PROG: 'PATH' line L: what" (light indices are checked as the lights come and go; a move
 * or path that no frames follow is an error). */
int cli_script_load(const char *prog, const char *path, const cli_script_caps *caps,
                    cli_script *s);
void cli_script_free(cli_script *s);

/* ------------------------------------------------------------------ playing it */
/* The lights and where the moving ones go during the current frames. */
typedef struct cli_motion {
    float pts[CLI_SCRIPT_MAX_POINTS + 1][3];
    size_t points;     /* 0: the light stays */
    int from_here;     /* a move: pts[0] is where it was, not a frame of its own */
} cli_motion;

typedef struct cli_lights {
    lrr_light_source light[CLI_MAX_LIGHTS];
    cli_motion motion[CLI_MAX_LIGHTS];
    size_t count;
} cli_lights;

/* 0, or -1 when there are CLI_MAX_LIGHTS already. */
int cli_lights_add(cli_lights *L, const lrr_light_source *l);
/* Removes light i and its motion; the lights after it move down one. */
void cli_lights_remove(cli_lights *L, size_t i);
/* Applies a CS_LIGHT, CS_REMOVE, CS_MOVE or CS_PATH statement to L: 1; -1 when its light
 * is not there (a key changed the lights: unknown when the script was read) or there are
 * CLI_MAX_LIGHTS already; anything else: 0. */
int cli_lights_apply(cli_lights *L, const cli_script_cmd *c);

enum { CLI_PLAY_END, CLI_PLAY_FRAME, CLI_PLAY_CMD };

typedef struct cli_player {
    const cli_script *s;
    unsigned tail;                 /* frames after the script (lrr view --frames) */
    /* where it is */
    size_t pc;
    int tail_done;
    const cli_script_cmd *drawing; /* the statement whose frames are drawn; NULL: the tail */
    unsigned frame, frames;        /* the frame drawn now, 1..frames */
    int moved;                     /* a light moved for this frame */
} cli_player;

/* The next step: CLI_PLAY_CMD with *cmd, a statement that draws nothing, for the caller
 * (who applies the light ones with cli_lights_apply); CLI_PLAY_FRAME: draw a frame, the
 * moving lights of L are in place for it (p->frame of p->frames of p->drawing); or
 * CLI_PLAY_END. */
int cli_player_next(cli_player *p, cli_lights *L, const cli_script_cmd **cmd);

#endif /* LRR_CLI_SCRIPT_H */
