// MapIntegrator's tiled carving (carve_tiles > 0): pass 2 in image column strips on the team
// lent for the frame, each tile against its own marks, the marks' union applied once per voxel.
#include <algorithm>
#include <atomic>
#include <cstring>

#include "map_carve_rays.hpp"
#include "map_integrator_inline.hpp"
#include "segment_walk.hpp"

namespace dynamap::detail {

// --- Tiled carving (carve_tiles > 0) ---------------------------------------------------------
// Each tile walks its rays exactly as the sequential carving does, but reads and writes its own
// mark sets instead of the voxels' miss stamps (hit stamps, written by pass 1, are only read).
// Tiles are claimed by the team's members through one atomic counter; what a tile computes
// depends only on its rays and pass 1, so the members' speed and number do not matter. The
// union of the marks is then applied once per voxel, each cell by one member.

/// One tile's walk: marks in the tile's scratch, hit stamps read from the map.
template <bool kEarlyStop>
struct MapIntegrator::TileCursor {
  const MapIntegrator& map;
  const LocalGrid grid;
  TileScratch& tile;
  const std::uint16_t hit_stamp;
  const std::uint32_t stop_after;
  const std::int32_t q_occupied;
  const std::uint16_t now_tick, min_age_ticks, static_ticks;
  const bool read_blocks;    // keep_own_surface, miss_max_offset, keep_unknown_backed: reads
                             // voxels pass 1 did not touch
  const float near, spread;  // miss_max_offset, miss_offset_spread in m (near 0: off)
  const bool backed;         // keep_unknown_backed
  const DepthView* depth;
  const Block* block = nullptr;
  bool unallocated = false;  // block is empty_block_: its voxels were never observed
  std::uint64_t* marks = nullptr;
  std::uint32_t run = 0;
  bool surface = false;  // still on the ray's own surface (keep_own_surface)
  const RayWalk* ray = nullptr;
  std::int32_t bi_ = 0, bj_ = 0, bk_ = 0;

  /// As the one walk's cursor: the ray passes too far from the centre of a voxel never observed
  /// or occupied long enough (miss_max_offset).
  bool passes_aside(std::int32_t li) const noexcept {
    if (near <= 0.f) return false;
    const auto at = static_cast<std::size_t>(li);
    return centre_rule_applies(unallocated ? kUnknown : block->voxels[at].log_odds, q_occupied,
                               block->occupied_since[at], now_tick, static_ticks) &&
           detail::passes_aside<kBlockBits>(*ray, bi_, bj_, bk_, li, map.p_->resolution, near,
                                            spread);
  }
  void enter(std::int32_t bi, std::int32_t bj, std::int32_t bk, std::size_t) noexcept {
    bi_ = bi;
    bj_ = bj;
    bk_ = bk;
    const auto gi = static_cast<std::uint32_t>(bi - grid.origin[0]);
    const auto gj = static_cast<std::uint32_t>(bj - grid.origin[1]);
    const auto gk = static_cast<std::uint32_t>(bk - grid.origin[2]);
    if (gi >= grid.dim[0] || gj >= grid.dim[1] || gk >= grid.dim[2]) {
      // Cannot happen (rays stay in the local region, inside the grid): nothing is kept.
      block = &map.empty_block_;
      marks = tile.discard.data();
      return;
    }
    const std::uint32_t cell = gi + grid.dim[0] * (gj + grid.dim[1] * gk);
    const std::uint16_t slot = grid.cells[cell];
    // A cell pass 1 did not resolve holds no hit of this frame. Its block, if any, is only
    // read (nothing writes the store while the tiles walk).
    block = slot != 0 ? &map.store_->block(slot - 1u) : &map.empty_block_;
    if (slot == 0 && read_blocks) {
      const Block* stored = static_cast<const BlockStore*>(map.store_)->find(bi, bj, bk);
      if (stored != nullptr) block = stored;
    }
    unallocated = block == &map.empty_block_;
    std::uint16_t& set = tile.slot_of_cell[cell];
    if (set == 0) {
      tile.cells[tile.cell_count] = static_cast<std::uint16_t>(cell);
      tile.marks[tile.cell_count].fill(0);
      // The one walk allocates every block it enters. Without miss_max_offset every voxel of
      // a new block is marked; with it a ray may pass all of them aside, and the block is
      // still acquired, as there.
      tile.nonempty[tile.cell_count] = unallocated && near > 0.f ? 1 : 0;
      set = static_cast<std::uint16_t>(++tile.cell_count);
    }
    marks = tile.marks[set - 1u].data();
  }
  void leave(std::size_t) noexcept {}
  /// As the one walk's cursor, from the voxels' states before this frame's misses (the tiles
  /// only mark; the one walk reads the misses its earlier rays applied).
  bool unknown_backed(std::int32_t li) const noexcept {
    if (!backed) return false;
    const std::int16_t q = block->voxels[static_cast<std::size_t>(li)].log_odds;
    if (q == kUnknown || q <= q_occupied) return false;
    return map.spares_unknown_backed(bi_, bj_, bk_, li, *depth);
  }
  /// Whether the voxel is occupied (long enough) before this frame's carving, or hit this frame.
  bool on_surface(std::size_t li) const noexcept {
    const Voxel& vx = block->voxels[li];
    return on_own_surface(vx.stamp == hit_stamp, vx.log_odds, q_occupied, block->occupied_since[li],
                          now_tick, min_age_ticks);
  }
  bool visit(std::int32_t li) noexcept {
    if (surface) {
      if (on_surface(static_cast<std::size_t>(li))) {
        run = 0;
        return false;
      }
      surface = false;
    }
    std::uint64_t& word = marks[li >> 6];
    const std::uint64_t bit = std::uint64_t{1} << (li & 63);
    if ((word & bit) != 0) {
      if constexpr (kEarlyStop) return ++run == stop_after;
      return false;
    }
    run = 0;
    if (block->voxels[static_cast<std::size_t>(li)].stamp != hit_stamp && !passes_aside(li) &&
        !unknown_backed(li)) {
      word |= bit;
    }
    return false;
  }
};

template <bool kEarlyStop>
void MapIntegrator::carve_tile(std::size_t t, const DepthView& depth) noexcept {
  TileScratch& tile = t_.tiles[t];
  for (std::size_t s = 0; s < tile.cell_count; ++s) tile.slot_of_cell[tile.cells[s]] = 0;
  tile.cell_count = 0;
  tile.counters = CarveCounters{};
  if (t_.tiles_list_rays) list_tile_rays(t);
  IndexVec camera{};
  if (!voxel_index(g_.origin, p_->inv_resolution, camera))
    return;  // cannot happen: integrate() checked the pose
  tile.counters.visits_left = std::max<std::size_t>(
      1, p_->config.max_voxel_visits_per_frame / static_cast<std::size_t>(p_->config.carve_tiles));
  const std::uint16_t hit_stamp = store_->stamp(kHit);
  TileCursor<kEarlyStop> cursor{*this,
                                local_grid(),
                                tile,
                                hit_stamp,
                                static_cast<std::uint32_t>(p_->config.free_ray_early_stop),
                                p_->q_occupied,
                                store_->since_tick(),
                                own_surface_min_ticks(),
                                static_min_ticks(),
                                p_->config.keep_own_surface || p_->config.miss_max_offset > 0.f ||
                                    p_->config.keep_unknown_backed,
                                miss_near(),
                                miss_spread(),
                                p_->config.keep_unknown_backed,
                                &depth};
  carve_rays<kEarlyStop>(tile.ray_begin, tile.ray_end, depth, camera, cursor, tile.counters);
  for (std::size_t s = 0; s < tile.cell_count; ++s) {
    std::uint64_t any = 0;
    for (const std::uint64_t w : tile.marks[s]) any |= w;
    if (any != 0) tile.nonempty[s] = 1;
  }
}

/// The cells any tile marked, in a fixed order (tile, then cell entry order), with the cell's
/// block acquired (allocated, evicting if needed) on this thread. Returns their number.
std::size_t MapIntegrator::collect_tile_marks() noexcept {
  const auto tiles = static_cast<std::size_t>(p_->config.carve_tiles);
  std::fill(t_.merged_seen.begin(), t_.merged_seen.end(), std::uint64_t{0});
  const LocalGrid grid = local_grid();
  std::size_t m = 0;
  for (std::size_t t = 0; t < tiles; ++t) {
    for (std::size_t s = 0; s < t_.tiles[t].cell_count; ++s) {
      const std::uint32_t cell = t_.tiles[t].cells[s];
      std::uint64_t& seen = t_.merged_seen[cell >> 6];
      const std::uint64_t bit = std::uint64_t{1} << (cell & 63);
      if ((seen & bit) != 0) continue;
      seen |= bit;
      bool any = false;  // earlier tiles did not enter the cell (it would have been seen)
      for (std::size_t o = t; o < tiles && !any; ++o) {
        const std::uint16_t set = t_.tiles[o].slot_of_cell[cell];
        any = set != 0 && t_.tiles[o].nonempty[set - 1u] != 0;
      }
      if (!any) continue;
      const std::uint32_t gi = cell % grid.dim[0];
      const std::uint32_t gj = (cell / grid.dim[0]) % grid.dim[1];
      const std::uint32_t gk = cell / (grid.dim[0] * grid.dim[1]);
      t_.merged_cell[m] = static_cast<std::uint16_t>(cell);
      t_.merged_block[m] = local_block(grid, grid.origin[0] + static_cast<std::int32_t>(gi),
                                       grid.origin[1] + static_cast<std::int32_t>(gj),
                                       grid.origin[2] + static_cast<std::int32_t>(gk));
      ++m;
    }
  }
  return m;
}

/// Member `member`'s share of the collected cells: the union of the tiles' marks of the cell,
/// one miss per marked voxel (marks never fall on this frame's hits). Cells are whole blocks,
/// so members never write the same block.
void MapIntegrator::apply_tile_marks(unsigned member) noexcept {
  const std::size_t members = team_->size();
  const std::size_t begin = t_.merged_count * member / members;
  const std::size_t end = t_.merged_count * (member + 1) / members;
  const auto tiles = static_cast<std::size_t>(p_->config.carve_tiles);
  const std::uint16_t miss_stamp = store_->stamp(kMiss);
  const std::int32_t q_miss = p_->q_miss, q_min = p_->q_min, q_occupied = p_->q_occupied;
  std::size_t updates = 0, dropped = 0;
  for (std::size_t m = begin; m < end; ++m) {
    const std::uint32_t cell = t_.merged_cell[m];
    std::array<const std::uint64_t*, kMaxCarveTiles> sets{};
    std::size_t set_count = 0;
    for (std::size_t t = 0; t < tiles; ++t) {
      const std::uint16_t set = t_.tiles[t].slot_of_cell[cell];
      if (set != 0) sets[set_count++] = t_.tiles[t].marks[set - 1u].data();
    }
    Block* block = t_.merged_block[m];
    for (std::size_t w = 0; w < kBlockVoxels / 64; ++w) {
      std::uint64_t bits = 0;
      for (std::size_t i = 0; i < set_count; ++i) bits |= sets[i][w];
      if (block == nullptr) {
        dropped += static_cast<std::size_t>(__builtin_popcountll(bits));
        continue;
      }
      while (bits != 0) {
        const std::size_t li = w * 64 + static_cast<std::size_t>(__builtin_ctzll(bits));
        bits &= bits - 1;
        Voxel& vx = block->voxels[li];
        const std::int16_t old = vx.log_odds;
        const std::int32_t current = old == kUnknown ? 0 : old;
        const auto updated = static_cast<std::int16_t>(std::max(current + q_miss, q_min));
        vx.log_odds = updated;
        vx.stamp = miss_stamp;
        ++updates;
        if (old > q_occupied && updated <= q_occupied) --block->occupied;
      }
    }
  }
  t_.member_updates[member] = {updates, dropped};
}

/// Claim order of the tiles: most voxel visits in the last frame first (longest task first
/// balances the members best); ties, and the first frame, in tile order. Only who walks which
/// tile depends on it, never the result.
void MapIntegrator::order_tile_claims() noexcept {
  const auto tiles = static_cast<std::size_t>(p_->config.carve_tiles);
  for (std::size_t t = 0; t < tiles; ++t) {
    std::size_t i = t;
    const std::size_t visits = t_.tiles[t].counters.visits;
    for (; i > 0 && t_.tiles[t_.tile_order[i - 1]].counters.visits < visits; --i) {
      t_.tile_order[i] = t_.tile_order[i - 1];
    }
    t_.tile_order[i] = static_cast<std::uint8_t>(t);
  }
}

void MapIntegrator::prepare_tiles() noexcept {
  if (!t_.tiles_list_rays) order_rays(p_->config.carve_tiles, p_->config.free_ray_early_stop > 0);
  order_tile_claims();
  t_.next_tile.store(0, std::memory_order_relaxed);
}

void MapIntegrator::carve_tile_claims() noexcept {
  const auto count = static_cast<std::uint32_t>(p_->config.carve_tiles);
  for (std::uint32_t i = t_.next_tile.fetch_add(1, std::memory_order_relaxed); i < count;
       i = t_.next_tile.fetch_add(1, std::memory_order_relaxed)) {
    const std::size_t t = t_.tile_order[i];
    if (p_->config.free_ray_early_stop > 0) {
      carve_tile<true>(t, *t_.team_depth);
    } else {
      carve_tile<false>(t, *t_.team_depth);
    }
  }
}

void MapIntegrator::finish_tiles() noexcept {
  const auto tiles = static_cast<std::size_t>(p_->config.carve_tiles);
  for (std::size_t t = 0; t < tiles; ++t) {
    const CarveCounters& k = t_.tiles[t].counters;
    stats_.rays += k.rays;
    stats_.rays_stopped_early += k.rays_stopped;
    stats_.rays_dropped += k.rays_dropped;
    stats_.voxel_visits += k.visits;
  }
  t_.merged_count = collect_tile_marks();
  team_->run([](void* self,
                unsigned member) { static_cast<MapIntegrator*>(self)->apply_tile_marks(member); },
             this);
  for (unsigned m = 0; m < team_->size(); ++m) {
    stats_.voxel_updates += t_.member_updates[m][0];
    stats_.updates_dropped += t_.member_updates[m][1];
  }
}

}  // namespace dynamap::detail
