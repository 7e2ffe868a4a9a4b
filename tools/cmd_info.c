/* lrr info: scene statistics after subdivision. */
#include <getopt.h>
#include <stdio.h>

#include "commands.h"

static const char info_help[] =
    "Usage: lrr info SCENE [OPTIONS]\n"
    "Prints scene statistics as 'key: value' lines (scene, triangles, skipped, patches,\n"
    "subpatches, d, area, emitters, max_patch_area, bounds_min, bounds_max).\n"
    "\n" SCENE_HELP "\n" SUBDIV_HELP "  -h, --help           show this help\n";

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
    lrr_scene *scene = NULL;
    rc = open_subdivided_scene(ctx, name, &sa, &scene);
    if (rc == CLI_EXIT_OK)
        print_scene_info(name, scene);
    lrr_scene_destroy(scene);
    lrr_context_destroy(ctx);
    return rc;
}
