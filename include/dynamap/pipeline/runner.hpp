// Runner: the threaded wrapper around Pipeline. A sensor thread submit()s frames, which are
// copied into preallocated slots of a lock-free SPSC ring (never blocks: a full ring rejects and
// counts); a worker thread runs Pipeline::process(); a planner thread takes the newest output
// snapshot through a lock-free triple buffer. Three threads, no locks, no allocation after start.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/latest_value.hpp"
#include "dynamap/core/spsc_ring.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/platform/worker_thread.hpp"

namespace dynamap {

/// Input slots between the sensor and the worker (each holds a full 640x480 image, ~600 KB).
inline constexpr std::size_t kRunnerInputSlots = 4;

/// Worker scheduling and idle behaviour.
struct RunnerConfig {
  platform::ThreadOptions thread{};
  std::uint64_t idle_sleep_ns = 200'000;  ///< worker sleep when the input ring is empty
};

/// Cumulative counters, readable from any thread.
/// Every submit() call ends in exactly one of submitted, rejected_full, rejected_bad and
/// rejected_stopped; every submitted frame in exactly one of processed, failed and
/// dropped_at_stop (once the worker has stopped).
struct RunnerCounters {
  std::uint64_t submitted = 0;         ///< frames accepted into the ring
  std::uint64_t rejected_full = 0;     ///< frames rejected because the ring was full
  std::uint64_t rejected_bad = 0;      ///< frames rejected by submit() (null, too large)
  std::uint64_t rejected_stopped = 0;  ///< frames rejected because stop() was requested
  std::uint64_t processed = 0;         ///< frames the pipeline accepted
  std::uint64_t failed = 0;            ///< frames the pipeline rejected (bad pose, stamp ...)
  std::uint64_t dropped_at_stop = 0;   ///< frames still queued when the worker stopped
  std::uint64_t published = 0;         ///< output snapshots published
};

/// One input slot: a copy of a frame with its image (namespace scope: a nested class with
/// member initialisers is not default-constructible inside its enclosing class).
struct RunnerFrameSlot {
  Stamp stamp = 0;
  Pose pose{};
  int width = 0;
  int height = 0;
  std::array<std::uint16_t, static_cast<std::size_t>(kMaxImageWidth) * kMaxImageHeight> pixels{};
};

class Runner {
 public:
  /// The pipeline must be initialised and must outlive the runner; while running, only the
  /// worker touches it.
  explicit Runner(Pipeline& pipeline) noexcept : pipeline_(pipeline) {}
  Runner(const Runner&) = delete;
  Runner& operator=(const Runner&) = delete;
  ~Runner() { stop(); }

  /// Starts the worker (also after a stop(): submit() accepts frames again). kNotInitialized if
  /// the pipeline is not; a platform Status (e.g. kPermissionDenied for SCHED_FIFO without
  /// privilege) if the thread cannot be created.
  [[nodiscard]] Status start(const RunnerConfig& config = RunnerConfig{}) noexcept;
  /// Stops: from the request on, submit() refuses (kStopped, counted); the worker finishes the
  /// frame it is processing, if any, and starts no other; frames still queued are counted as
  /// dropped_at_stop; then the worker is joined. Returns within one frame's processing time
  /// whatever the sensor thread does. Frames queued before start() are dropped the same way by
  /// a stop() without a start(). Idempotent. Call it from one thread (the owner's).
  void stop() noexcept;
  bool running() const noexcept { return worker_.joinable(); }

  /// Sensor side (one thread): copies the frame into a free slot. Never blocks.
  /// kCapacityExceeded when the ring is full (counted), kNullData / kWrongSize /
  /// kInvalidArgument for a frame that cannot be copied (validate_depth_layout), kStopped once
  /// stop() has been requested (counted). Pose and stamp are checked later by the pipeline.
  [[nodiscard]] Status submit(const Frame& frame) noexcept;

  /// Planner side (one thread): true when a newer snapshot than the last one taken is there;
  /// read it with latest(). Never blocks.
  bool poll() noexcept { return outputs_.update(); }
  const FrameOutput& latest() const noexcept { return outputs_.read_buffer(); }

  RunnerCounters counters() const noexcept;

 private:
  using FrameSlot = RunnerFrameSlot;

  static void worker_entry(void* self) noexcept;
  void worker_loop() noexcept;
  Status push(const Frame& frame) noexcept;
  /// Consumer side, after the stop request: waits out a submit() that began before it, then
  /// empties the ring, counting each frame as dropped_at_stop.
  void drop_queued() noexcept;

  Pipeline& pipeline_;
  RunnerConfig config_{};
  platform::WorkerThread worker_{};
  std::atomic<bool> stop_requested_{false};
  /// submit() calls in progress past their stop check (0 or 1: one sensor thread).
  std::atomic<std::uint32_t> submitting_{0};
  SpscRing<FrameSlot, kRunnerInputSlots> inputs_{};
  LatestValue<FrameOutput> outputs_{};
  std::atomic<std::uint64_t> submitted_{0};
  std::atomic<std::uint64_t> rejected_bad_{0};
  std::atomic<std::uint64_t> rejected_stopped_{0};
  std::atomic<std::uint64_t> dropped_at_stop_{0};
  std::atomic<std::uint64_t> processed_{0};
  std::atomic<std::uint64_t> failed_{0};
};

}  // namespace dynamap
