#include <algorithm>
#include <cmath>
#include <limits>

#include "dynamap/pipeline_config.hpp"

namespace dynamap {
namespace {

// Small helpers so each check reads as one line: field name, condition, reason.
struct Checker {
  ConfigError error{};
  bool failed() const noexcept { return error.status != Status::kOk; }
  void require(bool good, const char* field, const char* reason) noexcept {
    if (!failed() && !good) error = ConfigError{Status::kInvalidArgument, field, reason};
  }
  void positive(float v, const char* field) noexcept {
    require(std::isfinite(v) && v > 0.f, field, "must be finite and > 0");
  }
  void probability(float v, const char* field) noexcept {
    require(std::isfinite(v) && v > 0.f && v < 1.f, field, "must be a probability in (0, 1)");
  }
  void sub(Status s, const char* field) noexcept {
    require(ok(s), field, "rejected by the stage's own validation (see its header)");
  }
};

/// Saturating product (worst-case figures of absurd configurations must not wrap).
std::size_t mul(std::size_t a, std::size_t b) noexcept {
  if (a != 0 && b > std::numeric_limits<std::size_t>::max() / a) {
    return std::numeric_limits<std::size_t>::max();
  }
  return a * b;
}

/// Saturating sum.
std::size_t add(std::size_t a, std::size_t b) noexcept {
  return a > std::numeric_limits<std::size_t>::max() - b ? std::numeric_limits<std::size_t>::max()
                                                         : a + b;
}

/// Non-negative finite float to a count, saturating (NaN and negatives give 0).
std::size_t count_of(float x) noexcept {
  if (!(x > 0.f)) return 0;
  if (!(x < 1e18f)) return std::numeric_limits<std::size_t>::max();
  return static_cast<std::size_t>(std::ceil(x));
}

}  // namespace

WorstCaseWork worst_case_work(const PipelineConfig& c) noexcept {
  WorstCaseWork w;
  const OccupancyMapConfig& m = c.map;
  // Sampled pixels at the finest stride the pipeline may use (its configured one).
  const auto sampled = [&](int size) -> std::size_t {
    const int margin = std::max(m.pixel_margin, 0);
    const int stride = std::max(m.pixel_stride, 1);
    return size > 2 * margin ? static_cast<std::size_t>((size - 2 * margin + stride - 1) / stride)
                             : 0;
  };
  w.rays = std::min(mul(sampled(c.camera.width), sampled(c.camera.height)), m.max_rays_per_frame);
  // A ray stays in the local region around the camera: at most the region's voxel span per axis.
  std::size_t ray_voxels = 1;
  for (int a = 0; a < 3; ++a) {
    ray_voxels = add(ray_voxels, mul(2, count_of(m.local_half_extent[a] / m.resolution)));
  }
  w.voxel_visits = std::min(mul(w.rays, ray_voxels), m.max_voxel_visits_per_frame);
  w.detections = c.detector.max_detections;
  w.refiner_voxels = mul(mul(w.detections, 2), c.refiner.max_voxels_per_box);
  w.tracks = kMaxTracks;
  w.cleaner_voxels = c.cleaner.max_voxels_per_frame;
  const PathLibraryConfig& paths = c.predictor.paths;
  w.path_samples = mul(mul(w.tracks, paths.num_paths + 1), kMaxPathSamples);
  const float horizon =
      std::max(paths.horizon_distance, paths.slow_speed * paths.slow_horizon_time);
  const std::size_t per_path =
      add(count_of(3.f * horizon / m.resolution), 3 * (kMaxPathSamples - 1));
  const ClearanceConfig& cl = c.predictor.clearance;
  const std::size_t per_track_path = mul(mul(cl.max_lines, cl.height_levels), per_path);
  const std::size_t sweeps = c.predictor.unknown_weight < 1.f ? 2 : 1;
  const std::size_t markov = mul(mul(w.tracks, paths.num_paths), mul(sweeps, per_track_path));
  const std::size_t linear = c.run_linear_baseline ? mul(w.tracks, per_track_path) : 0;
  w.predictor_voxel_steps = add(markov, linear);
  return w;
}

ConfigError validate(const PipelineConfig& c) noexcept {
  Checker k;
  // Camera.
  k.positive(c.camera.fx, "camera.fx");
  k.positive(c.camera.fy, "camera.fy");
  k.require(std::isfinite(c.camera.cx), "camera.cx", "must be finite");
  k.require(std::isfinite(c.camera.cy), "camera.cy", "must be finite");
  k.require(c.camera.width > 0 && c.camera.width <= kMaxImageWidth, "camera.width",
            "must be in 1..kMaxImageWidth (640)");
  k.require(c.camera.height > 0 && c.camera.height <= kMaxImageHeight, "camera.height",
            "must be in 1..kMaxImageHeight (480)");
  k.positive(c.camera.depth_scale, "camera.depth_scale");

  // Occupancy map.
  k.positive(c.map.resolution, "map.resolution");
  k.require(c.map.resolution >= kMinMapResolution && c.map.resolution <= kMaxMapResolution,
            "map.resolution", "must be in [kMinMapResolution, kMaxMapResolution] (0.01..10 m)");
  k.probability(c.map.prob_hit, "map.prob_hit");
  k.probability(c.map.prob_miss, "map.prob_miss");
  k.probability(c.map.prob_min, "map.prob_min");
  k.probability(c.map.prob_max, "map.prob_max");
  k.probability(c.map.prob_occupied, "map.prob_occupied");
  k.require(c.map.prob_hit > 0.5f, "map.prob_hit", "must be > 0.5 (a hit raises occupancy)");
  k.require(c.map.prob_miss < 0.5f, "map.prob_miss", "must be < 0.5 (a miss lowers occupancy)");
  k.require(c.map.prob_min < c.map.prob_occupied && c.map.prob_occupied < c.map.prob_max,
            "map.prob_occupied", "must lie between prob_min and prob_max");
  k.require(std::isfinite(c.map.min_depth) && c.map.min_depth >= 0.f, "map.min_depth",
            "must be finite and >= 0");
  k.require(std::isfinite(c.map.max_depth) && c.map.max_depth > c.map.min_depth, "map.max_depth",
            "must be finite and > map.min_depth");
  k.require(c.map.pixel_stride >= 1, "map.pixel_stride", "must be >= 1");
  k.require(c.map.pixel_margin >= 0, "map.pixel_margin", "must be >= 0");
  k.require(c.map.local_half_extent.allFinite() && (c.map.local_half_extent.array() > 0.f).all(),
            "map.local_half_extent", "must be finite and > 0 on every axis");
  k.require((c.map.local_half_extent.array() <= kMaxLocalHalfExtentVoxels * c.map.resolution).all(),
            "map.local_half_extent",
            "must be <= kMaxLocalHalfExtentVoxels (1000) x map.resolution on every axis "
            "(bounds the length of every ray)");
  k.require(c.map.max_blocks >= 1 && c.map.max_blocks <= kMaxMapBlocks, "map.max_blocks",
            "must be in 1..kMaxMapBlocks");
  k.require(c.map.max_rays_per_frame >= 1 && c.map.max_rays_per_frame <= kMaxRaysPerFrame,
            "map.max_rays_per_frame", "must be in 1..kMaxRaysPerFrame");
  k.require(c.map.max_voxel_visits_per_frame >= 1 &&
                c.map.max_voxel_visits_per_frame <= kMaxPipelineVoxelVisitsPerFrame,
            "map.max_voxel_visits_per_frame",
            "must be in 1..kMaxPipelineVoxelVisitsPerFrame (2'000'000)");
  k.require(c.map.free_ray_early_stop >= 0, "map.free_ray_early_stop",
            "must be >= 0 (0: exact walk from the camera)");
  k.require(c.map.carve_tiles >= 0 && c.map.carve_tiles <= kMaxCarveTiles, "map.carve_tiles",
            "must be in 0..kMaxCarveTiles (8; 0: one walk over all rays)");
  k.require(c.map.threads >= 1 && c.map.threads <= kMaxMapThreads, "map.threads",
            "must be in 1..kMaxMapThreads (4)");
  k.require(c.map.threads == 1 || c.map.carve_tiles > 0, "map.threads",
            "must be 1 unless map.carve_tiles > 0 (only tiled carving runs on several threads)");

  // Detector.
  k.require(c.detector.bins >= 1 && c.detector.bins <= kMaxUMapBins, "detector.bins",
            "must be in 1..kMaxUMapBins");
  k.require(std::isfinite(c.detector.d_min) && c.detector.d_min >= 0.f, "detector.d_min",
            "must be finite and >= 0");
  k.require(std::isfinite(c.detector.d_max) && c.detector.d_max > c.detector.d_min,
            "detector.d_max", "must be finite and > detector.d_min");
  k.require(c.detector.max_detections >= 1 && c.detector.max_detections <= kMaxDetections,
            "detector.max_detections", "must be in 1..kMaxDetections");

  // Tracker.
  k.require(std::isfinite(c.tracker.overlap_threshold) && c.tracker.overlap_threshold > 0.f &&
                c.tracker.overlap_threshold <= 1.f,
            "tracker.overlap_threshold", "must be in (0, 1]");
  k.require(std::isfinite(c.tracker.centre_gate) && c.tracker.centre_gate >= 0.f,
            "tracker.centre_gate", "must be finite and >= 0");
  k.require(c.tracker.history_length >= 2 && c.tracker.history_length < kMaxTrackHistory,
            "tracker.history_length", "must be in 2..kMaxTrackHistory-1");
  k.require(c.tracker.box_history_length >= 1 && c.tracker.box_history_length <= kMaxBoxHistory,
            "tracker.box_history_length", "must be in 1..kMaxBoxHistory");
  {
    const ContinuityConfig& cc = c.tracker.continuity;
    k.require(cc.min_size.allFinite() && (cc.min_size.array() >= 0.f).all(),
              "tracker.continuity.min_size", "must be finite and >= 0 on every axis");
    k.require(cc.max_size.allFinite() && (cc.max_size.array() >= cc.min_size.array()).all(),
              "tracker.continuity.max_size", "must be finite and >= min_size on every axis");
  }

  // Predictor.
  k.require(c.predictor.paths.num_paths >= 1 && c.predictor.paths.num_paths <= kMaxPaths,
            "predictor.paths.num_paths", "must be in 1..kMaxPaths");
  k.require(std::isfinite(c.predictor.beta) && c.predictor.beta >= 0.f, "predictor.beta",
            "must be finite and >= 0");
  k.require(std::isfinite(c.predictor.unknown_weight) && c.predictor.unknown_weight >= 0.f &&
                c.predictor.unknown_weight <= 1.f,
            "predictor.unknown_weight", "must be in [0, 1]");
  k.require(c.predictor.belief_update == BeliefUpdate::kCompound ||
                c.predictor.belief_update == BeliefUpdate::kChoiceOnly,
            "predictor.belief_update", "must be compound or choice_only");
  {
    const DepthCheckConfig& d = c.predictor.depth_check;
    k.require(std::isfinite(d.noise_margin) && d.noise_margin >= 0.f,
              "predictor.depth_check.noise_margin", "must be finite and >= 0");
    k.require(std::isfinite(d.noise_quadratic) && d.noise_quadratic >= 0.f,
              "predictor.depth_check.noise_quadratic", "must be finite and >= 0");
    k.require(std::isfinite(d.surface_thickness) && d.surface_thickness >= 0.f,
              "predictor.depth_check.surface_thickness", "must be finite and >= 0");
    k.require(std::isfinite(d.min_depth) && d.min_depth > 0.f, "predictor.depth_check.min_depth",
              "must be finite and > 0");
    k.require(std::isfinite(d.max_depth) && d.max_depth > d.min_depth,
              "predictor.depth_check.max_depth", "must be finite and > min_depth");
  }

  // Work caps of the later stages.
  k.require(
      c.refiner.max_voxels_per_box >= 1 && c.refiner.max_voxels_per_box <= kMaxRefinerVoxelsPerBox,
      "refiner.max_voxels_per_box", "must be in 1..kMaxRefinerVoxelsPerBox (1'048'576)");
  k.require(c.cleaner.max_voxels_per_frame >= 1 &&
                c.cleaner.max_voxels_per_frame <= kMaxCleanerVoxelsPerFrame,
            "cleaner.max_voxels_per_frame", "must be in 1..kMaxCleanerVoxelsPerFrame (1'000'000)");
  k.require(
      c.cleaner.max_purge_per_frame >= 1 && c.cleaner.max_purge_per_frame <= kCleanHistoryCapacity,
      "cleaner.max_purge_per_frame", "must be in 1..kCleanHistoryCapacity (8192)");
  k.require(c.cleaner.older_boxes_per_frame <= kMaxBoxHistory, "cleaner.older_boxes_per_frame",
            "must be in 0..kMaxBoxHistory");
  k.require(
      c.predictor.clearance.max_lines >= 1 && c.predictor.clearance.max_lines <= kMaxClearanceLines,
      "predictor.clearance.max_lines", "must be in 1..kMaxClearanceLines");
  k.require(c.predictor.clearance.height_levels >= 1 &&
                c.predictor.clearance.height_levels <= kMaxHeightLevels,
            "predictor.clearance.height_levels", "must be in 1..kMaxHeightLevels");
  {
    const PathLibraryConfig& pl = c.predictor.paths;
    k.require(std::isfinite(pl.horizon_distance) && pl.horizon_distance > 0.f &&
                  std::isfinite(pl.slow_speed) && pl.slow_speed >= 0.f &&
                  std::isfinite(pl.slow_horizon_time) && pl.slow_horizon_time > 0.f,
              "predictor.paths.horizon_distance",
              "horizon_distance and slow_horizon_time must be finite and > 0, slow_speed >= 0");
  }
  // The derived worst case of the whole frame (only once every field above is in range).
  if (!k.failed()) {
    const WorstCaseWork w = worst_case_work(c);
    k.require(w.refiner_voxels <= kMaxRefinerVoxelsPerFrame, "refiner.max_voxels_per_box",
              "detector.max_detections x 2 passes x this must be <= kMaxRefinerVoxelsPerFrame "
              "(2'097'152)");
    k.require(w.predictor_voxel_steps <= kMaxPredictorVoxelStepsPerFrame,
              "predictor.paths.horizon_distance",
              "the prediction sweep's worst case (kMaxTracks x paths x clearance lines x height "
              "levels x horizon / map.resolution voxels, see worst_case_work) exceeds "
              "kMaxPredictorVoxelStepsPerFrame (4'000'000): shorten the horizon, use fewer "
              "paths, lines or height levels, or a coarser map.resolution");
  }

  // Timing budgets.
  k.require(c.budgets.max_pixel_stride >= 1 && c.budgets.max_pixel_stride <= kMaxImageWidth,
            "budgets.max_pixel_stride", "must be in 1..kMaxImageWidth");
  k.require(!c.budgets.adaptive_stride || c.budgets.max_pixel_stride >= c.map.pixel_stride,
            "budgets.max_pixel_stride", "must be >= map.pixel_stride in adaptive mode");
  k.require(std::isfinite(c.budgets.restore_fraction) && c.budgets.restore_fraction > 0.f &&
                c.budgets.restore_fraction < 1.f,
            "budgets.restore_fraction", "must be in (0, 1)");
  k.require(std::isfinite(c.ground_height), "ground_height", "must be finite");

  // Then each stage's own full validation, for the fields not named above (the detector and
  // the predictors check theirs in init(); Pipeline::init reports those as field "pipeline").
  TrackerConfig tc = c.tracker;
  tc.image_width = c.camera.width;
  tc.image_height = c.camera.height;
  k.sub(tc.validate(), "tracker");
  k.sub(c.cleaner.validate(), "cleaner");
  return k.error;
}

}  // namespace dynamap
