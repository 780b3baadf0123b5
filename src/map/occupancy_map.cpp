// OccupancyMap: set-up, the input checks and the integration steps (the work is the
// integrator's, detail::MapIntegrator); the queries are in occupancy_map_queries.cpp.
#include "dynamap/map/occupancy_map.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>

#include "dynamap/map/map_params.hpp"

namespace dynamap {
namespace {

inline std::int16_t quantize(float log_odds) noexcept {
  return static_cast<std::int16_t>(std::lround(log_odds * OccupancyMap::kLogOddsScale));
}

inline float logit(float p) noexcept {
  return std::log(p / (1.f - p));
}

inline bool finite_positive(float x) noexcept {
  return std::isfinite(x) && x > 0.f;
}

}  // namespace

OccupancyMap::OccupancyMap() noexcept = default;

namespace {

// Every rule init() applies to a configuration on its own: the ranges of params::kOccupancyMap,
// then the relations of params::kOccupancyMapRelations (PipelineConfig's validate() names them).
bool config_valid(const OccupancyMapConfig& c) noexcept {
  if (!all_in_range(c, params::kOccupancyMap)) return false;
  if (!all_hold(c, params::kOccupancyMapRelations)) return false;
  // The clamp range must fit int16 next to the kUnknown sentinel (the ranges of prob_min and
  // prob_max already keep |logit| below 17; a guard for the quantisation, not a user rule).
  return std::fabs(logit(c.prob_min)) <= 30.f && std::fabs(logit(c.prob_max)) <= 30.f;
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
