// dynamap-suite-table ROOT [--min KEY=V]... [--max KEY=V]...: one table over the generated
// scenario suite (scripts/suite.sh). For every ROOT/seed_N with ROOT/seed_N_out/metrics.json
// (dynamap-eval --map) and timing.csv (dynamap-replay), it prints the distribution over seeds:
// median and 10th percentile of recall, precision, SA and DA; median and 90th percentile of the
// position and velocity error and of the prediction failure ratio (Markov, linear, Markov /
// linear); whole-frame time p99; then the five worst seeds per metric with their pictures.
// --min / --max: exit 1 when a seed's metric is below / above V (the smoke test's floors).
// The text is also written to ROOT/suite.md.
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

using namespace dynamap::tools;

namespace {

struct Metric {
  const char* key;    // name in the table and for --min / --max
  const char* label;  // what it is
  bool higher_better;
};

// Keys of metrics.json, then the derived ones (ratio, time).
const Metric kMetrics[] = {
    {"recall", "recall", true},
    {"precision", "precision", true},
    {"sa", "SA (static accuracy of the map)", true},
    {"da", "DA (dynamic accuracy of the map)", true},
    // Erased static surface with no occupied voxel beside it: where the surface is gone.
    {"erased_bare_max", "erased obstacle voxels, bare, within 3 m (worst frame)", false},
    // Inside of a static shape held free (issue 28's goal: 0 within 3 m in every frame).
    {"free_through_max", "free through obstacle voxels within 3 m (worst frame)", false},
    // Of those, voxels wholly inside a shape: a hole a voxel deep, not a partly filled boundary
    // voxel.
    {"free_through_whole_max", "free through obstacle voxels, whole, within 3 m (worst frame)",
     false},
    {"position_error_m", "position error (m)", false},
    {"velocity_error_mps", "velocity error (m/s)", false},
    {"prediction_failure_ratio", "prediction failure ratio, Markov", false},
    {"linear_failure_ratio", "prediction failure ratio, linear", false},
    {"failure_vs_linear", "failure ratio Markov / linear", false},
    {"frame_p99_ms", "whole-frame time p99 (ms, CPU)", false},
    // The velocity sigma's calibration (a Gaussian: 0.683 and 0.954). Within 1 sigma the worse
    // side is the wide one today (the sigma is too wide on most seeds).
    {"velocity_within_1sigma", "velocity errors within 1 sigma (Gaussian 0.683)", false},
    {"velocity_within_2sigma", "velocity errors within 2 sigma (Gaussian 0.954)", true},
    // A static object labelled dynamic: the longest any one track was dynamic away from every
    // listed obstacle (issue 29's goal: more than 3 frames on at most 2 % of the seeds).
    {"false_dynamic_frames_max", "false dynamic frames, worst track", false},
};
constexpr std::size_t kCount = sizeof(kMetrics) / sizeof(kMetrics[0]);
const double kNaN = std::numeric_limits<double>::quiet_NaN();

// Where a metric sits in kMetrics (the derived ones are filled in by key, not by position).
std::size_t metric_index(const std::string& key) {
  for (std::size_t k = 0; k < kCount; ++k)
    if (key == kMetrics[k].key) return k;
  throw ToolError("no metric '" + key + "'");
}

struct Seed {
  std::string name;  // seed_N
  std::string what;  // the README's one-line description
  double v[kCount];
};

std::string fmt(double v, int decimals = 3) {
  if (std::isnan(v)) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string read_text(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw ToolError(path + ": cannot read");
  std::stringstream buf;
  buf << in.rdbuf();
  return buf.str();
}

// `"key": number` anywhere in metrics.json (first one); NaN when absent or null.
double json_value(const std::string& text, const std::string& key) {
  const std::string needle = "\"" + key + "\": ";
  const std::size_t at = text.find(needle);
  if (at == std::string::npos) return kNaN;
  const char* start = text.c_str() + at + needle.size();
  char* end = nullptr;
  const double v = std::strtod(start, &end);
  return end == start ? kNaN : v;
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const auto r = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, r == 0 ? 0 : r - 1)];
}

// p99 of timing.csv's last column (total, microseconds) in ms.
double frame_p99_ms(const std::string& path) {
  const std::vector<std::string> lines = read_lines(path);
  std::vector<double> total;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> f = split_csv(lines[i]);
    if (f.empty()) continue;
    total.push_back(1e-3 * parse_double(f.back(), TextLocation{path, i + 1}, "total"));
  }
  return percentile(total, 0.99);
}

Seed read_seed(const std::string& root, const std::string& name) {
  Seed s;
  s.name = name;
  const std::string out = join_path(root, name + "_out");
  const std::string text = read_text(join_path(out, "metrics.json"));
  for (std::size_t k = 0; k < kCount; ++k) s.v[k] = json_value(text, kMetrics[k].key);
  const double markov = s.v[metric_index("prediction_failure_ratio")];
  const double linear = s.v[metric_index("linear_failure_ratio")];
  s.v[metric_index("failure_vs_linear")] = linear > 0.0 ? markov / linear : kNaN;
  s.v[metric_index("frame_p99_ms")] = frame_p99_ms(join_path(out, "timing.csv"));
  const std::string readme = join_path(join_path(root, name), "README.md");
  if (file_exists(readme)) {
    const std::vector<std::string> lines = read_lines(readme);
    if (lines.size() > 4) s.what = lines[4];
  }
  return s;
}

// Seeds in ROOT: seed_N folders with a result folder, by N.
std::vector<Seed> read_suite(const std::string& root) {
  std::vector<std::pair<long long, std::string>> names;
  const std::string list = read_text(join_path(root, "seeds.txt"));
  std::istringstream in(list);
  long long n = 0;
  while (in >> n) names.emplace_back(n, "seed_" + std::to_string(n));
  std::sort(names.begin(), names.end());
  std::vector<Seed> seeds;
  for (const auto& [number, name] : names) {
    if (file_exists(join_path(join_path(root, name + "_out"), "metrics.json"))) {
      seeds.push_back(read_seed(root, name));
    } else {
      std::fprintf(stderr, "dynamap-suite-table: %s has no results (failed run?)\n", name.c_str());
    }
  }
  return seeds;
}

std::string distribution_table(const std::vector<Seed>& seeds) {
  std::ostringstream t;
  t << "| metric | seeds | median | 10th / 90th percentile (worse side) | worst |\n"
    << "|---|---|---|---|---|\n";
  for (std::size_t k = 0; k < kCount; ++k) {
    std::vector<double> v;
    for (const auto& s : seeds) {
      if (!std::isnan(s.v[k])) v.push_back(s.v[k]);
    }
    const bool hi = kMetrics[k].higher_better;
    const double worst = v.empty() ? kNaN
                         : hi      ? *std::min_element(v.begin(), v.end())
                                   : *std::max_element(v.begin(), v.end());
    t << "| " << kMetrics[k].label << " | " << v.size() << " | " << fmt(percentile(v, 0.5)) << " | "
      << (hi ? "p10 " : "p90 ") << fmt(percentile(v, hi ? 0.1 : 0.9)) << " | " << fmt(worst)
      << " |\n";
  }
  return t.str();
}

// Issue 29's goal: a static object dynamic for more than this many frames on at most 2 % of seeds.
constexpr double kFalseDynamicFrames = 3.0;

std::string false_dynamic_seeds(const std::vector<Seed>& seeds) {
  std::size_t k = 0;
  while (k < kCount && std::string(kMetrics[k].key) != "false_dynamic_frames_max") ++k;
  std::ostringstream t;
  std::size_t over = 0, with_value = 0;
  std::string names;
  for (const auto& s : seeds) {
    if (k == kCount || std::isnan(s.v[k])) continue;
    ++with_value;
    if (s.v[k] <= kFalseDynamicFrames) continue;
    names += (over++ ? ", " : " (") + s.name;
  }
  t << "Seeds with a track dynamic away from every listed obstacle for more than "
    << fmt(kFalseDynamicFrames, 0) << " frames: " << over << " of " << with_value
    << (over ? names + ")" : std::string()) << "\n\n";
  return t.str();
}

std::string worst_seeds(const std::vector<Seed>& seeds, const std::string& root) {
  std::ostringstream t;
  t << "Five worst seeds per metric (pictures: ROOT/seed_N_out/topview.png, "
       "ROOT/seed_N_out/eval_topview.png, ROOT/seed_N_out/overlay/contact_sheet.png; the scene: "
       "ROOT/seed_N/README.md), ROOT = "
    << root << "\n\n";
  for (std::size_t k = 0; k < kCount; ++k) {
    std::vector<const Seed*> v;
    for (const auto& s : seeds) {
      if (!std::isnan(s.v[k])) v.push_back(&s);
    }
    const bool hi = kMetrics[k].higher_better;
    std::stable_sort(v.begin(), v.end(), [&](const Seed* a, const Seed* b) {
      return hi ? a->v[k] < b->v[k] : a->v[k] > b->v[k];
    });
    t << "- " << kMetrics[k].label << ":";
    for (std::size_t i = 0; i < std::min<std::size_t>(5, v.size()); ++i) {
      t << (i ? ", " : " ") << v[i]->name << " " << fmt(v[i]->v[k]);
    }
    t << "\n";
  }
  t << "\nSeeds:\n\n";
  for (const auto& s : seeds) t << "- " << s.name << ": " << s.what << "\n";
  return t.str();
}

// --min KEY=V / --max KEY=V: every seed's KEY within the bound (NaN values are skipped).
int check_bounds(const std::vector<Seed>& seeds, const std::vector<std::string>& args) {
  int failures = 0;
  for (std::size_t i = 0; i + 1 < args.size(); i += 2) {
    const bool is_min = args[i] == "--min";
    const std::size_t eq = args[i + 1].find('=');
    if (eq == std::string::npos) throw ToolError(args[i] + ": expected KEY=VALUE");
    const std::string key = args[i + 1].substr(0, eq);
    const double bound = parse_double(args[i + 1].substr(eq + 1), {"command line", 0}, "bound");
    std::size_t k = 0;
    while (k < kCount && key != kMetrics[k].key) ++k;
    if (k == kCount) throw ToolError("unknown metric '" + key + "'");
    for (const auto& s : seeds) {
      const double v = s.v[k];
      if (std::isnan(v) || (is_min ? v >= bound : v <= bound)) continue;
      std::printf("FAIL: %s %s = %s is %s the bound %s\n", s.name.c_str(), key.c_str(),
                  fmt(v).c_str(), is_min ? "below" : "above", fmt(bound).c_str());
      ++failures;
    }
  }
  return failures;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argv[1][0] == '-') {
    std::fprintf(stderr,
                 "usage: dynamap-suite-table ROOT [--min KEY=V]... [--max KEY=V]...\n"
                 "  (ROOT/seeds.txt lists the seeds; ROOT/seed_N and ROOT/seed_N_out)\n");
    return 2;
  }
  try {
    const std::string root = argv[1];
    std::vector<std::string> bounds;
    for (int i = 2; i < argc; ++i) {
      const std::string a = argv[i];
      if ((a != "--min" && a != "--max") || i + 1 >= argc) {
        throw ToolError("unexpected argument '" + a + "'");
      }
      bounds.push_back(a);
      bounds.emplace_back(argv[++i]);
    }
    const std::vector<Seed> seeds = read_suite(root);
    if (seeds.empty()) throw ToolError(root + ": no evaluated seeds");
    const std::string text = "### Generated scenario suite: " + std::to_string(seeds.size()) +
                             " seeds\n\n" + distribution_table(seeds) + "\n" +
                             false_dynamic_seeds(seeds) + worst_seeds(seeds, root);
    std::printf("%s", text.c_str());
    std::ofstream(join_path(root, "suite.md")) << text;
    const int failures = check_bounds(seeds, bounds);
    if (failures > 0) std::printf("%d bound(s) failed\n", failures);
    return failures > 0 ? 1 : 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynamap-suite-table: error: %s\n", e.what());
    return 1;
  }
}
