// dynamap-sim random --seed N [--out DIR] [--frames F] [--no-picture] [--describe]: renders a
// generated scene (sim/random_scene.hpp) with the realistic sensor and writes README.md with
// every draw (--describe: prints the draws, renders nothing).
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "common/text_io.hpp"
#include "sim/random_scene.hpp"
#include "sim/writer.hpp"

namespace dynamap::tools::sim {
namespace {

long long number(const std::string& flag, const char* value, long long lo, long long hi) {
  char* end = nullptr;
  const long long v = std::strtoll(value, &end, 10);
  if (*value == '\0' || *end != '\0' || v < lo || v > hi) {
    throw ToolError(flag + ": expected an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "], got '" + value + "'");
  }
  return v;
}

}  // namespace

int random_main(int argc, char** argv) {
  std::string out;
  SimulateOptions opt;
  opt.frames = 450;
  bool seed_given = false, describe = false;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&]() -> const char* {
      if (i + 1 >= argc) throw ToolError(a + ": missing value");
      return argv[++i];
    };
    if (a == "--seed") {
      opt.seed = static_cast<std::uint64_t>(number(a, value(), 0, 1LL << 62));
      seed_given = true;
    } else if (a == "--out") {
      out = value();
    } else if (a == "--frames") {
      opt.frames = static_cast<int>(number(a, value(), 1, 100000));
    } else if (a == "--no-picture") {
      opt.picture = false;
    } else if (a == "--describe") {
      describe = true;
    } else {
      throw ToolError("random: unknown argument '" + a +
                      "' (usage: dynamap-sim random --seed N [--out DIR] [--frames F] "
                      "[--no-picture] [--describe])");
    }
  }
  if (!seed_given) throw ToolError("random: --seed N is required");
  if (out.empty()) out = "random_" + std::to_string(opt.seed);
  const RandomScene r = make_random_scene(opt.seed, opt.frames);
  if (describe) {  // the draws only, nothing rendered
    std::printf("%s", random_scene_readme(r, opt.seed, opt.frames).c_str());
    return 0;
  }
  std::printf("dynamap-sim: random seed %llu: %s, %d frames -> %s\n",
              static_cast<unsigned long long>(opt.seed), r.scene.description.c_str(), opt.frames,
              out.c_str());
  const SimulateSummary s = simulate(r.scene, out, opt);
  std::ofstream readme(join_path(out, "README.md"));
  readme << random_scene_readme(r, opt.seed, opt.frames);
  if (!readme.flush()) throw ToolError(join_path(out, "README.md") + ": write error");
  std::printf("wrote %d frames, %zu obstacle lines (%zu visible) in %.1f s (%.1f ms/frame)\n",
              s.frames, s.obstacle_lines, s.visible_obstacle_lines, s.seconds,
              1000.0 * s.seconds / std::max(1, s.frames));
  if (s.walker_overlap_frames > 0) {
    std::printf(
        "note: walkers brush each other in %d frames (allowed: centres >= %.1f x the "
        "summed radii)\n",
        s.walker_overlap_frames, RandomSceneLimits::walker_overlap);
  }
  return 0;
}

}  // namespace dynamap::tools::sim
