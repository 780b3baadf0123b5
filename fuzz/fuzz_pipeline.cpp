// Pipeline::process with fuzzed frames: stamps, poses (raw float bits or normalised), strides,
// data alignment and pixels of a small camera, several frames per input. Checks the contract:
// a frame refused with a Status leaves the map, the tracks and the frame counter as they were.
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <vector>

#include "dynamap/pipeline.hpp"
#include "fuzz_input.hpp"

namespace {

constexpr int kWidth = 40;
constexpr int kHeight = 30;
constexpr int kFramesPerInput = 4;

dynamap::PipelineConfig fuzz_config() {
  dynamap::PipelineConfig c;
  c.camera.width = kWidth;
  c.camera.height = kHeight;
  c.camera.fx = c.camera.fy = 40.f;
  c.camera.cx = 20.f;
  c.camera.cy = 15.f;
  c.detector.min_segment_length = 2;
  c.detector.min_area = 3;
  return c;
}

void check(bool condition) {
  if (!condition) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace dynamap;
  static Pipeline* const pipeline = new Pipeline;  // ~30 MB: once, never on the stack
  static FrameOutput* const out = new FrameOutput;
  static const PipelineConfig config = fuzz_config();
  check(ok(pipeline->init(config)));
  fuzz::FuzzInput in(data, size);
  // Room for the largest stride below plus one byte of misalignment.
  std::vector<std::uint16_t> pixels(static_cast<std::size_t>(kWidth + 4) * (kHeight + 1));
  Stamp stamp = 0;
  for (int f = 0; f < kFramesPerInput && in.remaining() > 0; ++f) {
    Frame frame;
    stamp += in.take<std::uint32_t>();
    frame.stamp = stamp;
    const std::uint8_t mode = in.take<std::uint8_t>();
    Eigen::Vector3f t;
    for (int a = 0; a < 3; ++a) t[a] = in.take<float>();
    Eigen::Quaternionf q(in.take<float>(), in.take<float>(), in.take<float>(), in.take<float>());
    if ((mode & 1u) != 0 && q.coeffs().allFinite() && q.norm() > 1e-3f) q.normalize();
    if ((mode & 2u) != 0 && t.allFinite()) t = t.cwiseMax(-20.f).cwiseMin(20.f);  // in range
    frame.T_map_camera.translation = t;
    frame.T_map_camera.rotation = q;
    const int extra = static_cast<int>((mode >> 2) & 7u);  // 0..7 extra stride bytes
    for (auto& p : pixels) p = in.take<std::uint16_t>();
    const std::uint8_t* base = reinterpret_cast<const std::uint8_t*>(pixels.data());
    if ((mode & 32u) != 0) ++base;  // misaligned data
    frame.depth = DepthView{reinterpret_cast<const std::uint16_t*>(base), kWidth, kHeight,
                            kWidth * 2 + extra};

    const std::uint64_t sum = pipeline->map().checksum();
    const std::size_t tracks = pipeline->tracker().size();
    const std::uint64_t processed = pipeline->counters().frames_processed;
    const Status s = pipeline->process(frame, *out);
    if (!ok(s)) {
      check(out->status == s);
      check(pipeline->map().checksum() == sum);
      check(pipeline->tracker().size() == tracks);
      check(pipeline->counters().frames_processed == processed);
    } else {
      for (std::size_t i = 0; i < out->num_obstacles; ++i) {
        check(out->obstacles[i].box.min.allFinite() && out->obstacles[i].box.max.allFinite());
        check(out->obstacles[i].velocity.allFinite());
      }
    }
  }
  return 0;
}
