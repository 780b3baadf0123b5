// Readers of the replay tool's outputs (docs/data_format.md): tracks.csv and predictions.csv, and
// the writer of predictions.csv rows. Columns are found by their header names, so extra columns
// (anywhere) are ignored.
#pragma once

#include <limits>
#include <ostream>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "dynamap/predict/prediction.hpp"

namespace dynamap::tools {

/// One row of tracks.csv: stamp,id,x,y,z,vx,vy,vz,sx,sy,sz,dynamic,path and, when written by
/// this project's replay, svx,svy (the velocity's standard deviation per axis).
struct TrackRow {
  double stamp = 0.0;
  std::string stamp_text;
  int id = 0;
  Eigen::Vector3d center = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  Eigen::Vector3d size = Eigen::Vector3d::Zero();
  bool dynamic = false;
  int path = -1;
  /// m/s per axis, from the filter's covariance; NaN when the file has no svx,svy columns.
  Eigen::Vector2d velocity_sigma =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
};

/// One row of predictions.csv: stamp,id,path,probability,k,t,x,y,z
struct PredictionRow {
  double stamp = 0.0;
  std::string stamp_text;
  int id = 0;
  int path = -1;
  double probability = 0.0;
  int k = 0;
  double t = 0.0;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
};

/// Throws ToolError ("file:line: ...") on a missing file, a header without a required column, or
/// a malformed row.
std::vector<TrackRow> read_tracks_csv(const std::string& path);
std::vector<PredictionRow> read_predictions_csv(const std::string& path);

/// Writes one prediction as predictions.csv rows (one per sample of the chosen path). `path` is
/// the chosen index, or -1 when no path of the library is free in the map: docs/data_format.md
/// counts such a prediction as failed whatever its samples do, so the evaluator must be told.
void write_prediction_rows(std::ostream& out, const std::string& stamp_text,
                           const PathPrediction& prediction);

}  // namespace dynamap::tools
