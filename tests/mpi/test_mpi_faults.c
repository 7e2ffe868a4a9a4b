/* Faults across ranks (lrr_mpi.h "Collective calls and faults"): an error on one rank, or
 * on all, ends every rank's call in seconds with an error and the failing rank's message,
 * never a hang (mpi.sh's timeout and MT_ALARM_SECONDS fail one), outputs untouched:
 *   a corrupt file on every rank, a file missing on one rank, another operator on one rank,
 *   a NaN in the emission one rank sees (lrr_mpi_solve and _gather), a root out of range,
 *   and every allocation of lrr_mpi_solver_create failing in turn on the last rank.
 * Each case prints what every rank's context recorded (rank 0's line). */
#include "mpi_test.h"
#include "solve/rows.h" /* lrr__rows_fail_after: the allocation-failure hook */

/* A fault ends within this (seconds): the agreement is two collectives, the loads are of a
 * small file; a hang would hit the alarm instead. */
#define FAULT_SECONDS 10.0

typedef struct outcome {
    lrr_status status;
    char message[512];
    double seconds;
    int callbacks; /* error callbacks seen during the call */
} outcome;

static void count_callback(void *user, lrr_status status, const char *message)
{
    (void)status, (void)message;
    ++*(int *)user;
}

/* Statuses of every rank equal to want, and this rank's message containing `needle` (and,
 * on a rank that did not fail itself, naming the failing rank). */
static void check_outcome(const char *what, const outcome *o, lrr_status want,
                          const char *needle, int failing_rank)
{
    int mine = (int)o->status, lo, hi;
    MPI_Allreduce(&mine, &lo, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(&mine, &hi, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
    double slowest;
    MPI_Allreduce(&o->seconds, &slowest, 1, MPI_DOUBLE, MPI_MAX, MPI_COMM_WORLD);
    mt_check(lo == (int)want && hi == (int)want, "%s: every rank returns %s", what,
             lrr_strerror(want));
    mt_check(slowest < FAULT_SECONDS, "%s: every rank returned within %.3f s", what, slowest);
    char prefix[32] = "";
    if (failing_rank >= 0 && mt_rank != failing_rank)
        snprintf(prefix, sizeof prefix, "rank %d: ", failing_rank);
    mt_check(strstr(o->message, needle) && strncmp(o->message, prefix, strlen(prefix)) == 0,
             "%s: rank %d's message names the cause: \"%s\"", what, mt_rank, o->message);
    mt_check(o->callbacks >= 1, "%s: the error callback saw it (%d calls)", what, o->callbacks);
}

static outcome create(lrr_context *ctx, const char *path, lrr_mpi_solver **s)
{
    outcome o = {0};
    lrr_context_set_error_callback(ctx, count_callback, &o.callbacks);
    double t0 = MPI_Wtime();
    o.status = lrr_mpi_solver_create(ctx, path, MPI_COMM_WORLD, s);
    o.seconds = MPI_Wtime() - t0;
    lrr_context_last_error(ctx, o.message, sizeof o.message);
    lrr_context_set_error_callback(ctx, NULL, NULL);
    return o;
}

/* Rank 0 copies src to dst with the byte at `at` of its size flipped (past the header and
 * the table: a section's checksum fails; 3/4 of the Cornell file is in M, 1/3 in F̄). */
static void write_corrupt(const char *src, const char *dst, double at)
{
    if (mt_rank == 0) {
        FILE *f = fopen(src, "rb");
        fseek(f, 0, SEEK_END);
        long size = ftell(f);
        unsigned char *buf = malloc((size_t)size);
        fseek(f, 0, SEEK_SET);
        if (fread(buf, 1, (size_t)size, f) != (size_t)size)
            size = 0;
        fclose(f);
        buf[(long)((double)size * at)] ^= 0x5a;
        f = fopen(dst, "wb");
        fwrite(buf, 1, (size_t)size, f);
        fclose(f);
        free(buf);
    }
    MPI_Barrier(MPI_COMM_WORLD);
}

static void files_faults(lrr_context *ctx, const char *good, const char *corrupt,
                         const char *corrupt_fbar, const char *other)
{
    lrr_mpi_solver *s = (lrr_mpi_solver *)1;
    outcome o = create(ctx, corrupt, &s);
    check_outcome("corrupt file on every rank", &o, LRR_ERR_CORRUPT, "checksum", -1);
    mt_check(s == NULL, "corrupt file: no solver");
    /* every rank reads F̄'s whole section for its checksum, though it keeps its rows only */
    o = create(ctx, corrupt_fbar, &s);
    check_outcome("corrupt F̄ on every rank", &o, LRR_ERR_CORRUPT, "section FBAR", -1);
    if (mt_size == 1)
        return;
    const int last = mt_size - 1;
    char missing[4200];
    snprintf(missing, sizeof missing, "%s.missing", good);
    o = create(ctx, mt_rank == last ? missing : good, &s);
    check_outcome("file missing on the last rank", &o, LRR_ERR_IO, ".missing", last);
    o = create(ctx, mt_rank == last ? other : good, &s);
    check_outcome("another operator on the last rank", &o, LRR_ERR_DIM,
                  "loaded different operators", -1);
}

/* A NaN in the emission of the last rank's first row, channel 1. */
static void emission_faults(lrr_context *ctx, const char *good)
{
    lrr_mpi_solver *s = NULL;
    if (lrr_mpi_solver_create(ctx, good, MPI_COMM_WORLD, &s) != LRR_OK) {
        mt_check(0, "emission faults: cannot create the solver");
        return;
    }
    size_t n, row0, rows;
    lrr_mpi_solver_rows(s, &n, &row0, &rows);
    const int last = mt_size - 1;
    unsigned long long bad = row0;
    MPI_Bcast(&bad, 1, MPI_UNSIGNED_LONG_LONG, last, MPI_COMM_WORLD);
    float *E = calloc(3 * rows + 3, sizeof *E), *B = calloc(3 * rows + 3, sizeof *B);
    float *Bg = calloc(3 * n, sizeof *Bg);
    memcpy(E, lrr_mpi_solver_emission(s), 3 * rows * sizeof *E);
    if (mt_rank == last)
        E[1] = NAN;
    for (size_t j = 0; j < 3 * rows; j++)
        B[j] = 12345.0f;
    for (size_t j = 0; j < 3 * n; j++)
        Bg[j] = 12345.0f;
    char needle[128];
    snprintf(needle, sizeof needle, "emission of subpatch %llu, channel 1 = nan", bad);
    for (int gather = 0; gather < 2; gather++) {
        outcome o = {0};
        lrr_context_set_error_callback(ctx, count_callback, &o.callbacks);
        double t0 = MPI_Wtime();
        o.status = gather ? lrr_mpi_solve_gather(s, E, 0, Bg) : lrr_mpi_solve(s, E, B);
        o.seconds = MPI_Wtime() - t0;
        lrr_context_last_error(ctx, o.message, sizeof o.message);
        lrr_context_set_error_callback(ctx, NULL, NULL);
        check_outcome(gather ? "NaN emission on the last rank (gather)"
                             : "NaN emission on the last rank", &o, LRR_ERR_INVALID_ARG,
                      needle, last);
    }
    int untouched = 1;
    for (size_t j = 0; j < 3 * rows; j++)
        untouched &= B[j] == 12345.0f;
    for (size_t j = 0; j < 3 * n; j++)
        untouched &= Bg[j] == 12345.0f;
    mt_check(untouched, "NaN emission: radiosity untouched on rank %d", mt_rank);
    /* the solver is still good after a failed frame */
    if (mt_rank == last)
        E[1] = 0.0f;
    lrr_status st = lrr_mpi_solve(s, E, B);
    mt_check(st == LRR_OK, "a good frame after the failed ones -> %s", lrr_strerror(st));
    outcome o = {0};
    lrr_context_set_error_callback(ctx, count_callback, &o.callbacks);
    o.status = lrr_mpi_solve_gather(s, E, mt_size, NULL);
    lrr_context_last_error(ctx, o.message, sizeof o.message);
    lrr_context_set_error_callback(ctx, NULL, NULL);
    check_outcome("gather to a root out of range", &o, LRR_ERR_INVALID_ARG, "is not a rank",
                  -1);
    free(E), free(B), free(Bg);
    lrr_mpi_solver_destroy(s);
}

/* Allocation n on the last rank fails, for n = 1, 2, … until the create succeeds. */
static void allocation_faults(lrr_context *ctx, const char *good)
{
    const int last = mt_size - 1;
    int steps = 0, agreed = 1, named = 1;
    double slowest = 0;
    for (unsigned long n = 1; n < 1000; n++) {
        if (mt_rank == last)
            lrr__rows_fail_after(ctx, n);
        lrr_mpi_solver *s = NULL;
        outcome o = create(ctx, good, &s);
        if (mt_rank == last)
            lrr__rows_fail_after(ctx, 0);
        int mine = (int)o.status, lo, hi;
        MPI_Allreduce(&mine, &lo, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
        MPI_Allreduce(&mine, &hi, 1, MPI_INT, MPI_MAX, MPI_COMM_WORLD);
        lrr_mpi_solver_destroy(s);
        slowest = fmax(slowest, o.seconds);
        if (hi == LRR_OK)
            break;
        steps++;
        agreed &= lo == hi && (s == NULL);
        named &= strstr(o.message, "allocate") != NULL;
        if (steps == 1 && mt_rank == 0)
            printf("# allocation 1 failing on rank %d: rank 0 reads \"%s\"\n", last,
                   o.message);
    }
    mt_check(steps > 0, "allocation faults: %d allocations failed in turn on rank %d", steps,
             last);
    mt_check(agreed, "allocation faults: every rank returned the same error each time");
    mt_check(named, "allocation faults: every message says what could not be allocated");
    mt_check(slowest < FAULT_SECONDS, "allocation faults: slowest call %.3f s", slowest);
}

int main(int argc, char **argv)
{
    mt_init(&argc, &argv);
    char good[4096], corrupt[4096], corrupt_fbar[4096], other[4096];
    mt_path(good, sizeof good, "fault-good");
    mt_path(corrupt, sizeof corrupt, "fault-corrupt");
    mt_path(corrupt_fbar, sizeof corrupt_fbar, "fault-corrupt-fbar");
    mt_path(other, sizeof other, "fault-other");
    mt_write_op(good, "cornell", 54, 1, LRR_STORAGE_F32);
    mt_write_op(other, "cornell", 40, 1, LRR_STORAGE_F32);
    write_corrupt(good, corrupt, 0.75);
    write_corrupt(good, corrupt_fbar, 1.0 / 3);
    lrr_context *ctx;
    if (lrr_context_create(&ctx) != LRR_OK)
        return 1;
    files_faults(ctx, good, corrupt, corrupt_fbar, other);
    emission_faults(ctx, good);
    allocation_faults(ctx, good);
    lrr_context_destroy(ctx);
    MPI_Barrier(MPI_COMM_WORLD);
    if (mt_rank == 0)
        unlink(good), unlink(corrupt), unlink(corrupt_fbar), unlink(other);
    return mt_finish();
}
