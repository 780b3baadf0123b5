#include "dynamap/occupancy_map.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "segment_walk.hpp"

namespace dynamap {
namespace {

/// Eviction passes allowed per frame; each frees a batch of far blocks (bounded O(pool) work).
constexpr std::size_t kMaxEvictionPassesPerFrame = 8;
/// Stamps per frame tag: 4 * tag + {kQueued, kHit, kMiss} (occupancy_map.hpp); 4 * 16383 + 3
/// fits in uint16.
constexpr std::uint16_t kMaxFrameTag = 16383;

inline std::int32_t fast_floor(float x) noexcept {
  const auto i = static_cast<std::int32_t>(x);
  return i - static_cast<std::int32_t>(x < static_cast<float>(i));
}

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

Status OccupancyMap::init(const OccupancyMapConfig& c) noexcept {
  const auto prob_ok = [](float p) { return std::isfinite(p) && p > 0.f && p < 1.f; };
  if (!prob_ok(c.prob_hit) || !prob_ok(c.prob_miss) || !prob_ok(c.prob_min) ||
      !prob_ok(c.prob_max) || !prob_ok(c.prob_occupied)) {
    return Status::kInvalidArgument;
  }
  if (!(c.prob_min < c.prob_miss && c.prob_miss < 0.5f && 0.5f < c.prob_hit &&
        c.prob_hit < c.prob_max && c.prob_min <= c.prob_occupied && c.prob_occupied < c.prob_max)) {
    return Status::kInvalidArgument;
  }
  // The clamp range must fit int16 next to the kUnknown sentinel.
  if (std::fabs(logit(c.prob_min)) > 30.f || std::fabs(logit(c.prob_max)) > 30.f) {
    return Status::kInvalidArgument;
  }
  if (!std::isfinite(c.resolution) || c.resolution < 0.01f || c.resolution > 10.f) {
    return Status::kInvalidArgument;
  }
  if (!std::isfinite(c.min_depth) || c.min_depth < 0.f || !finite_positive(c.max_depth) ||
      c.max_depth <= c.min_depth) {
    return Status::kInvalidArgument;
  }
  if (c.pixel_margin < 0 || c.pixel_stride < 1 || c.pixel_stride > kMaxImageWidth) {
    return Status::kInvalidArgument;
  }
  for (int a = 0; a < 3; ++a) {
    // Half extents up to 1000 voxels keep the whole local region far inside the key range.
    if (!finite_positive(c.local_half_extent[a]) ||
        c.local_half_extent[a] > 1000.f * c.resolution) {
      return Status::kInvalidArgument;
    }
  }
  if (c.max_blocks < 1 || c.max_blocks > kMaxMapBlocks || c.max_rays_per_frame < 1 ||
      c.max_rays_per_frame > kMaxRaysPerFrame || c.max_voxel_visits_per_frame < 1 ||
      c.max_voxel_visits_per_frame > kMaxVoxelVisitsPerFrame) {
    return Status::kInvalidArgument;
  }
  if (c.free_ray_early_stop < 0) return Status::kInvalidArgument;

  config_ = c;
  resolution_ = c.resolution;
  inv_resolution_ = 1.f / c.resolution;
  q_hit_ = quantize(logit(c.prob_hit));
  q_miss_ = quantize(logit(c.prob_miss));
  q_min_ = quantize(logit(c.prob_min));
  q_max_ = quantize(logit(c.prob_max));
  q_occupied_ = quantize(logit(c.prob_occupied));

  // Dense per-frame block cache over the local region (+1 block margin each side); disabled
  // (hash lookups only) when the region is too large for kLocalGridCells.
  std::size_t cells = 1;
  for (int a = 0; a < 3; ++a) {
    const float blocks = c.local_half_extent[a] / (static_cast<float>(kBlockEdge) * c.resolution);
    grid_dim_[static_cast<std::size_t>(a)] = 2 * static_cast<std::int32_t>(std::ceil(blocks)) + 3;
    cells *= static_cast<std::size_t>(grid_dim_[static_cast<std::size_t>(a)]);
  }
  grid_enabled_ = cells <= kLocalGridCells;
  grid_cells_ = grid_enabled_ ? cells : 0;

  table_.clear();
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    free_slots_[s] = static_cast<std::uint32_t>(kMaxMapBlocks - 1 - s);  // pop yields 0, 1, ...
  }
  slot_used_.fill(0);
  free_count_ = kMaxMapBlocks;
  blocks_in_use_ = 0;
  total_blocks_evicted_ = 0;
  frames_ = 0;
  last_stamp_ = 0;
  frame_tag_ = 0;
  sink_tag_ = 0;
  ray_count_ = 0;
  stats_ = IntegrationStats{};
  initialized_ = true;
  return Status::kOk;
}

// ---------------------------------------------------------------------------------------------
// Keys and lookups.

bool OccupancyMap::index_of(const Eigen::Vector3f& p, IndexVec& idx) const noexcept {
  constexpr float kLimit = static_cast<float>(kKeyHalfRange);
  for (int a = 0; a < 3; ++a) {
    const float x = p[a] * inv_resolution_;
    if (!(x >= -kLimit && x < kLimit)) return false;  // also rejects NaN
    idx[static_cast<std::size_t>(a)] = fast_floor(x);
  }
  return idx[0] < kKeyHalfRange && idx[1] < kKeyHalfRange && idx[2] < kKeyHalfRange;
}

OccupancyMap::VoxelKey OccupancyMap::key_of(const Eigen::Vector3f& p) const noexcept {
  IndexVec idx{};
  for (int a = 0; a < 3; ++a) {
    const float x = p[a] * inv_resolution_;
    std::int32_t i = 0;
    if (std::isnan(x)) {
      i = 0;
    } else if (x < -static_cast<float>(kKeyHalfRange)) {
      i = -kKeyHalfRange;
    } else if (x >= static_cast<float>(kKeyHalfRange - 1)) {
      i = kKeyHalfRange - 1;
    } else {
      i = fast_floor(x);
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

bool OccupancyMap::is_occupied(const Eigen::Vector3f& p) const noexcept {
  return state(p) == Occupancy::kOccupied;
}

bool OccupancyMap::box_range(const Box3& box, IndexVec& lo, IndexVec& hi) const noexcept {
  if (!box.min.allFinite() || !box.max.allFinite()) return false;
  constexpr float kLimit = static_cast<float>(kKeyHalfRange);
  for (int a = 0; a < 3; ++a) {
    // Voxel i has its centre inside [min, max] iff min/res - 0.5 <= i <= max/res - 0.5.
    const float l = std::max(std::ceil(box.min[a] * inv_resolution_ - 0.5f), -kLimit);
    const float h = std::min(std::floor(box.max[a] * inv_resolution_ - 0.5f), kLimit - 1.f);
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
  detail::SegmentWalk w = detail::start_segment_walk(a, b, idx, end, resolution_);
  std::int32_t* const step = w.step;
  std::int32_t* const remaining = w.remaining;
  float* const t_max = w.t_max;
  float* const t_delta = w.t_delta;
  constexpr float kInf = std::numeric_limits<float>::infinity();
  constexpr std::int32_t kMask = kBlockEdge - 1;
  std::size_t n = 0;  // voxels visited so far (cap kMaxSegmentVisits, as for the voxel walk)
  while (n < kMaxSegmentVisits) {
    const Block* block =
        find_block(idx[0] >> kBlockBits, idx[1] >> kBlockBits, idx[2] >> kBlockBits);
    // Steps each axis can make before it leaves the block.
    std::int32_t inside[3];
    for (std::size_t ax = 0; ax < 3; ++ax) {
      const std::int32_t local = idx[ax] & kMask;
      inside[ax] = step[ax] > 0 ? kMask - local : local;
    }
    if (block == nullptr || block->occupied == 0) {
      // t of each axis's boundary-crossing step (inf when its steps run out first).
      float cross[3];
      for (std::size_t ax = 0; ax < 3; ++ax) {
        cross[ax] = kInf;
        if (inside[ax] + 1 > remaining[ax]) continue;
        float t = t_max[ax];
        for (std::int32_t s = 0; s < inside[ax]; ++s) t += t_delta[ax];
        cross[ax] = t;
      }
      std::size_t exit_ax = 0;
      if (cross[1] < cross[exit_ax]) exit_ax = 1;
      if (cross[2] < cross[exit_ax]) exit_ax = 2;
      if (cross[exit_ax] == kInf) return false;  // the segment ends inside this block
      const float t_exit = cross[exit_ax];
      std::size_t steps = 0;
      for (std::size_t ax = 0; ax < 3; ++ax) {
        if (ax == exit_ax) continue;
        // Steps of this axis that come before the exit step in (t, axis) order.
        const std::int32_t limit = std::min(inside[ax], remaining[ax]);
        std::int32_t k = 0;
        float t = t_max[ax];
        while (k < limit && (t < t_exit || (t == t_exit && ax < exit_ax))) {
          ++k;
          t = k == remaining[ax] ? kInf : t + t_delta[ax];
        }
        idx[ax] += k * step[ax];
        remaining[ax] -= k;
        t_max[ax] = t;
        steps += static_cast<std::size_t>(k);
      }
      steps += static_cast<std::size_t>(inside[exit_ax]);
      // Visits in this block: the current voxel and one per step inside it.
      if (n + steps + 1 >= kMaxSegmentVisits) return false;
      n += steps + 1;
      const std::int32_t k = inside[exit_ax] + 1;
      idx[exit_ax] += k * step[exit_ax];
      remaining[exit_ax] -= k;
      t_max[exit_ax] = remaining[exit_ax] == 0 ? kInf : t_exit + t_delta[exit_ax];
      continue;
    }
    // Voxel walk inside a block with occupied voxels, until the walk leaves it.
    for (;;) {
      if (classify(block->voxels[local_index(idx[0], idx[1], idx[2])].log_odds) ==
          Occupancy::kOccupied) {
        if (hit != nullptr) *hit = center_of(idx);
        return true;
      }
      if (remaining[0] + remaining[1] + remaining[2] == 0) return false;
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
    if (!slot_used_[s]) continue;
    std::uint64_t h = mix64(slot_key_[s]);
    for (const Voxel& v : pool_[s].voxels) {
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
  Block* b = find_block(bi, bj, bk);
  if (b == nullptr) b = allocate_block(bi, bj, bk);
  if (b == nullptr) return Status::kCapacityExceeded;
  const float q =
      std::clamp(value * kLogOddsScale, static_cast<float>(q_min_), static_cast<float>(q_max_));
  Voxel& v = b->voxels[local_index(idx[0], idx[1], idx[2])];
  const auto updated = static_cast<std::int16_t>(std::lround(q));
  b->occupied = static_cast<std::uint16_t>(b->occupied + (updated > q_occupied_) -
                                           (v.log_odds > q_occupied_));
  v.log_odds = updated;
  return Status::kOk;
}

// ---------------------------------------------------------------------------------------------
// Block pool.

OccupancyMap::Block* OccupancyMap::allocate_block(std::int32_t bi, std::int32_t bj,
                                                  std::int32_t bk) noexcept {
  if (free_count_ == 0 || blocks_in_use_ >= config_.max_blocks) return nullptr;
  const std::uint64_t key = pack(bi, bj, bk);
  const std::uint32_t slot = free_slots_[free_count_ - 1];
  if (!ok(table_.insert_or_assign(key, slot))) return nullptr;  // cannot happen at load <= 0.5
  --free_count_;
  ++blocks_in_use_;
  slot_used_[slot] = 1;
  slot_key_[slot] = key;
  Block& b = pool_[slot];
  b.voxels.fill(Voxel{kUnknown, 0});
  b.index = {bi, bj, bk};
  b.occupied = 0;
  b.last_frame = frames_;
  ++stats_.blocks_allocated;
  return &b;
}

void OccupancyMap::release_block(std::uint32_t slot) noexcept {
  table_.erase(slot_key_[slot]);
  slot_used_[slot] = 0;
  free_slots_[free_count_++] = slot;
  --blocks_in_use_;
}

std::size_t OccupancyMap::evict_far_blocks() noexcept {
  if (evictions_this_frame_ >= kMaxEvictionPassesPerFrame) return 0;
  ++evictions_this_frame_;
  std::size_t n = 0;
  const float half_block = 0.5f * static_cast<float>(kBlockEdge);
  for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
    // Blocks touched this frame stay: they may hold this frame's hits and cached pointers.
    if (!slot_used_[s] || pool_[s].last_frame == frames_) continue;
    const Block& b = pool_[s];
    Eigen::Vector3f c;
    for (int a = 0; a < 3; ++a) {
      c[a] = (static_cast<float>(b.index[static_cast<std::size_t>(a)] * kBlockEdge) + half_block) *
             resolution_;
    }
    eviction_[n++] = EvictionCandidate{(c - origin_).squaredNorm(), static_cast<std::uint32_t>(s)};
  }
  if (n == 0) return 0;
  const std::size_t batch = std::min(n, std::max<std::size_t>(1, config_.max_blocks / 16));
  const auto farther = [](const EvictionCandidate& x, const EvictionCandidate& y) {
    return x.distance_sq > y.distance_sq;
  };
  std::nth_element(eviction_.begin(), eviction_.begin() + static_cast<std::ptrdiff_t>(batch - 1),
                   eviction_.begin() + static_cast<std::ptrdiff_t>(n), farther);
  for (std::size_t e = 0; e < batch; ++e) release_block(eviction_[e].slot);
  stats_.blocks_evicted += batch;
  total_blocks_evicted_ += batch;
  return batch;
}

OccupancyMap::Block* OccupancyMap::acquire_block(std::int32_t bi, std::int32_t bj,
                                                 std::int32_t bk) noexcept {
  Block* b = find_block(bi, bj, bk);
  if (b == nullptr) {
    b = allocate_block(bi, bj, bk);
    if (b == nullptr && evict_far_blocks() > 0) b = allocate_block(bi, bj, bk);
    if (b == nullptr) return nullptr;
  }
  b->last_frame = frames_;
  return b;
}

inline OccupancyMap::LocalGrid OccupancyMap::local_grid() noexcept {
  LocalGrid g{grid_origin_, {}, local_grid_.data()};
  if (grid_enabled_) {
    for (std::size_t a = 0; a < 3; ++a) g.dim[a] = static_cast<std::uint32_t>(grid_dim_[a]);
  }
  return g;
}

inline OccupancyMap::Block* OccupancyMap::local_block(const LocalGrid& g, std::int32_t bi,
                                                      std::int32_t bj, std::int32_t bk) noexcept {
  // Unsigned compares reject both sides; a disabled grid has dimensions 0, so every block goes
  // to the table.
  const auto gi = static_cast<std::uint32_t>(bi - g.origin[0]);
  const auto gj = static_cast<std::uint32_t>(bj - g.origin[1]);
  const auto gk = static_cast<std::uint32_t>(bk - g.origin[2]);
  if (gi >= g.dim[0] || gj >= g.dim[1] || gk >= g.dim[2]) return acquire_block(bi, bj, bk);
  std::uint16_t& cell = g.cells[gi + g.dim[0] * (gj + g.dim[1] * gk)];
  if (cell != 0) return &pool_[cell - 1u];
  Block* b = acquire_block(bi, bj, bk);
  // Blocks touched this frame are never evicted this frame, so the cached slot stays valid.
  if (b != nullptr) cell = static_cast<std::uint16_t>(b - pool_.data() + 1);
  return b;
}

void OccupancyMap::advance_frame_stamp() noexcept {
  if (frame_tag_ >= kMaxFrameTag) {
    // Rare wrap (every ~9 min at 30 Hz): old stamps could alias new ones, so clear them all.
    for (std::size_t s = 0; s < kMaxMapBlocks; ++s) {
      if (!slot_used_[s]) continue;
      for (Voxel& v : pool_[s].voxels) v.stamp = 0;
    }
    frame_tag_ = 0;
    sink_tag_ = 0;
  }
  ++frame_tag_;
}

// ---------------------------------------------------------------------------------------------
// Integration.

inline bool OccupancyMap::end_point(std::uint16_t raw, const Eigen::Array4f& dir,
                                    Eigen::Array4f& end, IndexVec& idx,
                                    bool& is_hit) const noexcept {
  float z = static_cast<float>(raw) * depth_scale_;
  is_hit = true;
  if (raw == 0 || z > config_.max_depth) {
    z = config_.max_depth;
    is_hit = false;
  } else if (z < config_.min_depth) {
    return false;
  }
  Eigen::Array4f offset = dir * z;
  // Clip to the local region (the camera is at its centre). One packed test, rarely true:
  // for floats, o - h > 0 exactly when o > h.
  if ((offset.abs() - half_extent4_).maxCoeff() > 0.f) {
    float scale = 1.f;
    for (int a = 0; a < 3; ++a) {
      const float o = std::fabs(offset[a]);
      const float h = half_extent4_[a];
      if (o > h) scale = std::min(scale, h / o);
    }
    if (scale < 1.f) {
      offset *= scale * (1.f - 1e-4f);  // stay just inside so the end voxel is in the region
      is_hit = false;
    }
  }
  end = origin4_ + offset;
  // Inside the local region, so inside the key range (init() bounds the region, integrate()
  // the pose): no range checks needed.
  const Eigen::Array4f x = end * inv_resolution_;
  idx = {fast_floor(x[0]), fast_floor(x[1]), fast_floor(x[2])};
  return true;
}

void OccupancyMap::mark_end_points(const DepthView& depth) noexcept {
  std::size_t pixels = 0, merged = 0, dropped = 0, dropped_updates = 0, updates = 0, hits = 0;
  const std::uint16_t base = static_cast<std::uint16_t>(frame_tag_ * 4u);
  const std::uint16_t queued_stamp = static_cast<std::uint16_t>(base + kQueued);
  const std::uint16_t hit_stamp = static_cast<std::uint16_t>(base + kHit);
  const bool merge = config_.merge_rays_per_voxel;
  const int margin = config_.pixel_margin, stride = config_.pixel_stride;
  const int width = cam_->width, height = cam_->height;
  const int columns = sampled_columns_;
  const std::size_t max_rays = config_.max_rays_per_frame;
  const std::int32_t q_hit = q_hit_, q_max = q_max_, q_occupied = q_occupied_;
  const float max_depth = config_.max_depth;
  Block* block = nullptr;
  // Loop constants in locals: the map writes below could otherwise alias the members, and the
  // compiler would reload and re-broadcast them for every packet.
  const Eigen::Array4i hit_raw_end_i =
      Eigen::Array4i::Constant(static_cast<std::int32_t>(hit_raw_end_));
  const Eigen::Array4i near_raw_end_i =
      Eigen::Array4i::Constant(static_cast<std::int32_t>(near_raw_end_));
  const float scale = depth_scale_, inv_res = inv_resolution_;
  const Eigen::Array4f half_x = Eigen::Array4f::Constant(half_extent4_[0]);
  const Eigen::Array4f half_y = Eigen::Array4f::Constant(half_extent4_[1]);
  const Eigen::Array4f half_z = Eigen::Array4f::Constant(half_extent4_[2]);
  const Eigen::Array4f origin_x = Eigen::Array4f::Constant(origin4_[0]);
  const Eigen::Array4f origin_y = Eigen::Array4f::Constant(origin4_[1]);
  const Eigen::Array4f origin_z = Eigen::Array4f::Constant(origin4_[2]);
  // End points lie in the local region, fewer than 2^(kKeyBlockBits - 1) blocks from the
  // camera's block per axis (init() bounds the region), so voxel indices taken relative to
  // key_base_ are non-negative (shifts are well defined) and a block is named by one int key.
  const Eigen::Array4i base_x = Eigen::Array4i::Constant(key_base_[0]);
  const Eigen::Array4i base_y = Eigen::Array4i::Constant(key_base_[1]);
  const Eigen::Array4i base_z = Eigen::Array4i::Constant(key_base_[2]);
  const std::int32_t key_block_x = key_base_[0] >> kBlockBits;
  const std::int32_t key_block_y = key_base_[1] >> kBlockBits;
  const std::int32_t key_block_z = key_base_[2] >> kBlockBits;
  const LocalGrid grid = local_grid();
  // Keys are >= 0, so the first pixel (and the one after a failed lookup) looks its block up.
  std::int32_t current_key = -1;
  std::size_t ray_count = ray_count_;
  for (int v = margin; v < height - margin; v += stride) {
    const std::uint16_t* row = depth.row(v);
    const Eigen::Array4f row_dir = row_direction(v);
    const Eigen::Array4f row_x = Eigen::Array4f::Constant(row_dir[0]);
    const Eigen::Array4f row_y = Eigen::Array4f::Constant(row_dir[1]);
    const Eigen::Array4f row_z = Eigen::Array4f::Constant(row_dir[2]);
    // Four sampled pixels per step, one per lane, structure of arrays. Every lane gets the
    // scalar end_point()'s float operations in the same order, branch-free (Eigen maps them to
    // SSE/NEON element-wise operations; the selects are exact arithmetic and floor_lanes is
    // exact), so the end voxels are bit-identical to end_point()'s, which pass 2 uses. The map
    // update stays scalar, in pixel order.
    for (int k0 = 0; k0 < columns; k0 += 4) {
      const int lanes = std::min(4, columns - k0);
      std::array<std::uint16_t, 4> raw{};
      const std::uint16_t* px = row + margin + k0 * stride;
      if (lanes == 4) {
        for (int l = 0; l < 4; ++l) raw[static_cast<std::size_t>(l)] = px[l * stride];
      } else {
        // Lanes past the row end repeat its last pixel; they are never used.
        for (int l = 0; l < 4; ++l) {
          raw[static_cast<std::size_t>(l)] = px[std::min(l, lanes - 1) * stride];
        }
      }
      const Eigen::Array4i raw_i{raw[0], raw[1], raw[2], raw[3]};
      const Eigen::Array4f raw_f = raw_i.cast<float>();  // exact: raw < 2^16
      // Free rays (no return, or beyond max_depth) are cast to max_depth. Select-free form:
      // (1 - raw)^+ is exactly 1 for raw == 0 and 0 otherwise, and z + 0 == z.
      const Eigen::Array4f z_ray =
          (raw_f * scale + (1.f - raw_f).max(0.f) * max_depth).min(max_depth);
      const auto k = static_cast<std::size_t>(k0);
      Eigen::Array4f off_x = (Eigen::Array4f::Map(&sampled_dir_x_[k]) + row_x) * z_ray;
      Eigen::Array4f off_y = (Eigen::Array4f::Map(&sampled_dir_y_[k]) + row_y) * z_ray;
      Eigen::Array4f off_z = (Eigen::Array4f::Map(&sampled_dir_z_[k]) + row_z) * z_ray;
      // For floats o - h > 0 exactly when o > h, as in end_point().
      const Eigen::Array4f outside =
          (off_x.abs() - half_x).max(off_y.abs() - half_y).max(off_z.abs() - half_z);
      const bool any_outside = outside.maxCoeff() > 0.f;
      // Lane classes as 0/1 integers, computed in the lanes (arithmetic shifts give -1 where
      // the difference is negative): raw in [1, near_raw_end) is closer than min_depth and
      // skipped; raw in [near_raw_end, hit_raw_end) is a hit unless clipped; the rest (0, or
      // beyond max_depth) are free rays. near_raw_end >= 1 and near_raw_end <= hit_raw_end, so
      // each difference below is 0 or 1.
      const Eigen::Array4i below_zero = (raw_i - 1).shiftRight<31>();
      const Eigen::Array4i below_near = (raw_i - near_raw_end_i).shiftRight<31>();
      const Eigen::Array4i below_hit = (raw_i - hit_raw_end_i).shiftRight<31>();
      const Eigen::Array4i too_near = below_zero - below_near;  // 1: skip the pixel
      Eigen::Array4i hit_lane = below_near - below_hit;         // 1: measured and not near
      if (any_outside) {
        // end_point()'s clip: min(1, h/|o|) is 1 where |o| <= h (h/|o| >= 1, or inf), so the
        // minimum over axes is its scale; lanes inside keep the factor 1 exactly. The factor
        // is shrink where scale < 1 and shrink + (1 - c) = c + (1 - c) = 1 (exact) where not.
        const Eigen::Array4f clip_scale =
            (half_x / off_x.abs()).min(half_y / off_y.abs()).min(half_z / off_z.abs()).min(1.f);
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
        hit_lane = (hit_lane + unclipped.cast<std::int32_t>()).shiftRight<1>();
      }
      const Eigen::Array4i ix = floor_lanes((origin_x + off_x) * inv_res) - base_x;
      const Eigen::Array4i iy = floor_lanes((origin_y + off_y) * inv_res) - base_y;
      const Eigen::Array4i iz = floor_lanes((origin_z + off_z) * inv_res) - base_z;
      const Eigen::Array4i blk_x = ix.shiftRight<kBlockBits>();
      const Eigen::Array4i blk_y = iy.shiftRight<kBlockBits>();
      const Eigen::Array4i blk_z = iz.shiftRight<kBlockBits>();
      const Eigen::Array4i in_block =
          (ix - blk_x.shiftLeft<kBlockBits>()) +
          (iy - blk_y.shiftLeft<kBlockBits>()).shiftLeft<kBlockBits>() +
          (iz - blk_z.shiftLeft<kBlockBits>()).shiftLeft<2 * kBlockBits>();
      const Eigen::Array4i key =
          blk_x + (blk_y + blk_z.shiftLeft<kKeyBlockBits>()).shiftLeft<kKeyBlockBits>();
      for (int l = 0; l < lanes; ++l) {
        if (too_near[l] != 0) continue;  // closer than min_depth
        const bool hit = hit_lane[l] != 0;
        const std::int32_t lane_key = key[l];
        ++pixels;
        if (lane_key != current_key) {
          block = local_block(grid, blk_x[l] + key_block_x, blk_y[l] + key_block_y,
                              blk_z[l] + key_block_z);
          if (block == nullptr) {
            current_key = -1;
            ++dropped;
            ++dropped_updates;
            continue;
          }
          current_key = lane_key;
        }
        Voxel& vx = block->voxels[static_cast<std::size_t>(in_block[l])];
        const std::uint16_t stamp = vx.stamp;
        if (merge && (stamp == hit_stamp || (!hit && stamp == queued_stamp))) {
          ++merged;
          continue;
        }
        if (ray_count >= max_rays) {
          ++dropped;
          continue;
        }
        if (hit) {
          if (stamp != hit_stamp) {
            const std::int32_t current = vx.log_odds == kUnknown ? 0 : vx.log_odds;
            const std::int32_t updated = std::min(current + q_hit, q_max);
            block->occupied = static_cast<std::uint16_t>(block->occupied + (updated > q_occupied) -
                                                         (vx.log_odds > q_occupied));
            vx.log_odds = static_cast<std::int16_t>(updated);
            vx.stamp = hit_stamp;
            ++updates;
            ++hits;
          }
        } else if (stamp != hit_stamp) {
          vx.stamp = queued_stamp;
        }
        rays_[ray_count++] = static_cast<std::uint32_t>(v * width + margin + (k0 + l) * stride);
      }
    }
  }
  ray_count_ = ray_count;
  stats_.pixels_sampled += pixels;
  stats_.rays_merged += merged;
  stats_.rays_dropped += dropped;
  stats_.updates_dropped += dropped_updates;
  stats_.voxel_updates += updates;
  stats_.hits += hits;
}

template <bool kEarlyStop>
void OccupancyMap::carve_free_space(const DepthView& depth) noexcept {
  // Counters live in locals (registers) for the hot loop and are stored once at the end.
  std::size_t visits_left = config_.max_voxel_visits_per_frame;
  std::size_t visits = 0, updates = 0, dropped_updates = 0, rays = 0, rays_dropped = 0;
  std::size_t rays_stopped = 0;
  const auto stop_after = static_cast<std::uint32_t>(config_.free_ray_early_stop);
  const std::uint16_t base = static_cast<std::uint16_t>(frame_tag_ * 4u);
  const std::uint16_t hit_stamp = static_cast<std::uint16_t>(base + kHit);
  const std::uint16_t miss_stamp = static_cast<std::uint16_t>(base + kMiss);
  const std::int32_t q_miss = q_miss_, q_min = q_min_, q_occupied = q_occupied_;
  const float res = resolution_;
  const LocalGrid grid = local_grid();
  constexpr float kInf = std::numeric_limits<float>::infinity();
  IndexVec camera{};
  if (!index_of(origin_, camera)) return;  // cannot happen: integrate() checked the pose
  const std::int32_t width = cam_->width;

  // Early stop walks the rays coarse to fine over the sampled pixel grid: first the pixels on
  // the lattice 2^kOrderLevels samples apart, then each finer lattice's new pixels (image
  // order within a level). In plain image order a ray stops as soon as it has run N voxels
  // inside its neighbour's tube, although the two lines still part at voxel corners nearer
  // the camera; here the rays that walk first are far apart, so they walk almost to the
  // camera and carve the near part densely before the finer rays stop against them. For the
  // same number of visits it skips a third to half fewer misses (docs/occupancy_map.md).
  constexpr std::uint32_t kOrderLevels = 4;
  constexpr int kLevelShift = 28;  // rays_ entries: pass number above the pixel index
  constexpr std::uint32_t kPixelMask = (1u << kLevelShift) - 1;
  static_assert(kMaxImageWidth * kMaxImageHeight <= (1 << kLevelShift), "pixel index bits");
  if constexpr (kEarlyStop) {
    const auto margin = static_cast<std::uint32_t>(config_.pixel_margin);
    const auto stride = static_cast<std::uint32_t>(config_.pixel_stride);
    for (std::size_t r = 0; r < ray_count_; ++r) {
      const std::uint32_t u = rays_[r] % static_cast<std::uint32_t>(width);
      const std::uint32_t v = rays_[r] / static_cast<std::uint32_t>(width);
      // Level of sampled pixel (k, j): the trailing zero bits k and j share, at most
      // kOrderLevels.
      const std::uint32_t kj = ((u - margin) / stride) | ((v - margin) / stride);
      std::uint32_t level = 0;
      while (level < kOrderLevels && ((kj >> level) & 1u) == 0) ++level;
      rays_[r] |= (kOrderLevels - level) << kLevelShift;
    }
  }
  std::size_t processed = 0;
  const std::uint32_t passes = kEarlyStop ? kOrderLevels + 1 : 1;
  for (std::uint32_t pass = 0; pass < passes; ++pass) {
    for (std::size_t r = 0; r < ray_count_; ++r) {
      std::uint32_t entry = rays_[r];
      if constexpr (kEarlyStop) {
        if ((entry >> kLevelShift) != pass) continue;
        entry &= kPixelMask;
      }
      if (visits_left == 0) {
        rays_dropped += ray_count_ - processed;
        pass = passes;  // the budget is spent: no later pass either
        break;
      }
      ++processed;
      const int u = static_cast<int>(entry % static_cast<std::uint32_t>(width));
      const int v = static_cast<int>(entry / static_cast<std::uint32_t>(width));
      Eigen::Array4f end;
      bool end_is_hit = false;
      IndexVec last{};
      if (!end_point(depth.at(u, v), column_dir_[static_cast<std::size_t>(u)] + row_direction(v),
                     end, last, end_is_hit)) {
        continue;
      }
      ++rays;

      // Amanatides-Woo set-up, parameter t in [0, 1] along from_point -> from_point + d. The exact
      // walk goes from the camera to the end voxel. The early-stop walk goes from the end voxel
      // back to the camera: the far part of a ray is its own, the near part mostly what earlier
      // rays (its neighbours in pixel order) already carved, so that is where it can stop.
      const Eigen::Array4f from_point = kEarlyStop ? end : origin4_;
      const Eigen::Array4f d = kEarlyStop ? Eigen::Array4f(origin4_ - end) : end - origin4_;
      const IndexVec& from = kEarlyStop ? last : camera;
      const IndexVec& to = kEarlyStop ? camera : last;
      std::int32_t ix = from[0], iy = from[1], iz = from[2];
      const std::int32_t ex = to[0], ey = to[1], ez = to[2];
      const std::int32_t sx = ex >= ix ? 1 : -1, sy = ey >= iy ? 1 : -1, sz = ez >= iz ? 1 : -1;
      const auto axis_setup = [&](std::int32_t i, std::int32_t e, std::int32_t s, float o, float di,
                                  float& t_max, float& t_delta) {
        if (i == e || di == 0.f) {
          t_max = kInf;
          t_delta = kInf;
          return;
        }
        const float boundary = static_cast<float>(i + (s > 0 ? 1 : 0)) * res;
        t_max = (boundary - o) / di;
        t_delta = res / std::fabs(di);
      };
      float tx, ty, tz, dx, dy, dz;
      axis_setup(ix, ex, sx, from_point.x(), d.x(), tx, dx);
      axis_setup(iy, ey, sy, from_point.y(), d.y(), ty, dy);
      axis_setup(iz, ez, sz, from_point.z(), d.z(), tz, dz);
      // Exactly |dx|+|dy|+|dz| steps (+1 visit) so the walk ends in its last voxel whatever the
      // rounding; an axis that reached its end index gets t = inf. The exact walk of a hit ray
      // stops before its end voxel, which already holds this frame's hit; the early-stop walk of
      // a hit ray starts on it (its hit stamp keeps it from being updated).
      std::size_t steps =
          static_cast<std::size_t>(std::abs(ex - ix) + std::abs(ey - iy) + std::abs(ez - iz)) +
          (kEarlyStop || !end_is_hit ? 1u : 0u);
      bool capped = false;
      if (steps > visits_left) {
        steps = visits_left;
        capped = true;
      }
      visits_left -= steps;
      visits += steps;

      // The walk keeps the block, the voxel's index inside it and, per axis, the steps left to
      // the next event of that axis: its block face or its last step, whichever comes first.
      // Between events a step is one axis choice, one index add, one t add and one decrement;
      // steps, end indices and block faces are only looked at in the (rare) event branch. The t
      // values get the same float additions in the same order as the plain walk, so the voxels
      // are the same.
      constexpr std::int32_t kM = kBlockEdge - 1;
      std::int32_t bx = ix >> kBlockBits, by = iy >> kBlockBits, bz = iz >> kBlockBits;
      std::int32_t rx = std::abs(ex - ix), ry = std::abs(ey - iy), rz = std::abs(ez - iz);
      const auto to_boundary = [](std::int32_t i, std::int32_t s) {
        return s > 0 ? kBlockEdge - (i & kM) : (i & kM) + 1;
      };
      std::int32_t cx = to_boundary(ix, sx), cy = to_boundary(iy, sy), cz = to_boundary(iz, sz);
      // An axis without steps has t = inf and is never chosen, so its event count never runs out.
      const auto to_event = [](std::int32_t face, std::int32_t left) {
        return left == 0 ? std::numeric_limits<std::int32_t>::max() : std::min(face, left);
      };
      std::int32_t kx = to_event(cx, rx), ky = to_event(cy, ry), kz = to_event(cz, rz);
      const std::int32_t ox = sx, oy = sy * kBlockEdge, oz = sz * kBlockEdge * kBlockEdge;
      std::int32_t li = static_cast<std::int32_t>(local_index(ix, iy, iz));
      Block* block = nullptr;
      std::size_t n = steps;       // visits left on this ray, including the current voxel
      std::size_t sink_entry = 0;  // n when the walk entered a block it could not allocate
      const auto enter_block = [&](std::int32_t i, std::int32_t j, std::int32_t k) {
        block = local_block(grid, i, j, k);
        if (block != nullptr) return;
        // Visits there are counted as dropped updates; the sink's stamps all read "hit this
        // frame", so the hot loop needs no null test, and an early-stop walk is not stopped
        // there (hits never stop a ray).
        if (sink_tag_ != frame_tag_) {
          for (Voxel& vx : sink_.voxels) vx.stamp = hit_stamp;
          sink_tag_ = frame_tag_;
        }
        block = &sink_;
        sink_entry = n;
      };
      const auto leave_block = [&] {
        if (block == &sink_) dropped_updates += sink_entry - n;
      };
      enter_block(bx, by, bz);
      if (n == 0) continue;
      std::uint32_t run = 0;  // consecutive voxels found missed this frame (early stop)
      bool stopped = false;
      const auto miss = [&](Voxel& vx) {
        const std::int16_t old = vx.log_odds;
        const std::int32_t current = old == kUnknown ? 0 : old;
        const auto updated = static_cast<std::int16_t>(std::max(current + q_miss, q_min));
        vx.log_odds = updated;
        vx.stamp = miss_stamp;
        ++updates;
        // A miss can only turn occupied into free.
        if (old > q_occupied && updated <= q_occupied) --block->occupied;
      };
      for (;;) {
        Voxel& vx = block->voxels[static_cast<std::size_t>(li)];
        if constexpr (kEarlyStop) {
          // Only misses count towards the stop: at grazing angles a ray crosses voxels that
          // other pixels hit, and the space beyond them may still be this ray's alone.
          const std::uint16_t stamp = vx.stamp;
          if (stamp == miss_stamp) {
            if (++run == stop_after) {
              stopped = true;
              break;
            }
          } else {
            run = 0;
            if (stamp != hit_stamp) miss(vx);
          }
        } else {
          // hit_stamp and miss_stamp are consecutive: one unsigned compare tests both. Most
          // visits (near the camera) find the voxel already updated this frame.
          if (static_cast<std::uint16_t>(vx.stamp - hit_stamp) > 1u) miss(vx);
        }
        if (--n == 0) break;
        // Step along the axis with the nearest boundary (ties to the lower axis).
        if ((tx <= ty) & (tx <= tz)) {
          li += ox;
          if (--kx != 0) {
            tx += dx;
            continue;
          }
          const std::int32_t done = std::min(cx, rx);
          rx -= done;
          cx -= done;
          tx = rx == 0 ? kInf : tx + dx;
          if (cx == 0) {
            li -= kBlockEdge * ox;  // wrap to the other face of the next block
            bx += sx;
            cx = kBlockEdge;
            leave_block();
            enter_block(bx, by, bz);
          }
          kx = to_event(cx, rx);
        } else if (ty <= tz) {
          li += oy;
          if (--ky != 0) {
            ty += dy;
            continue;
          }
          const std::int32_t done = std::min(cy, ry);
          ry -= done;
          cy -= done;
          ty = ry == 0 ? kInf : ty + dy;
          if (cy == 0) {
            li -= kBlockEdge * oy;
            by += sy;
            cy = kBlockEdge;
            leave_block();
            enter_block(bx, by, bz);
          }
          ky = to_event(cy, ry);
        } else {
          li += oz;
          if (--kz != 0) {
            tz += dz;
            continue;
          }
          const std::int32_t done = std::min(cz, rz);
          rz -= done;
          cz -= done;
          tz = rz == 0 ? kInf : tz + dz;
          if (cz == 0) {
            li -= kBlockEdge * oz;
            bz += sz;
            cz = kBlockEdge;
            leave_block();
            enter_block(bx, by, bz);
          }
          kz = to_event(cz, rz);
        }
      }
      leave_block();
      if (stopped) {
        // The voxels after the current one were never looked at: give them back to the budget.
        visits_left += n - 1;
        visits -= n - 1;
        ++rays_stopped;
      } else if (capped) {
        ++rays_dropped;
      }
    }
  }
  stats_.rays += rays;
  stats_.rays_stopped_early += rays_stopped;
  stats_.rays_dropped += rays_dropped;
  stats_.voxel_visits += visits;
  stats_.voxel_updates += updates;
  stats_.updates_dropped += dropped_updates;
}

Status OccupancyMap::integrate(const DepthView& depth, const CameraIntrinsics& cam,
                               const Pose& T_map_camera, Stamp stamp) noexcept {
  if (!initialized_) return Status::kNotInitialized;
  if (const Status s = validate_depth(depth, cam); !ok(s)) return s;
  if (cam.width > kMaxImageWidth || cam.height > kMaxImageHeight) return Status::kWrongSize;
  if (!finite_positive(cam.fx) || !finite_positive(cam.fy) || !std::isfinite(cam.cx) ||
      !std::isfinite(cam.cy) || !finite_positive(cam.depth_scale)) {
    return Status::kInvalidArgument;
  }
  if (const Status s = validate_pose(T_map_camera); !ok(s)) return s;
  // Keep the local region well inside the key range.
  if (const Status s = check_pose_range(T_map_camera); !ok(s)) return s;
  if (frames_ > 0 && stamp <= last_stamp_) return Status::kTimeNotIncreasing;

  // Input accepted: from here on the frame always completes.
  stats_ = IntegrationStats{};
  ++frames_;
  last_stamp_ = stamp;
  advance_frame_stamp();
  evictions_this_frame_ = 0;
  ray_count_ = 0;
  cam_ = &cam;
  depth_scale_ = cam.depth_scale;
  // Pass 1 classifies raw depths with integer compares, exactly as end_point() does with floats.
  hit_raw_end_ = first_raw_where(depth_scale_, [&](float z) { return z > config_.max_depth; });
  near_raw_end_ = first_raw_where(depth_scale_, [&](float z) { return !(z < config_.min_depth); });
  cy_ = cam.cy;
  inv_fy_ = 1.f / cam.fy;
  origin_ = T_map_camera.translation;
  origin4_ << origin_, 0.f;
  half_extent4_ << config_.local_half_extent, std::numeric_limits<float>::infinity();
  const Eigen::Matrix3f R = T_map_camera.rotation.normalized().toRotationMatrix();
  for (int u = 0; u < cam.width; ++u) {
    column_dir_[static_cast<std::size_t>(u)]
        << R.col(0) * ((static_cast<float>(u) - cam.cx) / cam.fx),
        0.f;
  }
  // Sampled columns' directions, one array per axis, padded to whole 4-lane packets with the
  // last column (the same floats as column_dir_, so both passes agree bit for bit).
  const int margin = config_.pixel_margin, stride = config_.pixel_stride;
  sampled_columns_ = cam.width > 2 * margin ? (cam.width - 2 * margin + stride - 1) / stride : 0;
  for (int k = 0; k < sampled_columns_ + 3; ++k) {
    const int u = margin + std::min(k, std::max(sampled_columns_ - 1, 0)) * stride;
    const Eigen::Array4f& dir = column_dir_[static_cast<std::size_t>(std::min(u, cam.width - 1))];
    sampled_dir_x_[static_cast<std::size_t>(k)] = dir[0];
    sampled_dir_y_[static_cast<std::size_t>(k)] = dir[1];
    sampled_dir_z_[static_cast<std::size_t>(k)] = dir[2];
  }
  for (std::size_t a = 0; a < 3; ++a) {
    const std::int32_t camera_block =
        fast_floor(origin_[static_cast<int>(a)] * inv_resolution_) >> kBlockBits;
    key_base_[a] = (camera_block - (1 << (kKeyBlockBits - 1))) * kBlockEdge;
  }
  // Element by element: the same values as a comma initialiser from R.col(), without the
  // packet load past R's end that GCC 12 -O3 reports (-Warray-bounds) once this is inlined.
  down_dir_ = Eigen::Array4f(R(0, 1), R(1, 1), R(2, 1), 0.f);
  forward_dir_ = Eigen::Array4f(R(0, 2), R(1, 2), R(2, 2), 0.f);
  if (grid_enabled_) {
    for (int a = 0; a < 3; ++a) {
      const std::size_t i = static_cast<std::size_t>(a);
      grid_origin_[i] = (fast_floor(origin_[a] * inv_resolution_) >> kBlockBits) - grid_dim_[i] / 2;
    }
    std::fill(local_grid_.begin(), local_grid_.begin() + static_cast<std::ptrdiff_t>(grid_cells_),
              std::uint16_t{0});
  }

  // Pass 1: end points. Hits are applied here (once per voxel), so pass 2's misses skip them:
  // hit wins over miss. Rays ending in an already-seen voxel are merged (when enabled).
  mark_end_points(depth);

  // Pass 2: free space along each ray with a 3-D DDA, within the visit budget.
  if (config_.free_ray_early_stop > 0) {
    carve_free_space<true>(depth);
  } else {
    carve_free_space<false>(depth);
  }
  cam_ = nullptr;
  return Status::kOk;
}

}  // namespace dynamap
