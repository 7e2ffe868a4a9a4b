/* The viewer's script (VIEW_SCRIPT_HELP in view.h): read and checked before any window
 * opens, so a typo fails at once with its line number. No GL here: always compiled. */
#include "view.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* "X,Y,Z" into v; 0 or -1. */
static int parse_vec3(const char *s, double v[3])
{
    char *end;
    for (int j = 0; j < 3; j++) {
        v[j] = strtod(s, &end);
        if (end == s || !isfinite(v[j]) || fabs(v[j]) > 3e38)
            return -1;
        if (j < 2 && *end != ',')
            return -1;
        s = end + 1;
    }
    return *end == '\0' ? 0 : -1;
}

static int parse_count(const char *s, unsigned long max, unsigned long *out)
{
    char *end;
    errno = 0;
    unsigned long v = strtoul(s, &end, 10);
    if (end == s || *end || errno || v > max || s[0] == '-')
        return -1;
    *out = v;
    return 0;
}

/* "key=value" with the given key: the value, or NULL. */
static const char *field(const char *word, const char *key)
{
    size_t k = strlen(key);
    return word && strncmp(word, key, k) == 0 && word[k] == '=' ? word + k + 1 : NULL;
}

/* One command line (already without its comment); 0 or -1 (the caller names the line). */
static int parse_words(char *line, view_cmd *c, size_t *lights)
{
    char *save = NULL, *verb = strtok_r(line, " \t\r", &save);
    char *a = strtok_r(NULL, " \t\r", &save), *b = a ? strtok_r(NULL, " \t\r", &save) : NULL;
    char *extra = b ? strtok_r(NULL, " \t\r", &save) : NULL;
    unsigned long u;
    if (strcmp(verb, "move") == 0) {
        double p[3];
        const char *fr = field(extra, "frames");
        if (!a || parse_count(a, *lights ? *lights - 1 : 0, &u) || !*lights || !field(b, "pos") ||
            parse_vec3(field(b, "pos"), p) || (extra && (!fr || parse_count(fr, 1000000, &u))))
            return -1;
        c->kind = VS_MOVE;
        c->index = strtoul(a, NULL, 10);
        c->frames = extra ? (unsigned)u : 1;
        for (int j = 0; j < 3; j++)
            c->pos[j] = (float)p[j];
        return c->frames ? 0 : -1;
    }
    if (extra)
        return -1;
    if (strcmp(verb, "remove") == 0) {
        if (b || !a || !*lights || parse_count(a, *lights - 1, &u))
            return -1;
        c->kind = VS_REMOVE;
        c->index = u;
        (*lights)--;
        return 0;
    }
    if (strcmp(verb, "camera") == 0) {
        c->kind = VS_CAMERA;
        return field(a, "eye") && field(b, "target") && !parse_vec3(field(a, "eye"), c->eye) &&
                       !parse_vec3(field(b, "target"), c->target)
                   ? 0
                   : -1;
    }
    if (b)
        return -1;
    if (strcmp(verb, "emitters") == 0 && a && (!strcmp(a, "on") || !strcmp(a, "off"))) {
        c->kind = VS_EMITTERS;
        c->on = strcmp(a, "on") == 0;
        return 0;
    }
    if (strcmp(verb, "exposure") == 0 && a) {
        char *end;
        c->kind = VS_EXPOSURE;
        c->exposure = strtod(a, &end);
        return end != a && !*end && isfinite(c->exposure) && c->exposure >= 0 ? 0 : -1;
    }
    if (strcmp(verb, "frames") == 0 && a && !parse_count(a, 1000000, &u)) {
        c->kind = VS_FRAMES;
        c->frames = (unsigned)u;
        return 0;
    }
    if (strcmp(verb, "screenshot") == 0 && a) {
        c->kind = VS_SCREENSHOT;
        c->path = strdup(a);
        return c->path ? 0 : -1;
    }
    return -1;
}

/* One line into c (c->kind stays 0 for a blank line); 0 or -1 after the message. */
static int parse_line(const char *prog, const char *path, int no, char *line, view_cmd *c,
                      size_t *lights)
{
    char *hash = strchr(line, '#');
    if (hash)
        *hash = '\0';
    line[strcspn(line, "\r\n")] = '\0';
    char *p = line + strspn(line, " \t");
    if (!*p)
        return 0;
    c->line = no;
    if (strncmp(p, "light", 5) == 0 && (p[5] == ' ' || p[5] == '\t')) {
        if (*lights >= VIEW_MAX_LIGHTS) {
            cli_usage_error(prog, "'%s' line %d: more than %d lights", path, no, VIEW_MAX_LIGHTS);
            return -1;
        }
        if (cli_parse_light(prog, p + 6 + strspn(p + 6, " \t"), &c->light) != 0) {
            cli_usage_error(prog, "'%s' line %d: bad light (above)", path, no);
            return -1;
        }
        c->kind = VS_LIGHT;
        (*lights)++;
        return 0;
    }
    char copy[1024];
    snprintf(copy, sizeof copy, "%s", p);
    if (parse_words(p, c, lights) != 0) {
        cli_usage_error(prog, "'%s' line %d: cannot read '%s' (see lrr view --help; light "
                              "indices count from 0 over %zu light(s))",
                        path, no, copy, *lights);
        return -1;
    }
    return 0;
}

int view_script_load(const char *prog, const char *path, size_t lights, view_script *s)
{
    memset(s, 0, sizeof *s);
    FILE *f = fopen(path, "r");
    if (!f) {
        cli_usage_error(prog, "cannot open the script '%s': %s", path, strerror(errno));
        return CLI_EXIT_FAIL;
    }
    char line[1024];
    size_t cap = 0;
    int no = 0, rc = CLI_EXIT_OK;
    while (rc == CLI_EXIT_OK && fgets(line, sizeof line, f)) {
        no++;
        if (s->count == cap) {
            size_t ncap = cap ? 2 * cap : 16;
            view_cmd *grown = realloc(s->cmd, ncap * sizeof *grown);
            if (!grown) {
                cli_usage_error(prog, "'%s': out of memory", path);
                rc = CLI_EXIT_FAIL;
                break;
            }
            s->cmd = grown;
            cap = ncap;
        }
        view_cmd *c = &s->cmd[s->count];
        memset(c, 0, sizeof *c);
        if (parse_line(prog, path, no, line, c, &lights) != 0)
            rc = CLI_EXIT_USAGE;
        else if (c->kind)
            s->count++;
    }
    if (rc == CLI_EXIT_OK && ferror(f)) {
        cli_usage_error(prog, "cannot read the script '%s'", path);
        rc = CLI_EXIT_FAIL;
    }
    fclose(f);
    if (rc != CLI_EXIT_OK)
        view_script_free(s);
    return rc;
}

void view_script_free(view_script *s)
{
    for (size_t i = 0; i < s->count; i++)
        free(s->cmd[i].path);
    free(s->cmd);
    s->cmd = NULL;
    s->count = 0;
}
