// Ray-cast depth renderer of a simulated scene: floor plane, static boxes and vertical
// cylinders, walking people (vertical cylinders), plus a D435i-like noise model. It also
// measures each walker's visible fraction from an id buffer.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "common/png_io.hpp"
#include "common/sequence.hpp"
#include "sim/scene.hpp"

namespace dynamap::tools::sim {

/// A walker at one instant: where it stands and its cylinder.
struct WalkerState {
  Eigen::Vector2d position = Eigen::Vector2d::Zero();
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();
  double radius = 0.25;
  double height = 1.7;
};

/// Sensor model of the simulated depth camera, a D435(i) at 640x480 (docs/simulator.md). Off
/// (`enabled = false`, `dynamap-sim --no-noise`): the exact depth of every surface hit.
struct DepthNoise {
  bool enabled = true;
  double sigma0 = 0.001;            ///< m, constant part
  double sigma_quadratic = 0.0042;  ///< m per m^2: stereo model z^2 * 0.08 px / (385 px * 0.05 m)
  double min_range = 0.3;           ///< m, closer -> 0 (D435 min-z ~0.28 m at 1280x720)
  double max_range = 8.0;           ///< m, farther -> 0
  double edge_dropout = 0.6;        ///< probability of losing a background pixel next to an edge
  double edge_dropout_foreground = 0.3;  ///< same for the foreground pixel next to an edge
  double random_dropout = 0.005;         ///< probability of losing any pixel
  double dark_dropout = 0.6;             ///< share of a dark/shiny surface lost (in patches)
  double dark_patch = 0.12;  ///< m, side of a patch cell in the surface's own coordinates
  int dark_period = 30;      ///< frames a cell keeps its draw (staggered per cell)
};

struct RenderOptions {
  bool static_geometry = true;  ///< floor, walls, boxes, pillars
  bool walkers = true;
  DepthNoise noise;
  std::uint64_t seed = 1;
  std::uint64_t frame_index = 0;  ///< with seed, selects the noise
};

/// Result of rendering one frame.
struct RenderedFrame {
  Image16 depth;                       ///< depth units of camera.depth_factor; 0 = none
  std::vector<float> range;            ///< noise-free depth (camera z, m); 0 = nothing hit
  std::vector<int> id;                 ///< per pixel: walker index, -1 static, -2 nothing
  std::vector<double> visible;         ///< per walker: visible / projected pixels
  std::vector<long> visible_pixels;    ///< per walker: pixels in the id buffer
  std::vector<long> projected_pixels;  ///< per walker: pixels of the walker rendered alone
};

/// Renders one depth image seen from T_world_camera. A walker's projected area is counted on a
/// canvas three times the image in each direction, so a walker half outside the image has
/// visible ~0.5 and one outside the view has 0.
RenderedFrame render_frame(const Scene& scene, const CameraModel& camera,
                           const PoseD& T_world_camera, const std::vector<WalkerState>& walkers,
                           const RenderOptions& options);

}  // namespace dynamap::tools::sim
