#include "dynamap/pipeline/pipeline.hpp"

#include <cmath>

#include "dynamap/platform/clock.hpp"

namespace dynamap {
namespace {

std::uint64_t platform_clock() {
  return platform::monotonic_ns();
}

constexpr std::size_t idx(Stage s) noexcept {
  return static_cast<std::size_t>(s);
}

// A dynamic track's input to the predictors: centre, top-view velocity and the footprint.
ObstacleState predictor_input(const TrackedObstacle& o) noexcept {
  ObstacleState s;
  s.track_id = o.id;
  s.position = o.box.center();
  s.velocity = o.velocity.head<2>();
  const Eigen::Vector3f size = o.box.size();
  s.footprint_radius = 0.5f * std::fmax(size.x(), size.y());
  s.height = size.z();
  return s;
}

}  // namespace

Pipeline::Clock Pipeline::default_clock() noexcept {
  return &platform_clock;
}

Status Pipeline::init(const PipelineConfig& config, ConfigError* error) noexcept {
  const ConfigError e = validate(config);
  if (error != nullptr) *error = e;
  if (!e.ok()) return e.status;

  // Stages validate their own configuration; the first refusal is reported. The camera size
  // and the ground height are the pipeline's fields, handed to the stages that need them.
  const float floor_top = config.ground_height + config.refiner.floor_margin;
  Status s = start_team(config.team);
  if (ok(s)) s = map_.init(config.map);
  if (ok(s)) s = detector_.init(config.detector);
  if (ok(s)) s = fragments_.init(config.fragments, floor_top);
  if (ok(s)) s = refiner_.init(config.refiner, config.ground_height);
  if (ok(s)) s = tracker_.init(config.tracker, config.camera.width, config.camera.height);
  if (ok(s)) s = history_.init(config.clean_history_max_age_ns);
  if (ok(s)) s = cleaner_.init(config.cleaner, floor_top);
  if (ok(s)) s = ever_free_.init(config.ever_free, config.ground_height);
  if (ok(s)) s = trail_.init(config.trail);
  if (ok(s)) map_.set_trail(&trail_);
  if (ok(s)) s = markov_.init(config.predictor);
  if (ok(s)) s = far_field_.init(config.far_field, config.ground_height);
  if (ok(s)) {
    LinearPredictorConfig lc;
    lc.paths = config.predictor.paths;
    lc.clearance = config.predictor.clearance;
    s = linear_.init(lc);
  }
  if (!ok(s)) {
    initialized_ = false;
    // A thread the OS refused is the only refusal validate() cannot foresee.
    if (s == Status::kPermissionDenied || s == Status::kSystemError) {
      if (error != nullptr) *error = ConfigError{s, "team", "the OS refused a helper thread"};
      return s;
    }
    // validate() accepts only what every stage accepts (test_parameters): this is a bug.
    if (error != nullptr) {
      *error = ConfigError{s, "pipeline", "a stage refused a configuration validate() accepted"};
    }
    return s;
  }

  config_ = config;
  pixel_stride_ = config.map.pixel_stride;
  has_stamp_ = false;
  last_stamp_ = 0;
  counters_ = PipelineCounters{};
  for (std::size_t i = 0; i < kStageCount; ++i) {
    stage_stats_[i].set_budget_ns(config.budgets.stage_ns[i]);
  }
  frame_stats_.set_budget_ns(config.budgets.frame_ns);
  reset_timing();
  initialized_ = true;
  return Status::kOk;
}

Status Pipeline::start_team(const TeamConfig& c) noexcept {
  if (team_.size() == static_cast<unsigned>(c.members) &&
      team_options_.helper_fifo_priority == c.helper_fifo_priority &&
      team_options_.helper_first_cpu == c.helper_first_cpu) {
    return Status::kOk;
  }
  team_.stop();
  platform::ThreadOptions options{};
  options.name = "dynamap-team";
  options.fifo_priority = c.helper_fifo_priority;
  options.cpu = c.helper_first_cpu;
  team_options_ = c;
  return team_.start(static_cast<unsigned>(c.members), options);
}

void Pipeline::reset_timing() noexcept {
  for (auto& st : stage_stats_) st.reset();
  frame_stats_.reset();
}

Status Pipeline::check_frame(const Frame& frame) const noexcept {
  if (!initialized_) return Status::kNotInitialized;
  Status s = validate_depth(frame.depth, config_.camera);
  if (!ok(s)) return s;
  s = validate_pose(frame.T_map_camera);
  if (!ok(s)) return s;
  // A finite pose beyond the map's key range cannot be integrated (and the other stages' float
  // geometry degrades there): the whole frame is refused, not just its map update.
  s = map_.check_pose_range(frame.T_map_camera);
  if (!ok(s)) return s;
  if (has_stamp_ && frame.stamp <= last_stamp_) return Status::kTimeNotIncreasing;
  return Status::kOk;
}

Status Pipeline::reject(const Frame& frame, Status why, FrameOutput& out) noexcept {
  if (initialized_) ++counters_.frames_rejected;
  out.status = why;
  out.stamp = frame.stamp;
  out.counters = counters_;
  return why;
}

Status Pipeline::process(const Frame& frame, FrameOutput& out) noexcept {
  // Every check happens before any stage runs, so a rejected frame changes nothing.
  const Status bad = check_frame(frame);
  if (!ok(bad)) return reject(frame, bad, out);
  FrameClock clock;
  clock.start = clock.prev = clock_();
  FrameWork work;
  // With a team, detection runs beside the map's carving: it reads only the frame and its own
  // state, so the outputs are the same; its stage time is then its own duration, inside the
  // occupancy stage's (docs/pipeline.md, "Threads").
  DetectionJob job{};
  job.pipeline = this;
  job.frame = &frame;
  job.work = &work;
  const bool on_team = team_.size() > 1;
  const Status map_status = integrate(frame, work, on_team ? &job : nullptr);
  if (!ok(map_status)) return reject(frame, map_status, out);
  lap(Stage::kOccupancy, clock);
  if (on_team) {
    const std::uint64_t start = clock_();
    if (step_ok(job.ever_free_status, work)) {
      ever_free_.annotate(detections_.data(), detections_.size());
    }
    const std::uint64_t annotated = clock_();
    record_stage(Stage::kDetection, job.ns[0] + job.ns[1] + (annotated - start), clock);
    clock.prev = annotated;
  } else {
    detect(frame, work);
    lap(Stage::kDetection, clock);
  }
  // Map refinement against the occupancy map and the clean history.
  const VoxelLookup cleaned{&history_, &CleanHistory::contains_thunk};
  if (step_ok(refiner_.refine(map_, cleaned, detections_), work)) {
    work.refined = refiner_.last_stats().refined;
  }
  lap(Stage::kRefinement, clock);
  track(frame, work);
  lap(Stage::kTracking, clock);
  clean(frame, work);
  lap(Stage::kCleaning, clock);
  // Prediction for dynamic tracks, after the far-field layer has taken this frame's far pixels.
  const std::size_t n_dyn = collect_dynamic(frame);
  const FarFieldLayer* far = update_far_field(frame, n_dyn, work);
  lap(Stage::kFarField, clock);
  out.num_predictions = predict(n_dyn, far, work, out);
  work.predictions = out.num_predictions;
  lap(Stage::kPrediction, clock);
  finish(frame, clock, work, out);
  return Status::kOk;
}

void Pipeline::lap(Stage stage, FrameClock& clock) noexcept {
  const std::uint64_t now = clock_();
  record_stage(stage, now > clock.prev ? now - clock.prev : 0, clock);
  clock.prev = now;
}

void Pipeline::record_stage(Stage stage, std::uint64_t ns, FrameClock& clock) noexcept {
  clock.stage_ns[idx(stage)] = ns;
  StageStats& st = stage_stats_[idx(stage)];
  const std::uint64_t overruns_before = st.overruns();
  st.record(ns);
  counters_.stage_overruns += st.overruns() - overruns_before;
}

void Pipeline::detect_part(DetectionJob& job, unsigned part) noexcept {
  const std::uint64_t start = clock_();
  if (part == 0) {
    detect_boxes(*job.frame, *job.work);
  } else {
    job.ever_free_status =
        ever_free_.integrate(job.frame->depth, config_.camera, job.frame->T_map_camera);
  }
  const std::uint64_t end = clock_();
  job.ns[part] = end > start ? end - start : 0;
}

/// One member's share of the frame's first team run: detection's parts are claimed first
/// (longest first: they usually outlast a tile's walk), then the map's tiles.
void Pipeline::detect_and_carve(void* job, unsigned member) noexcept {
  auto& j = *static_cast<DetectionJob*>(job);
  for (std::uint32_t i = j.next_part.fetch_add(1, std::memory_order_relaxed);
       i < DetectionJob::kParts; i = j.next_part.fetch_add(1, std::memory_order_relaxed)) {
    j.pipeline->detect_part(j, i);
  }
  j.pipeline->map_.carve_share(member);
}

Status Pipeline::integrate(const Frame& frame, FrameWork& work, DetectionJob* job) noexcept {
  // check_frame() applied the map's own checks, so it does not refuse the frame; if it ever
  // did, it changed nothing (detection runs only for an accepted frame), and neither has any
  // other stage yet.
  Status s = Status::kOk;
  // Where the tracks labelled dynamic up to the last frame have been; only the map's
  // keep_unknown_backed asks.
  if (config_.map.keep_unknown_backed) {
    trail_.next_frame();
    trail_.mark_dynamic_tracks(tracker_);
  }
  if (job == nullptr) {
    s = map_.integrate(frame.depth, config_.camera, frame.T_map_camera, frame.stamp, &team_);
  } else {
    s = map_.begin_integration(frame.depth, config_.camera, frame.T_map_camera, frame.stamp, team_);
    if (ok(s)) {
      team_.run(&Pipeline::detect_and_carve, job);
      map_.end_integration();
    }
  }
  if (!ok(s)) return s;
  const IntegrationStats& ms = map_.last_stats();
  work.rays = ms.rays;
  work.voxel_visits = ms.voxel_visits;
  counters_.rays_dropped += ms.rays_dropped;
  counters_.blocks_evicted += ms.blocks_evicted;
  return Status::kOk;
}

void Pipeline::detect(const Frame& frame, FrameWork& work) noexcept {
  detect_boxes(frame, work);
  // Where the camera has seen free space: dynamic evidence for each detection (tracker.md).
  if (step_ok(ever_free_.integrate(frame.depth, config_.camera, frame.T_map_camera), work)) {
    ever_free_.annotate(detections_.data(), detections_.size());
  }
}

bool Pipeline::step_ok(Status s, FrameWork& work) noexcept {
  if (ok(s)) return true;
  ++work.step_errors;
  ++counters_.step_errors;
  return false;
}

void Pipeline::detect_boxes(const Frame& frame, FrameWork& work) noexcept {
  if (!step_ok(detector_.detect(frame.depth, config_.camera, frame.T_map_camera, detections_),
               work)) {
    detections_.clear();
  }
  counters_.detections_dropped += detector_.last_stats().detections_dropped;
  // Fragments of one person joined first; what is still wider than a person is a group.
  counters_.fragments_joined += fragments_.join(detections_);
  counters_.groups_split +=
      fragments_.split(frame.depth, config_.camera, frame.T_map_camera, detections_);
  work.detections = detections_.size();
}

void Pipeline::track(const Frame& frame, FrameWork& work) noexcept {
  const std::uint64_t refused_before = tracker_.refused_tracks();
  (void)step_ok(
      tracker_.update(detections_.data(), detections_.size(), frame.T_map_camera, frame.stamp),
      work);
  counters_.tracks_refused += tracker_.refused_tracks() - refused_before;
  work.tracks = tracker_.size();
}

void Pipeline::clean(const Frame& frame, FrameWork& work) noexcept {
  (void)step_ok(cleaner_.clean(tracker_, map_, history_, frame.stamp), work);
  work.voxels_cleaned = cleaner_.last_stats().voxels_freed;
  work.dynamic_tracks = cleaner_.last_stats().dynamic_tracks;
}

std::size_t Pipeline::collect_dynamic(const Frame& frame) noexcept {
  const Eigen::Vector3f camera = frame.T_map_camera.translation;
  const float per_m2 = config_.predictor.clearance.self_range_margin;
  const float max_range2 = config_.map.max_depth * config_.map.max_depth;
  std::size_t n_dyn = 0;
  for (std::size_t i = 0; i < tracker_.size(); ++i) {
    const TrackedObstacle& o = tracker_.obstacle(i);
    if (!o.dynamic) continue;
    ObstacleState& s = predictor_input_[n_dyn++];
    s = predictor_input(o);
    // The map holds no hits beyond max_depth, so the margin stops growing there.
    const float range2 = std::fmin((s.position - camera).squaredNorm(), max_range2);
    s.body_margin = per_m2 * range2;
  }
  return n_dyn;
}

void Pipeline::bin_far_field(void* job, unsigned) noexcept {
  auto& j = *static_cast<BinJob*>(job);
  for (std::uint32_t i = j.next_part.fetch_add(1, std::memory_order_relaxed);
       i < kFarFieldMaxBinParts; i = j.next_part.fetch_add(1, std::memory_order_relaxed)) {
    j.pipeline->far_field_.bin_columns(i, kFarFieldMaxBinParts);
  }
}

const FarFieldLayer* Pipeline::update_far_field(const Frame& frame, std::size_t n_dyn,
                                                FrameWork& work) noexcept {
  if (!config_.far_field.enabled) return nullptr;
  // The dynamic tracks' pixels are not walls. Walkers not (yet) labelled dynamic are kept out by
  // the layer's wall_height; static tracks are often pieces of a wall, and cutting their pixels
  // out would leave the wall's near noise tail as a ghost wall in front of it.
  const std::size_t n_ex = std::min(n_dyn, kFarFieldMaxExclusions);
  for (std::size_t k = 0; k < n_ex; ++k) {
    far_exclusions_[k].centre = predictor_input_[k].position.head<2>();
    far_exclusions_[k].radius =
        predictor_input_[k].footprint_radius + config_.predictor.clearance.self_margin;
  }
  if (!step_ok(far_field_.begin_update(frame.depth, config_.camera, frame.T_map_camera,
                                       far_exclusions_.data(), n_ex),
               work)) {
    return nullptr;
  }
  // With a team its column binning is shared by the members; the grid is written in column
  // order after, so the layer is the same for every thread count.
  if (team_.size() > 1) {
    BinJob job{};
    job.pipeline = this;
    team_.run(&Pipeline::bin_far_field, &job);
  } else {
    far_field_.bin_columns(0, 1);
  }
  far_field_.finish_update();
  return &far_field_;
}

std::size_t Pipeline::predict(std::size_t n_dyn, const FarFieldLayer* far, FrameWork& work,
                              FrameOutput& out) noexcept {
  const OccupancyQuery query = OccupancyQuery::of(map_);
  if (!step_ok(markov_.predict(predictor_input_.data(), n_dyn, query, far, out.predictions.data()),
               work)) {
    return 0;
  }
  if (config_.run_linear_baseline && n_dyn > 0) {
    // Map only (no far-field layer): the baseline's straight path is fixed, and its failure
    // counts "no path free" (tools/eval), so another environment source would change its figure
    // by a test that is not the collision of that path with the world.
    (void)step_ok(
        linear_.predict(predictor_input_.data(), n_dyn, query, out.linear_predictions.data()),
        work);
  }
  return n_dyn;
}

void Pipeline::finish(const Frame& frame, const FrameClock& clock, const FrameWork& work,
                      FrameOutput& out) noexcept {
  const std::uint64_t total = clock.prev - clock.start;
  const std::uint64_t frame_overruns_before = frame_stats_.overruns();
  frame_stats_.record(total);
  counters_.budget_overruns += frame_stats_.overruns() - frame_overruns_before;
  if (config_.budgets.adaptive_stride) adapt_stride(clock.stage_ns[idx(Stage::kOccupancy)]);

  has_stamp_ = true;
  last_stamp_ = frame.stamp;
  ++counters_.frames_processed;

  out.stamp = frame.stamp;
  out.status = Status::kOk;
  out.stage_ns = clock.stage_ns;
  out.total_ns = total;
  out.work = work;
  fill_output(out);
}

void Pipeline::fill_output(FrameOutput& out) noexcept {
  out.num_obstacles = tracker_.size();
  for (std::size_t i = 0; i < out.num_obstacles; ++i) out.obstacles[i] = tracker_.obstacle(i);
  out.pixel_stride = pixel_stride_;
  out.counters = counters_;
}

void Pipeline::adapt_stride(std::uint64_t occupancy_ns) noexcept {
  const std::uint64_t budget = config_.budgets.stage_ns[idx(Stage::kOccupancy)];
  if (budget == 0) return;
  int stride = pixel_stride_;
  if (occupancy_ns > budget && stride < config_.budgets.max_pixel_stride) {
    ++stride;  // coarser: roughly (s/(s+1))^2 of the rays
  } else if (stride > config_.map.pixel_stride &&
             static_cast<double>(occupancy_ns) <
                 config_.budgets.restore_fraction * static_cast<double>(budget)) {
    --stride;
  }
  if (stride != pixel_stride_ && ok(map_.set_pixel_stride(stride))) {
    pixel_stride_ = stride;
    ++counters_.stride_changes;
  }
}

const char* to_string(Stage s) noexcept {
  switch (s) {
    case Stage::kOccupancy:
      return "occupancy";
    case Stage::kDetection:
      return "detection";
    case Stage::kRefinement:
      return "refinement";
    case Stage::kTracking:
      return "tracking";
    case Stage::kCleaning:
      return "cleaning";
    case Stage::kPrediction:
      return "prediction";
    case Stage::kFarField:
      return "far_field";
  }
  return "unknown";
}

}  // namespace dynamap
