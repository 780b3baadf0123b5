#include "dynamap/predict/linear_predictor.hpp"

#include "dynamap/predict/detail/path_sweep.hpp"

namespace dynamap {

Status LinearPredictor::init(const LinearPredictorConfig& c) noexcept {
  PathLibraryConfig straight = c.paths;
  straight.num_paths = 1;  // heading change 0: the constant-velocity line
  PathLibrary lib;
  if (!ok(lib.init(straight))) return Status::kInvalidArgument;
  if (!ok(validate(c.clearance))) return Status::kInvalidArgument;
  config_ = c;
  library_ = lib;
  initialised_ = true;
  return Status::kOk;
}

Status LinearPredictor::predict(const ObstacleState* obstacles, std::size_t count,
                                const OccupancyQuery& map, PathPrediction* out) noexcept {
  if (!initialised_) return Status::kNotInitialized;
  const Status bad = validate_prediction_call(obstacles, count, map, out);
  if (!ok(bad)) return bad;
  for (std::size_t k = 0; k < count; ++k) {
    // The yardstick stays as it was: no range-dependent own-body margin.
    ObstacleState o = obstacles[k];
    o.body_margin = 0.0f;
    PathPrediction& p = out[k];
    library_.sample(0, o.position.head<2>(), o.velocity, &path_);
    const PathClearance c = sweep_path(map, path_, o, config_.clearance);
    p.track_id = o.track_id;
    p.num_paths = 1;
    p.chosen = 0;
    p.probability.fill(0.0f);
    p.probability[0] = 1.0f;
    p.free_distance.fill(0.0f);
    p.free_distance[0] = c.free_distance;
    p.free_mask = c.free ? 1u : 0u;
    p.any_free = c.free;
    p.failed = !c.free;
    write_chosen_path(path_, o.position.z(), &p);
  }
  return Status::kOk;
}

}  // namespace dynamap
