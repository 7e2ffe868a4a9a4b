/*
 * lrr-bench stress: closed rooms with uniform emission and reflectance up to 0.999, where
 * B = E/(1 − rho) exactly: the operator and every reference solver.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

static const char stress_help[] =
    "Usage: lrr-bench stress [OPTIONS]\n"
    "Closed rooms with nothing inside, every face pointing inwards: 'box' (a sealed\n"
    "2 × 1.5 × 1 box) and 'l-room' (an L-shaped, non-convex room), built with\n"
    "lrr_scene_create from unit squares (watertight, no T-junctions). Uniform emission\n"
    "E = 1 and reflectance rho in {0.5, 0.9, 0.99, 0.999}, so B = E/(1 - rho) exactly when\n"
    "the rows of F sum to 1. For each room and rho: the operator (lrr_solve) and each\n"
    "reference method (jacobi, gauss-seidel, southwell, direct; tol 1e-6) against the exact\n"
    "answer: max relative error, area-weighted relative L2, iterations, seconds, status,\n"
    "non-finite values, condition estimates and the range of row sums of F̄·d (operator)\n"
    "or F (reference).\n"
    "\n"
    "Options:\n"
    "  --csv OUT.csv        one row per (scene, rho, method): scene,n,k,d,rho,method,\n"
    "                       max_rel_err,rel_l2,iterations,seconds,residual,status,\n"
    "                       nonfinite,cond_max,row_sum_min,row_sum_max\n"
    "  --hemicube R         hemicube resolution (default 128; 64 with --quick)\n"
    "  --quick              smaller rooms (n about 100-200), for tests\n"
    "  -h, --help           show this help\n";


/* ================================================================== stress */
/* A room as a union of unit voxels: one unit square per voxel face that borders the
 * outside, its normal pointing into the voxel, each split into two triangles. All vertices
 * lie on the integer grid (scaled per axis), so neighbouring squares share whole edges: the
 * room is watertight without T-junctions. */
typedef struct voxel_room {
    const char *name;
    const int (*vox)[3];
    size_t n_vox;
    double scale[3];
    size_t target_patches, quick_patches;
    unsigned levels, quick_levels;
} voxel_room;

static const int box_voxels[][3] = {{0, 0, 0}};
static const int l_voxels[][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};

static const voxel_room stress_rooms[] = {
    {"box", box_voxels, 1, {2.0, 1.5, 1.0}, 24, 12, 2, 2},
    {"l-room", l_voxels, 3, {1.0, 1.0, 0.8}, 28, 28, 2, 1},
};

static int voxel_at(const voxel_room *r, int x, int y, int z)
{
    for (size_t i = 0; i < r->n_vox; i++)
        if (r->vox[i][0] == x && r->vox[i][1] == y && r->vox[i][2] == z)
            return 1;
    return 0;
}

/* Writes the triangles (9 floats each) to v, or only counts them when v is NULL. */
static size_t voxel_triangles(const voxel_room *r, float *v)
{
    size_t t = 0;
    for (size_t i = 0; i < r->n_vox; i++)
        for (int ax = 0; ax < 3; ax++)
            for (int s = -1; s <= 1; s += 2) {
                int nb[3] = {r->vox[i][0], r->vox[i][1], r->vox[i][2]};
                nb[ax] += s;
                if (voxel_at(r, nb[0], nb[1], nb[2]))
                    continue;
                int bx = (ax + 1) % 3, cx = (ax + 2) % 3;
                double o[3] = {r->vox[i][0], r->vox[i][1], r->vox[i][2]};
                if (s > 0)
                    o[ax] += 1;
                double q[4][3];
                for (int j = 0; j < 4; j++)
                    memcpy(q[j], o, sizeof o);
                q[1][bx] += 1;
                q[2][bx] += 1;
                q[2][cx] += 1;
                q[3][cx] += 1;
                /* (q0, q1, q2) has normal e_bx × e_cx = +e_ax; the inward normal is -s·e_ax */
                int order[4] = {0, 1, 2, 3};
                if (s > 0) {
                    order[1] = 3;
                    order[3] = 1;
                }
                const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
                for (int h = 0; h < 2; h++, t++)
                    if (v)
                        for (int j = 0; j < 3; j++)
                            for (int k = 0; k < 3; k++)
                                v[9 * t + 3 * j + k] =
                                    (float)(q[order[tri[h][j]]][k] * r->scale[k]);
            }
    return t;
}

typedef struct stress_row {
    const char *scene;
    size_t n, k, d;
    double rho;
    const char *method;
    double max_rel, rel_l2;
    size_t iterations;
    double seconds, residual;
    char status[40];
    size_t nonfinite;
    double cond_max, row_min, row_max;
} stress_row;

/* max relative error and area-weighted relative L2 of b against the constant `exact` */
static void compare_exact(size_t n, const float *area, const float *b, double exact,
                          double *max_rel, double *rel_l2, size_t *nonfinite)
{
    double mr = 0, num = 0, den = 0;
    size_t bad = 0;
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < 3; c++) {
            double x = b[3 * i + c];
            if (!isfinite(x)) {
                bad++;
                continue;
            }
            double dlt = x - exact;
            mr = fmax(mr, fabs(dlt) / exact);
            num += area[i] * dlt * dlt;
            den += area[i] * exact * exact;
        }
    *max_rel = bad ? INFINITY : mr;
    *rel_l2 = bad ? INFINITY : sqrt(num / den);
    *nonfinite = bad;
}

static void print_stress_row(const stress_row *r)
{
    char it[32], cond[32];
    if (r->iterations)
        snprintf(it, sizeof it, "%zu", r->iterations);
    else
        snprintf(it, sizeof it, "-");
    if (isnan(r->cond_max))
        snprintf(cond, sizeof cond, "-");
    else
        snprintf(cond, sizeof cond, "%.3g", r->cond_max);
    printf("%-7s %5zu %4zu %3zu %6g %-13s %10.3g %10.3g %9s %9.4f %-14s %4zu %9s %.7f..%.7f\n",
           r->scene, r->n, r->k, r->d, r->rho, r->method, r->max_rel, r->rel_l2, it, r->seconds,
           r->status, r->nonfinite, cond, r->row_min, r->row_max);
    fflush(stdout);
}

static int write_stress_csv(const char *path, const stress_row *rows, size_t count)
{
    cli_outfile out;
    if (cli_outfile_open(&out, path) != 0)
        return bench_fail("cannot create a temporary file for '%s': %s", path, strerror(errno));
    fputs("scene,n,k,d,rho,method,max_rel_err,rel_l2,iterations,seconds,residual,status,"
          "nonfinite,cond_max,row_sum_min,row_sum_max\n",
          out.f);
    for (size_t i = 0; i < count; i++) {
        const stress_row *r = &rows[i];
        fprintf(out.f, "%s,%zu,%zu,%zu,%g,%s,", r->scene, r->n, r->k, r->d, r->rho, r->method);
        bench_csv_num(out.f, r->max_rel, 0);
        bench_csv_num(out.f, r->rel_l2, 0);
        fprintf(out.f, "%zu,", r->iterations);
        bench_csv_num(out.f, r->seconds, 0);
        bench_csv_num(out.f, r->residual, 0);
        fprintf(out.f, "%s,%zu,", r->status, r->nonfinite);
        bench_csv_num(out.f, r->cond_max, 0);
        fprintf(out.f, "%.9g,%.9g\n", r->row_min, r->row_max);
    }
    if (cli_outfile_commit(&out) != 0)
        return bench_fail("cannot write '%s': %s", path, strerror(errno));
    return 0;
}

static const char *status_word(lrr_status s)
{
    return s == LRR_OK ? "ok" : s == LRR_NOT_CONVERGED ? "not-converged" : lrr_strerror(s);
}

/* The room as a scene: reflectance rho and emission 1 everywhere, subdivided (*scene is set
 * once created, also when the subdivision fails). */
static int room_scene(lrr_context *ctx, const voxel_room *room, int quick, double rho,
                      lrr_scene **scene)
{
    size_t ntri = voxel_triangles(room, NULL);
    float *v = calloc(ntri * 9, sizeof *v), *rh = calloc(ntri * 3, sizeof *rh);
    float *em = calloc(ntri * 3, sizeof *em);
    int rc = CLI_EXIT_OK;
    lrr_status s;
    if (!v || !rh || !em) {
        rc = bench_fail("out of memory");
        goto done;
    }
    voxel_triangles(room, v);
    for (size_t i = 0; i < ntri * 3; i++) {
        rh[i] = (float)rho;
        em[i] = 1.0f;
    }
    if ((s = lrr_scene_create(ctx, ntri, v, rh, em, room->name, scene)) != LRR_OK) {
        rc = bench_lib_fail(ctx, s, room->name);
        goto done;
    }
    lrr_subdivision sub = {.target_patches = quick ? room->quick_patches : room->target_patches,
                           .levels = quick ? room->quick_levels : room->levels};
    if ((s = lrr_scene_subdivide(*scene, &sub)) != LRR_OK)
        rc = bench_lib_fail(ctx, s, "subdivision");
done:
    free(v);
    free(rh);
    free(em);
    return rc;
}

/* the operator: rows of F̄·d are the form factors to whole patches; B (into b) for the
 * emission e = 1 against the exact one */
static int operator_row(lrr_context *ctx, const voxel_room *room, double rho,
                        const lrr_operator *op, const float *e, float *b, stress_row *r)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    size_t n = oi.n, k = oi.k, d = oi.d;
    *r = (stress_row){room->name, n, k, d, rho, "lrr", 0, 0, 0, 0, NAN, "", 0, 0, INFINITY,
                      -INFINITY};
    float *row = bench_alloc_floats(k, 1);
    if (!row)
        return bench_fail("cannot allocate a row of F̄");
    for (size_t i = 0; i < n; i++) {
        double sum = 0;
        lrr_operator_fbar_row(op, i, row);
        for (size_t p = 0; p < k; p++)
            sum += row[p];
        sum *= (double)d;
        r->row_min = fmin(r->row_min, sum);
        r->row_max = fmax(r->row_max, sum);
    }
    lrr_aligned_free(row);
    r->cond_max = fmax(oi.condition[0], fmax(oi.condition[1], oi.condition[2]));
    lrr_solver *solver = NULL;
    lrr_status s;
    if ((s = lrr_solver_create(op, LRR_BACKEND_CPU, &solver)) != LRR_OK ||
        (s = lrr_solver_set_path(solver, LRR_PATH_FULL)) != LRR_OK) {
        lrr_solver_destroy(solver);
        return bench_lib_fail(ctx, s, "solver");
    }
    double t0 = cli_now();
    s = lrr_solve(solver, e, b);
    r->seconds = cli_now() - t0;
    snprintf(r->status, sizeof r->status, "%s", status_word(s));
    if (s != LRR_OK) {
        char msg[256] = "";
        lrr_context_last_error(ctx, msg, sizeof msg);
        bench_note("%s rho %g lrr_solve: %s%s%s", room->name, rho, lrr_strerror(s),
                   msg[0] ? ": " : "",
             msg);
        r->max_rel = r->rel_l2 = NAN;
    } else {
        compare_exact(n, lrr_operator_area(op), b, 1.0 / (1.0 - rho), &r->max_rel, &r->rel_l2,
                      &r->nonfinite);
    }
    lrr_solver_destroy(solver);
    return CLI_EXIT_OK;
}

/* the reference: full F from the same hemicubes (options bo), solved for e = 1 by each
 * method (B into b). Appends 4 rows. */
static int reference_rows(lrr_context *ctx, const voxel_room *room, double rho,
                          const lrr_scene *scene, const lrr_build_options *bo,
                          const lrr_operator *op, const float *e, float *b, stress_row *rows,
                          size_t *count)
{
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    size_t n = oi.n, k = oi.k, d = oi.d;
    const double exact = 1.0 / (1.0 - rho);
    const float *area = lrr_operator_area(op);
    lrr_reference *ref = NULL;
    lrr_status s;
    if ((s = lrr_reference_build(scene, bo, 0, &ref)) != LRR_OK)
        return bench_lib_fail(ctx, s, "reference build");
    const float *F = lrr_reference_f(ref);
    double fmin_ = INFINITY, fmax_ = -INFINITY;
    for (size_t i = 0; i < n; i++) {
        double sum = 0;
        for (size_t j = 0; j < n; j++)
            sum += F[i * n + j];
        fmin_ = fmin(fmin_, sum);
        fmax_ = fmax(fmax_, sum);
    }
    static const lrr_method methods[] = {LRR_METHOD_JACOBI, LRR_METHOD_GAUSS_SEIDEL,
                                         LRR_METHOD_SOUTHWELL, LRR_METHOD_DIRECT};
    for (size_t m = 0; m < sizeof methods / sizeof methods[0]; m++) {
        stress_row q = {room->name, n, k, d, rho, lrr_method_name(methods[m]), NAN, NAN, 0, 0,
                        NAN, "", 0, NAN, fmin_, fmax_};
        lrr_reference_stats st = {0};
        memset(b, 0, 3 * n * sizeof *b);
        s = lrr_reference_solve(ref, methods[m], 1e-6, 0, e, b, &st, sizeof st);
        snprintf(q.status, sizeof q.status, "%s", status_word(s));
        q.iterations = st.iterations;
        q.seconds = st.seconds;
        q.residual = st.residual;
        if (s == LRR_OK || s == LRR_NOT_CONVERGED)
            compare_exact(n, area, b, exact, &q.max_rel, &q.rel_l2, &q.nonfinite);
        if (s != LRR_OK) {
            char msg[256] = "";
            lrr_context_last_error(ctx, msg, sizeof msg);
            if (msg[0])
                bench_note("%s rho %g %s: %s", room->name, rho, q.method, msg);
        }
        rows[(*count)++] = q;
        print_stress_row(&q);
    }
    lrr_reference_destroy(ref);
    return CLI_EXIT_OK;
}

/* One room at one rho: the operator and the four reference methods. Appends 5 rows. */
static int stress_case(lrr_context *ctx, const voxel_room *room, int quick, unsigned R,
                       double rho, stress_row *rows, size_t *count)
{
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    float *e = NULL, *b = NULL;
    lrr_status s;
    int rc = room_scene(ctx, room, quick, rho, &scene);
    if (rc)
        goto done;
    lrr_build_options bo = {.hemicube_resolution = R, .seed = DEFAULT_SEED};
    double t0 = cli_now();
    if ((s = lrr_operator_build(scene, &bo, &op)) != LRR_OK) {
        rc = bench_lib_fail(ctx, s, "operator build");
        goto done;
    }
    double build_s = cli_now() - t0;
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    size_t n = oi.n;
    e = cli_alloc_rgb(n);
    b = cli_alloc_rgb(n);
    if (!e || !b) {
        rc = CLI_EXIT_FAIL;
        goto done;
    }
    for (size_t i = 0; i < 3 * n; i++)
        e[i] = 1.0f;
    stress_row r;
    if ((rc = operator_row(ctx, room, rho, op, e, b, &r)))
        goto done;
    rows[(*count)++] = r;
    print_stress_row(&r);
    bench_note("%s rho %g: operator n %zu built in %.2f s; reference solvers", room->name, rho, n,
               build_s);
    rc = reference_rows(ctx, room, rho, scene, &bo, op, e, b, rows, count);
done:
    lrr_operator_destroy(op);
    lrr_scene_destroy(scene);
    free(e);
    free(b);
    return rc;
}

int cmd_stress(int argc, char *argv[])
{
    static const char prog[] = "lrr-bench stress";
    static const struct option longopts[] = {{"csv", required_argument, NULL, OPT_CSV},
                                             {"hemicube", required_argument, NULL, OPT_HEMICUBE},
                                             {"quick", no_argument, NULL, OPT_QUICK},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    const char *csv = NULL;
    unsigned R = 0;
    int quick = 0;
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(stress_help, stdout);
            return CLI_EXIT_OK;
        case OPT_CSV:
            csv = optarg;
            break;
        case OPT_HEMICUBE:
            if (cli_parse_unsigned(prog, "--hemicube", optarg, 8, 4096, &R) != 0)
                return CLI_EXIT_USAGE;
            if (R % 2) {
                cli_usage_error(prog, "--hemicube: %u is odd (it must be even)", R);
                return CLI_EXIT_USAGE;
            }
            break;
        case OPT_QUICK:
            quick = 1;
            break;
        default:
            return bench_bad_option(prog, c, argv);
        }
    }
    if (bench_no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if (csv && !csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (R == 0)
        R = quick ? 64 : DEFAULT_HEMICUBE;

    static const double rhos[] = {0.5, 0.9, 0.99, 0.999};
    const size_t n_rooms = sizeof stress_rooms / sizeof stress_rooms[0];
    const size_t n_rho = sizeof rhos / sizeof rhos[0];
    stress_row *rows = calloc(n_rooms * n_rho * 5, sizeof *rows);
    if (!rows)
        return bench_fail("out of memory");
    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK) {
        free(rows);
        return bench_lib_fail(NULL, s, "context");
    }
    double t_start = cli_now();
    printf("benchmark: stress\n");
    bench_print_machine();
    printf("hemicube: %u\n", R);
    printf("exact: B = E/(1 - rho) with E = 1 (valid when the rows of F sum to 1)\n");
    printf("reference_tol: 1e-6\n");
    printf("\n%-7s %5s %4s %3s %6s %-13s %10s %10s %9s %9s %-14s %4s %9s %s\n", "scene", "n",
           "k", "d", "rho", "method", "max_rel", "rel_l2", "iters", "seconds", "status", "nan",
           "cond", "row sums (F̄·d or F)");
    fflush(stdout);
    int rc = CLI_EXIT_OK;
    size_t count = 0;
    for (size_t r = 0; r < n_rooms && rc == CLI_EXIT_OK; r++)
        for (size_t j = 0; j < n_rho && rc == CLI_EXIT_OK; j++)
            rc = stress_case(ctx, &stress_rooms[r], quick, R, rhos[j], rows, &count);
    /* summary: the worst of each kind */
    double worst_op[2] = {0, 0}, worst_ref = 0;
    size_t nonfinite = 0;
    for (size_t i = 0; i < count; i++) {
        const stress_row *q = &rows[i];
        nonfinite += q->nonfinite;
        double err = isnan(q->max_rel) ? INFINITY : q->max_rel;
        if (strcmp(q->method, "lrr") == 0)
            worst_op[q->rho > 0.995] = fmax(worst_op[q->rho > 0.995], err);
        else
            worst_ref = fmax(worst_ref, err);
    }
    printf("\nworst_operator_max_rel_rho_le_0.99: %.3g\n", worst_op[0]);
    printf("worst_operator_max_rel_rho_0.999: %.3g\n", worst_op[1]);
    printf("worst_reference_max_rel: %.3g\n", worst_ref);
    printf("nonfinite_values: %zu\n", nonfinite);
    printf("total_seconds: %.1f\n", cli_now() - t_start);
    if (csv && count) {
        if (write_stress_csv(csv, rows, count) != 0)
            rc = CLI_EXIT_FAIL;
        else
            printf("csv: %s\n", csv);
    }
    free(rows);
    lrr_context_destroy(ctx);
    return rc;
}
