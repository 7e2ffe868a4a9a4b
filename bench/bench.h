/*
 * Shared parts of lrr-bench, each name with the prefix bench_: messages, option helpers,
 * scenes, comparison of radiosities and number formatting (bench_util.c), the machine
 * description and cache size (bench_machine.c), timing and the lrr_solve and sgemv steps
 * (bench_timing.c), read bandwidth (bench_bandwidth.c), the pass and its floor in
 * interleaved pairs and the multiply-add peak (bench_interleave.c), OpenCL (bench_opencl.c)
 * and the paper's method (bench_paper.c). One file per command: table.c, stress.c,
 * hemicube.c, realtime.c, probes.c, adaptive.c, scenes.c, lights.c; four of them measure in
 * a second file (table_cell.c, realtime_cell.c, adaptive_scene.c, scenes_run.c; scenes
 * writes its output in scenes_out.c and judges accuracy in judge.c), and what the files of
 * a command share is declared at the end.
 */
#ifndef LRR_BENCH_H
#define LRR_BENCH_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include <cblas.h>

#include "cli.h"
#include "lrr.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define DEFAULT_HEMICUBE 128u
#define DEFAULT_SEED 1u
#define MB 1e6 /* memory columns are in MB = 10^6 bytes */
#define MIN_RUNS 20
#define MIN_SECONDS 0.5
#define MAX_RUNS 200000
#define BANDWIDTH_PASSES 5

enum {
    OPT_SCENE = 256,
    OPT_CELLS,
    OPT_HEMICUBE,
    OPT_CSV,
    OPT_PLOT,
    OPT_MEMORY_BUDGET,
    OPT_REPEAT,
    OPT_SEED,
    OPT_QUICK,
    OPT_SEEDS,
    OPT_N,
    OPT_K,
    OPT_BACKEND,
    OPT_SOURCES,
    OPT_NORMALS,
    OPT_MAX_ITERATIONS,
    OPT_SUBPATCHES,
    OPT_BUDGETS,
    OPT_SAMPLES,
    OPT_RATES,
    OPT_BUILDS,
    OPT_TOLERANCE
};

/* ------------------------------------------------------------------ commands */
int cmd_table(int argc, char *argv[]);
int cmd_stress(int argc, char *argv[]);
int cmd_hemicube(int argc, char *argv[]);
/* lrr-bench hemicube --rates (hemicube_rates.c): builds per row, R 16 and 32 when quick */
int hemicube_rates(const char *csv, unsigned builds, int quick);
int cmd_realtime(int argc, char *argv[]);
int cmd_probes(int argc, char *argv[]);
int cmd_adaptive(int argc, char *argv[]);
int cmd_scenes(int argc, char *argv[]);
int cmd_lights(int argc, char *argv[]);
int cmd_raycast(int argc, char *argv[]);
int cmd_fbar(int argc, char *argv[]);
int cmd_mpi(int argc, char *argv[]);
/* lrr-bench raycast --rays SCENE (raycast_rays.c) */
int bench_raycast_rays(const char *scene, unsigned R);

/* ------------------------------------------------------------------ messages */
/* "lrr-bench: <message>" on stderr; returns CLI_EXIT_FAIL. */
int bench_fail(const char *fmt, ...) __attribute__((format(printf, 1, 2)));
/* "lrr-bench: <what>: <status>: <library message>"; returns CLI_EXIT_FAIL. */
int bench_lib_fail(lrr_context *ctx, lrr_status s, const char *what);
/* Ends a CSV from cli_outfile_open: committed when rc is CLI_EXIT_OK ("csv: path" on stdout),
 * else discarded. Returns rc, or the failure to write it. */
int bench_csv_finish(cli_outfile *out, int rc, const char *path);
/* A progress line on stderr. */
void bench_note(const char *fmt, ...) __attribute__((format(printf, 1, 2)));

/* ------------------------------------------------------------------ options */
/* Reports getopt_long's ':' or '?' and returns CLI_EXIT_USAGE. */
int bench_bad_option(const char *prog, int c, char *const argv[]);
/* Resets getopt for a subcommand (opterr off, glibc re-initialised). */
void bench_start_getopt(void);
/* Non-zero (after a usage message) when positional arguments are left. */
int bench_no_positional(const char *prog, int argc, char *const argv[]);
/* What a command's option parser returns when the command is to run; any other value is the
 * exit status (CLI_EXIT_OK after --help, CLI_EXIT_USAGE, ...). */
#define BENCH_RUN (-1)

/* ------------------------------------------------------------------ machine, scenes */
/* cpu, cores, threads, OpenBLAS, lrr version, date and load as 'key: value' lines. */
void bench_print_machine(void);
/* A scene file, or a built-in name; CLI_EXIT_OK or a reported failure. */
int bench_open_scene(lrr_context *ctx, const char *name, lrr_scene **scene);
/* levels with 4^levels = d, or -1 */
int bench_levels_of(size_t d);
/* Progress on stderr: a bar on a terminal, nothing otherwise (phase lines say enough). */
void bench_progress_begin(cli_progress *bar, const char *label, lrr_build_options *bo);

/* ------------------------------------------------------------------ timing */
typedef struct timing {
    double median, min, max; /* milliseconds */
    size_t runs;
} timing;

typedef int (*frame_fn)(void *user);

/* Two warm-up runs, then `repeat` timed runs (0: adaptive, at least MIN_RUNS and at least
 * MIN_SECONDS in all). Returns 0 or the frame's non-zero status. */
int bench_time_frames(frame_fn fn, void *user, unsigned repeat, timing *t);
/* min, max and median of runs ≥ 1 samples (ms); v is reordered. */
void bench_timing_from_samples(double *v, size_t runs, timing *t);

/* Size of the last-level cache in bytes (the largest cache sysfs lists; not cpuid), 0 if
 * unknown. */
size_t bench_llc_bytes(void);
/* Bytes of the bandwidth buffer: 4 × the last-level cache, at least 512 MiB, at most 4 GiB. */
size_t bench_bandwidth_buffer_bytes(void);
/* Read bandwidth in bytes per second (0 on failure): an OpenMP sum, the best of
 * BANDWIDTH_PASSES passes of each read loop the CPU runs (portable, AVX2, AVX-512). */
double bench_measure_bandwidth(size_t bytes);
/* the read loops bench_measure_bandwidth runs: portable, AVX2, AVX-512, both with prefetch */
#define BENCH_READ_LOOPS 5
/* count floats (a multiple of 128), 64-byte aligned, first touched by the OpenMP threads that
 * read them; NULL when out of memory (lrr_aligned_free it). */
float *bench_read_buffer(size_t count);
/* Read bandwidth over buf (count floats, a multiple of 128, from bench_read_buffer) in bytes
 * per second: each read loop the CPU runs `reps` times in a row, the fastest pass of any; the
 * sums are added to *check (use it, so no pass is optimised away). */
double bench_read_bandwidth(const float *buf, size_t count, unsigned reps, double *check);

/* The pass and its floor in alternation (bench_interleave.c): `pairs` pairs (at most
 * BENCH_MAX_PAIRS) of the read loops over a buffer of `bytes` (what one frame must read)
 * then fn, each half at least 3 runs and about 20 ms (frame_ms: a frame's earlier median),
 * the fastest run of each half. */
#define BENCH_MAX_PAIRS 31
typedef struct bench_pairs {
    double median, min, max; /* the pairs' ratios pass ms / floor ms */
    double floor_ms;         /* the median floor: bytes / the pair's read bandwidth */
    unsigned pairs;
} bench_pairs;
int bench_interleave(frame_fn fn, void *user, double bytes, double frame_ms, unsigned pairs,
                     bench_pairs *out);
/* Two ways A and B in alternation, as bench_interleave: `pairs` pairs of the fastest of a
 * few runs each; out's ratios are A ms / B ms and its floor_ms is B's median ms. */
int bench_ab(frame_fn a, void *ua, frame_fn b, void *ub, double frame_ms, unsigned pairs,
             bench_pairs *out);
/* Multiply-add peak in flop/s: an OpenMP loop of independent FMA chains, the best of each
 * vector width the CPU has (0 on failure). */
double bench_fma_peak(void);

/* ------------------------------------------------------------------ real-time steps */
typedef struct ours_frame {
    lrr_solver *solver;
    const float *e, *e_alt; /* e_alt: used on every other frame when not NULL */
    float *b;
    lrr_status status;
    unsigned long frame;
} ours_frame;

/* One lrr_solve (a frame_fn on an ours_frame). */
int bench_ours_step(void *user);
/* "full", "sparse", "incremental", "auto" */
const char *bench_path_name(lrr_path p);

/* The paper's real-time step: B_c = E_c - Y_c (Vᵀ E_c), channels stored planar. */
typedef struct paper_frame {
    blasint n, k;
    float *v;        /* n×k indicator, dense */
    float *y[3];     /* n×k, Y_c = -diag(rho_c) F̄ M_c */
    float *e[3], *b[3];
    float *w;        /* k */
} paper_frame;

int bench_paper_step(void *user);
void bench_paper_free(paper_frame *f);
/* a×b zeroed floats, 64-byte aligned (lrr_aligned_free); NULL on overflow or failure */
float *bench_alloc_floats(size_t a, size_t b);
float *bench_fbar_rows(const lrr_operator *op);
/* Builds the paper's Y_c and V from the operator (sgemm, outside any timing). */
int bench_paper_setup(const lrr_operator *op, const float *e, paper_frame *f);

/* Three sgemv over F̄, one per channel, nothing else. */
typedef struct sgemv_frame {
    blasint n, k;
    const float *fbar;
    float *z[3], *out[3];
    float *rows; /* the row-major copy fbar points to, when owned (bench_fbar_rows) */
} sgemv_frame;

int bench_sgemv_step(void *user);

/* ------------------------------------------------------------------ OpenCL */
/* --backend cpu|opencl: *opencl = 0 or 1; -1 after a usage message. */
int bench_parse_backend(const char *prog, const char *text, int *opencl);
/* The context of a table or realtime run, after checking that the scene can be read and,
 * with opencl, that an OpenCL solver can be created (so a bad setup fails before the long
 * measurements). Returns CLI_EXIT_OK or the exit status, having printed why. */
int bench_start(const char *scene, int opencl, lrr_context **out);
/* Whether an OpenCL solver can be created (on a one-triangle operator): CLI_EXIT_OK, or
 * "lrr-bench: --backend opencl: <library message>" (e.g. no OpenCL platform) and
 * CLI_EXIT_FAIL. */
int bench_opencl_probe(lrr_context *ctx);
/* A frame_fn: lrr_solve on an OpenCL solver, then its lrr_solver_timings, appended to
 * kernel_ms/transfer_ms (at most cap frames). */
typedef struct cl_frame {
    ours_frame of;
    double *kernel_ms, *transfer_ms;
    size_t cap, count;
} cl_frame;
int bench_cl_step(void *user);
/* Median of the last `runs` recorded timings of a cl_frame (reorders them). */
void bench_cl_medians(cl_frame *f, size_t runs, double *kernel_ms, double *transfer_ms);
/* lrr-bench fbar --backend opencl (fbar_opencl.c): dense and sparse F̄ on the device for
 * one operator and storage, strip groups groups[0..n_groups), printed and in csv. */
int bench_fbar_opencl(lrr_context *ctx, const lrr_operator *op, const float *e, const char *file,
                      lrr_storage st, const unsigned *groups, int n_groups, unsigned frames,
                      FILE *csv);
/* The solver's lrr_solver_kernel, commas replaced, into buf. */
const char *bench_cl_device_name(const lrr_solver *s, char *buf, size_t len);

/* ------------------------------------------------------------------ comparison, formatting */
/* Area-weighted relative L2 over all channels (area NULL: unweighted) and the largest
 * relative error over entries above 1e-3 of the largest reference value (max_rel may be
 * NULL). With e the emission is subtracted from both (the reflected part only). */
/* max |a − b| / max |b| over m entries (|a − b| alone when b is 0): a whole-array error. */
double bench_max_rel(size_t m, const float *a, const float *b);
void bench_compare_b(size_t n, const float *area, const float *b, const float *ref, const float *e,
                     double *rel_l2, double *max_rel);
/* 12.2 GB, 4.3 GB, 35.4 MB: decimal units */
const char *bench_fmt_bytes(char *buf, size_t len, size_t bytes);
/* milliseconds with 3 significant-ish digits; "-" for NaN */
const char *bench_fmt_ms(char *buf, size_t len, double v);
/* a CSV number (%.6g, nan, inf) followed by ',' or, when last, '\n' */
void bench_csv_num(FILE *f, double v, int last);

/* ------------------------------------------------------------------ table.c, table_cell.c */
/* Gauss-Seidel tolerance of the n×n references (table and adaptive) */
#define REFERENCE_TOL 1e-7

typedef struct cell {
    size_t n, k, d;
} cell;

/* --cells: paper, small, all, tiny or a list "N/K/D,N/K/D,...". Replaces *cells (freed
 * first; the caller frees it after use, also after a failure) and sets *n_cells and *name
 * (= text); -1 after a usage message, or when out of memory. */
int parse_cells(const char *prog, const char *text, cell **cells, size_t *n_cells,
                const char **name);

typedef struct cell_result {
    cell target;
    size_t n, k, d;
    double mem_mb, mem_mb_paper, mem_mib_paper, preprocess_s;
    timing ours, paper, sgemv3, ours_auto;
    char auto_path[16], kernel[32];
    double floor_ms, floor_ms_full, bandwidth_gbs;
    double rel_l2, max_rel, rel_l2_reflected, reference_s, reference_residual;
    double paper_vs_ours;
    double cond[3];
    int threads;
    char label[64];
    char note[256];
    int have_cl;                          /* --backend opencl */
    timing ocl;                           /* ours on the OpenCL solver */
    double ocl_kernel_ms, ocl_transfer_ms, ocl_ratio; /* medians; ours / OpenCL */
    char ocl_device[160];
} cell_result;

typedef struct table_args {
    const char *scene, *csv, *plot;
    unsigned hemicube, repeat;
    uint64_t seed;
    size_t budget;
    cell *cells;
    size_t n_cells;
    const char *cells_name;
    int opencl; /* --backend opencl */
} table_args;

/* One cell of lrr-bench table: builds its operator, times the real-time step and measures
 * the error (table_cell.c). Returns 0, or the exit status having printed why: with r->n still
 * 0 when nothing was measured, else after a failed check (the row is kept). */
int run_cell(lrr_context *ctx, const table_args *a, const cell *c, size_t index,
             double bandwidth, cell_result *r);

/* ------------------------------------------------------------------ realtime.c, realtime_cell.c */
/* each implementation's block: warm-up runs, idle time, then (--repeat not given) timed runs
 * for at least this long; lrr_solve_batch's frames */
#define RT_WARMUPS 3u
#define RT_IDLE_MS 200u
#define RT_MIN_SECONDS 0.3
#define RT_BATCH 16
#define RT_PAIRS 11 /* interleaved pairs of the fused rows (bench_interleave) */

/* the rows of a cell: lrr-bench realtime --help says what each measures */
enum {
    RT_FUSED_F32,
    RT_FUSED_F16,
    RT_FUSED_BF16,
    RT_SGEMV3,
    RT_SGEMM3,
    RT_PAPER,
    RT_SPARSE,
    RT_INCREMENTAL,
    RT_COUNT
};

typedef struct rt_row {
    const char *impl, *storage;
    char kernel[32];
    char path[16];      /* the path most timed frames took ("-" for the baselines) */
    size_t other_path;  /* timed frames that took another path */
    char other_name[16];
    timing t;
    double floor_ms, floor_ms_full, ratio_to_floor, ratio_to_paper, rel_l2;
    double bytes;       /* what one frame must read, for the cache warning */
    int reads_fbar;     /* ratio_to_floor < 1 means something */
    const char *backend;  /* "cpu" or "opencl" */
    double kernel_ms, transfer_ms, ratio_to_cpu; /* OpenCL rows; nan otherwise */
    char device[160];   /* OpenCL rows: lrr_solver_kernel; "cpu" otherwise */
    /* CPU fused rows: the interleaved pairs (pairs 0 and nan elsewhere), and the
     * multiply-add roofline's time, flops / the measured FMA peak */
    bench_pairs pairs;
    double roofline_ms;
    double m_bytes;     /* fused rows: what a frame reads of M (lrr_solver_info.m_bytes) */
    bench_pairs m_ab;   /* 16-bit fused rows: M − I in binary16 over M in f32, A/B pairs */
} rt_row;

typedef struct rt_cell {
    cell target;
    size_t n, k, d;
    double preprocess_s;
    double bw_kernel, bw_sgemv3, bw; /* bytes per second; bw_sgemv3 NAN when not used */
    /* the read loops over a buffer of F̄'s own size (f32, 16-bit), when it fits the
     * last-level cache (NAN otherwise), and the 16-bit rows' floor bandwidth */
    double bw_resident, bw_resident16, bw16;
    const char *bw_source, *bw16_source;
    int fits_llc;
    timing batch;
    double batch_ms_per_frame, batch_rel_l2;
    rt_row rows[RT_COUNT];
    rt_row cl_rows[3];  /* --backend opencl: fused f32, f16, bf16 on the OpenCL solver */
    int have_cl;
} rt_cell;

typedef struct rt_args {
    const char *scene, *csv;
    unsigned hemicube, repeat;
    cell *cells;
    size_t n_cells;
    const char *cells_name;
    size_t llc;
    double bandwidth;
    double fma_peak; /* flop/s, 0 when not measured */
    int opencl; /* --backend opencl */
} rt_args;

/* One cell of lrr-bench realtime: builds its operator and times every implementation on it
 * (realtime_cell.c). Returns 0, or the exit status having printed why. */
int rt_cell_run(lrr_context *ctx, const rt_args *a, const cell *c, size_t index, rt_cell *r);
/* Bytes of an n×k F̄ in storage st. */
double storage_bytes(size_t n, size_t k, lrr_storage st);

/* ----------------------------------------------------------------- adaptive.c, adaptive_scene.c */
#define MAX_SCENES 16
#define MAX_BUDGETS 32
#define MAX_LEVELS 3         /* the standard uniform operator: levels 1..3 are tried */

typedef struct adaptive_row {
    char scene[64];
    size_t triangles, n, budget; /* budget 0: a levels-L row */
    char split[16];
    size_t k, d_min, d_max;
    double rel_l2, max_rel, rel_l2_reflected, rel_l2_plain, ratio;
    double preprocess_s, build_s, selection_s, selection_share;
    timing rt;
    double cond_max, mem_mb;
    double reference_s, reference_residual;
} adaptive_row;

typedef struct adaptive_args {
    const char *scenes[MAX_SCENES];
    size_t n_scenes;
    size_t subpatches;
    size_t budgets[MAX_BUDGETS];
    size_t n_budgets;
    size_t samples;
    unsigned hemicube, repeat;
    uint64_t seed;
    size_t memory_budget;
    const char *csv, *plot;
} adaptive_args;

typedef struct scene_ref {
    lrr_scene *scene;
    size_t n, triangles;
    double max_patch_area, diag;
    float *centre, *normal, *area; /* the scene's (reference) subpatch order */
    float *bref, *eref;            /* reference B and E (nan-filled when no reference) */
    int have_ref;
    double reference_s, reference_residual;
    char note[256];
} scene_ref;

/* One scene of lrr-bench adaptive (adaptive_scene.c). */
typedef struct adaptive_scene {
    const char *name;   /* as given (--scene) */
    char label[64];     /* scene_label */
    scene_ref ref;      /* subdivided at levels 0, with the n×n reference when it fits */
    size_t budgets[MAX_BUDGETS], n_budgets;
    size_t levels[MAX_LEVELS], n_levels; /* the levels-L operators with the same subpatches */
} adaptive_scene;

/* A short name for a scene argument: the file name without directory and extension
 * (adaptive.c). */
void scene_label(const char *scene, char *buf, size_t len);
/* Subdivides the scene, builds and solves its reference and prints them, then its budgets
 * and which levels-L operators it has. Returns 0 or the exit status, having printed why;
 * adaptive_scene_free in either case. */
int adaptive_scene_open(lrr_context *ctx, const adaptive_args *a, const char *name,
                        adaptive_scene *sc);
/* Measures and prints the scene's rows (uniform and adaptive per budget, then levels-L),
 * appended to rows[0..*count). Returns 0 or the exit status (the rows measured are kept). */
int adaptive_scene_rows(lrr_context *ctx, const adaptive_args *a, const adaptive_scene *sc,
                        adaptive_row *rows, size_t *count);
void adaptive_scene_free(adaptive_scene *sc);

/* ------------------------------------------ scenes.c, scenes_run.c, scenes_out.c, judge.c */
#define SC_MAX_SCENES 16

typedef struct sc_args {
    char scenes[SC_MAX_SCENES][1024]; /* resolved paths or built-in names */
    size_t n_scenes;
    size_t patches, samples;          /* K (adaptive_patches), path-traced samples */
    size_t verify_samples;            /* lrr_verify_options.samples (0: automatic) */
    unsigned hemicube, repeat;
    int split, threads, quick;
    uint64_t seed;
    const char *csv, *md, *plot;
    const char *operator_file;        /* --operator: judge this file instead of a build */
} sc_args;

/* median and quartiles of the timed frames, ms */
typedef struct sc_quart {
    double median, q1, q3;
    size_t runs;
} sc_quart;

/* The judgement of judge.c (its top comment defines each figure; nan when undefined). */
#define SC_GRID 8 /* cells per axis of the regions' grid */
enum { SC_UP, SC_SIDE, SC_DOWN, SC_FACINGS };
typedef struct sc_judgement {
    double rel_l2, noise, rel_l2_debiased, rel_l2_f16; /* over regions */
    size_t regions, subpatches;                         /* non-empty regions; subpatches judged */
    double ratio[SC_FACINGS], ratio_noise[SC_FACINGS];  /* operator / reference per facing */
    double rel_l2_subpatch, noise_subpatch;             /* every subpatch its own region */
    double rel_l2_verify_grid; /* debiased, over lrr_operator_verify's regions (judge.c) */
} sc_judgement;

/* Per-subpatch geometry in the scene's order (lrr_scene_subpatches), SC_GEO floats each. */
enum { SC_GEO_CENTRE = 0, SC_GEO_NORMAL = 3, SC_GEO_AREA = 6, SC_GEO_RHO = 7,
       SC_GEO_EMISSION = 10, SC_GEO = 13 };

typedef struct sc_judge_input {
    size_t n;
    const float *geo;     /* n×SC_GEO */
    const float *b, *b16; /* the operator's B with F̄ in f32 and in f16 (n×3, scene order) */
    const float *p, *se;  /* the path-traced B and its standard errors (n×3) */
    size_t verify_grid;   /* cells per axis of lrr_operator_verify's grid; 0: not judged */
} sc_judge_input;

/* Fills *j (judge.c). Returns 0, or -1 when out of memory or n >= 2^32. */
int sc_judge(const sc_judge_input *in, sc_judgement *j);
/* Every figure nan, the counts 0. */
void sc_judgement_init(sc_judgement *j);

/* One scene's row: every number nan until measured. */
typedef struct sc_result {
    char label[64];
    char failed[96];  /* the step that failed, "" when all went through */
    size_t triangles, emitters, n, k, d_min, d_max;
    int threads, hierarchy, receiver_sampling;
    double subdivide_s, build_s, clustering_s, formfactor_s, smw_s, preprocess_s;
    double op_mib, peak_mib, peak_mib_build, back_face_share;
    sc_quart f32, f16;
    char kernel[32];
    double bandwidth, floor_f32, floor_f16, ratio_f32, ratio_f16;
    double reference_s, reference_peak_mib;
    sc_judgement judge;
    /* lrr_operator_verify's own error bar, from lrr_operator_info */
    double verify_rel_l2, verify_noise, verify_seconds;
    size_t verify_subpatches, verify_samples;
} sc_result;

/* The read bandwidth (bytes/s, 0 on failure) measured in a child process, so that its
 * buffer counts in no scene's peak memory. Returns 0 or the exit status, having said why. */
int sc_measure_bandwidth(const sc_args *a, double *bandwidth);
/* One scene: the operator pipeline (build, lrr_operator_verify, frames) in one child
 * process (its peak memory is the scene's), the path-traced reference in another, then the
 * judgement (judge.c). r->failed names the step that failed (the message is printed);
 * returns 0 or the exit status. */
int sc_run_scene(const sc_args *a, const char *scene, sc_result *r);
/* scenes_out.c: the CSV of rows[0..count) (rewritten whole); 0 or the exit status. */
int sc_write_csv(const sc_args *a, const char *cpu, const sc_result *rows, size_t count);
/* scenes_out.c: the table and targets on stdout, then --md and --plot; 0 or the exit status. */
int sc_outputs(const sc_args *a, const char *cmdline, const char *cpu, double bw,
               const sc_result *rows, size_t count);

#endif /* LRR_BENCH_H */
