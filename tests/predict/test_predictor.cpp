// Tests of the trajectory predictors: path library geometry, Markov maths, scenes (free space,
// wall with a side opening, L-shaped corridor) on a fake box world and on the real OccupancyMap,
// numerical safety, track bookkeeping, bad input, bounded work and zero allocations.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <random>
#include <vector>

#include "alloc_guard.hpp"
#include "dynamap/core/fixed_vector.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/predict/detail/path_sweep.hpp"
#include "dynamap/predict/far_field_layer.hpp"
#include "dynamap/predict/linear_predictor.hpp"
#include "dynamap/predict/markov_predictor.hpp"
#include "dynamap/predict/path_library.hpp"
#include "dynamap/predict/prediction.hpp"
#include "world_scene.hpp"

namespace dynamap {
namespace {

constexpr float kPiF = 3.14159265358979f;

// ---------------------------------------------------------------------------------------------
// Worlds. Both expose add_box() (solid obstacle) and query() (the predictor's view).

/// Exact fake world: a list of solid boxes, segment query by slab intersection.
class BoxWorld {
 public:
  void add_box(const Box3& b) { ASSERT_EQ(boxes_.push_back(b), Status::kOk); }
  OccupancyQuery query() const { return OccupancyQuery::of(*this); }

  bool first_occupied_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                 Eigen::Vector3f* hit) const noexcept {
    ++queries;
    float best = 2.0f;
    for (const Box3& box : boxes_) {
      float t0 = 0.0f;
      float t1 = 1.0f;
      bool miss = false;
      for (int ax = 0; ax < 3 && !miss; ++ax) {
        const float d = b[ax] - a[ax];
        if (std::fabs(d) < 1e-9f) {
          miss = a[ax] < box.min[ax] || a[ax] > box.max[ax];
          continue;
        }
        float ta = (box.min[ax] - a[ax]) / d;
        float tb = (box.max[ax] - a[ax]) / d;
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        miss = t0 > t1;
      }
      if (!miss) best = std::min(best, t0);
    }
    if (best > 1.0f) return false;
    *hit = a + best * (b - a);
    return true;
  }

  mutable std::size_t queries = 0;  // segment queries answered, for the bounded-work test

 private:
  FixedVector<Box3, 64> boxes_;
};

/// The real OccupancyMap with every voxel whose centre lies in a box set occupied.
class MapWorld {
 public:
  MapWorld() : map_(std::make_unique<OccupancyMap>()) {
    EXPECT_EQ(map_->init(OccupancyMapConfig{}), Status::kOk);
  }
  void add_box(const Box3& b) {
    const float res = map_->resolution();
    for (float x = b.min.x() + 0.5f * res; x < b.max.x(); x += res) {
      for (float y = b.min.y() + 0.5f * res; y < b.max.y(); y += res) {
        for (float z = b.min.z() + 0.5f * res; z < b.max.z(); z += res) {
          ASSERT_EQ(map_->set_log_odds(Eigen::Vector3f(x, y, z), 3.0f), Status::kOk);
        }
      }
    }
  }
  OccupancyQuery query() const { return OccupancyQuery::of(*map_); }
  const OccupancyMap& map() const { return *map_; }

 private:
  std::unique_ptr<OccupancyMap> map_;
};

/// A wall of thickness 0.1 m from the floor to 2.5 m between two x-y corners.
Box3 wall(float x0, float y0, float x1, float y1) {
  return Box3{Eigen::Vector3f(x0, y0, 0.0f), Eigen::Vector3f(x1, y1, 2.5f)};
}

ObstacleState walker(std::uint32_t id, float x, float y, float vx, float vy) {
  ObstacleState o;
  o.track_id = id;
  o.position = Eigen::Vector3f(x, y, 0.9f);
  o.velocity = Eigen::Vector2f(vx, vy);
  o.footprint_radius = 0.3f;
  o.height = 1.8f;
  return o;
}

// The scenes below were built for a library that ends at 90 degrees (l = 5: 0, +-45, +-90);
// the default's U-turns have their own test.
MarkovPredictorConfig markov_config(std::size_t l) {
  MarkovPredictorConfig c;
  c.paths.num_paths = l;
  c.paths.max_heading_change = 0.5f * kPiF;
  return c;
}

void expect_valid_distribution(const PathPrediction& p) {
  float sum = 0.0f;
  for (std::size_t i = 0; i < p.num_paths; ++i) {
    EXPECT_TRUE(std::isfinite(p.probability[i]));
    EXPECT_GE(p.probability[i], 0.0f);
    sum += p.probability[i];
  }
  EXPECT_NEAR(sum, 1.0f, 1e-5f);
  EXPECT_LT(p.chosen, p.num_paths);
  // Default choose_free: the most likely of the free paths when any is free, else of all.
  if (p.any_free) {
    EXPECT_TRUE(p.path_free(p.chosen));
  }
  EXPECT_EQ(p.failed, !p.path_free(p.chosen));
  // Default straight_when_free: the straight path whenever it is free (no path can be better
  // supported than a free one); otherwise the most likely (free) path.
  const bool straight_rule =
      p.num_paths % 2 == 1 && p.chosen == p.num_paths / 2 && p.path_free(p.chosen);
  if (p.num_paths % 2 == 1 && p.path_free(p.num_paths / 2)) {
    EXPECT_TRUE(straight_rule);
  }
  for (std::size_t i = 0; i < p.num_paths && !straight_rule; ++i) {
    if (p.any_free && !p.path_free(i)) continue;
    EXPECT_LE(p.probability[i], p.probability[p.chosen]);
  }
}

// Scene 1: walls on the right and ahead; the left wall ends at x = 0.2, leaving an opening.
template <class World>
void build_wall_with_left_opening(World& w) {
  w.add_box(wall(-3.0f, -1.1f, 2.1f, -1.0f));  // right
  w.add_box(wall(2.0f, -1.1f, 2.1f, 3.5f));    // ahead
  w.add_box(wall(-3.0f, 1.0f, 0.2f, 1.1f));    // left, up to the opening
}

// Scene 2: corridor along +x (|y| < 1) that turns to +y (left) or -y (right, mirror) for
// 2 < x < 4. `side` = +1 for a left turn, -1 for a right turn.
template <class World>
void build_l_corridor(World& w, float side) {
  auto mirrored = [side](float x0, float y0, float x1, float y1) {
    return side > 0.0f ? wall(x0, y0, x1, y1) : wall(x0, -y1, x1, -y0);
  };
  w.add_box(mirrored(-5.0f, -1.1f, 4.1f, -1.0f));  // outer wall of the corridor (turn side away)
  w.add_box(mirrored(-5.0f, 1.0f, 2.0f, 1.1f));    // inner wall, ends at the corner
  w.add_box(mirrored(1.9f, 1.0f, 2.0f, 6.0f));     // inner wall of the new leg
  w.add_box(mirrored(4.0f, -1.1f, 4.1f, 6.0f));    // end wall / outer wall of the new leg
}

// ---------------------------------------------------------------------------------------------
// PathLibrary

TEST(PathLibrary, HorizonFollowsTheDesign) {
  PathLibrary lib;
  ASSERT_EQ(lib.init(PathLibraryConfig{}), Status::kOk);
  const PathHorizon fast = lib.horizon(1.5f);
  EXPECT_FLOAT_EQ(fast.length, 3.0f);
  EXPECT_FLOAT_EQ(fast.duration, 2.0f);
  EXPECT_EQ(fast.samples, 21u);  // 0.1 s apart
  const PathHorizon slow = lib.horizon(0.05f);
  EXPECT_FLOAT_EQ(slow.duration, 2.0f);
  EXPECT_FLOAT_EQ(slow.length, 0.1f);
  const PathHorizon crawl = lib.horizon(0.11f);  // 27 s: capped sample count, wider spacing
  EXPECT_NEAR(crawl.duration, 3.0f / 0.11f, 1e-3f);
  EXPECT_EQ(crawl.samples, kMaxPathSamples);
  const PathHorizon still = lib.horizon(0.0f);
  EXPECT_FLOAT_EQ(still.length, 0.0f);
  EXPECT_GE(still.samples, 2u);
}

TEST(PathLibrary, OrderedLeftStraightRightAndMirrorSymmetric) {
  for (std::size_t l : {1u, 2u, 5u, 15u, 16u}) {
    PathLibraryConfig c;
    c.num_paths = l;
    c.max_heading_change = 0.5f * kPiF;  // past 90 degrees the end points fold back
    PathLibrary lib;
    ASSERT_EQ(lib.init(c), Status::kOk);
    PathSamples a;
    PathSamples b;
    float prev_y = INFINITY;
    for (std::size_t i = 0; i < l; ++i) {
      lib.sample_local(i, 1.2f, &a);
      ASSERT_GE(a.count, 2u);
      ASSERT_LE(a.count, kMaxPathSamples);
      const float y_end = a.position[a.count - 1].y();
      EXPECT_LT(y_end, prev_y) << "l=" << l << " i=" << i;  // strictly left to right
      prev_y = y_end;
      lib.sample_local(l - 1 - i, 1.2f, &b);
      for (std::size_t k = 0; k < a.count; ++k) {
        EXPECT_NEAR(a.position[k].x(), b.position[k].x(), 1e-4f);
        EXPECT_NEAR(a.position[k].y(), -b.position[k].y(), 1e-4f);
      }
      EXPECT_NEAR(lib.heading_change(i), -lib.heading_change(l - 1 - i), 1e-6f);
    }
    if (l % 2 == 1) {
      lib.sample_local(l / 2, 1.2f, &a);
      for (std::size_t k = 0; k < a.count; ++k) EXPECT_NEAR(a.position[k].y(), 0.0f, 1e-6f);
      EXPECT_FLOAT_EQ(lib.center_index(), static_cast<float>(l / 2));
    }
  }
}

TEST(PathLibrary, SamplesAreConsistentArcs) {
  PathLibraryConfig c;
  c.num_paths = 7;
  c.max_heading_change = 0.5f * kPiF;  // every turn completes within the 3 m horizon
  PathLibrary lib;
  ASSERT_EQ(lib.init(c), Status::kOk);
  const float speed = 1.3f;
  const PathHorizon h = lib.horizon(speed);
  for (std::size_t i = 0; i < lib.size(); ++i) {
    PathSamples p;
    lib.sample_local(i, speed, &p);
    ASSERT_EQ(p.count, h.samples);
    EXPECT_EQ(p.position[0], Eigen::Vector2f::Zero());
    EXPECT_NEAR(p.arc_length[p.count - 1], h.length, 1e-4f);
    EXPECT_NEAR(p.time[p.count - 1], h.duration, 1e-4f);
    float polyline = 0.0f;
    for (std::size_t k = 0; k < p.count; ++k) {
      EXPECT_NEAR(p.tangent[k].norm(), 1.0f, 1e-4f);
      EXPECT_NEAR(p.arc_length[k], speed * p.time[k], 1e-4f);  // travelled at the current speed
      if (k > 0) {
        EXPECT_LE(p.time[k] - p.time[k - 1], c.sample_interval + 1e-5f);
        polyline += (p.position[k] - p.position[k - 1]).norm();
      }
    }
    // Chords are at most slightly shorter than the arc.
    EXPECT_LE(polyline, h.length + 1e-4f);
    EXPECT_GT(polyline, 0.99f * h.length);
    // Final heading is the path's heading change.
    const float final_heading = std::atan2(p.tangent[p.count - 1].y(), p.tangent[p.count - 1].x());
    EXPECT_NEAR(final_heading, lib.heading_change(i), 1e-3f);
  }
  EXPECT_NEAR(lib.heading_change(0), c.max_heading_change, 1e-6f);
}

TEST(PathLibrary, MapFrameFollowsVelocity) {
  PathLibrary lib;
  ASSERT_EQ(lib.init(PathLibraryConfig{}), Status::kOk);
  PathSamples p;
  const auto straight = static_cast<std::size_t>(lib.center_index());
  lib.sample(straight, Eigen::Vector2f(1.0f, 2.0f), Eigen::Vector2f(0.0f, 1.5f), &p);  // +y
  EXPECT_NEAR(p.position[p.count - 1].x(), 1.0f, 1e-5f);
  EXPECT_NEAR(p.position[p.count - 1].y(), 5.0f, 1e-4f);
  lib.sample(0, Eigen::Vector2f(1.0f, 2.0f), Eigen::Vector2f(0.0f, 1.5f), &p);  // left of +y is -x
  EXPECT_LT(p.position[p.count - 1].x(), 0.0f);
}

TEST(PathLibrary, DefaultLibraryReachesUTurnsAt45DegreeSpacing) {
  const PathLibraryConfig c;
  PathLibrary lib;
  ASSERT_EQ(lib.init(c), Status::kOk);
  ASSERT_EQ(lib.size(), 9u);
  for (std::size_t i = 0; i < lib.size(); ++i) {
    EXPECT_NEAR(lib.heading_change(i), kPiF * (1.0f - 0.25f * static_cast<float>(i)), 1e-5f);
  }
  // The outermost left path at 1 m/s: a 1 m radius turn that reaches 1 m ahead and comes back
  // towards where it started, 2 m to the left, heading back (3 rad of the 3 m horizon).
  PathSamples p;
  lib.sample_local(0, 1.0f, &p);
  float reach = 0.0f;
  for (std::size_t k = 0; k < p.count; ++k) reach = std::max(reach, p.position[k].x());
  EXPECT_NEAR(reach, 1.0f, 0.01f);
  const Eigen::Vector2f end = p.position[p.count - 1];
  EXPECT_LT(end.x(), 0.2f);
  EXPECT_NEAR(end.y(), 2.0f, 0.02f);
  EXPECT_LT(p.tangent[p.count - 1].x(), -0.95f);
}

TEST(PathLibrary, RejectsBadConfig) {
  PathLibrary lib;
  PathLibraryConfig c;
  c.num_paths = 0;
  EXPECT_EQ(lib.init(c), Status::kInvalidArgument);
  c.num_paths = kMaxPaths + 1;
  EXPECT_EQ(lib.init(c), Status::kInvalidArgument);
  c = PathLibraryConfig{};
  c.sample_interval = 0.0f;
  EXPECT_EQ(lib.init(c), Status::kInvalidArgument);
  c = PathLibraryConfig{};
  c.turn_curvature = NAN;
  EXPECT_EQ(lib.init(c), Status::kInvalidArgument);
  c = PathLibraryConfig{};
  c.max_heading_change = 4.0f;
  EXPECT_EQ(lib.init(c), Status::kInvalidArgument);
}

// ---------------------------------------------------------------------------------------------
// Markov maths

TEST(MarkovPredictor, InitialAndTransitionAreStochasticGaussians) {
  for (std::size_t l : {1u, 4u, 5u, 15u, 16u}) {
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(markov_config(l)), Status::kOk);
    double init_sum = 0.0;
    for (std::size_t i = 0; i < l; ++i) {
      init_sum += mp.initial(i);
      EXPECT_NEAR(mp.initial(i), mp.initial(l - 1 - i), 1e-12);  // centred on straight
      double row = 0.0;
      for (std::size_t j = 0; j < l; ++j) {
        EXPECT_GE(mp.transition(i, j), 0.0);
        EXPECT_LE(mp.transition(i, j), mp.transition(i, i));  // peak on the diagonal
        row += mp.transition(i, j);
      }
      EXPECT_NEAR(row, 1.0, 1e-12) << "l=" << l << " row " << i;
    }
    EXPECT_NEAR(init_sum, 1.0, 1e-12);
    const std::size_t c = (l - 1) / 2;
    for (std::size_t i = 0; i < l; ++i) EXPECT_LE(mp.initial(i), mp.initial(c) + 1e-15);
  }
  // Even tiny sigmas stay normalised (no 0/0).
  MarkovPredictorConfig c = markov_config(4);
  c.sigma_init = 1e-4f;
  c.sigma_trans = 1e-4f;
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(c), Status::kOk);
  EXPECT_NEAR(mp.initial(1) + mp.initial(2), 1.0, 1e-12);
  EXPECT_NEAR(mp.transition(3, 3), 1.0, 1e-12);
}

TEST(MarkovPredictor, RejectsBadConfig) {
  MarkovPredictor mp;
  MarkovPredictorConfig c;
  c.sigma_trans = 0.0f;
  EXPECT_EQ(mp.init(c), Status::kInvalidArgument);
  c = MarkovPredictorConfig{};
  c.beta = -1.0f;
  EXPECT_EQ(mp.init(c), Status::kInvalidArgument);
  c = MarkovPredictorConfig{};
  c.clearance.max_lines = 0;
  EXPECT_EQ(mp.init(c), Status::kInvalidArgument);
  c = MarkovPredictorConfig{};
  c.paths.num_paths = 17;
  EXPECT_EQ(mp.init(c), Status::kInvalidArgument);
  BoxWorld w;
  const ObstacleState o = walker(1, 0, 0, 1, 0);
  PathPrediction out;
  EXPECT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kNotInitialized);
}

TEST(MarkovPredictor, UpdateIsTheDocumentedFormula) {
  BoxWorld w;
  build_wall_with_left_opening(w);
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
  const double beta = mp.config().beta;
  auto env_of = [&](const PathPrediction& p) {
    MarkovPredictor::Belief e{};
    double sum = 0.0;
    for (std::size_t i = 0; i < 5; ++i) {
      e[i] = std::exp(beta * p.free_distance[i]);
      sum += e[i];
    }
    for (std::size_t i = 0; i < 5; ++i) e[i] /= sum;
    return e;
  };
  PathPrediction out;
  ObstacleState o = walker(7, -0.3f, 0.0f, 1.0f, 0.0f);
  ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
  MarkovPredictor::Belief b{};
  ASSERT_TRUE(mp.belief(7, &b));
  // New track: normalise(P_init (.) P_env).
  MarkovPredictor::Belief env = env_of(out);
  double sum = 0.0;
  MarkovPredictor::Belief want{};
  for (std::size_t i = 0; i < 5; ++i) sum += want[i] = mp.initial(i) * env[i];
  for (std::size_t i = 0; i < 5; ++i) EXPECT_NEAR(b[i], want[i] / sum, 1e-6);
  // Next frame: normalise((P * P_trans) (.) P_env).
  const MarkovPredictor::Belief prev = b;
  o.position.x() += 0.1f;
  ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
  ASSERT_TRUE(mp.belief(7, &b));
  env = env_of(out);
  sum = 0.0;
  for (std::size_t j = 0; j < 5; ++j) {
    double pred = 0.0;
    for (std::size_t i = 0; i < 5; ++i) pred += prev[i] * mp.transition(i, j);
    sum += want[j] = pred * env[j];
  }
  for (std::size_t j = 0; j < 5; ++j) {
    EXPECT_NEAR(b[j], want[j] / sum, 1e-6);
    EXPECT_NEAR(out.probability[j], want[j] / sum, 1e-6);
  }
}

// ---------------------------------------------------------------------------------------------
// Scenes, on both worlds.

template <class World>
class PredictorScenes : public ::testing::Test {};
using Worlds = ::testing::Types<BoxWorld, MapWorld>;
TYPED_TEST_SUITE(PredictorScenes, Worlds);

TYPED_TEST(PredictorScenes, FreeSpaceStraightWalkerGetsStraightPath) {
  TypeParam w;
  for (std::size_t l : {1u, 5u, 15u}) {
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(markov_config(l)), Status::kOk);
    PathPrediction out;
    for (int f = 0; f < 10; ++f) {
      const ObstacleState o = walker(3, 0.12f * static_cast<float>(f), 1.0f, 1.2f, 0.0f);
      ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
      expect_valid_distribution(out);
      EXPECT_EQ(out.chosen, l / 2);
      EXPECT_FALSE(out.failed);
      EXPECT_TRUE(out.any_free);
      EXPECT_EQ(out.free_mask, (1u << l) - 1u);
      // Chosen path in the map frame: a straight line along the velocity, timed at its speed.
      ASSERT_EQ(out.num_samples, 26u);  // 3 m at 1.2 m/s = 2.5 s, 0.1 s apart
      for (std::size_t k = 0; k < out.num_samples; ++k) {
        EXPECT_NEAR(out.position[k].x(), o.position.x() + 1.2f * out.time[k], 1e-4f);
        EXPECT_NEAR(out.position[k].y(), 1.0f, 1e-5f);
        EXPECT_FLOAT_EQ(out.position[k].z(), 0.9f);
      }
      EXPECT_NEAR(out.time[out.num_samples - 1], 2.5f, 1e-4f);
    }
  }
}

TYPED_TEST(PredictorScenes, WallAheadOpeningLeftTurnsLeftWhileLinearFails) {
  TypeParam w;
  build_wall_with_left_opening(w);
  for (std::size_t l : {5u, 15u}) {
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(markov_config(l)), Status::kOk);
    LinearPredictor lin;
    ASSERT_EQ(lin.init(LinearPredictorConfig{}), Status::kOk);
    PathPrediction out;
    PathPrediction lin_out;
    int first_win = -1;  // first frame in which the free sharp-left turn is chosen
    for (int f = 0; f < 6; ++f) {
      const ObstacleState o = walker(11, -0.3f + 0.1f * static_cast<float>(f), 0.0f, 1.0f, 0.0f);
      ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
      ASSERT_EQ(lin.predict(&o, 1, w.query(), &lin_out), Status::kOk);
      expect_valid_distribution(out);
      EXPECT_FALSE(out.path_free(l / 2)) << "the straight path meets the wall ahead";
      EXPECT_TRUE(lin_out.failed);
      EXPECT_LT(lin_out.free_distance[0], 2.5f);
      const bool win = mp.library().heading_change(out.chosen) > 1.2f && !out.failed;
      if (win && first_win < 0) first_win = f;
      if (first_win >= 0) {
        EXPECT_TRUE(win) << "frame " << f << " l=" << l;  // and it stays
      }
    }
    ASSERT_GE(first_win, 0) << "l=" << l;
    EXPECT_LE(first_win, 3) << "l=" << l;  // "within a few frames": at most the fourth
    // The chosen path really goes through the opening: it ends left of the left wall line.
    EXPECT_GT(out.position[out.num_samples - 1].y(), 1.2f);
  }
}

TYPED_TEST(PredictorScenes, LCorridorPicksTheMatchingTurn) {
  for (float side : {1.0f, -1.0f}) {
    TypeParam w;
    build_l_corridor(w, side);
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
    PathPrediction out;
    std::size_t frames_checked = 0;
    for (int f = 0; f < 16; ++f) {
      const float x = 0.0f + 0.12f * static_cast<float>(f);  // 1.2 m/s at 10 Hz towards the corner
      const ObstacleState o = walker(5, x, 0.0f, 1.2f, 0.0f);
      ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
      expect_valid_distribution(out);
      if (x < 1.5f) continue;  // corner not yet reachable by the library's turns
      ++frames_checked;
      const float turn = mp.library().heading_change(out.chosen);
      EXPECT_GT(side * turn, 0.7f) << "side " << side << " x " << x;  // 45 or 90 deg that way
      // Free, or (on the voxelised map) grazing a wall only in the last few centimetres.
      EXPECT_GT(out.free_distance[out.chosen], 0.95f * out.path_length)
          << "side " << side << " x " << x;
      // The predicted path ends in the new leg of the corridor.
      const Eigen::Vector3f end = out.position[out.num_samples - 1];
      EXPECT_GT(end.x(), 2.0f);
      EXPECT_LT(end.x(), 4.0f);
      EXPECT_GT(side * end.y(), 1.0f);
    }
    EXPECT_GE(frames_checked, 3u);
    EXPECT_FALSE(out.failed) << "side " << side;  // at the corner the chosen turn is fully free
  }
}

/// `count` boxes 2 m tall of top-view `size`, their corners drawn from u in x and y.
template <class World>
void add_random_boxes(World& w, std::mt19937& rng, std::uniform_real_distribution<float>& u,
                      int count, const Eigen::Vector2f& size) {
  for (int b = 0; b < count; ++b) {
    const float x = u(rng), y = u(rng);
    w.add_box(Box3{Eigen::Vector3f(x, y, 0.0f), Eigen::Vector3f(x + size.x(), y + size.y(), 2.0f)});
  }
}

/// One prediction that must be a free turn to the left of more than min_heading (rad).
void predict_turning_back(MarkovPredictor& mp, const ObstacleState& o, const OccupancyQuery& q,
                          float min_heading, PathPrediction* out) {
  ASSERT_EQ(mp.predict(&o, 1, q, out), Status::kOk);
  expect_valid_distribution(*out);
  EXPECT_TRUE(out->any_free);
  EXPECT_FALSE(out->failed);
  EXPECT_GT(mp.library().heading_change(out->chosen), min_heading);
}

/// A dead end open towards -x: side walls from x = -3 to the end wall at x = 1.6, their inner
/// faces at y = right and y = left.
template <class World>
void add_dead_end(World& w, float right, float left) {
  w.add_box(wall(1.6f, right - 0.1f, 1.7f, left + 0.1f));  // end wall
  w.add_box(wall(-3.0f, right - 0.1f, 1.7f, right));
  w.add_box(wall(-3.0f, left, 1.7f, left + 0.1f));
}

// A walker 1.6 m from the end wall of a 2.9 m wide dead end, 0.5 m from its right side: every
// path up to 90 degrees meets a wall, so a library that ends there has no free path. The
// default's turns past 90 degrees to the left lead back out.
TYPED_TEST(PredictorScenes, DeadEndGetsAUTurnWhereANinetyDegreeLibraryHasNoFreePath) {
  TypeParam w;
  add_dead_end(w, -1.5f, 1.4f);
  const ObstacleState o = walker(4, 0.0f, -1.0f, 1.0f, 0.0f);
  MarkovPredictor ninety;
  ASSERT_EQ(ninety.init(markov_config(5)), Status::kOk);
  PathPrediction out;
  ASSERT_EQ(ninety.predict(&o, 1, w.query(), &out), Status::kOk);
  EXPECT_FALSE(out.any_free);
  EXPECT_TRUE(out.failed);
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(MarkovPredictorConfig{}), Status::kOk);
  for (int f = 0; f < 3; ++f) {
    predict_turning_back(mp, o, w.query(), 2.0f, &out);
    EXPECT_LT(out.position[out.num_samples - 1].x(), 0.5f);  // back the way it came
  }
}

// The same walker in a dead end 2 m wide: a U-turn at the library's 1 m radius needs 2 m to
// the side and meets the left wall, so nothing is free; at turn_back_curvature's radius (1/3 m)
// it fits and leads back out. Off (0), the prediction fails as before.
TYPED_TEST(PredictorScenes, NarrowDeadEndGetsAUTurnOnTheSpot) {
  TypeParam w;
  add_dead_end(w, -1.0f, 1.0f);
  const ObstacleState o = walker(4, 0.0f, -0.5f, 1.0f, 0.0f);
  MarkovPredictorConfig off;
  off.turn_back_curvature = 0.0f;
  MarkovPredictor wide;
  ASSERT_EQ(wide.init(off), Status::kOk);
  PathPrediction out;
  ASSERT_EQ(wide.predict(&o, 1, w.query(), &out), Status::kOk);
  EXPECT_FALSE(out.any_free);
  EXPECT_TRUE(out.failed);
  const MarkovPredictorConfig on;
  const float radius = 1.0f / on.turn_back_curvature;
  ASSERT_LT(radius, 0.6f);
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(on), Status::kOk);
  for (int f = 0; f < 3; ++f) {
    predict_turning_back(mp, o, w.query(), 3.0f, &out);
    float reach = -10.0f, side = -10.0f;
    for (std::size_t k = 0; k < out.num_samples; ++k) {
      reach = std::max(reach, out.position[k].x());
      side = std::max(side, out.position[k].y());
    }
    EXPECT_NEAR(reach, radius, 0.02f);
    EXPECT_NEAR(side, -0.5f + 2.0f * radius, 0.02f);
    EXPECT_LT(out.position[out.num_samples - 1].x(), -1.0f);  // back the way it came
  }
}

// Where any path is free at the library's radius, turn_back_curvature changes nothing: random
// walkers among random boxes give bit-identical predictions with it on and off.
TEST(MarkovPredictor, TurnBackCurvatureActsOnlyWhenNothingIsFree) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-3.0f, 3.0f);
  std::uniform_real_distribution<float> speed(0.3f, 1.8f);
  MarkovPredictorConfig off;
  off.turn_back_curvature = 0.0f;
  std::size_t identical = 0, retried = 0, rescued = 0;
  for (int world = 0; world < 30; ++world) {
    MapWorld w;
    add_random_boxes(w, rng, u, 10, Eigen::Vector2f(1.0f, 0.3f));
    MarkovPredictor on_mp, off_mp;
    ASSERT_EQ(on_mp.init(MarkovPredictorConfig{}), Status::kOk);
    ASSERT_EQ(off_mp.init(off), Status::kOk);
    for (int k = 0; k < 10; ++k) {
      const float heading = u(rng), v = speed(rng);
      const ObstacleState o = walker(static_cast<std::uint32_t>(k + 1), u(rng), u(rng),
                                     v * std::cos(heading), v * std::sin(heading));
      PathPrediction a, b;
      ASSERT_EQ(on_mp.predict(&o, 1, w.query(), &a), Status::kOk);
      ASSERT_EQ(off_mp.predict(&o, 1, w.query(), &b), Status::kOk);
      if (b.any_free) {
        EXPECT_EQ(a.chosen, b.chosen);
        EXPECT_EQ(a.free_mask, b.free_mask);
        for (std::size_t i = 0; i < a.num_paths; ++i) {
          EXPECT_EQ(a.free_distance[i], b.free_distance[i]);
          EXPECT_EQ(a.probability[i], b.probability[i]);
        }
        for (std::size_t s = 0; s < a.num_samples; ++s) EXPECT_EQ(a.position[s], b.position[s]);
        ++identical;
      } else {
        ++retried;
        rescued += a.any_free ? 1 : 0;
        for (std::size_t i = 0; i < a.num_paths; ++i) {
          EXPECT_GE(a.free_distance[i], b.free_distance[i]);  // the freer radius is kept
        }
      }
    }
  }
  EXPECT_GT(identical, 100u);
  EXPECT_GT(retried, 10u);  // the worlds do block every path sometimes
  EXPECT_GT(rescued, 0u);
}

TYPED_TEST(PredictorScenes, ZeroHeapAllocations) {
  TypeParam w;
  build_wall_with_left_opening(w);
  auto mp = std::make_unique<MarkovPredictor>();
  ASSERT_EQ(mp->init(markov_config(15)), Status::kOk);
  auto lin = std::make_unique<LinearPredictor>();
  ASSERT_EQ(lin->init(LinearPredictorConfig{}), Status::kOk);
  constexpr std::size_t kTracks = 10;
  std::array<ObstacleState, kTracks> in{};
  std::array<PathPrediction, kTracks> out{};
  for (std::size_t k = 0; k < kTracks; ++k) {
    in[k] = walker(static_cast<std::uint32_t>(100 + k), -0.5f + 0.05f * static_cast<float>(k),
                   0.02f * static_cast<float>(k), 1.0f, 0.1f);
  }
  const OccupancyQuery q = w.query();
  test::AllocationGuard guard;
  for (int f = 0; f < 5; ++f) {
    EXPECT_EQ(mp->predict(in.data(), kTracks - static_cast<std::size_t>(f), q, out.data()),
              Status::kOk);
    EXPECT_EQ(lin->predict(in.data(), kTracks, q, out.data()), Status::kOk);
  }
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(guard.deallocations(), 0u);
}

// ---------------------------------------------------------------------------------------------
// Numerical safety, bookkeeping, bad input, bounded work.

TEST(MarkovPredictor, ProbabilitiesStayFiniteAndNormalisedUnderStress) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<float> u(-4.0f, 4.0f);
  std::uniform_real_distribution<float> v(-2.0f, 2.0f);
  const float betas[] = {0.0f, 2.0f, 1e4f};
  const float sigmas[] = {0.04f, 30.0f};
  for (std::size_t l : {1u, 5u, 15u}) {
    for (float beta : betas) {
      for (float sigma : sigmas) {
        BoxWorld w;
        for (int b = 0; b < 8; ++b) {
          const Eigen::Vector3f c(u(rng), u(rng), 1.0f);
          w.add_box(Box3::from_center_size(c, Eigen::Vector3f(0.3f, 0.3f, 2.0f)));
        }
        MarkovPredictorConfig cfg = markov_config(l);
        cfg.beta = beta;
        cfg.sigma_init = sigma;
        cfg.sigma_trans = sigma;
        MarkovPredictor mp;
        ASSERT_EQ(mp.init(cfg), Status::kOk);
        std::array<ObstacleState, 3> in{};
        std::array<PathPrediction, 3> out{};
        for (int f = 0; f < 6; ++f) {
          for (std::size_t k = 0; k < in.size(); ++k) {
            // Teleporting, turning obstacles: the belief must survive anything.
            in[k] = walker(static_cast<std::uint32_t>(k), u(rng), u(rng), v(rng), v(rng));
          }
          ASSERT_EQ(mp.predict(in.data(), in.size(), w.query(), out.data()), Status::kOk);
          for (const PathPrediction& p : out) {
            expect_valid_distribution(p);
            EXPECT_EQ(p.failed, !p.path_free(p.chosen));
            EXPECT_EQ(p.any_free, p.free_mask != 0);
            for (std::size_t i = 0; i < l; ++i) {
              EXPECT_GE(p.free_distance[i], 0.0f);
              EXPECT_LE(p.free_distance[i], p.path_length + 1e-4f);
            }
          }
        }
      }
    }
  }
}

TEST(MarkovPredictor, UnderflowRestartsFromThePrior) {
  // Belief locked on the sharpest left turn, then only the sharpest right turn is free; with a
  // huge beta and a near-identity P_trans every product underflows to zero in double.
  MarkovPredictorConfig cfg = markov_config(5);
  cfg.beta = 1e4f;
  cfg.sigma_trans = 0.04f;  // 0.05 path spacings
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(cfg), Status::kOk);
  BoxWorld left_open;  // everything but the left 90-degree turn blocked
  left_open.add_box(wall(1.6f, -3.0f, 1.7f, 3.0f));
  left_open.add_box(wall(-1.0f, -0.6f, 1.6f, -0.5f));
  BoxWorld right_open;
  right_open.add_box(wall(1.6f, -3.0f, 1.7f, 3.0f));
  right_open.add_box(wall(-1.0f, 0.5f, 1.6f, 0.6f));
  const ObstacleState o = walker(1, 0.0f, 0.0f, 1.0f, 0.0f);
  PathPrediction out;
  for (int f = 0; f < 3; ++f) ASSERT_EQ(mp.predict(&o, 1, left_open.query(), &out), Status::kOk);
  EXPECT_EQ(out.chosen, 0u);
  EXPECT_EQ(mp.underflow_restarts(), 0u);
  ASSERT_EQ(mp.predict(&o, 1, right_open.query(), &out), Status::kOk);
  EXPECT_GE(mp.underflow_restarts(), 1u);
  expect_valid_distribution(out);
  EXPECT_EQ(out.chosen, 4u);
  EXPECT_FALSE(out.failed);
}

TEST(MarkovPredictor, TracksAreForgottenWhenTheyDisappear) {
  BoxWorld w;
  build_wall_with_left_opening(w);
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
  std::array<ObstacleState, 3> in = {walker(1, 0, 0, 1, 0), walker(2, 0, 0.5f, 1, 0),
                                     walker(3, -1, 0, 1, 0)};
  std::array<PathPrediction, 3> out{};
  ASSERT_EQ(mp.predict(in.data(), 3, w.query(), out.data()), Status::kOk);
  for (int f = 0; f < 3; ++f)
    ASSERT_EQ(mp.predict(in.data(), 3, w.query(), out.data()), Status::kOk);
  EXPECT_EQ(mp.tracked(), 3u);
  MarkovPredictor::Belief settled{};
  ASSERT_TRUE(mp.belief(1, &settled));
  // Track 2 disappears.
  std::array<ObstacleState, 2> two = {in[0], in[2]};
  ASSERT_EQ(mp.predict(two.data(), 2, w.query(), out.data()), Status::kOk);
  EXPECT_EQ(mp.tracked(), 2u);
  MarkovPredictor::Belief b{};
  EXPECT_FALSE(mp.belief(2, &b));
  EXPECT_TRUE(mp.belief(1, &b));
  EXPECT_EQ(out[0].track_id, 1u);
  EXPECT_EQ(out[1].track_id, 3u);
  // Track 2 comes back: it restarts from P_init (.) P_env, like track 1 did in its first frame.
  MarkovPredictor fresh;
  ASSERT_EQ(fresh.init(markov_config(5)), Status::kOk);
  PathPrediction first{};
  ASSERT_EQ(fresh.predict(&in[1], 1, w.query(), &first), Status::kOk);
  ASSERT_EQ(mp.predict(in.data(), 3, w.query(), out.data()), Status::kOk);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_FLOAT_EQ(out[1].probability[i], first.probability[i]);
  // An empty frame forgets everything.
  ASSERT_EQ(mp.predict(nullptr, 0, w.query(), nullptr), Status::kOk);
  EXPECT_EQ(mp.tracked(), 0u);
}

TEST(MarkovPredictor, BadInputChangesNothing) {
  BoxWorld w;
  build_wall_with_left_opening(w);
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
  std::array<ObstacleState, 2> in = {walker(1, 0, 0, 1, 0), walker(2, -1, 0, 1, 0)};
  std::array<PathPrediction, kMaxTracks + 1> out{};
  ASSERT_EQ(mp.predict(in.data(), 2, w.query(), out.data()), Status::kOk);
  MarkovPredictor::Belief before1{};
  MarkovPredictor::Belief before2{};
  ASSERT_TRUE(mp.belief(1, &before1));
  ASSERT_TRUE(mp.belief(2, &before2));
  out[0].track_id = 999;  // sentinel: errors must not write output either

  std::array<ObstacleState, 2> bad = in;
  bad[1].position.x() = NAN;
  EXPECT_EQ(mp.predict(bad.data(), 2, w.query(), out.data()), Status::kNonFinite);
  bad = in;
  bad[0].velocity.y() = INFINITY;
  EXPECT_EQ(mp.predict(bad.data(), 2, w.query(), out.data()), Status::kNonFinite);
  bad = in;
  bad[1].footprint_radius = -0.1f;
  EXPECT_EQ(mp.predict(bad.data(), 2, w.query(), out.data()), Status::kInvalidArgument);
  bad = in;
  bad[1].body_margin = -0.1f;
  EXPECT_EQ(mp.predict(bad.data(), 2, w.query(), out.data()), Status::kInvalidArgument);
  bad = in;
  bad[0].body_margin = NAN;
  EXPECT_EQ(mp.predict(bad.data(), 2, w.query(), out.data()), Status::kNonFinite);
  bad = in;
  bad[1].track_id = bad[0].track_id;
  EXPECT_EQ(mp.predict(bad.data(), 2, w.query(), out.data()), Status::kInvalidArgument);
  EXPECT_EQ(mp.predict(nullptr, 2, w.query(), out.data()), Status::kNullData);
  EXPECT_EQ(mp.predict(in.data(), 2, OccupancyQuery{}, out.data()), Status::kNullData);
  std::array<ObstacleState, kMaxTracks + 1> many{};
  for (std::size_t k = 0; k < many.size(); ++k) many[k].track_id = static_cast<std::uint32_t>(k);
  EXPECT_EQ(mp.predict(many.data(), many.size(), w.query(), out.data()), Status::kCapacityExceeded);

  EXPECT_EQ(out[0].track_id, 999u);
  EXPECT_EQ(mp.tracked(), 2u);
  MarkovPredictor::Belief after{};
  ASSERT_TRUE(mp.belief(1, &after));
  EXPECT_EQ(after, before1);
  ASSERT_TRUE(mp.belief(2, &after));
  EXPECT_EQ(after, before2);

  LinearPredictor lin;
  EXPECT_EQ(lin.predict(in.data(), 2, w.query(), out.data()), Status::kNotInitialized);
  ASSERT_EQ(lin.init(LinearPredictorConfig{}), Status::kOk);
  bad = in;
  bad[0].height = NAN;
  EXPECT_EQ(lin.predict(bad.data(), 2, w.query(), out.data()), Status::kNonFinite);
  EXPECT_EQ(out[0].track_id, 999u);
}

TEST(MarkovPredictor, WorkIsBoundedByPathsTimesSamples) {
  BoxWorld w;  // empty: no early exit, the worst case
  for (std::size_t l : {1u, 5u, 15u}) {
    MarkovPredictorConfig cfg = markov_config(l);
    cfg.clearance.line_spacing = 0.3f;  // 3 lines for the 0.3 m footprint
    cfg.clearance.height_levels = 2;
    cfg.clearance.self_margin = 0.0f;  // count every line's query, also of paths inside the body
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(cfg), Status::kOk);
    for (float speed : {0.05f, 0.11f, 1.2f, 5.0f}) {
      const ObstacleState o = walker(1, 0, 0, speed, 0);
      PathPrediction out;
      w.queries = 0;
      ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
      const std::size_t samples = mp.library().horizon(speed).samples;
      // Worst case l x (samples - 1) x lines x levels; chords merge samples, and paths turning
      // the same way share their arc (a slow walker's gentler paths are all arc: none left).
      EXPECT_LE(w.queries, l * (samples - 1) * 3 * 2);
      EXPECT_LE(w.queries, l * (kMaxPathSamples - 1) * 3 * 2);
      EXPECT_GE(w.queries, std::min<std::size_t>(l, 3) * 3 * 2);
      if (l == 1) {
        EXPECT_EQ(w.queries, 3u * 2u);  // a straight path is a single chord per line
      }
      EXPECT_EQ(clearance_lines(cfg.clearance, o.footprint_radius), 3u);
    }
  }
}

TEST(MarkovPredictor, FootprintClearanceCountsNearMisses) {
  // A thin pillar 0.15-0.25 m beside the straight line: the centre line misses it, a 0.3 m
  // footprint does not (7 lines 0.1 m apart); with radius 0.1 the path is free.
  BoxWorld w;
  w.add_box(Box3{Eigen::Vector3f(1.0f, 0.15f, 0.0f), Eigen::Vector3f(1.1f, 0.25f, 2.0f)});
  EXPECT_EQ(clearance_lines(ClearanceConfig{}, 0.3f), 7u);
  EXPECT_EQ(clearance_lines(ClearanceConfig{}, 0.1f), 3u);
  EXPECT_EQ(clearance_lines(ClearanceConfig{}, 0.0f), 1u);
  EXPECT_EQ(clearance_lines(ClearanceConfig{}, 2.0f), kMaxClearanceLines);
  LinearPredictor lin;
  ASSERT_EQ(lin.init(LinearPredictorConfig{}), Status::kOk);
  ObstacleState o = walker(1, 0, 0, 1.5f, 0);
  PathPrediction out;
  ASSERT_EQ(lin.predict(&o, 1, w.query(), &out), Status::kOk);
  EXPECT_TRUE(out.failed);
  EXPECT_NEAR(out.free_distance[0], 1.0f, 0.16f);  // within one sample spacing of the pillar
  o.footprint_radius = 0.1f;
  ASSERT_EQ(lin.predict(&o, 1, w.query(), &out), Status::kOk);
  EXPECT_FALSE(out.failed);
  EXPECT_FLOAT_EQ(out.free_distance[0], 3.0f);
  EXPECT_FLOAT_EQ(out.probability[0], 1.0f);
}

// ---------------------------------------------------------------------------------------------
// Causes of prediction failures on the simulated scenes
// (docs/notes/predictor-failures-1-own-body.md).

// A walker walks straight along +x, 0.8 m left of a long wall on its right (y = -0.8): the
// straight path and both left turns are free for the whole horizon, the two right turns meet
// the wall. Returns the path chosen in each of `frames` frames.
std::vector<std::size_t> walk_along_right_wall(int frames, bool straight_when_free = false) {
  BoxWorld w;
  w.add_box(wall(-5.0f, -0.9f, 60.0f, -0.8f));
  MarkovPredictorConfig c = markov_config(5);
  c.straight_when_free = straight_when_free;
  MarkovPredictor mp;
  EXPECT_EQ(mp.init(c), Status::kOk);
  std::vector<std::size_t> chosen;
  PathPrediction out;
  for (int f = 0; f < frames; ++f) {
    const ObstacleState o = walker(4, 0.05f * static_cast<float>(f), 0.0f, 1.5f, 0.0f);
    EXPECT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
    EXPECT_EQ(out.free_mask, 0x07u) << "frame " << f;  // paths 0, 1, 2 free; 3, 4 blocked
    if (straight_when_free) expect_valid_distribution(out);
    chosen.push_back(out.chosen);
  }
  return chosen;
}

TEST(MarkovPredictor, CompoundingBeliefDriftsOffTheStraightPathAlongAWall) {
  // docs/design.md §4.6 as written: every frame P_trans leaks belief from the straight path into
  // the blocked right turns and P_env takes it away again, so the same wall counts again every
  // frame and the belief settles in the middle of the free set: a left turn, though nothing but the
  // wall on the right has changed since the first frame (the "lane-centre drift").
  const std::vector<std::size_t> chosen = walk_along_right_wall(60);
  EXPECT_EQ(chosen.front(), 2u);
  EXPECT_LT(chosen.back(), 2u);
}

TEST(MarkovPredictor, StraightWhenFreeKeepsTheStraightPathAlongAWallDespiteTheDrift) {
  // The default choice rule: the belief still drifts (the previous test), but the straight path
  // is free and no turn is better supported, so the output never turns into the unseen.
  const std::vector<std::size_t> chosen = walk_along_right_wall(60, true);
  for (std::size_t f = 0; f < chosen.size(); ++f) EXPECT_EQ(chosen[f], 2u) << "frame " << f;
}

TEST(MarkovPredictor, CompoundedBeliefIsAllocationFree) {
  const MarkovPredictorConfig c = markov_config(5);
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(c), Status::kOk);
  BoxWorld w;
  build_wall_with_left_opening(w);
  std::array<ObstacleState, 3> in{};
  std::array<PathPrediction, 3> out{};
  for (std::size_t k = 0; k < in.size(); ++k) {
    in[k] = walker(static_cast<std::uint32_t>(20 + k), -0.6f + 0.1f * static_cast<float>(k),
                   0.1f * static_cast<float>(k), 1.0f, 0.1f);
  }
  const OccupancyQuery q = w.query();
  test::AllocationGuard guard;
  for (int f = 0; f < 5; ++f) {
    EXPECT_EQ(mp.predict(in.data(), in.size(), q, out.data()), Status::kOk);
  }
  EXPECT_EQ(guard.allocations(), 0u);
  EXPECT_EQ(guard.deallocations(), 0u);
}

TEST(MarkovPredictor, OwnBodyInTheMapIsNotAnObstacle) {
  // The map still holds the walker's own body (this frame's hits around its centre, plus a
  // voxel layer just ahead of a lagging box): those must not block every path. A wall 1.2 m
  // ahead must still be found.
  MapWorld w;
  w.add_box(Box3{Eigen::Vector3f(-0.2f, -0.2f, 0.0f), Eigen::Vector3f(0.4f, 0.2f, 1.7f)});
  w.add_box(wall(1.5f, -3.0f, 1.6f, 3.0f));
  const ObstacleState o = walker(1, 0.0f, 0.0f, 1.0f, 0.0f);
  for (float margin : {0.0f, 0.15f}) {
    LinearPredictorConfig lc;
    lc.clearance.self_margin = margin;
    LinearPredictor lin;
    ASSERT_EQ(lin.init(lc), Status::kOk);
    PathPrediction out;
    ASSERT_EQ(lin.predict(&o, 1, w.query(), &out), Status::kOk);
    EXPECT_TRUE(out.failed);
    if (margin > 0.0f) {
      EXPECT_NEAR(out.free_distance[0], 1.5f, 0.06f);  // the wall, not the body
    } else {
      EXPECT_LT(out.free_distance[0], 0.1f);  // the body
    }
    MarkovPredictorConfig mc = markov_config(5);
    mc.clearance.self_margin = margin;
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(mc), Status::kOk);
    ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
    // The sharp turns avoid the wall (1 m radius, then along it): free only without the body.
    EXPECT_EQ(out.any_free, margin > 0.0f);
    if (margin > 0.0f) {
      EXPECT_FALSE(out.failed);
      EXPECT_TRUE(out.chosen == 0u || out.chosen == 4u);
    }
  }
  ClearanceConfig bad;
  bad.self_margin = -0.1f;
  EXPECT_EQ(validate(bad), Status::kInvalidArgument);
  bad.self_margin = std::nanf("");
  EXPECT_EQ(validate(bad), Status::kInvalidArgument);
  bad = ClearanceConfig{};
  bad.self_range_margin = -0.01f;
  EXPECT_EQ(validate(bad), Status::kInvalidArgument);
}

TEST(MarkovPredictor, FarWalkersNoisyFrontIsNotAnObstacle) {
  // A walker 5 m from the camera coming towards it: its own hits scatter along the ray by the
  // depth noise, so the map holds a layer of its front just outside r + self_margin (0.45 m),
  // across every path. With the range margin (body_margin 0.21 m) the layer is inside the skipped
  // disc and a wall 2 m ahead is still found; the linear yardstick ignores body_margin.
  BoxWorld w;
  w.add_box(Box3{Eigen::Vector3f(0.47f, -0.55f, 0.0f), Eigen::Vector3f(0.55f, 0.55f, 1.7f)});
  w.add_box(wall(2.0f, -0.6f, 2.2f, 0.6f));
  ObstacleState o = walker(1, 0.0f, 0.0f, 1.0f, 0.0f);
  for (float body : {0.0f, 0.21f}) {
    o.body_margin = body;
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
    PathPrediction out;
    ASSERT_EQ(mp.predict(&o, 1, w.query(), &out), Status::kOk);
    EXPECT_FALSE(out.path_free(2));  // the straight path meets the front or the wall
    if (body > 0.0f) {
      EXPECT_NEAR(out.free_distance[2], 2.0f, 0.05f);  // the wall
    } else {
      EXPECT_LT(out.free_distance[2], 0.6f);  // the front
      EXPECT_FALSE(out.any_free);
    }
    LinearPredictor lin;
    ASSERT_EQ(lin.init(LinearPredictorConfig{}), Status::kOk);
    ASSERT_EQ(lin.predict(&o, 1, w.query(), &out), Status::kOk);
    EXPECT_LT(out.free_distance[0], 0.6f);  // the front, with or without body_margin
  }
}

// ---------------------------------------------------------------------------------------------
// The choice among free paths (choose_free) and its ties.

/// Sets every voxel whose centre lies in `b` to `log_odds` (negative: observed free).
void fill(OccupancyMap& map, const Box3& b, float log_odds) {
  const float res = map.resolution();
  for (float x = b.min.x() + 0.5f * res; x < b.max.x(); x += res) {
    for (float y = b.min.y() + 0.5f * res; y < b.max.y(); y += res) {
      for (float z = b.min.z() + 0.5f * res; z < b.max.z(); z += res) {
        ASSERT_EQ(map.set_log_odds(Eigen::Vector3f(x, y, z), log_odds), Status::kOk);
      }
    }
  }
}

TEST(MarkovPredictor, MirrorTurnsTieAndTheTieGoesLeft) {
  // Walker at the origin heading +x; a thin wall ahead blocks the straight path only. Both
  // 45-degree turns are free and mirror each other (unknown space counts as free, seen free or
  // not), so their probabilities are equal and the exact tie goes to the left one.
  auto map = std::make_unique<OccupancyMap>();
  ASSERT_EQ(map->init(OccupancyMapConfig{}), Status::kOk);
  fill(*map, Box3{Eigen::Vector3f(-1.0f, -3.0f, 0.0f), Eigen::Vector3f(4.0f, 0.5f, 2.5f)}, -2.0f);
  fill(*map, Box3{Eigen::Vector3f(1.5f, -0.4f, 0.0f), Eigen::Vector3f(1.6f, 0.4f, 2.5f)}, 3.0f);
  const OccupancyQuery q = OccupancyQuery::of(*map);
  const ObstacleState o = walker(3, 0.0f, 0.0f, 1.0f, 0.0f);
  PathPrediction out;
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
  ASSERT_EQ(mp.predict(&o, 1, q, &out), Status::kOk);
  expect_valid_distribution(out);
  EXPECT_EQ(out.free_mask, 0b11011u);
  EXPECT_FALSE(out.failed);
  EXPECT_FLOAT_EQ(out.probability[1], out.probability[3]);
  EXPECT_EQ(out.chosen, 1u);
}

TEST(MarkovPredictor, ChoosesTheMostLikelyFreePathOverAKnownCollision) {
  // A wall just before the end of the straight path: P_env hardly penalises a hit at 2.85 m of
  // 3 m, so with P_init the straight path stays the most likely although it collides.
  BoxWorld w;
  w.add_box(wall(2.85f, -0.35f, 2.95f, 0.35f));
  const ObstacleState o = walker(4, 0.0f, 0.0f, 1.0f, 0.0f);
  std::array<PathPrediction, 2> out{};
  for (int choose_free = 0; choose_free < 2; ++choose_free) {
    MarkovPredictorConfig c = markov_config(5);
    c.choose_free = choose_free != 0;
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(c), Status::kOk);
    ASSERT_EQ(mp.predict(&o, 1, w.query(), &out[choose_free]), Status::kOk);
  }
  const PathPrediction& plain = out[0];
  const PathPrediction& chosen_free = out[1];
  ASSERT_FALSE(plain.path_free(2));
  EXPECT_NEAR(plain.free_distance[2], 2.85f, 0.01f);  // the wall face (lines run along the path)
  ASSERT_TRUE(plain.any_free);
  EXPECT_EQ(plain.chosen, 2u);
  EXPECT_TRUE(plain.failed);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_EQ(plain.probability[i], chosen_free.probability[i]);  // same belief
    if (i != 2) {
      EXPECT_LT(plain.probability[i], plain.probability[2]);
    }
  }
  EXPECT_TRUE(chosen_free.path_free(chosen_free.chosen));
  EXPECT_FALSE(chosen_free.failed);
  EXPECT_EQ(std::abs(static_cast<int>(chosen_free.chosen) - 2), 1);  // a 45-degree turn
  expect_valid_distribution(chosen_free);
}

TEST(MarkovPredictor, NoFreePathKeepsTheMostLikelyOne) {
  // Walled in on all sides within 1 m: every path collides; choose_free changes nothing.
  BoxWorld w;
  w.add_box(wall(1.0f, -1.1f, 1.1f, 1.1f));
  w.add_box(wall(-1.1f, -1.1f, -1.0f, 1.1f));
  w.add_box(wall(-1.1f, 1.0f, 1.1f, 1.1f));
  w.add_box(wall(-1.1f, -1.1f, 1.1f, -1.0f));
  std::array<PathPrediction, 2> out{};
  for (int choose_free = 0; choose_free < 2; ++choose_free) {
    MarkovPredictorConfig c = markov_config(5);
    c.choose_free = choose_free != 0;
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(c), Status::kOk);
    const ObstacleState o = walker(6, 0.0f, 0.0f, 1.0f, 0.2f);
    ASSERT_EQ(mp.predict(&o, 1, w.query(), &out[choose_free]), Status::kOk);
  }
  EXPECT_FALSE(out[1].any_free);
  EXPECT_TRUE(out[1].failed);
  EXPECT_EQ(out[0].chosen, out[1].chosen);
  expect_valid_distribution(out[1]);
}

}  // namespace
}  // namespace dynamap

// ---------------------------------------------------------------------------------------------
// Issue 16: the far-field layer's memory and the straight-when-free choice.

namespace dynamap {
namespace {

CameraIntrinsics far_camera() {
  CameraIntrinsics c;
  c.fx = 385.0f;
  c.fy = 385.0f;
  c.cx = 320.0f;
  c.cy = 240.0f;
  return c;
}

// The end wall of a corridor 7 m ahead of the origin, beyond the map's range.
test::WorldScene corridor_end_wall() {
  test::WorldScene scene;
  scene.boxes.push_back(
      Box3{Eigen::Vector3f(7.0f, -1.6f, 0.0f), Eigen::Vector3f(7.2f, 1.6f, 2.5f)});
  return scene;
}

TEST(MarkovPredictorFarField, CorridorEndWallSeenOnlyEarlierMakesTheChoiceTurnBeforeIt) {
  // The end wall of a corridor 7 m from the camera, beyond the map's range: seen in one frame,
  // then 10 frames looking back the other way. The map holds nothing. A walker at x = 5 walks
  // towards the wall at 1 m/s: the Markov choice turns before it, the linear line walks into it.
  const CameraIntrinsics cam = far_camera();
  auto layer = std::make_unique<FarFieldLayer>();
  ASSERT_EQ(layer->init(FarFieldConfig{}, 0.0f), Status::kOk);
  const test::WorldScene scene = corridor_end_wall();
  std::vector<std::uint16_t> pixels;
  const Pose ahead = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, 1.3f), 0.0f);
  const Pose back = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, 1.3f), kPiF);
  DepthView view = test::render(scene, cam, ahead, pixels);
  ASSERT_EQ(layer->update(view, cam, ahead, nullptr, 0), Status::kOk);
  view = test::render(scene, cam, back, pixels);  // the wall is behind the camera now
  for (int f = 0; f < 10; ++f) ASSERT_EQ(layer->update(view, cam, back, nullptr, 0), Status::kOk);

  BoxWorld empty;
  const ObstacleState o = walker(3, 5.0f, 0.0f, 1.0f, 0.0f);
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
  PathPrediction out;
  ASSERT_EQ(mp.predict(&o, 1, empty.query(), layer.get(), &out), Status::kOk);
  EXPECT_FALSE(out.path_free(2));  // straight: into the remembered wall
  EXPECT_NE(out.far_blocked_mask & (1u << 2), 0u);
  ASSERT_TRUE(out.any_free);
  EXPECT_NE(out.chosen, 2u);
  EXPECT_FALSE(out.failed);
  for (std::size_t k = 0; k < out.num_samples; ++k) {
    EXPECT_LT(out.position[k].x(), 7.0f - o.footprint_radius) << k;
  }
  // Without the layer the choice is the straight path into the wall (the test can fail).
  MarkovPredictor blind;
  ASSERT_EQ(blind.init(markov_config(5)), Status::kOk);
  ASSERT_EQ(blind.predict(&o, 1, empty.query(), &out), Status::kOk);
  EXPECT_EQ(out.chosen, 2u);
  // The linear baseline (map only, as the yardstick) walks through the wall.
  LinearPredictor lin;
  ASSERT_EQ(lin.init(LinearPredictorConfig{}), Status::kOk);
  PathPrediction line;
  ASSERT_EQ(lin.predict(&o, 1, empty.query(), &line), Status::kOk);
  EXPECT_FALSE(line.failed);
  EXPECT_GT(line.position[line.num_samples - 1].x(), 7.2f);
}

TEST(MarkovPredictorFarField, WalkerPassingABoxCornerWithItsStraightPathFreeGoesStraight) {
  // 10 frames with a wall ahead and on the left push the belief onto the right turns; then the
  // wall is gone and only a box's corner is left on the left, clear of the straight path (0.45 m
  // from its centre line, footprint 0.3 m) but in the way of the left turns. The compounded
  // belief still favours a turn; the choice must be the straight path.
  BoxWorld before;
  before.add_box(wall(1.5f, -0.2f, 1.6f, 3.0f));
  BoxWorld corner;
  corner.add_box(Box3{Eigen::Vector3f(1.2f, 0.45f, 0.0f), Eigen::Vector3f(2.2f, 1.5f, 1.0f)});
  for (const bool rule : {true, false}) {
    MarkovPredictorConfig c = markov_config(5);
    c.straight_when_free = rule;
    MarkovPredictor mp;
    ASSERT_EQ(mp.init(c), Status::kOk);
    PathPrediction out;
    const ObstacleState o = walker(5, 0.0f, 0.0f, 1.2f, 0.0f);
    for (int f = 0; f < 10; ++f) ASSERT_EQ(mp.predict(&o, 1, before.query(), &out), Status::kOk);
    ASSERT_GT(out.chosen, 2u);  // a right turn
    ASSERT_EQ(mp.predict(&o, 1, corner.query(), &out), Status::kOk);
    EXPECT_TRUE(out.path_free(2));
    EXPECT_FALSE(out.path_free(0));  // the sharp left turn meets the corner
    if (rule) {
      EXPECT_EQ(out.chosen, 2u);
      EXPECT_FALSE(out.failed);
    } else {
      EXPECT_NE(out.chosen, 2u);  // the old belief: what the rule fixes
    }
  }
}

TEST(MarkovPredictorFarField, ZeroAllocationsWithTheLayer) {
  const CameraIntrinsics cam = far_camera();
  auto layer = std::make_unique<FarFieldLayer>();
  ASSERT_EQ(layer->init(FarFieldConfig{}, 0.0f), Status::kOk);
  const test::WorldScene scene = corridor_end_wall();
  std::vector<std::uint16_t> pixels;
  const Pose ahead = test::level_camera(Eigen::Vector3f(0.0f, 0.0f, 1.3f), 0.0f);
  const DepthView view = test::render(scene, cam, ahead, pixels);
  BoxWorld empty;
  MarkovPredictor mp;
  ASSERT_EQ(mp.init(markov_config(5)), Status::kOk);
  std::array<ObstacleState, 3> obs = {walker(1, 5.0f, 0.0f, 1.0f, 0.0f),
                                      walker(2, 4.0f, 1.0f, 1.0f, 0.2f),
                                      walker(3, 5.5f, -1.0f, 0.8f, 0.0f)};
  std::array<PathPrediction, 3> out;
  std::size_t allocations = 0;
  {
    test::AllocationGuard guard;
    for (int f = 0; f < 5; ++f) {
      (void)layer->update(view, cam, ahead, nullptr, 0);
      (void)mp.predict(obs.data(), obs.size(), empty.query(), layer.get(), out.data());
    }
    allocations = guard.allocations();
  }
  EXPECT_EQ(allocations, 0u);
  EXPECT_NE(out[0].chosen, 2u);
}

// The predictor sweeps each side's shared turning arc once (sweep_library). Its distances and
// masks must equal sweeping every path on its own with the same chord ends (the turn ends of
// the paths on its side no sharper than itself), over random walkers among random boxes, with
// and without a far-field wall.
TEST(MarkovPredictor, SharedArcSweepEqualsSweepingEveryPathAlone) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-4.0f, 4.0f);
  std::uniform_real_distribution<float> speed(0.05f, 2.0f);
  std::size_t compared = 0, blocked = 0, far_walls = 0;
  for (int world = 0; world < 20; ++world) {
    MapWorld w;
    add_random_boxes(w, rng, u, 6, Eigen::Vector2f(0.6f, 0.4f));
    auto far = std::make_unique<FarFieldLayer>();
    ASSERT_EQ(far->init(FarFieldConfig{}, 0.0f), Status::kOk);
    if (world % 2 == 1) {  // a wall 3.5 m east of the origin, seen from 4 m behind it
      test::WorldScene scene;
      scene.boxes.push_back(
          Box3{Eigen::Vector3f(3.5f, -3.0f, 0.0f), Eigen::Vector3f(3.7f, 3.0f, 2.5f)});
      std::vector<std::uint16_t> pixels;
      const Pose cam_pose = test::level_camera(Eigen::Vector3f(-1.5f, 0.0f, 1.3f), 0.0f);
      const DepthView view = test::render(scene, far_camera(), cam_pose, pixels);
      for (int f = 0; f < 5; ++f) {
        ASSERT_EQ(far->update(view, far_camera(), cam_pose, nullptr, 0), Status::kOk);
      }
    }
    for (std::size_t l : {9u, 5u, 8u}) {
      MarkovPredictorConfig cfg;
      cfg.paths.num_paths = l;
      cfg.turn_back_curvature = 0.0f;  // compared with sweeps at the library's one radius
      MarkovPredictor mp;
      ASSERT_EQ(mp.init(cfg), Status::kOk);
      const PathLibrary& lib = mp.library();
      for (int k = 0; k < 10; ++k) {
        const float heading = u(rng);
        const float v = speed(rng);
        const ObstacleState o = walker(static_cast<std::uint32_t>(k + 1), u(rng), u(rng),
                                       v * std::cos(heading), v * std::sin(heading));
        PathPrediction out;
        ASSERT_EQ(mp.predict(&o, 1, w.query(), far.get(), &out), Status::kOk);
        for (std::size_t i = 0; i < l; ++i) {
          const float theta = lib.heading_change(i);
          SweepSpan span;
          for (std::size_t j = 0; j < l; ++j) {
            const float tj = lib.heading_change(j);
            if (tj != 0.0f && (tj > 0.0f) == (theta > 0.0f) && std::fabs(tj) <= std::fabs(theta)) {
              span.breaks |= 1u << lib.turn_end_sample(j, v);
            }
          }
          PathSamples path;
          lib.sample(i, o.position.head<2>(), o.velocity, &path);
          const PathClearance alone =
              sweep_path(w.query(), path, o, cfg.clearance, far.get(), span);
          EXPECT_EQ(out.free_distance[i], alone.free_distance) << "world " << world << " i " << i;
          EXPECT_EQ(out.path_free(i), alone.free);
          EXPECT_EQ((out.far_blocked_mask >> i) & 1u, alone.far_blocked ? 1u : 0u);
          ++compared;
          blocked += alone.free ? 0 : 1;
          far_walls += alone.far_blocked ? 1 : 0;
        }
      }
    }
  }
  EXPECT_GT(blocked, compared / 4);  // the worlds do block paths, on the arcs too
  EXPECT_GT(far_walls, 0u);
}

}  // namespace
}  // namespace dynamap
