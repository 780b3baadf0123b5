// The parameter table (parameters.hpp): every field has a range that validate() enforces by
// name, every value in range is accepted by every stage (no anonymous "pipeline" refusals), the
// table's accessors reach the field they name, each stage's own validation refuses what its
// table's ranges refuse, every relation of a stage's Relation table is refused by the stage and
// by validate() under its field and reason, and the README's parameter table names real fields
// with their defaults.
#include <gtest/gtest.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>
#include <string>
#include <vector>

#include "dynamap/detect/detect_params.hpp"
#include "dynamap/map/map_params.hpp"
#include "dynamap/pipeline/parameters.hpp"
#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/predict/predict_params.hpp"
#include "dynamap/track/track_params.hpp"

namespace dynamap {
namespace {

// A value just outside the range at the lower (below = true) or upper end, if one exists.
template <class Config>
bool outside(const Param<Config>& p, bool below, double* v) {
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

template <class Config>
void set_all(const Param<Config>& p, Config& c, double v) {
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

// Each stage's own validation refuses every value its table's range refuses: the stage checks
// read the same rows (there is no second copy of a range to drift).
template <class Config, std::size_t N, class Accepts>
int expect_stage_refuses(const Param<Config> (&table)[N], Accepts accepts, const char* stage) {
  int refused = 0;
  for (const Param<Config>& p : table) {
    for (bool below : {true, false}) {
      double v = 0;
      if (!outside(p, below, &v)) continue;
      Config c{};
      set_all(p, c, v);
      EXPECT_FALSE(accepts(c)) << stage << "." << p.path << " = " << v;
      ++refused;
    }
    EXPECT_TRUE(accepts(Config{})) << stage;
  }
  return refused;
}

TEST(Parameters, StageValidationComesFromTheStageTables) {
  int n = 0;
  auto map = std::make_unique<OccupancyMap>();
  n += expect_stage_refuses(
      params::kOccupancyMap, [&](const OccupancyMapConfig& c) { return ok(map->init(c)); }, "map");
  auto detector = std::make_unique<UMapDetector>();
  n += expect_stage_refuses(
      params::kUMapDetector, [&](const UMapDetectorConfig& c) { return ok(detector->init(c)); },
      "detector");
  auto refiner = std::make_unique<MapRefiner>();
  n += expect_stage_refuses(
      params::kMapRefiner, [&](const MapRefinerConfig& c) { return ok(refiner->init(c, 0.f)); },
      "refiner");
  const auto valid = [](const auto& c) { return ok(c.validate()); };
  n += expect_stage_refuses(params::kKalman, valid, "kalman");
  n += expect_stage_refuses(params::kImm, valid, "imm");
  n += expect_stage_refuses(params::kContinuity, valid, "continuity");
  n += expect_stage_refuses(params::kTracker, valid, "tracker");
  n += expect_stage_refuses(params::kLabel, valid, "label");
  n += expect_stage_refuses(params::kDetectionRefiner, valid, "fragments");
  n += expect_stage_refuses(params::kEverFree, valid, "ever_free");
  n += expect_stage_refuses(params::kDynamicRegionCleaner, valid, "cleaner");
  const auto free_validate = [](const auto& c) { return ok(validate(c)); };
  n += expect_stage_refuses(params::kClearance, free_validate, "clearance");
  n += expect_stage_refuses(params::kFarField, free_validate, "far_field");
  n += expect_stage_refuses(
      params::kPathLibrary, [](const PathLibraryConfig& c) { return ok(PathLibrary{}.init(c)); },
      "paths");
  auto predictor = std::make_unique<MarkovPredictor>();
  n += expect_stage_refuses(
      params::kMarkovPredictor,
      [&](const MarkovPredictorConfig& c) { return ok(predictor->init(c)); }, "predictor");
  EXPECT_GT(n, 150);
}

// --- Relations: each stage's Relation table, enforced by the stage and by validate() --------

// One relation broken minimally from the defaults, with the field and reason the pipeline has
// always reported for it (so a table edit cannot silently change the message).
struct Breaking {
  const char* field;   ///< PipelineConfig path validate() names
  const char* reason;  ///< validate()'s reason
  void (*apply)(PipelineConfig& c);
};

// Every row of `table` is broken by one of `cases` (a row nothing breaks fails the test); each
// case stays within the ranges, is refused by the stage (`accepts`) and by validate() and
// Pipeline::init, which name the row's field under `prefix` with the row's reason.
template <class Config, std::size_t N, class Of, class Accepts>
void expect_relations_enforced(const Relation<Config> (&table)[N], const char* prefix, Of of,
                               Accepts accepts, const std::vector<Breaking>& cases) {
  const PipelineConfig defaults;
  EXPECT_TRUE(validate(defaults).ok());
  EXPECT_EQ(first_broken(of(defaults), table, N), nullptr) << prefix;
  EXPECT_TRUE(accepts(of(defaults))) << prefix;
  auto pipeline = std::make_unique<Pipeline>();
  std::vector<bool> broken(N, false);
  for (const Breaking& b : cases) {
    PipelineConfig c;
    b.apply(c);
    ASSERT_TRUE(check_ranges(c).ok()) << b.field << ": the break leaves a range";
    const Relation<Config>* r = first_broken(of(c), table, N);
    ASSERT_NE(r, nullptr) << b.field << ": no relation of the " << prefix << " table refuses it";
    broken[static_cast<std::size_t>(r - table)] = true;
    EXPECT_EQ(std::string(prefix) + r->field, b.field);
    EXPECT_FALSE(accepts(of(c))) << b.field << ": the stage accepts it";
    const ConfigError e = validate(c);
    EXPECT_EQ(e.status, Status::kInvalidArgument) << b.field;
    EXPECT_STREQ(e.field, b.field);
    EXPECT_STREQ(e.reason, b.reason) << b.field;
    // By content: string literals in a header need not share one address (ASan builds differ).
    EXPECT_STREQ(e.reason, r->reason) << b.field << ": the reason is not the table's";
    EXPECT_EQ(e.parameter, nullptr) << b.field;
    ConfigError from_init;
    EXPECT_EQ(pipeline->init(c, &from_init), Status::kInvalidArgument) << b.field;
    EXPECT_STREQ(from_init.field, b.field);
  }
  for (std::size_t k = 0; k < N; ++k) {
    EXPECT_TRUE(broken[k]) << prefix << table[k].field << " (" << table[k].reason
                           << "): no case breaks this relation";
  }
}

float above(float x) {
  return std::nextafter(x, INFINITY);
}

TEST(Relations, MapRelationsAreEnforcedByTheMapAndByValidate) {
  auto map = std::make_unique<OccupancyMap>();
  expect_relations_enforced(
      params::kOccupancyMapRelations, "map.", [](const PipelineConfig& c) { return c.map; },
      [&](const OccupancyMapConfig& c) { return ok(map->init(c)); },
      {
          {"map.prob_min", "must be < map.prob_miss",
           [](PipelineConfig& c) { c.map.prob_min = c.map.prob_miss; }},
          {"map.prob_max", "must be > map.prob_hit",
           [](PipelineConfig& c) { c.map.prob_max = c.map.prob_hit; }},
          {"map.prob_occupied", "must be in [map.prob_min, map.prob_max)",
           [](PipelineConfig& c) { c.map.prob_occupied = c.map.prob_max; }},
          {"map.prob_occupied", "must be in [map.prob_min, map.prob_max)",
           [](PipelineConfig& c) {
             c.map.prob_min = 0.3f;
             c.map.prob_occupied = 0.29f;
           }},
          {"map.max_depth", "must be > map.min_depth",
           [](PipelineConfig& c) { c.map.max_depth = c.map.min_depth; }},
          {"map.no_return_free_depth", "must be <= map.max_depth",
           [](PipelineConfig& c) { c.map.no_return_free_depth = above(c.map.max_depth); }},
          {"map.local_half_extent",
           "must be <= kMaxLocalHalfExtentVoxels (1000) x map.resolution on every axis "
           "(bounds the length of every ray)",
           [](PipelineConfig& c) {
             c.map.local_half_extent.z() = above(kMaxLocalHalfExtentVoxels * c.map.resolution);
           }},
          {"map.local_half_extent",
           "too large for tiled carving: the local block grid must have at most kMaxTileCells "
           "(4096) cells when map.carve_tiles > 0",
           [](PipelineConfig& c) {
             c.map.carve_tiles = 4;
             c.map.local_half_extent = Eigen::Vector3f(20.f, 20.f, 5.f);
           }},
      });
}

TEST(Relations, DetectorRelationsAreEnforcedByTheDetectorAndByValidate) {
  auto detector = std::make_unique<UMapDetector>();
  expect_relations_enforced(
      params::kUMapDetectorRelations, "detector.",
      [](const PipelineConfig& c) { return c.detector; },
      [&](const UMapDetectorConfig& c) { return ok(detector->init(c)); },
      {
          {"detector.d_max", "must be > detector.d_min",
           [](PipelineConfig& c) { c.detector.d_max = c.detector.d_min; }},
      });
}

TEST(Relations, TrackRelationsAreEnforcedByTheTrackConfigsAndByValidate) {
  expect_relations_enforced(
      params::kContinuityRelations, "tracker.continuity.",
      [](const PipelineConfig& c) { return c.tracker.continuity; },
      [](const ContinuityConfig& c) { return ok(c.validate()); },
      {
          {"tracker.continuity.dynamic_votes", "must be <= tracker.continuity.vote_window",
           [](PipelineConfig& c) {
             c.tracker.continuity.dynamic_votes = c.tracker.continuity.vote_window + 1;
           }},
          {"tracker.continuity.static_votes", "must be < tracker.continuity.dynamic_votes",
           [](PipelineConfig& c) {
             c.tracker.continuity.static_votes = c.tracker.continuity.dynamic_votes;
           }},
          {"tracker.continuity.max_size", "must be >= tracker.continuity.min_size on every axis",
           [](PipelineConfig& c) {
             c.tracker.continuity.min_size.y() = above(c.tracker.continuity.max_size.y());
           }},
      });
  // The tracker's own validate() (its nested configs' tables included) and Tracker::init.
  expect_relations_enforced(
      params::kContinuityRelations, "tracker.continuity.",
      [](const PipelineConfig& c) { return c.tracker.continuity; },
      [](const ContinuityConfig& c) {
        TrackerConfig t;
        t.continuity = c;
        return ok(t.validate());
      },
      {
          {"tracker.continuity.dynamic_votes", "must be <= tracker.continuity.vote_window",
           [](PipelineConfig& c) { c.tracker.continuity.vote_window = 15; }},
          {"tracker.continuity.static_votes", "must be < tracker.continuity.dynamic_votes",
           [](PipelineConfig& c) { c.tracker.continuity.dynamic_votes = 4; }},
          {"tracker.continuity.max_size", "must be >= tracker.continuity.min_size on every axis",
           [](PipelineConfig& c) { c.tracker.continuity.min_size.x() = 1.5f; }},
      });
  auto tracker = std::make_unique<Tracker>();
  expect_relations_enforced(
      params::kTrackerRelations, "tracker.", [](const PipelineConfig& c) { return c.tracker; },
      [&](const TrackerConfig& c) { return ok(tracker->init(c, 640, 480)); },
      {
          {"tracker.continuity.displacement_frames",
           "must be <= tracker.history_length - 1 (the filter needs n + 2 states)",
           [](PipelineConfig& c) {
             c.tracker.history_length = c.tracker.continuity.displacement_frames;
           }},
          {"tracker.label.early_votes", "must be <= tracker.continuity.vote_window",
           [](PipelineConfig& c) {
             c.tracker.label.early_votes = c.tracker.continuity.vote_window + 1;
           }},
          {"tracker.early_displacement_frames", "must be < tracker.continuity.displacement_frames",
           [](PipelineConfig& c) {
             c.tracker.early_displacement_frames = c.tracker.continuity.displacement_frames;
           }},
      });
}

TEST(Relations, FarFieldRelationsAreEnforcedByTheLayerAndByValidate) {
  auto layer = std::make_unique<FarFieldLayer>();
  expect_relations_enforced(
      params::kFarFieldRelations, "far_field.", [](const PipelineConfig& c) { return c.far_field; },
      [&](const FarFieldConfig& c) { return ok(layer->init(c, 0.f)); },
      {
          {"far_field.max_range", "must be > far_field.hit_min_range",
           [](PipelineConfig& c) { c.far_field.hit_min_range = c.far_field.max_range; }},
          {"far_field.max_range",
           "must be <= (kFarFieldCellsPerSide / 2 - 1) x far_field.cell_size (12.6 m at 0.2 m)",
           [](PipelineConfig& c) { c.far_field.max_range = 12.7f; }},
          {"far_field.max_height", "must be > far_field.min_height",
           [](PipelineConfig& c) { c.far_field.max_height = c.far_field.min_height; }},
          {"far_field.wall_height", "must be in [far_field.min_height, far_field.max_height]",
           [](PipelineConfig& c) { c.far_field.wall_height = above(c.far_field.max_height); }},
          {"far_field.wall_height", "must be in [far_field.min_height, far_field.max_height]",
           [](PipelineConfig& c) {
             c.far_field.wall_height = std::nextafter(c.far_field.min_height, -INFINITY);
           }},
          {"far_field.max_evidence", "must be >= far_field.hit_evidence",
           [](PipelineConfig& c) { c.far_field.max_evidence = c.far_field.hit_evidence - 1; }},
      });
}

// The detector's depth band against the camera's depth unit (a rule between two sections, in
// pipeline_config.cpp): validate() refuses what UMapDetector::detect would refuse on every
// frame, and accepts what it takes. (It used to accept both: detector.d_max = 14 m with a TUM
// camera, 1/5000 m per unit, passed validate() and then failed every frame's detection.)
TEST(Relations, DetectorDepthBandFitsTheCameraDepthUnit) {
  struct Case {
    float depth_scale;
    float d_max;
    int bins;
    const char* refused;  ///< field validate() names, nullptr: accepted
  };
  const Case cases[] = {
      {1.f / 5000.f, 8.f, 120, nullptr},            // the defaults on TUM / Bonn data
      {1.f / 5000.f, 13.f, 120, nullptr},           // 65000 raw
      {1.f / 5000.f, 14.f, 120, "detector.d_max"},  // 70000 raw: beyond uint16
      {0.001f, 65.f, 120, nullptr},
      {0.001f, 66.f, 120, "detector.d_max"},
      {0.1f, 8.f, 80, nullptr},           // raw 1..80: 80 values
      {0.1f, 8.f, 81, "detector.bins"},   // more bins than raw values
      {0.1f, 8.f, 120, "detector.bins"},  // the default bins at 10 cm per unit
  };
  auto detector = std::make_unique<UMapDetector>();
  const std::vector<std::uint16_t> depth(640 * 480, 1000);
  for (const Case& k : cases) {
    PipelineConfig c;
    c.camera.depth_scale = k.depth_scale;
    c.detector.d_max = k.d_max;
    c.detector.bins = k.bins;
    const ConfigError e = validate(c);
    if (k.refused == nullptr) {
      EXPECT_TRUE(e.ok()) << k.d_max << " m, " << k.bins << " bins: " << e.field;
    } else {
      EXPECT_STREQ(e.field, k.refused) << k.d_max << " m, " << k.bins << " bins";
    }
    ASSERT_EQ(detector->init(c.detector), Status::kOk);
    DetectionList out;
    const Status s =
        detector->detect(DepthView{depth.data(), 640, 480, 1280}, c.camera, Pose{}, out);
    EXPECT_EQ(ok(s), k.refused == nullptr) << k.d_max << " m, " << k.bins << " bins";
  }
}

// --- The README's "The parameters you set" table against the code ---------------------------

std::string read_text(const std::string& path) {
  std::ifstream f(path);
  return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

std::string trim(const std::string& s) {
  const std::size_t a = s.find_first_not_of(" \t");
  const std::size_t b = s.find_last_not_of(" \t");
  return a == std::string::npos ? "" : s.substr(a, b - a + 1);
}

// Splits "0, [1, 1, 2.2] m" at the commas outside brackets.
std::vector<std::string> split_top_level(const std::string& s) {
  std::vector<std::string> parts(1);
  int depth = 0;
  for (char ch : s) {
    depth += ch == '[' ? 1 : ch == ']' ? -1 : 0;
    if (ch == ',' && depth == 0) {
      parts.emplace_back();
    } else {
      parts.back() += ch;
    }
  }
  for (std::string& p : parts) p = trim(p);
  return parts;
}

// A README default: "0.4 m/s", "[5, 5, 3] m", "0 (none)", "true". Values as the field's float.
struct ShownDefault {
  std::vector<double> values;
  std::string unit;  ///< "" when none is shown
  bool parsed = false;
};

ShownDefault parse_default(std::string text) {
  ShownDefault d;
  if (const std::size_t paren = text.find(" ("); paren != std::string::npos) {
    text = text.substr(0, paren);  // "0 (none)": the words in brackets are a gloss
  }
  text = trim(text);
  std::string rest;
  if (text.rfind("true", 0) == 0 || text.rfind("false", 0) == 0) {
    d.values.push_back(text[0] == 't' ? 1.0 : 0.0);
    rest = text.substr(text[0] == 't' ? 4 : 5);
  } else if (!text.empty() && text[0] == '[') {
    const std::size_t close = text.find(']');
    if (close == std::string::npos) return d;
    for (const std::string& item : split_top_level(text.substr(1, close - 1))) {
      char* end = nullptr;
      d.values.push_back(std::strtod(item.c_str(), &end));
      if (end == item.c_str() || *end != '\0') return d;
    }
    rest = text.substr(close + 1);
  } else {
    char* end = nullptr;
    d.values.push_back(std::strtod(text.c_str(), &end));
    if (end == text.c_str()) return d;
    rest = end;
  }
  d.unit = trim(rest);
  d.parsed = true;
  return d;
}

// The shown default names the code's default: as many values as components (one value stands
// for all three of a vector), each equal to the field's value once stored as a float.
bool same_default(const Parameter& p, const ShownDefault& shown, const PipelineConfig& code) {
  if (shown.values.size() != 1 && static_cast<int>(shown.values.size()) != p.components()) {
    return false;
  }
  for (int i = 0; i < p.components(); ++i) {
    const double v = shown.values[shown.values.size() == 1 ? 0 : static_cast<std::size_t>(i)];
    if (static_cast<float>(v) != static_cast<float>(p.get(code, i))) return false;
  }
  return true;
}

// The backticked spans of `text`, in order. (No std::regex: GCC 12's <regex> trips
// -Wmaybe-uninitialized under ASan at -O2.)
std::vector<std::string> backticked(const std::string& text) {
  std::vector<std::string> spans;
  for (std::size_t a = text.find('`'); a != std::string::npos; a = text.find('`', a + 1)) {
    const std::size_t b = text.find('`', a + 1);
    if (b == std::string::npos) break;
    spans.push_back(text.substr(a + 1, b - a - 1));
    a = b;
  }
  return spans;
}

// The number N in "Of the N fields", or -1.
long stated_field_count(const std::string& text) {
  const std::string lead = "Of the ";
  const std::size_t at = text.find(lead);
  if (at == std::string::npos) return -1;
  std::size_t end = at + lead.size();
  while (end < text.size() && std::isdigit(static_cast<unsigned char>(text[end])) != 0) ++end;
  if (end == at + lead.size() || text.compare(end, 7, " fields") != 0) return -1;
  return std::stol(text.substr(at + lead.size(), end - at - lead.size()));
}

// The section "### The parameters you set" of README.md, up to the next heading.
std::string readme_parameter_section() {
  const std::string readme = read_text(std::string(DYNAMAP_SOURCE_DIR) + "/README.md");
  const std::size_t at = readme.find("### The parameters you set");
  if (at == std::string::npos) return "";
  const std::size_t end = readme.find("\n#", at + 4);
  return readme.substr(at, end == std::string::npos ? std::string::npos : end - at);
}

TEST(Parameters, ReadmeTableNamesRealFieldsWithTheirDefaults) {
  const std::string section = readme_parameter_section();
  ASSERT_FALSE(section.empty()) << "README.md lacks \"### The parameters you set\"";
  const long count = stated_field_count(section);
  ASSERT_GE(count, 0) << "README.md: no \"Of the N fields\"";
  EXPECT_EQ(static_cast<std::size_t>(count), parameters().size())
      << "README.md: \"Of the N fields of PipelineConfig\" is stale";
  const PipelineConfig code;
  int rows = 0;
  std::size_t from = 0;
  for (std::size_t eol; (eol = section.find('\n', from)) != std::string::npos; from = eol + 1) {
    const std::string line = section.substr(from, eol - from);
    if (line.rfind("| `", 0) != 0) continue;  // only parameter rows (not the header or rule)
    std::vector<std::string> cells;
    for (std::size_t a = 1, b; (b = line.find('|', a)) != std::string::npos; a = b + 1) {
      cells.push_back(trim(line.substr(a, b - a)));
    }
    ASSERT_GE(cells.size(), 2u) << line;
    const std::vector<std::string> names = backticked(cells[0]);
    const std::vector<std::string> shown = split_top_level(cells[1]);
    for (std::size_t i = 0; i < names.size(); ++i) {
      const std::string& name = names[i];
      if (name.size() > 2 && name.compare(name.size() - 2, 2, ".*") == 0) {
        // A group (camera.*, budgets.*): its fields exist; the default column is prose.
        const std::string prefix = name.substr(0, name.size() - 1);
        bool any = false;
        for (const Parameter& p : parameters())
          any = any || std::string(p.path).rfind(prefix, 0) == 0;
        EXPECT_TRUE(any) << "README.md names group " << name << " but no field starts with it";
        continue;
      }
      const Parameter* p = find_parameter(name.c_str());
      if (p == nullptr) {
        ADD_FAILURE() << "README.md names " << name << ", which is not a PipelineConfig field";
        continue;
      }
      ++rows;
      // One default per name, or one default shared by all names of the row.
      const std::string text = shown.size() == names.size() ? shown[i] : cells[1];
      const ShownDefault d = parse_default(text);
      ASSERT_TRUE(d.parsed) << name << ": cannot read the README default '" << text << "'";
      EXPECT_TRUE(same_default(*p, d, code))
          << "README.md shows " << name << " = '" << text << "', the code's default differs";
      if (!d.unit.empty()) {
        EXPECT_EQ(d.unit, p->unit) << name << ": unit in README.md";
      }
    }
  }
  EXPECT_GT(rows, 5) << "no parameter rows read from README.md";
}

// The README check itself: a wrong default, unit or name is caught.
TEST(Parameters, ReadmeDefaultParsing) {
  const Parameter& max_size = *find_parameter("tracker.continuity.max_size");
  const PipelineConfig code;
  EXPECT_TRUE(same_default(max_size, parse_default("[1, 1, 2.2] m"), code));
  EXPECT_FALSE(same_default(max_size, parse_default("[2, 2, 2.2] m"), code));
  EXPECT_EQ(parse_default("[1, 1, 2.2] m").unit, "m");
  EXPECT_EQ(split_top_level("0, [1, 1, 2.2] m").size(), 2u);
  const Parameter& min_size = *find_parameter("tracker.continuity.min_size");
  EXPECT_TRUE(same_default(min_size, parse_default("0"), code));
  const Parameter& speed = *find_parameter("tracker.continuity.min_speed");
  EXPECT_TRUE(same_default(speed, parse_default("0.4 m/s"), code));
  EXPECT_FALSE(same_default(speed, parse_default("0.5 m/s"), code));
  EXPECT_FALSE(parse_default("about five").parsed);
  EXPECT_TRUE(same_default(*find_parameter("budgets.frame_ns"), parse_default("0 (none)"), code));
}

}  // namespace
}  // namespace dynamap
