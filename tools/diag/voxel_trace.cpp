// dynamap-voxel-trace: follows chosen voxels through the occupancy map alone (no detector,
// tracker or cleaner) over a sequence: their log-odds after every frame, and for each frame that
// lowers one, the sampled pixels whose carving segment (the map's settings: range, noise gap,
// pixel sampling) crosses it. Tells ray carving apart from the cleaner when a static voxel is
// erased in a replay: if the voxel stays occupied here, something after the map cleared it.
// Host-only developer tool (docs/tools.md).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "common/png_io.hpp"
#include "common/sequence.hpp"
#include "common/text_io.hpp"
#include "dynamap/map/occupancy_map.hpp"
#include "dynamap/pipeline/pipeline_config.hpp"
#include "params.hpp"

namespace dynamap::tools {
namespace {

constexpr int kListedRays = 12;  // rays printed per lowered voxel and frame

// Does the segment a-b cross the axis-aligned box [lo, hi]? (slab test)
bool segment_crosses(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& lo,
                     const Eigen::Vector3d& hi) {
  double t0 = 0.0, t1 = 1.0;
  for (int k = 0; k < 3; ++k) {
    const double d = b[k] - a[k];
    if (std::abs(d) < 1e-12) {
      if (a[k] < lo[k] || a[k] > hi[k]) return false;
      continue;
    }
    double ta = (lo[k] - a[k]) / d, tb = (hi[k] - a[k]) / d;
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

// The sampled pixels whose carving segment crosses the voxel at `centre` (edge `res`).
void list_rays(const Image16& depth, const OccupancyMapConfig& m, const CameraIntrinsics& cam,
               const PoseD& pose, const Eigen::Vector3d& centre, double res) {
  const Eigen::Vector3d lo = centre.array() - 0.5 * res, hi = centre.array() + 0.5 * res;
  const Eigen::Vector3d c = pose.translation;
  int n = 0;
  for (int v = m.pixel_margin; v < depth.height - m.pixel_margin; v += m.pixel_stride) {
    for (int u = m.pixel_margin; u < depth.width - m.pixel_margin; u += m.pixel_stride) {
      const std::size_t at = static_cast<std::size_t>(v) * static_cast<std::size_t>(depth.width) +
                             static_cast<std::size_t>(u);
      const std::uint16_t raw = depth.pixels[at];
      const double z = raw * static_cast<double>(cam.depth_scale);
      if (raw == 0 || z < m.min_depth) continue;  // no measurement: neither hits nor carves
      // Up to the noise gap short of the return, and no further than the range.
      const double carve =
          std::min(z - m.carve_gap_quadratic * z * z, static_cast<double>(m.max_depth));
      auto world = [&](double d) {
        const Eigen::Vector3d p((u - cam.cx) / cam.fx * d, (v - cam.cy) / cam.fy * d, d);
        return Eigen::Vector3d(pose.rotation * p + c);
      };
      const Eigen::Vector3d stop = world(carve);
      if (!segment_crosses(c, stop, lo, hi)) continue;
      if (n++ < kListedRays) {
        const Eigen::Vector3d e = world(z);
        // miss_max_offset: how far the ray's line passes from the centre, and what the map
        // allows there (occupancy_map.md, "A ray clipping a voxel"), in voxel edges.
        const Eigen::Vector3d dir = (stop - c).normalized();
        const Eigen::Vector3d off = centre - c;
        const double offset = off.cross(dir).norm() / res;
        const double allowed = std::max(static_cast<double>(m.miss_max_offset),
                                        m.miss_offset_spread * off.dot(dir) / (stop - c).norm());
        std::printf(
            "    pixel (%d, %d) depth %.3f m, end (%.2f, %.2f, %.2f), passes %.2f voxel edges "
            "from the centre (allowed %.2f)\n",
            u, v, z, e.x(), e.y(), e.z(), offset, allowed);
      }
    }
  }
  std::printf("    %d sampled rays cross it (before ray merging and early stop)\n", n);
}

int run(int argc, char** argv) {
  if (argc < 6 || (argc - 3) % 3 != 0) {
    std::cerr << "usage: dynamap-voxel-trace SEQ LAST_FRAME X Y Z [X Y Z]...\n";
    return 2;
  }
  const Sequence seq = read_sequence(argv[1]);
  const long last = std::stol(argv[2]);
  std::vector<Eigen::Vector3f> voxels;
  for (int i = 3; i + 2 < argc; i += 3) {
    voxels.emplace_back(std::stof(argv[i]), std::stof(argv[i + 1]), std::stof(argv[i + 2]));
  }
  const PipelineConfig config = config_for_sequence(seq, "");
  auto map = std::make_unique<OccupancyMap>();  // ~9 MB: never on the stack
  if (!ok(map->init(config.map))) throw ToolError("map configuration refused");
  long f = 0;
  for (const SequenceFrame& sf : seq.frames) {
    if (f > last) break;
    const Image16 depth = load_depth(seq, sf);
    const DepthView view{depth.pixels.data(), depth.width, depth.height,
                         depth.width * static_cast<int>(sizeof(std::uint16_t))};
    std::vector<float> before;
    for (const auto& p : voxels) before.push_back(map->log_odds(p));
    if (!ok(map->integrate(view, config.camera, to_pose(sf.pose), seq.stamp_ns(sf.stamp)))) {
      throw ToolError("integrate failed at " + sf.stamp_text);
    }
    const Eigen::Vector3d c = sf.pose.translation;
    for (std::size_t i = 0; i < voxels.size(); ++i) {
      const float now = map->log_odds(voxels[i]);
      const Eigen::Vector3f centre = map->center_of(map->key_of(voxels[i]));
      std::printf(
          "frame %ld camera (%.2f, %.2f, %.2f) voxel (%.2f, %.2f, %.2f) log-odds %.2f -> %.2f\n", f,
          c.x(), c.y(), c.z(), centre.x(), centre.y(), centre.z(), before[i], now);
      if (now < before[i]) {
        list_rays(depth, config.map, config.camera, sf.pose, centre.cast<double>(),
                  map->resolution());
      }
    }
    ++f;
  }
  return 0;
}

}  // namespace
}  // namespace dynamap::tools

int main(int argc, char** argv) {
  try {
    return dynamap::tools::run(argc, argv);
  } catch (const std::exception& e) {
    std::cerr << "dynamap-voxel-trace: " << e.what() << "\n";
    return 1;
  }
}
