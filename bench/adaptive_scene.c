/*
 * lrr-bench adaptive, one scene (adaptive.c has the command, its options and its output): the
 * subdivision at levels 0 and its n×n reference, the subpatches of other operators matched to
 * it, and one operator per budget and split (and per levels-L) built, timed, compared and
 * printed.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

/* ------------------------------------------------------------------ matching subpatches */
typedef struct geo {
    const float *centre, *normal, *area;
} geo;

static const float *sort_key_x;
static int cmp_by_x(const void *a, const void *b)
{
    float x = sort_key_x[3 * *(const size_t *)a], y = sort_key_x[3 * *(const size_t *)b];
    return x < y ? -1 : x > y;
}

/* perm[i] = the reference subpatch that operator subpatch i is, matched by centre (within
 * tol), normal (dot > 0.99) and area (1e-4 relative). Returns 0, or -1 when some subpatch has
 * no partner (different subdivisions). */
static int match_subpatches(size_t n, geo ref, geo op, double tol, size_t *perm)
{
    size_t *order = malloc(n * sizeof *order);
    unsigned char *used = calloc(n, 1);
    int rc = -1;
    if (!order || !used)
        goto out;
    for (size_t i = 0; i < n; i++)
        order[i] = i;
    sort_key_x = ref.centre;
    qsort(order, n, sizeof *order, cmp_by_x);
    for (size_t i = 0; i < n; i++) {
        const float *c = op.centre + 3 * i, *nm = op.normal + 3 * i;
        /* the first reference subpatch with x >= c[0] - tol */
        size_t lo = 0, hi = n;
        while (lo < hi) {
            size_t mid = (lo + hi) / 2;
            if (ref.centre[3 * order[mid]] < c[0] - tol)
                lo = mid + 1;
            else
                hi = mid;
        }
        size_t found = SIZE_MAX;
        for (size_t j = lo; j < n && ref.centre[3 * order[j]] <= c[0] + tol; j++) {
            size_t r = order[j];
            if (used[r])
                continue;
            const float *rc3 = ref.centre + 3 * r, *rn = ref.normal + 3 * r;
            if (fabs(rc3[1] - c[1]) > tol || fabs(rc3[2] - c[2]) > tol)
                continue;
            if ((double)rn[0] * nm[0] + (double)rn[1] * nm[1] + (double)rn[2] * nm[2] < 0.99)
                continue;
            if (fabs((double)ref.area[r] - op.area[i]) > 1e-4 * ref.area[r])
                continue;
            found = r;
            break;
        }
        if (found == SIZE_MAX)
            goto out;
        used[found] = 1;
        perm[i] = found;
    }
    rc = 0;
out:
    free(order);
    free(used);
    return rc;
}

/* ------------------------------------------------------------------ one scene */
static void scene_ref_free(scene_ref *s)
{
    lrr_scene_destroy(s->scene);
    free(s->centre);
    free(s->normal);
    free(s->area);
    free(s->bref);
    free(s->eref);
    memset(s, 0, sizeof *s);
}

/* Subdivides (levels 0), builds and solves the n×n reference. */
static int scene_setup(lrr_context *ctx, const adaptive_args *a, const char *name,
                       const char *label, scene_ref *s)
{
    memset(s, 0, sizeof *s);
    s->reference_s = s->reference_residual = NAN;
    int rc = bench_open_scene(ctx, name, &s->scene);
    if (rc)
        return rc;
    lrr_subdivision sub = {.target_patches = a->subpatches};
    lrr_status st = lrr_scene_subdivide(s->scene, &sub);
    if (st != LRR_OK)
        return bench_lib_fail(ctx, st, "subdivision");
    lrr_scene_info si;
    lrr_scene_get_info(s->scene, &si, sizeof si);
    s->n = si.subpatches;
    s->triangles = si.triangles;
    s->max_patch_area = si.max_patch_area;
    double d2 = 0;
    for (int j = 0; j < 3; j++)
        d2 += (si.bounds_max[j] - si.bounds_min[j]) * (si.bounds_max[j] - si.bounds_min[j]);
    s->diag = sqrt(d2) > 0 ? sqrt(d2) : 1.0;
    s->centre = cli_alloc_rgb(s->n);
    s->normal = cli_alloc_rgb(s->n);
    s->area = calloc(s->n, sizeof *s->area);
    s->bref = cli_alloc_rgb(s->n);
    s->eref = cli_alloc_rgb(s->n);
    if (!s->centre || !s->normal || !s->area || !s->bref || !s->eref)
        return bench_fail("%s: out of memory", label);
    if ((st = lrr_scene_subpatches(s->scene, s->centre, s->normal, s->area, NULL, s->eref)) !=
        LRR_OK)
        return bench_lib_fail(ctx, st, "subpatches");

    size_t need = lrr_reference_bytes(s->n);
    if (need == SIZE_MAX || need > a->memory_budget) {
        char nb[32], bb[32];
        snprintf(s->note, sizeof s->note, "n×n needs %s > budget %s",
                 need == SIZE_MAX ? "more than SIZE_MAX bytes"
                                  : bench_fmt_bytes(nb, sizeof nb, need),
                 bench_fmt_bytes(bb, sizeof bb, a->memory_budget));
        bench_note("%s: no reference: %s", label, s->note);
        return CLI_EXIT_OK;
    }
    bench_note("%s: %zu triangles, n = %zu subpatches; reference: n×n form factors (%.1f MB)",
               label, s->triangles, s->n, (double)need / MB);
    lrr_build_options bo = {.hemicube_resolution = a->hemicube, .seed = a->seed};
    cli_progress bar;
    bench_progress_begin(&bar, "n×n hemicubes", &bo);
    lrr_reference *ref = NULL;
    double t0 = cli_now();
    st = lrr_reference_build(s->scene, &bo, a->memory_budget, &ref);
    cli_progress_finish(&bar);
    if (st == LRR_ERR_BUDGET) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        snprintf(s->note, sizeof s->note, "reference refused: %s", msg);
        bench_note("%s: %s", label, s->note);
        return CLI_EXIT_OK;
    }
    if (st != LRR_OK)
        return bench_lib_fail(ctx, st, "reference build");
    lrr_reference_stats rs = {0};
    st = lrr_reference_solve(ref, LRR_METHOD_GAUSS_SEIDEL, REFERENCE_TOL, 0,
                             lrr_reference_emission(ref), s->bref, &rs, sizeof rs);
    s->reference_s = cli_now() - t0;
    s->reference_residual = rs.residual;
    memcpy(s->eref, lrr_reference_emission(ref), 3 * s->n * sizeof *s->eref);
    lrr_reference_destroy(ref);
    if (st != LRR_OK && st != LRR_NOT_CONVERGED)
        return bench_lib_fail(ctx, st, "Gauss-Seidel reference solve");
    if (st == LRR_NOT_CONVERGED) {
        lrr_context_last_error(ctx, NULL, 0);
        snprintf(s->note, sizeof s->note, "Gauss-Seidel stopped at residual %.2g after %zu",
                 rs.residual, rs.iterations);
    }
    bench_note("%s: reference: Gauss-Seidel %zu sweeps, residual %.2g, %.1f s with F", label,
               rs.iterations, rs.residual, s->reference_s);
    s->have_ref = 1;
    return CLI_EXIT_OK;
}

/* Builds one operator on `scene` (adaptive when budget > 0), solves, times and compares. */
static int measure(lrr_context *ctx, const adaptive_args *a, const scene_ref *s,
                   const lrr_scene *scene, size_t budget, int split, const char *split_name,
                   const char *label, adaptive_row *r)
{
    r->budget = budget;
    snprintf(r->split, sizeof r->split, "%s", split_name);
    r->triangles = s->triangles;
    r->n = s->n;
    r->rel_l2 = r->max_rel = r->rel_l2_reflected = r->rel_l2_plain = r->ratio = NAN;
    r->reference_s = s->reference_s;
    r->reference_residual = s->reference_residual;
    r->rt.median = r->rt.min = r->rt.max = NAN;

    lrr_build_options bo = {.hemicube_resolution = a->hemicube,
                            .seed = a->seed,
                            .adaptive_patches = budget,
                            .adaptive_samples = a->samples,
                            .adaptive_split = split};
    lrr_operator *op = NULL;
    lrr_solver *solver = NULL;
    float *b = NULL, *bm = NULL;
    size_t *perm = NULL;
    int rc = CLI_EXIT_OK;
    cli_progress bar;
    bench_progress_begin(&bar, "hemicubes", &bo);
    double t0 = cli_now();
    lrr_status st = lrr_operator_build(scene, &bo, &op);
    r->preprocess_s = cli_now() - t0;
    cli_progress_finish(&bar);
    if (st != LRR_OK)
        return bench_lib_fail(ctx, st, "operator build");
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    r->k = oi.k;
    r->d_min = oi.d_min;
    r->d_max = oi.d_max;
    r->build_s = oi.build_seconds;
    r->selection_s = oi.selection_seconds;
    r->selection_share = oi.build_seconds > 0 ? oi.selection_seconds / oi.build_seconds : NAN;
    r->cond_max = fmax(oi.condition[0], fmax(oi.condition[1], oi.condition[2]));
    r->mem_mb = ((double)oi.n * (double)oi.k + 3.0 * (double)oi.k * (double)oi.k) *
                sizeof(float) / MB;
    if (oi.n != s->n) {
        rc = bench_fail("%s: the operator has n = %zu subpatches, the scene %zu", label, oi.n,
                        s->n);
        goto done;
    }
    if (budget && oi.k > budget) {
        rc = bench_fail("%s: k = %zu patches > the budget K = %zu (adaptive_patches not "
                        "honoured by this library?)",
                        label, oi.k, budget);
        goto done;
    }
    bench_note("%s: k = %zu (d %zu..%zu), built in %.2f s (selection %.3f s); timing", label, oi.k,
               oi.d_min, oi.d_max, r->preprocess_s, r->selection_s);

    const float *e = lrr_operator_emission(op);
    b = cli_alloc_rgb(s->n);
    bm = cli_alloc_rgb(s->n);
    perm = malloc(s->n * sizeof *perm);
    if (!b || !bm || !perm) {
        rc = bench_fail("%s: out of memory", label);
        goto done;
    }
    if ((st = lrr_solver_create(op, LRR_BACKEND_CPU, &solver)) != LRR_OK ||
        (st = lrr_solver_set_path(solver, LRR_PATH_FULL)) != LRR_OK) {
        rc = bench_lib_fail(ctx, st, "solver");
        goto done;
    }
    ours_frame of = {solver, e, NULL, b, LRR_OK, 0};
    if (bench_time_frames(bench_ours_step, &of, a->repeat, &r->rt)) {
        rc = of.status != LRR_OK ? bench_lib_fail(ctx, of.status, "lrr_solve") : CLI_EXIT_FAIL;
        goto done;
    }
    for (size_t i = 0; i < 3 * s->n; i++)
        if (!isfinite(b[i])) {
            rc = bench_fail("%s: lrr_solve gave a non-finite value at subpatch %zu", label,
                            i / 3);
            goto done;
        }
    if (!s->have_ref)
        goto done;
    geo gref = {s->centre, s->normal, s->area};
    geo gop = {lrr_operator_centre(op), lrr_operator_normal(op), lrr_operator_area(op)};
    if (match_subpatches(s->n, gref, gop, 1e-5 * s->diag, perm) != 0) {
        rc = bench_fail("%s: the operator's subpatches are not the scene's (no match by "
                        "centre, normal and area)",
                        label);
        goto done;
    }
    for (size_t i = 0; i < s->n; i++)
        for (int c = 0; c < 3; c++)
            bm[3 * perm[i] + c] = b[3 * i + c];
    bench_compare_b(s->n, s->area, bm, s->bref, NULL, &r->rel_l2, &r->max_rel);
    bench_compare_b(s->n, s->area, bm, s->bref, s->eref, &r->rel_l2_reflected, NULL);
    bench_compare_b(s->n, NULL, bm, s->bref, NULL, &r->rel_l2_plain, NULL);
done:
    lrr_solver_destroy(solver);
    lrr_operator_destroy(op);
    free(b);
    free(bm);
    free(perm);
    return rc;
}

/* Whether two subdivisions have the same subpatches (as sets). */
static int same_subpatches(const scene_ref *s, const lrr_scene *other)
{
    lrr_scene_info si;
    lrr_scene_get_info(other, &si, sizeof si);
    if (si.subpatches != s->n)
        return 0;
    float *c = cli_alloc_rgb(s->n), *nm = cli_alloc_rgb(s->n);
    float *ar = calloc(s->n, sizeof *ar);
    size_t *perm = malloc(s->n * sizeof *perm);
    int same = 0;
    if (c && nm && ar && perm &&
        lrr_scene_subpatches(other, c, nm, ar, NULL, NULL) == LRR_OK) {
        geo g0 = {s->centre, s->normal, s->area}, g1 = {c, nm, ar};
        same = match_subpatches(s->n, g0, g1, 1e-5 * s->diag, perm) == 0;
    }
    free(c);
    free(nm);
    free(ar);
    free(perm);
    return same;
}

/* ------------------------------------------------------------------ table rows, budgets */
static void print_header(void)
{
    printf("\n| %-10s | %5s | %6s | %-8s | %5s | %5s | %5s | %9s | %9s | %6s | %7s | %7s | "
           "%6s | %17s |\n",
           "scene", "n", "budget", "split", "k", "d_min", "d_max", "rel_l2", "max_rel", "ratio",
           "prep_s", "sel_s", "sel_%", "rt_ms (min)");
    printf("|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|%s|\n", "------------", "-------",
           "--------", "----------", "-------", "-------", "-------", "-----------",
           "-----------", "--------", "---------", "---------", "--------", "-------------------");
}

static void print_row(const adaptive_row *r)
{
    char budget[24], e1[24], e2[24], ratio[24], share[24], rt[72];
    if (r->budget)
        snprintf(budget, sizeof budget, "%zu", r->budget);
    else
        snprintf(budget, sizeof budget, "-");
    if (isnan(r->rel_l2)) {
        snprintf(e1, sizeof e1, "n/a");
        snprintf(e2, sizeof e2, "n/a");
    } else {
        snprintf(e1, sizeof e1, "%.3g", r->rel_l2);
        snprintf(e2, sizeof e2, "%.3g", r->max_rel);
    }
    if (isnan(r->ratio))
        snprintf(ratio, sizeof ratio, "-");
    else
        snprintf(ratio, sizeof ratio, "%.3f", r->ratio);
    if (isnan(r->selection_share))
        snprintf(share, sizeof share, "-");
    else
        snprintf(share, sizeof share, "%.1f", 100.0 * r->selection_share);
    char med[32], lo[32];
    snprintf(rt, sizeof rt, "%s (%s)", bench_fmt_ms(med, sizeof med, r->rt.median),
             bench_fmt_ms(lo, sizeof lo, r->rt.min));
    printf("| %-10s | %5zu | %6s | %-8s | %5zu | %5zu | %5zu | %9s | %9s | %6s | %7.2f | %7.3f | "
           "%6s | %17s |\n",
           r->scene, r->n, budget, r->split, r->k, r->d_min, r->d_max, e1, e2, ratio,
           r->preprocess_s, r->selection_s, share, rt);
    fflush(stdout);
}

/* The budgets of one scene: the given list, or the default; those below the triangle
 * count or above n are skipped (noted). */
static size_t scene_budgets(const adaptive_args *a, const scene_ref *s, const char *label,
                            size_t *out)
{
    size_t m = 0;
    if (a->n_budgets) {
        for (size_t i = 0; i < a->n_budgets; i++) {
            size_t k = a->budgets[i];
            if (k < s->triangles) {
                printf("skipped: %s budget %zu (below the %zu triangles)\n", label, k,
                       s->triangles);
                continue;
            }
            if (k > s->n) {
                printf("budget: %s %zu taken as n = %zu (one patch per subpatch)\n", label, k,
                       s->n);
                k = s->n;
            }
            if (m == 0 || out[m - 1] != k)
                out[m++] = k;
        }
        return m;
    }
    static const unsigned div[] = {32, 16, 8, 4};
    for (size_t i = 0; i < sizeof div / sizeof div[0]; i++) {
        size_t k = (s->n + div[i] / 2) / div[i];
        if (k >= 2 * s->triangles && k <= s->n && (m == 0 || out[m - 1] != k))
            out[m++] = k;
    }
    return m;
}

/* ------------------------------------------------------------------ the scene's operators */
/* Which levels-L operators (L = 1..MAX_LEVELS) have the reference's subpatches: sc->levels. */
static int scene_levels(lrr_context *ctx, adaptive_scene *sc)
{
    const scene_ref *s = &sc->ref;
    int rc = CLI_EXIT_OK;
    sc->n_levels = 0;
    /* the standard uniform operator, where it has the same subpatches */
    for (unsigned L = 1; L <= MAX_LEVELS; L++) {
        lrr_scene *other = NULL;
        if ((rc = bench_open_scene(ctx, sc->name, &other)))
            break;
        double scale = (double)(1u << (2 * L));
        lrr_subdivision sub = {.max_patch_area = s->max_patch_area * scale, .levels = L};
        lrr_status st = lrr_scene_subdivide(other, &sub);
        lrr_scene_info oi;
        lrr_scene_get_info(other, &oi, sizeof oi);
        if (st == LRR_OK && same_subpatches(s, other)) {
            sc->levels[sc->n_levels++] = L;
            printf("levels: %u (k %zu, d %zu): same subpatches, included\n", L, oi.patches,
                   oi.d);
        } else {
            if (st != LRR_OK)
                lrr_context_last_error(ctx, NULL, 0);
            printf("levels: %u: left out (%s)\n", L,
                   st != LRR_OK ? "subdivision failed"
                   : oi.subpatches != s->n
                       ? "a different subpatch count"
                       : "different subpatches");
        }
        lrr_scene_destroy(other);
    }
    return rc;
}

int adaptive_scene_open(lrr_context *ctx, const adaptive_args *a, const char *name,
                        adaptive_scene *sc)
{
    memset(sc, 0, sizeof *sc);
    sc->name = name;
    scene_label(name, sc->label, sizeof sc->label);
    const scene_ref *s = &sc->ref;
    int rc = scene_setup(ctx, a, name, sc->label, &sc->ref);
    if (rc)
        return rc;
    printf("\nscene: %s (%s): triangles %zu, n %zu, max_patch_area %g", sc->label, name,
           s->triangles, s->n, s->max_patch_area);
    if (s->have_ref)
        printf(", reference %.1f s (residual %.2g)%s%s\n", s->reference_s,
               s->reference_residual, s->note[0] ? ", " : "", s->note);
    else
        printf(", no reference: %s\n", s->note);
    sc->n_budgets = scene_budgets(a, s, sc->label, sc->budgets);
    return scene_levels(ctx, sc);
}

/* Per budget, the uniform row, then the adaptive one with its ratio to the uniform. */
static int budget_rows(lrr_context *ctx, const adaptive_args *a, const adaptive_scene *sc,
                       adaptive_row *rows, size_t *count)
{
    const scene_ref *s = &sc->ref;
    int rc = CLI_EXIT_OK;
    for (size_t i = 0; i < sc->n_budgets && rc == CLI_EXIT_OK; i++) {
        for (int kind = 0; kind < 2 && rc == CLI_EXIT_OK; kind++) {
            adaptive_row *r = &rows[*count];
            snprintf(r->scene, sizeof r->scene, "%s", sc->label);
            char what[128];
            snprintf(what, sizeof what, "%s K %zu %s", sc->label, sc->budgets[i],
                     kind ? "adaptive" : "uniform");
            rc = measure(ctx, a, s, s->scene, sc->budgets[i],
                         kind ? LRR_SPLIT_VARIANCE : LRR_SPLIT_AREA,
                         kind ? "adaptive" : "uniform", what, r);
            if (rc) {
                memset(r, 0, sizeof *r);
                break;
            }
            if (kind == 0)
                r->ratio = isnan(r->rel_l2) ? NAN : 1.0;
            else if (rows[*count - 1].rel_l2 > 0)
                r->ratio = r->rel_l2 / rows[*count - 1].rel_l2;
            print_row(r);
            (*count)++;
        }
    }
    return rc;
}

/* The levels-L rows: each operator over its own subdivision of the scene. */
static int levels_rows(lrr_context *ctx, const adaptive_args *a, const adaptive_scene *sc,
                       adaptive_row *rows, size_t *count)
{
    const scene_ref *s = &sc->ref;
    int rc = CLI_EXIT_OK;
    for (size_t j = 0; j < sc->n_levels && rc == CLI_EXIT_OK; j++) {
        unsigned L = (unsigned)sc->levels[j];
        lrr_scene *other = NULL;
        if ((rc = bench_open_scene(ctx, sc->name, &other)))
            break;
        lrr_subdivision sub = {.max_patch_area = s->max_patch_area * (double)(1u << (2 * L)),
                               .levels = L};
        lrr_status st;
        if ((st = lrr_scene_subdivide(other, &sub)) != LRR_OK) {
            rc = bench_lib_fail(ctx, st, "subdivision");
            lrr_scene_destroy(other);
            break;
        }
        adaptive_row *r = &rows[*count];
        snprintf(r->scene, sizeof r->scene, "%s", sc->label);
        char name[16], what[128];
        snprintf(name, sizeof name, "levels-%u", L);
        snprintf(what, sizeof what, "%s %s", sc->label, name);
        rc = measure(ctx, a, s, other, 0, 0, name, what, r);
        lrr_scene_destroy(other);
        if (rc) {
            memset(r, 0, sizeof *r);
            break;
        }
        print_row(r);
        (*count)++;
    }
    return rc;
}

int adaptive_scene_rows(lrr_context *ctx, const adaptive_args *a, const adaptive_scene *sc,
                        adaptive_row *rows, size_t *count)
{
    print_header();
    int rc = budget_rows(ctx, a, sc, rows, count);
    if (rc == CLI_EXIT_OK)
        rc = levels_rows(ctx, a, sc, rows, count);
    return rc;
}

void adaptive_scene_free(adaptive_scene *sc)
{
    scene_ref_free(&sc->ref);
}
