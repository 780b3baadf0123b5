// 16-bit grayscale PNG read/write through libpng (depth images of the TUM layout).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace dynamap::tools {

/// A 16-bit single-channel image, row-major, tightly packed (stride = width).
struct Image16 {
  int width = 0;
  int height = 0;
  std::vector<std::uint16_t> pixels;

  std::uint16_t at(int u, int v) const { return pixels[static_cast<std::size_t>(v) * width + u]; }
  std::uint16_t& at(int u, int v) { return pixels[static_cast<std::size_t>(v) * width + u]; }
};

/// Reads a 16-bit grayscale PNG. Any other kind (8-bit, RGB, palette, alpha) is an error that
/// names the file and what was found. Throws ToolError.
Image16 read_png16(const std::string& path);

/// Writes a 16-bit grayscale PNG. `compression_level` 0..9 (zlib). Output bytes depend only on
/// the pixels (no time stamps are written). Throws ToolError.
void write_png16(const std::string& path, const Image16& image, int compression_level = 3);

}  // namespace dynamap::tools
