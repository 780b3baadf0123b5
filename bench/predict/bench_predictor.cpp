// Prediction time per frame: 10 dynamic obstacles walking through a cluttered static map
// (pillars and wall segments in a 12 m x 12 m room whose air is observed free, real
// OccupancyMap), Markov predictor with l = 9 (the default), 5 and 15, with and without the
// far-field layer (fed a 640x480 frame of the room's walls, pillars and segments rendered from its
// west wall), and the linear baseline. One iteration = one frame = predict() for all 10.
#include <benchmark/benchmark.h>

#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/predict/detail/path_sweep.hpp"
#include "dynamap/predict/far_field_layer.hpp"
#include "dynamap/predict/linear_predictor.hpp"
#include "dynamap/predict/markov_predictor.hpp"
#include "dynamap/predict/prediction.hpp"
#include "world_scene.hpp"

namespace {

using namespace dynamap;

constexpr std::size_t kObstacles = 10;
constexpr std::size_t kFrames = 64;  // replayed cyclically; 30 Hz

struct Scene {
  std::unique_ptr<OccupancyMap> map = std::make_unique<OccupancyMap>();
  std::array<std::array<ObstacleState, kObstacles>, kFrames> frames{};
  std::size_t occupied_voxels = 0;
  std::vector<std::uint16_t> pixels;  // depth frame of the static boxes
  DepthView depth{};
  CameraIntrinsics camera{};
  Pose pose{};
  std::unique_ptr<FarFieldLayer> far = std::make_unique<FarFieldLayer>();  // fed that frame
};

void fill_box(OccupancyMap& map, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
              std::size_t* count, dynamap::test::WorldScene* scene) {
  scene->boxes.push_back(Box3{lo, hi});
  const float r = map.resolution();
  for (float x = lo.x() + 0.5f * r; x < hi.x(); x += r) {
    for (float y = lo.y() + 0.5f * r; y < hi.y(); y += r) {
      for (float z = lo.z() + 0.5f * r; z < hi.z(); z += r) {
        if (ok(map.set_log_odds(Eigen::Vector3f(x, y, z), 3.0f))) ++*count;
      }
    }
  }
}

const Scene& scene() {
  static const Scene* s = [] {
    auto* sc = new Scene;
    if (!ok(sc->map->init(OccupancyMapConfig{}))) std::abort();
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> pos(-6.0f, 6.0f);
    std::uniform_real_distribution<float> ang(-3.14159f, 3.14159f);
    std::uniform_real_distribution<float> spd(0.6f, 1.6f);
    // The room's air observed free (as the camera would leave it); then room walls, 60 pillars
    // (0.3 m), 12 wall segments (1.5 m), all floor to 2.4 m.
    const float h = 2.4f;
    dynamap::test::WorldScene world;
    for (float x = -6.05f; x < 6.1f; x += 0.1f) {
      for (float y = -6.05f; y < 6.1f; y += 0.1f) {
        for (float z = 0.05f; z < h; z += 0.1f) {
          if (!ok(sc->map->set_log_odds(Eigen::Vector3f(x, y, z), -2.0f))) std::abort();
        }
      }
    }
    fill_box(*sc->map, {-6.1f, -6.1f, 0.f}, {6.1f, -6.0f, h}, &sc->occupied_voxels, &world);
    fill_box(*sc->map, {-6.1f, 6.0f, 0.f}, {6.1f, 6.1f, h}, &sc->occupied_voxels, &world);
    fill_box(*sc->map, {-6.1f, -6.1f, 0.f}, {-6.0f, 6.1f, h}, &sc->occupied_voxels, &world);
    fill_box(*sc->map, {6.0f, -6.1f, 0.f}, {6.1f, 6.1f, h}, &sc->occupied_voxels, &world);
    for (int i = 0; i < 60; ++i) {
      const Eigen::Vector3f c(pos(rng), pos(rng), 0.f);
      fill_box(*sc->map, c + Eigen::Vector3f(-0.15f, -0.15f, 0.f),
               c + Eigen::Vector3f(0.15f, 0.15f, h), &sc->occupied_voxels, &world);
    }
    for (int i = 0; i < 12; ++i) {
      const Eigen::Vector3f c(pos(rng), pos(rng), 0.f);
      const bool along_x = i % 2 == 0;
      const Eigen::Vector3f half(along_x ? 0.75f : 0.05f, along_x ? 0.05f : 0.75f, 0.f);
      fill_box(*sc->map, c - half, c + half + Eigen::Vector3f(0.f, 0.f, h), &sc->occupied_voxels,
               &world);
    }
    // The camera on the west wall, 1.3 m up, looking east over the room (the simulator's model).
    CameraIntrinsics cam;
    cam.fx = cam.fy = 385.0f;
    cam.cx = 320.0f;
    cam.cy = 240.0f;
    const Pose pose = dynamap::test::level_camera(Eigen::Vector3f(-5.9f, 0.0f, 1.3f));
    sc->depth = dynamap::test::render(world, cam, pose, sc->pixels);
    sc->camera = cam;
    sc->pose = pose;
    if (!ok(sc->far->init(FarFieldConfig{}, 0.0f))) std::abort();
    for (int f = 0; f < 3; ++f) {
      if (!ok(sc->far->update(sc->depth, cam, pose, nullptr, 0))) std::abort();
    }
    // Walkers: straight lines at their speed, turning slightly every frame.
    for (std::size_t k = 0; k < kObstacles; ++k) {
      Eigen::Vector2f p(pos(rng) * 0.5f, pos(rng) * 0.5f);  // stay inside the room
      float heading = ang(rng);
      const float speed = spd(rng);
      for (std::size_t f = 0; f < kFrames; ++f) {
        ObstacleState& o = sc->frames[f][k];
        o.track_id = static_cast<std::uint32_t>(k + 1);
        o.position = Eigen::Vector3f(p.x(), p.y(), 0.9f);
        o.velocity = speed * Eigen::Vector2f(std::cos(heading), std::sin(heading));
        o.footprint_radius = 0.3f;
        o.height = 1.8f;
        p += o.velocity / 30.0f;
        heading += 0.01f;
      }
    }
    return sc;
  }();
  return *s;
}

// Counts the segment queries and the voxel-edge lengths they cover (outside the timed loop).
struct CountingMap {
  const OccupancyMap* map;
  mutable double queries = 0;
  mutable double voxel_lengths = 0;
  bool first_occupied_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                 Eigen::Vector3f* hit) const noexcept {
    const bool h = map->first_occupied_on_segment(a, b, hit);
    queries += 1;
    voxel_lengths += static_cast<double>(((h ? *hit : b) - a).lpNorm<1>() / map->resolution());
    return h;
  }
};

// The linear baseline is map-only (docs/predictor.md): the layer is for the Markov predictor.
Status run(MarkovPredictor& p, const ObstacleState* o, const OccupancyQuery& q,
           const FarFieldLayer* far, PathPrediction* out) {
  return p.predict(o, kObstacles, q, far, out);
}
Status run(LinearPredictor& p, const ObstacleState* o, const OccupancyQuery& q,
           const FarFieldLayer*, PathPrediction* out) {
  return p.predict(o, kObstacles, q, out);
}

template <class Predictor>
void count_work(benchmark::State& state, const Scene& sc, const Predictor& proto,
                const FarFieldLayer* far = nullptr) {
  auto p = std::make_unique<Predictor>(proto);
  CountingMap counting{sc.map.get()};
  const OccupancyQuery q = OccupancyQuery::of(counting);
  std::array<PathPrediction, kObstacles> out{};
  for (std::size_t f = 0; f < kFrames; ++f) {
    if (!ok(run(*p, sc.frames[f].data(), q, far, out.data()))) std::abort();
  }
  state.counters["queries/frame"] = counting.queries / kFrames;
  state.counters["voxels/frame"] = counting.voxel_lengths / kFrames;  // ~DDA steps (L1 length)
}

// Args: number of paths l, max clearance lines (9 = default 0.1 m spacing for r = 0.3 m -> 7),
// far-field layer lookups (1 = default, 0 off; the layer's update is BM_FarFieldUpdate), the
// outermost paths' heading change in degrees (180 = default; l = 5 to 90 is the same 45-degree
// spacing without the U-turns, the lighter library a tight prediction budget may choose), and
// turn_back_curvature in tenths of 1/m (0 off; it sweeps again only walkers with no free path).
void BM_MarkovPredictor(benchmark::State& state) {
  const Scene& sc = scene();
  MarkovPredictorConfig cfg;
  cfg.paths.num_paths = static_cast<std::size_t>(state.range(0));
  cfg.paths.max_heading_change = static_cast<float>(state.range(3)) * 3.14159265f / 180.0f;
  cfg.clearance.max_lines = static_cast<std::size_t>(state.range(1));
  cfg.turn_back_curvature = static_cast<float>(state.range(4)) / 10.0f;
  const FarFieldLayer* far = state.range(2) != 0 ? sc.far.get() : nullptr;
  auto mp = std::make_unique<MarkovPredictor>();
  if (!ok(mp->init(cfg))) {
    state.SkipWithError("init failed");
    return;
  }
  count_work(state, sc, *mp, far);
  const OccupancyQuery q = OccupancyQuery::of(*sc.map);
  std::array<PathPrediction, kObstacles> out{};
  std::size_t f = 0;
  std::size_t failed = 0;
  std::size_t predictions = 0;
  for (auto _ : state) {
    const Status s = mp->predict(sc.frames[f].data(), kObstacles, q, far, out.data());
    benchmark::DoNotOptimize(s);
    benchmark::DoNotOptimize(out.data());
    for (const PathPrediction& p : out) failed += p.failed ? 1 : 0;
    predictions += kObstacles;
    f = (f + 1) % kFrames;
  }
  state.counters["fail_ratio"] =
      predictions > 0 ? static_cast<double>(failed) / static_cast<double>(predictions) : 0.0;
  state.counters["lines"] = static_cast<double>(clearance_lines(cfg.clearance, 0.3f));
  state.counters["occupied_voxels"] = static_cast<double>(sc.occupied_voxels);
}
BENCHMARK(BM_MarkovPredictor)
    ->ArgNames({"l", "max_lines", "far", "deg", "back"})
    ->Args({9, 9, 1, 180, 30})
    ->Args({9, 9, 1, 180, 0})
    ->Args({5, 9, 1, 90, 30})
    ->Args({7, 9, 1, 135, 30})
    ->Args({9, 9, 0, 180, 30})
    ->Args({15, 9, 1, 180, 30})
    ->Args({9, 3, 1, 180, 30})
    ->Args({15, 3, 1, 180, 30})
    ->Repetitions(5)
    ->ReportAggregatesOnly(true)
    ->Unit(benchmark::kMicrosecond);

// The far-field layer's update (its own pipeline stage): the room frame, 640 x 480, with the 10
// walkers' discs excluded.
void BM_FarFieldUpdate(benchmark::State& state) {
  const Scene& sc = scene();
  auto layer = std::make_unique<FarFieldLayer>();
  if (!ok(layer->init(FarFieldConfig{}, 0.0f))) {
    state.SkipWithError("init failed");
    return;
  }
  std::array<FarFieldExclusion, kObstacles> discs{};
  for (std::size_t k = 0; k < kObstacles; ++k) {
    discs[k].centre = sc.frames[0][k].position.head<2>();
    discs[k].radius = 0.45f;
  }
  for (auto _ : state) {
    const Status s = layer->update(sc.depth, sc.camera, sc.pose, discs.data(), kObstacles);
    benchmark::DoNotOptimize(s);
  }
  state.counters["hits/frame"] = static_cast<double>(layer->last_hits());
}
BENCHMARK(BM_FarFieldUpdate)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true)
    ->Unit(benchmark::kMicrosecond);

void BM_LinearPredictor(benchmark::State& state) {
  const Scene& sc = scene();
  LinearPredictor lin;
  if (!ok(lin.init(LinearPredictorConfig{}))) {
    state.SkipWithError("init failed");
    return;
  }
  count_work(state, sc, lin);
  const OccupancyQuery q = OccupancyQuery::of(*sc.map);
  std::array<PathPrediction, kObstacles> out{};
  std::size_t f = 0;
  std::size_t failed = 0;
  std::size_t predictions = 0;
  for (auto _ : state) {
    const Status s = lin.predict(sc.frames[f].data(), kObstacles, q, out.data());
    benchmark::DoNotOptimize(s);
    benchmark::DoNotOptimize(out.data());
    for (const PathPrediction& p : out) failed += p.failed ? 1 : 0;
    predictions += kObstacles;
    f = (f + 1) % kFrames;
  }
  state.counters["fail_ratio"] =
      predictions > 0 ? static_cast<double>(failed) / static_cast<double>(predictions) : 0.0;
}
BENCHMARK(BM_LinearPredictor)
    ->Repetitions(5)
    ->ReportAggregatesOnly(true)
    ->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
