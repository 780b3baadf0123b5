// OccupancyMap: log-odds occupancy on a hashed voxel grid with a budget fixed at compile time.
// Blocks of 8x8x8 voxels live in an inline pool located through an open-addressing table, so
// the object never allocates after construction and can be a static global (it is ~9 MB: never
// put one on the stack). See docs/occupancy_map.md for the layout, update rule and eviction.
#pragma once

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/map/detail/block_store.hpp"
#include "dynamap/platform/worker_team.hpp"

namespace dynamap {

/// Compile-time capacity of the per-frame ray list: a 640x480 image sampled with stride 2.
inline constexpr std::size_t kMaxRaysPerFrame =
    static_cast<std::size_t>(kMaxImageWidth) * static_cast<std::size_t>(kMaxImageHeight) / 4;

/// Upper bound of OccupancyMapConfig::max_voxel_visits_per_frame (DDA steps per frame): room for
/// the exact walk of every pixel of a 640x480 frame (offline measurements use up to 20 M); the
/// pipeline bounds it far lower (kMaxPipelineVoxelVisitsPerFrame).
inline constexpr std::size_t kMaxVoxelVisitsPerFrame = 32'000'000;

/// Upper bound of OccupancyMapConfig::threads (members of the map's worker team).
inline constexpr int kMaxMapThreads = static_cast<int>(platform::WorkerTeam::kMaxMembers);
/// Highest CPU index a map helper may be pinned to (glibc's CPU_SETSIZE - 1).
inline constexpr int kMaxCpuIndex = 1023;
/// Upper bound of OccupancyMapConfig::carve_tiles.
inline constexpr int kMaxCarveTiles = 8;
/// Tiled carving needs the local block grid to have at most this many cells (the default
/// region has 3179); each tile's scratch holds one 512-bit mark set per cell it touches.
inline constexpr std::size_t kMaxTileCells = 4096;

/// Edge (pixels) of the image cells in which map.no_return_free_depth looks for no-return
/// regions.
inline constexpr int kNoReturnCellPixels = 16;
inline constexpr int kNoReturnCellsX =
    (kMaxImageWidth + kNoReturnCellPixels - 1) / kNoReturnCellPixels;
inline constexpr int kNoReturnCellsY =
    (kMaxImageHeight + kNoReturnCellPixels - 1) / kNoReturnCellPixels;

/// What the map knows about a voxel: free (p < 0.5), occupied (p > prob_occupied), or unknown
/// (never observed, or the evidence undecided in between).
enum class Occupancy : std::uint8_t { kUnknown = 0, kFree, kOccupied };

/// Parameters of OccupancyMap; probabilities, depths and sampling are the paper's (docs/design.md
/// §4.1). Probabilities are turned into log-odds at init(); init() rejects inconsistent values.
struct OccupancyMapConfig {
  float resolution = 0.1f;  ///< voxel edge (m)
  float prob_hit = 0.70f, prob_miss = 0.35f, prob_min = 0.12f, prob_max = 0.97f,
        prob_occupied = 0.80f;
  float min_depth = 0.5f;  ///< closer measurements are dropped entirely
  float max_depth = 5.0f;  ///< deeper measurements -> free-space ray truncated here (camera z)
  /// A pixel with no measurement (raw 0) is unknown: it neither hits nor carves, because on a
  /// real camera 0 mostly means "no valid match" (dark, shiny, edge, too near), not "nothing
  /// there". d > 0: a 0 pixel inside a large no-return region (its kNoReturnCellPixels-square cell
  /// and the 8 around it nearly all 0, as sky or a hall beyond range) carves free space up to
  /// camera depth d (<= max_depth). Default 0: never (docs/occupancy_map.md, "No return").
  float no_return_free_depth = 0.f;
  int pixel_margin = 2, pixel_stride = 2;
  Eigen::Vector3f local_half_extent{5.f, 5.f, 3.f};    ///< only this region around the camera is
                                                       ///< updated (rays are clipped to it)
  std::size_t max_blocks = kMaxMapBlocks;              ///< runtime capacity <= kMaxMapBlocks
  std::size_t max_rays_per_frame = kMaxRaysPerFrame;   ///< work cap, <= kMaxRaysPerFrame
  std::size_t max_voxel_visits_per_frame = 1'000'000;  ///< work cap on DDA steps per frame,
                                                       ///< <= kMaxVoxelVisitsPerFrame
  /// Cast one representative ray per distinct end voxel per frame (the other pixels ending in
  /// the same voxel would carve nearly the same voxels). false casts every sampled pixel.
  bool merge_rays_per_voxel = true;
  /// Early-stop free-space carving: 0 walks every free ray from the camera to its end (exact).
  /// N > 0 walks each ray from its end back towards the camera (rays coarse to fine over the
  /// image) and stops it after N consecutive voxels that an earlier ray of this frame already
  /// marked missed (the near parts of the rays overlap). Approximate: a voxel that only the
  /// stopped part of a ray would cross misses this frame's update. Hits are never affected.
  /// Default 12; why, and what it costs against the exact walk: docs/occupancy_map.md.
  int free_ray_early_stop = 12;
  /// Free-space carving split into this many column strips of the image (tiles), each walked
  /// on its own against its own marks, the marks then merged as a set union and applied once
  /// per voxel. 0 (default): one walk over all rays, today's result. T in 1..kMaxCarveTiles:
  /// the result depends on T but not on `threads` (docs/occupancy_map.md, "Tiled carving").
  /// Needs the local block grid (at most kMaxTileCells cells).
  int carve_tiles = 0;
  /// Threads integrating a frame, the caller included (1..kMaxMapThreads), created once by
  /// init(). More than 1 needs carve_tiles > 0; the map is bit-identical for every value.
  int threads = 1;
  /// SCHED_FIFO priority of the helper threads (1..99); 0 (default): they inherit the policy of
  /// the thread that calls init(). Two threads need a real-time policy on a shared machine.
  int helper_fifo_priority = 0;
  /// Pin helper m (1..threads-1) to CPU helper_first_cpu + m - 1; -1 (default): no pinning.
  int helper_first_cpu = -1;
};

/// Counters of the last integrate() call (work done, work dropped by caps, pool churn).
struct IntegrationStats {
  std::size_t rays = 0;           ///< rays traversed (after merging)
  std::size_t rays_dropped = 0;   ///< rays not (fully) traversed: ray/visit cap or pool full
  std::size_t voxel_visits = 0;   ///< DDA steps
  std::size_t voxel_updates = 0;  ///< updates applied (hits + misses, <= 1 per voxel; a
                                  ///< clamped voxel counts even if its value stays)
  std::size_t blocks_allocated = 0;
  std::size_t blocks_evicted = 0;
  // Added beyond the shared contract:
  std::size_t pixels_sampled = 0;      ///< sampled pixels that produced a ray (hit or free)
  std::size_t rays_merged = 0;         ///< pixels whose ray was merged into another one
  std::size_t hits = 0;                ///< hit updates applied
  std::size_t updates_dropped = 0;     ///< voxel updates lost because no block could be allocated
  std::size_t rays_stopped_early = 0;  ///< free_ray_early_stop: rays stopped before the camera
};

namespace detail {
struct RayWalk;
}

/// The static occupancy map. Single-threaded: integrate() and clear_box() mutate; the const
/// queries may run concurrently with each other but not with a mutation.
class OccupancyMap {
 public:
  using VoxelKey = std::uint64_t;  ///< packed signed integer voxel indices (i, j, k), 21 bits each

  static constexpr int kBlockBits = detail::kBlockBits;
  static constexpr int kBlockEdge = detail::kBlockEdge;  ///< voxels per block edge
  static constexpr std::size_t kBlockVoxels = detail::kBlockVoxels;
  /// Hash table slots: power of two, load <= kMaxMapBlocks / kBlockTableCapacity = 0.5.
  static constexpr std::size_t kBlockTableCapacity = detail::BlockStore::kTableCapacity;
  /// Voxel indices representable in a key: [-kKeyHalfRange, kKeyHalfRange).
  static constexpr std::int32_t kKeyHalfRange = detail::kKeyHalfRange;
  /// Upper bound on DDA steps of one segment query (longer segments are cut there).
  static constexpr std::size_t kMaxSegmentVisits = 1 << 16;
  /// Cells of the per-frame dense block cache over the local region (default region: 3179).
  static constexpr std::size_t kLocalGridCells = 32768;
  /// Log-odds are stored as int16 in units of 1/kLogOddsScale.
  static constexpr float kLogOddsScale = 1000.f;

  OccupancyMap() noexcept;

  OccupancyMap(const OccupancyMap&) = delete;
  OccupancyMap& operator=(const OccupancyMap&) = delete;

  /// Validates `config`, empties the map and (re)starts the worker team with config.threads
  /// members. kInvalidArgument (map unchanged) when inconsistent; a thread creation error as
  /// platform::WorkerTeam::start() reports it (map not initialised).
  [[nodiscard]] Status init(const OccupancyMapConfig& config) noexcept;
  /// Cells of the dense per-frame block grid over `config`'s local region (one block margin each
  /// side); tiled carving (carve_tiles > 0) needs at most kMaxTileCells.
  static std::size_t local_grid_cells(const OccupancyMapConfig& config) noexcept;
  /// Tests only: called by each team member (0 = the integrating thread) of every map when it
  /// starts its share of a frame's carving, e.g. to delay one worker. nullptr (default): none.
  using WorkerHook = void (*)(unsigned member);
  static void set_worker_hook(WorkerHook hook) noexcept;

  /// Work a caller hands to integrate() to run on the map's team while it carves, e.g. the
  /// pipeline's detection: run(context, part) for each part in [0, parts), in any order and
  /// possibly at once on different threads. It must not touch the map.
  struct SideTask {
    static constexpr unsigned kMaxParts = 4;
    void (*run)(void* context, unsigned part) noexcept = nullptr;
    void* context = nullptr;
    unsigned parts = 1;  ///< 1..kMaxParts
  };

  /// Integrates one depth frame taken at T_map_camera. On any bad input returns its Status and
  /// changes nothing: kOutOfRange when the camera lies beyond max_abs_translation() (see
  /// check_pose_range()). Never fails for lack of space: far blocks are evicted instead.
  /// `side` (when set) runs each of its parts exactly once if and only if the frame is
  /// accepted: during the tiled carving as tasks the members claim (before the tiles),
  /// otherwise after the map's update on the calling thread. integrate() returns after all
  /// have finished. kInvalidArgument (nothing run or changed) for parts outside 1..kMaxParts.
  [[nodiscard]] Status integrate(const DepthView& depth, const CameraIntrinsics& cam,
                                 const Pose& T_map_camera, Stamp stamp, SideTask side) noexcept;
  [[nodiscard]] Status integrate(const DepthView& depth, const CameraIntrinsics& cam,
                                 const Pose& T_map_camera, Stamp stamp) noexcept {
    return integrate(depth, cam, T_map_camera, stamp, SideTask{});
  }

  /// Runs `task`'s parts on the map's team (the calling thread is one of its members), each
  /// exactly once, and returns when all have finished; without a team (threads 1), in order on
  /// the calling thread. For other work of a frame, outside integrate(); it must not touch the
  /// map. kInvalidArgument (nothing run) without a function or for parts outside 1..kMaxParts.
  [[nodiscard]] Status run_on_team(const SideTask& task) noexcept;

  Occupancy state(const Eigen::Vector3f& p) const noexcept;
  Occupancy state(VoxelKey key) const noexcept;
  float log_odds(const Eigen::Vector3f& p) const noexcept;  ///< 0 when unknown
  bool is_occupied(const Eigen::Vector3f& p) const noexcept;
  /// First occupied voxel on the segment a->b (3-D DDA); fills *hit (voxel centre) when found.
  bool first_occupied_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                 Eigen::Vector3f* hit) const noexcept;
  /// First voxel on the segment a->b that is not observed free (unknown or occupied), with the
  /// same 3-D DDA: fills *hit (voxel centre) and *state when found. Planners and the predictor
  /// use it to tell space seen to be free from space never seen
  /// (src/map/occupancy_map_free_query.cpp). Work: one step per voxel crossed (no block is
  /// skipped), at most kMaxSegmentVisits; a longer segment reports its first unchecked voxel as
  /// unknown.
  bool first_non_free_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                 Eigen::Vector3f* hit, Occupancy* state = nullptr) const noexcept;

  /// Visits occupied voxels whose centre lies inside `box`; examines at most `max_voxels`
  /// (each block position looked up and each voxel read counts one).
  /// f(VoxelKey, const Eigen::Vector3f& centre). Returns the number of voxels visited.
  template <class F>
  std::size_t for_each_occupied_in_box(const Box3& box, std::size_t max_voxels, F&& f) const;
  /// Sets occupied voxels whose centre lies inside `box` to free (clamp minimum), except those
  /// occupied without a break for at least `keep_frames` frames (static structure; pass
  /// kKeepNone to clear all); on_cleared(VoxelKey, centre) for each changed voxel. Same budget
  /// as above. Returns the number of voxels changed.
  template <class F>
  std::size_t clear_box(const Box3& box, std::size_t max_voxels, std::uint64_t keep_frames,
                        F&& on_cleared);
  static constexpr std::uint64_t kKeepNone = ~std::uint64_t{0};
  /// Frames the voxel at p has been occupied without a break (to kSinceTickFrames; ages over
  /// kMaxSinceAgeTicks ticks read as that), 0 when it is not occupied.
  std::uint64_t occupied_frames(const Eigen::Vector3f& p) const noexcept;

  /// Sets one voxel's log-odds (clamped). kCapacityExceeded when its block cannot be allocated.
  [[nodiscard]] Status set_log_odds(const Eigen::Vector3f& p, float log_odds) noexcept;
  VoxelKey key_of(const Eigen::Vector3f& p) const noexcept;  ///< clamps to the key range
  /// Largest |component| (m) of a camera position integrate() accepts: half the key range
  /// (kKeyHalfRange / 2 voxels, 52 km at 0.1 m), so the local region around the camera and every
  /// ray in it stay far inside the key range.
  float max_abs_translation() const noexcept {
    return 0.5f * static_cast<float>(kKeyHalfRange) * resolution_;
  }
  /// kOk for a camera pose integrate() can represent; kNonFinite for NaN/inf; kOutOfRange for a
  /// finite translation beyond max_abs_translation() on some axis.
  [[nodiscard]] Status check_pose_range(const Pose& T_map_camera) const noexcept {
    if (!T_map_camera.translation.allFinite()) return Status::kNonFinite;
    if ((T_map_camera.translation.array().abs() > max_abs_translation()).any()) {
      return Status::kOutOfRange;
    }
    return Status::kOk;
  }
  Eigen::Vector3f center_of(VoxelKey key) const noexcept;
  float resolution() const noexcept { return resolution_; }
  float occupied_log_odds() const noexcept { return dequantize(q_occupied_); }  ///< threshold
  /// Whole footprint of the object (pool, table, scratch): sizeof, independent of contents.
  std::size_t memory_bytes() const noexcept { return sizeof(*this); }
  const IntegrationStats& last_stats() const noexcept { return stats_; }
  /// Hash of all allocated blocks' voxel log-odds (order independent), for "unchanged" tests.
  std::uint64_t checksum() const noexcept;
  /// Whole map, tools only: f(VoxelKey, const Eigen::Vector3f& centre) for each occupied voxel.
  template <class F>
  void for_each_occupied(F&& f) const;
  /// Tests and tools only (O(pool)): f(VoxelKey, bool hit) for each voxel the last integrate()
  /// updated, hit (true) or miss (false).
  template <class F>
  void for_each_updated_last_frame(F&& f) const;

  // Added beyond the shared contract.
  const OccupancyMapConfig& config() const noexcept { return config_; }
  /// Changes the pixel sampling stride between frames (the pipeline's adaptive budget mode
  /// coarsens it under load). kInvalidArgument, and no change, outside 1..kMaxImageWidth.
  [[nodiscard]] Status set_pixel_stride(int stride) noexcept {
    if (stride < 1 || stride > kMaxImageWidth) return Status::kInvalidArgument;
    config_.pixel_stride = stride;
    return Status::kOk;
  }
  bool initialized() const noexcept { return initialized_; }
  std::size_t blocks_in_use() const noexcept { return store_.blocks_in_use(); }
  std::size_t total_blocks_evicted() const noexcept { return store_.total_evicted(); }
  std::uint64_t frames_integrated() const noexcept { return store_.frames(); }

 private:
  void reset_storage() noexcept;  // empties the block store and the counters
  using Voxel = detail::Voxel;
  using Block = detail::Block;
  using IndexVec = detail::IndexVec;
  static constexpr std::int16_t kUnknown = detail::kUnknownLogOdds;
  static constexpr std::uint16_t kQueued = detail::kStampQueued;
  static constexpr std::uint16_t kHit = detail::kStampHit;
  static constexpr std::uint16_t kMiss = detail::kStampMiss;
  static constexpr std::uint64_t kSinceTickFrames = detail::BlockStore::kSinceTickFrames;
  static constexpr std::uint16_t kMaxSinceAgeTicks = detail::BlockStore::kMaxSinceAgeTicks;
  std::uint16_t since_tick() const noexcept { return store_.since_tick(); }
  static_assert(kMaxMapBlocks < 65535, "local_grid_ stores slot + 1 as uint16");

  static float dequantize(std::int32_t q) noexcept { return static_cast<float>(q) / kLogOddsScale; }
  static std::uint64_t pack(std::int32_t i, std::int32_t j, std::int32_t k) noexcept {
    return detail::pack_key(i, j, k);
  }
  static IndexVec unpack(std::uint64_t key) noexcept { return detail::unpack_key(key); }
  static std::size_t local_index(std::int32_t i, std::int32_t j, std::int32_t k) noexcept {
    return detail::local_index(i, j, k);
  }
  bool index_of(const Eigen::Vector3f& p, IndexVec& idx) const noexcept;  ///< false if outside
  const Block* find_block(std::int32_t bi, std::int32_t bj, std::int32_t bk) const noexcept {
    return store_.find(bi, bj, bk);
  }
  const Voxel* find_voxel(const IndexVec& idx) const noexcept;
  Occupancy classify(std::int16_t q) const noexcept {
    if (q == kUnknown) return Occupancy::kUnknown;
    if (q > q_occupied_) return Occupancy::kOccupied;
    // Free needs the evidence to say more likely empty than not (p < 0.5, as OctoMap's
    // threshold); between 0.5 and prob_occupied it is undecided, which is not free.
    return q < 0 ? Occupancy::kFree : Occupancy::kUnknown;
  }
  Eigen::Vector3f center_of(const IndexVec& idx) const noexcept {
    return {(static_cast<float>(idx[0]) + 0.5f) * resolution_,
            (static_cast<float>(idx[1]) + 0.5f) * resolution_,
            (static_cast<float>(idx[2]) + 0.5f) * resolution_};
  }
  /// Voxel index range [lo, hi] of the voxels whose centres lie in `box`; false if empty.
  bool box_range(const Box3& box, IndexVec& lo, IndexVec& hi) const noexcept;
  template <class Visit>
  std::size_t scan_box(const Box3& box, std::size_t max_voxels, Visit&& visit) const;

  // Integration internals (src/map/occupancy_map.cpp).
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
  // A ray's end point and end voxel (clipped to the local region). Pass 2 calls this; pass 1
  // does the same float operations four pixels at a time, so both agree bit for bit.
  bool end_point(std::uint16_t raw, bool zero_carves, const Eigen::Array4f& dir,
                 Eigen::Array4f& end, IndexVec& idx, bool& is_hit) const noexcept;
  Eigen::Array4f row_direction(int v) const noexcept {
    return ((static_cast<float>(v) - cy_) * inv_fy_) * down_dir_ + forward_dir_;
  }
  void set_frame_geometry(const CameraIntrinsics& cam, const Pose& T_map_camera) noexcept;
  // Pass 1 (end points), src/map/occupancy_map.cpp "Integration".
  struct EndPointConstants;
  EndPointConstants end_point_constants() const noexcept;
  /// End voxels of four sampled pixels: classes as 0/1 lanes, block indices relative to
  /// key_base_ >> kBlockBits, voxel index inside the block.
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
  /// no_return_free_depth: finds this frame's cells whose 0 pixels carve (no_return_carves_).
  void find_no_return_regions(const DepthView& depth) noexcept;
  /// The carve flags of row v's cells, or nullptr when no 0 pixel of the frame carves.
  const std::uint8_t* no_return_row(int v) const noexcept {
    return no_return_any_ ? &no_return_carves_[static_cast<std::size_t>(v / kNoReturnCellPixels) *
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
  void mark_end_points_in_team(const DepthView& depth) noexcept;
  struct EndCodeSink;
  void compute_end_codes(std::size_t chunk) noexcept;
  void acquire_end_blocks() noexcept;
  void mark_end_codes(unsigned member, std::size_t samples) noexcept;
  // Pass 2 (free space), src/map/occupancy_map.cpp "Carving".
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
    std::array<std::uint8_t, kMaxTileCells> nonempty;      ///< mark set holds a mark
    std::size_t cell_count;
    std::size_t ray_begin, ray_end;  ///< its rays in ordered_rays_
    CarveCounters counters;
  };
  template <bool kEarlyStop>
  struct SequentialCursor;
  template <bool kEarlyStop>
  struct TileCursor;
  std::size_t order_rays(int tiles, bool by_level) noexcept;
  void list_tile_rays(std::size_t tile) noexcept;
  void order_tile_claims() noexcept;
  bool start_ray(std::uint32_t pixel, const DepthView& depth, const IndexVec& camera, bool from_end,
                 detail::RayWalk& w) const noexcept;
  template <bool kEarlyStop, class Cursor>
  void carve_rays(std::size_t begin, std::size_t end, const DepthView& depth,
                  const IndexVec& camera, Cursor& cursor, CarveCounters& k) const noexcept;
  template <bool kEarlyStop>
  void carve_free_space(const DepthView& depth) noexcept;
  template <bool kEarlyStop>
  void carve_tile(std::size_t tile, const DepthView& depth) noexcept;
  void carve_tiles_in_team(const DepthView& depth) noexcept;
  std::size_t collect_tile_marks() noexcept;
  void apply_tile_marks(unsigned member) noexcept;

  // --- configuration (derived at init) ---
  OccupancyMapConfig config_{};
  float resolution_ = 0.1f;
  float inv_resolution_ = 10.f;
  std::int16_t q_hit_ = 0, q_miss_ = 0, q_min_ = 0, q_max_ = 0, q_occupied_ = 0;
  bool initialized_ = false;

  // --- map state ---
  detail::BlockStore store_;
  Stamp last_stamp_ = 0;

  // --- per-frame scratch (inline, reused) ---
  std::array<std::uint32_t, kMaxRaysPerFrame> rays_{};  ///< pixel index (v * width + u)
  std::size_t ray_count_ = 0;
  /// rays_ in carving order: by tile, then coarse-to-fine level, then pixel order.
  std::array<std::uint32_t, kMaxRaysPerFrame> ordered_rays_{};

  // --- tiled carving (carve_tiles > 0) ---
  platform::WorkerTeam team_{};
  int team_fifo_priority_ = 0, team_first_cpu_ = -1;  ///< the options team_ was started with
  const DepthView* team_depth_ = nullptr;  ///< the frame being carved, for the team's task
  SideTask side_task_{};                   ///< integrate()'s side task, claimed before the tiles
  std::atomic<std::uint32_t> next_tile_{0};
  std::array<TileScratch, kMaxCarveTiles> tiles_{};
  /// Tiles in the order the members claim them: most voxel visits in the last frame first.
  std::array<std::uint8_t, kMaxCarveTiles> tile_order_{};
  /// Pass 1 ran on the team: each tile lists and orders its own rays from end_kept_.
  bool tiles_list_rays_ = false;
  /// Cells with a mark of any tile, in the fixed collection order, and their blocks (nullptr:
  /// pool full); the members take the union of the tiles' marks of their share of them.
  std::array<std::uint16_t, kMaxTileCells> merged_cell_{};
  std::array<Block*, kMaxTileCells> merged_block_{};
  std::array<std::uint64_t, kMaxTileCells / 64> merged_seen_{};  ///< cells collected
  /// Pass 1 on the team: cells whose block could not be acquired this frame (not retried).
  std::array<std::uint64_t, kMaxTileCells / 64> acquire_failed_{};
  std::size_t merged_count_ = 0;
  /// Per team member: misses applied and updates dropped by apply_tile_marks().
  std::array<std::array<std::size_t, 2>, platform::WorkerTeam::kMaxMembers> member_updates_{};
  /// Pass 1 on the team: per sampled pixel (row-major), its end voxel as
  /// cell << 10 | hit << 9 | index in block (or a skip code), and whether its ray is listed.
  std::array<std::uint32_t, kMaxRaysPerFrame> end_codes_{};
  std::array<std::uint8_t, kMaxRaysPerFrame> end_kept_{};
  std::size_t team_samples_ = 0;
  static constexpr std::size_t kMembers = platform::WorkerTeam::kMaxMembers;
  /// Pass 1's rows are split into kCodeChunks fixed chunks, claimed by the members one at a
  /// time (a late member only computes fewer of them).
  static constexpr std::size_t kCodeChunks = 16;
  std::atomic<std::uint32_t> next_chunk_{0};
  /// Pass 1's codes bucketed by owner (cell % members): owner_samples_[o] holds, from
  /// chunk_first_[c] on, the owner_counts_[c][o] sample indices of chunk c's rows that end in a
  /// cell of o, in pixel order; so each owner reads only its own.
  std::array<std::array<std::uint32_t, kMaxRaysPerFrame>, kMembers> owner_samples_{};
  std::array<std::array<std::uint32_t, kMembers>, kCodeChunks> owner_counts_{};
  std::array<std::size_t, kCodeChunks> chunk_first_{};
  /// Per chunk: the cells its rows end in, in order of first appearance (so the blocks are
  /// acquired in pixel order of first appearance), and the set of them.
  std::array<std::array<std::uint16_t, kMaxTileCells>, kCodeChunks> chunk_cells_{};
  std::array<std::size_t, kCodeChunks> chunk_cell_count_{};
  std::array<std::array<std::uint64_t, kMaxTileCells / 64>, kCodeChunks> chunk_seen_{};
  std::array<EndMarkCounters, platform::WorkerTeam::kMaxMembers> member_marks_{};
  Block empty_block_{};  ///< stamps 0: what a walk reads in a cell without a block
  // Ray geometry as 4-lane arrays (lane 3 = 0) so the per-pixel maths is one SIMD operation.
  std::array<Eigen::Array4f, kMaxImageWidth> column_dir_{};  ///< R * ((u-cx)/fx, 0, 0)
  /// column_dir_ of the sampled columns (margin + k * stride), one array per axis, so pass 1
  /// loads 4 pixels' directions per axis at once; padded to whole packets.
  std::array<float, kMaxImageWidth + 4> sampled_dir_x_{}, sampled_dir_y_{}, sampled_dir_z_{};
  int sampled_columns_ = 0;
  /// Per image cell: 1 where 0 pixels carve free space this frame (no_return_free_depth > 0).
  std::array<std::uint8_t, kNoReturnCellsX * kNoReturnCellsY> no_return_carves_{};
  bool no_return_any_ = false;
  /// Raw depths 1 .. hit_raw_end_ - 1 are hits (depth <= max_depth); below near_raw_end_ they
  /// are closer than min_depth (end_point()'s float tests, as integer ranges of the raw value).
  std::uint32_t hit_raw_end_ = 0, near_raw_end_ = 0;
  /// Pass 1 names blocks by an int key of block indices relative to key_base_ (voxel index of
  /// the camera's block less 2^(kKeyBlockBits-1) blocks per axis; the local region is at most
  /// 1000 voxels = 125 blocks each side of the camera, init() checks it).
  static constexpr int kKeyBlockBits = 9;
  std::array<std::int32_t, 3> key_base_{};
  /// Pool slot + 1 of each block of the local region resolved this frame (0: not yet).
  std::array<std::uint16_t, kLocalGridCells> local_grid_{};
  std::array<std::int32_t, 3> grid_origin_{}, grid_dim_{};
  /// Stands in for a block the walk could not allocate (pool full): its stamps are set to this
  /// frame's miss stamp when first needed, so visits there change nothing.
  Block sink_{};
  std::uint16_t sink_tag_ = 0;  ///< frame tag the sink's stamps were set for (0: none)
  std::size_t grid_cells_ = 0;
  bool grid_enabled_ = false;
  Eigen::Vector3f origin_ = Eigen::Vector3f::Zero();
  Eigen::Array4f origin4_ = Eigen::Array4f::Zero();       ///< origin_, lane 3 = 0
  Eigen::Array4f half_extent4_ = Eigen::Array4f::Zero();  ///< local region, lane 3 = inf
  Eigen::Array4f down_dir_ = Eigen::Array4f::Zero();      ///< R.col(1)
  Eigen::Array4f forward_dir_ = Eigen::Array4f::Zero();   ///< R.col(2)
  Eigen::Vector3f box_min_ = Eigen::Vector3f::Zero(), box_max_ = Eigen::Vector3f::Zero();
  const CameraIntrinsics* cam_ = nullptr;
  float depth_scale_ = 0.f, cy_ = 0.f, inv_fy_ = 0.f;
  IntegrationStats stats_{};
};

// ---------------------------------------------------------------------------------------------
// Template members.

template <class Visit>
std::size_t OccupancyMap::scan_box(const Box3& box, std::size_t max_voxels, Visit&& visit) const {
  IndexVec lo{}, hi{};
  if (!initialized_ || !box_range(box, lo, hi)) return 0;
  std::size_t examined = 0;
  std::size_t visited = 0;
  const std::int32_t b_lo[3] = {lo[0] >> kBlockBits, lo[1] >> kBlockBits, lo[2] >> kBlockBits};
  const std::int32_t b_hi[3] = {hi[0] >> kBlockBits, hi[1] >> kBlockBits, hi[2] >> kBlockBits};
  for (std::int32_t bk = b_lo[2]; bk <= b_hi[2]; ++bk) {
    for (std::int32_t bj = b_lo[1]; bj <= b_hi[1]; ++bj) {
      for (std::int32_t bi = b_lo[0]; bi <= b_hi[0]; ++bi) {
        if (examined >= max_voxels) return visited;
        ++examined;
        const Block* block = find_block(bi, bj, bk);
        if (block == nullptr) continue;
        const std::int32_t i0 = std::max(lo[0], bi * kBlockEdge);
        const std::int32_t i1 = std::min(hi[0], bi * kBlockEdge + kBlockEdge - 1);
        const std::int32_t j0 = std::max(lo[1], bj * kBlockEdge);
        const std::int32_t j1 = std::min(hi[1], bj * kBlockEdge + kBlockEdge - 1);
        const std::int32_t k0 = std::max(lo[2], bk * kBlockEdge);
        const std::int32_t k1 = std::min(hi[2], bk * kBlockEdge + kBlockEdge - 1);
        for (std::int32_t k = k0; k <= k1; ++k) {
          for (std::int32_t j = j0; j <= j1; ++j) {
            for (std::int32_t i = i0; i <= i1; ++i) {
              if (examined >= max_voxels) return visited;
              ++examined;
              const std::size_t li = local_index(i, j, k);
              if (classify(block->voxels[li].log_odds) != Occupancy::kOccupied) continue;
              if (visit(block, li, IndexVec{i, j, k})) ++visited;
            }
          }
        }
      }
    }
  }
  return visited;
}

template <class F>
std::size_t OccupancyMap::for_each_occupied_in_box(const Box3& box, std::size_t max_voxels,
                                                   F&& f) const {
  return scan_box(box, max_voxels, [&](const Block*, std::size_t, const IndexVec& idx) {
    const Eigen::Vector3f c = center_of(idx);
    f(pack(idx[0], idx[1], idx[2]), c);
    return true;
  });
}

template <class F>
std::size_t OccupancyMap::clear_box(const Box3& box, std::size_t max_voxels,
                                    std::uint64_t keep_frames, F&& on_cleared) {
  const std::uint16_t now = since_tick();
  const std::uint64_t keep_ticks =
      keep_frames == kKeepNone ? kKeepNone : keep_frames / kSinceTickFrames;
  return scan_box(box, max_voxels, [&](const Block* block, std::size_t li, const IndexVec& idx) {
    const auto age = static_cast<std::uint16_t>(now - block->occupied_since[li]);
    if (age >= keep_ticks) return false;  // static structure: kept
    // scan_box is const; the block lives in our own pool, so writing through it is sound.
    Block* mutable_block = &store_.block(store_.slot_of(block));
    mutable_block->voxels[li].log_odds = q_min_;  // q_min_ <= q_occupied_ (init checks it)
    --mutable_block->occupied;
    const Eigen::Vector3f c = center_of(idx);
    on_cleared(pack(idx[0], idx[1], idx[2]), c);
    return true;
  });
}

template <class F>
void OccupancyMap::for_each_occupied(F&& f) const {
  if (!initialized_) return;
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    if (!store_.used(s)) continue;
    const Block& b = store_.block(s);
    for (std::int32_t k = 0; k < kBlockEdge; ++k) {
      for (std::int32_t j = 0; j < kBlockEdge; ++j) {
        for (std::int32_t i = 0; i < kBlockEdge; ++i) {
          const std::size_t li = local_index(i, j, k);
          if (classify(b.voxels[li].log_odds) != Occupancy::kOccupied) continue;
          const IndexVec idx{b.index[0] * kBlockEdge + i, b.index[1] * kBlockEdge + j,
                             b.index[2] * kBlockEdge + k};
          const Eigen::Vector3f c = center_of(idx);
          f(pack(idx[0], idx[1], idx[2]), c);
        }
      }
    }
  }
}

template <class F>
void OccupancyMap::for_each_updated_last_frame(F&& f) const {
  if (!initialized_ || store_.frames() == 0) return;
  const std::uint16_t hit_stamp = store_.stamp(kHit);
  const std::uint16_t miss_stamp = store_.stamp(kMiss);
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    if (!store_.used(s)) continue;
    const Block& b = store_.block(s);
    for (std::size_t li = 0; li < kBlockVoxels; ++li) {
      const std::uint16_t stamp = b.voxels[li].stamp;
      if (stamp != hit_stamp && stamp != miss_stamp) continue;
      const auto i = static_cast<std::int32_t>(li & (kBlockEdge - 1));
      const auto j = static_cast<std::int32_t>((li >> kBlockBits) & (kBlockEdge - 1));
      const auto k = static_cast<std::int32_t>(li >> (2 * kBlockBits));
      f(pack(b.index[0] * kBlockEdge + i, b.index[1] * kBlockEdge + j, b.index[2] * kBlockEdge + k),
        stamp == hit_stamp);
    }
  }
}

}  // namespace dynamap
