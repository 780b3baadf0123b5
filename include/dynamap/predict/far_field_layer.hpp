// FarFieldLayer: a coarse, fixed-size top-view memory of walls beyond the occupancy map's range,
// for the predictor (docs/predictor.md, "Far-field layer"). The map integrates depth up to
// map.max_depth (5 m); the camera sees 8-10 m, and walkers the tracker follows out there head
// for walls the map holds as unknown. Each frame, every sampled image column is reduced to the
// first surface (and the one behind it) in a height band above the floor, found in a histogram
// of horizontal range whose window grows with the stereo noise sigma(d), so single noisy far
// pixels never make a wall. Surfaces at least hit_min_range from the camera are written as hits
// into a rolling 2-D grid, the space before the first surface as free. A cell is a wall while
// its evidence is positive and it was hit within memory_frames: walls seen a moment ago and now
// out of view still count. Surfaces lower than a person are walls only once they stayed in
// their cell for low_frames. All state is inline; update() never allocates and does bounded work.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"

namespace dynamap {

/// Cells per side of the rolling grid (power of two): 128 x 0.2 m = 25.6 m, enough for a 10 m
/// range around the camera on every side.
inline constexpr std::size_t kFarFieldCellsPerSide = 128;
/// Range bins of one column's histogram: max_range / cell_size must fit.
inline constexpr std::size_t kFarFieldMaxBins = 128;
/// Discs (walkers) whose pixels are not walls.
inline constexpr std::size_t kFarFieldMaxExclusions = 64;
/// Parts a frame's column binning can be split into (bin_columns()), each with its own scratch.
inline constexpr unsigned kFarFieldMaxBinParts = 4;

struct FarFieldConfig {
  bool enabled = true;         ///< false: no update, the predictor uses the map alone
  float cell_size = 0.2f;      ///< m, grid cell and range bin, [0.05, 1]
  float max_range = 9.0f;      ///< m, horizontal range of pixels used, (hit_min_range, 25]
  float hit_min_range = 4.5f;  ///< m: nearer surfaces are the map's; >= 0
  float min_height = 0.3f;     ///< m above ground_height: lower pixels are floor
  float max_height = 2.5f;     ///< m above ground_height: higher pixels are ceiling (> min)
  /// m above ground_height a surface must reach (some of its points) to be written as a wall:
  /// taller than a person, so untracked walkers leave no trail; in [min, max_height]. Lower
  /// surfaces end the free ray and are walls only once they stayed (low_frames).
  float wall_height = 2.0f;
  float noise_margin = 0.05f;       ///< m, sigma(d) = noise_margin + noise_quadratic * d^2, >= 0
  float noise_quadratic = 0.0042f;  ///< m per m^2, >= 0 (one sigma of a stereo camera)
  int pixel_stride = 4;             ///< sampled columns and rows, 1..16
  int min_pixels = 3;  ///< pixels in one column's noise window to accept a surface, >= 1
  /// A surface whose points span less than this many sigmas of the noise's vertical share
  /// (sigma(d) |z - camera z| / d) in height is no wall (it still ends the free ray), >= 0: the
  /// noise bunches a ceiling's returns, seen edge-on, into one window at nearly one height,
  /// while a wall's come from rows pixel_stride apart.
  float min_rise_sigmas = 2.5f;
  int hit_evidence = 3;     ///< added per frame a cell is hit, 1..100
  int free_evidence = 1;    ///< removed per frame a ray passes the cell, 0..100
  int max_evidence = 6;     ///< clamp, >= hit_evidence
  int memory_frames = 150;  ///< a wall is forgotten this many frames after its last hit, >= 1
  /// Frames a surface lower than wall_height must be seen in one cell (unseen for up to half a
  /// second in between) before it is a wall too: a crate beyond the map's range stays, a
  /// walker's front moves on (0.2 m in 0.4 s at 0.5 m/s). A ray passing the cell takes 4 frames
  /// off the count. 0: low surfaces are never walls. [0, 255]
  int low_frames = 30;
};

/// kInvalidArgument when a field is out of range or breaks a relation with another
/// (params::kFarField and kFarFieldRelations, predict_params.hpp).
[[nodiscard]] Status validate(const FarFieldConfig& c) noexcept;

/// A disc (top view) whose pixels are not static walls: a tracked walker.
struct FarFieldExclusion {
  Eigen::Vector2f centre = Eigen::Vector2f::Zero();
  float radius = 0.0f;
};

class FarFieldLayer {
 public:
  /// kInvalidArgument (nothing changes) on a bad config.
  [[nodiscard]] Status init(const FarFieldConfig& config, float ground_height) noexcept;

  /// Integrates one frame. Pixels within an exclusion disc (plus the noise margin) are skipped.
  /// Errors, state unchanged: kNotInitialized; validate_depth's; kNonFinite (pose);
  /// kCapacityExceeded (more than kFarFieldMaxExclusions); kNullData (exclusions null, count > 0).
  /// Work: (width / stride) x (height / stride) pixels plus kFarFieldMaxBins cells per column.
  [[nodiscard]] Status update(const DepthView& depth, const CameraIntrinsics& camera,
                              const Pose& T_map_camera, const FarFieldExclusion* exclusions,
                              std::size_t count) noexcept;
  /// update() in three steps, so its per-column binning (most of its work) can be shared by
  /// threads: begin_update() checks the input (update()'s errors, nothing changed) and takes
  /// the frame, whose image, camera and exclusions must stay valid until finish_update();
  /// bin_columns(part, parts) bins the part-th of `parts` (1..kFarFieldMaxBinParts) column
  /// ranges — different parts may run at once on different threads; finish_update() writes the
  /// grid from every column in order. The layer ends exactly as update() leaves it. Without a
  /// begun frame, bin_columns() and finish_update() do nothing.
  [[nodiscard]] Status begin_update(const DepthView& depth, const CameraIntrinsics& camera,
                                    const Pose& T_map_camera, const FarFieldExclusion* exclusions,
                                    std::size_t count) noexcept;
  void bin_columns(unsigned part, unsigned parts) noexcept;
  void finish_update() noexcept;

  /// Is the cell holding map point `p` (top view) a remembered wall? Inline: the predictor asks
  /// this for every footprint point of every sample of every path.
  bool occupied(const Eigen::Vector2f& p) const noexcept {
    const Cell* c = initialised_ ? cell_for_read(p) : nullptr;
    return c != nullptr &&
           (c->evidence > 0 || (config_.low_frames > 0 && c->low_count >= config_.low_frames)) &&
           frame_ - c->last_hit <= static_cast<std::uint32_t>(config_.memory_frames);
  }
  /// Evidence of that cell (0 when never touched or overwritten by the rolling window).
  int evidence(const Eigen::Vector2f& p) const noexcept;

  bool initialised() const noexcept { return initialised_; }
  const FarFieldConfig& config() const noexcept { return config_; }
  std::uint32_t frames() const noexcept { return frame_; }
  /// Surfaces written as hits in the last update (for diagnosis).
  std::size_t last_hits() const noexcept { return last_hits_; }
  void reset() noexcept;

 private:
  struct Cell {
    std::int32_t ix = 0;
    std::int32_t iy = 0;
    std::uint32_t last_hit = 0;  ///< frame_ at the last hit
    std::int8_t evidence = 0;
    bool used = false;
    std::uint8_t low_count = 0;  ///< frames a low surface was seen here (see low_frames)
    std::uint8_t low_tick = 0;   ///< frame_ (mod 256) of the last low hit
  };
  static_assert(sizeof(Cell) == 16, "docs/predictor.md: 16 bytes a cell");
  /// Cell coordinates are kept well inside int32 (and float's exact integers).
  static constexpr float kMaxCellCoord = 1.0e6f;

  Cell* cell_for_write(const Eigen::Vector2f& p) noexcept;
  const Cell* cell_for_read(const Eigen::Vector2f& p) const noexcept {
    std::int32_t ix = 0;
    std::int32_t iy = 0;
    if (!key(p, &ix, &iy)) return nullptr;
    const Cell& c = cells_[slot_of(ix, iy)];
    return c.used && c.ix == ix && c.iy == iy ? &c : nullptr;
  }
  /// Grid coordinates of `p`: floor(p / cell_size), false when out of range or not finite.
  bool key(const Eigen::Vector2f& p, std::int32_t* ix, std::int32_t* iy) const noexcept {
    const float qx = p.x() * inv_cell_size_;
    const float qy = p.y() * inv_cell_size_;
    if (!(qx > -kMaxCellCoord && qx < kMaxCellCoord && qy > -kMaxCellCoord && qy < kMaxCellCoord)) {
      return false;  // also rejects NaN
    }
    // floor without a libm call: truncation rounds negative non-integers up by one.
    const auto tx = static_cast<std::int32_t>(qx);
    const auto ty = static_cast<std::int32_t>(qy);
    *ix = tx - static_cast<std::int32_t>(qx < static_cast<float>(tx));
    *iy = ty - static_cast<std::int32_t>(qy < static_cast<float>(ty));
    return true;
  }
  /// Rolling-window slot of a cell: its coordinates modulo the grid side.
  static std::size_t slot_of(std::int32_t ix, std::int32_t iy) noexcept {
    constexpr std::uint32_t mask = static_cast<std::uint32_t>(kFarFieldCellsPerSide - 1);
    const std::uint32_t sx = static_cast<std::uint32_t>(ix) & mask;
    const std::uint32_t sy = static_cast<std::uint32_t>(iy) & mask;
    return static_cast<std::size_t>(sy) * kFarFieldCellsPerSide + sx;
  }
  void add_hit(const Eigen::Vector2f& p) noexcept;
  void add_low_hit(const Eigen::Vector2f& p) noexcept;
  void add_free(const Eigen::Vector2f& from, const Eigen::Vector2f& to) noexcept;
  // update() in steps (far_field_layer.cpp).
  /// One frame's camera geometry, height band and exclusion discs, shared by its columns.
  struct FrameGeometry {
    const CameraIntrinsics* camera = nullptr;
    Eigen::Matrix3f R = Eigen::Matrix3f::Identity();
    Eigen::Vector3f origin = Eigen::Vector3f::Zero();
    Eigen::Vector2f o2 = Eigen::Vector2f::Zero();
    Eigen::Vector3f row_step = Eigen::Vector3f::Zero();  ///< ray change per image row (unit depth)
    float z_lo = 0.0f, z_hi = 0.0f, z_tall = 0.0f;
    std::size_t bins = 0;
    float inv_fx = 0.0f;
    const FarFieldExclusion* exclusions = nullptr;
    std::size_t count = 0;
    // The discs' bearings from the camera: a column only tests the discs its bearing passes
    // (usually none), not every disc at every pixel.
    std::array<float, kFarFieldMaxExclusions> disc_angle{};
    std::array<float, kFarFieldMaxExclusions> disc_half{};
  };
  /// One column's range-bin histogram: count, points above wall_height, sum of x, y.
  struct ColumnBins {
    std::array<std::uint16_t, kFarFieldMaxBins> count{};
    std::array<std::uint16_t, kFarFieldMaxBins> tall{};
    std::array<Eigen::Vector2f, kFarFieldMaxBins> sum{};
    /// Lowest and highest point, for flatness; valid only where count > 0 (not reset per column).
    std::array<float, kFarFieldMaxBins> z_min{};
    std::array<float, kFarFieldMaxBins> z_max{};
  };
  /// What a surface is for the layer.
  enum class SurfaceKind : std::uint8_t {
    kFlat,  ///< returns at nearly one height (a ceiling seen edge-on): no wall
    kLow,   ///< no point above wall_height: a wall only once it stayed (low_frames)
    kTall,  ///< a wall
  };
  /// A column's first two surfaces (centroid, kind) and, when it has none, the last point beyond
  /// max_range (NaN when none).
  struct ColumnSurfaces {
    std::array<Eigen::Vector2f, 2> hit{};
    std::array<SurfaceKind, 2> kind{};
    int count = 0;
    Eigen::Vector2f beyond = Eigen::Vector2f::Zero();
  };
  using DiscList = std::array<std::size_t, kFarFieldMaxExclusions>;
  float sigma(float d) const noexcept;  ///< depth noise margin at range d
  FrameGeometry frame_geometry(const CameraIntrinsics& camera, const Pose& T_map_camera,
                               const FarFieldExclusion* exclusions,
                               std::size_t count) const noexcept;
  std::size_t column_discs(const FrameGeometry& g, const Eigen::Vector3f& col_dir, int height,
                           DiscList& near) const noexcept;
  /// Fills the range-bin histogram of column u; returns the last point beyond the range (NaN
  /// when none).
  Eigen::Vector2f bin_column(const FrameGeometry& g, const DepthView& depth, int u,
                             ColumnBins& h) const noexcept;
  std::size_t densest_window(const ColumnBins& h, std::size_t b, std::size_t w,
                             std::size_t bins) const noexcept;
  ColumnSurfaces find_surfaces(const FrameGeometry& g, const ColumnBins& h,
                               const Eigen::Vector2f& beyond) const noexcept;
  void mark_column(const FrameGeometry& g, const ColumnSurfaces& s) noexcept;
  void mark_surface(const Eigen::Vector2f& o2, const Eigen::Vector2f& hit, bool first,
                    SurfaceKind kind) noexcept;

  FarFieldConfig config_{};
  float ground_height_ = 0.0f;
  float inv_cell_size_ = 5.0f;  ///< 1 / config_.cell_size
  bool initialised_ = false;
  std::uint32_t frame_ = 0;
  std::size_t last_hits_ = 0;
  std::array<Cell, kFarFieldCellsPerSide * kFarFieldCellsPerSide> cells_{};
  // The frame begin_update() took: its geometry, image, and every sampled column's surfaces;
  // one histogram scratch per part (no allocation).
  bool begun_ = false;
  FrameGeometry geometry_{};
  DepthView depth_{};
  std::size_t columns_ = 0;
  std::array<ColumnSurfaces, kMaxImageWidth> surfaces_{};
  std::array<ColumnBins, kFarFieldMaxBinParts> bins_{};
};

}  // namespace dynamap
