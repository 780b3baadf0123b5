#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>

#include "dynamap/track/continuity_filter.hpp"

namespace dynamap {
namespace {

TEST(ContinuityFilter, StraightMotionScoresOneAndReversalScoresLow) {
  std::array<Eigen::Vector2f, 21> p;
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = Eigen::Vector2f(0.1f * i, 0.05f * i);
  float c = -2.f;
  ASSERT_TRUE(continuity_score(p.data(), p.size(), 10, &c));
  EXPECT_NEAR(c, 1.f, 1e-5f);

  // Back and forth with period 2: displacements 10 frames apart are zero -> cosine 0.
  for (std::size_t i = 0; i < p.size(); ++i) p[i] = Eigen::Vector2f(i % 2 ? 0.3f : 0.f, 0.f);
  ASSERT_TRUE(continuity_score(p.data(), p.size(), 10, &c));
  EXPECT_NEAR(c, 0.f, 1e-6f);

  // A standing target with noisy positions: displacement directions are random, C_con ~ 0.
  std::mt19937 rng(11);
  std::normal_distribution<float> noise(0.f, 0.05f);
  float mean = 0.f;
  for (int trial = 0; trial < 50; ++trial) {
    for (auto& q : p) q = Eigen::Vector2f(noise(rng), noise(rng));
    ASSERT_TRUE(continuity_score(p.data(), p.size(), 10, &c));
    EXPECT_LT(c, ContinuityConfig{}.continuity_threshold);
    mean += c / 50.f;
  }
  EXPECT_NEAR(mean, 0.f, 0.1f);
}

TEST(ContinuityFilter, NeedsTwoDisplacements) {
  std::array<Eigen::Vector2f, 12> p;
  for (auto& q : p) q.setZero();
  float c = 5.f;
  EXPECT_FALSE(continuity_score(p.data(), 11, 10, &c));
  EXPECT_FLOAT_EQ(c, 5.f);
  EXPECT_TRUE(continuity_score(p.data(), 12, 10, &c));
  EXPECT_FALSE(continuity_score(nullptr, 12, 10, &c));
}

TEST(ContinuityFilter, VoteNeedsSpeedAndContinuityAtOrAboveThreshold) {
  ContinuityConfig cfg;
  const ContinuityFilter f(cfg);
  const Eigen::Vector3f person(0.5f, 0.5f, 1.7f);
  EXPECT_TRUE(f.vote(1.0f, cfg.continuity_threshold, person));  // >=, as in the original code
  EXPECT_FALSE(f.vote(1.0f, cfg.continuity_threshold - 0.01f, person));
  EXPECT_FALSE(f.vote(cfg.min_speed, 1.f, person));  // speed must exceed v_min
  EXPECT_FALSE(f.vote(std::nanf(""), 1.f, person));
}

TEST(ContinuityFilter, SizeCheckHasUpperLimitsOnlyByDefault) {
  ContinuityConfig cfg;
  ASSERT_TRUE(cfg.check_size);
  const ContinuityFilter sized(cfg);
  EXPECT_TRUE(sized.vote(1.f, 1.f, Eigen::Vector3f(0.5f, 0.5f, 1.7f)));     // a person
  EXPECT_TRUE(sized.vote(1.f, 1.f, Eigen::Vector3f(0.05f, 0.05f, 0.3f)));   // partly hidden
  EXPECT_FALSE(sized.vote(1.f, 1.f, Eigen::Vector3f(3.f, 1.5f, 1.5f)));     // a car
  EXPECT_FALSE(sized.vote(1.f, 1.f, Eigen::Vector3f(0.05f, 1.0f, 2.55f)));  // a wall piece
  cfg.min_size = Eigen::Vector3f(0.2f, 0.2f, 0.8f);
  const ContinuityFilter with_lower(cfg);
  EXPECT_FALSE(with_lower.vote(1.f, 1.f, Eigen::Vector3f(0.05f, 0.05f, 0.3f)));
  cfg.check_size = false;
  const ContinuityFilter unsized(cfg);
  EXPECT_TRUE(unsized.vote(1.f, 1.f, Eigen::Vector3f(3.f, 1.5f, 1.5f)));
  EXPECT_TRUE(unsized.vote(1.f, 1.f, Eigen::Vector3f(0.05f, 1.0f, 2.55f)));
}

TEST(ContinuityConfig, SizeLimitsMustBeOrderedAndNonNegative) {
  ContinuityConfig cfg;
  cfg.min_size = Eigen::Vector3f(0.f, 0.f, 2.5f);  // above max_size.z
  EXPECT_EQ(cfg.validate(), Status::kInvalidArgument);
  cfg.min_size = Eigen::Vector3f(-0.1f, 0.f, 0.f);
  EXPECT_EQ(cfg.validate(), Status::kInvalidArgument);
  cfg.min_size = Eigen::Vector3f::Zero();
  EXPECT_EQ(cfg.validate(), Status::kOk);
}

TEST(DynamicVoter, ThresholdsAndHysteresis) {
  const ContinuityConfig cfg;  // c = 20, >= 16 dynamic, <= 4 static
  DynamicVoter v;
  for (int i = 0; i < 15; ++i) v.push(true, cfg);
  EXPECT_FALSE(v.dynamic());
  v.push(true, cfg);
  EXPECT_TRUE(v.dynamic());
  EXPECT_EQ(v.dynamic_votes(), 16u);
  // Static votes push dynamic ones out; between 5 and 15 dynamic votes the label holds.
  for (int i = 0; i < 15; ++i) v.push(false, cfg);
  EXPECT_EQ(v.votes(), 20u);
  EXPECT_EQ(v.dynamic_votes(), 5u);
  EXPECT_TRUE(v.dynamic());
  v.push(false, cfg);
  EXPECT_EQ(v.dynamic_votes(), 4u);
  EXPECT_FALSE(v.dynamic());
  // And back: it takes 16 dynamic votes in the window again.
  for (int i = 0; i < 15; ++i) v.push(true, cfg);
  EXPECT_EQ(v.dynamic_votes(), 15u);
  EXPECT_FALSE(v.dynamic());
  v.push(true, cfg);
  EXPECT_TRUE(v.dynamic());
}

TEST(ContinuityConfig, Validation) {
  EXPECT_EQ(ContinuityConfig{}.validate(), Status::kOk);
  ContinuityConfig c;
  c.vote_window = 65;
  EXPECT_EQ(c.validate(), Status::kInvalidArgument);
  c = ContinuityConfig{};
  c.static_votes = 16;
  EXPECT_EQ(c.validate(), Status::kInvalidArgument);
  c = ContinuityConfig{};
  c.displacement_frames = 0;
  EXPECT_EQ(c.validate(), Status::kInvalidArgument);
}

}  // namespace
}  // namespace dynamap
