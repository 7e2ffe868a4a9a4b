/* OpenEXR probe reading (C++: OpenEXR's C API cannot decode DWA-compressed files, its C++
 * reading API can). Only lrr__exr_read_rgb is visible to the C side; no exception escapes. */
#include "config.h"
#ifdef LRR_HAVE_OPENEXR

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <new>
#include <string>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <openexr.h>

#include <sys/stat.h>

extern "C" {
#include "core/path.h"
#include "probe/probe.h"
}

namespace {

/* Scanlines per chunk for each OpenEXR compression (NO, RLE, ZIPS, ZIP, PIZ, PXR24, B44,
 * B44A, DWAA, DWAB); OpenEXR itself rejects the others. */
int lines_per_chunk(unsigned compression)
{
    static const int lines[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
    return compression < sizeof lines / sizeof lines[0] ? lines[compression] : 1;
}

/* OpenEXR's reader allocates a buffer for one unpacked chunk (up to 256 scanlines of every
 * channel, or one tile) from the header alone. A 16384-wide RGBA float DWAB chunk is 64 MiB;
 * a header asking for more is refused rather than trusted. */
const std::uint64_t MAX_CHUNK_BYTES = 256u << 20;

/* The first message of OpenEXR's core library, which would otherwise print it. */
struct core_message {
    char text[256];
};

void keep_core_message(exr_const_context_t ctx, exr_result_t code, const char *msg)
{
    (void)code;
    void *user = nullptr;
    if (exr_get_user_data(ctx, &user) == EXR_ERR_SUCCESS && user && msg) {
        core_message *m = static_cast<core_message *>(user);
        if (!m->text[0])
            std::snprintf(m->text, sizeof m->text, "%s", msg);
    }
}

/* OpenEXR 3.1's C++ reader allocates what the file claims before it finds the file too
 * short: an attribute's declared size (a 1.4 GB "unknown attribute" in a 300-byte file) or
 * the offset table (one 8-byte entry per chunk of the data window). Its core library (the C
 * API) parses the headers strictly and with bounded memory, so it reads them first; an
 * offset table longer than the whole file is refused here. Returns what is wrong, or an
 * empty string. */
std::string check_headers(const char *path, std::uint64_t size)
{
    core_message m = {};
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = keep_core_message;
    init.user_data = &m;
    exr_context_t ctx = nullptr;
    exr_result_t rv = exr_start_read(&ctx, path, &init);
    std::string bad;
    if (rv != EXR_ERR_SUCCESS) {
        bad = m.text[0] ? m.text : exr_get_default_error_message(rv);
    } else {
        int parts = 0;
        std::uint64_t chunks = 0;
        if (exr_get_count(ctx, &parts) != EXR_ERR_SUCCESS)
            parts = 0;
        for (int p = 0; p < parts && bad.empty(); p++) {
            std::int32_t n = 0;
            std::uint64_t unpacked = 0;
            if (exr_get_chunk_count(ctx, p, &n) == EXR_ERR_SUCCESS && n > 0)
                chunks += (std::uint64_t)n; /* at most 2^31 parts × 2^31: no overflow */
            if (exr_get_chunk_unpacked_size(ctx, p, &unpacked) == EXR_ERR_SUCCESS &&
                unpacked > MAX_CHUNK_BYTES)
                bad = "one chunk unpacks to " + std::to_string(unpacked) +
                      " bytes, more than this loader's limit of " +
                      std::to_string(MAX_CHUNK_BYTES) + " (a data window far wider than any "
                      "probe, or thousands of channels)";
        }
        if (bad.empty() && chunks > size / 8)
            bad = "the data window needs " + std::to_string(chunks) +
                  " chunks, more than the file can list";
    }
    exr_finish(&ctx);
    return bad;
}

std::uint32_t le32(const unsigned char *p)
{
    return (std::uint32_t)p[0] | (std::uint32_t)p[1] << 8 | (std::uint32_t)p[2] << 16 |
           (std::uint32_t)p[3] << 24;
}

/* Bytes the C++ reader takes for a fixed-size attribute type (whatever size the file
 * declares), 0 if the type is not one of them. */
std::uint64_t fixed_size(const std::string &type)
{
    static const struct {
        const char *name;
        unsigned size;
    } types[] = {{"box2i", 16}, {"box2f", 16},    {"chromaticities", 32}, {"compression", 1},
                 {"deepImageState", 1}, {"double", 8}, {"envmap", 1},   {"float", 4},
                 {"int", 4},    {"keycode", 28},  {"lineOrder", 1},     {"m33f", 36},
                 {"m33d", 72},  {"m44f", 64},     {"m44d", 128},        {"rational", 8},
                 {"tiledesc", 9}, {"timecode", 8}, {"v2i", 8},          {"v2f", 8},
                 {"v2d", 16},   {"v3i", 12},      {"v3f", 12},          {"v3d", 24}};
    for (const auto &t : types)
        if (type == t.name)
            return t.size;
    return 0;
}

/* The core library and the C++ reader disagree on some malformed headers (the C++ reader
 * takes a fixed-size attribute's own size and reads a channel list up to its terminator,
 * whatever size the file declares), and the C++ reader allocates an unknown attribute's
 * declared size and a preview's width × height × 4 bytes before reading them. Follows its
 * reading and checks each of those against what the file holds. Returns what does not fit,
 * or an empty string (also when it meets a type it cannot follow). */
/* Xdr::read of a name: up to max + 1 characters, stopping after a NUL; false at the end of
 * the file. */
bool read_name(std::FILE *f, std::size_t max, std::string *s, std::uint64_t *pos)
{
    s->clear();
    for (std::size_t n = 0; n <= max; n++) {
        int c = std::fgetc(f);
        if (c < 0)
            return false;
        ++*pos;
        if (c == 0)
            break;
        s->push_back((char)c);
    }
    return true;
}

std::string check_cxx_headers(std::FILE *f, std::uint64_t size)
{
    unsigned char magic[8];
    if (std::fread(magic, 1, 8, f) != 8)
        return "the file ends inside the magic number";
    const std::uint32_t version = le32(magic + 4);
    const bool multipart = (version & 0x1000u) != 0;
    const std::size_t max_name = 255; /* Name::MAX_LENGTH, whatever the long-names flag */
    std::uint64_t pos = 8;
    auto left = [&]() { return size - pos; };
    for (int part = 0;; part++) {
        int attributes = 0;
        /* what sizes the reader's chunk buffer, as it will see it: a later copy of an
         * attribute replaces an earlier one */
        std::uint64_t w = 64, h = 64, tile_x = 0, tile_y = 0, pixel_bytes = 0; /* Header() */
        unsigned compression = 3;                                        /* ZIP */
        for (;; attributes++) {
            std::string name, type;
            if (!read_name(f, max_name, &name, &pos))
                return std::string(); /* OpenEXR reports the end of the file */
            if (name.empty())
                break;
            if (!read_name(f, max_name, &type, &pos))
                return std::string();
            unsigned char len[4];
            if (std::fread(len, 1, 4, f) != 4)
                return std::string();
            pos += 4;
            const std::int32_t declared = (std::int32_t)le32(len);
            std::uint64_t take = fixed_size(type);
            if (type == "chlist") {
                /* entries: name, then type, pLinear, 3 reserved, x and y sampling, up to an
                 * empty name */
                std::uint64_t bytes = 0;
                for (;;) {
                    std::string ch;
                    if (!read_name(f, 255, &ch, &pos))
                        return std::string();
                    if (ch.empty())
                        break;
                    unsigned char e[16];
                    if (left() < 16 || std::fread(e, 1, 16, f) != 16)
                        return "channel list of attribute '" + name + "' runs past the file";
                    pos += 16;
                    bytes += le32(e) == 1 ? 2 : 4; /* HALF, else UINT or FLOAT */
                }
                if (name == "channels") /* a second copy adds to the first one's channels */
                    pixel_bytes += bytes;
                continue;
            }
            if (type == "preview") {
                unsigned char wh[8];
                if (std::fread(wh, 1, 8, f) != 8)
                    return std::string();
                pos += 8;
                if (__builtin_mul_overflow((std::uint64_t)le32(wh) * 4, le32(wh + 4), &take) ||
                    take > left())
                    return "preview '" + name + "' claims " + std::to_string(take) +
                           " bytes, the file has " + std::to_string(left()) + " left";
            } else if (take == 0) {
                /* unknown (opaque), string, vectors, id manifest: the declared size */
                if (declared < 0 || (std::uint64_t)declared > left())
                    return "attribute '" + name + "' claims " + std::to_string(declared) +
                           " bytes, the file has " + std::to_string(left()) + " left";
                take = (std::uint64_t)declared;
            } else {
                /* a fixed-size value: keep the ones that size the chunk buffer */
                unsigned char v[128];
                if (take > left() || std::fread(v, 1, (std::size_t)take, f) != take)
                    return "attribute '" + name + "' runs past the file";
                pos += take;
                if (name == "dataWindow" && type == "box2i") {
                    const long long x0 = (std::int32_t)le32(v), y0 = (std::int32_t)le32(v + 4);
                    const long long x1 = (std::int32_t)le32(v + 8), y1 = (std::int32_t)le32(v + 12);
                    w = x1 >= x0 ? (std::uint64_t)(x1 - x0 + 1) : 0;
                    h = y1 >= y0 ? (std::uint64_t)(y1 - y0 + 1) : 0;
                } else if (name == "compression" && type == "compression") {
                    compression = v[0];
                } else if (name == "tiles" && type == "tiledesc") {
                    tile_x = le32(v), tile_y = le32(v + 4);
                }
                continue;
            }
            if (take > left() || std::fseek(f, (long)take, SEEK_CUR) != 0)
                return "attribute '" + name + "' runs past the file";
            pos += take;
        }
        /* one unpacked chunk: a tile, or lines_per_chunk whole scanlines (the buffer holds
         * that many even for a shorter image) */
        const std::uint64_t cw = tile_x ? tile_x : w;
        const std::uint64_t rows = tile_y ? tile_y : (std::uint64_t)lines_per_chunk(compression);
        /* and the offset table: one 8-byte entry per chunk (per tile of the first level) */
        std::uint64_t chunks = 0;
        if (__builtin_mul_overflow((h + rows - 1) / rows, tile_x ? (w + cw - 1) / cw : 1,
                                   &chunks) ||
            chunks > size / 8)
            return "the data window needs " + std::to_string(chunks) +
                   " chunks, more than the file can list";
        std::uint64_t chunk = 0;
        if (__builtin_mul_overflow(cw, rows, &chunk) ||
            __builtin_mul_overflow(chunk, pixel_bytes, &chunk) || chunk > MAX_CHUNK_BYTES)
            return "one chunk unpacks to more than this loader's limit of " +
                   std::to_string(MAX_CHUNK_BYTES) + " bytes (a data window far wider than any "
                   "probe, or thousands of channels)";
        if (!multipart || (attributes == 0 && part > 0))
            break;
    }
    return std::string();
}

/* Rows decoded per readPixels call: one chunk's (a tile row's) worth, which OpenEXR's own
 * chunk buffer holds anyway. */
long long strip_rows(const Imf::Header &hdr, long long h)
{
    long long rows = hdr.hasTileDescription() ? (long long)hdr.tileDescription().ySize
                                               : lines_per_chunk((unsigned)hdr.compression());
    return rows < 1 ? 1 : rows > h ? h : rows;
}

} // namespace

extern "C" lrr_status lrr__exr_read_rgb(lrr_context *ctx, const char *path, float **rgb,
                                        size_t *width, size_t *height)
{
    *rgb = nullptr;
    *width = *height = 0;
    std::FILE *f = nullptr;
    struct stat sb;
    int oe = lrr__open_regular(path, &f, &sb);
    if (oe == LRR__NOT_REGULAR || oe == EISDIR)
        return lrr__error(ctx, LRR_ERR_IO, "'%s': " LRR__NOT_REGULAR_TEXT, path);
    if (oe)
        return lrr__error(ctx, LRR_ERR_IO, "'%s': cannot open", path);
    float *pix = nullptr;
    try {
        std::string bad;
        if (sb.st_size < 0)
            bad = "not a regular file";
        std::fclose(f);
        f = nullptr;
        if (bad.empty())
            bad = check_headers(path, (std::uint64_t)sb.st_size);
        if (bad.empty() && (f = std::fopen(path, "rb"))) {
            bad = check_cxx_headers(f, (std::uint64_t)sb.st_size);
            std::fclose(f);
            f = nullptr;
        }
        if (!bad.empty())
            return lrr__error(ctx, LRR_ERR_FORMAT, "'%s': cannot read the OpenEXR file: %s",
                              path, bad.c_str());
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
        /* refused before decoding: the pixels of a wrong layout are never needed */
        if (w != 2 * h)
            return lrr__error(ctx, LRR_ERR_DIM,
                              "'%s': %lld×%lld pixels is not a latitude–longitude probe "
                              "(expected width = 2 × height, row 0 the zenith, e.g. 1024×512)",
                              path, w, h);
        const size_t sw = (size_t)w, sh = (size_t)h, row_bytes = sw * 3 * sizeof(float);
        /* Decoded chunk by chunk into a buffer that grows (doubling) with what decoded: a
         * header claiming a huge window over a little corrupt data fails at its first chunk
         * instead of first allocating the whole window. */
        const long long strip = strip_rows(hdr, h);
        size_t cap_rows = 0;
        const float *framed = nullptr; /* the buffer the frame buffer points into */
        for (long long y = dw.min.y; y <= dw.max.y; y += strip) {
            const long long y_end = y + strip - 1 < dw.max.y ? y + strip - 1 : dw.max.y;
            const size_t rows = (size_t)(y_end - dw.min.y + 1);
            if (rows > cap_rows) {
                cap_rows = cap_rows > sh / 2 ? sh : cap_rows * 2 > rows ? cap_rows * 2 : rows;
                float *bigger =
                    static_cast<float *>(lrr__realloc(ctx, pix, cap_rows * row_bytes));
                if (!bigger) {
                    std::free(pix);
                    return lrr__error(ctx, LRR_ERR_NOMEM,
                                      "'%s': cannot allocate %zu×%zu RGB pixels", path, sw,
                                      cap_rows);
                }
                pix = bigger;
            }
            if (pix != framed) {
                /* the slice base is the address of pixel (0, 0), which may lie outside the
                 * buffer */
                char *base = reinterpret_cast<char *>(pix) -
                             ((ptrdiff_t)dw.min.x + (ptrdiff_t)dw.min.y * (ptrdiff_t)w) *
                                 (ptrdiff_t)(3 * sizeof(float));
                Imf::FrameBuffer fb;
                for (int c = 0; c < 3; c++)
                    fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float),
                                                   3 * sizeof(float), row_bytes));
                in.setFrameBuffer(fb);
                framed = pix;
            }
            in.readPixels((int)y, (int)y_end);
        }
        *rgb = pix;
        *width = sw;
        *height = sh;
        return LRR_OK;
    } catch (const std::bad_alloc &) {
        if (f)
            std::fclose(f);
        std::free(pix);
        return lrr__error(ctx, LRR_ERR_NOMEM, "'%s': out of memory reading the OpenEXR file",
                          path);
    } catch (const std::exception &e) {
        if (f)
            std::fclose(f);
        std::free(pix);
        return lrr__error(ctx, LRR_ERR_FORMAT, "'%s': cannot read the OpenEXR file: %s", path,
                          e.what());
    } catch (...) {
        if (f)
            std::fclose(f);
        std::free(pix);
        return lrr__error(ctx, LRR_ERR_FORMAT, "'%s': cannot read the OpenEXR file", path);
    }
}
#else /* !LRR_HAVE_OPENEXR */

/* configure --without-openexr: .exr probes are refused, naming the file. */
extern "C" {
#include "probe/probe.h"
}

extern "C" lrr_status lrr__exr_read_rgb(lrr_context *ctx, const char *path, float **rgb,
                                        size_t *width, size_t *height)
{
    *rgb = nullptr;
    *width = *height = 0;
    return lrr__error(ctx, LRR_ERR_UNSUPPORTED,
                      "'%s': lrr was built without OpenEXR: cannot read .exr files "
                      "(a Radiance .hdr probe works)",
                      path);
}
#endif
