/* The distributed error bar (lrr_mpi.h lrr_mpi_operator_verify): the root runs
 * lrr_operator_verify (lib/verify/rows.h: lrr__verify_with) and hands each of its path
 * tracings (the scout, then the two estimates in batches of equal path counts) to every
 * rank: a command with the batch's options and subpatches, broadcast; each rank traces the
 * list positions of its chunks (chunks.c, dealt as the build's receivers) with a tracer of
 * its own, built once; the root receives the estimates in place. The other ranks wait for
 * commands until the root says the verify ended, with its status. Each path has its own
 * random stream from (seed, subpatch, sample), so the figures are the serial ones bit for
 * bit. */
#include "config.h"
#include "mpi/mpi_internal.h"
#include "reference/rows.h"
#include "verify/rows.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define TAG_P 5
#define TAG_SE 6

enum { CMD_TRACE = 1, CMD_DONE = 2 };

typedef struct verify {
    lrr_context *ctx;
    MPI_Comm comm;
    int rank, size, root;
    const lrr_scene *scene;
    const lrr_verify_options *o; /* this rank's: threads */
    lrr__tracer *tracer;         /* this rank's (the root's: the verify's own) */
    int uniform;                 /* the emission the tracer was made for */
    lrr_status early;            /* the others: building the tracer before the first batch */
} verify;

/* A batch: the command (what, samples, seed, count, std_error wanted, uniform emission,
 * the root's subpatch count) and its subpatches, from the root to every rank. */
static lrr_status command(verify *v, uint64_t cmd[7], size_t **rows)
{
    int rc = MPI_Bcast(cmd, 7, MPI_UINT64_T, v->root, v->comm);
    if (rc != MPI_SUCCESS)
        return lrr__mpi_failed(v->ctx, "MPI_Bcast (verify command)", rc);
    if (cmd[0] != CMD_TRACE)
        return LRR_OK;
    lrr_scene_info si;
    lrr_scene_get_info(v->scene, &si, sizeof si);
    lrr_status st = LRR_OK;
    if (si.subpatches != cmd[6])
        st = lrr__mpi_error(v->ctx, LRR_ERR_DIM, "lrr_mpi_operator_verify: rank %d's scene has "
                            "%zu subpatches, the root's (rank %d) %llu", v->rank, si.subpatches,
                            v->root, (unsigned long long)cmd[6]);
    else if (cmd[3] > INT32_MAX / 3)
        st = lrr__mpi_error(v->ctx, LRR_ERR_OVERFLOW, "lrr_mpi_operator_verify: %llu "
                            "subpatches exceed MPI's int counts", (unsigned long long)cmd[3]);
    else if (v->rank != v->root && !(*rows = calloc(cmd[3] ? cmd[3] : 1, sizeof **rows)))
        st = lrr__mpi_error(v->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_verify: cannot allocate "
                            "a batch of %llu subpatches", (unsigned long long)cmd[3]);
    if ((st = lrr__mpi_spread(v->ctx, v->comm, st)))
        return st;
    rc = MPI_Bcast(*rows, (int)cmd[3], sizeof(size_t) == 8 ? MPI_UINT64_T : MPI_UINT32_T,
                   v->root, v->comm);
    return rc == MPI_SUCCESS ? LRR_OK : lrr__mpi_failed(v->ctx, "MPI_Bcast (verify batch)", rc);
}

/* The root's progress over its share, scaled to the whole batch. */
typedef struct scaled {
    const lrr_path_trace_options *o;
    size_t batch;
} scaled;

static int scaled_progress(void *user, size_t done, size_t total)
{
    const scaled *sc = user;
    const size_t d = total ? (size_t)((double)done / (double)total * (double)sc->batch) : 0;
    return sc->o->progress(sc->o->progress_user, d, sc->batch);
}

/* This rank's share of a batch: the positions of its chunks of the list (pos), their
 * subpatches (mine) traced into p (and se), packed, with the given tracer (the root's: the
 * verify's own) or this rank's (made, or made again for another emission, here). */
static lrr_status share(verify *v, const lrr__tracer *given, const lrr_path_trace_options *ro,
                        const uint64_t cmd[7], const size_t *rows, size_t *pos, size_t *mine,
                        float *p, float *se)
{
    lrr_path_trace_options po = lrr_path_trace_options_defaults();
    po.samples = cmd[1];
    po.seed = cmd[2];
    po.threads = v->o ? v->o->threads : 0;
    scaled sc = {ro, cmd[3]};
    if (ro && ro->progress) { /* the root: the verify's bar */
        po.progress = scaled_progress;
        po.progress_user = &sc;
    }
    const size_t count = lrr__mpi_chunk_rows(cmd[3], v->rank, v->size, pos);
    for (size_t j = 0; j < count; j++)
        mine[j] = rows[pos[j]];
    lrr_status st = v->early;
    v->early = LRR_OK;
    if (!st && !given && (!v->tracer || v->uniform != (int)cmd[5])) {
        lrr__tracer_destroy(v->tracer);
        v->tracer = NULL;
        v->uniform = (int)cmd[5];
        st = lrr__trace_start(v->scene, v->uniform, &v->tracer);
    }
    if (!st && count)
        st = lrr__tracer_rows(given ? given : v->tracer, &po, mine, count, p,
                             cmd[4] ? se : NULL);
    return st;
}

/* One batch on every rank (the command already broadcast): the shares traced, agreed, and
 * sent to the root, which places them in p and se (count×3). */
static lrr_status batch(verify *v, const lrr__tracer *given, const lrr_path_trace_options *ro,
                        const uint64_t cmd[7], const size_t *rows, float *p, float *se)
{
    const size_t count = cmd[3], most = lrr__mpi_chunk_rows(count, v->rank, v->size, NULL);
    const size_t chunks = lrr__mpi_chunk_most(count, v->size);
    size_t *pos = calloc(most + 1, sizeof *pos), *mine = calloc(most + 1, sizeof *mine);
    float *bp = calloc(6 * most + 1, sizeof *bp);
    int *len = calloc(chunks, sizeof *len), *at = calloc(chunks, sizeof *at);
    lrr_status st = pos && mine && bp && len && at
                        ? share(v, given, ro, cmd, rows, pos, mine, bp, bp + 3 * most)
                        : lrr__mpi_error(v->ctx, LRR_ERR_NOMEM, "lrr_mpi_operator_verify: "
                                         "cannot allocate this rank's %zu subpatches", most);
    int rc = MPI_SUCCESS;
    if (!(st = lrr__mpi_spread(v->ctx, v->comm, st)) &&
        (rc = lrr__mpi_chunk_gather(v->comm, v->root, count, pos, most, bp, p, len, at,
                                    TAG_P)) == MPI_SUCCESS &&
        cmd[4])
        rc = lrr__mpi_chunk_gather(v->comm, v->root, count, pos, most, bp + 3 * most, se, len,
                                   at, TAG_SE);
    free(pos);
    free(mine);
    free(bp);
    free(len);
    free(at);
    if (st)
        return st;
    return lrr__mpi_spread(v->ctx, v->comm, rc == MPI_SUCCESS ? LRR_OK
                                                : lrr__mpi_failed(v->ctx, "sending estimates",
                                                                  rc));
}

/* The root's lrr__verify_trace_fn: the batch to every rank. */
static lrr_status root_trace(void *user, const lrr__tracer *tracer, int uniform,
                             const lrr_path_trace_options *o, const size_t *rows, size_t count,
                             float *p, float *se)
{
    verify *v = user;
    lrr_scene_info si;
    lrr_scene_get_info(v->scene, &si, sizeof si);
    uint64_t cmd[7] = {CMD_TRACE, o->samples, o->seed, count, se != NULL, (uint64_t)uniform,
                       si.subpatches};
    size_t *list = (size_t *)(uintptr_t)rows; /* broadcast from here, not written */
    lrr_status st = command(v, cmd, &list);
    return st ? st : batch(v, tracer, o, cmd, rows, p, se);
}

/* The other ranks: batches until the root's verify ends (CMD_DONE), then its status. A
 * failed batch was agreed: the root's verify returns, and its next command is CMD_DONE. */
static lrr_status serve(verify *v)
{
    for (;;) {
        uint64_t cmd[7] = {0};
        size_t *rows = NULL;
        lrr_status st = command(v, cmd, &rows);
        if (!st && cmd[0] == CMD_TRACE)
            st = batch(v, NULL, NULL, cmd, rows, NULL, NULL);
        free(rows);
        if (cmd[0] == CMD_DONE)
            return lrr__mpi_spread(v->ctx, v->comm, LRR_OK);
        if (cmd[0] != CMD_TRACE)
            return st; /* the command's broadcast failed */
    }
}

lrr_status lrr_mpi_operator_verify(lrr_operator *op, const lrr_scene *scene,
                                   const lrr_verify_options *opts, MPI_Comm comm, int root)
{
    verify v;
    memset(&v, 0, sizeof v);
    v.ctx = lrr__trace_context(scene);
    v.scene = scene;
    v.o = opts;
    v.root = root;
    lrr_status st = lrr__mpi_open(v.ctx, comm, root, "lrr_mpi_operator_verify", &v.comm,
                                  &v.rank, &v.size);
    if (v.comm == MPI_COMM_NULL)
        return st;
    if (!st)
        st = lrr__mpi_spread(v.ctx, v.comm,
                             v.rank == root && !op
                                 ? lrr__mpi_error(v.ctx, LRR_ERR_INVALID_ARG,
                                                  "lrr_mpi_operator_verify: the root's "
                                                  "operator is NULL")
                                 : LRR_OK);
    if (!st && v.rank != root) {
        /* the tracer, built while the root builds its own and solves: for the scene's
         * emission, or E = 1 where no triangle emits (the first command says which, and a
         * wrong guess is built again); a failure is reported at the first command, where
         * the ranks agree */
        lrr_scene_info si;
        lrr_scene_get_info(scene, &si, sizeof si);
        v.uniform = si.emitters == 0;
        v.early = lrr__trace_start(scene, v.uniform, &v.tracer);
        st = serve(&v);
    } else if (!st) {
        st = lrr__verify_with(op, scene, opts, root_trace, &v);
        uint64_t done[7] = {CMD_DONE};
        lrr_status sent = command(&v, done, NULL);
        st = lrr__mpi_spread(v.ctx, v.comm, st ? st : sent);
    }
    lrr__tracer_destroy(v.tracer);
    MPI_Comm_free(&v.comm);
    return st;
}
