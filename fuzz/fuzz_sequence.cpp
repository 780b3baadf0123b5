// The sequence text readers with fuzzed files: depth.txt, groundtruth.txt and camera.txt come
// from the input (separated by NUL bytes). Every outcome is a sequence whose stamps convert to
// increasing nanoseconds, or a ToolError.
#include <cstdint>
#include <fstream>
#include <string>

#include "common/sequence.hpp"
#include "common/text_io.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dynamap::tools;
  static const std::string dir = [] {
    const std::string d = dynamap::fuzz::scratch_path("seq");
    make_directories(d);
    return d;
  }();
  dynamap::fuzz::FuzzInput in(data, size);
  const char* names[] = {"depth.txt", "groundtruth.txt", "camera.txt"};
  for (const char* name : names) {
    std::ofstream(join_path(dir, name), std::ios::binary | std::ios::trunc) << in.take_until('\0');
  }
  try {
    const Sequence seq = read_sequence(dir);
    std::uint64_t last = 0;
    for (std::size_t i = 0; i < seq.frames.size(); ++i) {
      const std::uint64_t ns = seq.stamp_ns(seq.frames[i].stamp);
      if (i > 0 && ns <= last) __builtin_trap();
      last = ns;
    }
  } catch (const ToolError&) {
  }
  return 0;
}
