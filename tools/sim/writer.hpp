// Writes a simulated sequence directory (TUM layout of docs/data_format.md + camera.txt,
// obstacles.txt, static_world.txt and a top-view picture of the scene).
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "sim/renderer.hpp"
#include "sim/scene.hpp"

namespace dynamap::tools::sim {

struct SimulateOptions {
  int frames = 300;
  std::uint64_t seed = 1;
  double start_stamp = 1700000000.0;  ///< time stamp of the first frame (s)
  bool noise = true;
  bool picture = true;  ///< write SEQ/scene_topview.png
  int png_compression = 3;
  /// Called after each frame (frame index, total) — for progress output.
  std::function<void(int, int)> on_frame;
};

/// What was written, for the summary.
struct SimulateSummary {
  int frames = 0;
  std::size_t obstacle_lines = 0;
  std::size_t visible_obstacle_lines = 0;  ///< visible >= 0.5
  int walker_overlap_frames = 0;           ///< frames where two walkers' cylinders overlap
  double zero_share = 0.0;                 ///< share of depth pixels that are 0, median over frames
  double nothing_hit_share = 0.0;          ///< share of pixels whose ray hits nothing, median
  double seconds = 0.0;
};

/// Walker states of a scene at time t (seconds since the first frame).
std::vector<WalkerState> walker_states(const std::vector<WalkerMotion>& motions, double t);

/// Renders and writes the whole sequence into out_dir (created if needed). Throws ToolError.
SimulateSummary simulate(const Scene& scene, const std::string& out_dir,
                         const SimulateOptions& options);

}  // namespace dynamap::tools::sim
