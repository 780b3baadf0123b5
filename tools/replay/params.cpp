#include "params.hpp"

#include <cstdint>
#include <exception>
#include <filesystem>
#include <limits>
#include <map>
#include <sstream>
#include <system_error>
#include <utility>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "common/text_io.hpp"
#include "dynamap/pipeline/parameters.hpp"

namespace dynamap::tools {
namespace {

// Reads one YAML value of parameter `p` into `config`. False when the value cannot be one of
// the field's type (a word for a number, a negative count, 2 numbers for a 3-vector); whether
// it is in range is validate()'s question, so the message can name the range.
bool set_value(const Parameter& p, const YAML::Node& n, PipelineConfig& config) {
  constexpr double kExactInteger = 9007199254740992.0;  // 2^53: larger counts lose digits
  if (p.kind == ParamKind::kVector3) {
    if (!n.IsSequence() || n.size() != 3) return false;
    double v[3];
    for (std::size_t i = 0; i < 3; ++i) {
      if (!n[i].IsScalar() || !YAML::convert<double>::decode(n[i], v[i])) return false;
    }
    for (int i = 0; i < 3; ++i) p.set(config, i, v[i]);
    return true;
  }
  if (!n.IsScalar()) return false;
  double v = 0.0;
  switch (p.kind) {
    case ParamKind::kBool: {
      bool b = false;
      if (!YAML::convert<bool>::decode(n, b)) return false;
      v = b ? 1.0 : 0.0;
      break;
    }
    case ParamKind::kEnum: {
      const ParamChoice* choice = nullptr;
      for (std::size_t i = 0; i < p.choice_count; ++i) {
        if (n.Scalar() == p.choices[i].name) choice = &p.choices[i];
      }
      if (choice == nullptr) return false;
      v = choice->value;
      break;
    }
    case ParamKind::kInt: {
      long long i = 0;
      if (!YAML::convert<long long>::decode(n, i) || i < std::numeric_limits<int>::min() ||
          i > std::numeric_limits<int>::max()) {
        return false;
      }
      v = static_cast<double>(i);
      break;
    }
    case ParamKind::kCount: {
      // yaml-cpp would wrap a negative number into a huge unsigned one; refuse it instead.
      long long i = 0;
      if (!YAML::convert<long long>::decode(n, i) || i < 0 ||
          static_cast<double>(i) > kExactInteger) {
        return false;
      }
      v = static_cast<double>(i);
      break;
    }
    case ParamKind::kFloat:
    case ParamKind::kVector3:
      if (!YAML::convert<double>::decode(n, v)) return false;
      break;
  }
  p.set(config, 0, v);
  return true;
}

// The accepted spelling of a value of `p`, for "bad value" messages.
std::string value_shape(const Parameter& p) {
  char range[128];
  switch (p.kind) {
    case ParamKind::kVector3:
      return "a list of three numbers, [x, y, z]";
    case ParamKind::kBool:
    case ParamKind::kEnum:
      return p.range_text(range, sizeof range);
    case ParamKind::kInt:
    case ParamKind::kCount:
      return std::string("an integer, ") + p.range_text(range, sizeof range);
    case ParamKind::kFloat:
      return std::string("a number, ") + p.range_text(range, sizeof range);
  }
  return "";
}

// The current value of `p` in `config`, as the YAML file would spell it.
std::string value_text(const Parameter& p, const PipelineConfig& config) {
  std::ostringstream os;
  const auto number = [&](int i) {
    const double v = p.get(config, i);
    if (p.kind == ParamKind::kInt || p.kind == ParamKind::kCount) {
      os << static_cast<unsigned long long>(v);
    } else {
      os << static_cast<float>(v);
    }
  };
  switch (p.kind) {
    case ParamKind::kBool:
      os << (p.get(config, 0) != 0.0 ? "true" : "false");
      break;
    case ParamKind::kEnum: {
      const int v = static_cast<int>(p.get(config, 0));
      const char* name = "invalid";
      for (std::size_t i = 0; i < p.choice_count; ++i) {
        if (p.choices[i].value == v) name = p.choices[i].name;
      }
      os << name;
      break;
    }
    case ParamKind::kVector3:
      os << "[";
      for (int i = 0; i < 3; ++i) {
        if (i > 0) os << ", ";
        number(i);
      }
      os << "]";
      break;
    case ParamKind::kInt:
      os << static_cast<long long>(p.get(config, 0));
      break;
    default:
      number(0);
  }
  return os.str();
}

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
    const Parameter* param = find_parameter(key.c_str());
    if (param == nullptr) {
      return where(path, kv.first) + ": unknown parameter '" + key +
             "' (dynamap-replay --help-params lists them all)";
    }
    if (!set_value(*param, value, config)) {
      return where(path, value) + ": bad value for '" + key + "': '" +
             (value.IsScalar() ? value.Scalar()
                               : std::string(value.IsSequence() ? "<a list>" : "<not a scalar>")) +
             "' (must be " + value_shape(*param) + ")";
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
  if (!ce.ok()) {
    char line[512];
    return path + ": invalid configuration: " + describe(ce, line, sizeof line);
  }
  config = candidate;
  return "";
}

std::vector<std::string> describe_params(const PipelineConfig& config, bool all_tiers) {
  std::vector<std::string> out;
  const PipelineConfig defaults = replay_defaults();
  for (const Parameter& p : parameters()) {
    if (!all_tiers && p.tier != ParamTier::kUser) continue;
    char range[128];
    std::string line = std::string(p.path) + ": " + value_text(p, config);
    const std::string d = value_text(p, defaults);
    if (d != value_text(p, config)) line += " (default " + d + ")";
    line += "  [" + std::string(to_string(p.tier)) + "; " + p.range_text(range, sizeof range) +
            "]  " + p.help;
    out.push_back(line);
  }
  return out;
}

std::string parameters_markdown() {
  std::ostringstream os;
  os << "# Parameters\n"
     << "\n"
     << "Every field of `PipelineConfig`: its YAML key, default, valid range and meaning,\n"
     << "generated from the library's parameter table by `dynamap-replay --params-markdown`;\n"
     << "`test_replay` fails when this page and the table differ. Regenerate it after changing\n"
     << "a parameter:\n"
     << "\n"
     << "    build/tools/dynamap-replay --params-markdown > docs/parameters.md\n"
     << "\n"
     << "(with a CMake preset the binary is under build/<preset>/tools/). Each parameter is\n"
     << "declared once, next to its stage: the default is the member initialiser of the stage's\n"
     << "config struct, its row (path, unit, range, tier, help) is in the stage's table\n"
     << "(`include/dynamap/map/map_params.hpp`, `detect/detect_params.hpp`,\n"
     << "`track/track_params.hpp`, `predict/predict_params.hpp`; the pipeline's own fields in\n"
     << "`src/pipeline/parameters.cpp`). docs/pipeline.md, \"Adding a parameter\", says how\n"
     << "to add one. Defaults are the library's; where the replay tools start from another\n"
     << "value, the row says so (\"replay tools: ...\").\n";
  const PipelineConfig library;
  const PipelineConfig replay = replay_defaults();
  for (ParamTier tier : {ParamTier::kUser, ParamTier::kCapacity, ParamTier::kExpert}) {
    os << "\n## "
       << (tier == ParamTier::kUser       ? "User"
           : tier == ParamTier::kCapacity ? "Capacity"
                                          : "Expert")
       << " parameters\n\n| parameter | default | valid | meaning |\n|---|---|---|---|\n";
    for (const Parameter& p : parameters()) {
      if (p.tier != tier) continue;
      char range[128];
      std::string shown = value_text(p, library);
      if (const std::string r = value_text(p, replay); r != shown) {
        shown += " (replay tools: " + r + ")";
      }
      os << "| `" << p.path << "` | " << shown << " | " << p.range_text(range, sizeof range)
         << " | " << p.help << " |\n";
    }
  }
  return os.str();
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
