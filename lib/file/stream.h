/* Saving an operator whose F̄ is held elsewhere (liblrr_mpi's lrr_mpi_operator_build_save):
 * the file lrr_operator_save_fbar writes, with F̄'s payload pulled piece by piece from a
 * stream, and the strips of rows held apart.
 *
 * PRIVATE ABI, as lib/solve/rows.h: exported under LRR_PRIVATE_3 (lib/liblrr.map) for
 * liblrr_mpi alone; names only lrr.h's types. */
#ifndef LRR_FILE_STREAM_H
#define LRR_FILE_STREAM_H

#include "lrr.h"

#include "core/private_api.h"

/* F̄'s payload in order, twice (the section's checksum, then the write): next() puts the
 * piece at *cursor (0 at the start of each pass; it advances it) into *data and returns its
 * bytes, 0 after the last: rows as stored (strips = 0) or whole tiles' blocks (strips = 1,
 * without the counts, which the writer puts first), every piece but the last a multiple of
 * 8 bytes. A failure sets status and returns 0: the save then removes its file and returns
 * status. tile_strips: the ⌈n/16⌉ tiles' strip counts (NULL: dense only). */
typedef struct lrr__fbar_stream {
    size_t (*next)(struct lrr__fbar_stream *s, int strips, size_t *cursor, const void **data);
    const size_t *tile_strips;
    lrr_status status;
} lrr__fbar_stream;

/* lrr_operator_save_fbar of op (which has no F̄: storage, row scales, M and the rest as the
 * file needs them) with F̄ from src: dense or strips as fbar and AUTO choose from the
 * counts, the same bytes. */
LRR__PRIVATE_API lrr_status lrr__operator_save_stream(const lrr_operator *op, const char *path,
                                                      lrr_fbar_format fbar,
                                                      lrr__fbar_stream *src);
/* The tiles of nrows consecutive rows of F̄ held apart (nrows × k elements of es bytes,
 * row-major; the first row a multiple of 16, nrows too unless they end F̄) as FBAR_STRIPS
 * stores them, into out (NULL: counted only), each tile's strip count into counts; their
 * bytes. A tile block's bytes for m strips. */
LRR__PRIVATE_API size_t lrr__strips_encode(size_t k, size_t es, const void *rows, size_t nrows,
                                           size_t *counts, unsigned char *out);
LRR__PRIVATE_API size_t lrr__strips_tile_bytes(size_t m, size_t es);

#endif
