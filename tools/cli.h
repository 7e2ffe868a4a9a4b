/*
 * Helpers shared by the `lrr` command-line tool: strict number parsing, a progress bar,
 * an atomic CSV writer, timing and error reporting. Uses only the public API (lrr.h).
 */
#ifndef LRR_CLI_H
#define LRR_CLI_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "lrr.h"

/* Exit statuses: 1 for a failure while working, 2 for a malformed command line. */
enum { CLI_EXIT_OK = 0, CLI_EXIT_FAIL = 1, CLI_EXIT_USAGE = 2 };

/* ------------------------------------------------------------------ messages */
/* "PROG: message\n" on stderr (PROG is e.g. "lrr info"). */
void cli_usage_error(const char *prog, const char *fmt, ...)
    __attribute__((format(printf, 2, 3)));

/* Reports a library error as "lrr: <status text>: <context message>" on stderr and returns
 * CLI_EXIT_FAIL. ctx may be NULL (then only the status text is printed). */
int cli_lib_error(lrr_context *ctx, lrr_status status);

/* Reports an error the tool itself detected in the same shape as a library error. */
int cli_fail(lrr_status status, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* ------------------------------------------------------------------ numbers */
/* Each parser accepts the whole string or nothing (no leading spaces, no trailing junk, no
 * sign on unsigned values); on failure it prints "PROG: OPT: 'TEXT' is not ..." or an
 * out-of-range message and returns -1, else stores the value and returns 0. */
int cli_parse_u64(const char *prog, const char *opt, const char *text, uint64_t min,
                  uint64_t max, uint64_t *out);
int cli_parse_size(const char *prog, const char *opt, const char *text, size_t min,
                   size_t max, size_t *out);
int cli_parse_unsigned(const char *prog, const char *opt, const char *text, unsigned min,
                       unsigned max, unsigned *out);
/* Finite numbers in [min, max]; min_open != 0 excludes min itself (for "> 0"). */
int cli_parse_double(const char *prog, const char *opt, const char *text, double min,
                     int min_open, double max, double *out);

/* ------------------------------------------------------------------ time */
double cli_now(void); /* monotonic seconds */

/* ------------------------------------------------------------------ progress bar */
typedef struct cli_progress {
    const char *label;
    int enabled;
    int drawn;        /* something is on the line: finish must end it */
    double start;     /* cli_now() at init */
    double last_draw; /* cli_now() at the last redraw */
    size_t last_done; /* `done` at the last redraw: the same state is not drawn twice */
} cli_progress;

/* enabled: draw at all (the caller decides: isatty(stderr) or --progress). */
void cli_progress_init(cli_progress *p, const char *label, int enabled);
/* An lrr_progress_fn: user is a cli_progress*. Redraws with \r at most ~10 times a second
 * and always on the last step; never cancels. */
int cli_progress_cb(void *user, size_t done, size_t total);
/* Ends the bar's line (if one was drawn). */
void cli_progress_finish(cli_progress *p);

/* ------------------------------------------------------------------ atomic output files */
/* Writes go to a temporary file next to `path`; cli_outfile_commit flushes, syncs and
 * renames it into place, so readers never see a half-written file under the final name. */
typedef struct cli_outfile {
    FILE *f;
    char *path;
    char *tmp_path;
} cli_outfile;

/* Returns 0, or -1 with errno set (nothing is left behind). */
int cli_outfile_open(cli_outfile *out, const char *path);
/* Returns 0, or -1 with errno set; the temporary file is removed on failure. */
int cli_outfile_commit(cli_outfile *out);
/* Discards an open output without touching `path`. */
void cli_outfile_abort(cli_outfile *out);

/* Writes the per-subpatch CSV for a solved operator:
 *   subpatch,patch,area,cx,cy,cz,nx,ny,nz,b_r,b_g,b_b
 * numbers with %.9g, atomically. Returns CLI_EXIT_OK or CLI_EXIT_FAIL (message printed). */
int cli_write_radiosity_csv(const char *path, const lrr_operator *op, const float *radiosity);

/* ------------------------------------------------------------------ misc */
/* n×3 float array with an overflow-checked size; NULL on failure (message printed). */
float *cli_alloc_rgb(size_t n);
/* Sorts v (length n) and returns its median; n must be > 0. */
double cli_median(double *v, size_t n);

#endif /* LRR_CLI_H */
