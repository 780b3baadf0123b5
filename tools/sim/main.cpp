// dynamap-sim SCENE --out SEQ_DIR [--frames N] [--seed S] [--no-noise] [--no-picture]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <string>

#include "common/text_io.hpp"
#include "sim/random_scene.hpp"
#include "sim/writer.hpp"

using namespace dynamap::tools;

namespace {

void usage(std::FILE* f) {
  std::fprintf(f,
               "usage: dynamap-sim SCENE --out SEQ_DIR [--frames N] [--seed S] [--no-noise] "
               "[--no-picture]\n"
               "  Renders a simulated depth sequence in the TUM RGB-D layout (see "
               "docs/tools.md).\n  SCENE is one of:");
  for (const auto& n : sim::scene_names()) std::fprintf(f, " %s", n.c_str());
  std::fprintf(f,
               "\n       dynamap-sim random --seed N [--out DIR] [--frames F] (a generated "
               "scene)\n  --frames N   number of 30 Hz frames (default: 300)\n"
               "  --seed S     noise and scene jitter seed (default: 1)\n"
               "  --no-noise   ideal sensor: exact depth, no noise, losses or range limits\n"
               "               (alias --ideal-sensor)\n");
}

long long parse_arg(const char* flag, const char* value, long long lo, long long hi) {
  char* end = nullptr;
  const long long v = std::strtoll(value, &end, 10);
  if (*value == '\0' || *end != '\0' || v < lo || v > hi) {
    throw ToolError(std::string(flag) + ": expected an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "], got '" + value + "'");
  }
  return v;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    if (argc > 1 && std::strcmp(argv[1], "random") == 0) return sim::random_main(argc, argv);
    std::string scene_name, out;
    sim::SimulateOptions opt;
    bool frames_given = false;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> const char* {
        if (i + 1 >= argc) throw ToolError(a + ": missing value");
        return argv[++i];
      };
      if (a == "--out") {
        out = value();
      } else if (a == "--frames") {
        opt.frames = static_cast<int>(parse_arg("--frames", value(), 1, 100000));
        frames_given = true;
      } else if (a == "--seed") {
        opt.seed = static_cast<std::uint64_t>(parse_arg("--seed", value(), 0, 1LL << 62));
      } else if (a == "--no-noise" || a == "--ideal-sensor") {
        opt.noise = false;
      } else if (a == "--no-picture") {
        opt.picture = false;
      } else if (a == "-h" || a == "--help") {
        usage(stdout);
        return 0;
      } else if (!a.empty() && a[0] == '-') {
        throw ToolError("unknown option '" + a + "'");
      } else if (scene_name.empty()) {
        scene_name = a;
      } else {
        throw ToolError("unexpected argument '" + a + "'");
      }
    }
    if (scene_name.empty() || out.empty()) {
      usage(stderr);
      return 2;
    }
    const sim::Scene scene = sim::make_scene(scene_name, opt.seed);
    if (!frames_given) opt.frames = scene.default_frames;
    std::printf("dynamap-sim: scene %s, %d frames, seed %llu -> %s\n", scene.name.c_str(),
                opt.frames, static_cast<unsigned long long>(opt.seed), out.c_str());
    const int step = std::max(1, opt.frames / 10);
    opt.on_frame = [step](int done, int total) {
      if (done % step == 0 || done == total) {
        std::fprintf(stderr, "  frame %d/%d (%d%%)\n", done, total, 100 * done / total);
      }
    };
    const auto s = sim::simulate(scene, out, opt);
    std::printf(
        "wrote %d frames, %zu obstacle lines (%zu with visible >= 0.5) in %.1f s "
        "(%.1f ms/frame)\n",
        s.frames, s.obstacle_lines, s.visible_obstacle_lines, s.seconds,
        1000.0 * s.seconds / s.frames);
    std::printf(
        "depth 0 (no measurement): median %.1f %% of the pixels per frame (rays hitting "
        "nothing: %.1f %%)\n",
        100.0 * s.zero_share, 100.0 * s.nothing_hit_share);
    if (s.walker_overlap_frames > 0) {
      std::printf("note: walkers overlap each other in %d frames (they do not avoid each other)\n",
                  s.walker_overlap_frames);
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynamap-sim: error: %s\n", e.what());
    return 1;
  }
}
