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
    glfwGetWindowSize(app->win, &w, &h);
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
    glfwGetWindowSize(app->win, &w, &h);
    long best = -1;
    double best_d = PICK_PIXELS;
    for (size_t i = 0; i < app->nlights; i++) {
        double x, y;
        if (app->lights[i].kind == LRR_LIGHT_SUN ||
            !view_camera_project(&app->cam, app->lights[i].position, w, h, &x, &y))
            continue;
        double dd = hypot(x - app->mx, y - app->my);
        if (dd < best_d) {
            best_d = dd;
            best = (long)i;
        }
    }
    return best;
}

static void on_button(GLFWwindow *win, int button, int action, int mods)
{
    view_app *app = app_of(win);
    if (action == GLFW_RELEASE) {
        app->dragging = app->orbiting = app->panning = 0;
        return;
    }
    if (button == GLFW_MOUSE_BUTTON_LEFT) {
        long i = pick_light(app);
        if (i >= 0) {
            app->selected = i;
            app->dragging = 1;
        } else {
            app->orbiting = 1;
        }
    } else if (button == GLFW_MOUSE_BUTTON_RIGHT) {
        app->panning = 1;
    }
}

static void on_cursor(GLFWwindow *win, double x, double y)
{
    view_app *app = app_of(win);
    double dx = x - app->mx, dy = y - app->my;
    app->mx = x;
    app->my = y;
    if (app->dragging && app->selected >= 0) {
        lrr_light_source *l = &app->lights[app->selected];
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

static void on_scroll(GLFWwindow *win, double xoff, double yoff)
{
    view_app *app = app_of(win);
    app->cam.dist = fmax(1e-3 * app->diag, app->cam.dist * pow(0.9, yoff));
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
    app->selected = (long)app->nlights - 1;
}

/* T, +, -, C on the selected light. */
static void edit_light(view_app *app, int key)
{
    static const float colours[][3] = {{1, 1, 1},     {1, 0.8f, 0.55f}, {0.7f, 0.85f, 1},
                                       {1, 0.2f, 0.2f}, {0.2f, 1, 0.2f},  {0.25f, 0.35f, 1}};
    static const int kinds[] = {LRR_LIGHT_POINT, LRR_LIGHT_SPOT, LRR_LIGHT_SUN};
    if (app->selected < 0)
        return;
    lrr_light_source *l = &app->lights[app->selected];
    float level = fmaxf(l->rgb[0], fmaxf(l->rgb[1], l->rgb[2]));
    if (key == GLFW_KEY_T) {
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
    } else if (key == GLFW_KEY_EQUAL || key == GLFW_KEY_KP_ADD || key == GLFW_KEY_MINUS ||
               key == GLFW_KEY_KP_SUBTRACT) {
        float f = key == GLFW_KEY_EQUAL || key == GLFW_KEY_KP_ADD ? 1.25f : 0.8f;
        for (int j = 0; j < 3; j++)
            l->rgb[j] *= f;
    } else if (key == GLFW_KEY_C) {
        app->colour = (app->colour + 1) % 6;
        for (int j = 0; j < 3; j++)
            l->rgb[j] = level * colours[app->colour][j];
    }
    app->dirty = 1;
}

static void on_key(GLFWwindow *win, int key, int scancode, int action, int mods)
{
    view_app *app = app_of(win);
    if (action == GLFW_RELEASE)
        return;
    switch (key) {
    case GLFW_KEY_ESCAPE: glfwSetWindowShouldClose(win, GLFW_TRUE); break;
    case GLFW_KEY_N: new_light(app); break;
    case GLFW_KEY_DELETE:
    case GLFW_KEY_BACKSPACE:
        if (app->selected >= 0)
            view_remove_light(app, (size_t)app->selected);
        break;
    case GLFW_KEY_P: app->want_shot = 1; break;
    case GLFW_KEY_F: app->smooth = !app->smooth; app->reupload = 1; break;
    case GLFW_KEY_L: app->emitters = !app->emitters; app->dirty = 1; break;
    case GLFW_KEY_LEFT_BRACKET: app->exposure /= 1.25; break;
    case GLFW_KEY_RIGHT_BRACKET: app->exposure *= 1.25; break;
    case GLFW_KEY_0: view_auto_exposure(app, app->w.shown); break;
    default: edit_light(app, key);
    }
}

void view_input_fly(view_app *app, double dt)
{
    static const int keys[6] = {GLFW_KEY_W, GLFW_KEY_S, GLFW_KEY_A, GLFW_KEY_D, GLFW_KEY_Q,
                                GLFW_KEY_E};
    int down[6];
    for (int k = 0; k < 6; k++)
        down[k] = glfwGetKey(app->win, keys[k]) == GLFW_PRESS;
    double v = 0.4 * app->diag * dt * (glfwGetKey(app->win, GLFW_KEY_LEFT_SHIFT) ? 4 : 1);
    view_camera_move(&app->cam, v * (down[3] - down[2]), v * (down[5] - down[4]),
                     v * (down[0] - down[1]));
}

void view_input_install(view_app *app)
{
    glfwGetCursorPos(app->win, &app->mx, &app->my);
    glfwSetMouseButtonCallback(app->win, on_button);
    glfwSetCursorPosCallback(app->win, on_cursor);
    glfwSetScrollCallback(app->win, on_scroll);
    glfwSetKeyCallback(app->win, on_key);
}
