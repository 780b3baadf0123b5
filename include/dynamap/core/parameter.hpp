// Parameter descriptors: each stage describes its config struct's fields once, in a table next
// to the stage (map/map_params.hpp, detect/detect_params.hpp, track/track_params.hpp,
// predict/predict_params.hpp): member path, unit, valid range, tier and help. The default is
// the struct's member initialiser, read from a default-constructed config, never repeated here.
// The stage's validate() checks every range from its table (first_out_of_range), then the
// relations between its fields from its Relation table (first_broken); the pipeline assembles
// the stage tables into the PipelineConfig tables (pipeline/parameters.hpp), which validate(),
// the tools' YAML keys, `dynamap-replay --help-params` and docs/parameters.md come from.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

namespace dynamap {

/// Who should touch a parameter: kUser (set it for your camera, vehicle and scene), kCapacity
/// (work caps and sizes: change with the memory and time budget), kExpert (method tuning,
/// measured in docs/; leave unless you re-run the evaluation).
enum class ParamTier : std::uint8_t { kUser, kCapacity, kExpert };

/// Storage type of a field: float, int, unsigned count (size_t / uint64), bool, Eigen::Vector3f
/// (the range applies per component) or an enum spelled by name.
enum class ParamKind : std::uint8_t { kFloat, kInt, kCount, kBool, kVector3, kEnum };

/// One spelling of an enum parameter's value (YAML and docs use the name).
struct ParamChoice {
  const char* name;
  int value;
};

/// True when `v` is finite, inside [min, max] (ends open as told) and, for an enum, a choice.
bool param_in_range(ParamKind kind, double min, double max, bool min_open, bool max_open,
                    const ParamChoice* choices, std::size_t choice_count, double v) noexcept;

/// "[0.01, 10] m", "(0, 1)", ">= 1", "cv or imm" ... into buf (always terminated); returns buf.
const char* param_range_text(ParamKind kind, double min, double max, bool min_open, bool max_open,
                             const char* unit, const ParamChoice* choices, std::size_t choice_count,
                             char* buf, std::size_t size) noexcept;

/// Description of one field of `Config`. Ranges are inclusive unless min_open / max_open; a
/// value must also be finite. get/set read and write component `i` (0 for scalars) as a double.
template <class Config>
struct Param {
  const char* path;  ///< member path in Config, e.g. "resolution", "kalman.imm.q_accel_turn"
  ParamKind kind;
  double (*get)(const Config& config, int component);
  void (*set)(Config& config, int component, double value);
  ParamTier tier;
  const char* unit;  ///< "m", "m/s", "ns", "px", "" (dimensionless)
  double min;
  double max;
  bool min_open;
  bool max_open;
  const char* help;
  const ParamChoice* choices = nullptr;  ///< kEnum only
  std::size_t choice_count = 0;

  constexpr int components() const noexcept { return kind == ParamKind::kVector3 ? 3 : 1; }
  bool in_range(double v) const noexcept {
    return param_in_range(kind, min, max, min_open, max_open, choices, choice_count, v);
  }
  const char* range_text(char* buf, std::size_t size) const noexcept {
    return param_range_text(kind, min, max, min_open, max_open, unit, choices, choice_count, buf,
                            size);
  }
};

/// The first field of `config` outside its range in `table` (in table order), or nullptr; the
/// bad value goes to *value when given. Stage validate()s and the pipeline's share it.
template <class Config>
const Param<Config>* first_out_of_range(const Config& config, const Param<Config>* table,
                                        std::size_t count, double* value = nullptr) noexcept {
  for (std::size_t k = 0; k < count; ++k) {
    const Param<Config>& p = table[k];
    for (int i = 0; i < p.components(); ++i) {
      const double v = p.get(config, i);
      if (!p.in_range(v)) {
        if (value != nullptr) *value = v;
        return &p;
      }
    }
  }
  return nullptr;
}
template <class Config, std::size_t N>
bool all_in_range(const Config& config, const Param<Config> (&table)[N]) noexcept {
  return first_out_of_range(config, table, N) == nullptr;
}

/// A rule relating fields of one config (prob_min < prob_miss), in a table next to the stage's
/// Param table so the stage's validate() and the pipeline's check the same code. `field` is the
/// member path to change (the pipeline adds its prefix, as for a Param); `reason` names fields by
/// their PipelineConfig path, as the YAML keys and error messages do.
template <class Config>
struct Relation {
  const char* field;   ///< member path, e.g. "prob_min", "continuity.static_votes"
  const char* reason;  ///< e.g. "must be < map.prob_miss"
  bool (*holds)(const Config& config) noexcept;
};

/// The first relation of `table` that `config` breaks (in table order), or nullptr. Meaningful
/// once every field is in range (a relation may divide by a field).
template <class Config>
const Relation<Config>* first_broken(const Config& config, const Relation<Config>* table,
                                     std::size_t count) noexcept {
  for (std::size_t k = 0; k < count; ++k) {
    if (!table[k].holds(config)) return &table[k];
  }
  return nullptr;
}
template <class Config, std::size_t N>
bool all_hold(const Config& config, const Relation<Config> (&table)[N]) noexcept {
  return first_broken(config, table, N) == nullptr;
}

namespace param_detail {

inline constexpr double kInf = std::numeric_limits<double>::infinity();

template <class T>
double read(const T& field, int) noexcept {
  if constexpr (std::is_enum_v<T>) {
    return static_cast<double>(static_cast<int>(field));
  } else {
    return static_cast<double>(field);
  }
}
inline double read(const Eigen::Vector3f& field, int i) noexcept {
  return static_cast<double>(field[i]);
}
template <class T>
void write(T& field, int, double v) noexcept {
  if constexpr (std::is_enum_v<T>) {
    field = static_cast<T>(static_cast<int>(v));
  } else if constexpr (std::is_same_v<T, bool>) {
    field = v != 0.0;
  } else {
    field = static_cast<T>(v);  // callers check the value fits the type first
  }
}
inline void write(Eigen::Vector3f& field, int i, double v) noexcept {
  field[i] = static_cast<float>(v);
}

template <class T>
constexpr ParamKind kind_of() noexcept {
  if constexpr (std::is_same_v<T, Eigen::Vector3f>) return ParamKind::kVector3;
  if constexpr (std::is_same_v<T, bool>) return ParamKind::kBool;
  if constexpr (std::is_enum_v<T>) return ParamKind::kEnum;
  if constexpr (std::is_floating_point_v<T>) return ParamKind::kFloat;
  if constexpr (std::is_signed_v<T>) return ParamKind::kInt;
  return ParamKind::kCount;
}

constexpr bool same(const char* a, const char* b) noexcept {
  while (*a != '\0' && *a == *b) {
    ++a;
    ++b;
  }
  return *a == *b;
}

}  // namespace param_detail

/// Short names for the rows of the parameter tables (used inside namespace dynamap::params).
namespace param_rows {
inline constexpr ParamTier U = ParamTier::kUser;
inline constexpr ParamTier C = ParamTier::kCapacity;
inline constexpr ParamTier X = ParamTier::kExpert;
inline constexpr bool kClosed = false;
inline constexpr bool kOpen = true;
using param_detail::kInf;
}  // namespace param_rows

/// True when no two rows of `table` share a path (for a static_assert next to each table).
template <class Config, std::size_t N>
constexpr bool paths_unique(const Param<Config> (&table)[N]) noexcept {
  for (std::size_t i = 0; i < N; ++i) {
    for (std::size_t j = i + 1; j < N; ++j) {
      if (param_detail::same(table[i].path, table[j].path)) return false;
    }
  }
  return true;
}

}  // namespace dynamap

/// Path, kind and accessors of member `member` of `Config`, the first four fields of a
/// Param<Config> row: {DYNAMAP_PARAM(OccupancyMapConfig, resolution), tier, unit, min, max, ...}.
/// (`Config` is a type and `member` a member path: neither can be parenthesised.)
// NOLINTBEGIN(bugprone-macro-parentheses)
#define DYNAMAP_NAMED_PARAM(Config, name, member)                                        \
  (name),                                                                                \
      ::dynamap::param_detail::kind_of<                                                  \
          std::remove_reference_t<decltype(std::declval<Config&>().member)>>(),          \
      [](const Config& c, int i) { return ::dynamap::param_detail::read(c.member, i); }, \
      [](Config& c, int i, double v) { ::dynamap::param_detail::write(c.member, i, v); }
#define DYNAMAP_PARAM(Config, member) DYNAMAP_NAMED_PARAM(Config, #member, member)
// NOLINTEND(bugprone-macro-parentheses)
