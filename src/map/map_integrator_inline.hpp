// MapIntegrator's inline helpers shared by its source files (internal to src/map/).
#pragma once

#include "dynamap/map/detail/map_integrator.hpp"

namespace dynamap::detail {

/// keep_own_surface: whether a voxel hit this frame, or with log-odds `before` (this frame's
/// carving) above the occupied threshold since tick `since` for at least `min_age` ticks, is
/// part of the surface a hit ray ends on.
inline bool on_own_surface(bool hit, std::int32_t before, std::int32_t q_occupied,
                           std::uint16_t since, std::uint16_t now, std::uint16_t min_age) noexcept {
  return hit || (before > q_occupied && static_cast<std::uint16_t>(now - since) >= min_age);
}

/// miss_max_offset: whether a voxel with log-odds `l` (kUnknown: never observed), occupied since
/// tick `since`, is one a ray lowers only near its centre: unknown, or occupied for at least
/// `static_age` ticks (static evidence).
inline bool centre_rule_applies(std::int32_t l, std::int32_t q_occupied, std::uint16_t since,
                                std::uint16_t now, std::uint16_t static_age) noexcept {
  return l == kUnknownLogOdds || on_own_surface(false, l, q_occupied, since, now, static_age);
}

inline MapIntegrator::LocalGrid MapIntegrator::local_grid() noexcept {
  LocalGrid g{grid_origin_, {}, local_grid_.data()};
  if (grid_enabled_) {
    for (std::size_t a = 0; a < 3; ++a) g.dim[a] = static_cast<std::uint32_t>(grid_dim_[a]);
  }
  return g;
}

inline Block* MapIntegrator::local_block(const LocalGrid& g, std::int32_t bi, std::int32_t bj,
                                         std::int32_t bk) noexcept {
  // Unsigned compares reject both sides; a disabled grid has dimensions 0, so every block goes
  // to the table.
  const auto gi = static_cast<std::uint32_t>(bi - g.origin[0]);
  const auto gj = static_cast<std::uint32_t>(bj - g.origin[1]);
  const auto gk = static_cast<std::uint32_t>(bk - g.origin[2]);
  if (gi >= g.dim[0] || gj >= g.dim[1] || gk >= g.dim[2]) return store_->acquire(bi, bj, bk);
  std::uint16_t& cell = g.cells[gi + g.dim[0] * (gj + g.dim[1] * gk)];
  if (cell != 0) return &store_->block(cell - 1u);
  Block* b = store_->acquire(bi, bj, bk);
  // Blocks touched this frame are never evicted this frame, so the cached slot stays valid.
  if (b != nullptr) cell = static_cast<std::uint16_t>(store_->slot_of(b) + 1);
  return b;
}

}  // namespace dynamap::detail
