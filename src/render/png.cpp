// PNG encoding and decoding of render::Image through libpng's simplified API (png_image_*), which
// reports errors in a message field instead of longjmp, so no setjmp crosses C++ frames here. This
// is the only file of the library that includes png.h (libpng is a PRIVATE dependency).
#include "pcp/render/render.hpp"

#include "pcp/core/error.hpp"
#include "pcp/core/files.hpp"

#include <png.h>

#include <cstring>
#include <fstream>
#include <iterator>
#include <ostream>

namespace pcp {

namespace {

void check_image(const Image& image, const std::string& what) {
    PCP_CHECK(image.width > 0 && image.height > 0,
              what << ": cannot encode an empty image (" << image.width << " x " << image.height << ")");
    PCP_CHECK(image.rgb.size() == static_cast<std::size_t>(image.width) * image.height * 3,
              what << ": image buffer holds " << image.rgb.size() << " bytes, expected width x height x 3 = "
                   << static_cast<std::size_t>(image.width) * image.height * 3);
}

std::vector<std::uint8_t> encode(const Image& image, const std::string& what) {
    check_image(image, what);
    png_image png;
    std::memset(&png, 0, sizeof png);
    png.version = PNG_IMAGE_VERSION;
    png.width = static_cast<png_uint_32>(image.width);
    png.height = static_cast<png_uint_32>(image.height);
    png.format = PNG_FORMAT_RGB;
    const png_int_32 stride = 3 * image.width;
    // First call with no buffer: libpng reports the size it needs.
    png_alloc_size_t size = 0;
    if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.rgb.data(), stride, nullptr)) {
        const std::string message = png.message;
        png_image_free(&png);
        PCP_FAIL(what << ": PNG encoding failed: " << message);
    }
    std::vector<std::uint8_t> bytes(size);
    if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, image.rgb.data(), stride, nullptr)) {
        const std::string message = png.message;
        png_image_free(&png);
        PCP_FAIL(what << ": PNG encoding failed: " << message);
    }
    bytes.resize(size);
    return bytes;
}

}  // namespace

std::vector<std::uint8_t> encode_png(const Image& image) { return encode(image, "encode_png"); }

void write_png(const std::string& path, const Image& image) {
    const std::vector<std::uint8_t> bytes = encode(image, path);
    write_file_atomically(path, [&](std::ostream& out) {
        out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    });
}

Image read_png(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    PCP_CHECK(in, path << ": cannot open PNG file (missing or unreadable)");
    const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    PCP_CHECK(!bytes.empty(), path << ": empty file");
    png_image png;
    std::memset(&png, 0, sizeof png);
    png.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size())) {
        const std::string message = png.message;
        png_image_free(&png);
        PCP_FAIL(path << ": not a readable PNG: " << message);
    }
    png.format = PNG_FORMAT_RGB;
    Image image;
    image.width = static_cast<int>(png.width);
    image.height = static_cast<int>(png.height);
    image.rgb.resize(PNG_IMAGE_SIZE(png));
    png_color black{0, 0, 0};
    if (!png_image_finish_read(&png, &black, image.rgb.data(), 0, nullptr)) {
        const std::string message = png.message;
        png_image_free(&png);
        PCP_FAIL(path << ": PNG decoding failed: " << message);
    }
    return image;
}

}  // namespace pcp
