/* Radiance RGBE (.hdr) probes: the file is read into memory and its pixel stream checked
 * before stb_image decodes it, because stb_image (as of Debian 12's 2022-09 snapshot)
 *   - reads zeros past the end of the data, so a truncated file decodes without an error
 *     into black rows (and a header claiming 16384×8192 pixels in 60 bytes allocates
 *     1.5 GB of them);
 *   - loops forever on a run-length count of 0 in a new-style RLE scanline.
 * check_stream follows stb_image's decoding step by step (flat pixels; new-style RLE
 * scanlines of width 8..32767; a scanline that does not start with 2 2 switching the whole
 * image to flat pixels) and only counts bytes, so once it passes, stb_image neither runs out
 * of data nor meets a zero count. It also refuses what stb_image would refuse itself (a
 * scanline length other than the width, a run longer than the rest of its scanline): stb_image
 * allocates the whole image before it meets those, so a 100-byte file claiming 16384×8192
 * pixels would cost 1.5 GB on its way to an error (found by fuzzing). A stream that passes
 * holds every pixel, at most 128 per 2 bytes, so the allocation is bounded by the file. */
#include "config.h"
#include "core/path.h"
#include "probe/probe.h"

#include <errno.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <stb_image.h>

/* Offset of the pixel data: after the magic line, the header lines up to an empty one, and
 * the resolution line (stb_image's reading, which ends a line at '\n' or at the end). */
static size_t data_offset(const unsigned char *p, size_t size)
{
    size_t i = 0;
    int empty_seen = 0;
    for (int line = 0; i < size; line++) {
        size_t start = i;
        while (i < size && p[i] != '\n')
            i++;
        bool empty = i == start;
        if (i < size)
            i++; /* the '\n' */
        if (line > 0 && empty_seen)
            return i; /* the resolution line */
        if (line > 0 && empty)
            empty_seen = 1;
    }
    return size;
}

/* NULL if stb_image will decode the whole stream without an error, else what is wrong. */
static const char *check_stream(const unsigned char *p, size_t size, size_t pos, size_t w,
                                size_t h)
{
    size_t pixels = w * h; /* w, h < 2^24 (stb_image's limit), checked by the caller */
    size_t left = size - pos;
    if (w < 8 || w >= 32768)
        return left / 4 < pixels ? "the file ends before the last pixel" : NULL;
    for (size_t y = 0; y < h; y++) {
        if (left < 4)
            return "the file ends before the last scanline";
        const unsigned char *s = p + size - left;
        if (s[0] != 2 || s[1] != 2 || (s[2] & 0x80)) {
            /* flat from here on, and stb_image starts over at pixel 1 of row 0 */
            return left / 4 < pixels ? "the file ends before the last pixel" : NULL;
        }
        if (((size_t)s[2] << 8 | s[3]) != w)
            return "a run-length encoded scanline's length is not the image width";
        left -= 4;
        for (int c = 0; c < 4; c++) {
            size_t x = 0;
            while (x < w) {
                if (left < 1)
                    return "the file ends inside a run-length encoded scanline";
                unsigned count = p[size - left];
                left--;
                if (count == 0)
                    return "a run-length encoded scanline has a run of length 0";
                size_t n = count > 128 ? count - 128 : count, need = count > 128 ? 1 : n;
                if (n > w - x)
                    return "a run-length encoded run is longer than the rest of its scanline";
                if (left < need)
                    return "the file ends inside a run-length encoded scanline";
                left -= need;
                x += n;
            }
        }
    }
    return NULL;
}

lrr_status lrr__hdr_read_rgb(lrr_context *ctx, const char *path, float **rgb, size_t *width,
                             size_t *height)
{
    *rgb = NULL;
    *width = *height = 0;
    FILE *f = NULL;
    struct stat sb;
    int e = lrr__open_regular(path, &f, &sb);
    if (e == LRR__NOT_REGULAR || e == EISDIR)
        return lrr__error(ctx, LRR_ERR_IO, "'%s': " LRR__NOT_REGULAR_TEXT, path);
    if (e) {
        char eb[128];
        return lrr__error(ctx, LRR_ERR_IO, "'%s': cannot open: %s", path,
                          lrr__errno_text(e, eb, sizeof eb));
    }
    if (sb.st_size < 0 || (uint64_t)sb.st_size > (uint64_t)INT_MAX) {
        fclose(f);
        return lrr__error(ctx, LRR_ERR_FORMAT,
                          "'%s': not a regular file of at most 2 GiB (a Radiance .hdr probe)",
                          path);
    }
    size_t size = (size_t)sb.st_size;
    unsigned char *buf = lrr__alloc(ctx, size ? size : 1);
    if (!buf) {
        fclose(f);
        return lrr__error(ctx, LRR_ERR_NOMEM, "'%s': cannot allocate %zu bytes to read it", path,
                          size);
    }
    size_t got = size ? fread(buf, 1, size, f) : 0;
    fclose(f);
    lrr_status st = LRR_OK;
    int w = 0, h = 0, comp = 0;
    if (got != size) {
        st = lrr__error(ctx, LRR_ERR_IO, "'%s': cannot read %zu bytes", path, size);
    } else if (!stbi_is_hdr_from_memory(buf, (int)size)) {
        st = lrr__error(ctx, LRR_ERR_FORMAT,
                        "'%s': not a Radiance RGBE (.hdr) file (probes are read from .hdr "
                        "and, by the .exr extension, OpenEXR files)",
                        path);
    } else if (!stbi_info_from_memory(buf, (int)size, &w, &h, &comp) || w <= 0 || h <= 0) {
        st = lrr__error(ctx, LRR_ERR_FORMAT, "'%s': cannot decode the .hdr header: %s", path,
                        stbi_failure_reason());
    } else if ((size_t)w != 2 * (size_t)h) {
        /* refused before decoding: the pixels of a wrong layout are never needed */
        st = lrr__error(ctx, LRR_ERR_DIM,
                        "'%s': %d×%d pixels is not a latitude–longitude probe (expected "
                        "width = 2 × height, row 0 the zenith, e.g. 1024×512)",
                        path, w, h);
    } else {
        const char *why = check_stream(buf, size, data_offset(buf, size), (size_t)w, (size_t)h);
        if (why)
            st = lrr__error(ctx, LRR_ERR_FORMAT, "'%s': %d×%d pixels: %s (truncated or corrupt)",
                            path, w, h, why);
    }
    if (st == LRR_OK) {
        float *pix = stbi_loadf_from_memory(buf, (int)size, &w, &h, &comp, 3);
        if (!pix)
            st = lrr__error(ctx, LRR_ERR_FORMAT, "'%s': cannot decode the .hdr file: %s", path,
                            stbi_failure_reason());
        *rgb = pix;
        *width = (size_t)w;
        *height = (size_t)h;
    }
    free(buf);
    return st;
}
