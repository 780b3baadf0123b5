// MapRefiner against a real OccupancyMap: shrinking an inflated noisy box to the occupied voxels,
// the clean history counting as occupied, the floor band ignored, no support -> raw box kept,
// bounded work, bad input, zero allocations.
#include <gtest/gtest.h>

#include <limits>
#include <memory>

#include "alloc_guard.hpp"
#include "dynamap/core/fixed_hash_map.hpp"
#include "dynamap/detect/umap_detector.hpp"
#include "dynamap/map/map_refiner.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "synthetic_depth.hpp"

namespace dynamap {
namespace {

using CleanSet = FixedHashSet<std::uint64_t, 4096>;

VoxelLookup lookup_of(const CleanSet& set) {
  return VoxelLookup{&set, [](const void* ctx, std::uint64_t key) noexcept {
                       return static_cast<const CleanSet*>(ctx)->contains(key);
                     }};
}

constexpr float kOccupied = 2.5f;  // log-odds above the 1.386 threshold

// Marks every voxel whose centre lies in [lo, hi) (metres) as occupied; optionally records
// them in `keys` instead (clean history) without marking them.
void fill(OccupancyMap& map, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi,
          CleanSet* keys = nullptr) {
  const float r = map.resolution();
  for (float z = lo.z() + 0.5f * r; z < hi.z(); z += r) {
    for (float y = lo.y() + 0.5f * r; y < hi.y(); y += r) {
      for (float x = lo.x() + 0.5f * r; x < hi.x(); x += r) {
        const Eigen::Vector3f c(x, y, z);
        if (keys != nullptr) {
          ASSERT_EQ(keys->insert(map.key_of(c)), Status::kOk);
          ASSERT_EQ(map.set_log_odds(c, -2.f), Status::kOk);  // freed by the cleaner
        } else {
          ASSERT_EQ(map.set_log_odds(c, kOccupied), Status::kOk);
        }
      }
    }
  }
}

void expect_box(const Box3& b, const Eigen::Vector3f& lo, const Eigen::Vector3f& hi) {
  EXPECT_TRUE(b.min.isApprox(lo, 1e-4f)) << b.min.transpose() << " vs " << lo.transpose();
  EXPECT_TRUE(b.max.isApprox(hi, 1e-4f)) << b.max.transpose() << " vs " << hi.transpose();
}

class MapRefinerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    map = std::make_unique<OccupancyMap>();
    ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
    // Floor: one voxel layer z in [0, 0.1) over 4 x 4 m.
    fill(*map, Eigen::Vector3f(0.f, -2.f, 0.f), Eigen::Vector3f(4.f, 2.f, 0.1f));
    // The obstacle, standing on the floor: x [2.0, 2.5], y [-0.3, 0.3], z [0.1, 1.2].
    fill(*map, Eigen::Vector3f(2.0f, -0.3f, 0.1f), Eigen::Vector3f(2.5f, 0.3f, 1.2f));
    // A neighbour outside the inflated box.
    fill(*map, Eigen::Vector3f(3.3f, -0.2f, 0.1f), Eigen::Vector3f(3.6f, 0.2f, 1.0f));
    ASSERT_EQ(refiner.init(MapRefinerConfig{}, 0.f), Status::kOk);
  }
  Detection noisy_detection() const {
    Detection d;
    // Raw box: too large and shifted, as a noisy depth detection would be.
    d.raw_box = Box3{Eigen::Vector3f(1.93f, -0.41f, 0.05f), Eigen::Vector3f(2.56f, 0.36f, 1.31f)};
    d.box = d.raw_box;
    return d;
  }
  std::unique_ptr<OccupancyMap> map;
  MapRefiner refiner;
};

TEST_F(MapRefinerTest, ShrinksNoisyBoxToOccupiedVoxelsAndIgnoresFloor) {
  Detection d = noisy_detection();
  const Box3 raw = d.raw_box;
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, &d, 1), Status::kOk);
  EXPECT_TRUE(d.refined);
  // Voxels with centres below ground + 0.2 m (the floor layer and the obstacle's bottom voxel
  // at z 0.15) are ignored, so the refined box starts at z = 0.2.
  expect_box(d.box, Eigen::Vector3f(2.0f, -0.3f, 0.2f), Eigen::Vector3f(2.5f, 0.3f, 1.2f));
  EXPECT_EQ(d.raw_box.min, raw.min);  // raw box kept for the caller
  EXPECT_EQ(d.raw_box.max, raw.max);
  EXPECT_EQ(refiner.last_stats().refined, 1u);
}

TEST_F(MapRefinerTest, FloorCountsWhenGroundIsLower) {
  // Same map, ground declared 1 m lower: now the floor layer is support and widens the box.
  ASSERT_EQ(refiner.set_ground_height(-1.f), Status::kOk);
  Detection d = noisy_detection();
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, &d, 1), Status::kOk);
  EXPECT_LT(d.box.min.z(), 0.11f);
  EXPECT_LT(d.box.min.y(), -0.35f);  // floor voxels inside the inflated box
}

TEST_F(MapRefinerTest, HonoursCleanHistory) {
  // The obstacle's top (z 0.8 .. 1.5) was freed by dynamic-region cleaning and remembered.
  CleanSet clean;
  fill(*map, Eigen::Vector3f(2.0f, -0.3f, 0.8f), Eigen::Vector3f(2.5f, 0.3f, 1.2f), &clean);
  Detection with = noisy_detection(), without = noisy_detection();
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, &without, 1), Status::kOk);
  expect_box(without.box, Eigen::Vector3f(2.0f, -0.3f, 0.2f), Eigen::Vector3f(2.5f, 0.3f, 0.8f));
  ASSERT_EQ(refiner.refine(*map, lookup_of(clean), &with, 1), Status::kOk);
  expect_box(with.box, Eigen::Vector3f(2.0f, -0.3f, 0.2f), Eigen::Vector3f(2.5f, 0.3f, 1.2f));
  // History voxels outside the inflated box do not count.
  CleanSet far;
  fill(*map, Eigen::Vector3f(2.0f, 1.0f, 0.5f), Eigen::Vector3f(2.2f, 1.2f, 0.7f), &far);
  Detection d = noisy_detection();
  ASSERT_EQ(refiner.refine(*map, lookup_of(far), &d, 1), Status::kOk);
  EXPECT_LT(d.box.max.y(), 0.31f);
}

TEST_F(MapRefinerTest, StaticShareIsTheShareOfLongOccupiedVoxelsInTheRawBox) {
  // The obstacle's voxels became occupied at map frame 0; a second obstacle's at frame 40.
  // At frame 45 (static_frames 30) the first is all old, the second all young.
  std::vector<std::uint16_t> zeros(64, 0);
  CameraIntrinsics cam;
  cam.width = cam.height = 8;
  cam.fx = cam.fy = 5.f;
  cam.cx = cam.cy = 3.5f;
  cam.depth_scale = 0.001f;
  const DepthView none{zeros.data(), 8, 8, 16};  // a frame with no measurement: the clock ticks
  Pose pose;
  for (int f = 1; f <= 45; ++f) {
    if (f == 40) fill(*map, Eigen::Vector3f(2.0f, 1.0f, 0.3f), Eigen::Vector3f(2.4f, 1.4f, 1.5f));
    ASSERT_EQ(map->integrate(none, cam, pose, static_cast<Stamp>(f) * 33'333'333), Status::kOk);
  }
  Detection dets[2] = {noisy_detection(), noisy_detection()};
  dets[1].raw_box =
      Box3{Eigen::Vector3f(1.95f, 0.95f, 0.25f), Eigen::Vector3f(2.45f, 1.45f, 1.55f)};
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, dets, 2), Status::kOk);
  EXPECT_FLOAT_EQ(dets[0].static_share, 1.f);
  EXPECT_FLOAT_EQ(dets[1].static_share, 0.f);
}

TEST_F(MapRefinerTest, NoSupportKeepsRawBoxUnrefined) {
  FixedVector<Detection, kMaxDetections> dets;
  Detection empty_space;
  empty_space.raw_box = Box3{Eigen::Vector3f(-3.f, 3.f, 0.5f), Eigen::Vector3f(-2.5f, 3.5f, 1.5f)};
  empty_space.box = Box3{};  // whatever was there is replaced by the raw box
  ASSERT_EQ(dets.push_back(noisy_detection()), Status::kOk);
  ASSERT_EQ(dets.push_back(empty_space), Status::kOk);
  Detection only_floor;  // a box on the floor band only: floor is not support
  only_floor.raw_box = Box3{Eigen::Vector3f(0.5f, -1.f, 0.f), Eigen::Vector3f(1.f, -0.5f, 0.12f)};
  ASSERT_EQ(dets.push_back(only_floor), Status::kOk);
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, dets), Status::kOk);
  EXPECT_TRUE(dets[0].refined);
  EXPECT_FALSE(dets[1].refined);
  EXPECT_EQ(dets[1].box.min, empty_space.raw_box.min);
  EXPECT_EQ(dets[1].box.max, empty_space.raw_box.max);
  EXPECT_FALSE(dets[2].refined);
  EXPECT_EQ(refiner.last_stats().refined, 1u);
  EXPECT_EQ(refiner.last_stats().unrefined, 2u);
}

TEST_F(MapRefinerTest, MinSupportVoxels) {
  MapRefinerConfig cfg;
  cfg.min_support_voxels = 10000;  // more than the obstacle has
  ASSERT_EQ(refiner.init(cfg, 0.f), Status::kOk);
  Detection d = noisy_detection();
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, &d, 1), Status::kOk);
  EXPECT_FALSE(d.refined);
}

TEST_F(MapRefinerTest, WorkIsBoundedPerBox) {
  MapRefinerConfig cfg;
  cfg.max_voxels_per_box = 64;
  ASSERT_EQ(refiner.init(cfg, 0.f), Status::kOk);
  CleanSet clean;
  ASSERT_EQ(clean.insert(12345u), Status::kOk);
  Detection huge;
  huge.raw_box = Box3{Eigen::Vector3f(-1e6f, -1e6f, -1e6f), Eigen::Vector3f(1e6f, 1e6f, 1e6f)};
  ASSERT_EQ(refiner.refine(*map, lookup_of(clean), &huge, 1), Status::kOk);
  EXPECT_EQ(refiner.last_stats().truncated, 1u);
  Detection d = noisy_detection();
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, &d, 1), Status::kOk);
  EXPECT_EQ(refiner.last_stats().truncated, 1u);  // ~750 voxels in the inflated box > 64
  EXPECT_LE(refiner.last_stats().support_voxels, 64u);
}

TEST_F(MapRefinerTest, BadInputChangesNothing) {
  Detection d[2] = {noisy_detection(), noisy_detection()};
  d[1].raw_box.max.x() = NAN;
  const Box3 before = d[0].box;
  EXPECT_EQ(refiner.refine(*map, VoxelLookup{}, d, 2), Status::kNonFinite);
  EXPECT_EQ(d[0].box.min, before.min);  // the valid first detection was not refined either
  EXPECT_FALSE(d[0].refined);
  d[1] = noisy_detection();
  std::swap(d[1].raw_box.min, d[1].raw_box.max);
  EXPECT_EQ(refiner.refine(*map, VoxelLookup{}, d, 2), Status::kInvalidArgument);
  EXPECT_EQ(refiner.refine(*map, VoxelLookup{}, nullptr, 2), Status::kNullData);
  EXPECT_FALSE(d[0].refined);

  MapRefiner fresh;
  EXPECT_EQ(fresh.refine(*map, VoxelLookup{}, d, 1), Status::kNotInitialized);
  auto empty_map = std::make_unique<OccupancyMap>();
  EXPECT_EQ(refiner.refine(*empty_map, VoxelLookup{}, d, 1), Status::kNotInitialized);

  MapRefinerConfig bad;
  bad.inflate = 0.9f;
  EXPECT_EQ(refiner.init(bad, 0.f), Status::kInvalidArgument);
  bad = {};
  bad.max_voxels_per_box = 0;
  EXPECT_EQ(refiner.init(bad, 0.f), Status::kInvalidArgument);
  bad.max_voxels_per_box = kMaxRefinerVoxelsPerBox + 1;  // every work cap has an upper bound
  EXPECT_EQ(refiner.init(bad, 0.f), Status::kInvalidArgument);
  EXPECT_EQ(refiner.set_ground_height(NAN), Status::kNonFinite);
  EXPECT_FLOAT_EQ(refiner.config().inflate, 1.15f);
  EXPECT_FLOAT_EQ(refiner.ground_height(), 0.f);
  EXPECT_EQ(refiner.init(MapRefinerConfig{}, NAN), Status::kInvalidArgument);
}

TEST_F(MapRefinerTest, ZeroAllocations) {
  CleanSet clean;
  fill(*map, Eigen::Vector3f(2.0f, -0.3f, 0.8f), Eigen::Vector3f(2.5f, 0.3f, 1.2f), &clean);
  FixedVector<Detection, kMaxDetections> dets;
  for (int i = 0; i < 5; ++i) ASSERT_EQ(dets.push_back(noisy_detection()), Status::kOk);
  const VoxelLookup lookup = lookup_of(clean);
  test::AllocationGuard guard;
  ASSERT_EQ(refiner.refine(*map, lookup, dets), Status::kOk);
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(refiner.last_stats().refined, 5u);
}

TEST(MapRefinerEndToEnd, DetectorBoxesRefinedAgainstIntegratedMap) {
  // Camera 1 m above the floor looking along map x; three boxes standing on the floor. The map
  // integrates a few frames, the detector's front-surface boxes are refined against it.
  CameraIntrinsics cam;
  const Pose pose = test::optical_to_map_pose(Eigen::Vector3f(0.f, 0.f, 1.f));
  test::SyntheticScene scene;
  auto box = [](float x0, float x1, float y0, float y1, float z0, float z1) {
    return test::SceneBox{Eigen::Vector3f(x0, y0, z0), Eigen::Vector3f(x1, y1, z1)};
  };
  // Camera frame: y down, floor at y = +1; tops at 1.0 / 0.6 / 0.8 m above the floor.
  scene.boxes = {box(-0.6f, -0.2f, 0.0f, 1.0f, 1.5f, 1.9f), box(0.1f, 0.5f, 0.4f, 1.0f, 2.5f, 2.8f),
                 box(0.8f, 1.3f, 0.2f, 1.0f, 3.5f, 3.9f)};
  scene.floor_y = 1.f;
  scene.wall_z = 6.f;
  const auto img = test::render_depth(scene, cam);
  auto map = std::make_unique<OccupancyMap>();
  ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
  for (int i = 1; i <= 4; ++i) {
    ASSERT_EQ(map->integrate(img.view(), cam, pose, static_cast<Stamp>(i) * 33'000'000),
              Status::kOk);
  }
  auto detector = std::make_unique<UMapDetector>();
  ASSERT_EQ(detector->init(UMapDetectorConfig{}), Status::kOk);
  DetectionList dets;
  ASSERT_EQ(detector->detect(img.view(), cam, pose, dets), Status::kOk);
  ASSERT_EQ(dets.size(), 3u);
  MapRefiner refiner;
  ASSERT_EQ(refiner.init(MapRefinerConfig{}, 0.f), Status::kOk);
  ASSERT_EQ(refiner.refine(*map, VoxelLookup{}, dets), Status::kOk);
  for (std::size_t i = 0; i < dets.size(); ++i) {
    const Box3 truth = test::box_to_map(scene.boxes[i].min, scene.boxes[i].max, pose);
    EXPECT_TRUE(dets[i].refined) << i;
    // Lateral (map y) and top (map z) to voxel accuracy; bottom is cut at ground + 0.2 m;
    // along the ray only the seen surface is in the map.
    EXPECT_NEAR(dets[i].box.min.y(), truth.min.y(), 0.11f) << i;
    EXPECT_NEAR(dets[i].box.max.y(), truth.max.y(), 0.11f) << i;
    EXPECT_NEAR(dets[i].box.max.z(), truth.max.z(), 0.11f) << i;
    EXPECT_GE(dets[i].box.min.z(), 0.2f - 1e-4f) << i;
    // The nearest box's foot is below the view (visible down to z ~0.35 m at 1.5 m).
    if (i > 0) {
      EXPECT_NEAR(dets[i].box.min.z(), 0.2f, 1e-4f) << i;
    }
    EXPECT_NEAR(dets[i].box.min.x(), truth.min.x(), 0.11f) << i;
  }
}

// Finite but absurd boxes, far on either side of the key range or spanning all of it: the index
// ranges are clamped on both sides before any conversion (UBSan: no overflow), and the work
// stays within the cap.
TEST_F(MapRefinerTest, FarAndHugeFiniteBoxesAreClampedToTheKeyRange) {
  constexpr float kBig = std::numeric_limits<float>::max();
  const Box3 boxes[] = {
      Box3{Eigen::Vector3f::Constant(1e30f), Eigen::Vector3f::Constant(1.0001e30f)},
      Box3{Eigen::Vector3f::Constant(-1.0001e30f), Eigen::Vector3f::Constant(-1e30f)},
      Box3{Eigen::Vector3f::Constant(-1e30f), Eigen::Vector3f::Constant(1e30f)},
      Box3{Eigen::Vector3f::Constant(-kBig), Eigen::Vector3f::Constant(kBig)},
      Box3{Eigen::Vector3f::Constant(1e38f), Eigen::Vector3f::Constant(kBig)},  // inflates to NaN
  };
  CleanSet clean;
  ASSERT_EQ(clean.insert(map->key_of(Eigen::Vector3f(2.25f, 0.f, 0.5f))), Status::kOk);
  for (const Box3& b : boxes) {
    Detection d;
    d.raw_box = b;
    d.box = b;
    ASSERT_EQ(refiner.refine(*map, lookup_of(clean), &d, 1), Status::kOk);
    EXPECT_LE(refiner.last_stats().refined + refiner.last_stats().unrefined, 1u);
  }
}

}  // namespace
}  // namespace dynamap
