#include <atomic>
#include <chrono>
#include <cstdio>
#include <memory>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_guard.hpp"
#include "dynamap/pipeline/runner.hpp"
#include "world_scene.hpp"

namespace dynamap {
namespace {

// A small camera keeps thousands of frames quick under TSan and qemu.
PipelineConfig tiny_config() {
  PipelineConfig c;
  c.camera.width = 80;
  c.camera.height = 60;
  c.camera.fx = c.camera.fy = 75.f;
  c.camera.cx = 40.f;
  c.camera.cy = 30.f;
  c.detector.min_segment_length = 3;
  c.detector.min_area = 6;
  return c;
}

TEST(Runner, StartNeedsAnInitialisedPipeline) {
  auto p = std::make_unique<Pipeline>();
  auto r = std::make_unique<Runner>(*p);
  EXPECT_EQ(r->start(), Status::kNotInitialized);
  EXPECT_FALSE(r->running());
}

TEST(Runner, SubmitRejectsFramesItCannotCopy) {
  auto p = std::make_unique<Pipeline>();
  ASSERT_EQ(p->init(tiny_config()), Status::kOk);
  auto r = std::make_unique<Runner>(*p);
  Frame f;
  EXPECT_EQ(r->submit(f), Status::kNullData);
  std::vector<std::uint16_t> big(1000 * 1000);
  f.depth = DepthView{big.data(), 1000, 1000, 2000};
  EXPECT_EQ(r->submit(f), Status::kWrongSize);
  EXPECT_EQ(r->counters().rejected_bad, 2u);
  EXPECT_EQ(r->counters().submitted, 0u);
}

TEST(Runner, FullRingRejectsAndCountsWithoutBlocking) {
  auto p = std::make_unique<Pipeline>();
  const PipelineConfig cfg = tiny_config();
  ASSERT_EQ(p->init(cfg), Status::kOk);
  auto r = std::make_unique<Runner>(*p);  // not started: nothing drains the ring
  std::vector<std::uint16_t> px(static_cast<std::size_t>(cfg.camera.width * cfg.camera.height),
                                2000);
  Frame f;
  f.depth = DepthView{px.data(), cfg.camera.width, cfg.camera.height, cfg.camera.width * 2};
  for (std::size_t i = 0; i < kRunnerInputSlots; ++i) {
    f.stamp = i + 1;
    EXPECT_EQ(r->submit(f), Status::kOk);
  }
  f.stamp = 100;
  EXPECT_EQ(r->submit(f), Status::kCapacityExceeded);
  EXPECT_EQ(r->counters().rejected_full, 1u);
  // Starting drains what was queued (stop() would drop what is still queued).
  ASSERT_EQ(r->start(), Status::kOk);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (r->counters().processed < kRunnerInputSlots &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  r->stop();
  EXPECT_EQ(r->counters().processed, kRunnerInputSlots);
  EXPECT_EQ(r->counters().dropped_at_stop, 0u);
}

TEST(Runner, SubmitRejectsAnOddStride) {
  auto p = std::make_unique<Pipeline>();
  const PipelineConfig cfg = tiny_config();
  ASSERT_EQ(p->init(cfg), Status::kOk);
  auto r = std::make_unique<Runner>(*p);
  std::vector<std::uint16_t> px(static_cast<std::size_t>(cfg.camera.width * cfg.camera.height),
                                2000);
  Frame f;
  f.depth = DepthView{px.data(), cfg.camera.width, cfg.camera.height - 1, cfg.camera.width * 2 + 1};
  EXPECT_EQ(r->submit(f), Status::kWrongSize);
  EXPECT_EQ(r->counters().rejected_bad, 1u);
}

// A sensor thread that never stops submitting: stop() still returns within about one frame's
// processing time, submit() refuses from the request on, and every frame is accounted for.
TEST(Runner, StopReturnsPromptlyWhileTheSensorKeepsSubmitting) {
  auto p = std::make_unique<Pipeline>();
  const PipelineConfig cfg = tiny_config();
  ASSERT_EQ(p->init(cfg), Status::kOk);
  auto r = std::make_unique<Runner>(*p);
  ASSERT_EQ(r->start(), Status::kOk);
  std::vector<std::uint16_t> px(static_cast<std::size_t>(cfg.camera.width * cfg.camera.height),
                                2000);
  std::atomic<bool> stop_returned{false};
  std::atomic<std::uint64_t> ok_count{0}, full_count{0}, stopped_count{0}, other_count{0};
  std::atomic<std::uint64_t> stopped_after_return{0}, ok_after_return{0};
  const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  std::thread sensor([&] {
    // Keeps submitting until well after stop() returned (or, with a stop() that waits for the
    // sensor, until the give-up time: then stop() returns late and the test fails on time).
    std::uint64_t after = 0;
    for (Stamp i = 1; after < 100 && std::chrono::steady_clock::now() < give_up; ++i) {
      Frame f;
      f.stamp = i * 1'000'000ULL;
      f.depth = DepthView{px.data(), cfg.camera.width, cfg.camera.height, cfg.camera.width * 2};
      const bool returned = stop_returned.load();
      const Status s = r->submit(f);
      if (s == Status::kOk) {
        ++ok_count;
        if (returned) ++ok_after_return;
      } else if (s == Status::kCapacityExceeded) {
        ++full_count;
      } else if (s == Status::kStopped) {
        ++stopped_count;
        if (returned) ++stopped_after_return;
      } else {
        ++other_count;
      }
      if (returned) ++after;
    }
  });
  while (r->counters().processed < 20) std::this_thread::yield();
  const auto t0 = std::chrono::steady_clock::now();
  r->stop();
  const double stop_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  stop_returned = true;
  sensor.join();
  EXPECT_LT(stop_s, 1.0) << "stop() waited for the sensor thread";
  EXPECT_FALSE(r->running());
  EXPECT_EQ(ok_after_return.load(), 0u);
  EXPECT_GE(stopped_after_return.load(), 100u);
  EXPECT_EQ(other_count.load(), 0u);
  const RunnerCounters c = r->counters();
  EXPECT_EQ(c.submitted, ok_count.load());
  EXPECT_EQ(c.rejected_full, full_count.load());
  EXPECT_EQ(c.rejected_stopped, stopped_count.load());
  EXPECT_EQ(c.processed + c.failed + c.dropped_at_stop, c.submitted) << "a frame was lost";
  // Nothing is left behind: a submit after the final stop is refused, not queued.
  Frame late;
  late.stamp = 1ULL << 60;
  late.depth = DepthView{px.data(), cfg.camera.width, cfg.camera.height, cfg.camera.width * 2};
  EXPECT_EQ(r->submit(late), Status::kStopped);
  r->stop();
  EXPECT_EQ(r->counters().submitted, c.submitted);
  EXPECT_EQ(r->counters().dropped_at_stop, c.dropped_at_stop);
  // A restart accepts frames again.
  ASSERT_EQ(r->start(), Status::kOk);
  EXPECT_EQ(r->submit(late), Status::kOk);
  r->stop();
  const RunnerCounters d = r->counters();
  EXPECT_EQ(d.processed + d.failed + d.dropped_at_stop, d.submitted);
}

TEST(Runner, StopWithoutStartDropsAndCountsQueuedFrames) {
  auto p = std::make_unique<Pipeline>();
  const PipelineConfig cfg = tiny_config();
  ASSERT_EQ(p->init(cfg), Status::kOk);
  auto r = std::make_unique<Runner>(*p);
  std::vector<std::uint16_t> px(static_cast<std::size_t>(cfg.camera.width * cfg.camera.height),
                                2000);
  Frame f;
  f.depth = DepthView{px.data(), cfg.camera.width, cfg.camera.height, cfg.camera.width * 2};
  f.stamp = 1;
  ASSERT_EQ(r->submit(f), Status::kOk);
  r->stop();
  EXPECT_EQ(r->counters().dropped_at_stop, 1u);
  EXPECT_EQ(r->submit(f), Status::kStopped);
}

TEST(Runner, ThreeThreadStressLosesNothingButCountedRejections) {
  auto p = std::make_unique<Pipeline>();
  const PipelineConfig cfg = tiny_config();
  ASSERT_EQ(p->init(cfg), Status::kOk);
  auto r = std::make_unique<Runner>(*p);
  ASSERT_EQ(r->start(), Status::kOk);

  constexpr int kFrames = 3000;
  std::atomic<bool> producer_done{false};
  std::atomic<std::size_t> producer_allocations{0};
  std::atomic<int> accepted{0}, rejected{0};

  // Sensor thread: a person walking in front of a wall, frames rendered up front.
  std::thread sensor([&] {
    test::WorldScene scene;
    std::vector<std::vector<std::uint16_t>> images(64);
    std::vector<Pose> poses(64);
    for (std::size_t k = 0; k < images.size(); ++k) {
      scene.boxes = {
          test::person_at(2.5f, -1.f + 0.03f * static_cast<float>(k)),
          Box3::from_center_size(Eigen::Vector3f(4.f, 0.f, 1.5f), Eigen::Vector3f(0.2f, 8.f, 3.f))};
      poses[k] = test::level_camera(Eigen::Vector3f(0.f, 0.f, 1.2f));
      (void)test::render(scene, cfg.camera, poses[k], images[k]);
    }
    test::AllocationGuard guard;  // the steady state of the sensor side never allocates
    for (int i = 0; i < kFrames; ++i) {
      const std::size_t k = static_cast<std::size_t>(i) % images.size();
      Frame f;
      f.stamp = static_cast<Stamp>(i + 1) * 1'000'000ULL;
      f.T_map_camera = poses[k];
      f.depth =
          DepthView{images[k].data(), cfg.camera.width, cfg.camera.height, cfg.camera.width * 2};
      if (ok(r->submit(f))) {
        ++accepted;
      } else {
        ++rejected;
        std::this_thread::yield();
      }
    }
    producer_allocations = guard.allocations();
    producer_done = true;
  });

  // Planner thread: takes the newest snapshots; stamps must never go backwards.
  std::size_t snapshots = 0;
  std::size_t planner_allocations = 0;
  bool monotonic = true;
  std::thread planner([&] {
    Stamp last = 0;
    test::AllocationGuard guard;
    // Polls until the sensor is done and every accepted frame is published, and at least once
    // after that: a planner thread scheduled late on a loaded machine still takes the last one.
    for (;;) {
      const bool all_published =
          producer_done.load() && r->counters().published >= r->counters().submitted;
      if (r->poll()) {
        const FrameOutput& out = r->latest();
        if (out.status == Status::kOk) {
          if (out.stamp <= last) monotonic = false;
          last = out.stamp;
        }
        ++snapshots;
      } else if (all_published) {
        break;
      } else {
        std::this_thread::yield();
      }
    }
    planner_allocations = guard.allocations();
  });
  sensor.join();
  planner.join();
  r->stop();

  const RunnerCounters c = r->counters();
  EXPECT_EQ(c.submitted + c.rejected_full, static_cast<std::uint64_t>(kFrames));
  EXPECT_EQ(c.submitted, static_cast<std::uint64_t>(accepted.load()));
  EXPECT_EQ(c.rejected_full, static_cast<std::uint64_t>(rejected.load()));
  EXPECT_EQ(c.processed + c.failed, c.submitted) << "an accepted frame was lost";
  EXPECT_EQ(c.failed, 0u);
  EXPECT_EQ(c.published, c.submitted);
  EXPECT_GT(snapshots, 0u);
  EXPECT_TRUE(monotonic);
  EXPECT_EQ(producer_allocations.load(), 0u);
  EXPECT_EQ(planner_allocations, 0u);
  EXPECT_EQ(p->counters().frames_processed, c.processed);
}

}  // namespace
}  // namespace dynamap

namespace dynamap {
namespace {

// ---- team threads (issue 17) ------------------------------------------------------------------

// The pipeline reads its clock on the thread running process() and, around the detection's
// parts, on the team's helper. This clock makes every read 2 ms slow on the process() thread
// (so the helper gets to claim a detection part) and 20 ms slow on the helper.
std::atomic<int> g_slow_calls{0};
std::atomic<std::thread::id> g_process_thread{};
std::uint64_t slow_helper_clock() {
  std::thread::id none{};
  g_process_thread.compare_exchange_strong(none, std::this_thread::get_id());  // first reader
  if (g_process_thread.load() != std::this_thread::get_id()) {
    g_slow_calls.fetch_add(1);
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  } else {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::nanoseconds>(
                                        std::chrono::steady_clock::now().time_since_epoch())
                                        .count());
}

// stop() while a frame is in flight on the pipeline's team (one member is 20 ms slow): the frame
// completes, stop() returns, the team's helpers are joined with the pipeline, nothing is lost.
TEST(Runner, StopWhileAFrameIsInFlightOnTheTeamIsClean) {
  auto p = std::make_unique<Pipeline>();
  PipelineConfig cfg = tiny_config();
  cfg.map.carve_tiles = 4;
  cfg.team.members = 2;
  ASSERT_EQ(p->init(cfg), Status::kOk);
  g_process_thread = std::thread::id{};
  g_slow_calls = 0;
  p->set_clock(&slow_helper_clock);
  auto r = std::make_unique<Runner>(*p);
  ASSERT_EQ(r->start(), Status::kOk);
  std::vector<std::uint16_t> px(static_cast<std::size_t>(cfg.camera.width * cfg.camera.height),
                                2000);
  for (Stamp i = 1; i <= 3; ++i) {
    Frame f;
    f.stamp = i * 1'000'000ULL;
    f.depth = DepthView{px.data(), cfg.camera.width, cfg.camera.height, cfg.camera.width * 2};
    EXPECT_EQ(r->submit(f), Status::kOk);
  }
  // A frame is on the team (unless every frame's detection ran on the process() thread alone).
  while (g_slow_calls.load() == 0 && r->counters().processed < 3) std::this_thread::yield();
  const int slow_before_stop = g_slow_calls.load();
  r->stop();
  EXPECT_FALSE(r->running());
  std::printf("[ runner ] helper clock reads before stop: %d\n", slow_before_stop);
  const RunnerCounters c = r->counters();
  EXPECT_GE(c.processed, 1u);
  EXPECT_EQ(c.processed + c.failed + c.dropped_at_stop, c.submitted) << "a frame was lost";
  EXPECT_EQ(c.failed, 0u);
  r.reset();
  p.reset();  // joins the team's helpers
}

}  // namespace
}  // namespace dynamap
