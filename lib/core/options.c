/* Growable structs (include/lrr.h "Conventions"): how the library reads a caller's option
 * struct and fills a caller's info struct whatever lrr version either was built against. */
#include "config.h"
#include "core/internal.h"

#include <string.h>

lrr_status lrr__options_read(lrr_context *ctx, const void *in, size_t known, size_t first,
                             void *out, const char *what)
{
    size_t size;
    memcpy(&size, in, sizeof size); /* every growable option struct starts with its size */
    if (size == 0)
        size = first; /* the first layout (ABI 1): designated initialisers leave size 0 */
    if (size < first || size % sizeof(size_t) != 0)
        return lrr__error(ctx, LRR_ERR_INVALID_ARG,
                          "%s.size = %zu: set it with %s_defaults() (it is %zu in this lrr), "
                          "or leave it 0",
                          what, size, what, known);
    if (size > known) {
        /* a newer caller's struct: fine while the fields this lrr does not know are unset */
        for (size_t b = known; b < size; b++)
            if (((const unsigned char *)in)[b] != 0)
                return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                                  "%s: byte %zu of %zu is set, a field this lrr (%s, %zu "
                                  "bytes) does not know: the caller was built against a newer "
                                  "lrr",
                                  what, b, size, lrr_version_string(), known);
    }
    /* an older caller's struct (size < known): the fields it lacks keep out's values */
    memcpy(out, in, size < known ? size : known);
    memcpy(out, &known, sizeof known);
    return LRR_OK;
}

void lrr__info_write(void *out, size_t out_size, const void *info, size_t info_size)
{
    size_t n = out_size < info_size ? out_size : info_size;
    memcpy(out, info, n);
    if (out_size > n)
        memset((unsigned char *)out + n, 0, out_size - n); /* fields of a newer lrr: zero */
}
