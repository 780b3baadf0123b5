// Detection refiner: one detection per person. join() merges the fragments of one obstacle that
// the U-map detector reports as separate detections (a head above a hole in the depth, the two
// halves of a torso split by flying pixels at an arm): pieces whose top-view boxes touch and
// whose joined footprint is still person-sized are one detection. split() does the opposite for
// a group the detector reports as one: people side by side (a density minimum of the group's
// pixels across its width) or one behind the other (an empty stretch of depth along the ray).
// Runs on the detector's output, before map refinement; no heap, bounded work
// (docs/detection_refiner.md).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/detection.hpp"
#include "dynamap/core/fixed_vector.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/detect/umap_detector.hpp"

namespace dynamap {

/// Depth histogram cells of the one-behind-the-other test (kSplitDepthCell each).
inline constexpr std::size_t kSplitDepthCells = 64;
inline constexpr float kSplitDepthCell = 0.05f;  ///< metres

struct DetectionRefinerConfig {
  bool join_fragments = true;
  /// Largest top-view gap (m) between two boxes that are joined (negative: they must overlap).
  float max_gap = 0.1f;
  /// Largest horizontal side (m) of the joined box: more is two obstacles side by side.
  float max_footprint = 0.8f;
  /// Split detections that hold several people (after joining).
  bool split_groups = true;
  /// Only detections wider than this across the view (m) are split side by side.
  float split_width = 0.8f;
  /// Each side of a split across the view is at least this wide (m).
  float split_min_part = 0.25f;
  /// Split across the view where the pixel count per column falls to at most this share of the
  /// lower of the peaks on either side.
  float split_dip = 0.5f;
  /// A stretch of depth along the ray at least this long (m) with (almost) no pixels splits a
  /// detection into a near and a far one.
  float split_depth_gap = 0.4f;

  Status validate() const noexcept;
};

class DetectionRefiner {
 public:
  /// `floor_top`: map-frame height below which split() ignores pixels (floor); the pipeline
  /// passes ground_height + refiner.floor_margin. kInvalidArgument when NaN or config is bad.
  [[nodiscard]] Status init(const DetectionRefinerConfig& config,
                            float floor_top = -std::numeric_limits<float>::infinity()) noexcept;
  /// Joins fragments in place (the list keeps its nearest-first order of first members).
  /// Returns the number of joins made.
  std::size_t join(DetectionList& dets) const noexcept;
  /// Splits detections holding several people, measuring each part from the depth image the
  /// detections came from (raw box and image box re-measured, refined = false). A part takes its
  /// parent's place, the other is inserted after it; both are examined again. Stops when the
  /// list is full. Returns the number of splits made.
  std::size_t split(const DepthView& depth, const CameraIntrinsics& cam, const Pose& T_map_camera,
                    DetectionList& dets) noexcept;
  const DetectionRefinerConfig& config() const noexcept { return config_; }

 private:
  /// A detection's pixels: image rectangle [u0, u1] x [v0, v1] and raw depth band [lo, hi].
  struct PixelRegion {
    int u0 = 0, u1 = -1, v0 = 0, v1 = -1;
    std::uint32_t lo = 0, hi = 0;
  };
  bool joinable(const Detection& a, const Detection& b) const noexcept;
  bool region_of(const Detection& d, const DepthView& depth, const CameraIntrinsics& cam,
                 const Pose& T_map_camera, PixelRegion* r) const noexcept;
  void floor_test(const CameraIntrinsics& cam, const Pose& T_map_camera,
                  const PixelRegion& r) noexcept;
  bool above_floor(int u, int v, std::uint32_t d) const noexcept;
  void profile(const DepthView& depth, const CameraIntrinsics& cam, const PixelRegion& r) noexcept;
  bool split_across(const PixelRegion& r, const CameraIntrinsics& cam, PixelRegion* a,
                    PixelRegion* b) noexcept;
  bool split_along(const PixelRegion& r, const CameraIntrinsics& cam, PixelRegion* a,
                   PixelRegion* b) const noexcept;
  bool sum_part(const DepthView& depth, const PixelRegion& r, int* pu0, int* pu1) noexcept;
  bool measure(const DepthView& depth, const CameraIntrinsics& cam, const Pose& T_map_camera,
               const PixelRegion& r, Detection* out) noexcept;

  DetectionRefinerConfig config_{};
  float floor_top_ = -std::numeric_limits<float>::infinity();
  // A pixel (u, v) at raw depth d is at map height floor_base_ + d * (col_slope_[u] +
  // row_slope_[v]) (floor_test() fills them for the region at hand).
  float floor_base_ = 0.f;
  std::array<float, kMaxImageWidth> col_slope_{};
  std::array<float, kMaxImageHeight> row_slope_{};
  // Working memory of split(): per-column and per-row in-region pixel counts and depth sums
  // (and their image-coordinate moments, for the mean surface point of each line), the columns'
  // running count and the depth histogram.
  std::array<std::uint16_t, kMaxImageWidth> col_count_{};
  std::array<std::uint32_t, kMaxImageWidth> col_depth_sum_{};
  std::array<std::uint64_t, kMaxImageWidth> col_vdepth_sum_{};
  std::array<std::uint32_t, kMaxImageWidth + 1> col_prefix_{};
  std::array<std::uint16_t, kMaxImageHeight> row_count_{};
  std::array<std::uint32_t, kMaxImageHeight> row_depth_sum_{};
  std::array<std::uint64_t, kMaxImageHeight> row_udepth_sum_{};
  std::array<std::uint32_t, kSplitDepthCells> depth_hist_{};
  std::uint32_t region_pixels_ = 0;
  std::uint64_t region_depth_sum_ = 0;
};

}  // namespace dynamap
