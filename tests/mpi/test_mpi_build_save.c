/* The distributed build that writes its file without gathering F̄
 * (lrr_mpi_operator_build_save) against the serial lrr_operator_build,
 * lrr_operator_set_storage and lrr_operator_save_fbar, on 1 to 4 ranks (tests/mpi/mpi.sh):
 *   the files equal byte for byte but for the timings, for the uniform quadtree (floats,
 *   dense), clusters (patches that span the ranks' chunks: G's partial rows passed on, the
 *   Vᵀ weights from every rank's row sums) in binary16 and bfloat16, as rows and as strips,
 *   and two patches on more ranks than patches; the root's operator without F̄ has the
 *   serial M and condition bit for bit; the ranks' rows of F̄ add up to F̄;
 *   with LRR_MPI_FACTOR=scalapack (mpi.sh, small blocks), the same but for M and the
 *   condition numbers, within rounding, and a solve of the file against the serial one;
 *   the memory budget per rank: a budget below what the serial build needs but above one
 *   rank's share of F̄ fails serially (LRR_ERR_BUDGET) and succeeds on two ranks or more;
 * and its faults, every rank returning the same error in seconds and no file left: a root
 * without a path, an unknown LRR_MPI_FACTOR (and scalapack when built without it), a
 * directory that does not exist, the root's and then the last rank's file size limited so
 * that its writes of its chunks of F̄ (MPI-IO) fail within the section, and every
 * allocation of the last rank failing in turn. */
#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <sys/resource.h>

#include "mpi_file.h"
#include "mpi_test.h"
#include "mpi_faults.h"

#define FAULT_SECONDS 10.0

typedef struct kind {
    const char *name, *scene;
    size_t K;
    unsigned levels;
    int cluster;
    lrr_storage storage;
    lrr_fbar_format fbar;
} kind;

static const kind KINDS[] = {
    {"uniform, f32", "cornell", 54, 1, 0, LRR_STORAGE_F32, LRR_FBAR_AUTO},
    {"clusters, f16", "cornell", 12, 0, 1, LRR_STORAGE_F16, LRR_FBAR_AUTO},
    {"clusters, bf16 as strips", "rooms", 12, 0, 1, LRR_STORAGE_BF16, LRR_FBAR_SPARSE},
    {"uniform, f16 dense", "rooms", 24, 1, 0, LRR_STORAGE_F16, LRR_FBAR_DENSE},
    {"two patches", "pair", 2, 1, 0, LRR_STORAGE_F32, LRR_FBAR_AUTO},
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
    return bo;
}

static lrr_status scene_for(lrr_context *ctx, const kind *kd, lrr_scene **sc)
{
    lrr_subdivision sd = lrr_subdivision_defaults();
    /* clusters group about 600 subpatches (the scene's patches, levels 0): clusters of
     * about 50 rows, most of them across a chunk's end */
    sd.target_patches = kd->cluster ? 600 : kd->K;
    sd.levels = kd->levels;
    lrr_status st = mt_scene(ctx, kd->scene, sc);
    return st ? st : lrr_scene_subdivide(*sc, &sd);
}

/* The serial file of kd at ps (the root's). */
static int serial_file(const lrr_scene *sc, const kind *kd, const char *ps, lrr_operator **s)
{
    lrr_build_options bo = options(kd);
    return lrr_operator_build(sc, &bo, s) == LRR_OK &&
           lrr_operator_set_storage(*s, kd->storage) == LRR_OK &&
           lrr_operator_save_fbar(*s, ps, kd->fbar) == LRR_OK;
}

/* Whether no file of this run (its pid in the name) is left in the scratch directory. */
static int no_file_left(const char *path)
{
    char dir[512];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/'), *base = slash ? slash + 1 : dir;
    char stem[512];
    snprintf(stem, sizeof stem, "%s", base);
    if (slash)
        *slash = '\0';
    DIR *d = opendir(slash ? dir : ".");
    int left = 0;
    for (struct dirent *e; d && (e = readdir(d));)
        left += strncmp(e->d_name, stem, strlen(stem)) == 0;
    if (d)
        closedir(d);
    return d ? left == 0 : errno == ENOENT; /* no directory: nothing in it */
}

/* Whether G is inverted with ScaLAPACK (tests/mpi/mpi.sh sets LRR_MPI_FACTOR=scalapack and
 * small blocks): then M and the condition numbers are the serial ones to rounding only. */
static int scalapack(void)
{
    const char *v = getenv("LRR_MPI_FACTOR");
    return v && strcmp(v, "scalapack") == 0;
}

/* max |a − b| / max |b| over m floats of M. */
static double m_rel(size_t m, const float *a, const float *b)
{
    return a && b ? mt_max_rel(m, a, b) : 1;
}

/* M is stored in float: each entry rounds to 2⁻²⁴ relative (6e-8), and the two inversions
 * differ in double by about cond·ε (cond < 100 here: 2e-14), so 1e-5 of max |M| is loose (they
 * agree bit for bit in practice). The condition: ScaLAPACK's is exact (lib/mpi/invert.c), the
 * serial dgecon's an estimate, equal to it for these matrices to rounding (1e-6). B of a
 * loaded file's solve against the serial operator's within 1e-6 (as test_mpi_build). */
static void near_serial(const char *what, const lrr_operator *head, const lrr_operator *s,
                        const char *pd)
{
    lrr_operator_info ih, is, il;
    lrr_operator_get_info(head, &ih, sizeof ih);
    lrr_operator_get_info(s, &is, sizeof is);
    const size_t kk3 = 3 * is.k * is.k, n3 = 3 * is.n;
    double rm = m_rel(kk3, lrr_operator_m(head), lrr_operator_m(s)), rc = 0;
    for (int c = 0; c < 3; c++)
        rc = fmax(rc, fabs(ih.condition[c] - is.condition[c]) / is.condition[c]);
    mt_check(rm <= 1e-5 && rc <= 1e-6 && ih.back_face_share == is.back_face_share,
             "%s: ScaLAPACK: the root's M within %.3g of max |M|, conditions within %.3g",
             what, rm, rc);
    lrr_context *ctx = NULL;
    lrr_operator *l = NULL;
    lrr_solver *sl = NULL, *ss = NULL;
    float *e = calloc(n3, sizeof(float)), *bl = calloc(n3, sizeof(float)),
          *bs = calloc(n3, sizeof(float));
    int ok = e && bl && bs && lrr_context_create(&ctx) == LRR_OK &&
             lrr_operator_load(ctx, pd, &l) == LRR_OK;
    if (ok)
        lrr_operator_get_info(l, &il, sizeof il);
    double rl = ok ? m_rel(kk3, lrr_operator_m(l), lrr_operator_m(s)) : 1;
    ok = ok && lrr_solver_create(l, LRR_BACKEND_CPU, &sl) == LRR_OK &&
         lrr_solver_create(s, LRR_BACKEND_CPU, &ss) == LRR_OK;
    for (size_t j = 0; ok && j < n3; j++)
        e[j] = (float)((j * 7919) % 101) / 100.0f;
    ok = ok && lrr_solve(sl, e, bl) == LRR_OK && lrr_solve(ss, e, bs) == LRR_OK;
    double rb = ok ? mt_max_rel(n3, bl, bs) : 1;
    mt_check(ok && rl <= 1e-5 && rb <= 1e-6 &&
                 memcmp(il.condition, ih.condition, sizeof il.condition) == 0,
             "%s: ScaLAPACK: the file's M within %.3g, its conditions the root's, B of its "
             "solve within %.3g of the serial one", what, rl, rb);
    lrr_solver_destroy(sl);
    lrr_solver_destroy(ss);
    lrr_operator_destroy(l);
    lrr_context_destroy(ctx);
    free(e);
    free(bl);
    free(bs);
}

static void equality(const kind *kd, int root)
{
    char what[160], pd[512], ps[512];
    snprintf(what, sizeof what, "%s, root %d", kd->name, root);
    mt_path(pd, sizeof pd, "save-d");
    mt_path(ps, sizeof ps, "save-s");
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL;
    lrr_operator *head = NULL, *s = NULL;
    lrr_build_options bo = options(kd);
    int ok = lrr_context_create(&ctx) == LRR_OK && scene_for(ctx, kd, &sc) == LRR_OK;
    lrr_mpi_build_info info;
    memset(&info, 0, sizeof info);
    lrr_status st = ok ? lrr_mpi_operator_build_save(sc, &bo, kd->storage, kd->fbar,
                                                     mt_rank == root ? pd : NULL,
                                                     MPI_COMM_WORLD, root, &head, &info,
                                                     sizeof info)
                       : LRR_ERR_INVALID_ARG;
    mt_check(st == LRR_OK && (mt_rank == root) == (head != NULL),
             "%s: the file written, the operator without F̄ on the root alone (%s)", what,
             lrr_strerror(st));
    unsigned long long mine = info.fbar_bytes, sum = 0;
    MPI_Allreduce(&mine, &sum, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    if (mt_rank == root && head) {
        ok = serial_file(sc, kd, ps, &s);
        mt_check(ok, "%s: the serial build and file", what);
        lrr_operator_info ih, is;
        lrr_operator_get_info(head, &ih, sizeof ih);
        if (ok)
            lrr_operator_get_info(s, &is, sizeof is);
        const size_t es = kd->storage == LRR_STORAGE_F32 ? 4 : 2;
        mt_check(ok && sum == is.n * is.k * es && lrr_operator_fbar(head) == NULL,
                 "%s: the ranks held %llu bytes of F̄ (n×k×%zu), the root's operator none",
                 what, sum, es);
        if (scalapack()) {
            mt_check(ok && same_files_but(pd, ps, 1u << 5 | 1u << 6),
                     "%s: ScaLAPACK: the file the serial one but for M and INFO", what);
            if (ok)
                near_serial(what, head, s, pd);
        } else {
            mt_check(ok && same_files(pd, ps), "%s: the file the serial one but for its "
                     "timings", what);
            mt_check(ok && memcmp(lrr_operator_m(head), lrr_operator_m(s),
                                  3 * is.k * is.k * sizeof(float)) == 0 &&
                         memcmp(ih.condition, is.condition, sizeof is.condition) == 0 &&
                         ih.back_face_share == is.back_face_share,
                     "%s: the root's M, condition estimates and back-face share bit for bit",
                     what);
        }
        remove(pd);
        remove(ps);
    }
    lrr_operator_destroy(head);
    lrr_operator_destroy(s);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* The serial build's need in bytes and F̄'s part, from its budget error. */
static int serial_need(lrr_context *ctx, const lrr_scene *sc, const kind *kd, double *need,
                       double *fbar)
{
    lrr_build_options bo = options(kd);
    bo.memory_budget = 1;
    lrr_operator *op = NULL;
    char msg[512];
    lrr_status st = lrr_operator_build(sc, &bo, &op);
    lrr_operator_destroy(op);
    lrr_context_last_error(ctx, msg, sizeof msg);
    const char *at = strstr(msg, "needs ");
    return st == LRR_ERR_BUDGET && at && sscanf(at, "needs %lf MiB (F̄ %lf MiB", need, fbar) == 2;
}

/* A budget the serial build exceeds by 40 % of F̄: two ranks hold half of F̄ each. */
static void budget(void)
{
    const kind kd = {"budget", "cornell", 216, 2, 0, LRR_STORAGE_F32, LRR_FBAR_AUTO};
    char path[512];
    mt_path(path, sizeof path, "save-budget");
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL;
    double need = 0, fbar = 0;
    int ok = lrr_context_create(&ctx) == LRR_OK && scene_for(ctx, &kd, &sc) == LRR_OK &&
             serial_need(ctx, sc, &kd, &need, &fbar) && fbar > 0.5 * need;
    mt_check(ok, "budget: the serial need %.1f MiB, F̄ %.1f MiB of it", need, fbar);
    if (!ok)
        return;
    lrr_build_options bo = options(&kd);
    bo.memory_budget = (size_t)((need - 0.4 * fbar) * 1048576.0);
    lrr_operator *op = NULL;
    lrr_status serial = lrr_operator_build(sc, &bo, &op);
    lrr_operator_destroy(op);
    mt_check(serial == LRR_ERR_BUDGET, "budget %.1f MiB: the serial build refuses (%s)",
             bo.memory_budget / 1048576.0, lrr_strerror(serial));
    lrr_status st = lrr_mpi_operator_build_save(sc, &bo, LRR_STORAGE_F32, LRR_FBAR_AUTO, path,
                                                MPI_COMM_WORLD, 0, NULL, NULL, 0);
    lrr_status want = mt_size >= 2 ? LRR_OK : LRR_ERR_BUDGET;
    mt_check(st == want, "budget %.1f MiB on %d rank(s): %s (want %s)",
             bo.memory_budget / 1048576.0, mt_size, lrr_strerror(st), lrr_strerror(want));
    if (mt_rank == 0)
        remove(path);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

/* One faulty build_save: every rank's status want within FAULT_SECONDS, the message with
 * needle, no file (nor temporary file) left. */
static void fault(const char *what, lrr_context *ctx, lrr_scene *sc, const char *path,
                  lrr_status want, const char *needle)
{
    const kind *kd = &KINDS[1];
    lrr_build_options bo = options(kd);
    lrr_operator *head = (lrr_operator *)1;
    double t0 = MPI_Wtime();
    lrr_status st = lrr_mpi_operator_build_save(sc, &bo, kd->storage, kd->fbar, path,
                                                MPI_COMM_WORLD, 0, &head, NULL, 0);
    double t = MPI_Wtime() - t0, slowest;
    int mine = (int)st, lo, hi;
    MPI_Allreduce(&mine, &lo, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &hi, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    MPI_Allreduce(&t, &slowest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    char msg[512];
    lrr_context_last_error(ctx, msg, sizeof msg);
    mt_check(lo == (int)want && hi == (int)want && head == NULL && slowest < FAULT_SECONDS &&
                 (!path || mt_rank != 0 || no_file_left(path)),
             "%s: every rank returns %s within %.3f s, no operator, no file", what,
             lrr_strerror(want), slowest);
    mt_check(strstr(msg, needle) != NULL, "%s: rank %d's message: \"%s\"", what, mt_rank, msg);
}

/* One build_save of KINDS[1] to path, for mt_allocation_faults; the root leaves no file
 * when it fails. */
struct save_call {
    lrr_scene *sc;
    const char *path;
};
static lrr_status save_once(void *user)
{
    struct save_call *c = user;
    lrr_build_options bo = options(&KINDS[1]);
    return lrr_mpi_operator_build_save(c->sc, &bo, KINDS[1].storage, KINDS[1].fbar, c->path,
                                       MPI_COMM_WORLD, 0, NULL, NULL, 0);
}
static int save_left_nothing(void *user, lrr_status st)
{
    const char *path = ((struct save_call *)user)->path;
    if (mt_rank != 0)
        return 1;
    int clean = st == LRR_OK || no_file_left(path); /* a success wrote it */
    remove(path);
    return clean;
}

static void faults(void)
{
    lrr_context *ctx = NULL;
    lrr_scene *sc = NULL;
    char path[512], nodir[600];
    mt_path(path, sizeof path, "save-fault");
    snprintf(nodir, sizeof nodir, "%s.missing/op.lrr", path);
    if (lrr_context_create(&ctx) != LRR_OK || scene_for(ctx, &KINDS[1], &sc) != LRR_OK) {
        mt_check(0, "faults: the test scene");
        return;
    }
    fault("no path on the root", ctx, sc, NULL, LRR_ERR_INVALID_ARG, "path is NULL");
    /* the root's LRR_MPI_FACTOR decides for every rank */
    char *was = getenv("LRR_MPI_FACTOR") ? strdup(getenv("LRR_MPI_FACTOR")) : NULL;
    setenv("LRR_MPI_FACTOR", "lapack", 1);
    fault("LRR_MPI_FACTOR=lapack", ctx, sc, path, LRR_ERR_INVALID_ARG, "LRR_MPI_FACTOR=lapack");
#ifndef LRR_SCALAPACK
    setenv("LRR_MPI_FACTOR", "scalapack", 1);
    fault("LRR_MPI_FACTOR=scalapack without ScaLAPACK", ctx, sc, path, LRR_ERR_UNSUPPORTED,
          "built without ScaLAPACK");
#endif
    if (was)
        setenv("LRR_MPI_FACTOR", was, 1);
    else
        unsetenv("LRR_MPI_FACTOR");
    free(was);
    fault("a missing directory", ctx, sc, nodir, LRR_ERR_IO, "op.lrr");
    /* a rank's files limited to 4 KiB past the start of F̄'s section (from the serial file):
     * its writes of its chunks (MPI-IO) fail within it (SIGXFSZ ignored: write() returns
     * EFBIG), the root's and then the last rank's, whose chunks lie past the limit too */
    struct rlimit old, small;
    getrlimit(RLIMIT_FSIZE, &old);
    small = old;
    unsigned long long limit = 0;
    if (mt_rank == 0) {
        lrr_operator *s = NULL;
        size_t len = 0, off[16], size[16];
        unsigned id[16];
        unsigned char *f = serial_file(sc, &KINDS[1], path, &s) ? slurp(path, &len) : NULL;
        int count = f ? sections(f, len, id, off, size) : 0;
        for (int j = 0; j < count; j++)
            if (id[j] == 4 || id[j] == 11) /* FBAR, FBAR_STRIPS */
                limit = (unsigned long long)off[j] + 4096;
        mt_check(limit + 4096 < len, "faults: F̄ of the serial file ends past %llu",
                 limit + 4096);
        free(f);
        lrr_operator_destroy(s);
        remove(path);
    }
    MPI_Bcast(&limit, 1, MPI_UNSIGNED_LONG_LONG, 0, MPI_COMM_WORLD);
    small.rlim_cur = (rlim_t)limit;
    signal(SIGXFSZ, SIG_IGN);
    for (int r = 0; r < mt_size; r += mt_size > 1 ? mt_size - 1 : 1) {
        char what[64], needle[64];
        snprintf(what, sizeof what, "rank %d's writes failing within F̄", r);
        /* the agreed message is the failing rank's, named on the others when not rank 0's */
        if (r == 0 || mt_rank == r)
            snprintf(needle, sizeof needle, ": cannot write F̄'s rows");
        else
            snprintf(needle, sizeof needle, "rank %d: file ", r);
        if (mt_rank == r)
            setrlimit(RLIMIT_FSIZE, &small);
        fault(what, ctx, sc, path, LRR_ERR_IO, needle);
        if (mt_rank == r)
            setrlimit(RLIMIT_FSIZE, &old);
    }
    /* every allocation counted on the last rank's context failing in turn */
    struct save_call call = {sc, path};
    mt_allocation_faults(ctx, "build_save", save_once, save_left_nothing, &call);
    if (mt_rank == 0)
        remove(path);
    lrr_scene_destroy(sc);
    lrr_context_destroy(ctx);
}

int main(int argc, char **argv)
{
    mt_init(&argc, &argv);
    for (size_t c = 0; c < sizeof KINDS / sizeof *KINDS; c++)
        equality(&KINDS[c], c % 2 ? mt_size - 1 : 0);
    budget();
    faults();
    return mt_finish();
}
