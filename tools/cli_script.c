/* The light script of lrr view and lrr animate (CLI_SCRIPT_HELP in cli_script.h): read and
 * checked whole before any work starts, so a typo fails at once naming its line; then
 * played statement by statement, frame by frame, by either command. */
#include "cli_script.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define MAX_WORDS (CLI_SCRIPT_MAX_POINTS + 4)
#define MAX_STEP_FRAMES 1000000 /* of one statement */
#define UNKNOWN ((size_t)-1)

typedef struct reader {
    const char *prog, *path;
    const cli_script_caps *caps;
    int line;
    size_t lights;   /* there now; UNKNOWN after a key (N adds one, Delete may remove one) */
    int pending;     /* the line of a move or path that no frames followed yet; 0: none */
} reader;

static int fail(const reader *r, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static int fail(const reader *r, const char *fmt, ...)
{
    char what[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(what, sizeof what, fmt, ap);
    va_end(ap);
    cli_usage_error(r->prog, "'%s' line %d: %s", r->path, r->line, what);
    return -1;
}

static int parse_point(const char *s, float p[3])
{
    double v[3];
    if (cli_parse_vec3(s, v) != 0)
        return -1;
    for (int j = 0; j < 3; j++)
        p[j] = (float)v[j];
    return 0;
}

static int parse_count(const char *s, unsigned long max, unsigned long *out)
{
    char *end;
    errno = 0;
    unsigned long v = strtoul(s, &end, 10);
    if (end == s || *end || errno || v > max || s[0] == '-' || s[0] == '+')
        return -1;
    *out = v;
    return 0;
}

static int parse_number(const char *s, double *out)
{
    char *end;
    errno = 0;
    *out = strtod(s, &end);
    return end != s && !*end && errno != ERANGE && isfinite(*out) ? 0 : -1;
}

/* "key=value" with the given key: the value, or NULL. */
static const char *field(const char *word, const char *key)
{
    size_t k = strlen(key);
    return word && strncmp(word, key, k) == 0 && word[k] == '=' ? word + k + 1 : NULL;
}

/* A light index of the lights there now. */
static int parse_index(const reader *r, const char *verb, const char *word, size_t *index)
{
    unsigned long i;
    if (!word || parse_count(word, CLI_MAX_LIGHTS - 1, &i) ||
        (r->lights != UNKNOWN && i >= r->lights))
        return fail(r, "%s: '%s' is not a light (they count from 0; there %s %zu now)", verb,
                    word ? word : "", r->lights == 1 ? "is" : "are", r->lights);
    *index = i;
    return 0;
}

/* The trailing "frames=N" of move, path and drag (words[k], may be absent); 0 or -1. */
static int frames_suffix(const reader *r, const char *verb, char **words, size_t nw, size_t k,
                         unsigned *frames)
{
    unsigned long u;
    if (nw == k)
        return 0;
    const char *f = field(words[k], "frames");
    if (nw > k + 1 || !f || parse_count(f, MAX_STEP_FRAMES, &u) || u == 0)
        return fail(r, "%s: '%s' is not frames=N (1..%d) at the end", verb, words[k],
                    MAX_STEP_FRAMES);
    *frames = (unsigned)u;
    return 0;
}

/* Whether this command may use the viewer's statements. */
static int viewer_only(const reader *r, const char *verb)
{
    if (r->caps->keys)
        return 0;
    return fail(r, "%s: only lrr view has a window to %s", verb,
                strcmp(verb, "screenshot") == 0 ? "take a screenshot of" : "send input to");
}

static int parse_light_verbs(reader *r, const char *verb, char **w, size_t nw, cli_script_cmd *c)
{
    if (strcmp(verb, "remove") == 0) {
        c->kind = CS_REMOVE;
        if (nw != 2)
            return fail(r, "remove: one light index");
        if (parse_index(r, verb, w[1], &c->index))
            return -1;
        if (r->lights != UNKNOWN)
            r->lights--;
        return 0;
    }
    if (strcmp(verb, "move") == 0) {
        c->kind = CS_MOVE;
        c->points = 1;
        if (nw < 3 || parse_index(r, verb, w[1], &c->index))
            return nw < 3 ? fail(r, "move: I pos=X,Y,Z [frames=N]") : -1;
        if (!field(w[2], "pos") || parse_point(field(w[2], "pos"), c->pts[0]))
            return fail(r, "move: '%s' is not pos=X,Y,Z (finite)", w[2]);
        return frames_suffix(r, verb, w, nw, 3, &c->frames);
    }
    /* path */
    c->kind = CS_PATH;
    if (nw < 2 || parse_index(r, verb, w[1], &c->index))
        return nw < 2 ? fail(r, "path: I X,Y,Z X,Y,Z ... [frames=N]") : -1;
    size_t k = 2;
    for (; k < nw && !field(w[k], "frames"); k++) {
        if (c->points == CLI_SCRIPT_MAX_POINTS ||
            parse_point(w[k], c->pts[c->points]) != 0)
            return fail(r, "path: points are X,Y,Z (finite, at most %d): '%s'",
                        CLI_SCRIPT_MAX_POINTS, w[k]);
        c->points++;
    }
    if (c->points < 2)
        return fail(r, "path: at least two points");
    return frames_suffix(r, verb, w, nw, k, &c->frames);
}

static int find_key(const char *const *keys, const char *name)
{
    for (int k = 0; keys[k]; k++)
        if (strcmp(keys[k], name) == 0)
            return k;
    return -1;
}

/* fly KEYS SECONDS [shift]: the held keys as CLI_SCRIPT_FLY_KEYS bits. */
static int parse_fly(reader *r, char **w, size_t nw, cli_script_cmd *c)
{
    c->kind = CS_FLY;
    c->key = 0;
    for (const char *k = nw > 1 ? w[1] : ""; *k; k++) {
        const char *at = strchr(CLI_SCRIPT_FLY_KEYS, *k);
        if (!at || (c->key >> (at - CLI_SCRIPT_FLY_KEYS) & 1))
            c->key = -1;
        else
            c->key |= 1 << (at - CLI_SCRIPT_FLY_KEYS);
    }
    c->on = nw == 4 && strcmp(w[3], "shift") == 0;
    if (nw < 3 || nw > 4 || (nw == 4 && !c->on) || c->key <= 0 || parse_number(w[2], &c->value) ||
        c->value < 0 || c->value > 60)
        return fail(r, "fly: KEYS (some of W A S D Q E) SECONDS (0..60) [shift]");
    return 0;
}

/* mouse, click, drag, scroll, key, fly, screenshot: the viewer's. */
static int parse_input(reader *r, const char *verb, char **w, size_t nw, cli_script_cmd *c)
{
    if (viewer_only(r, verb))
        return -1;
    if (strcmp(verb, "screenshot") == 0) {
        c->kind = CS_SCREENSHOT;
        if (nw != 2)
            return fail(r, "screenshot: one file name (no spaces)");
        c->path = strdup(w[1]);
        return c->path ? 0 : fail(r, "out of memory");
    }
    if (strcmp(verb, "key") == 0) {
        c->kind = CS_KEY;
        if (nw != 2 || (c->key = find_key(r->caps->keys, w[1])) < 0)
            return fail(r, "key: '%s' is not one of the keys of lrr view --help",
                        nw > 1 ? w[1] : "");
        r->lights = UNKNOWN; /* checked when played */
        return 0;
    }
    if (strcmp(verb, "fly") == 0)
        return parse_fly(r, w, nw, c);
    if (strcmp(verb, "scroll") == 0) {
        c->kind = CS_SCROLL;
        if (nw != 2 || parse_number(w[1], &c->value) || fabs(c->value) > 1000)
            return fail(r, "scroll: one number of notches (-1000..1000)");
        return 0;
    }
    int drag = strcmp(verb, "drag") == 0;
    c->kind = drag ? CS_DRAG : strcmp(verb, "click") == 0 ? CS_CLICK : CS_MOUSE;
    size_t want = drag ? 4 : 2;
    for (size_t j = 0; j < want; j++)
        if (nw < want + 1 || parse_number(w[1 + j], &c->xy[j]) || fabs(c->xy[j]) > 1e6)
            return fail(r, "%s: %s (window pixels)", verb, drag ? "X0 Y0 X1 Y1 [frames=N]"
                                                                 : "X Y");
    c->frames = drag ? 8 : 0;
    if (!drag && nw != 3)
        return fail(r, "%s: X Y (window pixels)", verb);
    return drag ? frames_suffix(r, verb, w, nw, 5, &c->frames) : 0;
}

/* One statement of nw >= 1 words into c. */
static int parse_statement(reader *r, char *text, char **w, size_t nw, cli_script_cmd *c)
{
    const char *verb = w[0];
    unsigned long u;
    if (strcmp(verb, "light") == 0) {
        c->kind = CS_LIGHT;
        if (r->lights != UNKNOWN && r->lights >= CLI_MAX_LIGHTS)
            return fail(r, "light: more than %d lights", CLI_MAX_LIGHTS);
        if (cli_parse_light(r->prog, text + strspn(text, " \t") + 5, &c->light) != 0)
            return fail(r, "bad light (above)");
        if (r->lights != UNKNOWN)
            r->lights++;
        return 0;
    }
    if (!strcmp(verb, "remove") || !strcmp(verb, "move") || !strcmp(verb, "path"))
        return parse_light_verbs(r, verb, w, nw, c);
    if (strcmp(verb, "frames") == 0) {
        c->kind = CS_FRAMES;
        if (nw != 2 || parse_count(w[1], MAX_STEP_FRAMES, &u))
            return fail(r, "frames: one number, 0..%d", MAX_STEP_FRAMES);
        c->frames = (unsigned)u;
        return 0;
    }
    if (strcmp(verb, "emitters") == 0) {
        c->kind = CS_EMITTERS;
        if (nw != 2 || (strcmp(w[1], "on") && strcmp(w[1], "off")))
            return fail(r, "emitters: on or off");
        c->on = strcmp(w[1], "on") == 0;
        return 0;
    }
    if (strcmp(verb, "exposure") == 0) {
        c->kind = CS_EXPOSURE;
        if (nw != 2 || parse_number(w[1], &c->value) || c->value < 0 || c->value > 1e30)
            return fail(r, "exposure: one number, > 0 (0 = automatic)");
        return 0;
    }
    if (strcmp(verb, "camera") == 0) {
        c->kind = CS_CAMERA;
        if (nw != 3 || !field(w[1], "eye") || !field(w[2], "target") ||
            cli_parse_vec3(field(w[1], "eye"), c->eye) ||
            cli_parse_vec3(field(w[2], "target"), c->target))
            return fail(r, "camera: eye=X,Y,Z target=X,Y,Z");
        if (c->eye[0] == c->target[0] && c->eye[1] == c->target[1] && c->eye[2] == c->target[2])
            return fail(r, "camera: the target equals the eye (no view direction)");
        return 0;
    }
    static const char *const input[] = {"screenshot", "mouse", "click", "drag",
                                        "scroll",     "key",   "fly"};
    for (size_t k = 0; k < sizeof input / sizeof *input; k++)
        if (strcmp(verb, input[k]) == 0)
            return parse_input(r, verb, w, nw, c);
    return fail(r, "'%s' is not a statement (light, remove, move, path, frames, emitters, "
                   "exposure, camera%s)",
                verb, r->caps->keys ? ", screenshot, mouse, click, drag, scroll, key, fly" : "");
}

/* Frames drawn by c (0 for most), checked against the script's total. */
static int count_frames(reader *r, const cli_script_cmd *c, cli_script *s)
{
    unsigned f = c->kind == CS_FRAMES || c->kind == CS_DRAG || c->kind == CS_MOVE ||
                         c->kind == CS_PATH
                     ? c->frames
                     : 0;
    if ((c->kind == CS_MOVE || c->kind == CS_PATH) && !f)
        r->pending = r->pending ? r->pending : r->line;
    else if (f)
        r->pending = 0;
    if (s->frames + f > CLI_SCRIPT_MAX_FRAMES)
        return fail(r, "the script draws more than %d frames", CLI_SCRIPT_MAX_FRAMES);
    s->frames += f;
    return 0;
}

/* One line (its comment cut off) into c; c->kind stays 0 for a blank line. */
static int parse_line(reader *r, char *line, cli_script_cmd *c, cli_script *s)
{
    line[strcspn(line, "#\r\n")] = '\0';
    char copy[4096], *w[MAX_WORDS], *save = NULL;
    snprintf(copy, sizeof copy, "%s", line);
    size_t nw = 0;
    for (char *t = strtok_r(copy, " \t", &save); t; t = strtok_r(NULL, " \t", &save)) {
        if (nw == MAX_WORDS)
            return fail(r, "too many words (a path has at most %d points)",
                        CLI_SCRIPT_MAX_POINTS);
        w[nw++] = t;
    }
    if (nw == 0)
        return 0;
    c->line = r->line;
    if (parse_statement(r, line, w, nw, c) != 0)
        return -1;
    return count_frames(r, c, s);
}

static int grow(cli_script *s, size_t *cap)
{
    if (s->count < *cap)
        return 0;
    size_t ncap = *cap ? 2 * *cap : 16;
    cli_script_cmd *grown = realloc(s->cmd, ncap * sizeof *grown);
    if (!grown)
        return -1;
    s->cmd = grown;
    *cap = ncap;
    return 0;
}

int cli_script_load(const char *prog, const char *path, const cli_script_caps *caps,
                    cli_script *s)
{
    memset(s, 0, sizeof *s);
    const char *why = NULL;
    FILE *f = cli_open_regular(path, &why);
    if (!f) {
        cli_usage_error(prog, "cannot open the script '%s': %s", path, why);
        return CLI_EXIT_FAIL;
    }
    reader r = {.prog = prog, .path = path, .caps = caps, .lights = caps->lights};
    char line[4096];
    size_t cap = 0;
    int rc = CLI_EXIT_OK;
    while (rc == CLI_EXIT_OK && fgets(line, sizeof line, f)) {
        r.line++;
        if (!strchr(line, '\n') && !feof(f)) {
            fail(&r, "longer than %zu characters", sizeof line - 2);
            rc = CLI_EXIT_USAGE;
        } else if (grow(s, &cap) != 0) {
            cli_usage_error(prog, "'%s': out of memory", path);
            rc = CLI_EXIT_FAIL;
        } else {
            cli_script_cmd *c = &s->cmd[s->count];
            memset(c, 0, sizeof *c);
            if (parse_line(&r, line, c, s) != 0) {
                free(c->path);
                rc = CLI_EXIT_USAGE;
            } else if (c->kind) {
                s->count++;
            }
        }
    }
    if (rc == CLI_EXIT_OK && ferror(f)) {
        cli_usage_error(prog, "cannot read the script '%s'", path);
        rc = CLI_EXIT_FAIL;
    }
    fclose(f);
    if (rc == CLI_EXIT_OK && r.pending && !caps->tail_frames) {
        r.line = r.pending;
        fail(&r, "no frames follow this move or path (add frames N, or frames=N to it)");
        rc = CLI_EXIT_USAGE;
    }
    if (rc != CLI_EXIT_OK)
        cli_script_free(s);
    return rc;
}

void cli_script_free(cli_script *s)
{
    for (size_t i = 0; i < s->count; i++)
        free(s->cmd[i].path);
    free(s->cmd);
    memset(s, 0, sizeof *s);
}

/* ------------------------------------------------------------------ playing it */
int cli_lights_add(cli_lights *L, const lrr_light_source *l)
{
    if (L->count >= CLI_MAX_LIGHTS)
        return -1;
    L->light[L->count] = *l;
    L->motion[L->count].points = 0;
    L->count++;
    return 0;
}

void cli_lights_remove(cli_lights *L, size_t i)
{
    if (i >= L->count)
        return;
    size_t after = L->count - i - 1;
    memmove(L->light + i, L->light + i + 1, after * sizeof *L->light);
    memmove(L->motion + i, L->motion + i + 1, after * sizeof *L->motion);
    L->count--;
}

int cli_lights_apply(cli_lights *L, const cli_script_cmd *c)
{
    int light = c->kind == CS_REMOVE || c->kind == CS_MOVE || c->kind == CS_PATH;
    if (light && c->index >= L->count) /* after a key: unknown when the script was read */
        return -1;
    switch (c->kind) {
    case CS_LIGHT: return cli_lights_add(L, &c->light) == 0 ? 1 : -1;
    case CS_REMOVE: cli_lights_remove(L, c->index); return 1;
    case CS_MOVE:
    case CS_PATH: {
        cli_motion *m = &L->motion[c->index];
        m->from_here = c->kind == CS_MOVE;
        m->points = c->points + (size_t)m->from_here;
        if (m->from_here)
            memcpy(m->pts[0], L->light[c->index].position, sizeof m->pts[0]);
        memcpy(m->pts[m->from_here], c->pts, c->points * sizeof c->pts[0]);
        return 1;
    }
    }
    return 0;
}

/* Every moving light of L where it is in frame k (1..n) of n; 1 if one moved. A move leaves
 * from where the light was (frame k at k/n of the way), a path from its first point (frame 1
 * there, frame n at the last). */
static int place(cli_lights *L, unsigned k, unsigned n)
{
    int moved = 0;
    for (size_t l = 0; l < L->count; l++) {
        const cli_motion *m = &L->motion[l];
        if (m->points < 2)
            continue;
        double u = m->from_here ? (double)k / n : n > 1 ? (double)(k - 1) / (n - 1) : 1.0;
        double t = u * (double)(m->points - 1);
        size_t seg = t >= (double)(m->points - 1) ? m->points - 2 : (size_t)t;
        double f = t - (double)seg;
        for (int j = 0; j < 3; j++)
            L->light[l].position[j] = (float)((1 - f) * m->pts[seg][j] + f * m->pts[seg + 1][j]);
        moved = 1;
    }
    return moved;
}

int cli_player_next(cli_player *p, cli_lights *L, const cli_script_cmd **cmd)
{
    for (;;) {
        if (p->frame < p->frames) {
            p->frame++;
            p->moved = place(L, p->frame, p->frames);
            if (p->frame == p->frames) /* the lights stay where these frames left them */
                for (size_t l = 0; l < L->count; l++)
                    L->motion[l].points = 0;
            return CLI_PLAY_FRAME;
        }
        p->frame = p->frames = 0;
        if (p->pc == p->s->count) {
            if (p->tail_done || !p->tail)
                return CLI_PLAY_END;
            p->tail_done = 1;
            p->drawing = NULL;
            p->frames = p->tail;
            continue;
        }
        const cli_script_cmd *c = &p->s->cmd[p->pc++];
        if (c->kind == CS_FRAMES || c->kind == CS_DRAG) {
            p->drawing = c;
            p->frames = c->frames;
            continue;
        }
        *cmd = c;
        if ((c->kind == CS_MOVE || c->kind == CS_PATH) && c->frames) {
            p->drawing = c; /* the caller applies it, then its own frames follow */
            p->frames = c->frames;
        }
        return CLI_PLAY_CMD;
    }
}
