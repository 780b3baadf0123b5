// Tracking + dynamic-region cleaning per frame with N walking obstacles (all dynamic: the
// cleaning worst case). Scene set-up per frame (detections, the walkers' voxels appearing in the
// map as integration would put them) is excluded from the timing.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "dynamap/map/clean_history.hpp"
#include "dynamap/map/dynamic_region_cleaner.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/track/tracker.hpp"

namespace {

using namespace dynamap;

constexpr Stamp kFrame = 33'333'333;

struct Scene {
  std::unique_ptr<OccupancyMap> map = std::make_unique<OccupancyMap>();
  std::unique_ptr<Tracker> tracker = std::make_unique<Tracker>();
  std::unique_ptr<CleanHistory> history = std::make_unique<CleanHistory>();
  DynamicRegionCleaner cleaner;
  std::vector<Detection> dets;
  std::mt19937 rng{42};
  std::normal_distribution<float> noise{0.f, 0.05f};
  std::size_t n = 0;
  int frame = 0;

  explicit Scene(std::size_t count, MotionModel model = KalmanConfig{}.model) : n(count) {
    (void)map->init(OccupancyMapConfig{});
    TrackerConfig tc;
    tc.kalman.model = model;
    (void)tracker->init(tc, 640, 480);
    (void)history->init(3'000'000'000ULL);
    (void)cleaner.init(DynamicRegionCleanerConfig{}, 0.f);
    dets.resize(n);
  }

  // Walker i circles (radius 1.5 m, 1 m/s) around its own spot on a 4 m grid.
  Box3 body(std::size_t i, int f) const {
    const float t = static_cast<float>(f) / 30.f;
    const float phase = static_cast<float>(i);
    const std::size_t column = i % 8, row = i / 8;  // eight walkers to a grid row
    const Eigen::Vector3f centre(2.f + 4.f * static_cast<float>(column),
                                 -14.f + 4.f * static_cast<float>(row), 0.85f);
    const Eigen::Vector3f c = centre + 1.5f * Eigen::Vector3f(std::cos(t / 1.5f + phase),
                                                              std::sin(t / 1.5f + phase), 0.f);
    return Box3::from_center_size(c, Eigen::Vector3f(0.5f, 0.5f, 1.7f));
  }

  void prepare() {
    const float r = map->resolution();
    for (std::size_t i = 0; i < n; ++i) {
      const Box3 b = body(i, frame);
      // Only the near surface shows up in a depth map: mark the body's shell.
      for (float z = b.min.z() + 0.5f * r; z < b.max.z(); z += r) {
        for (float y = b.min.y() + 0.5f * r; y < b.max.y(); y += r) {
          (void)map->set_log_odds(Eigen::Vector3f(b.min.x() + 0.5f * r, y, z), 2.f);
          (void)map->set_log_odds(Eigen::Vector3f(b.max.x() - 0.5f * r, y, z), 2.f);
        }
      }
      Detection& d = dets[i];
      const Eigen::Vector3f jitter(noise(rng), noise(rng), 0.f);
      d.box = Box3{b.min + jitter, b.max + jitter};
      d.raw_box = d.box;
      d.image_box = ImageBox{200, 100, 300, 400};
    }
  }

  void step(bool clean) {
    const Stamp stamp = kFrame * static_cast<Stamp>(frame + 1);
    (void)tracker->update(dets.data(), n, Pose{}, stamp);
    if (clean) (void)cleaner.clean(*tracker, *map, *history, stamp);
    ++frame;
  }
};

void run(benchmark::State& state, bool clean, MotionModel model = KalmanConfig{}.model) {
  Scene scene(static_cast<std::size_t>(state.range(0)), model);
  for (int f = 0; f < 60; ++f) {  // warm up: every walker is dynamic by now
    scene.prepare();
    scene.step(clean);
  }
  std::size_t dynamic = 0;
  for (std::size_t i = 0; i < scene.tracker->size(); ++i)
    dynamic += scene.tracker->obstacle(i).dynamic;
  double voxels = 0.0;
  for (auto _ : state) {
    state.PauseTiming();
    scene.prepare();
    state.ResumeTiming();
    scene.step(clean);
    voxels += static_cast<double>(scene.cleaner.last_stats().voxels_budgeted);
  }
  state.counters["tracks"] = static_cast<double>(scene.tracker->size());
  state.counters["dynamic"] = static_cast<double>(dynamic);
  state.counters["voxels/frame"] = benchmark::Counter(voxels, benchmark::Counter::kAvgIterations);
}

void BM_TrackAndClean(benchmark::State& state) {
  run(state, true);
}
void BM_TrackOnly(benchmark::State& state) {
  run(state, false);
}
// The original constant-velocity filter, for the cost of the IMM (docs/tracker.md).
void BM_TrackOnlyConstantVelocity(benchmark::State& state) {
  run(state, false, MotionModel::kConstantVelocity);
}

BENCHMARK(BM_TrackAndClean)
    ->Arg(10)
    ->Arg(static_cast<int>(kMaxTracks))
    ->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TrackOnly)->Arg(10)->Arg(static_cast<int>(kMaxTracks))->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_TrackOnlyConstantVelocity)
    ->Arg(10)
    ->Arg(static_cast<int>(kMaxTracks))
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
