// dynamap-sim random: the same seed gives the same bytes, and every drawn world is sound, checked
// here with distance code of its own (not the generator's nor StaticWorld's).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "common/text_io.hpp"
#include "sim/random_scene.hpp"
#include "sim/writer.hpp"

using namespace dynamap::tools;
using Limits = sim::RandomSceneLimits;

namespace {

std::string bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Top-view distance from p to the nearest box or cylinder (0 inside one).
double distance_to_static(const StaticWorld& w, const Eigen::Vector2d& p) {
  double best = 1e18;
  for (const auto& b : w.boxes) {
    const Eigen::Vector2d lo = b.min.head<2>(), hi = b.max.head<2>();
    const Eigen::Vector2d q = p.cwiseMax(lo).cwiseMin(hi);  // nearest point of the box
    best = std::min(best, (p - q).norm());
  }
  for (const auto& c : w.cylinders) {
    best = std::min(best, std::max(0.0, (p - c.center).norm() - c.radius));
  }
  return best;
}

// Render a short generated sequence into dir (as dynamap-sim random does, README included).
void render(std::uint64_t seed, int frames, const std::string& dir) {
  const sim::RandomScene r = sim::make_random_scene(seed, frames);
  sim::SimulateOptions opt;
  opt.frames = frames;
  opt.seed = seed;
  opt.picture = false;
  (void)sim::simulate(r.scene, dir, opt);
  std::ofstream(join_path(dir, "README.md")) << sim::random_scene_readme(r, seed, frames);
}

}  // namespace

TEST(RandomScene, SameSeedSameBytes) {
  const std::string root = ::testing::TempDir() + "dynamap_random_scene";
  const int frames = 6;
  render(5, frames, root + "/a");
  render(5, frames, root + "/b");
  render(6, frames, root + "/c");
  for (const char* f :
       {"obstacles.txt", "groundtruth.txt", "static_world.txt", "README.md", "depth.txt"}) {
    const std::string a = bytes(root + "/a/" + f);
    EXPECT_FALSE(a.empty()) << f;
    EXPECT_EQ(a, bytes(root + "/b/" + f)) << f;
  }
  const auto lines = read_lines(root + "/a/depth.txt");
  int pngs = 0;
  for (const auto& l : lines) {
    if (l.empty() || l[0] == '#') continue;
    const std::string name = l.substr(l.find(' ') + 1);
    EXPECT_EQ(bytes(root + "/a/" + name), bytes(root + "/b/" + name)) << name;
    ++pngs;
  }
  EXPECT_EQ(pngs, frames);
  EXPECT_NE(bytes(root + "/a/static_world.txt"), bytes(root + "/c/static_world.txt"));
}

// 200 worlds, nothing rendered: walkers (whole loop) and the camera (every frame) keep their
// clearances from the static shapes, the camera from the walkers, walkers from each other.
TEST(RandomScene, DrawnWorldsAreSound) {
  const int frames = 450;
  std::set<std::string> layouts, cameras;
  std::size_t walkers = 0, grouped = 0, pausing = 0, standing = 0;
  for (std::uint64_t seed = 1; seed <= 200; ++seed) {
    const sim::RandomScene r = sim::make_random_scene(seed, frames);
    const auto& s = r.scene;
    layouts.insert(r.layout);
    cameras.insert(r.camera);
    std::vector<sim::WalkerMotion> motions(s.walkers.begin(), s.walkers.end());
    for (std::size_t k = 0; k < motions.size(); ++k) {
      const auto& w = s.walkers[k];
      EXPECT_GE(w.speed, 0.5);
      EXPECT_LE(w.speed, 1.6);
      EXPECT_GE(w.radius, 0.15);
      Eigen::Vector2d last = motions[k].position(0.0);
      for (double t = 0.0; t < motions[k].period(); t += 0.02) {
        const Eigen::Vector2d p = motions[k].position(t);
        ASSERT_GE(distance_to_static(s.world, p), w.radius + Limits::walker_static - 1e-6)
            << "seed " << seed << " walker " << k + 1 << " t " << t;
        ASSERT_LE((p - last).norm(), 1.1 * Limits::max_speed * 0.02) << "seed " << seed;
        // Nobody walking alone reverses at walking pace within a frame: a turn back slows to a
        // stop first. (A group's inner member in a turn tighter than its place in the group
        // still steps back: timing by the outer member's pace, docs/tools.md.)
        const Eigen::Vector2d v0 = motions[k].velocity(t), v1 = motions[k].velocity(t + 1 / 30.0);
        if (w.group == 0 && v0.norm() > 0.3 && v1.norm() > 0.3) {
          ASSERT_GT(v0.dot(v1), 0.0) << "seed " << seed << " walker " << k + 1 << " t " << t;
        }
        last = p;
      }
      grouped += w.group > 0;
      for (const auto& wp : w.waypoints) pausing += wp.pause > 0.0;
    }
    walkers += s.walkers.size();
    for (const auto& c : s.world.cylinders) standing += c.zmax < 2.0;
    const sim::CameraMotion cam(s.camera);
    for (int f = 0; f < frames; ++f) {
      const double t = f / 30.0;
      const Eigen::Vector2d c = cam.position_xy(t);
      ASSERT_GE(distance_to_static(s.world, c), Limits::camera_static - 1e-6)
          << "seed " << seed << " frame " << f;
      if (!s.camera.hover) {
        const double turn = std::remainder(cam.yaw(t + 1.0 / 30) - cam.yaw(t), 2 * M_PI);
        ASSERT_LE(std::fabs(turn) * 30.0, Limits::max_yaw_rate + 1e-6) << "seed " << seed;
      }
      const auto st = sim::walker_states(motions, t);
      for (std::size_t a = 0; a < st.size(); ++a) {
        ASSERT_GE((st[a].position - c).norm(), st[a].radius + Limits::camera_walker - 1e-6)
            << "seed " << seed << " frame " << f << " walker " << a + 1;
        for (std::size_t b = a + 1; b < st.size(); ++b) {
          ASSERT_GE((st[a].position - st[b].position).norm(),
                    Limits::walker_overlap * (st[a].radius + st[b].radius) - 1e-6)
              << "seed " << seed << " frame " << f << " walkers " << a + 1 << ", " << b + 1;
        }
      }
    }
  }
  // The distribution covers what docs/tools.md promises.
  EXPECT_EQ(layouts.size(), 5u);
  EXPECT_EQ(cameras.size(), 3u);
  EXPECT_GT(walkers, 200u * 4);
  EXPECT_GT(grouped, 50u);
  EXPECT_GT(pausing, 100u);
  EXPECT_GT(standing, 50u);
}
