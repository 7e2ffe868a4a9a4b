/* --light SPEC of solve and render: moving lights (lrr_light_source) from the command line.
 * SPEC is a kind and key=value fields, e.g. 'point pos=0.5,1.9,0.5 rgb=2,2,2' or
 * 'spot pos=0,2,0 dir=0,-1,0 angle=30 soft=5 rgb=4'. */
#include "commands.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* cli_parse_vec3 into v, or (one_ok, for rgb) a single such number for all three; 0 or -1. */
static int parse_vec(const char *s, int one_ok, float v[3])
{
    double d[3];
    char three[3 * 512 + 3];
    if (one_ok && !strchr(s, ',') && strlen(s) < 512) {
        snprintf(three, sizeof three, "%s,%s,%s", s, s, s);
        s = three;
    }
    if (cli_parse_vec3(s, d) != 0)
        return -1;
    for (int j = 0; j < 3; j++)
        v[j] = (float)d[j];
    return 0;
}

static int parse_kind(const char *word, int *kind)
{
    static const char *const names[] = {"point", "spot", "area", "sun"};
    for (int k = 0; k < 4; k++)
        if (strcmp(word, names[k]) == 0) {
            *kind = LRR_LIGHT_POINT + k;
            return 0;
        }
    return -1;
}

/* One key=value field into l; 0, or -1 for an unknown key or a bad value. */
static int parse_field(const char *key, const char *val, lrr_light_source *l)
{
    char *end;
    if (strcmp(key, "pos") == 0)
        return parse_vec(val, 0, l->position);
    if (strcmp(key, "dir") == 0)
        return parse_vec(val, 0, l->direction);
    if (strcmp(key, "rgb") == 0)
        return parse_vec(val, 1, l->rgb);
    if (strcmp(key, "u") == 0)
        return parse_vec(val, 0, l->u);
    if (strcmp(key, "v") == 0)
        return parse_vec(val, 0, l->v);
    if (strcmp(key, "angle") == 0 || strcmp(key, "soft") == 0) {
        double deg = strtod(val, &end);
        if (end == val || *end || !isfinite(deg))
            return -1;
        *(key[0] == 'a' ? &l->cone_angle : &l->cone_softness) = (float)(deg * M_PI / 180);
        return 0;
    }
    if (strcmp(key, "samples") == 0) {
        unsigned long s = strtoul(val, &end, 10);
        if (end == val || *end || s > 1024)
            return -1;
        l->samples = (unsigned)s;
        return 0;
    }
    return -1;
}

int cli_parse_light(const char *prog, const char *spec, lrr_light_source *l)
{
    memset(l, 0, sizeof *l);
    char *copy = strdup(spec), *save = NULL;
    if (!copy) {
        cli_usage_error(prog, "--light: out of memory");
        return -1;
    }
    char *word = strtok_r(copy, " \t", &save);
    int rc = 0;
    if (!word || parse_kind(word, &l->kind) != 0) {
        cli_usage_error(prog, "--light '%s': starts with point, spot, area or sun", spec);
        rc = -1;
    }
    while (!rc && (word = strtok_r(NULL, " \t", &save))) {
        char *eq = strchr(word, '=');
        if (eq)
            *eq = '\0';
        if (!eq || parse_field(word, eq + 1, l) != 0) {
            cli_usage_error(prog, "--light '%s': bad field '%s%s%s' (pos=X,Y,Z dir=X,Y,Z "
                                  "rgb=R,G,B u=X,Y,Z v=X,Y,Z angle=DEG soft=DEG samples=N)",
                            spec, word, eq ? "=" : "", eq ? eq + 1 : "");
            rc = -1;
        }
    }
    free(copy);
    if (!rc && l->kind == LRR_LIGHT_SPOT && l->cone_angle == 0)
        l->cone_angle = (float)(30 * M_PI / 180); /* a spot without angle= */
    return rc;
}
