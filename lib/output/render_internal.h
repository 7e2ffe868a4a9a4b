/* Shared by the files of the renderer (lib/output/ only; lrr.h declares lrr_render_png and
 * lrr_render_exr): render.c (the entry points, tone mapping, PNG output), exr.cpp (OpenEXR
 * output), camera.c (the camera of the
 * built-in scenes and of generic bounds), weld.c (subpatch corners welded into shared
 * vertices for smooth shading) and raster.c (clipping, triangle setup, the z-buffer
 * rasteriser). */
#ifndef LRR_RENDER_INTERNAL_H
#define LRR_RENDER_INTERNAL_H

#include "operator/operator.h"

#include <stdint.h>

typedef struct lrr__camera {
    double eye[3], right[3], up[3], fwd[3];
    double tan_x, tan_y; /* tangents of the half fields of view */
    double near;         /* view-space depth of the near clipping plane */
} lrr__camera;

/* A screen triangle, positively oriented, in fixed-point pixels. */
typedef struct lrr__rtri {
    int64_t x[3], y[3];
    int64_t area;         /* twice the signed area, > 0 */
    float iw[3];          /* 1/w, interpolated linearly in screen space */
    float c[3][3];        /* colour/w */
    uint32_t id;          /* subpatch */
    int32_t x0, x1, y0, y1; /* pixel bounding box on screen, inclusive */
} lrr__rtri;

typedef struct lrr__framebuffer {
    unsigned width, height;
    float *depth;    /* 1/w; 0 = background */
    float *rgb;      /* interpolated radiosity */
    uint32_t *id;    /* subpatch + 1; 0 = background */
} lrr__framebuffer;


/* camera.c */
/* The camera of a width×height picture of op with radiosity (n×3) under options o (checked):
 * the eye/target camera, the Cornell box's published one, one inside a lit closed scene or
 * one framing the scene's bounding sphere (lrr.h lrr_render_png says which when). */
lrr_status lrr__render_camera_setup(lrr__camera *cam, const lrr_operator *op,
                                    const float *radiosity, const lrr_render_options *o,
                                    unsigned width, unsigned height);

/* weld.c */
/* corner_vertex (3n): per subpatch corner (pos, 9 per subpatch) a welded vertex;
 * *vertex_colour: per vertex the area-weighted mean radiosity of the subpatches that touch
 * it (free with lrr_aligned_free). */
lrr_status lrr__render_weld_vertices(const lrr_operator *op, const double *pos,
                                     const float *radiosity, uint32_t *corner_vertex,
                                     float **vertex_colour);

/* raster.c */
/* The clipped screen triangles of subpatch id, Gouraud-coloured by its welded vertices
 * (vcol); fills out unless it is NULL, and returns their number. Back faces give none. */
int lrr__render_setup_subpatch(const lrr__camera *cam, unsigned width, unsigned height,
                               uint32_t id, const double *pos, const uint32_t *corner_vertex,
                               const float *vcol, lrr__rtri *out);
/* Draws the nt triangles into fb (depth, colour and subpatch id per pixel). */
lrr_status lrr__render_raster_all(lrr_context *ctx, lrr__framebuffer *fb,
                                  const lrr__rtri *tris, size_t nt);

/* exr.cpp */
/* Encodes width×height linear RGB floats (row 0 at the top) as an OpenEXR file (float R, G,
 * B, ZIP compression) in memory: *data (lrr__alloc'd, free with lrr_aligned_free) of *len
 * bytes. Errors name path; no exception escapes. */
lrr_status lrr__render_encode_exr(lrr_context *ctx, const char *path, unsigned width,
                                  unsigned height, const float *rgb, unsigned char **data,
                                  size_t *len);

#endif
