/* The viewer's mouse and keys (lrr view --help lists them): orbit, pan, zoom and fly; pick a
 * light and drag it across the surfaces; add, remove and edit lights; emitters; exposure. */
#include "view_app.h"

#include <math.h>
#include <string.h>

#define PICK_PIXELS 12.0 /* how near a click must be to a light's marker */

static view_app *app_of(GLFWwindow *win)
{
    return glfwGetWindowUserPointer(win);
}

/* The size the mouse's pixels refer to: the window's, or headless the picture's (a hidden
 * window may be smaller than the picture, e.g. on a small Xvfb screen). */
static void window_size(const view_app *app, int *w, int *h)
{
    if (view_headless(app->a)) {
        *w = app->gl.fb_w;
        *h = app->gl.fb_h;
    } else {
        glfwGetWindowSize(app->win, w, h);
    }
}

/* The nearest front-or-back hit of the ray among the subpatch triangles (Möller–Trumbore):
 * its distance (INFINITY: none) and the triangle's unit normal facing the ray's origin. */
static double cast(const view_app *app, const double o[3], const double d[3], double nrm[3])
{
    double best = INFINITY;
    for (size_t i = 0; i < app->n; i++) {
        const float *v = app->vtx + 9 * i;
        double e1[3], e2[3], p[3], s[3], q[3];
        for (int j = 0; j < 3; j++) {
            e1[j] = v[3 + j] - v[j];
            e2[j] = v[6 + j] - v[j];
            s[j] = o[j] - v[j];
        }
        p[0] = d[1] * e2[2] - d[2] * e2[1], p[1] = d[2] * e2[0] - d[0] * e2[2],
        p[2] = d[0] * e2[1] - d[1] * e2[0];
        double det = e1[0] * p[0] + e1[1] * p[1] + e1[2] * p[2];
        if (fabs(det) < 1e-12)
            continue;
        double u = (s[0] * p[0] + s[1] * p[1] + s[2] * p[2]) / det;
        q[0] = s[1] * e1[2] - s[2] * e1[1], q[1] = s[2] * e1[0] - s[0] * e1[2],
        q[2] = s[0] * e1[1] - s[1] * e1[0];
        double w = (d[0] * q[0] + d[1] * q[1] + d[2] * q[2]) / det;
        double t = (e2[0] * q[0] + e2[1] * q[1] + e2[2] * q[2]) / det;
        if (u < 0 || w < 0 || u + w > 1 || t <= 0 || t >= best)
            continue;
        best = t;
        nrm[0] = e1[1] * e2[2] - e1[2] * e2[1], nrm[1] = e1[2] * e2[0] - e1[0] * e2[2],
        nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
    }
    if (isfinite(best)) {
        double l = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        double sgn = nrm[0] * d[0] + nrm[1] * d[1] + nrm[2] * d[2] > 0 ? -1 : 1;
        for (int j = 0; j < 3; j++)
            nrm[j] *= sgn / l;
    }
    return best;
}

/* Where the mouse points on the surfaces, lifted off them by 5% of the scene's size; 0 if
 * it points at nothing. nrm: the surface normal there. */
static int surface_point(view_app *app, float pos[3], double nrm[3])
{
    int w, h;
    window_size(app, &w, &h);
    double o[3], d[3];
    view_camera_ray(&app->cam, app->mx, app->my, w, h, o, d);
    double t = cast(app, o, d, nrm);
    if (!isfinite(t))
        return 0;
    for (int j = 0; j < 3; j++)
        pos[j] = (float)(o[j] + t * d[j] + 0.05 * app->diag * nrm[j]);
    return 1;
}

/* The light whose marker is within PICK_PIXELS of the mouse, or −1. */
static long pick_light(view_app *app)
{
    int w, h;
    window_size(app, &w, &h);
    long best = -1;
    double best_d = PICK_PIXELS;
    for (size_t i = 0; i < app->L.count; i++) {
        double x, y;
        if (app->L.light[i].kind == LRR_LIGHT_SUN ||
            !view_camera_project(&app->cam, app->L.light[i].position, w, h, &x, &y))
            continue;
        double dd = hypot(x - app->mx, y - app->my);
        if (dd < best_d) {
            best_d = dd;
            best = (long)i;
        }
    }
    return best;
}

/* A button at the mouse's position: left picks a light (else orbits), right pans. */
void view_input_button(view_app *app, int left, int press)
{
    if (!press) {
        app->dragging = app->orbiting = app->panning = 0;
        return;
    }
    if (left) {
        long i = pick_light(app);
        if (i >= 0) {
            app->selected = i;
            app->dragging = 1;
        } else {
            app->orbiting = 1;
        }
    } else {
        app->panning = 1;
    }
}

static void on_button(GLFWwindow *win, int button, int action, int mods)
{
    (void)mods;
    if (button == GLFW_MOUSE_BUTTON_LEFT || button == GLFW_MOUSE_BUTTON_RIGHT)
        view_input_button(app_of(win), button == GLFW_MOUSE_BUTTON_LEFT,
                          action != GLFW_RELEASE);
}

void view_input_cursor(view_app *app, double x, double y)
{
    double dx = x - app->mx, dy = y - app->my;
    app->mx = x;
    app->my = y;
    if (app->dragging && app->selected >= 0) {
        lrr_light_source *l = &app->L.light[app->selected];
        double nrm[3];
        if (surface_point(app, l->position, nrm)) {
            if (l->kind == LRR_LIGHT_SPOT) /* a spot faces back onto the surface it is on */
                for (int j = 0; j < 3; j++)
                    l->direction[j] = (float)-nrm[j];
            app->dirty = 1;
        }
    } else if (app->orbiting) {
        view_camera_orbit(&app->cam, -0.005 * dx, -0.005 * dy);
    } else if (app->panning) {
        double k = 0.0015 * app->cam.dist;
        view_camera_move(&app->cam, -k * dx, k * dy, 0);
    }
}

static void on_cursor(GLFWwindow *win, double x, double y)
{
    view_input_cursor(app_of(win), x, y);
}

/* Each notch towards the scene brings the eye 10% closer to the target. */
void view_input_scroll(view_app *app, double notches)
{
    app->cam.dist = fmax(1e-3 * app->diag, app->cam.dist * pow(0.9, notches));
}

static void on_scroll(GLFWwindow *win, double xoff, double yoff)
{
    (void)xoff;
    view_input_scroll(app_of(win), yoff);
}

/* A new point light where the mouse points (else at the camera's target), bright enough to
 * light a surface at a third of the scene's size about as the scene is lit. */
static void new_light(view_app *app)
{
    lrr_light_source l;
    memset(&l, 0, sizeof l);
    l.kind = LRR_LIGHT_POINT;
    double nrm[3];
    if (!surface_point(app, l.position, nrm))
        for (int j = 0; j < 3; j++)
            l.position[j] = (float)app->cam.target[j];
    l.rgb[0] = l.rgb[1] = l.rgb[2] = (float)(0.1 * app->diag * app->diag);
    l.direction[1] = -1;
    l.cone_angle = (float)(35 * M_PI / 180);
    l.cone_softness = (float)(10 * M_PI / 180);
    view_add_light(app, &l);
    app->selected = (long)app->L.count - 1;
}

/* T, +, -, C on the selected light. */
static void edit_light(view_app *app, int key)
{
    static const float colours[][3] = {{1, 1, 1},     {1, 0.8f, 0.55f}, {0.7f, 0.85f, 1},
                                       {1, 0.2f, 0.2f}, {0.2f, 1, 0.2f},  {0.25f, 0.35f, 1}};
    static const int kinds[] = {LRR_LIGHT_POINT, LRR_LIGHT_SPOT, LRR_LIGHT_SUN};
    if (app->selected < 0)
        return;
    lrr_light_source *l = &app->L.light[app->selected];
    float level = fmaxf(l->rgb[0], fmaxf(l->rgb[1], l->rgb[2]));
    if (key == VK_TYPE) {
        int k = 0;
        while (k < 3 && kinds[k] != l->kind)
            k++;
        l->kind = kinds[(k + 1) % 3];
        if (l->kind == LRR_LIGHT_SPOT && !(l->cone_angle > 0)) { /* a --light point */
            l->cone_angle = (float)(35 * M_PI / 180);
            l->cone_softness = (float)(10 * M_PI / 180);
        }
        if (l->kind == LRR_LIGHT_SPOT && !l->direction[0] && !l->direction[1] && !l->direction[2])
            l->direction[1] = -1;
        if (l->kind == LRR_LIGHT_SUN) { /* a sun gives irradiance, not intensity */
            for (int j = 0; j < 3; j++)
                l->direction[j] = j == 1 ? 1.0f : 0.3f;
            for (int j = 0; j < 3; j++)
                l->rgb[j] *= (float)(10 / (app->diag * app->diag));
        } else if (k == 2) {
            for (int j = 0; j < 3; j++)
                l->rgb[j] *= (float)(app->diag * app->diag / 10);
        }
    } else if (key == VK_BRIGHTER || key == VK_DIMMER) {
        float f = key == VK_BRIGHTER ? 1.25f : 0.8f;
        for (int j = 0; j < 3; j++)
            l->rgb[j] *= f;
    } else if (key == VK_COLOUR) {
        app->colour = (app->colour + 1) % 6;
        for (int j = 0; j < 3; j++)
            l->rgb[j] = level * colours[app->colour][j];
    }
    app->dirty = 1;
}

void view_input_key(view_app *app, int key)
{
    switch (key) {
    case VK_QUIT: glfwSetWindowShouldClose(app->win, GLFW_TRUE); break;
    case VK_NEW: new_light(app); break;
    case VK_DELETE:
        if (app->selected >= 0)
            view_remove_light(app, (size_t)app->selected);
        break;
    case VK_PICTURE: app->want_shot = 1; break;
    case VK_FLAT: app->smooth = !app->smooth; app->reupload = 1; break;
    case VK_EMITTERS: app->emitters = !app->emitters; app->dirty = 1; break;
    case VK_EXPOSURE_DOWN: app->exposure /= 1.25; break;
    case VK_EXPOSURE_UP: app->exposure *= 1.25; break;
    case VK_EXPOSURE_AUTO: view_auto_exposure(app, app->w.shown); break;
    default: edit_light(app, key);
    }
}

/* The GLFW key's enum view_key, or -1. */
static int view_key_of(int key)
{
    static const int map[][2] = {
        {GLFW_KEY_ESCAPE, VK_QUIT},           {GLFW_KEY_N, VK_NEW},
        {GLFW_KEY_DELETE, VK_DELETE},         {GLFW_KEY_BACKSPACE, VK_DELETE},
        {GLFW_KEY_P, VK_PICTURE},             {GLFW_KEY_F, VK_FLAT},
        {GLFW_KEY_L, VK_EMITTERS},            {GLFW_KEY_LEFT_BRACKET, VK_EXPOSURE_DOWN},
        {GLFW_KEY_RIGHT_BRACKET, VK_EXPOSURE_UP}, {GLFW_KEY_0, VK_EXPOSURE_AUTO},
        {GLFW_KEY_T, VK_TYPE},                {GLFW_KEY_C, VK_COLOUR},
        {GLFW_KEY_EQUAL, VK_BRIGHTER},        {GLFW_KEY_KP_ADD, VK_BRIGHTER},
        {GLFW_KEY_MINUS, VK_DIMMER},          {GLFW_KEY_KP_SUBTRACT, VK_DIMMER}};
    for (size_t i = 0; i < sizeof map / sizeof *map; i++)
        if (map[i][0] == key)
            return map[i][1];
    return -1;
}

static void on_key(GLFWwindow *win, int key, int scancode, int action, int mods)
{
    (void)scancode, (void)mods;
    int vk = view_key_of(key);
    if (action != GLFW_RELEASE && vk >= 0)
        view_input_key(app_of(win), vk);
}

/* The scene's size per second (×4 with shift): W moves the eye and target forward. */
void view_input_fly_keys(view_app *app, unsigned held, int shift, double dt)
{
    int down[6];
    for (int k = 0; k < 6; k++)
        down[k] = held >> k & 1;
    double v = 0.4 * app->diag * dt * (shift ? 4 : 1);
    view_camera_move(&app->cam, v * (down[3] - down[2]), v * (down[5] - down[4]),
                     v * (down[0] - down[1]));
}

void view_input_fly(view_app *app, double dt)
{
    static const int keys[6] = {GLFW_KEY_W, GLFW_KEY_S, GLFW_KEY_A, GLFW_KEY_D, GLFW_KEY_Q,
                                GLFW_KEY_E}; /* CLI_SCRIPT_FLY_KEYS */
    unsigned held = 0;
    for (int k = 0; k < 6; k++)
        held |= (unsigned)(glfwGetKey(app->win, keys[k]) == GLFW_PRESS) << k;
    view_input_fly_keys(app, held, glfwGetKey(app->win, GLFW_KEY_LEFT_SHIFT) == GLFW_PRESS, dt);
}

void view_input_install(view_app *app)
{
    glfwGetCursorPos(app->win, &app->mx, &app->my);
    glfwSetMouseButtonCallback(app->win, on_button);
    glfwSetCursorPosCallback(app->win, on_cursor);
    glfwSetScrollCallback(app->win, on_scroll);
    glfwSetKeyCallback(app->win, on_key);
}
