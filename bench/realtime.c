/*
 * lrr-bench realtime: the real-time step alone, every implementation measured in one run on
 * the same matrix: our fused kernel with F̄ in f32, f16 and bf16, three sgemv, one sgemm with
 * three right-hand sides, the paper's method, the sparse and incremental paths; a bandwidth
 * floor per storage, ratios to it and to the paper's method, and the error of 16-bit storage.
 * The command, its options and output are here; the measurements of one cell are in
 * realtime_cell.c.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

#define RT_DEFAULT_HEMICUBE 64u
/* the real-time pass's goals (issue 16): f32 within 1.25× its floor, 16-bit within 1.3×
 * theirs; 5× (f32) and 8× (f16) the paper's method on the 191 MB cells */
#define RT_TARGET_FLOOR 1.25
#define RT_TARGET_FLOOR16 1.3
#define RT_TARGET_PAPER_F32 5.0
#define RT_TARGET_PAPER_F16 8.0

static const char realtime_help[] =
    "Usage: lrr-bench realtime [--n N --k K | --cells paper|small|LIST] [--scene SCENE]\n"
    "                          [--hemicube R] [--repeat N] [--backend cpu|opencl]\n"
    "                          [--csv OUT.csv]\n"
    "The real-time step alone: every implementation measured in one run on the same matrix.\n"
    "For each cell the scene is subdivided into about k patches of d = 4^levels subpatches\n"
    "and the operator built once; it is saved to a temporary .lrr file in $TMPDIR (deleted\n"
    "afterwards) and a fresh copy is loaded for each 16-bit storage, so that f16 and bf16\n"
    "are both rounded from the float values. The emission is the scene's own.\n"
    "  fused        lrr_solve forced to its full path (LRR_PATH_FULL) over dense F̄\n"
    "               (lrr_solver_set_fbar; lrr-bench fbar measures sparse), one solver per\n"
    "               storage (f32, f16, bf16): one pass over F̄ for all three channels,\n"
    "               B_c = E_c + rho_c ∘ (F̄ (M_c (Vᵀ E_c))) with the epilogue fused\n"
    "  sgemv3       three cblas_sgemv over F̄ (f32), no epilogue\n"
    "  sgemm3       one cblas_sgemm F̄ (n×k) × Z (k×3), no epilogue\n"
    "  paper        the paper's method, as in 'table': dense Y_c = -diag(rho_c) F̄ M_c and\n"
    "               a dense V (built once, not timed), two cblas_sgemv per channel\n"
    "  sparse       LRR_PATH_SPARSE (f32): a sum of cached columns of F̄ M_c for the\n"
    "               emitting patches\n"
    "  incremental  LRR_PATH_INCREMENTAL (f32), the emission scaled by 1 and 0.5 on\n"
    "               alternate frames: the previous B plus the columns of the changed\n"
    "               patches (a frame that took another path is reported)\n"
    "and, in the text only, lrr_solve_batch with 16 frames (ms per frame).\n"
    "With --backend opencl, also fused on an OpenCL solver (LRR_BACKEND_OPENCL; device from\n"
    "LRR_OPENCL_DEVICE) for f32, f16 and bf16: rows with backend=opencl, timed the same way,\n"
    "with the median kernel_ms (the kernels' END - START) and transfer_ms (E up, B down)\n"
    "from OpenCL profiling events (lrr_solver_timings), their sum, and ratio_to_cpu = CPU\n"
    "fused (same storage) median / OpenCL median, measured in the same run.\n"
    "Timing: each implementation in its own block: 3 warm-up runs, then 200 ms idle (the\n"
    "spinning OpenMP or OpenBLAS workers of the previous block go to sleep, so the two\n"
    "thread pools never compete), then the timed runs: median, min and max, ms per frame.\n"
    "Our kernels use OpenMP (OMP_NUM_THREADS), the baselines OpenBLAS\n"
    "(OPENBLAS_NUM_THREADS); the configuration is printed.\n"
    "Floor: bandwidth = the larger of the tuned read kernels (OpenMP sums with eight\n"
    "accumulators of each vector width the CPU has, over max(512 MiB, 4 × the last-level\n"
    "cache), the best pass of 5 each) and the effective bandwidth of sgemv3 on the same matrix\n"
    "(3·n·k·4 bytes / its median), so no baseline runs below its own floor; where F̄ fits\n"
    "the last-level cache, also the same read kernels over a buffer of F̄'s bytes (f32, and\n"
    "half that for the 16-bit rows), warm from the cache as the kernels are.\n"
    "floor_ms = F̄'s bytes in the row's storage (n·k·4 or n·k·2) / bandwidth; sgemv3,\n"
    "sgemm3, paper, sparse and incremental get the f32 floor; floor_ms_full (CSV) adds M\n"
    "as the row reads it (12·k² bytes; the 16-bit rows read M − I in binary16, 6·k² + 12·k:\n"
    "lrr_solver_set_m). ratio_to_floor = ms_median / floor_ms (below 1 a warning says whether\n"
    "the matrix was cache-resident or the floor too low; sparse and incremental do not read\n"
    "F̄ and may go below it); ratio_to_paper = the paper's ms_median / ms_median (a\n"
    "speed-up). rel_l2_vs_f32 = the area-weighted relative L2 of B against fused f32's B\n"
    "(incremental: a frame with the x1 emission); nan for fused f32 itself and for sgemv3\n"
    "and sgemm3, which compute no B.\n"
    "Interleaved floor (fused f32, f16, bf16 on the CPU): the bandwidth drifts on a shared\n"
    "machine, so the floor and the pass are also measured in 11 pairs A B A B ...: A = the\n"
    "read kernels over a buffer of exactly the bytes a frame must read (F̄ as stored + M\n"
    "as read + E and B (n·3 floats each)); B = the fused pass; each half one untimed\n"
    "run, then at least 3 runs and about 20 ms, the fastest run kept (a preempted run would\n"
    "dominate a mean). Per pair ratio = pass ms / (those bytes / A's bandwidth);\n"
    "ratio_pairs_median, _min and _max over the pairs, and floor_pairs_ms = the median of\n"
    "the pairs' floors. Roofline: 2·n·k·3 + 2·3·k² flops per frame; roofline_ms = flops /\n"
    "the multiply-add peak of an FMA loop measured at the start\n"
    "(fma_peak_gflops; \"not measured\" when it failed). The target line (fused f32 <= 1.25\n"
    "× floor and >= 5× paper; f16 and bf16 <= 1.3 × their floor; f16 >= 8× paper; floors\n"
    "judged on ratio_pairs_median, the paper ratios the goal on the 191 MB cells) is\n"
    "reported, never enforced. The line m_f16 times each 16-bit fused pass against the\n"
    "same pass with M in f32, in 11 alternating pairs (the median ratio and its range).\n"
    "\n"
    "Options:\n"
    "  --n N, --k K         one matrix of about N subpatches and K patches: target_patches K,\n"
    "                       levels = round(log4(N/K)); the actual n and k are reported\n"
    "  --cells SET          the cells of 'table': paper (its 9 cells), small (its 4\n"
    "                       cheapest), all, or a list N/K/D,... with D a power of 4\n"
    "                       (default paper)\n"
    "  --scene SCENE        a scene file (OBJ/PLY/glTF) or built-in name 'cornell',\n"
    "                       'cornell-closed' (default cornell; a file wins over a name)\n"
    "  --hemicube R         hemicube resolution: even, 8..4096 (default 64). Timing does\n"
    "                       not depend on R: only the preprocessing time does\n"
    "  --repeat N           timed runs per implementation (default: adaptive, at least 20\n"
    "                       runs and at least 0.3 s)\n"
    "  --backend B          cpu (default: the rows above) or opencl (also the OpenCL rows;\n"
    "                       fails when no OpenCL device or platform is available)\n"
    "  --csv OUT.csv        one row per implementation and cell (rewritten after each cell):\n"
    "                       impl,storage,n,k,ms_median,ms_min,ms_max,floor_ms,\n"
    "                       ratio_to_floor,ratio_to_paper,rel_l2_vs_f32, then extra columns\n"
    "                       ending in backend,kernel_ms,transfer_ms,device,ratio_to_cpu\n"
    "                       (CPU rows: cpu,nan,nan,cpu,nan; nan where a value does not\n"
    "                       apply), then ratio_pairs_median,ratio_pairs_min,\n"
    "                       ratio_pairs_max,pairs,floor_pairs_ms,roofline_ms (CPU fused\n"
    "                       rows; nan and 0 pairs elsewhere)\n"
    "  -h, --help           show this help\n";

/* ------------------------------------------------------------------ output */
static const char rt_csv_header[] =
    "impl,storage,n,k,ms_median,ms_min,ms_max,floor_ms,ratio_to_floor,ratio_to_paper,"
    "rel_l2_vs_f32,d,runs,kernel,path,other_path_frames,floor_ms_full,bandwidth_gbs,"
    "bandwidth_source,llc_mib,threads_openmp,threads_openblas,n_target,k_target,d_target,"
    "preprocess_s,hemicube,backend,kernel_ms,transfer_ms,device,ratio_to_cpu,"
    "ratio_pairs_median,ratio_pairs_min,ratio_pairs_max,pairs,floor_pairs_ms,roofline_ms\n";

static int write_rt_csv(const char *path, const rt_args *a, const rt_cell *cells, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs(rt_csv_header, out.f);
    for (size_t i = 0; i < count; i++) {
        const rt_cell *r = &cells[i];
        for (int j = 0; j < RT_COUNT + (r->have_cl ? 3 : 0); j++) {
            const rt_row *w = j < RT_COUNT ? &r->rows[j] : &r->cl_rows[j - RT_COUNT];
            fprintf(out.f, "%s,%s,%zu,%zu,", w->impl, w->storage, r->n, r->k);
            const double v[] = {w->t.median,       w->t.min,          w->t.max,
                                w->floor_ms,       w->ratio_to_floor, w->ratio_to_paper,
                                w->rel_l2};
            for (size_t q = 0; q < sizeof v / sizeof v[0]; q++)
                bench_csv_num(out.f, v[q], 0);
            fprintf(out.f, "%zu,%zu,%s,%s,%zu,", r->d, w->t.runs, w->kernel, w->path,
                    w->other_path);
            bench_csv_num(out.f, w->floor_ms_full, 0);
            const int wide = strcmp(w->storage, "f32") == 0;
            bench_csv_num(out.f, (wide ? r->bw : r->bw16) / 1e9, 0);
            fprintf(out.f, "%s,%zu,%d,%d,%zu,%zu,%zu,", wide ? r->bw_source : r->bw16_source,
                    a->llc >> 20,
                    omp_get_max_threads(), openblas_get_num_threads(), r->target.n,
                    r->target.k, r->target.d);
            bench_csv_num(out.f, r->preprocess_s, 0);
            fprintf(out.f, "%u,%s,", a->hemicube, w->backend);
            bench_csv_num(out.f, w->kernel_ms, 0);
            bench_csv_num(out.f, w->transfer_ms, 0);
            fprintf(out.f, "%s,", w->device);
            bench_csv_num(out.f, w->ratio_to_cpu, 0);
            bench_csv_num(out.f, w->pairs.median, 0);
            bench_csv_num(out.f, w->pairs.min, 0);
            bench_csv_num(out.f, w->pairs.max, 0);
            fprintf(out.f, "%u,", w->pairs.pairs);
            bench_csv_num(out.f, w->pairs.floor_ms, 0);
            bench_csv_num(out.f, w->roofline_ms, 1);
        }
    }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

static const char *fmt_ratio(char *buf, size_t len, double v)
{
    if (isnan(v))
        snprintf(buf, len, "-");
    else
        snprintf(buf, len, v < 10 ? "%.2f" : "%.1f", v);
    return buf;
}

static const char *yes_no(int v)
{
    return v ? "yes" : "no";
}

static const char *bw_source_name(const char *source)
{
    return strcmp(source, "sgemv3") == 0          ? "sgemv3's effective bandwidth"
           : strcmp(source, "resident-read") == 0 ? "the read kernel over F̄'s bytes"
                                                  : "the tuned read kernel";
}

/* The fused rows' interleaved pairs beside the one-time ratio_to_floor, and the roofline. */
static void print_rt_pairs(const rt_cell *r)
{
    printf("\ninterleaved: %u pairs of (the read loops over every byte a frame reads: F̄ as "
           "stored + M + E + B) then (the fused pass); ratio = pass ms / floor ms per pair\n",
           r->rows[RT_FUSED_F32].pairs.pairs);
    printf("%-7s %13s %29s %14s %12s %17s\n", "storage", "floor_ms", "ratio_pairs median "
           "(min-max)", "ratio_to_floor", "roofline_ms", "ms / roofline_ms");
    for (int i = RT_FUSED_F32; i <= RT_FUSED_BF16; i++) {
        const rt_row *w = &r->rows[i];
        char fl[32], md[32], lo[32], hi[32], t[128], rf[32], rl[32], rr[32];
        bench_fmt_ms(fl, sizeof fl, w->pairs.floor_ms);
        snprintf(t, sizeof t, "%s (%s-%s)", fmt_ratio(md, sizeof md, w->pairs.median),
                 fmt_ratio(lo, sizeof lo, w->pairs.min), fmt_ratio(hi, sizeof hi, w->pairs.max));
        if (isnan(w->roofline_ms))
            snprintf(rl, sizeof rl, "not measured");
        else
            snprintf(rl, sizeof rl, "%.3g", w->roofline_ms);
        printf("%-7s %13s %29s %14s %12s %17s\n", w->storage, fl, t,
               fmt_ratio(rf, sizeof rf, w->ratio_to_floor), rl,
               fmt_ratio(rr, sizeof rr, w->t.median / w->roofline_ms));
    }
}

static void print_rt_cell(const rt_args *a, const rt_cell *r)
{
    char b1[32], b2[32], b3[32];
    const double f32_bytes = storage_bytes(r->n, r->k, LRR_STORAGE_F32);
    printf("\ncell: %zu×%zu (d %zu; target %zu/%zu/%zu)\n", r->n, r->k, r->d, r->target.n,
           r->target.k, r->target.d);
    printf("preprocess_s: %.2f (hemicube %u)\n", r->preprocess_s, a->hemicube);
    printf("fbar_bytes: f32 %s, f16/bf16 %s; M %s; fits in the last-level cache (%zu MiB): "
           "%s\n",
           bench_fmt_bytes(b1, sizeof b1, (size_t)f32_bytes),
           bench_fmt_bytes(b2, sizeof b2, (size_t)(f32_bytes / 2)),
           bench_fmt_bytes(b3, sizeof b3, (size_t)12 * r->k * r->k), a->llc >> 20,
           a->llc ? yes_no(r->fits_llc) : "unknown");
    printf("bandwidth_gbs: %.2f (%s; read kernel %.2f, sgemv3 effective 3·n·k·4 B / "
           "median %.2f, read kernel over F̄'s own bytes, cache-resident %.2f)\n",
           r->bw / 1e9, bw_source_name(r->bw_source), r->bw_kernel / 1e9, r->bw_sgemv3 / 1e9,
           r->bw_resident / 1e9);
    printf("bandwidth16_gbs: %.2f (16-bit rows: %s; over their bytes, cache-resident %.2f)\n",
           r->bw16 / 1e9, bw_source_name(r->bw16_source), r->bw_resident16 / 1e9);
    char f1[32], f2[32], f3[32], f4[32];
    printf("floor_ms: f32 %s, f16/bf16 %s; floor_ms_full (F̄ + M): f32 %s, f16/bf16 %s\n",
           bench_fmt_ms(f1, sizeof f1, r->rows[RT_FUSED_F32].floor_ms),
           bench_fmt_ms(f2, sizeof f2, r->rows[RT_FUSED_F16].floor_ms),
           bench_fmt_ms(f3, sizeof f3, r->rows[RT_FUSED_F32].floor_ms_full),
           bench_fmt_ms(f4, sizeof f4, r->rows[RT_FUSED_F16].floor_ms_full));
    printf("\n%-12s %-7s %-8s %28s %7s %9s %14s %14s %13s  %s\n", "impl", "storage", "kernel",
           "ms median (min-max)", "runs", "floor_ms", "ratio_to_floor", "ratio_to_paper",
           "rel_l2_vs_f32", "path");
    for (int i = 0; i < RT_COUNT; i++) {
        const rt_row *w = &r->rows[i];
        char med[32], lo[32], hi[32], t[128], fl[32], rf[32], rp[32], el[32], pth[96];
        bench_fmt_ms(med, sizeof med, w->t.median);
        bench_fmt_ms(lo, sizeof lo, w->t.min);
        bench_fmt_ms(hi, sizeof hi, w->t.max);
        snprintf(t, sizeof t, "%s (%s-%s)", med, lo, hi);
        bench_fmt_ms(fl, sizeof fl, w->floor_ms);
        fmt_ratio(rf, sizeof rf, w->ratio_to_floor);
        fmt_ratio(rp, sizeof rp, w->ratio_to_paper);
        if (isnan(w->rel_l2))
            snprintf(el, sizeof el, "-");
        else
            snprintf(el, sizeof el, "%.3g", w->rel_l2);
        if (w->other_path)
            snprintf(pth, sizeof pth, "%s (%zu of %zu timed frames %s)", w->path, w->other_path,
                     w->t.runs, w->other_name);
        else
            snprintf(pth, sizeof pth, "%s", w->path);
        printf("%-12s %-7s %-8s %28s %7zu %9s %14s %14s %13s  %s\n", w->impl, w->storage,
               w->kernel, t, w->t.runs, fl, rf, rp, el, pth);
    }
    if (r->have_cl) {
        printf("\nopencl: %s (fused, full path; kernel and transfer: medians of the OpenCL "
               "profiling events; ratio_to_cpu = CPU fused ms / OpenCL ms)\n",
               r->cl_rows[0].device);
        printf("%-7s %28s %7s %10s %11s %10s %12s %13s\n", "storage", "ms median (min-max)",
               "runs", "kernel_ms", "transfer_ms", "sum_ms", "ratio_to_cpu", "rel_l2_vs_f32");
        for (int i = 0; i < 3; i++) {
            const rt_row *w = &r->cl_rows[i];
            char med[32], lo[32], hi[32], t[128], km[32], tm[32], sm[32], rc[32], el[32];
            bench_fmt_ms(med, sizeof med, w->t.median);
            bench_fmt_ms(lo, sizeof lo, w->t.min);
            bench_fmt_ms(hi, sizeof hi, w->t.max);
            snprintf(t, sizeof t, "%s (%s-%s)", med, lo, hi);
            if (isnan(w->rel_l2))
                snprintf(el, sizeof el, "-");
            else
                snprintf(el, sizeof el, "%.3g", w->rel_l2);
            snprintf(km, sizeof km, "%.3g", w->kernel_ms);
            snprintf(tm, sizeof tm, "%.3g", w->transfer_ms);
            snprintf(sm, sizeof sm, "%.3g", w->kernel_ms + w->transfer_ms);
            printf("%-7s %28s %7zu %10s %11s %10s %12s %13s\n", w->storage, t, w->t.runs, km, tm,
                   sm,
                   fmt_ratio(rc, sizeof rc, w->ratio_to_cpu), el);
        }
    }
    const rt_row *f32 = &r->rows[RT_FUSED_F32], *f16 = &r->rows[RT_FUSED_F16];
    char bm[32], fm[32];
    printf("\nbatch: lrr_solve_batch %d frames: %s ms per frame (median %s ms per batch, %zu "
           "runs); speed-up vs fused f32: %.2f; rel_l2_vs_f32 %.3g\n",
           RT_BATCH, bench_fmt_ms(bm, sizeof bm, r->batch_ms_per_frame),
           bench_fmt_ms(fm, sizeof fm, r->batch.median), r->batch.runs,
           f32->t.median / r->batch_ms_per_frame, r->batch_rel_l2);
    for (int j = 0; j < 2; j++) {
        const rt_row *w = &r->rows[RT_FUSED_F16 + j];
        if (w->m_ab.pairs)
            printf("m_f16: fused %s, M − I in binary16 (%.1f MB) / M in f32 (%.1f MB): %.3f "
                   "(%.3f-%.3f, %u interleaved pairs; M in f32 %.3f ms)\n",
                   w->storage, w->m_bytes / 1e6, 12.0 * (double)r->k * (double)r->k / 1e6,
                   w->m_ab.median, w->m_ab.min, w->m_ab.max, w->m_ab.pairs, w->m_ab.floor_ms);
    }
    for (int i = 0; i < RT_COUNT; i++) {
        const rt_row *w = &r->rows[i];
        if (!w->reads_fbar || !(w->ratio_to_floor < 1))
            continue;
        char by[32];
        if (a->llc && w->bytes <= (double)a->llc)
            printf("warning: %s %s: ratio_to_floor %.2f < 1: the %s it reads fit in the "
                   "last-level cache (%zu MiB); it ran faster than a read loop over F̄'s "
                   "bytes alone\n",
                   w->impl, w->storage, w->ratio_to_floor,
                   bench_fmt_bytes(by, sizeof by, (size_t)w->bytes), a->llc >> 20);
        else
            printf("warning: %s %s: ratio_to_floor %.2f < 1: the floor was measured too low "
                   "(bandwidth %.2f GB/s from the %s; it reads %s, more than the last-level "
                   "cache)\n",
                   w->impl, w->storage, w->ratio_to_floor, r->bw / 1e9,
                   bw_source_name(r->bw_source),
                   bench_fmt_bytes(by, sizeof by, (size_t)w->bytes));
    }
    const rt_row *b16 = &r->rows[RT_FUSED_BF16];
    print_rt_pairs(r);
    char m1[32], m2[32], m3[32];
    printf("target: fused f32 ≤ %.2f × floor (interleaved median %s): %s; ≥ %g× paper: %s; "
           "f16 ≤ %.2f × its floor (%s): %s; bf16 ≤ %.2f × its floor (%s): %s; f16 ≥ %g× "
           "paper: %s\n",
           RT_TARGET_FLOOR, fmt_ratio(m1, sizeof m1, f32->pairs.median),
           yes_no(f32->pairs.median <= RT_TARGET_FLOOR), RT_TARGET_PAPER_F32,
           yes_no(f32->ratio_to_paper >= RT_TARGET_PAPER_F32), RT_TARGET_FLOOR16,
           fmt_ratio(m2, sizeof m2, f16->pairs.median),
           yes_no(f16->pairs.median <= RT_TARGET_FLOOR16), RT_TARGET_FLOOR16,
           fmt_ratio(m3, sizeof m3, b16->pairs.median),
           yes_no(b16->pairs.median <= RT_TARGET_FLOOR16), RT_TARGET_PAPER_F16,
           yes_no(f16->ratio_to_paper >= RT_TARGET_PAPER_F16));
    fflush(stdout);
}

static const char *env_or_unset(const char *name)
{
    const char *v = getenv(name);
    return v && v[0] ? v : "(unset)";
}

static const char *openblas_parallel_name(void)
{
    switch (openblas_get_parallel()) {
    case 0:
        return "sequential";
    case 1:
        return "pthreads";
    case 2:
        return "openmp";
    default:
        return "unknown";
    }
}

/* ------------------------------------------------------------------ command */
/* The options into *a (nk_name: the cells' name for --n/--k). Returns BENCH_RUN, or the exit
 * status (CLI_EXIT_OK after --help). */
static int rt_parse(int argc, char *argv[], rt_args *a, char *nk_name, size_t nk_len)
{
    static const char prog[] = "lrr-bench realtime";
    static const struct option longopts[] = {
        {"n", required_argument, NULL, OPT_N},
        {"k", required_argument, NULL, OPT_K},
        {"cells", required_argument, NULL, OPT_CELLS},
        {"scene", required_argument, NULL, OPT_SCENE},
        {"hemicube", required_argument, NULL, OPT_HEMICUBE},
        {"repeat", required_argument, NULL, OPT_REPEAT},
        {"csv", required_argument, NULL, OPT_CSV},
        {"backend", required_argument, NULL, OPT_BACKEND},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    size_t opt_n = 0, opt_k = 0;
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(realtime_help, stdout);
            return CLI_EXIT_OK;
        case OPT_N:
            if (cli_parse_size(prog, "--n", optarg, 1, (size_t)1 << 32, &opt_n) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_K:
            if (cli_parse_size(prog, "--k", optarg, 1, (size_t)1 << 32, &opt_k) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_CELLS:
            if (parse_cells(prog, optarg, &a->cells, &a->n_cells, &a->cells_name) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_SCENE:
            a->scene = optarg;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &a->hemicube) != 0)
                return CLI_EXIT_USAGE;
            if (a->hemicube % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", a->hemicube);
                return CLI_EXIT_USAGE;
            }
            break;
        case OPT_REPEAT:
            if (cli_parse_unsigned(prog, "--repeat", optarg, 1, 1000000, &a->repeat) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_CSV:
            a->csv = optarg;
            break;
        case OPT_BACKEND:
            if (bench_parse_backend(prog, optarg, &a->opencl) != 0)
                return CLI_EXIT_USAGE;
            break;
        default:
            return bench_bad_option(prog, c, argv);
        }
    }
    if (bench_no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if (a->csv && !a->csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if ((opt_n || opt_k) && a->cells) {
        cli_usage_error(prog, "--n/--k and --cells exclude each other");
        return CLI_EXIT_USAGE;
    }
    if (!opt_n != !opt_k) {
        cli_usage_error(prog, "%s needs %s too", opt_n ? "--n" : "--k", opt_n ? "--k" : "--n");
        return CLI_EXIT_USAGE;
    }
    if (opt_n) {
        if (opt_n < opt_k) {
            cli_usage_error(prog, "--n %zu is smaller than --k %zu (n = k·4^levels)", opt_n,
                            opt_k);
            return CLI_EXIT_USAGE;
        }
        double lv = round(log((double)opt_n / (double)opt_k) / log(4.0));
        if (lv > 10) {
            cli_usage_error(prog, "--n/--k: N/K = %g needs more than 10 levels",
                            (double)opt_n / (double)opt_k);
            return CLI_EXIT_USAGE;
        }
        a->cells = malloc(sizeof *a->cells);
        if (!a->cells)
            return bench_fail("out of memory");
        a->cells[0] = (cell){opt_n, opt_k, (size_t)1 << (2 * (unsigned)lv)};
        a->n_cells = 1;
        snprintf(nk_name, nk_len, "--n %zu --k %zu, levels %u", opt_n, opt_k, (unsigned)lv);
        a->cells_name = nk_name;
    }
    if (!a->cells && parse_cells(prog, "paper", &a->cells, &a->n_cells, &a->cells_name) != 0)
        return bench_fail("out of memory");
    return BENCH_RUN;
}

/* The run's configuration and threading, then the read bandwidth (a->llc, a->bandwidth). */
static void rt_print_setup(rt_args *a)
{
    printf("benchmark: realtime\n");
    bench_print_machine();
    printf("omp_wait_policy: %s\n", env_or_unset("OMP_WAIT_POLICY"));
    printf("omp_proc_bind: %s\n", env_or_unset("OMP_PROC_BIND"));
    printf("omp_num_threads: %s\n", env_or_unset("OMP_NUM_THREADS"));
    printf("openblas_num_threads: %s\n", env_or_unset("OPENBLAS_NUM_THREADS"));
    printf("openblas_parallel: %s\n", openblas_parallel_name());
    printf("threading: lrr kernels OpenMP (%d threads), baselines OpenBLAS (%d threads); each "
           "implementation in its own block: %u warm-up runs, %u ms idle, timed runs\n",
           omp_get_max_threads(), openblas_get_num_threads(), RT_WARMUPS, RT_IDLE_MS);
    printf("scene: %s\n", a->scene);
    printf("cells: %s (%zu)\n", a->cells_name, a->n_cells);
    printf("hemicube: %u (the timings do not depend on it)\n", a->hemicube);
    if (a->opencl)
        printf("backend: cpu and opencl\n");
    if (a->repeat)
        printf("repeat: %u\n", a->repeat);
    else
        printf("repeat: adaptive (at least %d runs and %.1f s)\n", MIN_RUNS, RT_MIN_SECONDS);
    fflush(stdout);
    a->llc = bench_llc_bytes();
    size_t bw_bytes = bench_bandwidth_buffer_bytes();
    printf("llc_mib: %zu\n", a->llc >> 20);
    bench_note("measuring the read bandwidth (%d passes over %zu MiB)", BANDWIDTH_PASSES,
               bw_bytes >> 20);
    a->bandwidth = bench_measure_bandwidth(bw_bytes);
    if (a->bandwidth > 0)
        printf("read_bandwidth_gbs: %.2f (tuned read kernels: OpenMP sums, 128-bit, AVX2 and "
               "AVX-512 where present, the last two also with a software prefetch, over %zu "
               "MiB, best of %d passes each, %d threads)\n",
               a->bandwidth / 1e9, bw_bytes >> 20, BANDWIDTH_PASSES, omp_get_max_threads());
    else
        printf("read_bandwidth_gbs: nan (cannot allocate %zu MiB)\n", bw_bytes >> 20);
    bench_note("measuring the multiply-add peak");
    a->fma_peak = bench_fma_peak();
    if (a->fma_peak > 0)
        printf("fma_peak_gflops: %.1f (FMA loop: 12 independent chains per thread, 128-, 256- "
               "and 512-bit where present, the best of 2 passes each, %d threads)\n",
               a->fma_peak / 1e9, omp_get_max_threads());
    else
        printf("fma_peak_gflops: not measured\n");
    printf("units: ms per frame, median (min-max); floor = F̄ bytes / bandwidth; "
           "ratio_to_paper = paper ms / ms (a speed-up)\n");
    fflush(stdout);
}

/* Every cell in turn, each printed (and the CSV rewritten) when measured. */
static int rt_run(rt_args *a)
{
    lrr_context *ctx = NULL;
    int rc;
    if ((rc = bench_start(a->scene, a->opencl, &ctx)) != CLI_EXIT_OK)
        return rc;
    rt_cell *res = calloc(a->n_cells, sizeof *res);
    if (!res) {
        lrr_context_destroy(ctx);
        return bench_fail("out of memory");
    }
    double t_start = cli_now();
    rt_print_setup(a);

    rc = CLI_EXIT_OK;
    size_t done = 0;
    for (size_t i = 0; i < a->n_cells; i++) {
        int crc = rt_cell_run(ctx, a, &a->cells[i], i, &res[done]);
        if (crc) {
            rc = crc;
            break;
        }
        print_rt_cell(a, &res[done]);
        done++;
        if (a->csv && write_rt_csv(a->csv, a, res, done) != 0) {
            rc = CLI_EXIT_FAIL;
            break;
        }
    }
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
    if (a->csv && done)
        printf("csv: %s\n", a->csv);
    free(res);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_realtime(int argc, char *argv[])
{
    rt_args a = {.scene = "cornell", .hemicube = RT_DEFAULT_HEMICUBE};
    char nk_name[96];
    int rc = rt_parse(argc, argv, &a, nk_name, sizeof nk_name);
    if (rc == BENCH_RUN)
        rc = rt_run(&a);
    free(a.cells);
    return rc;
}
