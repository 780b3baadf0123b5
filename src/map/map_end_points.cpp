// MapIntegrator pass 1: each sampled pixel's end voxel, its hit applied once per voxel, and the
// list of rays pass 2 walks; on this thread (mark_end_points()) or on the team.
#include <algorithm>
#include <cstring>

#include "map_integrator_inline.hpp"

namespace dynamap::detail {
namespace {

/// fast_floor of each lane, exactly: x - trunc(x) is exact and negative exactly where
/// truncation rounded up; adding +0 turns the -0 of x = -0 into +0, so the sign bit (shifted
/// down arithmetically to -1) is the correction.
inline Eigen::Array4i floor_lanes(const Eigen::Array4f& x) noexcept {
  const Eigen::Array4i truncated = x.cast<std::int32_t>();
  const Eigen::Array4f fraction = (x - truncated.cast<float>()) + 0.f;
  Eigen::Array4i bits;
  std::memcpy(bits.data(), fraction.data(), sizeof(bits));
  return truncated + bits.shiftRight<31>();
}

}  // namespace

/// Pass 1's loop constants, in locals of the loops that use them: the map writes there could
/// otherwise alias the members, and the compiler would reload and re-broadcast them for every
/// packet.
struct MapIntegrator::EndPointConstants {
  Eigen::Array4i hit_raw_end, near_raw_end;
  float scale, inv_res, max_depth, zero_depth;
  Eigen::Array4f half_x, half_y, half_z, origin_x, origin_y, origin_z;
  Eigen::Array4i base_x, base_y, base_z;
  int margin, stride;
};

MapIntegrator::EndPointConstants MapIntegrator::end_point_constants() const noexcept {
  // End points lie in the local region, fewer than 2^(kKeyBlockBits - 1) blocks from the
  // camera's block per axis (init() bounds the region), so voxel indices taken relative to
  // g_.key_base are non-negative (shifts are well defined) and a block is named by one int key.
  return {Eigen::Array4i::Constant(static_cast<std::int32_t>(g_.hit_raw_end)),
          Eigen::Array4i::Constant(static_cast<std::int32_t>(g_.near_raw_end)),
          g_.depth_scale,
          p_->inv_resolution,
          p_->config.max_depth,
          p_->config.no_return_free_depth,
          Eigen::Array4f::Constant(g_.half_extent4[0]),
          Eigen::Array4f::Constant(g_.half_extent4[1]),
          Eigen::Array4f::Constant(g_.half_extent4[2]),
          Eigen::Array4f::Constant(g_.origin4[0]),
          Eigen::Array4f::Constant(g_.origin4[1]),
          Eigen::Array4f::Constant(g_.origin4[2]),
          Eigen::Array4i::Constant(g_.key_base[0]),
          Eigen::Array4i::Constant(g_.key_base[1]),
          Eigen::Array4i::Constant(g_.key_base[2]),
          p_->config.pixel_margin,
          p_->config.pixel_stride};
}

/// End voxels of four sampled pixels of row v, columns k0 .. k0 + 3 (lanes past the row's end
/// repeat its last pixel and are never used).
///
/// One pixel per lane, structure of arrays. Every lane gets the scalar end_point()'s float
/// operations in the same order, branch-free (Eigen maps them to SSE/NEON element-wise
/// operations; the selects are exact arithmetic and floor_lanes is exact), so the end voxels
/// are bit-identical to end_point()'s, which pass 2 uses.
// Always inlined: called once per packet, and its lanes feed the caller's loop in registers.
EIGEN_ALWAYS_INLINE MapIntegrator::EndLanes MapIntegrator::end_lanes(
    const EndPointConstants& c, const std::uint16_t* row, const std::uint8_t* carve_cells,
    const RowDirection& row_dir, int k0, int lanes) const noexcept {
  std::array<std::uint16_t, 4> raw{};
  const std::uint16_t* px = row + c.margin + k0 * c.stride;
  if (lanes == 4) {
    for (int l = 0; l < 4; ++l) raw[static_cast<std::size_t>(l)] = px[l * c.stride];
  } else {
    for (int l = 0; l < 4; ++l) {
      raw[static_cast<std::size_t>(l)] = px[std::min(l, lanes - 1) * c.stride];
    }
  }
  const Eigen::Array4i raw_i{raw[0], raw[1], raw[2], raw[3]};
  const Eigen::Array4f raw_f = raw_i.cast<float>();  // exact: raw < 2^16
  // Free rays beyond max_depth are cast to max_depth, carving 0 pixels to zero_depth.
  // Select-free form: (1 - raw)^+ is exactly 1 for raw == 0 and 0 otherwise, and z + 0 == z.
  const Eigen::Array4f z_ray =
      (raw_f * c.scale + (1.f - raw_f).max(0.f) * c.zero_depth).min(c.max_depth);
  const auto k = static_cast<std::size_t>(k0);
  Eigen::Array4f off_x = (Eigen::Array4f::Map(&g_.sampled_dir_x[k]) + row_dir.x) * z_ray;
  Eigen::Array4f off_y = (Eigen::Array4f::Map(&g_.sampled_dir_y[k]) + row_dir.y) * z_ray;
  Eigen::Array4f off_z = (Eigen::Array4f::Map(&g_.sampled_dir_z[k]) + row_dir.z) * z_ray;
  // For floats o - h > 0 exactly when o > h, as in end_point().
  const Eigen::Array4f outside =
      (off_x.abs() - c.half_x).max(off_y.abs() - c.half_y).max(off_z.abs() - c.half_z);
  // Lane classes as 0/1 integers, computed in the lanes (arithmetic shifts give -1 where the
  // difference is negative): raw in [0, near_raw_end) is unknown (0: no measurement) or
  // closer than min_depth, and skipped; raw in [near_raw_end, hit_raw_end) is a hit unless
  // clipped; the rest (beyond max_depth) are free rays. near_raw_end >= 1 and near_raw_end <=
  // hit_raw_end, so each difference below is 0 or 1.
  const Eigen::Array4i below_near = (raw_i - c.near_raw_end).shiftRight<31>();
  const Eigen::Array4i below_hit = (raw_i - c.hit_raw_end).shiftRight<31>();
  EndLanes e;
  e.too_near = -below_near;        // 1: skip the pixel
  e.hit = below_near - below_hit;  // 1: measured and not near
  if (carve_cells != nullptr) {
    // no_return_free_depth: 0 pixels in a carving cell are free rays to zero_depth.
    for (int l = 0; l < 4; ++l) {
      const int u = c.margin + (k0 + std::min(l, lanes - 1)) * c.stride;
      if (raw[static_cast<std::size_t>(l)] == 0 && carve_cells[u / kNoReturnCellPixels] != 0) {
        e.too_near[l] = 0;
      }
    }
  }
  if (outside.maxCoeff() > 0.f) {
    // end_point()'s clip: min(1, h/|o|) is 1 where |o| <= h (h/|o| >= 1, or inf), so the
    // minimum over axes is its scale; lanes inside keep the factor 1 exactly. The factor is
    // shrink where scale < 1 and shrink + (1 - c) = c + (1 - c) = 1 (exact) where not.
    const Eigen::Array4f clip_scale =
        (c.half_x / off_x.abs()).min(c.half_y / off_y.abs()).min(c.half_z / off_z.abs()).min(1.f);
    constexpr float kInside = 1.f - 1e-4f;
    const Eigen::Array4f shrink = clip_scale * kInside;
    // 1 where scale == 1, 0 where scale < 1 (then scale - 1 <= -2^-24).
    const Eigen::Array4f unclipped = 1.f + ((clip_scale - 1.f) * 1073741824.f).max(-1.f);
    const Eigen::Array4f factor = shrink + unclipped * (1.f - kInside);
    off_x *= factor;
    off_y *= factor;
    off_z *= factor;
    // A clipped ray loses its hit: hit and unclipped are both 0/1, so (hit + unclipped) >> 1
    // is their conjunction.
    e.hit = (e.hit + unclipped.cast<std::int32_t>()).shiftRight<1>();
  }
  const Eigen::Array4i ix = floor_lanes((c.origin_x + off_x) * c.inv_res) - c.base_x;
  const Eigen::Array4i iy = floor_lanes((c.origin_y + off_y) * c.inv_res) - c.base_y;
  const Eigen::Array4i iz = floor_lanes((c.origin_z + off_z) * c.inv_res) - c.base_z;
  e.blk_x = ix.shiftRight<kBlockBits>();
  e.blk_y = iy.shiftRight<kBlockBits>();
  e.blk_z = iz.shiftRight<kBlockBits>();
  e.in_block = (ix - e.blk_x.shiftLeft<kBlockBits>()) +
               (iy - e.blk_y.shiftLeft<kBlockBits>()).shiftLeft<kBlockBits>() +
               (iz - e.blk_z.shiftLeft<kBlockBits>()).shiftLeft<2 * kBlockBits>();
  return e;
}

/// The map update of one end voxel in pixel order: a hit is applied once per voxel; the ray is
/// listed unless merged into an earlier one ending in the same voxel. Returns whether listed.
inline bool MapIntegrator::mark_end_voxel(Block& block, std::size_t li, bool hit,
                                          const EndMarkStamps& s, EndMarkCounters& k) noexcept {
  Voxel& vx = block.voxels[li];
  const std::uint16_t stamp = vx.stamp;
  if (s.merge && (stamp == s.hit || (!hit && stamp == s.queued))) {
    ++k.merged;
    return false;
  }
  if (k.rays >= s.max_rays) {
    ++k.dropped;
    return false;
  }
  if (hit) {
    if (stamp != s.hit) {
      const std::int32_t current = vx.log_odds == kUnknown ? 0 : vx.log_odds;
      const std::int32_t updated = std::min(current + s.q_hit, s.q_max);
      block.occupied = static_cast<std::uint16_t>(block.occupied + (updated > s.q_occupied) -
                                                  (vx.log_odds > s.q_occupied));
      if (updated > s.q_occupied && vx.log_odds <= s.q_occupied) block.occupied_since[li] = s.since;
      vx.log_odds = static_cast<std::int16_t>(updated);
      vx.stamp = s.hit;
      ++k.updates;
      ++k.hits;
    }
  } else if (stamp != s.hit) {
    vx.stamp = s.queued;
  }
  ++k.rays;
  return true;
}

MapIntegrator::EndMarkStamps MapIntegrator::end_mark_stamps(std::size_t max_rays) const noexcept {
  const auto base = static_cast<std::uint16_t>(store_->frame_tag() * 4u);
  return {static_cast<std::uint16_t>(base + kQueued),
          static_cast<std::uint16_t>(base + kHit),
          store_->since_tick(),
          p_->config.merge_rays_per_voxel,
          max_rays,
          p_->q_hit,
          p_->q_max,
          p_->q_occupied};
}

void MapIntegrator::add_end_mark_counters(const EndMarkCounters& k) noexcept {
  stats_.pixels_sampled += k.pixels;
  stats_.rays_merged += k.merged;
  stats_.rays_dropped += k.dropped;
  stats_.updates_dropped += k.dropped_updates;
  stats_.voxel_updates += k.updates;
  stats_.hits += k.hits;
}

/// Pass 1 on this thread: end voxels four pixels at a time, map updates one pixel at a time in
/// pixel order; blocks are looked up once per run of pixels in the same block.
void MapIntegrator::mark_end_points(const DepthView& depth) noexcept {
  const EndPointConstants c = end_point_constants();
  const EndMarkStamps stamps = end_mark_stamps(p_->config.max_rays_per_frame);
  EndMarkCounters k{};
  k.rays = ray_count_;
  const int margin = p_->config.pixel_margin, stride = p_->config.pixel_stride;
  const int width = g_.cam->width, columns = g_.sampled_columns;
  const std::int32_t key_block_x = g_.key_base[0] >> kBlockBits;
  const std::int32_t key_block_y = g_.key_base[1] >> kBlockBits;
  const std::int32_t key_block_z = g_.key_base[2] >> kBlockBits;
  const LocalGrid grid = local_grid();
  Block* block = nullptr;
  // Keys are >= 0, so the first pixel (and the one after a failed lookup) looks its block up.
  std::int32_t current_key = -1;
  for (int v = margin; v < g_.cam->height - margin; v += stride) {
    const std::uint16_t* row = depth.row(v);
    const RowDirection row_dir = row_direction_lanes(v);
    const std::uint8_t* carve_cells = no_return_row(v);
    for (int k0 = 0; k0 < columns; k0 += 4) {
      const int lanes = std::min(4, columns - k0);
      const EndLanes e = end_lanes(c, row, carve_cells, row_dir, k0, lanes);
      const Eigen::Array4i key =
          e.blk_x + (e.blk_y + e.blk_z.shiftLeft<kKeyBlockBits>()).shiftLeft<kKeyBlockBits>();
      for (int l = 0; l < lanes; ++l) {
        if (e.too_near[l] != 0) continue;  // closer than min_depth
        ++k.pixels;
        if (key[l] != current_key) {
          block = local_block(grid, e.blk_x[l] + key_block_x, e.blk_y[l] + key_block_y,
                              e.blk_z[l] + key_block_z);
          if (block == nullptr) {
            current_key = -1;
            ++k.dropped;
            ++k.dropped_updates;
            continue;
          }
          current_key = key[l];
        }
        const std::size_t before = k.rays;
        if (mark_end_voxel(*block, static_cast<std::size_t>(e.in_block[l]), e.hit[l] != 0, stamps,
                           k)) {
          rays_[before] = static_cast<std::uint32_t>(v * width + margin + (k0 + l) * stride);
        }
      }
    }
  }
  ray_count_ = k.rays;
  add_end_mark_counters(k);
}

// --- Pass 1 on the team (carve_tiles > 0) ----------------------------------------------------
// The same end voxels and map updates as mark_end_points(), in three steps: the members claim
// fixed chunks of rows, compute their end voxels into t_.end_codes, bucket the sample indices by
// owner (cell % members) and list the cells each chunk ends in; this thread acquires those
// cells' blocks, in pixel order of first appearance; each member then runs the pixel-order
// updates of the cells it owns, reading only its buckets, which decide merges and hits per
// voxel exactly as the one-thread loop does, since they depend only on the pixels ending in
// that voxel. Each tile then lists its kept rays itself (list_tile_rays()). Used when the visit
// of every sampled pixel fits max_rays_per_frame (the cap is a pixel-order rule).

namespace {
constexpr std::uint32_t kSkipCode = 0xFFFFFFFFu;     ///< closer than min_depth
constexpr std::uint32_t kOutsideCode = 0xFFFFFFFEu;  ///< outside the local grid (never)

/// Owner of a cell among `members` team members (a mask when their number is a power of two).
inline unsigned cell_owner(std::uint32_t cell, unsigned members) noexcept {
  return (members & (members - 1)) == 0 ? cell & (members - 1) : cell % members;
}
}  // namespace

/// One member's pass-1 output while it computes its rows: the sample indices bucketed by
/// owner, and the cells in order of first appearance.
struct MapIntegrator::EndCodeSink {
  unsigned members;
  std::array<std::uint32_t*, kMembers> buckets;
  std::array<std::uint32_t, kMembers> counts;
  std::uint64_t* seen;
  std::uint16_t* cells;
  std::size_t cell_count;
  std::uint32_t last_cell;  ///< cell of the last listed pixel (kMaxTileCells: none yet)

  /// A pixel ending outside the grid (never happens): member 0 counts it.
  void add_outside(std::uint32_t sample) noexcept { buckets[0][counts[0]++] = sample; }
  void add(std::uint32_t cell, std::uint32_t sample) noexcept {
    const unsigned o = cell_owner(cell, members);
    buckets[o][counts[o]++] = sample;
    if (cell == last_cell) return;
    last_cell = cell;
    const std::uint64_t bit = std::uint64_t{1} << (cell & 63u);
    if ((seen[cell >> 6] & bit) != 0) return;
    seen[cell >> 6] |= bit;
    cells[cell_count++] = static_cast<std::uint16_t>(cell);
  }
  /// Four pixels ending in the cell of the last one: one bucket.
  void add_four(std::uint32_t s0) noexcept {
    const unsigned o = cell_owner(last_cell, members);
    std::uint32_t* b = &buckets[o][counts[o]];
    for (std::uint32_t l = 0; l < 4; ++l) b[l] = s0 + l;
    counts[o] += 4;
  }
};

/// End codes of the rows of `chunk` (pass 1 on the team), bucketed by owner.
void MapIntegrator::compute_end_codes(std::size_t chunk) noexcept {
  const EndPointConstants c = end_point_constants();
  const int margin = p_->config.pixel_margin, stride = p_->config.pixel_stride;
  const int columns = g_.sampled_columns;
  const int rows = std::max(0, (g_.cam->height - 2 * margin + stride - 1) / stride);
  const unsigned members = team_->size();
  const auto j0 = static_cast<int>(static_cast<std::size_t>(rows) * chunk / kCodeChunks);
  const auto j1 = static_cast<int>(static_cast<std::size_t>(rows) * (chunk + 1) / kCodeChunks);
  const LocalGrid grid = local_grid();
  const Eigen::Array4i off_x =
      Eigen::Array4i::Constant((g_.key_base[0] >> kBlockBits) - grid.origin[0]);
  const Eigen::Array4i off_y =
      Eigen::Array4i::Constant((g_.key_base[1] >> kBlockBits) - grid.origin[1]);
  const Eigen::Array4i off_z =
      Eigen::Array4i::Constant((g_.key_base[2] >> kBlockBits) - grid.origin[2]);
  const Eigen::Array4i dim_x = Eigen::Array4i::Constant(static_cast<std::int32_t>(grid.dim[0]));
  const Eigen::Array4i dim_y = Eigen::Array4i::Constant(static_cast<std::int32_t>(grid.dim[1]));
  const Eigen::Array4i dim_z = Eigen::Array4i::Constant(static_cast<std::int32_t>(grid.dim[2]));
  const std::size_t band_first = static_cast<std::size_t>(j0) * static_cast<std::size_t>(columns);
  t_.chunk_first[chunk] = band_first;
  EndCodeSink sink{
      members, {}, {}, t_.chunk_seen[chunk].data(), t_.chunk_cells[chunk].data(), 0, kMaxTileCells};
  for (unsigned o = 0; o < members; ++o) sink.buckets[o] = &t_.owner_samples[o][band_first];
  std::fill_n(sink.seen, kMaxTileCells / 64, std::uint64_t{0});
  for (int j = j0; j < j1; ++j) {
    const int v = margin + j * stride;
    const std::uint16_t* row = t_.team_depth->row(v);
    const RowDirection row_dir = row_direction_lanes(v);
    const std::uint8_t* carve_cells = no_return_row(v);
    const std::size_t first = static_cast<std::size_t>(j) * static_cast<std::size_t>(columns);
    std::uint32_t* codes = &t_.end_codes[first];
    std::fill_n(&t_.end_kept[first], columns, std::uint8_t{0});
    for (int k0 = 0; k0 < columns; k0 += 4) {
      const int lanes = std::min(4, columns - k0);
      const EndLanes e = end_lanes(c, row, carve_cells, row_dir, k0, lanes);
      const Eigen::Array4i gi = e.blk_x + off_x, gj = e.blk_y + off_y, gk = e.blk_z + off_z;
      const Eigen::Array4i cell = gi + dim_x * (gj + dim_y * gk);
      const Eigen::Array<bool, 4, 1> inside =
          (gi.min(gj).min(gk) >= 0) && (gi < dim_x) && (gj < dim_y) && (gk < dim_z);
      const Eigen::Array4i code = cell.shiftLeft<10>() + e.hit.shiftLeft<9>() + e.in_block;
      const auto s0 = static_cast<std::uint32_t>(first + static_cast<std::size_t>(k0));
      if (lanes == 4 && cell[0] == static_cast<std::int32_t>(sink.last_cell) && inside.all() &&
          (cell == cell[0]).all() && (e.too_near == 0).all()) {
        std::memcpy(&codes[k0], code.data(), sizeof(code));  // the common packet
        sink.add_four(s0);
        continue;
      }
      for (int l = 0; l < lanes; ++l) {
        const std::uint32_t sample = s0 + static_cast<std::uint32_t>(l);
        if (e.too_near[l] != 0) {
          codes[k0 + l] = kSkipCode;
        } else if (!inside[l]) {
          codes[k0 + l] = kOutsideCode;
          sink.add_outside(sample);
        } else {
          codes[k0 + l] = static_cast<std::uint32_t>(code[l]);
          sink.add(static_cast<std::uint32_t>(cell[l]), sample);
        }
      }
    }
  }
  t_.owner_counts[chunk] = sink.counts;
  t_.chunk_cell_count[chunk] = sink.cell_count;
}

/// The blocks of the cells the members' rows end in, in pixel order of first appearance (the
/// members' lists in row order, cells already acquired skipped). A cell whose block cannot be
/// had (pool full) is not tried again this frame, whatever the number of members.
void MapIntegrator::acquire_end_blocks() noexcept {
  const LocalGrid grid = local_grid();
  std::fill(t_.acquire_failed.begin(), t_.acquire_failed.end(), std::uint64_t{0});
  for (std::size_t c = 0; c < kCodeChunks; ++c) {
    for (std::size_t i = 0; i < t_.chunk_cell_count[c]; ++i) {
      const std::uint32_t cell = t_.chunk_cells[c][i];
      const std::uint64_t bit = std::uint64_t{1} << (cell & 63u);
      if (grid.cells[cell] != 0 || (t_.acquire_failed[cell >> 6] & bit) != 0) continue;
      const std::uint32_t gi = cell % grid.dim[0];
      const std::uint32_t gj = (cell / grid.dim[0]) % grid.dim[1];
      const std::uint32_t gk = cell / (grid.dim[0] * grid.dim[1]);
      if (local_block(grid, grid.origin[0] + static_cast<std::int32_t>(gi),
                      grid.origin[1] + static_cast<std::int32_t>(gj),
                      grid.origin[2] + static_cast<std::int32_t>(gk)) == nullptr) {
        t_.acquire_failed[cell >> 6] |= bit;
      }
    }
  }
}

/// Owner `member`'s pixel-order updates: its buckets of every chunk's rows, in row order.
void MapIntegrator::mark_end_codes(unsigned member, std::size_t samples) noexcept {
  const EndMarkStamps stamps = end_mark_stamps(samples);
  EndMarkCounters k{};
  const std::uint16_t* cells = local_grid_.data();
  const std::uint32_t* bucket = t_.owner_samples[member].data();
  // kOutsideCode's cell is past every grid cell, so it never has a block.
  static_assert((kOutsideCode >> 10) >= kMaxTileCells, "outside code names no cell");
  std::uint32_t last_cell = 0xFFFFFFFFu;
  Block* block = nullptr;
  for (std::size_t c = 0; c < kCodeChunks; ++c) {
    const std::size_t first = t_.chunk_first[c];
    const std::size_t end = first + t_.owner_counts[c][member];
    for (std::size_t i = first; i < end; ++i) {
      const std::uint32_t s = bucket[i];
      const std::uint32_t code = t_.end_codes[s];
      const std::uint32_t cell = code >> 10;
      ++k.pixels;
      if (cell != last_cell) {
        last_cell = cell;
        const std::uint16_t slot = cell < kMaxTileCells ? cells[cell] : std::uint16_t{0};
        block = slot != 0 ? &store_->block(slot - 1u) : nullptr;
      }
      if (block == nullptr) {
        ++k.dropped;  // no block: outside the grid (never) or the pool is full
        ++k.dropped_updates;
        continue;
      }
      t_.end_kept[s] =
          mark_end_voxel(*block, code & 511u, ((code >> 9) & 1u) != 0, stamps, k) ? 1 : 0;
    }
  }
  t_.member_marks[member] = k;
}

void MapIntegrator::mark_end_points_in_team() noexcept {
  const int margin = p_->config.pixel_margin, stride = p_->config.pixel_stride;
  const int columns = g_.sampled_columns;
  const int rows = std::max(0, (g_.cam->height - 2 * margin + stride - 1) / stride);
  const std::size_t samples = static_cast<std::size_t>(rows) * static_cast<std::size_t>(columns);
  t_.next_chunk.store(0, std::memory_order_relaxed);
  team_->run(
      [](void* self, unsigned) {
        auto& map = *static_cast<MapIntegrator*>(self);
        for (std::uint32_t c = map.t_.next_chunk.fetch_add(1, std::memory_order_relaxed);
             c < kCodeChunks; c = map.t_.next_chunk.fetch_add(1, std::memory_order_relaxed)) {
          map.compute_end_codes(c);
        }
      },
      this);
  acquire_end_blocks();
  t_.team_samples = samples;
  team_->run(
      [](void* self, unsigned member) {
        auto& map = *static_cast<MapIntegrator*>(self);
        map.mark_end_codes(member, map.t_.team_samples);
      },
      this);
  EndMarkCounters total{};
  for (unsigned m = 0; m < team_->size(); ++m) {
    const EndMarkCounters& k = t_.member_marks[m];
    total.rays += k.rays;
    total.pixels += k.pixels;
    total.merged += k.merged;
    total.dropped += k.dropped;
    total.dropped_updates += k.dropped_updates;
    total.updates += k.updates;
    total.hits += k.hits;
  }
  add_end_mark_counters(total);
  ray_count_ = total.rays;  // listed by the tiles themselves (list_tile_rays())
  t_.tiles_list_rays = true;
}

}  // namespace dynamap::detail
