// Map accuracy (docs/evaluation.md, "Map accuracy"): the PLY map file, the truth voxels of a
// static world, dynamap-eval --map's scoring on a hand-made world and dynamap-replay's per-frame
// erased / free-through counting and its --static-model hole counting on hand-made maps.
#include <gtest/gtest.h>

#include "temp_dir.hpp"

#include <stdlib.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <string>

#include "common/map_io.hpp"
#include "common/map_truth.hpp"
#include "common/png_io.hpp"
#include "common/static_world.hpp"
#include "common/text_io.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "eval/map_accuracy.hpp"

namespace {

namespace fs = std::filesystem;
using namespace dynamap;
using namespace dynamap::tools;

using dynamap::test::TempDir;

void write_file(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// The message of the ToolError that f throws ("" when it throws none).
template <class F>
std::string error_of(F&& f) {
  try {
    f();
  } catch (const ToolError& e) {
    return e.what();
  }
  return "";
}

std::int64_t key(int i, int j, int k) {
  return pack_voxel(Eigen::Vector3i(i, j, k));
}

TEST(MapPly, WriteThenReadGivesTheSameVoxelsAndProbabilities) {
  TempDir dir;
  const std::vector<MapVoxel> voxels = {{Eigen::Vector3f(0.05f, -1.25f, 0.35f), 0.97f},
                                        {Eigen::Vector3f(-12.35f, 4.45f, 2.95f), 0.8012345f},
                                        {Eigen::Vector3f(1e3f, 0.15f, -0.05f), 1.0f}};
  write_map_ply(dir / "map.ply", voxels);
  const std::vector<MapVoxel> back = read_map_ply(dir / "map.ply");
  ASSERT_EQ(back.size(), voxels.size());
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    EXPECT_EQ(back[i].centre, voxels[i].centre) << i;  // binary float32: bit for bit
    EXPECT_EQ(back[i].probability, voxels[i].probability) << i;
  }
  write_map_ply(dir / "empty.ply", {});
  EXPECT_TRUE(read_map_ply(dir / "empty.ply").empty());
}

TEST(MapPly, ReadsAsciiWithOtherPropertiesAndNamesTheLineOfBadInput) {
  TempDir dir;
  write_file(dir / "a.ply",
             "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex 2\n"
             "property uchar red\nproperty float x\nproperty float y\nproperty float z\n"
             "property double probability\nend_header\n"
             "255 0.05 0.15 0.25 0.9\n0 -0.05 0.05 1.05 0.75\n");
  const auto v = read_map_ply(dir / "a.ply");
  ASSERT_EQ(v.size(), 2u);
  EXPECT_FLOAT_EQ(v[1].centre.z(), 1.05f);
  EXPECT_FLOAT_EQ(v[1].probability, 0.75f);
  write_file(dir / "b.ply",
             "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
             "property float z\nproperty float probability\nend_header\n0 0 0 0.9\n0 0 zero 0.9\n");
  EXPECT_NE(error_of([&] { read_map_ply(dir / "b.ply"); }).find("b.ply:10:"), std::string::npos);
  write_file(dir / "c.ply",
             "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
             "end_header\n0\n");
  EXPECT_NE(error_of([&] { read_map_ply(dir / "c.ply"); }).find("probability"), std::string::npos);
  // Binary body shorter than its vertex count.
  write_map_ply(dir / "d.ply", {{Eigen::Vector3f::Zero(), 0.9f}, {Eigen::Vector3f::Ones(), 0.9f}});
  fs::resize_file(dir / "d.ply", fs::file_size(dir / "d.ply") - 4);
  EXPECT_NE(error_of([&] { read_map_ply(dir / "d.ply"); }).find("d.ply: file ends at vertex 1"),
            std::string::npos);
  EXPECT_NE(error_of([&] { read_map_ply(dir / "none.ply"); }).find("none.ply"), std::string::npos);
}

TEST(MapSummary, KeysAndBadNumbers) {
  TempDir dir;
  write_map_summary(dir / "s.txt", {{"resolution", "0.1"}, {"local_half_extent", "5 5 3"}});
  const MapSummary s = read_map_summary(dir / "s.txt");
  EXPECT_DOUBLE_EQ(s.number("resolution", 0.2), 0.1);
  EXPECT_DOUBLE_EQ(s.number("max_depth", 5.0), 5.0);
  EXPECT_FALSE(error_of([&] { s.number("local_half_extent", 0); }).empty());
  write_file(dir / "t.txt", "resolution 0.1\nresolution 0.2\n");
  EXPECT_NE(error_of([&] { read_map_summary(dir / "t.txt"); }).find("t.txt:2:"), std::string::npos);
}

// A box of 4 x 4 x 4 voxels (0.1 m) standing on the floor z = 0.
StaticWorld one_box_world() {
  StaticWorld w;
  w.has_floor = true;
  w.floor_z = 0.0;
  w.boxes.push_back(StaticBox{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.4, 0.4, 0.4)});
  return w;
}

TEST(MapTruth, SurfaceInteriorAndFloorVoxelsOfABox) {
  const StaticTruthVoxels t = static_truth_voxels(one_box_world(), 0.1);
  // 64 voxels overlap the box; the 2 x 2 x 2 in the middle touch no face: 56 surface voxels.
  // Every centre (0.05 .. 0.35 per axis) lies inside: 64 interior voxels. The voxels beyond a
  // face (e.g. i = 4, whose face x = 0.4 lies on the box's) are neither.
  EXPECT_EQ(t.surface.size(), 56u);
  EXPECT_EQ(t.interior.size(), 64u);
  const std::set<std::int64_t> surface = [&] {
    std::set<std::int64_t> s;
    for (const auto& v : t.surface) s.insert(pack_voxel(v));
    return s;
  }();
  EXPECT_EQ(surface.count(key(1, 1, 1)), 0u);
  EXPECT_EQ(surface.count(key(3, 3, 3)), 1u);
  EXPECT_EQ(surface.count(key(4, 0, 0)), 0u);
  EXPECT_EQ(surface.count(key(0, 0, -1)), 0u);
  // The floor at z = 0 lies on a voxel boundary: the layers k = -1 and k = 0 both touch it.
  const StaticWorld w = one_box_world();
  EXPECT_TRUE(is_floor_voxel(w, Eigen::Vector3i(7, 7, -1), 0.1));
  EXPECT_TRUE(is_floor_voxel(w, Eigen::Vector3i(7, 7, 0), 0.1));
  EXPECT_FALSE(is_floor_voxel(w, Eigen::Vector3i(7, 7, 1), 0.1));
  // Within one voxel of the box: i = 4 is; i = 5 is not (grown by 0.1 m it only touches x = 0.4).
  EXPECT_TRUE(near_static_shape(w, Eigen::Vector3i(4, 1, 1), 0.1, 0.1));
  EXPECT_FALSE(near_static_shape(w, Eigen::Vector3i(5, 1, 1), 0.1, 0.1));
  EXPECT_EQ(pack_voxel(unpack_voxel(key(-7, 3, -1))), key(-7, 3, -1));
  EXPECT_EQ(unpack_voxel(key(-7, 3, -1)), Eigen::Vector3i(-7, 3, -1));
}

// dynamap-eval --map's scoring on the box world, every figure worked out by hand.
TEST(MapScore, HandMadeWorldGivesHandComputedSaDaAa) {
  eval::MapObservation obs;
  obs.resolution = 0.1;
  // Observed static surface voxels of the box: A (0,0,0), B (3,0,0), C (0,3,3); floor: F (6,6,0).
  obs.static_surface = {key(0, 0, 0), key(3, 0, 0), key(0, 3, 3)};
  obs.floor = {key(6, 6, 0)};
  // Walker voxels: W1 (10,0,5), W2 (11,0,5), W3 (12,0,5), W4 (20,0,5).
  obs.walker = {key(10, 0, 5), key(11, 0, 5), key(12, 0, 5), key(20, 0, 5)};
  // The map holds: A itself; (3,1,1), a diagonal neighbour of B, not B; F itself; W1 and W4.
  // Nothing within one voxel of C = (0,3,3): A is 3 away.
  const eval::VoxelSet occupied = {key(0, 0, 0), key(3, 1, 1), key(6, 6, 0), key(10, 0, 5),
                                   key(20, 0, 5)};
  // At the final frame a walker's box covers [2.0, 2.1] x [0, 0.1] x [0.5, 0.6]: W4's voxel.
  const std::vector<eval::AlignedBox> final_walkers = {
      {Eigen::Vector3d(2.0, 0.0, 0.5), Eigen::Vector3d(2.1, 0.1, 0.6)}};
  const eval::MapAccuracy r = eval::score_map(obs, occupied, final_walkers);
  // Static: 4 observed (A, B, C, F); held with the one-voxel tolerance: A, B, F = 3 -> SA 0.75;
  // held strictly (the voxel itself): A, F = 2 -> SA strict 0.5. Shapes 2 / 3, floor 1 / 1.
  EXPECT_EQ(r.static_observed, 4u);
  EXPECT_EQ(r.static_held, 3u);
  EXPECT_EQ(r.static_held_strict, 2u);
  EXPECT_DOUBLE_EQ(r.sa, 0.75);
  EXPECT_DOUBLE_EQ(r.sa_strict, 0.5);
  EXPECT_DOUBLE_EQ(r.sa_shapes, 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(r.sa_floor, 1.0);
  ASSERT_EQ(r.missing_static.size(), 1u);  // C's centre
  EXPECT_TRUE(r.missing_static[0].isApprox(Eigen::Vector3d(0.05, 0.35, 0.35)));
  // Walkers: W4 is left out (in the final box); of W1, W2, W3 the map no longer holds W2, W3:
  // DA = 2 / 3. AA = sqrt(0.75 * 2 / 3) = sqrt(0.5).
  EXPECT_EQ(r.walker_in_final, 1u);
  EXPECT_EQ(r.walker_observed, 3u);
  EXPECT_EQ(r.walker_cleared, 2u);
  EXPECT_DOUBLE_EQ(r.da, 2.0 / 3.0);
  EXPECT_NEAR(r.aa, std::sqrt(0.5), 1e-12);
  ASSERT_EQ(r.held_walker.size(), 1u);  // W1's centre
  EXPECT_TRUE(r.held_walker[0].isApprox(Eigen::Vector3d(1.05, 0.05, 0.55)));
  // Nothing observed: no figure (NaN), not a division by zero.
  const eval::MapAccuracy empty = eval::score_map(eval::MapObservation{}, occupied, {});
  EXPECT_TRUE(std::isnan(empty.sa));
  EXPECT_TRUE(std::isnan(empty.da));
  EXPECT_TRUE(std::isnan(empty.aa));
}

// map_frames.csv's header as files of each age had it: the first four counts, then the bare
// pair, then the whole pair.
constexpr const char* kFramesHeader =
    "stamp,erased_obstacle_voxels,free_through_obstacle_voxels,"
    "erased_obstacle_voxels_all,free_through_obstacle_voxels_all";
constexpr const char* kBareColumns = ",erased_obstacle_voxels_bare,erased_obstacle_voxels_bare_all";
constexpr const char* kWholeColumns =
    ",free_through_obstacle_voxels_whole,free_through_obstacle_voxels_whole_all";

TEST(MapScore, MapFramesCsvMaximaAndBadRows) {
  TempDir dir;
  write_file(dir / "map_frames.csv",
             std::string(kFramesHeader) + "\n1.0,0,2,1,5\n2.0,3,0,4,6\n3.0,1,1,2,7\n");
  eval::MapAccuracy r;
  eval::read_map_frames(dir / "map_frames.csv", r);
  EXPECT_TRUE(r.frames_available);
  EXPECT_EQ(r.checked_frames, 3u);
  EXPECT_EQ(r.erased_max, 3u);
  EXPECT_EQ(r.free_through_max, 2u);
  EXPECT_EQ(r.erased_all_max, 4u);
  EXPECT_EQ(r.free_through_all_max, 7u);
  EXPECT_EQ(r.free_through_final, 1u);
  EXPECT_EQ(r.free_through_final_all, 7u);
  EXPECT_FALSE(r.bare_available);  // a file from before the bare columns still scores
  write_file(dir / "bare.csv",
             std::string(kFramesHeader) + kBareColumns + "\n1.0,3,0,4,6,2,3\n2.0,1,1,2,7,0,1\n");
  eval::MapAccuracy with_bare;
  eval::read_map_frames(dir / "bare.csv", with_bare);
  EXPECT_TRUE(with_bare.bare_available);
  EXPECT_EQ(with_bare.erased_bare_max, 2u);
  EXPECT_EQ(with_bare.erased_bare_all_max, 3u);
  EXPECT_FALSE(with_bare.whole_available);
  write_file(dir / "whole.csv", std::string(kFramesHeader) + kBareColumns + kWholeColumns +
                                    "\n1.0,3,4,4,6,2,3,1,2\n2.0,1,5,2,7,0,1,0,5\n");
  eval::MapAccuracy with_whole;
  eval::read_map_frames(dir / "whole.csv", with_whole);
  EXPECT_TRUE(with_whole.whole_available);
  EXPECT_EQ(with_whole.free_through_whole_max, 1u);
  EXPECT_EQ(with_whole.free_through_whole_all_max, 5u);
  EXPECT_EQ(with_whole.free_through_max, 5u);
  write_file(dir / "bad.csv", std::string(kFramesHeader) + "\n1.0,0,x,1,5\n");
  eval::MapAccuracy b;
  EXPECT_NE(error_of([&] { eval::read_map_frames(dir / "bad.csv", b); }).find("bad.csv:2:"),
            std::string::npos);
}

// dynamap-replay's per-frame checks on a hand-made map: a 2 x 2 x 2 voxel box
// [1.0, 1.2] x [0, 0.2] x [0.5, 0.7] (all 8 voxels are surface and interior voxels).
TEST(MapFrameChecks, OccupiedThenFreeBoxVoxelIsErasedAndFreeThrough) {
  StaticWorld w;
  w.boxes.push_back(StaticBox{Eigen::Vector3d(1.0, 0.0, 0.5), Eigen::Vector3d(1.2, 0.2, 0.7)});
  auto map = std::make_unique<OccupancyMap>();  // ~9 MB: never on the stack
  ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
  MapFrameChecker checker(w, *map);
  EXPECT_EQ(checker.surface_voxels(), 8u);
  EXPECT_EQ(checker.interior_voxels(), 8u);
  const Eigen::Vector3f camera(0.f, 0.f, 0.6f), far_camera(10.f, 0.f, 0.6f);
  const Eigen::Vector3f a(1.05f, 0.05f, 0.55f), b(1.15f, 0.15f, 0.65f);
  // Frame 1: A occupied, the rest unknown -> nothing erased, nothing free.
  ASSERT_EQ(map->set_log_odds(a, 2.0f), Status::kOk);
  MapFrameChecker::Counts n = checker.check(*map, camera, 3.f);
  EXPECT_EQ(n.erased_near + n.erased_all + n.free_through_near + n.free_through_all, 0u);
  // Frame 2: A free (it was occupied before: erased, and free inside the box); B free without
  // ever having been occupied (free through, not erased). Both lie ~1.1 m from the camera.
  ASSERT_EQ(map->set_log_odds(a, -2.0f), Status::kOk);
  ASSERT_EQ(map->set_log_odds(b, -2.0f), Status::kOk);
  n = checker.check(*map, camera, 3.f);
  EXPECT_EQ(n.erased_near, 1u);
  EXPECT_EQ(n.erased_all, 1u);
  EXPECT_EQ(n.free_through_near, 2u);
  EXPECT_EQ(n.free_through_all, 2u);
  // Frame 3: the camera 10 m away: nothing within 3 m, the whole-world counts stay.
  n = checker.check(*map, far_camera, 3.f);
  EXPECT_EQ(n.erased_near, 0u);
  EXPECT_EQ(n.free_through_near, 0u);
  EXPECT_EQ(n.erased_all, 1u);
  EXPECT_EQ(n.free_through_all, 2u);
  // A's neighbours are unknown or free: where A was, the surface is gone (bare).
  EXPECT_EQ(n.erased_bare_all, 1u);
  // Frame 4: A occupied again: no longer erased nor free.
  ASSERT_EQ(map->set_log_odds(a, 2.0f), Status::kOk);
  n = checker.check(*map, camera, 3.f);
  EXPECT_EQ(n.erased_all, 0u);
  EXPECT_EQ(n.free_through_all, 1u);
  EXPECT_EQ(n.erased_bare_all, 0u);
}

// An erased voxel beside a held one thins the surface; with no held voxel among its 26
// neighbours it is bare. Same box; B is A's diagonal neighbour (1, 1, 1 voxel away).
TEST(MapFrameChecks, ErasedVoxelIsBareOnlyWithNoOccupiedNeighbour) {
  StaticWorld w;
  w.boxes.push_back(StaticBox{Eigen::Vector3d(1.0, 0.0, 0.5), Eigen::Vector3d(1.2, 0.2, 0.7)});
  auto map = std::make_unique<OccupancyMap>();
  ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
  MapFrameChecker checker(w, *map);
  const Eigen::Vector3f camera(0.f, 0.f, 0.6f), far_camera(10.f, 0.f, 0.6f);
  const Eigen::Vector3f a(1.05f, 0.05f, 0.55f), b(1.15f, 0.15f, 0.65f);
  ASSERT_EQ(map->set_log_odds(a, 2.0f), Status::kOk);
  ASSERT_EQ(map->set_log_odds(b, 2.0f), Status::kOk);
  (void)checker.check(*map, camera, 3.f);
  ASSERT_EQ(map->set_log_odds(a, -2.0f), Status::kOk);  // A erased, B still held
  MapFrameChecker::Counts n = checker.check(*map, camera, 3.f);
  EXPECT_EQ(n.erased_near, 1u);
  EXPECT_EQ(n.erased_bare_near, 0u);
  EXPECT_EQ(n.erased_bare_all, 0u);
  ASSERT_EQ(map->set_log_odds(b, -2.0f), Status::kOk);  // both erased: both bare
  n = checker.check(*map, camera, 3.f);
  EXPECT_EQ(n.erased_near, 2u);
  EXPECT_EQ(n.erased_bare_near, 2u);
  EXPECT_EQ(n.erased_bare_all, 2u);
  n = checker.check(*map, far_camera, 3.f);  // the near count follows the camera
  EXPECT_EQ(n.erased_bare_near, 0u);
  EXPECT_EQ(n.erased_bare_all, 2u);
}

// A free-through voxel is whole when no part of the shape's boundary lies in it. A 4 x 4 x 4
// voxel box [1.0, 1.4] x [0, 0.4] x [0.5, 0.9] has 8 whole voxels; a box whose top lies inside a
// voxel layer (z up to 0.88) has its top layer's voxels interior but not whole.
TEST(MapFrameChecks, FreeThroughVoxelIsWholeOnlyWhenNoBoundaryLiesInIt) {
  StaticWorld w;
  w.boxes.push_back(StaticBox{Eigen::Vector3d(1.0, 0.0, 0.5), Eigen::Vector3d(1.4, 0.4, 0.9)});
  w.boxes.push_back(StaticBox{Eigen::Vector3d(3.0, 0.0, 0.5), Eigen::Vector3d(3.4, 0.4, 0.88)});
  auto map = std::make_unique<OccupancyMap>();
  ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
  MapFrameChecker checker(w, *map);
  EXPECT_EQ(checker.interior_voxels(), 128u);
  const Eigen::Vector3f camera(2.f, 0.2f, 0.7f), far_camera(20.f, 0.f, 0.7f);
  const Eigen::Vector3f inner(1.15f, 0.15f, 0.65f);  // all six faces 0.1 m or more away
  const Eigen::Vector3f face(1.05f, 0.15f, 0.65f);   // holds the face x = 1.0
  const Eigen::Vector3f top(3.15f, 0.15f, 0.85f);    // centre inside, the top at 0.88 inside
  const Eigen::Vector3f under(3.15f, 0.15f, 0.75f);  // the layer under that top: whole
  for (const Eigen::Vector3f& p : {inner, face, top, under})
    ASSERT_EQ(map->set_log_odds(p, -2.0f), Status::kOk);
  MapFrameChecker::Counts n = checker.check(*map, camera, 3.f);
  EXPECT_EQ(n.free_through_near, 4u);
  EXPECT_EQ(n.free_through_whole_near, 2u);  // inner and under
  EXPECT_EQ(n.free_through_whole_all, 2u);
  ASSERT_EQ(map->set_log_odds(under, 2.0f), Status::kOk);
  n = checker.check(*map, far_camera, 3.f);
  EXPECT_EQ(n.free_through_whole_near, 0u);
  EXPECT_EQ(n.free_through_whole_all, 1u);
  EXPECT_EQ(n.free_through_all, 3u);
}

// dynamap-replay --static-model on a hand-made map: the model's voxels (a PLY as dynamap-label
// --static-model writes it) counted by the map's state at their centres. Camera (0, 0, 1),
// region +- (5, 5, 3), 3 m range.
TEST(MapModelHoles, HeldFreeModelVoxelsAreCountedExactly) {
  TempDir dir;
  auto map = std::make_unique<OccupancyMap>();
  ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
  const Eigen::Vector3f a(1.05f, 0.05f, 1.05f), b(1.15f, 0.05f, 1.05f), c(1.25f, 0.05f, 1.05f);
  const Eigen::Vector3f d(4.05f, 4.05f, 1.05f), e(6.05f, 0.05f, 1.05f);
  ASSERT_EQ(map->set_log_odds(a, -2.0f), Status::kOk);  // held free: a hole
  ASSERT_EQ(map->set_log_odds(b, 2.0f), Status::kOk);   // occupied; c never set: unknown
  ASSERT_EQ(map->set_log_odds(d, -2.0f), Status::kOk);  // a hole 5.7 m away
  ASSERT_EQ(map->set_log_odds(e, -2.0f), Status::kOk);  // free, outside the region
  std::vector<MapVoxel> model;
  for (const Eigen::Vector3f& p : {a, b, c, d, e}) model.push_back(MapVoxel{p, 0.8f});
  model.push_back(MapVoxel{Eigen::Vector3f(1.06f, 0.04f, 1.04f), 0.9f});  // a's voxel again
  model.push_back(MapVoxel{Eigen::Vector3f(2.0f, 0.05f, 1.05f), 0.7f});   // on a voxel face
  write_map_ply(dir / "static_model.ply", model, "test model");
  const std::vector<MapVoxel> read = read_map_ply(dir / "static_model.ply");
  ASSERT_EQ(read.size(), model.size());
  const ModelHoleCounts n = count_model_holes(*map, read, Eigen::Vector3f(0.f, 0.f, 1.f),
                                              Eigen::Vector3f(5.f, 5.f, 3.f), 3.f);
  EXPECT_EQ(n.region.voxels, 5u);  // a, b, c, d and the face voxel (unknown)
  EXPECT_EQ(n.region.free, 2u);
  EXPECT_EQ(n.region.occupied, 1u);
  EXPECT_EQ(n.region.unknown, 2u);
  EXPECT_NEAR(n.region.free_percent(), 40.0, 1e-9);
  EXPECT_EQ(n.depth.voxels, 4u);  // d is beyond 3 m
  EXPECT_EQ(n.depth.free, 1u);
  EXPECT_EQ(n.depth.occupied, 1u);
  EXPECT_EQ(n.misaligned, 1u);
  ASSERT_EQ(n.holes.size(), 2u);
  EXPECT_LT((n.holes[0] - a).norm(), 1e-4f);
  EXPECT_LT((n.holes[1] - d).norm(), 1e-4f);
}

// The whole --map evaluation on a hand-made two-frame sequence: an 8 x 6 camera at (0, 0, 1)
// looking along +x at a wall x in [2.0, 2.2]; depth 2.05 m (voxel i = 20, a surface voxel), the
// bottom row without measurement. Column u ends at y = 2.05 (3.5 - u) / 4, row v at
// z = 1 + 2.05 (2.5 - v) / 4: 8 x 5 distinct wall voxels. A walker stands at x = 1.05 in column
// 0 at frame 1 and in column 7 at frame 2 (the last): its end points are 5 voxels each.
TEST(MapScore, HandMadeSequenceObservedAsTheMapSamplesIt) {
  TempDir seq, res;
  write_file(seq / "camera.txt",
             "fx 4\nfy 4\ncx 3.5\ncy 2.5\nwidth 8\nheight 6\ndepth_factor 1000\nworld_z_up 1\n");
  const std::string q = " -0.5 0.5 -0.5 0.5\n";  // optical z = world x, x = -y, y = -z
  write_file(seq / "groundtruth.txt", "1.0 0 0 1" + q + "2.0 0 0 1" + q);
  write_file(seq / "depth.txt", "1.000000 d1.png\n2.000000 d2.png\n");
  for (int f = 1; f <= 2; ++f) {
    Image16 d;
    d.width = 8;
    d.height = 6;
    d.pixels.assign(48, 2050);
    for (int u = 0; u < 8; ++u) d.at(u, 5) = 0;
    for (int v = 0; v < 5; ++v) d.at(f == 1 ? 0 : 7, v) = 1050;
    write_png16(seq / ("d" + std::to_string(f) + ".png"), d);
  }
  write_file(seq / "static_world.txt", "floor 0\nbox 2.0 -3 0 2.2 3 3\n");
  write_file(seq / "obstacles.txt",
             "1.000000 1 1.05 0.9 1.0 0 -1 0 0.3 0.3 2.0 1.0\n"
             "2.000000 1 1.05 -0.9 1.0 0 -1 0 0.3 0.3 2.0 1.0\n");
  // Every pixel (stride 1, margin 0), as map_summary.txt says.
  write_map_summary(res / "map_summary.txt", {{"resolution", "0.1"},
                                              {"min_depth", "0.5"},
                                              {"max_depth", "5"},
                                              {"pixel_stride", "1"},
                                              {"pixel_margin", "0"},
                                              {"local_half_extent", "5 5 3"}});
  // The map holds 39 of the 40 wall voxels (not column 3, row 2: j = 2, k = 12, whose
  // neighbours are no wall voxels: columns 2 and 4 are j = 7 and -3, rows 1 and 3 k = 17 and 7)
  // and one voxel of the walker's frame-1 column (row 0: i = 10, j = 9, k = 16).
  std::vector<MapVoxel> map;
  for (int u = 0; u < 8; ++u) {
    for (int v = 0; v < 5; ++v) {
      if (u == 3 && v == 2) continue;
      const Eigen::Vector3d p(2.05, 2.05 * (3.5 - u) / 4, 1 + 2.05 * (2.5 - v) / 4);
      map.push_back({voxel_centre(voxel_of(p, 0.1), 0.1).cast<float>(), 0.9f});
    }
  }
  map.push_back({voxel_centre(Eigen::Vector3i(10, 9, 16), 0.1).cast<float>(), 0.9f});
  write_map_ply(res / "map.ply", map);
  const eval::MapAccuracy r = eval::evaluate_map(seq / "", res / "");
  // SA = 39 / 40 (strict too: the missing voxel has no occupied neighbour); no floor seen.
  EXPECT_EQ(r.shape_observed, 40u);
  EXPECT_EQ(r.floor_observed, 0u);
  EXPECT_DOUBLE_EQ(r.sa, 39.0 / 40.0);
  EXPECT_DOUBLE_EQ(r.sa_strict, 39.0 / 40.0);
  // Walker: frame 1's 5 voxels are scored, 1 still held: DA = 4 / 5; frame 2's 5 voxels touch
  // the walker's box at the last frame and are left out.
  EXPECT_EQ(r.walker_observed, 5u);
  EXPECT_EQ(r.walker_cleared, 4u);
  EXPECT_EQ(r.walker_in_final, 5u);
  EXPECT_DOUBLE_EQ(r.da, 0.8);
  EXPECT_FALSE(r.frames_available);  // no map_frames.csv
  // Without static_world.txt: a clear error naming it.
  fs::remove(seq / "static_world.txt");
  EXPECT_NE(error_of([&] { eval::evaluate_map(seq / "", res / ""); }).find("static_world.txt"),
            std::string::npos);
}

}  // namespace
