// SPDX-License-Identifier: Apache-2.0
#include "Image.h"

#include <rockvdb/core/Bake.h>
#include <rockvdb/core/Error.h>
#include <rockvdb/core/VdbIO.h>

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>
#include <OpenEXR/ImfIO.h>
#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <sys/stat.h>

namespace rockvdb {

namespace {

std::string readAll(const std::string& path, const char* op)
{
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) fail<IoError>(op, ": cannot read '", path, "': no such file");
    if (S_ISDIR(st.st_mode)) fail<IoError>(op, ": cannot read '", path, "': it is a folder");
    std::ifstream f(path, std::ios::binary);
    if (!f) fail<IoError>(op, ": cannot read '", path, "'");
    return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// Before a decode allocates for the size its header claims: that size must fit what the
// file's bytes can hold (a 346-byte PNG claiming 60000x60000 pixels would take 7 GB first and
// fail on truncation after), and the image with its float copies (about 10 bytes per pixel
// between decode and use) must fit the memory limit.
void checkClaimedSize(const std::string& path, const char* op, double width, double height,
                      double sampleBytes, double maxExpansion, size_t fileBytes, double maxMemoryBytes)
{
    const double raw = width * height * sampleBytes;
    if (raw > maxExpansion * double(fileBytes) + 65536.0) {
        fail<IoError>(op, ": cannot read '", path, "': corrupt or truncated image (its header claims ",
                      width, "x", height, " pixels, ", formatBytes(raw), ", but the file holds only ",
                      fileBytes, " bytes)");
    }
    const double need = width * height * 10.0, limit = memoryLimitBytes(maxMemoryBytes);
    if (need > limit) {
        fail<ValueError>(op, ": '", path, "' is ", width, "x", height, " pixels: reading it needs about ",
                         formatBytes(need), ", over the ", formatBytes(limit),
                         " allowed; use a smaller image or raise --max-memory");
    }
}

// ---- PNG ------------------------------------------------------------------------------

struct PngReadState
{
    const std::string* bytes;
    size_t pos;
};

void pngReadFn(png_structp png, png_bytep out, png_size_t n)
{
    auto* s = static_cast<PngReadState*>(png_get_io_ptr(png));
    if (s->pos + n > s->bytes->size()) png_error(png, "truncated PNG");
    std::memcpy(out, s->bytes->data() + s->pos, n);
    s->pos += n;
}

void pngErrorFn(png_structp png, png_const_charp msg)
{
    auto* err = static_cast<std::string*>(png_get_error_ptr(png));
    if (err) *err = msg;
    png_longjmp(png, 1);
}
void pngWarnFn(png_structp, png_const_charp) {}

GrayImage readPng(const std::string& path, const std::string& bytes, const char* op, double maxMemoryBytes)
{
    std::string err;
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &err, pngErrorFn, pngWarnFn);
    png_infop info = png_create_info_struct(png);
    PngReadState state{&bytes, 8};
    GrayImage img;
    std::vector<png_bytep> rows;
    std::vector<uint16_t> data;
    int bitDepth = 0, colorType = 0;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, nullptr);
        fail<IoError>(op, ": cannot read '", path, "': ", err.empty() ? "corrupt PNG" : err);
    }
    png_set_read_fn(png, &state, pngReadFn);
    png_set_sig_bytes(png, 8);
    png_read_info(png, info);
    bitDepth = png_get_bit_depth(png, info);
    colorType = png_get_color_type(png, info);
    img.width = int(png_get_image_width(png, info));
    img.height = int(png_get_image_height(png, info));
    if (colorType != PNG_COLOR_TYPE_GRAY || bitDepth != 16) {
        png_destroy_read_struct(&png, &info, nullptr);
        const char* kind = colorType == PNG_COLOR_TYPE_GRAY ? "greyscale"
                         : colorType == PNG_COLOR_TYPE_GRAY_ALPHA ? "greyscale+alpha (2 channels)"
                         : colorType == PNG_COLOR_TYPE_RGB ? "RGB (3 channels)"
                         : colorType == PNG_COLOR_TYPE_RGB_ALPHA ? "RGBA (4 channels)"
                         : "palette";
        fail<ValueError>(op, ": '", path, "' is a ", bitDepth, "-bit ", kind,
                         " PNG; expected a 16-bit single-channel (greyscale) PNG");
    }
    // Deflate expands at most 1032:1 (and each row carries a filter byte).
    checkClaimedSize(path, op, img.width, img.height, 2.0, 1100.0, bytes.size(), maxMemoryBytes);
    png_set_swap(png); // big-endian samples to host order
    data.resize(size_t(img.width) * size_t(img.height));
    rows.resize(size_t(img.height));
    for (int j = 0; j < img.height; ++j) {
        rows[size_t(j)] = reinterpret_cast<png_bytep>(data.data() + size_t(j) * size_t(img.width));
    }
    png_read_image(png, rows.data());
    png_destroy_read_struct(&png, &info, nullptr);
    img.pixels.resize(data.size());
    for (size_t k = 0; k < data.size(); ++k) img.pixels[k] = float(data[k]) / 65535.0f;
    return img;
}

void pngWriteFn(png_structp png, png_bytep in, png_size_t n)
{
    auto* out = static_cast<std::string*>(png_get_io_ptr(png));
    out->append(reinterpret_cast<const char*>(in), n);
}
void pngFlushFn(png_structp) {}

std::string encodePng(int width, int height, int colorType, int bitDepth,
                      const uint8_t* data, size_t rowBytes)
{
    std::string out, err;
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &err, pngErrorFn, pngWarnFn);
    png_infop info = png_create_info_struct(png);
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_write_struct(&png, &info);
        fail<IoError>("png: cannot encode image: ", err);
    }
    png_set_write_fn(png, &out, pngWriteFn, pngFlushFn);
    png_set_IHDR(png, info, png_uint_32(width), png_uint_32(height), bitDepth, colorType,
                 PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    if (bitDepth == 16) png_set_swap(png);
    for (int j = 0; j < height; ++j) {
        png_write_row(png, const_cast<png_bytep>(data + size_t(j) * rowBytes));
    }
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    return out;
}

// ---- EXR ------------------------------------------------------------------------------

class MemoryIStream : public Imf::IStream
{
public:
    MemoryIStream(const std::string& bytes, const std::string& name)
        : Imf::IStream(name.c_str()), mBytes(bytes) {}
    bool read(char c[], int n) override
    {
        // OpenEXR seeks to offsets read from the file (line offset tables): a corrupt table
        // can put mPos anywhere, so compare without forming mPos + n (found by fuzz_image,
        // regressions/image/exr-seek-past-end).
        if (n < 0 || mPos > mBytes.size() || uint64_t(n) > mBytes.size() - mPos) {
            throw std::runtime_error("truncated EXR file");
        }
        std::memcpy(c, mBytes.data() + mPos, size_t(n));
        mPos += uint64_t(n);
        return mPos < mBytes.size();
    }
    uint64_t tellg() override { return mPos; }
    void seekg(uint64_t pos) override { mPos = pos; }

private:
    const std::string& mBytes;
    uint64_t mPos = 0;
};

// The channels @a want of an EXR (every one of the file's when empty: it must then hold
// exactly one), interleaved, rows from the top; width and height out.
std::vector<float> readExrChannels(const std::string& path, const std::string& bytes, const char* op,
                                   double maxMemoryBytes, std::vector<std::string> want,
                                   int& width, int& height)
{
    try {
        MemoryIStream stream(bytes, path);
        Imf::InputFile file(stream);
        const Imf::ChannelList& channels = file.header().channels();
        std::vector<std::string> names;
        for (auto it = channels.begin(); it != channels.end(); ++it) names.push_back(it.name());
        std::string list;
        for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
        if (want.empty()) {
            if (names.size() != 1) {
                fail<ValueError>(op, ": '", path, "' has ", names.size(), " channels (", list,
                                 "); expected a single-channel EXR");
            }
            want = names;
        }
        for (const auto& w : want) {
            if (std::find(names.begin(), names.end(), w) == names.end()) {
                fail<ValueError>(op, ": '", path, "' has no channel ", w, " (it has ", list, ")");
            }
        }
        const auto dw = file.header().dataWindow();
        width = dw.max.x - dw.min.x + 1;
        height = dw.max.y - dw.min.y + 1;
        // EXR's codecs expand less than deflate's 1032:1 except on constant data (run-length
        // coded PIZ): 10 000:1 is generous for any real file.
        checkClaimedSize(path, op, double(dw.max.x) - dw.min.x + 1, double(dw.max.y) - dw.min.y + 1,
                         4.0 * double(want.size()), 1e4, bytes.size(), maxMemoryBytes);
        const size_t n = want.size();
        std::vector<float> pixels(size_t(width) * size_t(height) * n, 0.0f);
        Imf::FrameBuffer fb;
        for (size_t c = 0; c < n; ++c) {
            char* base = reinterpret_cast<char*>(pixels.data() + c) -
                         (ptrdiff_t(dw.min.x) + ptrdiff_t(dw.min.y) * width) * ptrdiff_t(n * sizeof(float));
            fb.insert(want[c], Imf::Slice(Imf::FLOAT, base, n * sizeof(float),
                                          n * sizeof(float) * size_t(width)));
        }
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        return pixels;
    } catch (const ValueError&) {
        throw;
    } catch (const IoError&) {
        throw;
    } catch (const std::exception& e) {
        fail<IoError>(op, ": cannot read '", path, "': ", e.what());
    }
}

GrayImage readExr(const std::string& path, const std::string& bytes, const char* op, double maxMemoryBytes)
{
    GrayImage img;
    img.pixels = readExrChannels(path, bytes, op, maxMemoryBytes, {}, img.width, img.height);
    return img;
}

bool endsWith(const std::string& s, const std::string& suffix)
{
    if (s.size() < suffix.size()) return false;
    return std::equal(suffix.rbegin(), suffix.rend(), s.rbegin(),
                      [](char a, char b) { return std::tolower(a) == std::tolower(b); });
}

} // namespace

GrayImage readGrayImage(const std::string& path, const char* op, double maxMemoryBytes)
{
    const std::string bytes = readAll(path, op);
    static const unsigned char pngSig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    static const unsigned char exrSig[4] = {0x76, 0x2f, 0x31, 0x01};
    GrayImage img;
    if (bytes.size() >= 8 && std::memcmp(bytes.data(), pngSig, 8) == 0) {
        img = readPng(path, bytes, op, maxMemoryBytes);
    } else if (bytes.size() >= 4 && std::memcmp(bytes.data(), exrSig, 4) == 0) {
        img = readExr(path, bytes, op, maxMemoryBytes);
    } else {
        fail<IoError>(op, ": cannot read '", path, "': not an EXR or PNG image");
    }
    if (img.width < 2 || img.height < 2) {
        fail<ValueError>(op, ": '", path, "' is ", img.width, "x", img.height,
                         " pixels; need at least 2x2");
    }
    for (float v : img.pixels) {
        if (!std::isfinite(v)) fail<ValueError>(op, ": '", path, "' holds NaN or infinite values");
    }
    return img;
}

std::string encodePngRgb8(int width, int height, const std::vector<uint8_t>& rgb)
{
    return encodePng(width, height, PNG_COLOR_TYPE_RGB, 8, rgb.data(), size_t(width) * 3);
}

std::string encodePng(int width, int height, int channels, int bits, const std::vector<uint16_t>& values)
{
    if ((channels != 1 && channels != 3) || (bits != 8 && bits != 16)) {
        fail<ValueError>("png: ", channels, " channels of ", bits, " bits (1 or 3 channels of 8 or "
                         "16 bits)");
    }
    const size_t n = size_t(width) * size_t(height) * size_t(channels);
    if (width <= 0 || height <= 0 || values.size() < n) {
        fail<ValueError>("png: ", values.size(), " values for a ", width, " x ", height, " image");
    }
    const int type = channels == 1 ? PNG_COLOR_TYPE_GRAY : PNG_COLOR_TYPE_RGB;
    if (bits == 16) {
        // host order; encodePng swaps to PNG's big-endian
        return encodePng(width, height, type, 16, reinterpret_cast<const uint8_t*>(values.data()),
                         size_t(width) * size_t(channels) * 2);
    }
    std::vector<uint8_t> bytes(n);
    for (size_t i = 0; i < n; ++i) bytes[i] = uint8_t(std::min<uint16_t>(values[i], 255));
    return encodePng(width, height, type, 8, bytes.data(), size_t(width) * size_t(channels));
}

namespace {

// OpenEXR into memory (so the file is written once, atomically, like every rockvdb output):
// float channels interleaved in @a data, rows from the top.
struct MemoryStream : Imf::OStream
{
    std::string bytes;
    uint64_t pos = 0;
    MemoryStream() : Imf::OStream("memory") {}
    void write(const char c[], int n) override
    {
        if (pos + uint64_t(n) > bytes.size()) bytes.resize(size_t(pos) + size_t(n));
        std::memcpy(&bytes[size_t(pos)], c, size_t(n));
        pos += uint64_t(n);
    }
    uint64_t tellp() override { return pos; }
    void seekp(uint64_t p) override { pos = p; }
};

std::string encodeExr(int width, int height, const std::vector<const char*>& channels,
                      const float* data,
                      const std::vector<std::pair<std::string, std::string>>& attributes = {})
{
    MemoryStream stream;
    try {
        Imf::Header header(width, height);
        for (const auto& [name, value] : attributes) {
            header.insert(name, Imf::StringAttribute(value));
        }
        for (const char* c : channels) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
        Imf::FrameBuffer fb;
        const size_t px = sizeof(float) * channels.size();
        for (size_t c = 0; c < channels.size(); ++c) {
            fb.insert(channels[c], Imf::Slice(Imf::FLOAT, (char*)(data + c), px, px * size_t(width)));
        }
        Imf::OutputFile file(stream, header);
        file.setFrameBuffer(fb);
        file.writePixels(height);
    } catch (const std::exception& e) {
        fail<IoError>("cannot encode EXR: ", e.what());
    }
    return std::move(stream.bytes);
}

} // namespace

void writeRgbExr(const std::string& path, int width, int height, const std::vector<float>& rgb,
                 const std::vector<std::pair<std::string, std::string>>& attributes)
{
    if (!endsWith(path, ".exr")) fail<ValueError>("image: '", path, "' must end in .exr");
    if (rgb.size() != size_t(width) * size_t(height) * 3) {
        fail<ValueError>("image: ", rgb.size(), " values for a ", width, "x", height, " RGB image");
    }
    writeFileAtomic(path, encodeExr(width, height, {"R", "G", "B"}, rgb.data(), attributes));
}

std::vector<float> readRgbExr(const std::string& path, int& width, int& height, const char* op)
{
    const std::string bytes = readAll(path, op);
    static const unsigned char exrSig[4] = {0x76, 0x2f, 0x31, 0x01};
    if (bytes.size() < 4 || std::memcmp(bytes.data(), exrSig, 4) != 0) {
        fail<ValueError>(op, ": '", path, "' is not an EXR file");
    }
    return readExrChannels(path, bytes, op, 0, {"R", "G", "B"}, width, height);
}

void writeGrayImage(const std::string& path, const GrayImage& image)
{
    if (endsWith(path, ".png")) {
        std::vector<uint16_t> data(image.pixels.size());
        for (size_t k = 0; k < data.size(); ++k) {
            data[k] = uint16_t(std::lround(std::clamp(image.pixels[k], 0.0f, 1.0f) * 65535.0f));
        }
        writeFileAtomic(path, encodePng(image.width, image.height, PNG_COLOR_TYPE_GRAY, 16,
                                        reinterpret_cast<const uint8_t*>(data.data()),
                                        size_t(image.width) * 2));
    } else if (endsWith(path, ".exr")) {
        writeFileAtomic(path, encodeExr(image.width, image.height, {"Y"}, image.pixels.data()));
    } else {
        fail<ValueError>("image: '", path, "' must end in .exr or .png");
    }
}

} // namespace rockvdb
