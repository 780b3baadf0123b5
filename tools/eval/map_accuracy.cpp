#include "eval/map_accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <unordered_map>

#include "common/map_io.hpp"
#include "common/map_truth.hpp"
#include "common/obstacles.hpp"
#include "common/sequence.hpp"
#include "common/static_world.hpp"
#include "common/text_io.hpp"
#include "common/topview.hpp"

namespace dynamap::tools::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double ratio(std::size_t num, std::size_t den) {
  return den == 0 ? kNaN : static_cast<double>(num) / static_cast<double>(den);
}

bool held_with_neighbours(const Eigen::Vector3i& v, const VoxelSet& occupied) {
  for (int dx = -1; dx <= 1; ++dx) {
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dz = -1; dz <= 1; ++dz) {
        if (occupied.count(pack_voxel(v + Eigen::Vector3i(dx, dy, dz))) != 0) return true;
      }
    }
  }
  return false;
}

// The voxel's closed cube touches the box.
bool touches(const Eigen::Vector3i& v, double res, const AlignedBox& b) {
  const Eigen::Vector3d lo = v.cast<double>() * res, hi = lo.array() + res;
  return (hi.array() >= b.min.array()).all() && (lo.array() <= b.max.array()).all();
}

// Walker boxes per frame (stamp_key), from obstacles.txt rows.
using WalkerBoxes = std::map<std::int64_t, std::vector<AlignedBox>>;

WalkerBoxes walker_boxes(const std::vector<ObstacleRecord>& rows) {
  WalkerBoxes boxes;
  for (const ObstacleRecord& r : rows) {
    boxes[stamp_key(r.stamp)].push_back(
        AlignedBox{r.center - 0.5 * r.size, r.center + 0.5 * r.size});
  }
  return boxes;
}

// Everything observe_frame() needs that does not change between frames.
struct ObserveContext {
  const StaticWorld* world = nullptr;
  const ObservationSettings* settings = nullptr;
  VoxelSet surface;                                   // truth surface voxels (boxes, cylinders)
  std::unordered_map<std::int64_t, bool> near_cache;  // near_static_shape() results
  double floor_z = 0.0;
};

bool inside_any(const Eigen::Vector3d& p, const std::vector<AlignedBox>* boxes) {
  if (boxes == nullptr) return false;
  for (const AlignedBox& b : *boxes) {
    if ((p.array() >= b.min.array()).all() && (p.array() <= b.max.array()).all()) return true;
  }
  return false;
}

void classify_end_point(const Eigen::Vector3d& p, const std::vector<AlignedBox>* walkers,
                        ObserveContext& ctx, MapObservation& obs) {
  const double res = ctx.settings->resolution;
  const Eigen::Vector3i v = voxel_of(p, res);
  const std::int64_t key = pack_voxel(v);
  if (inside_any(p, walkers)) {
    if (p.z() < ctx.floor_z + ctx.settings->floor_clearance) return;  // a floor hit
    auto it = ctx.near_cache.find(key);
    if (it == ctx.near_cache.end())
      it = ctx.near_cache.emplace(key, near_static_shape(*ctx.world, v, res, res)).first;
    if (!it->second) obs.walker.insert(key);
    return;
  }
  if (ctx.surface.count(key) != 0) {
    obs.static_surface.insert(key);
  } else if (is_floor_voxel(*ctx.world, v, res)) {
    obs.floor.insert(key);
  }
}

// The end points of one frame, sampled as the map samples them (docs/evaluation.md).
void observe_frame(const Image16& depth, const CameraModel& cam, const PoseD& pose,
                   const std::vector<AlignedBox>* walkers, ObserveContext& ctx,
                   MapObservation& obs) {
  const ObservationSettings& s = *ctx.settings;
  const Eigen::Matrix3d R = pose.rotation.normalized().toRotationMatrix();
  const double scale = 1.0 / cam.depth_factor;
  for (int v = s.pixel_margin; v < cam.height - s.pixel_margin; v += s.pixel_stride) {
    const double dy = (v - cam.cy) / cam.fy;
    for (int u = s.pixel_margin; u < cam.width - s.pixel_margin; u += s.pixel_stride) {
      const std::uint16_t raw = depth.pixels[static_cast<std::size_t>(v) * depth.width + u];
      const double z = raw * scale;
      if (raw == 0 || z > s.max_depth || z < s.min_depth) continue;
      const Eigen::Vector3d offset = R * (Eigen::Vector3d((u - cam.cx) / cam.fx, dy, 1.0) * z);
      if ((offset.array().abs() > s.local_half_extent.array()).any()) continue;  // clipped
      ++obs.end_points;
      classify_end_point(pose.translation + offset, walkers, ctx, obs);
    }
  }
}

// Stamps of the replayed frames: timing.csv has one row per replayed frame.
std::set<std::int64_t> replayed_stamps(const std::string& timing_path) {
  std::set<std::int64_t> stamps;
  const auto lines = read_lines(timing_path);
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const auto f = split_csv(lines[i]);
    if (f.empty() || f[0].empty()) continue;
    stamps.insert(stamp_key(parse_double(f[0], TextLocation{timing_path, i + 1}, "stamp")));
  }
  return stamps;
}

ObservationSettings settings_from(const std::string& summary_path, std::string* said) {
  ObservationSettings s;
  if (!file_exists(summary_path)) {
    *said = "map defaults (no " + summary_path + ")";
    return s;
  }
  const MapSummary m = read_map_summary(summary_path);
  s.resolution = m.number("resolution", s.resolution);
  s.min_depth = m.number("min_depth", s.min_depth);
  s.max_depth = m.number("max_depth", s.max_depth);
  s.pixel_stride = static_cast<int>(m.number("pixel_stride", s.pixel_stride));
  s.pixel_margin = static_cast<int>(m.number("pixel_margin", s.pixel_margin));
  const auto it = m.values.find("local_half_extent");
  if (it != m.values.end() && it->second.size() == 3) {
    for (int a = 0; a < 3; ++a) {
      s.local_half_extent[a] = parse_double(it->second[static_cast<std::size_t>(a)],
                                            TextLocation{summary_path, 0}, "local_half_extent");
    }
  }
  if (!(s.resolution > 0) || s.pixel_stride < 1 || s.pixel_margin < 0)
    throw ToolError(summary_path + ": resolution, pixel_stride or pixel_margin out of range");
  *said = summary_path;
  return s;
}

}  // namespace

MapAccuracy score_map(const MapObservation& observed, const VoxelSet& occupied,
                      const std::vector<AlignedBox>& final_walkers) {
  MapAccuracy r;
  r.available = true;
  const double res = observed.resolution;
  auto score_static = [&](const VoxelSet& set, bool floor) {
    for (std::int64_t key : set) {
      if (floor && observed.static_surface.count(key) != 0) continue;
      const Eigen::Vector3i v = unpack_voxel(key);
      const bool strict = occupied.count(key) != 0;
      const bool held = strict || held_with_neighbours(v, occupied);
      ++r.static_observed;
      r.static_held += held ? 1 : 0;
      r.static_held_strict += strict ? 1 : 0;
      (floor ? r.floor_observed : r.shape_observed) += 1;
      (floor ? r.floor_held : r.shape_held) += held ? 1 : 0;
      if (!held) r.missing_static.push_back(voxel_centre(v, res));
    }
  };
  score_static(observed.static_surface, false);
  score_static(observed.floor, true);
  for (std::int64_t key : observed.walker) {
    const Eigen::Vector3i v = unpack_voxel(key);
    if (std::any_of(final_walkers.begin(), final_walkers.end(),
                    [&](const AlignedBox& b) { return touches(v, res, b); })) {
      ++r.walker_in_final;
      continue;
    }
    ++r.walker_observed;
    if (occupied.count(key) == 0) {
      ++r.walker_cleared;
    } else {
      r.held_walker.push_back(voxel_centre(v, res));
    }
  }
  r.sa = ratio(r.static_held, r.static_observed);
  r.sa_strict = ratio(r.static_held_strict, r.static_observed);
  r.sa_shapes = ratio(r.shape_held, r.shape_observed);
  r.sa_floor = ratio(r.floor_held, r.floor_observed);
  r.da = ratio(r.walker_cleared, r.walker_observed);
  r.aa = std::sqrt(r.sa * r.da);
  return r;
}

void read_map_frames(const std::string& path, MapAccuracy& r) {
  const auto lines = read_lines(path);
  if (lines.empty()) throw ToolError(path + ": empty (expected a header line)");
  const auto header = split_csv(lines[0]);
  const std::vector<std::string> names = {"erased_obstacle_voxels", "free_through_obstacle_voxels",
                                          "erased_obstacle_voxels_all",
                                          "free_through_obstacle_voxels_all"};
  std::vector<std::size_t> col;
  for (const std::string& n : names) {
    const auto it = std::find(header.begin(), header.end(), n);
    if (it == header.end()) fail_at(TextLocation{path, 1}, "no column '" + n + "'");
    col.push_back(static_cast<std::size_t>(it - header.begin()));
  }
  // The bare and whole counts came later: a file without them still scores, without them.
  const std::vector<std::string> bare_names = {"erased_obstacle_voxels_bare",
                                               "erased_obstacle_voxels_bare_all"};
  const std::vector<std::string> whole_names = {"free_through_obstacle_voxels_whole",
                                                "free_through_obstacle_voxels_whole_all"};
  auto columns_of = [&](const std::vector<std::string>& wanted) {
    std::vector<std::size_t> found;
    for (const std::string& n : wanted) {
      const auto it = std::find(header.begin(), header.end(), n);
      if (it != header.end()) found.push_back(static_cast<std::size_t>(it - header.begin()));
    }
    return found;
  };
  const std::vector<std::size_t> bare_col = columns_of(bare_names);
  const std::vector<std::size_t> whole_col = columns_of(whole_names);
  r.bare_available = bare_col.size() == bare_names.size();
  r.whole_available = whole_col.size() == whole_names.size();
  auto count_at = [&](const std::vector<std::string>& f, std::size_t c, const std::string& name,
                      const TextLocation& at) {
    const long long x = parse_int(f[c], at, name.c_str());
    if (x < 0) fail_at(at, "negative count in '" + name + "'");
    return static_cast<std::size_t>(x);
  };
  std::vector<std::size_t> v(names.size());
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const TextLocation at{path, i + 1};
    const auto f = split_csv(lines[i]);
    if (f.size() < header.size()) fail_at(at, "too few columns");
    for (std::size_t k = 0; k < names.size(); ++k) v[k] = count_at(f, col[k], names[k], at);
    if (r.bare_available) {
      r.erased_bare_max = std::max(r.erased_bare_max, count_at(f, bare_col[0], bare_names[0], at));
      r.erased_bare_all_max =
          std::max(r.erased_bare_all_max, count_at(f, bare_col[1], bare_names[1], at));
    }
    if (r.whole_available) {
      r.free_through_whole_max =
          std::max(r.free_through_whole_max, count_at(f, whole_col[0], whole_names[0], at));
      r.free_through_whole_all_max =
          std::max(r.free_through_whole_all_max, count_at(f, whole_col[1], whole_names[1], at));
    }
    r.erased_max = std::max(r.erased_max, v[0]);
    r.free_through_max = std::max(r.free_through_max, v[1]);
    r.erased_all_max = std::max(r.erased_all_max, v[2]);
    r.free_through_all_max = std::max(r.free_through_all_max, v[3]);
    r.free_through_final = v[1];
    r.free_through_final_all = v[3];
    ++r.checked_frames;
  }
  r.frames_available = true;
}

MapAccuracy evaluate_map(const std::string& seq_dir, const std::string& result_dir,
                         const std::string& obstacles_file) {
  const std::string world_path = join_path(seq_dir, "static_world.txt");
  if (!file_exists(world_path))
    throw ToolError(world_path +
                    " is absent: --map scores the map against the true static world, "
                    "which only simulated sequences have");
  const StaticWorld world = read_static_world(world_path);
  std::string said;
  const ObservationSettings settings =
      settings_from(join_path(result_dir, "map_summary.txt"), &said);
  VoxelSet occupied;
  for (const MapVoxel& m : read_map_ply(join_path(result_dir, "map.ply")))
    occupied.insert(pack_voxel(voxel_of(m.centre.cast<double>(), settings.resolution)));
  const Sequence seq = read_sequence(seq_dir);
  const std::string timing = join_path(result_dir, "timing.csv");
  const bool have_timing = file_exists(timing);
  const std::set<std::int64_t> replayed =
      have_timing ? replayed_stamps(timing) : std::set<std::int64_t>{};
  const std::string obstacles_path =
      obstacles_file.empty() ? join_path(seq_dir, "obstacles.txt") : obstacles_file;
  const WalkerBoxes walkers =
      file_exists(obstacles_path) ? walker_boxes(read_obstacles(obstacles_path)) : WalkerBoxes{};
  ObserveContext ctx;
  ctx.world = &world;
  ctx.settings = &settings;
  ctx.floor_z = world.has_floor ? world.floor_z : 0.0;
  for (const auto& v : static_truth_voxels(world, settings.resolution).surface)
    ctx.surface.insert(pack_voxel(v));
  MapObservation obs;
  obs.resolution = settings.resolution;
  std::int64_t final_stamp = std::numeric_limits<std::int64_t>::min();
  Image16 depth;
  for (const SequenceFrame& f : seq.frames) {
    const std::int64_t key = stamp_key(f.stamp);
    if (have_timing && replayed.count(key) == 0) continue;
    std::string problem;
    if (try_load_depth(seq, f, &depth, &problem) != DepthProblem::kNone) continue;
    const auto it = walkers.find(key);
    observe_frame(depth, seq.camera, f.pose, it == walkers.end() ? nullptr : &it->second, ctx, obs);
    ++obs.frames;
    final_stamp = key;
  }
  const auto last = walkers.find(final_stamp);
  MapAccuracy r =
      score_map(obs, occupied, last == walkers.end() ? std::vector<AlignedBox>{} : last->second);
  r.settings = said;
  const std::string frames_csv = join_path(result_dir, "map_frames.csv");
  if (file_exists(frames_csv)) read_map_frames(frames_csv, r);
  return r;
}

std::string format_map_table(const MapAccuracy& r) {
  std::ostringstream o;
  auto num = [](double v) {
    if (std::isnan(v)) return std::string("n/a");
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%.4f", v);
    return std::string(buf);
  };
  auto row = [&](const char* name, const std::string& value, const std::string& detail) {
    char buf[320];
    std::snprintf(buf, sizeof(buf), "  %-26s %10s   %s\n", name, value.c_str(), detail.c_str());
    o << buf;
  };
  auto of = [](std::size_t a, std::size_t b, const char* what) {
    return std::to_string(a) + " / " + std::to_string(b) + " " + what;
  };
  row("map SA", num(r.sa),
      of(r.static_held, r.static_observed, "observed static voxels held (26-nbr)"));
  row("  SA strict", num(r.sa_strict),
      of(r.static_held_strict, r.static_observed, "held (voxel itself)"));
  row("  SA boxes+cylinders", num(r.sa_shapes), of(r.shape_held, r.shape_observed, "held"));
  row("  SA floor", num(r.sa_floor), of(r.floor_held, r.floor_observed, "held"));
  row("map DA", num(r.da),
      of(r.walker_cleared, r.walker_observed, "walker voxels not held") + " (" +
          std::to_string(r.walker_in_final) + " in a final walker box left out)");
  row("map AA", num(r.aa), "sqrt(SA * DA)");
  if (r.frames_available) {
    row("erased obstacle max", std::to_string(r.erased_max),
        "voxels within 3 m, worst of " + std::to_string(r.checked_frames) + " frames (all range " +
            std::to_string(r.erased_all_max) + ")");
    if (r.bare_available)
      row("  of them bare, max", std::to_string(r.erased_bare_max),
          "no occupied voxel among the 26 neighbours (all range " +
              std::to_string(r.erased_bare_all_max) + ")");
    row("free through obst. max", std::to_string(r.free_through_max),
        "voxels within 3 m (all range " + std::to_string(r.free_through_all_max) + ")");
    if (r.whole_available)
      row("  of them whole, max", std::to_string(r.free_through_whole_max),
          "the whole voxel inside a shape, not a boundary voxel (all range " +
              std::to_string(r.free_through_whole_all_max) + ")");
    row("free through obst. final", std::to_string(r.free_through_final),
        "voxels within 3 m at the last frame (all range " +
            std::to_string(r.free_through_final_all) + ")");
  } else {
    row("erased / free through", "n/a", "no map_frames.csv");
  }
  o << "  note: map sampling and range from " << r.settings << "\n";
  return o.str();
}

void write_map_picture(const std::string& png_path, const std::string& seq_dir,
                       const std::string& result_dir, const MapAccuracy& r) {
  TopViewScene pic;
  pic.title = "dynamap-eval --map: " + seq_dir;
  char sub[256];
  std::snprintf(sub, sizeof(sub), "final map: SA %.4f, DA %.4f, AA %.4f", r.sa, r.da, r.aa);
  pic.subtitle = sub;
  pic.static_world = read_static_world(join_path(seq_dir, "static_world.txt"));
  std::string said;
  const ObservationSettings s = settings_from(join_path(result_dir, "map_summary.txt"), &said);
  pic.cell_size = s.resolution;
  const double floor_z = pic.static_world.has_floor ? pic.static_world.floor_z : 0.0;
  for (const MapVoxel& m : read_map_ply(join_path(result_dir, "map.ply"))) {
    if (m.centre.z() > floor_z + 0.25 && m.centre.z() < floor_z + 2.05)
      pic.occupied_cells.push_back(m.centre.cast<double>());
  }
  pic.missing_static_cells = r.missing_static;
  pic.held_dynamic_cells = r.held_walker;
  render_top_view(pic, png_path);
}

}  // namespace dynamap::tools::eval
