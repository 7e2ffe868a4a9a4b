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
#include "core/atomic_file.h"
#include "core/path.h"

/* Exit statuses: 1 for a failure while working, 2 for a malformed command line, 3 when an
 * iterative reference solve stopped before its tolerance (its result is still written). */
enum { CLI_EXIT_OK = 0, CLI_EXIT_FAIL = 1, CLI_EXIT_USAGE = 2, CLI_EXIT_NOT_CONVERGED = 3 };

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
/* "X,Y,Z": three finite numbers within float range (|v| <= FLT_MAX: the geometry is
 * float), separated by single commas, with no spaces and nothing trailing; an overflow or
 * underflow strtod reports (ERANGE) is refused. Prints nothing: 0, or -1 and the caller's
 * message names the option, the script line or the light field. */
int cli_parse_vec3(const char *text, double v[3]);
/* "cpu" or "opencl" (the --backend option of lrr and lrr-bench). */
int cli_parse_backend(const char *prog, const char *text, lrr_backend *out);
/* Finite numbers in [min, max]; min_open != 0 excludes min itself (for "> 0"). */
int cli_parse_double(const char *prog, const char *opt, const char *text, double min,
                     int min_open, double max, double *out);

/* ------------------------------------------------------------------ probes */
/* The error of an irradiance approximation against the truth (m normals × RGB), as lrr probe
 * and lrr-bench probes report it: mean and max of |approx − truth| / truth in percent over
 * the entries whose truth exceeds 1e-6 of the largest (NaN when none does). */
void cli_irradiance_error_pct(size_t m, const float *truth, const float *approx,
                              double *mean_pct, double *max_pct);

/* ------------------------------------------------------------------ time */
double cli_now(void); /* monotonic seconds */
/* OpenBLAS 0.3.21 falls back to its SSE3 "Prescott" kernels on a CPU model it does not know
 * (an Emerald Rapids Xeon: the SMW factorisation at k = 3456 took 19-29 s instead of
 * 6.2-8.0 s, sgemv 3× the read floor). It reads OPENBLAS_CORETYPE only when it loads, so
 * this runs the program again (execv of the binary /proc/self/exe names, same argv) with
 * the family the CPU's instructions support, SkylakeX or Haswell; a no-op when
 * OPENBLAS_CORETYPE is set, OpenBLAS chose anything else, or it is not the BLAS loaded.
 * say: a line on stderr. */
void cli_fair_openblas(char *argv[], int say);
/* Ends OpenBLAS's thread pool (it starts again with the next BLAS call) so that its workers'
 * spin-wait does not take a core from the hemicubes' OpenMP threads; the tools' mains call
 * it after cli_fair_openblas. A no-op without that OpenBLAS symbol. */
void cli_idle_openblas(void);

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
 * renames it into place, so readers never see a half-written file under the final name.
 * The library's own writer (lib/core/atomic_file.c, compiled into lrr and lrr-bench). */
typedef struct cli_outfile {
    FILE *f;          /* write here */
    char *path;
    lrr__atomic_file w;
} cli_outfile;

/* Returns 0, or -1 with errno set (nothing is left behind). */
int cli_outfile_open(cli_outfile *out, const char *path);
/* Returns 0, or -1 with errno set; the temporary file is removed on failure. */
int cli_outfile_commit(cli_outfile *out);
/* Discards an open output without touching `path`. */
void cli_outfile_abort(cli_outfile *out);

/* The per-subpatch CSV written by `lrr solve --csv` and `lrr reference --csv` and read by
 * `lrr compare`: this header line, then one row per subpatch, numbers with %.9g. */
#define CLI_CSV_HEADER "subpatch,patch,area,cx,cy,cz,nx,ny,nz,b_r,b_g,b_b"

/* Writes the CSV atomically for n subpatches, d per patch (patch = subpatch / d), or patches
 * given by the k+1 offsets `first` when not NULL (adaptive hierarchy): area n,
 * centre, normal and radiosity n×3. Returns CLI_EXIT_OK or CLI_EXIT_FAIL (message printed). */
int cli_write_subpatch_csv(const char *path, size_t n, size_t d, const size_t *first,
                           const float *area, const float *centre, const float *normal,
                           const float *radiosity);
/* The same for an operator's data in its order: origin (n, NULL = the scene's order) maps
 * operator subpatch i to the scene's row origin[i]; rows come out in the scene's order. */
int cli_write_subpatch_csv_order(const char *path, size_t n, size_t d, const size_t *first,
                                 const size_t *origin, const float *area, const float *centre,
                                 const float *normal, const float *radiosity);
/* The same for a solved operator, with its stored geometry. */
int cli_write_radiosity_csv(const char *path, const lrr_operator *op, const float *radiosity);

/* ------------------------------------------------------------------ CSV comparison (cmd_compare.c) */
typedef struct cli_csv_row {
    size_t subpatch, patch;
    double area, centre[3], normal[3], b[3];
} cli_csv_row;

typedef struct cli_csv_table {
    size_t n;          /* data rows (the header is line 1, row i is line i + 2) */
    cli_csv_row *rows;
} cli_csv_table;

/* Reads a CSV in the format above. The header must match exactly; every row must have 12
 * fields, non-negative integers for subpatch and patch, finite numbers elsewhere and an area
 * > 0; the last line must end with a newline (else the file is truncated). On failure prints
 * "lrr: ...: 'PATH' line L: what" and returns CLI_EXIT_FAIL with *out empty. */
int cli_read_radiosity_csv(const char *path, cli_csv_table *out);
void cli_csv_table_free(cli_csv_table *t);

/* Differences of A against the reference B, area-weighted with B's areas, over the three
 * channels together and per channel (index 0..2 = r, g, b):
 *   rel_l2   = sqrt(Σ a_i Σ_c ΔB_ic²) / sqrt(Σ a_i Σ_c B_ic²)
 *   max_rel  = max |ΔB_ic| / |B_ic| over the entries with |B_ic| > 1e-3 · max |B| (one
 *              threshold for all channels, so max_rel is the largest max_rel_c)
 *   mean_abs = Σ a_i Σ_c |ΔB_ic| / (3 Σ a_i) */
typedef struct cli_comparison {
    size_t n;
    double rel_l2, max_rel, mean_abs;
    int have_max_rel;        /* 0 when B has no non-negligible entry (B = 0 everywhere) */
    size_t max_rel_subpatch; /* the subpatch column of the row with max_rel */
    double rel_l2_c[3], max_rel_c[3], mean_abs_c[3];
} cli_comparison;

/* The rows must agree one by one: same count, same subpatch index, areas within 1e-6
 * relative and centres within 1e-5 of the scene's size, else a message naming both files and
 * the line ("different subdivisions") and CLI_EXIT_FAIL. a_path/b_path name them. */
int cli_compare_radiosity(const cli_csv_table *a, const char *a_path, const cli_csv_table *b,
                          const char *b_path, cli_comparison *out);

/* ------------------------------------------------------------------ the lrr tool */
/* The whole `lrr` command line (tools/lrr.c; its main is this with parse_only = 0). With
 * parse_only != 0 every command stops right after parsing and checking its options and
 * returns CLI_EXIT_OK (or the usual CLI_EXIT_USAGE), before it opens a file, creates a
 * directory or does any work: the fuzz target of the option parsers (tests/fuzz/fuzz_cli.c)
 * builds the tool's sources (tools/lrr.c, tools/cmd_*.c, ...) with -DLRR_CLI_NO_MAIN and
 * calls this. Not reentrant (getopt). */
int lrr_cli_main(int argc, char *argv[], int parse_only);

/* ------------------------------------------------------------------ misc */
/* n×3 float array with an overflow-checked size; NULL on failure (message printed). */
float *cli_alloc_rgb(size_t n);
/* Sorts v (length n) and returns its median; n must be > 0. */
double cli_median(double *v, size_t n);

/* A path the tool reads itself (a script, a CSV): lrr__open_regular (core/path.h), so a
 * FIFO, socket or device is refused before it can block. The stream, or NULL with *why
 * LRR__NOT_REGULAR_TEXT or strerror's text. */
FILE *cli_open_regular(const char *path, const char **why);

/* mkdir -p: creates each missing component of dir; CLI_EXIT_OK or CLI_EXIT_FAIL (reported:
 * what cannot be created, or a component that is not a directory). */
int cli_make_dir(const char *dir);

#endif /* LRR_CLI_H */
