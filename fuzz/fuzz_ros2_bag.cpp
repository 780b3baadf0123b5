// The ROS 2 bag reader with fuzzed files: the input is written as one .mcap file and read as a
// sequence (container, chunks, CRCs, CDR, schemas, topic choice, poses), every depth image
// loaded, and every message decoded with its schema. Every outcome is a sequence, a counted skip
// or a ToolError: never a crash.
#include <cstdint>
#include <fstream>
#include <string>

#include "common/ros2_bag.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"
#include "fuzz_input.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dynamap::tools;
  static const std::string path = dynamap::fuzz::scratch_path("bag.mcap");
  std::ofstream(path, std::ios::binary | std::ios::trunc)
      .write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    Ros2Bag bag(path);
    for (const Ros2Bag::Topic& t : bag.topics()) {
      for (const Ros2Bag::Message& m : bag.messages(t.name)) {
        try {
          bag.decode(m);
        } catch (const ToolError&) {
        }
      }
    }
  } catch (const ToolError&) {
  }
  try {
    const Sequence seq = read_sequence(path);
    for (const SequenceFrame& f : seq.frames) {
      Image16 img;
      std::string problem;
      if (try_load_depth(seq, f, &img, &problem) == DepthProblem::kNone &&
          img.pixels.size() != static_cast<std::size_t>(seq.camera.width) * seq.camera.height) {
        __builtin_trap();
      }
    }
  } catch (const ToolError&) {
  }
  return 0;
}
