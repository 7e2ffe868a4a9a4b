/* OpenEXR probe reading (C++: OpenEXR's C API cannot decode DWA-compressed files, its C++
 * reading API can). Only lrr__exr_read_rgb is visible to the C side; no exception escapes. */
#include "config.h"

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>

extern "C" {
#include "internal.h"
}

extern "C" lrr_status lrr__exr_read_rgb(lrr_context *ctx, const char *path, float **rgb,
                                        size_t *width, size_t *height)
{
    *rgb = nullptr;
    *width = *height = 0;
    std::FILE *f = std::fopen(path, "rb");
    if (!f)
        return lrr__error(ctx, LRR_ERR_IO, "'%s': cannot open", path);
    std::fclose(f);
    float *pix = nullptr;
    try {
        Imf::InputFile in(path);
        const Imf::Header &hdr = in.header();
        const Imath::Box2i dw = hdr.dataWindow();
        const long long w = (long long)dw.max.x - dw.min.x + 1;
        const long long h = (long long)dw.max.y - dw.min.y + 1;
        const Imf::ChannelList &ch = hdr.channels();
        std::string found;
        for (Imf::ChannelList::ConstIterator it = ch.begin(); it != ch.end(); ++it)
            found += std::string(found.empty() ? "" : " ") + it.name();
        static const char *const names[3] = {"R", "G", "B"};
        for (int c = 0; c < 3; c++) {
            const Imf::Channel *chan = ch.findChannel(names[c]);
            if (!chan)
                return lrr__error(ctx, LRR_ERR_FORMAT,
                                  "'%s': OpenEXR file without an %s channel (an RGB probe needs "
                                  "R, G and B; found: %s)",
                                  path, names[c], found.empty() ? "none" : found.c_str());
            if (chan->xSampling != 1 || chan->ySampling != 1)
                return lrr__error(ctx, LRR_ERR_FORMAT,
                                  "'%s': OpenEXR channel %s is subsampled (%d×%d); probes need "
                                  "full-resolution R, G, B",
                                  path, names[c], chan->xSampling, chan->ySampling);
        }
        if (w <= 0 || h <= 0 || (unsigned long long)w > SIZE_MAX / 3 / sizeof(float) /
                                                            (unsigned long long)h)
            return lrr__error(ctx, LRR_ERR_DIM, "'%s': OpenEXR data window of %lld×%lld pixels",
                              path, w, h);
        const size_t sw = (size_t)w, sh = (size_t)h;
        pix = static_cast<float *>(lrr__alloc(ctx, sw * sh * 3 * sizeof(float)));
        if (!pix)
            return lrr__error(ctx, LRR_ERR_NOMEM, "'%s': cannot allocate %zu×%zu RGB pixels",
                              path, sw, sh);
        /* the slice base is the address of pixel (0, 0), which may lie outside the buffer */
        char *base = reinterpret_cast<char *>(pix) -
                     ((ptrdiff_t)dw.min.x + (ptrdiff_t)dw.min.y * (ptrdiff_t)w) *
                         (ptrdiff_t)(3 * sizeof(float));
        Imf::FrameBuffer fb;
        for (int c = 0; c < 3; c++)
            fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float),
                                           3 * sizeof(float), 3 * sizeof(float) * sw));
        in.setFrameBuffer(fb);
        in.readPixels(dw.min.y, dw.max.y);
        *rgb = pix;
        *width = sw;
        *height = sh;
        return LRR_OK;
    } catch (const std::bad_alloc &) {
        std::free(pix);
        return lrr__error(ctx, LRR_ERR_NOMEM, "'%s': out of memory reading the OpenEXR file",
                          path);
    } catch (const std::exception &e) {
        std::free(pix);
        return lrr__error(ctx, LRR_ERR_FORMAT, "'%s': cannot read the OpenEXR file: %s", path,
                          e.what());
    } catch (...) {
        std::free(pix);
        return lrr__error(ctx, LRR_ERR_FORMAT, "'%s': cannot read the OpenEXR file", path);
    }
}
