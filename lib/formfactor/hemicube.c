/* Hemicube form factors: one software z-buffer hemicube at each subpatch centre gives one
 * row of F̄ (F̄_ip = F_{i→p}/d_p), docs/METHOD.md "Form factors".
 *
 * Per receiver i with centre x and unit normal N:
 *   - a frame (U, V, N), rotated about N by a pseudo-random angle drawn from (seed, i), so
 *     aliasing of the pixel grid does not line up across receivers yet results are
 *     reproducible whatever the thread count;
 *   - five faces: the top (R×R, looking along N) and four sides (R wide, R/2 high, above the
 *     tangent plane only);
 *   - the *input triangles* are rasterised (not the subdivision), so a hemicube's cost does
 *     not depend on k or d; the item buffer holds the triangle id, and the visible point's
 *     barycentric coordinates in its triangle give the patch;
 *   - back faces write depth and LRR__ITEM_BACK (they occlude but carry nothing);
 *   - row_p = Σ multiplier(pixel) over pixels showing patch p, and the receiver's back-face
 *     share = Σ multiplier(pixel) over pixels showing a back face (the light-leak indicator
 *     of lrr_operator_info: light that should reach the receiver through a surface modelled
 *     the wrong way round is lost), summed in the same pass over the pixels.
 *
 * The rasteriser (watertight: a closed room's rows sum to 1 to rounding) is
 * hemicube_raster.c, the integration hemicube_integrate.c; their SIMD
 * steps come from one table per build (lrr__hemi_simd_pick: hemicube_avx2.c,
 * hemicube_avx512.c), chosen from core/cpu.h's level (LRR_SIMD, else the widest the CPU
 * runs).
 */
#include "config.h"
#include "formfactor/hemicube_raster.h"

#include <math.h>
#include <omp.h>
#include <stdlib.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* ------------------------------------------------------------------ multiplier map */
lrr_status lrr__multiplier_map_create(lrr_context *ctx, unsigned res, lrr__multiplier_map *m)
{
    memset(m, 0, sizeof *m);
    if (res < 8 || res > 4096 || res % 2)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "hemicube resolution %u: must be even and in 8..4096", res);
    lrr_status st;
    size_t rr = (size_t)res * res;
    if ((st = lrr__calloc(ctx, &m->top, rr, sizeof(double), "hemicube top multipliers")))
        return st;
    if ((st = lrr__calloc(ctx, &m->side, rr / 2, sizeof(double), "hemicube side multipliers"))) {
        lrr_aligned_free(m->top);
        return st;
    }
    m->res = res;
    const double h = 2.0 / res, dA = h * h;
    double sum = 0;
    for (unsigned r = 0; r < res; r++)
        for (unsigned c = 0; c < res; c++) {
            double x = -1 + (c + 0.5) * h, y = -1 + (r + 0.5) * h;
            double q = x * x + y * y + 1;
            m->top[(size_t)r * res + c] = dA / (M_PI * q * q);
            sum += m->top[(size_t)r * res + c];
        }
    for (unsigned r = 0; r < res / 2; r++)
        for (unsigned c = 0; c < res; c++) {
            double a = -1 + (c + 0.5) * h, z = (r + 0.5) * h;
            double q = a * a + z * z + 1;
            m->side[(size_t)r * res + c] = z * dA / (M_PI * q * q);
            sum += 4 * m->side[(size_t)r * res + c];
        }
    /* The midpoint rule misses the exact total by O(1/R²); normalise so that a fully covered
     * hemisphere gives exactly 1 (closed scenes must conserve energy). */
    m->raw_sum = sum;
    for (size_t i = 0; i < rr; i++)
        m->top[i] /= sum;
    for (size_t i = 0; i < rr / 2; i++)
        m->side[i] /= sum;
    return LRR_OK;
}

void lrr__multiplier_map_free(lrr__multiplier_map *m)
{
    lrr_aligned_free(m->top);
    lrr_aligned_free(m->side);
    memset(m, 0, sizeof *m);
}

/* ------------------------------------------------------------------ per-triangle data */
typedef lrr__tri_info tri_info;
_Static_assert(sizeof(tri_info) == LRR__HEMICUBE_TRI_BYTES, "budget.c counts tri_info's size");
typedef lrr__hemi_face face;
typedef lrr__hemi_ctx hemi_ctx;
typedef lrr__hemi_scratch scratch;

/* ------------------------------------------------------------------ SIMD steps */
const lrr__hemi_simd *lrr__hemi_simd_pick(lrr__isa isa)
{
#if defined(__x86_64__) || defined(__i386__)
    if (isa == LRR__ISA_AVX512)
        return &lrr__hemi_simd_avx512;
    if (isa == LRR__ISA_AVX2)
        return &lrr__hemi_simd_avx2;
#endif
    (void)isa;
    return NULL;
}

/* ------------------------------------------------------------------ one hemicube */
/* Receiver i's centre x, unit normal N and tangent frame (U, V): rotated about N by an angle
 * drawn from (seed, i) when rotate. */
static void receiver_frame(const lrr__geometry *g, size_t i, uint64_t seed, int rotate,
                           double x[3], double N[3], double U[3], double Vv[3])
{
    double v[9];
    lrr__subpatch_vertices(g, i, v);
    double e1[3], e2[3];
    for (int j = 0; j < 3; j++) {
        x[j] = (v[j] + v[3 + j] + v[6 + j]) / 3;
        e1[j] = v[3 + j] - v[j];
        e2[j] = v[6 + j] - v[j];
    }
    lrr__cross3(e1, e2, N);
    lrr__normalize3(N);
    /* tangent frame, then the per-receiver random rotation about N */
    double helper[3] = {1, 0, 0};
    if (fabs(N[0]) > 0.6) { helper[0] = 0; helper[1] = 1; }
    double U0[3], V0[3];
    lrr__cross3(helper, N, U0);
    lrr__normalize3(U0);
    lrr__cross3(N, U0, V0);
    /* drawn from the subpatch's scene-order index, so a cluster hierarchy's renumbering
     * leaves every receiver's hemicube the same */
    const size_t id = g->origin ? g->origin[i] : i;
    double theta =
        rotate ? 2 * M_PI * (double)(lrr__splitmix64(seed ^ lrr__splitmix64(id)) >> 11) *
                     0x1.0p-53
               : 0;
    double ct = cos(theta), st = sin(theta);
    for (int j = 0; j < 3; j++)
        U[j] = ct * U0[j] + st * V0[j];
    lrr__cross3(N, U, Vv);
}

/* Receiver i's row into out (NULL: patch ids into sc->item for the device); its back-face
 * share into *back when back is not NULL. */
static void hemicube_row(const hemi_ctx *h, size_t i, uint64_t seed, int rotate, scratch *sc,
                         float *out, double *back)
{
    const lrr__geometry *g = h->g;
    unsigned R = h->mm->res;
    double x[3], N[3], U[3], Vv[3];
    receiver_frame(g, i, seed, rotate, x, N, U, Vv);

    size_t rr = (size_t)R * R;
    face faces[5];
    for (int fi = 0; fi < 5; fi++) {
        face *f = &faces[fi];
        f->W = (int)R;
        f->H = fi == 0 ? (int)R : (int)R / 2;
        f->side = fi != 0;
        f->sy = fi == 0 ? h->sy_top : h->sy_side;
        f->weight = fi == 0 ? h->mm->top : h->mm->side;
        f->prefix = fi == 0 ? h->pre_top : h->pre_side;
        f->depth = sc->depth + (fi == 0 ? 0 : rr + (size_t)(fi - 1) * rr / 2);
        f->item = sc->item + (fi == 0 ? 0 : rr + (size_t)(fi - 1) * rr / 2);
        f->code = sc->code + (fi == 0 ? 0 : rr + (size_t)(fi - 1) * rr / 2);
        if (fi == 0) {
            memcpy(f->fwd, N, sizeof N);
            memcpy(f->right, U, sizeof U);
            memcpy(f->up, Vv, sizeof Vv);
        } else {
            const double *ax = (fi == 1 || fi == 2) ? U : Vv;
            double sgn = (fi == 1 || fi == 3) ? 1 : -1;
            for (int j = 0; j < 3; j++)
                f->fwd[j] = sgn * ax[j];
            memcpy(f->up, N, sizeof N);
            lrr__cross3(f->up, f->fwd, f->right);
        }
    }
    if (h->rc) {
        /* area sampling: the points are drawn from (seed, the scene-order id, face, pixel),
         * so a row does not depend on the threads or a cluster renumbering */
        double corners[9];
        if (h->area_origins)
            lrr__subpatch_vertices(g, i, corners);
        const uint64_t key = lrr__splitmix64(seed ^ lrr__splitmix64(
                                 0x5bd1e995u + (g->origin ? g->origin[i] : i)));
        for (int fi = 0; fi < 5; fi++)
            lrr__raycast_face(h, x, N, h->area_origins ? corners : NULL,
                              lrr__splitmix64(key + (uint64_t)fi), &faces[fi]);
    } else {
        lrr__hemi_raster_faces(h, x, N, faces, sc);
    }
    size_t cols = h->by_subpatch ? g->n : g->k;
    if (out)
        memset(sc->row, 0, cols * sizeof(double));
    double back_sum = 0;
    /* the CPU's own buffers are cleared as they are integrated (a memset of both a hemicube
     * costs 2.5% of a Cornell R 64 profile); the device's item buffers are its input */
    const int clear = out && !h->rc;
    for (int fi = 0; fi < 5; fi++)
        back_sum += lrr__hemi_integrate_face(h, x, &faces[fi], out ? sc->row : NULL, clear);
    sc->clean = clear;
    if (back)
        *back = back_sum;
    if (!out) /* device integration: the item buffer now holds patch ids */
        return;
    if (h->by_subpatch) {
        for (size_t p = 0; p < cols; p++)
            out[p] = (float)sc->row[p];
    } else if (g->d) {
        double scale = 1.0 / (double)g->d;
        for (size_t p = 0; p < cols; p++)
            out[p] = (float)(sc->row[p] * scale);
    } else { /* adaptive: F̄_ip = F_{i→p} / d_p */
        for (size_t p = 0; p < cols; p++)
            out[p] = (float)(sc->row[p] / (double)lrr__patch_size(g, p));
    }
}

lrr_status lrr__build_options_resolve(const lrr_scene *scene, const lrr_build_options *opts,
                                      lrr_build_options *o)
{
    if (!scene->geom.depth)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG,
                          "the scene is not subdivided: call lrr_scene_subdivide first");
    memset(o, 0, sizeof *o);
    o->size = sizeof *o;
    lrr_status st;
    if (opts && (st = lrr__options_read(scene->ctx, opts, sizeof *o,
                                        LRR__FIRST_SIZE(lrr_build_options, formfactor_method), o,
                                        "lrr_build_options")))
        return st;
    if (o->hemicube_resolution == 0)
        o->hemicube_resolution = 128;
    if (o->threads < 0)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG, "threads = %d: must be >= 0",
                          o->threads);
    if (o->hierarchy != LRR_HIERARCHY_QUADTREE && o->hierarchy != LRR_HIERARCHY_CLUSTER)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG,
                          "hierarchy = %d: must be LRR_HIERARCHY_QUADTREE or _CLUSTER",
                          o->hierarchy);
    if (o->hierarchy == LRR_HIERARCHY_CLUSTER && o->adaptive_patches == 0)
        return lrr__error(scene->ctx, LRR_ERR_INVALID_ARG,
                          "hierarchy = LRR_HIERARCHY_CLUSTER needs adaptive_patches (the "
                          "cluster count K) > 0");
    int method = LRR_FORMFACTOR_RASTER;
    return lrr__formfactor_method(scene->ctx, &scene->geom, o, &method);
}

static lrr_status rows_impl(lrr_context *ctx, const lrr__geometry *g,
                            const lrr_build_options *opts, int by_subpatch, const size_t *rows,
                            size_t count, int placed, float *out, double *back);

lrr_status lrr__hemicube_fbar(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, float *fbar, double *back)
{
    return rows_impl(ctx, g, opts, 0, NULL, g->n, 0, fbar, back);
}

lrr_status lrr__hemicube_fbar_rows(lrr_context *ctx, const lrr__geometry *g,
                                   const lrr_build_options *opts, const size_t *rows,
                                   size_t count, int placed, float *fbar, double *back)
{
    for (size_t r = 0; r < count; r++)
        if (rows[r] >= g->n)
            return lrr__error(ctx, LRR_ERR_INVALID_ARG, "row %zu of F̄ beyond n = %zu",
                              rows[r], g->n);
    if (opts->backend == LRR_BACKEND_OPENCL)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "a list of F̄'s rows is integrated on the CPU only");
    return rows_impl(ctx, g, opts, 0, rows, count, placed, fbar, back);
}

/* Batches of hemicubes are rasterised and resolved to patch ids on the CPU (OpenMP, each
 * receiver straight into its slice of the batch's id buffer), then integrated on the device.
 * A batch is at most 256 hemicubes and 64 MiB of ids. */
static lrr_status device_rows(lrr_context *ctx, const hemi_ctx *h, const lrr_build_options *opts,
                              float *out, double *back)
{
    const lrr__geometry *g = h->g;
    const unsigned R = h->mm->res;
    const size_t P = 3 * (size_t)R * R;
    if (g->k > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW,
                          "k = %zu patches: the device integration uses int32 patch ids", g->k);
    size_t batch = ((size_t)64 << 20) / (P * sizeof(int32_t));
    if (batch > 256)
        batch = 256;
    if (batch < 1)
        batch = 1;
    if (batch > g->n)
        batch = g->n ? g->n : 1;
    lrr__cl_hemi *dev;
    /* an adaptive hierarchy's 1/d_p is applied here after the device's sums */
    lrr_status st = lrr__cl_hemi_create(ctx, h->mm, g->k, g->d ? g->d : 1, batch, &dev);
    if (st)
        return st;
    int32_t *ids;
    if ((st = lrr__calloc(ctx, &ids, batch, P * sizeof(int32_t), "hemicube id batch"))) {
        lrr__cl_hemi_destroy(dev);
        return st;
    }
    int nthreads = opts->threads > 0 ? opts->threads : omp_get_max_threads();
    for (size_t i0 = 0; i0 < g->n && !st; i0 += batch) {
        const size_t i1 = i0 + batch < g->n ? i0 + batch : g->n;
        volatile int failed = 0;
        #pragma omp parallel num_threads(nthreads)
        {
            scratch sc = {0};
            if (lrr__calloc(ctx, &sc.depth, P, sizeof(float), "hemicube depth buffer") ||
                lrr__calloc(ctx, &sc.code, P, sizeof(uint32_t), "hemicube code buffer")) {
                #pragma omp atomic write
                failed = 1;
            }
            #pragma omp for schedule(dynamic, 4)
            for (size_t i = i0; i < i1; i++) {
                if (failed)
                    continue;
                sc.item = ids + (i - i0) * P;
                hemicube_row(h, i, opts->seed, !opts->no_rotation, &sc, NULL,
                             back ? back + i : NULL);
            }
            lrr_aligned_free(sc.depth);
            lrr_aligned_free(sc.code);
        }
        if (failed) {
            st = LRR_ERR_NOMEM;
            break;
        }
        if ((st = lrr__cl_hemi_rows(dev, ids, i1 - i0, out + i0 * g->k)))
            break;
        if (!g->d)
            for (size_t i = i0; i < i1; i++)
                for (size_t p = 0; p < g->k; p++)
                    out[i * g->k + p] =
                        (float)((double)out[i * g->k + p] / (double)lrr__patch_size(g, p));
        if (opts->progress && opts->progress(opts->progress_user, i1, g->n))
            st = lrr__error(ctx, LRR_ERR_CANCELLED,
                            "form-factor build cancelled after %zu of %zu receivers", i1, g->n);
    }
    lrr_aligned_free(ids);
    lrr__cl_hemi_destroy(dev);
    return st;
}

lrr_status lrr__hemicube_rows(lrr_context *ctx, const lrr__geometry *g,
                              const lrr_build_options *opts, int by_subpatch, float *out)
{
    return rows_impl(ctx, g, opts, by_subpatch, NULL, g->n, 0, out, NULL);
}

lrr_status lrr__hemicube_sample_rows(lrr_context *ctx, const lrr__geometry *g,
                                     const lrr_build_options *opts, const size_t *rows,
                                     size_t count, float *out)
{
    lrr_build_options o = *opts;
    o.backend = LRR_BACKEND_CPU; /* subpatch columns are integrated on the CPU only */
    o.progress = NULL;
    return rows_impl(ctx, g, &o, 1, rows, count, 0, out, NULL);
}

void lrr__hemi_tri_info(const float v[9], lrr__tri_info *ti)
{
    for (int j = 0; j < 3; j++) {
        ti->v0[j] = v[j];
        ti->e1[j] = (double)v[3 + j] - v[j];
        ti->e2[j] = (double)v[6 + j] - v[j];
    }
    lrr__cross3(ti->e1, ti->e2, ti->n);
    ti->g11 = lrr__dot3(ti->e1, ti->e1);
    ti->g12 = lrr__dot3(ti->e1, ti->e2);
    ti->g22 = lrr__dot3(ti->e2, ti->e2);
    ti->inv = 1.0 / (ti->g11 * ti->g22 - ti->g12 * ti->g12);
}

/* The per-triangle table of g (the rasteriser's; the ray caster keeps its own smaller one,
 * so *out stays NULL for rays) and the diagonal of its bounding box. */
static lrr_status tri_table(lrr_context *ctx, const lrr__geometry *g, int rays, tri_info **out,
                            double *diag)
{
    *out = NULL;
    *diag = lrr__geometry_bounds(g, NULL, NULL);
    if (rays)
        return LRR_OK;
    tri_info *tri;
    lrr_status st = lrr__calloc(ctx, &tri, g->n_tri, sizeof *tri, "triangle table");
    if (st)
        return st;
    for (size_t t = 0; t < g->n_tri; t++)
        lrr__hemi_tri_info(g->vert + 9 * t, &tri[t]);
    *out = tri;
    return LRR_OK;
}

/* The multiplier maps' running sums per row, R + 1 from 0: the top's R rows, then the
 * side's R/2 (integrate_face sums a run of pixels as a difference of two). */
static lrr_status prefix_maps(lrr_context *ctx, const lrr__multiplier_map *mm, double **out)
{
    const size_t R = mm->res, rows = R + R / 2;
    double *pre;
    lrr_status st = lrr__calloc(ctx, &pre, rows, (R + 1) * sizeof *pre, "hemicube prefix sums");
    if (st)
        return st;
    for (size_t y = 0; y < rows; y++) {
        const double *w = y < R ? mm->top + y * R : mm->side + (y - R) * R;
        double *p = pre + y * (R + 1), acc = 0;
        p[0] = 0;
        for (size_t x = 0; x < R; x++)
            p[x + 1] = acc += w[x];
    }
    *out = pre;
    return LRR_OK;
}

/* rows (or 0..count-1 when NULL) on the CPU, OpenMP over receivers; row r of the
 * list goes to out's row r, or row rows[r] when placed. */
static lrr_status cpu_rows(lrr_context *ctx, const hemi_ctx *h, const lrr_build_options *opts,
                           const size_t *rows, size_t count, int placed, float *out,
                           double *back)
{
    const size_t rr = (size_t)h->mm->res * h->mm->res;
    const size_t cols = h->by_subpatch ? h->g->n : h->g->k;
    int nthreads = opts->threads > 0 ? opts->threads : omp_get_max_threads();
    volatile int cancelled = 0, failed = 0;
    size_t done = 0;
    double last_report = lrr__now();
    #pragma omp parallel num_threads(nthreads)
    {
        scratch sc = {0};
        int ok = lrr__calloc(ctx, &sc.depth, rr * 3, sizeof(float), "hemicube depth buffer") == 0 &&
                 lrr__calloc(ctx, &sc.item, rr * 3, sizeof(int32_t), "hemicube item buffer") == 0 &&
                 lrr__calloc(ctx, &sc.code, rr * 3, sizeof(uint32_t), "hemicube code buffer") == 0 &&
                 lrr__calloc(ctx, &sc.row, cols, sizeof(double), "hemicube row") == 0;
        if (!ok) {
            #pragma omp atomic write
            failed = 1;
        }
        #pragma omp for schedule(dynamic, 16)
        for (size_t r = 0; r < count; r++) {
            if (cancelled || failed)
                continue;
            const size_t at = placed ? rows[r] : r; /* where the row goes */
            hemicube_row(h, rows ? rows[r] : r, opts->seed, !opts->no_rotation, &sc,
                         out + at * cols, back ? back + at : NULL);
            size_t now_done;
            #pragma omp atomic capture
            now_done = ++done;
            if (opts->progress && omp_get_thread_num() == 0) {
                double t = lrr__now();
                if (t - last_report > 0.05 || now_done == count) {
                    last_report = t;
                    if (opts->progress(opts->progress_user, now_done, count)) {
                        #pragma omp atomic write
                        cancelled = 1;
                    }
                }
            }
        }
        lrr_aligned_free(sc.depth);
        lrr_aligned_free(sc.item);
        lrr_aligned_free(sc.code);
        lrr_aligned_free(sc.row);
    }
    if (failed)
        return LRR_ERR_NOMEM;
    if (cancelled)
        return lrr__error(ctx, LRR_ERR_CANCELLED, "form-factor build cancelled after %zu of %zu "
                          "receivers", done, count);
    if (opts->progress)
        opts->progress(opts->progress_user, count, count);
    return LRR_OK;
}

static lrr_status rows_impl(lrr_context *ctx, const lrr__geometry *g,
                            const lrr_build_options *opts, int by_subpatch, const size_t *rows,
                            size_t count, int placed, float *out, double *back)
{
    unsigned R = opts->hemicube_resolution ? opts->hemicube_resolution : 128;
    const int on_device = opts->backend == LRR_BACKEND_OPENCL;
    if (opts->backend != 0 && opts->backend != LRR_BACKEND_CPU && !on_device)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "build backend %d: must be 0, LRR_BACKEND_CPU or LRR_BACKEND_OPENCL",
                          opts->backend);
    if (on_device && by_subpatch)
        return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                          "the full form-factor matrix (lrr_reference_build) is integrated on "
                          "the CPU only: use backend LRR_BACKEND_CPU");
    if (g->n_tri > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "%zu triangles: the item buffer holds int32 ids",
                          g->n_tri);
    int method = LRR_FORMFACTOR_RASTER;
    lrr_status st = lrr__formfactor_method(ctx, g, opts, &method);
    if (st)
        return st;
    lrr__cpu_choice cpu; /* LRR_SIMD checked for every method: one set of names everywhere */
    if ((st = lrr__cpu_choose(ctx, &cpu)))
        return st;
    if (method == LRR_FORMFACTOR_RAYCAST && (by_subpatch ? g->n : g->k) > INT32_MAX)
        return lrr__error(ctx, LRR_ERR_OVERFLOW, "%zu %s: ray casting keeps int32 ids per pixel",
                          by_subpatch ? g->n : g->k, by_subpatch ? "subpatches" : "patches");
    lrr__multiplier_map mm;
    if ((st = lrr__multiplier_map_create(ctx, R, &mm)))
        return st;
    tri_info *tri;
    double diag;
    if ((st = tri_table(ctx, g, method == LRR_FORMFACTOR_RAYCAST, &tri, &diag))) {
        lrr__multiplier_map_free(&mm);
        return st;
    }
    lrr__raycaster *rc = NULL;
    if (method == LRR_FORMFACTOR_RAYCAST && (st = lrr__raycaster_create(ctx, g, diag, &rc))) {
        lrr_aligned_free(tri);
        lrr__multiplier_map_free(&mm);
        return st;
    }
    /* Distances below ~1e-7 of the scene size are float rounding of the input coordinates:
     * treat such points as lying in the plane (edge-on / tangent), and put the near plane
     * there too so touching geometry (a block on the floor) is still seen up close. */
    uint16_t *cells = NULL;
    double *sx = NULL, *pre = NULL;
    if (!rc && ((st = lrr__hemi_cell_table(ctx, &cells)) ||
                (st = lrr__calloc(ctx, &sx, 3 * (size_t)R, sizeof *sx, "hemicube pixel columns")) ||
                (st = prefix_maps(ctx, &mm, &pre)))) {
        lrr_aligned_free(sx);
        lrr_aligned_free(cells);
        lrr_aligned_free(tri);
        lrr__multiplier_map_free(&mm);
        return st;
    }
    uint32_t *patch_at = NULL;
    if (!by_subpatch && g->origin && g->k <= UINT32_MAX &&
        !(st = lrr__calloc(ctx, &patch_at, g->n, sizeof *patch_at, "patch of each subpatch")))
        for (size_t p = 0; p < g->k; p++)
            for (size_t i = g->first[p]; i < g->first[p + 1]; i++)
                patch_at[i] = (uint32_t)p;
    if (st) {
        lrr_aligned_free(pre);
        lrr_aligned_free(sx);
        lrr_aligned_free(cells);
        lrr__raycaster_destroy(rc);
        lrr_aligned_free(tri);
        lrr__multiplier_map_free(&mm);
        return st;
    }
    hemi_ctx h = {g, tri, &mm, 1e-7 * diag, 1e-7 * diag, by_subpatch, rc,
                  lrr__hemi_simd_pick(cpu.isa),
                  cells, sx, sx ? sx + R : NULL, sx ? sx + 2 * (size_t)R : NULL, pre,
                  pre ? pre + (size_t)R * (R + 1) : NULL,
                  lrr__receiver_sampling(opts, method) == LRR_RECEIVER_AREA, patch_at};
    /* pixel column x looks along sx = (x + 0.5)/(R/2) − 1 (every face is R wide), row y
     * along sy = that on the top face, (y + 0.5)/(R/2) on a side (a division per row of each
     * triangle in the depth test, else) */
    for (unsigned c = 0; sx && c < R; c++) {
        const double half = 0.5 * R;
        sx[c] = (c + 0.5) / half - 1;
        sx[R + c] = (c + 0.5) / half - 1;
        sx[2 * (size_t)R + c] = (c + 0.5) / half;
    }
    /* the device integration takes the same item buffers, rasterised or ray cast */
    st = rc ? lrr__raycaster_bind(ctx, rc, &h) : LRR_OK;
    if (!st)
        st = on_device ? device_rows(ctx, &h, opts, out, back)
                       : cpu_rows(ctx, &h, opts, rows, count, placed, out, back);
    if (rc) {
        lrr_status rst = lrr__raycaster_status(ctx, rc);
        if (!st)
            st = rst;
        lrr__raycaster_destroy(rc);
    }
    lrr_aligned_free(patch_at);
    lrr_aligned_free(pre);
    lrr_aligned_free(sx);
    lrr_aligned_free(cells);
    lrr_aligned_free(tri);
    lrr__multiplier_map_free(&mm);
    return st;
}
