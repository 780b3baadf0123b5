// dynamap-track-diag: why is an obstacle-frame missed, why is a velocity wrong? Replays a
// simulated sequence through the Pipeline (like dynamap-replay) and writes one CSV row per track
// and frame with the tracker's internals (votes, continuity, age, missed frames, size fixing)
// next to the nearest ground-truth obstacle (id, distance, velocity, visible fraction, depth
// ahead of the camera, turn rate). Host-only diagnosis tool: heap, iostreams and exceptions are
// fine here.
#include <cmath>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "common/obstacles.hpp"
#include "common/png_io.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"
#include "dynamap/pipeline/pipeline.hpp"
#include "params.hpp"

namespace dynamap::tools {
namespace {

// Ground-truth turn rate (rad/s at 30 Hz) per obstacle id from its velocity now and in the
// previous frame; updates `previous_velocity`.
std::map<int, double> turn_rates(const std::vector<ObstacleRecord>& listed,
                                 std::map<int, Eigen::Vector2d>& previous_velocity) {
  std::map<int, double> turn_rate;
  for (const ObstacleRecord& r : listed) {
    const Eigen::Vector2d v = r.velocity.head<2>();
    const auto it = previous_velocity.find(r.id);
    double w = 0.0;
    if (it != previous_velocity.end() && v.norm() > 0.1 && it->second.norm() > 0.1) {
      const Eigen::Vector2d a = it->second;
      w = std::atan2(a.x() * v.y() - a.y() * v.x(), a.dot(v)) * 30.0;
    }
    turn_rate[r.id] = w;
    previous_velocity[r.id] = v;
  }
  return turn_rate;
}

// The listed obstacle nearest to c in the top view (null when none), its distance in `best`.
const ObstacleRecord* nearest(const std::vector<ObstacleRecord>& listed, const Eigen::Vector2d& c,
                              double* best) {
  const ObstacleRecord* near = nullptr;
  *best = 1e9;
  for (const ObstacleRecord& r : listed) {
    const double d = (r.center.head<2>() - c).norm();
    if (d < *best) {
      *best = d;
      near = &r;
    }
  }
  return near;
}

// The detection behind this frame's update, and whether its image box touches another
// detection's (a nearer one may hide part of it; any may have been grouped with it).
void write_detection_fields(std::ostream& os, const TrackedObstacle& ob,
                            const DetectionList& dets) {
  if (ob.detection < 0 || static_cast<std::size_t>(ob.detection) >= dets.size()) {
    os << ",-1,0,0,0,0,0,0,0,0,0,0,0";
    return;
  }
  const Detection& d = dets[static_cast<std::size_t>(ob.detection)];
  int touch_nearer = 0, touch = 0;
  for (std::size_t j = 0; j < dets.size(); ++j) {
    if (j == static_cast<std::size_t>(ob.detection)) continue;
    const ImageBox& a = d.image_box;
    const ImageBox& b = dets[j].image_box;
    const bool adjacent = b.u0 <= a.u1 + 3 && b.u1 >= a.u0 - 3 && b.v0 <= a.v1 && b.v1 >= a.v0;
    if (!adjacent) continue;
    touch = 1;
    if (dets[j].near_depth < d.near_depth) touch_nearer = 1;
  }
  const Eigen::Vector3f dc = d.box.center(), ds = d.box.size();
  os << "," << ob.detection << "," << dc.x() << "," << dc.y() << "," << ds.x() << "," << ds.y()
     << "," << d.image_box.u0 << "," << d.image_box.u1 << "," << d.image_box.v0 << ","
     << d.image_box.v1 << "," << d.near_depth << "," << touch_nearer << "," << touch;
}

// The detection's box before refinement, whether it was refined, and its map evidence.
void write_raw_fields(std::ostream& os, const TrackedObstacle& ob, const DetectionList& dets) {
  if (ob.detection < 0 || static_cast<std::size_t>(ob.detection) >= dets.size()) {
    os << ",0,0,0,0,0,0,0";
    return;
  }
  const Detection& d = dets[static_cast<std::size_t>(ob.detection)];
  const Eigen::Vector3f rc = d.raw_box.center(), rs = d.raw_box.size();
  os << "," << rc.x() << "," << rc.y() << "," << rs.x() << "," << rs.y() << "," << d.refined << ","
     << d.ever_free << "," << d.static_share;
}

// One CSV row: the track's internals, the nearest true obstacle, its detection.
void write_track_row(std::ostream& os, std::size_t f, const SequenceFrame& sf,
                     const TrackedObstacle& ob, const std::vector<ObstacleRecord>& listed,
                     std::map<int, double>& turn_rate, const DetectionList& dets) {
  const Eigen::Vector2d c = ob.box.center().head<2>().cast<double>();
  double best = 0.0;
  const ObstacleRecord* near = nearest(listed, c, &best);
  const Eigen::Vector3f sz = ob.box.size();
  os << f << "," << ob.id << "," << c.x() << "," << c.y() << "," << ob.velocity.x() << ","
     << ob.velocity.y() << "," << ob.speed << "," << ob.continuity << "," << ob.dynamic << ","
     << ob.votes << "," << ob.dynamic_votes << "," << ob.age << "," << ob.hits << ","
     << ob.missed_frames << "," << ob.size_fixed << "," << sz.x() << "," << sz.y() << ",";
  if (near != nullptr) {
    const Eigen::Matrix3d Rt = sf.pose.rotation.toRotationMatrix().transpose();
    const double depth_ahead = (Rt * (near->center - sf.pose.translation)).z();
    os << near->id << "," << best << "," << near->velocity.x() << "," << near->velocity.y() << ","
       << near->visible << "," << depth_ahead << "," << turn_rate[near->id];
  } else {
    os << "-1,-1,0,0,0,0,0";
  }
  write_detection_fields(os, ob, dets);
  os << "," << sf.pose.translation.x() << "," << sf.pose.translation.y();
  write_raw_fields(os, ob, dets);
  os << "," << ob.dynamic_streak << "," << sz.z() << "," << std::sqrt(ob.velocity_covariance(0, 0))
     << "," << std::sqrt(ob.velocity_covariance(1, 1)) << "," << ob.cut << "\n";
}

int run(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: dynamap-track-diag SEQ [--params FILE] > diag.csv\n";
    return 2;
  }
  const std::string seq_dir = argv[1];
  const Sequence seq = read_sequence(seq_dir);
  const PipelineConfig config = config_for_sequence(seq, option_value(argc, argv, 2, "--params"));
  const auto pipeline = make_pipeline(config);
  std::map<std::string, std::vector<ObstacleRecord>> truth;  // by stamp text
  for (const ObstacleRecord& r : read_obstacles(join_path(seq_dir, "obstacles.txt"))) {
    truth[r.stamp_text].push_back(r);
  }
  // Previous frame's ground-truth velocity per obstacle id, for the turn rate.
  std::map<int, Eigen::Vector2d> previous_velocity;

  std::cout << "frame,id,x,y,vx,vy,speed,continuity,dynamic,votes,dynamic_votes,age,hits,missed,"
               "size_fixed,sx,sy,gt_id,gt_dist,gt_vx,gt_vy,gt_visible,gt_depth,gt_turn_rate,det,"
               "det_x,det_y,"
               "det_sx,det_sy,det_u0,det_u1,det_v0,det_v1,det_near,det_touch_nearer,det_touch,"
               "cam_x,cam_y,raw_x,raw_y,raw_sx,raw_sy,refined,ever_free,static_share,streak,sz,svx,"
               "svy,cut\n";
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
    const std::vector<ObstacleRecord>& listed = truth[sf.stamp_text];
    std::map<int, double> turn_rate = turn_rates(listed, previous_velocity);
    for (std::size_t k = 0; k < out->num_obstacles; ++k) {
      write_track_row(std::cout, f, sf, out->obstacles[k], listed, turn_rate,
                      pipeline->detections());
    }
  }
  return 0;
}

}  // namespace
}  // namespace dynamap::tools

int main(int argc, char** argv) {
  try {
    return dynamap::tools::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dynamap-track-diag: " << e.what() << "\n";
    return 1;
  }
}
