// dynamap-tables ROOT SCENE...: the paper's three tables from simulated runs. For each scene it
// expects the sequence in ROOT/SCENE and the replay's results in ROOT/SCENE_out, evaluates them
// (the same evaluation as dynamap-eval) and prints, as markdown:
//   Table I   position and velocity error per scene (+ recall, precision, MOTA, ID switches)
//   Table II  runtime per module (median and p99 over all frames of all scenes, from timing.csv)
//   Failure   Markov vs linear prediction failure ratio per environment
//   Map       SA, DA, AA of the final map and the per-frame map checks' maxima, per scene, from
//             ROOT/SCENE_out/metrics.json when `dynamap-eval --map` wrote them there
// The same text is written to ROOT/tables.md.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "common/text_io.hpp"
#include "eval/metrics.hpp"

using namespace dynamap::tools;

namespace {

std::string fmt(double v, int decimals) {
  if (std::isnan(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const std::size_t r = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, r == 0 ? 0 : r - 1)];
}

// timing.csv: header "stamp,<stage>...,total", values in microseconds.
void read_timing(const std::string& path, std::vector<std::string>& names,
                 std::vector<std::vector<double>>& columns) {
  const std::vector<std::string> lines = read_lines(path);
  if (lines.empty()) throw ToolError(path + ": empty");
  const std::vector<std::string> header = split_csv(lines[0]);
  if (names.empty()) {
    names.assign(header.begin() + 1, header.end());
    columns.assign(names.size(), {});
  } else if (std::vector<std::string>(header.begin() + 1, header.end()) != names) {
    throw ToolError(path + ":1: timing columns differ from the other scenes'");
  }
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> f = split_csv(lines[i]);
    if (f.size() != header.size())
      throw ToolError(path + ":" + std::to_string(i + 1) + ": wrong column count");
    for (std::size_t k = 0; k < names.size(); ++k) {
      columns[k].push_back(parse_double(f[k + 1], TextLocation{path, i + 1}, names[k].c_str()));
    }
  }
}

// A number of metrics.json by key (`"key": value` at any depth; the first one): NaN when the
// key is absent or null. dynamap-eval writes each key once per line.
double json_value(const std::string& text, const std::string& key) {
  const std::string needle = "\"" + key + "\": ";
  const std::size_t at = text.find(needle);
  if (at == std::string::npos) return std::numeric_limits<double>::quiet_NaN();
  const char* start = text.c_str() + at + needle.size();
  char* end = nullptr;
  const double v = std::strtod(start, &end);
  return end == start ? std::numeric_limits<double>::quiet_NaN() : v;
}

// One row of the map accuracy table, or "" when metrics.json has no map accuracy.
std::string map_row(const std::string& scene, const std::string& metrics_path) {
  if (!file_exists(metrics_path)) return "";
  std::ifstream in(metrics_path);
  std::stringstream buf;
  buf << in.rdbuf();
  const std::string text = buf.str();
  if (text.find("\"sa\": ") == std::string::npos) return "";
  auto count = [&](const char* key) {
    const double v = json_value(text, key);
    return std::isnan(v) ? std::string("n/a") : fmt(v, 0);
  };
  return "| " + scene + " | " + fmt(json_value(text, "sa"), 4) + " | " +
         fmt(json_value(text, "sa_strict"), 4) + " | " + fmt(json_value(text, "da"), 4) + " | " +
         fmt(json_value(text, "aa"), 4) + " | " + count("erased_max") + " (" +
         count("erased_bare_max") + ") | " + count("free_through_max") + " (" +
         count("free_through_whole_max") + ") |\n";
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: dynamap-tables ROOT SCENE...  (expects ROOT/SCENE and ROOT/SCENE_out)\n");
    return 2;
  }
  try {
    const std::string root = argv[1];
    std::ostringstream t1, t3, t4;
    bool any_map = false;
    std::vector<std::string> stage_names;
    std::vector<std::vector<double>> stage_us;
    t1 << "### Table I: tracking accuracy per scene (dynamic obstacles, docs/data_format.md "
          "metrics)\n\n"
       << "| scene | GT obstacle-frames | position error (m) | velocity error (m/s) | recall | "
          "precision | MOTA | ID switches | dynamic rows "
          "|\n|---|---|---|---|---|---|---|---|---|\n";
    t3 << "### Prediction failure ratio (chosen path collides with the true static world, or no "
          "path is free)\n\n| scene | predictions | Markov | linear baseline | Markov / linear |\n"
          "|---|---|---|---|---|\n";
    t4 << "### Map accuracy (final map vs the true static world and the walkers, "
          "docs/evaluation.md \"Map accuracy\")\n\n"
       << "| scene | SA | SA strict | DA | AA | erased obstacle voxels, max (<= 3 m; bare) | free "
          "through obstacle voxels, max (<= 3 m; whole) |\n|---|---|---|---|---|---|---|\n";
    for (int i = 2; i < argc; ++i) {
      const std::string scene = argv[i];
      const std::string seq = join_path(root, scene);
      const std::string out = join_path(root, scene + "_out");
      const eval::EvalResult r = eval::evaluate(seq, out);
      t1 << "| " << scene << " | " << r.gt_count << " | " << fmt(r.position_error, 3) << " | "
         << fmt(r.velocity_error, 3) << " | " << fmt(r.recall, 3) << " | " << fmt(r.precision, 3)
         << " | " << fmt(r.mota, 3) << " | " << r.id_switches << " | " << r.dynamic_track_rows
         << " |\n";
      if (r.markov.available) {
        const double ratio = r.linear.available && r.linear.failure_ratio > 0
                                 ? r.markov.failure_ratio / r.linear.failure_ratio
                                 : std::nan("");
        t3 << "| " << scene << " | " << r.markov.predictions << " | "
           << fmt(r.markov.failure_ratio, 3) << " | "
           << (r.linear.available ? fmt(r.linear.failure_ratio, 3) : "n/a") << " | "
           << fmt(ratio, 2) << " |\n";
      }
      read_timing(join_path(out, "timing.csv"), stage_names, stage_us);
      const std::string row = map_row(scene, join_path(out, "metrics.json"));
      any_map = any_map || !row.empty();
      t4 << row;
    }
    std::ostringstream t2;
    t2 << "### Table II: runtime per module (this machine, one core, as timed by the replay; all "
          "frames of all scenes)\n\n"
       << "| module | median (ms) | p99 (ms) | share of summed medians |\n|---|---|---|---|\n";
    double sum = 0;
    for (std::size_t k = 0; k + 1 < stage_names.size(); ++k) sum += percentile(stage_us[k], 0.5);
    for (std::size_t k = 0; k < stage_names.size(); ++k) {
      const bool total = k + 1 == stage_names.size();
      const double med = percentile(stage_us[k], 0.5);
      t2 << "| " << (total ? "**total**" : stage_names[k]) << " | " << fmt(med * 1e-3, 3) << " | "
         << fmt(percentile(stage_us[k], 0.99) * 1e-3, 3) << " | "
         << (total ? std::string("") : fmt(100.0 * med / sum, 0) + " %") << " |\n";
    }
    const std::string text =
        t1.str() + "\n" + t2.str() + "\n" + t3.str() + (any_map ? "\n" + t4.str() : "");
    std::printf("%s", text.c_str());
    std::ofstream f(join_path(root, "tables.md"));
    f << text;
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynamap-tables: error: %s\n", e.what());
    return 1;
  }
}
