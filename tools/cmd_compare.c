/* `lrr compare`: the command, reading the per-subpatch radiosity CSV and the error measures
 * (the latter two declared in cli.h). */
#include "cli.h"

#include <ctype.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>

#include "commands.h"

/* Longer lines cannot come from our writer (12 numbers of at most ~16 characters). */
#define CSV_MAX_LINE 4096
#define CSV_FIELDS 12

static const char *const field_names[CSV_FIELDS] = {"subpatch", "patch", "area", "cx",
                                                    "cy",       "cz",    "nx",   "ny",
                                                    "nz",       "b_r",   "b_g",  "b_b"};

/* ------------------------------------------------------------------ reading */
/* A non-negative integer made only of digits that fits in size_t. */
static int parse_index(const char *path, size_t line, int field, const char *text, size_t *out)
{
    char *end = NULL;
    errno = 0;
    unsigned long long v = isdigit((unsigned char)text[0]) ? strtoull(text, &end, 10) : 0;
    if (!end || *end != '\0') {
        cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: %s '%s' is not a non-negative integer", path,
                 line, field_names[field], text);
        return -1;
    }
    if (errno == ERANGE || v > SIZE_MAX) {
        cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: %s '%s' is out of range", path, line,
                 field_names[field], text);
        return -1;
    }
    *out = (size_t)v;
    return 0;
}

/* A finite number, the whole field (no surrounding spaces). */
static int parse_number(const char *path, size_t line, int field, const char *text, double *out)
{
    if (text[0] == '\0') {
        cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: %s is empty", path, line, field_names[field]);
        return -1;
    }
    /* strtod skips leading spaces; the writer never puts any there. */
    char *end = NULL;
    double v = isspace((unsigned char)text[0]) ? 0.0 : strtod(text, &end);
    if (!end || *end != '\0') {
        cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: %s '%s' is not a number", path, line,
                 field_names[field], text);
        return -1;
    }
    if (!isfinite(v)) {
        cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: %s '%s' is not a finite number", path, line,
                 field_names[field], text);
        return -1;
    }
    *out = v;
    return 0;
}

/* Splits `text` (NUL-terminated, modified in place) at commas into one row. */
static int parse_row(const char *path, size_t line, char *text, cli_csv_row *row)
{
    char *field[CSV_FIELDS];
    size_t count = 0;
    for (char *p = text;;) {
        char *comma = strchr(p, ',');
        if (count < CSV_FIELDS)
            field[count] = p;
        count++;
        if (!comma)
            break;
        *comma = '\0';
        p = comma + 1;
    }
    if (count != CSV_FIELDS) {
        cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: %zu fields, expected %d (%s)", path, line,
                 count, CSV_FIELDS, CLI_CSV_HEADER);
        return -1;
    }
    double v[CSV_FIELDS];
    if (parse_index(path, line, 0, field[0], &row->subpatch) != 0 ||
        parse_index(path, line, 1, field[1], &row->patch) != 0)
        return -1;
    for (int f = 2; f < CSV_FIELDS; f++)
        if (parse_number(path, line, f, field[f], &v[f]) != 0)
            return -1;
    if (!(v[2] > 0.0)) {
        cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: area '%s' is not positive", path, line,
                 field[2]);
        return -1;
    }
    row->area = v[2];
    for (int c = 0; c < 3; c++) {
        row->centre[c] = v[3 + c];
        row->normal[c] = v[6 + c];
        row->b[c] = v[9 + c];
    }
    return 0;
}

void cli_csv_table_free(cli_csv_table *t)
{
    free(t->rows);
    t->rows = NULL;
    t->n = 0;
}

int cli_read_radiosity_csv(const char *path, cli_csv_table *out)
{
    out->n = 0;
    out->rows = NULL;
    const char *why = NULL;
    FILE *f = cli_open_regular(path, &why);
    if (!f)
        return cli_fail(LRR_ERR_IO, "cannot open '%s': %s", path, why);

    cli_csv_table t = {0, NULL};
    size_t cap = 0, lineno = 0;
    char *line = NULL;
    size_t line_cap = 0;
    int rc = CLI_EXIT_OK;
    for (;;) {
        errno = 0;
        ssize_t len = getline(&line, &line_cap, f);
        if (len < 0) {
            if (ferror(f))
                rc = cli_fail(LRR_ERR_IO, "cannot read '%s' after line %zu: %s", path, lineno,
                              strerror(errno ? errno : EIO));
            break;
        }
        lineno++;
        if ((size_t)len > CSV_MAX_LINE) {
            rc = cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: %zd characters, not a radiosity CSV",
                          path, lineno, len);
            break;
        }
        if (strlen(line) != (size_t)len) {
            rc = cli_fail(LRR_ERR_FORMAT, "'%s' line %zu: contains a NUL byte, not a CSV", path,
                          lineno);
            break;
        }
        if (line[len - 1] != '\n') {
            rc = cli_fail(LRR_ERR_FORMAT,
                          "'%s' line %zu: the file ends in the middle of a line (truncated?)",
                          path, lineno);
            break;
        }
        line[--len] = '\0';
        if (len > 0 && line[len - 1] == '\r') /* tolerate CRLF line ends */
            line[--len] = '\0';
        if (lineno == 1) {
            if (strcmp(line, CLI_CSV_HEADER) != 0) {
                int printable = len <= 200;
                for (ssize_t i = 0; printable && i < len; i++)
                    printable = isprint((unsigned char)line[i]);
                if (printable)
                    rc = cli_fail(LRR_ERR_FORMAT, "'%s' line 1: the header is '%s', expected '%s'",
                                  path, line, CLI_CSV_HEADER);
                else
                    rc = cli_fail(LRR_ERR_FORMAT, "'%s' line 1 is not the header '%s'", path,
                                  CLI_CSV_HEADER);
                break;
            }
            continue;
        }
        if (t.n == cap) {
            size_t new_cap = cap ? 2 * cap : 1024;
            if (new_cap < cap || new_cap > SIZE_MAX / sizeof *t.rows) {
                rc = cli_fail(LRR_ERR_OVERFLOW, "'%s' line %zu: too many rows", path, lineno);
                break;
            }
            cli_csv_row *p = realloc(t.rows, new_cap * sizeof *p);
            if (!p) {
                rc = cli_fail(LRR_ERR_NOMEM, "'%s' line %zu: cannot allocate %zu rows", path,
                              lineno, new_cap);
                break;
            }
            t.rows = p;
            cap = new_cap;
        }
        if (parse_row(path, lineno, line, &t.rows[t.n]) != 0) {
            rc = CLI_EXIT_FAIL;
            break;
        }
        t.n++;
    }
    free(line);
    fclose(f);
    if (rc == CLI_EXIT_OK && lineno == 0)
        rc = cli_fail(LRR_ERR_FORMAT, "'%s' is empty, expected the header '%s'", path,
                      CLI_CSV_HEADER);
    else if (rc == CLI_EXIT_OK && t.n == 0)
        rc = cli_fail(LRR_ERR_FORMAT, "'%s': no rows after the header", path);
    if (rc != CLI_EXIT_OK) {
        cli_csv_table_free(&t);
        return rc;
    }
    *out = t;
    return CLI_EXIT_OK;
}

/* ------------------------------------------------------------------ comparison */
static double ratio(double num, double den)
{
    if (den > 0.0)
        return num / den;
    return num > 0.0 ? INFINITY : 0.0;
}

int cli_compare_radiosity(const cli_csv_table *a, const char *a_path, const cli_csv_table *b,
                          const char *b_path, cli_comparison *out)
{
    memset(out, 0, sizeof *out);
    if (a->n != b->n)
        return cli_fail(LRR_ERR_DIM,
                        "'%s' has %zu rows but '%s' has %zu (a truncated file, or different "
                        "subdivisions)",
                        a_path, a->n, b_path, b->n);
    size_t n = b->n;

    /* The scene's size, for the tolerance on centres; the largest |B|, for max_rel. */
    double lo[3], hi[3], max_b = 0.0;
    for (int c = 0; c < 3; c++)
        lo[c] = hi[c] = n ? b->rows[0].centre[c] : 0.0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            const cli_csv_row *r = &b->rows[i];
            lo[c] = fmin(lo[c], r->centre[c]);
            hi[c] = fmax(hi[c], r->centre[c]);
            max_b = fmax(max_b, fabs(r->b[c]));
        }
    double extent = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    double centre_tol = 1e-5 * (extent > 0.0 ? extent : 1.0);

    for (size_t i = 0; i < n; i++) {
        const cli_csv_row *ra = &a->rows[i], *rb = &b->rows[i];
        size_t line = i + 2;
        if (ra->subpatch != rb->subpatch)
            return cli_fail(LRR_ERR_DIM,
                            "'%s' line %zu: subpatch %zu, but %zu in '%s': the rows are in a "
                            "different order",
                            a_path, line, ra->subpatch, rb->subpatch, b_path);
        if (fabs(ra->area - rb->area) > 1e-6 * fabs(rb->area))
            return cli_fail(LRR_ERR_DIM,
                            "'%s' line %zu: subpatch %zu has area %.9g, but %.9g in '%s': "
                            "different subdivisions",
                            a_path, line, rb->subpatch, ra->area, rb->area, b_path);
        for (int c = 0; c < 3; c++)
            if (fabs(ra->centre[c] - rb->centre[c]) > centre_tol)
                return cli_fail(LRR_ERR_DIM,
                                "'%s' line %zu: subpatch %zu has centre (%.9g %.9g %.9g), but "
                                "(%.9g %.9g %.9g) in '%s': different subdivisions",
                                a_path, line, rb->subpatch, ra->centre[0], ra->centre[1],
                                ra->centre[2], rb->centre[0], rb->centre[1], rb->centre[2],
                                b_path);
    }

    double total_area = 0.0, num[3] = {0, 0, 0}, den[3] = {0, 0, 0}, abs_sum[3] = {0, 0, 0};
    double threshold = 1e-3 * max_b;
    for (size_t i = 0; i < n; i++) {
        const cli_csv_row *ra = &a->rows[i], *rb = &b->rows[i];
        double w = rb->area;
        total_area += w;
        for (int c = 0; c < 3; c++) {
            double diff = ra->b[c] - rb->b[c];
            num[c] += w * diff * diff;
            den[c] += w * rb->b[c] * rb->b[c];
            abs_sum[c] += w * fabs(diff);
            if (fabs(rb->b[c]) > threshold) {
                double rel = fabs(diff) / fabs(rb->b[c]);
                if (rel > out->max_rel_c[c])
                    out->max_rel_c[c] = rel;
                if (!out->have_max_rel || rel > out->max_rel) {
                    out->max_rel = rel;
                    out->max_rel_subpatch = rb->subpatch;
                    out->have_max_rel = 1;
                }
            }
        }
    }
    out->n = n;
    for (int c = 0; c < 3; c++) {
        out->rel_l2_c[c] = sqrt(ratio(num[c], den[c]));
        out->mean_abs_c[c] = ratio(abs_sum[c], total_area);
    }
    out->rel_l2 = sqrt(ratio(num[0] + num[1] + num[2], den[0] + den[1] + den[2]));
    out->mean_abs = ratio(abs_sum[0] + abs_sum[1] + abs_sum[2], 3.0 * total_area);
    return CLI_EXIT_OK;
}

/* ------------------------------------------------------------------ lrr compare */
static const char compare_help[] =
    "Usage: lrr compare A.csv B.csv\n"
    "Compares the radiosity in A with the reference B, both written by 'lrr solve --csv' or\n"
    "'lrr reference --csv' for the same subdivision (same rows, same order, same areas).\n"
    "Prints 'key: value' lines, area-weighted with B's areas a_i, ΔB = B_A − B_B:\n"
    "  n                    subpatches\n"
    "  rel_l2               sqrt(Σ_i a_i Σ_c ΔB_ic²) / sqrt(Σ_i a_i Σ_c B_ic²)\n"
    "  max_rel              max |ΔB_ic| / |B_ic| over the entries with |B_ic| > 1e-3 max |B|\n"
    "  max_rel_subpatch     the subpatch where max_rel occurs ('none' if B is all zero)\n"
    "  mean_abs             Σ_i a_i Σ_c |ΔB_ic| / (3 Σ_i a_i)\n"
    "  rel_l2_r, rel_l2_g, rel_l2_b, max_rel_r, max_rel_g, max_rel_b, mean_abs_r,\n"
    "  mean_abs_g, mean_abs_b  the same per channel (max_rel_c with the same threshold)\n"
    "\n"
    "Options:\n"
    "  -h, --help           show this help\n"
    "\n"
    "Exit status: 0 success, 1 a file that cannot be read or parsed (the message names the\n"
    "file and line) or files of different subdivisions, 2 bad command line.\n";

/* CLI_RUN with the two paths, or the exit status (after --help or a usage message). */
static int parse_compare(int argc, char *argv[], const char **path_a, const char **path_b)
{
    static const char prog[] = "lrr compare";
    static const struct option longopts[] = {{"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        if (c == 'h') {
            fputs(compare_help, stdout);
            return CLI_EXIT_OK;
        }
        return bad_option(prog, c, argv);
    }
    if (argc - optind != 2) {
        if (argc - optind > 2)
            cli_usage_error(prog, "unexpected argument '%s'", argv[optind + 2]);
        else
            cli_usage_error(prog, "missing %s", optind == argc ? "A.csv and B.csv" : "B.csv");
        fprintf(stderr, "Try '%s --help'.\n", prog);
        return CLI_EXIT_USAGE;
    }
    *path_a = argv[optind];
    *path_b = argv[optind + 1];
    return CLI_RUN;
}

static void print_comparison(const cli_comparison *cmp)
{
    static const char ch[3] = {'r', 'g', 'b'};
    printf("n: %zu\n", cmp->n);
    printf("rel_l2: %.9g\n", cmp->rel_l2);
    printf("max_rel: %.9g\n", cmp->max_rel);
    if (cmp->have_max_rel)
        printf("max_rel_subpatch: %zu\n", cmp->max_rel_subpatch);
    else
        printf("max_rel_subpatch: none\n");
    printf("mean_abs: %.9g\n", cmp->mean_abs);
    for (int k = 0; k < 3; k++)
        printf("rel_l2_%c: %.9g\n", ch[k], cmp->rel_l2_c[k]);
    for (int k = 0; k < 3; k++)
        printf("max_rel_%c: %.9g\n", ch[k], cmp->max_rel_c[k]);
    for (int k = 0; k < 3; k++)
        printf("mean_abs_%c: %.9g\n", ch[k], cmp->mean_abs_c[k]);
}

int cmd_compare(int argc, char *argv[])
{
    const char *path_a = NULL, *path_b = NULL;
    int rc = parse_compare(argc, argv, &path_a, &path_b);
    if (rc != CLI_RUN)
        return rc;
    if (cli_parse_only)
        return CLI_EXIT_OK;
    cli_csv_table a = {0, NULL}, b = {0, NULL};
    cli_comparison cmp;
    rc = cli_read_radiosity_csv(path_a, &a);
    if (rc == CLI_EXIT_OK)
        rc = cli_read_radiosity_csv(path_b, &b);
    if (rc == CLI_EXIT_OK)
        rc = cli_compare_radiosity(&a, path_a, &b, path_b, &cmp);
    if (rc == CLI_EXIT_OK)
        print_comparison(&cmp);
    cli_csv_table_free(&a);
    cli_csv_table_free(&b);
    return rc;
}
