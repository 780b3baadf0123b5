// Replay parameters: a YAML file whose keys name PipelineConfig fields ("map.resolution",
// nested maps or dotted keys). Every key is checked: an unknown key or a bad value is an error
// naming the file, the line and the key; then the whole configuration is validated.
// Compiled once (the dynamap_replay_params library): the replay, the diagnosis tools and
// fuzz_params link it.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "common/sequence.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"

namespace dynamap::tools {

/// Applies the YAML file at `path` onto `config`. Returns "" on success, else the error text.
std::string apply_params_file(const std::string& path, PipelineConfig& config);

/// One line per parameter the file accepts (the library's parameter table): key, value in
/// `config` (and the default when it differs), tier, valid range and help. Only the user tier
/// unless `all_tiers` (for --help-params).
std::vector<std::string> describe_params(const PipelineConfig& config, bool all_tiers);

/// docs/parameters.md: the parameter table as Markdown, one table per tier, with the library's
/// defaults and the replay tools' own where they differ (`dynamap-replay --params-markdown`;
/// test_replay keeps the page current).
std::string parameters_markdown();

/// The library's intrinsics for a sequence's camera.txt model.
CameraIntrinsics intrinsics_of(const CameraModel& camera);

/// The library's (float) pose for a sequence pose.
Pose to_pose(const PoseD& pose);

/// The library's defaults as the replay tools use them: the linear baseline on (the evaluation
/// compares against it).
PipelineConfig replay_defaults();

/// Default configuration with the sequence's camera, then the parameter file on top when
/// `params_file` is not empty; a bad file throws ToolError with apply_params_file's message.
PipelineConfig config_for_sequence(const Sequence& seq, const std::string& params_file);

/// A pipeline initialised with `config`, on the heap (it holds its whole ~9.5 MiB budget
/// inline); throws ToolError naming the rejected field and why.
std::unique_ptr<Pipeline> make_pipeline(const PipelineConfig& config);

/// The value after option `name` among argv[first..argc), or "" when it is not given.
std::string option_value(int argc, char** argv, int first, const std::string& name);

}  // namespace dynamap::tools
