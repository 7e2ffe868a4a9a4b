/*
 * A small log-log scatter plot renderer for lrr-bench: draws into an RGB buffer with an
 * embedded 5×7 bitmap font and writes a PNG (stb_image_write) atomically. No dependency on
 * the library; used for "error against real-time milliseconds" figures.
 */
#ifndef LRR_BENCH_PLOT_H
#define LRR_BENCH_PLOT_H

#include <stddef.h>
#include <stdint.h>

enum plot_marker { PLOT_CIRCLE = 0, PLOT_SQUARE = 1, PLOT_TRIANGLE = 2, PLOT_DIAMOND = 3 };

typedef struct plot_series {
    const char *name;          /* legend text (ASCII, plus U+00D7 '×') */
    const double *x, *y;       /* `count` points; non-finite or <= 0 values are skipped */
    const char *const *labels; /* a text per point drawn beside it, or NULL */
    size_t count;
    unsigned char rgb[3];      /* marker colour */
    int marker;                /* enum plot_marker */
    int line;                  /* 0: markers only; 1: consecutive points joined by a solid
                                  line, 2: by a dashed one (in array order) */
} plot_series;

typedef struct plot_spec {
    const char *title, *x_title, *y_title;
    unsigned width, height;    /* pixels; 0 = 960 × 680 */
    const plot_series *series;
    size_t n_series;
    int link_first_two;        /* != 0: join point i of series 0 and 1 by a thin line */
} plot_spec;

/* Renders a log-log scatter plot (both axes logarithmic, decades labelled, minor ticks at
 * 2..9, grid, axis titles, legend, point labels) into a new malloc'd RGB buffer of
 * width·height·3 bytes. Returns 0, or -1 with errno set (EINVAL: no plottable point or a
 * bad size; ENOMEM). */
int plot_render(const plot_spec *spec, unsigned char **rgb, unsigned *width, unsigned *height);

/* plot_render, then a PNG written to a temporary file next to `path`, synced and renamed.
 * Returns 0, or -1 with errno set (nothing is left behind under `path`). */
int plot_write_png(const plot_spec *spec, const char *path);

/* Writes an RGB buffer (width·height·3 bytes) as a PNG to a temporary file next to `path`,
 * synced and renamed. Returns 0, or -1 with errno set (nothing is left behind). */
int plot_write_rgb_png(const unsigned char *rgb, unsigned width, unsigned height,
                       const char *path);

/* Draws UTF-8 `text` (ASCII and '×'; anything else as '?') in the embedded 5×7 font (a
 * character takes 6 pixels across and 9 down with descenders, at scale 1) at (x, y) = top
 * left, `scale` pixels per font pixel, rotated 90° counter-clockwise (reading upwards from
 * (x, y)) when `vertical` != 0. Pixels outside the buffer are clipped. Returns the text's
 * width in pixels. */
int plot_text(unsigned char *rgb, unsigned width, unsigned height, int x, int y,
              const char *text, int scale, int vertical, const unsigned char colour[3]);

/* The font that plot_text draws (plot_font.c): ASCII 32..126, then '×' (index 95), 5×7
 * pixels, one byte per row. */
extern const uint8_t plot_font5x7[96][7];

#endif /* LRR_BENCH_PLOT_H */
