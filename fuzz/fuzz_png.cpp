// read_png16 with fuzzed files: every outcome is an image or a ToolError, never a crash, a
// leak or an allocation driven by an unchecked header.
#include <cstdint>
#include <fstream>
#include <string>

#include "common/png_io.hpp"
#include "common/text_io.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = dynamap::fuzz::scratch_path("depth.png");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    const dynamap::tools::Image16 img = dynamap::tools::read_png16(path);
    if (img.pixels.size() != static_cast<std::size_t>(img.width) * img.height) __builtin_trap();
  } catch (const dynamap::tools::ToolError&) {
  }
  return 0;
}
