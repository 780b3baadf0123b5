#include "dynamap/map/ever_free_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dynamap/map/map_params.hpp"

namespace dynamap {

namespace {

constexpr int kColumnMask = kEverFreeColumns - 1;
static_assert((kEverFreeColumns & kColumnMask) == 0, "column count must be a power of two");
/// Largest horizontal box extent (cells per axis) ever_free_share examines.
constexpr int kMaxQueryCells = 24;
/// Coordinates beyond this (m) are not keyed (the int conversion would overflow long before).
constexpr float kMaxCoordinate = 1.0e5f;

}  // namespace

Status EverFreeConfig::validate() const noexcept {
  // whole_in_view names pairs of sides: one side or three would be a lopsided view.
  const bool sides = whole_in_view == 0 || whole_in_view == 2 || whole_in_view == 4;
  return sides && all_in_range(*this, params::kEverFree) ? Status::kOk : Status::kInvalidArgument;
}

Status EverFreeGrid::init(const EverFreeConfig& config, float ground_height) noexcept {
  if (!ok(config.validate()) || !std::isfinite(ground_height)) return Status::kInvalidArgument;
  config_ = config;
  z0_ = ground_height + config.z_min;
  inv_res_ = 1.f / config.resolution;
  clear();
  return Status::kOk;
}

void EverFreeGrid::clear() noexcept {
  for (ColumnTag& t : tags_) t.valid = false;
  frame_ = 0;
}

bool EverFreeGrid::key_of(const Eigen::Vector3f& p, int* kx, int* ky, int* kz) const noexcept {
  if (!(std::fabs(p.x()) < kMaxCoordinate && std::fabs(p.y()) < kMaxCoordinate)) return false;
  const float z = (p.z() - z0_) * inv_res_;
  if (!(z >= 0.f && z < static_cast<float>(config_.layers))) return false;
  *kx = static_cast<int>(std::floor(p.x() * inv_res_));
  *ky = static_cast<int>(std::floor(p.y() * inv_res_));
  *kz = static_cast<int>(z);
  return true;
}

EverFreeGrid::Cell* EverFreeGrid::cell(int kx, int ky, int kz, bool claim) noexcept {
  const std::size_t column =
      static_cast<std::size_t>(ky & kColumnMask) * static_cast<std::size_t>(kEverFreeColumns) +
      static_cast<std::size_t>(kx & kColumnMask);
  ColumnTag& tag = tags_[column];
  if (!tag.valid || tag.x != kx || tag.y != ky) {
    if (!claim) return nullptr;
    tag = ColumnTag{kx, ky, true};
    Cell* first = &cells_[column * kEverFreeMaxLayers];
    for (int z = 0; z < kEverFreeMaxLayers; ++z) first[z] = Cell{};
  }
  return &cells_[column * kEverFreeMaxLayers + static_cast<std::size_t>(kz)];
}

const EverFreeGrid::Cell* EverFreeGrid::cell(int kx, int ky, int kz) const noexcept {
  const std::size_t column =
      static_cast<std::size_t>(ky & kColumnMask) * static_cast<std::size_t>(kEverFreeColumns) +
      static_cast<std::size_t>(kx & kColumnMask);
  const ColumnTag& tag = tags_[column];
  if (!tag.valid || tag.x != kx || tag.y != ky) return nullptr;
  return &cells_[column * kEverFreeMaxLayers + static_cast<std::size_t>(kz)];
}

void EverFreeGrid::mark_hit(const Eigen::Vector3f& p) noexcept {
  int kx = 0, ky = 0, kz = 0;
  if (!key_of(p, &kx, &ky, &kz)) return;
  Cell* c = cell(kx, ky, kz, true);
  if (c->frame == frame_ && (c->flags & kHit) != 0) return;
  c->frame = frame_;
  c->flags = static_cast<std::uint8_t>(c->flags | kHit);
  c->free_run = 0;
  c->flags = static_cast<std::uint8_t>(c->flags & ~kWhole);
  if (c->hit_run < 255) ++c->hit_run;
  if (c->hit_run >= config_.forget_frames) c->flags = static_cast<std::uint8_t>(c->flags & ~kEver);
  block_neighbours(kx, ky, kz);
}

void EverFreeGrid::block_neighbours(int kx, int ky, int kz) noexcept {
  // Rays passing beside a static surface see the rest of its cell, and the cells next to it,
  // empty: a surface keeps the free run of its horizontal neighbours at zero, so only space
  // nothing has been seen in or next to becomes ever free.
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (dx == 0 && dy == 0) continue;
      Cell* n = cell(kx + dx, ky + dy, kz, true);
      n->free_run = 0;
      n->flags = static_cast<std::uint8_t>(n->flags & ~kWhole);
    }
  }
}

bool EverFreeGrid::inside_view(int kx, int ky, int kz) const noexcept {
  const float r = config_.resolution;
  const Eigen::Vector3f centre((static_cast<float>(kx) + 0.5f) * r,
                               (static_cast<float>(ky) + 0.5f) * r,
                               z0_ + (static_cast<float>(kz) + 0.5f) * r);
  const Eigen::Vector3f d = centre - view_origin_;
  for (int i = 0; i < view_planes_; ++i) {
    if (view_normals_[static_cast<std::size_t>(i)].dot(d) <
        view_reach_[static_cast<std::size_t>(i)])
      return false;
  }
  return true;
}

void EverFreeGrid::mark_free(int kx, int ky, int kz) noexcept {
  if (kz < 0 || kz >= config_.layers) return;
  Cell* c = cell(kx, ky, kz, true);
  if (c->frame == frame_) return;  // hit (or already counted) this frame
  c->frame = frame_;
  c->flags = static_cast<std::uint8_t>(c->flags & ~kHit);
  c->hit_run = 0;
  if (c->free_run < 255) ++c->free_run;
  // A cell the view's side cuts may hold something just beyond the border: its run counts once
  // the whole cell has been seen free.
  if ((c->flags & kWhole) == 0 && (view_planes_ == 0 || inside_view(kx, ky, kz))) {
    c->flags = static_cast<std::uint8_t>(c->flags | kWhole);
  }
  if (c->free_run >= config_.burn_in_frames && (c->flags & kWhole) != 0) {
    c->flags = static_cast<std::uint8_t>(c->flags | kEver);
  }
}

void EverFreeGrid::walk_free(const Eigen::Vector3f& from, const Eigen::Vector3f& to) noexcept {
  // Amanatides-Woo over the cells from `from` to `to`, in cell units.
  const Eigen::Vector3f origin(0.f, 0.f, z0_);
  const Eigen::Vector3f a = (from - origin) * inv_res_;
  const Eigen::Vector3f b = (to - origin) * inv_res_;
  const Eigen::Vector3f d = b - a;
  int c[3];
  int step[3];
  float t_max[3];
  float t_delta[3];
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 3; ++i) {
    const float fc = std::floor(a[i]);
    c[i] = static_cast<int>(fc);
    step[i] = d[i] > 0.f ? 1 : (d[i] < 0.f ? -1 : 0);
    t_delta[i] = step[i] != 0 ? 1.f / std::fabs(d[i]) : kInf;
    t_max[i] = step[i] > 0 ? (fc + 1.f - a[i]) / d[i] : (step[i] < 0 ? (a[i] - fc) / -d[i] : kInf);
  }
  const int max_steps = 3 * static_cast<int>(std::ceil(config_.max_range * inv_res_)) + 3;
  for (int n = 0; n < max_steps; ++n) {
    mark_free(c[0], c[1], c[2]);
    const int axis =
        t_max[0] < t_max[1] ? (t_max[0] < t_max[2] ? 0 : 2) : (t_max[1] < t_max[2] ? 1 : 2);
    if (t_max[axis] > 1.f) break;
    c[axis] += step[axis];
    t_max[axis] += t_delta[axis];
  }
}

void EverFreeGrid::set_view_planes(const DepthView& depth, const CameraIntrinsics& cam,
                                   const Eigen::Matrix3f& R, const Eigen::Vector3f& t) noexcept {
  // The image's outer pixel edges, as rays x/z = a (columns) and y/z = b (rows) in the camera
  // frame; each side plane holds the camera and one of them, its normal pointing into the view.
  const float left = (-0.5f - cam.cx) / cam.fx;
  const float right = (static_cast<float>(depth.width) - 0.5f - cam.cx) / cam.fx;
  const float top = (-0.5f - cam.cy) / cam.fy;
  const float bottom = (static_cast<float>(depth.height) - 0.5f - cam.cy) / cam.fy;
  const Eigen::Vector3f normals[4] = {
      Eigen::Vector3f(1.f, 0.f, -left), Eigen::Vector3f(-1.f, 0.f, right),
      Eigen::Vector3f(0.f, 1.f, -top), Eigen::Vector3f(0.f, -1.f, bottom)};
  view_planes_ = config_.whole_in_view;  // 0, 2 or 4 (validate())
  view_origin_ = t;
  const float half = 0.5f * config_.resolution;
  for (int i = 0; i < view_planes_; ++i) {
    const Eigen::Vector3f n = R * normals[i].normalized();
    view_normals_[static_cast<std::size_t>(i)] = n;
    view_reach_[static_cast<std::size_t>(i)] = half * n.cwiseAbs().sum();
  }
}

Status EverFreeGrid::integrate(const DepthView& depth, const CameraIntrinsics& cam,
                               const Pose& T_map_camera) noexcept {
  if (depth.data == nullptr) return Status::kNullData;
  if (!T_map_camera.translation.allFinite() || !T_map_camera.rotation.coeffs().allFinite()) {
    return Status::kNonFinite;
  }
  if (!config_.enabled) return Status::kOk;
  frame_ = frame_ == 255 ? 1 : static_cast<std::uint8_t>(frame_ + 1);
  const int s = config_.pixel_step;
  const Eigen::Matrix3f R = T_map_camera.rotation.toRotationMatrix();
  const Eigen::Vector3f& t = T_map_camera.translation;
  set_view_planes(depth, cam, R, t);
  // Two passes over the same rays: every hit of the frame first, so a cell some ray ends in is
  // not also counted free by a ray passing it in the same frame.
  for (int pass = 0; pass < 2; ++pass) {
    for (int v = s / 2; v < depth.height; v += s) {
      const std::uint16_t* row = depth.row(v);
      for (int u = s / 2; u < depth.width; u += s) {
        if (row[u] == 0) continue;
        const float z = static_cast<float>(row[u]) * cam.depth_scale;
        const Eigen::Vector3f ray_cam((static_cast<float>(u) - cam.cx) / cam.fx,
                                      (static_cast<float>(v) - cam.cy) / cam.fy, 1.f);
        const float range = z * ray_cam.norm();
        const Eigen::Vector3f dir = R * ray_cam.normalized();
        if (pass == 0) {
          if (range <= config_.max_range) mark_hit(t + range * dir);
          continue;
        }
        // Short of the surface by the depth noise, and never past max_range: a wall just beyond
        // it must not make its own near cells free.
        const float margin = config_.surface_margin + config_.margin_per_range2 * range * range;
        const float reach = std::min(config_.max_range, range - margin);
        if (reach > 0.f) walk_free(t, t + reach * dir);
      }
    }
  }
  return Status::kOk;
}

float EverFreeGrid::ever_free_share(const Box3& box) const noexcept {
  if (!config_.enabled || !box.min.allFinite() || !box.max.allFinite()) return 0.f;
  int x0 = 0, y0 = 0, z0 = 0, x1 = 0, y1 = 0, z1 = 0;
  const Eigen::Vector3f lo(box.min.x(), box.min.y(), std::max(box.min.z(), z0_));
  const float top = z0_ + static_cast<float>(config_.layers) * config_.resolution;
  const Eigen::Vector3f hi(box.max.x(), box.max.y(), std::min(box.max.z(), top - 1e-4f));
  if (!key_of(lo, &x0, &y0, &z0) || !key_of(hi, &x1, &y1, &z1)) return 0.f;
  x1 = std::min(x1, x0 + kMaxQueryCells - 1);
  y1 = std::min(y1, y0 + kMaxQueryCells - 1);
  int hit = 0;
  int ever = 0;
  for (int kx = x0; kx <= x1; ++kx) {
    for (int ky = y0; ky <= y1; ++ky) {
      for (int kz = z0; kz <= z1; ++kz) {
        const Cell* c = cell(kx, ky, kz);
        if (c == nullptr || c->frame != frame_ || (c->flags & kHit) == 0) continue;
        ++hit;
        if ((c->flags & kEver) != 0) ++ever;
      }
    }
  }
  return hit >= 2 ? static_cast<float>(ever) / static_cast<float>(hit) : 0.f;
}

void EverFreeGrid::annotate(Detection* dets, std::size_t count) const noexcept {
  for (std::size_t i = 0; i < count; ++i) dets[i].ever_free = ever_free_share(dets[i].raw_box);
}

bool EverFreeGrid::ever_free_at(const Eigen::Vector3f& p) const noexcept {
  int kx = 0, ky = 0, kz = 0;
  if (!key_of(p, &kx, &ky, &kz)) return false;
  const Cell* c = cell(kx, ky, kz);
  return c != nullptr && (c->flags & kEver) != 0;
}

}  // namespace dynamap
