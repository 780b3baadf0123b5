// dynamap-predict-diag: why do predictions fail? Replays a simulated sequence through the
// Pipeline (like dynamap-replay) and, for every Markov prediction, tests every library path
// against the true static world with the evaluator's rule (tools/eval/metrics.cpp) and against
// the map with the predictor's own sweep, and looks at what the map holds where the chosen path
// truly collides. Writes one CSV row per prediction (see the header line) to stdout.
// Host-only diagnosis tool: heap, iostreams and exceptions are fine here.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/obstacles.hpp"
#include "common/png_io.hpp"
#include "common/sequence.hpp"
#include "common/static_world.hpp"
#include "common/text_io.hpp"
#include "dynamap/pipeline/pipeline.hpp"
#include "params.hpp"

namespace dynamap::tools {
namespace {

// The evaluator's collision test of one polyline (tools/eval/metrics.cpp, evaluate_predictions):
// returns the arc length of the first point closer than `radius` to a shape, or -1 when free.
double true_hit(const StaticWorld& w, const std::vector<Eigen::Vector2d>& pts, double radius,
                double zlo, double zhi, Eigen::Vector2d* where) {
  if (pts.empty()) return -1.0;
  if (w.top_view_distance(pts[0], zlo, zhi) < radius) {
    *where = pts[0];
    return 0.0;
  }
  double s = 0.0;
  for (std::size_t i = 1; i < pts.size(); ++i) {
    const Eigen::Vector2d a = pts[i - 1], b = pts[i];
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / 0.05)));
    for (int j = 1; j <= n; ++j) {
      const Eigen::Vector2d p = a + (b - a) * (static_cast<double>(j) / n);
      if (w.top_view_distance(p, zlo, zhi) < radius) {
        *where = p;
        return s + (p - a).norm();
      }
    }
    s += (b - a).norm();
  }
  return -1.0;
}

// Per-path values as one CSV field, "|"-separated.
template <class Array>
std::string joined(const Array& v, std::size_t n) {
  std::string s;
  char buf[32];
  for (std::size_t i = 0; i < n; ++i) {
    std::snprintf(buf, sizeof buf, "%s%.3g", i > 0 ? "|" : "", static_cast<double>(v[i]));
    s += buf;
  }
  return s;
}

// DYNAMAP_DIAG_FAR_FRAME=f: the far-field layer's walls after frame f, to stderr (x y evidence).
void dump_far_field(const Pipeline& pipeline, const Frame& frame, std::size_t f) {
  const char* ff = std::getenv("DYNAMAP_DIAG_FAR_FRAME");
  if (ff == nullptr || static_cast<std::size_t>(std::atoi(ff)) != f ||
      !pipeline.far_field().initialised()) {
    return;
  }
  const FarFieldLayer& layer = pipeline.far_field();
  const float c = layer.config().cell_size;
  const Eigen::Vector2f cam = frame.T_map_camera.translation.head<2>();
  for (float y = -12.f; y < 12.f; y += c) {
    for (float x = -12.f; x < 12.f; x += c) {
      const Eigen::Vector2f p = cam + Eigen::Vector2f(x + 0.5f * c, y + 0.5f * c);
      if (layer.occupied(p)) {
        std::cerr << "far " << p.x() << " " << p.y() << " " << layer.evidence(p) << "\n";
      }
    }
  }
}

std::vector<Eigen::Vector2d> polyline_of(const PathPrediction& p) {
  std::vector<Eigen::Vector2d> v;
  for (std::size_t k = 0; k < p.num_samples; ++k) {
    v.push_back(p.position[k].head<2>().cast<double>());
  }
  return v;
}

// What the diagnosis reads besides the pipeline: the true world and obstacles, the path library.
struct DiagInputs {
  StaticWorld world;
  double floor_z = 0.0;
  std::map<std::string, std::vector<ObstacleRecord>> truth;  // by stamp text
  PathLibrary lib;
};

// Map voxel counts (occupied, free, unknown) on the truly hit shapes near the hit point.
struct WallCounts {
  int occ = 0, fre = 0, unk = 0;
};

// Voxels within r_eval + 0.15 of the hit point, at body heights, that lie inside a true shape.
WallCounts map_at_hit(const OccupancyMap& map, const StaticWorld& world,
                      const Eigen::Vector2d& where, double r_eval, double zlo, double zhi) {
  WallCounts w;
  const float res = map.resolution();
  const double reach = r_eval + 0.15;
  for (double dx = -reach; dx <= reach; dx += res) {
    for (double dy = -reach; dy <= reach; dy += res) {
      const Eigen::Vector2d q = where + Eigen::Vector2d(dx, dy);
      if (world.top_view_distance(q, zlo, zhi) > 0.5 * res) continue;
      for (double z = zlo + 0.05; z < zhi; z += res) {
        const Occupancy o = map.state(Eigen::Vector3f(
            static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(z)));
        if (o == Occupancy::kOccupied)
          ++w.occ;
        else if (o == Occupancy::kFree)
          ++w.fre;
        else
          ++w.unk;
      }
    }
  }
  return w;
}

// Bit j set when library path j from the obstacle is free of the true world.
unsigned true_free_mask(const DiagInputs& in, const TrackedObstacle& ob, std::size_t num_paths,
                        double r_eval, double zlo, double zhi) {
  PathSamples ps;
  unsigned true_mask = 0;
  for (std::size_t j = 0; j < num_paths; ++j) {
    in.lib.sample(j, ob.box.center().head<2>(), ob.velocity.head<2>(), &ps);
    std::vector<Eigen::Vector2d> v;
    for (std::size_t k = 0; k < ps.count; ++k) v.push_back(ps.position[k].cast<double>());
    Eigen::Vector2d w;
    if (true_hit(in.world, v, r_eval, zlo, zhi, &w) < 0) true_mask |= 1u << j;
  }
  return true_mask;
}

// One CSV row for one Markov prediction (pm) and its linear baseline (pl) of obstacle ob.
void write_prediction_row(std::ostream& os, const DiagInputs& in, const OccupancyMap& map,
                          std::size_t f, const SequenceFrame& sf, const Frame& frame,
                          const PathPrediction& pm, const PathPrediction& pl,
                          const TrackedObstacle& ob, int age) {
  const Eigen::Vector3f size = ob.box.size();
  const double r_eval = 0.5 * std::min(size.x(), size.y());
  const double r_pred = 0.5 * std::max(size.x(), size.y());
  const double ztop = ob.box.center().z() + 0.5 * size.z();
  const double zlo = in.floor_z + 0.2;
  const double zhi = std::max(ztop, zlo + 0.1);
  Eigen::Vector2d where(0, 0), where_l(0, 0);
  const double hit_s = true_hit(in.world, polyline_of(pm), r_eval, zlo, zhi, &where);
  const double hit_l = true_hit(in.world, polyline_of(pl), r_eval, zlo, zhi, &where_l);
  const unsigned true_mask = true_free_mask(in, ob, pm.num_paths, r_eval, zlo, zhi);
  const WallCounts wall =
      hit_s >= 0 ? map_at_hit(map, in.world, where, r_eval, zlo, zhi) : WallCounts{};
  // Distance to the nearest listed (true) obstacle: > 1 m means a false dynamic track.
  double gt_dist = 1e9;
  const auto listed = in.truth.find(sf.stamp_text);
  if (listed != in.truth.end()) {
    for (const ObstacleRecord& r : listed->second) {
      gt_dist =
          std::min(gt_dist, (r.center.head<2>() - ob.box.center().head<2>().cast<double>()).norm());
    }
  }
  float maxd = 0.0f;
  for (std::size_t j = 0; j < pm.num_paths; ++j) maxd = std::max(maxd, pm.free_distance[j]);
  const Eigen::Vector2d start = ob.box.center().head<2>().cast<double>();
  os << f << "," << pm.track_id << "," << age << "," << ob.speed << "," << r_pred << "," << r_eval
     << "," << pm.num_paths << "," << pm.chosen << "," << pm.probability[pm.chosen] << ","
     << (hit_s >= 0) << "," << (hit_l >= 0) << "," << pm.free_mask << "," << true_mask << ","
     << pm.any_free << "," << in.world.top_view_distance(start, zlo, zhi) << "," << hit_s << ","
     << where.x() << "," << where.y() << "," << wall.occ << "," << wall.fre << "," << wall.unk
     << "," << pm.free_distance[pm.chosen] << "," << maxd << ","
     << pm.free_distance[pm.num_paths / 2] << "," << gt_dist << ","
     << joined(pm.free_distance, pm.num_paths) << "," << joined(pm.probability, pm.num_paths) << ","
     << frame.T_map_camera.translation.x() << "," << frame.T_map_camera.translation.y() << ","
     << start.x() << "," << start.y() << "," << ob.velocity.x() << "," << ob.velocity.y() << ","
     << pm.far_blocked_mask << "\n";
}

int run(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: dynamap-predict-diag SEQ [--params FILE] > diag.csv\n";
    return 2;
  }
  const std::string seq_dir = argv[1];
  const Sequence seq = read_sequence(seq_dir);
  const PipelineConfig config = config_for_sequence(seq, option_value(argc, argv, 2, "--params"));
  const auto pipeline = make_pipeline(config);
  DiagInputs in;
  in.world = read_static_world(join_path(seq_dir, "static_world.txt"));
  in.floor_z = in.world.has_floor ? in.world.floor_z : 0.0;
  for (const ObstacleRecord& r : read_obstacles(join_path(seq_dir, "obstacles.txt"))) {
    in.truth[r.stamp_text].push_back(r);
  }
  if (!ok(in.lib.init(config.predictor.paths))) throw ToolError("path library");

  std::cout << "frame,id,age,speed,radius_pred,radius_eval,l,chosen,prob_chosen,markov_fail,"
               "linear_fail,map_free_mask,true_free_mask,any_map_free,start_dist,hit_s,hit_x,"
               "hit_y,wall_occ,wall_free,wall_unknown,chosen_free_dist,max_free_dist,"
               "straight_free_dist,gt_dist,free_dists,probs,cam_x,cam_y,x,y,vx,vy,far_mask\n";
  std::map<std::uint32_t, int> age;
  auto out = std::make_unique<FrameOutput>();
  for (std::size_t f = 0; f < seq.frames.size(); ++f) {
    const SequenceFrame& sf = seq.frames[f];
    const Image16 depth = load_depth(seq, sf);
    Frame frame;
    frame.stamp = seq.stamp_ns(sf.stamp);
    frame.T_map_camera = to_pose(sf.pose);
    frame.depth = DepthView{depth.pixels.data(), depth.width, depth.height,
                            depth.width * static_cast<int>(sizeof(std::uint16_t))};
    if (!ok(pipeline->process(frame, *out))) continue;
    dump_far_field(*pipeline, frame, f);
    std::map<std::uint32_t, int> next_age;
    for (std::size_t i = 0; i < out->num_predictions; ++i) {
      const PathPrediction& pm = out->predictions[i];
      const TrackedObstacle* ob = nullptr;
      for (std::size_t k = 0; k < out->num_obstacles; ++k) {
        if (out->obstacles[k].id == pm.track_id) ob = &out->obstacles[k];
      }
      if (ob == nullptr) continue;
      const int a = age.count(pm.track_id) ? age[pm.track_id] + 1 : 0;
      next_age[pm.track_id] = a;
      write_prediction_row(std::cout, in, pipeline->map(), f, sf, frame, pm,
                           out->linear_predictions[i], *ob, a);
    }
    age = next_age;
  }
  return 0;
}

}  // namespace
}  // namespace dynamap::tools

int main(int argc, char** argv) {
  try {
    return dynamap::tools::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dynamap-predict-diag: " << e.what() << "\n";
    return 1;
  }
}
