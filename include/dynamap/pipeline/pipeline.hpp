// Pipeline: the six stages of dynamap in order, with fixed memory and bounded work; on the
// calling thread, plus the pipeline's thread team when team.members > 1 (it carves the map's
// tiles while detection runs beside them, then bins the far field). init() takes all memory (the
// object holds it inline, so a Pipeline can be a static global); process() never allocates, throws,
// locks or does I/O. This is the unit an RTOS-like loop calls once per depth frame.
#pragma once

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/detect/umap_detector.hpp"
#include "dynamap/map/clean_history.hpp"
#include "dynamap/map/dynamic_region_cleaner.hpp"
#include "dynamap/map/map_refiner.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/map/trail_grid.hpp"
#include "dynamap/pipeline/parameters.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"
#include "dynamap/pipeline/stage_timing.hpp"
#include "dynamap/platform/worker_team.hpp"
#include "dynamap/predict/far_field_layer.hpp"
#include "dynamap/predict/linear_predictor.hpp"
#include "dynamap/predict/markov_predictor.hpp"
#include "dynamap/predict/prediction.hpp"
#include "dynamap/track/tracker.hpp"

namespace dynamap {

/// One input frame: a non-owning depth view, the camera pose T_map_camera and its stamp.
struct Frame {
  Stamp stamp = 0;
  DepthView depth{};
  Pose T_map_camera{};
};

/// Cumulative counters since init(); a planner or a health monitor can watch them.
struct PipelineCounters {
  std::uint64_t frames_processed = 0;
  std::uint64_t frames_rejected = 0;     ///< bad input: process() returned an error
  std::uint64_t rays_dropped = 0;        ///< rays over the occupancy work cap
  std::uint64_t blocks_evicted = 0;      ///< map blocks evicted because the pool was full
  std::uint64_t detections_dropped = 0;  ///< detections over the per-frame capacity
  std::uint64_t fragments_joined = 0;    ///< detector fragments merged into one (fragments.join)
  std::uint64_t groups_split = 0;        ///< detections split into people (fragments.split_groups)
  std::uint64_t tracks_refused = 0;      ///< tracks not started because the tracker was full
  std::uint64_t budget_overruns = 0;     ///< frames over the whole-frame budget
  std::uint64_t stage_overruns = 0;      ///< stage runs over their own budget (all stages)
  std::uint64_t stride_changes = 0;      ///< adaptive-stride adjustments
  std::uint64_t step_errors = 0;         ///< stage steps that returned an error (FrameWork)
};

/// Work done in the last frame, for worst-case tests (each is capped by the configuration).
struct FrameWork {
  std::size_t rays = 0;
  std::size_t voxel_visits = 0;
  std::size_t detections = 0;
  std::size_t refined = 0;
  std::size_t tracks = 0;
  std::size_t dynamic_tracks = 0;
  std::size_t voxels_cleaned = 0;
  std::size_t predictions = 0;
  /// Stage steps that returned an error on a valid frame (detector, ever-free grid, refiner,
  /// tracker, cleaner, far field, predictors): the step's output is left empty or as it
  /// was. 0 in normal operation; counted so that no status is dropped unseen.
  std::size_t step_errors = 0;
};

/// Everything one process() call produces, in fixed-size storage (~100 KB): copy it into a
/// snapshot for another thread, or read it in place.
struct FrameOutput {
  Stamp stamp = 0;
  Status status = Status::kNotInitialized;
  std::size_t num_obstacles = 0;
  std::array<TrackedObstacle, kMaxTracks> obstacles{};
  /// Predictions for the dynamic obstacles, matched by track_id; [0, num_predictions).
  std::size_t num_predictions = 0;
  std::array<PathPrediction, kMaxTracks> predictions{};
  std::array<PathPrediction, kMaxTracks> linear_predictions{};  ///< baseline, same order
  std::array<std::uint64_t, kStageCount> stage_ns{};
  std::uint64_t total_ns = 0;
  int pixel_stride = 0;  ///< occupancy stride used this frame (adaptive mode may change it)
  FrameWork work{};
  PipelineCounters counters{};
};

/// The real-time pipeline. Not copyable; create once (static, or heap at start-up), init(),
/// then call process() per frame from one thread.
class Pipeline {
 public:
  using Clock = std::uint64_t (*)();

  Pipeline() noexcept = default;
  Pipeline(const Pipeline&) = delete;
  Pipeline& operator=(const Pipeline&) = delete;

  /// Validates `config` (see validate()) and resets every stage. On error nothing changes and
  /// `error` (when given) names the bad field.
  [[nodiscard]] Status init(const PipelineConfig& config, ConfigError* error = nullptr) noexcept;

  /// Runs the six stages on `frame` and fills `out`. Bad input returns its Status, counts a
  /// rejected frame (out.status, out.stamp and out.counters are set; the rest of `out` is not
  /// touched) and leaves the map and the tracks exactly as they were:
  ///  - kNullData, kWrongSize, kInvalidArgument: no pixels, wrong size, a stride that is not a
  ///    whole number of pixels, misaligned data (validate_depth);
  ///  - kNonFinite, kNonUnitQuaternion: NaN/inf in the pose, a non-unit quaternion;
  ///  - kOutOfRange: a finite camera position beyond the map's representable range
  ///    (|component| > OccupancyMap::max_abs_translation(), 52 km at 0.1 m voxels);
  ///  - kTimeNotIncreasing: stamp not after the previous accepted frame's.
  [[nodiscard]] Status process(const Frame& frame, FrameOutput& out) noexcept;

  /// Read-only map for planners' queries between frames (same thread, or after a hand-off).
  const OccupancyMap& map() const noexcept { return map_; }
  /// The far-field layer the Markov predictor reads (config().far_field; empty when disabled).
  const FarFieldLayer& far_field() const noexcept { return far_field_; }
  const Tracker& tracker() const noexcept { return tracker_; }
  /// The last frame's refined detections, in the order the tracker received them
  /// (TrackedObstacle::detection indexes this list).
  const DetectionList& detections() const noexcept { return detections_; }
  const CleanHistory& clean_history() const noexcept { return history_; }
  const PipelineConfig& config() const noexcept { return config_; }
  const PipelineCounters& counters() const noexcept { return counters_; }
  bool initialized() const noexcept { return initialized_; }

  /// Timing statistics per stage and for the whole frame (budgets from the configuration).
  const StageStats& stage_stats(Stage s) const noexcept {
    return stage_stats_[static_cast<std::size_t>(s)];
  }
  const StageStats& frame_stats() const noexcept { return frame_stats_; }
  void reset_timing() noexcept;
  /// Replaces the monotonic clock (tests inject a fake one for deterministic budget logic).
  /// With team.members > 1 it is also read on the team's helper threads, at once: thread-safe.
  void set_clock(Clock clock) noexcept { clock_ = clock != nullptr ? clock : default_clock(); }

  /// Whole footprint in bytes (the object holds all its memory inline).
  static constexpr std::size_t memory_bytes() noexcept { return sizeof(Pipeline); }

 private:
  static Clock default_clock() noexcept;
  Status check_frame(const Frame& frame) const noexcept;
  Status reject(const Frame& frame, Status why, FrameOutput& out) noexcept;
  void adapt_stride(std::uint64_t occupancy_ns) noexcept;
  void fill_output(FrameOutput& out) noexcept;

  // process() in named steps, one per stage (src/pipeline/pipeline.cpp).
  struct FrameClock {  ///< stage laps of one process() call
    std::uint64_t start = 0;
    std::uint64_t prev = 0;
    std::array<std::uint64_t, kStageCount> stage_ns{};
  };
  /// Detection on the team (team.members > 1) in two parts the members claim before their
  /// share of the map's tiles: 0 the detector and its fragment join/split, 1 the ever-free
  /// grid's update. Each part is timed on the thread that runs it.
  struct DetectionJob {
    static constexpr unsigned kParts = 2;
    Pipeline* pipeline = nullptr;
    const Frame* frame = nullptr;
    FrameWork* work = nullptr;
    std::array<std::uint64_t, kParts> ns{};
    Status ever_free_status = Status::kOk;  ///< part 1's, counted by the caller after the join
    std::atomic<std::uint32_t> next_part{0};
  };
  /// (Re)starts team_ when `config` asks for another one.
  Status start_team(const TeamConfig& config) noexcept;
  static void detect_and_carve(void* job, unsigned member) noexcept;
  void detect_part(DetectionJob& job, unsigned part) noexcept;
  /// The far-field layer's column binning on the team: parts claimed by whichever member is free.
  struct BinJob {
    Pipeline* pipeline = nullptr;
    std::atomic<std::uint32_t> next_part{0};
  };
  static void bin_far_field(void* job, unsigned member) noexcept;
  void detect_boxes(const Frame& frame, FrameWork& work) noexcept;
  /// True when `s` is kOk; otherwise counts a step error in `work` and the counters.
  bool step_ok(Status s, FrameWork& work) noexcept;
  void lap(Stage stage, FrameClock& clock) noexcept;
  void record_stage(Stage stage, std::uint64_t ns, FrameClock& clock) noexcept;
  Status integrate(const Frame& frame, FrameWork& work, DetectionJob* job) noexcept;
  void detect(const Frame& frame, FrameWork& work) noexcept;
  void track(const Frame& frame, FrameWork& work) noexcept;
  void clean(const Frame& frame, FrameWork& work) noexcept;
  std::size_t collect_dynamic(const Frame& frame) noexcept;
  const FarFieldLayer* update_far_field(const Frame& frame, std::size_t n_dyn,
                                        FrameWork& work) noexcept;
  std::size_t predict(std::size_t n_dyn, const FarFieldLayer* far, FrameWork& work,
                      FrameOutput& out) noexcept;
  void finish(const Frame& frame, const FrameClock& clock, const FrameWork& work,
              FrameOutput& out) noexcept;

  PipelineConfig config_{};
  bool initialized_ = false;
  bool has_stamp_ = false;
  Stamp last_stamp_ = 0;
  int pixel_stride_ = 2;
  Clock clock_ = default_clock();
  /// The threads of a frame, lent to the map's tiled carving and shared by detection and the
  /// far-field binning; started with team_options_ (members, priority, first CPU).
  platform::WorkerTeam team_{};
  TeamConfig team_options_{};

  OccupancyMap map_{};
  UMapDetector detector_{};
  DetectionRefiner fragments_{};
  MapRefiner refiner_{};
  Tracker tracker_{};
  CleanHistory history_{};
  DynamicRegionCleaner cleaner_{};
  EverFreeGrid ever_free_{};
  TrailGrid
      trail_{};  ///< where dynamic tracks have been: the map's keep_unknown_backed is off there
  MarkovPredictor markov_{};
  LinearPredictor linear_{};

  DetectionList detections_{};
  std::array<ObstacleState, kMaxTracks> predictor_input_{};
  FarFieldLayer far_field_{};
  std::array<FarFieldExclusion, kFarFieldMaxExclusions> far_exclusions_{};

  std::array<StageStats, kStageCount> stage_stats_{};
  StageStats frame_stats_{};
  PipelineCounters counters_{};
};

}  // namespace dynamap
