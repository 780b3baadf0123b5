// MapIntegrator::carve_rays(), the ray loop both carvings share (the one walk in
// map_carving.cpp, the tiles in map_tiled_carving.cpp); internal to src/map/.
#pragma once

#include "dynamap/map/detail/map_integrator.hpp"
#include "segment_walk.hpp"

namespace dynamap::detail {

/// Walks ordered_rays_[begin, end) in order within k's visit budget.
template <bool kEarlyStop, class Cursor>
void MapIntegrator::carve_rays(std::size_t begin, std::size_t end, const DepthView& depth,
                               const IndexVec& camera, Cursor& cursor,
                               CarveCounters& k) const noexcept {
  for (std::size_t r = begin; r < end; ++r) {
    if (k.visits_left == 0) {
      k.rays_dropped += end - r;  // the budget is spent
      return;
    }
    detail::RayWalk w;
    if (!start_ray(ordered_rays_[r], depth, camera, kEarlyStop || p_->config.keep_own_surface, w))
      continue;
    ++k.rays;
    std::size_t steps = w.visits;
    const bool capped = steps > k.visits_left;
    if (capped) steps = k.visits_left;
    k.visits_left -= steps;
    k.visits += steps;
    cursor.run = 0;
    cursor.surface = w.own_surface;
    cursor.ray = &w;
    const std::size_t left = detail::walk_ray<kBlockBits>(w, steps, cursor);
    if (left > 0) {
      // The voxels after the stopping one were never looked at: back to the budget.
      k.visits_left += left - 1;
      k.visits -= left - 1;
      ++k.rays_stopped;
    } else if (capped) {
      ++k.rays_dropped;
    }
  }
}

}  // namespace dynamap::detail
