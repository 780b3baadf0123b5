#include "dynamap/pipeline/runner.hpp"

#include <cstring>

namespace dynamap {
namespace {
/// Pause while waiting out a submit() in progress at stop (it copies one frame, ~0.1 ms).
constexpr std::uint64_t kStopPollNs = 20'000;
}  // namespace

Status Runner::start(const RunnerConfig& config) noexcept {
  if (!pipeline_.initialized()) return Status::kNotInitialized;
  if (worker_.joinable()) return Status::kInvalidArgument;
  config_ = config;
  stop_requested_.store(false, std::memory_order_seq_cst);
  return worker_.start(&Runner::worker_entry, this, config.thread);
}

void Runner::stop() noexcept {
  stop_requested_.store(true, std::memory_order_seq_cst);
  if (worker_.joinable()) {
    (void)worker_.join();  // the worker drops what is queued before it returns
  } else {
    drop_queued();  // never started: this thread is the only consumer
  }
}

void Runner::drop_queued() noexcept {
  // Dekker-style hand-shake, all seq_cst: submit() raises submitting_ and then reads the stop
  // flag; stop() set the flag before this reads submitting_. So either that submit() saw the
  // flag and refuses, or this sees it in progress and waits until its frame is in the ring.
  while (submitting_.load(std::memory_order_seq_cst) != 0) {
    (void)platform::sleep_for_ns(kStopPollNs);
  }
  while (inputs_.try_front() != nullptr) {
    inputs_.pop_front();
    dropped_at_stop_.fetch_add(1, std::memory_order_relaxed);
  }
}

Status Runner::submit(const Frame& frame) noexcept {
  // Once the stop request is seen, calls refuse without announcing themselves, so the worker's
  // wait in drop_queued() covers at most the one call that straddled the request.
  if (stop_requested_.load(std::memory_order_seq_cst)) {
    rejected_stopped_.fetch_add(1, std::memory_order_relaxed);
    return Status::kStopped;
  }
  submitting_.fetch_add(1, std::memory_order_seq_cst);
  if (stop_requested_.load(std::memory_order_seq_cst)) {
    submitting_.fetch_sub(1, std::memory_order_seq_cst);
    rejected_stopped_.fetch_add(1, std::memory_order_relaxed);
    return Status::kStopped;
  }
  const Status s = push(frame);
  submitting_.fetch_sub(1, std::memory_order_seq_cst);
  return s;
}

Status Runner::push(const Frame& frame) noexcept {
  const DepthView& d = frame.depth;
  if (const Status s = validate_depth_layout(d); !ok(s)) {
    rejected_bad_.fetch_add(1, std::memory_order_relaxed);
    return s;
  }
  if (d.width > kMaxImageWidth || d.height > kMaxImageHeight) {
    rejected_bad_.fetch_add(1, std::memory_order_relaxed);
    return Status::kWrongSize;
  }
  FrameSlot* slot = inputs_.try_begin_push();
  if (slot == nullptr) return Status::kCapacityExceeded;  // the ring counts the drop
  slot->stamp = frame.stamp;
  slot->pose = frame.T_map_camera;
  slot->width = d.width;
  slot->height = d.height;
  const std::size_t row_bytes = static_cast<std::size_t>(d.width) * sizeof(std::uint16_t);
  for (int v = 0; v < d.height; ++v) {
    std::memcpy(slot->pixels.data() + static_cast<std::size_t>(v) * d.width, d.row(v), row_bytes);
  }
  inputs_.commit_push();
  submitted_.fetch_add(1, std::memory_order_relaxed);
  return Status::kOk;
}

RunnerCounters Runner::counters() const noexcept {
  RunnerCounters c;
  c.submitted = submitted_.load(std::memory_order_relaxed);
  c.rejected_full = inputs_.drops();
  c.rejected_bad = rejected_bad_.load(std::memory_order_relaxed);
  c.rejected_stopped = rejected_stopped_.load(std::memory_order_relaxed);
  c.processed = processed_.load(std::memory_order_relaxed);
  c.failed = failed_.load(std::memory_order_relaxed);
  c.dropped_at_stop = dropped_at_stop_.load(std::memory_order_relaxed);
  c.published = outputs_.publish_count();
  return c;
}

void Runner::worker_entry(void* self) noexcept {
  static_cast<Runner*>(self)->worker_loop();
}

void Runner::worker_loop() noexcept {
  for (;;) {
    // Checked before every frame, so after a stop request at most the frame in progress is
    // finished: stop() returns within one frame's processing time, however full the ring.
    if (stop_requested_.load(std::memory_order_seq_cst)) {
      drop_queued();
      return;
    }
    const FrameSlot* slot = inputs_.try_front();
    if (slot == nullptr) {
      (void)platform::sleep_for_ns(config_.idle_sleep_ns);
      continue;
    }
    Frame frame;
    frame.stamp = slot->stamp;
    frame.T_map_camera = slot->pose;
    frame.depth = DepthView{slot->pixels.data(), slot->width, slot->height,
                            slot->width * static_cast<int>(sizeof(std::uint16_t))};
    FrameOutput& out = outputs_.write_buffer();
    const Status s = pipeline_.process(frame, out);
    inputs_.pop_front();  // the pipeline does not keep the depth view past process()
    if (ok(s)) {
      processed_.fetch_add(1, std::memory_order_relaxed);
    } else {
      failed_.fetch_add(1, std::memory_order_relaxed);
    }
    outputs_.publish();  // failures are published too: out.status says why
  }
}

}  // namespace dynamap
