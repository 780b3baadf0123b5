// MapIntegrator pass 2: free space along each listed ray: the rays' order and start, and the one
// walk on this thread (carve_tiles = 0). The tiles on the team: map_tiled_carving.cpp.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>

#include "map_carve_rays.hpp"
#include "map_integrator_inline.hpp"
#include "segment_walk.hpp"

namespace dynamap::detail {

inline bool MapIntegrator::end_point(std::uint16_t raw, bool zero_carves, const Eigen::Array4f& dir,
                                     Eigen::Array4f& end, IndexVec& idx, bool& is_hit,
                                     float& end_depth) const noexcept {
  float z = static_cast<float>(raw) * g_.depth_scale;
  is_hit = true;
  if (raw == 0) {
    if (!zero_carves) return false;  // no measurement: unknown
    z = p_->config.no_return_free_depth;
    is_hit = false;
  } else if (z > p_->config.max_depth) {
    z = p_->config.max_depth;
    is_hit = false;
  } else if (z < p_->config.min_depth) {
    return false;
  }
  Eigen::Array4f offset = dir * z;
  // Clip to the local region (the camera is at its centre). One packed test, rarely true:
  // for floats, o - h > 0 exactly when o > h.
  if ((offset.abs() - g_.half_extent4).maxCoeff() > 0.f) {
    float scale = 1.f;
    for (int a = 0; a < 3; ++a) {
      const float o = std::fabs(offset[a]);
      const float h = g_.half_extent4[a];
      if (o > h) scale = std::min(scale, h / o);
    }
    if (scale < 1.f) {
      offset *= scale * (1.f - 1e-4f);  // stay just inside so the end voxel is in the region
      z *= scale * (1.f - 1e-4f);
      is_hit = false;
    }
  }
  end_depth = z;
  end = g_.origin4 + offset;
  // Inside the local region, so inside the key range (init() bounds the region, integrate()
  // the pose): no range checks needed.
  const Eigen::Array4f x = end * p_->inv_resolution;
  idx = {fast_floor(x[0]), fast_floor(x[1]), fast_floor(x[2])};
  return true;
}

// ---------------------------------------------------------------------------------------------
// Carving (pass 2): free space along each listed ray, walked from its end back to the camera
// with early stop, or from the camera to its end (exact walk).

namespace {
/// Coarse-to-fine ray order of the early-stop walk (carve_free_space()).
constexpr std::uint32_t kOrderLevels = 4;
/// Keys of order_rays()'s counting sort: tile * kLevelKeys + level.
constexpr std::size_t kLevelKeys = kOrderLevels + 1;
/// Sort keys are kept in the top bits of a ray's pixel index (which needs 19) until sorted.
constexpr int kKeyShift = 24;
static_assert(kMaxImageWidth * kMaxImageHeight < (1 << kKeyShift), "pixel index bits");
constexpr std::uint32_t kPixelMask = (1u << kKeyShift) - 1;

/// Level of sampled pixel (column k, row j) in the coarse-to-fine order: the trailing zero bits
/// k and j share, at most kOrderLevels; the coarsest lattice (level 0) is walked first.
inline std::uint32_t order_level(std::uint32_t k, std::uint32_t j) noexcept {
  const std::uint32_t kj = k | j;
  std::uint32_t level = 0;
  while (level < kOrderLevels && ((kj >> level) & 1u) == 0) ++level;
  return kOrderLevels - level;
}
}  // namespace

/// Level of each listed ray in the early-stop order and its tile, then a stable counting sort
/// of rays_ into ordered_rays_ by (tile, level): pixel order within each. Returns the rays.
///
/// Early stop walks the rays coarse to fine over the sampled pixel grid: first the pixels on
/// the lattice 2^kOrderLevels samples apart, then each finer lattice's new pixels (image order
/// within a level). In plain image order a ray stops as soon as it has run N voxels inside its
/// neighbour's tube, although the two lines still part at voxel corners nearer the camera;
/// here the rays that walk first are far apart, so they walk almost to the camera and carve
/// the near part densely before the finer rays stop against them. For the same number of
/// visits it skips a third to half fewer misses (docs/occupancy_map.md).
std::size_t MapIntegrator::order_rays(int tiles, bool by_level) noexcept {
  const auto width = static_cast<std::uint32_t>(g_.cam->width);
  const auto margin = static_cast<std::uint32_t>(p_->config.pixel_margin);
  const auto stride = static_cast<std::uint32_t>(p_->config.pixel_stride);
  const auto columns = static_cast<std::uint32_t>(std::max(g_.sampled_columns, 1));
  const auto tile_count = static_cast<std::uint32_t>(tiles);
  std::array<std::size_t, kMaxCarveTiles * kLevelKeys + 1> start{};
  for (std::size_t r = 0; r < ray_count_; ++r) {
    const std::uint32_t u = rays_[r] % width, v = rays_[r] / width;
    const std::uint32_t k = (u - margin) / stride;
    const std::uint32_t level = by_level ? order_level(k, (v - margin) / stride) : 0;
    const std::uint32_t tile = tiles > 1 ? k * tile_count / columns : 0;
    const std::uint32_t key = tile * static_cast<std::uint32_t>(kLevelKeys) + level;
    rays_[r] |= key << kKeyShift;
    ++start[key + 1];
  }
  for (std::size_t key = 1; key < start.size(); ++key) start[key] += start[key - 1];
  for (int t = 0; t < tiles; ++t) {
    TileScratch& tile = t_.tiles[static_cast<std::size_t>(t)];
    tile.ray_begin = start[static_cast<std::size_t>(t) * kLevelKeys];
    tile.ray_end = start[static_cast<std::size_t>(t + 1) * kLevelKeys];
  }
  for (std::size_t r = 0; r < ray_count_; ++r) {
    const std::uint32_t key = rays_[r] >> kKeyShift;
    rays_[r] &= kPixelMask;
    ordered_rays_[start[key]++] = rays_[r];
  }
  return ray_count_;
}

/// order_rays() for one tile when pass 1 ran on the team: the tile's kept rays (its column
/// strip of t_.end_kept, in pixel order), stably sorted by level into its own range of
/// ordered_rays_ (rays_'s same range is the scratch). Runs on the member that claimed the tile;
/// the result is order_rays()'s range for the tile.
void MapIntegrator::list_tile_rays(std::size_t t) noexcept {
  TileScratch& tile = t_.tiles[t];
  const auto width = static_cast<std::uint32_t>(g_.cam->width);
  const auto margin = static_cast<std::uint32_t>(p_->config.pixel_margin);
  const auto stride = static_cast<std::uint32_t>(p_->config.pixel_stride);
  const auto columns = static_cast<std::size_t>(std::max(g_.sampled_columns, 0));
  const std::size_t rows = columns == 0 ? 0 : t_.team_samples / columns;
  const auto tiles = static_cast<std::size_t>(p_->config.carve_tiles);
  // Column k is in tile k * tiles / columns: tile t has ceil(t * columns / tiles) onwards.
  const std::size_t k0 = (t * columns + tiles - 1) / tiles;
  const std::size_t k1 = ((t + 1) * columns + tiles - 1) / tiles;
  const std::size_t begin = rows * k0;
  const bool by_level = p_->config.free_ray_early_stop > 0;
  std::array<std::size_t, kLevelKeys + 1> start{};
  std::size_t n = begin;
  for (std::size_t j = 0; j < rows; ++j) {
    const std::uint8_t* kept = &t_.end_kept[j * columns];
    const auto v = static_cast<std::uint32_t>(margin + j * stride);
    const auto take = [&](std::size_t k) {
      const auto kk = static_cast<std::uint32_t>(k);
      const std::uint32_t level = by_level ? order_level(kk, static_cast<std::uint32_t>(j)) : 0;
      rays_[n++] = (v * width + margin + kk * stride) | (level << kKeyShift);
      ++start[level + 1];
    };
    std::size_t k = k0;
    for (; k + 8 <= k1; k += 8) {
      std::uint64_t eight = 0;  // few pixels keep a ray (most merge): skip 8 flags at once
      std::memcpy(&eight, &kept[k], sizeof(eight));
      if (eight == 0) continue;
      for (std::size_t i = k; i < k + 8; ++i) {
        if (kept[i] != 0) take(i);
      }
    }
    for (; k < k1; ++k) {
      if (kept[k] != 0) take(k);
    }
  }
  for (std::size_t key = 1; key < start.size(); ++key) start[key] += start[key - 1];
  for (std::size_t r = begin; r < n; ++r) {
    const std::uint32_t ray = rays_[r];
    ordered_rays_[begin + start[ray >> kKeyShift]++] = ray & kPixelMask;
  }
  tile.ray_begin = begin;
  tile.ray_end = n;
}

/// The end of the free walk of a hit ray at camera depth z: depth noise puts returns behind
/// their surface, so no voxel any part of which lies within carve_gap_quadratic * z^2 of the
/// end point is carved. The walk ends in the voxel before the one holding the point that far
/// short, where the ray enters that voxel. False when that is the camera's own voxel.
bool MapIntegrator::stop_short(float z, const Eigen::Array4f& dir, Eigen::Array4f& end,
                               IndexVec& last) const noexcept {
  const float stop = z - p_->config.carve_gap_quadratic * z * z;
  if (stop <= 0.f) return false;
  const Eigen::Array4f x = (g_.origin4 + dir * stop) * p_->inv_resolution;
  float t_entry = 0.f;  // camera depth at which the ray enters the stop point's voxel
  for (int a = 0; a < 3; ++a) {
    if (dir[a] == 0.f) continue;
    const float face =
        static_cast<float>(fast_floor(x[a]) + (dir[a] > 0.f ? 0 : 1)) * p_->resolution;
    t_entry = std::max(t_entry, (face - g_.origin4[a]) / dir[a]);
  }
  if (t_entry <= 0.f) return false;
  // A near-parallel axis can round its face past the point; the entry is never beyond it.
  t_entry = std::min(t_entry, stop);
  end = g_.origin4 + dir * (t_entry * (1.f - 1e-5f));
  const Eigen::Array4f e = end * p_->inv_resolution;
  last = {fast_floor(e[0]), fast_floor(e[1]), fast_floor(e[2])};
  return true;
}

/// The walk of the ray of `pixel` (false when its depth is too near): from its end voxel to
/// the camera's when from_end (early stop), else from the camera's to its end voxel.
bool MapIntegrator::start_ray(std::uint32_t pixel, const DepthView& depth, const IndexVec& camera,
                              bool from_end, detail::RayWalk& w) const noexcept {
  const auto width = static_cast<std::uint32_t>(g_.cam->width);
  const int u = static_cast<int>(pixel % width);
  const int v = static_cast<int>(pixel / width);
  Eigen::Array4f end;
  bool end_is_hit = false;
  float end_depth = 0.f;
  IndexVec last{};
  w.own_surface = false;
  const std::uint16_t raw = depth.at(u, v);
  const Eigen::Array4f dir = g_.column_dir[static_cast<std::size_t>(u)] + row_direction(v);
  const std::uint8_t* carve_cells = no_return_row(v);
  const bool zero_carves = carve_cells != nullptr && carve_cells[u / kNoReturnCellPixels] != 0;
  if (!end_point(raw, zero_carves, dir, end, last, end_is_hit, end_depth)) return false;
  w.own_surface = end_is_hit && from_end && p_->config.keep_own_surface;
  // The noise gap protects a measured surface wherever the walk would end: at the hit, and on a
  // free ray cut at max_depth or the local region when the return lies just beyond the cut (its
  // surface may lie just within it). Free rays of 0 pixels (no_return_free_depth) have none.
  const float measured = static_cast<float>(raw) * g_.depth_scale;
  const float gap = p_->config.carve_gap_quadratic;
  if (raw != 0 && gap > 0.f && measured - gap * measured * measured < end_depth) {
    if (!stop_short(measured, dir, end, last)) return false;
    end_is_hit = false;  // the walk now ends short of the return and carves its last voxel
  }
  // Parameter t in [0, 1] along from_point -> from_point + d. The far part of a ray is its own,
  // the near part mostly what earlier rays (its neighbours in pixel order) already carved, so
  // that is where the early-stop walk, which goes backwards, can stop.
  const Eigen::Array4f from_point = from_end ? end : g_.origin4;
  const Eigen::Array4f d = from_end ? Eigen::Array4f(g_.origin4 - end) : end - g_.origin4;
  if (p_->config.miss_max_offset > 0.f) {
    // The line from the camera towards the end, whichever way the walk goes.
    const Eigen::Array4f out = end - g_.origin4;
    const float length = out.head<3>().matrix().norm();
    const float inv = length > 0.f ? 1.f / length : 0.f;
    w.px = g_.origin4[0];
    w.py = g_.origin4[1];
    w.pz = g_.origin4[2];
    w.ux = out[0] * inv;
    w.uy = out[1] * inv;
    w.uz = out[2] * inv;
    w.inv_length = inv;
  }
  const IndexVec& from = from_end ? last : camera;
  const IndexVec& to = from_end ? camera : last;
  const auto axis = [&](std::size_t a, std::int32_t& i, std::int32_t& s, std::int32_t& r,
                        float& t_max, float& t_delta) {
    const int e = static_cast<int>(a);
    const detail::AxisStart start =
        detail::start_axis(from[a], to[a], from_point[e], d[e], p_->resolution);
    i = from[a];
    s = start.step;
    r = start.remaining;
    t_max = start.t_max;
    t_delta = start.t_delta;
  };
  axis(0, w.ix, w.sx, w.rx, w.tx, w.dx);
  axis(1, w.iy, w.sy, w.ry, w.ty, w.dy);
  axis(2, w.iz, w.sz, w.rz, w.tz, w.dz);
  // Exactly |dx|+|dy|+|dz| steps (+1 visit) so the walk ends in its last voxel whatever the
  // rounding; an axis that reached its end index gets t = inf. The exact walk of a hit ray
  // stops before its end voxel, which already holds this frame's hit; the early-stop walk of a
  // hit ray starts on it (its hit stamp keeps it from being updated).
  w.visits = static_cast<std::size_t>(w.rx + w.ry + w.rz) + (from_end || !end_is_hit ? 1u : 0u);
  return true;
}

/// Carving on the map itself (carve_tiles = 0): each visit updates the voxel at once.
template <bool kEarlyStop>
struct MapIntegrator::SequentialCursor {
  MapIntegrator& map;
  const LocalGrid grid;
  CarveCounters& k;
  const std::uint16_t hit_stamp, miss_stamp;
  const std::int32_t q_miss, q_min, q_occupied;
  const std::uint32_t stop_after;
  const std::uint16_t now_tick, min_age_ticks, static_ticks;
  const float near, spread;  // miss_max_offset, miss_offset_spread in m (near 0: off)
  const bool backed;         // keep_unknown_backed
  const DepthView* depth;
  Block* block = nullptr;
  std::size_t sink_entry = 0;  // n when the walk entered a block it could not allocate
  std::uint32_t run = 0;       // consecutive voxels found missed this frame (early stop)
  bool surface = false;        // still on the ray's own surface (keep_own_surface)
  const RayWalk* ray = nullptr;
  std::int32_t bi_ = 0, bj_ = 0, bk_ = 0;

  /// miss_max_offset: the ray passes too far from the centre of a voxel never observed or
  /// static (occupied long enough).
  bool passes_aside(const Voxel& vx, std::int32_t li) const noexcept {
    return near > 0.f &&
           centre_rule_applies(vx.log_odds, q_occupied,
                               block->occupied_since[static_cast<std::size_t>(li)], now_tick,
                               static_ticks) &&
           detail::passes_aside<kBlockBits>(*ray, bi_, bj_, bk_, li, map.p_->resolution, near,
                                            spread);
  }
  void enter(std::int32_t bi, std::int32_t bj, std::int32_t bk, std::size_t n) noexcept {
    bi_ = bi;
    bj_ = bj;
    bk_ = bk;
    block = map.local_block(grid, bi, bj, bk);
    if (block != nullptr) return;
    // Visits there are counted as dropped updates; the sink's stamps all read "hit this frame",
    // so the hot loop needs no null test, and an early-stop walk is not stopped there (hits
    // never stop a ray).
    if (map.sink_tag_ != map.store_->frame_tag()) {
      for (Voxel& vx : map.sink_.voxels) vx.stamp = hit_stamp;
      map.sink_tag_ = map.store_->frame_tag();
    }
    block = &map.sink_;
    sink_entry = n;
  }
  void leave(std::size_t n) noexcept {
    if (block == &map.sink_) k.dropped_updates += sink_entry - n;
  }
  /// keep_unknown_backed, for a voxel this ray would lower.
  bool unknown_backed(const Voxel& vx, std::int32_t li) const noexcept {
    if (!backed || vx.log_odds == kUnknown || vx.log_odds <= q_occupied) return false;
    return map.spares_unknown_backed(bi_, bj_, bk_, li, *depth);
  }
  void miss(Voxel& vx) noexcept {
    const std::int16_t old = vx.log_odds;
    const std::int32_t current = old == kUnknown ? 0 : old;
    const auto updated = static_cast<std::int16_t>(std::max(current + q_miss, q_min));
    vx.log_odds = updated;
    vx.stamp = miss_stamp;
    ++k.updates;
    // A miss can only turn occupied into free.
    if (old > q_occupied && updated <= q_occupied) --block->occupied;
  }
  /// Whether the voxel was occupied before this frame's carving (a voxel an earlier ray missed
  /// this frame is judged by its value before that miss) and long enough, or hit this frame.
  bool on_surface(std::size_t li) const noexcept {
    const Voxel& vx = block->voxels[li];
    const std::int32_t before = vx.stamp == miss_stamp ? vx.log_odds - q_miss : vx.log_odds;
    return on_own_surface(vx.stamp == hit_stamp, before, q_occupied, block->occupied_since[li],
                          now_tick, min_age_ticks);
  }
  bool visit(std::int32_t li) noexcept {
    Voxel& vx = block->voxels[static_cast<std::size_t>(li)];
    if (surface) {
      if (on_surface(static_cast<std::size_t>(li))) {
        run = 0;
        return false;
      }
      surface = false;
    }
    if constexpr (kEarlyStop) {
      // Only misses count towards the stop: at grazing angles a ray crosses voxels that other
      // pixels hit, and the space beyond them may still be this ray's alone.
      const std::uint16_t stamp = vx.stamp;
      if (stamp == miss_stamp) return ++run == stop_after;
      run = 0;
      if (stamp != hit_stamp && !passes_aside(vx, li) && !unknown_backed(vx, li)) miss(vx);
    } else {
      // hit_stamp and miss_stamp are consecutive: one unsigned compare tests both. Most visits
      // (near the camera) find the voxel already updated this frame.
      if (static_cast<std::uint16_t>(vx.stamp - hit_stamp) > 1u && !passes_aside(vx, li) &&
          !unknown_backed(vx, li))
        miss(vx);
    }
    return false;
  }
};

template <bool kEarlyStop>
void MapIntegrator::carve_free_space(const DepthView& depth) noexcept {
  IndexVec camera{};
  if (!voxel_index(g_.origin, p_->inv_resolution, camera))
    return;  // cannot happen: integrate() checked the pose
  const std::size_t rays = order_rays(1, kEarlyStop);
  const std::uint16_t base = static_cast<std::uint16_t>(store_->frame_tag() * 4u);
  CarveCounters k{};
  k.visits_left = p_->config.max_voxel_visits_per_frame;
  SequentialCursor<kEarlyStop> cursor{*this,
                                      local_grid(),
                                      k,
                                      static_cast<std::uint16_t>(base + kHit),
                                      static_cast<std::uint16_t>(base + kMiss),
                                      p_->q_miss,
                                      p_->q_min,
                                      p_->q_occupied,
                                      static_cast<std::uint32_t>(p_->config.free_ray_early_stop),
                                      store_->since_tick(),
                                      own_surface_min_ticks(),
                                      static_min_ticks(),
                                      miss_near(),
                                      miss_spread(),
                                      p_->config.keep_unknown_backed,
                                      &depth};
  carve_rays<kEarlyStop>(0, rays, depth, camera, cursor, k);
  stats_.rays += k.rays;
  stats_.rays_stopped_early += k.rays_stopped;
  stats_.rays_dropped += k.rays_dropped;
  stats_.voxel_visits += k.visits;
  stats_.voxel_updates += k.updates;
  stats_.updates_dropped += k.dropped_updates;
}

void MapIntegrator::carve_one_walk(const DepthView& depth) noexcept {
  if (p_->config.free_ray_early_stop > 0) {
    carve_free_space<true>(depth);
  } else {
    carve_free_space<false>(depth);
  }
}

bool MapIntegrator::spares_unknown_backed(std::int32_t bi, std::int32_t bj, std::int32_t bk,
                                          std::int32_t li, const DepthView& depth) const noexcept {
  constexpr std::int32_t m = kBlockEdge - 1;
  const std::int32_t i = bi * kBlockEdge + (li & m);
  const std::int32_t j = bj * kBlockEdge + ((li >> kBlockBits) & m);
  const std::int32_t k = bk * kBlockEdge + (li >> (2 * kBlockBits));
  // Where a dynamic track has been the rule is off: asked first, it spares the neighbour
  // lookups for the voxels walkers leave behind, most of the voxels that come here.
  if (trail_ != nullptr) {
    const float res = p_->resolution;
    if (trail_->recent(Eigen::Vector3f((static_cast<float>(i) + 0.5f) * res,
                                       (static_cast<float>(j) + 0.5f) * res,
                                       (static_cast<float>(k) + 0.5f) * res))) {
      return false;
    }
  }
  static constexpr std::int32_t kFaces[6][3] = {{1, 0, 0},  {-1, 0, 0}, {0, 1, 0},
                                                {0, -1, 0}, {0, 0, 1},  {0, 0, -1}};
  const BlockStore& store = *store_;
  // Most neighbours share the voxel's block: look each block up once.
  const Block* block = store.find(bi, bj, bk);
  for (const auto& d : kFaces) {
    const std::int32_t ni = i + d[0], nj = j + d[1], nk = k + d[2];
    const std::int32_t nbi = ni >> kBlockBits, nbj = nj >> kBlockBits, nbk = nk >> kBlockBits;
    if (nbi != bi || nbj != bj || nbk != bk) {
      bi = nbi;
      bj = nbj;
      bk = nbk;
      block = store.find(bi, bj, bk);
    }
    if (block != nullptr && block->voxels[local_index(ni, nj, nk)].log_odds != kUnknown) continue;
    if (unseen_in_view(ni, nj, nk, depth)) return true;
  }
  return false;
}

/// Whether a never-observed voxel could not have been seen this frame although it lies ahead of
/// the camera within range: beyond the image's edge (nothing tells what is there), or hidden,
/// the pixel looking through its centre having measured a surface more than a voxel and the
/// depth noise in front of it. Unknown elsewhere in the view means merely not reached yet.
bool MapIntegrator::unseen_in_view(std::int32_t i, std::int32_t j, std::int32_t k,
                                   const DepthView& depth) const noexcept {
  const float res = p_->resolution;
  const Eigen::Array4f d4 =
      Eigen::Array4f((static_cast<float>(i) + 0.5f) * res, (static_cast<float>(j) + 0.5f) * res,
                     (static_cast<float>(k) + 0.5f) * res, 0.f) -
      g_.origin4;
  const float z = (d4 * g_.forward_dir).sum();
  if (!(z > 0.f) || z > p_->config.max_depth) return false;
  const float y = (d4 * g_.down_dir).sum();
  const float x = (d4 * g_.right_dir).sum();
  const CameraIntrinsics& cam = *g_.cam;
  const float u = cam.cx + cam.fx * x / z, v = cam.cy + cam.fy * y / z;
  if (!(std::isfinite(u) && std::isfinite(v))) return false;
  if (!(u >= 0.f && v >= 0.f && u < static_cast<float>(depth.width) &&
        v < static_cast<float>(depth.height))) {
    return true;
  }
  const std::uint16_t raw = depth.at(static_cast<int>(u), static_cast<int>(v));
  const float margin = res + p_->config.carve_gap_quadratic * z * z;
  return raw != 0 && static_cast<float>(raw) * g_.depth_scale < z - margin;
}

}  // namespace dynamap::detail
