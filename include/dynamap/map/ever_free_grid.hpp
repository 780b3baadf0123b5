// EverFreeGrid: where the camera has observed free space for a while ("ever free", after
// Dynablox, Schmid et al., RA-L 2023). A coarse voxel grid next to the occupancy map: every frame
// a sparse set of depth rays marks the cells they pass as observed free and the cells they end
// in as hit. A cell observed free on `burn_in_frames` observed frames in a row, with no hit in or
// next to it, becomes ever free; it stays so until it has been hit on `forget_frames` observed
// frames in a row. An obstacle whose surface lies in ever-free cells has moved into space that
// was empty: dynamic evidence that needs no motion history (docs/tracker.md, "Static or
// dynamic"). Fixed size, no heap; the horizontal axes wrap (a column remembers which cell it
// holds and starts over when the camera has moved far enough to reuse it).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/detection.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"

namespace dynamap {

/// Cells per horizontal axis (the grid wraps: 128 x 0.2 m = 25.6 m before a column is reused).
inline constexpr int kEverFreeColumns = 128;
/// Most vertical layers.
inline constexpr int kEverFreeMaxLayers = 12;

/// Parameters of the ever-free grid; defaults in docs/tracker.md.
struct EverFreeConfig {
  bool enabled = true;
  float resolution = 0.2f;  ///< cell edge (m)
  float z_min = 0.2f;       ///< bottom of the lowest layer above the ground (m)
  int layers = 10;          ///< vertical layers (<= kEverFreeMaxLayers)
  int pixel_step = 16;      ///< one ray every this many pixels in u and v
  float max_range = 5.0f;   ///< rays are walked at most this far (m)
  /// Free marking stops this far short of the measured point: surface_margin +
  /// margin_per_range2 * range^2 (depth noise grows with the square of the range).
  float surface_margin = 0.15f;
  float margin_per_range2 = 0.01f;
  int burn_in_frames = 10;  ///< observed-free frames in a row to become ever free (<= 255)
  int forget_frames = 90;   ///< hit frames in a row to stop being ever free (<= 255)
  /// A cell's free run makes it ever free only once the cell has been seen free lying wholly
  /// inside these sides of the view: 0 none, 2 the left and right image borders, 4 all four.
  /// A cell the border cuts may hold something just beyond it, which the view turns onto.
  /// Off by default: it delays walkers entering through the side (docs/tracker.md).
  int whole_in_view = 0;

  Status validate() const noexcept;
};

class EverFreeGrid {
 public:
  /// Validates and applies `config` (kInvalidArgument, nothing changed, when out of range) and
  /// forgets everything. `ground_height` is the map-frame z of the floor.
  [[nodiscard]] Status init(const EverFreeConfig& config, float ground_height) noexcept;
  void clear() noexcept;

  /// One frame: marks the sampled rays' cells. The depth view and pose are the pipeline's,
  /// already validated; returns kNullData / kNonFinite without changes otherwise.
  [[nodiscard]] Status integrate(const DepthView& depth, const CameraIntrinsics& cam,
                                 const Pose& T_map_camera) noexcept;

  /// Share of the cells in `box` hit by this frame's rays that are ever free (0 when fewer than
  /// two such cells). Call after integrate() of the same frame.
  float ever_free_share(const Box3& box) const noexcept;
  /// Sets Detection::ever_free of every detection from its raw box.
  void annotate(Detection* dets, std::size_t count) const noexcept;

  /// True when the cell holding `p` is ever free (tests, diagnosis).
  bool ever_free_at(const Eigen::Vector3f& p) const noexcept;
  const EverFreeConfig& config() const noexcept { return config_; }

 private:
  struct Cell {
    std::uint8_t frame = 0;     // low byte of the frame counter at the last touch
    std::uint8_t free_run = 0;  // observed-free frames in a row
    std::uint8_t hit_run = 0;   // hit frames in a row
    std::uint8_t flags = 0;     // kEver, kHit (hit in `frame`), kWhole
  };
  struct ColumnTag {
    std::int32_t x = 0, y = 0;
    bool valid = false;
  };
  static constexpr std::uint8_t kEver = 1;
  static constexpr std::uint8_t kHit = 2;
  static constexpr std::uint8_t kWhole = 4;  // seen free wholly inside the view in this free run

  Cell* cell(int kx, int ky, int kz, bool claim) noexcept;
  const Cell* cell(int kx, int ky, int kz) const noexcept;
  bool key_of(const Eigen::Vector3f& p, int* kx, int* ky, int* kz) const noexcept;
  void mark_hit(const Eigen::Vector3f& p) noexcept;
  void block_neighbours(int kx, int ky, int kz) noexcept;
  void walk_free(const Eigen::Vector3f& from, const Eigen::Vector3f& to) noexcept;
  void mark_free(int kx, int ky, int kz) noexcept;
  void set_view_planes(const DepthView& depth, const CameraIntrinsics& cam,
                       const Eigen::Matrix3f& R, const Eigen::Vector3f& t) noexcept;
  /// Whether cell (kx, ky, kz) lies wholly inside the view planes set for this frame.
  bool inside_view(int kx, int ky, int kz) const noexcept;

  /// This frame's view side planes (map frame, through the camera, normals pointing in) and
  /// each normal's half-extent over a cell, |n|_1 * resolution / 2.
  std::array<Eigen::Vector3f, 4> view_normals_{};
  std::array<float, 4> view_reach_{};
  int view_planes_ = 0;
  Eigen::Vector3f view_origin_ = Eigen::Vector3f::Zero();

  EverFreeConfig config_{};
  float z0_ = 0.2f;  // map-frame bottom of layer 0
  float inv_res_ = 5.f;
  std::uint8_t frame_ = 0;
  std::array<ColumnTag, kEverFreeColumns * kEverFreeColumns> tags_{};
  std::array<Cell, kEverFreeColumns * kEverFreeColumns * kEverFreeMaxLayers> cells_{};
};

}  // namespace dynamap
