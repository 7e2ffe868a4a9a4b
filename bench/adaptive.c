/*
 * lrr-bench adaptive: the adaptive patch hierarchy (issue 7) against uniform subdivision at
 * the same patch budget K and over the same subpatches, both measured against the full n×n
 * solution.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "bench.h"
#include "plot.h"

#define DEFAULT_SUBPATCHES 4000u
#define DEFAULT_BUDGET_MIB 4096u
#define REFERENCE_TOL 1e-7
#define MAX_SCENES 16
#define MAX_BUDGETS 32
#define MAX_LEVELS 3         /* the standard uniform operator: levels 1..3 are tried */
#define TARGET_RATIO 0.5     /* adaptive rel_l2 <= 0.5 × uniform at each budget */
#define TARGET_SELECTION 0.2 /* selection <= 20% of the build */

static const char adaptive_help[] =
    "Usage: lrr-bench adaptive [OPTIONS]\n"
    "The adaptive patch hierarchy against uniform subdivision at the same memory.\n"
    "For each scene: subdivide with {target_patches = N, levels = 0} (n subpatches, the\n"
    "leaves of each input triangle's 4-way quadtree), build the full n×n form factors from\n"
    "the same hemicubes (lrr_reference_build) and solve them by Gauss-Seidel (tol 1e-7) for\n"
    "the scene's emission: the reference. Then for each patch budget K build two operators\n"
    "over these n subpatches with lrr_build_options.adaptive_patches = K:\n"
    "  uniform   adaptive_split = LRR_SPLIT_AREA: the largest patch is split next, i.e.\n"
    "            uniform subdivision (the baseline)\n"
    "  adaptive  adaptive_split = LRR_SPLIT_VARIANCE: the patch whose subpatches' sampled\n"
    "            form-factor columns vary most is split next\n"
    "solve each for the scene's emission and compare with the reference. Both have k <= K\n"
    "patches, so F̄ (n×k) and M (3·k²) take the same memory. A split adds 3 patches, so\n"
    "k = triangles + 3·splits may be up to 2 below K.\n"
    "levels-L rows: the standard uniform operator (target_patches = 0, max_patch_area =\n"
    "4^L × the threshold of the levels-0 subdivision, levels = L, d = 4^L), L = 1..3,\n"
    "included only when its subpatches are exactly the same set (centres, normals, areas);\n"
    "otherwise left out (a 'levels' line says why).\n"
    "\n"
    "Columns (table and CSV):\n"
    "  scene, triangles  the scene and its input triangle count\n"
    "  n                 subpatches (the same for every operator of the scene)\n"
    "  budget            K = adaptive_patches (nan for the levels-L rows)\n"
    "  split             uniform, adaptive or levels-L (see above)\n"
    "  k                 patches of the operator actually built\n"
    "  d_min, d_max      fewest and most subpatches in one patch (lrr_operator_info)\n"
    "  rel_l2            area-weighted relative L2 of B against the reference over all\n"
    "                    channels, emission included (as in lrr-bench table and lrr compare;\n"
    "                    rel_l2_reflected in the CSV leaves E out of both)\n"
    "  max_rel           largest |ΔB|/|B_ref| over entries with |B_ref| > 1e-3·max|B_ref|\n"
    "  ratio             adaptive rel_l2 / uniform rel_l2 at the same budget (the target\n"
    "                    is <= 0.5); 1 on the uniform rows\n"
    "  prep_s            wall time of lrr_operator_build (hemicubes, selection, M_c)\n"
    "  sel_s, sel_%      lrr_operator_info.selection_seconds and its share of the build\n"
    "                    (build_seconds; the target is <= 20%)\n"
    "  rt_ms             one real-time RGB frame, lrr_solve forced to the full path\n"
    "                    (LRR_PATH_FULL): median of many runs after two warm-ups, and in\n"
    "                    brackets the fastest run (max in the CSV too); on a shared machine\n"
    "                    the median can catch other processes' load, the minimum hardly\n"
    "CSV only: build_s (lrr_operator_info.build_seconds), selection_share (sel_% / 100),\n"
    "runs, cond_max (largest condition estimate of the three M_c), mem_mb (F̄ + M in\n"
    "MB = 10^6 bytes: (n·k + 3·k²)·4), the options, reference_s (n×n build and solve)\n"
    "and reference_residual; rel_l2_plain: rel_l2 without the area weights (every\n"
    "subpatch counts alike).\n"
    "Operators keep their own subpatch order; B is matched to the reference's subpatches by\n"
    "centre, normal and area before the comparison.\n"
    "Targets (printed at the end, informational: never an exit failure): adaptive rel_l2\n"
    "<= 0.5 × uniform at each budget K < n (PASS/MISS per cell; at K = n both are exact),\n"
    "selection <= 20% of the build (each adaptive build).\n"
    "\n"
    "Options:\n"
    "  --scene SCENE        a scene file or a built-in name (cornell, cornell-closed);\n"
    "                       repeatable (default: cornell and office.obj from DATA, DATA\n"
    "                       being $LRR_DATA_DIR, else the installed data directory, else\n"
    "                       ./data)\n"
    "  --subpatches N       target subpatch count n (default 4000)\n"
    "  --budgets K1,K2,...  patch budgets (default per scene: those of n/32, n/16,\n"
    "                       n/8, n/4 that are at least twice the triangle count);\n"
    "                       budgets below the triangle count are skipped, those above n\n"
    "                       taken as n (one patch per subpatch: the exact model)\n"
    "  --samples S          adaptive_samples: receivers sampled for the variance\n"
    "                       (default 0 = the library's, 2048)\n"
    "  --hemicube R         hemicube resolution: even, 8..4096 (default 128)\n"
    "  --seed S             seed of the hemicube rotations (default 1)\n"
    "  --repeat N           timed runs per frame measurement (default: adaptive, at least\n"
    "                       20 runs and 0.5 s)\n"
    "  --memory-budget MB   most memory for the n×n reference, in MiB (default 4096); a\n"
    "                       scene over it gets nan errors\n"
    "  --csv OUT.csv        write the results (rewritten after each scene):\n"
    "                       scene,triangles,n,budget,split,k,d_min,d_max,rel_l2,max_rel,\n"
    "                       rel_l2_reflected,ratio,preprocess_s,build_s,selection_s,\n"
    "                       selection_share,rt_ms,rt_ms_min,rt_ms_max,runs,cond_max,\n"
    "                       mem_mb,hemicube,samples,seed,reference_s,reference_residual,\n"
    "                       rel_l2_plain\n"
    "  --plot OUT.png       rel_l2 against k, log-log: uniform (squares, dashed) and\n"
    "                       adaptive (circles, solid), one colour per scene\n"
    "  -h, --help           show this help\n";

/* ------------------------------------------------------------------ rows */
typedef struct adaptive_row {
    char scene[64];
    size_t triangles, n, budget; /* budget 0: a levels-L row */
    char split[16];
    size_t k, d_min, d_max;
    double rel_l2, max_rel, rel_l2_reflected, rel_l2_plain, ratio;
    double preprocess_s, build_s, selection_s, selection_share;
    timing rt;
    double cond_max, mem_mb;
    double reference_s, reference_residual;
} adaptive_row;

typedef struct adaptive_args {
    const char *scenes[MAX_SCENES];
    size_t n_scenes;
    size_t subpatches;
    size_t budgets[MAX_BUDGETS];
    size_t n_budgets;
    size_t samples;
    unsigned hemicube, repeat;
    uint64_t seed;
    size_t memory_budget;
    const char *csv, *plot;
} adaptive_args;

static int cmp_size(const void *a, const void *b)
{
    size_t x = *(const size_t *)a, y = *(const size_t *)b;
    return x < y ? -1 : x > y;
}

/* "126,252,504": sorted, duplicates removed; -1 after a usage message */
static int parse_budgets(const char *prog, const char *text, size_t *list, size_t *count)
{
    char buf[1024];
    if (strlen(text) >= sizeof buf || !text[0]) {
        cli_usage_error(prog, "--budgets: '%s' is not a list of patch counts", text);
        return -1;
    }
    strcpy(buf, text);
    size_t n = 0;
    for (char *save = NULL, *tok = strtok_r(buf, ",", &save); tok;
         tok = strtok_r(NULL, ",", &save)) {
        if (n == MAX_BUDGETS) {
            cli_usage_error(prog, "--budgets: more than %d budgets", MAX_BUDGETS);
            return -1;
        }
        if (cli_parse_size(prog, "--budgets", tok, 1, (size_t)1 << 24, &list[n]) != 0)
            return -1;
        n++;
    }
    if (n == 0) {
        cli_usage_error(prog, "--budgets: '%s' is not a list of patch counts", text);
        return -1;
    }
    qsort(list, n, sizeof *list, cmp_size);
    size_t m = 0;
    for (size_t i = 0; i < n; i++)
        if (m == 0 || list[m - 1] != list[i])
            list[m++] = list[i];
    *count = m;
    return 0;
}

/* The office scene: DATA/office.obj with DATA as in `lrr-bench probes`. */
static void default_office(char *buf, size_t len)
{
    const char *dir = getenv("LRR_DATA_DIR");
    struct stat st;
    if (!dir || !dir[0]) {
        dir = "./data";
#ifdef LRR_PKGDATADIR
        snprintf(buf, len, "%s/office.obj", LRR_PKGDATADIR);
        if (stat(buf, &st) == 0)
            dir = LRR_PKGDATADIR;
#endif
    }
    snprintf(buf, len, "%s/office.obj", dir);
}

/* A short name for a scene argument: the file name without directory and extension. */
static void scene_label(const char *scene, char *buf, size_t len)
{
    const char *base = strrchr(scene, '/');
    base = base ? base + 1 : scene;
    snprintf(buf, len, "%s", base);
    char *dot = strrchr(buf, '.');
    if (dot && dot != buf)
        *dot = '\0';
}

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
typedef struct scene_ref {
    lrr_scene *scene;
    size_t n, triangles;
    double max_patch_area, diag;
    float *centre, *normal, *area; /* the scene's (reference) subpatch order */
    float *bref, *eref;            /* reference B and E (nan-filled when no reference) */
    int have_ref;
    double reference_s, reference_residual;
    char note[256];
} scene_ref;

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
    int rc = open_scene(ctx, name, &s->scene);
    if (rc)
        return rc;
    lrr_subdivision sub = {0.0, a->subpatches, 0};
    lrr_status st = lrr_scene_subdivide(s->scene, &sub);
    if (st != LRR_OK)
        return lib_fail(ctx, st, "subdivision");
    lrr_scene_info si;
    lrr_scene_get_info(s->scene, &si);
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
        return lib_fail(ctx, st, "subpatches");

    size_t need = lrr_reference_bytes(s->n);
    if (need == SIZE_MAX || need > a->memory_budget) {
        char nb[32], bb[32];
        snprintf(s->note, sizeof s->note, "n×n needs %s > budget %s",
                 need == SIZE_MAX ? "more than SIZE_MAX bytes" : fmt_bytes(nb, sizeof nb, need),
                 fmt_bytes(bb, sizeof bb, a->memory_budget));
        note("%s: no reference: %s", label, s->note);
        return CLI_EXIT_OK;
    }
    note("%s: %zu triangles, n = %zu subpatches; reference: n×n form factors (%.1f MB)",
         label, s->triangles, s->n, (double)need / MB);
    lrr_build_options bo = {.hemicube_resolution = a->hemicube, .seed = a->seed};
    cli_progress bar;
    progress_begin(&bar, "n×n hemicubes", &bo);
    lrr_reference *ref = NULL;
    double t0 = cli_now();
    st = lrr_reference_build(s->scene, &bo, a->memory_budget, &ref);
    cli_progress_finish(&bar);
    if (st == LRR_ERR_BUDGET) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        snprintf(s->note, sizeof s->note, "reference refused: %s", msg);
        note("%s: %s", label, s->note);
        return CLI_EXIT_OK;
    }
    if (st != LRR_OK)
        return lib_fail(ctx, st, "reference build");
    lrr_reference_stats rs = {0};
    st = lrr_reference_solve(ref, LRR_METHOD_GAUSS_SEIDEL, REFERENCE_TOL, 0,
                             lrr_reference_emission(ref), s->bref, &rs);
    s->reference_s = cli_now() - t0;
    s->reference_residual = rs.residual;
    memcpy(s->eref, lrr_reference_emission(ref), 3 * s->n * sizeof *s->eref);
    lrr_reference_destroy(ref);
    if (st != LRR_OK && st != LRR_NOT_CONVERGED)
        return lib_fail(ctx, st, "Gauss-Seidel reference solve");
    if (st == LRR_NOT_CONVERGED) {
        lrr_context_last_error(ctx, NULL, 0);
        snprintf(s->note, sizeof s->note, "Gauss-Seidel stopped at residual %.2g after %zu",
                 rs.residual, rs.iterations);
    }
    note("%s: reference: Gauss-Seidel %zu sweeps, residual %.2g, %.1f s with F", label,
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
    progress_begin(&bar, "hemicubes", &bo);
    double t0 = cli_now();
    lrr_status st = lrr_operator_build(scene, &bo, &op);
    r->preprocess_s = cli_now() - t0;
    cli_progress_finish(&bar);
    if (st != LRR_OK)
        return lib_fail(ctx, st, "operator build");
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi);
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
    note("%s: k = %zu (d %zu..%zu), built in %.2f s (selection %.3f s); timing", label, oi.k,
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
        rc = lib_fail(ctx, st, "solver");
        goto done;
    }
    ours_frame of = {solver, e, NULL, b, LRR_OK, 0};
    if (time_frames(ours_step, &of, a->repeat, &r->rt)) {
        rc = of.status != LRR_OK ? lib_fail(ctx, of.status, "lrr_solve") : CLI_EXIT_FAIL;
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
    compare_b(s->n, s->area, bm, s->bref, NULL, &r->rel_l2, &r->max_rel);
    compare_b(s->n, s->area, bm, s->bref, s->eref, &r->rel_l2_reflected, NULL);
    compare_b(s->n, NULL, bm, s->bref, NULL, &r->rel_l2_plain, NULL);
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
    lrr_scene_get_info(other, &si);
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

/* ------------------------------------------------------------------ output */
static const char adaptive_csv_header[] =
    "scene,triangles,n,budget,split,k,d_min,d_max,rel_l2,max_rel,rel_l2_reflected,ratio,"
    "preprocess_s,build_s,selection_s,selection_share,rt_ms,rt_ms_min,rt_ms_max,runs,"
    "cond_max,mem_mb,hemicube,samples,seed,reference_s,reference_residual,rel_l2_plain\n";

static int write_adaptive_csv(const char *path, const adaptive_args *a, const adaptive_row *rows,
                              size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs(adaptive_csv_header, out.f);
    for (size_t i = 0; i < count; i++) {
        const adaptive_row *r = &rows[i];
        fprintf(out.f, "%s,%zu,%zu,", r->scene, r->triangles, r->n);
        if (r->budget)
            fprintf(out.f, "%zu,", r->budget);
        else
            fputs("nan,", out.f);
        fprintf(out.f, "%s,%zu,%zu,%zu,", r->split, r->k, r->d_min, r->d_max);
        const double v[] = {r->rel_l2,     r->max_rel,         r->rel_l2_reflected,
                            r->ratio,      r->preprocess_s,    r->build_s,
                            r->selection_s, r->selection_share, r->rt.median,
                            r->rt.min,     r->rt.max};
        for (size_t j = 0; j < sizeof v / sizeof v[0]; j++)
            csv_num(out.f, v[j], 0);
        fprintf(out.f, "%zu,", r->rt.runs);
        csv_num(out.f, r->cond_max, 0);
        csv_num(out.f, r->mem_mb, 0);
        fprintf(out.f, "%u,%zu,%llu,", a->hemicube, a->samples, (unsigned long long)a->seed);
        csv_num(out.f, r->reference_s, 0);
        csv_num(out.f, r->reference_residual, 0);
        csv_num(out.f, r->rel_l2_plain, 1);
    }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

/* Returns 0, 1 when nothing can be plotted, -1 on failure. */
static int write_adaptive_plot(const char *path, const adaptive_args *a,
                               const adaptive_row *rows, size_t count)
{
    static const unsigned char colours[][3] = {{31, 119, 180}, {214, 39, 40}, {44, 160, 44},
                                               {148, 103, 189}, {255, 127, 14}, {140, 86, 75}};
    const size_t nc = sizeof colours / sizeof colours[0];
    char names[MAX_SCENES][2][96];
    plot_series series[2 * MAX_SCENES];
    double *x = calloc(count + 1, sizeof *x), *y = calloc(count + 1, sizeof *y);
    int rc = -1;
    if (!x || !y) {
        bench_fail("cannot allocate the plot's points");
        goto out;
    }
    size_t m = 0, ns = 0;
    for (size_t sc = 0; sc < a->n_scenes; sc++) {
        char label[64];
        scene_label(a->scenes[sc], label, sizeof label);
        for (int kind = 0; kind < 2; kind++) {
            const char *want = kind ? "adaptive" : "uniform";
            size_t first = m;
            for (size_t i = 0; i < count; i++)
                if (strcmp(rows[i].scene, label) == 0 && strcmp(rows[i].split, want) == 0 &&
                    isfinite(rows[i].rel_l2) && rows[i].rel_l2 > 0) {
                    x[m] = (double)rows[i].k;
                    y[m] = rows[i].rel_l2;
                    m++;
                }
            if (m == first)
                continue;
            snprintf(names[sc][kind], sizeof names[sc][kind], "%s %s", label,
                     kind ? "adaptive (variance)" : "uniform (area)");
            series[ns++] = (plot_series){names[sc][kind],
                                         x + first,
                                         y + first,
                                         NULL,
                                         m - first,
                                         {colours[sc % nc][0], colours[sc % nc][1],
                                          colours[sc % nc][2]},
                                         kind ? PLOT_CIRCLE : PLOT_SQUARE,
                                         kind ? 1 : 2};
        }
    }
    if (ns == 0) {
        rc = 1;
        goto out;
    }
    char title[256];
    snprintf(title, sizeof title,
             "adaptive vs uniform patches: error against k (n about %zu, hemicube %u)",
             a->subpatches, a->hemicube);
    plot_spec spec = {title, "patches k (memory: n*k + 3*k^2 floats)",
                      "relative L2 error vs n×n Gauss-Seidel", 0, 0, series, ns, 0};
    if (plot_write_png(&spec, path) != 0)
        bench_fail("cannot write '%s': %s", path, strerror(errno));
    else
        rc = 0;
out:
    free(x);
    free(y);
    return rc;
}

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
    snprintf(rt, sizeof rt, "%s (%s)", fmt_ms(med, sizeof med, r->rt.median),
             fmt_ms(lo, sizeof lo, r->rt.min));
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

int cmd_adaptive(int argc, char *argv[])
{
    static const char prog[] = "lrr-bench adaptive";
    static const struct option longopts[] = {
        {"scene", required_argument, NULL, OPT_SCENE},
        {"subpatches", required_argument, NULL, OPT_SUBPATCHES},
        {"budgets", required_argument, NULL, OPT_BUDGETS},
        {"samples", required_argument, NULL, OPT_SAMPLES},
        {"hemicube", required_argument, NULL, OPT_HEMICUBE},
        {"seed", required_argument, NULL, OPT_SEED},
        {"repeat", required_argument, NULL, OPT_REPEAT},
        {"memory-budget", required_argument, NULL, OPT_MEMORY_BUDGET},
        {"csv", required_argument, NULL, OPT_CSV},
        {"plot", required_argument, NULL, OPT_PLOT},
        {"help", no_argument, NULL, 'h'},
        {NULL, 0, NULL, 0}};
    adaptive_args a = {.subpatches = DEFAULT_SUBPATCHES,
                       .hemicube = DEFAULT_HEMICUBE,
                       .seed = DEFAULT_SEED,
                       .memory_budget = (size_t)DEFAULT_BUDGET_MIB << 20};
    size_t mib = DEFAULT_BUDGET_MIB;
    char office[4096];
    start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(adaptive_help, stdout);
            return CLI_EXIT_OK;
        case OPT_SCENE:
            if (a.n_scenes == MAX_SCENES) {
                cli_usage_error(prog, "--scene: more than %d scenes", MAX_SCENES);
                return CLI_EXIT_USAGE;
            }
            if (!optarg[0]) {
                cli_usage_error(prog, "--scene: the name is empty");
                return CLI_EXIT_USAGE;
            }
            a.scenes[a.n_scenes++] = optarg;
            break;
        case OPT_SUBPATCHES:
            if (cli_parse_size(prog, "--subpatches", optarg, 1, (size_t)1 << 24,
                               &a.subpatches) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_BUDGETS:
            if (parse_budgets(prog, optarg, a.budgets, &a.n_budgets) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_SAMPLES:
            if (cli_parse_size(prog, "--samples", optarg, 1, (size_t)1 << 24, &a.samples) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &a.hemicube) != 0)
                return CLI_EXIT_USAGE;
            if (a.hemicube % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", a.hemicube);
                return CLI_EXIT_USAGE;
            }
            break;
        case OPT_SEED:
            if (cli_parse_u64(prog, "--seed", optarg, 0, UINT64_MAX, &a.seed) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_REPEAT:
            if (cli_parse_unsigned(prog, "--repeat", optarg, 1, 1000000, &a.repeat) != 0)
                return CLI_EXIT_USAGE;
            break;
        case OPT_MEMORY_BUDGET:
            if (cli_parse_size(prog, "--memory-budget", optarg, 1, SIZE_MAX >> 20, &mib) != 0)
                return CLI_EXIT_USAGE;
            a.memory_budget = mib << 20;
            break;
        case OPT_CSV:
            a.csv = optarg;
            break;
        case OPT_PLOT:
            a.plot = optarg;
            break;
        default:
            return bad_option(prog, c, argv);
        }
    }
    if (no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if ((a.csv && !a.csv[0]) || (a.plot && !a.plot[0])) {
        cli_usage_error(prog, "--csv/--plot: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (a.n_scenes == 0) {
        default_office(office, sizeof office);
        a.scenes[a.n_scenes++] = "cornell";
        a.scenes[a.n_scenes++] = office;
    }

    lrr_context *ctx = NULL;
    lrr_status st = lrr_context_create(&ctx);
    if (st != LRR_OK)
        return lib_fail(NULL, st, "context");
    /* every scene must be readable before the long measurements */
    for (size_t i = 0; i < a.n_scenes; i++) {
        lrr_scene *probe = NULL;
        int rc = open_scene(ctx, a.scenes[i], &probe);
        lrr_scene_destroy(probe);
        if (rc) {
            lrr_context_destroy(ctx);
            return rc;
        }
    }
    /* rows: per scene, 2 per budget (scene_budgets gives at most MAX_BUDGETS) plus up to
     * MAX_LEVELS; sized for the most, since a count of 3 default budgets once overflowed
     * when a scene had 4 (AddressSanitizer, lrr-bench adaptive --scene cornell) */
    size_t cap = a.n_scenes * (2 * MAX_BUDGETS + MAX_LEVELS);
    adaptive_row *rows = calloc(cap, sizeof *rows);
    if (!rows) {
        lrr_context_destroy(ctx);
        return bench_fail("out of memory");
    }
    double t_start = cli_now();
    printf("benchmark: adaptive\n");
    print_machine();
    printf("scenes:");
    for (size_t i = 0; i < a.n_scenes; i++)
        printf(" %s", a.scenes[i]);
    printf("\nsubpatches_target: %zu (levels 0)\n", a.subpatches);
    if (a.n_budgets) {
        printf("budgets:");
        for (size_t i = 0; i < a.n_budgets; i++)
            printf("%s%zu", i ? "," : " ", a.budgets[i]);
        printf("\n");
    } else
        printf("budgets: default (per scene: those of n/32, n/16, n/8, n/4 that "
               "are >= 2 x triangles)\n");
    printf("adaptive_samples: %zu%s\n", a.samples, a.samples ? "" : " (the library's default)");
    printf("hemicube: %u\n", a.hemicube);
    printf("seed: %llu\n", (unsigned long long)a.seed);
    printf("memory_budget_mib: %zu\n", a.memory_budget >> 20);
    printf("reference: lrr_reference_build + Gauss-Seidel, tol %g, same hemicubes and seed\n",
           REFERENCE_TOL);
    printf("error: rel_l2 = area-weighted relative L2 over all channels (emission included, "
           "as in lrr-bench table); ratio = adaptive / uniform rel_l2 at the same budget\n");
    printf("rt_ms: lrr_solve, full path, ms per RGB frame: median (min)\n");
    fflush(stdout);

    int rc = CLI_EXIT_OK;
    size_t count = 0;
    for (size_t sc = 0; sc < a.n_scenes && rc == CLI_EXIT_OK; sc++) {
        char label[64];
        scene_label(a.scenes[sc], label, sizeof label);
        scene_ref s;
        rc = scene_setup(ctx, &a, a.scenes[sc], label, &s);
        if (rc) {
            scene_ref_free(&s);
            break;
        }
        printf("\nscene: %s (%s): triangles %zu, n %zu, max_patch_area %g", label,
               a.scenes[sc], s.triangles, s.n, s.max_patch_area);
        if (s.have_ref)
            printf(", reference %.1f s (residual %.2g)%s%s\n", s.reference_s,
                   s.reference_residual, s.note[0] ? ", " : "", s.note);
        else
            printf(", no reference: %s\n", s.note);
        size_t budgets[MAX_BUDGETS];
        size_t nb = scene_budgets(&a, &s, label, budgets);
        /* the standard uniform operator, where it has the same subpatches */
        size_t levels_ok[MAX_LEVELS], n_levels = 0;
        for (unsigned L = 1; L <= MAX_LEVELS; L++) {
            lrr_scene *other = NULL;
            if ((rc = open_scene(ctx, a.scenes[sc], &other)))
                break;
            double scale = (double)(1u << (2 * L));
            lrr_subdivision sub = {s.max_patch_area * scale, 0, L};
            st = lrr_scene_subdivide(other, &sub);
            lrr_scene_info oi;
            lrr_scene_get_info(other, &oi);
            if (st == LRR_OK && same_subpatches(&s, other)) {
                levels_ok[n_levels++] = L;
                printf("levels: %u (k %zu, d %zu): same subpatches, included\n", L,
                       oi.patches, oi.d);
            } else {
                if (st != LRR_OK)
                    lrr_context_last_error(ctx, NULL, 0);
                printf("levels: %u: left out (%s)\n", L,
                       st != LRR_OK ? "subdivision failed"
                       : oi.subpatches != s.n
                           ? "a different subpatch count"
                           : "different subpatches");
            }
            lrr_scene_destroy(other);
        }
        if (rc) {
            scene_ref_free(&s);
            break;
        }
        print_header();
        for (size_t i = 0; i < nb && rc == CLI_EXIT_OK; i++) {
            for (int kind = 0; kind < 2 && rc == CLI_EXIT_OK; kind++) {
                adaptive_row *r = &rows[count];
                snprintf(r->scene, sizeof r->scene, "%s", label);
                char what[128];
                snprintf(what, sizeof what, "%s K %zu %s", label, budgets[i],
                         kind ? "adaptive" : "uniform");
                rc = measure(ctx, &a, &s, s.scene, budgets[i],
                             kind ? LRR_SPLIT_VARIANCE : LRR_SPLIT_AREA,
                             kind ? "adaptive" : "uniform", what, r);
                if (rc) {
                    memset(r, 0, sizeof *r);
                    break;
                }
                if (kind == 0)
                    r->ratio = isnan(r->rel_l2) ? NAN : 1.0;
                else if (rows[count - 1].rel_l2 > 0)
                    r->ratio = r->rel_l2 / rows[count - 1].rel_l2;
                print_row(r);
                count++;
            }
        }
        for (size_t j = 0; j < n_levels && rc == CLI_EXIT_OK; j++) {
            unsigned L = (unsigned)levels_ok[j];
            lrr_scene *other = NULL;
            if ((rc = open_scene(ctx, a.scenes[sc], &other)))
                break;
            lrr_subdivision sub = {s.max_patch_area * (double)(1u << (2 * L)), 0, L};
            if ((st = lrr_scene_subdivide(other, &sub)) != LRR_OK) {
                rc = lib_fail(ctx, st, "subdivision");
                lrr_scene_destroy(other);
                break;
            }
            adaptive_row *r = &rows[count];
            snprintf(r->scene, sizeof r->scene, "%s", label);
            char name[16], what[128];
            snprintf(name, sizeof name, "levels-%u", L);
            snprintf(what, sizeof what, "%s %s", label, name);
            rc = measure(ctx, &a, &s, other, 0, 0, name, what, r);
            lrr_scene_destroy(other);
            if (rc) {
                memset(r, 0, sizeof *r);
                break;
            }
            print_row(r);
            count++;
        }
        scene_ref_free(&s);
        if (a.csv && count && write_adaptive_csv(a.csv, &a, rows, count) != 0)
            rc = CLI_EXIT_FAIL;
    }

    /* targets */
    printf("\ntarget: adaptive rel_l2 <= %.1f x uniform at each budget (informational)\n",
           TARGET_RATIO);
    size_t pass = 0, cells = 0;
    for (size_t i = 0; i < count; i++) {
        const adaptive_row *r = &rows[i];
        if (strcmp(r->split, "adaptive") != 0)
            continue;
        if (r->budget >= r->n) {
            printf("  %-10s K %5zu = n: one patch per subpatch, both exact (rel_l2 %.3g and "
                   "%.3g): not counted\n",
                   r->scene, r->budget, r->rel_l2, rows[i - 1].rel_l2);
            continue;
        }
        cells++;
        int ok = r->ratio <= TARGET_RATIO;
        pass += ok;
        char verdict[16];
        snprintf(verdict, sizeof verdict, "%s", isnan(r->ratio) ? "n/a" : ok ? "PASS" : "MISS");
        printf("  %-10s K %5zu (k %zu vs %zu): adaptive %.3g / uniform %.3g = %.3f: %s\n",
               r->scene, r->budget, r->k, rows[i - 1].k, r->rel_l2, rows[i - 1].rel_l2,
               r->ratio, verdict);
    }
    printf("target_ratio: %zu of %zu cells PASS\n", pass, cells);
    printf("target: selection <= %.0f%% of the build (adaptive rows)\n", 100 * TARGET_SELECTION);
    size_t spass = 0, sbuilds = 0;
    for (size_t i = 0; i < count; i++) {
        const adaptive_row *r = &rows[i];
        if (strcmp(r->split, "adaptive") != 0)
            continue;
        int ok = r->selection_share <= TARGET_SELECTION;
        spass += ok;
        sbuilds++;
        printf("  %-10s K %5zu: selection %.3f s of %.2f s = %.1f%%: %s\n", r->scene, r->budget,
               r->selection_s, r->build_s, 100 * r->selection_share,
               isnan(r->selection_share) ? "n/a" : ok ? "PASS" : "MISS");
    }
    printf("target_selection: %zu of %zu builds PASS\n", spass, sbuilds);
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
    if (a.csv && count)
        printf("csv: %s\n", a.csv);
    if (a.plot && count) {
        int prc = write_adaptive_plot(a.plot, &a, rows, count);
        if (prc == 0)
            printf("plot: %s\n", a.plot);
        else if (prc == 1)
            printf("plot: nothing to plot (no finite error), '%s' not written\n", a.plot);
        else
            rc = CLI_EXIT_FAIL;
    }
    free(rows);
    lrr_context_destroy(ctx);
    return rc;
}
