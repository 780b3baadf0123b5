#include "eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>

#include "common/obstacles.hpp"
#include "common/results.hpp"
#include "common/sequence.hpp"
#include "common/static_world.hpp"
#include "common/text_io.hpp"
#include "common/topview.hpp"
#include "eval/map_accuracy.hpp"

namespace dynamap::tools::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double top_dist(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return (a.head<2>() - b.head<2>()).norm();
}

template <class Row>
std::map<std::int64_t, std::vector<Row>> by_stamp(const std::vector<Row>& rows) {
  std::map<std::int64_t, std::vector<Row>> m;
  for (const auto& r : rows) m[stamp_key(r.stamp)].push_back(r);
  return m;
}

PredictionMetrics evaluate_predictions(const std::string& path, const StaticWorld& world,
                                       const std::vector<TrackRow>& tracks,
                                       const EvalOptions& opt) {
  PredictionMetrics m;
  m.available = true;
  const auto rows = read_predictions_csv(path);
  // (stamp, id) -> samples; path index of the group.
  std::map<std::pair<std::int64_t, int>, std::vector<PredictionRow>> groups;
  for (const auto& r : rows) groups[{stamp_key(r.stamp), r.id}].push_back(r);
  std::map<std::pair<std::int64_t, int>, const TrackRow*> track_of;
  for (const auto& t : tracks) track_of[{stamp_key(t.stamp), t.id}] = &t;
  const double floor_z = world.has_floor ? world.floor_z : 0.0;
  for (auto& [key, samples] : groups) {
    ++m.predictions;
    if (std::any_of(samples.begin(), samples.end(),
                    [](const PredictionRow& r) { return r.path < 0; })) {
      ++m.no_path;
      continue;
    }
    std::sort(samples.begin(), samples.end(),
              [](const PredictionRow& a, const PredictionRow& b) { return a.k < b.k; });
    double radius = 0.25, ztop = floor_z + 1.7;
    const auto it = track_of.find(key);
    if (it != track_of.end()) {
      radius = 0.5 * std::min(it->second->size.x(), it->second->size.y());
      ztop = it->second->center.z() + 0.5 * it->second->size.z();
    }
    if (opt.footprint_radius > 0.0) radius = opt.footprint_radius;
    const double zlo = floor_z + opt.ground_clearance;
    const double zhi = std::max(ztop, zlo + 0.1);
    bool hit = false;
    auto check = [&](const Eigen::Vector2d& p) {
      hit = hit || world.top_view_distance(p, zlo, zhi) < radius;
    };
    check(samples.front().position.head<2>());
    for (std::size_t i = 1; i < samples.size() && !hit; ++i) {
      const Eigen::Vector2d a = samples[i - 1].position.head<2>();
      const Eigen::Vector2d b = samples[i].position.head<2>();
      const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.05)));
      for (int j = 1; j <= n && !hit; ++j) check(a + (b - a) * (static_cast<double>(j) / n));
    }
    if (hit) ++m.colliding;
  }
  m.failure_ratio =
      m.predictions > 0 ? static_cast<double>(m.colliding + m.no_path) / m.predictions : kNaN;
  return m;
}

}  // namespace

std::vector<int> min_cost_assignment(const std::vector<double>& cost, std::size_t rows,
                                     std::size_t cols, double forbidden) {
  std::vector<int> result(rows, -1);
  if (rows == 0 || cols == 0) return result;
  const bool transpose = rows > cols;
  const std::size_t n = transpose ? cols : rows, m = transpose ? rows : cols;
  const double big = 1e9;
  auto c = [&](std::size_t i, std::size_t j) {  // 1-based, i < n rows, j < m cols
    const double v = transpose ? cost[(j - 1) * cols + (i - 1)] : cost[(i - 1) * cols + (j - 1)];
    return v >= forbidden ? big : v;
  };
  // Hungarian method with potentials, O(n^2 m).
  std::vector<double> u(n + 1, 0.0), v(m + 1, 0.0);
  std::vector<std::size_t> p(m + 1, 0), way(m + 1, 0);
  for (std::size_t i = 1; i <= n; ++i) {
    p[0] = i;
    std::size_t j0 = 0;
    std::vector<double> minv(m + 1, std::numeric_limits<double>::infinity());
    std::vector<bool> used(m + 1, false);
    do {
      used[j0] = true;
      const std::size_t i0 = p[j0];
      double delta = std::numeric_limits<double>::infinity();
      std::size_t j1 = 0;
      for (std::size_t j = 1; j <= m; ++j) {
        if (used[j]) continue;
        const double cur = c(i0, j) - u[i0] - v[j];
        if (cur < minv[j]) {
          minv[j] = cur;
          way[j] = j0;
        }
        if (minv[j] < delta) {
          delta = minv[j];
          j1 = j;
        }
      }
      for (std::size_t j = 0; j <= m; ++j) {
        if (used[j]) {
          u[p[j]] += delta;
          v[j] -= delta;
        } else {
          minv[j] -= delta;
        }
      }
      j0 = j1;
    } while (p[j0] != 0);
    do {
      const std::size_t j1 = way[j0];
      p[j0] = p[j1];
      j0 = j1;
    } while (j0 != 0);
  }
  for (std::size_t j = 1; j <= m; ++j) {
    if (p[j] == 0 || c(p[j], j) >= big) continue;
    if (transpose) {
      result[j - 1] = static_cast<int>(p[j] - 1);
    } else {
      result[p[j] - 1] = static_cast<int>(j - 1);
    }
  }
  return result;
}

namespace {

// Each track id's first frame (index into seq.frames) among its rows at frame stamps.
std::map<int, std::size_t> first_frames(const Sequence& seq, const std::vector<TrackRow>& rows) {
  std::map<std::int64_t, std::size_t> index;
  for (std::size_t i = 0; i < seq.frames.size(); ++i) index[stamp_key(seq.frames[i].stamp)] = i;
  std::map<int, std::size_t> first;
  for (const auto& t : rows) {
    const auto it = index.find(stamp_key(t.stamp));
    if (it == index.end()) continue;
    const auto f = first.find(t.id);
    if (f == first.end() || it->second < f->second) first[t.id] = it->second;
  }
  return first;
}

// Sums over all frames for the mean errors, and each ground-truth obstacle's last match.
struct MatchState {
  std::map<int, int> last_track_of_gt;  // gt id -> track id of its last match
  double pos_sum = 0.0, vel_sum = 0.0, settled_vel_sum = 0.0;
  std::size_t within_1sigma = 0, within_2sigma = 0;  // per-axis velocity errors (calibration)
  std::map<int, std::size_t> false_dynamic_rows;     // track id -> dynamic rows far from all
};

// Per-axis velocity errors against the track's reported sigma (rows with svx,svy only).
void count_calibration(const ObstacleRecord& o, const TrackRow& t, MatchState& m, EvalResult& r) {
  if (!t.velocity_sigma.allFinite()) return;
  for (int a = 0; a < 2; ++a) {
    const double err = std::fabs(o.velocity[a] - t.velocity[a]);
    ++r.velocity_sigma_errors;
    m.within_1sigma += err <= t.velocity_sigma[a];
    m.within_2sigma += err <= 2.0 * t.velocity_sigma[a];
  }
}

// One frame's obstacles and dynamic track rows as the matching sees them.
struct FrameSets {
  std::vector<const ObstacleRecord*> gt, dont_care;  // counted / ignored obstacles
  std::vector<const TrackRow*> dyn;                  // dynamic track rows
};

// Splits the frame's obstacles into counted ones (moving, visible enough, in the depth range)
// and don't-care ones; collects the dynamic rows and counts those near any obstacle.
FrameSets frame_sets(const SequenceFrame& frame, const std::vector<ObstacleRecord>& listed,
                     const std::vector<TrackRow>& rows, const EvalOptions& opt, MatchState& m,
                     EvalResult& r) {
  FrameSets s;
  const Eigen::Matrix3d Rt = frame.pose.rotation.toRotationMatrix().transpose();
  for (const auto& o : listed) {
    const double depth = (Rt * (o.center - frame.pose.translation)).z();
    const bool counted = o.velocity.norm() >= opt.moving_speed && o.visible >= opt.min_visible &&
                         depth >= opt.min_depth && depth <= opt.max_depth;
    (counted ? s.gt : s.dont_care).push_back(&o);
  }
  for (const auto& t : rows) {
    if (!t.dynamic) continue;
    s.dyn.push_back(&t);
    const bool near = std::any_of(listed.begin(), listed.end(), [&](const ObstacleRecord& o) {
      return top_dist(o.center, t.center) <= opt.precision_radius;
    });
    r.dynamic_rows_near_obstacle += near ? 1 : 0;
    if (!near) {
      const std::size_t n = ++m.false_dynamic_rows[t.id];
      r.false_dynamic_frames_max = std::max(r.false_dynamic_frames_max, n);
    }
  }
  return s;
}

// Matching: keep last frame's correspondences inside the gate, then the cheapest one-to-one
// assignment of the rest (CLEAR-MOT style). Returns gt index -> dyn index (-1: missed) and
// marks the matched rows in track_used.
std::vector<int> match_frame(const FrameSets& s, const std::map<int, int>& last_track_of_gt,
                             const EvalOptions& opt, std::vector<bool>& track_used) {
  const auto& gt = s.gt;
  const auto& dyn = s.dyn;
  std::vector<int> match(gt.size(), -1);
  track_used.assign(dyn.size(), false);
  for (std::size_t g = 0; g < gt.size(); ++g) {
    const auto prev = last_track_of_gt.find(gt[g]->id);
    if (prev == last_track_of_gt.end()) continue;
    for (std::size_t d = 0; d < dyn.size(); ++d) {
      if (!track_used[d] && dyn[d]->id == prev->second &&
          top_dist(gt[g]->center, dyn[d]->center) <= opt.gate) {
        match[g] = static_cast<int>(d);
        track_used[d] = true;
      }
    }
  }
  std::vector<std::size_t> free_gt, free_dyn;
  for (std::size_t g = 0; g < gt.size(); ++g) {
    if (match[g] < 0) free_gt.push_back(g);
  }
  for (std::size_t d = 0; d < dyn.size(); ++d) {
    if (!track_used[d]) free_dyn.push_back(d);
  }
  std::vector<double> cost(free_gt.size() * free_dyn.size());
  for (std::size_t a = 0; a < free_gt.size(); ++a) {
    for (std::size_t b = 0; b < free_dyn.size(); ++b) {
      const double d = top_dist(gt[free_gt[a]]->center, dyn[free_dyn[b]]->center);
      cost[a * free_dyn.size() + b] = d <= opt.gate ? d : 1e6;
    }
  }
  const auto assign = min_cost_assignment(cost, free_gt.size(), free_dyn.size(), 1e5);
  for (std::size_t a = 0; a < free_gt.size(); ++a) {
    if (assign[a] < 0) continue;
    match[free_gt[a]] = static_cast<int>(free_dyn[static_cast<std::size_t>(assign[a])]);
    track_used[free_dyn[static_cast<std::size_t>(assign[a])]] = true;
  }
  return match;
}

// Counts one frame's matches, misses, ID switches and false positives (unmatched dynamic rows
// not near a don't-care obstacle).
void score_frame(const FrameSets& s, const std::vector<int>& match,
                 const std::vector<bool>& track_used, std::size_t frame_index,
                 const std::map<int, std::size_t>& first_frame, const EvalOptions& opt,
                 MatchState& m, EvalResult& r) {
  r.gt_count += s.gt.size();
  for (std::size_t g = 0; g < s.gt.size(); ++g) {
    if (match[g] < 0) {
      ++r.false_negatives;
      continue;
    }
    const ObstacleRecord& o = *s.gt[g];
    const TrackRow& t = *s.dyn[static_cast<std::size_t>(match[g])];
    ++r.matched;
    m.pos_sum += top_dist(o.center, t.center);
    const double vel_error = (o.velocity.head<2>() - t.velocity.head<2>()).norm();
    m.vel_sum += vel_error;
    count_calibration(o, t, m, r);
    if (frame_index >= first_frame.at(t.id) + opt.settled_frames) {
      ++r.matched_settled;
      m.settled_vel_sum += vel_error;
    }
    const auto prev = m.last_track_of_gt.find(o.id);
    if (prev != m.last_track_of_gt.end() && prev->second != t.id) ++r.id_switches;
    m.last_track_of_gt[o.id] = t.id;
  }
  for (std::size_t d = 0; d < s.dyn.size(); ++d) {
    if (track_used[d]) continue;
    const bool ignored = std::any_of(s.dont_care.begin(), s.dont_care.end(), [&](const auto* o) {
      return top_dist(o->center, s.dyn[d]->center) <= opt.gate;
    });
    if (!ignored) ++r.false_positives;
  }
}

// Track id counts, rows at unknown stamps, and the rates from the sums (NaN when undefined).
void finish_rates(const std::vector<TrackRow>& track_rows, const std::set<std::int64_t>& frame_keys,
                  const MatchState& m, EvalResult& r) {
  std::set<int> ids, dynamic_ids;
  for (const auto& t : track_rows) {
    ids.insert(t.id);
    if (t.dynamic) dynamic_ids.insert(t.id);
    if (t.dynamic) ++r.dynamic_track_rows;
    if (frame_keys.count(stamp_key(t.stamp)) == 0) ++r.track_rows_unknown_stamp;
  }
  r.track_ids = ids.size();
  r.dynamic_track_ids = dynamic_ids.size();
  // Dynamic rows at stamps that are no frame were not visited above: count them as not near.
  r.position_error = r.matched > 0 ? m.pos_sum / r.matched : kNaN;
  r.velocity_error = r.matched > 0 ? m.vel_sum / r.matched : kNaN;
  r.velocity_error_settled = r.matched_settled > 0 ? m.settled_vel_sum / r.matched_settled : kNaN;
  const double n_sigma = static_cast<double>(r.velocity_sigma_errors);
  r.velocity_within_1sigma = n_sigma > 0 ? static_cast<double>(m.within_1sigma) / n_sigma : kNaN;
  r.velocity_within_2sigma = n_sigma > 0 ? static_cast<double>(m.within_2sigma) / n_sigma : kNaN;
  r.recall = r.gt_count > 0 ? static_cast<double>(r.matched) / r.gt_count : kNaN;
  r.precision = r.dynamic_track_rows > 0
                    ? static_cast<double>(r.dynamic_rows_near_obstacle) / r.dynamic_track_rows
                    : kNaN;
  r.mota = r.gt_count > 0
               ? 1.0 - static_cast<double>(r.false_negatives + r.false_positives + r.id_switches) /
                           r.gt_count
               : kNaN;
}

// Prediction failure ratios (chosen and linear) against the static world, when both exist.
void score_predictions(const std::string& seq_dir, const std::string& result_dir,
                       const std::vector<TrackRow>& track_rows, const EvalOptions& opt,
                       EvalResult& r) {
  const std::string world_path = join_path(seq_dir, "static_world.txt");
  const std::string pred_path = join_path(result_dir, "predictions.csv");
  const std::string lin_path = join_path(result_dir, "predictions_linear.csv");
  if (!file_exists(world_path)) {
    r.notes.push_back(world_path + " missing: no prediction failure ratio");
    return;
  }
  const StaticWorld world = read_static_world(world_path);
  if (file_exists(pred_path)) {
    r.markov = evaluate_predictions(pred_path, world, track_rows, opt);
  } else {
    r.notes.push_back(pred_path + " missing: no prediction failure ratio");
  }
  if (file_exists(lin_path)) r.linear = evaluate_predictions(lin_path, world, track_rows, opt);
}

}  // namespace

EvalResult evaluate(const std::string& seq_dir, const std::string& result_dir,
                    const EvalOptions& opt) {
  EvalResult r;
  // The default reading: a world_z_up 0 sequence gets the same gravity-aligned, floor-levelled
  // world as in dynamap-replay and dynamap-label, so tracks and reference boxes share it.
  const Sequence seq = read_sequence(seq_dir);
  const std::string obstacles_path =
      opt.obstacles_file.empty() ? join_path(seq_dir, "obstacles.txt") : opt.obstacles_file;
  if (!file_exists(obstacles_path)) {
    throw ToolError(obstacles_path +
                    ": missing (evaluation needs ground-truth or reference obstacles; for a real "
                    "sequence make them with dynamap-label and pass --reference FILE)");
  }
  const auto obstacles = by_stamp(read_obstacles(obstacles_path));
  const auto track_rows = read_tracks_csv(join_path(result_dir, "tracks.csv"));
  const auto tracks = by_stamp(track_rows);
  r.frames = seq.frames.size();

  const std::map<int, std::size_t> first_frame = first_frames(seq, track_rows);
  std::set<std::int64_t> frame_keys;
  MatchState m;
  r.settled_frames = opt.settled_frames;
  static const std::vector<ObstacleRecord> kNoObstacles;
  static const std::vector<TrackRow> kNoTracks;
  for (const auto& frame : seq.frames) {
    const auto frame_index = static_cast<std::size_t>(&frame - seq.frames.data());
    const std::int64_t key = stamp_key(frame.stamp);
    frame_keys.insert(key);
    const auto oit = obstacles.find(key);
    const auto& listed = oit != obstacles.end() ? oit->second : kNoObstacles;
    const auto tit = tracks.find(key);
    const auto& rows = tit != tracks.end() ? tit->second : kNoTracks;
    const FrameSets s = frame_sets(frame, listed, rows, opt, m, r);
    std::vector<bool> track_used;
    const std::vector<int> match = match_frame(s, m.last_track_of_gt, opt, track_used);
    score_frame(s, match, track_used, frame_index, first_frame, opt, m, r);
  }
  finish_rates(track_rows, frame_keys, m, r);
  if (r.track_rows_unknown_stamp > 0) {
    r.notes.push_back(std::to_string(r.track_rows_unknown_stamp) +
                      " tracks.csv rows have a stamp that is no frame of the sequence");
  }
  if (seq.images_without_pose > 0) {
    r.notes.push_back(std::to_string(seq.images_without_pose) + " images without a pose skipped");
  }
  score_predictions(seq_dir, result_dir, track_rows, opt, r);
  return r;
}

namespace {

std::string num(double v, int decimals) {
  if (std::isnan(v)) return "n/a";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string json_num(double v) {
  if (!std::isfinite(v)) return "null";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') {
      out += '\\';
      out += c;
    } else if (static_cast<unsigned char>(c) < 0x20) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\u%04x", c);
      out += buf;
    } else {
      out += c;
    }
  }
  return out + "\"";
}

}  // namespace

std::string format_table(const EvalResult& r) {
  std::ostringstream o;
  auto row = [&](const char* name, const std::string& value, const std::string& detail) {
    char buf[256];
    std::snprintf(buf, sizeof(buf), "  %-26s %10s   %s\n", name, value.c_str(), detail.c_str());
    o << buf;
  };
  o << "  metric                          value   detail\n";
  o << "  ------------------------------------------------------------------------\n";
  row("position error (m)", num(r.position_error, 3), "mean top-view distance, matched pairs");
  row("velocity error (m/s)", num(r.velocity_error, 3), "mean |(vx,vy) difference|");
  row("  settled tracks", num(r.velocity_error_settled, 3),
      std::to_string(r.matched_settled) +
          " matched pairs whose track is >= " + std::to_string(r.settled_frames) + " frames old");
  row("velocity within 1 sigma", num(r.velocity_within_1sigma, 3),
      "share of " + std::to_string(r.velocity_sigma_errors) +
          " per-axis errors inside the reported sigma (Gaussian 0.683)");
  row("velocity within 2 sigma", num(r.velocity_within_2sigma, 3), "(Gaussian 0.954)");
  row("recall", num(r.recall, 3),
      std::to_string(r.matched) + " matched / " + std::to_string(r.gt_count) + " ground truth");
  row("precision", num(r.precision, 3),
      std::to_string(r.dynamic_rows_near_obstacle) + " near an obstacle / " +
          std::to_string(r.dynamic_track_rows) + " dynamic rows");
  row("false dynamic, worst track", std::to_string(r.false_dynamic_frames_max),
      "frames one track was dynamic with no obstacle within the precision radius");
  row("MOTA", num(r.mota, 3),
      "FN " + std::to_string(r.false_negatives) + ", FP " + std::to_string(r.false_positives) +
          ", ID switches " + std::to_string(r.id_switches));
  row("ID switches", std::to_string(r.id_switches), "");
  row("track ids", std::to_string(r.track_ids),
      std::to_string(r.dynamic_track_ids) + " of them labelled dynamic at some frame");
  auto pred = [&](const char* name, const PredictionMetrics& p) {
    if (!p.available) {
      row(name, "n/a", "no file");
      return;
    }
    row(name, num(p.failure_ratio, 3),
        std::to_string(p.colliding) + " colliding + " + std::to_string(p.no_path) +
            " without path / " + std::to_string(p.predictions) + " predictions");
  };
  pred("prediction failure ratio", r.markov);
  pred("linear baseline failure", r.linear);
  row("frames", std::to_string(r.frames), "depth images with a pose");
  for (const auto& n : r.notes) o << "  note: " << n << "\n";
  return o.str();
}

namespace {

// The map accuracy keys of metrics.json (each line ends with ",\n").
std::string map_json(const MapAccuracy& m) {
  std::ostringstream o;
  auto frames = [&](std::size_t v) {
    return m.frames_available ? std::to_string(v) : std::string("null");
  };
  auto bare = [&](std::size_t v) {
    return m.frames_available && m.bare_available ? std::to_string(v) : std::string("null");
  };
  auto whole = [&](std::size_t v) {
    return m.frames_available && m.whole_available ? std::to_string(v) : std::string("null");
  };
  o << "  \"sa\": " << json_num(m.sa) << ",\n"
    << "  \"sa_strict\": " << json_num(m.sa_strict) << ",\n"
    << "  \"sa_shapes\": " << json_num(m.sa_shapes) << ",\n"
    << "  \"sa_floor\": " << json_num(m.sa_floor) << ",\n"
    << "  \"da\": " << json_num(m.da) << ",\n"
    << "  \"aa\": " << json_num(m.aa) << ",\n"
    << "  \"erased_max\": " << frames(m.erased_max) << ",\n"
    << "  \"free_through_max\": " << frames(m.free_through_max) << ",\n"
    << "  \"erased_all_max\": " << frames(m.erased_all_max) << ",\n"
    << "  \"erased_bare_max\": " << bare(m.erased_bare_max) << ",\n"
    << "  \"erased_bare_all_max\": " << bare(m.erased_bare_all_max) << ",\n"
    << "  \"free_through_all_max\": " << frames(m.free_through_all_max) << ",\n"
    << "  \"free_through_whole_max\": " << whole(m.free_through_whole_max) << ",\n"
    << "  \"free_through_whole_all_max\": " << whole(m.free_through_whole_all_max) << ",\n"
    << "  \"free_through_final\": " << frames(m.free_through_final) << ",\n"
    << "  \"map\": {\"static_observed\": " << m.static_observed
    << ", \"static_held\": " << m.static_held
    << ", \"static_held_strict\": " << m.static_held_strict
    << ", \"shape_observed\": " << m.shape_observed << ", \"floor_observed\": " << m.floor_observed
    << ", \"walker_observed\": " << m.walker_observed
    << ", \"walker_cleared\": " << m.walker_cleared
    << ", \"walker_in_final_box\": " << m.walker_in_final
    << ", \"checked_frames\": " << m.checked_frames << ", \"settings\": " << json_string(m.settings)
    << "},\n";
  return o.str();
}

}  // namespace

void write_metrics_json(const std::string& path, const EvalResult& r, const std::string& seq_dir,
                        const std::string& result_dir, const std::string& obstacles_file,
                        const MapAccuracy* map) {
  std::ofstream o(path);
  if (!o) throw ToolError(path + ": cannot create file");
  auto pred = [&](const PredictionMetrics& p) {
    std::ostringstream s;
    s << "{\"available\": " << (p.available ? "true" : "false")
      << ", \"predictions\": " << p.predictions << ", \"colliding\": " << p.colliding
      << ", \"no_path\": " << p.no_path
      << ", \"failure_ratio\": " << (p.available ? json_num(p.failure_ratio) : "null") << "}";
    return s.str();
  };
  o << "{\n"
    << "  \"sequence\": " << json_string(seq_dir) << ",\n"
    << "  \"result_dir\": " << json_string(result_dir) << ",\n"
    << "  \"obstacles\": "
    << json_string(obstacles_file.empty() ? join_path(seq_dir, "obstacles.txt") : obstacles_file)
    << ",\n"
    << "  \"frames\": " << r.frames << ",\n"
    << "  \"gt_count\": " << r.gt_count << ",\n"
    << "  \"matched\": " << r.matched << ",\n"
    << "  \"position_error_m\": " << json_num(r.position_error) << ",\n"
    << "  \"velocity_error_mps\": " << json_num(r.velocity_error) << ",\n"
    << "  \"matched_settled\": " << r.matched_settled << ",\n"
    << "  \"velocity_error_settled_mps\": " << json_num(r.velocity_error_settled) << ",\n"
    << "  \"velocity_sigma_errors\": " << r.velocity_sigma_errors << ",\n"
    << "  \"velocity_within_1sigma\": " << json_num(r.velocity_within_1sigma) << ",\n"
    << "  \"velocity_within_2sigma\": " << json_num(r.velocity_within_2sigma) << ",\n"
    << "  \"recall\": " << json_num(r.recall) << ",\n"
    << "  \"precision\": " << json_num(r.precision) << ",\n"
    << "  \"dynamic_track_rows\": " << r.dynamic_track_rows << ",\n"
    << "  \"track_ids\": " << r.track_ids << ",\n"
    << "  \"dynamic_track_ids\": " << r.dynamic_track_ids << ",\n"
    << "  \"dynamic_rows_near_obstacle\": " << r.dynamic_rows_near_obstacle << ",\n"
    << "  \"false_dynamic_frames_max\": " << r.false_dynamic_frames_max << ",\n"
    << "  \"false_negatives\": " << r.false_negatives << ",\n"
    << "  \"false_positives\": " << r.false_positives << ",\n"
    << "  \"id_switches\": " << r.id_switches << ",\n"
    << "  \"mota\": " << json_num(r.mota) << ",\n"
    << "  \"prediction_failure_ratio\": "
    << (r.markov.available ? json_num(r.markov.failure_ratio) : "null") << ",\n"
    << "  \"linear_failure_ratio\": "
    << (r.linear.available ? json_num(r.linear.failure_ratio) : "null") << ",\n"
    << "  \"prediction\": " << pred(r.markov) << ",\n"
    << "  \"prediction_linear\": " << pred(r.linear) << ",\n"
    << (map != nullptr && map->available ? map_json(*map) : std::string()) << "  \"notes\": [";
  for (std::size_t i = 0; i < r.notes.size(); ++i) {
    o << (i ? ", " : "") << json_string(r.notes[i]);
  }
  o << "]\n}\n";
  if (!o) throw ToolError(path + ": write error");
}

void write_eval_picture(const std::string& png_path, const std::string& seq_dir,
                        const std::string& result_dir, const std::string& obstacles_file) {
  const Sequence seq = read_sequence(seq_dir);  // the world of the replay (see evaluate())
  TopViewScene pic;
  pic.title = "dynamap-eval: " + seq_dir;
  pic.subtitle = "tracked dynamic obstacles vs ground truth (boxes at the last frame)";
  const std::string world_path = join_path(seq_dir, "static_world.txt");
  if (file_exists(world_path)) pic.static_world = read_static_world(world_path);
  for (const auto& f : seq.frames) pic.camera_trajectory.push_back(f.pose.translation.head<2>());
  if (!seq.frames.empty()) {
    const auto& last = seq.frames.back().pose;
    const Eigen::Vector3d fwd = last.rotation * Eigen::Vector3d::UnitZ();
    pic.show_camera = true;
    pic.camera_position = last.translation.head<2>();
    pic.camera_yaw = std::atan2(fwd.y(), fwd.x());
    pic.camera_hfov = 2.0 * std::atan(0.5 * seq.camera.width / seq.camera.fx);
  }
  std::map<int, TopViewPath> gt_paths, track_paths;
  const std::string obstacles_path =
      obstacles_file.empty() ? join_path(seq_dir, "obstacles.txt") : obstacles_file;
  const auto obstacles =
      file_exists(obstacles_path) ? read_obstacles(obstacles_path) : std::vector<ObstacleRecord>{};
  for (const auto& o : obstacles) {
    gt_paths[o.id].id = o.id;
    gt_paths[o.id].points.push_back(o.center.head<2>());
  }
  const auto tracks = read_tracks_csv(join_path(result_dir, "tracks.csv"));
  double last_stamp = -1;
  for (const auto& t : tracks) last_stamp = std::max(last_stamp, t.stamp);
  for (const auto& t : tracks) {
    if (!t.dynamic) continue;
    track_paths[t.id].id = t.id;
    track_paths[t.id].points.push_back(t.center.head<2>());
  }
  for (const auto& t : tracks) {
    if (stamp_key(t.stamp) != stamp_key(last_stamp)) continue;
    TopViewObstacle o;
    o.center = t.center.head<2>();
    o.size = t.size.head<2>();
    o.velocity = t.velocity.head<2>();
    o.dynamic = t.dynamic;
    char label[64];
    std::snprintf(label, sizeof(label), "track %d  %.1f m/s", t.id, o.velocity.norm());
    o.label = label;
    pic.obstacles.push_back(o);
  }
  for (const auto& o : obstacles) {
    if (stamp_key(o.stamp) != stamp_key(last_stamp)) continue;
    pic.ground_truth_boxes.push_back(
        TopViewObstacle{o.center.head<2>(), o.size.head<2>(), Eigen::Vector2d::Zero(), false, ""});
  }
  for (auto& [id, p] : gt_paths) pic.ground_truth_paths.push_back(p);
  for (auto& [id, p] : track_paths) pic.tracked_paths.push_back(p);
  for (const char* name : {"predictions.csv", "predictions_linear.csv"}) {
    const std::string path = join_path(result_dir, name);
    if (!file_exists(path)) continue;
    std::map<int, TopViewPath> paths;
    for (const auto& r : read_predictions_csv(path)) {
      if (stamp_key(r.stamp) != stamp_key(last_stamp)) continue;
      paths[r.id].points.push_back(r.position.head<2>());
    }
    auto& dst = std::string(name) == "predictions.csv" ? pic.predicted_paths : pic.linear_paths;
    for (auto& [id, p] : paths) dst.push_back(p);
  }
  render_top_view(pic, png_path);
}

}  // namespace dynamap::tools::eval
