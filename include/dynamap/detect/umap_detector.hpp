// UMapDetector: obstacle proposals from one depth image via the U map (per-column depth
// histograms). Thresholded U-map cells form segments per bin row, segments overlapping across
// adjacent bins form groups, and each group's columns + depth band give a pixel region whose
// back-projected points bound a 3-D box (map frame: from the mean surface points of its columns
// and rows by default, or the 8 transformed corners of the camera-frame box).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/detection.hpp"
#include "dynamap/core/fixed_vector.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/detect/detail/umap_histogram.hpp"

namespace dynamap {

/// Most U-map segments kept per frame (extra ones are counted as dropped).
inline constexpr std::size_t kMaxUMapSegments = 2048;
/// Largest smoothing radius (bins summed on each side of a cell).
inline constexpr int kMaxUMapSmoothingRadius = 4;

/// Parameters of the U-map detector; defaults in docs/umap_detector.md.
struct UMapDetectorConfig {
  // U map
  int bins = 120;            ///< depth bins over [d_min, d_max] (<= kMaxUMapBins)
  float d_min = 0.1f;        ///< metres; nearer depths are not counted
  float d_max = 8.0f;        ///< metres; farther depths are not counted
  int smoothing_radius = 0;  ///< cell test uses the sum over bins [b-r, b+r] (0 = off)
  // "points": a cell is a point when its (smoothed) count reaches
  //   max(count_threshold, min_point_height * fy / depth_of_bin)
  // i.e. a pixel floor plus "the column shows at least this many metres of surface".
  int count_threshold = 10;
  float min_point_height = 0.2f;
  // segments and groups
  int min_segment_length = 6;  ///< columns; shorter runs of points are ignored
  int min_area = 20;           ///< U-map cells (points) per group; smaller groups are dropped
  // height search: rows whose in-band pixel count over the group's columns is at least
  // max(1, row_fill_fraction * width) are hits; the longest run of hits (gaps of at most
  // max_row_gap rows bridged) of at least min_run_rows rows gives the vertical extent.
  float band_factor = 1.3f;  ///< depth band is [near, near + band_factor * extent]
  float row_fill_fraction = 0.2f;
  int max_row_gap = 2;
  int min_run_rows = 4;
  // background rejection (walls): groups spanning at least this fraction of the image width,
  // or larger than these metric sizes, are not obstacles.
  float max_width_fraction = 0.9f;
  float max_width = 4.0f;   ///< metres (camera x)
  float max_height = 3.0f;  ///< metres (camera y)
  /// Groups whose column-mean depths span more than this (metres along the ray) are background:
  /// a wall seen at a grazing angle, not an object to track (it stays in the map).
  float max_depth_extent = 1.5f;
  // bounded work
  std::size_t max_candidates = 64;  ///< height searches per frame (nearest groups first)
  std::size_t max_detections = kMaxDetections;
  bool use_fast_histogram = true;  ///< false: scalar reference kernel (tests, debugging)
  /// Height search and box sums in branch-free 16-column chunks the compiler vectorises, with
  /// 32-bit partial sums (same detections); false: the per-pixel reference loops.
  bool use_fast_measure = true;
};

/// Counters of the last detect() call.
struct UMapDetectorStats {
  std::size_t segments = 0;
  std::size_t segments_dropped = 0;  ///< over kMaxUMapSegments
  std::size_t groups = 0;
  std::size_t rejected_area = 0;
  std::size_t rejected_size = 0;       ///< wall-like (too wide / too tall)
  std::size_t rejected_height = 0;     ///< no run of rows found in the depth band
  std::size_t candidates_dropped = 0;  ///< over max_candidates
  std::size_t detections = 0;
  std::size_t detections_dropped = 0;  ///< over max_detections / output capacity
};

/// Fixed-capacity output of one detect() call.
using DetectionList = FixedVector<Detection, kMaxDetections>;

/// U-map detector; holds its whole working memory inline (~190 KB), so create it once (static
/// or heap at start-up) and call detect() per frame: no allocation, bounded work.
class UMapDetector {
 public:
  /// kInvalidArgument (and the previous configuration kept) when a parameter is out of range.
  [[nodiscard]] Status init(const UMapDetectorConfig& config) noexcept;

  /// Detects obstacles. On success `out` is replaced by the detections, nearest first (box and
  /// raw_box in the map frame, refined = false). On error `out` and the stats are unchanged.
  [[nodiscard]] Status detect(const DepthView& depth, const CameraIntrinsics& cam,
                              const Pose& T_map_camera, DetectionList& out) noexcept;

  const UMapDetectorConfig& config() const noexcept { return config_; }
  const UMapDetectorStats& last_stats() const noexcept { return stats_; }
  /// The last frame's U map (bin-major, stride kMaxImageWidth, bins + 1 rows) and its binning.
  const std::uint16_t* umap() const noexcept { return counts_.data(); }
  const UMapBinning& binning() const noexcept { return binning_; }

 private:
  struct Segment {
    std::int16_t u0, u1;  // inclusive columns
    std::int16_t bin;
    std::int16_t parent;  // union-find
  };
  struct Group {
    int u0, u1, b0, b1, area;
  };

  void set_point_thresholds(const CameraIntrinsics& cam) noexcept;
  void boxes_from_groups(const DepthView& depth, const CameraIntrinsics& cam,
                         const Pose& T_map_camera, DetectionList& out) noexcept;
  void extract_segments(int width) noexcept;
  void scan_bin_row(const std::uint16_t* sum, int width, int b) noexcept;
  int find_root(int i) noexcept;
  void unite(int a, int b) noexcept;
  void build_groups() noexcept;
  bool measure_group(const Group& g, const DepthView& depth, const CameraIntrinsics& cam,
                     const Pose& T_map_camera, Box3* box_cam, Box3* box_map, ImageBox* ibox,
                     float* near_depth) noexcept;
  // The steps of measure_group: the group's columns [u0, u1] and raw depth band [raw_lo,
  // raw_hi]; the longest run of image rows [v0, v1] with enough in-band pixels; the in-band
  // depth sums per column and row over it; the camera- and map-frame boxes from those sums.
  struct PixelBand {
    int u0 = 0, u1 = -1, v0 = 0, v1 = -1;
    std::uint32_t raw_lo = 0, raw_hi = 0;
  };
  bool find_row_run(const DepthView& depth, PixelBand* band) noexcept;
  void count_row_hits(const DepthView& depth, const PixelBand& band) noexcept;
  void count_row_hits_fast(const DepthView& depth, const PixelBand& band) noexcept;
  void sum_band_depths(const DepthView& depth, const PixelBand& band) noexcept;
  void sum_band_depths_fast(const DepthView& depth, const PixelBand& band) noexcept;
  void clear_column_sums(const PixelBand& band) noexcept;
  bool fit_boxes(const PixelBand& band, const CameraIntrinsics& cam, const Pose& T_map_camera,
                 Box3* box_cam, Box3* box_map, ImageBox* ibox, float* near_depth) const noexcept;

  UMapDetectorConfig config_{};
  bool initialized_ = false;
  UMapBinning binning_{};
  UMapDetectorStats stats_{};

  static constexpr int kUMapStride = kMaxImageWidth;
  alignas(kCacheLine) std::array<std::uint16_t, (kMaxUMapBins + 1) * kUMapStride> counts_{};
  alignas(kCacheLine) std::array<std::uint16_t, kMaxImageWidth> row_sum_{};
  std::array<std::uint16_t, kMaxUMapBins> thresholds_{};
  std::array<Segment, kMaxUMapSegments> segments_{};
  std::array<int, kMaxUMapBins + 1>
      bin_first_segment_{};  // segments of bin b: [first[b], first[b+1])
  std::size_t segment_count_ = 0;
  std::array<std::int16_t, kMaxUMapSegments> group_of_root_{};
  std::array<Group, kMaxUMapSegments> groups_{};
  std::size_t group_count_ = 0;
  std::array<std::uint16_t, kMaxImageHeight> row_hits_{};
  // Per-column / per-row sums of in-band raw depths for the box measurement.
  std::array<std::uint32_t, kMaxImageWidth> col_depth_sum_{};
  std::array<std::uint32_t, kMaxImageWidth> col_count_{};
  std::array<std::uint32_t, kMaxImageHeight> row_depth_sum_{};
  // Sums of row * depth per column and column * depth per row (mean surface point per line).
  std::array<std::uint64_t, kMaxImageWidth> col_vdepth_sum_{};
  std::array<std::uint64_t, kMaxImageHeight> row_udepth_sum_{};
  // Fast path: 32-bit partial sums over rows of the running column depth sum, added to
  // col_vdepth_sum_ every kVDepthFlushRows rows (480 * 65535 * 128 < 2^32: they cannot wrap).
  static constexpr int kVDepthFlushRows = 128;
  alignas(kCacheLine) std::array<std::uint32_t, kMaxImageWidth> col_vdepth_part_{};
};

}  // namespace dynamap
