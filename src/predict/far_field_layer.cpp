#include "dynamap/predict/far_field_layer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "dynamap/predict/predict_params.hpp"

namespace dynamap {

Status validate(const FarFieldConfig& c) noexcept {
  return all_in_range(c, params::kFarField) && all_hold(c, params::kFarFieldRelations)
             ? Status::kOk
             : Status::kInvalidArgument;
}

Status FarFieldLayer::init(const FarFieldConfig& config, float ground_height) noexcept {
  if (!ok(validate(config)) || !std::isfinite(ground_height)) return Status::kInvalidArgument;
  config_ = config;
  inv_cell_size_ = 1.0f / config.cell_size;
  ground_height_ = ground_height;
  initialised_ = true;
  reset();
  return Status::kOk;
}

void FarFieldLayer::reset() noexcept {
  for (Cell& c : cells_) c = Cell{};
  frame_ = 0;
  last_hits_ = 0;
  begun_ = false;
}

FarFieldLayer::Cell* FarFieldLayer::cell_for_write(const Eigen::Vector2f& p) noexcept {
  std::int32_t ix = 0;
  std::int32_t iy = 0;
  if (!key(p, &ix, &iy)) return nullptr;
  Cell& c = cells_[slot_of(ix, iy)];
  if (!c.used || c.ix != ix || c.iy != iy) {
    // The rolling window moved on: the slot now holds this cell, with no evidence yet.
    c = Cell{};
    c.ix = ix;
    c.iy = iy;
    c.used = true;
  }
  return &c;
}

int FarFieldLayer::evidence(const Eigen::Vector2f& p) const noexcept {
  const Cell* c = initialised_ ? cell_for_read(p) : nullptr;
  return c == nullptr ? 0 : c->evidence;
}

void FarFieldLayer::add_hit(const Eigen::Vector2f& p) noexcept {
  Cell* c = cell_for_write(p);
  if (c == nullptr) return;
  const int e = std::max(0, static_cast<int>(c->evidence)) + config_.hit_evidence;
  c->evidence = static_cast<std::int8_t>(std::min(e, config_.max_evidence));
  c->last_hit = frame_;
}

namespace {
// A ray passing a cell takes this many frames off its low-surface count: the space was seen
// empty, but a ray grazing a crate's cell from the next column must not undo a second of it.
constexpr std::uint8_t kLowFree = 4;
// Frames a low surface may go unseen in its cell and keep its count: a walker passing in front
// of a crate hides it for a few tenths of a second (half a second at 30 Hz).
constexpr std::uint8_t kLowGap = 15;
}  // namespace

void FarFieldLayer::add_free(const Eigen::Vector2f& from, const Eigen::Vector2f& to) noexcept {
  if (config_.free_evidence == 0) return;
  const Eigen::Vector2f d = to - from;
  const float len = d.norm();
  if (!(len > 0.0f)) return;
  // Half-cell steps: at most 2 * kFarFieldMaxBins cells per column.
  const float step = 0.5f * config_.cell_size;
  const int n = std::min(static_cast<int>(len / step), static_cast<int>(2 * kFarFieldMaxBins));
  const Eigen::Vector2f inc = d * (step / len);
  Eigen::Vector2f p = from;
  std::int32_t last_ix = 0;
  std::int32_t last_iy = 0;
  bool have_last = false;
  for (int k = 0; k <= n; ++k, p += inc) {
    std::int32_t ix = 0;
    std::int32_t iy = 0;
    if (!key(p, &ix, &iy)) continue;
    if (have_last && ix == last_ix && iy == last_iy) continue;  // once per cell and ray
    have_last = true;
    last_ix = ix;
    last_iy = iy;
    Cell* c = cell_for_write(p);
    if (c == nullptr) continue;
    const int e = static_cast<int>(c->evidence) - config_.free_evidence;
    c->evidence = static_cast<std::int8_t>(std::max(e, -config_.max_evidence));
    c->low_count = static_cast<std::uint8_t>(c->low_count > kLowFree ? c->low_count - kLowFree : 0);
  }
}

void FarFieldLayer::add_low_hit(const Eigen::Vector2f& p) noexcept {
  Cell* c = cell_for_write(p);
  if (c == nullptr) return;
  const auto tick = static_cast<std::uint8_t>(frame_ & 0xFFu);
  const auto since = static_cast<std::uint8_t>(tick - c->low_tick);
  if (c->low_count > 0 && since == 0) return;  // once per frame
  c->low_count = (c->low_count > 0 && since <= kLowGap)
                     ? static_cast<std::uint8_t>(std::min(255, static_cast<int>(c->low_count) + 1))
                     : std::uint8_t{1};
  c->low_tick = tick;
  c->last_hit = frame_;
}

namespace {
constexpr float kPi = 3.14159265f;

float wrap_angle(float a) noexcept {
  while (a > kPi) a -= 2.0f * kPi;
  while (a < -kPi) a += 2.0f * kPi;
  return a;
}

// update()'s argument checks (everything but initialisation), before any state changes.
Status check_update_input(const DepthView& depth, const CameraIntrinsics& camera,
                          const Pose& T_map_camera, const FarFieldExclusion* exclusions,
                          std::size_t count) noexcept {
  const Status s = validate_depth(depth, camera);
  if (!ok(s)) return s;
  if (!T_map_camera.translation.allFinite() || !T_map_camera.rotation.coeffs().allFinite()) {
    return Status::kNonFinite;
  }
  if (count > kFarFieldMaxExclusions) return Status::kCapacityExceeded;
  if (count > 0 && exclusions == nullptr) return Status::kNullData;
  for (std::size_t k = 0; k < count; ++k) {
    if (!exclusions[k].centre.allFinite() || !std::isfinite(exclusions[k].radius)) {
      return Status::kNonFinite;
    }
  }
  return Status::kOk;
}
}  // namespace

float FarFieldLayer::sigma(float d) const noexcept {
  return config_.noise_margin + config_.noise_quadratic * d * d;
}

FarFieldLayer::FrameGeometry FarFieldLayer::frame_geometry(const CameraIntrinsics& camera,
                                                           const Pose& T_map_camera,
                                                           const FarFieldExclusion* exclusions,
                                                           std::size_t count) const noexcept {
  const FarFieldConfig& c = config_;
  FrameGeometry g;
  g.camera = &camera;
  g.R = T_map_camera.rotation.toRotationMatrix();
  g.origin = T_map_camera.translation;
  g.o2 = g.origin.head<2>();
  g.z_lo = ground_height_ + c.min_height;
  g.z_hi = ground_height_ + c.max_height;
  g.z_tall = ground_height_ + c.wall_height;
  g.bins =
      std::min(kFarFieldMaxBins, static_cast<std::size_t>(std::ceil(c.max_range / c.cell_size)));
  g.inv_fx = 1.0f / camera.fx;
  g.row_step = g.R.col(1) * (1.0f / camera.fy);
  g.exclusions = exclusions;
  g.count = count;
  const float m_max = sigma(c.max_range);
  for (std::size_t k = 0; k < count; ++k) {
    const Eigen::Vector2f rel = exclusions[k].centre - g.o2;
    const float dist = rel.norm();
    const float reach = std::fabs(exclusions[k].radius) + m_max;
    g.disc_angle[k] = std::atan2(rel.y(), rel.x());
    g.disc_half[k] = dist <= reach ? 4.0f : std::asin(reach / dist);  // 4 > pi: every column
  }
  return g;
}

std::size_t FarFieldLayer::column_discs(const FrameGeometry& g, const Eigen::Vector3f& col_dir,
                                        int height, DiscList& near) const noexcept {
  if (g.count == 0) return 0;
  const Eigen::Vector3f top = col_dir - g.camera->cy * g.row_step;
  const Eigen::Vector3f bottom = col_dir + (static_cast<float>(height) - g.camera->cy) * g.row_step;
  const float a0 = std::atan2(top.y(), top.x());
  const float a1 = std::atan2(bottom.y(), bottom.x());
  const float mid = a0 + 0.5f * wrap_angle(a1 - a0);
  const float span = 0.5f * std::fabs(wrap_angle(a1 - a0));
  std::size_t n_near = 0;
  for (std::size_t k = 0; k < g.count; ++k) {
    if (std::fabs(wrap_angle(g.disc_angle[k] - mid)) <= g.disc_half[k] + span + 0.01f) {
      near[n_near++] = k;
    }
  }
  return n_near;
}

Eigen::Vector2f FarFieldLayer::bin_column(const FrameGeometry& g, const DepthView& depth, int u,
                                          ColumnBins& h) const noexcept {
  const FarFieldConfig& c = config_;
  const CameraIntrinsics& camera = *g.camera;
  const int stride = c.pixel_stride;
  std::fill(h.count.begin(), h.count.begin() + static_cast<std::ptrdiff_t>(g.bins), 0);
  std::fill(h.tall.begin(), h.tall.begin() + static_cast<std::ptrdiff_t>(g.bins), 0);
  for (std::size_t b = 0; b < g.bins; ++b) h.sum[b].setZero();
  const float xn = (static_cast<float>(u) - camera.cx) * g.inv_fx;
  // Map-frame ray direction of pixel (u, v) with unit depth: col_dir + (v - cy) * row_step.
  const Eigen::Vector3f col_dir = g.R.col(0) * xn + g.R.col(2);
  DiscList near_discs{};
  const std::size_t n_near = column_discs(g, col_dir, depth.height, near_discs);
  Eigen::Vector2f beyond(std::numeric_limits<float>::quiet_NaN(), 0.0f);
  for (int v = stride / 2; v < depth.height; v += stride) {
    const std::uint16_t raw = depth.at(u, v);
    if (raw == 0) continue;
    const float d = static_cast<float>(raw) * camera.depth_scale;
    const Eigen::Vector3f p =
        g.origin + d * (col_dir + (static_cast<float>(v) - camera.cy) * g.row_step);
    // Floor and ceiling: the band's edges move in by the depth noise's vertical share, so
    // neither leaks into it.
    const float m = sigma(d);
    const float mz = m * std::fabs(p.z() - g.origin.z()) / d;
    if (p.z() < g.z_lo + mz || p.z() > g.z_hi - mz) continue;
    const bool tall = p.z() >= g.z_tall;
    const Eigen::Vector2f q = p.head<2>();
    const float range = (q - g.o2).norm();
    bool walker = false;
    for (std::size_t j = 0; j < n_near && !walker; ++j) {
      const FarFieldExclusion& e = g.exclusions[near_discs[j]];
      const float r = e.radius + m;
      walker = (q - e.centre).squaredNorm() < r * r;
    }
    if (walker) continue;
    if (!(range < c.max_range)) {
      // A surface beyond the range: the column is seen free out to max_range (unless a
      // nearer surface is found below), which clears what walked through it.
      if (range >= c.max_range) beyond = q;
      continue;
    }
    const std::size_t b = std::min(g.bins - 1, static_cast<std::size_t>(range / c.cell_size));
    if (h.count[b] == 0) {
      h.z_min[b] = p.z();
      h.z_max[b] = p.z();
    } else {
      h.z_min[b] = std::min(h.z_min[b], p.z());
      h.z_max[b] = std::max(h.z_max[b], p.z());
    }
    if (h.count[b] < 0xFFFF) ++h.count[b];
    if (tall && h.tall[b] < 0xFFFF) ++h.tall[b];
    h.sum[b] += q;
  }
  return beyond;
}

std::size_t FarFieldLayer::densest_window(const ColumnBins& h, std::size_t b, std::size_t w,
                                          std::size_t bins) const noexcept {
  std::size_t peak = b;
  int peak_n = -1;
  for (std::size_t k = b; k <= std::min(bins - 1, b + 2 * w); ++k) {
    int m = 0;
    for (std::size_t j = k; j < std::min(bins, k + w); ++j) m += h.count[j];
    if (m > peak_n) {
      peak_n = m;
      peak = k;
    }
  }
  return peak;
}

FarFieldLayer::ColumnSurfaces FarFieldLayer::find_surfaces(
    const FrameGeometry& g, const ColumnBins& h, const Eigen::Vector2f& beyond) const noexcept {
  const FarFieldConfig& c = config_;
  const float bin = c.cell_size;
  const std::size_t bins = g.bins;
  ColumnSurfaces s;
  s.beyond = beyond;
  // The first two surfaces of the column: the nearest window of range bins, as wide as the
  // noise at that range, holding at least min_pixels points.
  std::size_t b = 0;
  while (b < bins && s.count < 2) {
    const float r_b = (static_cast<float>(b) + 0.5f) * bin;
    const std::size_t w =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(sigma(r_b) / bin)));
    int n = 0;
    for (std::size_t k = b; k < std::min(bins, b + w); ++k) n += h.count[k];
    if (n < c.min_pixels) {
      ++b;
      continue;
    }
    // The noise spreads a surface along the ray, and its near tail triggers first: the
    // surface is the densest window in the next two windows, and its position the centroid of
    // the points in that window (a wider one would mix in a walker just in front of a wall).
    const std::size_t lo = densest_window(h, b, w, bins);
    const std::size_t end = std::min(bins, lo + w);
    int total = 0;
    int tall = 0;
    Eigen::Vector2f sum = Eigen::Vector2f::Zero();
    float z_min = std::numeric_limits<float>::infinity();
    float z_max = -std::numeric_limits<float>::infinity();
    for (std::size_t k = lo; k < end; ++k) {
      total += h.count[k];
      tall += h.tall[k];
      sum += h.sum[k];
      if (h.count[k] == 0) continue;
      z_min = std::min(z_min, h.z_min[k]);
      z_max = std::max(z_max, h.z_max[k]);
    }
    const Eigen::Vector2f centroid = sum / static_cast<float>(total);
    // Returns at nearly one height are a horizontal surface seen edge-on (a ceiling within the
    // band), whose noise bunches a few returns into one window: it ends the free ray, but it
    // is no wall.
    const float range = std::max((centroid - g.o2).norm(), bin);
    const float rise = std::max(std::fabs(z_max - g.origin.z()), std::fabs(z_min - g.origin.z()));
    const bool flat = z_max - z_min < c.min_rise_sigmas * sigma(range) * rise / range;
    const auto i = static_cast<std::size_t>(s.count++);
    s.hit[i] = centroid;
    s.kind[i] = flat ? SurfaceKind::kFlat : (tall > 0 ? SurfaceKind::kTall : SurfaceKind::kLow);
    // The far tail of this surface is not a second one.
    b = end + 2 * w;
  }
  return s;
}

void FarFieldLayer::mark_column(const FrameGeometry& g, const ColumnSurfaces& s) noexcept {
  for (int i = 0; i < s.count; ++i) {
    const auto k = static_cast<std::size_t>(i);
    mark_surface(g.o2, s.hit[k], i == 0, s.kind[k]);
  }
  if (s.count == 0 && std::isfinite(s.beyond.x())) {
    const Eigen::Vector2f ray = s.beyond - g.o2;
    add_free(g.o2, g.o2 + ray * (config_.max_range / ray.norm()));
  }
}

void FarFieldLayer::mark_surface(const Eigen::Vector2f& o2, const Eigen::Vector2f& hit, bool first,
                                 SurfaceKind kind) noexcept {
  const Eigen::Vector2f ray = hit - o2;
  const float range = ray.norm();
  if (first && range > 0.0f) {
    // Seen free up to the surface, less half its noise and a cell.
    const float free_to = range - 0.5f * sigma(range) - config_.cell_size;
    if (free_to > 0.0f) add_free(o2, o2 + ray * (free_to / range));
  }
  // A surface taller than a person is a wall at once; a lower one only once it stayed, so
  // walkers the tracker has not (yet) got leave no remembered trail. Both end the free ray.
  if (range < config_.hit_min_range) return;
  if (kind == SurfaceKind::kTall) {
    add_hit(hit);
    ++last_hits_;
  } else if (kind == SurfaceKind::kLow && config_.low_frames > 0) {
    add_low_hit(hit);
  }
}

Status FarFieldLayer::update(const DepthView& depth, const CameraIntrinsics& camera,
                             const Pose& T_map_camera, const FarFieldExclusion* exclusions,
                             std::size_t count) noexcept {
  const Status s = begin_update(depth, camera, T_map_camera, exclusions, count);
  if (!ok(s)) return s;
  bin_columns(0, 1);
  finish_update();
  return Status::kOk;
}

Status FarFieldLayer::begin_update(const DepthView& depth, const CameraIntrinsics& camera,
                                   const Pose& T_map_camera, const FarFieldExclusion* exclusions,
                                   std::size_t count) noexcept {
  if (!initialised_) return Status::kNotInitialized;
  const Status s = check_update_input(depth, camera, T_map_camera, exclusions, count);
  if (!ok(s)) return s;
  geometry_ = frame_geometry(camera, T_map_camera, exclusions, count);
  depth_ = depth;
  const int stride = config_.pixel_stride;
  columns_ = static_cast<std::size_t>((depth.width - stride / 2 + stride - 1) / stride);
  begun_ = true;
  return Status::kOk;
}

void FarFieldLayer::bin_columns(unsigned part, unsigned parts) noexcept {
  if (!begun_ || parts < 1 || parts > kFarFieldMaxBinParts || part >= parts) return;
  // Contiguous column ranges: neighbouring columns share the image's cache lines.
  const std::size_t first = columns_ * part / parts;
  const std::size_t end = columns_ * (part + 1) / parts;
  const int stride = config_.pixel_stride;
  ColumnBins& h = bins_[part];
  for (std::size_t i = first; i < end; ++i) {
    const int u = stride / 2 + static_cast<int>(i) * stride;
    const Eigen::Vector2f beyond = bin_column(geometry_, depth_, u, h);
    surfaces_[i] = find_surfaces(geometry_, h, beyond);
  }
}

void FarFieldLayer::finish_update() noexcept {
  if (!begun_) return;
  begun_ = false;
  ++frame_;
  last_hits_ = 0;
  for (std::size_t i = 0; i < columns_; ++i) mark_column(geometry_, surfaces_[i]);
}

}  // namespace dynamap
