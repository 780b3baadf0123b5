// OccupancyMap's queries: keys, voxel states and segment walks. They read the map and never
// change it, apart from the integration code (occupancy_map.cpp, the integrator).
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "dynamap/map/occupancy_map.hpp"
#include "segment_walk.hpp"

namespace dynamap {
namespace {

inline std::uint64_t mix64(std::uint64_t x) noexcept {
  return IntegerHash{}(x);
}

}  // namespace

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

bool OccupancyMap::first_non_free_on_segment(const Eigen::Vector3f& a, const Eigen::Vector3f& b,
                                             Eigen::Vector3f* hit,
                                             Occupancy* state) const noexcept {
  // Same Amanatides-Woo walk (set-up, tie order) as first_occupied_on_segment's voxel walk, so
  // both name the same voxels. No block can be crossed in one step here: a block without
  // occupied voxels may still hold unknown ones, and a missing block is unknown throughout.
  IndexVec idx{}, end{};
  if (!initialized_ || !index_of(a, idx) || !index_of(b, end)) {
    // Nothing outside the representable range (or in an empty map) was ever observed.
    if (hit != nullptr) *hit = a;
    if (state != nullptr) *state = Occupancy::kUnknown;
    return true;
  }
  detail::SegmentWalk w = detail::start_segment_walk(a, b, idx, end, params_.resolution);
  // One table lookup per block entered, not per voxel.
  std::int32_t bi = idx[0] >> kBlockBits, bj = idx[1] >> kBlockBits, bk = idx[2] >> kBlockBits;
  const Block* block = find_block(bi, bj, bk);
  for (std::size_t n = 0; n < kMaxSegmentVisits; ++n) {
    const std::int32_t ci = idx[0] >> kBlockBits, cj = idx[1] >> kBlockBits,
                       ck = idx[2] >> kBlockBits;
    if (ci != bi || cj != bj || ck != bk) {
      bi = ci;
      bj = cj;
      bk = ck;
      block = find_block(bi, bj, bk);
    }
    const Occupancy s = block == nullptr
                            ? Occupancy::kUnknown
                            : classify(block->voxels[local_index(idx[0], idx[1], idx[2])].log_odds);
    if (s != Occupancy::kFree) {
      if (hit != nullptr) *hit = center_of(idx);
      if (state != nullptr) *state = s;
      return true;
    }
    if (w.remaining[0] + w.remaining[1] + w.remaining[2] == 0) return false;
    (void)w.advance(idx);
  }
  // Walk budget spent: the rest of the segment was not checked, so it cannot count as free.
  if (hit != nullptr) *hit = center_of(idx);
  if (state != nullptr) *state = Occupancy::kUnknown;
  return true;
}

}  // namespace dynamap
