// MapIntegrator: a frame's set-up (geometry, no-return regions) and the order of its two
// passes on the team lent for the frame. The passes: src/map/map_end_points.cpp,
// src/map/map_carving.cpp.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>

#include "map_integrator_inline.hpp"

namespace dynamap::detail {
namespace {

/// Smallest raw depth in [1, 65536) for which `pred(raw * scale)` holds; pred must be monotone
/// (false, then true) in the depth, as float products with a positive scale are. 65536 if none.
template <class Pred>
std::uint32_t first_raw_where(float scale, Pred pred) noexcept {
  std::uint32_t lo = 1, hi = 65536;  // answer in [lo, hi]
  while (lo < hi) {
    const std::uint32_t mid = lo + (hi - lo) / 2;
    if (pred(static_cast<float>(mid) * scale)) {
      hi = mid;
    } else {
      lo = mid + 1;
    }
  }
  return lo;
}

}  // namespace

void MapIntegrator::reset(const std::array<std::int32_t, 3>& grid_dim, std::size_t cells) noexcept {
  grid_dim_ = grid_dim;
  grid_enabled_ = cells <= kLocalGridCells;
  grid_cells_ = grid_enabled_ ? cells : 0;
  sink_tag_ = 0;
  ray_count_ = 0;
  stats_ = IntegrationStats{};
}

/// A cell is a no-return cell when at least 15/16 of its sampled pixels are 0; a 0 pixel
/// carves only when its cell and the 8 around it are (cells beyond the border count as
/// no-return), so scattered dropouts, edges and small dark patches never carve.
void MapIntegrator::find_no_return_regions(const DepthView& depth) noexcept {
  g_.no_return_any = false;
  if (p_->config.no_return_free_depth <= 0.f) return;
  const int cx = (g_.cam->width + kNoReturnCellPixels - 1) / kNoReturnCellPixels;
  const int cy = (g_.cam->height + kNoReturnCellPixels - 1) / kNoReturnCellPixels;
  const int margin = p_->config.pixel_margin, stride = p_->config.pixel_stride;
  std::array<std::uint16_t, kNoReturnCellsX * kNoReturnCellsY> zeros{}, sampled{};
  for (int v = margin; v < g_.cam->height - margin; v += stride) {
    const std::uint16_t* row = depth.row(v);
    const std::size_t base = static_cast<std::size_t>(v / kNoReturnCellPixels) * kNoReturnCellsX;
    for (int u = margin; u < g_.cam->width - margin; u += stride) {
      const std::size_t cell = base + static_cast<std::size_t>(u / kNoReturnCellPixels);
      ++sampled[cell];
      zeros[cell] = static_cast<std::uint16_t>(zeros[cell] + (row[u] == 0));
    }
  }
  const auto empty = [&](int i, int j) {
    if (i < 0 || j < 0 || i >= cx || j >= cy) return true;
    const std::size_t cell = static_cast<std::size_t>(j) * kNoReturnCellsX + i;
    return 16 * zeros[cell] >= 15 * sampled[cell];
  };
  for (int j = 0; j < cy; ++j) {
    for (int i = 0; i < cx; ++i) {
      bool all = true;
      for (int dj = -1; dj <= 1 && all; ++dj) {
        for (int di = -1; di <= 1 && all; ++di) all = empty(i + di, j + dj);
      }
      g_.no_return_carves[static_cast<std::size_t>(j) * kNoReturnCellsX + i] = all ? 1 : 0;
      g_.no_return_any = g_.no_return_any || all;
    }
  }
}

/// Per-frame constants of both passes: depth classes, ray directions, key base, block grid.
void MapIntegrator::set_frame_geometry(const CameraIntrinsics& cam,
                                       const Pose& T_map_camera) noexcept {
  g_.cam = &cam;
  g_.depth_scale = cam.depth_scale;
  // Pass 1 classifies raw depths with integer compares, exactly as end_point() does with floats.
  g_.hit_raw_end =
      first_raw_where(g_.depth_scale, [&](float z) { return z > p_->config.max_depth; });
  g_.near_raw_end =
      first_raw_where(g_.depth_scale, [&](float z) { return !(z < p_->config.min_depth); });
  g_.cy = cam.cy;
  g_.inv_fy = 1.f / cam.fy;
  g_.origin = T_map_camera.translation;
  g_.origin4 << g_.origin, 0.f;
  g_.half_extent4 << p_->config.local_half_extent, std::numeric_limits<float>::infinity();
  const Eigen::Matrix3f R = T_map_camera.rotation.normalized().toRotationMatrix();
  for (int u = 0; u < cam.width; ++u) {
    g_.column_dir[static_cast<std::size_t>(u)]
        << R.col(0) * ((static_cast<float>(u) - cam.cx) / cam.fx),
        0.f;
  }
  // Sampled columns' directions, one array per axis, padded to whole 4-lane packets with the
  // last column (the same floats as g_.column_dir, so both passes agree bit for bit).
  const int margin = p_->config.pixel_margin, stride = p_->config.pixel_stride;
  g_.sampled_columns = cam.width > 2 * margin ? (cam.width - 2 * margin + stride - 1) / stride : 0;
  for (int k = 0; k < g_.sampled_columns + 3; ++k) {
    const int u = margin + std::min(k, std::max(g_.sampled_columns - 1, 0)) * stride;
    const Eigen::Array4f& dir = g_.column_dir[static_cast<std::size_t>(std::min(u, cam.width - 1))];
    g_.sampled_dir_x[static_cast<std::size_t>(k)] = dir[0];
    g_.sampled_dir_y[static_cast<std::size_t>(k)] = dir[1];
    g_.sampled_dir_z[static_cast<std::size_t>(k)] = dir[2];
  }
  for (std::size_t a = 0; a < 3; ++a) {
    const std::int32_t camera_block =
        fast_floor(g_.origin[static_cast<int>(a)] * p_->inv_resolution) >> kBlockBits;
    g_.key_base[a] = (camera_block - (1 << (kKeyBlockBits - 1))) * kBlockEdge;
  }
  // Element by element: the same values as a comma initialiser from R.col(), without the
  // packet load past R's end that GCC 12 -O3 reports (-Warray-bounds) once this is inlined.
  g_.right_dir = Eigen::Array4f(R(0, 0), R(1, 0), R(2, 0), 0.f);
  g_.down_dir = Eigen::Array4f(R(0, 1), R(1, 1), R(2, 1), 0.f);
  g_.forward_dir = Eigen::Array4f(R(0, 2), R(1, 2), R(2, 2), 0.f);
  if (grid_enabled_) {
    for (int a = 0; a < 3; ++a) {
      const std::size_t i = static_cast<std::size_t>(a);
      grid_origin_[i] =
          (fast_floor(g_.origin[a] * p_->inv_resolution) >> kBlockBits) - grid_dim_[i] / 2;
    }
    std::fill(local_grid_.begin(), local_grid_.begin() + static_cast<std::ptrdiff_t>(grid_cells_),
              std::uint16_t{0});
  }
}

void MapIntegrator::begin(const DepthView& depth, const CameraIntrinsics& cam,
                          const Pose& T_map_camera, TaskTeam& team) noexcept {
  team_ = &team;
  t_.team_depth = &depth;
  stats_ = IntegrationStats{};
  // Eviction keeps the blocks near the camera.
  if (store_->begin_frame(T_map_camera.translation)) sink_tag_ = 0;  // stamps wrapped
  ray_count_ = 0;
  t_.tiles_list_rays = false;
  set_frame_geometry(cam, T_map_camera);
  find_no_return_regions(depth);

  // Pass 1: end points. Hits are applied here (once per voxel), so pass 2's misses skip them:
  // hit wins over miss. Rays ending in an already-seen voxel are merged (when enabled).
  const int margin = p_->config.pixel_margin, stride = p_->config.pixel_stride;
  const std::size_t samples =
      static_cast<std::size_t>(g_.sampled_columns) *
      static_cast<std::size_t>(std::max(0, (cam.height - 2 * margin + stride - 1) / stride));
  if (p_->config.carve_tiles > 0 && samples <= p_->config.max_rays_per_frame) {
    mark_end_points_in_team();
  } else {
    mark_end_points(depth);
  }
  // Pass 2 (free space along each ray, a 3-D DDA within the visit budget) is carve_share().
  if (p_->config.carve_tiles > 0) prepare_tiles();
}

void MapIntegrator::carve_share(unsigned member) noexcept {
  if (team_ == nullptr) return;
  if (p_->config.carve_tiles > 0) {
    carve_tile_claims();
  } else if (member == 0) {
    carve_one_walk(*t_.team_depth);
  }
}

void MapIntegrator::finish() noexcept {
  if (team_ == nullptr) return;
  if (p_->config.carve_tiles > 0) finish_tiles();
  stats_.blocks_allocated = store_->allocated_this_frame();
  stats_.blocks_evicted = store_->evicted_this_frame();
  g_.cam = nullptr;
  t_.team_depth = nullptr;
  team_ = nullptr;
}

}  // namespace dynamap::detail
