// PipelineConfig: every parameter of every stage in one plain struct, with the documented
// defaults (the paper's and the original code's, corrected as in docs/). validate() names the
// first bad field and says why, so a user never has to guess which number is wrong.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamap/dynamic_region_cleaner.hpp"
#include "dynamap/map_refiner.hpp"
#include "dynamap/markov_predictor.hpp"
#include "dynamap/occupancy_map.hpp"
#include "dynamap/status.hpp"
#include "dynamap/tracker.hpp"
#include "dynamap/types.hpp"
#include "dynamap/umap_detector.hpp"

namespace dynamap {

/// The six stages of Pipeline::process, in order.
enum class Stage : std::uint8_t {
  kOccupancy = 0,  ///< depth -> rays -> hashed voxel grid
  kDetection,      ///< U-map region proposals
  kRefinement,     ///< raw boxes tightened to occupied voxels
  kTracking,       ///< association, Kalman filter, continuity + voting
  kCleaning,       ///< dynamic obstacles' trails freed in the map
  kPrediction,     ///< Markov path prediction (+ linear baseline)
};
inline constexpr std::size_t kStageCount = 6;
/// Short stage name ("occupancy", "detection", ...), stable for CSV headers.
const char* to_string(Stage s) noexcept;

/// Time budgets. 0 disables a budget. The adaptive mode coarsens the occupancy update's pixel
/// stride when that stage overruns its budget and restores it when there is slack.
struct BudgetConfig {
  std::array<std::uint64_t, kStageCount> stage_ns{};  ///< per-stage budgets (0 = none)
  std::uint64_t frame_ns = 0;                         ///< whole-frame budget (0 = none)
  bool adaptive_stride = false;
  int max_pixel_stride = 8;       ///< coarsest stride the adaptive mode may use
  float restore_fraction = 0.5f;  ///< restore a finer stride when below this share of budget
};

/// Everything the pipeline needs. Default-constructed, it is the documented configuration for a
/// 640x480 RealSense-like camera (depth in millimetres).
struct PipelineConfig {
  CameraIntrinsics camera{};
  OccupancyMapConfig map{};
  UMapDetectorConfig detector{};
  MapRefinerConfig refiner{};
  TrackerConfig tracker{};
  DynamicRegionCleanerConfig cleaner{};
  MarkovPredictorConfig predictor{};
  Stamp clean_history_max_age_ns =
      3'000'000'000ULL;  ///< cleaned voxels count as occupied this long
  /// Also run the constant-velocity predictor (FrameOutput::linear_predictions): the yardstick
  /// of the evaluation's failure ratio, no use in flight, so off; the replay tools turn it on.
  bool run_linear_baseline = false;
  float ground_height = 0.0f;  ///< map-frame z of the floor (m)
  BudgetConfig budgets{};
};

/// Result of PipelineConfig validation: the status, the first offending field and why.
struct ConfigError {
  Status status = Status::kOk;
  const char* field = "";   ///< e.g. "map.resolution"
  const char* reason = "";  ///< e.g. "must be > 0 and finite"
  bool ok() const noexcept { return status == Status::kOk; }
};

/// Checks every field of `config`; returns the first problem found (status kOk when none).
ConfigError validate(const PipelineConfig& config) noexcept;

}  // namespace dynamap
