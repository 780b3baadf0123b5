// PipelineConfig's parameter and relation tables, assembled from the stage tables
// (map/map_params.hpp, detect/detect_params.hpp, track/track_params.hpp,
// predict/predict_params.hpp) plus the pipeline's own fields below. Each stage section adds its
// prefix ("map.", "tracker.kalman.") to its rows' member paths and its relations' fields at
// compile time; nothing here repeats a stage's range, relation or help.
#include "dynamap/pipeline/parameters.hpp"

#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <iterator>
#include <utility>

#include "dynamap/detect/detect_params.hpp"
#include "dynamap/map/map_params.hpp"
#include "dynamap/predict/predict_params.hpp"
#include "dynamap/track/track_params.hpp"

namespace dynamap {
namespace {

using namespace param_rows;  // NOLINT(google-build-using-namespace): U, C, X, kOpen, ...

// The pipeline's own fields (camera, ground, history age, baseline, budgets, team), in table
// order;
// kOwnHead, kOwnClean and kOwnTail below say where each slice goes.
constexpr Param<PipelineConfig> kOwn[] = {
    // clang-format off
    // Camera (the tools read it from the sequence's camera.txt).
    {DYNAMAP_PARAM(PipelineConfig, camera.fx), U, "px", 0, kInf, kOpen, kOpen, "focal length along image x"},
    {DYNAMAP_PARAM(PipelineConfig, camera.fy), U, "px", 0, kInf, kOpen, kOpen, "focal length along image y"},
    {DYNAMAP_PARAM(PipelineConfig, camera.cx), U, "px", -kInf, kInf, kOpen, kOpen, "principal point x"},
    {DYNAMAP_PARAM(PipelineConfig, camera.cy), U, "px", -kInf, kInf, kOpen, kOpen, "principal point y"},
    {DYNAMAP_PARAM(PipelineConfig, camera.width), U, "px", 1, kMaxImageWidth, kClosed, kClosed, "depth image width"},
    {DYNAMAP_PARAM(PipelineConfig, camera.height), U, "px", 1, kMaxImageHeight, kClosed, kClosed, "depth image height"},
    {DYNAMAP_PARAM(PipelineConfig, camera.depth_scale), U, "m", 0, kInf, kOpen, kOpen, "metres per depth unit (RealSense 0.001, TUM 1/5000)"},
    {DYNAMAP_PARAM(PipelineConfig, ground_height), U, "m", -kInf, kInf, kOpen, kOpen, "map-frame z of the floor: the refiner ignores and the cleaner never clears voxels below ground + refiner.floor_margin"},
    // Cleaner's history (after the cleaner's rows).
    {DYNAMAP_PARAM(PipelineConfig, clean_history_max_age_ns), X, "ns", 0, kInf, kClosed, kOpen, "cleared voxels count as occupied this long for the refiner"},
    // Linear baseline and budgets (last).
    {DYNAMAP_PARAM(PipelineConfig, run_linear_baseline), X, "", 0, 1, kClosed, kClosed, "also run the constant-velocity predictor (the evaluation's yardstick)"},
    {DYNAMAP_PARAM(PipelineConfig, budgets.frame_ns), U, "ns", 0, kInf, kClosed, kOpen, "whole-frame time budget (0: none)"},
    {DYNAMAP_NAMED_PARAM(PipelineConfig, "budgets.stage_ns.occupancy", budgets.stage_ns[0]), U, "ns", 0, kInf, kClosed, kOpen, "occupancy stage budget (0: none)"},
    {DYNAMAP_NAMED_PARAM(PipelineConfig, "budgets.stage_ns.detection", budgets.stage_ns[1]), U, "ns", 0, kInf, kClosed, kOpen, "detection stage budget (0: none)"},
    {DYNAMAP_NAMED_PARAM(PipelineConfig, "budgets.stage_ns.refinement", budgets.stage_ns[2]), U, "ns", 0, kInf, kClosed, kOpen, "refinement stage budget (0: none)"},
    {DYNAMAP_NAMED_PARAM(PipelineConfig, "budgets.stage_ns.tracking", budgets.stage_ns[3]), U, "ns", 0, kInf, kClosed, kOpen, "tracking stage budget (0: none)"},
    {DYNAMAP_NAMED_PARAM(PipelineConfig, "budgets.stage_ns.cleaning", budgets.stage_ns[4]), U, "ns", 0, kInf, kClosed, kOpen, "cleaning stage budget (0: none)"},
    {DYNAMAP_NAMED_PARAM(PipelineConfig, "budgets.stage_ns.prediction", budgets.stage_ns[5]), U, "ns", 0, kInf, kClosed, kOpen, "prediction stage budget (0: none)"},
    {DYNAMAP_NAMED_PARAM(PipelineConfig, "budgets.stage_ns.far_field", budgets.stage_ns[6]), U, "ns", 0, kInf, kClosed, kOpen, "far-field layer stage budget (0: none)"},
    {DYNAMAP_PARAM(PipelineConfig, budgets.adaptive_stride), U, "", 0, 1, kClosed, kClosed, "coarsen the map's pixel stride when the occupancy stage overruns"},
    {DYNAMAP_PARAM(PipelineConfig, budgets.max_pixel_stride), C, "px", 1, kMaxImageWidth, kClosed, kClosed, "coarsest stride the adaptive mode may use"},
    {DYNAMAP_PARAM(PipelineConfig, budgets.restore_fraction), X, "", 0, 1, kOpen, kOpen, "restore a finer stride below this share of the budget"},
    // The thread team.
    {DYNAMAP_PARAM(PipelineConfig, team.members), C, "", 1, kMaxTeamMembers, kClosed, kClosed, "threads working on a frame, the caller included (> 1 needs map.carve_tiles > 0)"},
    {DYNAMAP_PARAM(PipelineConfig, team.helper_fifo_priority), X, "", 0, 99, kClosed, kClosed, "SCHED_FIFO priority of the team's helper threads (0: the policy of the thread calling init())"},
    {DYNAMAP_PARAM(PipelineConfig, team.helper_first_cpu), X, "", -1, kMaxCpuIndex, kClosed, kClosed, "pin helper m to CPU helper_first_cpu + m - 1 (-1: no pinning)"},
    // clang-format on
};
static_assert(kStageCount == 7, "every stage has a budgets.stage_ns.<stage> row in the table");

// A section: the rows table[first, first + count) of one config struct, reached from a
// PipelineConfig by of(), under the dotted prefix.
#define DYNAMAP_SECTION(Name, prefix_text, stage_table, member)                \
  struct Name {                                                                \
    static constexpr const char prefix[] = prefix_text;                        \
    static constexpr const auto& table = stage_table;                          \
    static constexpr std::size_t first = 0;                                    \
    static constexpr std::size_t count = std::size(stage_table);               \
    static const auto& of(const PipelineConfig& c) noexcept { return member; } \
    static auto& of(PipelineConfig& c) noexcept { return member; }             \
  }
#define DYNAMAP_OWN_SECTION(Name, begin, end)                                       \
  struct Name {                                                                     \
    static constexpr const char prefix[] = "";                                      \
    static constexpr const auto& table = kOwn;                                      \
    static constexpr std::size_t first = begin;                                     \
    static constexpr std::size_t count = (end) - (begin);                           \
    static const PipelineConfig& of(const PipelineConfig& c) noexcept { return c; } \
    static PipelineConfig& of(PipelineConfig& c) noexcept { return c; }             \
  }

DYNAMAP_OWN_SECTION(OwnHead, 0, 8);
DYNAMAP_SECTION(Map, "map.", params::kOccupancyMap, c.map);
DYNAMAP_SECTION(Detector, "detector.", params::kUMapDetector, c.detector);
DYNAMAP_SECTION(Refiner, "refiner.", params::kMapRefiner, c.refiner);
DYNAMAP_SECTION(Kalman, "tracker.kalman.", params::kKalman, c.tracker.kalman);
DYNAMAP_SECTION(Imm, "tracker.kalman.imm.", params::kImm, c.tracker.kalman.imm);
DYNAMAP_SECTION(Continuity, "tracker.continuity.", params::kContinuity, c.tracker.continuity);
DYNAMAP_SECTION(Label, "tracker.label.", params::kLabel, c.tracker.label);
DYNAMAP_SECTION(Tracker, "tracker.", params::kTracker, c.tracker);
DYNAMAP_SECTION(Fragments, "fragments.", params::kDetectionRefiner, c.fragments);
DYNAMAP_SECTION(EverFree, "ever_free.", params::kEverFree, c.ever_free);
DYNAMAP_SECTION(Cleaner, "cleaner.", params::kDynamicRegionCleaner, c.cleaner);
DYNAMAP_OWN_SECTION(OwnClean, 8, 9);
DYNAMAP_SECTION(Trail, "trail.", params::kTrailGrid, c.trail);
DYNAMAP_SECTION(Paths, "predictor.paths.", params::kPathLibrary, c.predictor.paths);
DYNAMAP_SECTION(Clearance, "predictor.clearance.", params::kClearance, c.predictor.clearance);
DYNAMAP_SECTION(Predictor, "predictor.", params::kMarkovPredictor, c.predictor);
DYNAMAP_SECTION(FarField, "far_field.", params::kFarField, c.far_field);
DYNAMAP_OWN_SECTION(OwnTail, 9, std::size(kOwn));

#undef DYNAMAP_SECTION
#undef DYNAMAP_OWN_SECTION

constexpr std::size_t length(const char* s) noexcept {
  std::size_t n = 0;
  while (s[n] != '\0') ++n;
  return n;
}

template <std::size_t N>
struct Text {
  char s[N];
};

// "<prefix><name>" built at compile time; Name gives prefix and name as constexpr pointers.
template <class Name>
struct Joined {
  static constexpr std::size_t size = length(Name::prefix) + length(Name::name) + 1;
  static constexpr Text<size> text = [] {
    Text<size> t{};
    std::size_t k = 0;
    for (const char* p = Name::prefix; *p != '\0'; ++p) t.s[k++] = *p;
    for (const char* p = Name::name; *p != '\0'; ++p) t.s[k++] = *p;
    t.s[k] = '\0';
    return t;
  }();
};

// The dotted path of row I of section S, one string per row.
template <class S, std::size_t I>
struct RowName {
  static constexpr const char* prefix = S::prefix;
  static constexpr const char* name = S::table[S::first + I].path;
};
template <class S, std::size_t I>
using Path = Joined<RowName<S, I>>;

template <class S, std::size_t I>
double get(const PipelineConfig& c, int i) noexcept {
  return S::table[S::first + I].get(S::of(c), i);
}
template <class S, std::size_t I>
void set(PipelineConfig& c, int i, double v) noexcept {
  S::table[S::first + I].set(S::of(c), i, v);
}

template <class S, std::size_t I>
constexpr Parameter row() noexcept {
  const auto& r = S::table[S::first + I];
  return Parameter{
      Path<S, I>::text.s, r.kind,     &get<S, I>, &set<S, I>, r.tier,        r.unit, r.min, r.max,
      r.min_open,         r.max_open, r.help,     r.choices,  r.choice_count};
}

template <class S, std::size_t... I>
constexpr std::array<Parameter, sizeof...(I)> rows(std::index_sequence<I...>) noexcept {
  return {{row<S, I>()...}};
}
template <class... S>
constexpr std::array<Parameter, (S::count + ...)> assemble() noexcept {
  std::array<Parameter, (S::count + ...)> all{};
  std::size_t k = 0;
  const auto add = [&](const auto& part) {
    for (const Parameter& p : part) all[k++] = p;
  };
  (add(rows<S>(std::make_index_sequence<S::count>{})), ...);
  return all;
}

// The pipeline bounds a cap tighter than its stage does (docs/realtime.md, "Bounded work"):
// the map alone admits kMaxVoxelVisitsPerFrame for offline exact walks.
template <std::size_t N>
constexpr std::array<Parameter, N> with_pipeline_bounds(std::array<Parameter, N> t) noexcept {
  for (Parameter& p : t) {
    if (param_detail::same(p.path, "map.max_voxel_visits_per_frame")) {
      p.max = static_cast<double>(kMaxPipelineVoxelVisitsPerFrame);
    }
  }
  return t;
}

constexpr auto kTable = with_pipeline_bounds(
    assemble<OwnHead, Map, Detector, Refiner, Kalman, Imm, Continuity, Label, Tracker, Fragments,
             EverFree, Cleaner, OwnClean, Trail, Paths, Clearance, Predictor, FarField, OwnTail>());

constexpr bool paths_unique() noexcept {
  for (std::size_t i = 0; i < kTable.size(); ++i) {
    for (std::size_t j = i + 1; j < kTable.size(); ++j) {
      if (param_detail::same(kTable[i].path, kTable[j].path)) return false;
    }
  }
  return true;
}
static_assert(paths_unique(), "every parameter path appears once in the table");

// --- Relations: each stage's Relation table under its section's prefix ----------------------

#define DYNAMAP_RELATIONS(Name, Section, stage_table)                                  \
  struct Name {                                                                        \
    static constexpr const char* prefix = Section::prefix;                             \
    static constexpr const auto& table = stage_table;                                  \
    static constexpr std::size_t count = std::size(stage_table);                       \
    static const auto& of(const PipelineConfig& c) noexcept { return Section::of(c); } \
  }

DYNAMAP_RELATIONS(MapRelations, Map, params::kOccupancyMapRelations);
DYNAMAP_RELATIONS(DetectorRelations, Detector, params::kUMapDetectorRelations);
DYNAMAP_RELATIONS(ContinuityRelations, Continuity, params::kContinuityRelations);
DYNAMAP_RELATIONS(TrackerRelations, Tracker, params::kTrackerRelations);
DYNAMAP_RELATIONS(FarFieldRelations, FarField, params::kFarFieldRelations);
DYNAMAP_RELATIONS(CleanerRelations, Cleaner, params::kDynamicRegionCleanerRelations);

#undef DYNAMAP_RELATIONS

template <class S, std::size_t I>
struct RelationName {
  static constexpr const char* prefix = S::prefix;
  static constexpr const char* name = S::table[I].field;
};

template <class S, std::size_t I>
bool holds(const PipelineConfig& c) noexcept {
  return S::table[I].holds(S::of(c));
}

template <class S, std::size_t... I>
constexpr std::array<Relation<PipelineConfig>, sizeof...(I)> relations(
    std::index_sequence<I...>) noexcept {
  return {{Relation<PipelineConfig>{Joined<RelationName<S, I>>::text.s, S::table[I].reason,
                                    &holds<S, I>}...}};
}
template <class... S>
constexpr std::array<Relation<PipelineConfig>, (S::count + ...)> assemble_relations() noexcept {
  std::array<Relation<PipelineConfig>, (S::count + ...)> all{};
  std::size_t k = 0;
  const auto add = [&](const auto& part) {
    for (const Relation<PipelineConfig>& r : part) all[k++] = r;
  };
  (add(relations<S>(std::make_index_sequence<S::count>{})), ...);
  return all;
}

constexpr auto kRelations =
    assemble_relations<MapRelations, DetectorRelations, ContinuityRelations, TrackerRelations,
                       FarFieldRelations, CleanerRelations>();

// A relation names a field of the table (its YAML key), so the error points at something the
// user can set.
constexpr bool relation_fields_known() noexcept {
  for (const Relation<PipelineConfig>& r : kRelations) {
    bool found = false;
    for (const Parameter& p : kTable) found = found || param_detail::same(p.path, r.field);
    if (!found) return false;
  }
  return true;
}
static_assert(relation_fields_known(), "every relation's field is a parameter path");

// "12", "0.01", "1e+06": short, exact enough for a value.
int print_number(char* buf, std::size_t size, double v) noexcept {
  return std::snprintf(buf, size, "%.6g", v);
}

}  // namespace

ParameterTable parameters() noexcept {
  return ParameterTable{kTable.data(), kTable.size()};
}

const Parameter* find_parameter(const char* path) noexcept {
  if (path == nullptr) return nullptr;
  for (const Parameter& p : kTable) {
    if (std::strcmp(p.path, path) == 0) return &p;
  }
  return nullptr;
}

const char* to_string(ParamTier tier) noexcept {
  switch (tier) {
    case ParamTier::kUser:
      return "user";
    case ParamTier::kCapacity:
      return "capacity";
    case ParamTier::kExpert:
      return "expert";
  }
  return "?";
}

ConfigError check_ranges(const PipelineConfig& config) noexcept {
  double v = 0.0;
  const Parameter* p = first_out_of_range(config, kTable.data(), kTable.size(), &v);
  if (p == nullptr) return ConfigError{};
  ConfigError e{Status::kInvalidArgument, p->path, "outside its valid range"};
  e.parameter = p;
  e.value = v;
  return e;
}

ConfigError check_relations(const PipelineConfig& config) noexcept {
  const Relation<PipelineConfig>* r = first_broken(config, kRelations.data(), kRelations.size());
  return r == nullptr ? ConfigError{} : ConfigError{Status::kInvalidArgument, r->field, r->reason};
}

const char* describe(const ConfigError& e, char* buf, std::size_t size) noexcept {
  if (size == 0) return buf;
  if (e.ok()) {
    std::snprintf(buf, size, "ok");
  } else if (e.parameter != nullptr) {
    char range[96];
    char value[32];
    if (e.parameter->kind == ParamKind::kEnum || e.parameter->kind == ParamKind::kBool) {
      std::snprintf(value, sizeof value, "%d", static_cast<int>(e.value));
    } else {
      print_number(value, sizeof value, e.value);
    }
    std::snprintf(buf, size, "%s = %s: must be %s%s", e.field, value,
                  std::isfinite(e.parameter->min) && std::isfinite(e.parameter->max) &&
                          e.parameter->kind != ParamKind::kEnum
                      ? "in "
                      : "",
                  e.parameter->range_text(range, sizeof range));
  } else {
    std::snprintf(buf, size, "%s: %s", e.field, e.reason);
  }
  return buf;
}

}  // namespace dynamap
