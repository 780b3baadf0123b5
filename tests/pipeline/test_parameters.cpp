// The parameter table (parameters.hpp): every field has a range that validate() enforces by
// name, every value in range is accepted by every stage (no anonymous "pipeline" refusals), and
// the table's accessors reach the field they name.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <string>

#include "dynamap/pipeline/parameters.hpp"
#include "dynamap/pipeline/pipeline.hpp"

namespace dynamap {
namespace {

// A value just outside the range at the lower (below = true) or upper end, if one exists.
bool outside(const Parameter& p, bool below, double* v) {
  const double bound = below ? p.min : p.max;
  if (!std::isfinite(bound) || p.kind == ParamKind::kBool) return false;
  const bool open = below ? p.min_open : p.max_open;
  const bool integral =
      p.kind == ParamKind::kInt || p.kind == ParamKind::kCount || p.kind == ParamKind::kEnum;
  if (open) {
    *v = bound;
  } else if (integral) {
    *v = below ? bound - 1 : bound + 1;
  } else {
    *v = static_cast<double>(
        std::nextafter(static_cast<float>(bound), below ? -INFINITY : INFINITY));
  }
  if (p.kind == ParamKind::kCount && *v < 0) return false;  // a count cannot hold it
  return true;
}

// A value at the end of the range (just inside an open end), as the field's type stores it.
bool at_bound(const Parameter& p, bool below, double* v) {
  const double bound = below ? p.min : p.max;
  if (!std::isfinite(bound)) return false;
  const bool open = below ? p.min_open : p.max_open;
  if (!open) {
    *v = bound;
  } else if (p.kind == ParamKind::kInt || p.kind == ParamKind::kCount) {
    *v = below ? bound + 1 : bound - 1;
  } else {
    float f = static_cast<float>(bound);
    f = std::nextafter(f, below ? INFINITY : -INFINITY);
    if (below ? !(f > bound) : !(f < bound)) f = std::nextafter(f, below ? INFINITY : -INFINITY);
    *v = static_cast<double>(f);
  }
  if (p.kind == ParamKind::kFloat || p.kind == ParamKind::kVector3) {
    *v = static_cast<double>(static_cast<float>(*v));  // what the field will hold
  }
  return true;
}

void set_all(const Parameter& p, PipelineConfig& c, double v) {
  for (int i = 0; i < p.components(); ++i) p.set(c, i, v);
}

TEST(Parameters, DefaultsAreInRangeAndPathsAreFound) {
  const PipelineConfig defaults;
  EXPECT_TRUE(check_ranges(defaults).ok());
  EXPECT_GT(parameters().size(), 100u);
  for (const Parameter& p : parameters()) {
    EXPECT_EQ(find_parameter(p.path), &p) << p.path;
    EXPECT_STRNE(p.help, "") << p.path;
  }
  EXPECT_EQ(find_parameter("map.resolutoin"), nullptr);
  EXPECT_EQ(find_parameter(nullptr), nullptr);
}

// The accessors reach the named field: writing through the table changes that member.
TEST(Parameters, AccessorsReachTheNamedField) {
  PipelineConfig c;
  find_parameter("map.resolution")->set(c, 0, 0.25);
  EXPECT_FLOAT_EQ(c.map.resolution, 0.25f);
  find_parameter("tracker.continuity.max_size")->set(c, 2, 2.5);
  EXPECT_FLOAT_EQ(c.tracker.continuity.max_size.z(), 2.5f);
  find_parameter("budgets.stage_ns.prediction")->set(c, 0, 1e5);
  EXPECT_EQ(c.budgets.stage_ns[5], 100000u);
  find_parameter("tracker.kalman.model")->set(c, 0, 0);
  EXPECT_EQ(c.tracker.kalman.model, MotionModel::kConstantVelocity);
  EXPECT_EQ(find_parameter("detector.max_detections")->get(c, 0),
            static_cast<double>(c.detector.max_detections));
}

// Every value outside a field's range is refused by validate() and by Pipeline::init, naming
// that field, and describe() spells the range.
TEST(Parameters, OutOfRangeValuesNameTheirFieldAndRange) {
  auto pipeline = std::make_unique<Pipeline>();
  int checked = 0;
  for (const Parameter& p : parameters()) {
    for (bool below : {true, false}) {
      double v = 0;
      if (!outside(p, below, &v)) continue;
      PipelineConfig c;
      set_all(p, c, v);
      const ConfigError e = validate(c);
      ASSERT_FALSE(e.ok()) << p.path << " = " << v;
      EXPECT_STREQ(e.field, p.path) << " = " << v;
      EXPECT_EQ(e.parameter, &p) << p.path;
      char line[256];
      char range[128];
      const std::string text = describe(e, line, sizeof line);
      EXPECT_NE(text.find(p.path), std::string::npos) << text;
      EXPECT_NE(text.find(p.range_text(range, sizeof range)), std::string::npos) << text;
      ConfigError from_init;
      EXPECT_EQ(pipeline->init(c, &from_init), Status::kInvalidArgument) << p.path;
      EXPECT_STREQ(from_init.field, p.path);
      ++checked;
    }
    if (p.kind != ParamKind::kBool && p.kind != ParamKind::kInt && p.kind != ParamKind::kCount &&
        p.kind != ParamKind::kEnum) {
      PipelineConfig c;
      set_all(p, c, std::nan(""));
      EXPECT_STREQ(validate(c).field, p.path) << "NaN";
    }
  }
  EXPECT_GT(checked, 100);
}

// A value at either end of a field's range either breaks a named relation with another field or
// is accepted by every stage: Pipeline::init never refuses what validate() accepted.
TEST(Parameters, ValuesInRangeAreAcceptedByEveryStage) {
  auto pipeline = std::make_unique<Pipeline>();
  int accepted = 0;
  for (const Parameter& p : parameters()) {
    for (bool below : {true, false}) {
      double v = 0;
      if (!at_bound(p, below, &v)) continue;
      PipelineConfig c;
      set_all(p, c, v);
      const ConfigError e = validate(c);
      if (!e.ok()) {
        EXPECT_EQ(e.parameter, nullptr)
            << p.path << " = " << v << " is in range but refused as " << e.field << " out of range";
        EXPECT_STRNE(e.reason, "") << p.path;
        continue;
      }
      ConfigError from_init;
      EXPECT_EQ(pipeline->init(c, &from_init), Status::kOk)
          << p.path << " = " << v << ": " << from_init.field << ": " << from_init.reason;
      ++accepted;
    }
  }
  EXPECT_GT(accepted, 80);
}

TEST(Parameters, RelationsNameTheField) {
  PipelineConfig c;
  c.map.max_depth = c.map.min_depth;
  EXPECT_STREQ(validate(c).field, "map.max_depth");
  c = PipelineConfig{};
  c.detector.d_max = c.detector.d_min;
  EXPECT_STREQ(validate(c).field, "detector.d_max");
  c = PipelineConfig{};
  c.tracker.image_margin = c.camera.height / 2;
  EXPECT_STREQ(validate(c).field, "tracker.image_margin");
  c = PipelineConfig{};
  c.tracker.continuity.static_votes = c.tracker.continuity.dynamic_votes;
  EXPECT_STREQ(validate(c).field, "tracker.continuity.static_votes");
  char line[256];
  EXPECT_STREQ(describe(validate(c), line, sizeof line),
               "tracker.continuity.static_votes: must be < tracker.continuity.dynamic_votes");
}

}  // namespace
}  // namespace dynamap
