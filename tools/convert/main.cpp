// dynamap-convert: a TUM/Bonn sequence folder as a ROS 2 bag (MCAP) and back, and a bag's
// messages as JSON (docs/tools.md, "ROS 2 bags").
//
//   dynamap-convert SEQ --to-bag OUT[.mcap] [--compression none|zstd|lz4] [--poses tum|bonn]
//   dynamap-convert BAG --to-folder OUT [bag options]
//   dynamap-convert BAG --json          one line per message, decoded with the bag's schemas
//   dynamap-convert BAG --topics
//   dynamap-convert SEQ|BAG --read-check   reads every depth image, prints the time it takes
#include <chrono>
#include <cstdio>
#include <iostream>
#include <string>

#include "common/replay_hooks.hpp"
#include "common/ros2_bag.hpp"
#include "common/ros2_convert.hpp"
#include "common/text_io.hpp"

namespace {

using namespace dynamap::tools;

void usage(std::ostream& os) {
  os << "usage: dynamap-convert SEQ --to-bag OUT[.mcap] [--compression none|zstd|lz4]\n"
        "                       [--poses tum|bonn]\n"
        "       dynamap-convert BAG --to-folder OUT [bag options]\n"
        "       dynamap-convert BAG --json | --topics\n"
        "       dynamap-convert SEQ|BAG --read-check [bag options]\n"
        "A folder OUT becomes a rosbag2 folder (OUT/OUT_0.mcap + metadata.yaml); OUT.mcap one\n"
        "file. Topics written: /camera/depth/image_rect_raw (16UC1 in the sequence's depth units,\n"
        "depth_factor kept in the bag's metadata), /camera/depth/camera_info, /camera/pose\n"
        "(PoseStamped of the optical frame).\n"
     << bag_options_usage();
}

double now_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// What reading costs the replay: the sequence opened and every depth image decoded.
int check_reading(const std::string& input, const BagReadOptions& bag) {
  SequenceReadOptions o;
  o.bag = bag;
  const double t0 = now_seconds();
  const Sequence seq = read_sequence(input, o);
  const double t1 = now_seconds();
  std::size_t bad = 0;
  std::uint64_t sum = 0;
  for (const SequenceFrame& f : seq.frames) {
    Image16 img;
    std::string problem;
    if (try_load_depth(seq, f, &img, &problem) != DepthProblem::kNone) {
      ++bad;
      continue;
    }
    sum += img.pixels[img.pixels.size() / 2];
  }
  const double t2 = now_seconds();
  for (const std::string& w : seq.warnings) std::cerr << "warning: " << w << "\n";
  std::printf(
      "%s: %zu frames (%zu unreadable); open %.3f s, depth images %.3f s, total %.3f s"
      " (checksum %llu)\n",
      input.c_str(), seq.frames.size(), bad, t1 - t0, t2 - t1, t2 - t0,
      static_cast<unsigned long long>(sum));
  return 0;
}

int run(int argc, char** argv) {
  std::string input, to_bag, to_folder;
  bool json = false, topics = false, read_check = false;
  BagWriteOptions w;
  ReplayExtras extras;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    bool error = false;
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw ToolError(a + " needs a value");
      return argv[++i];
    };
    if (a == "--help" || a == "-h") {
      usage(std::cout);
      return 0;
    } else if (a == "--to-bag") {
      to_bag = value();
    } else if (a == "--to-folder") {
      to_folder = value();
    } else if (a == "--json") {
      json = true;
    } else if (a == "--read-check") {
      read_check = true;
    } else if (a == "--topics") {
      topics = true;
    } else if (a == "--compression") {
      w.compression = value();
      if (w.compression == "none") w.compression.clear();
    } else if (a == "--poses") {
      const std::string p = value();
      if (p != "tum" && p != "bonn") throw ToolError("--poses takes tum or bonn");
      w.poses = p == "bonn" ? PoseConvention::kBonn : PoseConvention::kTum;
    } else if (parse_replay_extra(argc, argv, i, extras, error)) {
      if (error) return 2;
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "dynamap-convert: unknown option '" << a << "'\n";
      usage(std::cerr);
      return 2;
    } else {
      input = a;
    }
  }
  if (input.empty() || (to_bag.empty() && to_folder.empty() && !json && !topics && !read_check)) {
    usage(std::cerr);
    return 2;
  }
  if (read_check) return check_reading(input, extras.bag);
  if (json) {
    dump_bag_json(input, stdout);
  } else if (topics) {
    std::cout << Ros2Bag(input).topic_list() << "\n";
  } else if (!to_bag.empty()) {
    const ConvertReport r = folder_to_bag(input, to_bag, w);
    std::printf("dynamap-convert %s -> %s: %zu images, %zu poses, %zu depth files skipped\n",
                input.c_str(), r.output.c_str(), r.images, r.poses, r.skipped);
  } else {
    const ConvertReport r = bag_to_folder(input, to_folder, extras.bag);
    std::printf("dynamap-convert %s -> %s: %zu images, %zu poses, %zu images skipped\n",
                input.c_str(), r.output.c_str(), r.images, r.poses, r.skipped);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dynamap-convert: error: " << e.what() << "\n";
    return 1;
  }
}
