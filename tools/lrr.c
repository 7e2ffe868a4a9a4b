/*
 * lrr — command-line front end of the Low-Rank Radiosity library.
 *
 *   lrr info SCENE        scene statistics after subdivision
 *   lrr check SCENE       the scene doctor: degenerate, intersecting, z-fighting, flipped faces
 *   lrr preprocess SCENE  build and save the operator (F̄, M_c)
 *   lrr solve FILE.lrr    solve for the stored emission, time it, write a CSV
 *   lrr render FILE.lrr   solve and draw a PNG (or EXR), lit by its emitters, lights or a probe
 *   lrr animate FILE.lrr  lights moving along paths: one picture per frame
 *   lrr export FILE.lrr   solve and write the lit mesh as glTF (.glb) or PLY
 *   lrr reference SCENE   the full n×n form factors and a classic solver, for comparison
 *   lrr compare A B       error measures of one radiosity CSV against another
 *   lrr demo              the Cornell box from start to picture
 *   lrr probe PROBE       fit lights or SH9 to a light probe and measure the irradiance error
 *   lrr view FILE.lrr     the interactive viewer (moving lights; headless with --script)
 *
 * This file is the dispatcher (top-level --help and --version, the table of subcommands);
 * each subcommand lives in tools/cmd_NAME.c, what several share in cli_options.c and
 * cli_steps.c (declared in commands.h).
 *
 * Exit status: 0 success, 1 a failure while working (library error, I/O), 2 a malformed
 * command line, 3 a reference solve that did not converge. Uses only the public API (lrr.h).
 */
#include <stdio.h>
#include <string.h>

#include "cli.h"
#include "commands.h"
#include "lrr.h"

int cli_parse_only;

static const char main_help[] =
    "Usage: lrr COMMAND [OPTIONS]\n"
    "Low-Rank Radiosity: preprocess a diffuse scene once, then solve for any emission.\n"
    "\n"
    "Commands:\n"
    "  info SCENE           scene statistics after subdivision\n"
    "  check SCENE          the scene doctor: degenerate, intersecting, z-fighting, flipped faces\n"
    "  preprocess SCENE     build the operator and save it to an .lrr file\n"
    "  solve FILE.lrr       solve for the stored emission, time it, optionally write a CSV\n"
    "  render FILE.lrr      solve and draw a PNG (or EXR)\n"
    "  animate FILE.lrr     lights moving along paths: one picture per frame\n"
    "  export FILE.lrr      solve and write the lit mesh as glTF (.glb) or PLY\n"
    "  reference SCENE      full n×n form factors and a classic solver, to measure against\n"
    "  compare A.csv B.csv  errors of the radiosity in A against the reference B\n"
    "  demo                 the Cornell box from scene to picture\n"
    "  probe PROBE.hdr      fit lights (median cut) or SH9 to a light probe, measure errors\n"
    "  view FILE.lrr        the interactive viewer: move lights, see the radiosity live\n"
    "\n"
    "Options:\n"
    "  -h, --help           show this help (COMMAND --help: help on a command)\n"
    "  -V, --version        print the library version and the optional features built\n"
    "\n"
    "Environment: OMP_NUM_THREADS (threads), LRR_SIMD (the SIMD level of the form factors\n"
    "and the real-time kernel: c, avx2, avx2+prefetch, avx512 or avx512+prefetch; the\n"
    "widest the CPU runs when unset), LRR_OPENCL_DEVICE.\n"
    "Where OpenBLAS would use its SSE3 'Prescott' kernels on a CPU it does not know (a\n"
    "newer Xeon), lrr runs itself again with OPENBLAS_CORETYPE=SkylakeX or Haswell, as the\n"
    "CPU supports; a preset OPENBLAS_CORETYPE is kept.\n"
    "\n"
    "Exit status: 0 success, 1 failure, 2 bad command line, 3 a reference solve that did\n"
    "not converge.\n";

static int print_version(void)
{
    const char *lib = lrr_version_string();
    if (!lib || strcmp(lib, LRR_VERSION_STRING) != 0) {
        fprintf(stderr, "lrr: the library is version %s but lrr was built with header %s\n",
                lib ? lib : "(null)", LRR_VERSION_STRING);
        return CLI_EXIT_FAIL;
    }
    printf("lrr %s\n", lib);
    /* the library's optional dependencies, then the tool's own (configure --without-X) */
    const char *features = lrr_features();
    printf("features:%s%s", *features ? " " : "", features);
#ifdef LRR_VIEWER
    fputs(" viewer", stdout);
#endif
#ifdef LRR_MPI
    fputs(" mpi", stdout); /* liblrr_mpi: mpirun -np P lrr solve */
#ifdef LRR_SCALAPACK
    fputs(" scalapack", stdout); /* liblrr_mpi inverts large G across the ranks */
#endif
#endif
    putchar('\n');
    return CLI_EXIT_OK;
}

int lrr_cli_main(int argc, char *argv[], int parse_only)
{
    cli_parse_only = parse_only;
    static const struct {
        const char *name;
        int (*run)(int, char *[]);
    } commands[] = {{"info", cmd_info},
                    {"check", cmd_check},
                    {"preprocess", cmd_preprocess},
                    {"solve", cmd_solve},
                    {"render", cmd_render},
                    {"animate", cmd_animate},
                    {"export", cmd_export},
                    {"reference", cmd_reference},
                    {"compare", cmd_compare},
                    {"demo", cmd_demo},
                    {"probe", cmd_probe},
                    {"view", cmd_view}};
    if (argc < 2) {
        fputs(main_help, stderr);
        return CLI_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (strcmp(cmd, "-h") == 0 || strcmp(cmd, "--help") == 0 || strcmp(cmd, "help") == 0) {
        fputs(main_help, stdout);
        return CLI_EXIT_OK;
    }
    if (strcmp(cmd, "-V") == 0 || strcmp(cmd, "--version") == 0)
        return print_version();
    for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
        if (strcmp(cmd, commands[i].name) == 0)
            return commands[i].run(argc - 1, argv + 1);
    if (cmd[0] == '-')
        cli_usage_error("lrr", "unknown option '%s'", cmd);
    else
        cli_usage_error("lrr", "unknown command '%s'", cmd);
    fprintf(stderr, "Try 'lrr --help'.\n");
    return CLI_EXIT_USAGE;
}

#ifndef LRR_CLI_NO_MAIN
int main(int argc, char *argv[])
{
    cli_fair_openblas(argv, 0);
    cli_idle_openblas();
    return lrr_cli_main(argc, argv, 0);
}
#endif
