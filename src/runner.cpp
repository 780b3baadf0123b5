#include "dynamap/runner.hpp"

#include <cstring>

namespace dynamap {

Status Runner::start(const RunnerConfig& config) noexcept {
  if (!pipeline_.initialized()) return Status::kNotInitialized;
  if (worker_.joinable()) return Status::kInvalidArgument;
  config_ = config;
  stop_requested_.store(false, std::memory_order_relaxed);
  return worker_.start(&Runner::worker_entry, this, config.thread);
}

void Runner::stop() noexcept {
  if (!worker_.joinable()) return;
  stop_requested_.store(true, std::memory_order_release);
  (void)worker_.join();
}

Status Runner::submit(const Frame& frame) noexcept {
  const DepthView& d = frame.depth;
  if (d.data == nullptr) {
    rejected_bad_.fetch_add(1, std::memory_order_relaxed);
    return Status::kNullData;
  }
  if (d.width <= 0 || d.height <= 0 || d.width > kMaxImageWidth || d.height > kMaxImageHeight ||
      d.stride_bytes < d.width * static_cast<int>(sizeof(std::uint16_t))) {
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
  c.processed = processed_.load(std::memory_order_relaxed);
  c.failed = failed_.load(std::memory_order_relaxed);
  c.published = outputs_.publish_count();
  return c;
}

void Runner::worker_entry(void* self) noexcept {
  static_cast<Runner*>(self)->worker_loop();
}

void Runner::worker_loop() noexcept {
  for (;;) {
    const FrameSlot* slot = inputs_.try_front();
    if (slot == nullptr) {
      // Drain everything queued before honouring stop, so no accepted frame is lost.
      if (stop_requested_.load(std::memory_order_acquire) && inputs_.try_front() == nullptr) {
        return;
      }
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
