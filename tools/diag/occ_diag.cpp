// dynamap-occ-diag: accuracy cost of early-stop free-space carving on a recorded or simulated
// sequence. Integrates every frame into an exact map and into one map per early-stop count
// (OccupancyMapConfig defaults otherwise, or a --params file's map keys) and prints, per count,
// the share of the exact map's misses it also carries out (per frame, and recovered within a
// few frames), the voxels it updates that the exact map does not, and how the final maps
// differ (tools/diag/carve_compare.hpp). Host-only developer tool.
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include "carve_compare.hpp"
#include "common/png_io.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"
#include "params.hpp"

namespace dynamap::tools {
namespace {

int run(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: dynamap-occ-diag SEQ [--stops 1,2,3] [--recover K] [--params FILE] "
                 "[--name NAME]\n";
    return 2;
  }
  const std::string seq_dir = argv[1];
  std::vector<int> stops{1, 2, 3, 4};
  int recover = 3;
  std::string params, name = seq_dir;
  for (int i = 2; i + 1 < argc; i += 2) {
    const std::string a = argv[i], v = argv[i + 1];
    if (a == "--stops") {
      stops.clear();
      std::stringstream ss(v);
      std::string item;
      while (std::getline(ss, item, ',')) stops.push_back(std::stoi(item));
    } else if (a == "--recover") {
      recover = std::stoi(v);
    } else if (a == "--params") {
      params = v;
    } else if (a == "--name") {
      name = v;
    } else {
      std::cerr << "unknown option " << a << "\n";
      return 2;
    }
  }
  const Sequence seq = read_sequence(seq_dir);
  const PipelineConfig config = config_for_sequence(seq, params);
  const CameraIntrinsics& cam = config.camera;
  diag::CarveComparison cmp(config.map, stops, recover);
  for (const SequenceFrame& sf : seq.frames) {
    const Image16 depth = load_depth(seq, sf);
    const DepthView view{depth.pixels.data(), depth.width, depth.height,
                         depth.width * static_cast<int>(sizeof(std::uint16_t))};
    if (!cmp.add_frame(view, cam, to_pose(sf.pose), seq.stamp_ns(sf.stamp))) {
      throw ToolError("integrate failed at " + sf.stamp_text);
    }
  }
  cmp.print(stdout, name.c_str());
  return 0;
}

}  // namespace
}  // namespace dynamap::tools

int main(int argc, char** argv) {
  try {
    return dynamap::tools::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dynamap-occ-diag: " << e.what() << "\n";
    return 1;
  }
}
