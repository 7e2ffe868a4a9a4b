/* The distributed build (lrr_mpi_operator_build) against the serial lrr_operator_build, on
 * 1 to 4 ranks (tests/mpi/mpi.sh):
 *   F̄ and M bit for bit, the back-face indicator equal, B of the same emission equal, and
 *   the saved files equal byte for byte but for the timings (build_seconds,
 *   selection_seconds, and the checksums over them), for a uniform raster build, a ray-cast one, clusters (the replicated
 *   selection) and two patches on more ranks than patches (empty blocks), rooted at rank 0
 *   and at the last rank;
 * and its faults, every rank returning the same error in seconds: a root out of range,
 * another scene on the last rank (LRR_ERR_DIM), every allocation of the build failing in
 * turn on the last rank (LRR_ERR_NOMEM); and the distributed path tracer
 * (lrr_mpi_reference_path_trace) against the serial one, bit for bit; and the distributed
 * verify (lrr_mpi_operator_verify) against lrr_operator_verify, its figures bit for bit for
 * the scene's emission and for a scene that emits nothing, and its faults. */
#include "mpi_file.h"
#include "mpi_test.h"
#include "mpi_faults.h"

#define FAULT_SECONDS 10.0

typedef struct kind {
    const char *name, *scene;
    size_t K;
    unsigned levels;
    int cluster, raycast;
} kind;

static const kind KINDS[] = {
    {"uniform raster", "cornell", 54, 1, 0, 0},
    {"uniform raycast", "cornell", 54, 1, 0, 1},
    {"clusters", "rooms", 12, 0, 1, 0},
    {"two patches", "pair", 2, 1, 0, 0},
};

static lrr_build_options options(const kind *kd)
{
    lrr_build_options bo = lrr_build_options_defaults();
    bo.hemicube_resolution = 16;
    bo.seed = 5;
    bo.threads = 1;
    if (kd->cluster) {
        bo.adaptive_patches = kd->K;
        bo.hierarchy = LRR_HIERARCHY_CLUSTER;
    }
    if (kd->raycast)
        bo.formfactor_method = LRR_FORMFACTOR_RAYCAST;
    return bo;
}

static lrr_status scene_for(lrr_context *ctx, const kind *kd, size_t K, lrr_scene **sc)
{
    lrr_subdivision sd = lrr_subdivision_defaults();
    sd.target_patches = kd->cluster ? 0 : K;
    sd.levels = kd->levels;
    lrr_status st = mt_scene(ctx, kd->scene, sc);
    return st ? st : lrr_scene_subdivide(*sc, &sd);
}

/* Root's checks of the distributed operator d against the serial s. */
static void compare(const char *what, lrr_operator *d, lrr_operator *s, const char *pd,
                    const char *ps)
{
    lrr_operator_info id, is;
    lrr_operator_get_info(d, &id, sizeof id);
    lrr_operator_get_info(s, &is, sizeof is);
    int fbar = id.n == is.n && id.k == is.k;
    float *rd = calloc(is.k, sizeof(float)), *rs = calloc(is.k, sizeof(float));
    for (size_t i = 0; fbar && rd && rs && i < is.n; i++) {
        lrr_operator_fbar_row(d, i, rd);
        lrr_operator_fbar_row(s, i, rs);
        fbar = memcmp(rd, rs, is.k * sizeof(float)) == 0;
    }
    mt_check(fbar && rd && rs, "%s: F̄ (%zu×%zu) bit for bit the serial build's", what, is.n,
             is.k);
    free(rd);
    free(rs);
    mt_check(fbar && memcmp(lrr_operator_m(d), lrr_operator_m(s),
                            3 * is.k * is.k * sizeof(float)) == 0,
             "%s: M bit for bit", what);
    mt_check(id.back_face_share == is.back_face_share &&
                 memcmp(id.condition, is.condition, sizeof id.condition) == 0,
             "%s: back-face share %g and condition estimates equal", what, id.back_face_share);
    float *e = calloc(3 * is.n, sizeof(float)), *bd = calloc(3 * is.n, sizeof(float)),
          *bs = calloc(3 * is.n, sizeof(float));
    lrr_solver *sd = NULL, *ss = NULL;
    int ok = e && bd && bs && lrr_solver_create(d, LRR_BACKEND_CPU, &sd) == LRR_OK &&
             lrr_solver_create(s, LRR_BACKEND_CPU, &ss) == LRR_OK;
    for (size_t j = 0; ok && j < 3 * is.n; j++)
        e[j] = (float)((j * 7919) % 101) / 100.0f;
    ok = ok && lrr_solve(sd, e, bd) == LRR_OK && lrr_solve(ss, e, bs) == LRR_OK;
    double rel = ok ? mt_max_rel(3 * is.n, bd, bs) : 1;
    mt_check(ok && rel <= 1e-6, "%s: B of a random emission, max rel diff %.3g", what, rel);
    lrr_solver_destroy(sd);
    lrr_solver_destroy(ss);
    free(e);
    free(bd);
    free(bs);
    ok = lrr_operator_save(d, pd) == LRR_OK && lrr_operator_save(s, ps) == LRR_OK;
    mt_check(ok && same_files(pd, ps), "%s: the saved files equal but for the timings", what);
    remove(pd);
    remove(ps);
}

static void equality(const kind *kd, int root)
{
    char what[128], pd[512], ps[512];
    snprintf(what, sizeof what, "%s, root %d", kd->name, root);
    mt_path(pd, sizeof pd, "build-d");
    mt_path(ps, sizeof ps, "build-s");
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL;
    lrr_operator *d = NULL, *s = NULL;
    lrr_build_options bo = options(kd);
    int ok = lrr_context_create(&ctx) == LRR_OK && scene_for(ctx, kd, kd->K, &sc) == LRR_OK;
    lrr_mpi_build_info info;
    lrr_status st = ok ? lrr_mpi_operator_build(sc, &bo, MPI_COMM_WORLD, root, &d, &info,
                                                sizeof info)
                       : LRR_ERR_INVALID_ARG;
    mt_check(st == LRR_OK && (mt_rank == root) == (d != NULL),
             "%s: the build returns the operator on the root alone (%s)", what,
             lrr_strerror(st));
    /* the ranks' receivers add up to n, within a chunk of each other */
    unsigned long long mine = info.rows, sum = 0, lo = 0, hi = 0;
    MPI_Allreduce(&mine, &sum, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &lo, 1, MPI_UNSIGNED_LONG_LONG, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &hi, 1, MPI_UNSIGNED_LONG_LONG, MPI_MAX, MPI_COMM_WORLD);
    if (mt_rank == root && d) {
        lrr_operator_info oi;
        lrr_operator_get_info(d, &oi, sizeof oi);
        mt_check(sum == oi.n && hi - lo <= 64, "%s: the ranks' %llu..%llu receivers add up to "
                 "n = %zu", what, lo, hi, oi.n);
        ok = lrr_operator_build(sc, &bo, &s) == LRR_OK;
        mt_check(ok, "%s: the serial build", what);
        if (ok)
            compare(what, d, s, pd, ps);
    }
    lrr_operator_destroy(d);
    lrr_operator_destroy(s);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* One faulty build: every rank's status equal to want within FAULT_SECONDS, *out NULL,
 * and the message containing needle. */
static void fault(const char *what, lrr_context *ctx, lrr_scene *sc, int root, lrr_status want,
                  const char *needle)
{
    lrr_build_options bo = options(&KINDS[0]);
    lrr_operator *op = (lrr_operator *)1;
    double t0 = MPI_Wtime();
    lrr_status st = lrr_mpi_operator_build(sc, &bo, MPI_COMM_WORLD, root, &op, NULL, 0);
    double t = MPI_Wtime() - t0, slowest;
    int mine = (int)st, lo, hi;
    MPI_Allreduce(&mine, &lo, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &hi, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&t, &slowest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    mt_check(lo == (int)want && hi == (int)want && op == NULL && slowest < FAULT_SECONDS,
             "%s: every rank returns %s within %.3f s, no operator", what, lrr_strerror(want),
             slowest);
    mt_check(strstr(msg, needle) != NULL, "%s: rank %d's message: \"%s\"", what, mt_rank, msg);
}

/* One build of KINDS[0], for mt_allocation_faults (the operator dropped). */
static lrr_status build_once(void *user)
{
    lrr_build_options bo = options(&KINDS[0]);
    lrr_operator *op = NULL;
    lrr_status st = lrr_mpi_operator_build(user, &bo, MPI_COMM_WORLD, 0, &op, NULL, 0);
    lrr_operator_destroy(op);
    return st;
}

static void faults(void)
{
    const kind *kd = &KINDS[0];
    const int last = mt_size - 1;
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL;
    if (lrr_context_create(&ctx) != LRR_OK || scene_for(ctx, kd, kd->K, &sc) != LRR_OK) {
        mt_check(0, "faults: the test scene");
        return;
    }
    fault("root out of range", ctx, sc, mt_size, LRR_ERR_INVALID_ARG, "is not a rank");
    lrr_scene *other = NULL;
    if (mt_size > 1) {
        int ok = mt_rank != last || scene_for(ctx, kd, 2 * kd->K, &other) == LRR_OK;
        mt_check(ok, "another scene on rank %d", last);
        fault("another scene on the last rank", ctx, mt_rank == last ? other : sc, 0,
              LRR_ERR_DIM, "selected another operator");
        lrr_scene_destroy(other);
    }
    /* every allocation counted on the last rank's context failing in turn, until the build
     * needs no more (the count is the same on every rank: it stops everywhere at once) */
    mt_allocation_faults(ctx, "build", build_once, NULL, sc);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* lrr_mpi_reference_path_trace against lrr_reference_path_trace: radiosity and standard
 * errors bit for bit (rooted at the last rank, and without std_error at rank 0); samples
 * of 1 fail on every rank. */
static void traces(void)
{
    const kind *kd = &KINDS[0];
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL;
    if (lrr_context_create(&ctx) != LRR_OK || scene_for(ctx, kd, kd->K, &sc) != LRR_OK) {
        mt_check(0, "path trace: the test scene");
        return;
    }
    lrr_scene_info si;
    lrr_scene_get_info(sc, &si, sizeof si);
    const size_t n = si.subpatches;
    float *b = calloc(3 * n, sizeof(float)), *se = calloc(3 * n, sizeof(float)),
          *bs = calloc(3 * n, sizeof(float)), *ses = calloc(3 * n, sizeof(float));
    lrr_path_trace_options o = lrr_path_trace_options_defaults();
    o.samples = 16;
    o.seed = 11;
    o.threads = 1;
    for (int pass = 0; pass < 2; pass++) {
        const int root = pass == 0 ? mt_size - 1 : 0;
        float *want_se = pass == 0 ? se : NULL;
        lrr_status st = lrr_mpi_reference_path_trace(sc, &o, MPI_COMM_WORLD, root, b, want_se);
        mt_check(st == LRR_OK, "path trace, root %d%s: %s", root,
                 want_se ? "" : ", no std_error", lrr_strerror(st));
        if (mt_rank != root)
            continue;
        int ok = b && se && bs && ses &&
                 lrr_reference_path_trace(sc, &o, bs, ses) == LRR_OK &&
                 memcmp(b, bs, 3 * n * sizeof(float)) == 0 &&
                 (!want_se || memcmp(se, ses, 3 * n * sizeof(float)) == 0);
        mt_check(ok, "path trace, root %d: the serial radiosity%s bit for bit (n = %zu)", root,
                 want_se ? " and standard errors" : "", n);
    }
    o.samples = 1;
    double t0 = MPI_Wtime();
    lrr_status st = lrr_mpi_reference_path_trace(sc, &o, MPI_COMM_WORLD, 0, b, NULL);
    double t = MPI_Wtime() - t0;
    int mine = (int)st, lo, hi;
    MPI_Allreduce(&mine, &lo, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &hi, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    mt_check(lo == LRR_ERR_INVALID_ARG && hi == LRR_ERR_INVALID_ARG && t < FAULT_SECONDS,
             "path trace with 1 sample: every rank returns invalid argument");
    free(b);
    free(se);
    free(bs);
    free(ses);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* Every rank's status equal to want within FAULT_SECONDS. */
static int all_return(lrr_status st, lrr_status want, double seconds)
{
    int mine = (int)st, lo, hi;
    double slowest;
    MPI_Allreduce(&mine, &lo, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &hi, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&seconds, &slowest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    return lo == (int)want && hi == (int)want && slowest < FAULT_SECONDS;
}

/* lrr_mpi_operator_verify on the root's operator against lrr_operator_verify on a second
 * build of it (the build is deterministic): the figures equal to the last bit. */
static void verify_equal(const kind *kd, int root)
{
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL;
    lrr_operator *od = NULL, *os = NULL;
    lrr_build_options bo = options(kd);
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = 16;
    vo.seed = 7;
    vo.threads = 1;
    int ok = lrr_context_create(&ctx) == LRR_OK && scene_for(ctx, kd, kd->K, &sc) == LRR_OK &&
             (mt_rank != root || (lrr_operator_build(sc, &bo, &od) == LRR_OK &&
                                  lrr_operator_build(sc, &bo, &os) == LRR_OK));
    mt_check(ok, "verify %s: the test operators", kd->name);
    lrr_status st = lrr_mpi_operator_verify(od, sc, &vo, MPI_COMM_WORLD, root);
    mt_check(st == LRR_OK, "verify %s, root %d: %s", kd->name, root, lrr_strerror(st));
    if (mt_rank == root && st == LRR_OK && lrr_operator_verify(os, sc, &vo) == LRR_OK) {
        lrr_operator_info id, is;
        lrr_operator_get_info(od, &id, sizeof id);
        lrr_operator_get_info(os, &is, sizeof is);
        mt_check(id.verify_rel_l2 == is.verify_rel_l2 && id.verify_noise == is.verify_noise &&
                     id.verify_subpatches == is.verify_subpatches &&
                     id.verify_samples == is.verify_samples &&
                     id.verify_uniform == is.verify_uniform && id.verify_subpatches > 0,
                 "verify %s, root %d: rel_l2 %.17g, noise %.17g, %zu subpatches%s: the serial "
                 "figures bit for bit", kd->name, root, id.verify_rel_l2, id.verify_noise,
                 id.verify_subpatches, id.verify_uniform ? ", uniform emission" : "");
    }
    lrr_operator_destroy(od);
    lrr_operator_destroy(os);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* Its faults: root out of range, no operator on the root, too few samples, another scene
 * on the last rank, and each allocation counted on the last rank failing in turn. */
/* One verify, for mt_allocation_faults. */
struct verify_call {
    lrr_operator *op;
    lrr_scene *sc;
    const lrr_verify_options *vo;
};
static lrr_status verify_once(void *user)
{
    struct verify_call *c = user;
    return lrr_mpi_operator_verify(c->op, c->sc, c->vo, MPI_COMM_WORLD, 0);
}

static void verify_faults(void)
{
    const kind *kd = &KINDS[0];
    const int last = mt_size - 1;
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL, *other = NULL;
    lrr_operator *op = NULL;
    lrr_build_options bo = options(kd);
    lrr_verify_options vo = lrr_verify_options_defaults();
    vo.samples = 4;
    vo.threads = 1;
    if (lrr_context_create(&ctx) != LRR_OK || scene_for(ctx, kd, kd->K, &sc) != LRR_OK ||
        (mt_rank == 0 && lrr_operator_build(sc, &bo, &op) != LRR_OK) ||
        (mt_rank == last && scene_for(ctx, kd, 2 * kd->K, &other) != LRR_OK)) {
        mt_check(0, "verify faults: the test scenes");
        return;
    }
    struct {
        const char *what;
        int root, other, with_op;
        size_t samples;
        lrr_status want;
    } cases[] = {{"root out of range", mt_size, 0, 1, 4, LRR_ERR_INVALID_ARG},
                 {"no operator on the root", last, 0, 0, 4, LRR_ERR_INVALID_ARG},
                 {"2 samples", 0, 0, 1, 2, LRR_ERR_INVALID_ARG},
                 {"another scene on the last rank", 0, 1, 1, 4, LRR_ERR_DIM}};
    for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
        if (cases[c].other && mt_size == 1)
            continue;
        vo.samples = cases[c].samples;
        double t0 = MPI_Wtime();
        lrr_status st = lrr_mpi_operator_verify(
            cases[c].with_op ? op : NULL, /* op is rank 0's (NULL elsewhere) */
            cases[c].other && mt_rank == last ? other : sc, &vo, MPI_COMM_WORLD, cases[c].root);
        char msg[512];
        lrr_context_last_error(ctx, msg, sizeof msg);
        mt_check(all_return(st, cases[c].want, MPI_Wtime() - t0),
                 "verify, %s: every rank returns %s (rank %d: \"%s\")", cases[c].what,
                 lrr_strerror(cases[c].want), mt_rank, msg);
    }
    vo.samples = 4;
    struct verify_call call = {op, sc, &vo};
    mt_allocation_faults(ctx, "verify", verify_once, NULL, &call);
    lrr_operator_destroy(op);
    lrr_scene_destroy(other);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

int main(int argc, char **argv)
{
    /* test_mpi_build --same A B: mpi.sh's check of `mpirun lrr preprocess`'s file */
    if (argc == 4 && strcmp(argv[1], "--same") == 0) {
        int same = same_files(argv[2], argv[3]);
        printf("%s: %s and %s\n", same ? "same but for the timings" : "differ", argv[2],
               argv[3]);
        return same ? 0 : 1;
    }
    mt_init(&argc, &argv);
    for (size_t c = 0; c < sizeof KINDS / sizeof *KINDS; c++)
        equality(&KINDS[c], c == 0 ? mt_size - 1 : 0);
    faults();
    traces();
    verify_equal(&KINDS[0], mt_size - 1);
    verify_equal(&(kind){"dark clusters", "dark", 12, 0, 1, 0}, 0);
    verify_faults();
    return mt_finish();
}
