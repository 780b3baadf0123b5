// Pipeline::process with fuzzed frames: stamps, poses (raw float bits or normalised), strides,
// data alignment and pixels, several frames per input, with a camera size (1x1 to 40x30), a
// range, a pixel stride and a local region chosen by the input. Checks the contract: a frame
// refused with a Status leaves the map, the tracks and the frame counter as they were.
//
// Input layout: width-1, height-1 (bytes, taken modulo the maximum), a configuration byte
// (bits 0-3: max_depth 1..8.5 m; bits 4-5: pixel stride 1..4; bit 6: a 2 m local region
// instead of the default), then per frame: stamp step (u32), mode (u8), translation (3 f32),
// quaternion w x y z (4 f32), (width + 4) x (height + 1) pixels (u16). Bytes past the end
// read as zero. A small camera chosen by the input keeps most inputs cheap (the cost is the
// rays the map carves), so a campaign reaches millions of inputs, while the full 40x30 frame
// stays reachable.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <vector>

#include "dynamap/pipeline/pipeline.hpp"
#include "fuzz_input.hpp"

namespace {

constexpr int kMaxWidth = 40;
constexpr int kMaxHeight = 30;
constexpr int kFramesPerInput = 4;

dynamap::PipelineConfig fuzz_config(int width, int height, std::uint8_t bits) {
  dynamap::PipelineConfig c;
  c.camera.width = width;
  c.camera.height = height;
  c.camera.fx = c.camera.fy = static_cast<float>(width);  // a 53 x 41 degree field of view
  c.camera.cx = 0.5f * static_cast<float>(width);
  c.camera.cy = 0.5f * static_cast<float>(height);
  c.detector.min_segment_length = 2;
  c.detector.min_area = 3;
  c.map.max_depth = 0.5f * static_cast<float>(2 + (bits & 15u));  // 1 .. 8.5 m
  c.map.pixel_stride = 1 + static_cast<int>((bits >> 4) & 3u);
  if ((bits & 64u) != 0) c.map.local_half_extent.setConstant(2.f);
  // The tracker needs 2 x image_margin < the image size: keep the default where it fits.
  c.tracker.image_margin = std::min(c.tracker.image_margin, (std::min(width, height) - 1) / 2);
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
  fuzz::FuzzInput in(data, size);
  const int width = 1 + in.take<std::uint8_t>() % kMaxWidth;
  const int height = 1 + in.take<std::uint8_t>() % kMaxHeight;
  const PipelineConfig config = fuzz_config(width, height, in.take<std::uint8_t>());
  ConfigError error;
  if (!ok(pipeline->init(config, &error))) {  // a fresh pipeline per input: no interactions
    std::fprintf(stderr, "configuration refused: %s: %s\n", error.field, error.reason);
    std::abort();
  }
  // Room for the largest stride below plus one byte of misalignment.
  std::vector<std::uint16_t> pixels(static_cast<std::size_t>(width + 4) * (height + 1));
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
    frame.depth =
        DepthView{reinterpret_cast<const std::uint16_t*>(base), width, height, width * 2 + extra};

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
