/* Log-log scatter plots for lrr-bench: see plot.h.
 *
 * Everything is drawn by hand into an RGB buffer: axes, a grid at every decade (and at 2..9
 * times it, lighter), tick labels, titles, a legend in the emptiest corner and a label
 * beside each point, placed where it overlaps nothing drawn before. Text uses the 5×7 font
 * in plot_font.c (one byte per row, bit 4 = leftmost column), written for these plots; g, p,
 * q and y are stored from their x-height down and drawn DESCENT rows lower. */
#include "plot.h"
#include "core/atomic_file.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* stb_image_write with every function static: no symbol can clash with another copy (Debian's
 * libstb, which liblrr links for its own PNGs). */
#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
#pragma GCC diagnostic ignored "-Wmissing-prototypes"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wsign-compare"
#include <stb_image_write.h>
#pragma GCC diagnostic pop

/* ------------------------------------------------------------------ font */
#define GLYPH_W 5
#define GLYPH_H 7
#define CELL_W 6
/* g, p, q and y are drawn this many rows lower: their bodies sit at the x-height */
#define DESCENT 2

/* Next glyph index from UTF-8 text (advances *s); '?' for anything the font lacks. */
static int next_glyph(const char **s)
{
    const unsigned char *p = (const unsigned char *)*s;
    if (p[0] < 0x80) {
        *s += 1;
        return p[0] >= 32 && p[0] <= 126 ? p[0] - 32 : '?' - 32;
    }
    if (p[0] == 0xC3 && p[1] == 0x97) { /* U+00D7 × */
        *s += 2;
        return 95;
    }
    /* skip one whole UTF-8 sequence */
    size_t len = 1;
    while (p[len] && (p[len] & 0xC0) == 0x80)
        len++;
    *s += len;
    return '?' - 32;
}

static int text_chars(const char *text)
{
    int n = 0;
    while (*text) {
        (void)next_glyph(&text);
        n++;
    }
    return n;
}

static int text_width(const char *text, int scale)
{
    int n = text_chars(text);
    return n ? (n * CELL_W - 1) * scale : 0;
}

/* ------------------------------------------------------------------ canvas */
typedef struct canvas {
    unsigned char *px;
    int w, h;
} canvas;

static void put(canvas *c, int x, int y, const unsigned char col[3])
{
    if (x < 0 || y < 0 || x >= c->w || y >= c->h)
        return;
    unsigned char *p = c->px + 3 * ((size_t)y * (size_t)c->w + (size_t)x);
    p[0] = col[0];
    p[1] = col[1];
    p[2] = col[2];
}

static void fill_rect(canvas *c, int x0, int y0, int x1, int y1, const unsigned char col[3])
{
    for (int y = y0; y <= y1; y++)
        for (int x = x0; x <= x1; x++)
            put(c, x, y, col);
}

static void rect_outline(canvas *c, int x0, int y0, int x1, int y1, const unsigned char col[3])
{
    fill_rect(c, x0, y0, x1, y0, col);
    fill_rect(c, x0, y1, x1, y1, col);
    fill_rect(c, x0, y0, x0, y1, col);
    fill_rect(c, x1, y0, x1, y1, col);
}

int plot_text(unsigned char *rgb, unsigned width, unsigned height, int x, int y,
              const char *text, int scale, int vertical, const unsigned char colour[3])
{
    canvas c = {rgb, (int)width, (int)height};
    int pos = 0;
    while (*text) {
        int g = next_glyph(&text);
        int drop = (g == 'g' - 32 || g == 'p' - 32 || g == 'q' - 32 || g == 'y' - 32) ? DESCENT : 0;
        for (int gy = 0; gy < GLYPH_H; gy++)
            for (int gx = 0; gx < GLYPH_W; gx++) {
                if (!(plot_font5x7[g][gy] & (0x10 >> gx)))
                    continue;
                int u = (pos + gx) * scale, v = (gy + drop) * scale;
                for (int sy = 0; sy < scale; sy++)
                    for (int sx = 0; sx < scale; sx++) {
                        if (vertical) /* 90° counter-clockwise: reads bottom to top */
                            put(&c, x + v + sy, y - u - sx, colour);
                        else
                            put(&c, x + u + sx, y + v + sy, colour);
                    }
            }
        pos += CELL_W;
    }
    return pos ? (pos - 1) * scale : 0;
}

/* Bresenham, one pixel wide */
static void line(canvas *c, int x0, int y0, int x1, int y1, const unsigned char col[3])
{
    int dx = abs(x1 - x0), dy = -abs(y1 - y0);
    int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1, err = dx + dy;
    for (;;) {
        put(c, x0, y0, col);
        if (x0 == x1 && y0 == y1)
            break;
        int e2 = 2 * err;
        if (e2 >= dy) {
            err += dy;
            x0 += sx;
        }
        if (e2 <= dx) {
            err += dx;
            y0 += sy;
        }
    }
}

/* Bresenham with a dash pattern (8 on, 5 off), two pixels thick vertically */
static void line_styled(canvas *c, int x0, int y0, int x1, int y1, int dashed,
                        const unsigned char col[3])
{
    int dx = abs(x1 - x0), dy = -abs(y1 - y0);
    int sx = x0 < x1 ? 1 : -1, sy = y0 < y1 ? 1 : -1, err = dx + dy;
    for (int k = 0;; k++) {
        if (!dashed || k % 13 < 8) {
            put(c, x0, y0, col);
            put(c, x0, y0 + 1, col);
        }
        if (x0 == x1 && y0 == y1)
            break;
        int e2 = 2 * err;
        if (e2 >= dy) {
            err += dy;
            x0 += sx;
        }
        if (e2 <= dx) {
            err += dx;
            y0 += sy;
        }
    }
}

static void draw_marker(canvas *c, int cx, int cy, int marker, int r,
                        const unsigned char fill[3], const unsigned char edge[3])
{
    for (int dy = -r - 1; dy <= r + 1; dy++)
        for (int dx = -r - 1; dx <= r + 1; dx++) {
            double fx = dx, fy = dy;
            int in, in_inner;
            switch (marker) {
            case PLOT_SQUARE:
                in = abs(dx) <= r && abs(dy) <= r;
                in_inner = abs(dx) <= r - 1 && abs(dy) <= r - 1;
                break;
            case PLOT_DIAMOND:
                in = abs(dx) + abs(dy) <= r + 1;
                in_inner = abs(dx) + abs(dy) <= r - 1;
                break;
            case PLOT_TRIANGLE: {
                /* apex up: |dx| <= (dy + r) / 2 · 1.15, within dy in [-r, r] */
                in = fy >= -r && fy <= r && fabs(fx) <= (fy + r) * 0.58 + 0.5;
                in_inner = fy >= -r + 2 && fy <= r - 1 && fabs(fx) <= (fy + r - 2) * 0.58 - 0.3;
                break;
            }
            default: /* circle */
                in = fx * fx + fy * fy <= (r + 0.5) * (r + 0.5);
                in_inner = fx * fx + fy * fy <= (r - 0.7) * (r - 0.7);
                break;
            }
            if (in)
                put(c, cx + dx, cy + dy, in_inner ? fill : edge);
        }
}

/* ------------------------------------------------------------------ axes */
typedef struct axis {
    double lo, hi; /* log10 of the range shown */
    int p0, p1;    /* pixel positions of lo and hi */
} axis;

static int axis_px(const axis *a, double v)
{
    double t = (log10(v) - a->lo) / (a->hi - a->lo);
    return (int)lround(a->p0 + t * (a->p1 - a->p0));
}

/* Decades covering [vmin, vmax] with a little room: at least one whole decade. */
static void axis_range(axis *a, double vmin, double vmax)
{
    double l0 = log10(vmin), l1 = log10(vmax);
    double pad = 0.08 * (l1 - l0 > 0.5 ? l1 - l0 : 0.5);
    a->lo = floor(l0 - pad);
    a->hi = ceil(l1 + pad);
    if (a->hi - a->lo < 1)
        a->hi = a->lo + 1;
}

static void tick_label(double v, char *buf, size_t len)
{
    double e = log10(v);
    if (e >= -4 && e <= 5)
        snprintf(buf, len, "%g", v);
    else {
        double m = v / pow(10, floor(e + 1e-9));
        if (fabs(m - 1) < 1e-9)
            snprintf(buf, len, "1e%d", (int)floor(e + 1e-9));
        else
            snprintf(buf, len, "%ge%d", m, (int)floor(e + 1e-9));
    }
}

typedef struct box {
    int x0, y0, x1, y1;
} box;

static int boxes_overlap(const box *a, const box *b)
{
    return a->x0 <= b->x1 && b->x0 <= a->x1 && a->y0 <= b->y1 && b->y0 <= a->y1;
}

static int point_ok(const plot_series *s, size_t i)
{
    return isfinite(s->x[i]) && isfinite(s->y[i]) && s->x[i] > 0 && s->y[i] > 0;
}

/* ------------------------------------------------------------------ the plot */
static const unsigned char white[3] = {255, 255, 255}, black[3] = {0, 0, 0},
                           grid_major[3] = {215, 215, 215}, grid_minor[3] = {238, 238, 238},
                           grey[3] = {90, 90, 90};
#define TEXT_SCALE 2 /* text scale: pixels per font pixel */
enum { R_MARK = 6 }; /* marker radius */

/* The image and where the data go in it. */
typedef struct layout {
    canvas c;
    unsigned W, H;
    int left, right, top, bottom; /* the plot area, in pixels */
    axis ax, ay;
} layout;

/* The range of the plottable points; returns their number. */
static size_t data_range(const plot_spec *spec, double *xmin, double *xmax, double *ymin,
                         double *ymax)
{
    size_t points = 0;
    for (size_t s = 0; s < spec->n_series; s++) {
        const plot_series *se = &spec->series[s];
        for (size_t i = 0; i < se->count; i++) {
            if (!point_ok(se, i))
                continue;
            points++;
            *xmin = fmin(*xmin, se->x[i]);
            *xmax = fmax(*xmax, se->x[i]);
            *ymin = fmin(*ymin, se->y[i]);
            *ymax = fmax(*ymax, se->y[i]);
        }
    }
    return points;
}

/* grid: minor lines at 2..9 × 10^e, major at decades */
static void draw_grid(const layout *f)
{
    canvas c = f->c;
    const axis ax = f->ax, ay = f->ay;
    const int left = f->left, right = f->right, top = f->top, bottom = f->bottom;
    for (int pass = 0; pass < 2; pass++)
        for (int e = (int)ax.lo; e <= (int)ax.hi; e++)
            for (int m = 1; m <= 9; m++) {
                double v = m * pow(10, e);
                if (log10(v) > ax.hi + 1e-9 || (pass == 0) != (m > 1))
                    continue;
                int x = axis_px(&ax, v);
                fill_rect(&c, x, top, x, bottom, m == 1 ? grid_major : grid_minor);
            }
    for (int pass = 0; pass < 2; pass++)
        for (int e = (int)ay.lo; e <= (int)ay.hi; e++)
            for (int m = 1; m <= 9; m++) {
                double v = m * pow(10, e);
                if (log10(v) > ay.hi + 1e-9 || (pass == 0) != (m > 1))
                    continue;
                int y = axis_px(&ay, v);
                fill_rect(&c, left, y, right, y, m == 1 ? grid_major : grid_minor);
            }
    rect_outline(&c, left, top, right, bottom, black);
}

/* ticks and labels: every decade (every other one past 8 decades), plus 2 and 5 when
 * the axis spans a single decade */
static void draw_ticks(const layout *f)
{
    canvas c = f->c;
    const axis ax = f->ax, ay = f->ay;
    const int left = f->left, right = f->right, top = f->top, bottom = f->bottom;
    unsigned char *px = c.px;
    const unsigned W = f->W, H = f->H;
    const int S = TEXT_SCALE;
    int xdec = (int)(ax.hi - ax.lo), ydec = (int)(ay.hi - ay.lo);
    char buf[32];
    for (int e = (int)ax.lo; e <= (int)ax.hi; e++)
        for (int m = 1; m <= 9; m++) {
            double v = m * pow(10, e);
            if (log10(v) > ax.hi + 1e-9)
                continue;
            int x = axis_px(&ax, v);
            int major = m == 1;
            fill_rect(&c, x, bottom - (major ? 7 : 4), x, bottom, black);
            fill_rect(&c, x, top, x, top + (major ? 7 : 4), black);
            int labelled = (major && (xdec <= 8 || (e - (int)ax.lo) % 2 == 0)) ||
                           (xdec == 1 && (m == 2 || m == 5));
            if (labelled) {
                tick_label(v, buf, sizeof buf);
                plot_text(px, W, H, x - text_width(buf, S) / 2, bottom + 10, buf, S, 0, black);
            }
        }
    for (int e = (int)ay.lo; e <= (int)ay.hi; e++)
        for (int m = 1; m <= 9; m++) {
            double v = m * pow(10, e);
            if (log10(v) > ay.hi + 1e-9)
                continue;
            int y = axis_px(&ay, v);
            int major = m == 1;
            fill_rect(&c, left, y, left + (major ? 7 : 4), y, black);
            fill_rect(&c, right - (major ? 7 : 4), y, right, y, black);
            int labelled = (major && (ydec <= 8 || (e - (int)ay.lo) % 2 == 0)) ||
                           (ydec == 1 && (m == 2 || m == 5));
            if (labelled) {
                tick_label(v, buf, sizeof buf);
                plot_text(px, W, H, left - 10 - text_width(buf, S), y - GLYPH_H * S / 2, buf, S,
                          0, black);
            }
        }
}

/* titles */
static void draw_titles(const layout *f, const plot_spec *spec)
{
    const int left = f->left, right = f->right, top = f->top, bottom = f->bottom;
    unsigned char *px = f->c.px;
    const unsigned W = f->W, H = f->H;
    const int S = TEXT_SCALE;
    if (spec->title)
        plot_text(px, W, H, ((int)W - text_width(spec->title, S)) / 2, 20, spec->title, S, 0,
                  black);
    if (spec->x_title)
        plot_text(px, W, H, (left + right - text_width(spec->x_title, S)) / 2, (int)H - 40,
                  spec->x_title, S, 0, black);
    if (spec->y_title)
        plot_text(px, W, H, 16, (top + bottom + text_width(spec->y_title, S)) / 2,
                  spec->y_title, S, 1, black);
}

/* The lines under the markers: links between the first two series, each series' own. */
static void draw_lines(const layout *f, const plot_spec *spec)
{
    canvas c = f->c;
    const axis ax = f->ax, ay = f->ay;
    /* links between the two series' points of the same index, under the markers */
    if (spec->link_first_two && spec->n_series >= 2) {
        static const unsigned char link[3] = {150, 150, 150};
        const plot_series *a = &spec->series[0], *b = &spec->series[1];
        for (size_t i = 0; i < a->count && i < b->count; i++)
            if (point_ok(a, i) && point_ok(b, i))
                line(&c, axis_px(&ax, a->x[i]), axis_px(&ay, a->y[i]), axis_px(&ax, b->x[i]),
                     axis_px(&ay, b->y[i]), link);
    }

    /* lines joining each series' consecutive points, under the markers */
    for (size_t s = 0; s < spec->n_series; s++) {
        const plot_series *se = &spec->series[s];
        if (!se->line)
            continue;
        size_t prev = (size_t)-1;
        for (size_t i = 0; i < se->count; i++) {
            if (!point_ok(se, i))
                continue;
            if (prev != (size_t)-1)
                line_styled(&c, axis_px(&ax, se->x[prev]), axis_px(&ay, se->y[prev]),
                            axis_px(&ax, se->x[i]), axis_px(&ay, se->y[i]), se->line == 2,
                            se->rgb);
            prev = i;
        }
    }
}

/* markers; their boxes are obstacles for the labels placed afterwards (in taken; returns
 * how many) */
static size_t draw_markers(const layout *f, const plot_spec *spec, box *taken)
{
    canvas c = f->c;
    const axis ax = f->ax, ay = f->ay;
    size_t nbox = 0;
    for (size_t s = 0; s < spec->n_series; s++) {
        const plot_series *se = &spec->series[s];
        unsigned char edge[3] = {(unsigned char)(se->rgb[0] * 0.55),
                                 (unsigned char)(se->rgb[1] * 0.55),
                                 (unsigned char)(se->rgb[2] * 0.55)};
        for (size_t i = 0; i < se->count; i++) {
            if (!point_ok(se, i))
                continue;
            int x = axis_px(&ax, se->x[i]), y = axis_px(&ay, se->y[i]);
            draw_marker(&c, x, y, se->marker, R_MARK, se->rgb, edge);
            taken[nbox++] = (box){x - R_MARK - 1, y - R_MARK - 1, x + R_MARK + 1, y + R_MARK + 1};
        }
    }
    return nbox;
}

/* legend in the corner holding the fewest points (its box is added to taken; returns nbox) */
static size_t draw_legend(const layout *f, const plot_spec *spec, box *taken, size_t nbox)
{
    canvas c = f->c;
    const int left = f->left, right = f->right, top = f->top, bottom = f->bottom;
    unsigned char *px = c.px;
    const unsigned W = f->W, H = f->H;
    const int S = TEXT_SCALE;
    int lw = 0, lh = 0;
    for (size_t s = 0; s < spec->n_series; s++) {
        int tw = text_width(spec->series[s].name ? spec->series[s].name : "", S);
        lw = tw > lw ? tw : lw;
    }
    lw += 48;
    lh = (int)spec->n_series * 24 + 12;
    box corners[4] = {{right - lw - 10, top + 10, right - 10, top + 10 + lh},
                      {left + 10, top + 10, left + 10 + lw, top + 10 + lh},
                      {right - lw - 10, bottom - 10 - lh, right - 10, bottom - 10},
                      {left + 10, bottom - 10 - lh, left + 10 + lw, bottom - 10}};
    int best = 0;
    size_t best_hits = SIZE_MAX;
    for (int k = 0; k < 4; k++) {
        size_t hits = 0;
        for (size_t b = 0; b < nbox; b++)
            hits += (size_t)boxes_overlap(&corners[k], &taken[b]);
        if (hits < best_hits) {
            best_hits = hits;
            best = k;
        }
    }
    if (spec->n_series > 0) {
        box L = corners[best];
        fill_rect(&c, L.x0, L.y0, L.x1, L.y1, white);
        rect_outline(&c, L.x0, L.y0, L.x1, L.y1, grey);
        for (size_t s = 0; s < spec->n_series; s++) {
            const plot_series *se = &spec->series[s];
            unsigned char edge[3] = {(unsigned char)(se->rgb[0] * 0.55),
                                     (unsigned char)(se->rgb[1] * 0.55),
                                     (unsigned char)(se->rgb[2] * 0.55)};
            int y = L.y0 + 18 + (int)s * 24;
            draw_marker(&c, L.x0 + 18, y, se->marker, R_MARK, se->rgb, edge);
            plot_text(px, W, H, L.x0 + 36, y - GLYPH_H * S / 2, se->name ? se->name : "", S, 0,
                      black);
        }
        taken[nbox++] = L;
    }
    return nbox;
}

/* point labels: the first free spot of eight around the marker, else skip */
static void draw_point_labels(const layout *f, const plot_spec *spec, box *taken, size_t nbox,
                              size_t cap)
{
    const axis ax = f->ax, ay = f->ay;
    const int left = f->left, right = f->right, top = f->top, bottom = f->bottom;
    unsigned char *px = f->c.px;
    const unsigned W = f->W, H = f->H;
    const int S = TEXT_SCALE;
    for (size_t s = 0; s < spec->n_series; s++) {
        const plot_series *se = &spec->series[s];
        if (!se->labels)
            continue;
        for (size_t i = 0; i < se->count; i++) {
            if (!point_ok(se, i) || !se->labels[i] || !se->labels[i][0])
                continue;
            int x = axis_px(&ax, se->x[i]), y = axis_px(&ay, se->y[i]);
            int tw = text_width(se->labels[i], S), th = GLYPH_H * S;
            const int g = R_MARK + 4;
            int cand[8][2] = {{x + g, y - g - th}, {x + g, y + g},   {x - g - tw, y - g - th},
                              {x - g - tw, y + g}, {x + g, y - th / 2}, {x - g - tw, y - th / 2},
                              {x - tw / 2, y - g - th}, {x - tw / 2, y + g}};
            for (int k = 0; k < 8; k++) {
                box b = {cand[k][0] - 1, cand[k][1] - 1, cand[k][0] + tw + 1, cand[k][1] + th + 1};
                if (b.x0 < left + 2 || b.x1 > right - 2 || b.y0 < top + 2 || b.y1 > bottom - 2)
                    continue;
                int clash = 0;
                for (size_t o = 0; o < nbox && !clash; o++)
                    clash = boxes_overlap(&b, &taken[o]);
                if (clash)
                    continue;
                plot_text(px, W, H, cand[k][0], cand[k][1], se->labels[i], S, 0, grey);
                if (nbox < cap)
                    taken[nbox++] = b;
                break;
            }
        }
    }
}

int plot_render(const plot_spec *spec, unsigned char **rgb_out, unsigned *w_out,
                unsigned *h_out)
{
    unsigned W = spec->width ? spec->width : 960, H = spec->height ? spec->height : 680;
    if (W < 200 || H < 150 || W > 8192 || H > 8192) {
        errno = EINVAL;
        return -1;
    }
    double xmin = INFINITY, xmax = -INFINITY, ymin = INFINITY, ymax = -INFINITY;
    size_t points = data_range(spec, &xmin, &xmax, &ymin, &ymax);
    if (points == 0) {
        errno = EINVAL;
        return -1;
    }
    unsigned char *px = malloc((size_t)W * H * 3);
    if (!px) {
        errno = ENOMEM;
        return -1;
    }
    memset(px, 255, (size_t)W * H * 3);
    layout f = {.c = {px, (int)W, (int)H}, .W = W, .H = H,
                .left = 118, .right = (int)W - 28, .top = 62, .bottom = (int)H - 92};

    axis_range(&f.ax, xmin, xmax);
    axis_range(&f.ay, ymin, ymax);
    f.ax.p0 = f.left;
    f.ax.p1 = f.right;
    f.ay.p0 = f.bottom; /* y grows downwards on the canvas */
    f.ay.p1 = f.top;
    draw_grid(&f);
    draw_ticks(&f);
    draw_titles(&f, spec);
    draw_lines(&f, spec);

    size_t cap = points * 2 + 8;
    box *taken = calloc(cap, sizeof *taken);
    if (!taken) {
        free(px);
        errno = ENOMEM;
        return -1;
    }
    size_t nbox = draw_markers(&f, spec, taken);
    nbox = draw_legend(&f, spec, taken, nbox);
    draw_point_labels(&f, spec, taken, nbox, cap);
    free(taken);
    *rgb_out = px;
    *w_out = W;
    *h_out = H;
    return 0;
}

/* ------------------------------------------------------------------ PNG output */
/* stb_image_write's callback: into the atomic writer (its first error sticks) */
static void sink_write(void *ctx, void *data, int size)
{
    if (size > 0)
        lrr__atomic_write(ctx, data, (size_t)size);
}

int plot_write_png(const plot_spec *spec, const char *path)
{
    unsigned char *rgb = NULL;
    unsigned W = 0, H = 0;
    if (plot_render(spec, &rgb, &W, &H) != 0)
        return -1;
    int r = plot_write_rgb_png(rgb, W, H, path);
    int e = errno;
    free(rgb);
    errno = e;
    return r;
}

int plot_write_rgb_png(const unsigned char *rgb, unsigned W, unsigned H, const char *path)
{
    /* the library's atomic writer (lib/core/atomic_file.c), as for every other output */
    lrr__atomic_file w;
    int e = lrr__atomic_open(&w, path, NULL);
    if (!e) {
        if (!stbi_write_png_to_func(sink_write, &w, (int)W, (int)H, 3, rgb, (int)(3 * W))) {
            lrr__atomic_abort(&w);
            e = ENOMEM;
        } else {
            e = lrr__atomic_commit(&w);
        }
    }
    lrr__atomic_free(&w);
    if (e) {
        errno = e;
        return -1;
    }
    return 0;
}
