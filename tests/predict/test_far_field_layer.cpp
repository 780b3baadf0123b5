// Tests of the far-field top-view layer: walls beyond the map's range are written and remembered
// out of view, noise (single far pixels, range noise that grows with depth) makes no obstacle,
// walkers leave no trail, free rays clear what moved, bad input changes nothing, no allocation.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/predict/far_field_layer.hpp"
#include "world_scene.hpp"

namespace dynamap {
namespace {

CameraIntrinsics camera() {
  CameraIntrinsics c;
  c.fx = 385.0f;
  c.fy = 385.0f;
  c.cx = 320.0f;
  c.cy = 240.0f;
  c.width = 640;
  c.height = 480;
  c.depth_scale = 0.001f;
  return c;
}

std::unique_ptr<FarFieldLayer> make_layer(const FarFieldConfig& c = [] {
  FarFieldConfig f;
  f.enabled = true;
  return f;
}()) {
  auto layer = std::make_unique<FarFieldLayer>();
  EXPECT_EQ(layer->init(c, 0.0f), Status::kOk);
  return layer;
}

/// A 2.5 m high, 0.2 m thick wall across x = x0, for |y| < half_width.
Box3 wall_across(float x0, float half_width) {
  return Box3{Eigen::Vector3f(x0, -half_width, 0.0f), Eigen::Vector3f(x0 + 0.2f, half_width, 2.5f)};
}

/// Adds Gaussian range noise with sigma(d) = a + b d^2 to every return of `pixels`.
void add_range_noise(std::vector<std::uint16_t>& pixels, float a, float b, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, 1.0f);
  for (auto& p : pixels) {
    if (p == 0) continue;
    const float d = 0.001f * static_cast<float>(p);
    const float noisy = d + (a + b * d * d) * n(rng);
    // Clamped to the format's range (a wrapped value would be a near return).
    p = static_cast<std::uint16_t>(std::lround(std::clamp(noisy, 0.31f, 65.535f) * 1000.0f));
  }
}

/// Is any cell within `r` of p (top view) a wall?
bool occupied_near(const FarFieldLayer& layer, const Eigen::Vector2f& p, float r) {
  for (float dx = -r; dx <= r + 1e-4f; dx += 0.05f) {
    for (float dy = -r; dy <= r + 1e-4f; dy += 0.05f) {
      if (layer.occupied(p + Eigen::Vector2f(dx, dy))) return true;
    }
  }
  return false;
}

const Pose kLookingAtWall = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, 1.3f), 0.0f);

/// The wall across x = 8 m, 6 m wide, seen from kLookingAtWall.
DepthView wall_at_8m(const CameraIntrinsics& cam, std::vector<std::uint16_t>& pixels) {
  test::WorldScene scene;
  scene.boxes.push_back(wall_across(8.0f, 3.0f));
  return test::render(scene, cam, kLookingAtWall, pixels);
}
const Pose kLookingAway = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, 1.3f), 3.14159265f);

TEST(FarFieldLayer, WallSeenOnceAt8mIsRememberedOutOfView) {
  test::WorldScene scene;
  scene.boxes.push_back(wall_across(8.0f, 3.0f));
  std::vector<std::uint16_t> pixels;
  const CameraIntrinsics cam = camera();
  const DepthView wall_view = test::render(scene, cam, kLookingAtWall, pixels);
  auto layer = make_layer();
  ASSERT_EQ(layer->update(wall_view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_GT(layer->last_hits(), 20u);
  EXPECT_TRUE(layer->occupied(Eigen::Vector2f(8.05f, 0.0f)));
  EXPECT_TRUE(layer->occupied(Eigen::Vector2f(8.05f, 1.5f)));
  EXPECT_FALSE(layer->occupied(Eigen::Vector2f(6.0f, 0.0f)));  // seen free in front of it
  EXPECT_LT(layer->evidence(Eigen::Vector2f(6.0f, 0.0f)), 0);

  // 30 frames looking the other way (nothing in view): the wall is still known.
  std::vector<std::uint16_t> away_pixels;
  const DepthView away = test::render(test::WorldScene{}, cam, kLookingAway, away_pixels);
  for (int f = 0; f < 30; ++f) {
    ASSERT_EQ(layer->update(away, cam, kLookingAway, nullptr, 0), Status::kOk);
  }
  EXPECT_TRUE(layer->occupied(Eigen::Vector2f(8.05f, 0.0f)));
  // ... and forgotten memory_frames after its last hit.
  const int rest = layer->config().memory_frames - 30;
  for (int f = 0; f < rest; ++f) {
    ASSERT_EQ(layer->update(away, cam, kLookingAway, nullptr, 0), Status::kOk);
  }
  EXPECT_TRUE(layer->occupied(Eigen::Vector2f(8.05f, 0.0f)));
  ASSERT_EQ(layer->update(away, cam, kLookingAway, nullptr, 0), Status::kOk);
  EXPECT_FALSE(layer->occupied(Eigen::Vector2f(8.05f, 0.0f)));
}

TEST(FarFieldLayer, NearSurfacesAreLeftToTheMap) {
  test::WorldScene scene;
  scene.boxes.push_back(wall_across(3.0f, 3.0f));
  std::vector<std::uint16_t> pixels;
  const CameraIntrinsics cam = camera();
  const DepthView view = test::render(scene, cam, kLookingAtWall, pixels);
  auto layer = make_layer();
  ASSERT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_EQ(layer->last_hits(), 0u);
  EXPECT_FALSE(layer->occupied(Eigen::Vector2f(3.05f, 0.0f)));
}

TEST(FarFieldLayer, SingleNoisyFarPixelsDoNotCreateObstacles) {
  // Only the floor in view, plus one stray return at 8 m in every sampled column (a different
  // row each time): never min_pixels in one noise window, so no wall anywhere.
  std::vector<std::uint16_t> pixels;
  const CameraIntrinsics cam = camera();
  DepthView view = test::render(test::WorldScene{}, cam, kLookingAtWall, pixels);
  auto layer = make_layer();
  const int stride = layer->config().pixel_stride;
  for (int u = stride / 2, k = 0; u < cam.width; u += stride, ++k) {
    const int v = 194 + stride * (k % 10);  // at 8 m: 2.25 m down to 1.5 m above the floor
    pixels[static_cast<std::size_t>(v * cam.width + u)] = 8000;
  }
  ASSERT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_EQ(layer->last_hits(), 0u);
  for (float y = -4.0f; y <= 4.0f; y += 0.1f) {
    for (float x = 4.5f; x <= 9.0f; x += 0.1f) {
      ASSERT_FALSE(layer->occupied(Eigen::Vector2f(x, y))) << x << " " << y;
    }
  }
  // The same returns stacked in one column are a surface (the test can fail).
  for (int k = 0; k < 8; ++k) {
    pixels[static_cast<std::size_t>((194 + stride * k) * cam.width + 322)] = 8000;
  }
  ASSERT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_EQ(layer->last_hits(), 1u);
}

TEST(FarFieldLayer, RangeNoiseMakesOneWallNotAScatterInFrontOfIt) {
  // sigma(d) = 0.05 + 0.0042 d^2 (0.32 m at 8 m): the wall lands within a cell or two of its
  // face, and nothing is written in the 1 m in front of it.
  test::WorldScene scene;
  scene.boxes.push_back(wall_across(8.0f, 3.0f));
  std::vector<std::uint16_t> pixels;
  const CameraIntrinsics cam = camera();
  auto layer = make_layer();
  for (int f = 0; f < 10; ++f) {
    const DepthView view = test::render(scene, cam, kLookingAtWall, pixels);
    add_range_noise(pixels, 0.05f, 0.0042f, static_cast<std::uint32_t>(f + 1));
    ASSERT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  }
  int on_wall = 0;
  for (float y = -2.0f; y <= 2.0f; y += 0.2f) {
    bool found = false;
    for (float x = 7.6f; x <= 8.6f; x += 0.1f) found = found || layer->occupied({x, y});
    on_wall += found ? 1 : 0;
    for (float x = 4.5f; x <= 7.0f; x += 0.1f) {
      EXPECT_FALSE(layer->occupied({x, y})) << x << " " << y;
    }
  }
  EXPECT_GE(on_wall, 19);  // of 21 rows
}

TEST(FarFieldLayer, WalkersLeaveNoTrailAndFreeRaysClearWhatMoved) {
  const CameraIntrinsics cam = camera();
  std::vector<std::uint16_t> pixels;
  // A person-sized box at 7 m (1.7 m tall): not a wall, with or without an exclusion disc.
  test::WorldScene person;
  person.boxes.push_back(test::person_at(7.0f, 0.0f));
  auto layer = make_layer();
  DepthView view = test::render(person, cam, kLookingAtWall, pixels);
  ASSERT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_FALSE(occupied_near(*layer, Eigen::Vector2f(7.0f, 0.0f), 0.5f));
  // A tall box there is a wall without the disc and none with it.
  test::WorldScene tall;
  tall.boxes.push_back(
      Box3{Eigen::Vector3f(6.75f, -0.25f, 0.0f), Eigen::Vector3f(7.25f, 0.25f, 2.4f)});
  view = test::render(tall, cam, kLookingAtWall, pixels);
  const FarFieldExclusion disc{Eigen::Vector2f(7.0f, 0.0f), 0.45f};
  ASSERT_EQ(layer->update(view, cam, kLookingAtWall, &disc, 1), Status::kOk);
  EXPECT_FALSE(occupied_near(*layer, Eigen::Vector2f(7.0f, 0.0f), 0.5f));
  ASSERT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_TRUE(occupied_near(*layer, Eigen::Vector2f(6.8f, 0.0f), 0.1f));
  // It goes away: the wall behind it at 8.5 m is seen and the rays through 6.8 m clear the cell.
  test::WorldScene behind;
  behind.boxes.push_back(wall_across(8.5f, 3.0f));
  view = test::render(behind, cam, kLookingAtWall, pixels);
  for (int f = 0; f < 8; ++f) {
    ASSERT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  }
  EXPECT_FALSE(occupied_near(*layer, Eigen::Vector2f(7.0f, 0.0f), 0.5f));
  EXPECT_TRUE(occupied_near(*layer, Eigen::Vector2f(8.55f, 0.0f), 0.1f));
}

TEST(FarFieldLayer, ALowCrateThatStaysIsAWallAWalkerGoingPastIsNot) {
  // Lower than wall_height, a 1 m crate at 7 m is a wall only once seen in low_frames frames
  // (short gaps allowed); an untracked walker's front moves on before any cell counts that long.
  const CameraIntrinsics cam = camera();
  std::vector<std::uint16_t> pixels;
  test::WorldScene crate;
  crate.boxes.push_back(
      Box3{Eigen::Vector3f(7.0f, -0.5f, 0.0f), Eigen::Vector3f(8.0f, 0.5f, 1.0f)});
  auto layer = make_layer();
  const int frames = layer->config().low_frames;
  ASSERT_GT(frames, 1);
  // Seen for 20 frames, hidden for 12 by a tracked walker in front (its pixels excluded), then
  // seen again: the count goes on through the gap.
  std::vector<std::uint16_t> hidden_pixels;
  test::WorldScene hidden = crate;
  hidden.boxes.push_back(test::person_at(5.5f, 0.0f));
  const FarFieldExclusion disc{Eigen::Vector2f(5.5f, 0.0f), 0.45f};
  const DepthView seen = test::render(crate, cam, kLookingAtWall, pixels);
  const DepthView behind = test::render(hidden, cam, kLookingAtWall, hidden_pixels);
  int seen_frames = 0;
  for (int f = 0; seen_frames < frames - 1; ++f) {
    const bool hide = f >= 20 && f < 32;
    ASSERT_EQ(layer->update(hide ? behind : seen, cam, kLookingAtWall, hide ? &disc : nullptr,
                            hide ? 1 : 0),
              Status::kOk);
    seen_frames += hide ? 0 : 1;
    ASSERT_FALSE(occupied_near(*layer, Eigen::Vector2f(7.1f, 0.0f), 0.2f)) << "frame " << f;
  }
  ASSERT_EQ(layer->update(seen, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_TRUE(occupied_near(*layer, Eigen::Vector2f(7.1f, 0.0f), 0.2f));
  EXPECT_EQ(layer->last_hits(), 0u);  // never a tall wall

  // A 1.7 m person 7 m away walking 2 m across and back at 0.5 m/s for 16 s, with no exclusion
  // disc and nothing behind it to clear its cells: it comes back to a cell too late for the
  // count to go on, so no wall anywhere.
  auto fresh = make_layer();
  for (int f = 0; f < 480; ++f) {
    const float s_walked = std::fmod(0.5f * static_cast<float>(f) / 30.0f, 4.0f);
    const float y = s_walked < 2.0f ? -1.0f + s_walked : 3.0f - s_walked;
    test::WorldScene walker;
    walker.boxes.push_back(test::person_at(7.0f, y));
    const DepthView v = test::render(walker, cam, kLookingAtWall, pixels);
    ASSERT_EQ(fresh->update(v, cam, kLookingAtWall, nullptr, 0), Status::kOk);
    for (float yy = -2.6f; yy <= 2.6f; yy += 0.2f) {
      ASSERT_FALSE(occupied_near(*fresh, Eigen::Vector2f(6.9f, yy), 0.3f)) << f << " " << yy;
    }
  }
}

TEST(FarFieldLayer, WallSeenOnlyAboveABoxInFrontIsAWall) {
  // A 2 m box 3.45 m away hides a 3 m wall at 5 m up to 2.29 m: only the wall's top is in view,
  // as a corridor's wall is behind the boxes lining it. The band up to max_height (2.5 m) holds
  // three or four sampled rows of it in every column, enough for a surface; a band ending at
  // 2.4 m holds one or two.
  const Pose pose = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, 1.35f), 0.0f);
  test::WorldScene scene;
  scene.boxes.push_back(
      Box3{Eigen::Vector3f(3.45f, -3.0f, 0.0f), Eigen::Vector3f(3.95f, 3.0f, 2.0f)});
  scene.boxes.push_back(
      Box3{Eigen::Vector3f(5.0f, -4.0f, 0.0f), Eigen::Vector3f(5.2f, 4.0f, 3.0f)});
  std::vector<std::uint16_t> pixels;
  const CameraIntrinsics cam = camera();
  const DepthView view = test::render(scene, cam, pose, pixels);
  auto layer = make_layer();
  ASSERT_EQ(layer->update(view, cam, pose, nullptr, 0), Status::kOk);
  int on_wall = 0;
  for (float y = -1.5f; y <= 1.5f; y += 0.2f) on_wall += occupied_near(*layer, {5.05f, y}, 0.1f);
  EXPECT_GE(on_wall, 14);  // of 16 rows
}

/// Walls the layer writes over `frames` frames of a flat ceiling `height` above the floor, seen
/// from a level camera `camera_z` high, with range noise on every frame.
std::size_t ceiling_hits(float height, float camera_z, const FarFieldConfig& config,
                         int frames = 20) {
  const Pose pose = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, camera_z), 0.0f);
  test::WorldScene scene;
  scene.boxes.push_back(
      Box3{Eigen::Vector3f(-1.0f, -8.0f, height), Eigen::Vector3f(14.0f, 8.0f, height + 0.1f)});
  const CameraIntrinsics cam = camera();
  auto layer = make_layer(config);
  std::vector<std::uint16_t> pixels;
  std::size_t hits = 0;
  for (int f = 0; f < frames; ++f) {
    const DepthView view = test::render(scene, cam, pose, pixels);
    add_range_noise(pixels, 0.05f, 0.0042f, static_cast<std::uint32_t>(f + 1));
    EXPECT_EQ(layer->update(view, cam, pose, nullptr, 0), Status::kOk);
    hits += layer->last_hits();
  }
  return hits;
}

TEST(FarFieldLayer, ACeilingInTheHeightBandIsNoWall) {
  // Seen edge-on, a ceiling's returns spread over the range bins, but the range noise bunches a
  // few of them into one window now and then; at nearly one height, unlike a wall's, so they
  // end the free ray but are written as no wall (min_rise_sigmas).
  FarFieldConfig on;
  on.enabled = true;
  FarFieldConfig off = on;
  off.min_rise_sigmas = 0.0f;
  // A 2.5 m ceiling, at the band's top: no wall from a camera 1.0, 1.35 or 1.6 m high.
  for (const float z : {1.0f, 1.35f, 1.6f}) {
    EXPECT_EQ(ceiling_hits(2.5f, z, on), 0u) << "camera at " << z;
  }
  // Just inside the band, where most bunches pass the band's noise margin: a third or fewer
  // of the walls without the flatness test are left.
  std::size_t with_test = 0;
  std::size_t without = 0;
  for (const float z : {1.0f, 1.35f}) {
    with_test += ceiling_hits(on.max_height - 0.05f, z, on);
    without += ceiling_hits(on.max_height - 0.05f, z, off);
  }
  EXPECT_GT(without, 30u);
  EXPECT_LE(3 * with_test, without) << with_test << " of " << without;

  // A hanging panel (a vertical face at the same height) is a wall: the test can fail.
  const Pose pose = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, 1.35f), 0.0f);
  test::WorldScene scene;
  scene.boxes.push_back(
      Box3{Eigen::Vector3f(-1.0f, -8.0f, 2.5f), Eigen::Vector3f(14.0f, 8.0f, 2.6f)});
  scene.boxes.push_back(
      Box3{Eigen::Vector3f(6.0f, -1.0f, 2.1f), Eigen::Vector3f(6.1f, 1.0f, 2.5f)});
  std::vector<std::uint16_t> pixels;
  const CameraIntrinsics cam = camera();
  auto layer = make_layer(on);
  const DepthView view = test::render(scene, cam, pose, pixels);
  ASSERT_EQ(layer->update(view, cam, pose, nullptr, 0), Status::kOk);
  EXPECT_TRUE(occupied_near(*layer, Eigen::Vector2f(6.05f, 0.0f), 0.1f));
}

TEST(FarFieldLayer, ConfigAndBadInputAreRefusedAndChangeNothing) {
  FarFieldConfig bad;
  bad.cell_size = 0.01f;
  FarFieldLayer l0;
  EXPECT_EQ(l0.init(bad, 0.0f), Status::kInvalidArgument);
  EXPECT_FALSE(l0.initialised());
  bad = FarFieldConfig{};
  bad.max_range = 30.0f;
  EXPECT_EQ(validate(bad), Status::kInvalidArgument);
  bad = FarFieldConfig{};
  bad.wall_height = 3.0f;  // above max_height
  EXPECT_EQ(validate(bad), Status::kInvalidArgument);
  bad = FarFieldConfig{};
  bad.min_pixels = 0;
  EXPECT_EQ(validate(bad), Status::kInvalidArgument);
  EXPECT_EQ(validate(FarFieldConfig{}), Status::kOk);

  const CameraIntrinsics cam = camera();
  std::vector<std::uint16_t> pixels;
  const DepthView view = wall_at_8m(cam, pixels);
  EXPECT_EQ(l0.update(view, cam, kLookingAtWall, nullptr, 0), Status::kNotInitialized);
  auto layer = make_layer();
  EXPECT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, 1), Status::kNullData);
  EXPECT_EQ(layer->update(view, cam, kLookingAtWall, nullptr, kFarFieldMaxExclusions + 1),
            Status::kCapacityExceeded);
  Pose nan_pose = kLookingAtWall;
  nan_pose.translation.x() = NAN;
  EXPECT_EQ(layer->update(view, cam, nan_pose, nullptr, 0), Status::kNonFinite);
  const FarFieldExclusion nan_disc{Eigen::Vector2f(NAN, 0.0f), 0.3f};
  EXPECT_EQ(layer->update(view, cam, kLookingAtWall, &nan_disc, 1), Status::kNonFinite);
  DepthView null_view = view;
  null_view.data = nullptr;
  EXPECT_NE(layer->update(null_view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  EXPECT_EQ(layer->frames(), 0u);
  EXPECT_FALSE(layer->occupied(Eigen::Vector2f(8.05f, 0.0f)));
}

/// Every cell's evidence and wall state within 12 m of the origin, and the last frame's hits.
std::vector<int> layer_state(const FarFieldLayer& layer) {
  std::vector<int> state;
  for (float x = -11.9f; x < 12.0f; x += 0.2f) {
    for (float y = -11.9f; y < 12.0f; y += 0.2f) {
      const Eigen::Vector2f p(x, y);
      state.push_back(layer.evidence(p) * 2 + (layer.occupied(p) ? 1 : 0));
    }
  }
  state.push_back(static_cast<int>(layer.last_hits()));
  state.push_back(static_cast<int>(layer.frames()));
  return state;
}

TEST(FarFieldLayer, BinningInPartsEndsBitForBitAsUpdate) {
  const CameraIntrinsics cam = camera();
  // Walls at 6-9 m, a tall box and a walker in front of them; the camera turns and moves, and
  // the discs change (none to three, one of them beside the camera).
  test::WorldScene scene;
  scene.boxes.push_back(wall_across(8.0f, 4.0f));
  scene.boxes.push_back(
      Box3{Eigen::Vector3f(-7.0f, -6.0f, 0.0f), Eigen::Vector3f(-6.8f, 6.0f, 2.5f)});
  scene.boxes.push_back(Box3{Eigen::Vector3f(6.0f, 1.0f, 0.0f), Eigen::Vector3f(6.5f, 1.5f, 2.4f)});
  scene.boxes.push_back(test::person_at(6.5f, -1.0f));
  const std::vector<FarFieldExclusion> discs = {{Eigen::Vector2f(6.2f, 1.2f), 0.5f},
                                                {Eigen::Vector2f(6.5f, -1.0f), 0.4f},
                                                {Eigen::Vector2f(0.3f, 0.2f), 0.4f}};
  for (unsigned parts = 1; parts <= kFarFieldMaxBinParts; ++parts) {
    SCOPED_TRACE(parts);
    auto whole = make_layer();
    auto in_parts = make_layer();
    std::vector<std::uint16_t> pixels;
    int frames_with_walls = 0;
    for (int f = 0; f < 16; ++f) {
      const float yaw = 0.15f * static_cast<float>(f % 8) - 0.5f + (f >= 12 ? 3.14159265f : 0.0f);
      const Pose pose =
          test::level_camera(Eigen::Vector3f(0.05f * static_cast<float>(f), 0.0f, 1.3f), yaw);
      const DepthView view = test::render(scene, cam, pose, pixels);
      add_range_noise(pixels, 0.02f, 0.0042f, static_cast<std::uint32_t>(f + 1));  // in place
      const std::size_t n = static_cast<std::size_t>(f % 4);
      ASSERT_EQ(whole->update(view, cam, pose, discs.data(), n), Status::kOk);
      ASSERT_EQ(in_parts->begin_update(view, cam, pose, discs.data(), n), Status::kOk);
      for (unsigned p = parts; p-- > 0;) in_parts->bin_columns(p, parts);  // any order
      in_parts->finish_update();
      ASSERT_EQ(layer_state(*whole), layer_state(*in_parts)) << "frame " << f;
      frames_with_walls += whole->last_hits() > 0 ? 1 : 0;
    }
    EXPECT_GE(frames_with_walls, 6);  // the comparison is not one of empty grids
  }
}

TEST(FarFieldLayer, StepsWithoutABegunFrameDoNothing) {
  const CameraIntrinsics cam = camera();
  std::vector<std::uint16_t> pixels;
  const DepthView view = wall_at_8m(cam, pixels);
  FarFieldLayer l0;
  EXPECT_EQ(l0.begin_update(view, cam, kLookingAtWall, nullptr, 0), Status::kNotInitialized);
  auto layer = make_layer();
  layer->bin_columns(0, 1);
  layer->finish_update();
  EXPECT_EQ(layer->frames(), 0u);
  EXPECT_EQ(layer->begin_update(view, cam, kLookingAtWall, nullptr, 1), Status::kNullData);
  layer->finish_update();  // the refused frame was not taken
  EXPECT_EQ(layer->frames(), 0u);
  ASSERT_EQ(layer->begin_update(view, cam, kLookingAtWall, nullptr, 0), Status::kOk);
  layer->bin_columns(1, 1);  // no such part
  layer->bin_columns(0, kFarFieldMaxBinParts + 1);
  EXPECT_EQ(layer->frames(), 0u);  // nothing written before finish_update()
  layer->bin_columns(0, 1);
  layer->finish_update();
  EXPECT_EQ(layer->frames(), 1u);
  EXPECT_TRUE(layer->occupied(Eigen::Vector2f(8.05f, 0.0f)));
  layer->finish_update();  // once per begun frame
  EXPECT_EQ(layer->frames(), 1u);
}

TEST(FarFieldLayer, UpdateAndItsStepsAllocateNothing) {
  const CameraIntrinsics cam = camera();
  std::vector<std::uint16_t> pixels;
  const DepthView view = wall_at_8m(cam, pixels);
  auto layer = make_layer();
  const FarFieldExclusion disc{Eigen::Vector2f(5.0f, 0.0f), 0.4f};
  std::size_t allocations = 0;
  {
    test::AllocationGuard guard;
    for (int f = 0; f < 5; ++f) {
      (void)layer->update(view, cam, kLookingAtWall, &disc, 1);
      (void)layer->begin_update(view, cam, kLookingAtWall, &disc, 1);
      for (unsigned p = 0; p < kFarFieldMaxBinParts; ++p)
        layer->bin_columns(p, kFarFieldMaxBinParts);
      layer->finish_update();
    }
    allocations = guard.allocations();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_TRUE(layer->occupied(Eigen::Vector2f(8.05f, 0.0f)));
}

}  // namespace
}  // namespace dynamap
