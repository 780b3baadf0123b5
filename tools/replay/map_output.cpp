#include "map_output.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <utility>
#include <vector>

#include "common/map_io.hpp"
#include "common/text_io.hpp"
#include "platform_clock_tools.hpp"

namespace dynamap::tools {
namespace {

std::string num(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

FinalMapCounts count_region(const OccupancyMap& map, const Eigen::Vector3f& camera,
                            const Eigen::Vector3f& half) {
  FinalMapCounts n;
  map.for_each_occupied([&](std::uint64_t, const Eigen::Vector3f&) { ++n.occupied; });
  const double res = map.resolution();
  const Eigen::Vector3i lo = voxel_of((camera - half).cast<double>(), res);
  const Eigen::Vector3i hi = voxel_of((camera + half).cast<double>(), res);
  for (int i = lo.x(); i <= hi.x(); ++i) {
    for (int j = lo.y(); j <= hi.y(); ++j) {
      for (int k = lo.z(); k <= hi.z(); ++k) {
        const Eigen::Vector3f c = voxel_centre(Eigen::Vector3i(i, j, k), res).cast<float>();
        if (((c - camera).array().abs() > half.array()).any()) continue;
        ++n.region;
        switch (map.state(c)) {
          case Occupancy::kOccupied:
            ++n.region_occupied;
            break;
          case Occupancy::kFree:
            ++n.region_free;
            break;
          case Occupancy::kUnknown:
            ++n.region_unknown;
            break;
        }
      }
    }
  }
  return n;
}

// map_summary.txt keys of the map against the static model.
void add_model_entries(const ModelHoleCounts& h,
                       std::vector<std::pair<std::string, std::string>>* entries) {
  auto add = [&](const std::string& prefix, const ModelHoleCounts::States& s) {
    entries->emplace_back(prefix + "_voxels", std::to_string(s.voxels));
    entries->emplace_back(prefix + "_occupied", std::to_string(s.occupied));
    entries->emplace_back(prefix + "_free", std::to_string(s.free));
    entries->emplace_back(prefix + "_unknown", std::to_string(s.unknown));
    entries->emplace_back(prefix + "_free_percent", num(s.free_percent()));
  };
  add("model_region", h.region);
  add("model_within_max_depth", h.depth);
  entries->emplace_back("model_misaligned", std::to_string(h.misaligned));
}

}  // namespace

MapFrameLog::MapFrameLog(const StaticWorld& world, const OccupancyMap& map,
                         const std::string& out_dir)
    : setup_seconds_(wall_seconds()),
      checker_(world, map),
      path_(join_path(out_dir, "map_frames.csv")) {
  setup_seconds_ = wall_seconds() - setup_seconds_;
  csv_.open(path_);
  if (!csv_) throw ToolError(path_ + ": cannot open for writing");
  csv_ << "stamp,erased_obstacle_voxels,free_through_obstacle_voxels,erased_obstacle_voxels_all,"
          "free_through_obstacle_voxels_all,erased_obstacle_voxels_bare,"
          "erased_obstacle_voxels_bare_all,free_through_obstacle_voxels_whole,"
          "free_through_obstacle_voxels_whole_all\n";
}

void MapFrameLog::record(const OccupancyMap& map, const std::string& stamp_text,
                         const Eigen::Vector3f& camera) {
  const double t0 = wall_seconds();
  const MapFrameChecker::Counts n = checker_.check(map, camera, kMapCheckNearRadius);
  seconds_ += wall_seconds() - t0;
  ++frames_;
  max_.erased_near = std::max(max_.erased_near, n.erased_near);
  max_.free_through_near = std::max(max_.free_through_near, n.free_through_near);
  max_.erased_all = std::max(max_.erased_all, n.erased_all);
  max_.free_through_all = std::max(max_.free_through_all, n.free_through_all);
  max_.erased_bare_near = std::max(max_.erased_bare_near, n.erased_bare_near);
  max_.erased_bare_all = std::max(max_.erased_bare_all, n.erased_bare_all);
  max_.free_through_whole_near = std::max(max_.free_through_whole_near, n.free_through_whole_near);
  max_.free_through_whole_all = std::max(max_.free_through_whole_all, n.free_through_whole_all);
  csv_ << stamp_text << "," << n.erased_near << "," << n.free_through_near << "," << n.erased_all
       << "," << n.free_through_all << "," << n.erased_bare_near << "," << n.erased_bare_all << ","
       << n.free_through_whole_near << "," << n.free_through_whole_all << "\n";
  if (!csv_) throw ToolError(path_ + ": write error");
}

std::string MapFrameLog::summary() const {
  char buf[512];
  std::snprintf(
      buf, sizeof(buf),
      "map checks: %zu surface + %zu interior truth voxels, worst frame within %.0f m: "
      "%zu erased obstacle (%zu bare), %zu free through obstacle voxels (%zu whole; all "
      "range %zu, %zu); "
      "added time %.3f ms/frame (+%.1f ms setup)",
      checker_.surface_voxels(), checker_.interior_voxels(),
      static_cast<double>(kMapCheckNearRadius), max_.erased_near, max_.erased_bare_near,
      max_.free_through_near, max_.free_through_whole_near, max_.erased_all, max_.free_through_all,
      frames_ > 0 ? 1e3 * seconds_ / static_cast<double>(frames_) : 0.0, 1e3 * setup_seconds_);
  return buf;
}

FinalMapCounts write_final_map(const OccupancyMap& map, const PipelineConfig& config,
                               const Pose& last_pose, std::size_t frames,
                               const std::string& out_dir,
                               const std::vector<MapVoxel>* static_model) {
  const double t0 = wall_seconds();
  std::vector<MapVoxel> voxels;
  map.for_each_occupied([&](std::uint64_t, const Eigen::Vector3f& c) {
    MapVoxel v;
    v.centre = c;
    v.probability =
        static_cast<float>(1.0 / (1.0 + std::exp(-static_cast<double>(map.log_odds(c)))));
    voxels.push_back(v);
  });
  write_map_ply(join_path(out_dir, "map.ply"), voxels);
  const OccupancyMapConfig& m = config.map;
  const Eigen::Vector3f cam = last_pose.translation;
  FinalMapCounts n = count_region(map, cam, m.local_half_extent);
  auto triple = [](const Eigen::Vector3f& v) {
    return num(v.x()) + " " + num(v.y()) + " " + num(v.z());
  };
  std::vector<std::pair<std::string, std::string>> entries = {
      {"resolution", num(map.resolution())},
      {"min_depth", num(m.min_depth)},
      {"max_depth", num(m.max_depth)},
      {"pixel_stride", std::to_string(m.pixel_stride)},
      {"pixel_stride_at_end", std::to_string(map.config().pixel_stride)},
      {"pixel_margin", std::to_string(m.pixel_margin)},
      {"local_half_extent", triple(m.local_half_extent)},
      {"prob_occupied", num(m.prob_occupied)},
      {"frames", std::to_string(frames)},
      {"last_camera_position", triple(cam)},
      {"occupied_voxels", std::to_string(n.occupied)},
      {"local_region_voxels", std::to_string(n.region)},
      {"local_region_occupied", std::to_string(n.region_occupied)},
      {"local_region_free", std::to_string(n.region_free)},
      {"local_region_unknown", std::to_string(n.region_unknown)},
      {"blocks_in_use", std::to_string(map.blocks_in_use())},
      {"blocks_evicted", std::to_string(map.total_blocks_evicted())}};
  if (static_model != nullptr) {
    n.has_model = true;
    n.model = count_model_holes(map, *static_model, cam, m.local_half_extent, m.max_depth);
    add_model_entries(n.model, &entries);
    std::vector<MapVoxel> holes;
    for (const Eigen::Vector3f& c : n.model.holes) {
      MapVoxel v;
      v.centre = c;
      v.probability =
          static_cast<float>(1.0 / (1.0 + std::exp(-static_cast<double>(map.log_odds(c)))));
      holes.push_back(v);
    }
    write_map_ply(join_path(out_dir, "model_holes.ply"), holes,
                  "dynamap-replay: static model voxels the final map holds free (map voxel "
                  "centres, world frame, m) and the map's occupancy probability");
  }
  write_map_summary(join_path(out_dir, "map_summary.txt"), entries);
  n.seconds = wall_seconds() - t0;
  return n;
}

}  // namespace dynamap::tools
