// dynamap-replay: runs the pipeline over a sequence in the TUM RGB-D layout (docs/data_format.md)
// and writes tracks.csv, detections.csv, predictions.csv (+ predictions_linear.csv), timing.csv and
// top-view pictures, printing progress and a summary. Real sequences have gaps: a listed depth
// file that is missing, unreadable or of the wrong size is skipped, counted and named (exit
// status 3), unless --strict asks to stop at the first one.
//
//   dynamap-replay SEQ --out DIR [--params FILE] [--max-frames N] [--picture-every N] [--quiet]
//                  [--strict] [--poses tum|bonn] [--cpu-clock] [--no-map-checks]
//   dynamap-replay --help-params | --params-markdown
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "common/foxglove.hpp"
#include "common/obstacles.hpp"
#include "common/png_io.hpp"
#include "common/replay_hooks.hpp"
#include "common/results.hpp"
#include "common/sequence.hpp"
#include "common/static_world.hpp"
#include "common/text_io.hpp"
#include "common/topview.hpp"
#include "dynamap/pipeline/pipeline.hpp"
#include "dynamap/platform/clock.hpp"
#include "map_output.hpp"
#include "params.hpp"
#include "platform_clock_tools.hpp"

namespace {

using namespace dynamap;
using namespace dynamap::tools;

struct Options {
  std::string seq;
  std::string out;
  std::string params;
  long max_frames = -1;
  long picture_every = 0;
  bool quiet = false;
  bool cpu_clock = false;
  bool strict = false;
  bool map_checks = true;    // map_frames.csv when the sequence has static_world.txt
  std::string static_model;  // --static-model FILE: holes of the final map against it
  PoseConvention poses = PoseConvention::kTum;
  ReplayExtras extras;  // ROS 2 bags and the Foxglove output (common/replay_hooks.hpp)
};

// Exit status of a run that completed but skipped listed depth files (docs/tools.md).
constexpr int kExitCompletedWithGaps = 3;

std::uint64_t thread_cpu_clock() {
  return dynamap::platform::thread_cpu_ns();
}

void usage(std::ostream& os) {
  os << "usage: dynamap-replay SEQ --out DIR [--params FILE] [--max-frames N]\n"
        "                      [--picture-every N] [--quiet] [--strict] [--poses tum|bonn]\n"
        "                      [--cpu-clock] [--no-map-checks] [--static-model FILE]\n"
        "       dynamap-replay --help-params | --params-markdown\n"
        "Runs the dynamap pipeline over SEQ (TUM RGB-D layout, see docs/data_format.md) and\n"
        "writes DIR/tracks.csv, DIR/detections.csv, DIR/predictions.csv,\n"
        "DIR/predictions_linear.csv, DIR/timing.csv, DIR/topview.png (final state),\n"
        "DIR/map.ply and DIR/map_summary.txt (the final map), DIR/map_frames.csv (per-frame\n"
        "checks of the map against SEQ/static_world.txt, when present) and, with\n"
        "--picture-every N, DIR/frames/frame_NNNNN.png.\n"
        "--no-map-checks: no map_frames.csv (the other outputs are the same either way).\n"
        "--static-model FILE: a PLY of static surface voxel centres (dynamap-label\n"
        "  --static-model): counts the final map's holes (model voxels in the local region\n"
        "  held free) into map_summary.txt, writes them to DIR/model_holes.ply.\n"
        "--params FILE: YAML with PipelineConfig keys (e.g. 'map: {resolution: 0.1}').\n"
        "--help-params: every key with its value, tier, valid range and meaning\n"
        "  (docs/parameters.md); --params-markdown prints that page's tables.\n"
        "--strict: stop at the first listed depth file that is missing, unreadable or of the\n"
        "  wrong size (default: skip it, count it, name it, go on, and exit with status 3).\n"
        "--poses bonn: the poses are the Bonn RGB-D Dynamic dataset's as published\n"
        "  (groundtruth_bonn.txt, else groundtruth.txt; marker frame, y-up world); they are\n"
        "  converted to the camera's optical frame in a z-up world. Default: tum.\n"
        "--cpu-clock: time the stages with the thread's CPU clock instead of the wall clock\n"
        "  (for timing tables on a shared, loaded machine).\n"
        "Exit status: 0 every listed image with a pose was replayed, 3 completed but depth files\n"
        "were skipped, 1 error, 2 usage.\n"
     << bag_options_usage();
}

// --help, --help-params and --params-markdown print their text on stdout: true for those.
bool print_help(const std::string& a) {
  if (a == "--help" || a == "-h") {
    usage(std::cout);
  } else if (a == "--help-params") {
    for (const std::string& line : describe_params(replay_defaults(), true)) {
      std::cout << line << "\n";
    }
  } else if (a == "--params-markdown") {
    std::cout << parameters_markdown();
  } else {
    return false;
  }
  return true;
}

// --poses tum|bonn; false (with the message on stderr) for anything else.
bool parse_poses(const std::string& p, PoseConvention& poses) {
  if (p == "tum") {
    poses = PoseConvention::kTum;
  } else if (p == "bonn") {
    poses = PoseConvention::kBonn;
  } else {
    std::cerr << "dynamap-replay: --poses takes tum or bonn, not '" << p << "'\n";
    return false;
  }
  return true;
}

bool parse_args(int argc, char** argv, Options& o, int& exit_code) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](const char* name) -> const char* {
      if (i + 1 >= argc) {
        std::cerr << "dynamap-replay: " << name << " needs a value\n";
        return nullptr;
      }
      return argv[++i];
    };
    auto number = [&](const char* name, long& target) {
      const char* v = value(name);
      if (v == nullptr) return false;
      char* end = nullptr;
      target = std::strtol(v, &end, 10);
      if (*end != '\0' || target < 0) {
        std::cerr << "dynamap-replay: " << name << " takes a non-negative integer, not '" << v
                  << "'\n";
        return false;
      }
      return true;
    };
    if (print_help(a)) {
      exit_code = 0;
      return false;
    } else if (a == "--out") {
      const char* v = value("--out");
      if (v == nullptr) return false;
      o.out = v;
    } else if (a == "--params") {
      const char* v = value("--params");
      if (v == nullptr) return false;
      o.params = v;
    } else if (a == "--max-frames") {
      if (!number("--max-frames", o.max_frames)) return false;
    } else if (a == "--picture-every") {
      if (!number("--picture-every", o.picture_every)) return false;
    } else if (a == "--quiet") {
      o.quiet = true;
    } else if (a == "--cpu-clock") {
      o.cpu_clock = true;
    } else if (a == "--strict") {
      o.strict = true;
    } else if (a == "--no-map-checks") {
      o.map_checks = false;
    } else if (a == "--static-model") {
      const char* v = value("--static-model");
      if (v == nullptr) return false;
      o.static_model = v;
    } else if (a == "--poses") {
      const char* v = value("--poses");
      if (v == nullptr) return false;
      if (!parse_poses(v, o.poses)) return false;
    } else if (bool bad = false; parse_replay_extra(argc, argv, i, o.extras, bad)) {
      if (bad) return false;
    } else if (!a.empty() && a[0] == '-') {
      std::cerr << "dynamap-replay: unknown option '" << a << "'\n";
      usage(std::cerr);
      return false;
    } else if (o.seq.empty()) {
      o.seq = a;
    } else {
      std::cerr << "dynamap-replay: unexpected argument '" << a << "'\n";
      return false;
    }
  }
  if (o.seq.empty() || o.out.empty()) {
    usage(std::cerr);
    return false;
  }
  return true;
}

std::ofstream open_out(const std::string& path) {
  std::ofstream f(path);
  if (!f) throw ToolError(path + ": cannot open for writing");
  f << std::setprecision(6) << std::fixed;
  return f;
}

// Everything the pictures need, accumulated while replaying.
struct PictureState {
  std::map<std::uint32_t, std::vector<Eigen::Vector2d>> dynamic_paths;  // by track id
  std::vector<Eigen::Vector2d> camera;
};

TopViewScene build_scene(const Pipeline& pipeline, const FrameOutput& out, const PictureState& ps,
                         const StaticWorld* world, const std::vector<ObstacleRecord>& truth,
                         double until_stamp, const Pose& camera_pose, const CameraModel& cam,
                         const std::string& title, const std::string& subtitle) {
  TopViewScene s;
  s.title = title;
  s.subtitle = subtitle;
  s.cell_size = pipeline.map().resolution();
  const float z_lo = pipeline.config().ground_height + 0.25f;
  pipeline.map().for_each_occupied([&](std::uint64_t, const Eigen::Vector3f& c) {
    if (c.z() > z_lo && c.z() < z_lo + 1.8f) s.occupied_cells.push_back(c.cast<double>());
  });
  if (world != nullptr) s.static_world = *world;
  for (std::size_t i = 0; i < out.num_obstacles; ++i) {
    const TrackedObstacle& o = out.obstacles[i];
    TopViewObstacle t;
    t.center = o.box.center().head<2>().cast<double>();
    t.size = o.box.size().head<2>().cast<double>();
    t.velocity = o.velocity.head<2>().cast<double>();
    t.dynamic = o.dynamic;
    std::ostringstream label;
    label << o.id;
    if (o.dynamic) label << "  " << std::setprecision(2) << std::fixed << o.speed << " m/s";
    t.label = label.str();
    s.obstacles.push_back(t);
  }
  for (const auto& [id, pts] : ps.dynamic_paths) {
    if (pts.size() >= 2) s.tracked_paths.push_back(TopViewPath{pts, static_cast<int>(id)});
  }
  // Ground truth: each obstacle's path up to now, and its box at the current stamp.
  std::map<int, TopViewPath> gt;
  for (const ObstacleRecord& r : truth) {
    if (r.stamp > until_stamp + 1e-6) continue;
    TopViewPath& p = gt[r.id];
    p.id = r.id;
    p.points.push_back(r.center.head<2>());
    if (std::fabs(r.stamp - until_stamp) < 1e-6) {
      TopViewObstacle b;
      b.center = r.center.head<2>();
      b.size = r.size.head<2>();
      b.velocity = r.velocity.head<2>();
      b.dynamic = true;
      s.ground_truth_boxes.push_back(b);
    }
  }
  for (auto& [id, p] : gt) s.ground_truth_paths.push_back(p);
  auto path_of = [](const PathPrediction& pr) {
    TopViewPath p;
    p.id = static_cast<int>(pr.track_id);
    for (std::size_t k = 0; k < pr.num_samples; ++k) {
      p.points.push_back(pr.position[k].head<2>().cast<double>());
    }
    return p;
  };
  for (std::size_t i = 0; i < out.num_predictions; ++i) {
    s.predicted_paths.push_back(path_of(out.predictions[i]));
    if (pipeline.config().run_linear_baseline) {
      s.linear_paths.push_back(path_of(out.linear_predictions[i]));
    }
  }
  s.camera_trajectory = ps.camera;
  s.show_camera = true;
  s.camera_position = camera_pose.translation.head<2>().cast<double>();
  const Eigen::Vector3f forward = camera_pose.rotation * Eigen::Vector3f::UnitZ();
  s.camera_yaw = std::atan2(forward.y(), forward.x());
  s.camera_hfov = 2.0 * std::atan2(0.5 * cam.width, cam.fx);
  s.camera_range = pipeline.config().map.max_depth;
  return s;
}

double percentile_ms(std::vector<double> v, double p) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const std::size_t r = static_cast<std::size_t>(std::ceil(p * static_cast<double>(v.size())));
  return v[std::min(v.size() - 1, r == 0 ? 0 : r - 1)];
}

// Listed depth files that could not be used, by problem, for the summary.
struct SkippedDepth {
  std::map<DepthProblem, std::size_t> count;
  std::vector<std::string> messages;
  std::size_t total() const {
    std::size_t n = 0;
    for (const auto& [problem, k] : count) n += k;
    return n;
  }
};

void write_detection_rows(std::ostream& out, const std::string& stamp_text,
                          const DetectionList& detections) {
  for (std::size_t k = 0; k < detections.size(); ++k) {
    const Detection& d = detections[k];
    const Eigen::Vector3f c = d.box.center(), sz = d.box.size();
    out << stamp_text << "," << k << "," << c.x() << "," << c.y() << "," << c.z() << "," << sz.x()
        << "," << sz.y() << "," << sz.z() << "," << d.image_box.u0 << "," << d.image_box.v0 << ","
        << d.image_box.u1 << "," << d.image_box.v1 << "," << (d.refined ? 1 : 0) << "\n";
  }
}

// The final map against --static-model (docs/evaluation.md, "Map accuracy").
void print_model_holes(const ModelHoleCounts& h, float max_depth) {
  std::printf(
      "  map holes vs static model: %zu of %zu model voxels in range held free (%.2f %%); "
      "%zu occupied, %zu unknown; within %.1f m of the camera: %zu of %zu (%.2f %%)%s "
      "(model_holes.ply)\n",
      h.region.free, h.region.voxels, h.region.free_percent(), h.region.occupied, h.region.unknown,
      static_cast<double>(max_depth), h.depth.free, h.depth.voxels, h.depth.free_percent(),
      h.misaligned > 0
          ? ("; " + std::to_string(h.misaligned) + " model voxels off the grid").c_str()
          : "");
}

// The sequence, checked against the library's image size limit; its warnings on stderr.
Sequence read_replay_sequence(const Options& o) {
  SequenceReadOptions read_options;
  read_options.poses = o.poses;
  read_options.bag = o.extras.bag;
  Sequence seq = read_sequence(o.seq, read_options);
  if (seq.frames.empty()) throw ToolError(o.seq + ": no depth image has a pose; nothing to replay");
  for (const std::string& w : seq.warnings) std::cerr << "warning: " << w << "\n";
  const CameraModel& cam = seq.camera;
  if (cam.width > kMaxImageWidth || cam.height > kMaxImageHeight) {
    throw ToolError(o.seq + "/camera.txt: image " + std::to_string(cam.width) + "x" +
                    std::to_string(cam.height) + " is larger than the library's maximum " +
                    std::to_string(kMaxImageWidth) + "x" + std::to_string(kMaxImageHeight));
  }
  return seq;
}

// A simulated sequence's truth: static_world.txt and obstacles.txt, each when present.
struct Truth {
  std::unique_ptr<StaticWorld> world;
  std::vector<ObstacleRecord> obstacles;
};

Truth read_truth(const std::string& seq_dir) {
  Truth t;
  const std::string world_path = join_path(seq_dir, "static_world.txt");
  if (file_exists(world_path))
    t.world = std::make_unique<StaticWorld>(read_static_world(world_path));
  const std::string truth_path = join_path(seq_dir, "obstacles.txt");
  if (file_exists(truth_path)) t.obstacles = read_obstacles(truth_path);
  return t;
}

// The per-frame CSV files, with their header lines.
struct OutputFiles {
  std::ofstream tracks, preds, linear, timing, detections;
};

OutputFiles open_outputs(const Options& o) {
  make_directories(o.out, "cannot create the output directory");
  if (o.picture_every > 0)
    make_directories(join_path(o.out, "frames"), "cannot create the output directory");
  OutputFiles f;
  f.tracks = open_out(join_path(o.out, "tracks.csv"));
  f.preds = open_out(join_path(o.out, "predictions.csv"));
  f.linear = open_out(join_path(o.out, "predictions_linear.csv"));
  f.timing = open_out(join_path(o.out, "timing.csv"));
  f.detections = open_out(join_path(o.out, "detections.csv"));
  f.tracks << "stamp,id,x,y,z,vx,vy,vz,sx,sy,sz,dynamic,path,svx,svy\n";
  f.detections << "stamp,index,x,y,z,sx,sy,sz,u0,v0,u1,v1,refined\n";
  f.preds << "stamp,id,path,probability,k,t,x,y,z\n";
  f.linear << "stamp,id,path,probability,k,t,x,y,z\n";
  f.timing << "stamp";
  for (std::size_t k = 0; k < kStageCount; ++k) f.timing << "," << to_string(static_cast<Stage>(k));
  f.timing << ",total\n";
  return f;
}

// What the summary reports, gathered frame by frame.
struct ReplayTally {
  std::set<std::uint32_t> ids, dynamic_ids;
  std::size_t rejected = 0, pictures = 0;
  SkippedDepth skipped;
  std::vector<double> decode_ms, process_ms;
  std::array<std::vector<double>, kStageCount> stage_ms;
  Pose last_pose;
  double last_stamp = 0.0;
};

// tracks.csv: every obstacle; path = chosen prediction of a dynamic track, else -1. Notes the
// ids and the dynamic tracks' paths for the pictures.
void write_track_rows(std::ostream& tracks, const std::string& stamp_text, const FrameOutput& out,
                      ReplayTally& tally, PictureState& ps) {
  for (std::size_t k = 0; k < out.num_obstacles; ++k) {
    const TrackedObstacle& ob = out.obstacles[k];
    int path = -1;
    for (std::size_t j = 0; j < out.num_predictions; ++j) {
      if (out.predictions[j].track_id == ob.id) path = static_cast<int>(out.predictions[j].chosen);
    }
    const Eigen::Vector3f c = ob.box.center(), sz = ob.box.size();
    tracks << stamp_text << "," << ob.id << "," << c.x() << "," << c.y() << "," << c.z() << ","
           << ob.velocity.x() << "," << ob.velocity.y() << "," << ob.velocity.z() << "," << sz.x()
           << "," << sz.y() << "," << sz.z() << "," << (ob.dynamic ? 1 : 0) << "," << path << ","
           << std::sqrt(ob.velocity_covariance(0, 0)) << ","
           << std::sqrt(ob.velocity_covariance(1, 1)) << "\n";
    tally.ids.insert(ob.id);
    if (ob.dynamic) {
      tally.dynamic_ids.insert(ob.id);
      ps.dynamic_paths[ob.id].push_back(c.head<2>().cast<double>());
    }
  }
}

// predictions.csv, predictions_linear.csv and timing.csv rows of one frame.
void write_prediction_and_timing_rows(OutputFiles& f, const std::string& stamp_text,
                                      const FrameOutput& out, bool linear_baseline) {
  for (std::size_t j = 0; j < out.num_predictions; ++j) {
    write_prediction_rows(f.preds, stamp_text, out.predictions[j]);
    if (linear_baseline) write_prediction_rows(f.linear, stamp_text, out.linear_predictions[j]);
  }
  f.timing << stamp_text;
  for (std::size_t k = 0; k < kStageCount; ++k)
    f.timing << "," << 1e-3 * static_cast<double>(out.stage_ns[k]);
  f.timing << "," << 1e-3 * static_cast<double>(out.total_ns) << "\n";
}

// The frames, one by one: decode, process, write the per-frame rows and pictures, tally.
class FrameLoop {
 public:
  FrameLoop(const Options& o, const Sequence& seq, const PipelineConfig& config, Pipeline& pipeline,
            const Truth& truth, FoxgloveOutput* foxglove, OutputFiles& files, MapFrameLog* map_log)
      : o_(o),
        seq_(seq),
        config_(config),
        pipeline_(pipeline),
        truth_(truth),
        foxglove_(foxglove),
        files_(files),
        map_log_(map_log) {}

  // Frames [0, n); progress on stderr unless --quiet.
  void run(std::size_t n) {
    t_start_ = wall_seconds();
    double t_report = t_start_;
    for (std::size_t i = 0; i < n; ++i) {
      frame(i);
      const double now = wall_seconds();
      if (!o_.quiet && (now - t_report > 1.0 || i + 1 == n)) {
        std::fprintf(stderr, "\rreplay: frame %zu/%zu  (%.0f frames/s)   ", i + 1, n,
                     static_cast<double>(i + 1) / std::max(1e-9, now - t_start_));
        t_report = now;
      }
    }
  }

  // The top view of the current state (its truth up to `stamp`).
  TopViewScene scene(double stamp, const std::string& title, const std::string& subtitle) const {
    return build_scene(pipeline_, *out_, ps_, truth_.world.get(), truth_.obstacles, stamp,
                       tally_.last_pose, seq_.camera, title, subtitle);
  }

  double start_seconds() const { return t_start_; }
  const ReplayTally& tally() const { return tally_; }

 private:
  void frame(std::size_t i) {
    const SequenceFrame& sf = seq_.frames[i];
    const double t0 = wall_seconds();
    if (!load(sf)) return;
    tally_.decode_ms.push_back(1e3 * (wall_seconds() - t0));
    Frame frame;
    frame.stamp = seq_.stamp_ns(sf.stamp);
    frame.T_map_camera = to_pose(sf.pose);
    frame.depth = DepthView{depth_.pixels.data(), depth_.width, depth_.height,
                            depth_.width * static_cast<int>(sizeof(std::uint16_t))};
    const Status s = pipeline_.process(frame, *out_);
    if (!ok(s)) {
      ++tally_.rejected;
      std::cerr << "warning: " << sf.depth_path << " at " << sf.stamp_text
                << ": frame rejected: " << to_string(s) << "\n";
      return;
    }
    tally_.process_ms.push_back(1e-6 * static_cast<double>(out_->total_ns));
    for (std::size_t k = 0; k < kStageCount; ++k) {
      tally_.stage_ms[k].push_back(1e-6 * static_cast<double>(out_->stage_ns[k]));
    }
    tally_.last_pose = frame.T_map_camera;
    tally_.last_stamp = sf.stamp;
    ps_.camera.push_back(frame.T_map_camera.translation.head<2>().cast<double>());
    write_outputs(sf, frame);
    if (o_.picture_every > 0 && i % static_cast<std::size_t>(o_.picture_every) == 0) {
      char name[64];
      std::snprintf(name, sizeof(name), "frames/frame_%05zu.png", i);
      render_top_view(scene(sf.stamp, "dynamap  " + o_.seq,
                            "frame " + std::to_string(i) + "  t = " + sf.stamp_text),
                      join_path(o_.out, name));
      ++tally_.pictures;
    }
  }

  // The frame's depth image into depth_; a file that cannot be used is counted and named (or
  // stops the replay with --strict).
  bool load(const SequenceFrame& sf) {
    std::string problem_text;
    const DepthProblem problem = try_load_depth(seq_, sf, &depth_, &problem_text);
    if (problem == DepthProblem::kNone) return true;
    if (o_.strict) throw ToolError(problem_text + " (--strict)");
    ++tally_.skipped.count[problem];
    tally_.skipped.messages.push_back(problem_text);
    std::cerr << (o_.quiet ? "" : "\n") << "warning: skipped: " << problem_text << "\n";
    return false;
  }

  // The per-frame rows (tracks, Foxglove, detections, predictions, timing, map checks).
  void write_outputs(const SequenceFrame& sf, const Frame& frame) {
    write_track_rows(files_.tracks, sf.stamp_text, *out_, tally_, ps_);
    if (foxglove_ != nullptr) {
      foxglove_->frame(sf, frame.stamp, depth_, frame.T_map_camera, pipeline_, *out_);
    }
    write_detection_rows(files_.detections, sf.stamp_text, pipeline_.detections());
    write_prediction_and_timing_rows(files_, sf.stamp_text, *out_, config_.run_linear_baseline);
    if (map_log_ != nullptr)
      map_log_->record(pipeline_.map(), sf.stamp_text, frame.T_map_camera.translation);
  }

  const Options& o_;
  const Sequence& seq_;
  const PipelineConfig& config_;
  Pipeline& pipeline_;
  const Truth& truth_;
  FoxgloveOutput* foxglove_;
  OutputFiles& files_;
  MapFrameLog* map_log_;
  std::unique_ptr<FrameOutput> out_ = std::make_unique<FrameOutput>();
  PictureState ps_;
  ReplayTally tally_;
  Image16 depth_;
  double t_start_ = 0.0;
};

// Summary: the listed depth files that were skipped, by problem, the first ones named.
void print_skipped(const SkippedDepth& skipped) {
  std::printf("  skipped depth files:");
  const char* sep = " ";
  for (const auto& [problem, k] : skipped.count) {
    std::printf("%s%zu %s", sep, k, to_string(problem));
    sep = ", ";
  }
  std::printf("\n");
  constexpr std::size_t kNamed = 10;  // a long list of gaps would bury the summary
  for (std::size_t k = 0; k < std::min(kNamed, skipped.messages.size()); ++k) {
    std::printf("    %s\n", skipped.messages[k].c_str());
  }
  if (skipped.messages.size() > kNamed) {
    std::printf("    ... and %zu more (each one is on stderr)\n", skipped.messages.size() - kNamed);
  }
}

// Summary: per-stage time per frame (median, p99, max) and the pipeline's counters.
void print_times_and_counters(const Options& o, const ReplayTally& t, const PipelineCounters& c) {
  std::printf("  time per frame (ms, %s)   median     p99     max\n",
              o.cpu_clock ? "thread CPU time" : "wall time");
  for (std::size_t k = 0; k < kStageCount; ++k) {
    std::printf("    %-16s %9.3f %7.3f %7.3f\n", to_string(static_cast<Stage>(k)),
                percentile_ms(t.stage_ms[k], 0.5), percentile_ms(t.stage_ms[k], 0.99),
                percentile_ms(t.stage_ms[k], 1.0));
  }
  std::printf("    %-16s %9.3f %7.3f %7.3f\n", "total", percentile_ms(t.process_ms, 0.5),
              percentile_ms(t.process_ms, 0.99), percentile_ms(t.process_ms, 1.0));
  std::printf("    %-16s %9.3f %7.3f %7.3f\n", "png decode", percentile_ms(t.decode_ms, 0.5),
              percentile_ms(t.decode_ms, 0.99), percentile_ms(t.decode_ms, 1.0));
  std::printf(
      "  counters: rays dropped %llu, blocks evicted %llu, detections dropped %llu, "
      "groups split %llu, tracks refused %llu, frames rejected %llu, step errors %llu\n",
      static_cast<unsigned long long>(c.rays_dropped),
      static_cast<unsigned long long>(c.blocks_evicted),
      static_cast<unsigned long long>(c.detections_dropped),
      static_cast<unsigned long long>(c.groups_split),
      static_cast<unsigned long long>(c.tracks_refused),
      static_cast<unsigned long long>(c.frames_rejected),
      static_cast<unsigned long long>(c.step_errors));
}

// What a replay prints when it is done.
struct ReplayReport {
  std::size_t n = 0;     // frames attempted
  double elapsed = 0.0;  // s, wall time of the frame loop
  FinalMapCounts map;    // the final map
  const MapFrameLog* map_log = nullptr;
};

void print_summary(const Options& o, const Sequence& seq, const PipelineConfig& config,
                   const Pipeline& pipeline, const ReplayTally& t, const ReplayReport& r) {
  std::printf("dynamap-replay %s -> %s\n", o.seq.c_str(), o.out.c_str());
  std::printf("  poses: %s%s\n", seq.pose_file.c_str(),
              o.poses == PoseConvention::kBonn ? " (Bonn marker poses, converted)" : "");
  std::printf(
      "  frames: %zu listed, %zu without pose (skipped), %zu depth files skipped, %zu processed, "
      "%zu rejected\n",
      seq.images_listed, seq.images_without_pose, t.skipped.total(), t.process_ms.size(),
      t.rejected);
  if (t.skipped.total() > 0) print_skipped(t.skipped);
  std::printf("  tracks: %zu ids, %zu ever labelled dynamic\n", t.ids.size(), t.dynamic_ids.size());
  print_times_and_counters(o, t, pipeline.counters());
  std::printf("  wall time %.2f s (%.1f frames/s incl. PNG decode and output)\n", r.elapsed,
              static_cast<double>(r.n) / std::max(1e-9, r.elapsed));
  std::printf(
      "  wrote tracks.csv, detections.csv, predictions.csv, predictions_linear.csv, timing.csv, "
      "topview.png%s\n",
      t.pictures > 0 ? (", " + std::to_string(t.pictures) + " pictures in frames/").c_str() : "");
  std::printf(
      "  final map: %zu occupied voxels (map.ply, map_summary.txt); local region: %zu occupied, "
      "%zu free, %zu unknown; written in %.1f ms\n",
      r.map.occupied, r.map.region_occupied, r.map.region_free, r.map.region_unknown,
      1e3 * r.map.seconds);
  if (r.map_log != nullptr) std::printf("  %s (map_frames.csv)\n", r.map_log->summary().c_str());
  if (r.map.has_model) print_model_holes(r.map.model, config.map.max_depth);
}

int run(const Options& o) {
  const Sequence seq = read_replay_sequence(o);
  const PipelineConfig config = config_for_sequence(seq, o.params);
  const auto pipeline = make_pipeline(config);
  if (o.cpu_clock) pipeline->set_clock(&thread_cpu_clock);
  const Truth truth = read_truth(o.seq);
  const auto foxglove = make_foxglove_output(o.extras, seq, truth.obstacles);
  std::vector<MapVoxel> model;  // read before the replay: a bad file fails at once
  if (!o.static_model.empty()) model = read_map_ply(o.static_model);
  OutputFiles files = open_outputs(o);
  std::unique_ptr<MapFrameLog> map_log;
  if (truth.world != nullptr && o.map_checks)
    map_log = std::make_unique<MapFrameLog>(*truth.world, pipeline->map(), o.out);

  FrameLoop loop(o, seq, config, *pipeline, truth, foxglove.get(), files, map_log.get());
  ReplayReport report;
  report.n = o.max_frames >= 0 ? std::min(seq.frames.size(), static_cast<std::size_t>(o.max_frames))
                               : seq.frames.size();
  loop.run(report.n);
  if (!o.quiet) std::fprintf(stderr, "\n");
  if (foxglove) foxglove->close();
  report.elapsed = wall_seconds() - loop.start_seconds();
  const ReplayTally& t = loop.tally();
  if (t.process_ms.empty()) {
    throw ToolError(o.seq + ": none of the " + std::to_string(report.n) +
                    " frames could be replayed (see the warnings above)");
  }
  render_top_view(loop.scene(t.last_stamp, "dynamap: final state of " + o.seq,
                             std::to_string(report.n) + " frames, " +
                                 std::to_string(t.dynamic_ids.size()) + " dynamic tracks"),
                  join_path(o.out, "topview.png"));
  report.map = write_final_map(pipeline->map(), config, t.last_pose, t.process_ms.size(), o.out,
                               o.static_model.empty() ? nullptr : &model);
  report.map_log = map_log.get();
  print_summary(o, seq, config, *pipeline, t, report);
  return t.skipped.total() > 0 ? kExitCompletedWithGaps : 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  int exit_code = 2;
  if (!parse_args(argc, argv, o, exit_code)) return exit_code;
  try {
    return run(o);
  } catch (const std::exception& e) {
    std::cerr << "dynamap-replay: error: " << e.what() << "\n";
    return 1;
  }
}
