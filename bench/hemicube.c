/*
 * lrr-bench hemicube: hemicube resolution against closed-form view factors and R = 512.
 */
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bench.h"

static const char hemicube_help[] =
    "Usage: lrr-bench hemicube [OPTIONS]\n"
    "For R in 16, 32, 64, 128, 256: preprocessing time of the Cornell box (216 patches,\n"
    "d = 4) and form-factor errors of\n"
    "  parallel     unit squares facing each other at distance 1 (closed form 0.19982)\n"
    "  perpendicular unit squares sharing an edge (closed form 0.20004)\n"
    "as relative errors against the closed forms (Howell's catalogue, computed here) and\n"
    "against the exact point-to-polygon form factors (Lambert) averaged over the same\n"
    "subpatch centres (the hemicube's own error, without the quadrature's), and the relative\n"
    "L2 difference of the Cornell F̄ from an R = 512 build.\n"
    "Each R is run with the random rotation about the normal (one row per seed) and without\n"
    "it (lrr_build_options.no_rotation: every hemicube in the same tangent frame, so the\n"
    "pixel grid's aliasing lines up across receivers instead of averaging out).\n"
    "\n"
    "Options:\n"
    "  --csv OUT.csv        R,seed,rotation,cornell_preprocess_s,f_parallel,err_parallel,\n"
    "                       err_parallel_quadrature,f_perpendicular,err_perpendicular,\n"
    "                       err_perpendicular_quadrature,cornell_rel_l2,n_cornell,k_cornell\n"
    "  --seeds N            seeds 1..N per resolution (1..10, default 3)\n"
    "  --quick              R in 16, 32 only, one seed, R = 128 as the reference (for tests)\n"
    "  --rates              instead: hemicubes per second of 'lrr preprocess cornell\n"
    "                       --patches 216 --levels 2 --hemicube R --threads T' (n = 3456),\n"
    "                       R in 32, 64, 128 (16, 32 with --quick), T = 1 and all threads:\n"
    "                       formfactor_seconds (the hemicubes alone) of --builds builds,\n"
    "                       min, median and max, and n / seconds at the median and the\n"
    "                       best. CSV: R,threads,n,builds,seconds_min,seconds_median,\n"
    "                       seconds_max,hemicubes_per_s_median,hemicubes_per_s_best\n"
    "  --builds N           --rates: builds per row (1..99, default 7)\n"
    "  -h, --help           show this help\n";


/* ================================================================== hemicube */
static double parallel_closed_form(double X, double Y)
{
    /* Howell C-11: parallel, directly opposed rectangles a×b at distance c, X = a/c, Y = b/c */
    double a = log(sqrt((1 + X * X) * (1 + Y * Y) / (1 + X * X + Y * Y)));
    double b = X * sqrt(1 + Y * Y) * atan(X / sqrt(1 + Y * Y));
    double c = Y * sqrt(1 + X * X) * atan(Y / sqrt(1 + X * X));
    return 2 / (M_PI * X * Y) * (a + b + c - X * atan(X) - Y * atan(Y));
}

static double perpendicular_closed_form(double W, double H)
{
    /* Howell C-14: perpendicular rectangles with a common edge l, W = w/l, H = h/l */
    double s = sqrt(H * H + W * W);
    double l1 = (1 + W * W) * (1 + H * H) / (1 + W * W + H * H);
    double l2 = pow(W * W * (1 + W * W + H * H) / ((1 + W * W) * (W * W + H * H)), W * W);
    double l3 = pow(H * H * (1 + W * W + H * H) / ((1 + H * H) * (W * W + H * H)), H * H);
    return 1 / (M_PI * W) *
           (W * atan(1 / W) + H * atan(1 / H) - s * atan(1 / s) + 0.25 * log(l1 * l2 * l3));
}

/* Lambert's formula: the exact form factor from a differential area at x (unit normal nr)
 * to a polygon wholly in front of it. */
static double point_to_polygon(const double x[3], const float nr[3], const double (*poly)[3],
                               int nv)
{
    double sum = 0;
    for (int i = 0; i < nv; i++) {
        double a[3], b[3];
        for (int j = 0; j < 3; j++) {
            a[j] = poly[i][j] - x[j];
            b[j] = poly[(i + 1) % nv][j] - x[j];
        }
        double cr[3] = {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2],
                        a[0] * b[1] - a[1] * b[0]};
        double len = sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
        if (len < 1e-300)
            continue;
        double gamma = atan2(len, a[0] * b[0] + a[1] * b[1] + a[2] * b[2]);
        sum += gamma * (nr[0] * cr[0] + nr[1] * cr[1] + nr[2] * cr[2]) / len;
    }
    return fabs(sum) / (2 * M_PI);
}

static void quad_triangles(float *v, const double q[4][3])
{
    const int tri[2][3] = {{0, 1, 2}, {0, 2, 3}};
    for (int h = 0; h < 2; h++)
        for (int j = 0; j < 3; j++)
            for (int k = 0; k < 3; k++)
                v[9 * h + 3 * j + k] = (float)q[tri[h][j]][k];
}

/* Two unit squares (4 triangles): the receiver on z = 0 facing +z, and the other. */
typedef struct square_pair {
    double recv[4][3], other[4][3];
} square_pair;

static const square_pair parallel_pair = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, /* normal +z */
    {{0, 0, 1}, {0, 1, 1}, {1, 1, 1}, {1, 0, 1}}, /* normal -z */
};
static const square_pair perpendicular_pair = {
    {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}}, /* normal +z */
    {{0, 0, 0}, {0, 1, 0}, {0, 1, 1}, {0, 0, 1}}, /* x = 0, normal +x */
};

typedef struct ff_result {
    double f;      /* area-averaged F from the hemicubes */
    double quad;   /* the same average of the exact point-to-square form factors */
    double build_s;
} ff_result;

/* Area-averaged form factor from the receiver square to the other, from F̄·d, with the exact
 * point-to-polygon value at the same subpatch centres. */
static int square_form_factor(lrr_context *ctx, const square_pair *sp, unsigned levels,
                              unsigned R, uint64_t seed, int no_rotation, ff_result *out)
{
    float v[36], rho[12], em[12] = {0};
    for (int i = 0; i < 12; i++)
        rho[i] = 0.5f;
    for (int i = 0; i < 2; i++)
        quad_triangles(v + 18 * i, i == 0 ? sp->recv : sp->other);
    lrr_scene *scene = NULL;
    lrr_operator *op = NULL;
    lrr_status s = lrr_scene_create(ctx, 4, v, rho, em, "squares", &scene);
    if (s == LRR_OK)
        s = lrr_scene_subdivide(scene, &(lrr_subdivision){.levels = levels});
    lrr_build_options bo = {.hemicube_resolution = R, .seed = seed, .no_rotation = no_rotation};
    cli_idle_openblas(); /* the last build's SMW left OpenBLAS's workers spinning */
    double t0 = cli_now();
    if (s == LRR_OK)
        s = lrr_operator_build(scene, &bo, &op);
    if (s == LRR_OK) /* the checks below read F̄ as rows */
        s = lrr_operator_set_layout(op, LRR_LAYOUT_ROWS);
    out->build_s = cli_now() - t0;
    lrr_scene_destroy(scene);
    if (s != LRR_OK)
        return bench_lib_fail(ctx, s, "squares");
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const float *fbar = lrr_operator_fbar(op), *area = lrr_operator_area(op);
    const float *centre = lrr_operator_centre(op), *normal = lrr_operator_normal(op);
    /* the receiver square's subpatches face +z and lie on z = 0; a patch belongs to the other
     * square when its first subpatch does not */
    double num = 0, qnum = 0, den = 0;
    for (size_t i = 0; i < oi.n; i++) {
        const float *c = centre + 3 * i, *nr = normal + 3 * i;
        if (!(nr[2] > 0.99f && fabsf(c[2]) < 1e-6f))
            continue;
        double row = 0;
        for (size_t p = 0; p < oi.k; p++) {
            const float *cp = centre + 3 * p * oi.d, *np = normal + 3 * p * oi.d;
            if (np[2] > 0.99f && fabsf(cp[2]) < 1e-6f)
                continue;
            row += fbar[i * oi.k + p];
        }
        double x[3] = {c[0], c[1], c[2]};
        num += area[i] * row * (double)oi.d;
        qnum += area[i] * point_to_polygon(x, nr, sp->other, 4);
        den += area[i];
    }
    out->f = num / den;
    out->quad = qnum / den;
    lrr_operator_destroy(op);
    return 0;
}

static int cornell_fbar(lrr_context *ctx, unsigned R, uint64_t seed, int no_rotation,
                        lrr_operator **op, double *seconds)
{
    lrr_scene *scene = NULL;
    lrr_status s = lrr_scene_builtin(ctx, "cornell", &scene);
    if (s == LRR_OK)
        s = lrr_scene_subdivide(scene, &(lrr_subdivision){.target_patches = 216, .levels = 1});
    lrr_build_options bo = {.hemicube_resolution = R, .seed = seed, .no_rotation = no_rotation};
    cli_progress bar;
    bench_progress_begin(&bar, "hemicubes", &bo);
    cli_idle_openblas(); /* the last build's SMW left OpenBLAS's workers spinning */
    double t0 = cli_now();
    if (s == LRR_OK)
        s = lrr_operator_build(scene, &bo, op);
    *seconds = cli_now() - t0;
    if (s == LRR_OK) /* fbar_rel_l2 reads F̄ as rows */
        s = lrr_operator_set_layout(*op, LRR_LAYOUT_ROWS);
    cli_progress_finish(&bar);
    lrr_scene_destroy(scene);
    return s == LRR_OK ? 0 : bench_lib_fail(ctx, s, "Cornell box");
}

typedef struct hemicube_args {
    const char *csv;
    unsigned seeds; /* seeds 1..N per resolution */
    int quick;
    int rates;       /* --rates: hemicube_rates.c instead */
    unsigned builds; /* --rates: builds per row */
} hemicube_args;

/* The options into *a (--quick without --seeds: one seed). Returns BENCH_RUN, or the exit
 * status (CLI_EXIT_OK after --help). */
static int hemicube_parse(int argc, char *argv[], hemicube_args *a)
{
    static const char prog[] = "lrr-bench hemicube";
    static const struct option longopts[] = {{"csv", required_argument, NULL, OPT_CSV},
                                             {"seeds", required_argument, NULL, OPT_SEEDS},
                                             {"quick", no_argument, NULL, OPT_QUICK},
                                             {"rates", no_argument, NULL, OPT_RATES},
                                             {"builds", required_argument, NULL, OPT_BUILDS},
                                             {"help", no_argument, NULL, 'h'},
                                             {NULL, 0, NULL, 0}};
    int have_seeds = 0, have_builds = 0;
    bench_start_getopt();
    int c;
    while ((c = getopt_long(argc, argv, ":h", longopts, NULL)) != -1) {
        switch (c) {
        case 'h':
            fputs(hemicube_help, stdout);
            return CLI_EXIT_OK;
        case OPT_CSV:
            a->csv = optarg;
            break;
        case OPT_SEEDS:
            if (cli_parse_unsigned(prog, "--seeds", optarg, 1, 10, &a->seeds) != 0)
                return CLI_EXIT_USAGE;
            have_seeds = 1;
            break;
        case OPT_QUICK:
            a->quick = 1;
            break;
        case OPT_RATES:
            a->rates = 1;
            break;
        case OPT_BUILDS:
            if (cli_parse_unsigned(prog, "--builds", optarg, 1, 99, &a->builds) != 0)
                return CLI_EXIT_USAGE;
            have_builds = 1;
            break;
        default:
            return bench_bad_option(prog, c, argv);
        }
    }
    if (bench_no_positional(prog, argc, argv))
        return CLI_EXIT_USAGE;
    if (a->csv && !a->csv[0]) {
        cli_usage_error(prog, "--csv: the file name is empty");
        return CLI_EXIT_USAGE;
    }
    if (a->quick && !have_seeds)
        a->seeds = 1;
    if (have_builds && !a->rates) {
        cli_usage_error(prog, "--builds goes with --rates");
        return CLI_EXIT_USAGE;
    }
    if (have_seeds && a->rates) {
        cli_usage_error(prog, "--seeds does not go with --rates");
        return CLI_EXIT_USAGE;
    }
    return BENCH_RUN;
}

/* Relative L2 of F̄ (count floats) against the reference's. */
static double fbar_rel_l2(const lrr_operator *op, const lrr_operator *ref, size_t count)
{
    const float *a = lrr_operator_fbar(op), *bref = lrr_operator_fbar(ref);
    double num = 0, den = 0;
    for (size_t j = 0; j < count; j++) {
        double dlt = (double)a[j] - bref[j];
        num += dlt * dlt;
        den += (double)bref[j] * bref[j];
    }
    return sqrt(num / den);
}

int cmd_hemicube(int argc, char *argv[])
{
    hemicube_args ha = {NULL, 3, 0, 0, 7};
    int prc = hemicube_parse(argc, argv, &ha);
    if (prc != BENCH_RUN)
        return prc;
    if (ha.rates)
        return hemicube_rates(ha.csv, ha.builds, ha.quick);
    const char *csv = ha.csv;
    const unsigned seeds = ha.seeds;
    const int quick = ha.quick;
    static const unsigned full_res[] = {16, 32, 64, 128, 256}, quick_res[] = {16, 32};
    const unsigned *res = quick ? quick_res : full_res;
    size_t n_res = quick ? 2 : 5;
    unsigned ref_res = quick ? 128 : 512;
    unsigned levels = quick ? 3 : 4;

    lrr_context *ctx = NULL;
    lrr_status s = lrr_context_create(&ctx);
    if (s != LRR_OK)
        return bench_lib_fail(NULL, s, "context");
    double t_start = cli_now();
    const double par_exact = parallel_closed_form(1, 1);
    const double perp_exact = perpendicular_closed_form(1, 1);
    printf("benchmark: hemicube\n");
    bench_print_machine();
    printf("rotation: with (one row per seed) and without (lrr_build_options.no_rotation)\n");
    printf("closed_form_parallel: %.6f\n", par_exact);
    printf("closed_form_perpendicular: %.6f\n", perp_exact);
    printf("square_subpatches: %u per triangle (levels %u)\n", 1u << (2 * levels), levels);
    bench_note("Cornell box reference build at R = %u", ref_res);
    lrr_operator *ref = NULL;
    double ref_s = 0;
    if (cornell_fbar(ctx, ref_res, 1, 0, &ref, &ref_s)) {
        lrr_context_destroy(ctx);
        return CLI_EXIT_FAIL;
    }
    lrr_operator_info ri;
    lrr_operator_get_info(ref, &ri, sizeof ri);
    printf("cornell: n %zu, k %zu, d %zu; reference R = %u seed 1 built in %.2f s\n", ri.n, ri.k,
           ri.d, ref_res, ref_s);

    cli_outfile out;
    int have_out = 0, rc = CLI_EXIT_OK;
    if (csv) {
        if (cli_outfile_open(&out, csv) != 0) {
            rc = bench_fail("cannot create a temporary file for '%s': %s", csv, strerror(errno));
            goto done;
        }
        have_out = 1;
        fputs("R,seed,rotation,cornell_preprocess_s,f_parallel,err_parallel,"
              "err_parallel_quadrature,f_perpendicular,err_perpendicular,"
              "err_perpendicular_quadrature,cornell_rel_l2,n_cornell,k_cornell\n",
              out.f);
    }
    int printed_quad = 0;
    printf("\n%5s %5s %8s %9s %10s %10s %10s %10s %10s %10s %12s\n", "R", "seed", "rotation",
           "prep_s", "F_par", "err_par", "err_par_q", "F_perp", "err_perp", "err_perp_q",
           "cornell_L2");
    for (size_t i = 0; i < n_res && rc == CLI_EXIT_OK; i++)
        for (unsigned sd = 1; sd <= seeds + 1 && rc == CLI_EXIT_OK; sd++) {
            /* seeds 1..N with the rotation, then one row without it (its seed is moot) */
            const int norot = sd == seeds + 1;
            unsigned R = res[i];
            bench_note("R = %u, %s %u", R, norot ? "no rotation, row" : "seed", sd);
            ff_result par, perp;
            if ((rc = square_form_factor(ctx, &parallel_pair, levels, R, sd, norot, &par)) ||
                (rc = square_form_factor(ctx, &perpendicular_pair, levels, R, sd, norot, &perp)))
                break;
            if (!printed_quad) {
                printf("# quadrature (exact point form factors at the receivers' centres): "
                       "parallel %.6f, perpendicular %.6f\n",
                       par.quad, perp.quad);
                printed_quad = 1;
            }
            lrr_operator *op = NULL;
            double prep = 0;
            if ((rc = cornell_fbar(ctx, R, sd, norot, &op, &prep)))
                break;
            double l2 = fbar_rel_l2(op, ref, ri.n * ri.k);
            lrr_operator_destroy(op);
            double ep = par.f / par_exact - 1, epq = par.f / par.quad - 1;
            double er = perp.f / perp_exact - 1, erq = perp.f / perp.quad - 1;
            char seed_text[16];
            snprintf(seed_text, sizeof seed_text, "%u", sd);
            printf("%5u %5s %8s %9.3f %10.6f %+10.2e %+10.2e %10.6f %+10.2e %+10.2e %12.3e\n", R,
                   norot ? "-" : seed_text, norot ? "no" : "yes", prep, par.f, ep, epq, perp.f,
                   er, erq, l2);
            fflush(stdout);
            if (have_out)
                fprintf(out.f, "%u,%s,%s,%.6g,%.9g,%.6g,%.6g,%.9g,%.6g,%.6g,%.6g,%zu,%zu\n", R,
                        norot ? "nan" : seed_text, norot ? "no" : "yes", prep, par.f, ep, epq,
                        perp.f, er, erq, l2, ri.n, ri.k);
        }
    printf("\ntotal_seconds: %.1f\n", cli_now() - t_start);
    if (have_out) {
        have_out = 0;
        rc = bench_csv_finish(&out, rc, csv);
    }
done:
    if (have_out)
        cli_outfile_abort(&out);
    lrr_operator_destroy(ref);
    lrr_context_destroy(ctx);
    return rc;
}
