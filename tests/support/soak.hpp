// The soak: a long mixed stream of simulated, noisy and adversarial frames pushed through the
// threaded Runner, with the memory, timing and counter figures taken every `checkpoint` frames.
// Shared by bench/pipeline/bench_soak.cpp (100,000 frames, release) and
// tests/pipeline/test_soak.cpp (a short run). Host-side test code: it allocates and reads /proc,
// the library under test does neither.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <thread>
#include <vector>

#include <unistd.h>

#include "dynamap/pipeline/runner.hpp"
#include "dynamap/testing/worst_case.hpp"
#include "world_scene.hpp"

namespace dynamap::test {

/// Every kind of frame the soak sends, grouped by what must become of it.
enum class SoakKind : std::uint8_t {
  // Accepted by the pipeline (counted as processed).
  kScene,           ///< a rendered room with two walkers
  kNoisyScene,      ///< the same with depth noise, holes and speckles
  kRandomDepth,     ///< uniformly random depth over the whole image
  kPaddedStride,    ///< a scene frame whose rows are padded (a valid, larger stride)
  kWorstMaxRange,   ///< make_worst_case_depth(kMaxRange)
  kWorstClutter,    ///< make_worst_case_depth(kClutter), alternating phases
  kAllZero,         ///< no valid pixel
  kAllSaturated,    ///< every pixel 65535
  kFarPose,         ///< a valid camera 20-30 km from the origin
  kTimeJump,        ///< a scene frame one hour after the previous one
  kRandomRotation,  ///< a scene image under a random unit quaternion
  // Refused by the pipeline (counted as failed).
  kNanPose,
  kInfPose,
  kNonUnitQuaternion,
  kOutOfRangePose,  ///< 1e6 m, beyond the map's key range
  kHugePose,        ///< 1e30 m
  kFltMaxPose,
  kTimeRepeat,  ///< the last accepted stamp again
  kTimeBack,    ///< one second before the last accepted stamp
  kSmallImage,  ///< half the camera's size (copied by the runner, refused by the pipeline)
  // Refused by Runner::submit (counted as rejected_bad).
  kNullData,
  kOddStride,
  kShortStride,
  kMisaligned,
  kOversize,  ///< wider than the runner's slots
  kCount
};
inline constexpr std::size_t kSoakKinds = static_cast<std::size_t>(SoakKind::kCount);
inline constexpr SoakKind kFirstPipelineRefused = SoakKind::kNanPose;
inline constexpr SoakKind kFirstSubmitRefused = SoakKind::kNullData;

inline const char* to_string(SoakKind k) {
  static constexpr std::array<const char*, kSoakKinds> names = {
      "scene",           "noisy_scene",         "random_depth",      "padded_stride",
      "worst_max_range", "worst_clutter",       "all_zero",          "all_saturated",
      "far_pose",        "time_jump",           "random_rotation",   "nan_pose",
      "inf_pose",        "non_unit_quaternion", "out_of_range_pose", "huge_pose",
      "flt_max_pose",    "time_repeat",         "time_back",         "small_image",
      "null_data",       "odd_stride",          "short_stride",      "misaligned",
      "oversize"};
  return names[static_cast<std::size_t>(k)];
}

inline bool pipeline_refuses(SoakKind k) {
  return k >= kFirstPipelineRefused && k < kFirstSubmitRefused;
}
inline bool submit_refuses(SoakKind k) {
  return k >= kFirstSubmitRefused;
}

/// Relative frequency of each kind (per mille): three quarters of the frames are accepted.
inline constexpr std::array<std::uint32_t, kSoakKinds> kSoakWeights = {
    420, 120, 40, 30, 25, 25, 15, 15, 15, 5, 30,  // accepted: 740
    25,  25,  25, 25, 20, 20, 25, 25, 20,         // refused by the pipeline: 210
    10,  10,  10, 10, 10};                        // refused by submit: 50

/// Deterministic frame source. Frames point into the source's own buffers, valid until the next
/// call. Stamps advance 33.3 ms per frame (an hour for kTimeJump); the refused-stamp kinds are
/// relative to the last stamp that will be accepted.
class SoakInput {
 public:
  static constexpr int kSceneImages = 32;
  static constexpr Stamp kFrameNs = 33'333'333;

  SoakInput(const CameraIntrinsics& cam, float max_depth_m, std::uint64_t seed)
      : cam_(cam), max_depth_(max_depth_m), rng_(seed * 0x9E3779B97F4A7C15ULL + 1) {
    WorldScene scene;
    for (int k = 0; k < kSceneImages; ++k) {
      const float s = static_cast<float>(k) / kSceneImages;
      scene.boxes = {
          Box3::from_center_size(Eigen::Vector3f(6.f, 0.f, 1.5f), Eigen::Vector3f(0.2f, 10.f, 3.f)),
          Box3::from_center_size(Eigen::Vector3f(3.f, 3.f, 1.5f), Eigen::Vector3f(6.f, 0.2f, 3.f)),
          Box3::from_center_size(Eigen::Vector3f(2.f, -1.2f, 0.4f),
                                 Eigen::Vector3f(0.6f, 0.6f, 0.8f)),
          person_at(2.5f, -1.5f + 3.f * s), person_at(4.0f, 1.2f - 2.f * s)};
      scene_poses_[static_cast<std::size_t>(k)] =
          level_camera(Eigen::Vector3f(0.f, 0.f, 1.3f), 0.05f * std::sin(6.283f * s));
      std::vector<std::uint16_t> img;
      (void)render(scene, cam, scene_poses_[static_cast<std::size_t>(k)], img);
      scenes_.push_back(std::move(img));
    }
    // Room for a padded or odd stride, one byte of misalignment and an oversize header.
    const std::size_t cap = std::max(
        static_cast<std::size_t>(cam.width + 64) * static_cast<std::size_t>(cam.height + 1),
        static_cast<std::size_t>(kMaxImageWidth + 64));
    buffer_.assign(cap, 0);
  }

  /// Fills `frame` with the next input and returns its kind.
  SoakKind next(Frame& frame) {
    const SoakKind kind = count_ < 10 ? SoakKind::kScene : draw_kind();
    ++count_;
    stamp_ += kind == SoakKind::kTimeJump ? 3600ULL * 1'000'000'000ULL : kFrameNs;
    frame.stamp = stamp_;
    const std::size_t k = scene_index_++ % kSceneImages;
    frame.T_map_camera = scene_poses_[k];
    const int w = cam_.width;
    const int h = cam_.height;
    const int row = w * static_cast<int>(sizeof(std::uint16_t));
    frame.depth = DepthView{scenes_[k].data(), w, h, row};
    std::uint16_t* px = buffer_.data();
    switch (kind) {
      case SoakKind::kScene:
      case SoakKind::kTimeJump:
        break;
      case SoakKind::kNoisyScene:
        for (std::size_t i = 0; i < scenes_[k].size(); ++i) {
          const std::uint32_t r = next_u32();
          const std::uint16_t z = scenes_[k][i];
          if ((r & 31u) == 0) {
            px[i] = 0;  // hole
          } else if ((r & 127u) == 1) {
            px[i] = static_cast<std::uint16_t>(r >> 16);  // speckle anywhere in range
          } else {
            // +-3 % multiplicative noise.
            const float f = 1.f + 0.06f * (static_cast<float>((r >> 8) & 1023u) / 1023.f - 0.5f);
            px[i] = static_cast<std::uint16_t>(std::min(65535.f, static_cast<float>(z) * f));
          }
        }
        frame.depth.data = px;
        break;
      case SoakKind::kRandomDepth:
        for (std::size_t i = 0; i < scenes_[k].size(); ++i) {
          px[i] = static_cast<std::uint16_t>(next_u32() >> 16);
        }
        frame.depth.data = px;
        break;
      case SoakKind::kPaddedStride: {
        const int stride_px = w + 16;
        for (int v = 0; v < h; ++v) {
          std::copy_n(scenes_[k].data() + static_cast<std::size_t>(v) * w, w,
                      px + static_cast<std::size_t>(v) * stride_px);
        }
        frame.depth = DepthView{px, w, h, stride_px * static_cast<int>(sizeof(std::uint16_t))};
        break;
      }
      case SoakKind::kWorstMaxRange:
        frame.depth = make_worst_case_depth(WorstCase::kMaxRange, cam_, max_depth_, 0, px);
        break;
      case SoakKind::kWorstClutter:
        frame.depth = make_worst_case_depth(WorstCase::kClutter, cam_, max_depth_, kMaxDetections,
                                            px, clutter_phase_++);
        break;
      case SoakKind::kAllZero:
      case SoakKind::kAllSaturated:
        std::fill_n(px, scenes_[k].size(), kind == SoakKind::kAllZero ? 0 : 65535);
        frame.depth.data = px;
        break;
      case SoakKind::kFarPose:
        frame.T_map_camera.translation +=
            Eigen::Vector3f(2e4f + static_cast<float>(next_u32() % 10000u), -2e4f, 3.f);
        break;
      case SoakKind::kRandomRotation: {
        Eigen::Quaternionf q(uniform() - 0.5f, uniform() - 0.5f, uniform() - 0.5f,
                             uniform() - 0.5f);
        if (q.norm() < 1e-3f) q = Eigen::Quaternionf::Identity();
        frame.T_map_camera.rotation = q.normalized();
        break;
      }
      case SoakKind::kNanPose:
        frame.T_map_camera.translation.y() = std::numeric_limits<float>::quiet_NaN();
        break;
      case SoakKind::kInfPose:
        frame.T_map_camera.rotation.w() = std::numeric_limits<float>::infinity();
        break;
      case SoakKind::kNonUnitQuaternion:
        frame.T_map_camera.rotation.coeffs() *= 1.1f;
        break;
      case SoakKind::kOutOfRangePose:
        frame.T_map_camera.translation.x() = 1e6f;
        break;
      case SoakKind::kHugePose:
        frame.T_map_camera.translation = Eigen::Vector3f(1e30f, -1e30f, 1e30f);
        break;
      case SoakKind::kFltMaxPose:
        frame.T_map_camera.translation.z() = FLT_MAX;
        break;
      case SoakKind::kTimeRepeat:
        frame.stamp = last_accepted_;
        break;
      case SoakKind::kTimeBack:
        frame.stamp = last_accepted_ - std::min<Stamp>(last_accepted_, 1'000'000'000ULL);
        break;
      case SoakKind::kSmallImage:
        frame.depth = DepthView{scenes_[k].data(), w / 2, h / 2, row};
        break;
      case SoakKind::kNullData:
        frame.depth.data = nullptr;
        break;
      case SoakKind::kOddStride:
        frame.depth = DepthView{px, w, h, row + 1};
        break;
      case SoakKind::kShortStride:
        frame.depth = DepthView{px, w, h, row - 2};
        break;
      case SoakKind::kMisaligned:
        frame.depth.data =
            reinterpret_cast<const std::uint16_t*>(reinterpret_cast<const std::uint8_t*>(px) + 1);
        break;
      case SoakKind::kOversize:
        frame.depth = DepthView{px, kMaxImageWidth + 1, 1,
                                (kMaxImageWidth + 1) * static_cast<int>(sizeof(std::uint16_t))};
        break;
      case SoakKind::kCount:
        break;
    }
    if (!pipeline_refuses(kind) && !submit_refuses(kind)) last_accepted_ = frame.stamp;
    ++sent_[static_cast<std::size_t>(kind)];
    return kind;
  }

  /// Frames of each kind produced so far.
  const std::array<std::uint64_t, kSoakKinds>& sent() const { return sent_; }

 private:
  std::uint32_t next_u32() {
    // xorshift64*
    rng_ ^= rng_ >> 12;
    rng_ ^= rng_ << 25;
    rng_ ^= rng_ >> 27;
    return static_cast<std::uint32_t>((rng_ * 0x2545F4914F6CDD1DULL) >> 32);
  }
  float uniform() { return static_cast<float>(next_u32() >> 8) / 16777216.f; }
  SoakKind draw_kind() {
    std::uint32_t r = next_u32() % 1000u;
    for (std::size_t i = 0; i < kSoakKinds; ++i) {
      if (r < kSoakWeights[i]) return static_cast<SoakKind>(i);
      r -= kSoakWeights[i];
    }
    return SoakKind::kScene;
  }

  CameraIntrinsics cam_;
  float max_depth_;
  std::uint64_t rng_;
  std::vector<std::vector<std::uint16_t>> scenes_;
  std::array<Pose, kSceneImages> scene_poses_{};
  std::vector<std::uint16_t> buffer_;
  std::uint64_t count_ = 0;
  std::size_t scene_index_ = 0;
  unsigned clutter_phase_ = 0;
  Stamp stamp_ = 0;
  Stamp last_accepted_ = 0;
  std::array<std::uint64_t, kSoakKinds> sent_{};
};

/// Resident set size of this process, bytes (Linux /proc/self/statm).
inline std::uint64_t resident_bytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (f == nullptr) return 0;
  unsigned long long size = 0, resident = 0;
  const int n = std::fscanf(f, "%llu %llu", &size, &resident);
  std::fclose(f);
  return n == 2 ? resident * static_cast<std::uint64_t>(::sysconf(_SC_PAGESIZE)) : 0;
}

/// Figures at one checkpoint (cumulative counters; timing over the frames since the previous
/// checkpoint, from the pipeline's own frame statistics).
struct SoakCheckpoint {
  std::uint64_t frames = 0;  ///< frames produced so far
  std::uint64_t rss_bytes = 0;
  std::uint64_t worst_frame_ns = 0;
  std::uint64_t median_frame_ns = 0;
  std::uint64_t p999_frame_ns = 0;  ///< 99.9th percentile (histogram bucket)
  std::uint64_t over_budget = 0;    ///< frames over budgets.frame_ns (when set)
  std::uint64_t submit_calls = 0;
  RunnerCounters runner{};
  PipelineCounters pipeline{};
  std::uint64_t snapshots_seen = 0;  ///< outputs the planner thread took
  std::uint64_t bad_snapshots = 0;   ///< of those: non-finite boxes/velocities, too many
  std::array<std::uint64_t, kSoakKinds> sent{};
};

/// What every checkpoint must satisfy; an empty string when it holds, else the first problem.
inline const char* soak_counter_problem(const SoakCheckpoint& c) {
  const RunnerCounters& r = c.runner;
  std::uint64_t accepted = 0, pipeline_refused = 0, submit_refused = 0;
  for (std::size_t i = 0; i < kSoakKinds; ++i) {
    const auto k = static_cast<SoakKind>(i);
    (submit_refuses(k)     ? submit_refused
     : pipeline_refuses(k) ? pipeline_refused
                           : accepted) += c.sent[i];
  }
  if (r.submitted + r.rejected_full + r.rejected_bad + r.rejected_stopped != c.submit_calls) {
    return "submit calls != submitted + rejected (full, bad, stopped)";
  }
  if (r.processed + r.failed + r.dropped_at_stop != r.submitted) {
    return "submitted != processed + failed + dropped_at_stop";
  }
  if (r.dropped_at_stop != 0) return "frames dropped although the ring was drained";
  if (r.rejected_stopped != 0) return "frames refused as stopped while running";
  if (r.processed != accepted) return "processed != frames of the accepted kinds";
  if (r.failed != pipeline_refused) return "failed != frames of the kinds the pipeline refuses";
  if (r.rejected_bad != submit_refused) return "rejected_bad != frames submit() must refuse";
  if (c.pipeline.frames_processed != r.processed) return "pipeline and runner disagree (processed)";
  if (c.pipeline.frames_rejected != r.failed) return "pipeline and runner disagree (rejected)";
  if (c.bad_snapshots != 0) return "a published output had non-finite obstacles";
  return "";
}

/// Runs `frames` frames through a Runner on `pipeline` (initialised; its clock is what the
/// timing figures use), calling `report(checkpoint)` every `checkpoint_every` frames. Between
/// checkpoints the runner runs freely; at a checkpoint the sensor waits until the ring is
/// drained, stops the runner (reading the pipeline's statistics is only safe then), reports and
/// starts it again, so stop/start is exercised too. Returns false if the runner could not start
/// or the ring did not drain within a minute.
template <class Report>
bool run_soak(Pipeline& pipeline, std::uint64_t frames, std::uint64_t checkpoint_every,
              std::uint64_t seed, Report&& report) {
  const PipelineConfig& cfg = pipeline.config();
  SoakInput input(cfg.camera, cfg.map.max_depth, seed);
  auto runner_owner = std::make_unique<Runner>(pipeline);  // ~2.5 MB of slots: not on a stack
  Runner& runner = *runner_owner;
  std::uint64_t submit_calls = 0;
  std::atomic<bool> planner_stop{false};
  std::atomic<std::uint64_t> seen{0}, bad{0};
  pipeline.reset_timing();
  for (std::uint64_t done = 0; done < frames;) {
    if (!ok(runner.start())) return false;
    planner_stop = false;
    std::thread planner([&] {
      while (!planner_stop.load()) {
        if (!runner.poll()) {
          std::this_thread::sleep_for(std::chrono::microseconds(200));
          continue;
        }
        const FrameOutput& o = runner.latest();
        ++seen;
        bool good = o.num_obstacles <= kMaxTracks;
        for (std::size_t i = 0; good && i < o.num_obstacles; ++i) {
          good = o.obstacles[i].box.min.allFinite() && o.obstacles[i].box.max.allFinite() &&
                 o.obstacles[i].velocity.allFinite();
        }
        if (!good) ++bad;
      }
    });
    const std::uint64_t block_end = std::min(frames, done + checkpoint_every);
    for (; done < block_end; ++done) {
      Frame f;
      (void)input.next(f);
      for (;;) {
        ++submit_calls;
        if (runner.submit(f) != Status::kCapacityExceeded) break;
        std::this_thread::sleep_for(std::chrono::microseconds(100));  // the worker is busy
      }
    }
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(1);
    for (;;) {
      const RunnerCounters c = runner.counters();
      if (c.processed + c.failed == c.submitted) break;
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    runner.stop();
    planner_stop = true;
    planner.join();
    SoakCheckpoint cp;
    cp.frames = done;
    cp.rss_bytes = resident_bytes();
    cp.worst_frame_ns = pipeline.frame_stats().max_ns();
    cp.median_frame_ns = pipeline.frame_stats().p50_ns();
    cp.p999_frame_ns = pipeline.frame_stats().percentile_ns(999);
    cp.over_budget = pipeline.frame_stats().overruns();
    cp.submit_calls = submit_calls;
    cp.runner = runner.counters();
    cp.pipeline = pipeline.counters();
    cp.snapshots_seen = seen.load();
    cp.bad_snapshots = bad.load();
    cp.sent = input.sent();
    pipeline.reset_timing();
    report(cp);
  }
  return true;
}

}  // namespace dynamap::test
