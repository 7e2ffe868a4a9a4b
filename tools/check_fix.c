/* lrr check --fix: the repaired scene as OBJ + MTL, in one linear pass over the report.
 *
 * What it keeps: vertex sharing (each distinct position written once, faces indexed into
 * them: exact float positions, -0 = +0), the file's material names (lrr_check_report's
 * material_names; m0, m1, ... for a built-in scene) with the reflectance and emission lrr
 * read as Kd and Ke, its objects/groups ('g' when the group changes) and one 'usemtl' per
 * run of faces with the same material. Polygons come out as the triangles lrr made of them;
 * textures and other MTL statements are not carried over (lrr reads none of them).
 * The previous writer gave each triangle its own three vertices, a 'usemtl' per face and
 * numbered materials, and matched materials pairwise (quadratic in the worst case). Measured
 * (CPU seconds of the writing alone, names included; loaded 2-core machine): two bunny rooms,
 * 145k triangles, 0.63-0.72 s before, 0.23-0.29 s now (22.2 MB -> 5.1 MB); four FZK houses,
 * 144k triangles, 1.5-2.0 s before, 0.16-0.24 s now (19.8 MB -> 4.7 MB).
 *
 * Both files go through the atomic writer (cli_outfile), written in full before either is
 * renamed: a failure leaves no half-written file and no new .mtl beside an old .obj. */
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"

/* ------------------------------------------------------------------ keys → first-seen numbers */
/* Open addressing over fixed-size keys of `words` 32-bit words; a key's number is the order
 * of its first insertion, and keys[number * words] holds it. */
typedef struct keytab {
    size_t words, count, cap; /* cap: a power of two, at least twice the most keys */
    uint32_t *keys;
    size_t *slot; /* number + 1, 0 = empty */
} keytab;

static int keytab_init(keytab *k, size_t words, size_t most)
{
    size_t cap = 16;
    while (cap < 2 * most && cap < SIZE_MAX / 4)
        cap *= 2;
    *k = (keytab){.words = words, .cap = cap};
    if (most > SIZE_MAX / sizeof(uint32_t) / words || cap < 2 * most)
        return -1;
    k->keys = malloc((most ? most : 1) * words * sizeof(uint32_t));
    k->slot = calloc(cap, sizeof *k->slot);
    return k->keys && k->slot ? 0 : -1;
}

static void keytab_free(keytab *k)
{
    free(k->keys);
    free(k->slot);
}

/* The number of key (inserted if new); *fresh = 1 when it was. */
static size_t keytab_id(keytab *k, const uint32_t *key, int *fresh)
{
    uint64_t h = 1469598103934665603u; /* FNV-1a over the words */
    for (size_t i = 0; i < k->words; i++)
        h = (h ^ key[i]) * 1099511628211u;
    size_t i = (size_t)(h ^ (h >> 29)) & (k->cap - 1);
    for (;; i = (i + 1) & (k->cap - 1)) {
        size_t s = k->slot[i];
        if (s == 0)
            break;
        if (memcmp(k->keys + (s - 1) * k->words, key, k->words * sizeof *key) == 0) {
            *fresh = 0;
            return s - 1;
        }
    }
    memcpy(k->keys + k->count * k->words, key, k->words * sizeof *key);
    k->slot[i] = ++k->count;
    *fresh = 1;
    return k->count - 1;
}

static uint32_t float_bits(float x)
{
    uint32_t u;
    x += 0.0f; /* -0 → +0: the same position */
    memcpy(&u, &x, sizeof u);
    return u;
}

/* ------------------------------------------------------------------ the repair, numbered */
/* What the writer needs, each array one entry per kept triangle (in the report's order) */
typedef struct fixed_mesh {
    size_t n_tri, n_vert, n_mat;
    size_t *corner;     /* 3 per kept triangle: vertex numbers, flipped where fix says */
    size_t *mat;        /* per kept triangle */
    size_t *src;        /* per kept triangle: the report's triangle */
    keytab verts, mats; /* vertex keys: x, y, z bits; material keys: source material, ρ, E */
    size_t *mat_first;  /* per material: a report triangle that uses it */
    size_t *variant;    /* per material: how many before it share its file's material */
    size_t *n_variants; /* per file material: the count so far */
} fixed_mesh;

static void fixed_free(fixed_mesh *m)
{
    free(m->corner);
    free(m->mat);
    free(m->src);
    free(m->mat_first);
    free(m->variant);
    free(m->n_variants);
    keytab_free(&m->verts);
    keytab_free(&m->mats);
}

static int fixed_number(const lrr_check_report *r, fixed_mesh *m)
{
    size_t n = r->triangles;
    *m = (fixed_mesh){0};
    if (n > SIZE_MAX / 3 / sizeof(size_t) || keytab_init(&m->verts, 3, 3 * n) != 0 ||
        keytab_init(&m->mats, 7, n) != 0)
        return -1;
    m->corner = malloc((n ? 3 * n : 1) * sizeof *m->corner);
    m->mat = malloc((n ? n : 1) * sizeof *m->mat);
    m->src = malloc((n ? n : 1) * sizeof *m->src);
    m->mat_first = malloc((n ? n : 1) * sizeof *m->mat_first);
    m->variant = malloc((n ? n : 1) * sizeof *m->variant);
    m->n_variants = calloc(r->n_materials + 1, sizeof *m->n_variants);
    if (!m->corner || !m->mat || !m->src || !m->mat_first || !m->variant || !m->n_variants)
        return -1;
    static const int order[2][3] = {{0, 1, 2}, {0, 2, 1}};
    for (size_t t = 0; t < n; t++) {
        if (r->fix[t] == 1)
            continue; /* degenerate: dropped */
        const int *o = order[r->fix[t] == 2];
        int fresh;
        for (int i = 0; i < 3; i++) {
            const float *p = r->vert + 9 * t + 3 * o[i];
            uint32_t key[3] = {float_bits(p[0]), float_bits(p[1]), float_bits(p[2])};
            m->corner[3 * m->n_tri + i] = keytab_id(&m->verts, key, &fresh);
        }
        /* a material is the file's material with the ρ and E lrr read for it (a file's
         * material is one pair; a built-in scene has only the pairs) */
        uint32_t mk[7] = {r->material ? (uint32_t)r->material[t] : 0};
        for (int c = 0; c < 3; c++) {
            mk[1 + c] = float_bits(r->rho[3 * t + c]);
            mk[4 + c] = float_bits(r->emission[3 * t + c]);
        }
        size_t id = keytab_id(&m->mats, mk, &fresh);
        if (fresh) {
            m->mat_first[id] = t;
            m->variant[id] = r->material && r->material[t] < r->n_materials
                                 ? m->n_variants[r->material[t]]++
                                 : 0;
        }
        m->mat[m->n_tri] = id;
        m->src[m->n_tri++] = t;
    }
    m->n_vert = m->verts.count;
    m->n_mat = m->mats.count;
    return 0;
}

/* ------------------------------------------------------------------ writing */
/* A name fit for one 'newmtl'/'usemtl'/'g' line: control characters become '_'. */
static void put_name(FILE *f, const char *s)
{
    for (; *s; s++)
        fputc((unsigned char)*s < 0x20 || *s == 0x7f ? '_' : *s, f);
}

/* Material `id`'s name: the file's (with "_N" for its N-th other ρ/E pair, which a file's
 * material does not have unless the library derives ρ per face), or mID. */
static void put_material(FILE *f, const lrr_check_report *r, const fixed_mesh *m, size_t id)
{
    size_t t = m->mat_first[id];
    const char *name = r->material_names && r->material[t] < r->n_materials
                           ? r->material_names[r->material[t]]
                           : "";
    if (!*name) {
        fprintf(f, "m%zu", id);
        return;
    }
    put_name(f, name);
    if (m->variant[id])
        fprintf(f, "_%zu", m->variant[id] + 1);
}

/* The shortest %g that reads back as x (as the file most likely wrote it: 1.9, not
 * 1.89999998); %.9g always does. */
static void put_float(FILE *f, float x)
{
    char buf[32];
    for (int prec = 6; prec < 9; prec++) {
        snprintf(buf, sizeof buf, "%.*g", prec, (double)x);
        if (strtof(buf, NULL) == x) {
            fputs(buf, f);
            return;
        }
    }
    fprintf(f, "%.9g", (double)x);
}

/* 'KEY x y z\n' */
static void put_vec(FILE *f, const char *key, const float *p)
{
    fputs(key, f);
    for (int i = 0; i < 3; i++) {
        fputc(' ', f);
        put_float(f, p[i]);
    }
    fputc('\n', f);
}

static void write_mtl(FILE *f, const lrr_check_report *r, const fixed_mesh *m)
{
    fprintf(f, "# written by lrr check --fix: Kd = reflectance, Ke = emission as lrr read "
               "them\n");
    for (size_t id = 0; id < m->n_mat; id++) {
        size_t t = m->mat_first[id];
        fputs("newmtl ", f);
        put_material(f, r, m, id);
        fputc('\n', f);
        put_vec(f, "Kd", r->rho + 3 * t);
        put_vec(f, "Ke", r->emission + 3 * t);
    }
}

static void write_obj(FILE *f, const lrr_check_report *r, const fixed_mesh *m,
                      const char *mtl_base)
{
    fprintf(f, "# written by lrr check --fix: %zu vertices, %zu triangles, %zu materials\n"
               "mtllib ", m->n_vert, m->n_tri, m->n_mat);
    put_name(f, mtl_base);
    fputc('\n', f);
    for (size_t v = 0; v < m->n_vert; v++) {
        float p[3];
        memcpy(p, m->verts.keys + 3 * v, sizeof p);
        put_vec(f, "v", p);
    }
    size_t group = SIZE_MAX, mat = SIZE_MAX;
    for (size_t i = 0; i < m->n_tri; i++) {
        size_t t = m->src[i];
        if (r->group && r->group[t] != group) {
            group = r->group[t];
            if (group < r->n_groups && *r->group_names[group]) {
                fputs("g ", f);
                put_name(f, r->group_names[group]);
                fputc('\n', f);
                mat = SIZE_MAX; /* a new group restates its material */
            }
        }
        if (m->mat[i] != mat) {
            mat = m->mat[i];
            fputs("usemtl ", f);
            put_material(f, r, m, mat);
            fputc('\n', f);
        }
        fprintf(f, "f %zu %zu %zu\n", m->corner[3 * i] + 1, m->corner[3 * i + 1] + 1,
                m->corner[3 * i + 2] + 1);
    }
}

/* Both files are written to temporaries and flushed before either is renamed, so a failed
 * write (a full disk, a size limit) changes neither; returns the exit status. */
static int write_both(const lrr_check_report *r, const fixed_mesh *m, const char *path,
                      const char *mtl, const char *mtl_base)
{
    cli_outfile out[2];
    const char *name[2] = {mtl, path};
    for (int i = 0; i < 2; i++)
        if (cli_outfile_open(&out[i], name[i]) != 0) {
            int e = errno;
            if (i)
                cli_outfile_abort(&out[0]);
            return cli_fail(LRR_ERR_IO, "'%s': cannot create: %s", name[i], strerror(e));
        }
    write_mtl(out[0].f, r, m);
    write_obj(out[1].f, r, m, mtl_base);
    for (int i = 0; i < 2; i++)
        if (fflush(out[i].f) != 0 || ferror(out[i].f)) {
            int e = errno;
            cli_outfile_abort(&out[0]);
            cli_outfile_abort(&out[1]);
            return cli_fail(LRR_ERR_IO, "'%s': write failed: %s", name[i], strerror(e));
        }
    if (cli_outfile_commit(&out[0]) != 0) {
        int e = errno;
        cli_outfile_abort(&out[1]);
        return cli_fail(LRR_ERR_IO, "'%s': cannot write: %s", mtl, strerror(e));
    }
    if (cli_outfile_commit(&out[1]) != 0)
        return cli_fail(LRR_ERR_IO, "'%s': cannot write: %s", path, strerror(errno));
    return CLI_EXIT_OK;
}

/* OUT.obj + OUT.mtl (the extension replaced, or appended). */
int check_write_fixed(const lrr_check_report *r, const char *path)
{
    size_t len = strlen(path);
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    size_t stem = dot && (!slash || dot > slash) ? (size_t)(dot - path) : len;
    fixed_mesh m;
    int numbered = fixed_number(r, &m);
    char *mtl = malloc(stem + 5);
    if (!mtl || numbered != 0) {
        free(mtl);
        fixed_free(&m);
        return cli_fail(LRR_ERR_NOMEM, "--fix: out of memory for %zu triangles", r->triangles);
    }
    memcpy(mtl, path, stem);
    memcpy(mtl + stem, ".mtl", 5);
    const char *mtl_base = strrchr(mtl, '/') ? strrchr(mtl, '/') + 1 : mtl;
    int rc = write_both(r, &m, path, mtl, mtl_base);
    free(mtl);
    fixed_free(&m);
    return rc;
}
