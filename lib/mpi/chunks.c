/* Work dealt in chunks across ranks (mpi_internal.h): chunk c of LRR__MPI_CHUNK rows to
 * rank c mod P, and the root's receive that puts rank r's chunks in place (one message of
 * an indexed datatype). The
 * distributed build (build.c) and reference (trace.c) deal their receivers so: a
 * receiver's cost follows what it sees, and neighbouring chunks cost about the same. */
#include "config.h"
#include "mpi/mpi_internal.h"

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
