// U-map detector benchmarks: histogram pass (scalar reference vs fast path, same run, reported
// as ns per pixel), whole detection, and map refinement, on a 640x480 frame with six obstacles
// in front of a back wall, above a floor, with stereo-like depth noise and dropouts; and whole
// detection on the recorded frames of a simulated sequence (--sequence=DIR or the environment
// variable DYNAMAP_BENCH_SEQUENCE; skipped with a message when neither names a readable one).
#include <benchmark/benchmark.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "dynamap/core/fixed_hash_map.hpp"
#include "dynamap/detect/umap_detector.hpp"
#include "dynamap/map/map_refiner.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "synthetic_depth.hpp"
#if defined(DYNAMAP_BENCH_HAVE_SEQUENCES)
#include "common/sequence.hpp"
#endif

namespace {
using namespace dynamap;

struct Scene {
  CameraIntrinsics cam;
  test::SyntheticImage image;
  Pose pose = test::optical_to_map_pose(Eigen::Vector3f(0.f, 0.f, 1.f));
};

const Scene& scene() {
  static const Scene s = [] {
    Scene sc;
    auto box = [](float x0, float x1, float y0, float y1, float z0, float z1) {
      return test::SceneBox{Eigen::Vector3f(x0, y0, z0), Eigen::Vector3f(x1, y1, z1)};
    };
    test::SyntheticScene world;
    // Camera 1 m above the floor (camera y = +1 is the floor); obstacles standing on it.
    world.boxes = {
        box(-0.55f, -0.30f, -0.2f, 1.0f, 1.2f, 1.6f), box(-0.40f, 0.00f, -0.6f, 1.0f, 2.0f, 2.4f),
        box(0.10f, 0.50f, -0.5f, 1.0f, 3.0f, 3.4f),   box(0.80f, 1.20f, -0.8f, 1.0f, 4.0f, 4.4f),
        box(1.80f, 2.20f, -0.7f, 1.0f, 5.0f, 5.4f),   box(-2.6f, -1.9f, -0.9f, 1.0f, 4.5f, 5.0f)};
    world.wall_z = 6.5f;
    world.floor_y = 1.0f;
    sc.image = test::render_depth(world, sc.cam);
    std::mt19937 rng(1);
    std::normal_distribution<float> gauss(0.f, 1.f);
    std::uniform_real_distribution<float> uniform(0.f, 1.f);
    for (std::uint16_t& p : sc.image.pixels) {
      if (p == 0) continue;
      if (uniform(rng) < 0.03f) {
        p = 0;
        continue;
      }
      const float z = static_cast<float>(p) * 0.001f;
      p = static_cast<std::uint16_t>(std::lround((z + 0.002f * z * z * gauss(rng)) / 0.001f));
    }
    return sc;
  }();
  return s;
}

template <bool kFast>
void BM_Histogram(benchmark::State& state) {
  const Scene& s = scene();
  UMapBinning b;
  if (!ok(make_umap_binning(0.1f, 8.f, 0.001f, 120, &b))) state.SkipWithError("binning");
  std::vector<std::uint16_t> counts(static_cast<std::size_t>(b.bins + 1) * 640);
  const UMapBuffer buf{counts.data(), 640, static_cast<int>(counts.size())};
  for (auto _ : state) {
    const Status st = kFast ? umap_histogram_fast(s.image.view(), b, buf)
                            : umap_histogram_scalar(s.image.view(), b, buf);
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(counts.data());
    benchmark::ClobberMemory();
  }
  const double pixels = 640.0 * 480.0;
  state.counters["ns_per_pixel"] =
      benchmark::Counter(pixels * static_cast<double>(state.iterations()),
                         benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
  state.SetLabel(kFast ? umap_histogram_fast_name() : "scalar");
}
BENCHMARK_TEMPLATE(BM_Histogram, false)->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Histogram, true)->Unit(benchmark::kMicrosecond);

// Whole detection; arg 0 selects the per-pixel reference height search and
// box sums (use_fast_measure = false), arg 1 the default.
template <bool kFast>
void BM_Detect(benchmark::State& state) {
  const Scene& s = scene();
  auto det = std::make_unique<UMapDetector>();
  UMapDetectorConfig cfg;
  cfg.use_fast_histogram = kFast;
  cfg.use_fast_measure = state.range(0) == 1;
  if (!ok(det->init(cfg))) state.SkipWithError("init");
  DetectionList out;
  for (auto _ : state) {
    const Status st = det->detect(s.image.view(), s.cam, s.pose, out);
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["detections"] = static_cast<double>(out.size());
  state.SetLabel(std::string(kFast ? umap_histogram_fast_name() : "scalar") +
                 (cfg.use_fast_measure ? ", fast measure" : ", per-pixel search"));
}
BENCHMARK_TEMPLATE(BM_Detect, false)
    ->ArgName("fast_measure")
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond);
BENCHMARK_TEMPLATE(BM_Detect, true)
    ->ArgName("fast_measure")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond);

// Recorded frames of a simulated sequence (docs/data_format.md), decoded once before timing.
struct RecordedFrames {
  std::string dir;
  std::string problem;  // why there are no frames
  CameraIntrinsics cam;
  std::vector<std::vector<std::uint16_t>> depth;
  std::vector<Pose> poses;
  int width = 0, height = 0;
};

std::string& sequence_dir() {
  static std::string dir;
  return dir;
}

const RecordedFrames& recorded_frames() {
  static const RecordedFrames r = [] {
    RecordedFrames f;
    f.dir = sequence_dir();
    if (f.dir.empty()) {
      f.problem = "no sequence: pass --sequence=DIR or set DYNAMAP_BENCH_SEQUENCE";
      return f;
    }
#if defined(DYNAMAP_BENCH_HAVE_SEQUENCES)
    try {
      const tools::Sequence seq = tools::read_sequence(f.dir);
      const tools::CameraModel& c = seq.camera;
      f.cam.fx = static_cast<float>(c.fx);
      f.cam.fy = static_cast<float>(c.fy);
      f.cam.cx = static_cast<float>(c.cx);
      f.cam.cy = static_cast<float>(c.cy);
      f.cam.width = c.width;
      f.cam.height = c.height;
      f.cam.depth_scale = static_cast<float>(1.0 / c.depth_factor);
      for (const tools::SequenceFrame& sf : seq.frames) {
        tools::Image16 im = tools::read_png16(sf.depth_path);
        f.width = im.width;
        f.height = im.height;
        f.depth.push_back(std::move(im.pixels));
        Pose p;
        p.translation = sf.pose.translation.cast<float>();
        p.rotation = sf.pose.rotation.cast<float>().normalized();
        f.poses.push_back(p);
      }
      if (f.depth.empty()) f.problem = f.dir + ": no depth image has a pose";
    } catch (const std::exception& e) {
      f.problem = e.what();
      f.depth.clear();
    }
#else
    f.problem = "built without the tools (DYNAMAP_BUILD_TOOLS=OFF): no PNG reader";
#endif
    return f;
  }();
  return r;
}

// Whole detection, one recorded frame per iteration, frames in turn (the pipeline's default
// detector configuration); arg 0 is the per-pixel reference height search, arg 1 the default.
void BM_DetectSequence(benchmark::State& state) {
  const RecordedFrames& f = recorded_frames();
  if (f.depth.empty()) {
    state.SkipWithError(f.problem.c_str());
    return;
  }
  auto det = std::make_unique<UMapDetector>();
  UMapDetectorConfig cfg;
  cfg.use_fast_measure = state.range(0) == 1;
  if (!ok(det->init(cfg))) state.SkipWithError("init");
  DetectionList out;
  std::size_t i = 0, detections = 0, frames = 0;
  const int stride = f.width * static_cast<int>(sizeof(std::uint16_t));
  for (auto _ : state) {
    const DepthView view{f.depth[i].data(), f.width, f.height, stride};
    const Status st = det->detect(view, f.cam, f.poses[i], out);
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(out.data());
    detections += out.size();
    ++frames;
    i = i + 1 == f.depth.size() ? 0 : i + 1;
  }
  state.counters["frames"] = static_cast<double>(f.depth.size());
  state.counters["detections_per_frame"] =
      frames > 0 ? static_cast<double>(detections) / static_cast<double>(frames) : 0.0;
  state.SetLabel(std::string(umap_histogram_fast_name()) +
                 (cfg.use_fast_measure ? ", fast measure" : ", per-pixel search"));
}
BENCHMARK(BM_DetectSequence)
    ->ArgName("fast_measure")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMicrosecond);

// Refinement of the frame's detections against a map built from 10 integrations of the frame;
// arg 1 adds a clean-history lookup (a second pass over the voxels of each inflated box).
void BM_Refine(benchmark::State& state) {
  const Scene& s = scene();
  static std::unique_ptr<OccupancyMap> map = [&] {
    auto m = std::make_unique<OccupancyMap>();
    if (!ok(m->init(OccupancyMapConfig{}))) return m;
    for (int i = 0; i < 10; ++i) {
      (void)m->integrate(s.image.view(), s.cam, s.pose, static_cast<Stamp>(i + 1) * 33'000'000);
    }
    return m;
  }();
  static auto clean = std::make_unique<FixedHashSet<std::uint64_t, 4096>>();
  auto det = std::make_unique<UMapDetector>();
  DetectionList raw;
  if (!ok(det->init(UMapDetectorConfig{})) ||
      !ok(det->detect(s.image.view(), s.cam, s.pose, raw))) {
    state.SkipWithError("detect");
  }
  MapRefiner refiner;
  if (!ok(refiner.init(MapRefinerConfig{}, 0.f))) state.SkipWithError("init");
  VoxelLookup lookup;
  if (state.range(0) == 1) {
    lookup = VoxelLookup{
        clean.get(), [](const void* ctx, std::uint64_t k) noexcept {
          return static_cast<const FixedHashSet<std::uint64_t, 4096>*>(ctx)->contains(k);
        }};
  }
  DetectionList work;
  for (auto _ : state) {
    work = raw;
    const Status st = refiner.refine(*map, lookup, work);
    benchmark::DoNotOptimize(st);
    benchmark::DoNotOptimize(work.data());
  }
  state.counters["boxes"] = static_cast<double>(raw.size());
  state.counters["refined"] = static_cast<double>(refiner.last_stats().refined);
}
BENCHMARK(BM_Refine)->Arg(0)->Arg(1)->Unit(benchmark::kMicrosecond);

}  // namespace

// BENCHMARK_MAIN plus --sequence=DIR (taken out of argv before Google Benchmark parses it).
int main(int argc, char** argv) {
  if (const char* env = std::getenv("DYNAMAP_BENCH_SEQUENCE")) sequence_dir() = env;
  int kept = 1;
  for (int i = 1; i < argc; ++i) {
    if (std::strncmp(argv[i], "--sequence=", 11) == 0) {
      sequence_dir() = argv[i] + 11;
    } else {
      argv[kept++] = argv[i];
    }
  }
  argc = kept;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  if (sequence_dir().empty()) {
    std::fprintf(stderr,
                 "bench_umap_detector: no recorded sequence (--sequence=DIR or "
                 "DYNAMAP_BENCH_SEQUENCE): BM_DetectSequence is skipped\n");
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
