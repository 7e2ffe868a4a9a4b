/* Saving an operator whose F̄ is held elsewhere (liblrr_mpi's lrr_mpi_operator_build_save):
 * the file lrr_operator_save_fbar writes, with F̄'s section written into it by others (each
 * rank its rows, through MPI-IO), and the strips of rows held apart.
 *
 * PRIVATE ABI, as lib/solve/rows.h: exported under LRR_PRIVATE_3/4 (lib/liblrr.map) for
 * liblrr_mpi alone; names only lrr.h's types. */
#ifndef LRR_FILE_STREAM_H
#define LRR_FILE_STREAM_H

#include <stdint.h>

#include "lrr.h"

#include "core/private_api.h"

/* F̄'s section placed by its holders. The writer lays the file out, creates its temporary
 * file and, before writing anything else, calls place() once: the holders write F̄'s rows as
 * stored (strips = 0) or its tiles' blocks (strips = 1; the strip counts that open the
 * section are the writer's) in order from byte offset of the file tmp, and run the section
 * checksum's state *h over those bytes in the same order (lrr__checksum_run). The writer
 * then puts the checksum in the table, writes the rest around F̄ and renames the file into
 * place; a failure of place() (its status, the holders' files closed) leaves no file.
 * tile_strips: the ⌈n/16⌉ tiles' strip counts (NULL: dense only), from which the writer
 * chooses strips or rows as AUTO would for the whole F̄. */
typedef struct lrr__fbar_placer {
    lrr_status (*place)(struct lrr__fbar_placer *p, const char *tmp, uint64_t offset,
                        int strips, uint64_t *h);
    const size_t *tile_strips;
} lrr__fbar_placer;

/* lrr_operator_save_fbar of op (which has no F̄: storage, row scales, M and the rest as the
 * file needs them) with F̄ placed by p: dense or strips as fbar and AUTO choose from the
 * counts, the same bytes. */
LRR__PRIVATE_API lrr_status lrr__operator_save_placed(const lrr_operator *op, const char *path,
                                                      lrr_fbar_format fbar,
                                                      lrr__fbar_placer *p);
/* The checksum's state over the next len bytes of a section (every piece but the last a
 * multiple of 8 bytes): the format's rule (lrr_file.c), for place(). */
LRR__PRIVATE_API uint64_t lrr__checksum_run(uint64_t h, const void *data, size_t len);
/* The tiles of nrows consecutive rows of F̄ held apart (nrows × k elements of es bytes,
 * row-major; the first row a multiple of 16, nrows too unless they end F̄) as FBAR_STRIPS
 * stores them, into out (NULL: counted only), each tile's strip count into counts; their
 * bytes. A tile block's bytes for m strips. */
LRR__PRIVATE_API size_t lrr__strips_encode(size_t k, size_t es, const void *rows, size_t nrows,
                                           size_t *counts, unsigned char *out);
LRR__PRIVATE_API size_t lrr__strips_tile_bytes(size_t m, size_t es);

#endif
