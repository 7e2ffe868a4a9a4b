/* Scenes: validation of input triangles and materials, the built-in Cornell box, and the
 * choice of patch depths (docs/METHOD.md "Triangles" and "Patches"). */
#include "config.h"
#include "scene/scene.h"
#include "scene/texture.h"

#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* A triangle is degenerate when its area is negligible next to its longest edge squared:
 * such slivers have no well-defined normal and would only add noise to the hemicubes. */
static bool degenerate(const float *v)
{
    double l2 = 0;
    for (int e = 0; e < 3; e++) {
        const float *a = v + 3 * e, *b = v + 3 * ((e + 1) % 3);
        double s = 0;
        for (int j = 0; j < 3; j++)
            s += ((double)a[j] - b[j]) * ((double)a[j] - b[j]);
        if (s > l2)
            l2 = s;
    }
    return !(lrr__tri_area(v) > 1e-10 * l2) || l2 == 0;
}

lrr_status lrr__scene_from_arrays(lrr_context *ctx, size_t n_tri, const float *vert,
                                  const float *rho, const float *emission,
                                  const size_t *face_ids, const char *source, int builtin,
                                  lrr_scene **out)
{
    *out = NULL;
    const char *src = source ? source : "scene";
    if (n_tri == 0)
        return lrr__error(ctx, LRR_ERR_EMPTY, "%s: the scene has no triangles", src);
    size_t kept = 0;
    for (size_t t = 0; t < n_tri; t++) {
        size_t face = face_ids ? face_ids[t] : t;
        for (int j = 0; j < 9; j++)
            if (!isfinite(vert[9 * t + j]))
                return lrr__error(ctx, LRR_ERR_GEOMETRY,
                                  "%s: face %zu: vertex %d coordinate %d is %g (not finite)", src,
                                  face, j / 3, j % 3, (double)vert[9 * t + j]);
        for (int c = 0; c < 3; c++) {
            float r = rho[3 * t + c], e = emission[3 * t + c];
            if (!(r >= 0.0f && r < 1.0f))
                return lrr__error(ctx, LRR_ERR_MATERIAL,
                                  "%s: face %zu: reflectance[%d] = %g is outside [0,1)", src, face,
                                  c, (double)r);
            if (!(e >= 0.0f) || !isfinite(e))
                return lrr__error(ctx, LRR_ERR_MATERIAL,
                                  "%s: face %zu: emission[%d] = %g (must be finite and >= 0)", src,
                                  face, c, (double)e);
        }
        /* Finite coordinates near FLT_MAX can still span more area than a float holds:
         * subpatch areas (float) would become infinite, and every form factor with them. */
        double area = lrr__tri_area(vert + 9 * t);
        if (!(area <= FLT_MAX))
            return lrr__error(ctx, LRR_ERR_GEOMETRY,
                              "%s: face %zu: area %g is beyond float's range (rescale the "
                              "scene)",
                              src, face, area);
        if (!degenerate(vert + 9 * t))
            kept++;
    }
    if (kept == 0)
        return lrr__error(ctx, LRR_ERR_GEOMETRY,
                          "%s: all %zu triangles have zero area; nothing is left", src, n_tri);

    lrr_scene *s = lrr__zalloc(ctx, sizeof *s);
    if (!s)
        return lrr__error(ctx, LRR_ERR_NOMEM, "%s: cannot allocate the scene", src);
    lrr_status st;
    if ((st = lrr__calloc(ctx, &s->geom.vert, kept, 9 * sizeof(float), "triangle vertices")) ||
        (st = lrr__calloc(ctx, &s->rho, kept, 3 * sizeof(float), "reflectances")) ||
        (st = lrr__calloc(ctx, &s->emission, kept, 3 * sizeof(float), "emissions"))) {
        lrr_aligned_free(s->geom.vert);
        lrr_aligned_free(s->rho);
        free(s);
        return st;
    }
    size_t j = 0;
    for (size_t t = 0; t < n_tri; t++) {
        if (degenerate(vert + 9 * t))
            continue;
        memcpy(s->geom.vert + 9 * j, vert + 9 * t, 9 * sizeof(float));
        memcpy(s->rho + 3 * j, rho + 3 * t, 3 * sizeof(float));
        memcpy(s->emission + 3 * j, emission + 3 * t, 3 * sizeof(float));
        j++;
    }
    s->geom.n_tri = kept;
    s->skipped = n_tri - kept;
    s->builtin = builtin;
    s->ctx = lrr__context_retain(ctx);
    *out = s;
    return LRR_OK;
}

lrr_status lrr_scene_create(lrr_context *ctx, size_t n_triangles, const float *vertices,
                            const float *rho, const float *emission, const char *source,
                            lrr_scene **out)
{
    return lrr__scene_from_arrays(ctx, n_triangles, vertices, rho, emission, NULL, source,
                                  LRR__SCENE_FILE, out);
}

void lrr_scene_destroy(lrr_scene *s)
{
    if (!s)
        return;
    lrr__geometry_free(&s->geom);
    lrr_aligned_free(s->rho);
    lrr_aligned_free(s->emission);
    lrr__scene_textures_free(s->textures);
    lrr__context_release(s->ctx);
    free(s);
}

/* ------------------------------------------------------------------ Cornell box */
/* The Cornell box as published by the Cornell Program of Computer Graphics (data/README.md
 * says where): millimetres, y up; each quad's vertices as published. */
static const double cb_room[5][4][3] = {
    {{552.8, 0, 0}, {0, 0, 0}, {0, 0, 559.2}, {549.6, 0, 559.2}},                 /* floor */
    {{556, 548.8, 0}, {556, 548.8, 559.2}, {0, 548.8, 559.2}, {0, 548.8, 0}},     /* ceiling */
    {{549.6, 0, 559.2}, {0, 0, 559.2}, {0, 548.8, 559.2}, {556, 548.8, 559.2}},   /* back */
    {{552.8, 0, 0}, {549.6, 0, 559.2}, {556, 548.8, 559.2}, {556, 548.8, 0}},     /* left, red */
    {{0, 0, 559.2}, {0, 0, 0}, {0, 548.8, 0}, {0, 548.8, 559.2}},                 /* right, green */
};
static const double cb_front[4][3] = {{0, 0, 0}, {552.8, 0, 0}, {556, 548.8, 0}, {0, 548.8, 0}};
/* The light is lowered this far below the ceiling (mm) so the two never overlap. */
#define CB_LIGHT_GAP 0.05
static const double cb_light[4][3] = {
    {343, 548.8, 227}, {343, 548.8, 332}, {213, 548.8, 332}, {213, 548.8, 227}};
static const double cb_short_top[4][3] = {{130, 165, 65}, {82, 165, 225}, {240, 165, 272}, {290, 165, 114}};
static const double cb_tall_top[4][3] = {{423, 330, 247}, {265, 330, 296}, {314, 330, 456}, {472, 330, 406}};

static const float cb_white[3] = {0.725f, 0.71f, 0.68f};
static const float cb_red[3] = {0.63f, 0.065f, 0.05f};
static const float cb_green[3] = {0.14f, 0.45f, 0.091f};
static const float cb_light_e[3] = {17.0f, 12.0f, 4.0f};

typedef struct {
    float *v, *rho, *em;
    size_t n;
} tri_buf;

static void push_tri(tri_buf *b, const double *p0, const double *p1, const double *p2,
                     const float *rho, const float *em)
{
    const double *p[3] = {p0, p1, p2};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            b->v[9 * b->n + 3 * i + j] = (float)p[i][j];
    for (int c = 0; c < 3; c++) {
        b->rho[3 * b->n + c] = rho[c];
        b->em[3 * b->n + c] = em ? em[c] : 0.0f;
    }
    b->n++;
}

/* Adds quad q as two triangles, wound so that the normal points along `towards`
 * (dot(normal, towards) > 0); the published vertex order is not consistently oriented. */
static void push_quad(tri_buf *b, const double q[4][3], const double towards[3],
                      const float *rho, const float *em)
{
    double e1[3], e2[3];
    for (int j = 0; j < 3; j++) {
        e1[j] = q[1][j] - q[0][j];
        e2[j] = q[2][j] - q[0][j];
    }
    double nrm[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                     e1[0] * e2[1] - e1[1] * e2[0]};
    double d = nrm[0] * towards[0] + nrm[1] * towards[1] + nrm[2] * towards[2];
    if (d > 0) {
        push_tri(b, q[0], q[1], q[2], rho, em);
        push_tri(b, q[0], q[2], q[3], rho, em);
    } else {
        push_tri(b, q[0], q[2], q[1], rho, em);
        push_tri(b, q[0], q[3], q[2], rho, em);
    }
}

static void push_block(tri_buf *b, const double top[4][3])
{
    double c[3] = {0, 0, 0};
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 3; j++)
            c[j] += 0.25 * top[i][j];
    c[1] *= 0.5; /* the block's centre is half way down */
    double up[3] = {0, 1, 0}, down[3] = {0, -1, 0};
    push_quad(b, top, up, cb_white, NULL);
    double bottom[4][3];
    for (int i = 0; i < 4; i++) {
        bottom[i][0] = top[i][0];
        bottom[i][1] = 0;
        bottom[i][2] = top[i][2];
    }
    push_quad(b, bottom, down, cb_white, NULL);
    for (int i = 0; i < 4; i++) {
        int k = (i + 1) % 4;
        double side[4][3] = {{top[i][0], top[i][1], top[i][2]},
                             {top[k][0], top[k][1], top[k][2]},
                             {top[k][0], 0, top[k][2]},
                             {top[i][0], 0, top[i][2]}};
        double out[3];
        for (int j = 0; j < 3; j++)
            out[j] = 0.5 * (top[i][j] + top[k][j]) - c[j];
        out[1] = 0;
        push_quad(b, side, out, cb_white, NULL);
    }
}

lrr_status lrr_scene_cornell_box(lrr_context *ctx, int closed, lrr_scene **out)
{
    float v[40 * 9], rho[40 * 3], em[40 * 3];
    tri_buf b = {v, rho, em, 0};
    const double centre[3] = {278, 274.4, 279.6};
    for (int s = 0; s < 5; s++) {
        double towards[3];
        for (int j = 0; j < 3; j++)
            towards[j] = centre[j] - cb_room[s][0][j];
        /* every room surface faces the room's centre */
        double q0c[3];
        for (int j = 0; j < 3; j++)
            q0c[j] = 0.25 * (cb_room[s][0][j] + cb_room[s][1][j] + cb_room[s][2][j] +
                             cb_room[s][3][j]);
        for (int j = 0; j < 3; j++)
            towards[j] = centre[j] - q0c[j];
        const float *r = s == 3 ? cb_red : s == 4 ? cb_green : cb_white;
        push_quad(&b, cb_room[s], towards, r, NULL);
    }
    double light[4][3];
    memcpy(light, cb_light, sizeof light);
    for (int i = 0; i < 4; i++)
        light[i][1] -= CB_LIGHT_GAP;
    const double down[3] = {0, -1, 0};
    push_quad(&b, light, down, cb_white, cb_light_e);
    push_block(&b, cb_short_top);
    push_block(&b, cb_tall_top);
    if (closed) {
        const double towards[3] = {0, 0, 1};
        push_quad(&b, cb_front, towards, cb_white, NULL);
    }
    return lrr__scene_from_arrays(ctx, b.n, v, rho, em, NULL,
                                  closed ? "cornell-closed" : "cornell",
                                  closed ? LRR__SCENE_CORNELL_CLOSED : LRR__SCENE_CORNELL, out);
}

lrr_status lrr_scene_builtin(lrr_context *ctx, const char *name, lrr_scene **out)
{
    *out = NULL;
    if (strcmp(name, "cornell") == 0)
        return lrr_scene_cornell_box(ctx, 0, out);
    if (strcmp(name, "cornell-closed") == 0)
        return lrr_scene_cornell_box(ctx, 1, out);
    return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                      "'%s' is not a built-in scene (known: cornell, cornell-closed)", name);
}

/* ------------------------------------------------------------------ subdivision */
/* Depth at which triangle area a drops to <= max_area (4 equal children per split). */
static unsigned depth_for(double a, double max_area)
{
    unsigned dpt = 0;
    if (!(max_area > 0))
        return 0;
    while (a > max_area && dpt < 24) {
        a *= 0.25;
        dpt++;
    }
    return dpt;
}

static double patch_count(const lrr_scene *s, double max_area)
{
    double k = 0;
    for (size_t t = 0; t < s->geom.n_tri; t++)
        k += ldexp(1.0, 2 * (int)depth_for(lrr__tri_area(s->geom.vert + 9 * t), max_area));
    return k;
}

static int cmp_double_desc(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x < y) - (x > y);
}

/* The patch count is a non-increasing step function of the threshold that changes only at
 * area_t / 4^j; search those candidates for the count closest to target. */
static lrr_status choose_threshold(lrr_scene *s, size_t target, double *best_area)
{
    size_t nt = s->geom.n_tri, nc;
    const int J = 13; /* up to 4^12 patches per triangle */
    if (!lrr__mul_size(nt, (size_t)J, &nc))
        return lrr__error(s->ctx, LRR_ERR_OVERFLOW, "too many triangles");
    double *cand;
    lrr_status st = lrr__calloc(s->ctx, &cand, nc, sizeof(double), "threshold candidates");
    if (st)
        return st;
    for (size_t t = 0; t < nt; t++) {
        double a = lrr__tri_area(s->geom.vert + 9 * t);
        for (int j = 0; j < J; j++)
            cand[t * J + j] = a * ldexp(1.0, -2 * j) * (1 + 1e-12);
    }
    qsort(cand, nc, sizeof(double), cmp_double_desc);
    /* counts grow as the threshold shrinks: binary search the first candidate reaching target */
    size_t lo = 0, hi = nc - 1;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (patch_count(s, cand[mid]) >= (double)target)
            hi = mid;
        else
            lo = mid + 1;
    }
    double a_hi = cand[lo];
    double k_hi = patch_count(s, a_hi);
    *best_area = a_hi;
    if (lo > 0) {
        double k_lo = patch_count(s, cand[lo - 1]);
        if (fabs(k_lo - (double)target) <= fabs(k_hi - (double)target))
            *best_area = cand[lo - 1];
    }
    lrr_aligned_free(cand);
    return LRR_OK;
}

lrr_status lrr_scene_subdivide(lrr_scene *s, const lrr_subdivision *user)
{
    lrr_subdivision o = lrr_subdivision_defaults();
    const lrr_subdivision *opts = &o;
    lrr_status st = lrr__options_read(s->ctx, user, sizeof o,
                                      LRR__FIRST_SIZE(lrr_subdivision, levels), &o,
                                      "lrr_subdivision");
    if (st)
        return st;
    if (opts->levels > 10)
        return lrr__error(s->ctx, LRR_ERR_INVALID_ARG, "levels = %u: at most 10", opts->levels);
    if (!(opts->max_patch_area >= 0) || !isfinite(opts->max_patch_area))
        return lrr__error(s->ctx, LRR_ERR_INVALID_ARG,
                          "max_patch_area = %g: must be finite and >= 0", opts->max_patch_area);
    double max_area = opts->max_patch_area;
    if (opts->target_patches > 0 && (st = choose_threshold(s, opts->target_patches, &max_area)))
        return st;
    lrr__geometry g = s->geom;
    uint8_t *depth;
    size_t *patch0;
    if ((st = lrr__calloc(s->ctx, &depth, g.n_tri, 1, "patch depths")))
        return st;
    if ((st = lrr__calloc(s->ctx, &patch0, g.n_tri + 1, sizeof(size_t), "patch index"))) {
        lrr_aligned_free(depth);
        return st;
    }
    for (size_t t = 0; t < g.n_tri; t++)
        depth[t] = (uint8_t)depth_for(lrr__tri_area(g.vert + 9 * t), max_area);
    g.depth = depth;
    g.patch0 = patch0;
    g.levels = opts->levels;
    if ((st = lrr__geometry_index(s->ctx, &g, SIZE_MAX))) {
        lrr_aligned_free(depth);
        lrr_aligned_free(patch0);
        return st;
    }
    lrr_aligned_free(s->geom.depth);
    lrr_aligned_free(s->geom.patch0);
    lrr_aligned_free(s->geom.sub0);
    lrr_aligned_free(s->geom.first);
    s->geom = g;
    s->max_patch_area = max_area;
    return LRR_OK;
}

void lrr_scene_get_info(const lrr_scene *s, lrr_scene_info *out, size_t out_size)
{
    lrr_scene_info all, *info = &all;
    memset(info, 0, sizeof *info);
    info->triangles = s->geom.n_tri;
    info->skipped = s->skipped;
    if (s->geom.depth) {
        info->patches = s->geom.k;
        info->subpatches = s->geom.n;
        info->d = s->geom.d;
    }
    info->max_patch_area = s->max_patch_area;
    if (s->textures) {
        info->textures = s->textures->n_tex;
        info->clamped_texels = s->textures->clamped_texels;
    }
    for (int j = 0; j < 3; j++) {
        info->bounds_min[j] = INFINITY;
        info->bounds_max[j] = -INFINITY;
    }
    for (size_t t = 0; t < s->geom.n_tri; t++) {
        info->area += lrr__tri_area(s->geom.vert + 9 * t);
        if (s->emission[3 * t] > 0 || s->emission[3 * t + 1] > 0 || s->emission[3 * t + 2] > 0)
            info->emitters++;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                double x = s->geom.vert[9 * t + 3 * i + j];
                if (x < info->bounds_min[j]) info->bounds_min[j] = x;
                if (x > info->bounds_max[j]) info->bounds_max[j] = x;
            }
    }
    lrr__info_write(out, out_size, info, sizeof *info);
}

size_t lrr_scene_subpatch_at(const lrr_scene *s, size_t triangle, double b1, double b2)
{
    if (!s->geom.depth || triangle >= s->geom.n_tri || !(b1 >= 0) || !(b2 >= 0) ||
        !(b1 + b2 <= 1))
        return (size_t)-1;
    return lrr__subpatch_at(&s->geom, triangle, b1, b2);
}

lrr_status lrr_scene_subpatches(const lrr_scene *s, float *centre, float *normal, float *area,
                                float *rho, float *emission)
{
    if (!s->geom.depth)
        return lrr__error(s->ctx, LRR_ERR_INVALID_ARG,
                          "the scene is not subdivided: call lrr_scene_subdivide first");
    lrr__subpatch_frames(&s->geom, centre, normal, area);
    const lrr__scene_textures *tx = s->textures;
    #pragma omp parallel for schedule(dynamic, 16)
    for (size_t t = 0; t < s->geom.n_tri; t++) {
        /* A textured triangle's subpatches take the texture's mean over their UV triangles
         * (texture.c); the texture already holds the material's factor and the clamp. */
        uint32_t rt = tx ? tx->rho_tex[t] : LRR__NO_TEXTURE;
        uint32_t et = tx ? tx->em_tex[t] : LRR__NO_TEXTURE;
        unsigned depth = s->geom.depth[t] + s->geom.levels;
        for (size_t i = s->geom.sub0[t]; i < s->geom.sub0[t + 1]; i++) {
            double uv[6], r[3], e[3];
            if ((rho && rt != LRR__NO_TEXTURE) || (emission && et != LRR__NO_TEXTURE))
                lrr__subtriangle_uv(tx->uv + 6 * t, depth, i - s->geom.sub0[t], uv);
            if (rho && rt != LRR__NO_TEXTURE)
                lrr__texture_mean(&tx->tex[rt], uv, r);
            if (emission && et != LRR__NO_TEXTURE)
                lrr__texture_mean(&tx->tex[et], uv, e);
            for (int c = 0; c < 3; c++) {
                if (rho)
                    rho[3 * i + c] = rt != LRR__NO_TEXTURE ? fminf((float)r[c], LRR__RHO_MAX)
                                                           : s->rho[3 * t + c];
                if (emission)
                    emission[3 * i + c] = et != LRR__NO_TEXTURE ? (float)e[c]
                                                                : s->emission[3 * t + c];
            }
        }
    }
    return LRR_OK;
}

lrr_status lrr__scene_attach_textures(lrr_scene *s, size_t n_in, const float *vert_in,
                                      lrr__scene_textures *t)
{
    size_t n = s->geom.n_tri, j = 0;
    for (size_t i = 0; i < n_in && j < n; i++) {
        if (degenerate(vert_in + 9 * i))
            continue;
        memmove(t->uv + 6 * j, t->uv + 6 * i, 6 * sizeof *t->uv);
        t->rho_tex[j] = t->rho_tex[i];
        t->em_tex[j] = t->em_tex[i];
        j++;
    }
    if (j != n) {
        lrr__scene_textures_free(t);
        return lrr__error(s->ctx, LRR_ERR_DIM,
                          "textures: %zu of %zu textured triangles match the scene's %zu", j,
                          n_in, n);
    }
    t->n_tri = n;
    lrr__scene_textures_free(s->textures);
    s->textures = t;
    return LRR_OK;
}
