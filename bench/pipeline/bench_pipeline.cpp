// Pipeline timing, laid out like the paper's Table II: per-stage and total time per frame
// (median and p99 over a synthetic 640x480 sequence with walkers), plus deliberately worst-case
// frames. Prints a table; timing goals are judged from it, never in unit tests.
//
//   ./build/release/bench/bench_pipeline [frames=300] [passes=3] [--wall]
//       [--threads=1,2,4 [--tiles=4] [--period-ms=P]]
//
// --threads runs the one-walk pipeline (map.carve_tiles 0, one thread) and then, for each
// listed count, team.members = count with map.carve_tiles = --tiles (default 4), pass by pass in
// turn (so load drift hits them alike), always on the wall clock, and prints the medians and
// their ratios to the first entry. Frames run back to back unless --period-ms starts them P ms
// apart, as a camera delivers them: the team's helpers then fall asleep between frames (they
// spin only briefly), and each frame pays for waking them.
//
// Stage times are the pipeline's own timers. By default they read the thread's CPU clock, so a
// shared, loaded machine does not inflate them with time spent descheduled; --wall uses the
// monotonic wall clock the pipeline uses in production.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/platform/clock.hpp"
#include "dynamap/testing/worst_case.hpp"
#include "world_scene.hpp"

namespace {

constexpr const char* kUsage =
    "usage: bench_pipeline [frames=300] [passes=3] [--wall] [--threads=1,2,4 [--tiles=4] "
    "[--period-ms=P]]\n";

using namespace dynamap;

struct Sequence {
  std::vector<std::vector<std::uint16_t>> images;
  std::vector<Pose> poses;
};

// An office-like room: walls, a few boxes and pillars, four people walking and one standing;
// the camera drifts slowly forward and yaws, as on a hovering drone.
Sequence make_sequence(const CameraIntrinsics& cam, int frames) {
  Sequence s;
  const std::vector<Box3> statics = {
      Box3::from_center_size({6.f, 0.f, 1.5f}, {0.2f, 12.f, 3.f}),     // far wall
      Box3::from_center_size({2.f, 4.f, 1.5f}, {10.f, 0.2f, 3.f}),     // left wall
      Box3::from_center_size({2.f, -4.f, 1.5f}, {10.f, 0.2f, 3.f}),    // right wall
      Box3::from_center_size({3.5f, 2.2f, 0.4f}, {0.8f, 0.8f, 0.8f}),  // boxes
      Box3::from_center_size({4.5f, -2.5f, 0.5f}, {1.0f, 0.6f, 1.0f}),
      Box3::from_center_size({2.8f, -1.0f, 1.5f}, {0.3f, 0.3f, 3.0f}),  // pillar
      test::person_at(5.0f, 1.0f),                                      // standing person
  };
  test::WorldScene scene;
  s.images.resize(static_cast<std::size_t>(frames));
  for (int i = 0; i < frames; ++i) {
    const float t = static_cast<float>(i) / 30.f;
    scene.boxes = statics;
    scene.boxes.push_back(test::person_at(3.0f, -2.5f + std::fmod(1.0f * t, 5.f)));
    scene.boxes.push_back(
        test::person_at(4.0f + 0.8f * std::sin(0.5f * t), 2.5f - std::fmod(0.8f * t, 5.f)));
    scene.boxes.push_back(test::person_at(2.2f + std::fmod(0.6f * t, 3.f), 1.2f));
    scene.boxes.push_back(test::person_at(5.2f - std::fmod(0.7f * t, 3.f), -0.5f));
    const Pose pose = test::level_camera(Eigen::Vector3f(0.3f * std::sin(0.2f * t), 0.f, 1.3f),
                                         0.25f * std::sin(0.3f * t));
    s.poses.push_back(pose);
    (void)test::render(scene, cam, pose, s.images[static_cast<std::size_t>(i)]);
  }
  return s;
}

double ms(std::uint64_t ns) {
  return static_cast<double>(ns) * 1e-6;
}
std::uint64_t cpu_clock() {
  return platform::thread_cpu_ns();
}
std::uint64_t wall_clock() {
  return platform::monotonic_ns();
}

/// Median wall-clock occupancy and whole-frame times per map thread count, passes in turn.
int compare_threads(const PipelineConfig& base, const Sequence& seq, int frames, int passes,
                    int tiles, const std::vector<int>& threads, int period_ms) {
  struct Run {
    const char* label;
    int tiles, threads;
    std::vector<std::uint64_t> occupancy, detection, total;
  };
  std::vector<Run> runs{{"one walk", 0, 1, {}, {}, {}}};
  for (int n : threads) runs.push_back({"tiled", tiles, n, {}, {}, {}});
  auto pipeline = std::make_unique<Pipeline>();
  auto out = std::make_unique<FrameOutput>();
  for (int pass = 0; pass < passes; ++pass) {
    for (Run& r : runs) {
      PipelineConfig config = base;
      config.map.carve_tiles = r.tiles;
      config.team.members = r.threads;
      if (!ok(pipeline->init(config))) return 1;
      pipeline->set_clock(&wall_clock);
      auto next = std::chrono::steady_clock::now();
      for (int i = 0; i < frames; ++i) {
        if (period_ms > 0) {
          next += std::chrono::milliseconds(period_ms);
          std::this_thread::sleep_until(next);
        }
        Frame f;
        f.stamp = static_cast<Stamp>(i + 1) * 33'333'333ULL;
        f.T_map_camera = seq.poses[static_cast<std::size_t>(i)];
        f.depth = DepthView{seq.images[static_cast<std::size_t>(i)].data(), config.camera.width,
                            config.camera.height, config.camera.width * 2};
        if (!ok(pipeline->process(f, *out))) return 1;
        if (i == 0) continue;
        r.occupancy.push_back(out->stage_ns[static_cast<std::size_t>(Stage::kOccupancy)]);
        r.detection.push_back(out->stage_ns[static_cast<std::size_t>(Stage::kDetection)]);
        r.total.push_back(out->total_ns);
      }
    }
  }
  const auto median = [](std::vector<std::uint64_t> v) {
    std::sort(v.begin(), v.end());
    return ms(v[v.size() / 2]);
  };
  std::printf("\nteam threads, wall clock, %d frames x %d passes in turn, %s\n", frames - 1, passes,
              period_ms > 0 ? "frames paced" : "frames back to back");
  std::printf(
      "| map | threads | occupancy median (ms) | ratio | detection median (ms) | frame median "
      "(ms) | ratio |\n|---|---|---|---|---|---|---|\n");
  const double occ0 = median(runs[0].occupancy), tot0 = median(runs[0].total);
  for (const Run& r : runs) {
    const double occ = median(r.occupancy), det = median(r.detection), tot = median(r.total);
    std::printf("| %s (tiles %d) | %d | %.3f | %.2f | %.3f | %.3f | %.2f |\n", r.label, r.tiles,
                r.threads, occ, occ / occ0, det, tot, tot / tot0);
  }
  std::printf(
      "(threads > 1: detection runs on the team beside the carving; its time is inside "
      "the occupancy column)\n");
  return 0;
}

struct Options {
  bool wall = false;
  int frames = 300, passes = 3, tiles = 4, period_ms = 0;
  std::vector<int> threads;
};

/// Reads the command line into `opt`; on a bad or out-of-range argument prints why and the
/// usage and returns false.
bool parse_args(int argc, char** argv, Options& opt) {
  std::vector<int> numbers;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--wall") {
      opt.wall = true;
    } else if (arg.rfind("--threads=", 0) == 0) {
      for (std::size_t at = 10; at < arg.size();) {
        const std::size_t comma = std::min(arg.find(',', at), arg.size());
        opt.threads.push_back(std::atoi(arg.substr(at, comma - at).c_str()));
        at = comma + 1;
      }
    } else if (arg.rfind("--tiles=", 0) == 0) {
      opt.tiles = std::atoi(arg.c_str() + 8);
    } else if (arg.rfind("--period-ms=", 0) == 0) {
      opt.period_ms = std::atoi(arg.c_str() + 12);
    } else if (!arg.empty() && arg.find_first_not_of("0123456789") == std::string::npos &&
               numbers.size() < 2) {
      numbers.push_back(std::atoi(argv[i]));
    } else {
      std::fprintf(stderr, "bench_pipeline: unknown argument '%s'\n%s", arg.c_str(), kUsage);
      return false;
    }
  }
  if (numbers.size() > 0) opt.frames = numbers[0];
  if (numbers.size() > 1) opt.passes = numbers[1];
  const bool threads_ok = std::all_of(opt.threads.begin(), opt.threads.end(), [](int n) {
    return n >= 1 && n <= static_cast<int>(kMaxTeamMembers);
  });
  if (opt.frames < 2 || opt.passes < 1 || opt.tiles < 1 || opt.tiles > kMaxCarveTiles ||
      !threads_ok || opt.period_ms < 0 || opt.period_ms > 1000) {
    std::fprintf(stderr,
                 "bench_pipeline: need frames >= 2, passes >= 1, tiles 1..%d, threads 1..%d, "
                 "period-ms 0..1000\n%s",
                 static_cast<int>(kMaxCarveTiles), static_cast<int>(kMaxTeamMembers), kUsage);
    return false;
  }
  return true;
}

/// The p-quantile (nearest rank) of `v`.
std::uint64_t pct(std::vector<std::uint64_t> v, double p) {
  std::sort(v.begin(), v.end());
  const std::size_t r = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, r == 0 ? 0 : r - 1)];
}

/// Per-frame figures of the sequence, over all passes, each pass's first frame left out.
struct SequenceTimes {
  std::array<std::vector<std::uint64_t>, kStageCount> stage;
  std::vector<std::uint64_t> total;
  std::size_t dynamic_tracks = 0, predictions = 0;
};

/// Runs the sequence `passes` times; false when init or a frame fails.
bool run_sequence(Pipeline& pipeline, FrameOutput& out, const PipelineConfig& config,
                  Pipeline::Clock clock, const Sequence& seq, int frames, int passes,
                  SequenceTimes& times) {
  // Each pass re-initialises (a fresh map), timing every frame; statistics accumulate over passes
  // except the first frame of each pass (cold caches, empty map).
  for (int pass = 0; pass < passes; ++pass) {
    if (!ok(pipeline.init(config))) return false;
    pipeline.set_clock(clock);
    for (int i = 0; i < frames; ++i) {
      Frame f;
      f.stamp = static_cast<Stamp>(i + 1) * 33'333'333ULL;
      f.T_map_camera = seq.poses[static_cast<std::size_t>(i)];
      f.depth = DepthView{seq.images[static_cast<std::size_t>(i)].data(), config.camera.width,
                          config.camera.height, config.camera.width * 2};
      if (!ok(pipeline.process(f, out))) return false;
      if (i == 0) continue;
      for (std::size_t k = 0; k < kStageCount; ++k) times.stage[k].push_back(out.stage_ns[k]);
      times.total.push_back(out.total_ns);
      times.dynamic_tracks += out.work.dynamic_tracks;
      times.predictions += out.num_predictions;
    }
  }
  return true;
}

/// Prints the Table II layout; returns the whole frame's median in ms.
double print_table(const SequenceTimes& times, bool wall) {
  const double total_med = ms(pct(times.total, 0.5));
  double sum_medians = 0;
  for (std::size_t k = 0; k < kStageCount; ++k) sum_medians += ms(pct(times.stage[k], 0.5));

  std::printf("\nTable II (this machine, one core, %zu frames, %s time): time per frame\n",
              times.total.size(), wall ? "wall" : "thread CPU");
  std::printf("| module | median (ms) | p99 (ms) | share of median |\n|---|---|---|---|\n");
  for (std::size_t k = 0; k < kStageCount; ++k) {
    const double m = ms(pct(times.stage[k], 0.5));
    std::printf("| %s | %.3f | %.3f | %.0f %% |\n", to_string(static_cast<Stage>(k)), m,
                ms(pct(times.stage[k], 0.99)), 100.0 * m / sum_medians);
  }
  std::printf("| **total** | **%.3f** | **%.3f** | |\n", total_med, ms(pct(times.total, 0.99)));
  std::printf("(mean %.1f dynamic tracks and %.1f predictions per frame)\n",
              static_cast<double>(times.dynamic_tracks) / static_cast<double>(times.total.size()),
              static_cast<double>(times.predictions) / static_cast<double>(times.total.size()));
  return total_med;
}

/// Worst-case frames: every pixel at max range (rays), and clutter (detections, a full
/// tracker). Each is timed 30 times on a warm pipeline; the median is reported against the
/// sequence's median `total_med`. False when init or a frame fails.
bool run_worst_cases(Pipeline& pipeline, FrameOutput& out, const PipelineConfig& config,
                     double total_med) {
  std::vector<std::uint16_t> px(
      static_cast<std::size_t>(config.camera.width * config.camera.height));
  std::printf("\nWorst-case frames (median of 30, ms): \n");
  for (WorstCase kind : {WorstCase::kMaxRange, WorstCase::kClutter}) {
    if (!ok(pipeline.init(config))) return false;
    Frame f;
    f.T_map_camera = test::level_camera(Eigen::Vector3f(0.f, 0.f, 1.3f));
    f.depth =
        make_worst_case_depth(kind, config.camera, config.map.max_depth, kMaxDetections, px.data());
    std::vector<std::uint64_t> t;
    std::size_t max_tracks = 0;
    for (int i = 0; i < 30; ++i) {
      f.stamp = static_cast<Stamp>(i + 1) * 33'333'333ULL;
      if (!ok(pipeline.process(f, out))) return false;
      t.push_back(out.total_ns);
      max_tracks = std::max(max_tracks, out.num_obstacles);
    }
    const double w = ms(pct(t, 0.5));
    std::printf(
        "  %-9s total %.3f ms = %.2fx the sequence median (rays %zu, detections %zu, "
        "tracks %zu)\n",
        kind == WorstCase::kMaxRange ? "max-range" : "clutter", w, w / total_med, out.work.rays,
        out.work.detections, max_tracks);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!parse_args(argc, argv, opt)) return 2;
  const Pipeline::Clock clock = opt.wall ? &wall_clock : &cpu_clock;
  PipelineConfig config;
  std::printf("rendering %d frames of 640x480 ...\n", opt.frames);
  const Sequence seq = make_sequence(config.camera, opt.frames);
  if (!opt.threads.empty()) {
    return compare_threads(config, seq, opt.frames, opt.passes, opt.tiles, opt.threads,
                           opt.period_ms);
  }
  auto pipeline = std::make_unique<Pipeline>();
  auto out = std::make_unique<FrameOutput>();
  SequenceTimes times;
  if (!run_sequence(*pipeline, *out, config, clock, seq, opt.frames, opt.passes, times)) return 1;
  const double total_med = print_table(times, opt.wall);
  if (!run_worst_cases(*pipeline, *out, config, total_med)) return 1;
  std::printf("\nfootprint: %.1f MiB (Pipeline::memory_bytes)\n",
              static_cast<double>(Pipeline::memory_bytes()) / (1024.0 * 1024.0));
  return 0;
}
