#include <cmath>

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

}  // namespace

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
  k.require(c.map.max_blocks >= 1 && c.map.max_blocks <= kMaxMapBlocks, "map.max_blocks",
            "must be in 1..kMaxMapBlocks");
  k.require(c.map.max_rays_per_frame >= 1 && c.map.max_rays_per_frame <= kMaxRaysPerFrame,
            "map.max_rays_per_frame", "must be in 1..kMaxRaysPerFrame");
  k.require(c.map.max_voxel_visits_per_frame >= 1, "map.max_voxel_visits_per_frame",
            "must be >= 1");
  k.require(c.map.free_ray_early_stop >= 0, "map.free_ray_early_stop",
            "must be >= 0 (0: exact walk from the camera)");

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

  // Timing budgets.
  k.require(c.budgets.max_pixel_stride >= 1, "budgets.max_pixel_stride", "must be >= 1");
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
