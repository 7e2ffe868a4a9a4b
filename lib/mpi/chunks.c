/* Work dealt in chunks across ranks (mpi_internal.h): chunk c of LRR__MPI_CHUNK rows to
 * rank c mod P, and the root's receive that puts rank r's chunks in place (one message of
 * an indexed datatype). The
 * distributed build (build.c) and reference (trace.c) deal their receivers so: a
 * receiver's cost follows what it sees, and neighbouring chunks cost about the same. */
#include "config.h"
#include "mpi/mpi_internal.h"

#include <string.h>

size_t lrr__mpi_chunk_rows(size_t n, int r, int size, size_t *rows)
{
    size_t count = 0;
    for (size_t c0 = (size_t)r * LRR__MPI_CHUNK; c0 < n; c0 += (size_t)size * LRR__MPI_CHUNK)
        for (size_t i = c0; i < n && i < c0 + LRR__MPI_CHUNK; i++) {
            if (rows)
                rows[count] = i;
            count++;
        }
    return count;
}

size_t lrr__mpi_chunk_most(size_t n, int size)
{
    return (n + LRR__MPI_CHUNK - 1) / LRR__MPI_CHUNK / (size_t)size + 1;
}

int lrr__mpi_chunk_recv(MPI_Comm comm, size_t n, int r, int size, MPI_Datatype row,
                        int *len, int *at, void *buf, int tag)
{
    const size_t chunks = (n + LRR__MPI_CHUNK - 1) / LRR__MPI_CHUNK;
    size_t m = 0;
    for (size_t c = (size_t)r; c < chunks; c += (size_t)size, m++) {
        at[m] = (int)(c * LRR__MPI_CHUNK);
        len[m] = (int)((c + 1) * LRR__MPI_CHUNK < n ? LRR__MPI_CHUNK : n - c * LRR__MPI_CHUNK);
    }
    if (m == 0)
        return MPI_SUCCESS; /* rank r has no rows and sends nothing */
    MPI_Datatype type;
    int rc = MPI_Type_indexed((int)m, len, at, row, &type);
    if (rc != MPI_SUCCESS)
        return rc;
    if ((rc = MPI_Type_commit(&type)) == MPI_SUCCESS)
        rc = MPI_Recv(buf, 1, type, r, tag, comm, MPI_STATUS_IGNORE);
    MPI_Type_free(&type);
    return rc;
}

int lrr__mpi_chunk_gather(MPI_Comm comm, int root, size_t n, const size_t *mine, size_t count,
                          const float *packed, float *whole, int *len, int *at, int tag)
{
    int rank, size, rc;
    MPI_Datatype rgb;
    if ((rc = MPI_Comm_rank(comm, &rank)) != MPI_SUCCESS ||
        (rc = MPI_Comm_size(comm, &size)) != MPI_SUCCESS ||
        (rc = MPI_Type_contiguous(3, MPI_FLOAT, &rgb)) != MPI_SUCCESS)
        return rc;
    if ((rc = MPI_Type_commit(&rgb)) == MPI_SUCCESS && rank != root && count) {
        rc = MPI_Send(packed, (int)count, rgb, root, tag, comm);
    } else if (rc == MPI_SUCCESS && rank == root) {
        for (size_t j = 0; j < count; j++)
            memcpy(whole + 3 * mine[j], packed + 3 * j, 3 * sizeof(float));
        for (int r = 0; r < size && rc == MPI_SUCCESS; r++)
            if (r != root)
                rc = lrr__mpi_chunk_recv(comm, n, r, size, rgb, len, at, whole, tag);
    }
    MPI_Type_free(&rgb);
    return rc;
}
