#include "dynamap/map/map_refiner.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

#include "dynamap/map/map_params.hpp"

namespace dynamap {

namespace {
/// A voxel index (float, integral) clamped to the map's key range, then converted: the
/// conversion is defined for any input, also +-inf and the NaN an inflated box of extreme
/// corners can give (inf - inf).
std::int64_t to_key_index(float x) noexcept {
  constexpr float kLimit = static_cast<float>(OccupancyMap::kKeyHalfRange);
  if (!(x >= -kLimit)) return -static_cast<std::int64_t>(OccupancyMap::kKeyHalfRange);
  if (!(x <= kLimit - 1.f)) return OccupancyMap::kKeyHalfRange - 1;
  return static_cast<std::int64_t>(x);
}

bool box_valid(const Box3& b) noexcept {
  return b.min.allFinite() && b.max.allFinite() && (b.min.array() <= b.max.array()).all();
}
}  // namespace

Status MapRefiner::init(const MapRefinerConfig& config, float ground_height) noexcept {
  if (!all_in_range(config, params::kMapRefiner) || !std::isfinite(ground_height)) {
    return Status::kInvalidArgument;
  }
  config_ = config;
  ground_height_ = ground_height;
  initialized_ = true;
  stats_ = MapRefinerStats{};
  return Status::kOk;
}

Status MapRefiner::set_ground_height(float z) noexcept {
  if (!std::isfinite(z)) return Status::kNonFinite;
  ground_height_ = z;
  return Status::kOk;
}

Status MapRefiner::refine(const OccupancyMap& map, const VoxelLookup& clean_history,
                          Detection* detections, std::size_t count) noexcept {
  if (!initialized_ || !map.initialized()) return Status::kNotInitialized;
  if (count > 0 && detections == nullptr) return Status::kNullData;
  for (std::size_t i = 0; i < count; ++i) {  // validate everything before changing anything
    const Box3& b = detections[i].raw_box;
    if (!b.min.allFinite() || !b.max.allFinite()) return Status::kNonFinite;
    if (!box_valid(b)) return Status::kInvalidArgument;
  }
  stats_ = MapRefinerStats{};
  for (std::size_t i = 0; i < count; ++i) refine_one(map, clean_history, detections[i]);
  return Status::kOk;
}

float MapRefiner::static_share(const OccupancyMap& map, const Box3& raw_box,
                               float floor_top) const noexcept {
  // Voxels whose centre lies within half a voxel of the raw box, above the floor band.
  const float half = 0.5f * map.resolution();
  Box3 box = raw_box;
  box.min.array() -= half;
  box.max.array() += half;
  box.min.z() = std::max(box.min.z(), floor_top);
  if (box.max.z() < box.min.z()) return 0.f;
  std::size_t all = 0, old = 0;
  map.for_each_occupied_in_box(box, config_.max_voxels_per_box,
                               [&](OccupancyMap::VoxelKey, const Eigen::Vector3f& c) {
                                 ++all;
                                 old += map.occupied_frames(c) >= config_.static_frames;
                               });
  return all > 0 ? static_cast<float>(old) / static_cast<float>(all) : 0.f;
}

void MapRefiner::refine_one(const OccupancyMap& map, const VoxelLookup& clean,
                            Detection& d) noexcept {
  const float res = map.resolution();
  const float half = 0.5f * res;
  // Voxels that overlap the inflated box, i.e. whose centres lie within half a voxel of it: a
  // detector box is often thinner than a voxel along the ray (it sees one surface) and would
  // otherwise miss the very voxels that surface occupies.
  Box3 search = d.raw_box.scaled(config_.inflate);
  search.min.array() -= half;
  search.max.array() += half;
  // The floor band is cut from the search box itself, so the voxel budget is not spent on it.
  const float floor_top = ground_height_ + config_.floor_margin;
  search.min.z() = std::max(search.min.z(), floor_top);

  Eigen::Vector3f lo = Eigen::Vector3f::Constant(std::numeric_limits<float>::max());
  Eigen::Vector3f hi = Eigen::Vector3f::Constant(std::numeric_limits<float>::lowest());
  std::size_t support = 0;
  const auto add = [&](const Eigen::Vector3f& c) noexcept {
    if (c.z() < floor_top) return;  // centre below the floor band (belt and braces)
    lo = lo.cwiseMin(c);
    hi = hi.cwiseMax(c);
    ++support;
  };

  if (search.max.z() >= search.min.z()) {
    // Voxels whose centres lie in the search box: index range per axis.
    std::int64_t n_total = 1;
    std::int64_t i0[3], i1[3];
    const auto cap = static_cast<std::int64_t>(config_.max_voxels_per_box);
    for (int a = 0; a < 3; ++a) {
      // Both ends clamped to the map's key range before the conversion (to_key_index), so an
      // absurd box, far on either side, converts in range.
      i0[a] = to_key_index(std::ceil(search.min[a] / res - 0.5f));
      i1[a] = to_key_index(std::floor(search.max[a] / res - 0.5f));
      // Saturated at cap + 1 (only "over the cap" matters): three axes of 2^21 would overflow.
      n_total = std::min(n_total * std::max<std::int64_t>(0, i1[a] - i0[a] + 1), cap + 1);
    }
    if (n_total > cap) ++stats_.truncated;

    // Pass 1: occupied voxels, block-wise through the map (skips unallocated blocks).
    map.for_each_occupied_in_box(search, config_.max_voxels_per_box,
                                 [&](OccupancyMap::VoxelKey, const Eigen::Vector3f& c) { add(c); });

    // Pass 2: voxels in the clean history count as occupied (they were freed on purpose).
    if (!clean.empty() && n_total > 0) {
      std::int64_t examined = 0;
      for (std::int64_t k = i0[2]; k <= i1[2] && examined < cap; ++k) {
        for (std::int64_t j = i0[1]; j <= i1[1] && examined < cap; ++j) {
          for (std::int64_t i = i0[0]; i <= i1[0] && examined < cap; ++i, ++examined) {
            const Eigen::Vector3f c((static_cast<float>(i) + 0.5f) * res,
                                    (static_cast<float>(j) + 0.5f) * res,
                                    (static_cast<float>(k) + 0.5f) * res);
            if (clean.has(map.key_of(c))) add(c);
          }
        }
      }
    }
  }

  stats_.support_voxels += support;
  d.static_share = static_share(map, d.raw_box, floor_top);
  apply_support(Box3{lo - Eigen::Vector3f::Constant(half), hi + Eigen::Vector3f::Constant(half)},
                support, d);
}

void MapRefiner::apply_support(Box3 refined, std::size_t support, Detection& d) noexcept {
  if (support > 0) {
    refined.min = refined.min.cwiseMax(d.raw_box.min);
    refined.max = refined.max.cwiseMin(d.raw_box.max);
    // Support beside but not overlapping the raw box on some axis: nothing to cut there.
    for (int a = 0; a < 3; ++a) {
      if (refined.min[a] > refined.max[a]) {
        refined.min[a] = d.raw_box.min[a];
        refined.max[a] = d.raw_box.max[a];
      }
    }
  }
  if (support >= config_.min_support_voxels && support > 0) {
    d.box = refined;
    d.refined = true;
    ++stats_.refined;
  } else {
    d.box = d.raw_box;
    d.refined = false;
    ++stats_.unrefined;
  }
}

}  // namespace dynamap
