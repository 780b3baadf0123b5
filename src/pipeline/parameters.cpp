#include "dynamap/pipeline/parameters.hpp"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

namespace dynamap {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// Field access as doubles, one overload set per storage type.
template <class T>
double read(const T& field, int) noexcept {
  if constexpr (std::is_enum_v<T>) {
    return static_cast<double>(static_cast<int>(field));
  } else {
    return static_cast<double>(field);
  }
}
double read(const Eigen::Vector3f& field, int i) noexcept {
  return static_cast<double>(field[i]);
}
template <class T>
void write(T& field, int, double v) noexcept {
  if constexpr (std::is_enum_v<T>) {
    field = static_cast<T>(static_cast<int>(v));
  } else if constexpr (std::is_same_v<T, bool>) {
    field = v != 0.0;
  } else {
    field = static_cast<T>(v);  // callers check the value fits the type first
  }
}
void write(Eigen::Vector3f& field, int i, double v) noexcept {
  field[i] = static_cast<float>(v);
}

template <class T>
constexpr ParamKind kind_of() noexcept {
  if constexpr (std::is_same_v<T, Eigen::Vector3f>) return ParamKind::kVector3;
  if constexpr (std::is_same_v<T, bool>) return ParamKind::kBool;
  if constexpr (std::is_enum_v<T>) return ParamKind::kEnum;
  if constexpr (std::is_floating_point_v<T>) return ParamKind::kFloat;
  if constexpr (std::is_signed_v<T>) return ParamKind::kInt;
  return ParamKind::kCount;
}

// Path, kind and accessors of one PipelineConfig member, for the table below.
#define DYNAMAP_NAMED_FIELD(name, member)                                                     \
  name, kind_of<std::remove_reference_t<decltype(std::declval<PipelineConfig&>().member)>>(), \
      [](const PipelineConfig& c, int i) { return read(c.member, i); },                       \
      [](PipelineConfig& c, int i, double v) { write(c.member, i, v); }
#define DYNAMAP_FIELD(member) DYNAMAP_NAMED_FIELD(#member, member)

constexpr ParamTier U = ParamTier::kUser;
constexpr ParamTier C = ParamTier::kCapacity;
constexpr ParamTier X = ParamTier::kExpert;
constexpr bool kClosed = false;
constexpr bool kOpen = true;

constexpr ParamChoice kMotionModels[] = {
    {"cv", static_cast<int>(MotionModel::kConstantVelocity)},
    {"imm", static_cast<int>(MotionModel::kTurnImm)},
};

// Every field of PipelineConfig. Ranges are what every stage accepts (a value in range never
// makes a stage refuse its configuration); relations between fields are checked in validate().
constexpr Parameter kTable[] = {
    // clang-format off
    // Camera (the tools read it from the sequence's camera.txt).
    {DYNAMAP_FIELD(camera.fx), U, "px", 0, kInf, kOpen, kOpen, "focal length along image x"},
    {DYNAMAP_FIELD(camera.fy), U, "px", 0, kInf, kOpen, kOpen, "focal length along image y"},
    {DYNAMAP_FIELD(camera.cx), U, "px", -kInf, kInf, kOpen, kOpen, "principal point x"},
    {DYNAMAP_FIELD(camera.cy), U, "px", -kInf, kInf, kOpen, kOpen, "principal point y"},
    {DYNAMAP_FIELD(camera.width), U, "px", 1, kMaxImageWidth, kClosed, kClosed, "depth image width"},
    {DYNAMAP_FIELD(camera.height), U, "px", 1, kMaxImageHeight, kClosed, kClosed, "depth image height"},
    {DYNAMAP_FIELD(camera.depth_scale), U, "m", 0, kInf, kOpen, kOpen, "metres per depth unit (RealSense 0.001, TUM 1/5000)"},
    {DYNAMAP_FIELD(ground_height), U, "m", -kInf, kInf, kOpen, kOpen, "map-frame z of the floor: the refiner ignores and the cleaner never clears voxels below ground + refiner.floor_margin"},
    // Occupancy map.
    {DYNAMAP_FIELD(map.resolution), U, "m", kMinMapResolution, kMaxMapResolution, kClosed, kClosed, "voxel edge"},
    {DYNAMAP_FIELD(map.prob_hit), X, "", 0.5, 1, kOpen, kOpen, "occupancy probability of a hit"},
    {DYNAMAP_FIELD(map.prob_miss), X, "", 0, 0.5, kOpen, kOpen, "occupancy probability of a miss (ray passes through)"},
    {DYNAMAP_FIELD(map.prob_min), X, "", 0x1p-20, 0.5, kClosed, kOpen, "lower clamp of a voxel's probability"},
    {DYNAMAP_FIELD(map.prob_max), X, "", 0.5, 1, kOpen, kOpen, "upper clamp of a voxel's probability"},
    {DYNAMAP_FIELD(map.prob_occupied), X, "", 0, 1, kOpen, kOpen, "a voxel at or above this is occupied"},
    {DYNAMAP_FIELD(map.min_depth), X, "m", 0, kInf, kClosed, kOpen, "nearer measurements are dropped"},
    {DYNAMAP_FIELD(map.max_depth), U, "m", 0, kInf, kOpen, kOpen, "map range: deeper pixels carve free space up to this depth only"},
    {DYNAMAP_FIELD(map.no_return_free_depth), X, "m", 0, kInf, kClosed, kOpen, "0: a pixel with no measurement (0) is unknown; d > 0: 0 pixels inside large no-return regions (sky, a hall beyond range) carve free space up to d (<= map.max_depth)"},
    {DYNAMAP_FIELD(map.pixel_margin), X, "px", 0, kMaxImageHeight, kClosed, kClosed, "image border left out of the map update"},
    {DYNAMAP_FIELD(map.pixel_stride), C, "px", 1, kMaxImageWidth, kClosed, kClosed, "every n-th pixel of every n-th row is a ray"},
    {DYNAMAP_FIELD(map.local_half_extent), U, "m", 0, kInf, kOpen, kOpen, "only this box around the camera is updated (per axis, <= 1000 voxels)"},
    {DYNAMAP_FIELD(map.max_blocks), C, "", 1, kMaxMapBlocks, kClosed, kClosed, "voxel blocks the hashed grid may hold (memory is reserved for kMaxMapBlocks)"},
    {DYNAMAP_FIELD(map.max_rays_per_frame), C, "", 1, kMaxRaysPerFrame, kClosed, kClosed, "work cap: rays cast per frame"},
    {DYNAMAP_FIELD(map.max_voxel_visits_per_frame), C, "", 1, kMaxPipelineVoxelVisitsPerFrame, kClosed, kClosed, "work cap: voxel steps of all rays per frame"},
    {DYNAMAP_FIELD(map.merge_rays_per_voxel), X, "", 0, 1, kClosed, kClosed, "cast one ray per distinct end voxel instead of one per pixel"},
    {DYNAMAP_FIELD(map.free_ray_early_stop), X, "voxels", 0, kInf, kClosed, kOpen, "stop a free ray after this many voxels an earlier ray marked (0: exact walk)"},
    {DYNAMAP_FIELD(map.carve_tiles), X, "", 0, kMaxCarveTiles, kClosed, kClosed, "free-space carving in this many image column strips (0: one walk; the map depends on it, not on threads)"},
    {DYNAMAP_FIELD(map.threads), C, "", 1, kMaxMapThreads, kClosed, kClosed, "threads integrating a frame, the caller included (> 1 needs map.carve_tiles > 0)"},
    {DYNAMAP_FIELD(map.helper_fifo_priority), X, "", 0, 99, kClosed, kClosed, "SCHED_FIFO priority of the map's helper threads (0: the policy of the thread calling init())"},
    {DYNAMAP_FIELD(map.helper_first_cpu), X, "", -1, kMaxCpuIndex, kClosed, kClosed, "pin map helper m to CPU helper_first_cpu + m - 1 (-1: no pinning)"},
    // Detector.
    {DYNAMAP_FIELD(detector.bins), X, "", 1, kMaxUMapBins, kClosed, kClosed, "U-map depth bins over [d_min, d_max]"},
    {DYNAMAP_FIELD(detector.d_min), X, "m", 0, kInf, kClosed, kOpen, "nearer depths are not counted in the U-map"},
    {DYNAMAP_FIELD(detector.d_max), U, "m", 0, kInf, kOpen, kOpen, "detection range: farther depths are not counted"},
    {DYNAMAP_FIELD(detector.smoothing_radius), X, "bins", 0, kMaxUMapSmoothingRadius, kClosed, kClosed, "U-map cells are tested on the sum over +-r bins (0: off)"},
    {DYNAMAP_FIELD(detector.count_threshold), X, "px", 1, 65535, kClosed, kClosed, "pixels a U-map cell needs to be a point"},
    {DYNAMAP_FIELD(detector.min_point_height), X, "m", 0, kInf, kClosed, kOpen, "surface height a U-map cell must show to be a point"},
    {DYNAMAP_FIELD(detector.min_segment_length), X, "columns", 1, kMaxImageWidth, kClosed, kClosed, "shorter runs of points are ignored"},
    {DYNAMAP_FIELD(detector.min_area), X, "cells", 1, kInf, kClosed, kOpen, "smaller point groups are dropped"},
    {DYNAMAP_FIELD(detector.band_factor), X, "", 1, 10, kClosed, kClosed, "depth band [near, near + factor x extent] of a group's pixels"},
    {DYNAMAP_FIELD(detector.max_candidates), C, "", 1, kInf, kClosed, kOpen, "work cap: height searches per frame, nearest groups first"},
    {DYNAMAP_FIELD(detector.max_detections), C, "", 1, kMaxDetections, kClosed, kClosed, "detections per frame"},
    {DYNAMAP_FIELD(detector.row_fill_fraction), X, "", 0, 1, kClosed, kClosed, "share of a group's columns a row needs to count in the height search"},
    {DYNAMAP_FIELD(detector.max_row_gap), X, "rows", 0, kMaxImageHeight, kClosed, kClosed, "gaps bridged in the height search"},
    {DYNAMAP_FIELD(detector.min_run_rows), X, "rows", 1, kMaxImageHeight, kClosed, kClosed, "shortest vertical run that is an object"},
    {DYNAMAP_FIELD(detector.max_width_fraction), X, "", 0, 1, kOpen, kClosed, "groups this wide a share of the image are background"},
    {DYNAMAP_FIELD(detector.max_width), X, "m", 0, kInf, kOpen, kOpen, "wider groups are background"},
    {DYNAMAP_FIELD(detector.max_height), X, "m", 0, kInf, kOpen, kOpen, "taller groups are background"},
    {DYNAMAP_FIELD(detector.max_depth_extent), X, "m", 0, kInf, kOpen, kOpen, "groups deeper than this are background (a wall at a grazing angle)"},
    {DYNAMAP_FIELD(detector.use_fast_histogram), X, "", 0, 1, kClosed, kClosed, "NEON/vectorised U-map histogram (false: scalar reference)"},
    {DYNAMAP_FIELD(detector.use_fast_measure), X, "", 0, 1, kClosed, kClosed, "vectorisable height search and box sums (false: per-pixel reference loops)"},
    // Refiner.
    {DYNAMAP_FIELD(refiner.inflate), X, "", 1, 10, kClosed, kClosed, "raw box extents are grown by this before the map search"},
    {DYNAMAP_FIELD(refiner.floor_margin), X, "m", 0, kInf, kClosed, kOpen, "voxels below ground_height + this are floor"},
    {DYNAMAP_FIELD(refiner.max_voxels_per_box), C, "", 1, kMaxRefinerVoxelsPerBox, kClosed, kClosed, "work cap: voxels examined per box and pass"},
    {DYNAMAP_FIELD(refiner.min_support_voxels), X, "", 1, kInf, kClosed, kOpen, "fewer occupied voxels keep the raw box"},
    {DYNAMAP_FIELD(refiner.static_frames), X, "frames", 0, kMaxStaticFrames, kClosed, kClosed, "a voxel occupied this long counts as long-seen for Detection::static_share"},
    // Tracker: Kalman filter.
    {DYNAMAP_FIELD(tracker.kalman.p0_position), X, "m^2", 0, kInf, kOpen, kOpen, "initial position variance"},
    {DYNAMAP_FIELD(tracker.kalman.p0_velocity), X, "(m/s)^2", 0, kInf, kOpen, kOpen, "initial velocity variance"},
    {DYNAMAP_FIELD(tracker.kalman.q_position), X, "m^2", 0, kInf, kOpen, kOpen, "position process noise per reference interval (cv)"},
    {DYNAMAP_FIELD(tracker.kalman.q_velocity), X, "(m/s)^2", 0, kInf, kOpen, kOpen, "velocity process noise per reference interval (cv)"},
    {DYNAMAP_FIELD(tracker.kalman.r_position), X, "m^2", 0, kInf, kOpen, kOpen, "position measurement variance"},
    {DYNAMAP_FIELD(tracker.kalman.r_velocity), X, "(m/s)^2", 0, kInf, kOpen, kOpen, "velocity measurement variance (cv)"},
    {DYNAMAP_FIELD(tracker.kalman.q_reference_dt), X, "s", 0, kInf, kOpen, kOpen, "interval q_position and q_velocity refer to"},
    {DYNAMAP_FIELD(tracker.kalman.model), X, "", 0, 1, kClosed, kClosed, "motion model: cv (original) or imm (adds the coordinated turn)", kMotionModels, 2},
    {DYNAMAP_FIELD(tracker.kalman.imm.q_accel_straight), X, "m^2/s^3", 0, kInf, kOpen, kOpen, "acceleration noise density of the straight mode"},
    {DYNAMAP_FIELD(tracker.kalman.imm.q_accel_turn), X, "m^2/s^3", 0, kInf, kOpen, kOpen, "acceleration noise density of the turn mode"},
    {DYNAMAP_FIELD(tracker.kalman.imm.q_turn_rate), X, "rad^2/s^3", 0, kInf, kOpen, kOpen, "turn-rate noise density of the turn mode"},
    {DYNAMAP_FIELD(tracker.kalman.imm.p0_turn_rate), X, "rad^2/s^2", 0, kInf, kOpen, kOpen, "initial turn-rate variance"},
    {DYNAMAP_FIELD(tracker.kalman.imm.max_turn_rate), X, "rad/s", 0, kInf, kOpen, kOpen, "turn rate clamp"},
    {DYNAMAP_FIELD(tracker.kalman.imm.mean_straight_time), X, "s", 0, kInf, kOpen, kOpen, "expected stay in the straight mode"},
    {DYNAMAP_FIELD(tracker.kalman.imm.mean_turn_time), X, "s", 0, kInf, kOpen, kOpen, "expected stay in the turn mode"},
    // Tracker: continuity filter and votes.
    {DYNAMAP_FIELD(tracker.continuity.displacement_frames), X, "frames", 1, kMaxTrackHistory, kClosed, kClosed, "n: displacements span n history states"},
    {DYNAMAP_FIELD(tracker.continuity.continuity_threshold), X, "", -kInf, kInf, kOpen, kOpen, "T_con: mean cosine of successive displacements that votes dynamic"},
    {DYNAMAP_FIELD(tracker.continuity.min_speed), U, "m/s", -kInf, kInf, kOpen, kOpen, "slower obstacles vote static"},
    {DYNAMAP_FIELD(tracker.continuity.vote_window), X, "frames", 1, kMaxVoteWindow, kClosed, kClosed, "c: votes kept"},
    {DYNAMAP_FIELD(tracker.continuity.dynamic_votes), X, "", 1, kMaxVoteWindow, kClosed, kClosed, "T_c: this many dynamic votes of c label dynamic"},
    {DYNAMAP_FIELD(tracker.continuity.static_votes), X, "", 0, kMaxVoteWindow, kClosed, kClosed, "this many or fewer dynamic votes label static"},
    {DYNAMAP_FIELD(tracker.continuity.check_size), X, "", 0, 1, kClosed, kClosed, "only obstacles within [min_size, max_size] vote dynamic"},
    {DYNAMAP_FIELD(tracker.continuity.min_size), U, "m", 0, kInf, kClosed, kOpen, "smallest box (x, y, z) that may vote dynamic"},
    {DYNAMAP_FIELD(tracker.continuity.max_size), U, "m", 0, kInf, kClosed, kOpen, "largest box (x, y, z) that may vote dynamic"},
    // Tracker: association and track life.
    {DYNAMAP_FIELD(tracker.overlap_threshold), X, "", 0, 1, kOpen, kClosed, "top-view overlap share that pairs a detection with a track"},
    {DYNAMAP_FIELD(tracker.centre_gate), X, "m", 0, kInf, kClosed, kOpen, "or a top-view centre distance below this"},
    {DYNAMAP_FIELD(tracker.max_missed_frames), X, "frames", 0, kInf, kClosed, kOpen, "frames a track coasts unmeasured before it is dropped"},
    {DYNAMAP_FIELD(tracker.max_coast_time), X, "s", 0, kInf, kOpen, kOpen, "a track unmeasured this long is dropped whatever the frame count"},
    {DYNAMAP_FIELD(tracker.history_length), X, "frames", 2, kMaxTrackHistory - 1, kClosed, kClosed, "k: positions kept for the continuity filter"},
    {DYNAMAP_FIELD(tracker.box_history_length), X, "frames", 1, kMaxBoxHistory, kClosed, kClosed, "f: past boxes kept for the cleaner"},
    {DYNAMAP_FIELD(tracker.size_fix_frames), X, "frames", 1, kInf, kClosed, kOpen, "k': frames fully in view before the size is frozen"},
    {DYNAMAP_FIELD(tracker.image_margin), X, "px", 0, kMaxImageHeight, kClosed, kClosed, "an image box this close to the border is cut, not fully in view"},
    {DYNAMAP_FIELD(tracker.size_fix_max_depth), X, "m", 0, kInf, kOpen, kOpen, "only nearer detections count towards the frozen size"},
    {DYNAMAP_FIELD(tracker.noise_reference_depth), X, "m", 0, kInf, kClosed, kOpen, "measurement noise grows with (depth / this)^4 beyond it (0: off)"},
    {DYNAMAP_FIELD(tracker.correct_near_surface_bias), X, "", 0, 1, kClosed, kClosed, "move box centres back by half their missing depth"},
    {DYNAMAP_FIELD(tracker.max_extent_change_ratio), X, "", -kInf, kInf, kOpen, kOpen, "rigid-motion test of the vote (negative: off)"},
    {DYNAMAP_FIELD(tracker.max_round_footprint), X, "m", 0, kInf, kClosed, kOpen, "bias correction only for footprints up to this long (0: no limit)"},
    {DYNAMAP_FIELD(tracker.label.early_votes), X, "", 0, kMaxVoteWindow, kClosed, kClosed, "this many consecutive dynamic votes label dynamic early (0: off)"},
    {DYNAMAP_FIELD(tracker.label.dynamic_hold_frames), X, "frames", 0, 100000, kClosed, kClosed, "a confirmed dynamic track keeps its label this long after its votes turn static (0: off)"},
    {DYNAMAP_FIELD(tracker.label.hold_min_dynamic_frames), X, "frames", 1, 100000, kClosed, kClosed, "frames labelled dynamic before the hold applies"},
    {DYNAMAP_FIELD(tracker.early_displacement_frames), X, "frames", 0, kMaxTrackHistory, kClosed, kClosed, "displacement span of the early votes (0: no early votes)"},
    {DYNAMAP_FIELD(tracker.size_fix_growth), X, "", 0, 1, kClosed, kClosed, "raise a frozen size to a larger window mean"},
    {DYNAMAP_FIELD(tracker.measure_raw_box), X, "", 0, 1, kClosed, kClosed, "measure from the detector's box, not the map-refined one"},
    {DYNAMAP_FIELD(tracker.compensate_size_steps), X, "", 0, 1, kClosed, kClosed, "keep a step of the frozen size from reading as motion"},
    {DYNAMAP_FIELD(tracker.compensate_cut_footprint), X, "", 0, 1, kClosed, kClosed, "keep the growing footprint of a border-cut detection from reading as motion"},
    {DYNAMAP_FIELD(tracker.label.ever_free_frames), X, "frames", 0, kMaxVoteWindow, kClosed, kClosed, "detections in ever-free space in a row that label a track dynamic (0: off)"},
    {DYNAMAP_FIELD(tracker.ever_free_share), X, "", 0, 1, kOpen, kClosed, "share of a detection's surface cells that must be ever free"},
    {DYNAMAP_FIELD(tracker.max_static_share), X, "", 0, 1, kClosed, kClosed, "detections with more of their voxels long occupied vote static (1: off)"},
    // Fragment joining (detection_refiner.hpp).
    {DYNAMAP_FIELD(fragments.join_fragments), X, "", 0, 1, kClosed, kClosed, "join the detector's fragments of one obstacle"},
    {DYNAMAP_FIELD(fragments.max_gap), X, "m", -kInf, 1, kOpen, kClosed, "largest top-view gap between joined boxes (negative: must overlap)"},
    {DYNAMAP_FIELD(fragments.max_footprint), X, "m", 0, 5, kOpen, kClosed, "largest horizontal side of a joined box"},
    {DYNAMAP_FIELD(fragments.split_groups), X, "", 0, 1, kClosed, kClosed, "split detections that hold several people (side by side, one behind the other)"},
    {DYNAMAP_FIELD(fragments.split_width), X, "m", 0.1, 5, kClosed, kClosed, "only detections wider than this across the view are split side by side"},
    {DYNAMAP_FIELD(fragments.split_min_part), X, "m", 0.05, 2, kClosed, kClosed, "each side of a split across the view is at least this wide"},
    {DYNAMAP_FIELD(fragments.split_dip), X, "", 0, 1, kClosed, kClosed, "split where the pixels per column fall to this share of the lower peak beside"},
    {DYNAMAP_FIELD(fragments.split_depth_gap), X, "m", 0.1, 2, kClosed, kClosed, "an empty stretch of depth this long along the ray splits near from far"},
    // Ever-free grid (ever_free_grid.hpp): space the camera has observed free.
    {DYNAMAP_FIELD(ever_free.enabled), X, "", 0, 1, kClosed, kClosed, "keep the ever-free grid and use it as dynamic evidence"},
    {DYNAMAP_FIELD(ever_free.resolution), X, "m", 0.05, 1, kClosed, kClosed, "cell edge"},
    {DYNAMAP_FIELD(ever_free.z_min), X, "m", -10, 10, kClosed, kClosed, "bottom of the lowest layer above the ground"},
    {DYNAMAP_FIELD(ever_free.layers), C, "", 1, kEverFreeMaxLayers, kClosed, kClosed, "vertical layers"},
    {DYNAMAP_FIELD(ever_free.pixel_step), C, "px", 1, 64, kClosed, kClosed, "one ray every this many pixels in u and v"},
    {DYNAMAP_FIELD(ever_free.max_range), X, "m", 0, 20, kOpen, kClosed, "rays are walked at most this far"},
    {DYNAMAP_FIELD(ever_free.surface_margin), X, "m", 0, kInf, kClosed, kOpen, "free marking stops this far short of the surface"},
    {DYNAMAP_FIELD(ever_free.margin_per_range2), X, "1/m", 0, kInf, kClosed, kOpen, "plus this times range^2"},
    {DYNAMAP_FIELD(ever_free.burn_in_frames), X, "frames", 1, 255, kClosed, kClosed, "observed-free frames in a row to become ever free"},
    {DYNAMAP_FIELD(ever_free.forget_frames), X, "frames", 1, 255, kClosed, kClosed, "hit frames in a row to stop being ever free"},
    // Cleaner and its history.
    {DYNAMAP_FIELD(cleaner.frames), X, "frames", 1, kMaxBoxHistory, kClosed, kClosed, "f: past boxes per dynamic track that are cleared"},
    {DYNAMAP_FIELD(cleaner.inflation), X, "", 1, kInf, kClosed, kOpen, "horizontal growth of a cleared box about its centre"},
    {DYNAMAP_FIELD(cleaner.z_margin), X, "m", 0, kInf, kClosed, kOpen, "added below and above a cleared box"},
    {DYNAMAP_FIELD(cleaner.older_boxes_per_frame), X, "", 0, kMaxBoxHistory, kClosed, kClosed, "older boxes revisited per track and frame"},
    {DYNAMAP_FIELD(cleaner.keep_static), X, "", 0, 1, kClosed, kClosed, "never clear voxels occupied since before a dynamic track started (static structure)"},
    {DYNAMAP_FIELD(cleaner.static_margin_frames), X, "frames", 0, 100000, kClosed, kClosed, "occupied this many frames before the track started counts as static"},
    {DYNAMAP_FIELD(cleaner.max_voxels_per_frame), C, "", 1, kMaxCleanerVoxelsPerFrame, kClosed, kClosed, "work cap: voxels examined per frame"},
    {DYNAMAP_FIELD(cleaner.max_purge_per_frame), C, "", 1, kCleanHistoryCapacity, kClosed, kClosed, "work cap: expired history entries purged per frame"},
    {DYNAMAP_FIELD(clean_history_max_age_ns), X, "ns", 0, kInf, kClosed, kOpen, "cleared voxels count as occupied this long for the refiner"},
    // Predictor: path library.
    {DYNAMAP_FIELD(predictor.paths.num_paths), C, "", 1, kMaxPaths, kClosed, kClosed, "l: paths in the library"},
    {DYNAMAP_FIELD(predictor.paths.max_heading_change), X, "rad", 0, static_cast<double>(3.14159265358979f), kClosed, kClosed, "heading change of the outermost paths"},
    {DYNAMAP_FIELD(predictor.paths.turn_curvature), X, "1/m", 0, kInf, kOpen, kOpen, "curvature while turning"},
    {DYNAMAP_FIELD(predictor.paths.horizon_distance), U, "m", 0, kInf, kOpen, kOpen, "prediction horizon: travel at the current speed"},
    {DYNAMAP_FIELD(predictor.paths.slow_speed), X, "m/s", 0, kInf, kClosed, kOpen, "slower obstacles are predicted for slow_horizon_time instead"},
    {DYNAMAP_FIELD(predictor.paths.slow_horizon_time), X, "s", 0, kInf, kOpen, kOpen, "horizon of slow obstacles"},
    {DYNAMAP_FIELD(predictor.paths.sample_interval), X, "s", 0, kInf, kOpen, kOpen, "upper bound on the time between path samples"},
    // Predictor: clearance sweep.
    {DYNAMAP_FIELD(predictor.clearance.line_spacing), X, "m", 0, kInf, kOpen, kOpen, "spacing of the swept lines across the footprint"},
    {DYNAMAP_FIELD(predictor.clearance.max_lines), C, "", 1, kMaxClearanceLines, kClosed, kClosed, "work cap: swept lines per path"},
    {DYNAMAP_FIELD(predictor.clearance.height_levels), C, "", 1, kMaxHeightLevels, kClosed, kClosed, "heights swept per line"},
    {DYNAMAP_FIELD(predictor.clearance.chord_tolerance), X, "m", 0, kInf, kClosed, kOpen, "a merged chord may leave the path by this much"},
    {DYNAMAP_FIELD(predictor.clearance.ground_clearance), X, "m", 0, kInf, kClosed, kOpen, "height above the box bottom not checked (floor voxels)"},
    {DYNAMAP_FIELD(predictor.clearance.self_margin), X, "m", 0, kInf, kClosed, kOpen, "space around the obstacle's own body not checked"},
    {DYNAMAP_FIELD(predictor.clearance.self_range_margin), X, "m/m^2", 0, kInf, kClosed, kOpen, "added to self_margin per squared m of the obstacle's range"},
    // Predictor: Markov chain.
    {DYNAMAP_FIELD(predictor.sigma_init), X, "rad", 0, kInf, kOpen, kOpen, "spread of the initial belief around the straight path"},
    {DYNAMAP_FIELD(predictor.sigma_trans), X, "rad", 0, kInf, kOpen, kOpen, "spread of each transition row around its diagonal"},
    {DYNAMAP_FIELD(predictor.beta), X, "1/m", 0, kInf, kClosed, kOpen, "P_env = softmax(beta x free distance); 0 ignores the map"},
    {DYNAMAP_FIELD(predictor.choose_free), X, "", 0, 1, kClosed, kClosed, "output the likeliest path that is free in the map"},
    {DYNAMAP_FIELD(predictor.straight_when_free), X, "", 0, 1, kClosed, kClosed, "output the straight path whenever it is free and no path is better supported"},
    // Far-field layer (the predictor's memory of walls beyond the map's range).
    {DYNAMAP_FIELD(far_field.enabled), X, "", 0, 1, kClosed, kClosed, "update the far-field layer and let the predictor use it"},
    {DYNAMAP_FIELD(far_field.cell_size), X, "m", 0.05, 1, kClosed, kClosed, "grid cell and range bin"},
    {DYNAMAP_FIELD(far_field.max_range), U, "m", 0, 25, kOpen, kClosed, "horizontal range of the pixels used (the camera's useful range)"},
    {DYNAMAP_FIELD(far_field.hit_min_range), X, "m", 0, kInf, kClosed, kOpen, "nearer surfaces are the map's"},
    {DYNAMAP_FIELD(far_field.min_height), X, "m", -kInf, kInf, kOpen, kOpen, "above ground_height: lower pixels are floor"},
    {DYNAMAP_FIELD(far_field.max_height), X, "m", -kInf, kInf, kOpen, kOpen, "above ground_height: higher pixels are ceiling"},
    {DYNAMAP_FIELD(far_field.wall_height), X, "m", -kInf, kInf, kOpen, kOpen, "above ground_height a surface must reach to be a wall"},
    {DYNAMAP_FIELD(far_field.noise_margin), X, "m", 0, kInf, kClosed, kOpen, "constant part of the range noise sigma(d)"},
    {DYNAMAP_FIELD(far_field.noise_quadratic), X, "1/m", 0, kInf, kClosed, kOpen, "quadratic part of the range noise sigma(d)"},
    {DYNAMAP_FIELD(far_field.pixel_stride), C, "px", 1, 16, kClosed, kClosed, "sampled columns and rows"},
    {DYNAMAP_FIELD(far_field.min_pixels), X, "px", 1, kInf, kClosed, kOpen, "pixels in a column's noise window to accept a surface"},
    {DYNAMAP_FIELD(far_field.hit_evidence), X, "", 1, 100, kClosed, kClosed, "added per frame a cell is hit"},
    {DYNAMAP_FIELD(far_field.free_evidence), X, "", 0, 100, kClosed, kClosed, "removed per frame a ray passes a cell"},
    {DYNAMAP_FIELD(far_field.max_evidence), X, "", 1, 127, kClosed, kClosed, "evidence clamp"},
    {DYNAMAP_FIELD(far_field.memory_frames), X, "frames", 1, kInf, kClosed, kOpen, "a wall is forgotten this many frames after its last hit"},
    {DYNAMAP_FIELD(run_linear_baseline), X, "", 0, 1, kClosed, kClosed, "also run the constant-velocity predictor (the evaluation's yardstick)"},
    // Budgets.
    {DYNAMAP_FIELD(budgets.frame_ns), U, "ns", 0, kInf, kClosed, kOpen, "whole-frame time budget (0: none)"},
    {DYNAMAP_NAMED_FIELD("budgets.stage_ns.occupancy", budgets.stage_ns[0]), U, "ns", 0, kInf, kClosed, kOpen, "occupancy stage budget (0: none)"},
    {DYNAMAP_NAMED_FIELD("budgets.stage_ns.detection", budgets.stage_ns[1]), U, "ns", 0, kInf, kClosed, kOpen, "detection stage budget (0: none)"},
    {DYNAMAP_NAMED_FIELD("budgets.stage_ns.refinement", budgets.stage_ns[2]), U, "ns", 0, kInf, kClosed, kOpen, "refinement stage budget (0: none)"},
    {DYNAMAP_NAMED_FIELD("budgets.stage_ns.tracking", budgets.stage_ns[3]), U, "ns", 0, kInf, kClosed, kOpen, "tracking stage budget (0: none)"},
    {DYNAMAP_NAMED_FIELD("budgets.stage_ns.cleaning", budgets.stage_ns[4]), U, "ns", 0, kInf, kClosed, kOpen, "cleaning stage budget (0: none)"},
    {DYNAMAP_NAMED_FIELD("budgets.stage_ns.prediction", budgets.stage_ns[5]), U, "ns", 0, kInf, kClosed, kOpen, "prediction stage budget (0: none)"},
    {DYNAMAP_NAMED_FIELD("budgets.stage_ns.far_field", budgets.stage_ns[6]), U, "ns", 0, kInf, kClosed, kOpen, "far-field layer stage budget (0: none)"},
    {DYNAMAP_FIELD(budgets.adaptive_stride), U, "", 0, 1, kClosed, kClosed, "coarsen the map's pixel stride when the occupancy stage overruns"},
    {DYNAMAP_FIELD(budgets.max_pixel_stride), C, "px", 1, kMaxImageWidth, kClosed, kClosed, "coarsest stride the adaptive mode may use"},
    {DYNAMAP_FIELD(budgets.restore_fraction), X, "", 0, 1, kOpen, kOpen, "restore a finer stride below this share of the budget"},
    // clang-format on
};

#undef DYNAMAP_FIELD
#undef DYNAMAP_NAMED_FIELD

constexpr std::size_t kTableSize = sizeof(kTable) / sizeof(kTable[0]);

constexpr bool same(const char* a, const char* b) noexcept {
  while (*a != '\0' && *a == *b) {
    ++a;
    ++b;
  }
  return *a == *b;
}

constexpr bool paths_unique() noexcept {
  for (std::size_t i = 0; i < kTableSize; ++i) {
    for (std::size_t j = i + 1; j < kTableSize; ++j) {
      if (same(kTable[i].path, kTable[j].path)) return false;
    }
  }
  return true;
}
static_assert(paths_unique(), "every parameter path appears once in the table");
static_assert(kStageCount == 7, "every stage has a budgets.stage_ns.<stage> row in the table");

// "12", "0.01", "1e+06": short, exact enough for a range.
int print_number(char* buf, std::size_t size, double v) noexcept {
  return std::snprintf(buf, size, "%.6g", v);
}

}  // namespace

bool Parameter::in_range(double v) const noexcept {
  if (!std::isfinite(v)) return false;
  if (min_open ? !(v > min) : !(v >= min)) return false;
  if (max_open ? !(v < max) : !(v <= max)) return false;
  if (kind == ParamKind::kEnum) {
    for (std::size_t i = 0; i < choice_count; ++i) {
      if (static_cast<double>(choices[i].value) == v) return true;
    }
    return false;
  }
  return true;
}

const char* Parameter::range_text(char* buf, std::size_t size) const noexcept {
  if (size == 0) return buf;
  buf[0] = '\0';
  std::size_t at = 0;
  const auto put = [&](int n) {
    at = n < 0 ? at : std::min(size - 1, at + static_cast<std::size_t>(n));
  };
  if (kind == ParamKind::kBool) {
    put(std::snprintf(buf, size, "true or false"));
    return buf;
  }
  if (kind == ParamKind::kEnum) {
    for (std::size_t i = 0; i < choice_count; ++i) {
      put(std::snprintf(buf + at, size - at, "%s%s",
                        i == 0                  ? ""
                        : i + 1 == choice_count ? " or "
                                                : ", ",
                        choices[i].name));
    }
    return buf;
  }
  const bool lo = std::isfinite(min);
  const bool hi = std::isfinite(max);
  if (lo && hi) {
    put(std::snprintf(buf, size, "%c", min_open ? '(' : '['));
    put(print_number(buf + at, size - at, min));
    put(std::snprintf(buf + at, size - at, ", "));
    put(print_number(buf + at, size - at, max));
    put(std::snprintf(buf + at, size - at, "%c", max_open ? ')' : ']'));
  } else if (lo) {
    put(std::snprintf(buf, size, "%s ", min_open ? ">" : ">="));
    put(print_number(buf + at, size - at, min));
  } else if (hi) {
    put(std::snprintf(buf, size, "%s ", max_open ? "<" : "<="));
    put(print_number(buf + at, size - at, max));
  } else {
    put(std::snprintf(buf, size, "finite"));
  }
  if (unit[0] != '\0' && (lo || hi)) put(std::snprintf(buf + at, size - at, " %s", unit));
  return buf;
}

ParameterTable parameters() noexcept {
  return ParameterTable{kTable, kTableSize};
}

const Parameter* find_parameter(const char* path) noexcept {
  if (path == nullptr) return nullptr;
  for (const Parameter& p : kTable) {
    if (std::strcmp(p.path, path) == 0) return &p;
  }
  return nullptr;
}

const char* to_string(ParamTier tier) noexcept {
  switch (tier) {
    case ParamTier::kUser:
      return "user";
    case ParamTier::kCapacity:
      return "capacity";
    case ParamTier::kExpert:
      return "expert";
  }
  return "?";
}

ConfigError check_ranges(const PipelineConfig& config) noexcept {
  for (const Parameter& p : kTable) {
    for (int i = 0; i < p.components(); ++i) {
      const double v = p.get(config, i);
      if (!p.in_range(v)) {
        ConfigError e{Status::kInvalidArgument, p.path, "outside its valid range"};
        e.parameter = &p;
        e.value = v;
        return e;
      }
    }
  }
  return ConfigError{};
}

const char* describe(const ConfigError& e, char* buf, std::size_t size) noexcept {
  if (size == 0) return buf;
  if (e.ok()) {
    std::snprintf(buf, size, "ok");
  } else if (e.parameter != nullptr) {
    char range[96];
    char value[32];
    if (e.parameter->kind == ParamKind::kEnum || e.parameter->kind == ParamKind::kBool) {
      std::snprintf(value, sizeof value, "%d", static_cast<int>(e.value));
    } else {
      print_number(value, sizeof value, e.value);
    }
    std::snprintf(buf, size, "%s = %s: must be %s%s", e.field, value,
                  std::isfinite(e.parameter->min) && std::isfinite(e.parameter->max) &&
                          e.parameter->kind != ParamKind::kEnum
                      ? "in "
                      : "",
                  e.parameter->range_text(range, sizeof range));
  } else {
    std::snprintf(buf, size, "%s: %s", e.field, e.reason);
  }
  return buf;
}

}  // namespace dynamap
