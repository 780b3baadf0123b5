#include "common/png_io.hpp"

#include <png.h>
#include <cerrno>
#include <csetjmp>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

// libpng reports errors through longjmp. The functions below that call libpng hold no C++
// objects with destructors between setjmp and the libpng calls, so the jump is well defined.
struct PngErrorSink {
  char message[256] = {0};
};

void on_png_error(png_structp png, png_const_charp msg) {
  auto* sink = static_cast<PngErrorSink*>(png_get_error_ptr(png));
  if (sink != nullptr) std::snprintf(sink->message, sizeof(sink->message), "%s", msg);
  png_longjmp(png, 1);
}

void on_png_warning(png_structp, png_const_charp) {}

/// Largest depth image read_png16 accepts: far beyond any depth camera (the pipeline takes at
/// most 640x480), small enough that decoding one is harmless (128 MB).
constexpr png_uint_32 kMaxPngSide = 8192;
/// zlib cannot expand data more than 1032:1, so a file this many times smaller than its
/// decoded rows (plus slack for the header) is lying about its size.
constexpr double kMaxDeflateRatio = 1032.0;

std::uintmax_t file_size_bytes(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t n = std::filesystem::file_size(path, ec);
  return ec ? 0 : n;
}

struct PngHeader {
  png_uint_32 width = 0, height = 0;
  int bit_depth = 0, color_type = 0;
};

bool read_header(png_structp png, png_infop info, std::FILE* f, PngHeader* h) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_init_io(png, f);
  png_read_info(png, info);
  int interlace = 0, compression = 0, filter = 0;
  png_get_IHDR(png, info, &h->width, &h->height, &h->bit_depth, &h->color_type, &interlace,
               &compression, &filter);
  return true;
}

bool read_rows(png_structp png, png_infop info, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  if (png_get_bit_depth(png, info) == 16) png_set_swap(png);  // PNG is big-endian
  png_read_image(png, rows);
  png_read_end(png, nullptr);
  return true;
}

bool write_all(png_structp png, png_infop info, std::FILE* f, const Image16& img, png_bytepp rows,
               int level) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_init_io(png, f);
  png_set_compression_level(png, level);
  png_set_IHDR(png, info, static_cast<png_uint_32>(img.width), static_cast<png_uint_32>(img.height),
               16, PNG_COLOR_TYPE_GRAY, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, nullptr);
  return true;
}

std::string describe(int bit_depth, int color_type) {
  std::string kind;
  switch (color_type) {
    case PNG_COLOR_TYPE_GRAY:
      kind = "grayscale";
      break;
    case PNG_COLOR_TYPE_GRAY_ALPHA:
      kind = "grayscale+alpha";
      break;
    case PNG_COLOR_TYPE_RGB:
      kind = "RGB";
      break;
    case PNG_COLOR_TYPE_RGB_ALPHA:
      kind = "RGBA";
      break;
    case PNG_COLOR_TYPE_PALETTE:
      kind = "palette";
      break;
    default:
      kind = "colour type " + std::to_string(color_type);
      break;
  }
  return std::to_string(bit_depth) + "-bit " + kind;
}

struct FileCloser {
  std::FILE* f;
  ~FileCloser() {
    if (f != nullptr) std::fclose(f);
  }
};

}  // namespace

Image16 read_png16(const std::string& path) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (f == nullptr) throw ToolError(path + ": cannot open PNG file");
  FileCloser closer{f};
  unsigned char sig[8] = {0};
  if (std::fread(sig, 1, 8, f) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
    throw ToolError(path + ": not a PNG file");
  }
  PngErrorSink sink;
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &sink, on_png_error, on_png_warning);
  if (png == nullptr) throw ToolError(path + ": libpng init failed");
  png_infop info = png_create_info_struct(png);
  png_set_sig_bytes(png, 8);
  PngHeader h;
  if (info == nullptr || !read_header(png, info, f, &h)) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw ToolError(path + ": corrupt PNG: " + sink.message);
  }
  if (h.bit_depth != 16 || h.color_type != PNG_COLOR_TYPE_GRAY) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw ToolError(path + ": expected a 16-bit single-channel (grayscale) depth PNG, found " +
                    describe(h.bit_depth, h.color_type));
  }
  // The header's size is not trusted: it must be a plausible depth image, and the file must be
  // large enough to hold that many rows at zlib's best ratio (a 69-byte file claiming
  // 20000x20000 is refused here, before any allocation).
  const std::string claimed = std::to_string(h.width) + "x" + std::to_string(h.height);
  if (h.width > kMaxPngSide || h.height > kMaxPngSide) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw ToolError(path + ": PNG header claims " + claimed + " pixels, more than the " +
                    std::to_string(kMaxPngSide) + "x" + std::to_string(kMaxPngSide) +
                    " a depth image may have");
  }
  const double decoded_bytes =
      static_cast<double>(h.height) * (1.0 + 2.0 * static_cast<double>(h.width));
  const double file_bytes = static_cast<double>(file_size_bytes(path));
  if (decoded_bytes > kMaxDeflateRatio * file_bytes + 1024.0) {
    png_destroy_read_struct(&png, &info, nullptr);
    throw ToolError(path + ": corrupt PNG: header claims " + claimed + " pixels, more than a " +
                    std::to_string(static_cast<long long>(file_bytes)) + "-byte file can hold");
  }
  Image16 img;
  img.width = static_cast<int>(h.width);
  img.height = static_cast<int>(h.height);
  img.pixels.assign(static_cast<std::size_t>(h.width) * h.height, 0);
  std::vector<png_bytep> rows(h.height);
  for (png_uint_32 v = 0; v < h.height; ++v) {
    rows[v] =
        reinterpret_cast<png_bytep>(img.pixels.data() + static_cast<std::size_t>(v) * h.width);
  }
  const bool ok = read_rows(png, info, rows.data());
  png_destroy_read_struct(&png, &info, nullptr);
  if (!ok) throw ToolError(path + ": corrupt PNG: " + sink.message);
  return img;
}

void write_png16(const std::string& path, const Image16& image, int compression_level) {
  if (image.width <= 0 || image.height <= 0 ||
      image.pixels.size() != static_cast<std::size_t>(image.width) * image.height) {
    throw ToolError(path + ": write_png16: image size does not match its pixel buffer");
  }
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (f == nullptr) throw ToolError(path + ": cannot create file: " + std::strerror(errno));
  FileCloser closer{f};
  PngErrorSink sink;
  png_structp png =
      png_create_write_struct(PNG_LIBPNG_VER_STRING, &sink, on_png_error, on_png_warning);
  if (png == nullptr) throw ToolError(path + ": libpng init failed");
  png_infop info = png_create_info_struct(png);
  std::vector<png_bytep> rows(static_cast<std::size_t>(image.height));
  for (int v = 0; v < image.height; ++v) {
    // libpng takes non-const rows but does not modify them when writing.
    rows[static_cast<std::size_t>(v)] = reinterpret_cast<png_bytep>(const_cast<std::uint16_t*>(
        image.pixels.data() + static_cast<std::size_t>(v) * image.width));
  }
  const bool ok = info != nullptr && write_all(png, info, f, image, rows.data(), compression_level);
  png_destroy_write_struct(&png, &info);
  if (!ok) throw ToolError(path + ": PNG write failed: " + sink.message);
  if (std::fflush(f) != 0) throw ToolError(path + ": write error");
}

}  // namespace dynamap::tools
