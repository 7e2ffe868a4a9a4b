/* Steps several of the `lrr` tool's subcommands take: opening scenes and operators, the
 * emission, timed solves and the summaries they print. See commands.h. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "commands.h"

/* ------------------------------------------------------------------ scenes */
int is_builtin(const char *name)
{
    return strcmp(name, "cornell") == 0 || strcmp(name, "cornell-closed") == 0;
}

int open_scene(lrr_context *ctx, const char *name, lrr_scene **scene)
{
    struct stat st;
    lrr_status s;
    if (stat(name, &st) == 0) {
        s = lrr_scene_load(ctx, name, scene);
    } else if (is_builtin(name)) {
        s = lrr_scene_builtin(ctx, name, scene);
    } else {
        return cli_fail(LRR_ERR_IO, "scene '%s': %s (built-in scenes: cornell, cornell-closed)",
                        name, strerror(errno));
    }
    return s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, s);
}

int open_subdivided_scene(lrr_context *ctx, const char *name, const subdiv_args *sa,
                          lrr_scene **scene)
{
    int rc = open_scene(ctx, name, scene);
    return rc != CLI_EXIT_OK ? rc : subdivide_scene(ctx, sa, scene);
}

int subdivide_scene(lrr_context *ctx, const subdiv_args *sa, lrr_scene **scene)
{
    int rc;
    lrr_subdivision sub = sa->sub;
    if (sa->clusters && !sa->have_area && !sa->have_patches) {
        /* one subpatch per small triangle, and about 16 per cluster on the large ones */
        lrr_scene_info si;
        lrr_scene_get_info(*scene, &si, sizeof si);
        sub.target_patches = si.triangles + 16 * sa->clusters;
    }
    lrr_status s = lrr_scene_subdivide(*scene, &sub);
    if (s != LRR_OK) {
        rc = cli_lib_error(ctx, s);
        lrr_scene_destroy(*scene);
        *scene = NULL;
        return rc;
    }
    return CLI_EXIT_OK;
}

void print_scene_info(const char *name, const lrr_scene *scene)
{
    lrr_scene_info si;
    lrr_scene_get_info(scene, &si, sizeof si);
    printf("scene: %s\n", name);
    printf("triangles: %zu\n", si.triangles);
    printf("skipped: %zu\n", si.skipped);
    printf("patches: %zu\n", si.patches);
    printf("subpatches: %zu\n", si.subpatches);
    printf("d: %zu\n", si.d);
    printf("area: %.9g\n", si.area);
    printf("emitters: %zu\n", si.emitters);
    printf("textures: %zu\n", si.textures);
    printf("clamped_texels: %zu\n", si.clamped_texels);
    printf("max_patch_area: %.9g\n", si.max_patch_area);
    printf("bounds_min: %.9g %.9g %.9g\n", si.bounds_min[0], si.bounds_min[1],
           si.bounds_min[2]);
    printf("bounds_max: %.9g %.9g %.9g\n", si.bounds_max[0], si.bounds_max[1],
           si.bounds_max[2]);
}

/* ------------------------------------------------------------------ operator builds */
void budget_hint(const char *prog, size_t budget, size_t clusters)
{
    if (clusters)
        fprintf(stderr, "%s: --memory-budget is %zu MiB (default: physical memory): raise it, "
                        "or give a smaller --clusters K (F̄ holds n×K, n = T + 16·K)\n",
                prog, budget >> 20);
    else
        fprintf(stderr, "%s: --memory-budget is %zu MiB (default: physical memory): raise it, "
                        "or use --clusters K (K clusters of subpatches across triangles, so F̄ "
                        "has K columns whatever the triangle count; e.g. --clusters 2000), or "
                        "fewer --patches or --levels\n", prog, budget >> 20);
}

void print_operator_info(const lrr_operator *op)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    printf("n: %zu\n", oi.n);
    printf("k: %zu\n", oi.k);
    printf("d: %zu\n", oi.d);
    printf("hierarchy: %s\n", oi.hierarchy == LRR_HIERARCHY_CLUSTER ? "clusters"
                              : oi.d ? "uniform" : "adaptive");
    if (oi.d == 0) { /* adaptive or cluster hierarchy */
        printf("d_min: %zu\n", oi.d_min);
        printf("d_max: %zu\n", oi.d_max);
        printf("selection_seconds: %.3f\n", oi.selection_seconds);
    }
    printf("hemicube: %u\n", oi.hemicube_resolution);
    printf("receiver: %s\n", oi.receiver_sampling == LRR_RECEIVER_AREA ? "area" : "centre");
    printf("seed: %llu\n", (unsigned long long)oi.seed);
    printf("build_seconds: %.3f\n", oi.build_seconds);
    printf("formfactor_seconds: %.3f\n", oi.formfactor_seconds);
    printf("smw_seconds: %.3f\n", oi.smw_seconds);
    printf("cond_r: %.6g\n", oi.condition[0]);
    printf("cond_g: %.6g\n", oi.condition[1]);
    printf("cond_b: %.6g\n", oi.condition[2]);
    printf("storage: %s\n", lrr_storage_name(oi.storage));
    printf("layout: %s\n", oi.layout == LRR_LAYOUT_ROWS ? "rows" : "panels");
    printf("memory_mb: %.3f\n", (double)oi.bytes / (1024.0 * 1024.0));
    if (oi.verify_subpatches) {
        printf("verify_rel_l2: %.6g\n", oi.verify_rel_l2);
        printf("verify_noise: %.6g\n", oi.verify_noise);
        printf("verify_subpatches: %zu\n", oi.verify_subpatches);
        printf("verify_samples: %zu\n", oi.verify_samples);
        printf("verify_seconds: %.3f\n", oi.verify_seconds);
        printf("verify_emission: %s\n", oi.verify_uniform ? "uniform" : "scene");
    }
}

int check_writable_dir(const char *path)
{
    const char *slash = strrchr(path, '/');
    char *dir = slash ? strndup(path, slash == path ? 1 : (size_t)(slash - path)) : strdup(".");
    if (!dir)
        return cli_fail(LRR_ERR_NOMEM, "cannot copy the path '%s'", path);
    int rc = CLI_EXIT_OK;
    if (access(dir, W_OK | X_OK) != 0)
        rc = cli_fail(LRR_ERR_IO, "cannot write '%s': directory '%s': %s", path, dir,
                      strerror(errno));
    free(dir);
    return rc;
}

/* ------------------------------------------------------------------ emission */
int load_operator(lrr_context *ctx, const char *path, lrr_operator **op)
{
    lrr_status s = lrr_operator_load(ctx, path, op);
    return s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, s);
}

int load_operator_head(lrr_context *ctx, const char *path, lrr_operator **op)
{
    lrr_status s = lrr_operator_load_head(ctx, path, op);
    return s == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, s);
}

int scaled_emission(const lrr_operator *op, double scale, float **out)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const float *e0 = lrr_operator_emission(op);
    if (!e0)
        return cli_fail(LRR_ERR_INVALID_ARG, "the operator has no stored emission");
    float *e = cli_alloc_rgb(oi.n);
    if (!e)
        return CLI_EXIT_FAIL;
    for (size_t i = 0; i < 3 * oi.n; i++) {
        e[i] = (float)((double)e0[i] * scale);
        if (!isfinite(e[i])) {
            free(e);
            return cli_fail(LRR_ERR_INVALID_ARG,
                            "--emission-scale %g: the emission of subpatch %zu overflows", scale,
                            i / 3);
        }
    }
    *out = e;
    return CLI_EXIT_OK;
}

/* direct (n×3) += the probe's fitted lights' direct light. */
static int probe_direct(lrr_context *ctx, const lrr_operator *op, const probe_args *p,
                        float *direct, double *seconds)
{
    lrr_probe *probe = NULL;
    lrr_light *lights = calloc(p->sources, sizeof *lights);
    lrr_status st = lights ? lrr_probe_load(ctx, p->path, &probe) : LRR_ERR_NOMEM;
    if (st == LRR_OK) {
        if (p->median_cut) {
            st = lrr_probe_median_cut(probe, p->sources, lights);
        } else {
            lrr_fit_stats fs;
            st = lrr_probe_fit_irradiance(probe, p->sources, PROBE_DEFAULT_NORMALS, NULL, lights,
                                          &fs, sizeof fs);
        }
    }
    if (st == LRR_OK) {
        for (size_t l = 0; l < p->sources; l++)
            for (int c = 0; c < 3; c++)
                lights[l].rgb[c] = (float)(lights[l].rgb[c] * p->scale);
        double t0 = cli_now();
        st = lrr_probe_direct_light(op, lights, p->sources, direct);
        *seconds += cli_now() - t0;
    }
    int rc = st == LRR_OK ? CLI_EXIT_OK : cli_lib_error(st == LRR_ERR_NOMEM && !probe ? NULL : ctx, st);
    free(lights);
    lrr_probe_destroy(probe);
    return rc;
}

/* direct (n×3) += the --light sources' direct light (lrr_lighting_direct). */
static int sources_direct(lrr_context *ctx, const lrr_operator *op, const probe_args *p,
                          float *direct, size_t n, double *seconds)
{
    float *add = cli_alloc_rgb(n);
    lrr_lighting *lt = NULL;
    if (!add)
        return CLI_EXIT_FAIL;
    double t0 = cli_now();
    lrr_status st = lrr_lighting_create(op, &lt);
    if (st == LRR_OK)
        st = lrr_lighting_direct(lt, p->light, p->lights, add);
    *seconds += cli_now() - t0;
    lrr_lighting_destroy(lt);
    for (size_t i = 0; st == LRR_OK && i < 3 * n; i++)
        direct[i] += add[i];
    free(add);
    return st == LRR_OK ? CLI_EXIT_OK : cli_lib_error(ctx, st);
}

int add_probe_light(lrr_context *ctx, const lrr_operator *op, const probe_args *p, float *e,
                    double *seconds)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    float *direct = cli_alloc_rgb(oi.n);
    *seconds = 0;
    int rc = direct ? CLI_EXIT_OK : CLI_EXIT_FAIL;
    if (rc == CLI_EXIT_OK && p->path)
        rc = probe_direct(ctx, op, p, direct, seconds);
    if (rc == CLI_EXIT_OK && p->lights)
        rc = sources_direct(ctx, op, p, direct, oi.n, seconds);
    const size_t bad = rc == CLI_EXIT_OK ? cli_add_direct(e, direct, oi.n, p->no_scene_emission)
                                         : oi.n;
    if (bad < oi.n)
        rc = cli_fail(LRR_ERR_INVALID_ARG,
                      "the emission of subpatch %zu overflows (--probe-scale %g, --light)", bad,
                      p->scale);
    free(direct);
    return rc;
}

size_t cli_add_direct(float *e, const float *direct, size_t n, int replace)
{
    size_t bad = n;
    for (size_t i = 0; i < 3 * n; i++) {
        e[i] = replace ? direct[i] : e[i] + direct[i];
        if (!isfinite(e[i]) && bad == n)
            bad = i / 3;
    }
    return bad;
}

/* ------------------------------------------------------------------ solving */
int solve_lit(lrr_context *ctx, const char *file, double scale, const probe_args *pa,
              lrr_operator **op, float **b)
{
    float *e = NULL;
    double ms = 0.0, direct_s = 0.0;
    *b = NULL;
    int rc = load_operator(ctx, file, op);
    if (rc == CLI_EXIT_OK)
        rc = scaled_emission(*op, scale, &e);
    if (rc == CLI_EXIT_OK && (pa->path || pa->lights))
        rc = add_probe_light(ctx, *op, pa, e, &direct_s);
    if (rc == CLI_EXIT_OK) {
        lrr_operator_info oi;
        lrr_operator_get_info(*op, &oi, sizeof oi);
        *b = cli_alloc_rgb(oi.n);
        rc = *b ? timed_solve(ctx, *op, LRR_BACKEND_CPU, LRR_FBAR_AUTO, SOLVE_M_AUTO, e, *b, 0,
                              LRR_PATH_AUTO, &ms, NULL, NULL)
                : CLI_EXIT_FAIL;
    }
    free(e);
    return rc;
}

int check_finite(const float *b, size_t n)
{
    for (size_t i = 0; i < 3 * n; i++)
        if (!isfinite(b[i])) {
            fprintf(stderr, "lrr: the radiosity of subpatch %zu is not finite (%g)\n", i / 3,
                    (double)b[i]);
            return CLI_EXIT_FAIL;
        }
    return CLI_EXIT_OK;
}

/* Solves once to warm up, then `repeat` timed runs; *median_ms gets their median. */
int timed_solve(lrr_context *ctx, const lrr_operator *op, lrr_backend backend,
                lrr_fbar_format fbar, int m, const float *e, float *b, unsigned repeat,
                lrr_path path, double *median_ms, lrr_path *used, solver_report *report)
{
    lrr_solver *solver = NULL;
    lrr_status s = lrr_solver_create(op, backend, &solver);
    if (s == LRR_OK && fbar != LRR_FBAR_AUTO) /* create chose for AUTO already */
        s = lrr_solver_set_fbar(solver, fbar);
    if (s == LRR_OK && m != SOLVE_M_AUTO)
        s = lrr_solver_set_m(solver, (lrr_storage)m);
    if (s == LRR_OK)
        s = lrr_solver_set_path(solver, path);
    if (s != LRR_OK) {
        lrr_solver_destroy(solver);
        return cli_lib_error(ctx, s);
    }
    double *t = calloc(repeat ? repeat : 1, sizeof *t);
    if (!t) {
        lrr_solver_destroy(solver);
        return cli_fail(LRR_ERR_NOMEM, "cannot allocate %u timings", repeat);
    }
    s = lrr_solve(solver, e, b);
    for (unsigned r = 0; s == LRR_OK && r < repeat; r++) {
        double t0 = cli_now();
        s = lrr_solve(solver, e, b);
        t[r] = 1e3 * (cli_now() - t0);
    }
    if (used)
        *used = lrr_solver_last_path(solver);
    if (report) {
        snprintf(report->kernel, KERNEL_NAME_MAX, "%s", lrr_solver_kernel(solver));
        lrr_solver_get_info(solver, &report->info, sizeof report->info);
    }
    lrr_solver_destroy(solver);
    if (s != LRR_OK) {
        free(t);
        return cli_lib_error(ctx, s);
    }
    *median_ms = repeat ? cli_median(t, repeat) : 0.0;
    free(t);
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    return check_finite(b, oi.n);
}

/* ------------------------------------------------------------------ summaries */
void print_radiosity_summary(size_t n, const float *area, const float *b)
{
    double sum[3] = {0, 0, 0}, total = 0.0, maxb = 0.0;
    for (size_t i = 0; i < n; i++) {
        double a = area ? (double)area[i] : 1.0;
        total += a;
        for (int c = 0; c < 3; c++) {
            sum[c] += a * (double)b[3 * i + c];
            if (b[3 * i + c] > maxb)
                maxb = b[3 * i + c];
        }
    }
    static const char ch[3] = {'r', 'g', 'b'};
    for (int c = 0; c < 3; c++)
        printf("mean_b_%c: %.9g\n", ch[c], total > 0 ? sum[c] / total : 0.0);
    printf("max_b: %.9g\n", maxb);
}

void print_solution_summary(const lrr_operator *op, const float *b)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    print_radiosity_summary(oi.n, lrr_operator_area(op), b);
}
