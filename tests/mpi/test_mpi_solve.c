/* The distributed solver (lrr_mpi.h) against the serial one, for 1 to 4 ranks (mpi.sh runs
 * this under mpirun -np 1..4): the Cornell box in each storage, four rooms whose F̄ is read
 * as sparse strips, and two patches for up to four ranks (empty blocks); the stored
 * emission and a pseudo-random one. Every rank's rows of B equal the serial lrr_solve's
 * (full path) within 1e-6 relative to max |B|; B gathered equals the distributed rows bit
 * for bit; the blocks cover 0..n−1 in rank order on patch boundaries; scatter hands out
 * the right rows. The tolerance: both sides run the same kernels over the same F̄ and the
 * same w (each patch's Vᵀ sum is made on one rank, the allreduce adds zeros to it); only
 * the order of a row's float sums may differ (a block's panels start at its first row):
 * k terms of at most ε relative each, k·ε ≈ 1.2e-5 for k = 102, bounds it; 1e-6 is the
 * issue's target and what is met (the values printed). */
#include "mpi_test.h"

/* E (n×3): the stored emission, or a pseudo-random field in [0, 1) (an LCG of the index,
 * the same on every rank) */
static void emission(size_t n, const float *stored, int random, float *E)
{
    uint64_t x = 88172645463325252u;
    for (size_t j = 0; j < 3 * n; j++) {
        x = x * 6364136223846793005u + 1442695040888963407u;
        E[j] = random ? (float)(x >> 40) / (float)(1u << 24) : stored[j];
    }
}

/* The blocks in rank order, contiguous, covering 0..n−1; returns the row counts (size). */
static void check_blocks(const lrr_mpi_solver *s, const lrr_operator *op)
{
    size_t n, row0, rows;
    lrr_mpi_solver_rows(s, &n, &row0, &rows);
    unsigned long long mine[2] = {row0, rows}, *all = calloc(2 * (size_t)mt_size, sizeof *all);
    MPI_Allgather(mine, 2, MPI_UNSIGNED_LONG_LONG, all, 2, MPI_UNSIGNED_LONG_LONG,
                  MPI_COMM_WORLD);
    unsigned long long next = 0;
    int ok = 1, whole = 1;
    lrr_operator_info oi;
    lrr_operator_get_info(op, &oi, sizeof oi);
    const size_t *first = lrr_operator_patch_offsets(op);
    for (int r = 0; r < mt_size; r++) {
        ok &= all[2 * r] == next;
        next += all[2 * r + 1];
        /* a block starts on a patch boundary */
        int boundary = 0;
        for (size_t p = 0; p <= oi.k && !boundary; p++)
            boundary = first[p] == all[2 * r];
        whole &= boundary;
    }
    mt_check(ok && next == n && n == oi.n, "blocks cover rows 0..%zu in rank order", n - 1);
    mt_check(whole, "every block starts on a patch boundary");
    free(all);
}

/* One operator file: every check above for both emissions. */
static void check_file(const char *name, const char *kind, size_t K, unsigned levels,
                       lrr_storage storage)
{
    char path[4096];
    mt_path(path, sizeof path, name);
    mt_write_op(path, kind, K, levels, storage);
    lrr_context *ctx;
    lrr_operator *op = NULL;
    lrr_mpi_solver *s = NULL;
    if (lrr_context_create(&ctx) != LRR_OK) {
        mt_check(0, "cannot create a context");
        return;
    }
    lrr_status st = lrr_mpi_solver_create(ctx, path, MPI_COMM_WORLD, &s);
    mt_check(st == LRR_OK, "%s: lrr_mpi_solver_create -> %s", name, lrr_strerror(st));
    if (st != LRR_OK || lrr_operator_load(ctx, path, &op) != LRR_OK) {
        mt_check(0, "%s: cannot go on", name);
        lrr_mpi_solver_destroy(s);
        lrr_context_destroy(ctx);
        return;
    }
    check_blocks(s, op);
    size_t n, row0, rows;
    lrr_mpi_solver_rows(s, &n, &row0, &rows);
    lrr_mpi_solver_info info;
    lrr_mpi_solver_get_info(s, &info, sizeof info);
    mt_check(info.ranks == mt_size && info.rank == mt_rank && info.rows == rows &&
                 info.allreduce_bytes == (3 * info.k + 1) * sizeof(float),
             "%s: info (ranks %d, k %zu, allreduce %zu bytes)", name, info.ranks, info.k,
             info.allreduce_bytes);
    if (strcmp(kind, "rooms") == 0) {
        unsigned long long mine = info.fbar_bytes, all = 0;
        MPI_Allreduce(&mine, &all, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
        mt_check(all < (unsigned long long)n * info.k * sizeof(float),
                 "%s: the ranks read F̄ as strips (%llu bytes a frame, dense %zu)", name, all,
                 n * info.k * sizeof(float));
    }
    const float *em = lrr_mpi_solver_emission(s);
    mt_check(rows == 0 || memcmp(em, lrr_operator_emission(op) + 3 * row0,
                                 3 * rows * sizeof(float)) == 0,
             "%s: this rank's stored emission", name);
    float *E = calloc(3 * n, sizeof *E), *B = calloc(3 * n, sizeof *B);
    float *Bd = calloc(3 * n, sizeof *B), *Bg = calloc(3 * n, sizeof *B);
    float *Bl = calloc(3 * rows + 3, sizeof *B), *El = calloc(3 * rows + 3, sizeof *B);
    for (int random = 0; random < 2; random++) {
        const char *which = random ? "random E" : "stored E";
        emission(n, lrr_operator_emission(op), random, E);
        mt_check(mt_serial_solve(ctx, path, E, B), "%s, %s: serial solve", name, which);
        st = lrr_mpi_solve(s, E + 3 * row0, Bl);
        mt_check(st == LRR_OK, "%s, %s: lrr_mpi_solve -> %s", name, which, lrr_strerror(st));
        /* the distributed rows, gathered by hand, against the serial B */
        int counts[64], displs[64];
        int c = (int)(3 * rows), d = (int)(3 * row0);
        MPI_Allgather(&c, 1, MPI_INT, counts, 1, MPI_INT, MPI_COMM_WORLD);
        MPI_Allgather(&d, 1, MPI_INT, displs, 1, MPI_INT, MPI_COMM_WORLD);
        MPI_Allgatherv(Bl, c, MPI_FLOAT, Bd, counts, displs, MPI_FLOAT, MPI_COMM_WORLD);
        double rel = mt_max_rel(3 * n, Bd, B);
        mt_check(rel <= 1e-6, "%s (n %zu, k %zu, %s), %s: distributed B vs serial lrr_solve: "
                 "max rel diff %.3g <= 1e-6", name, n, info.k, lrr_storage_name(storage),
                 which, rel);
        memset(Bg, 0, 3 * n * sizeof *Bg);
        st = lrr_mpi_solve_gather(s, E + 3 * row0, 0, mt_rank == 0 ? Bg : NULL);
        mt_check(st == LRR_OK, "%s, %s: lrr_mpi_solve_gather -> %s", name, which,
                 lrr_strerror(st));
        if (mt_rank == 0)
            mt_check(memcmp(Bg, Bd, 3 * n * sizeof *Bg) == 0,
                     "%s, %s: B gathered on rank 0 = the distributed rows, bit for bit (max "
                     "rel diff to serial %.3g)", name, which, mt_max_rel(3 * n, Bg, B));
        st = lrr_mpi_scatter(s, 0, mt_rank == 0 ? E : NULL, El);
        mt_check(st == LRR_OK && memcmp(El, E + 3 * row0, 3 * rows * sizeof *El) == 0,
                 "%s, %s: lrr_mpi_scatter hands out this rank's rows", name, which);
    }
    free(E), free(B), free(Bd), free(Bg), free(Bl), free(El);
    lrr_mpi_solver_destroy(s);
    lrr_operator_destroy(op);
    lrr_context_destroy(ctx);
    MPI_Barrier(MPI_COMM_WORLD);
    if (mt_rank == 0)
        unlink(path);
}

int main(int argc, char **argv)
{
    mt_init(&argc, &argv);
    if (mt_size > 64) {
        mt_check(0, "at most 64 ranks here");
        return mt_finish();
    }
    check_file("cornell-f32", "cornell", 54, 1, LRR_STORAGE_F32);
    check_file("cornell-f16", "cornell", 100, 2, LRR_STORAGE_F16);
    check_file("cornell-bf16", "cornell", 40, 1, LRR_STORAGE_BF16);
    check_file("rooms-sparse", "rooms", 96, 1, LRR_STORAGE_F32);
    check_file("pair-2-patches", "pair", 0, 2, LRR_STORAGE_F32);
    return mt_finish();
}
