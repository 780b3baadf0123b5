#include "params.hpp"

#include <cstdint>
#include <exception>
#include <filesystem>
#include <functional>
#include <map>
#include <sstream>
#include <system_error>
#include <type_traits>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "common/text_io.hpp"

namespace dynamap::tools {
namespace {

// One settable field: its dotted key, a parser from a YAML scalar, and a printer.
struct Param {
  std::string key;
  std::function<bool(const YAML::Node&, PipelineConfig&)> set;
  std::function<std::string(const PipelineConfig&)> get;
  std::string allowed;  // spelled-out values of an enum key, for the error message
  bool list = false;    // the value is a YAML list (a 3-vector), not a scalar
};

template <typename Access>
Param make_param(const char* key, Access access) {
  using T = std::remove_pointer_t<decltype(access(std::declval<PipelineConfig&>()))>;
  Param p;
  p.key = key;
  p.set = [access](const YAML::Node& n, PipelineConfig& c) {
    T v{};
    if constexpr (std::is_same_v<T, bool>) {
      if (!YAML::convert<bool>::decode(n, v)) return false;
    } else if constexpr (std::is_unsigned_v<T>) {
      // yaml-cpp would wrap a negative number into a huge unsigned one; refuse it instead.
      long long s = 0;
      if (!YAML::convert<long long>::decode(n, s) || s < 0) return false;
      v = static_cast<T>(s);
    } else {
      if (!YAML::convert<T>::decode(n, v)) return false;
    }
    *access(c) = v;
    return true;
  };
  p.get = [access](const PipelineConfig& c) {
    std::ostringstream os;
    os << +*access(const_cast<PipelineConfig&>(c));
    return os.str();
  };
  return p;
}

// A 3-vector (x, y, z), written as a YAML list of three numbers: [0.2, 0.2, 0.8].
Param vector3_param(const char* key, Eigen::Vector3f* (*access)(PipelineConfig&)) {
  Param p;
  p.key = key;
  p.list = true;
  p.set = [access](const YAML::Node& n, PipelineConfig& c) {
    if (!n.IsSequence() || n.size() != 3) return false;
    Eigen::Vector3f v;
    for (std::size_t i = 0; i < 3; ++i) {
      if (!n[i].IsScalar() || !YAML::convert<float>::decode(n[i], v[static_cast<int>(i)])) {
        return false;
      }
    }
    *access(c) = v;
    return true;
  };
  p.get = [access](const PipelineConfig& c) {
    const Eigen::Vector3f& v = *access(const_cast<PipelineConfig&>(c));
    std::ostringstream os;
    os << "[" << v.x() << ", " << v.y() << ", " << v.z() << "]";
    return os.str();
  };
  p.allowed = "a list of three numbers, [x, y, z]";
  return p;
}

// An enum key, spelled out in YAML: `names` lists each accepted spelling with its value.
template <typename E>
Param enum_param(const char* key, E* (*access)(PipelineConfig&),
                 std::vector<std::pair<std::string, E>> names) {
  Param p;
  p.key = key;
  for (std::size_t i = 0; i < names.size(); ++i) {
    p.allowed += (i == 0 ? "" : i + 1 == names.size() ? " or " : ", ") + names[i].first;
  }
  p.set = [access, names](const YAML::Node& n, PipelineConfig& c) {
    std::string v;
    if (!YAML::convert<std::string>::decode(n, v)) return false;
    for (const auto& [name, value] : names) {
      if (v == name) {
        *access(c) = value;
        return true;
      }
    }
    return false;
  };
  p.get = [access, names](const PipelineConfig& c) {
    const E value = *access(const_cast<PipelineConfig&>(c));
    for (const auto& [name, v] : names) {
      if (v == value) return name;
    }
    return std::string("invalid");
  };
  return p;
}

#define DYNAMAP_PARAM(path) make_param(#path, [](PipelineConfig& c) { return &c.path; })

const std::vector<Param>& params() {
  static const std::vector<Param> table = {
      DYNAMAP_PARAM(map.resolution),
      DYNAMAP_PARAM(map.prob_hit),
      DYNAMAP_PARAM(map.prob_miss),
      DYNAMAP_PARAM(map.prob_min),
      DYNAMAP_PARAM(map.prob_max),
      DYNAMAP_PARAM(map.prob_occupied),
      DYNAMAP_PARAM(map.min_depth),
      DYNAMAP_PARAM(map.max_depth),
      DYNAMAP_PARAM(map.pixel_margin),
      DYNAMAP_PARAM(map.pixel_stride),
      vector3_param("map.local_half_extent",
                    [](PipelineConfig& c) { return &c.map.local_half_extent; }),
      DYNAMAP_PARAM(map.max_blocks),
      DYNAMAP_PARAM(map.max_rays_per_frame),
      DYNAMAP_PARAM(map.max_voxel_visits_per_frame),
      DYNAMAP_PARAM(map.merge_rays_per_voxel),
      DYNAMAP_PARAM(map.free_ray_early_stop),
      DYNAMAP_PARAM(map.carve_tiles),
      DYNAMAP_PARAM(map.threads),
      DYNAMAP_PARAM(detector.bins),
      DYNAMAP_PARAM(detector.d_min),
      DYNAMAP_PARAM(detector.d_max),
      DYNAMAP_PARAM(detector.smoothing_radius),
      DYNAMAP_PARAM(detector.count_threshold),
      DYNAMAP_PARAM(detector.min_point_height),
      DYNAMAP_PARAM(detector.min_segment_length),
      DYNAMAP_PARAM(detector.min_area),
      DYNAMAP_PARAM(detector.band_factor),
      DYNAMAP_PARAM(detector.max_candidates),
      DYNAMAP_PARAM(detector.max_detections),
      DYNAMAP_PARAM(detector.row_fill_fraction),
      DYNAMAP_PARAM(detector.max_row_gap),
      DYNAMAP_PARAM(detector.min_run_rows),
      DYNAMAP_PARAM(detector.max_width_fraction),
      DYNAMAP_PARAM(detector.max_width),
      DYNAMAP_PARAM(detector.max_height),
      DYNAMAP_PARAM(detector.max_depth_extent),
      DYNAMAP_PARAM(detector.box_from_surface_points),
      DYNAMAP_PARAM(refiner.inflate),
      DYNAMAP_PARAM(refiner.floor_margin),
      DYNAMAP_PARAM(refiner.max_voxels_per_box),
      DYNAMAP_PARAM(refiner.min_support_voxels),
      DYNAMAP_PARAM(refiner.tighten_only),
      DYNAMAP_PARAM(tracker.kalman.p0_position),
      DYNAMAP_PARAM(tracker.kalman.p0_velocity),
      DYNAMAP_PARAM(tracker.kalman.q_position),
      DYNAMAP_PARAM(tracker.kalman.q_velocity),
      DYNAMAP_PARAM(tracker.kalman.r_position),
      DYNAMAP_PARAM(tracker.kalman.r_velocity),
      // "cv" is the original filter (docs/design.md), "imm" adds the coordinated turn.
      enum_param<MotionModel>(
          "tracker.kalman.model", [](PipelineConfig& c) { return &c.tracker.kalman.model; },
          {{"cv", MotionModel::kConstantVelocity}, {"imm", MotionModel::kTurnImm}}),
      DYNAMAP_PARAM(tracker.kalman.imm.q_accel_straight),
      DYNAMAP_PARAM(tracker.kalman.imm.q_accel_turn),
      DYNAMAP_PARAM(tracker.kalman.imm.q_turn_rate),
      DYNAMAP_PARAM(tracker.kalman.imm.p0_turn_rate),
      DYNAMAP_PARAM(tracker.kalman.imm.max_turn_rate),
      DYNAMAP_PARAM(tracker.kalman.imm.mean_straight_time),
      DYNAMAP_PARAM(tracker.kalman.imm.mean_turn_time),
      DYNAMAP_PARAM(tracker.continuity.displacement_frames),
      DYNAMAP_PARAM(tracker.continuity.continuity_threshold),
      DYNAMAP_PARAM(tracker.continuity.min_speed),
      DYNAMAP_PARAM(tracker.continuity.vote_window),
      DYNAMAP_PARAM(tracker.continuity.dynamic_votes),
      DYNAMAP_PARAM(tracker.continuity.static_votes),
      DYNAMAP_PARAM(tracker.continuity.check_size),
      vector3_param("tracker.continuity.min_size",
                    [](PipelineConfig& c) { return &c.tracker.continuity.min_size; }),
      vector3_param("tracker.continuity.max_size",
                    [](PipelineConfig& c) { return &c.tracker.continuity.max_size; }),
      DYNAMAP_PARAM(tracker.overlap_threshold),
      DYNAMAP_PARAM(tracker.centre_gate),
      DYNAMAP_PARAM(tracker.max_missed_frames),
      DYNAMAP_PARAM(tracker.max_coast_time),
      DYNAMAP_PARAM(tracker.history_length),
      DYNAMAP_PARAM(tracker.box_history_length),
      DYNAMAP_PARAM(tracker.size_fix_frames),
      DYNAMAP_PARAM(tracker.image_margin),
      DYNAMAP_PARAM(tracker.size_fix_max_depth),
      DYNAMAP_PARAM(tracker.noise_reference_depth),
      DYNAMAP_PARAM(tracker.correct_near_surface_bias),
      DYNAMAP_PARAM(tracker.max_extent_change_ratio),
      DYNAMAP_PARAM(tracker.max_round_footprint),
      DYNAMAP_PARAM(tracker.early_votes),
      DYNAMAP_PARAM(tracker.early_displacement_frames),
      DYNAMAP_PARAM(tracker.size_fix_growth),
      DYNAMAP_PARAM(tracker.measure_raw_box),
      DYNAMAP_PARAM(tracker.compensate_size_steps),
      DYNAMAP_PARAM(cleaner.frames),
      DYNAMAP_PARAM(cleaner.inflation),
      DYNAMAP_PARAM(cleaner.z_margin),
      DYNAMAP_PARAM(cleaner.max_voxels_per_frame),
      DYNAMAP_PARAM(predictor.paths.num_paths),
      DYNAMAP_PARAM(predictor.paths.turn_curvature),
      DYNAMAP_PARAM(predictor.paths.max_heading_change),
      DYNAMAP_PARAM(predictor.paths.horizon_distance),
      DYNAMAP_PARAM(predictor.paths.sample_interval),
      DYNAMAP_PARAM(predictor.sigma_init),
      DYNAMAP_PARAM(predictor.sigma_trans),
      DYNAMAP_PARAM(predictor.beta),
      DYNAMAP_PARAM(predictor.unknown_weight),
      DYNAMAP_PARAM(predictor.choose_free),
      // The update of docs/design.md §4.6 is "compound"; the others: BeliefUpdate.
      enum_param<BeliefUpdate>(
          "predictor.belief_update", [](PipelineConfig& c) { return &c.predictor.belief_update; },
          {{"compound", BeliefUpdate::kCompound}, {"choice_only", BeliefUpdate::kChoiceOnly}}),
      DYNAMAP_PARAM(predictor.depth_check.enabled),
      DYNAMAP_PARAM(predictor.depth_check.noise_margin),
      DYNAMAP_PARAM(predictor.depth_check.noise_quadratic),
      DYNAMAP_PARAM(predictor.depth_check.surface_thickness),
      DYNAMAP_PARAM(predictor.depth_check.min_depth),
      DYNAMAP_PARAM(predictor.depth_check.max_depth),
      DYNAMAP_PARAM(predictor.clearance.height_levels),
      DYNAMAP_PARAM(predictor.clearance.self_margin),
      DYNAMAP_PARAM(run_linear_baseline),
      DYNAMAP_PARAM(ground_height),
      DYNAMAP_PARAM(clean_history_max_age_ns),
      DYNAMAP_PARAM(budgets.frame_ns),
      DYNAMAP_PARAM(budgets.adaptive_stride),
      DYNAMAP_PARAM(budgets.max_pixel_stride),
  };
  return table;
}

#undef DYNAMAP_PARAM

std::string where(const std::string& path, const YAML::Node& n) {
  std::ostringstream os;
  os << path << ":" << (n.Mark().line + 1);
  return os.str();
}

// Walks nested maps, joining keys with dots, and sets each scalar leaf. `seen` holds every
// dotted key (maps and leaves) met so far with its place: a key given twice is refused (YAML
// leaves duplicates undefined; yaml-cpp would keep either silently).
std::string apply_node(const std::string& path, const YAML::Node& node, const std::string& prefix,
                       PipelineConfig& config, std::map<std::string, std::string>& seen) {
  for (const auto& kv : node) {
    const std::string key = prefix + kv.first.as<std::string>();
    const YAML::Node& value = kv.second;
    const auto [first, inserted] = seen.emplace(key, where(path, kv.first));
    if (!inserted) {
      return where(path, kv.first) + ": duplicate key '" + key + "' (first given at " +
             first->second + ")";
    }
    if (value.IsMap()) {
      std::string e = apply_node(path, value, key + ".", config, seen);
      if (!e.empty()) return e;
      continue;
    }
    const Param* param = nullptr;
    for (const Param& p : params()) {
      if (p.key == key) param = &p;
    }
    if (param == nullptr) {
      return where(path, kv.first) + ": unknown parameter '" + key +
             "' (dynamap-replay --help-params lists them all)";
    }
    if (value.IsScalar() == param->list || !param->set(value, config)) {
      return where(path, value) + ": bad value for '" + key + "': '" +
             (value.IsScalar() ? value.Scalar()
                               : std::string(value.IsSequence() ? "<a list>" : "<not a scalar>")) +
             "'" + (param->allowed.empty() ? std::string() : " (must be " + param->allowed + ")");
    }
  }
  return "";
}

}  // namespace

std::string apply_params_file(const std::string& path, PipelineConfig& config) {
  // A directory opens as a stream on Linux and fails only on reading, with the stream's own
  // message: refuse anything but a regular file first.
  std::error_code ec;
  if (std::filesystem::exists(path, ec) && !std::filesystem::is_regular_file(path, ec)) {
    return path + ": not a parameter file (a directory or a special file)";
  }
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    return path + ": cannot open the parameter file";
  } catch (const YAML::Exception& e) {
    return path + ":" + std::to_string(e.mark.line + 1) + ": not valid YAML: " + e.msg;
  } catch (const std::exception& e) {
    return path + ": cannot read the parameter file: " + e.what();
  }
  if (root.IsNull()) return "";  // an empty file changes nothing
  if (!root.IsMap()) return path + ": the parameter file must be a map of keys to values";
  PipelineConfig candidate = config;  // nothing changes unless the whole file is good
  std::map<std::string, std::string> seen;
  std::string e;
  try {
    e = apply_node(path, root, "", candidate, seen);
  } catch (const YAML::Exception& ex) {  // e.g. a key that is a list, not a scalar
    return path + ":" + std::to_string(ex.mark.line + 1) + ": not a parameter: " + ex.msg;
  }
  if (!e.empty()) return e;
  const ConfigError ce = validate(candidate);
  if (!ce.ok()) return path + ": invalid value for '" + ce.field + "': " + ce.reason;
  config = candidate;
  return "";
}

std::vector<std::string> describe_params(const PipelineConfig& config) {
  std::vector<std::string> out;
  for (const Param& p : params()) out.push_back(p.key + ": " + p.get(config));
  return out;
}

CameraIntrinsics intrinsics_of(const CameraModel& camera) {
  CameraIntrinsics c;
  c.fx = static_cast<float>(camera.fx);
  c.fy = static_cast<float>(camera.fy);
  c.cx = static_cast<float>(camera.cx);
  c.cy = static_cast<float>(camera.cy);
  c.width = camera.width;
  c.height = camera.height;
  c.depth_scale = static_cast<float>(1.0 / camera.depth_factor);
  return c;
}

Pose to_pose(const PoseD& pose) {
  Pose r;
  r.translation = pose.translation.cast<float>();
  r.rotation = pose.rotation.cast<float>().normalized();
  return r;
}

PipelineConfig replay_defaults() {
  PipelineConfig config;
  config.run_linear_baseline = true;  // the evaluation's yardstick (a parameter file may say no)
  return config;
}

PipelineConfig config_for_sequence(const Sequence& seq, const std::string& params_file) {
  PipelineConfig config = replay_defaults();
  config.camera = intrinsics_of(seq.camera);
  if (!params_file.empty()) {
    const std::string err = apply_params_file(params_file, config);
    if (!err.empty()) throw ToolError(err);
  }
  return config;
}

std::unique_ptr<Pipeline> make_pipeline(const PipelineConfig& config) {
  auto pipeline = std::make_unique<Pipeline>();
  ConfigError ce;
  if (!ok(pipeline->init(config, &ce))) {
    throw ToolError(std::string("configuration rejected: ") + ce.field + ": " + ce.reason);
  }
  return pipeline;
}

std::string option_value(int argc, char** argv, int first, const std::string& name) {
  for (int i = first; i + 1 < argc; ++i) {
    if (argv[i] == name) return argv[i + 1];
  }
  return "";
}

}  // namespace dynamap::tools
