#include <atomic>
#include <memory>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "alloc_guard.hpp"
#include "dynamap/runner.hpp"
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
  // Starting drains what was queued; stop() waits for it.
  ASSERT_EQ(r->start(), Status::kOk);
  r->stop();
  EXPECT_EQ(r->counters().processed, kRunnerInputSlots);
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
    while (!producer_done.load() || r->counters().published < r->counters().submitted) {
      if (r->poll()) {
        const FrameOutput& out = r->latest();
        if (out.status == Status::kOk) {
          if (out.stamp <= last) monotonic = false;
          last = out.stamp;
        }
        ++snapshots;
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
