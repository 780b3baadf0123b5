#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <memory>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/detect/detection_refiner.hpp"
#include "dynamap/detect/umap_detector.hpp"
#include "world_scene.hpp"

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

// Renders people (and a wall at 6 m) for a level camera 1.2 m above the floor at the origin,
// looking along +x, runs the detector, then join and split as the pipeline does.
struct GroupScene {
  CameraIntrinsics cam{};
  Pose pose = test::level_camera(Eigen::Vector3f(0.f, 0.f, 1.2f));
  test::WorldScene scene;
  std::vector<std::uint16_t> pixels;
  std::unique_ptr<UMapDetector> detector = std::make_unique<UMapDetector>();
  std::unique_ptr<DetectionRefiner> refiner = std::make_unique<DetectionRefiner>();
  DepthView depth{};
  DetectionList detected;  // the detector's own output
  std::size_t splits = 0;

  explicit GroupScene(const DetectionRefinerConfig& config = {}) {
    EXPECT_EQ(detector->init({}), Status::kOk);
    EXPECT_EQ(refiner->init(config, 0.2f), Status::kOk);  // floor cut as the pipeline's
    scene.boxes.push_back(
        Box3{Eigen::Vector3f(6.f, -5.f, 0.f), Eigen::Vector3f(6.2f, 5.f, 3.f)});  // wall
  }
  void add(const std::vector<Box3>& person) {
    scene.boxes.insert(scene.boxes.end(), person.begin(), person.end());
  }
  DetectionList run() {
    depth = test::render(scene, cam, pose, pixels);
    EXPECT_EQ(detector->detect(depth, cam, pose, detected), Status::kOk);
    DetectionList l = detected;
    (void)refiner->join(l);
    splits = refiner->split(depth, cam, pose, l);
    return l;
  }
};

// The detections near (x, y) in the top view (within 0.3 m of the box centre).
std::size_t near(const DetectionList& l, float x, float y) {
  std::size_t n = 0;
  for (const Detection& d : l) {
    const Eigen::Vector3f c = d.raw_box.center();
    n += std::hypot(c.x() - x, c.y() - y) < 0.3f ? 1u : 0u;
  }
  return n;
}

TEST(DetectionRefinerSplit, TwoPeopleSideBySideHalfAMetreApartAreTwo) {
  // Centres 0.5 m apart at 3 m: arms touching, one U-map group 1.04 m wide.
  GroupScene g;
  g.add(test::person_shape_at(3.f, -0.25f));
  g.add(test::person_shape_at(3.f, 0.25f));
  const DetectionList l = g.run();
  EXPECT_EQ(g.detected.size(), 1u);  // what the refiner gets
  ASSERT_EQ(l.size(), 2u);
  EXPECT_EQ(g.splits, 1u);
  EXPECT_EQ(near(l, 3.f, -0.25f), 1u);
  EXPECT_EQ(near(l, 3.f, 0.25f), 1u);
  for (const Detection& d : l) {
    // Cut in the middle of the arms between them, at y = 0.
    EXPECT_NEAR(std::min(std::fabs(d.raw_box.min.y()), std::fabs(d.raw_box.max.y())), 0.f, 0.03f);
    EXPECT_LT(d.raw_box.size().y(), 0.65f);
    EXPECT_GT(d.raw_box.size().y(), 0.4f);
    EXPECT_GT(d.raw_box.max.z(), 1.6f);
    EXPECT_FALSE(d.refined);
  }
  // A gap of 0.5 m between them: two groups already, and nothing for the refiner to do.
  GroupScene apart;
  apart.add(test::person_shape_at(3.f, -0.52f));
  apart.add(test::person_shape_at(3.f, 0.52f));
  EXPECT_EQ(apart.run().size(), 2u);
  EXPECT_EQ(apart.splits, 0u);
}

TEST(DetectionRefinerSplit, ThreeSideBySideAreThree) {
  GroupScene g;
  for (float y : {-0.5f, 0.f, 0.5f}) g.add(test::person_shape_at(3.5f, y));
  const DetectionList l = g.run();
  ASSERT_EQ(l.size(), 3u);
  for (float y : {-0.5f, 0.f, 0.5f}) EXPECT_EQ(near(l, 3.5f, y), 1u) << y;
}

TEST(DetectionRefinerSplit, OnePersonOneMetreBehindAnotherIsTwo) {
  GroupScene g;
  g.add(test::person_shape_at(2.f, 0.f));
  g.add(test::person_shape_at(3.f, 0.5f));  // partly hidden by the first
  const DetectionList l = g.run();
  ASSERT_EQ(l.size(), 2u);
  EXPECT_EQ(near(l, 2.f, 0.f), 1u);
  EXPECT_LT(l[0].near_depth, l[1].near_depth);  // nearest first

  // When flying pixels at the silhouettes make one group of them (here: the detector's two
  // detections joined by hand), the empty metre of depth between them splits it again.
  DetectionList merged;
  Detection m = g.detected[0];
  for (const Detection& d : g.detected) {
    m.raw_box = Box3{m.raw_box.min.cwiseMin(d.raw_box.min), m.raw_box.max.cwiseMax(d.raw_box.max)};
    m.image_box = ImageBox{
        std::min(m.image_box.u0, d.image_box.u0), std::min(m.image_box.v0, d.image_box.v0),
        std::max(m.image_box.u1, d.image_box.u1), std::max(m.image_box.v1, d.image_box.v1)};
    m.near_depth = std::min(m.near_depth, d.near_depth);
  }
  m.box = m.raw_box;
  ASSERT_EQ(merged.push_back(m), Status::kOk);
  EXPECT_EQ(g.refiner->split(g.depth, g.cam, g.pose, merged), 1u);
  ASSERT_EQ(merged.size(), 2u);
  EXPECT_NEAR(merged[0].raw_box.min.x(), 1.9f, 0.05f);
  EXPECT_LT(merged[0].raw_box.max.x(), 2.2f);
  EXPECT_NEAR(merged[1].raw_box.min.x(), 2.9f, 0.05f);
  EXPECT_EQ(near(merged, 2.f, 0.f), 1u);
}

TEST(DetectionRefinerSplit, OnePersonWithAHoleThroughTheTorsoIsOne) {
  for (float x : {1.5f, 3.f, 4.5f}) {
    GroupScene g;
    g.add(test::person_shape_at(x, 0.1f, /*hole=*/true));
    const DetectionList l = g.run();
    EXPECT_EQ(g.splits, 0u);
    ASSERT_EQ(near(l, x, 0.1f), 1u) << x;  // the wall seen through the hole may be another
    for (const Detection& d : l) {
      if (d.raw_box.center().x() < x + 1.f) {
        EXPECT_GT(d.raw_box.size().y(), 0.45f) << x;
      }
    }
  }
  // One person and a wide crate (1.2 m, flat profile) are never split.
  GroupScene c;
  c.add(test::person_shape_at(3.f, -1.f));
  c.scene.boxes.push_back(Box3{Eigen::Vector3f(3.f, 0.f, 0.f), Eigen::Vector3f(3.5f, 1.2f, 0.9f)});
  const DetectionList l = c.run();
  EXPECT_EQ(c.splits, 0u);
  EXPECT_EQ(l.size(), c.detected.size());
}

TEST(DetectionRefinerSplit, NoAllocationOffAndSameResultTwice) {
  GroupScene g;
  for (float y : {-0.5f, 0.f, 0.5f}) g.add(test::person_shape_at(3.5f, y));
  g.add(test::person_shape_at(2.f, -1.f));
  const DetectionList first = g.run();
  DetectionList again = g.detected;
  std::size_t splits = 0;
  {
    test::AllocationGuard guard;
    (void)g.refiner->join(again);
    splits = g.refiner->split(g.depth, g.cam, g.pose, again);
    EXPECT_EQ(guard.allocations(), 0u);
  }
  EXPECT_EQ(splits, 2u);
  ASSERT_EQ(again.size(), first.size());
  for (std::size_t i = 0; i < again.size(); ++i) {
    EXPECT_EQ(again[i].raw_box.min, first[i].raw_box.min);
    EXPECT_EQ(again[i].raw_box.max, first[i].raw_box.max);
  }
  DetectionRefinerConfig off;
  off.split_groups = false;
  GroupScene o(off);
  for (float y : {-0.5f, 0.f, 0.5f}) o.add(test::person_shape_at(3.5f, y));
  const std::size_t n_off = o.run().size();
  EXPECT_EQ(n_off, o.detected.size());
  EXPECT_EQ(o.splits, 0u);
  for (float bad : {0.f, -1.f, 3.f, std::numeric_limits<float>::quiet_NaN()}) {
    DetectionRefinerConfig c;
    c.split_depth_gap = bad;
    DetectionRefiner rr;
    EXPECT_EQ(rr.init(c), Status::kInvalidArgument) << bad;
  }
}

}  // namespace
}  // namespace dynamap
