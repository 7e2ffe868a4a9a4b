/* lrr info: scene statistics after subdivision, or what an operator file holds. */
#include <getopt.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "commands.h"

static const char info_help[] =
    "Usage: lrr info SCENE [OPTIONS]\n"
    "       lrr info FILE.lrr\n"
    "Prints scene statistics as 'key: value' lines (scene, triangles, skipped, patches,\n"
    "subpatches, d, area, emitters, max_patch_area, bounds_min, bounds_max), or for an\n"
    "operator file (a .lrr of 'lrr preprocess') file_version (5: F̄ stored as strips; 1 to\n"
    "4: dense; 'lrr preprocess --fbar-file'), file_bytes, then what 'lrr preprocess'\n"
    "printed of it: n, k, d, hierarchy, hemicube, receiver, seed, build_seconds, the\n"
    "condition estimates, storage, memory_mb and, when it was verified (--verify),\n"
    "verify_rel_l2, verify_noise, verify_subpatches, verify_samples, verify_seconds,\n"
    "verify_emission;\n"
    "then how 'lrr solve' reads F̄ (a CPU solver's --fbar auto): fbar (dense or sparse),\n"
    "fbar_bytes (read per full frame), fbar_dense_bytes, fbar_density (nonzero entries /\n"
    "n·k), fbar_strip_density (entries of the 16-row strips that hold a nonzero / n·k),\n"
    "m (f32, or f16: M_c - I in binary16, chosen when F̄ is 16-bit) and m_bytes (read per\n"
    "full frame).\n"
    "\n" SCENE_HELP "\n" SUBDIV_HELP "  -h, --help           show this help\n";

/* How a CPU solver reads the operator's F̄ (lrr_solver_get_info). */
static int print_fbar_info(lrr_context *ctx, const lrr_operator *op)
{
    lrr_solver *sv = NULL;
    lrr_status s = lrr_solver_create(op, LRR_BACKEND_CPU, &sv);
    if (s != LRR_OK)
        return cli_lib_error(ctx, s);
    lrr_solver_info si;
    lrr_solver_get_info(sv, &si, sizeof si);
    lrr_solver_destroy(sv);
    printf("fbar: %s\n", lrr_fbar_format_name(si.fbar));
    printf("fbar_bytes: %zu\n", si.fbar_bytes);
    printf("fbar_dense_bytes: %zu\n", si.fbar_dense_bytes);
    printf("fbar_density: %.4f\n", si.fbar_density);
    printf("fbar_strip_density: %.4f\n", si.fbar_strip_density);
    printf("m: %s\n", lrr_storage_name(si.m));
    printf("m_bytes: %zu\n", si.m_bytes);
    return CLI_EXIT_OK;
}

/* 1 when the file starts with the .lrr magic ("LRROPER\0"); then *version is its format
 * version (bytes 8..11, little-endian) and *bytes its size. */
static int is_operator_file(const char *path, unsigned *version, long *bytes)
{
    unsigned char head[12] = {0};
    const char *why = NULL;
    FILE *f = cli_open_regular(path, &why); /* a FIFO would block fopen */
    if (!f)
        return 0; /* the scene loader reports why */
    size_t got = fread(head, 1, sizeof head, f);
    *bytes = fseek(f, 0, SEEK_END) == 0 ? ftell(f) : -1;
    fclose(f);
    *version = head[8] | head[9] << 8 | head[10] << 16 | (unsigned)head[11] << 24;
    return got == sizeof head && memcmp(head, "LRROPER", 8) == 0;
}

int cmd_info(int argc, char *argv[])
{
    static const char prog[] = "lrr info";
    static const struct option longopts[] = {SUBDIV_LONGOPTS,
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    subdiv_args sa;
    subdiv_init(&sa);
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        int r = subdiv_option(&sa, prog, c, optarg);
        if (r < 0)
            return CLI_EXIT_USAGE;
        if (r > 0)
            continue;
        if (c == 'h') {
            fputs(info_help, stdout);
            return CLI_EXIT_OK;
        }
        return bad_option(prog, c, argv);
    }
    const char *name = one_positional(prog, "SCENE", argc, argv);
    if (!name)
        return CLI_EXIT_USAGE;
    int rc = subdiv_finish(&sa, prog);
    if (rc)
        return rc;

    if (cli_parse_only)
        return CLI_EXIT_OK;
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    unsigned version;
    long bytes;
    if (is_operator_file(name, &version, &bytes)) {
        lrr_operator *op = NULL;
        rc = load_operator(ctx, name, &op);
        if (rc == CLI_EXIT_OK) {
            printf("file: %s\n", name);
            printf("file_version: %u\n", version);
            printf("file_bytes: %ld\n", bytes);
            print_operator_info(op);
            rc = print_fbar_info(ctx, op);
        }
        lrr_operator_destroy(op);
        lrr_context_destroy(ctx);
        return rc;
    }
    lrr_scene *scene = NULL;
    rc = open_subdivided_scene(ctx, name, &sa, &scene);
    if (rc == CLI_EXIT_OK)
        print_scene_info(name, scene);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}
