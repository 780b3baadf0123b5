#include <gtest/gtest.h>

#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/map/trail_grid.hpp"

namespace dynamap {
namespace {

using Vec3 = Eigen::Vector3f;

TrailGrid make_grid(const TrailGridConfig& config = TrailGridConfig{}) {
  TrailGrid g;
  EXPECT_EQ(g.init(config), Status::kOk);
  return g;
}

TEST(TrailGrid, AMarkCoversTheBoxAndItsMarginForTheConfiguredFrames) {
  TrailGridConfig c;
  c.resolution = 0.25f;
  c.margin = 0.2f;
  c.frames = 10;
  TrailGrid g = make_grid(c);
  g.mark(Box3{Vec3(1.f, 1.f, 0.f), Vec3(1.5f, 1.5f, 1.8f)});
  EXPECT_TRUE(g.recent(Vec3(1.2f, 1.2f, 0.9f)));
  EXPECT_TRUE(g.recent(Vec3(1.2f, 1.2f, 5.f)));   // a column: any height
  EXPECT_TRUE(g.recent(Vec3(0.85f, 1.6f, 0.f)));  // within the margin
  EXPECT_FALSE(g.recent(Vec3(0.7f, 1.2f, 0.f)));  // beyond margin and cell
  EXPECT_FALSE(g.recent(Vec3(1.2f, 2.01f, 0.f)));
  for (std::uint32_t f = 1; f < c.frames; ++f) {
    g.next_frame();
    EXPECT_TRUE(g.recent(Vec3(1.2f, 1.2f, 0.f))) << f;
  }
  g.next_frame();
  EXPECT_FALSE(g.recent(Vec3(1.2f, 1.2f, 0.f)));
  g.mark(Box3{Vec3(1.f, 1.f, 0.f), Vec3(1.5f, 1.5f, 1.8f)});  // marked again: counts again
  EXPECT_TRUE(g.recent(Vec3(1.2f, 1.2f, 0.f)));
  g.clear();
  EXPECT_FALSE(g.recent(Vec3(1.2f, 1.2f, 0.f)));
}

TEST(TrailGrid, TheGridWrapsWithoutMistakingAFarCellForANearOne) {
  TrailGrid g = make_grid();
  const float span = static_cast<float>(kTrailColumns) * g.config().resolution;  // 16 m
  g.mark(Box3{Vec3(0.3f, 0.3f, 0.f), Vec3(0.4f, 0.4f, 1.f)});
  EXPECT_TRUE(g.recent(Vec3(0.35f, 0.35f, 0.f)));
  EXPECT_FALSE(g.recent(Vec3(0.35f + span, 0.35f, 0.f)));  // the same slot, another column
  EXPECT_FALSE(g.recent(Vec3(0.35f, 0.35f - span, 0.f)));
  g.mark(Box3{Vec3(0.3f + span, 0.3f, 0.f), Vec3(0.4f + span, 0.4f, 1.f)});  // takes the slot
  EXPECT_TRUE(g.recent(Vec3(0.35f + span, 0.35f, 0.f)));
  EXPECT_FALSE(g.recent(Vec3(0.35f, 0.35f, 0.f)));
}

TEST(TrailGrid, BadBoxesAndPointsMarkNothingAndNeverCrash) {
  TrailGrid g = make_grid();
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  g.mark(Box3{Vec3(nan, 0.f, 0.f), Vec3(1.f, 1.f, 1.f)});
  g.mark(Box3{Vec3(0.f, 0.f, 0.f), Vec3(inf, 1.f, 1.f)});
  g.mark(Box3{Vec3(0.f, 0.f, 0.f), Vec3(1e20f, 1.f, 1.f)});
  EXPECT_FALSE(g.recent(Vec3(0.5f, 0.5f, 0.f)));
  EXPECT_FALSE(g.recent(Vec3(nan, 0.5f, 0.f)));
  EXPECT_FALSE(g.recent(Vec3(1e20f, 0.5f, 0.f)));
  // A box wider than the grid marks every slot once (bounded work), nothing wraps twice.
  g.mark(Box3{Vec3(-100.f, -100.f, 0.f), Vec3(100.f, 100.f, 1.f)});
  EXPECT_TRUE(g.recent(Vec3(-99.9f, -99.9f, 0.f)));
}

TEST(TrailGrid, BadConfigIsRefusedAndChangesNothing) {
  TrailGrid g = make_grid();
  g.mark(Box3{Vec3(0.f, 0.f, 0.f), Vec3(0.5f, 0.5f, 1.f)});
  using Spoil = void (*)(TrailGridConfig&);
  for (Spoil bad : {Spoil{[](TrailGridConfig& c) { c.resolution = 0.f; }},
                    Spoil{[](TrailGridConfig& c) { c.resolution = std::nanf(""); }},
                    Spoil{[](TrailGridConfig& c) { c.frames = 0; }},
                    Spoil{[](TrailGridConfig& c) { c.margin = -0.1f; }}}) {
    TrailGridConfig c;
    bad(c);
    EXPECT_EQ(c.validate(), Status::kInvalidArgument);
    EXPECT_EQ(g.init(c), Status::kInvalidArgument);
    EXPECT_TRUE(g.recent(Vec3(0.2f, 0.2f, 0.f)));  // the marks are kept
    EXPECT_FLOAT_EQ(g.config().resolution, TrailGridConfig{}.resolution);
  }
}

/// The part of the Tracker interface mark_dynamic_tracks() reads.
struct FakeTracks {
  struct Obstacle {
    bool dynamic = false;
  };
  std::vector<Obstacle> obstacles;
  std::vector<std::vector<Box3>> boxes;  // newest first
  std::size_t size() const { return obstacles.size(); }
  const Obstacle& obstacle(std::size_t i) const { return obstacles[i]; }
  std::size_t box_history_size(std::size_t i) const { return boxes[i].size(); }
  const Box3& past_box(std::size_t i, std::size_t age) const { return boxes[i][age]; }
};

Box3 box_at(float x) {
  return Box3{Vec3(x, 0.f, 0.f), Vec3(x + 0.1f, 0.1f, 1.8f)};
}

TEST(TrailGrid, MarksWhereDynamicTracksAreAndWereButNotStaticOnes) {
  TrailGridConfig c;
  c.margin = 0.f;
  TrailGrid g = make_grid(c);
  FakeTracks t;
  t.obstacles = {{true}, {false}};
  t.boxes.resize(2);
  for (int b = 0; b < 40; ++b) {
    t.boxes[0].push_back(box_at(-static_cast<float>(b) * 0.3f));  // a walker along -x
    t.boxes[1].push_back(Box3{Vec3(0.f, 5.f, 0.f), Vec3(1.f, 6.f, 2.f)});
  }
  g.mark_dynamic_tracks(t);
  EXPECT_TRUE(g.recent(Vec3(0.05f, 0.05f, 0.f)));  // the newest box at once
  std::size_t marked = 0;
  for (int b = 0; b < 40; ++b)
    marked += g.recent(Vec3(-static_cast<float>(b) * 0.3f + 0.05f, 0.05f, 0.f)) ? 1u : 0u;
  EXPECT_LT(marked, 40u);  // older boxes in turn
  {
    test::AllocationGuard guard;
    for (std::size_t f = 1; f < TrailGrid::kOlderBoxPeriod; ++f) {
      g.next_frame();
      g.mark_dynamic_tracks(t);
    }
    EXPECT_EQ(guard.allocations(), 0u);
  }
  for (int b = 0; b < 40; ++b)
    EXPECT_TRUE(g.recent(Vec3(-static_cast<float>(b) * 0.3f + 0.05f, 0.05f, 0.f))) << b;
  EXPECT_FALSE(g.recent(Vec3(0.5f, 5.5f, 0.f)));  // the static track's box
}

}  // namespace
}  // namespace dynamap
