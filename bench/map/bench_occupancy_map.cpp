// OccupancyMap vs OctoMap on a synthetic indoor scene (640x480 depth, ranges up to ~5 m).
// The scene is rendered here by a small analytic ray-caster (planes + boxes) with RealSense-like
// noise and dropouts. Both maps get the same sampled pixels (margin 2, stride 2) from the same
// origin; OctoMap gets them as a point cloud with maxrange 5 m.
//
// Output: Google Benchmark timings (use --benchmark_repetitions=5
// --benchmark_report_aggregates_only=true), then a summary of per-frame medians, the ratio and
// both memory footprints (skip it with --skip_summary).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <limits>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>
#include <octomap/octomap.h>

#include "carve_compare.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/platform/worker_team.hpp"

namespace {

using dynamap::Box3;
using dynamap::CameraIntrinsics;
using dynamap::DepthView;
using dynamap::OccupancyMap;
using dynamap::OccupancyMapConfig;
using dynamap::Pose;
using Vec3 = Eigen::Vector3f;

constexpr int kFrames = 48;
constexpr dynamap::Stamp kFrameNs = 33'333'333;
/// The early-stop count benchmarked against the exact walk (free_ray_early_stop = 0).
constexpr int kEarlyStop = 12;

/// Index of pixel (u, v) in a row-major image `width` pixels wide, widened before multiplying.
std::size_t pixel_index(int u, int v, int width) {
  return static_cast<std::size_t>(v) * static_cast<std::size_t>(width) +
         static_cast<std::size_t>(u);
}

struct Plane {
  Vec3 point, normal;
};

/// A 6 x 6 x 3 m room with furniture-sized boxes.
struct Scene {
  std::vector<Plane> planes{
      {Vec3(0, 0, 0), Vec3(0, 0, 1)},  {Vec3(0, 0, 3), Vec3(0, 0, -1)},
      {Vec3(3, 0, 0), Vec3(-1, 0, 0)}, {Vec3(-3, 0, 0), Vec3(1, 0, 0)},
      {Vec3(0, 3, 0), Vec3(0, -1, 0)}, {Vec3(0, -3, 0), Vec3(0, 1, 0)},
  };
  std::vector<Box3> boxes{
      {Vec3(1.0f, -1.4f, 0.0f), Vec3(2.0f, -0.6f, 0.75f)},     // table
      {Vec3(2.4f, 0.9f, 0.0f), Vec3(2.9f, 2.1f, 1.8f)},        // cabinet
      {Vec3(0.3f, 0.6f, 0.0f), Vec3(0.7f, 1.0f, 0.4f)},        // box on the floor
      {Vec3(0.75f, -2.45f, 0.0f), Vec3(1.25f, -1.95f, 0.9f)},  // chair
      {Vec3(-0.35f, 1.85f, 0.0f), Vec3(-0.05f, 2.15f, 3.0f)},  // pillar
      {Vec3(1.75f, 0.0f, 0.0f), Vec3(2.25f, 0.4f, 1.7f)},      // person
  };

  /// Camera z-depth along the map-frame ray o + t * d (d has camera z = 1), or +inf.
  float trace(const Vec3& o, const Vec3& d) const {
    float best = std::numeric_limits<float>::infinity();
    for (const Plane& p : planes) {
      const float den = p.normal.dot(d);
      if (den >= -1e-9f) continue;  // only surfaces facing the camera
      const float t = p.normal.dot(p.point - o) / den;
      if (t > 0.f) best = std::min(best, t);
    }
    for (const Box3& b : boxes) {
      float t0 = 0.f, t1 = std::numeric_limits<float>::infinity();
      for (int a = 0; a < 3; ++a) {
        const float inv = 1.f / d[a];
        float ta = (b.min[a] - o[a]) * inv, tb = (b.max[a] - o[a]) * inv;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
      }
      if (t0 <= t1 && t0 > 0.f) best = std::min(best, t0);
    }
    return best;
  }
};

Eigen::Quaternionf camera_rotation(float yaw, float pitch) {
  Eigen::Matrix3f body_from_cam;  // optical (x right, y down, z fwd) -> body (x fwd, y left, z up)
  body_from_cam << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  const Eigen::Matrix3f m =
      (Eigen::AngleAxisf(yaw, Vec3::UnitZ()) * Eigen::AngleAxisf(pitch, Vec3::UnitY()))
          .toRotationMatrix();
  return Eigen::Quaternionf(m * body_from_cam).normalized();
}

struct Frame {
  std::vector<std::uint16_t> depth;
  Pose pose;
  octomap::Pointcloud cloud;  // the same sampled pixels, for OctoMap
};

struct Dataset {
  CameraIntrinsics cam;  // defaults: 640x480, fx 535.4
  OccupancyMapConfig config;
  std::vector<Frame> frames;
  std::size_t returns = 0, no_returns = 0, unmeasured = 0;

  DepthView view(const Frame& f) const {
    return DepthView{f.depth.data(), cam.width, cam.height,
                     cam.width * static_cast<int>(sizeof(std::uint16_t))};
  }
};

const Dataset& dataset() {
  static const Dataset ds = [] {
    Dataset d;
    const Scene scene;
    std::mt19937 rng(7);
    std::normal_distribution<float> gauss(0.f, 1.f);
    std::uniform_real_distribution<float> uni(0.f, 1.f);
    const CameraIntrinsics& c = d.cam;
    const OccupancyMapConfig& cfg = d.config;
    for (int i = 0; i < kFrames; ++i) {
      const float s = static_cast<float>(i) / kFrames;
      Frame f;
      // A slow walk across the room with the camera sweeping left and right.
      f.pose.translation =
          Vec3(-2.2f + 1.2f * s, -0.8f + 1.2f * s, 1.3f + 0.1f * std::sin(6.f * s));
      f.pose.rotation = camera_rotation(0.7f * std::sin(2.f * 3.14159f * s), 0.12f);
      f.depth.assign(pixel_index(0, c.height, c.width), 0);  // width x height zeros
      for (int v = 0; v < c.height; ++v) {
        for (int u = 0; u < c.width; ++u) {
          const Vec3 dir = f.pose.rotation * Vec3((static_cast<float>(u) - c.cx) / c.fx,
                                                  (static_cast<float>(v) - c.cy) / c.fy, 1.f);
          float z = scene.trace(f.pose.translation, dir);
          if (!std::isfinite(z) || uni(rng) < 0.01f) continue;  // 1 % dropouts
          z += 0.0015f * z * z * gauss(rng);                    // RealSense-like noise
          f.depth[pixel_index(u, v, c.width)] =
              static_cast<std::uint16_t>(std::lround(std::clamp(z, 0.f, 60.f) / c.depth_scale));
        }
      }
      // OctoMap input: the same sampled pixels and the same rule. A pixel without a
      // measurement (0) is no ray at all, as in dynamap; one beyond the map range becomes a
      // point beyond the max range so OctoMap inserts a free-only ray truncated at 5 m (range,
      // not camera z).
      for (int v = cfg.pixel_margin; v < c.height - cfg.pixel_margin; v += cfg.pixel_stride) {
        for (int u = cfg.pixel_margin; u < c.width - cfg.pixel_margin; u += cfg.pixel_stride) {
          const std::uint16_t raw = f.depth[pixel_index(u, v, c.width)];
          float z = static_cast<float>(raw) * c.depth_scale;
          if (raw == 0) {
            ++d.unmeasured;
            continue;
          }
          if (z < cfg.min_depth) continue;
          if (z > cfg.max_depth) {
            z = cfg.max_depth + 1.f;
            ++d.no_returns;
          } else {
            ++d.returns;
          }
          const Vec3 p = f.pose.translation +
                         f.pose.rotation * Vec3((static_cast<float>(u) - c.cx) / c.fx * z,
                                                (static_cast<float>(v) - c.cy) / c.fy * z, z);
          f.cloud.push_back(p.x(), p.y(), p.z());
        }
      }
      d.frames.push_back(std::move(f));
    }
    return d;
  }();
  return ds;
}

octomap::point3d to_octo(const Vec3& p) {
  return octomap::point3d(p.x(), p.y(), p.z());
}

// ---- Google Benchmark ---------------------------------------------------------------------

void BM_Dynamap(benchmark::State& state) {
  const Dataset& d = dataset();
  OccupancyMapConfig cfg = d.config;
  cfg.merge_rays_per_voxel = state.range(0) != 0;
  cfg.free_ray_early_stop = static_cast<int>(state.range(1));
  if (state.range(2) == 0) cfg.carve_gap_quadratic = 0.f;  // carve to the end voxel, as OctoMap
  if (state.range(3) == 0) cfg.miss_max_offset = 0.f;      // lower every voxel crossed, as OctoMap
  cfg.max_voxel_visits_per_frame = 20'000'000;             // measure the work, do not cap it
  auto map = std::make_unique<OccupancyMap>();
  if (!dynamap::ok(map->init(cfg))) state.SkipWithError("init failed");
  dynamap::Stamp t = 0;
  std::size_t i = 0, updates = 0, visits = 0, rays = 0;
  for (auto _ : state) {
    const Frame& f = d.frames[i++ % d.frames.size()];
    const dynamap::Status s = map->integrate(d.view(f), d.cam, f.pose, t += kFrameNs);
    benchmark::DoNotOptimize(s);
    updates += map->last_stats().voxel_updates;
    visits += map->last_stats().voxel_visits;
    rays += map->last_stats().rays;
  }
  state.counters["updates_per_s"] =
      benchmark::Counter(static_cast<double>(updates), benchmark::Counter::kIsRate);
  state.counters["rays"] =
      benchmark::Counter(static_cast<double>(rays), benchmark::Counter::kAvgIterations);
  state.counters["visits"] =
      benchmark::Counter(static_cast<double>(visits), benchmark::Counter::kAvgIterations);
  state.counters["mem_MB"] = static_cast<double>(map->memory_bytes()) / 1e6;
}
// Exact walk and early stop, with and without the noise gap and the centre rule
// (miss_max_offset), next to each other, so one run gives every median (same-run ratios under
// the same load). OctoMap's peer is the exact walk without either
// (merge:1/early_stop:0/gap:0/centre:0); the defaults are merge:1/early_stop:12/gap:1/centre:1.
BENCHMARK(BM_Dynamap)
    ->ArgNames({"merge", "early_stop", "gap", "centre"})
    ->Args({1, 0, 0, 0})
    ->Args({1, kEarlyStop, 1, 1})
    ->Args({1, kEarlyStop, 1, 0})
    ->Args({1, kEarlyStop, 0, 0})
    ->Args({0, 0, 0, 0})
    ->Unit(benchmark::kMillisecond);

/// Tiled carving on a team of threads (as the pipeline lends the map its team), next to the
/// one-walk carving (tiles 0) in the same run; early stop and the default visit cap, as the
/// pipeline runs it. Wall time (UseRealTime): the helpers' CPU time is not the caller's.
void BM_DynamapThreads(benchmark::State& state) {
  const Dataset& d = dataset();
  OccupancyMapConfig cfg = d.config;
  cfg.free_ray_early_stop = kEarlyStop;
  cfg.carve_tiles = static_cast<int>(state.range(0));
  auto map = std::make_unique<OccupancyMap>();
  if (!dynamap::ok(map->init(cfg))) state.SkipWithError("init failed");
  dynamap::platform::WorkerTeam team;
  if (!dynamap::ok(team.start(static_cast<unsigned>(state.range(1)), {}))) {
    state.SkipWithError("team start failed");
  }
  dynamap::Stamp t = 0;
  std::size_t i = 0, visits = 0;
  for (auto _ : state) {
    const Frame& f = d.frames[i++ % d.frames.size()];
    const dynamap::Status s = map->integrate(d.view(f), d.cam, f.pose, t += kFrameNs, &team);
    benchmark::DoNotOptimize(s);
    visits += map->last_stats().voxel_visits;
  }
  state.counters["visits"] =
      benchmark::Counter(static_cast<double>(visits), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_DynamapThreads)
    ->ArgNames({"tiles", "threads"})
    ->Args({0, 1})
    ->Args({4, 1})
    ->Args({4, 2})
    ->Args({4, 4})
    ->UseRealTime()
    ->Unit(benchmark::kMillisecond);

/// Deliberately bad frame: uniform random depths (0.5-5 m) defeat ray merging, so the visit cap
/// (default 1e6) is what bounds the time.
void BM_DynamapWorstCase(benchmark::State& state) {
  const Dataset& d = dataset();
  std::vector<std::uint16_t> noise(d.frames[0].depth.size());
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> depth_mm(500, 5000);
  for (auto& px : noise) px = static_cast<std::uint16_t>(depth_mm(rng));
  const DepthView view{noise.data(), d.cam.width, d.cam.height,
                       d.cam.width * static_cast<int>(sizeof(std::uint16_t))};
  auto map = std::make_unique<OccupancyMap>();
  if (!dynamap::ok(map->init(d.config))) state.SkipWithError("init failed");
  dynamap::Stamp t = 0;
  std::size_t visits = 0;
  for (auto _ : state) {
    const dynamap::Status s = map->integrate(view, d.cam, d.frames[0].pose, t += kFrameNs);
    benchmark::DoNotOptimize(s);
    visits += map->last_stats().voxel_visits;
  }
  state.counters["visits"] =
      benchmark::Counter(static_cast<double>(visits), benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_DynamapWorstCase)->Unit(benchmark::kMillisecond);

void BM_OctoMap(benchmark::State& state) {
  const Dataset& d = dataset();
  const bool discretize = state.range(0) != 0;
  octomap::OcTree tree(0.1);
  std::size_t i = 0;
  for (auto _ : state) {
    const Frame& f = d.frames[i++ % d.frames.size()];
    tree.insertPointCloud(f.cloud, to_octo(f.pose.translation), d.config.max_depth, false,
                          discretize);
  }
  state.counters["mem_MB"] = static_cast<double>(tree.memoryUsage()) / 1e6;
}
BENCHMARK(BM_OctoMap)
    ->ArgName("discretize")
    ->Arg(0)
    ->Arg(1)
    ->Iterations(12)
    ->Unit(benchmark::kMillisecond);

// ---- summary: per-frame medians over the whole sequence ---------------------------------

/// Thread CPU time: the machine is shared, so wall time includes waiting for a core.
double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

struct RunResult {
  double min_ms = 0, wall_median_ms = 0;
  double median_ms = 0, updates_per_s = 0, mean_rays = 0, mean_visits = 0;
  std::size_t memory = 0, used = 0;
  std::uint64_t checksum = 0;  // map state after the run (bit-exactness check across versions)
};

/// The exact walks (early_stop 0) carve to the end voxel and lower every voxel they cross, as
/// OctoMap does (no noise gap, no centre rule); the early-stop run is the library's defaults.
RunResult run_dynamap(bool merge, int early_stop, int passes) {
  const Dataset& d = dataset();
  OccupancyMapConfig cfg = d.config;
  cfg.merge_rays_per_voxel = merge;
  cfg.free_ray_early_stop = early_stop;
  if (early_stop == 0) {
    cfg.carve_gap_quadratic = 0.f;
    cfg.miss_max_offset = 0.f;
  }
  if (!merge) cfg.max_voxel_visits_per_frame = 20'000'000;
  auto map = std::make_unique<OccupancyMap>();
  if (!dynamap::ok(map->init(cfg))) std::abort();
  std::vector<double> ms, cpu_ms;
  double total_s = 0, updates = 0, rays = 0, visits = 0;
  dynamap::Stamp t = 0;
  for (int p = 0; p < passes; ++p) {
    for (const Frame& f : d.frames) {
      const double c0 = cpu_seconds();
      const auto t0 = std::chrono::steady_clock::now();
      const dynamap::Status s = map->integrate(d.view(f), d.cam, f.pose, t += kFrameNs);
      const auto t1 = std::chrono::steady_clock::now();
      const double c1 = cpu_seconds();
      if (!dynamap::ok(s)) std::abort();
      ms.push_back(1e3 * std::chrono::duration<double>(t1 - t0).count());
      cpu_ms.push_back(1e3 * (c1 - c0));
      total_s += c1 - c0;
      updates += static_cast<double>(map->last_stats().voxel_updates);
      rays += static_cast<double>(map->last_stats().rays);
      visits += static_cast<double>(map->last_stats().voxel_visits);
    }
  }
  RunResult r;
  r.median_ms = median(cpu_ms);
  r.min_ms = *std::min_element(cpu_ms.begin(), cpu_ms.end());
  r.wall_median_ms = median(ms);
  r.updates_per_s = updates / total_s;
  r.mean_rays = rays / static_cast<double>(ms.size());
  r.mean_visits = visits / static_cast<double>(ms.size());
  r.memory = map->memory_bytes();
  r.used = map->blocks_in_use();
  r.checksum = map->checksum();
  return r;
}

RunResult run_octomap(bool discretize, int frames) {
  const Dataset& d = dataset();
  octomap::OcTree tree(0.1);
  std::vector<double> ms, cpu_ms;
  for (int i = 0; i < frames; ++i) {
    const Frame& f = d.frames[static_cast<std::size_t>(i) % d.frames.size()];
    const double c0 = cpu_seconds();
    const auto t0 = std::chrono::steady_clock::now();
    tree.insertPointCloud(f.cloud, to_octo(f.pose.translation), d.config.max_depth, false,
                          discretize);
    const auto t1 = std::chrono::steady_clock::now();
    const double c1 = cpu_seconds();
    ms.push_back(1e3 * std::chrono::duration<double>(t1 - t0).count());
    cpu_ms.push_back(1e3 * (c1 - c0));
  }
  RunResult r;
  r.median_ms = median(cpu_ms);
  r.wall_median_ms = median(ms);
  r.memory = tree.memoryUsage();
  r.used = tree.size();
  return r;
}

/// Which dynamap runs the summary makes (--quick_summary[=exact|early]).
enum class Quick { kOff, kBoth, kExact, kEarly };

void print_dynamap(const char* what, const RunResult& r) {
  std::printf(
      "dynamap  %-17s: median %7.3f ms/frame [%7.3f wall], min %.3f, %5.1f M updates/s, %.0f "
      "rays, %.0f visits/frame, checksum %llu\n",
      what, r.median_ms, r.wall_median_ms, r.min_ms, r.updates_per_s / 1e6, r.mean_rays,
      r.mean_visits, static_cast<unsigned long long>(r.checksum));
}

void print_summary(Quick quick) {
  const Dataset& d = dataset();
  std::printf(
      "\n== summary: %d frames 640x480, stride %d, margin %d; %.0f returns + %.0f beyond "
      "the map range + %.0f unmeasured (0) sampled pixels per frame ==\n",
      kFrames, d.config.pixel_stride, d.config.pixel_margin,
      static_cast<double>(d.returns) / kFrames, static_cast<double>(d.no_returns) / kFrames,
      static_cast<double>(d.unmeasured) / kFrames);
  std::printf(
      "(per-frame medians of thread CPU time over 5 x %d frames; wall-clock medians in "
      "brackets)\n",
      kFrames);
  // One mode after the other: each map needs its own consecutive frames.
  RunResult exact, early;
  if (quick != Quick::kEarly) {
    exact = run_dynamap(true, 0, 5);
    print_dynamap("(merge, exact)", exact);
  }
  if (quick != Quick::kExact) {
    early = run_dynamap(true, kEarlyStop, 5);
    char what[32];
    std::snprintf(what, sizeof what, "(merge, stop %d)", kEarlyStop);
    print_dynamap(what, early);
  }
  if (quick == Quick::kBoth || quick == Quick::kOff) {
    std::printf("ratio exact / early stop: %.2fx time, %.2fx visits\n",
                exact.median_ms / early.median_ms, exact.mean_visits / early.mean_visits);
  }
  if (quick != Quick::kOff) return;
  const RunResult every = run_dynamap(false, 0, 1);
  const RunResult octo = run_octomap(false, 24);
  const RunResult octo_disc = run_octomap(true, 24);
  print_dynamap("(every ray)", every);
  std::printf("memory %.2f MB (fixed; %zu blocks used)\n", static_cast<double>(exact.memory) / 1e6,
              exact.used);
  std::printf(
      "OctoMap  insertPointCloud : median %7.3f ms/frame [%7.3f wall], memory %.2f MB (%zu "
      "nodes)\n",
      octo.median_ms, octo.wall_median_ms, static_cast<double>(octo.memory) / 1e6, octo.used);
  std::printf("OctoMap  (discretize=true): median %7.3f ms/frame [%7.3f wall], memory %.2f MB\n",
              octo_disc.median_ms, octo_disc.wall_median_ms,
              static_cast<double>(octo_disc.memory) / 1e6);
  // Like for like: OctoMap walks every ray exactly; discretize=true is its form of merging.
  // Early stop is an approximation OctoMap has no counterpart for, so it gets its own line.
  std::printf("ratio OctoMap / dynamap (merge, exact)        : %.1fx\n",
              octo.median_ms / exact.median_ms);
  std::printf("ratio OctoMap / dynamap (merge, stop %d)       : %.1fx\n", kEarlyStop,
              octo.median_ms / early.median_ms);
  std::printf("ratio OctoMap / dynamap (every ray, no merge) : %.1fx\n",
              octo.median_ms / every.median_ms);
  std::printf("ratio OctoMap discretize / dynamap merge exact: %.1fx\n",
              octo_disc.median_ms / exact.median_ms);
}

/// Accuracy cost of early-stop carving on this scene (tools/diag/carve_compare.hpp): `passes`
/// times over the 48 frames, exact mode vs each count in `stops`.
void print_accuracy(const std::vector<int>& stops, int passes) {
  const Dataset& d = dataset();
  dynamap::diag::CarveComparison cmp(d.config, stops);
  dynamap::Stamp t = 0;
  for (int p = 0; p < passes; ++p) {
    for (const Frame& f : d.frames) {
      if (!cmp.add_frame(d.view(f), d.cam, f.pose, t += kFrameNs)) std::abort();
    }
  }
  cmp.print(stdout, "bench");
}

}  // namespace

int main(int argc, char** argv) {
  bool summary = true;
  Quick quick = Quick::kOff;
  std::vector<int> accuracy_stops;
  std::vector<char*> args;
  for (int i = 0; i < argc; ++i) {
    if (std::strcmp(argv[i], "--skip_summary") == 0) {
      summary = false;
    } else if (std::strcmp(argv[i], "--quick_summary") == 0) {
      quick = Quick::kBoth;  // dynamap only (development)
    } else if (std::strcmp(argv[i], "--quick_summary=exact") == 0) {
      quick = Quick::kExact;  // one mode only, e.g. for callgrind
    } else if (std::strcmp(argv[i], "--quick_summary=early") == 0) {
      quick = Quick::kEarly;
    } else if (std::strncmp(argv[i], "--accuracy=", 11) == 0) {
      // Comma-separated early-stop counts, e.g. --accuracy=1,2,3; prints the comparison only.
      std::stringstream list(argv[i] + 11);
      std::string item;
      while (std::getline(list, item, ',')) accuracy_stops.push_back(std::stoi(item));
    } else {
      args.push_back(argv[i]);
    }
  }
  int n = static_cast<int>(args.size());
  benchmark::Initialize(&n, args.data());
  if (benchmark::ReportUnrecognizedArguments(n, args.data())) return 1;
  (void)dataset();  // render once, outside any timing
  if (!accuracy_stops.empty()) {
    print_accuracy(accuracy_stops, 2);
    return 0;
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  if (summary) print_summary(quick);
  return 0;
}
