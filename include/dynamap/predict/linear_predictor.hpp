// LinearPredictor: the constant-velocity baseline of docs/design.md §4.6. Extrapolates each
// obstacle along its velocity over the same horizon and samples as the path library's straight
// path, and fails under the same definition as MarkovPredictor (its single path meets the static
// map).
#pragma once

#include <cstddef>

#include "dynamap/core/status.hpp"
#include "dynamap/predict/path_library.hpp"
#include "dynamap/predict/prediction.hpp"

namespace dynamap {

/// Horizon/sampling (paths.num_paths and the turn parameters are ignored) and footprint check.
struct LinearPredictorConfig {
  PathLibraryConfig paths{};
  ClearanceConfig clearance{};
};

/// Stateless constant-velocity predictor; output has num_paths = 1, probability[0] = 1.
class LinearPredictor {
 public:
  /// kInvalidArgument (and nothing changes) on an out-of-range or non-finite parameter.
  [[nodiscard]] Status init(const LinearPredictorConfig& config) noexcept;

  /// Predicts obstacles[0..count) into out[0..count). Same errors as MarkovPredictor::predict
  /// (except duplicate ids, which are harmless here); nothing is written on error.
  [[nodiscard]] Status predict(const ObstacleState* obstacles, std::size_t count,
                               const OccupancyQuery& map, PathPrediction* out) noexcept;

  const PathLibrary& library() const noexcept { return library_; }

 private:
  LinearPredictorConfig config_{};
  PathLibrary library_{};  // one straight path
  bool initialised_ = false;
  PathSamples path_{};  // scratch
};

}  // namespace dynamap
