/* lrr check: the scene doctor (degenerate, intersecting, z-fighting and flipped faces), and
 * --fix to write a repaired OBJ. */
#include <errno.h>
#include <getopt.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "commands.h"

static const char prog[] = "lrr check";

static const char check_help[] =
    "Usage: lrr check SCENE [--fix OUT.obj] [--max-report N] [--strict]\n"
    "The scene doctor (exact predicates, CGAL). Reads the raw triangles (zero-area ones\n"
    "included) and prints 'key: value' lines (triangles, degenerate, intersecting_pairs,\n"
    "coplanar_overlaps, contacts, open_edges, inconsistent_components,\n"
    "upside_down_sheets), then one line per\n"
    "finding naming the file's face numbers (for a built-in scene, triangle indices).\n"
    "Errors: degenerate (zero-area) triangles; intersecting pairs (each crosses the other's\n"
    "plane: light leaks); coplanar overlaps facing the same way (z-fighting); closed\n"
    "components whose faces disagree on orientation (the minority is named).\n"
    "Warnings: open edges (boundaries; the Cornell box's front is open) and contacts\n"
    "(coplanar overlaps facing opposite ways, e.g. a block standing on the floor);\n"
    "open sheets that look upside down (a few rays from each side of the sheet: its\n"
    "front sees back faces or nothing while its back sees front faces, e.g. a floor quad\n"
    "facing down into its room).\n"
    "\n" SCENE_HELP "\n"
    "  --fix OUT.obj        write the scene without degenerates and with each closed\n"
    "                       component oriented like its majority: OBJ triangles on shared\n"
    "                       vertices with the file's groups and material names, OUT.mtl\n"
    "                       with Kd/Ke as read (both written atomically); intersections\n"
    "                       are not repaired\n"
    "  --max-report N       print at most N finding lines (default 50; 0 = none)\n"
    "  --strict             warnings count as errors\n"
    "  -h, --help           show this help\n"
    "Exit status: 0 no errors, 1 errors found (about the input, also with --fix) or the scene\n"
    "cannot be read, 2 usage error.\n";

typedef struct check_args {
    const char *scene, *fix;
    size_t max_report;
    int strict;
} check_args;

/* ------------------------------------------------------------------ parsing */
/* CLI_RUN with *a filled in, or the exit status (after --help or a usage message). */
static int parse_check(check_args *a, int argc, char *argv[])
{
    enum { OPT_FIX = 1024, OPT_MAX_REPORT, OPT_STRICT };
    static const struct option longopts[] = {{"fix", required_argument, NULL, OPT_FIX},
                                             {"max-report", required_argument, NULL, OPT_MAX_REPORT},
                                             {"strict", no_argument, NULL, OPT_STRICT},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    *a = (check_args){.fix = NULL, .max_report = 50, .strict = 0};
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(check_help, stdout);
            return CLI_EXIT_OK;
        } else if (c == OPT_FIX) {
            if (!*optarg) {
                cli_usage_error(prog, "--fix: the file name is empty");
                return CLI_EXIT_USAGE;
            }
            a->fix = optarg;
        } else if (c == OPT_MAX_REPORT) {
            if (cli_parse_size(prog, "--max-report", optarg, 0, SIZE_MAX, &a->max_report) != 0)
                return CLI_EXIT_USAGE;
        } else if (c == OPT_STRICT) {
            a->strict = 1;
        } else {
            return bad_option(prog, c, argv);
        }
    }
    a->scene = one_positional(prog, "SCENE", argc, argv);
    if (!a->scene)
        return CLI_EXIT_USAGE;
    return CLI_RUN;
}

/* ------------------------------------------------------------------ printing */
static void print_finding(const lrr_check_finding *f)
{
    switch (f->kind) {
    case LRR_CHECK_DEGENERATE:
        printf("error: face %zu is degenerate (zero area)\n", f->face_a);
        break;
    case LRR_CHECK_INTERSECT:
        printf("error: face %zu and face %zu intersect\n", f->face_a, f->face_b);
        break;
    case LRR_CHECK_ZFIGHT:
        printf("error: face %zu and face %zu are coplanar and overlap, facing the same way "
               "(z-fighting)\n", f->face_a, f->face_b);
        break;
    case LRR_CHECK_CONTACT:
        printf("warning: face %zu and face %zu are coplanar and overlap, facing opposite ways "
               "(contact)\n", f->face_a, f->face_b);
        break;
    case LRR_CHECK_OPEN_EDGE:
        printf("warning: face %zu has an open edge (boundary)\n", f->face_a);
        break;
    case LRR_CHECK_ORIENTATION:
        printf("error: face %zu is oriented against its closed component (e.g. face %zu)\n",
               f->face_a, f->face_b);
        break;
    case LRR_CHECK_UPSIDE_DOWN:
        printf("warning: face %zu is in an open sheet that looks upside down (its front sees "
               "back faces or nothing, its back sees front faces; sheet of face %zu)\n",
               f->face_a, f->face_b);
        break;
    }
}

/* The counts, the first max_report findings and the verdict; returns the exit status. */
static int print_report(const check_args *a, const lrr_check_report *r)
{
    printf("scene: %s\ntriangles: %zu\ndegenerate: %zu\nintersecting_pairs: %zu\n"
           "coplanar_overlaps: %zu\ncontacts: %zu\nopen_edges: %zu\n"
           "inconsistent_components: %zu\nupside_down_sheets: %zu\n",
           a->scene, r->triangles, r->degenerate, r->intersecting_pairs, r->coplanar_overlaps,
           r->contacts, r->open_edges, r->inconsistent_components, r->upside_down_sheets);
    for (size_t i = 0; i < r->n_findings && i < a->max_report; i++)
        print_finding(&r->findings[i]);
    if (r->n_findings > a->max_report)
        printf("(%zu more findings not shown; see --max-report)\n",
               r->n_findings - a->max_report);
    size_t errors = r->degenerate + r->intersecting_pairs + r->coplanar_overlaps +
                    r->inconsistent_components;
    size_t warnings = r->contacts + r->open_edges + r->upside_down_sheets;
    int rc = errors || (a->strict && warnings) ? CLI_EXIT_FAIL : CLI_EXIT_OK;
    printf("result: %s\n", errors ? "errors" : warnings ? (a->strict ? "warnings (strict)" : "warnings only") : "clean");
    return rc;
}

/* ------------------------------------------------------------------ running */
static int run_check(const check_args *a)
{
    struct stat st;
    if (stat(a->scene, &st) != 0 && !is_builtin(a->scene))
        return cli_fail(LRR_ERR_IO, "scene '%s': %s (built-in scenes: cornell, cornell-closed)",
                        a->scene, strerror(errno));
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return cli_lib_error(NULL, s);
    lrr_check_report *r = NULL;
    s = lrr_scene_check(ctx, a->scene, &r);
    if (s != LRR_OK) {
        int rc = cli_lib_error(ctx, s);
        lrr_context_destroy(ctx);
        return rc;
    }
    int rc = print_report(a, r);
    if (a->fix) {
        s = lrr_check_report_names(ctx, a->scene, r);
        int frc = s == LRR_OK ? check_write_fixed(r, a->fix) : cli_lib_error(ctx, s);
        if (frc != CLI_EXIT_OK)
            rc = frc;
    }
    lrr_check_report_destroy(r);
    lrr_context_destroy(ctx);
    return rc;
}

int cmd_check(int argc, char *argv[])
{
    check_args a;
    int rc = parse_check(&a, argc, argv);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    return run_check(&a);
}
