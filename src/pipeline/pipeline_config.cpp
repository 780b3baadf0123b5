#include <algorithm>
#include <cmath>
#include <limits>

#include "dynamap/detect/detail/umap_histogram.hpp"
#include "dynamap/pipeline/parameters.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"

namespace dynamap {
namespace {

// Small helpers so each check reads as one line: field name, condition, reason.
struct Checker {
  ConfigError error{};
  bool failed() const noexcept { return error.status != Status::kOk; }
  void require(bool good, const char* field, const char* reason) noexcept {
    if (!failed() && !good) error = ConfigError{Status::kInvalidArgument, field, reason};
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
  const std::size_t markov = mul(mul(w.tracks, paths.num_paths), per_track_path);
  const std::size_t linear = c.run_linear_baseline ? mul(w.tracks, per_track_path) : 0;
  w.predictor_voxel_steps = add(markov, linear);
  return w;
}

namespace {

// Rules no single stage's Relation table holds: the thread team against the map's tiling and
// the CPU indices, and the map's stride against the pipeline's budgets.
void check_map_relations(const PipelineConfig& c, Checker& k) noexcept {
  const OccupancyMapConfig& m = c.map;
  k.require(c.team.members == 1 || m.carve_tiles > 0, "team.members",
            "must be 1 unless map.carve_tiles > 0 (only tiled carving runs on several threads)");
  k.require(c.team.helper_first_cpu + c.team.members - 2 <= kMaxCpuIndex, "team.helper_first_cpu",
            "the last helper's CPU (helper_first_cpu + members - 2) must be <= 1023");
  k.require(!c.budgets.adaptive_stride || c.budgets.max_pixel_stride >= m.pixel_stride,
            "budgets.max_pixel_stride", "must be >= map.pixel_stride in adaptive mode");
}

// The detector's depth band against the camera's depth unit: UMapDetector::detect bins raw
// 16-bit depths and refuses every frame whose binning make_umap_binning refuses.
void check_detector_relations(const PipelineConfig& c, Checker& k) noexcept {
  const UMapDetectorConfig& d = c.detector;
  const float scale = c.camera.depth_scale;
  UMapBinning b;
  const bool band_ok = ok(make_umap_binning(d.d_min, d.d_max, scale, 1, &b));
  k.require(band_ok, "detector.d_max",
            "must be <= 65535 x camera.depth_scale (the largest raw depth) and leave a raw depth "
            "value above detector.d_min");
  k.require(!band_ok || ok(make_umap_binning(d.d_min, d.d_max, scale, d.bins, &b)), "detector.bins",
            "must be <= the number of raw depth values in [detector.d_min, detector.d_max] at "
            "camera.depth_scale");
}

// The tracker against the camera (Tracker::init checks it against the image size it is given).
void check_tracker_relations(const PipelineConfig& c, Checker& k) noexcept {
  const TrackerConfig& t = c.tracker;
  k.require(2 * t.image_margin < c.camera.width && 2 * t.image_margin < c.camera.height,
            "tracker.image_margin", "must be < half of camera.width and of camera.height");
}

// The derived worst case of the whole frame (only once every field is in range).
void check_worst_case(const PipelineConfig& c, Checker& k) noexcept {
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

}  // namespace

ConfigError validate(const PipelineConfig& c) noexcept {
  const ConfigError range = check_ranges(c);
  if (!range.ok()) return range;
  const ConfigError relation = check_relations(c);
  if (!relation.ok()) return relation;
  Checker k;
  check_map_relations(c, k);
  check_detector_relations(c, k);
  check_tracker_relations(c, k);
  if (!k.failed()) check_worst_case(c, k);
  return k.error;
}

}  // namespace dynamap
