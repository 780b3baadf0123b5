#include <gtest/gtest.h>

#include <initializer_list>
#include <limits>

#include "alloc_guard.hpp"
#include "dynamap/detection_refiner.hpp"

namespace dynamap {
namespace {

// A detection whose raw box (map frame, x along the view) spans [x0, x1] x [y0, y1] x [z0, z1].
Detection piece(float x0, float x1, float y0, float y1, float z0, float z1, ImageBox ib) {
  Detection d;
  d.raw_box = Box3{Eigen::Vector3f(x0, y0, z0), Eigen::Vector3f(x1, y1, z1)};
  d.box = d.raw_box;
  d.image_box = ib;
  d.near_depth = x0;
  return d;
}

DetectionList list_of(std::initializer_list<Detection> ds) {
  DetectionList l;
  for (const Detection& d : ds) EXPECT_EQ(l.push_back(d), Status::kOk);
  return l;
}

TEST(DetectionRefiner, PersonWithAHoleThroughTheTorsoIsOneDetection) {
  // The two halves of one person at 3 m, split by a 4 cm column of missing depth.
  DetectionRefiner r;
  ASSERT_EQ(r.init({}), Status::kOk);
  DetectionList l = list_of({piece(3.0f, 3.1f, -0.25f, -0.02f, 0.0f, 1.7f, {280, 60, 315, 420}),
                             piece(3.0f, 3.12f, 0.02f, 0.25f, 0.1f, 1.6f, {322, 70, 358, 410})});
  EXPECT_EQ(r.join(l), 1u);
  ASSERT_EQ(l.size(), 1u);
  EXPECT_FLOAT_EQ(l[0].raw_box.min.y(), -0.25f);
  EXPECT_FLOAT_EQ(l[0].raw_box.max.y(), 0.25f);
  EXPECT_FLOAT_EQ(l[0].raw_box.max.x(), 3.12f);
  EXPECT_EQ(l[0].image_box.u0, 280);
  EXPECT_EQ(l[0].image_box.u1, 358);
  EXPECT_EQ(l[0].image_box.v0, 60);
}

TEST(DetectionRefiner, HeadAboveADepthHoleJoinsItsBody) {
  DetectionRefiner r;
  ASSERT_EQ(r.init({}), Status::kOk);
  DetectionList l = list_of({piece(2.0f, 2.1f, -0.25f, 0.25f, 0.0f, 1.3f, {250, 150, 390, 470}),
                             piece(2.05f, 2.15f, -0.1f, 0.08f, 1.5f, 1.75f, {290, 40, 340, 110})});
  EXPECT_EQ(r.join(l), 1u);
  ASSERT_EQ(l.size(), 1u);
  EXPECT_FLOAT_EQ(l[0].raw_box.max.z(), 1.75f);
}

TEST(DetectionRefiner, TwoPeopleSideBySideOrOneBehindTheOtherStayTwo) {
  DetectionRefiner r;
  ASSERT_EQ(r.init({}), Status::kOk);
  // Side by side, centres 0.5 m apart (shoulders touching).
  DetectionList side = list_of({piece(3.0f, 3.1f, -0.5f, 0.0f, 0.f, 1.7f, {200, 60, 320, 420}),
                                piece(3.0f, 3.1f, 0.0f, 0.5f, 0.f, 1.8f, {320, 60, 440, 420})});
  EXPECT_EQ(r.join(side), 0u);
  EXPECT_EQ(side.size(), 2u);
  // One 1 m behind the other, partly hidden by it.
  DetectionList behind = list_of({piece(2.0f, 2.1f, -0.25f, 0.25f, 0.f, 1.7f, {250, 40, 390, 470}),
                                  piece(3.0f, 3.1f, 0.2f, 0.5f, 0.f, 1.7f, {395, 60, 450, 420})});
  EXPECT_EQ(r.join(behind), 0u);
  EXPECT_EQ(behind.size(), 2u);
}

TEST(DetectionRefiner, ChainsJoinOrderIsKeptAndNothingIsAllocated) {
  DetectionRefiner r;
  ASSERT_EQ(r.init({}), Status::kOk);
  // Three pieces of one person (nearest first) and, between them in the list, a far person.
  DetectionList l = list_of({piece(2.0f, 2.1f, -0.25f, -0.1f, 0.f, 1.7f, {}),
                             piece(5.0f, 5.1f, 1.0f, 1.5f, 0.f, 1.7f, {}),
                             piece(2.0f, 2.1f, -0.08f, 0.05f, 0.f, 1.7f, {}),
                             piece(2.0f, 2.1f, 0.08f, 0.25f, 0.f, 1.7f, {})});
  std::size_t joins = 0;
  {
    test::AllocationGuard guard;
    joins = r.join(l);
    EXPECT_EQ(guard.allocations(), 0u);
  }
  EXPECT_EQ(joins, 2u);
  ASSERT_EQ(l.size(), 2u);
  EXPECT_FLOAT_EQ(l[0].raw_box.max.y(), 0.25f);
  EXPECT_FLOAT_EQ(l[1].raw_box.min.x(), 5.0f);
}

TEST(DetectionRefiner, OffJoinsNothingAndBadConfigIsRefused) {
  DetectionRefinerConfig off;
  off.join_fragments = false;
  DetectionRefiner r;
  ASSERT_EQ(r.init(off), Status::kOk);
  DetectionList l = list_of({piece(3.0f, 3.1f, -0.25f, -0.02f, 0.f, 1.7f, {}),
                             piece(3.0f, 3.1f, 0.02f, 0.25f, 0.f, 1.7f, {})});
  EXPECT_EQ(r.join(l), 0u);
  EXPECT_EQ(l.size(), 2u);
  for (float bad : {0.f, -1.f, std::numeric_limits<float>::quiet_NaN()}) {
    DetectionRefinerConfig c;
    c.max_footprint = bad;
    DetectionRefiner rr;
    EXPECT_EQ(rr.init(c), Status::kInvalidArgument) << bad;
  }
}

}  // namespace
}  // namespace dynamap
