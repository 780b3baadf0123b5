// Generated scenes (dynamap-sim random): a world and a run drawn from one seed, for the scenario
// suite (scripts/suite.sh). Every draw comes from SplitMix64, so a seed gives the same scene on
// every platform, and every draw is logged for the sequence's README.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "sim/scene.hpp"

namespace dynamap::tools::sim {

/// Soundness margins a generated scene keeps (the generator checks them while drawing, and
/// test_tools checks them again independently). People may brush each other: their centres
/// never come closer than walker_overlap * (ra + rb).
struct RandomSceneLimits {
  static constexpr double walker_static = 0.1;    ///< m from a walker's cylinder to static shapes
  static constexpr double camera_static = 0.5;    ///< m from the camera centre to static shapes
  static constexpr double camera_walker = 0.3;    ///< m from the camera centre to a walker
  static constexpr double walker_overlap = 0.6;   ///< share of (ra + rb) two centres keep apart
  static constexpr double max_speed = 2.0;        ///< m/s no walker exceeds (groups in turns)
  static constexpr double max_yaw_rate = 1.5708;  ///< rad/s (90 deg/s) of a flying camera
};

/// A generated scene and the log of its draws (one line each, human-readable).
struct RandomScene {
  Scene scene;
  std::vector<std::string> draws;
  std::string layout;  ///< room, corridor, l_corridor, open_space or cluttered_hall
  std::string camera;  ///< hover, carried or fly
};

/// Draws a scene from `seed` for a run of `frames` frames at 30 Hz (the soundness checks between
/// people and the camera cover that run; static clearances hold for all times).
RandomScene make_random_scene(std::uint64_t seed, int frames);

/// README.md text of a generated sequence: how to rebuild it and every draw.
std::string random_scene_readme(const RandomScene& r, std::uint64_t seed, int frames);

/// `dynamap-sim random ...` (argv[1] == "random"): renders a generated scene; throws ToolError.
int random_main(int argc, char** argv);

}  // namespace dynamap::tools::sim
