// dynamap-eval SEQ RESULT_DIR [--picture] [--reference OBSTACLES_FILE] [--map]
#include <cstdio>
#include <exception>
#include <string>

#include "common/text_io.hpp"
#include "eval/map_accuracy.hpp"
#include "eval/metrics.hpp"

using namespace dynamap::tools;

int main(int argc, char** argv) {
  try {
    std::string seq, result;
    bool picture = false, map = false;
    eval::EvalOptions options;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--picture") {
        picture = true;
      } else if (a == "--map") {
        map = true;
      } else if (a == "--reference") {
        if (i + 1 >= argc) throw ToolError("--reference needs a file (obstacles.txt layout)");
        options.obstacles_file = argv[++i];
      } else if (a == "-h" || a == "--help") {
        std::printf(
            "usage: dynamap-eval SEQ RESULT_DIR [--picture] [--reference FILE] [--map]\n"
            "  Compares RESULT_DIR/tracks.csv and predictions.csv (and, when present,\n"
            "  predictions_linear.csv) with the ground truth of the simulated sequence\n"
            "  SEQ; prints a table and writes RESULT_DIR/metrics.json. --picture also\n"
            "  writes RESULT_DIR/eval_topview.png. --reference FILE scores against FILE\n"
            "  (obstacles.txt layout, e.g. dynamap-label's reference for a real sequence)\n"
            "  instead of SEQ/obstacles.txt. --map also scores the replay's final map\n"
            "  (RESULT_DIR/map.ply) against SEQ/static_world.txt: SA, DA, AA and the\n"
            "  per-frame erased / free-through counts of map_frames.csv; with --picture it\n"
            "  writes RESULT_DIR/map_topview.png. See docs/tools.md.\n");
        return 0;
      } else if (!a.empty() && a[0] == '-') {
        throw ToolError("unknown option '" + a + "'");
      } else if (seq.empty()) {
        seq = a;
      } else if (result.empty()) {
        result = a;
      } else {
        throw ToolError("unexpected argument '" + a + "'");
      }
    }
    if (seq.empty() || result.empty()) {
      std::fprintf(stderr,
                   "usage: dynamap-eval SEQ RESULT_DIR [--picture] [--reference FILE] [--map]\n");
      return 2;
    }
    const eval::EvalResult r = eval::evaluate(seq, result, options);
    std::printf("dynamap-eval: %s vs %s%s%s\n%s", seq.c_str(), result.c_str(),
                options.obstacles_file.empty() ? "" : ", reference ",
                options.obstacles_file.c_str(), eval::format_table(r).c_str());
    eval::MapAccuracy m;
    if (map && !file_exists(join_path(seq, "static_world.txt"))) {
      std::printf(
          "  map accuracy: skipped: %s is absent (--map needs the true static world, "
          "which only simulated sequences have)\n",
          join_path(seq, "static_world.txt").c_str());
    } else if (map) {
      m = eval::evaluate_map(seq, result, options.obstacles_file);
      std::printf("%s", eval::format_map_table(m).c_str());
    }
    const std::string json = join_path(result, "metrics.json");
    eval::write_metrics_json(json, r, seq, result, options.obstacles_file, &m);
    std::printf("wrote %s\n", json.c_str());
    if (picture && m.available) {
      const std::string png = join_path(result, "map_topview.png");
      eval::write_map_picture(png, seq, result, m);
      std::printf("wrote %s\n", png.c_str());
    }
    if (picture) {
      const std::string png = join_path(result, "eval_topview.png");
      eval::write_eval_picture(png, seq, result, options.obstacles_file);
      std::printf("wrote %s\n", png.c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynamap-eval: error: %s\n", e.what());
    return 1;
  }
}
