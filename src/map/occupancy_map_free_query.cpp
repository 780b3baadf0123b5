// OccupancyMap::first_non_free_on_segment, in its own file so that it stays apart from the
// integration code in occupancy_map.cpp (it reads the map, it never changes it).
#include <cmath>
#include <cstdlib>

#include "dynamap/map/occupancy_map.hpp"
#include "segment_walk.hpp"

namespace dynamap {

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
