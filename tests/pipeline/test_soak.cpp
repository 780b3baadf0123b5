// A short soak (the long one is bench_soak): 2,000 mixed simulated, noisy and adversarial frames
// through the threaded Runner. Checks the counters add up at every checkpoint (every submit()
// call and every submitted frame accounted for, each kind of frame ending where it must) and
// that memory does not grow after the warm-up. Timing is not checked here (bench_soak does).
#include <cstdint>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "soak.hpp"

namespace dynamap {
namespace {

// A 320x240 camera keeps 2,000 frames within seconds in the debug and sanitizer builds.
PipelineConfig soak_config() {
  PipelineConfig c;
  c.camera.width = 320;
  c.camera.height = 240;
  c.camera.fx = c.camera.fy = 270.f;
  c.camera.cx = 160.f;
  c.camera.cy = 120.f;
  return c;
}

TEST(Soak, CountersAddUpAndMemoryStaysFlatOver2000MixedFrames) {
  auto p = std::make_unique<Pipeline>();
  ASSERT_EQ(p->init(soak_config()), Status::kOk);
  std::vector<test::SoakCheckpoint> cps;
  ASSERT_TRUE(
      test::run_soak(*p, 2000, 400, 7, [&](const test::SoakCheckpoint& c) { cps.push_back(c); }));
  ASSERT_EQ(cps.size(), 5u);
  for (const auto& c : cps) EXPECT_STREQ(test::soak_counter_problem(c), "") << c.frames;
  const test::SoakCheckpoint& last = cps.back();
  // Every kind was sent, so every refusal path was taken.
  for (std::size_t i = 0; i < test::kSoakKinds; ++i) {
    if (static_cast<test::SoakKind>(i) == test::SoakKind::kTimeJump) continue;  // 0.5 %
    EXPECT_GT(last.sent[i], 0u) << test::to_string(static_cast<test::SoakKind>(i));
  }
  EXPECT_GT(last.runner.processed, 1000u);
  EXPECT_GT(last.snapshots_seen, 0u);
  // Memory after the warm-up (the first checkpoint) changes by at most 1 % (natively: under an
  // emulator RSS is the emulator's, whose translation cache grows with each new code path).
#ifdef DYNAMAP_TEST_EMULATED
  GTEST_SKIP() << "RSS not checked under an emulator";
#endif
  const double warm = static_cast<double>(cps.front().rss_bytes);
  ASSERT_GT(warm, 0.0);
  for (const auto& c : cps) {
    EXPECT_LE(static_cast<double>(c.rss_bytes), warm * 1.01) << "RSS grew by " << c.frames;
    EXPECT_GE(static_cast<double>(c.rss_bytes), warm * 0.99) << c.frames;
  }
}

// The checks would catch a lost frame: a checkpoint whose counters do not add up is reported.
TEST(Soak, CounterCheckNamesALostFrame) {
  test::SoakCheckpoint c;
  c.sent[static_cast<std::size_t>(test::SoakKind::kScene)] = 3;
  c.submit_calls = 3;
  c.runner.submitted = 3;
  c.runner.processed = 3;
  c.pipeline.frames_processed = 3;
  EXPECT_STREQ(test::soak_counter_problem(c), "");
  c.runner.processed = 2;
  EXPECT_STRNE(test::soak_counter_problem(c), "");
  c.runner.processed = 3;
  c.sent[static_cast<std::size_t>(test::SoakKind::kNanPose)] = 1;  // a NaN pose was accepted
  EXPECT_STRNE(test::soak_counter_problem(c), "");
}

}  // namespace
}  // namespace dynamap
