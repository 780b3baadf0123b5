#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <set>
#include <utility>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/map/clean_history.hpp"
#include "dynamap/map/dynamic_region_cleaner.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/track/tracker.hpp"

namespace dynamap {
namespace {

constexpr Stamp kFrame = 33'333'333;
constexpr float kOccupiedLogOdds = 2.0f;

// Marks every voxel whose centre lies in `box` occupied, as integrating depth would.
void occupy(OccupancyMap& map, const Box3& box, std::vector<OccupancyMap::VoxelKey>* keys) {
  const float r = map.resolution();
  for (float z = std::floor(box.min.z() / r) * r + 0.5f * r; z <= box.max.z(); z += r) {
    for (float y = std::floor(box.min.y() / r) * r + 0.5f * r; y <= box.max.y(); y += r) {
      for (float x = std::floor(box.min.x() / r) * r + 0.5f * r; x <= box.max.x(); x += r) {
        const Eigen::Vector3f p(x, y, z);
        if (!box.contains(p)) continue;
        ASSERT_EQ(map.set_log_odds(p, kOccupiedLogOdds), Status::kOk);
        if (keys != nullptr) keys->push_back(map.key_of(p));
      }
    }
  }
}

Detection detection_of(const Box3& box) {
  Detection d;
  d.box = box;
  d.raw_box = box;
  d.image_box = ImageBox{200, 100, 300, 400};
  d.refined = true;
  return d;
}

void tick(OccupancyMap& map, Stamp stamp);

// A scene: a walker crossing in front of the camera at 1 m/s, a static pillar that is tracked,
// a wall and a floor that are not.
struct Scene {
  std::unique_ptr<OccupancyMap> map = std::make_unique<OccupancyMap>();
  std::unique_ptr<Tracker> tracker = std::make_unique<Tracker>();
  std::unique_ptr<CleanHistory> history = std::make_unique<CleanHistory>();
  DynamicRegionCleaner cleaner;
  std::vector<OccupancyMap::VoxelKey> wall, floor, pillar;
  Box3 pillar_box{Eigen::Vector3f(5.3f, 0.8f, 0.0f), Eigen::Vector3f(5.7f, 1.2f, 1.6f)};
  bool clock = false;    // step() advances the map's frame count too (an empty frame)
  int clock_offset = 0;  // frames the map integrated before the walker's frame 0

  static Box3 walker_box(int frame) {
    const Eigen::Vector3f c(4.f, -1.5f + frame / 30.f, 0.85f);
    return Box3::from_center_size(c, Eigen::Vector3f(0.4f, 0.4f, 1.6f));
  }

  void init(const DynamicRegionCleanerConfig& config = {}) {
    ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
    ASSERT_EQ(tracker->init(TrackerConfig{}, 640, 480), Status::kOk);
    ASSERT_EQ(history->init(3'000'000'000ULL), Status::kOk);
    // The floor (voxels below z = 0) is never cleared.
    ASSERT_EQ(cleaner.init(config, 0.0f), Status::kOk);
    occupy(*map, Box3{Eigen::Vector3f(7.0f, -1.f, 0.f), Eigen::Vector3f(7.1f, 1.f, 2.f)}, &wall);
    occupy(*map, Box3{Eigen::Vector3f(3.f, -2.f, -0.1f), Eigen::Vector3f(6.f, 2.f, 0.f)}, &floor);
    occupy(*map, pillar_box, &pillar);
  }

  // One frame: the walker's body shows up in the map, the tracker sees both, the cleaner runs.
  void step(int frame, std::vector<OccupancyMap::VoxelKey>* walker_keys) {
    occupy(*map, walker_box(frame), walker_keys);
    const Detection dets[2] = {detection_of(walker_box(frame)), detection_of(pillar_box)};
    const Stamp stamp = kFrame * static_cast<Stamp>(clock_offset + frame + 1);
    if (clock) tick(*map, stamp);
    ASSERT_EQ(tracker->update(dets, 2, Pose{}, stamp), Status::kOk);
    ASSERT_EQ(cleaner.clean(*tracker, *map, *history, stamp), Status::kOk);
  }
};

TEST(DynamicRegionCleaner, FreesTheWalkersTrailAndRecordsIt) {
  Scene s;
  s.init();
  std::vector<OccupancyMap::VoxelKey> walker;
  constexpr int kFrames = 90;
  for (int f = 0; f < kFrames; ++f) s.step(f, &walker);

  // The walker became dynamic; the pillar did not.
  ASSERT_EQ(s.tracker->size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    const TrackedObstacle& o = s.tracker->obstacle(i);
    EXPECT_EQ(o.dynamic, o.box.center().x() < 5.f);
  }
  // Every voxel the walker ever occupied is free now and remembered in the clean history.
  const std::set<OccupancyMap::VoxelKey> trail(walker.begin(), walker.end());
  ASSERT_GT(trail.size(), 500u);
  std::size_t still_occupied = 0, not_recorded = 0;
  for (OccupancyMap::VoxelKey k : trail) {
    if (s.map->state(k) == Occupancy::kOccupied) ++still_occupied;
    if (!s.history->contains(k)) ++not_recorded;
  }
  EXPECT_EQ(still_occupied, 0u);
  EXPECT_EQ(not_recorded, 0u);
  // Static voxels elsewhere are untouched: wall, floor under the walker, the static pillar.
  for (auto k : s.wall) EXPECT_EQ(s.map->state(k), Occupancy::kOccupied);
  for (auto k : s.floor) EXPECT_EQ(s.map->state(k), Occupancy::kOccupied);
  for (auto k : s.pillar) EXPECT_EQ(s.map->state(k), Occupancy::kOccupied);
  for (auto k : s.pillar) EXPECT_FALSE(s.history->contains(k));
}

/// Advances the map's clock one frame without changing a voxel: a frame with no measurement.
void tick(OccupancyMap& map, Stamp stamp) {
  CameraIntrinsics cam;
  cam.width = 8;
  cam.height = 8;
  cam.fx = cam.fy = 5.f;
  cam.cx = cam.cy = 3.5f;
  cam.depth_scale = 0.001f;
  const std::uint16_t zeros[64] = {};
  const DepthView view{zeros, 8, 8, 8 * static_cast<int>(sizeof(std::uint16_t))};
  ASSERT_EQ(map.integrate(view, cam, Pose{}, stamp), Status::kOk);
}

/// A walker walking 3 s along a wall whose voxels its boxes reach (a detection that took in the
/// wall's pixels at its edge), with the map's clock running; returns the wall voxels still
/// occupied and the trail voxels (walker voxels outside its last box) not cleared.
std::pair<std::size_t, std::size_t> walk_along_a_wall(const DynamicRegionCleanerConfig& config) {
  Scene s;
  s.init(config);
  std::vector<OccupancyMap::VoxelKey> wall;
  occupy(*s.map, Box3{Eigen::Vector3f(2.5f, 0.75f, 0.f), Eigen::Vector3f(6.5f, 0.85f, 2.f)}, &wall);
  for (int f = 0; f < 60; ++f) tick(*s.map, kFrame * static_cast<Stamp>(f + 1));  // seen for 2 s
  std::vector<OccupancyMap::VoxelKey> walker;
  Box3 box;
  for (int f = 0; f < 90; ++f) {
    const Stamp stamp = kFrame * static_cast<Stamp>(f + 61);
    tick(*s.map, stamp);
    box = Box3::from_center_size(Eigen::Vector3f(3.f + f / 30.f, 0.55f, 0.85f),
                                 Eigen::Vector3f(0.4f, 0.4f, 1.6f));
    occupy(*s.map, box, &walker);
    const Detection det = detection_of(box);
    EXPECT_EQ(s.tracker->update(&det, 1, Pose{}, stamp), Status::kOk);
    EXPECT_EQ(s.cleaner.clean(*s.tracker, *s.map, *s.history, stamp), Status::kOk);
  }
  EXPECT_TRUE(s.tracker->size() == 1 && s.tracker->obstacle(0).dynamic);
  std::size_t wall_kept = 0, trail_left = 0;
  for (auto k : wall) wall_kept += s.map->state(k) == Occupancy::kOccupied;
  for (auto k : walker) {
    const Eigen::Vector3f c = s.map->center_of(k);
    const bool now = c.x() > box.min.x() - 0.35f;  // the current box and its inflated margin
    trail_left += !now && s.map->state(k) == Occupancy::kOccupied;
  }
  EXPECT_GT(walker.size(), 1000u);
  return {wall.size() - wall_kept, trail_left};
}

TEST(DynamicRegionCleaner, AWalkerAlongAWallClearsItsTrailButNotTheWall) {
  const auto [wall_erased, trail_left] = walk_along_a_wall(DynamicRegionCleanerConfig{});
  EXPECT_EQ(wall_erased, 0u);
  EXPECT_EQ(trail_left, 0u);
  // Without keep_static the same boxes erase the wall's near layer.
  DynamicRegionCleanerConfig off;
  off.keep_static = false;
  const auto [erased_off, trail_off] = walk_along_a_wall(off);
  EXPECT_GT(erased_off, 50u);
  EXPECT_EQ(trail_off, 0u);
}

TEST(DynamicRegionCleaner, NothingIsClearedBeforeTheWalkerIsDynamic) {
  Scene s;
  s.init();
  std::vector<OccupancyMap::VoxelKey> walker;
  // The earliest label: the first vote needs 2 * d + 1 states, then E dynamic votes in a row.
  const TrackerConfig tc;
  const int first_label =
      static_cast<int>(2 * tc.early_displacement_frames + tc.label.early_votes) - 1;
  for (int f = 0; f < first_label; ++f) s.step(f, &walker);  // too early for any dynamic label
  EXPECT_EQ(s.cleaner.last_stats().dynamic_tracks, 0u);
  for (auto k : walker) EXPECT_EQ(s.map->state(k), Occupancy::kOccupied);
  EXPECT_EQ(s.history->size(), 0u);
  s.step(first_label, &walker);  // the walker is labelled now and its trail starts to be freed
  EXPECT_EQ(s.cleaner.last_stats().dynamic_tracks, 1u);
}

// The walker of Scene, the map's clock running from `pre_frames` frames before it appears: the
// frames from its label to the first frame its track clears anything (the label's first frame
// counts 1; nothing is freed or recorded before), and whether its first box, from before the
// label, is freed within the revisit period after that.
struct LabelWait {
  int frames = -1;
  bool first_box_freed = false;
};
LabelWait label_wait(const DynamicRegionCleanerConfig& config, int pre_frames) {
  Scene s;
  s.init(config);
  s.clock = true;
  s.clock_offset = pre_frames;
  for (int f = 0; f < pre_frames; ++f) tick(*s.map, kFrame * static_cast<Stamp>(f + 1));
  std::vector<OccupancyMap::VoxelKey> walker;
  int f = 0;
  while (s.cleaner.last_stats().dynamic_tracks == 0 && f < 60) s.step(f++, &walker);
  LabelWait r;
  if (f >= 60) return r;  // never labelled
  int held = 1;
  while (s.cleaner.last_stats().voxels_freed == 0 && held < 45) {
    EXPECT_EQ(s.cleaner.last_stats().tracks_waiting, 1u) << "label frame " << held;
    EXPECT_EQ(s.history->size(), 0u) << "label frame " << held;
    s.step(f++, &walker);
    ++held;
  }
  r.frames = held;
  EXPECT_EQ(s.cleaner.last_stats().tracks_waiting, 0u);
  const std::vector<OccupancyMap::VoxelKey> first(walker.begin(), walker.begin() + 20);
  for (int k = 0; k < 20; ++k) s.step(f++, nullptr);
  r.first_box_freed = std::none_of(first.begin(), first.end(), [&](OccupancyMap::VoxelKey key) {
    return s.map->state(key) == Occupancy::kOccupied;
  });
  return r;
}

// A label that has held for fewer than min_dynamic_frames frames clears nothing; a track that
// started in the run's first static_margin_frames frames, where keep_static keeps nothing, waits
// early_min_dynamic_frames. The boxes from before are cleared once the label has held.
TEST(DynamicRegionCleaner, ALabelClearsOnlyOnceItHasHeld) {
  DynamicRegionCleanerConfig config;
  config.min_dynamic_frames = 5;
  config.early_min_dynamic_frames = 12;
  const LabelWait later = label_wait(config, 60);  // the map is 2 s old when the walker comes
  EXPECT_EQ(later.frames, 5);
  EXPECT_TRUE(later.first_box_freed);
  const LabelWait early = label_wait(config, 0);  // the walker is there from the run's start
  EXPECT_EQ(early.frames, 12);
  EXPECT_TRUE(early.first_box_freed);
}

TEST(DynamicRegionCleaner, WorkPerFrameIsCapped) {
  Scene s;
  DynamicRegionCleanerConfig config;
  config.max_voxels_per_frame = 1500;  // about one inflated walker box
  s.init(config);
  std::size_t skipped = 0;
  for (int f = 0; f < 60; ++f) {
    s.step(f, nullptr);
    EXPECT_LE(s.cleaner.last_stats().voxels_budgeted, config.max_voxels_per_frame);
    skipped += s.cleaner.last_stats().boxes_skipped;
  }
  EXPECT_GT(skipped, 0u);
  EXPECT_GT(s.history->size(), 0u);
}

TEST(DynamicRegionCleaner, BadStampChangesNothingAndNoAllocationPerFrame) {
  Scene s;
  s.init();
  for (int f = 0; f < 40; ++f) s.step(f, nullptr);
  const std::uint64_t before = s.map->checksum();
  const std::size_t history_size = s.history->size();
  occupy(*s.map, Scene::walker_box(40), nullptr);
  const std::uint64_t with_body = s.map->checksum();
  EXPECT_NE(before, with_body);
  EXPECT_EQ(s.cleaner.clean(*s.tracker, *s.map, *s.history, kFrame * 40),
            Status::kTimeNotIncreasing);
  EXPECT_EQ(s.map->checksum(), with_body);
  EXPECT_EQ(s.history->size(), history_size);

  test::AllocationGuard guard;
  for (int f = 40; f < 70; ++f) {
    const Box3 body = Scene::walker_box(f);
    const Detection dets[2] = {detection_of(body), detection_of(s.pillar_box)};
    const Stamp stamp = kFrame * static_cast<Stamp>(f + 1);
    ASSERT_EQ(s.tracker->update(dets, 2, Pose{}, stamp), Status::kOk);
    ASSERT_EQ(s.cleaner.clean(*s.tracker, *s.map, *s.history, stamp), Status::kOk);
  }
  EXPECT_EQ(guard.allocations(), 0u);
}

TEST(DynamicRegionCleaner, BadConfigIsRefused) {
  DynamicRegionCleaner c;
  DynamicRegionCleanerConfig config;
  config.frames = kMaxBoxHistory + 1;
  EXPECT_EQ(c.init(config, 0.f), Status::kInvalidArgument);
  config = DynamicRegionCleanerConfig{};
  config.inflation = 0.5f;
  EXPECT_EQ(c.init(config, 0.f), Status::kInvalidArgument);
  EXPECT_EQ(c.init(DynamicRegionCleanerConfig{}, NAN), Status::kInvalidArgument);
  config = DynamicRegionCleanerConfig{};
  config.min_dynamic_frames = 0;  // a track must be dynamic at least one frame
  EXPECT_EQ(c.init(config, 0.f), Status::kInvalidArgument);
  config.min_dynamic_frames = config.frames;  // its first boxes would have left the history
  EXPECT_EQ(c.init(config, 0.f), Status::kInvalidArgument);
  config.min_dynamic_frames = config.frames - 1;
  EXPECT_EQ(c.init(config, 0.f), Status::kOk);
  config.early_min_dynamic_frames = config.frames;
  EXPECT_EQ(c.init(config, 0.f), Status::kInvalidArgument);
}

}  // namespace
}  // namespace dynamap
