// TrailGrid: marking and lookup (include/dynamap/map/trail_grid.hpp).
#include "dynamap/map/trail_grid.hpp"

#include <algorithm>
#include <cmath>

#include "dynamap/map/map_params.hpp"

namespace dynamap {
namespace {

/// Cell index of a coordinate, false when it is not finite or beyond what an int32 cell holds.
bool cell_of(float v, float inv_resolution, std::int32_t& out) noexcept {
  const float c = std::floor(v * inv_resolution);
  if (!(std::fabs(c) < 1e9f)) return false;  // NaN and inf fail too
  out = static_cast<std::int32_t>(c);
  return true;
}

}  // namespace

Status TrailGridConfig::validate() const noexcept {
  return all_in_range(*this, params::kTrailGrid) ? Status::kOk : Status::kInvalidArgument;
}

Status TrailGrid::init(const TrailGridConfig& config) noexcept {
  const Status s = config.validate();
  if (!ok(s)) return s;
  config_ = config;
  inv_resolution_ = 1.f / config.resolution;
  clear();
  return Status::kOk;
}

void TrailGrid::clear() noexcept {
  cells_.fill(Cell{});
  frame_ = 1;
}

void TrailGrid::mark(const Box3& box) noexcept {
  std::int32_t x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  if (!cell_of(box.min.x() - config_.margin, inv_resolution_, x0) ||
      !cell_of(box.min.y() - config_.margin, inv_resolution_, y0) ||
      !cell_of(box.max.x() + config_.margin, inv_resolution_, x1) ||
      !cell_of(box.max.y() + config_.margin, inv_resolution_, y1)) {
    return;
  }
  // A box wider than the grid marks the grid once (every cell it could wrap onto).
  x1 = std::min(x1, x0 + kTrailColumns - 1);
  y1 = std::min(y1, y0 + kTrailColumns - 1);
  for (std::int32_t y = y0; y <= y1; ++y) {
    for (std::int32_t x = x0; x <= x1; ++x) cells_[slot(x, y)] = Cell{x, y, frame_};
  }
}

bool TrailGrid::recent(const Eigen::Vector3f& p) const noexcept {
  std::int32_t x = 0, y = 0;
  if (!cell_of(p.x(), inv_resolution_, x) || !cell_of(p.y(), inv_resolution_, y)) return false;
  const Cell& c = cells_[slot(x, y)];
  return c.frame != 0 && c.x == x && c.y == y && frame_ - c.frame < config_.frames;
}

}  // namespace dynamap
