// Command-line options that dynamap-replay (and dynamap-convert) take for ROS 2 bags and the
// Foxglove MCAP output, parsed here so that the tools' own option loops only hook them in.
#pragma once

#include <string>

#include "common/sequence.hpp"

namespace dynamap::tools {

struct ReplayExtras {
  BagReadOptions bag;
  std::string mcap;          ///< --mcap FILE: Foxglove MCAP of the replay
  long mcap_map_every = 10;  ///< --mcap-map-every N: occupied voxels every N frames
  std::string reference;     ///< --reference FILE: reference people (obstacles.txt layout)
};

/// When argv[i] is one of these options, consumes it (and its value, advancing i) and returns
/// true; `error` is set (after a message on stderr) for a missing or bad value.
bool parse_replay_extra(int argc, char** argv, int& i, ReplayExtras& extras, bool& error);

/// The usage lines of these options.
std::string bag_options_usage();

}  // namespace dynamap::tools
