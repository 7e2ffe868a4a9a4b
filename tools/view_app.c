/* The viewer's application: window, main loop, the script, the frame-time split. Input
 * handling (mouse and keys) is in view_input.c. */
#include "view_app.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ setup */
static char glfw_error_text[256];

static void on_glfw_error(int code, const char *text)
{
    snprintf(glfw_error_text, sizeof glfw_error_text, "%s (GLFW error 0x%x)", text, code);
}

/* The window and its GL 3.3 core context; 0 or -1 after a message. */
static int open_window(view_app *app)
{
    const viewer_args *a = app->a;
    if (!getenv("DISPLAY") && !getenv("WAYLAND_DISPLAY")) {
        fprintf(stderr, "lrr view: no display: use --screenshot with xvfb-run, or set DISPLAY\n");
        return -1;
    }
    glfwSetErrorCallback(on_glfw_error);
    if (!glfwInit()) {
        fprintf(stderr, "lrr view: cannot open the display: %s\n", glfw_error_text);
        return -1;
    }
    app->glfw_up = 1;
    glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 3);
    glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 3);
    glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
    glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
    glfwWindowHint(GLFW_VISIBLE, view_headless(a) ? GLFW_FALSE : GLFW_TRUE);
    app->win = glfwCreateWindow(a->width, a->height, "lrr view", NULL, NULL);
    if (!app->win) {
        fprintf(stderr, "lrr view: cannot create an OpenGL 3.3 core window: %s (under "
                        "xvfb-run try LIBGL_ALWAYS_SOFTWARE=1)\n", glfw_error_text);
        return -1;
    }
    glfwMakeContextCurrent(app->win);
    glfwSwapInterval(view_headless(a) ? 0 : 1); /* headless: as fast as it goes */
    glfwSetWindowUserPointer(app->win, app);
    return 0;
}

/* The Cornell camera of lrr render for the built-in boxes (their bounds), else a view from
 * the +z side framing the scene's bounds. */
static void default_camera(view_app *app)
{
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (size_t i = 0; i < 3 * app->n; i++)
        for (int j = 0; j < 3; j++) {
            lo[j] = fmin(lo[j], app->vtx[3 * i + j]);
            hi[j] = fmax(hi[j], app->vtx[3 * i + j]);
        }
    double d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    app->diag = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
    if (!(app->diag > 0) || !isfinite(app->diag))
        app->diag = 1;
    int cornell = fabs(lo[0]) < 5 && fabs(lo[1]) < 5 && fabs(lo[2]) < 5 && fabs(hi[0] - 556) < 5 &&
                  fabs(hi[1] - 548.8) < 5 && fabs(hi[2] - 559.2) < 5;
    view_camera *c = &app->cam;
    c->fov_y = app->a->fov > 0 ? app->a->fov : cornell ? 2 * atan(12.5 / 35) * 180 / M_PI : 50;
    c->near_z = 1e-3 * app->diag;
    c->far_z = 10 * app->diag;
    if (app->a->have_eye) {
        view_camera_look(c, app->a->eye, app->a->target);
    } else if (cornell) {
        static const double eye[3] = {278, 273, -800}, target[3] = {278, 273, 279.6};
        view_camera_look(c, eye, target);
    } else {
        double t[3], e[3];
        for (int j = 0; j < 3; j++)
            t[j] = (lo[j] + hi[j]) / 2;
        e[0] = t[0], e[1] = t[1] + 0.35 * app->diag, e[2] = t[2] + 1.1 * app->diag;
        view_camera_look(c, e, t);
    }
}

/* Operator, subpatch triangles (for picking), window, GL, worker; CLI_EXIT_*. */
static int app_open(view_app *app)
{
    if (lrr_context_create(&app->ctx) != LRR_OK) {
        fprintf(stderr, "lrr view: out of memory\n");
        return CLI_EXIT_FAIL;
    }
    int rc = load_operator(app->ctx, app->a->file, &app->op);
    if (rc != CLI_EXIT_OK)
        return rc;
    lrr_operator_info info;
    lrr_operator_get_info(app->op, &info, sizeof info);
    app->n = info.n;
    app->vtx = malloc(app->n * 9 * sizeof *app->vtx);
    if (!app->vtx) {
        fprintf(stderr, "lrr view: out of memory for %zu triangles\n", app->n);
        return CLI_EXIT_FAIL;
    }
    lrr_operator_subpatch_vertices(app->op, app->vtx);
    default_camera(app);
    if (open_window(app) != 0)
        return CLI_EXIT_FAIL;
    int fw, fh;
    glfwGetFramebufferSize(app->win, &fw, &fh);
    if (view_headless(app->a))
        fw = app->a->width, fh = app->a->height; /* the picture's size, whatever the screen */
    if (view_smooth_init(&app->sm, app->vtx, lrr_operator_normal(app->op),
                         lrr_operator_area(app->op), app->n) != 0 ||
        view_gl_init(&app->gl, app->vtx, app->n, app->sm.corner, app->sm.m, fw, fh) != 0)
        return CLI_EXIT_FAIL;
    app->gl_up = 1;
    if ((!view_headless(app->a) || app->a->overlay) && view_font_init() == 0)
        app->font_up = 1;
    if (view_worker_start(&app->w, app->op, app->a->shadow_tol) != 0)
        return CLI_EXIT_FAIL;
    return CLI_EXIT_OK;
}

static void app_close(view_app *app)
{
    view_worker_stop(&app->w);
    if (app->font_up)
        view_font_free();
    if (app->gl_up)
        view_gl_free(&app->gl);
    if (app->win)
        glfwDestroyWindow(app->win);
    if (app->glfw_up)
        glfwTerminate();
    view_smooth_free(&app->sm);
    free(app->vtx);
    lrr_operator_destroy(app->op);
    lrr_context_destroy(app->ctx);
}

/* ------------------------------------------------------------------ frames */
/* The library's automatic exposure (lrr_render_auto_exposure: what lrr export and lrr
 * animate use), keyed on the whole scene rather than on what the window shows, so orbiting
 * does not change it. A black B (no light yet) gives no key: then a later B sets it. */
void view_auto_exposure(view_app *app, const float *b)
{
    int lit = 0;
    for (size_t i = 0; i < 3 * app->n && !lit; i++)
        lit = b[i] > 0;
    app->exposure = lrr_render_auto_exposure(app->op, b);
    app->exposure_auto_pending = !lit;
}

/* The split line: frames per second and the mean times since the last line. */
static void split_line(view_app *app, char *buf, size_t size)
{
    double now = view_now_ms(), dt = now - app->line_t, sd, ss;
    uint64_t relights;
    view_worker_stats(&app->w, &relights, &sd, &ss);
    uint64_t f = app->frames - app->line_frames, r = relights - app->line_relights;
    double dd = sd - app->line_direct, ds = ss - app->line_solve;
    double du = app->sum_upload_ms - app->line_upload, dr = app->sum_draw_ms - app->line_draw;
    snprintf(buf, size,
             "%.0f fps %.0f relit/s | direct %.2f solve %.2f upload %.2f draw %.2f ms | "
             "%zu lights, emitters %s, exposure %.3g",
             f * 1e3 / dt, r * 1e3 / dt, r ? dd / r : 0.0, r ? ds / r : 0.0, f ? du / f : 0.0,
             f ? dr / f : 0.0, app->L.count, app->emitters ? "on" : "off", app->exposure);
    app->line_t = now;
    app->line_frames = app->frames;
    app->line_relights = relights;
    app->line_direct = sd;
    app->line_solve = ss;
    app->line_upload = app->sum_upload_ms;
    app->line_draw = app->sum_draw_ms;
}

/* What a screenshot shows besides the picture (lrr view --help): the lights, each as a
 * --light SPEC that gives it back, the selection, the emitters, the exposure and the eye. */
static void print_state(const view_app *app)
{
    static const char *const kinds[] = {"?", "point", "spot", "area", "sun"};
    printf("lights: %zu\n", app->L.count);
    for (size_t i = 0; i < app->L.count; i++) {
        const lrr_light_source *l = &app->L.light[i];
        int k = l->kind >= LRR_LIGHT_POINT && l->kind <= LRR_LIGHT_SUN ? l->kind : 0;
        printf("light %zu: %s pos=%.9g,%.9g,%.9g dir=%.9g,%.9g,%.9g angle=%.9g soft=%.9g", i,
               kinds[k], l->position[0], l->position[1], l->position[2], l->direction[0],
               l->direction[1], l->direction[2], l->cone_angle * 180 / M_PI,
               l->cone_softness * 180 / M_PI);
        if (l->kind == LRR_LIGHT_AREA)
            printf(" u=%.9g,%.9g,%.9g v=%.9g,%.9g,%.9g samples=%u", l->u[0], l->u[1], l->u[2],
                   l->v[0], l->v[1], l->v[2], l->samples);
        printf(" rgb=%.9g,%.9g,%.9g\n", l->rgb[0], l->rgb[1], l->rgb[2]);
    }
    if (app->selected >= 0)
        printf("selected: %ld\n", app->selected);
    else
        printf("selected: none\n");
    double eye[3];
    view_camera_eye(&app->cam, eye);
    printf("emitters: %s\nexposure: %.9g\neye: %.9g,%.9g,%.9g\n", app->emitters ? "on" : "off",
           app->exposure, eye[0], eye[1], eye[2]);
}

static void print_shot(const view_app *app, const char *path, const double half[2])
{
    printf("screenshot: %s\nleft_luma: %.2f\nright_luma: %.2f\nluma: %.2f\n", path, half[0],
           half[1], (half[0] + half[1]) / 2);
    print_state(app);
    fflush(stdout);
}

/* P: the picture as shown (the newest finished B, not waited for) to lrr-view-N.png. */
static void interactive_shot(view_app *app)
{
    char path[64];
    double half[2];
    app->want_shot = 0;
    snprintf(path, sizeof path, "lrr-view-%03u.png", app->shots++);
    if (view_gl_screenshot(&app->gl, path, half) == CLI_EXIT_OK)
        print_shot(app, path, half);
}

/* Uploads the newest B if there is one, draws into the offscreen picture; times both. */
static void render(view_app *app)
{
    double t0 = view_now_ms();
    if (view_worker_take(&app->w) || app->reupload) {
        if (app->exposure_auto_pending)
            view_auto_exposure(app, app->w.shown);
        if (app->smooth) /* the corners' means: part of the upload's time */
            view_gl_upload(&app->gl, view_smooth_apply(&app->sm, app->w.shown), app->sm.m);
        else
            view_gl_upload(&app->gl, app->w.shown, app->n);
        app->reupload = 0;
        app->uploads++;
        glFinish(); /* so the upload's time is the upload's, not the draw's */
        app->sum_upload_ms += view_now_ms() - t0;
    }
    double t1 = view_now_ms();
    float mvp[16], markers[3 * VIEW_MAX_LIGHTS];
    view_camera_matrix(&app->cam, (double)app->gl.fb_w / app->gl.fb_h, mvp);
    for (size_t i = 0; i < app->L.count; i++)
        memcpy(markers + 3 * i, app->L.light[i].position, sizeof app->L.light[i].position);
    view_gl_draw(&app->gl, mvp, app->exposure, app->smooth, markers, app->L.count,
                 app->selected);
    if (app->font_up) { /* into the picture, so screenshots show it too */
        if (!app->line[0] || view_now_ms() - app->line_t > 500)
            split_line(app, app->line, sizeof app->line);
        view_font_draw(app->line, app->gl.fbo, app->gl.fb_w, app->gl.fb_h,
                       app->gl.fb_w > 1600 ? 2 : 1);
    }
    glFinish();
    app->sum_draw_ms += view_now_ms() - t1;
    app->frames++;
    if (app->want_shot) /* P, pressed by the user or the script */
        interactive_shot(app);
}

/* Hands the lights to the worker when they changed; with sync, waits for them. */
static int post_lights(view_app *app, int wait)
{
    if (app->dirty) {
        view_worker_post(&app->w, app->L.light, app->L.count, app->emitters);
        app->dirty = 0;
    }
    if (wait && view_worker_wait(&app->w) != 0) {
        fprintf(stderr, "lrr view: %s\n", app->w.error_text);
        return -1;
    }
    return 0;
}

static int screenshot(view_app *app, const char *path)
{
    if (post_lights(app, 1) != 0)
        return CLI_EXIT_FAIL;
    app->line[0] = '\0'; /* the split line as of now, not of up to 0.5 s ago */
    render(app);
    double half[2];
    int rc = view_gl_screenshot(&app->gl, path, half);
    if (rc == CLI_EXIT_OK)
        print_shot(app, path, half);
    return rc;
}

/* Shows the picture (and, interactive, the split line, refreshed twice a second). */
static void present(view_app *app)
{
    int fw, fh;
    glfwGetFramebufferSize(app->win, &fw, &fh);
    view_gl_present(&app->gl, fw, fh);
    if (!view_headless(app->a) && view_now_ms() - app->title_t > 500) {
        glfwSetWindowTitle(app->win, app->line[0] ? app->line : "lrr view");
        app->title_t = view_now_ms();
    }
    glfwSwapBuffers(app->win);
}

/* ------------------------------------------------------------------ the script */
void view_add_light(view_app *app, const lrr_light_source *l)
{
    if (cli_lights_add(&app->L, l) == 0)
        app->dirty = 1;
}

void view_remove_light(view_app *app, size_t i)
{
    if (i >= app->L.count)
        return;
    cli_lights_remove(&app->L, i);
    app->selected = -1;
    app->dirty = 1;
}

/* One statement that draws no frame (the player handles frames); CLI_EXIT_*. */
static int apply(view_app *app, const cli_script_cmd *c)
{
    int r = cli_lights_apply(&app->L, c);
    if (r < 0) {
        fprintf(stderr, "lrr view: '%s' line %d: light %zu is not there (%zu lights now)\n",
                app->a->script, c->line, c->index, app->L.count);
        return CLI_EXIT_FAIL;
    }
    if (r > 0) {
        if (c->kind == CS_REMOVE)
            app->selected = -1;
        app->dirty = 1;
        return CLI_EXIT_OK;
    }
    switch (c->kind) {
    case CS_CAMERA: view_camera_look(&app->cam, c->eye, c->target); break;
    case CS_EMITTERS: app->emitters = c->on; app->dirty = 1; break;
    case CS_EXPOSURE:
        app->exposure = c->value;
        app->exposure_auto_pending = c->value == 0;
        if (c->value == 0 && app->w.shown_gen)
            view_auto_exposure(app, app->w.shown); /* keyed on what is shown now */
        break;
    case CS_SCREENSHOT: return screenshot(app, c->path);
    case CS_MOUSE: view_input_cursor(app, c->xy[0], c->xy[1]); break;
    case CS_CLICK:
        view_input_cursor(app, c->xy[0], c->xy[1]);
        view_input_button(app, 1, 1);
        view_input_button(app, 1, 0);
        break;
    case CS_SCROLL: view_input_scroll(app, c->value); break;
    case CS_KEY: view_input_key(app, c->key); break;
    case CS_FLY: view_input_fly_keys(app, (unsigned)c->key, c->on, c->value); break;
    }
    return CLI_EXIT_OK;
}

/* Frame k of a drag's n: the button goes down at its start before the first, the mouse
 * moves k/n of the way, and the button comes up after the last. */
static void drag_step(view_app *app, const cli_script_cmd *c, unsigned k, unsigned n)
{
    if (k == 1) {
        view_input_cursor(app, c->xy[0], c->xy[1]);
        view_input_button(app, 1, 1);
    }
    double t = (double)k / n;
    view_input_cursor(app, c->xy[0] + t * (c->xy[2] - c->xy[0]),
                      c->xy[1] + t * (c->xy[3] - c->xy[1]));
    if (k == n)
        view_input_button(app, 1, 0);
}

/* Runs the script up to the next frame: 1 draw a frame, 0 finished, -1 failed. */
static int script_step(view_app *app)
{
    for (;;) {
        if (glfwWindowShouldClose(app->win)) /* the script pressed Escape */
            return 0;
        const cli_script_cmd *c;
        int r = cli_player_next(&app->play, &app->L, &c);
        if (r == CLI_PLAY_END)
            return 0;
        if (r == CLI_PLAY_FRAME) {
            if (app->play.moved)
                app->dirty = 1;
            if (app->play.drawing && app->play.drawing->kind == CS_DRAG)
                drag_step(app, app->play.drawing, app->play.frame, app->play.frames);
            return 1;
        }
        if (apply(app, c) != CLI_EXIT_OK)
            return -1;
    }
}

/* ------------------------------------------------------------------ main loop */
static void print_split(view_app *app, double seconds)
{
    uint64_t r;
    double sd, ss;
    view_worker_stats(&app->w, &r, &sd, &ss);
    printf("frames: %llu\nrelights: %llu\nseconds: %.3f\nfps: %.1f\nrelit_fps: %.1f\n",
           (unsigned long long)app->frames, (unsigned long long)r, seconds,
           app->frames / seconds, r / seconds);
    printf("direct_ms: %.3f\nsolve_ms: %.3f\nupload_ms: %.3f\ndraw_ms: %.3f\n",
           r ? sd / r : 0.0, r ? ss / r : 0.0,
           app->uploads ? app->sum_upload_ms / app->uploads : 0.0,
           app->frames ? app->sum_draw_ms / app->frames : 0.0);
}

static int headless_loop(view_app *app)
{
    double t0 = view_now_ms();
    int step;
    while ((step = script_step(app)) == 1) {
        if (post_lights(app, app->a->sync) != 0)
            return CLI_EXIT_FAIL;
        render(app);
        present(app);
        glfwPollEvents();
    }
    if (step < 0)
        return CLI_EXIT_FAIL;
    if (app->a->screenshot && screenshot(app, app->a->screenshot) != CLI_EXIT_OK)
        return CLI_EXIT_FAIL;
    print_split(app, (view_now_ms() - t0) / 1e3);
    return CLI_EXIT_OK;
}

static int interactive_loop(view_app *app)
{
    view_input_install(app);
    double last = view_now_ms();
    while (!glfwWindowShouldClose(app->win)) {
        double now = view_now_ms();
        view_input_fly(app, (now - last) / 1e3);
        last = now;
        if (post_lights(app, 0) != 0)
            return CLI_EXIT_FAIL;
        if (view_worker_failed(&app->w)) {
            fprintf(stderr, "lrr view: %s\n", app->w.error_text);
            return CLI_EXIT_FAIL;
        }
        render(app);
        present(app);
        glfwPollEvents();
    }
    return CLI_EXIT_OK;
}

int view_run(const viewer_args *a, const cli_script *s)
{
    view_app app = {.a = a, .s = s, .selected = -1, .emitters = a->emitters, .dirty = 1,
                    .smooth = !a->flat,
                    .exposure = a->exposure, .exposure_auto_pending = a->exposure == 0};
    for (size_t i = 0; i < a->lights; i++)
        cli_lights_add(&app.L, &a->light[i]);
    app.play = (cli_player){.s = s, .tail = a->frames};
    app.mx = a->width / 2.0; /* headless: the mouse starts in the middle */
    app.my = a->height / 2.0;
    int rc = app_open(&app);
    if (rc == CLI_EXIT_OK) {
        app.line_t = view_now_ms();
        rc = view_headless(a) ? headless_loop(&app) : interactive_loop(&app);
    }
    app_close(&app);
    return rc;
}
