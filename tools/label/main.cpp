// dynamap-label SEQ --out DIR [--first-frame N] [--max-frames N] [--quiet] [--static-model]
// [--overlays DIR [--overlay-every N]] Offline reference labels of moving people from the depth
// data (docs/reference_labels.md).
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

#include "common/text_io.hpp"
#include "label/labeller.hpp"

using namespace dynamap::tools;

namespace {

void usage(std::FILE* to) {
  std::fprintf(to,
               "usage: dynamap-label SEQ --out DIR [--first-frame N] [--max-frames N] [--quiet]\n"
               "                     [--static-model] [--overlays DIR [--overlay-every N]]\n"
               "  Offline, non-causal reference labels of moving people in the depth sequence\n"
               "  SEQ (TUM layout, world z up, floor at z = 0): writes DIR/obstacles.txt and\n"
               "  DIR/tracks.csv (dynamic = 1, path = -1; for dynamap-eval SEQ DIR).\n"
               "  --first-frame N skips the first N frames that have a pose.\n"
               "  Missing or unreadable depth images are skipped and listed.\n"
               "  --overlays DIR: every N-th frame (default 30) a PNG for checking by eye:\n"
               "  depth, points held free by the static model (red), labelled boxes (green;\n"
               "  blue when interpolated).\n"
               "  --static-model: also DIR/static_model.ply, the centres of the static voxels\n"
               "  of the labeller's all-frames model (probability = hit ratio), for\n"
               "  dynamap-replay --static-model. The labels are the same either way.\n"
               "  See docs/reference_labels.md.\n");
}

}  // namespace

int main(int argc, char** argv) {
  try {
    std::string seq, out;
    bool quiet = false;
    label::LabelOptions opt;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      auto value = [&]() -> std::string {
        if (i + 1 >= argc) throw ToolError("option '" + a + "' needs a value");
        return argv[++i];
      };
      if (a == "-h" || a == "--help") {
        usage(stdout);
        return 0;
      } else if (a == "--out") {
        out = value();
      } else if (a == "--max-frames") {
        const std::string v = value();
        const long long n = parse_int(v, TextLocation{"--max-frames", 0}, "frame count");
        if (n < 0) throw ToolError("--max-frames must be >= 0, got " + v);
        opt.max_frames = static_cast<int>(n);
      } else if (a == "--first-frame") {
        const std::string v = value();
        const long long n = parse_int(v, TextLocation{"--first-frame", 0}, "frame index");
        if (n < 0) throw ToolError("--first-frame must be >= 0, got " + v);
        opt.first_frame = static_cast<int>(n);
      } else if (a == "--overlays") {
        opt.overlay_dir = value();
        if (opt.overlay_every <= 0) opt.overlay_every = 30;
      } else if (a == "--overlay-every") {
        const std::string v = value();
        const long long n = parse_int(v, TextLocation{"--overlay-every", 0}, "frame step");
        if (n <= 0) throw ToolError("--overlay-every must be > 0, got " + v);
        opt.overlay_every = static_cast<int>(n);
      } else if (a == "--static-model") {
        opt.keep_static_model = true;
      } else if (a == "--quiet") {
        quiet = true;
      } else if (!a.empty() && a[0] == '-') {
        throw ToolError("unknown option '" + a + "'");
      } else if (seq.empty()) {
        seq = a;
      } else {
        throw ToolError("unexpected argument '" + a + "'");
      }
    }
    if (seq.empty() || out.empty()) {
      usage(stderr);
      return 2;
    }
    if (!quiet) {
      opt.progress = [](const std::string& line) {
        std::fprintf(stderr, "dynamap-label: %s\n", line.c_str());
      };
    }
    const label::LabelResult r = label::label_sequence(seq, opt);
    label::write_labels(out, r, opt);
    const auto& s = r.summary;
    std::fprintf(stderr,
                 "dynamap-label: %s: %zu frames (%zu listed, %zu without a pose), %zu depth "
                 "files skipped, %zu people-tracks, %zu rows (%zu interpolated) in %s, %.1f s\n",
                 seq.c_str(), s.frames, s.listed, s.without_pose, s.skipped.size(), s.tracks,
                 s.rows, s.interpolated_rows, out.c_str(), s.seconds);
    for (const auto& w : s.warnings) std::fprintf(stderr, "  warning: %s\n", w.c_str());
    for (const auto& why : s.skipped) std::fprintf(stderr, "  skipped: %s\n", why.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynamap-label: error: %s\n", e.what());
    return 1;
  }
}
