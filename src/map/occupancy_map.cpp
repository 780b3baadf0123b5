#include "dynamap/map/occupancy_map.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>

#include "dynamap/map/map_params.hpp"
#include "segment_walk.hpp"

namespace dynamap {
namespace {

inline std::int16_t quantize(float log_odds) noexcept {
  return static_cast<std::int16_t>(std::lround(log_odds * OccupancyMap::kLogOddsScale));
}

inline float logit(float p) noexcept {
  return std::log(p / (1.f - p));
}

inline std::uint64_t mix64(std::uint64_t x) noexcept {
  return IntegerHash{}(x);
}

inline bool finite_positive(float x) noexcept {
  return std::isfinite(x) && x > 0.f;
}

}  // namespace

OccupancyMap::OccupancyMap() noexcept = default;

namespace {

// Every rule init() applies to a configuration on its own: the ranges of params::kOccupancyMap,
// then the relations between fields (PipelineConfig's validate() names them).
bool config_valid(const OccupancyMapConfig& c) noexcept {
  if (!all_in_range(c, params::kOccupancyMap)) return false;
  if (!(c.prob_min < c.prob_miss && c.prob_hit < c.prob_max && c.prob_min <= c.prob_occupied &&
        c.prob_occupied < c.prob_max)) {
    return false;
  }
  // The clamp range must fit int16 next to the kUnknown sentinel.
  if (std::fabs(logit(c.prob_min)) > 30.f || std::fabs(logit(c.prob_max)) > 30.f) {
    return false;
  }
  if (c.max_depth <= c.min_depth || c.no_return_free_depth > c.max_depth) return false;
  for (int a = 0; a < 3; ++a) {
    // Half extents up to 1000 voxels keep the whole local region far inside the key range.
    if (c.local_half_extent[a] > 1000.f * c.resolution) return false;
  }
  return true;
}

// Blocks per axis of the dense per-frame grid over the local region, +1 block margin each side.
std::array<std::int32_t, 3> local_grid_dims(const OccupancyMapConfig& c) noexcept {
  std::array<std::int32_t, 3> dim{};
  for (int a = 0; a < 3; ++a) {
    const float blocks =
        c.local_half_extent[a] / (static_cast<float>(OccupancyMap::kBlockEdge) * c.resolution);
    dim[static_cast<std::size_t>(a)] = 2 * static_cast<std::int32_t>(std::ceil(blocks)) + 3;
  }
  return dim;
}

}  // namespace

std::size_t OccupancyMap::local_grid_cells(const OccupancyMapConfig& c) noexcept {
  std::size_t cells = 1;
  for (const std::int32_t d : local_grid_dims(c)) cells *= static_cast<std::size_t>(d);
  return cells;
}

Status OccupancyMap::init(const OccupancyMapConfig& c) noexcept {
  if (!config_valid(c)) return Status::kInvalidArgument;
  // Dense per-frame block cache over the local region; disabled (hash lookups only) when the
  // region is too large for kLocalGridCells.
  const std::array<std::int32_t, 3> grid_dim = local_grid_dims(c);
  const std::size_t cells = local_grid_cells(c);
  if (c.carve_tiles > 0 && cells > kMaxTileCells) return Status::kInvalidArgument;
  if (integrator_.frame_open()) return Status::kInvalidArgument;  // end_integration() first

  params_.config = c;
  params_.resolution = c.resolution;
  params_.inv_resolution = 1.f / c.resolution;
  params_.q_hit = quantize(logit(c.prob_hit));
  params_.q_miss = quantize(logit(c.prob_miss));
  params_.q_min = quantize(logit(c.prob_min));
  params_.q_max = quantize(logit(c.prob_max));
  params_.q_occupied = quantize(logit(c.prob_occupied));

  integrator_.reset(grid_dim, cells);
  reset_storage();
  initialized_ = true;
  return Status::kOk;
}

void OccupancyMap::reset_storage() noexcept {
  store_.reset(params_.config.max_blocks, params_.resolution);
  last_stamp_ = 0;
}

// ---------------------------------------------------------------------------------------------
// Keys and lookups.

bool OccupancyMap::index_of(const Eigen::Vector3f& p, IndexVec& idx) const noexcept {
  return detail::voxel_index(p, params_.inv_resolution, idx);
}

OccupancyMap::VoxelKey OccupancyMap::key_of(const Eigen::Vector3f& p) const noexcept {
  IndexVec idx{};
  for (int a = 0; a < 3; ++a) {
    const float x = p[a] * params_.inv_resolution;
    std::int32_t i = 0;
    if (std::isnan(x)) {
      i = 0;
    } else if (x < -static_cast<float>(kKeyHalfRange)) {
      i = -kKeyHalfRange;
    } else if (x >= static_cast<float>(kKeyHalfRange - 1)) {
      i = kKeyHalfRange - 1;
    } else {
      i = detail::fast_floor(x);
    }
    idx[static_cast<std::size_t>(a)] = i;
  }
  return pack(idx[0], idx[1], idx[2]);
}

Eigen::Vector3f OccupancyMap::center_of(VoxelKey key) const noexcept {
  return center_of(unpack(key));
}

const OccupancyMap::Voxel* OccupancyMap::find_voxel(const IndexVec& idx) const noexcept {
  const Block* b = find_block(idx[0] >> kBlockBits, idx[1] >> kBlockBits, idx[2] >> kBlockBits);
  return b == nullptr ? nullptr : &b->voxels[local_index(idx[0], idx[1], idx[2])];
}

Occupancy OccupancyMap::state(const Eigen::Vector3f& p) const noexcept {
  IndexVec idx{};
  if (!initialized_ || !index_of(p, idx)) return Occupancy::kUnknown;
  const Voxel* v = find_voxel(idx);
  return v == nullptr ? Occupancy::kUnknown : classify(v->log_odds);
}

Occupancy OccupancyMap::state(VoxelKey key) const noexcept {
  if (!initialized_) return Occupancy::kUnknown;
  const Voxel* v = find_voxel(unpack(key));
  return v == nullptr ? Occupancy::kUnknown : classify(v->log_odds);
}

float OccupancyMap::log_odds(const Eigen::Vector3f& p) const noexcept {
  IndexVec idx{};
  if (!initialized_ || !index_of(p, idx)) return 0.f;
  const Voxel* v = find_voxel(idx);
  if (v == nullptr || v->log_odds == kUnknown) return 0.f;
  return dequantize(v->log_odds);
}

std::uint64_t OccupancyMap::occupied_frames(const Eigen::Vector3f& p) const noexcept {
  IndexVec idx{};
  if (!initialized_ || !index_of(p, idx)) return 0;
  const Block* b = find_block(idx[0] >> kBlockBits, idx[1] >> kBlockBits, idx[2] >> kBlockBits);
  if (b == nullptr) return 0;
  const std::size_t li = local_index(idx[0], idx[1], idx[2]);
  if (classify(b->voxels[li].log_odds) != Occupancy::kOccupied) return 0;
  const auto age = static_cast<std::uint16_t>(since_tick() - b->occupied_since[li]);
  return std::uint64_t{std::min(age, kMaxSinceAgeTicks)} * kSinceTickFrames;
}

bool OccupancyMap::is_occupied(const Eigen::Vector3f& p) const noexcept {
  return state(p) == Occupancy::kOccupied;
}

bool OccupancyMap::box_range(const Box3& box, IndexVec& lo, IndexVec& hi) const noexcept {
  if (!box.min.allFinite() || !box.max.allFinite()) return false;
  constexpr float kLimit = static_cast<float>(kKeyHalfRange);
  for (int a = 0; a < 3; ++a) {
    // Voxel i has its centre inside [min, max] iff min/res - 0.5 <= i <= max/res - 0.5.
    const float l = std::max(std::ceil(box.min[a] * params_.inv_resolution - 0.5f), -kLimit);
    const float h = std::min(std::floor(box.max[a] * params_.inv_resolution - 0.5f), kLimit - 1.f);
    if (l > h) return false;
    lo[static_cast<std::size_t>(a)] = static_cast<std::int32_t>(l);
    hi[static_cast<std::size_t>(a)] = static_cast<std::int32_t>(h);
  }
  return true;
}

bool OccupancyMap::first_occupied_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                             Eigen::Vector3f* hit) const noexcept {
  // Amanatides-Woo walk. Within a block that holds occupied voxels it goes voxel by voxel; a
  // missing block or one without occupied voxels is crossed in one go: each axis's t sequence
  // (t_max, t_max + t_delta, ...) does not depend on the other axes, and the walk visits the
  // merged sequence in (t, axis) order, so the step that leaves the block is the axis whose
  // boundary-crossing t is smallest (ties to the lower axis, as in the voxel walk). The same
  // float additions are made in the same order, so the result is exactly the voxel walk's.
  IndexVec idx{}, end{};
  if (!initialized_ || !index_of(a, idx) || !index_of(b, end)) return false;
  detail::SegmentWalk w = detail::start_segment_walk(a, b, idx, end, params_.resolution);
  constexpr std::int32_t kMask = kBlockEdge - 1;
  std::size_t n = 0;  // voxels visited so far (cap kMaxSegmentVisits, as for the voxel walk)
  while (n < kMaxSegmentVisits) {
    const Block* block =
        find_block(idx[0] >> kBlockBits, idx[1] >> kBlockBits, idx[2] >> kBlockBits);
    // Steps each axis can make before it leaves the block.
    std::int32_t inside[3];
    for (std::size_t ax = 0; ax < 3; ++ax) {
      const std::int32_t local = idx[ax] & kMask;
      inside[ax] = w.step[ax] > 0 ? kMask - local : local;
    }
    if (block == nullptr || block->occupied == 0) {
      if (!w.cross_block(idx, inside, n, kMaxSegmentVisits)) return false;
      continue;
    }
    // Voxel walk inside a block with occupied voxels, until the walk leaves it.
    for (;;) {
      if (classify(block->voxels[local_index(idx[0], idx[1], idx[2])].log_odds) ==
          Occupancy::kOccupied) {
        if (hit != nullptr) *hit = center_of(idx);
        return true;
      }
      if (w.remaining[0] + w.remaining[1] + w.remaining[2] == 0) return false;
      const std::size_t ax = w.advance(idx);
      if (++n >= kMaxSegmentVisits) return false;
      if (inside[ax]-- == 0) break;  // crossed into the next block
    }
  }
  return false;
}

std::uint64_t OccupancyMap::checksum() const noexcept {
  std::uint64_t sum = 0;
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    if (!store_.used(s)) continue;
    std::uint64_t h = mix64(store_.key(s));
    for (const Voxel& v : store_.block(s).voxels) {
      h = mix64(h ^ static_cast<std::uint16_t>(v.log_odds));
    }
    sum += mix64(h);  // a sum of per-block hashes does not depend on the pool layout
  }
  return sum;
}

Status OccupancyMap::set_log_odds(const Eigen::Vector3f& p, float value) noexcept {
  if (!initialized_) return Status::kNotInitialized;
  if (!p.allFinite() || !std::isfinite(value)) return Status::kNonFinite;
  IndexVec idx{};
  if (!index_of(p, idx)) return Status::kInvalidArgument;
  const std::int32_t bi = idx[0] >> kBlockBits, bj = idx[1] >> kBlockBits,
                     bk = idx[2] >> kBlockBits;
  Block* b = store_.find(bi, bj, bk);
  if (b == nullptr) {
    b = store_.allocate(bi, bj, bk);
    if (b == nullptr) return Status::kCapacityExceeded;
    integrator_.count_allocated_block();
  }
  const float q = std::clamp(value * kLogOddsScale, static_cast<float>(params_.q_min),
                             static_cast<float>(params_.q_max));
  Voxel& v = b->voxels[local_index(idx[0], idx[1], idx[2])];
  const auto updated = static_cast<std::int16_t>(std::lround(q));
  b->occupied = static_cast<std::uint16_t>(b->occupied + (updated > params_.q_occupied) -
                                           (v.log_odds > params_.q_occupied));
  if (updated > params_.q_occupied && v.log_odds <= params_.q_occupied) {
    b->occupied_since[local_index(idx[0], idx[1], idx[2])] = since_tick();
  }
  v.log_odds = updated;
  return Status::kOk;
}

// ---------------------------------------------------------------------------------------------
// Integration: the input is checked here; the integrator does the work.

Status OccupancyMap::integrate(const DepthView& depth, const CameraIntrinsics& cam,
                               const Pose& T_map_camera, Stamp stamp, TaskTeam* team) noexcept {
  SoloTeam solo;
  TaskTeam& t = team != nullptr ? *team : solo;
  const Status s = begin_integration(depth, cam, T_map_camera, stamp, t);
  if (!ok(s)) return s;
  t.run([](void* map, unsigned member) { static_cast<OccupancyMap*>(map)->carve_share(member); },
        this);
  end_integration();
  return Status::kOk;
}

Status OccupancyMap::begin_integration(const DepthView& depth, const CameraIntrinsics& cam,
                                       const Pose& T_map_camera, Stamp stamp,
                                       TaskTeam& team) noexcept {
  if (!initialized_) return Status::kNotInitialized;
  if (integrator_.frame_open()) return Status::kInvalidArgument;
  if (const Status s = validate_depth(depth, cam); !ok(s)) return s;
  if (cam.width > kMaxImageWidth || cam.height > kMaxImageHeight) return Status::kWrongSize;
  if (!finite_positive(cam.fx) || !finite_positive(cam.fy) || !std::isfinite(cam.cx) ||
      !std::isfinite(cam.cy) || !finite_positive(cam.depth_scale)) {
    return Status::kInvalidArgument;
  }
  if (const Status s = validate_pose(T_map_camera); !ok(s)) return s;
  // Keep the local region well inside the key range.
  if (const Status s = check_pose_range(T_map_camera); !ok(s)) return s;
  if (store_.frames() > 0 && stamp <= last_stamp_) return Status::kTimeNotIncreasing;
  // Input accepted: from here on the frame always completes.
  last_stamp_ = stamp;
  integrator_.begin(depth, cam, T_map_camera, team);
  return Status::kOk;
}

}  // namespace dynamap
