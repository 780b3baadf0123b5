// MapIntegrator: one depth frame's rays into the occupancy map's block store, and all the
// scratch that takes (ray lists, frame geometry, the local block grid, the tiled carving's mark
// sets). Held inline by OccupancyMap, which validates the input and owns the store and the
// parameters; see docs/occupancy_map.md, "Parts". Threads are lent per frame (TaskTeam), never
// owned. Pass 1 (end points): src/map/map_end_points.cpp; pass 2 (carving): the one walk in
// src/map/map_carving.cpp, the tiles on the team in src/map/map_tiled_carving.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/status.hpp"
#include "dynamap/core/task_team.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/map/detail/block_store.hpp"
#include "dynamap/map/occupancy_map_config.hpp"
#include "dynamap/map/trail_grid.hpp"

namespace dynamap::detail {

struct RayWalk;

/// Cells of the per-frame dense block cache over the local region (default region: 3179).
inline constexpr std::size_t kLocalGridCells = 32768;
/// Log-odds are stored as int16 in units of 1/kLogOddsScale.
inline constexpr float kLogOddsScale = 1000.f;

/// The map's parameters as init() derived them: the configuration, and the probabilities as
/// quantized log-odds. Owned by OccupancyMap, read by its integrator.
struct MapParams {
  OccupancyMapConfig config{};
  float resolution = 0.1f;
  float inv_resolution = 10.f;
  std::int16_t q_hit = 0, q_miss = 0, q_min = 0, q_max = 0, q_occupied = 0;
};

class MapIntegrator {
 public:
  MapIntegrator(BlockStore& store, const MapParams& params) noexcept
      : p_(&params), store_(&store) {}
  MapIntegrator(const MapIntegrator&) = delete;
  MapIntegrator& operator=(const MapIntegrator&) = delete;

  /// The local block grid's dimensions (enabled when it has at most kLocalGridCells cells),
  /// and no frame integrated yet.
  void reset(const std::array<std::int32_t, 3>& grid_dim, std::size_t cells) noexcept;
  /// One frame the map has validated, in the three steps of OccupancyMap::begin_integration():
  /// set-up and pass 1 (on `team` when the carving is tiled); one member's share of the
  /// carving, called by every member of one run of the same team; the tiles' marks applied
  /// (on the team) and the stats totalled. `team` must outlive finish().
  void begin(const DepthView& depth, const CameraIntrinsics& cam, const Pose& T_map_camera,
             TaskTeam& team) noexcept;
  void carve_share(unsigned member) noexcept;
  void finish() noexcept;
  bool frame_open() const noexcept { return team_ != nullptr; }

  const IntegrationStats& stats() const noexcept { return stats_; }
  /// keep_unknown_backed does not apply where `trail` (the caller's, or none) says a dynamic
  /// track has been.
  void set_trail(const TrailGrid* trail) noexcept { trail_ = trail; }
  /// A block allocated outside integration (OccupancyMap::set_log_odds()) counts in the stats.
  void count_allocated_block() noexcept { ++stats_.blocks_allocated; }

 private:
  using IndexVec = detail::IndexVec;
  static constexpr std::int16_t kUnknown = kUnknownLogOdds;
  static constexpr std::uint16_t kQueued = kStampQueued;
  static constexpr std::uint16_t kHit = kStampHit;
  static constexpr std::uint16_t kMiss = kStampMiss;
  static_assert(kMaxMapBlocks < 65535, "local_grid_ stores slot + 1 as uint16");
  /// Pass 1 names blocks by an int key of block indices relative to key_base (voxel index of
  /// the camera's block less 2^(kKeyBlockBits-1) blocks per axis; the local region is at most
  /// 1000 voxels = 125 blocks each side of the camera, init() checks it).
  static constexpr int kKeyBlockBits = 9;
  static constexpr std::size_t kMembers = kMaxTeamMembers;
  /// Pass 1's rows are split into kCodeChunks fixed chunks, claimed by the members one at a
  /// time (a late member only computes fewer of them).
  static constexpr std::size_t kCodeChunks = 16;

  /// The local block grid's geometry for one frame, held in the integration loops' locals so
  /// a block look-up does not reload the members after every map write (or after a call).
  struct LocalGrid {
    std::array<std::int32_t, 3> origin;  ///< grid_origin_
    std::array<std::uint32_t, 3> dim;    ///< grid_dim_, all 0 when the grid is disabled
    std::uint16_t* cells;                ///< local_grid_
  };
  LocalGrid local_grid() noexcept;
  Block* local_block(const LocalGrid& g, std::int32_t bi, std::int32_t bj,
                     std::int32_t bk) noexcept;
  // A ray's end point, end voxel (clipped to the local region) and the camera depth there. Pass 2
  // calls this; pass 1 does the same float operations four pixels at a time, so both agree bit
  // for bit.
  bool end_point(std::uint16_t raw, bool zero_carves, const Eigen::Array4f& dir,
                 Eigen::Array4f& end, IndexVec& idx, bool& is_hit, float& end_depth) const noexcept;
  Eigen::Array4f row_direction(int v) const noexcept {
    return ((static_cast<float>(v) - g_.cy) * g_.inv_fy) * g_.down_dir + g_.forward_dir;
  }
  void set_frame_geometry(const CameraIntrinsics& cam, const Pose& T_map_camera) noexcept;
  // Pass 1 (end points), src/map/map_end_points.cpp.
  struct EndPointConstants;
  EndPointConstants end_point_constants() const noexcept;
  /// End voxels of four sampled pixels: classes as 0/1 lanes, block indices relative to
  /// g_.key_base >> kBlockBits, voxel index inside the block.
  struct EndLanes {
    Eigen::Array4i too_near, hit, blk_x, blk_y, blk_z, in_block;
  };
  /// A row's ray direction, one broadcast array per axis.
  struct RowDirection {
    Eigen::Array4f x, y, z;
  };
  RowDirection row_direction_lanes(int v) const noexcept {
    const Eigen::Array4f d = row_direction(v);
    return {Eigen::Array4f::Constant(d[0]), Eigen::Array4f::Constant(d[1]),
            Eigen::Array4f::Constant(d[2])};
  }
  EndLanes end_lanes(const EndPointConstants& c, const std::uint16_t* row,
                     const std::uint8_t* carve_cells, const RowDirection& row_dir, int k0,
                     int lanes) const noexcept;
  /// no_return_free_depth: finds this frame's cells whose 0 pixels carve (g_.no_return_carves).
  void find_no_return_regions(const DepthView& depth) noexcept;
  /// The carve flags of row v's cells, or nullptr when no 0 pixel of the frame carves.
  const std::uint8_t* no_return_row(int v) const noexcept {
    return g_.no_return_any
               ? &g_.no_return_carves[static_cast<std::size_t>(v / kNoReturnCellPixels) *
                                      kNoReturnCellsX]
               : nullptr;
  }
  struct EndMarkStamps {
    std::uint16_t queued, hit, since;
    bool merge;
    std::size_t max_rays;
    std::int32_t q_hit, q_max, q_occupied;
  };
  struct EndMarkCounters {
    std::size_t rays = 0, pixels = 0, merged = 0, dropped = 0, dropped_updates = 0, updates = 0,
                hits = 0;
  };
  EndMarkStamps end_mark_stamps(std::size_t max_rays) const noexcept;
  bool mark_end_voxel(Block& block, std::size_t li, bool hit, const EndMarkStamps& s,
                      EndMarkCounters& k) noexcept;
  void add_end_mark_counters(const EndMarkCounters& k) noexcept;
  void mark_end_points(const DepthView& depth) noexcept;
  void mark_end_points_in_team() noexcept;
  struct EndCodeSink;
  void compute_end_codes(std::size_t chunk) noexcept;
  void acquire_end_blocks() noexcept;
  void mark_end_codes(unsigned member, std::size_t samples) noexcept;
  // Pass 2 (free space), src/map/map_carving.cpp.
  /// Work counters of one ray list's walk, summed into stats_ by the caller.
  struct CarveCounters {
    std::size_t visits_left = 0, visits = 0, rays = 0, rays_dropped = 0, rays_stopped = 0;
    std::size_t updates = 0, dropped_updates = 0;
  };
  /// One tile's marks: a 512-bit set (one bit per voxel) per local grid cell it entered.
  struct TileScratch {
    std::array<std::uint16_t, kMaxTileCells> slot_of_cell;  ///< mark set + 1; 0: none yet
    std::array<std::uint16_t, kMaxTileCells> cells;         ///< cells entered, in order
    std::array<std::array<std::uint64_t, kBlockVoxels / 64>, kMaxTileCells> marks;
    std::array<std::uint64_t, kBlockVoxels / 64> discard;  ///< marks outside the grid (none)
    std::array<std::uint8_t, kMaxTileCells>
        nonempty;  ///< mark set holds a mark, or its block is to be acquired
    std::size_t cell_count;
    std::size_t ray_begin, ray_end;  ///< its rays in ordered_rays_
    CarveCounters counters;
  };
  template <bool kEarlyStop>
  struct SequentialCursor;
  template <bool kEarlyStop>
  struct TileCursor;
  std::size_t order_rays(int tiles, bool by_level) noexcept;
  /// own_surface_min_frames in occupied-since ticks, rounded up.
  std::uint16_t own_surface_min_ticks() const noexcept {
    const auto frames = static_cast<std::uint64_t>(p_->config.own_surface_min_frames);
    return static_cast<std::uint16_t>((frames + BlockStore::kSinceTickFrames - 1) /
                                      BlockStore::kSinceTickFrames);
  }
  /// Age (ticks) from which miss_max_offset treats an occupied voxel as static: three times
  /// keep_own_surface's, within the ages the store tells apart.
  std::uint16_t static_min_ticks() const noexcept {
    return static_cast<std::uint16_t>(
        std::min<std::uint32_t>(3u * own_surface_min_ticks(), BlockStore::kMaxSinceAgeTicks));
  }
  float miss_near() const noexcept { return p_->config.miss_max_offset * p_->resolution; }
  float miss_spread() const noexcept { return p_->config.miss_offset_spread * p_->resolution; }
  void list_tile_rays(std::size_t tile) noexcept;
  void order_tile_claims() noexcept;
  bool stop_short(float z, const Eigen::Array4f& dir, Eigen::Array4f& end,
                  IndexVec& last) const noexcept;
  bool start_ray(std::uint32_t pixel, const DepthView& depth, const IndexVec& camera, bool from_end,
                 RayWalk& w) const noexcept;
  template <bool kEarlyStop, class Cursor>
  void carve_rays(std::size_t begin, std::size_t end, const DepthView& depth,
                  const IndexVec& camera, Cursor& cursor, CarveCounters& k) const noexcept;
  template <bool kEarlyStop>
  void carve_free_space(const DepthView& depth) noexcept;
  /// keep_unknown_backed, for the occupied voxel li of block (bi, bj, bk) a miss would lower;
  /// both walks.
  bool spares_unknown_backed(std::int32_t bi, std::int32_t bj, std::int32_t bk, std::int32_t li,
                             const DepthView& depth) const noexcept;
  bool unseen_in_view(std::int32_t i, std::int32_t j, std::int32_t k,
                      const DepthView& depth) const noexcept;
  template <bool kEarlyStop>
  void carve_tile(std::size_t tile, const DepthView& depth) noexcept;
  /// Pass 2 in one walk on this thread (carve_tiles = 0).
  void carve_one_walk(const DepthView& depth) noexcept;
  void prepare_tiles() noexcept;
  void carve_tile_claims() noexcept;
  void finish_tiles() noexcept;
  std::size_t collect_tile_marks() noexcept;
  void apply_tile_marks(unsigned member) noexcept;

  /// This frame's camera and ray geometry (set_frame_geometry()). Ray geometry as 4-lane
  /// arrays (lane 3 = 0) so the per-pixel maths is one SIMD operation.
  struct FrameGeometry {
    std::array<Eigen::Array4f, kMaxImageWidth> column_dir{};  ///< R * ((u-cx)/fx, 0, 0)
    /// column_dir of the sampled columns (margin + k * stride), one array per axis, so pass 1
    /// loads 4 pixels' directions per axis at once; padded to whole packets.
    std::array<float, kMaxImageWidth + 4> sampled_dir_x{}, sampled_dir_y{}, sampled_dir_z{};
    int sampled_columns = 0;
    /// Per image cell: 1 where 0 pixels carve free space this frame (no_return_free_depth > 0).
    std::array<std::uint8_t, kNoReturnCellsX * kNoReturnCellsY> no_return_carves{};
    bool no_return_any = false;
    /// Raw depths 1 .. hit_raw_end - 1 are hits (depth <= max_depth); below near_raw_end they
    /// are closer than min_depth (end_point()'s float tests, as integer ranges of the raw value).
    std::uint32_t hit_raw_end = 0, near_raw_end = 0;
    std::array<std::int32_t, 3> key_base{};  ///< see kKeyBlockBits
    Eigen::Vector3f origin = Eigen::Vector3f::Zero();
    Eigen::Array4f origin4 = Eigen::Array4f::Zero();       ///< origin, lane 3 = 0
    Eigen::Array4f half_extent4 = Eigen::Array4f::Zero();  ///< local region, lane 3 = inf
    Eigen::Array4f right_dir = Eigen::Array4f::Zero();     ///< R.col(0)
    Eigen::Array4f down_dir = Eigen::Array4f::Zero();      ///< R.col(1)
    Eigen::Array4f forward_dir = Eigen::Array4f::Zero();   ///< R.col(2)
    const CameraIntrinsics* cam = nullptr;
    float depth_scale = 0.f, cy = 0.f, inv_fy = 0.f;
  };

  /// Scratch of pass 1 on the team and of the tiled carving (carve_tiles > 0).
  struct TeamScratch {
    const DepthView* team_depth = nullptr;  ///< the frame being integrated (begin() .. finish())
    std::atomic<std::uint32_t> next_tile{0};
    std::array<TileScratch, kMaxCarveTiles> tiles{};
    /// Tiles in the order the members claim them: most voxel visits in the last frame first.
    std::array<std::uint8_t, kMaxCarveTiles> tile_order{};
    /// Pass 1 ran on the team: each tile lists and orders its own rays from end_kept.
    bool tiles_list_rays = false;
    /// Cells with a mark of any tile, in the fixed collection order, and their blocks (nullptr:
    /// pool full); the members take the union of the tiles' marks of their share of them.
    std::array<std::uint16_t, kMaxTileCells> merged_cell{};
    std::array<Block*, kMaxTileCells> merged_block{};
    std::array<std::uint64_t, kMaxTileCells / 64> merged_seen{};  ///< cells collected
    /// Pass 1 on the team: cells whose block could not be acquired this frame (not retried).
    std::array<std::uint64_t, kMaxTileCells / 64> acquire_failed{};
    std::size_t merged_count = 0;
    /// Per team member: misses applied and updates dropped by apply_tile_marks().
    std::array<std::array<std::size_t, 2>, kMembers> member_updates{};
    /// Pass 1 on the team: per sampled pixel (row-major), its end voxel as
    /// cell << 10 | hit << 9 | index in block (or a skip code), and whether its ray is listed.
    std::array<std::uint32_t, kMaxRaysPerFrame> end_codes{};
    std::array<std::uint8_t, kMaxRaysPerFrame> end_kept{};
    std::size_t team_samples = 0;
    std::atomic<std::uint32_t> next_chunk{0};
    /// Pass 1's codes bucketed by owner (cell % members): owner_samples[o] holds, from
    /// chunk_first[c] on, the owner_counts[c][o] sample indices of chunk c's rows that end in a
    /// cell of o, in pixel order; so each owner reads only its own.
    std::array<std::array<std::uint32_t, kMaxRaysPerFrame>, kMembers> owner_samples{};
    std::array<std::array<std::uint32_t, kMembers>, kCodeChunks> owner_counts{};
    std::array<std::size_t, kCodeChunks> chunk_first{};
    /// Per chunk: the cells its rows end in, in order of first appearance (so the blocks are
    /// acquired in pixel order of first appearance), and the set of them.
    std::array<std::array<std::uint16_t, kMaxTileCells>, kCodeChunks> chunk_cells{};
    std::array<std::size_t, kCodeChunks> chunk_cell_count{};
    std::array<std::array<std::uint64_t, kMaxTileCells / 64>, kCodeChunks> chunk_seen{};
    std::array<EndMarkCounters, kMembers> member_marks{};
  };

  const MapParams* p_;
  const TrailGrid* trail_ = nullptr;
  BlockStore* store_;
  IntegrationStats stats_{};
  std::array<std::uint32_t, kMaxRaysPerFrame> rays_{};  ///< pixel index (v * width + u)
  std::size_t ray_count_ = 0;
  /// rays_ in carving order: by tile, then coarse-to-fine level, then pixel order.
  std::array<std::uint32_t, kMaxRaysPerFrame> ordered_rays_{};
  TaskTeam* team_ = nullptr;  ///< the team lent for the open frame (begin() .. finish())
  /// Pool slot + 1 of each block of the local region resolved this frame (0: not yet).
  std::array<std::uint16_t, kLocalGridCells> local_grid_{};
  std::array<std::int32_t, 3> grid_origin_{}, grid_dim_{};
  std::size_t grid_cells_ = 0;
  bool grid_enabled_ = false;
  /// Stands in for a block the walk could not allocate (pool full): its stamps are set to this
  /// frame's miss stamp when first needed, so visits there change nothing.
  Block sink_{};
  std::uint16_t sink_tag_ = 0;  ///< frame tag the sink's stamps were set for (0: none)
  Block empty_block_{};         ///< stamps 0: what a walk reads in a cell without a block
  FrameGeometry g_{};
  TeamScratch t_{};
};

}  // namespace dynamap::detail
