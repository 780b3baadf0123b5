// The parameter table: one constexpr description of every PipelineConfig field (dotted path,
// tier, unit, valid range, one-line help). validate() checks every range from it and names the
// field; the tools' YAML keys, `dynamap-replay --help-params` and docs/parameters.md come from
// it too. The defaults are the struct initialisers of the stage configs, read from a
// default-constructed PipelineConfig, so each default is written once.
#pragma once

#include <cstddef>
#include <cstdint>

#include "dynamap/pipeline/pipeline_config.hpp"

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

/// Description of one parameter. Ranges are inclusive unless min_open / max_open; a field's value
/// must also be finite. get/set read and write component `i` (0 for scalars) as a double.
struct Parameter {
  const char* path;  ///< e.g. "map.resolution": the C++ member path and the YAML key
  ParamKind kind;
  double (*get)(const PipelineConfig& config, int component);
  void (*set)(PipelineConfig& config, int component, double value);
  ParamTier tier;
  const char* unit;  ///< "m", "m/s", "ns", "px", "" (dimensionless)
  double min;
  double max;
  bool min_open;
  bool max_open;
  const char* help;
  const ParamChoice* choices = nullptr;  ///< kEnum only
  std::size_t choice_count = 0;

  int components() const noexcept { return kind == ParamKind::kVector3 ? 3 : 1; }
  /// True when `v` is finite and inside the valid range.
  bool in_range(double v) const noexcept;
  /// "[0.01, 10] m", "(0, 1)", ">= 1", "cv or imm" ... into buf (always terminated); returns buf.
  const char* range_text(char* buf, std::size_t size) const noexcept;
};

/// The whole table, in PipelineConfig order.
struct ParameterTable {
  const Parameter* first;
  std::size_t count;
  const Parameter* begin() const noexcept { return first; }
  const Parameter* end() const noexcept { return first + count; }
  std::size_t size() const noexcept { return count; }
};
ParameterTable parameters() noexcept;

/// The parameter with dotted path `path`, or nullptr.
const Parameter* find_parameter(const char* path) noexcept;

/// Short name of a tier ("user", "capacity", "expert").
const char* to_string(ParamTier tier) noexcept;

/// Checks every field against its range in the table; the first field outside names itself
/// (ConfigError::parameter, ::value). Relations between fields are validate()'s.
ConfigError check_ranges(const PipelineConfig& config) noexcept;

/// One line for a validation error, e.g. "map.resolution = 20: must be in [0.01, 10] m" or
/// "map.max_depth: must be > map.min_depth", into buf (always terminated); returns buf.
const char* describe(const ConfigError& error, char* buf, std::size_t size) noexcept;

}  // namespace dynamap
