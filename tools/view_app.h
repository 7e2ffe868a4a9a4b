/* The viewer's application state, shared by view_app.c (loop, script) and view_input.c
 * (mouse and keys). */
#ifndef LRR_VIEW_APP_H
#define LRR_VIEW_APP_H

#define GLFW_INCLUDE_NONE /* epoxy provides the GL declarations */
#include <GLFW/glfw3.h>

#include "view_internal.h"

typedef struct view_app {
    const viewer_args *a;
    const cli_script *s;
    lrr_context *ctx;
    lrr_operator *op;
    float *vtx;                 /* n×9: the subpatch triangles, for picking */
    size_t n;
    double diag;                /* the scene's bounding-box diagonal */
    GLFWwindow *win;
    int glfw_up, gl_up, font_up;
    view_gl gl;
    view_smooth sm;
    int smooth, reupload;       /* smooth shading; colours to upload again (F pressed) */
    view_worker w;
    view_camera cam;
    /* what is lit */
    cli_lights L;               /* the lights (and the script's moves under way) */
    long selected;              /* −1: none */
    int emitters, dirty;        /* dirty: the worker has not been told yet */
    double exposure;
    int exposure_auto_pending;  /* key the exposure on the next B */
    cli_player play;            /* the script */
    /* the split */
    uint64_t frames, uploads;
    double sum_upload_ms, sum_draw_ms;
    double title_t, line_t, line_direct, line_solve, line_upload, line_draw;
    uint64_t line_frames, line_relights;
    char line[256];
    /* the mouse */
    int dragging, orbiting, panning, colour;
    int want_shot;              /* P pressed */
    unsigned shots;
    double mx, my;
} view_app;

void view_auto_exposure(view_app *app, const float *b);
void view_add_light(view_app *app, const lrr_light_source *l);
void view_remove_light(view_app *app, size_t i);

/* view_input.c: the GLFW callbacks call these, and so does the script (a user's session
 * replayed headless). x, y: window pixels from the top-left corner. */
void view_input_cursor(view_app *app, double x, double y);
void view_input_button(view_app *app, int left, int press);
void view_input_scroll(view_app *app, double notches);
void view_input_key(view_app *app, int key); /* enum view_key */
void view_input_install(view_app *app);
/* WASDQE flying, dt seconds since the last frame: the keys held now (GLFW). */
void view_input_fly(view_app *app, double dt);
/* The same for the held keys given, bit k for CLI_SCRIPT_FLY_KEYS[k] (a script's fly). */
void view_input_fly_keys(view_app *app, unsigned held, int shift, double dt);

#endif /* LRR_VIEW_APP_H */
