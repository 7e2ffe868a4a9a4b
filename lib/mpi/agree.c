/* Agreeing on errors across ranks (lrr_mpi.h "Collective calls and faults"). A rank that
 * fails must still take part in the collective calls the others are in, or they wait for it
 * forever: so every collective function checks locally first, then all ranks learn whether
 * any failed (the solver's frames carry that in their allreduce; here one more allreduce),
 * and only then exchange data. The message travels once, from the lowest failing rank, so
 * every rank reports the same cause. */
#include "config.h"
#include "mpi/mpi_internal.h"

#include <stdarg.h>
#include <stdio.h>
#include <string.h>

/* lrr_context's message buffer (lib/core/internal.h): longer messages are cut there too */
#define MESSAGE_BYTES 512

lrr_status lrr__mpi_error(lrr_context *ctx, lrr_status status, const char *fmt, ...)
{
    char buf[MESSAGE_BYTES];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    return lrr__rows_record(ctx, status, buf);
}

lrr_status lrr__mpi_failed(lrr_context *ctx, const char *call, int rc)
{
    char text[MPI_MAX_ERROR_STRING];
    int len = 0;
    if (MPI_Error_string(rc, text, &len) != MPI_SUCCESS)
        snprintf(text, sizeof text, "MPI error code %d", rc);
    return lrr__mpi_error(ctx, LRR_ERR_IO, "%s failed: %s", call, text);
}

/* What the lowest failing rank sends: its status and message. */
typedef struct wire {
    int status;
    char message[MESSAGE_BYTES];
} wire;

lrr_status lrr__mpi_spread(lrr_context *ctx, MPI_Comm comm, lrr_status mine)
{
    int rank, size, rc;
    if ((rc = MPI_Comm_rank(comm, &rank)) != MPI_SUCCESS ||
        (rc = MPI_Comm_size(comm, &size)) != MPI_SUCCESS)
        return lrr__mpi_failed(ctx, "MPI_Comm_rank/size", rc);
    int me = mine != LRR_OK ? rank : size, low = size;
    if ((rc = MPI_Allreduce(&me, &low, 1, MPI_INT, MPI_MIN, comm)) != MPI_SUCCESS)
        return lrr__mpi_failed(ctx, "MPI_Allreduce (status)", rc);
    if (low == size)
        return LRR_OK;
    wire w;
    memset(&w, 0, sizeof w);
    if (rank == low) {
        w.status = (int)mine;
        /* a failure that recorded nothing (or whose record an older unread error holds)
         * still has its status' name */
        if (lrr__rows_peek(ctx, w.message, sizeof w.message) == LRR_OK)
            snprintf(w.message, sizeof w.message, "%s", lrr_strerror(mine));
    }
    if ((rc = MPI_Bcast(&w, (int)sizeof w, MPI_BYTE, low, comm)) != MPI_SUCCESS)
        return lrr__mpi_failed(ctx, "MPI_Bcast (error message)", rc);
    if (mine != LRR_OK)
        return mine; /* its own message is on its context already */
    w.message[sizeof w.message - 1] = '\0';
    return lrr__mpi_error(ctx, (lrr_status)w.status, "rank %d: %s", low, w.message);
}

lrr_status lrr_mpi_agree(lrr_context *ctx, MPI_Comm comm, lrr_status status)
{
    return lrr__mpi_spread(ctx, comm, status);
}

lrr_status lrr__mpi_open(lrr_context *ctx, MPI_Comm comm, int root, const char *fn,
                         MPI_Comm *dup, int *rank, int *size)
{
    int rc = MPI_Comm_dup(comm, dup);
    if (rc != MPI_SUCCESS) {
        *dup = MPI_COMM_NULL;
        return lrr__mpi_failed(ctx, "MPI_Comm_dup", rc);
    }
    MPI_Comm_set_errhandler(*dup, MPI_ERRORS_RETURN);
    MPI_Comm_rank(*dup, rank);
    MPI_Comm_size(*dup, size);
    /* the same check on every rank: they all return alike */
    if (root < 0 || root >= *size)
        return lrr__mpi_error(ctx, LRR_ERR_INVALID_ARG, "%s: root %d is not a rank of %d", fn,
                              root, *size);
    return LRR_OK;
}
