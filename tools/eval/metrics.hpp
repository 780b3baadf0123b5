// The evaluation of docs/data_format.md ("Metrics"): position / velocity error, recall, precision,
// MOTA, ID switches and the prediction failure ratio, from a simulated sequence (obstacles.txt,
// static_world.txt) and a replay result directory (tracks.csv, predictions.csv).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace dynamap::tools::eval {

/// Thresholds; the defaults are the ones docs/data_format.md prescribes.
struct EvalOptions {
  double moving_speed = 0.2;  ///< m/s: ground truth counted when at least this fast
  double min_visible = 0.5;   ///< visible fraction
  double min_depth = 0.5;     ///< m ahead of the camera (camera-frame z of the centre)
  double max_depth = 5.0;
  double gate = 1.0;              ///< m, top-view matching gate
  double precision_radius = 1.0;  ///< m, a dynamic track this close to a listed obstacle is right
  /// Footprint radius for the collision test of predicted paths; <= 0: half the smaller
  /// horizontal size of the track's box at that time stamp (0.25 m when the track row is missing).
  double footprint_radius = 0.0;
  double ground_clearance = 0.2;  ///< m: static shapes lower than floor + this are ignored
  /// A matched pair whose track has existed this many frames also counts towards the settled
  /// velocity error: a young track's velocity is still converging (docs/tools.md).
  std::size_t settled_frames = 20;
  /// The obstacles to score against; empty: SEQ/obstacles.txt (the simulator's truth). For a
  /// real sequence, a reference made from the data (dynamap-label's obstacles.txt).
  std::string obstacles_file;
};

/// Failure ratio of one predictor's chosen paths against the true static world.
struct PredictionMetrics {
  bool available = false;  ///< file present and static_world.txt present
  std::size_t predictions = 0;
  std::size_t colliding = 0;  ///< chosen path intersects static geometry
  std::size_t no_path = 0;    ///< rows with path = -1 (no free path)
  double failure_ratio = 0.0;
};

struct EvalResult {
  std::size_t frames = 0;    ///< depth images with a pose
  std::size_t gt_count = 0;  ///< ground-truth obstacle-frames counted
  std::size_t matched = 0;
  std::size_t false_negatives = 0;
  std::size_t false_positives = 0;  ///< MOTA sense, see docs/tools.md
  std::size_t id_switches = 0;
  std::size_t dynamic_track_rows = 0;  ///< all dynamic rows of tracks.csv
  std::size_t track_ids = 0;           ///< distinct track ids in tracks.csv
  std::size_t dynamic_track_ids = 0;   ///< of those, ids labelled dynamic in some row
  std::size_t dynamic_rows_near_obstacle = 0;
  /// The most dynamic rows any one track has with no listed obstacle within precision_radius:
  /// how long the worst static object (or ghost) was labelled dynamic, in frames.
  std::size_t false_dynamic_frames_max = 0;
  std::size_t track_rows_unknown_stamp = 0;  ///< rows whose stamp is no frame of the sequence
  double position_error = 0.0;               ///< m, NaN when nothing matched
  double velocity_error = 0.0;               ///< m/s
  std::size_t settled_frames = 0;            ///< EvalOptions::settled_frames of the run
  std::size_t matched_settled = 0;           ///< matched pairs with a track >= settled_frames old
  double velocity_error_settled = 0.0;       ///< m/s over those, NaN when there are none
  /// Calibration of the reported velocity uncertainty (tracks.csv svx,svy): per-axis velocity
  /// errors of matched pairs, and the shares of them within 1 and 2 reported sigma (a Gaussian:
  /// 0.683, 0.954). NaN when tracks.csv has no sigma columns.
  std::size_t velocity_sigma_errors = 0;
  double velocity_within_1sigma = 0.0;
  double velocity_within_2sigma = 0.0;
  double recall = 0.0;       ///< NaN when gt_count == 0
  double precision = 0.0;    ///< NaN when there are no dynamic rows
  double mota = 0.0;         ///< NaN when gt_count == 0
  PredictionMetrics markov;  ///< predictions.csv
  PredictionMetrics linear;  ///< predictions_linear.csv (optional)
  std::vector<std::string> notes;
};

/// Runs the evaluation. Throws ToolError on missing or malformed input (naming file and line).
EvalResult evaluate(const std::string& seq_dir, const std::string& result_dir,
                    const EvalOptions& options = {});

/// Human-readable table.
std::string format_table(const EvalResult& r);

struct MapAccuracy;

/// metrics.json (NaN written as null); with `map` (dynamap-eval --map) also the map accuracy
/// keys sa, sa_strict, sa_shapes, sa_floor, da, aa, erased_max, free_through_max, ... and map{}.
void write_metrics_json(const std::string& path, const EvalResult& r, const std::string& seq_dir,
                        const std::string& result_dir, const std::string& obstacles_file = "",
                        const MapAccuracy* map = nullptr);

/// Optional picture: static world, true paths, tracked dynamic paths, final boxes, predictions.
void write_eval_picture(const std::string& png_path, const std::string& seq_dir,
                        const std::string& result_dir, const std::string& obstacles_file = "");

/// Minimum-cost one-to-one assignment (Hungarian method) of a rows x cols cost matrix
/// (row-major). Returns for each row the assigned column or -1. Pairs with cost >= `forbidden`
/// are never assigned.
std::vector<int> min_cost_assignment(const std::vector<double>& cost, std::size_t rows,
                                     std::size_t cols, double forbidden);

}  // namespace dynamap::tools::eval
