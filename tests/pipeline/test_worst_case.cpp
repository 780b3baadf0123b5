// The worst-case frames (make_worst_case_depth) against the work bound worst_case_work()
// derives from the configuration: work counters, not time (time is bench_worst_case's).
#include <algorithm>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/testing/worst_case.hpp"
#include "world_scene.hpp"

namespace dynamap {
namespace {

constexpr Stamp kFrameNs = 33'333'333;

/// The largest work of any frame of a run, counted the way the bound counts it.
struct Work {
  std::size_t rays = 0, voxel_visits = 0, detections = 0, tracks = 0, path_samples = 0,
              voxels_cleaned = 0;
};

std::size_t path_samples(const FrameOutput& out) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < out.num_predictions; ++i) {
    n += out.predictions[i].num_paths * out.predictions[i].num_samples;
    n += out.linear_predictions[i].num_paths * out.linear_predictions[i].num_samples;
  }
  return n;
}

/// Runs `frames` worst-case frames of `kind` on a fresh pipeline and checks every frame's work
/// against the configuration's bound; returns the largest work seen.
Work run_and_check(const PipelineConfig& cfg, WorstCase kind, unsigned frames) {
  auto p = std::make_unique<Pipeline>();
  auto out = std::make_unique<FrameOutput>();
  EXPECT_EQ(p->init(cfg), Status::kOk);
  const WorstCaseWork bound = worst_case_work(cfg);
  std::vector<std::uint16_t> px(static_cast<std::size_t>(cfg.camera.width * cfg.camera.height));
  Work m;
  for (unsigned i = 0; i < frames; ++i) {
    Frame f;
    f.T_map_camera = test::level_camera(Eigen::Vector3f(0.f, 0.f, 1.3f));
    f.depth =
        make_worst_case_depth(kind, cfg.camera, cfg.map.max_depth, kMaxDetections, px.data(), i);
    f.stamp = (i + 1) * kFrameNs;
    EXPECT_EQ(p->process(f, *out), Status::kOk);
    const FrameWork& w = out->work;
    EXPECT_LE(w.rays, bound.rays) << "frame " << i;
    EXPECT_LE(w.voxel_visits, bound.voxel_visits) << "frame " << i;
    EXPECT_LE(w.detections, bound.detections) << "frame " << i;
    EXPECT_LE(w.tracks, bound.tracks) << "frame " << i;
    EXPECT_LE(path_samples(*out), bound.path_samples) << "frame " << i;
    EXPECT_LE(w.voxels_cleaned, bound.cleaner_voxels) << "frame " << i;
    m.rays = std::max(m.rays, w.rays);
    m.voxel_visits = std::max(m.voxel_visits, w.voxel_visits);
    m.detections = std::max(m.detections, w.detections);
    m.tracks = std::max(m.tracks, w.tracks);
    m.path_samples = std::max(m.path_samples, path_samples(*out));
    m.voxels_cleaned = std::max(m.voxels_cleaned, w.voxels_cleaned);
  }
  return m;
}

TEST(WorstCaseFrames, DefaultsStayWithinTheDerivedBoundAndExerciseEveryStage) {
  const PipelineConfig cfg;
  const Work range = run_and_check(cfg, WorstCase::kMaxRange, 3);
  EXPECT_GT(range.voxel_visits, range.rays * 10) << "max-range rays must be long";
  const Work clutter = run_and_check(cfg, WorstCase::kClutter, 6);
  EXPECT_GE(clutter.detections, 18u);
  EXPECT_EQ(clutter.tracks, kMaxTracks);
  // Approaching bars live long enough to be classified dynamic and predicted (from the tenth
  // frame on).
  const Work approach = run_and_check(cfg, WorstCase::kApproach, 16);
  EXPECT_GT(approach.path_samples, 0u) << "no prediction: the predictors were not exercised";
  EXPECT_GT(approach.tracks, 10u);
}

TEST(WorstCaseFrames, LargestAcceptedCapsStayWithinTheDerivedBound) {
  const PipelineConfig cfg = largest_work_caps();
  ASSERT_TRUE(validate(cfg).ok());
  const Work range = run_and_check(cfg, WorstCase::kMaxRange, 3);
  EXPECT_GT(range.rays, 0u);
  const Work approach = run_and_check(cfg, WorstCase::kApproach, 16);
  EXPECT_GT(approach.path_samples, 0u);
}

// With small caps the worst-case frames reach each cap and stop exactly there: the counters
// are bounded by the configuration, not by what the frames happen to need.
TEST(WorstCaseFrames, SmallCapsAreReachedAndNeverExceeded) {
  PipelineConfig rays;
  rays.map.max_rays_per_frame = 2000;
  EXPECT_EQ(worst_case_work(rays).rays, 2000u);
  EXPECT_EQ(run_and_check(rays, WorstCase::kMaxRange, 2).rays, 2000u);

  PipelineConfig visits;
  visits.map.max_voxel_visits_per_frame = 30'000;
  EXPECT_EQ(worst_case_work(visits).voxel_visits, 30'000u);
  EXPECT_EQ(run_and_check(visits, WorstCase::kMaxRange, 2).voxel_visits, 30'000u);

  PipelineConfig detections;
  detections.detector.max_detections = 6;
  EXPECT_EQ(worst_case_work(detections).detections, 6u);
  EXPECT_EQ(run_and_check(detections, WorstCase::kClutter, 4).detections, 6u);
}

}  // namespace
}  // namespace dynamap
