// Worst-case frames against the documented bound (issue 19). For a few configurations (the
// defaults, the largest work caps validation accepts) it builds the worst-case frames
// (make_worst_case_depth: every pixel at max range; clutter that fills the detector and the
// tracker; approaching bars that live long enough to be predicted), runs each sequence through
// a Pipeline and prints, per configuration, the largest work counters next to the bound
// worst_case_work() derives from the configuration, and the frame times next to the documented
// time bound. A plain executable (prints a table, exits 1 when a figure exceeds its bound).
// The defaults run once more with two map threads (tiled carving, 4 tiles; the detection on the
// map's team).
//
//   bench_worst_case [--wall]
//
// Times are the pipeline's own timer on the thread's CPU clock (--wall: monotonic clock); the
// two-thread run always on the monotonic clock, since its work is spread over two threads.
#include <algorithm>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <memory>
#include <vector>

#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/platform/clock.hpp"
#include "dynamap/testing/worst_case.hpp"
#include "world_scene.hpp"

namespace {

using namespace dynamap;

std::uint64_t cpu_clock() {
  return platform::thread_cpu_ns();
}
std::uint64_t wall_clock() {
  return platform::monotonic_ns();
}
double ms(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-6;
}

/// Work of one frame as the bound counts it.
struct Work {
  std::size_t rays = 0, voxel_visits = 0, detections = 0, tracks = 0, path_samples = 0,
              cleaner_voxels = 0;
  void max_with(const Work& o) {
    rays = std::max(rays, o.rays);
    voxel_visits = std::max(voxel_visits, o.voxel_visits);
    detections = std::max(detections, o.detections);
    tracks = std::max(tracks, o.tracks);
    path_samples = std::max(path_samples, o.path_samples);
    cleaner_voxels = std::max(cleaner_voxels, o.cleaner_voxels);
  }
};

Work work_of(const FrameOutput& out) {
  Work w;
  w.rays = out.work.rays;
  w.voxel_visits = out.work.voxel_visits;
  w.detections = out.work.detections;
  w.tracks = out.work.tracks;
  w.cleaner_voxels = out.work.voxels_cleaned;
  for (std::size_t i = 0; i < out.num_predictions; ++i) {
    w.path_samples += out.predictions[i].num_paths * out.predictions[i].num_samples;
    w.path_samples += out.linear_predictions[i].num_paths * out.linear_predictions[i].num_samples;
  }
  return w;
}

struct Named {
  const char* name;
  PipelineConfig config;
  double bound_ms;  ///< documented worst-frame bound (docs/reliability.md)
};

PipelineConfig two_map_threads() {
  PipelineConfig c;
  c.map.carve_tiles = 4;
  c.team.members = 2;
  return c;
}

/// The largest caps validation accepts: every work cap at its bound, the longest horizon the
/// prediction bound admits.
PipelineConfig largest_caps() {
  PipelineConfig c = largest_work_caps();
  for (float h = c.predictor.paths.horizon_distance;; h += 0.5f) {
    PipelineConfig t = c;
    t.predictor.paths.horizon_distance = h;
    if (worst_case_work(t).predictor_voxel_steps > kMaxPredictorVoxelStepsPerFrame) break;
    c = t;
  }
  return c;
}

}  // namespace

int main(int argc, char** argv) {
  const bool wall = argc > 1 && std::strcmp(argv[1], "--wall") == 0;
  const Named configs[] = {
      {"defaults", PipelineConfig{}, 33.3},
      {"largest caps", largest_caps(), 100.0},
      {"defaults, 2 map threads", two_map_threads(), 33.3},
  };
  auto pipeline = std::make_unique<Pipeline>();
  auto out = std::make_unique<FrameOutput>();
  int failures = 0;
  std::printf("worst-case frames, %s time per frame (host loaded: medians over the sequence)\n",
              wall ? "wall" : "thread CPU");
  for (const Named& n : configs) {
    ConfigError err;
    if (!ok(pipeline->init(n.config, &err))) {
      std::printf("%s: refused by validation at %s (%s)\n", n.name, err.field, err.reason);
      return 1;
    }
    const bool on_wall = wall || n.config.team.members > 1;
    pipeline->set_clock(on_wall ? &wall_clock : &cpu_clock);
    const WorstCaseWork bound = worst_case_work(n.config);
    const CameraIntrinsics& cam = n.config.camera;
    std::vector<std::uint16_t> px(static_cast<std::size_t>(cam.width) * cam.height);
    const Pose pose = test::level_camera(Eigen::Vector3f(0.f, 0.f, 1.3f));
    std::printf("\n%s (horizon %.1f m, pixel stride %d, %s time): bound %.1f ms\n", n.name,
                static_cast<double>(n.config.predictor.paths.horizon_distance),
                n.config.map.pixel_stride, on_wall ? "wall" : "thread CPU", n.bound_ms);
    std::printf(
        "| frames | n | median ms | max ms | rays | voxel visits | detections | tracks "
        "| path samples | cleaned voxels |\n|---|---|---|---|---|---|---|---|---|---|\n");
    Work all;
    std::uint64_t worst_ns = 0;
    Stamp stamp = 0;
    const struct {
      WorstCase kind;
      const char* name;
      unsigned frames;
    } runs[] = {{WorstCase::kMaxRange, "max-range", 30},
                {WorstCase::kClutter, "clutter", 30},
                {WorstCase::kApproach, "approach", 188}};
    for (const auto& r : runs) {
      std::vector<std::uint64_t> t;
      Work seen;
      for (unsigned i = 0; i < r.frames; ++i) {
        Frame f;
        f.T_map_camera = pose;
        f.depth = make_worst_case_depth(r.kind, cam, n.config.map.max_depth, kMaxDetections,
                                        px.data(), i);
        stamp += 33'333'333ULL;
        f.stamp = stamp;
        if (!ok(pipeline->process(f, *out))) return 1;
        t.push_back(out->total_ns);
        seen.max_with(work_of(*out));
      }
      std::vector<std::uint64_t> sorted = t;
      std::sort(sorted.begin(), sorted.end());
      worst_ns = std::max(worst_ns, sorted.back());
      all.max_with(seen);
      std::printf("| %s | %u | %.2f | %.2f | %zu | %zu | %zu | %zu | %zu | %zu |\n", r.name,
                  r.frames, ms(sorted[sorted.size() / 2]), ms(sorted.back()), seen.rays,
                  seen.voxel_visits, seen.detections, seen.tracks, seen.path_samples,
                  seen.cleaner_voxels);
    }
    std::printf("| **bound** | | | **%.1f** | %zu | %zu | %zu | %zu | %zu | %zu |\n", n.bound_ms,
                bound.rays, bound.voxel_visits, bound.detections, bound.tracks, bound.path_samples,
                bound.cleaner_voxels);
    const bool within = all.rays <= bound.rays && all.voxel_visits <= bound.voxel_visits &&
                        all.detections <= bound.detections && all.tracks <= bound.tracks &&
                        all.path_samples <= bound.path_samples &&
                        all.cleaner_voxels <= bound.cleaner_voxels;
    std::printf("work within the bound: %s; worst frame %.2f ms = %.0f %% of the bound\n",
                within ? "yes" : "NO", ms(worst_ns), 100.0 * ms(worst_ns) / n.bound_ms);
    if (!within || ms(worst_ns) > n.bound_ms) ++failures;
  }
  std::printf("\n%s\n", failures == 0 ? "PASS" : "FAIL");
  return failures == 0 ? 0 : 1;
}
