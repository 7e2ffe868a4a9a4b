/* OpenEXR picture output (C++: OpenEXR's C++ API, as lib/probe/exr.cpp reads probes with it).
 * The file is encoded into memory here and written by render.c through the atomic writer, so
 * no partial file ever appears under its name. Only lrr__render_encode_exr is visible to the
 * C side; no exception escapes. */
#include "config.h"
#ifdef LRR_HAVE_OPENEXR

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfOutputFile.h>

extern "C" {
#include "output/render_internal.h"
}

namespace {

/* Thrown when the context's allocator refuses (it records no error itself). */
struct out_of_memory {};

/* A growable in-memory file that OpenEXR writes into (it seeks back once, to fill in the
 * offset table after the pixels). Memory comes from the context's counted allocator. */
class memory_stream : public Imf::OStream {
  public:
    explicit memory_stream(lrr_context *ctx) : Imf::OStream("memory"), ctx_(ctx) {}
    ~memory_stream() override { std::free(data_); }
    memory_stream(const memory_stream &) = delete;
    memory_stream &operator=(const memory_stream &) = delete;

    void write(const char c[], int n) override
    {
        if (n <= 0)
            return;
        const std::uint64_t end = pos_ + (std::uint64_t)n;
        if (end > SIZE_MAX)
            throw out_of_memory();
        reserve((std::size_t)end);
        if (pos_ > len_) /* a seek past the end leaves zeros, as a file would */
            std::memset(data_ + len_, 0, (std::size_t)pos_ - len_);
        std::memcpy(data_ + pos_, c, (std::size_t)n);
        pos_ = end;
        if (end > len_)
            len_ = (std::size_t)end;
    }
    std::uint64_t tellp() override { return pos_; }
    void seekp(std::uint64_t pos) override { pos_ = pos; }

    /* Hands the bytes over (the caller frees them). */
    unsigned char *release(std::size_t *len)
    {
        unsigned char *d = data_;
        *len = len_;
        data_ = nullptr;
        len_ = cap_ = 0;
        return d;
    }

  private:
    void reserve(std::size_t need)
    {
        if (need <= cap_)
            return;
        std::size_t cap = cap_ ? cap_ : (std::size_t)1 << 16;
        while (cap < need) {
            if (cap > SIZE_MAX / 2)
                throw out_of_memory();
            cap *= 2;
        }
        void *p = lrr__realloc(ctx_, data_, cap);
        if (!p)
            throw out_of_memory();
        data_ = static_cast<unsigned char *>(p);
        cap_ = cap;
    }

    lrr_context *ctx_;
    unsigned char *data_ = nullptr;
    std::size_t len_ = 0, cap_ = 0;
    std::uint64_t pos_ = 0;
};

} // namespace

extern "C" lrr_status lrr__render_encode_exr(lrr_context *ctx, const char *path, unsigned width,
                                             unsigned height, const float *rgb,
                                             unsigned char **data, size_t *len)
{
    *data = nullptr;
    *len = 0;
    try {
        memory_stream mem(ctx);
        {
            Imf::Header hdr((int)width, (int)height);
            hdr.compression() = Imf::ZIP_COMPRESSION; /* lossless */
            static const char *const names[3] = {"R", "G", "B"};
            Imf::FrameBuffer fb;
            const std::size_t px = 3 * sizeof(float), row = px * width;
            for (int c = 0; c < 3; c++) {
                hdr.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
                fb.insert(names[c], Imf::Slice(Imf::FLOAT,
                                               const_cast<char *>(
                                                   reinterpret_cast<const char *>(rgb + c)),
                                               px, row));
            }
            Imf::OutputFile out(mem, hdr);
            out.setFrameBuffer(fb);
            out.writePixels((int)height);
        } /* the OutputFile's destructor writes the offset table */
        *data = mem.release(len);
        return LRR_OK;
    } catch (const out_of_memory &) {
        return lrr__error(ctx, LRR_ERR_NOMEM, "render %s: no memory for the OpenEXR encoding",
                          path);
    } catch (const std::bad_alloc &) {
        return lrr__error(ctx, LRR_ERR_NOMEM, "render %s: no memory for the OpenEXR encoding",
                          path);
    } catch (const std::exception &e) {
        return lrr__error(ctx, LRR_ERR_IO, "render %s: OpenEXR encoding failed: %s", path,
                          e.what());
    } catch (...) {
        return lrr__error(ctx, LRR_ERR_IO, "render %s: OpenEXR encoding failed", path);
    }
}
#else /* !LRR_HAVE_OPENEXR */

/* configure --without-openexr: .exr pictures are refused, naming the file. */
extern "C" {
#include "output/render_internal.h"
}

extern "C" lrr_status lrr__render_encode_exr(lrr_context *ctx, const char *path, unsigned width,
                                             unsigned height, const float *rgb,
                                             unsigned char **data, size_t *len)
{
    *data = nullptr;
    *len = 0;
    return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                      "render %s: lrr was built without OpenEXR: cannot write .exr files "
                      "(write a .png)",
                      path);
}
#endif
