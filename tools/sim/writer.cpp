#include "sim/writer.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "common/obstacles.hpp"
#include "common/png_io.hpp"
#include "common/text_io.hpp"
#include "common/topview.hpp"

namespace dynamap::tools::sim {
namespace {

std::string fmt_stamp(double t) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", t);
  return buf;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

std::ofstream open_out(const std::string& path) {
  std::ofstream out(path);
  if (!out) throw ToolError(path + ": cannot create file");
  return out;
}

}  // namespace

std::vector<WalkerState> walker_states(const std::vector<WalkerMotion>& motions, double t) {
  std::vector<WalkerState> states;
  for (const auto& m : motions) {
    WalkerState s;
    s.position = m.position(t);
    s.velocity = m.velocity(t);
    s.radius = m.spec().radius;
    s.height = m.spec().height;
    states.push_back(s);
  }
  return states;
}

namespace {

// depth.txt, groundtruth.txt and obstacles.txt of the sequence, with their headers.
struct SequenceFiles {
  std::ofstream depth_txt, gt_txt, obs_txt;
};

SequenceFiles open_sequence_files(const std::string& out_dir, const Scene& scene,
                                  const SimulateOptions& opt) {
  const std::string header = "# dynamap-sim scene " + scene.name + " seed " +
                             std::to_string(opt.seed) + " frames " + std::to_string(opt.frames) +
                             "\n";
  SequenceFiles files;
  files.depth_txt = open_out(join_path(out_dir, "depth.txt"));
  files.gt_txt = open_out(join_path(out_dir, "groundtruth.txt"));
  files.obs_txt = open_out(join_path(out_dir, "obstacles.txt"));
  files.depth_txt << "# depth maps\n" << header << "# timestamp filename\n";
  files.gt_txt << "# ground-truth trajectory (camera optical frame in world, z up)\n"
               << header << "# timestamp tx ty tz qx qy qz qw\n";
  write_obstacles_header(files.obs_txt);
  return files;
}

// One groundtruth.txt line: stamp, translation, quaternion (x y z w).
void write_pose_line(std::ostream& out, const std::string& stamp, const PoseD& pose) {
  char buf[256];
  const auto& q = pose.rotation;
  std::snprintf(buf, sizeof(buf), "%s %.6f %.6f %.6f %.9f %.9f %.9f %.9f\n", stamp.c_str(),
                pose.translation.x(), pose.translation.y(), pose.translation.z(), q.x(), q.y(),
                q.z(), q.w());
  out << buf;
}

// The frame's walkers as obstacles.txt lines (ids from 1), counted in the summary; their
// positions extend the true paths of the picture.
void write_walker_lines(std::ostream& out, const std::string& stamp,
                        const std::vector<WalkerState>& walkers, const RenderedFrame& frame,
                        double floor_z, SimulateSummary& summary,
                        std::vector<TopViewPath>& gt_paths) {
  for (std::size_t k = 0; k < walkers.size(); ++k) {
    ObstacleRecord r;
    r.stamp_text = stamp;
    r.id = static_cast<int>(k) + 1;
    r.center = {walkers[k].position.x(), walkers[k].position.y(),
                floor_z + 0.5 * walkers[k].height};
    r.velocity = {walkers[k].velocity.x(), walkers[k].velocity.y(), 0.0};
    r.size = {2 * walkers[k].radius, 2 * walkers[k].radius, walkers[k].height};
    r.visible = frame.visible[k];
    write_obstacle_line(out, r);
    ++summary.obstacle_lines;
    if (r.visible >= 0.5) ++summary.visible_obstacle_lines;
    gt_paths[k].points.push_back(walkers[k].position);
    gt_paths[k].id = r.id;
  }
}

// True when two walkers' discs overlap.
bool walkers_overlap(const std::vector<WalkerState>& walkers) {
  bool overlap = false;
  for (std::size_t a = 0; a < walkers.size(); ++a) {
    for (std::size_t b = a + 1; b < walkers.size(); ++b) {
      overlap |= (walkers[a].position - walkers[b].position).norm() <
                 walkers[a].radius + walkers[b].radius;
    }
  }
  return overlap;
}

// scene_topview.png: the static world, the true paths, the camera path and the walkers and
// camera at the last frame.
void write_scene_picture(const Scene& scene, const SimulateOptions& opt, const CameraModel& cam,
                         const CameraMotion& camera_motion,
                         const std::vector<WalkerMotion>& motions,
                         const std::vector<TopViewPath>& gt_paths,
                         const std::vector<Eigen::Vector2d>& cam_path, const std::string& out_dir) {
  TopViewScene pic;
  pic.title = "dynamap-sim scene '" + scene.name + "' (seed " + std::to_string(opt.seed) + ", " +
              std::to_string(opt.frames) + " frames, " +
              std::to_string(static_cast<double>(opt.frames) / scene.fps).substr(0, 4) + " s)";
  pic.subtitle = scene.description;
  pic.static_world = scene.world;
  pic.ground_truth_paths = gt_paths;
  pic.camera_trajectory = cam_path;
  const double t_end = (opt.frames - 1) / scene.fps;
  pic.show_camera = true;
  pic.camera_position = camera_motion.position_xy(t_end);
  pic.camera_yaw = camera_motion.yaw(t_end);
  pic.camera_hfov = 2.0 * std::atan(0.5 * cam.width / cam.fx);
  for (const auto& w : walker_states(motions, t_end)) {
    TopViewObstacle o;
    o.center = w.position;
    o.size = Eigen::Vector2d::Constant(2 * w.radius);
    o.velocity = w.velocity;
    o.dynamic = true;
    char label[64];
    std::snprintf(label, sizeof(label), "person %zu  %.1f m/s", pic.obstacles.size() + 1,
                  w.velocity.norm());
    o.label = label;
    pic.obstacles.push_back(o);
  }
  render_top_view(pic, join_path(out_dir, "scene_topview.png"));
}

}  // namespace

SimulateSummary simulate(const Scene& scene, const std::string& out_dir,
                         const SimulateOptions& opt) {
  if (opt.frames <= 0) throw ToolError("--frames must be positive");
  const auto t_begin = std::chrono::steady_clock::now();
  make_directories(out_dir);
  make_directories(join_path(out_dir, "depth"));
  const CameraModel cam = sim_camera_model();
  write_camera_file(join_path(out_dir, "camera.txt"), cam);
  write_static_world(join_path(out_dir, "static_world.txt"), scene.world);

  std::vector<WalkerMotion> motions;
  for (const auto& w : scene.walkers) motions.emplace_back(w);
  const CameraMotion camera_motion(scene.camera);
  SequenceFiles files = open_sequence_files(out_dir, scene, opt);

  SimulateSummary summary;
  std::vector<TopViewPath> gt_paths(motions.size());
  std::vector<Eigen::Vector2d> cam_path;
  std::vector<double> zero_shares, nothing_shares;
  for (int f = 0; f < opt.frames; ++f) {
    const double t = f / scene.fps;
    const std::string stamp = fmt_stamp(opt.start_stamp + t);
    const PoseD pose = camera_motion.pose(t);
    const auto walkers = walker_states(motions, t);
    RenderOptions ro;
    ro.seed = opt.seed;
    ro.frame_index = static_cast<std::uint64_t>(f);
    ro.noise.enabled = opt.noise;
    const RenderedFrame frame = render_frame(scene, cam, pose, walkers, ro);

    const auto n = static_cast<double>(frame.depth.pixels.size());
    zero_shares.push_back(std::count(frame.depth.pixels.begin(), frame.depth.pixels.end(), 0) / n);
    nothing_shares.push_back(std::count(frame.range.begin(), frame.range.end(), 0.0f) / n);
    const std::string name = "depth/" + stamp + ".png";
    write_png16(join_path(out_dir, name), frame.depth, opt.png_compression);
    if (opt.picture && f == opt.frames / 2) {
      render_depth_preview(
          frame.depth, cam.depth_factor, 8.0,
          "frame " + std::to_string(f) + ": bright = near, dark = far (8 m), dark red = no depth",
          join_path(out_dir, "depth_preview.png"));
    }
    files.depth_txt << stamp << " " << name << "\n";
    write_pose_line(files.gt_txt, stamp, pose);
    write_walker_lines(files.obs_txt, stamp, walkers, frame, scene.world.floor_z, summary,
                       gt_paths);
    summary.walker_overlap_frames += walkers_overlap(walkers) ? 1 : 0;
    cam_path.push_back(pose.translation.head<2>());
    ++summary.frames;
    if (opt.on_frame) opt.on_frame(f + 1, opt.frames);
  }
  files.depth_txt.flush();
  files.gt_txt.flush();
  files.obs_txt.flush();
  if (!files.depth_txt || !files.gt_txt || !files.obs_txt) {
    throw ToolError(out_dir + ": write error");
  }
  summary.zero_share = median(zero_shares);
  summary.nothing_hit_share = median(nothing_shares);
  if (opt.picture) {
    write_scene_picture(scene, opt, cam, camera_motion, motions, gt_paths, cam_path, out_dir);
  }
  summary.seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_begin).count();
  return summary;
}

}  // namespace dynamap::tools::sim
