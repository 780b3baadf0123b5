// Replay parameters: a YAML file whose keys name PipelineConfig fields ("map.resolution",
// nested maps or dotted keys). Every key is checked: an unknown key or a bad value is an error
// naming the file, the line and the key; then the whole configuration is validated.
#pragma once

#include <string>
#include <vector>

#include "dynamap/pipeline_config.hpp"

namespace dynamap::tools {

/// Applies the YAML file at `path` onto `config`. Returns "" on success, else the error text.
std::string apply_params_file(const std::string& path, PipelineConfig& config);

/// Every key the parameter file accepts, with its current value in `config` (for --help-params).
std::vector<std::string> describe_params(const PipelineConfig& config);

}  // namespace dynamap::tools
