#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <memory>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/map/ever_free_grid.hpp"
#include "dynamap/track/tracker.hpp"
#include "world_scene.hpp"

namespace dynamap {
namespace {

constexpr Stamp kFrame = 33'333'333;  // 30 Hz
constexpr float kCameraHeight = 1.0f;
constexpr float kWallDistance = 4.0f;

// Camera at (0, 0, 1 m) looking along map +x (optical z -> map x, x -> -y, y -> -z).
Pose camera_pose() {
  Pose p;
  p.translation = Eigen::Vector3f(0.f, 0.f, kCameraHeight);
  Eigen::Matrix3f r;
  r << 0.f, 0.f, 1.f, -1.f, 0.f, 0.f, 0.f, -1.f, 0.f;
  p.rotation = Eigen::Quaternionf(r);
  return p;
}

// An upright box of the scene: near face at depth `x`, lateral [y0, y1], heights [z0, z1].
struct Block {
  float x, y0, y1, z0, z1;
  Box3 visible_box() const {  // the near surface, as a depth detector measures it
    return Box3{Eigen::Vector3f(x, y0, z0), Eigen::Vector3f(x + 0.05f, y1, z1)};
  }
};

// A wall at kWallDistance filling the view, with the blocks in front of it.
struct Scene {
  CameraIntrinsics cam{};
  std::vector<std::uint16_t> pixels;

  DepthView render(const std::vector<Block>& blocks) {
    pixels.assign(static_cast<std::size_t>(cam.width * cam.height), 0);
    for (int v = 0; v < cam.height; ++v) {
      for (int u = 0; u < cam.width; ++u) {
        float depth = kWallDistance;
        const float lateral = -(static_cast<float>(u) - cam.cx) / cam.fx;  // map y per metre
        const float up = -(static_cast<float>(v) - cam.cy) / cam.fy;       // map z per metre
        for (const Block& b : blocks) {
          const float y = lateral * b.x;
          const float z = kCameraHeight + up * b.x;
          if (b.x < depth && y >= b.y0 && y <= b.y1 && z >= b.z0 && z <= b.z1) depth = b.x;
        }
        pixels[static_cast<std::size_t>(v * cam.width + u)] =
            static_cast<std::uint16_t>(std::lround(depth / cam.depth_scale));
      }
    }
    return DepthView{pixels.data(), cam.width, cam.height,
                     cam.width * static_cast<int>(sizeof(std::uint16_t))};
  }
};

std::unique_ptr<EverFreeGrid> make_grid(const EverFreeConfig& config = {}) {
  auto g = std::make_unique<EverFreeGrid>();
  EXPECT_EQ(g->init(config, 0.f), Status::kOk);
  return g;
}

Block walker_at(float y) {
  return Block{2.5f, y - 0.25f, y + 0.25f, 0.05f, 1.75f};
}

TEST(EverFreeGrid, SpaceSeenEmptyBecomesEverFreeAndAWalkerInItCounts) {
  auto grid = make_grid();
  Scene scene;
  const Pose pose = camera_pose();
  const EverFreeConfig c;
  for (int i = 0; i < c.burn_in_frames - 1; ++i) {
    ASSERT_EQ(grid->integrate(scene.render({}), scene.cam, pose), Status::kOk);
  }
  EXPECT_FALSE(grid->ever_free_at(Eigen::Vector3f(2.5f, 0.f, 1.f)));  // one frame short
  ASSERT_EQ(grid->integrate(scene.render({}), scene.cam, pose), Status::kOk);
  EXPECT_TRUE(grid->ever_free_at(Eigen::Vector3f(2.5f, 0.f, 1.f)));
  EXPECT_FALSE(grid->ever_free_at(Eigen::Vector3f(kWallDistance, 0.f, 1.f)));  // the wall
  EXPECT_FALSE(grid->ever_free_at(Eigen::Vector3f(6.f, 0.f, 1.f)));            // behind it

  const Block walker = walker_at(0.f);
  ASSERT_EQ(grid->integrate(scene.render({walker}), scene.cam, pose), Status::kOk);
  EXPECT_GE(grid->ever_free_share(walker.visible_box()), 0.9f);
  const Box3 wall_piece{Eigen::Vector3f(kWallDistance - 0.05f, 1.f, 0.3f),
                        Eigen::Vector3f(kWallDistance + 0.05f, 1.5f, 1.8f)};
  EXPECT_EQ(grid->ever_free_share(wall_piece), 0.f);
}

TEST(EverFreeGrid, AnObjectThereFromTheStartIsNeverEverFree) {
  auto grid = make_grid();
  Scene scene;
  const Pose pose = camera_pose();
  const Block cabinet{3.0f, 1.0f, 1.5f, 0.05f, 1.2f};
  for (int i = 0; i < 60; ++i) {
    ASSERT_EQ(grid->integrate(scene.render({cabinet}), scene.cam, pose), Status::kOk);
    EXPECT_EQ(grid->ever_free_share(cabinet.visible_box()), 0.f) << "frame " << i;
  }
}

TEST(EverFreeGrid, AnOccupantStayingLongerThanForgetFramesIsForgotten) {
  EverFreeConfig c;
  c.forget_frames = 20;
  auto grid = make_grid(c);
  Scene scene;
  const Pose pose = camera_pose();
  for (int i = 0; i < c.burn_in_frames; ++i) {
    ASSERT_EQ(grid->integrate(scene.render({}), scene.cam, pose), Status::kOk);
  }
  const Block stopped = walker_at(0.f);
  for (int i = 1; i <= c.forget_frames; ++i) {
    ASSERT_EQ(grid->integrate(scene.render({stopped}), scene.cam, pose), Status::kOk);
    if (i < c.forget_frames) {
      EXPECT_GE(grid->ever_free_share(stopped.visible_box()), 0.9f);
    }
  }
  EXPECT_EQ(grid->ever_free_share(stopped.visible_box()), 0.f);
}

TEST(EverFreeGrid, BadInputChangesNothingAndBadConfigIsRefused) {
  auto grid = make_grid();
  Scene scene;
  const Pose pose = camera_pose();
  for (int i = 0; i < 10; ++i)
    ASSERT_EQ(grid->integrate(scene.render({}), scene.cam, pose), Status::kOk);
  const Block walker = walker_at(0.f);
  ASSERT_EQ(grid->integrate(scene.render({walker}), scene.cam, pose), Status::kOk);
  const float before = grid->ever_free_share(walker.visible_box());
  DepthView null_view = scene.render({});
  null_view.data = nullptr;
  EXPECT_EQ(grid->integrate(null_view, scene.cam, pose), Status::kNullData);
  Pose nan_pose = pose;
  nan_pose.translation.x() = std::nanf("");
  EXPECT_EQ(grid->integrate(scene.render({}), scene.cam, nan_pose), Status::kNonFinite);
  EXPECT_EQ(grid->ever_free_share(walker.visible_box()), before);

  using Edit = void (*)(EverFreeConfig&);
  for (Edit bad :
       std::initializer_list<Edit>{[](EverFreeConfig& c) { c.resolution = 0.f; },
                                   [](EverFreeConfig& c) { c.layers = kEverFreeMaxLayers + 1; },
                                   [](EverFreeConfig& c) { c.pixel_step = 0; },
                                   [](EverFreeConfig& c) { c.burn_in_frames = 256; },
                                   [](EverFreeConfig& c) { c.max_range = std::nanf(""); },
                                   [](EverFreeConfig& c) { c.whole_in_view = 5; },
                                   [](EverFreeConfig& c) { c.whole_in_view = 1; },
                                   [](EverFreeConfig& c) { c.whole_in_view = 3; }}) {
    EverFreeConfig c;
    bad(c);
    EverFreeGrid g;
    EXPECT_EQ(g.init(c, 0.f), Status::kInvalidArgument);
  }
}

// A standing person just beyond the right image border while the camera looks ahead, then the
// view turning onto it, as a hovering camera's yaw sweep does: the rays beside it see the
// in-view part of its cells empty. Only a cell wholly inside the view's sides counts as seen
// free, so the person's first hits are no ever-free evidence; marking the cut cells too
// labelled such a person dynamic for 41 frames (fresh suite seed 136).
float share_while_turning_onto_a_person(int whole_in_view) {
  EverFreeConfig c;
  c.whole_in_view = whole_in_view;
  auto grid = make_grid(c);
  const CameraIntrinsics cam;
  const float half_fov =
      std::atan((static_cast<float>(cam.width) - 0.5f - cam.cx) / cam.fx);  // right border
  // The person's corner nearest the view's right border 0.03 rad beyond it.
  const float x = 2.5f;
  const float y = -std::tan(half_fov + 0.03f) * (x + 0.25f) - 0.25f;
  test::WorldScene world;
  world.boxes = {Box3{Eigen::Vector3f(5.f, -6.f, 0.f), Eigen::Vector3f(5.2f, 6.f, 3.f)},
                 test::person_at(x, y)};
  std::vector<std::uint16_t> pixels;
  const Eigen::Vector3f position(0.f, 0.f, 1.2f);
  float share = 0.f;
  for (int i = 0; i < 30; ++i) {  // looking ahead: three times the burn-in
    const Pose pose = test::level_camera(position, 0.f);
    EXPECT_EQ(grid->integrate(test::render(world, cam, pose, pixels), cam, pose), Status::kOk);
    share = std::max(share, grid->ever_free_share(world.boxes[1]));
  }
  EXPECT_EQ(share, 0.f);           // out of view
  for (int i = 1; i <= 15; ++i) {  // turning right 0.6 degrees a frame, 0.15 rad in all
    const Pose pose = test::level_camera(position, -0.01f * static_cast<float>(i));
    EXPECT_EQ(grid->integrate(test::render(world, cam, pose, pixels), cam, pose), Status::kOk);
    share = std::max(share, grid->ever_free_share(world.boxes[1]));
  }
  return share;
}

TEST(EverFreeGrid, AnObjectTheViewTurnsOntoIsNotEverFree) {
  const float evidence = TrackerConfig{}.ever_free_share;
  const float sides = share_while_turning_onto_a_person(2);
  const float all_four = share_while_turning_onto_a_person(4);
  const float cut_cells_too = share_while_turning_onto_a_person(0);
  EXPECT_LT(sides, evidence);
  EXPECT_LT(all_four, evidence);
  EXPECT_GE(cut_cells_too, evidence);  // marking the cells the border cuts: ever free
  std::printf("ever-free share of the person: sides %.2f, all four %.2f, cut cells too %.2f\n",
              static_cast<double>(sides), static_cast<double>(all_four),
              static_cast<double>(cut_cells_too));
}

// The tracker side: a walker stepping into space the camera has seen free is dynamic within 5
// frames of its first detection; a cabinet there from the start is never dynamic. Both run
// allocation-free.
TEST(EverFreeGrid, TrackerLabelsAWalkerInEverFreeSpaceWithinFiveFrames) {
  auto grid = make_grid();
  auto tracker = std::make_unique<Tracker>();
  ASSERT_EQ(tracker->init(TrackerConfig{}, 640, 480), Status::kOk);
  Scene scene;
  const Pose pose = camera_pose();
  const Block cabinet{3.0f, 1.0f, 1.5f, 0.05f, 1.2f};
  constexpr int kEmptyFrames = 30;
  constexpr int kFrames = 90;
  std::vector<DepthView> views;
  std::vector<std::vector<std::uint16_t>> images(kFrames);
  std::vector<Block> walkers;
  for (int i = 0; i < kFrames; ++i) {  // render first: the renderer allocates
    const float y = -1.5f + static_cast<float>(i - kEmptyFrames) / 30.f;  // 1 m/s along +y
    walkers.push_back(walker_at(y));
    std::vector<Block> blocks{cabinet};
    if (i >= kEmptyFrames) blocks.push_back(walkers.back());
    scene.render(blocks);
    images[static_cast<std::size_t>(i)] = scene.pixels;
    views.push_back(DepthView{images[static_cast<std::size_t>(i)].data(), scene.cam.width,
                              scene.cam.height, scene.cam.width * 2});
  }
  int walker_dynamic_at = -1;
  bool cabinet_ever_dynamic = false;
  std::size_t allocations = 0;
  {
    test::AllocationGuard guard;
    for (int i = 0; i < kFrames; ++i) {
      ASSERT_EQ(grid->integrate(views[static_cast<std::size_t>(i)], scene.cam, pose), Status::kOk);
      std::array<Detection, 2> dets{};
      std::size_t n = 0;
      const Block* blocks[2] = {&cabinet, &walkers[static_cast<std::size_t>(i)]};
      for (int b = 0; b < (i >= kEmptyFrames ? 2 : 1); ++b) {
        Detection& d = dets[n++];
        d.raw_box = blocks[b]->visible_box();
        d.box = d.raw_box;
        d.image_box = ImageBox{200, 100, 300, 400};
        d.near_depth = blocks[b]->x;
      }
      grid->annotate(dets.data(), n);
      ASSERT_EQ(tracker->update(dets.data(), n, pose, static_cast<Stamp>(i + 1) * kFrame),
                Status::kOk);
      for (std::size_t k = 0; k < tracker->size(); ++k) {
        const TrackedObstacle& o = tracker->obstacle(k);
        if (!o.dynamic) continue;
        if (o.box.center().x() > 2.9f) cabinet_ever_dynamic = true;
        if (o.box.center().x() < 2.9f && walker_dynamic_at < 0) walker_dynamic_at = i;
      }
    }
    allocations = guard.allocations();
  }
  EXPECT_EQ(allocations, 0u);
  ASSERT_GE(walker_dynamic_at, kEmptyFrames);
  EXPECT_LT(walker_dynamic_at - kEmptyFrames, 5);  // within 5 frames of its first detection
  EXPECT_FALSE(cabinet_ever_dynamic);
}

TEST(EverFreeGrid, WithoutEvidenceTheTrackerWaitsForItsVotes) {
  // Same walker with the ever-free label off: the continuity votes need more than 5 frames.
  TrackerConfig tc;
  tc.label.ever_free_frames = 0;
  auto tracker = std::make_unique<Tracker>();
  ASSERT_EQ(tracker->init(tc, 640, 480), Status::kOk);
  const Pose pose = camera_pose();
  int dynamic_at = -1;
  for (int i = 0; i < 30 && dynamic_at < 0; ++i) {
    Detection d;
    d.raw_box = walker_at(-1.5f + static_cast<float>(i) / 30.f).visible_box();
    d.box = d.raw_box;
    d.image_box = ImageBox{200, 100, 300, 400};
    d.near_depth = 2.5f;
    d.ever_free = 1.f;
    ASSERT_EQ(tracker->update(&d, 1, pose, static_cast<Stamp>(i + 1) * kFrame), Status::kOk);
    if (tracker->size() == 1 && tracker->obstacle(0).dynamic) dynamic_at = i;
  }
  EXPECT_GE(dynamic_at, 5);
}

}  // namespace
}  // namespace dynamap
