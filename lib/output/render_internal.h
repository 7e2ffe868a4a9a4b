/* Shared by the files of the renderer and the exporter (lib/output/ only; lrr.h declares
 * lrr_render_png, lrr_render_exr, lrr_export_gltf and lrr_export_ply): render.c (the entry
 * points, tone mapping, PNG output), exr.cpp (OpenEXR output), export.c, gltf.c and
 * ply_out.c (the lit mesh as glTF 2.0 or PLY), camera.c (the camera of the
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

/* render.c */
/* Writes data to path through the atomic writer (core/atomic_file.c): path never holds a
 * partial file; every step goes through the context's I/O fault hook. */
lrr_status lrr__output_write_atomic(lrr_context *ctx, const char *path,
                                    const unsigned char *data, size_t len);

/* export.c */
/* The lit mesh that lrr_export_gltf and lrr_export_ply write (lrr.h "export"). */
typedef struct lrr__export_mesh {
    size_t nv, nt, nm;     /* vertices, triangles, materials */
    float *pos, *normal;   /* nv×3 */
    float *radiosity;      /* nv×3: the vertex's area-weighted mean B, unscaled */
    float *colour;         /* nv×3: min(1, radiosity × exposure) */
    uint32_t *index;       /* nt×3, grouped by material */
    size_t *tri_start;     /* nm+1: material m's triangles are tri_start[m] .. [m+1]-1 */
    float *rho, *emission; /* nm×3: each material's reflectance and emission */
    double exposure;       /* the exposure used (resolved when the option was 0) */
    int subpatches;        /* the mesh is the subpatch mesh */
} lrr__export_mesh;
/* Checks the request (options, radiosity; errors name `what`, the function, and path) and
 * builds the mesh. m is zeroed first; free it with lrr__export_mesh_free even on failure. */
lrr_status lrr__export_mesh_build(const lrr_operator *op, const float *radiosity,
                                  const lrr_export_options *opts, const char *what,
                                  const char *path, lrr__export_mesh *m);
void lrr__export_mesh_free(lrr__export_mesh *m);

/* weld.c */
/* corner_vertex (3n): per subpatch corner (pos, 9 per subpatch) a welded vertex;
 * *vertex_colour: per vertex the area-weighted mean radiosity of the subpatches that touch
 * it (free with lrr_aligned_free); *n_vertices (unless NULL) their number. group (n, or
 * NULL for one group): corners of subpatches in different groups never share a vertex (the
 * exporter's material edges). */
lrr_status lrr__render_weld_vertices(const lrr_operator *op, const double *pos,
                                     const float *radiosity, const uint32_t *group,
                                     uint32_t *corner_vertex, float **vertex_colour,
                                     size_t *n_vertices);

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
