/* Helpers of the MPI tests (tests/mpi/, run by tests/mpi/mpi.sh under mpirun with 1 to 4
 * ranks): GSL-style checks that print one line per check on rank 0 and count failures on
 * every rank, test operators written by rank 0, a serial reference solve, and an alarm so
 * that a hang fails the test instead of blocking the suite. */
#ifndef LRR_MPI_TEST_H
#define LRR_MPI_TEST_H

#include <math.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "lrr_mpi.h"

/* Seconds after which a test process kills itself (a hang is a failure, never a wait). */
#define MT_ALARM_SECONDS 60

static int mt_rank, mt_size, mt_failures;

/* One check on this rank: failures print on any rank (naming it), passes on rank 0 only. */
static inline void mt_check(int ok, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static inline void mt_check(int ok, const char *fmt, ...)
{
    if (ok && mt_rank != 0)
        return;
    char text[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    printf("%s: [%d ranks, rank %d] %s\n", ok ? "PASS" : "FAIL", mt_size, mt_rank, text);
    fflush(stdout);
    mt_failures += !ok;
}

static inline void mt_init(int *argc, char ***argv)
{
    alarm(MT_ALARM_SECONDS);
    MPI_Init(argc, argv);
    MPI_Comm_rank(MPI_COMM_WORLD, &mt_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &mt_size);
}

/* The exit status: 1 when a check failed on any rank. */
static inline int mt_finish(void)
{
    int any = 0;
    MPI_Allreduce(&mt_failures, &any, 1, MPI_INT, MPI_SUM, MPI_COMM_WORLD);
    if (mt_rank == 0)
        printf("%s: %d failed checks over %d ranks\n", any ? "FAIL" : "PASS", any, mt_size);
    MPI_Finalize();
    return any ? 1 : 0;
}

/* A per-run scratch path (the same on every rank: rank 0's pid is broadcast). */
static inline void mt_path(char *buf, size_t len, const char *name)
{
    long pid = (long)getpid();
    MPI_Bcast(&pid, 1, MPI_LONG, 0, MPI_COMM_WORLD);
    const char *dir = getenv("LRR_TEST_TMP");
    snprintf(buf, len, "%s/mpi-%s.%ld.lrr", dir && *dir ? dir : "/tmp", name, pid);
}

/* The test scenes: "cornell" (the open box, 36 triangles), "rooms" (four closed unit rooms
 * side by side, 48 triangles: a patch sees its own room only, so F̄ is sparse and the
 * solver reads strips), "dark" (the rooms emitting nothing), "pair" (two triangles facing
 * each other, 1 apart: k = 2 patches, fewer than the ranks, so some blocks are empty). */
static inline lrr_status mt_scene(lrr_context *ctx, const char *kind, lrr_scene **out)
{
    if (strcmp(kind, "cornell") == 0)
        return lrr_scene_builtin(ctx, "cornell", out);
    enum { MAX_T = 48 };
    float v[9 * MAX_T], rho[3 * MAX_T], e[3 * MAX_T];
    size_t T;
    if (strcmp(kind, "pair") == 0) {
        static const float pair[18] = {0, 0, 0, 1, 0, 0, 0, 1, 0, /* faces +z */
                                       0, 0, 1, 0, 1, 1, 1, 0, 1}; /* faces −z */
        memcpy(v, pair, sizeof pair);
        T = 2;
    } else {
        /* each room a unit box whose faces look inwards: two triangles per face */
        static const int face[6][4][3] = {
            {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {1, 0, 0}}, {{0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}},
            {{0, 0, 0}, {1, 0, 0}, {1, 0, 1}, {0, 0, 1}}, {{0, 1, 0}, {0, 1, 1}, {1, 1, 1}, {1, 1, 0}},
            {{0, 0, 0}, {0, 0, 1}, {0, 1, 1}, {0, 1, 0}}, {{1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {1, 0, 1}}};
        static const int tri[2][3] = {{0, 2, 1}, {0, 3, 2}}; /* counter-clockwise from inside */
        T = 0;
        for (int room = 0; room < 4; room++)
            for (int f = 0; f < 6; f++)
                for (int t = 0; t < 2; t++, T++)
                    for (int c = 0; c < 3; c++)
                        for (int x = 0; x < 3; x++)
                            v[9 * T + 3 * c + x] = (float)face[f][tri[t][c]][x] +
                                                   (x == 0 ? 1.5f * (float)room : 0.0f);
    }
    for (size_t t = 0; t < T; t++)
        for (int c = 0; c < 3; c++) {
            rho[3 * t + c] = 0.3f + 0.2f * (float)c;
            e[3 * t + c] = (t == 0 || t == 5) && strcmp(kind, "dark") != 0 ? 1.0f : 0.0f;
        }
    return lrr_scene_create(ctx, T, v, rho, e, kind, out);
}

/* Rank 0 builds an operator (scene `kind`, about K patches of 4^levels subpatches,
 * hemicube resolution 16, F̄ in `storage`) and saves it at path; every rank returns once
 * the file exists. Exits on failure (nothing to test without it). */
static inline void mt_write_op(const char *path, const char *kind, size_t K, unsigned levels,
                               lrr_storage storage)
{
    int ok = 1;
    if (mt_rank == 0) {
        lrr_context *ctx;
        lrr_scene *sc = NULL;
        lrr_operator *op = NULL;
        lrr_subdivision sd = lrr_subdivision_defaults();
        sd.target_patches = K;
        sd.levels = levels;
        lrr_build_options bo = lrr_build_options_defaults();
        bo.hemicube_resolution = 16;
        bo.seed = 7;
        ok = lrr_context_create(&ctx) == LRR_OK && mt_scene(ctx, kind, &sc) == LRR_OK &&
             lrr_scene_subdivide(sc, &sd) == LRR_OK && lrr_operator_build(sc, &bo, &op) == LRR_OK &&
             (storage == LRR_STORAGE_F32 || lrr_operator_set_storage(op, storage) == LRR_OK) &&
             lrr_operator_save(op, path) == LRR_OK;
        if (!ok) {
            char msg[512];
            lrr_context_last_error(ctx, msg, sizeof msg);
            printf("FAIL: cannot write the test operator %s: %s\n", path, msg);
        }
        lrr_operator_destroy(op);
        lrr_scene_destroy(sc);
        lrr_context_destroy(ctx);
    }
    MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (!ok) {
        MPI_Finalize();
        exit(1);
    }
}

/* The serial library's B (n×3) for E (n×3) on the full path, from the same file. */
static inline int mt_serial_solve(lrr_context *ctx, const char *path, const float *E, float *B)
{
    lrr_operator *op = NULL;
    lrr_solver *s = NULL;
    int ok = lrr_operator_load(ctx, path, &op) == LRR_OK &&
             lrr_solver_create(op, LRR_BACKEND_CPU, &s) == LRR_OK &&
             lrr_solver_set_path(s, LRR_PATH_FULL) == LRR_OK && lrr_solve(s, E, B) == LRR_OK;
    lrr_solver_destroy(s);
    lrr_operator_destroy(op);
    return ok;
}

/* max |a − b| over m entries relative to max |b| */
static inline double mt_max_rel(size_t m, const float *a, const float *b)
{
    double num = 0, den = 0;
    for (size_t i = 0; i < m; i++) {
        num = fmax(num, fabs((double)a[i] - b[i]));
        den = fmax(den, fabs((double)b[i]));
    }
    return den > 0 ? num / den : num;
}

#endif
