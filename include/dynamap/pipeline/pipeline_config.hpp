// PipelineConfig: every parameter of every stage in one plain struct, with the documented
// defaults (the paper's and the original code's, corrected as in docs/). validate() names the
// first bad field and says why, so a user never has to guess which number is wrong.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/parameter.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/task_team.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/detect/detection_refiner.hpp"
#include "dynamap/detect/umap_detector.hpp"
#include "dynamap/map/dynamic_region_cleaner.hpp"
#include "dynamap/map/ever_free_grid.hpp"
#include "dynamap/map/map_refiner.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/map/trail_grid.hpp"
#include "dynamap/predict/far_field_layer.hpp"
#include "dynamap/predict/markov_predictor.hpp"
#include "dynamap/predict/prediction.hpp"
#include "dynamap/track/tracker.hpp"

namespace dynamap {

/// The stages of Pipeline::process, in order, except kFarField: it runs between cleaning and
/// prediction, and is listed last so the other indices (budgets, timing columns) keep their
/// meaning.
enum class Stage : std::uint8_t {
  kOccupancy = 0,  ///< depth -> rays -> hashed voxel grid
  kDetection,      ///< U-map region proposals
  kRefinement,     ///< raw boxes tightened to occupied voxels
  kTracking,       ///< association, Kalman filter, continuity + voting
  kCleaning,       ///< dynamic obstacles' trails freed in the map
  kPrediction,     ///< Markov path prediction (+ linear baseline)
  kFarField,       ///< far-field top-view layer for the predictor (runs before prediction)
};
inline constexpr std::size_t kStageCount = 7;
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

/// Highest CPU index a helper thread may be pinned to (glibc's CPU_SETSIZE - 1).
inline constexpr int kMaxCpuIndex = 1023;

/// The pipeline's thread team (platform::WorkerTeam), created once by init(). It is lent to the
/// map's tiled carving, and detection and the far-field binning share it (docs/pipeline.md,
/// "Threads"); every output is bit-identical for every number of members.
struct TeamConfig {
  /// Threads working on a frame, the caller of process() included (1..kMaxTeamMembers). More
  /// than 1 needs map.carve_tiles > 0.
  int members = 1;
  /// SCHED_FIFO priority of the helper threads (1..99); 0 (default): they inherit the policy of
  /// the thread that calls init(). Two threads need a real-time policy on a shared machine.
  int helper_fifo_priority = 0;
  /// Pin helper m (1..members-1) to CPU helper_first_cpu + m - 1; -1 (default): no pinning.
  int helper_first_cpu = -1;
};

/// Everything the pipeline needs. Default-constructed, it is the documented configuration for a
/// 640x480 RealSense-like camera (depth in millimetres).
struct PipelineConfig {
  CameraIntrinsics camera{};
  OccupancyMapConfig map{};
  UMapDetectorConfig detector{};
  DetectionRefinerConfig fragments{};  ///< joining the detector's fragments of one obstacle
  MapRefinerConfig refiner{};
  TrackerConfig tracker{};
  DynamicRegionCleanerConfig cleaner{};
  EverFreeConfig ever_free{};  ///< ever-free space, the tracker's dynamic evidence
  TrailGridConfig trail{};     ///< where dynamic tracks have been (map.keep_unknown_backed)
  MarkovPredictorConfig predictor{};
  /// Far-field top-view layer the Markov predictor reads beyond the map's range (not the linear
  /// baseline); its update is Stage::kFarField.
  FarFieldConfig far_field{};
  Stamp clean_history_max_age_ns =
      3'000'000'000ULL;  ///< cleaned voxels count as occupied this long
  /// Also run the constant-velocity predictor (FrameOutput::linear_predictions): the yardstick
  /// of the evaluation's failure ratio, no use in flight, so off; the replay tools turn it on.
  bool run_linear_baseline = false;
  float ground_height = 0.0f;  ///< map-frame z of the floor (m)
  BudgetConfig budgets{};
  TeamConfig team{};
};

/// Documented upper bounds on the per-frame work a configuration may ask for (docs/realtime.md,
/// "Bounded work"). validate() derives each figure of WorstCaseWork from the configuration and
/// refuses one over its bound, naming the field to change. The defaults use a fraction of each.
/// Map DDA steps per frame (map.max_voxel_visits_per_frame; default 1'000'000). Tighter than
/// the map's own kMaxVoxelVisitsPerFrame, which also admits offline exact-walk measurements.
inline constexpr std::size_t kMaxPipelineVoxelVisitsPerFrame = 2'000'000;
/// Half extent of the map's local region: kMaxLocalHalfExtentVoxels (occupancy_map_config.hpp).
/// Voxels the refiner examines per frame: max_detections x 2 passes x refiner.max_voxels_per_box
/// (default 32 x 2 x 16384 = 1'048'576).
inline constexpr std::size_t kMaxRefinerVoxelsPerFrame = 2'097'152;
/// Voxels the dynamic-region cleaner examines per frame: kMaxCleanerVoxelsPerFrame
/// (dynamic_region_cleaner.hpp).
/// Voxel steps of the predictors' footprint sweeps per frame, worst case over kMaxTracks dynamic
/// tracks (WorstCaseWork::predictor_voxel_steps; default about 0.5 M).
inline constexpr std::size_t kMaxPredictorVoxelStepsPerFrame = 4'000'000;

/// The most work one Pipeline::process call can do under a configuration, stage by stage, as
/// validate() derives it (each figure is also capped at run time by the named field).
struct WorstCaseWork {
  std::size_t rays = 0;                   ///< min(sampled pixels, map.max_rays_per_frame)
  std::size_t voxel_visits = 0;           ///< min(rays x longest ray, map visit cap)
  std::size_t detections = 0;             ///< detector.max_detections
  std::size_t refiner_voxels = 0;         ///< detections x 2 x refiner.max_voxels_per_box
  std::size_t tracks = 0;                 ///< kMaxTracks
  std::size_t cleaner_voxels = 0;         ///< cleaner.max_voxels_per_frame
  std::size_t path_samples = 0;           ///< tracks x paths x kMaxPathSamples
  std::size_t predictor_voxel_steps = 0;  ///< see worst_case_work()
};

/// Worst-case work of `config` (meaningful for a configuration whose individual fields are
/// valid). predictor_voxel_steps = (markov + linear baseline) sweeps over tracks x paths x
/// clearance lines x height levels x (3 x horizon / map.resolution + 3 x (kMaxPathSamples - 1));
/// horizon = the longer of predictor.paths.horizon_distance and slow_speed x slow_horizon_time.
WorstCaseWork worst_case_work(const PipelineConfig& config) noexcept;

/// A PipelineConfig field's table entry (parameters.hpp).
using Parameter = Param<PipelineConfig>;

/// Result of PipelineConfig validation: the status, the first offending field and why.
/// describe() (parameters.hpp) writes it as one line with the field's valid range.
struct ConfigError {
  Status status = Status::kOk;
  const char* field = "";                ///< full path, e.g. "map.resolution"
  const char* reason = "";               ///< e.g. "must be > map.min_depth"
  const Parameter* parameter = nullptr;  ///< the field's table entry when its range was broken
  double value = 0.0;                    ///< the value out of range (with `parameter`)
  bool ok() const noexcept { return status == Status::kOk; }
};

/// Checks every field of `config` against its range (the parameter table, parameters.hpp), then
/// the relations between fields (the stages' Relation tables, then those between stages) and the
/// worst-case work; returns the first problem found (status kOk when none). A configuration it
/// accepts is accepted by every stage's init.
ConfigError validate(const PipelineConfig& config) noexcept;

}  // namespace dynamap
