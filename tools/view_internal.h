/* What the GL half of the viewer (tools/view_*.c) shares; see view.h. */
#ifndef LRR_VIEW_INTERNAL_H
#define LRR_VIEW_INTERNAL_H

#include <pthread.h>
#include <stdint.h>

#include <epoxy/gl.h>

#include "view.h"

/* ------------------------------------------------------------------ camera (view_camera.c) */
typedef struct view_camera {
    double target[3], dist, yaw, pitch; /* eye = target − dist · forward(yaw, pitch) */
    double fov_y, near_z, far_z;        /* degrees; scene units */
} view_camera;

void view_camera_look(view_camera *c, const double eye[3], const double target[3]);
void view_camera_eye(const view_camera *c, double eye[3]);
void view_camera_frame(const view_camera *c, double f[3], double r[3], double u[3]);
void view_camera_orbit(view_camera *c, double dyaw, double dpitch);
void view_camera_move(view_camera *c, double right, double up, double fwd);
void view_camera_matrix(const view_camera *c, double aspect, float m[16]);
void view_camera_ray(const view_camera *c, double x, double y, int w, int h, double org[3],
                     double dir[3]);
int view_camera_project(const view_camera *c, const float p[3], int w, int h, double *x,
                        double *y);

/* ------------------------------------------------------------------ worker (view_worker.c) */
/* The relighting thread. The GL thread posts the lights (view_worker_post); the worker
 * computes E = (emission if emitters) + direct(lights) and B = solve(E) into its own buffer,
 * then swaps it with `ready` under the mutex; the GL thread swaps `ready` with `shown`
 * (view_worker_take). No B is ever copied under the lock, and the window shows the newest
 * finished one. */
typedef struct view_worker {
    pthread_t thread;
    pthread_mutex_t mu;
    pthread_cond_t wake, done;
    int started, quit;
    /* the request (under mu) */
    lrr_light_source lights[VIEW_MAX_LIGHTS];
    size_t nlights;
    int emitters;
    uint64_t posted;          /* generation of the newest request */
    /* the result (under mu) */
    float *work, *ready, *shown; /* n×3 each */
    uint64_t ready_gen, shown_gen, finished_gen;
    double ready_direct_ms, ready_solve_ms;
    uint64_t relights;        /* B finished so far */
    double sum_direct_ms, sum_solve_ms;
    lrr_status error;         /* first failure; the worker stops */
    char error_text[256];
    /* the worker's own */
    const lrr_operator *op;
    lrr_solver *solver;
    lrr_lighting *lighting;
    float *e;
    size_t n;
} view_worker;

/* shadow_tol: lrr_lighting_set_tolerance */
int view_worker_start(view_worker *w, const lrr_operator *op, double shadow_tol);
void view_worker_post(view_worker *w, const lrr_light_source *lights, size_t count,
                      int emitters);
/* If a newer B than the one shown is ready: swaps it in and returns 1 (w->shown). */
int view_worker_take(view_worker *w);
/* 1 once the worker has failed (error_text says why; it is not written again). */
int view_worker_failed(view_worker *w);
/* The relights finished so far and the sums of their direct-light and solve times. */
void view_worker_stats(view_worker *w, uint64_t *relights, double *direct_ms,
                       double *solve_ms);
/* Waits until the newest request is finished; 0, or -1 after a worker failure. */
int view_worker_wait(view_worker *w);
void view_worker_stop(view_worker *w);

/* ------------------------------------------------------------------ smooth shading (view_smooth.c) */
typedef struct view_smooth {
    uint32_t *corner;   /* 3n: the welded corner of each triangle corner */
    uint32_t *first;    /* m+1: corner u gathers entries first[u] .. first[u+1]-1 */
    uint32_t *src;      /* 3n: the subpatch of each entry */
    float *w;           /* 3n: its area's share at that corner */
    float *out;         /* m×3 corner radiosity */
    size_t n, m;
} view_smooth;

/* Welds the corners of the n triangles vtx (n×9) of normals normal (n×3); 0 or -1. */
int view_smooth_init(view_smooth *s, const float *vtx, const float *normal, const float *area,
                     size_t n);
/* The m corner colours (m×3) of radiosity b (n×3); valid until the next call. */
const float *view_smooth_apply(view_smooth *s, const float *b);
void view_smooth_free(view_smooth *s);

/* ------------------------------------------------------------------ GL (view_gl.c) */
typedef struct view_gl {
    GLuint prog, vao, vbo, btex, bbuf;      /* the scene: positions + radiosity texture */
    GLuint marker_prog, marker_vao, marker_vbo;
    GLuint fbo, color_rb, depth_rb;         /* what is drawn; blitted to the window */
    GLuint corner_vbo;                      /* per vertex: its welded corner */
    GLint u_mvp, u_exposure, u_bsamp, u_smooth, u_marker_mvp;
    int fb_w, fb_h;
    size_t n, texels;                       /* texels: room in the texture buffer /3 */
} view_gl;

/* Shaders, the mesh (n triangles vtx, n×9; corner: the welded corner of each of the 3n
 * vertices, of m) and an offscreen w×h framebuffer; 0 or -1. */
int view_gl_init(view_gl *g, const float *vtx, size_t n, const uint32_t *corner, size_t m,
                 int w, int h);
/* count RGB triples: n subpatch radiosities (flat) or m corner colours (smooth). */
void view_gl_upload(view_gl *g, const float *rgb, size_t count);
/* markers: count points (xyz), the selected one (or −1) highlighted; smooth: colours per
 * welded corner (else per triangle). */
void view_gl_draw(view_gl *g, const float mvp[16], double exposure, int smooth,
                  const float *markers, size_t count, long selected);
void view_gl_present(view_gl *g, int win_w, int win_h);
/* The offscreen picture to a PNG, written atomically, and the mean luma (0..255) of its
 * left and right halves; CLI_EXIT_*. */
int view_gl_screenshot(view_gl *g, const char *path, double half_luma[2]);
void view_gl_free(view_gl *g);

/* ------------------------------------------------------------------ text (view_font.c) */
/* Draws ASCII text in the top-left corner of framebuffer fbo (w×h; a built-in 5×7 font,
 * `scale` screen pixels a font pixel). */
int view_font_init(void);
void view_font_draw(const char *text, GLuint fbo, int w, int h, int scale);
void view_font_free(void);

double view_now_ms(void);

#endif /* LRR_VIEW_INTERNAL_H */
