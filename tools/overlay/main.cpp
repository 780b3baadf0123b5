// dynamap-overlay SEQ RESULT_DIR [--out DIR] [--every N] [--reference FILE] [--max-frames N]
//                 [--sheet-columns C] [--quiet]
#include <cstdio>
#include <exception>
#include <iostream>
#include <string>

#include "common/text_io.hpp"
#include "overlay/overlay.hpp"

using namespace dynamap::tools;

namespace {

constexpr const char* kUsage =
    "usage: dynamap-overlay SEQ RESULT_DIR [--out DIR] [--every N] [--reference FILE]\n"
    "                       [--max-frames N] [--sheet-columns C] [--quiet]\n";

long long int_arg(int argc, char** argv, int* i, long long min) {
  const std::string name = argv[*i];
  if (*i + 1 >= argc) throw ToolError(name + " needs a value");
  const std::string v = argv[++*i];
  const long long n = parse_int(v, {"command line", 0}, name.c_str());
  if (n < min) throw ToolError(name + " must be at least " + std::to_string(min) + ", got " + v);
  return n;
}

std::string str_arg(int argc, char** argv, int* i) {
  const std::string name = argv[*i];
  if (*i + 1 >= argc) throw ToolError(name + " needs a value");
  return argv[++*i];
}

void print_help() {
  std::printf(
      "%s"
      "  Draws tracking results on the depth images of SEQ: colour-mapped depth,\n"
      "  detections (RESULT_DIR/detections.csv, when present), every track of\n"
      "  RESULT_DIR/tracks.csv projected into the image (dynamic red, static blue),\n"
      "  reference people (--reference FILE, default SEQ/obstacles.txt) dashed green,\n"
      "  MISSED people (no dynamic track within 1 m) orange and FALSE DYN tracks (no\n"
      "  reference obstacle within 1 m) magenta. Writes DIR/frame_NNNNN.png every N\n"
      "  sequence frames (default 30; 0: none) and DIR/contact_sheet.png (about 36\n"
      "  thumbnails, C columns, default 6). DIR defaults to RESULT_DIR/overlay.\n"
      "  See docs/tools.md.\n",
      kUsage);
}

// What was written and what the totals say, on stderr.
void print_summary(const overlay::RunOptions& o, const overlay::RunSummary& s) {
  std::fprintf(
      stderr,
      "dynamap-overlay: %s + %s: %zu frames, %zu pictures + contact sheet (%zu tiles) in %s\n",
      o.seq.c_str(), o.result_dir.c_str(), s.frames, s.pictures, s.tiles,
      (o.out_dir.empty() ? join_path(o.result_dir, "overlay") : o.out_dir).c_str());
  std::fprintf(stderr,
               "  depth missing: %zu listed files absent in the %zu frames; %zu of the frames "
               "drawn had no readable depth (drawn as \"depth missing\")\n",
               s.depth_files_missing, s.frames, s.depth_missing);
  if (s.has_reference) {
    std::fprintf(stderr,
                 "  reference %s: %zu person-frames, %zu missed; %zu dynamic track-frames, "
                 "%zu false dynamic\n",
                 s.reference_path.c_str(), s.reference_people, s.missed, s.dynamic_tracks,
                 s.false_dynamic);
  } else {
    std::fprintf(stderr,
                 "  no reference (no --reference, no SEQ/obstacles.txt): %zu dynamic "
                 "track-frames, nothing judged\n",
                 s.dynamic_tracks);
  }
  if (!s.has_detections)
    std::fprintf(stderr, "  no detections.csv in %s: detections not drawn\n", o.result_dir.c_str());
  if (s.frames_after_result > 0) {
    std::fprintf(stderr,
                 "  note: %zu frames are later than the result's last stamp (replay stopped "
                 "early?); use --max-frames\n",
                 s.frames_after_result);
  }
}

}  // namespace

int main(int argc, char** argv) {
  try {
    overlay::RunOptions o;
    bool quiet = false;
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--out") {
        o.out_dir = str_arg(argc, argv, &i);
      } else if (a == "--every") {
        o.every = static_cast<int>(int_arg(argc, argv, &i, 0));
      } else if (a == "--reference") {
        o.reference = str_arg(argc, argv, &i);
      } else if (a == "--max-frames") {
        o.max_frames = int_arg(argc, argv, &i, 1);
      } else if (a == "--sheet-columns") {
        o.sheet_columns = static_cast<int>(int_arg(argc, argv, &i, 1));
      } else if (a == "--quiet") {
        quiet = true;
      } else if (a == "-h" || a == "--help") {
        print_help();
        return 0;
      } else if (!a.empty() && a[0] == '-') {
        throw ToolError("unknown option '" + a + "'");
      } else if (o.seq.empty()) {
        o.seq = a;
      } else if (o.result_dir.empty()) {
        o.result_dir = a;
      } else {
        throw ToolError("unexpected argument '" + a + "'");
      }
    }
    if (o.seq.empty() || o.result_dir.empty()) {
      std::fputs(kUsage, stderr);
      return 2;
    }
    if (!quiet) o.progress = [](const std::string& line) { std::cerr << "  " << line << "\n"; };
    const overlay::RunSummary s = overlay::run_overlay(o);
    print_summary(o, s);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dynamap-overlay: error: %s\n", e.what());
    return 1;
  }
}
