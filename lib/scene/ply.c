/* PLY files are checked before assimp reads them. Debian 12's assimp 5.2 trusts the file:
 *   - a header that never reaches "end_header", or a binary body shorter than the header
 *     declares, makes it read past its buffer (a crash);
 *   - a list whose count is larger than the file makes it allocate that many items first
 *     (an 830-byte file: 14.6 GB resident and 43 s before "File corrupted"; found by the
 *     scene fuzzer), and so does an element count far beyond the body;
 *   - a second element of one name ("vertex" twice) corrupts its heap (the scene fuzzer
 *     under ASan: a CHECK in the allocator's quarantine at a later free), so names are
 *     unique here.
 * lrr__ply_check reads the header strictly (the lines of the PLY specification, nothing
 * else, so assimp cannot read it differently) and then walks the body, element by element:
 * binary bodies by their byte sizes, ASCII bodies by their whitespace-separated tokens, and
 * every list count must fit in what is left of the file. A well-formed file passes
 * unchanged; the walk reads the file once. */
#include "config.h"
#include "scene/scene.h"

#include <inttypes.h>
#include <stdio.h>
#include <sys/types.h>
#include <stdlib.h>
#include <string.h>

#define MAX_ELEMENTS 64
#define MAX_PROPERTIES 512

typedef struct {
    uint8_t list;       /* 1 for "property list COUNT ITEM NAME" */
    uint8_t count_size; /* bytes of a list's count (an integer type) */
    uint8_t size;       /* bytes of the scalar, or of one list item */
} ply_property;

typedef struct {
    uint64_t count;
    size_t first, n; /* its properties: props[first .. first + n) */
    uint64_t row;    /* bytes of one instance when it has no list */
    int lists;
    char name[32];  /* for messages (truncated) */
    uint64_t hash;  /* of the whole name (FNV-1a), for repeated names */
} ply_element;

typedef struct {
    lrr_context *ctx;
    const char *path;
    FILE *f;
    uint64_t left; /* bytes of the body not read yet */
    int big_endian;
} ply_body;

/* Bytes of a PLY scalar type; 0 if unknown. *integer: whether it can count a list. */
static unsigned type_size(const char *t, int *integer)
{
    static const struct {
        const char *name;
        unsigned size;
        int integer;
    } types[] = {{"char", 1, 1},    {"uchar", 1, 1},  {"int8", 1, 1},      {"uint8", 1, 1},
                 {"short", 2, 1},   {"ushort", 2, 1}, {"int16", 2, 1},     {"uint16", 2, 1},
                 {"int", 4, 1},     {"uint", 4, 1},   {"int32", 4, 1},     {"uint32", 4, 1},
                 {"float", 4, 0},   {"float32", 4, 0}, {"double", 8, 0},   {"float64", 8, 0}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (strcmp(t, types[i].name) == 0) {
            if (integer)
                *integer = types[i].integer;
            return types[i].size;
        }
    return 0;
}

/* Splits line into at most max whitespace-separated words; returns how many (max + 1 if
 * there are more). */
static int split(char *line, char **w, int max)
{
    int n = 0;
    char *save = NULL; /* strtok_r: imports may run in several threads at once */
    for (char *p = strtok_r(line, " \t\r\n", &save); p; p = strtok_r(NULL, " \t\r\n", &save)) {
        if (n == max)
            return max + 1;
        w[n++] = p;
    }
    return n;
}

enum { LINE_EOF = -1, LINE_LONG = -2, LINE_NUL = -3 };

/* One header line without its '\n' into line (size bytes with the NUL); its length, or
 * LINE_EOF (nothing before the end), LINE_LONG, LINE_NUL (a NUL byte in it). */
static int read_line(FILE *f, char *line, size_t size)
{
    size_t n = 0;
    int c;
    while ((c = getc(f)) != EOF && c != '\n') {
        if (c == '\0')
            return LINE_NUL;
        if (n + 1 == size)
            return LINE_LONG;
        line[n++] = (char)c;
    }
    line[n] = '\0';
    return c == EOF && n == 0 ? LINE_EOF : (int)n;
}

static int parse_count(const char *s, uint64_t *out)
{
    if (!*s || strspn(s, "0123456789") != strlen(s) || strlen(s) > 19)
        return 0;
    *out = strtoull(s, NULL, 10);
    return 1;
}

static lrr_status header_error(lrr_context *ctx, const char *path, unsigned line,
                               const char *what)
{
    return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: PLY header line %u: %s", path, line, what);
}

/* Reads the header; leaves f at the body. */
static lrr_status read_header(lrr_context *ctx, const char *path, FILE *f, int *format,
                              ply_element *el, size_t *n_el, ply_property *props)
{
    char line[512];
    unsigned no = 0;
    size_t n_props = 0;
    *n_el = 0;
    *format = -1;
    for (;;) {
        int len = read_line(f, line, sizeof line);
        no++;
        if (len == LINE_EOF)
            return lrr__error(ctx, LRR_ERR_FORMAT,
                              "file %s: PLY header without an end_header line", path);
        if (len == LINE_LONG)
            return header_error(ctx, path, no, "longer than 511 characters");
        if (len == LINE_NUL)
            return header_error(ctx, path, no, "a NUL byte");
        char *w[6];
        int n = split(line, w, 5);
        if (no == 1) {
            if (n != 1 || strcmp(w[0], "ply") != 0)
                return header_error(ctx, path, no, "the file does not start with 'ply'");
            continue;
        }
        if (n == 0)
            continue;
        if (strcmp(w[0], "comment") == 0 || strcmp(w[0], "obj_info") == 0)
            continue;
        if (strcmp(w[0], "end_header") == 0) {
            if (n != 1)
                return header_error(ctx, path, no, "words after end_header");
            break;
        }
        if (strcmp(w[0], "format") == 0) {
            static const char *formats[] = {"ascii", "binary_little_endian",
                                            "binary_big_endian"};
            int fmt = -1;
            for (int i = 0; n == 3 && i < 3; i++)
                if (strcmp(w[1], formats[i]) == 0)
                    fmt = i;
            if (fmt < 0 || strcmp(w[2], "1.0") != 0 || *format >= 0)
                return header_error(ctx, path, no,
                                    "expected one 'format ascii|binary_little_endian|"
                                    "binary_big_endian 1.0'");
            *format = fmt;
        } else if (strcmp(w[0], "element") == 0) {
            uint64_t count;
            if (n != 3 || !parse_count(w[2], &count))
                return header_error(ctx, path, no, "expected 'element NAME COUNT'");
            if (*n_el == MAX_ELEMENTS)
                return header_error(ctx, path, no, "more than 64 elements");
            uint64_t h = 1469598103934665603u;
            for (const char *c = w[1]; *c; c++)
                h = (h ^ (unsigned char)*c) * 1099511628211u;
            /* assimp 5.2 merges a repeated element into the first and corrupts its heap (a
             * second "vertex" element; scene fuzzer, ASan): one element per name */
            for (size_t k = 0; k < *n_el; k++)
                if (el[k].hash == h && strncmp(el[k].name, w[1], sizeof el[k].name - 1) == 0)
                    return header_error(ctx, path, no, "an element name declared twice");
            ply_element *e = &el[(*n_el)++];
            *e = (ply_element){.count = count, .first = n_props, .hash = h};
            snprintf(e->name, sizeof e->name, "%s", w[1]);
        } else if (strcmp(w[0], "property") == 0) {
            if (*n_el == 0)
                return header_error(ctx, path, no, "a property before any element");
            if (n_props == MAX_PROPERTIES)
                return header_error(ctx, path, no, "more than 512 properties");
            ply_property p = {0};
            int integer = 0;
            if (n == 5 && strcmp(w[1], "list") == 0) {
                p.list = 1;
                p.count_size = (uint8_t)type_size(w[2], &integer);
                p.size = (uint8_t)type_size(w[3], NULL);
                if (!p.count_size || !integer || !p.size)
                    return header_error(ctx, path, no,
                                        "expected 'property list INTEGER_TYPE TYPE NAME'");
            } else if (n == 3 && strcmp(w[1], "list") != 0) {
                p.size = (uint8_t)type_size(w[1], NULL);
                if (!p.size)
                    return header_error(ctx, path, no, "unknown property type");
            } else {
                return header_error(ctx, path, no, "expected 'property TYPE NAME'");
            }
            ply_element *e = &el[*n_el - 1];
            props[n_props++] = p;
            e->n++;
            e->lists += p.list;
            e->row += p.list ? 0 : p.size;
        } else {
            return header_error(ctx, path, no, "not a PLY header line");
        }
    }
    if (*format < 0)
        return lrr__error(ctx, LRR_ERR_FORMAT, "file %s: PLY header without a format line",
                          path);
    for (size_t k = 0; k < *n_el; k++)
        if (el[k].count > 0 && el[k].n == 0) /* nothing bounds it by the file's size */
            return lrr__error(ctx, LRR_ERR_FORMAT,
                              "file %s: PLY element '%s' has %" PRIu64 " entries but no "
                              "properties", path, el[k].name, el[k].count);
    return LRR_OK;
}

static lrr_status body_error(const ply_body *b, const ply_element *e, uint64_t i,
                             const char *what)
{
    return lrr__error(b->ctx, LRR_ERR_FORMAT,
                      "file %s: PLY %s %" PRIu64 " of %" PRIu64 ": %s (truncated or corrupt)",
                      b->path, e->name, i, e->count, what);
}

/* Binary: reads n bytes (n <= 8) or fails. */
static int take(ply_body *b, unsigned n, unsigned char *out)
{
    if (b->left < n || fread(out, 1, n, b->f) != n)
        return 0;
    b->left -= n;
    return 1;
}

static int skip(ply_body *b, uint64_t n)
{
    if (b->left < n || n > (uint64_t)INT64_MAX || fseeko(b->f, (off_t)n, SEEK_CUR) != 0)
        return 0;
    b->left -= n;
    return 1;
}

static lrr_status walk_binary(ply_body *b, const ply_element *el, size_t n_el,
                              const ply_property *props)
{
    for (size_t k = 0; k < n_el; k++) {
        const ply_element *e = &el[k];
        if (!e->lists) { /* fixed size: one check */
            uint64_t bytes;
            if (__builtin_mul_overflow(e->count, e->row, &bytes) || !skip(b, bytes))
                return body_error(b, e, 0, "the elements need more bytes than the file has");
            continue;
        }
        for (uint64_t i = 0; i < e->count; i++)
            for (size_t q = e->first; q < e->first + e->n; q++) {
                const ply_property *p = &props[q];
                if (!p->list) {
                    if (!skip(b, p->size))
                        return body_error(b, e, i, "the file ends inside it");
                    continue;
                }
                unsigned char c[8] = {0};
                if (!take(b, p->count_size, c))
                    return body_error(b, e, i, "the file ends inside it");
                uint64_t count = 0;
                for (unsigned j = 0; j < p->count_size; j++)
                    count |= (uint64_t)c[b->big_endian ? p->count_size - 1 - j : j] << (8 * j);
                /* a negative signed count reads as a huge one: refused the same way */
                if (count > b->left / p->size || !skip(b, count * p->size))
                    return body_error(b, e, i, "a list longer than the rest of the file");
            }
    }
    return LRR_OK;
}

/* ASCII: the next whitespace-separated token into tok (false at the end). */
static int token(ply_body *b, char *tok, size_t size)
{
    int c;
    do {
        c = getc(b->f);
    } while (c == ' ' || c == '\t' || c == '\n' || c == '\r');
    size_t n = 0;
    while (c != EOF && c != ' ' && c != '\t' && c != '\n' && c != '\r') {
        if (n + 1 < size)
            tok[n++] = (char)c;
        c = getc(b->f);
    }
    tok[n] = '\0';
    return n > 0;
}

static lrr_status walk_ascii(ply_body *b, const ply_element *el, size_t n_el,
                             const ply_property *props)
{
    char tok[64];
    for (size_t k = 0; k < n_el; k++) {
        const ply_element *e = &el[k];
        for (uint64_t i = 0; i < e->count; i++)
            for (size_t q = e->first; q < e->first + e->n; q++) {
                if (!token(b, tok, sizeof tok))
                    return body_error(b, e, i, "the file ends inside it");
                if (!props[q].list)
                    continue;
                uint64_t count;
                long pos = ftell(b->f);
                uint64_t left = pos >= 0 && (uint64_t)pos <= b->left ? b->left - (uint64_t)pos : 0;
                /* each item takes at least one character and a separator */
                if (!parse_count(tok, &count) || count > left / 2 + 1)
                    return body_error(b, e, i, "a list count that is not a count the rest "
                                               "of the file can hold");
                for (uint64_t j = 0; j < count; j++)
                    if (!token(b, tok, sizeof tok))
                        return body_error(b, e, i, "the file ends inside a list");
            }
    }
    return LRR_OK;
}

lrr_status lrr__ply_check(lrr_context *ctx, const char *path, FILE *f, uint64_t file_size)
{
    ply_element el[MAX_ELEMENTS];
    ply_property *props = calloc(MAX_PROPERTIES, sizeof *props);
    if (!props)
        return lrr__error(ctx, LRR_ERR_NOMEM, "file %s: cannot allocate the PLY check", path);
    size_t n_el = 0;
    int format;
    lrr_status st = read_header(ctx, path, f, &format, el, &n_el, props);
    if (st == LRR_OK) {
        long pos = ftell(f);
        ply_body b = {ctx, path, f, 0, format == 2};
        if (format == 0) {
            b.left = file_size; /* ASCII: left is the file size, positions are absolute */
            st = walk_ascii(&b, el, n_el, props);
        } else {
            b.left = pos >= 0 && (uint64_t)pos <= file_size ? file_size - (uint64_t)pos : 0;
            st = walk_binary(&b, el, n_el, props);
        }
    }
    free(props);
    return st;
}
