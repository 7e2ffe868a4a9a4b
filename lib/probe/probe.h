/* The probe stage (lib/probe/): HDR light probes at infinity, their fits, and the direct
 * light they put on an operator's subpatches. */
#ifndef LRR_PROBE_H
#define LRR_PROBE_H

#include "operator/operator.h"

/* ------------------------------------------------------------ light probes */
struct lrr_probe {
    lrr_context *ctx;
    size_t w, h;
    float *rgb;          /* w×h×3 radiance */
    /* per pixel (index v·w + u), structure of arrays for the irradiance sum */
    float *dir;          /* 3 arrays of w·h: x, y, z */
    float *q;            /* 3 arrays of w·h: radiance × solid angle, r, g, b */
    double *energy;      /* w·h: luminance × solid angle (median cut) */
};

/* Reads the R, G, B channels (half or float) of a scanline or tiled OpenEXR file
 * (lib/probe/exr.cpp, C++: DWA compression included) into a malloc'd w×h×3 float buffer,
 * pixels unvalidated; a layout other than w = 2h is refused (LRR_ERR_DIM) before decoding.
 * Errors (unreadable, truncated, no R/G/B channel) are recorded naming the file; no
 * exception escapes. */
lrr_status lrr__exr_read_rgb(lrr_context *ctx, const char *path, float **rgb, size_t *width,
                             size_t *height);
/* Reads a Radiance RGBE file (lib/probe/hdr.c) into a w×h×3 float buffer from stb_image
 * (free with stbi_image_free), after checking that the pixel data is all there; a layout
 * other than w = 2h is refused (LRR_ERR_DIM) before decoding. Errors name the file. */
lrr_status lrr__hdr_read_rgb(lrr_context *ctx, const char *path, float **rgb, size_t *width,
                             size_t *height);
#endif
