// The parameter table of PipelineConfig: every field's dotted path, tier, unit, valid range and
// one-line help, assembled at compile time from the stage tables next to each stage
// (map/map_params.hpp, detect/detect_params.hpp, track/track_params.hpp,
// predict/predict_params.hpp) and the pipeline's own rows (src/pipeline/parameters.cpp).
// validate() checks every range from it, and every stage's Relation table the same way, naming
// the field; the tools' YAML keys,
// `dynamap-replay --help-params` and docs/parameters.md come from it too. The defaults are the
// struct initialisers of the stage configs, read from a default-constructed PipelineConfig.
#pragma once

#include <cstddef>
#include <cstdint>

#include "dynamap/pipeline/pipeline_config.hpp"

namespace dynamap {

/// The whole table, in PipelineConfig order. A Parameter (pipeline_config.hpp) is one field:
/// its dotted path ("map.resolution", the YAML key), kind, accessors, tier, unit, range, help.
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

/// Checks the relations of every stage's Relation table (e.g. params::kOccupancyMapRelations),
/// the same code the stage's init() runs; the first broken one gives its field with the
/// section's prefix ("map.prob_min") and its reason. Meaningful once check_ranges() passed;
/// the relations between stages are validate()'s.
ConfigError check_relations(const PipelineConfig& config) noexcept;

/// One line for a validation error, e.g. "map.resolution = 20: must be in [0.01, 10] m" or
/// "map.max_depth: must be > map.min_depth", into buf (always terminated); returns buf.
const char* describe(const ConfigError& error, char* buf, std::size_t size) noexcept;

}  // namespace dynamap
