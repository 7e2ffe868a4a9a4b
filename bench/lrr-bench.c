/*
 * lrr-bench — the benchmark driver of the Low-Rank Radiosity library.
 *
 *   lrr-bench table     the paper's n×k table: memory, preprocessing, real-time step (ours,
 *                       the paper's two-gemv method, three plain sgemv), a bandwidth floor and
 *                       the error against the full n×n solution, as a table, CSV and plot
 *                       (table.c)
 *   lrr-bench stress    closed rooms with uniform emission and reflectance up to 0.999, where
 *                       B = E/(1 − rho) exactly: the operator and every reference solver
 *                       (stress.c)
 *   lrr-bench hemicube  hemicube resolution against closed-form view factors and R = 512
 *                       (hemicube.c)
 *   lrr-bench realtime  the real-time step alone: every implementation (fused f32/f16/bf16,
 *                       sgemv, sgemm, the paper's method, sparse and incremental paths) on
 *                       the same matrix against a bandwidth floor (realtime.c)
 *   lrr-bench probes    light probes: error of median cut, irradiance optimisation and SH9
 *                       against the number of sources, with the time per method (probes.c)
 *   lrr-bench adaptive  the adaptive patch hierarchy against uniform subdivision at the same
 *                       patch budget and subpatches: error against the n×n solution,
 *                       preprocessing, selection and real-time step (adaptive.c)
 *   lrr-bench scenes    the real scenes end to end: preprocessing split, peak memory, ms per
 *                       frame (f32, f16) against the bandwidth floor, reflected light
 *                       against a path-traced reference per region and facing, beside
 *                       lrr_operator_verify's figure (scenes.c, scenes_run.c,
 *                       scenes_out.c, judge.c)
 *   lrr-bench mpi       the real-time step across MPI ranks against one process (mpi.c)
 * What they share (messages, options, timing, bandwidth, the baselines) is in
 * bench_*.c (bench.h).
 *
 * Results go to stdout ('key: value' lines and aligned tables), progress to stderr. Exit
 * status: 0 success, 1 a failure (library error, I/O, a check that did not hold), 2 a
 * malformed command line. Uses only the public API (lrr.h), cblas for the baselines.
 */
#include <stdio.h>
#include <string.h>

#include "bench.h"

static const char main_help[] =
    "Usage: lrr-bench COMMAND [OPTIONS]\n"
    "Benchmarks of the Low-Rank Radiosity library.\n"
    "\n"
    "Commands:\n"
    "  table      the n×k table of the paper: memory, preprocessing, real-time step of lrr,\n"
    "             of the paper's method and of three plain sgemv, a bandwidth floor and the\n"
    "             error against the full n×n solution\n"
    "  stress     closed empty rooms, uniform emission, rho up to 0.999: the operator and the\n"
    "             reference solvers against the exact B = E/(1 - rho)\n"
    "  hemicube   form-factor error and preprocessing time against hemicube resolution\n"
    "  realtime   the real-time step alone, all on one matrix: lrr's fused kernel with F̄ in\n"
    "             f32, f16 and bf16, three sgemv, one sgemm, the paper's method, the sparse\n"
    "             and incremental paths, against a bandwidth floor\n"
    "  probes     light probes: error of median cut, irradiance optimisation and SH9\n"
    "             against the number of sources (2..256), time per method\n"
    "  adaptive   adaptive patch hierarchy against uniform subdivision at the same patch\n"
    "             budget: error against the n×n solution, selection and build time\n"
    "  scenes     the real scenes (FZK-Haus, bunny room) end to end: preprocessing\n"
    "             (clustering, form factors, SMW), peak memory, ms per frame in f32 and f16\n"
    "             against the bandwidth floor, reflected light against a path-traced\n"
    "             reference per region and per facing, with its noise, beside\n"
    "             lrr_operator_verify's own error bar\n"
    "  lights     moving point lights: ms per frame of the direct light and its shadow rays\n"
    "             per second, all lights moving or one, against Embree's occlusion rate\n"
    "  raycast    hemicubes per second of the rasteriser and of the ray caster against the\n"
    "             number of triangles (the crossover LRR_FORMFACTOR_AUTO uses)\n"
    "  fbar       saved operators' F̄ read dense and sparse: bytes, ms per frame against\n"
    "             each pass's own floor, the two in alternation, the difference of B\n"
    "  mpi        the real-time step across MPI ranks (mpirun; configure --with-mpi):\n"
    "             ms per frame against one process, the allreduce alone, bytes per rank\n"
    "\n"
    "Options:\n"
    "  -h, --help     show this help (COMMAND --help: help on a command)\n"
    "  -V, --version  print the library version\n"
    "\n"
    "Threads: OMP_NUM_THREADS (lrr) and OPENBLAS_NUM_THREADS (the cblas baselines).\n"
    "Where OpenBLAS would use its SSE3 'Prescott' kernels on a CPU it does not know,\n"
    "lrr-bench runs itself again with OPENBLAS_CORETYPE=SkylakeX or Haswell (said on\n"
    "stderr; openblas_core in the configuration), so no baseline is handicapped.\n"
    "Exit status: 0 success, 1 failure or a failed check, 2 bad command line.\n";

/* ================================================================== main */
int main(int argc, char *argv[])
{
    cli_fair_openblas(argv, 1);
    cli_idle_openblas();
    static const struct {
        const char *name;
        int (*run)(int, char *[]);
    } commands[] = {{"table", cmd_table},
                    {"stress", cmd_stress},
                    {"hemicube", cmd_hemicube},
                    {"realtime", cmd_realtime},
                    {"probes", cmd_probes},
                    {"adaptive", cmd_adaptive},
                    {"scenes", cmd_scenes},
                    {"lights", cmd_lights},
                    {"raycast", cmd_raycast},
                    {"fbar", cmd_fbar},
                    {"mpi", cmd_mpi}};
    if (argc < 2) {
        fputs(main_help, stderr);
        return CLI_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "-h") == 0 || strcmp(cmd, "--help") == 0 || strcmp(cmd, "help") == 0) {
        fputs(main_help, stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(cmd, "-V") == 0 || strcmp(cmd, "--version") == 0) {
        printf("lrr-bench %s\n", lrr_version_string());
        return CLI_EXIT_OK;
    }
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(cmd, commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    cli_usage_error("lrr-bench", "unknown %s '%s'", cmd[0] == '-' ? "option" : "command", cmd);
    fprintf(stderr, "Try 'lrr-bench --help'.\n");
    return CLI_EXIT_USAGE;
}

