/*
 * lrr_mpi — the real-time step of lrr across MPI ranks (liblrr_mpi, beside liblrr as
 * fftw3-mpi is beside fftw3). Link with -llrr_mpi -llrr (pkg-config lrr_mpi). lrr.h and
 * liblrr know nothing of MPI; this header includes <mpi.h>.
 *
 * Design (docs/MPI.md). Each rank holds a block of rows of F̄: the subpatches of a range of
 * whole patches (rows are patch-major), about n/P rows each, and all of M (3×k×k,
 * replicated; read as lrr_solver_create reads it: M − I in binary16 when F̄ is 16-bit). A frame B_c = E_c + rho_c ∘ (F̄ (M_c (Vᵀ E_c))) splits at w = Vᵀ E: each rank
 * sums its patches' entries of w from its own rows of E, ONE MPI_Allreduce of the 3k floats
 * (plus one float that carries the ranks' status) gives every rank the whole w, and each
 * computes its rows of B. E and B are distributed: each rank passes and gets only its own
 * rows (lrr_mpi_solver_rows says which); lrr_mpi_solve_gather collects B on one rank, and
 * lrr_mpi_scatter hands out rows of an E that one rank holds whole. The result is the
 * serial lrr_solve's full path (lrr_solver_set_path LRR_PATH_FULL, M as that solver
 * chooses) up to float rounding in the F̄ pass.
 *
 * Collective calls and faults. Functions marked "collective" must be called by every rank
 * of the solver's communicator, in the same order. They never hang on a local error and
 * never abort: each rank checks its own part first, the ranks agree, and when any rank
 * failed EVERY rank's call returns an error: a failing rank its own status (its message
 * recorded on its context, as the serial library does), every other rank the status of the
 * lowest failing rank with that rank's message, recorded on its context as
 * "rank R: <message>" (lrr_context_last_error, the error callback). Outputs are then
 * untouched. MPI's own errors are returned (the solver's communicator is a duplicate with
 * MPI_ERRORS_RETURN) as LRR_ERR_IO naming the call and MPI's error string. A rank that dies
 * is for the MPI runtime to handle (Open MPI's mpirun ends the job).
 *
 * Memory: each rank reads only its rows of F̄ into memory (the file's F̄ section is streamed
 * whole for its checksum), so a rank holds about F̄/P, all of M and the per-subpatch
 * arrays.
 *
 * The library never prints, never exits and keeps no global state; it does not call
 * MPI_Init (the caller does, before any collective call here, with a thread level of at
 * least MPI_THREAD_FUNNELED since the kernels use OpenMP threads that make no MPI calls).
 */
#ifndef LRR_MPI_H
#define LRR_MPI_H

#include <mpi.h>

#include "lrr.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct lrr_mpi_solver lrr_mpi_solver;

/* Collective over comm (duplicated: the solver's messages never mix with the caller's).
 * Every rank loads the operator file at path (the same file: their n, k and patch offsets
 * are compared, LRR_ERR_DIM naming the rank that differs), its rows of F̄ alone: the file
 * is checked as lrr_operator_load checks it, but a dense F̄'s entries only within the
 * rank's block (the blocks together cover them). Errors as lrr_operator_load's and lrr_solver_create's, agreed (above).
 * *out is NULL on every rank on error. ctx records the errors; the solver holds a reference
 * to it. Thread safety: one thread per rank. */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_solver_create(lrr_context *ctx, const char *path,
                                                       MPI_Comm comm, lrr_mpi_solver **out)
    LRR_NONNULL(1, 2, 4);
/* Collective (it frees the duplicated communicator). NULL does nothing (on every rank). */
LRR_API void lrr_mpi_solver_destroy(lrr_mpi_solver *solver);

/* This rank's block: subpatches row0 .. row0 + rows − 1 of the operator's n (rows may be 0
 * when there are more ranks than patches). Blocks are in rank order and cover 0..n−1.
 * Thread safety: any thread (read only). */
LRR_API void lrr_mpi_solver_rows(const lrr_mpi_solver *solver, size_t *n, size_t *row0,
                                 size_t *rows) LRR_NONNULL(1, 2, 3, 4);
/* This rank's rows of the emission stored in the file (rows×3; NULL when rows = 0), valid
 * for the solver's life. */
LRR_API const float *lrr_mpi_solver_emission(const lrr_mpi_solver *solver) LRR_NONNULL(1);

typedef struct lrr_mpi_solver_info {
    size_t n, k;         /* the whole operator */
    size_t row0, rows;   /* this rank's block */
    int rank, ranks;     /* in the solver's communicator */
    size_t fbar_bytes;   /* bytes of F̄ this rank reads per frame (dense or strips) */
    size_t m_bytes;      /* M, 3·k·k floats, on every rank */
    size_t allreduce_bytes; /* what each rank contributes to the frame's allreduce */
    const char *kernel;  /* the SIMD variant this rank runs (lrr_solver_kernel's names) */
} lrr_mpi_solver_info;
/* info_size = sizeof *info (lrr.h Conventions). Thread safety: any thread. */
LRR_API void lrr_mpi_solver_get_info(const lrr_mpi_solver *solver, lrr_mpi_solver_info *info,
                                     size_t info_size) LRR_NONNULL(1, 2);

/* Collective. One frame: emission and radiosity are this rank's rows (rows×3, row-major;
 * a caller holding the whole n×3 E passes E + 3·row0). Emission must be finite and >= 0:
 * a bad entry on any rank fails every rank (LRR_ERR_INVALID_ARG naming the subpatch by its
 * global index). They may not alias. On a rank with rows = 0 both may be NULL. */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_solve(lrr_mpi_solver *solver, const float *emission,
                                               float *radiosity) LRR_NONNULL(1);

/* Collective. lrr_mpi_solve, then every rank's rows of B gathered into radiosity (n×3) on
 * rank root (ignored, may be NULL, elsewhere). emission as in lrr_mpi_solve. root must be
 * the same on every rank (LRR_ERR_INVALID_ARG when out of range). */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_solve_gather(lrr_mpi_solver *solver,
                                                      const float *emission, int root,
                                                      float *radiosity) LRR_NONNULL(1);

/* Collective. Hands out the rows of a whole n×3 array that rank root holds (whole: read on
 * root only, may be NULL elsewhere) to the ranks: rows receives this rank's rows×3 (may be
 * NULL when rows = 0). For an emission computed on one rank (lights, a probe). */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_scatter(lrr_mpi_solver *solver, int root,
                                                 const float *whole, float *rows)
    LRR_NONNULL(1);

/* ---------------------------------------------------------------- preprocessing */
typedef struct lrr_mpi_build_info {
    int ranks;
    size_t rows;             /* this rank's receivers (rows of F̄) */
    double rows_seconds;     /* this rank's hemicubes */
    double rows_seconds_min, rows_seconds_max; /* over the ranks: the balance */
    double gather_seconds;   /* the blocks of F̄ to the root (build_save: the row scales,
                                back-face shares and weights' sums) */
    double seconds;          /* the whole call on this rank */
    /* added with lrr_mpi_operator_build_save (info_size tells which fields a caller has) */
    size_t fbar_bytes;       /* this rank's rows of F̄ held, in the file's storage */
    double save_seconds;     /* build_save: G's assembly and inversion excluded, the file */
} lrr_mpi_build_info;

/* Collective over comm. lrr_operator_build across ranks: every rank passes the same scene
 * (loaded and subdivided alike) and options; each selects the hierarchy (replicated: the
 * ranks' selections are compared, LRR_ERR_DIM when one differs), computes the hemicubes of
 * its receivers on the CPU with opts->threads (chunks of 64 rows dealt round-robin, chunk c
 * to rank c mod P, so that costs that vary across the scene even out), and the rows are
 * sent to rank root, which factorises M_c
 * and returns the operator in *out: F̄ bit for bit, and hence M and B, the serial
 * lrr_operator_build's (a receiver's hemicube depends on its index alone). *out is NULL on
 * the other ranks and on every rank on error (agreed, as above). opts->progress is called
 * on each rank for its own receivers. The root holds the whole operator; the others their
 * rows only; the memory budget is checked against the whole operator on every rank.
 * LRR_ERR_UNSUPPORTED for opts->backend LRR_BACKEND_OPENCL (the hemicubes of a list of
 * receivers are integrated on the CPU). info
 * (may be NULL; info_size = sizeof *info) receives the timings and this rank's block, on
 * error what was reached. The operator's formfactor_seconds is the slowest rank's hemicubes
 * plus the transfer. */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_operator_build(const lrr_scene *scene,
                                                        const lrr_build_options *opts,
                                                        MPI_Comm comm, int root,
                                                        lrr_operator **out,
                                                        lrr_mpi_build_info *info,
                                                        size_t info_size)
    LRR_NONNULL(1, 5);

/* Collective over comm. lrr_mpi_operator_build, then lrr_operator_set_storage(storage) and
 * lrr_operator_save_fbar(path, fbar) on the root, without any rank holding more of F̄ than
 * its own rows: each rank keeps the rows of its chunks (64 rows dealt round-robin) in
 * `storage`; the Vᵀ weights and G_c's rows are summed where the rows are, in the serial
 * order (a patch that spans chunks passes its partial row on), and the root inverts G_c;
 * the root writes the file, each rank its chunks of F̄'s section (MPI-IO: every rank must
 * see the root's file system). The file
 * is the serial one byte for byte but for its timings (INFO's build seconds, the
 * selection's seconds). storage, fbar and path are the root's (path may be NULL
 * elsewhere). opts->memory_budget is checked on every rank against what it holds: its
 * share of F̄ (about n/P rows), M, the per-subpatch arrays and the build's buffers, so a
 * scene whose F̄ exceeds one rank's budget can be built by more ranks. head (may be NULL)
 * receives on the root the operator without F̄ (its rows of F̄ are not held: the calls
 * that read F̄ refuse it, see lrr_operator_load_head), NULL elsewhere and on error. Errors
 * as lrr_mpi_operator_build's, agreed; the file is not written (no file under path) when
 * any rank fails.
 * The inversion of G_c (docs/MPI.md "The factorisation"): replicated (the root's LAPACK, as
 * above) or, when built with ScaLAPACK (lrr --version lists scalapack), across the ranks,
 * the root then holding no k×k G_c: M and the condition numbers are then the serial ones to
 * rounding, not byte for byte. The environment variable LRR_MPI_FACTOR, read on the root at
 * the call, chooses: replicated; scalapack (LRR_ERR_UNSUPPORTED when built without it); auto
 * or unset, ScaLAPACK when k >= 2048 on 2 ranks or more. Another value is
 * LRR_ERR_INVALID_ARG naming it. LRR_MPI_SCALAPACK_NB (1 to 4096, default 64) sets
 * ScaLAPACK's block size. */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_operator_build_save(const lrr_scene *scene,
                                                             const lrr_build_options *opts,
                                                             lrr_storage storage,
                                                             lrr_fbar_format fbar,
                                                             const char *path, MPI_Comm comm,
                                                             int root, lrr_operator **head,
                                                             lrr_mpi_build_info *info,
                                                             size_t info_size)
    LRR_NONNULL(1);

/* Collective over comm. lrr_reference_path_trace across ranks: every rank passes the same
 * scene (subdivided alike) and options and traces the subpatches of its chunks (64 dealt
 * round-robin, as lrr_mpi_operator_build's) on the CPU with opts->threads; rank root
 * receives radiosity and, when its std_error is not NULL, std_error (n×3 each, the scene's
 * order; ignored, may be NULL, elsewhere), bit for bit lrr_reference_path_trace's (each
 * path has its own random stream from (seed, subpatch, sample)). Errors as
 * lrr_reference_path_trace's, agreed; LRR_ERR_DIM when a rank's subpatch count differs from
 * the root's. opts->progress is called on each rank for its own subpatches. */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_reference_path_trace(const lrr_scene *scene,
                                                              const lrr_path_trace_options *opts,
                                                              MPI_Comm comm, int root,
                                                              float *radiosity,
                                                              float *std_error)
    LRR_NONNULL(1);

/* Collective over comm. lrr_operator_verify across ranks: rank root passes the operator
 * (op, ignored elsewhere, may be NULL there) and runs the verify; each of its path tracings
 * (the scout, then the two estimates) is dealt across the ranks in chunks of 64 subpatches,
 * every rank tracing its own with a tracer it builds once from its scene (the same scene,
 * subdivided alike, on every rank: LRR_ERR_DIM when a rank's subpatch count differs) and
 * opts->threads (opts may be NULL; only the root's samples, seed and progress count). The
 * figures in op are lrr_operator_verify's bit for bit (each path has its own random stream
 * from (seed, subpatch, sample)). Errors as lrr_operator_verify's, agreed; the root's are
 * recorded on op's context, and sent to the others from the scene's: give the root's op
 * and scene one context. opts->progress is called on the root for its own share. */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_operator_verify(lrr_operator *op,
                                                         const lrr_scene *scene,
                                                         const lrr_verify_options *opts,
                                                         MPI_Comm comm, int root)
    LRR_NONNULL(2);

/* Collective over comm: every rank passes the status of its own work; returns LRR_OK on
 * every rank when all passed LRR_OK, else the agreed error (above: a failing rank keeps its
 * own; the others get the lowest failing rank's status, its message recorded on ctx as
 * "rank R: <message>"). For callers that mix their own per-rank steps with the solver's. */
LRR_API LRR_NODISCARD lrr_status lrr_mpi_agree(lrr_context *ctx, MPI_Comm comm,
                                               lrr_status status) LRR_NONNULL(1);

#ifdef __cplusplus
}
#endif
#endif /* LRR_MPI_H */
