#include "dynamap/detect/detection_refiner.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dynamap/detect/detect_params.hpp"
#include "pixel_footprint.hpp"

namespace dynamap {

namespace {

Box3 box_union(const Box3& a, const Box3& b) noexcept {
  return Box3{a.min.cwiseMin(b.min), a.max.cwiseMax(b.max)};
}

ImageBox image_union(const ImageBox& a, const ImageBox& b) noexcept {
  if (a.u1 < a.u0 || a.v1 < a.v0) return b;  // empty / unknown
  if (b.u1 < b.u0 || b.v1 < b.v0) return a;
  return ImageBox{std::min(a.u0, b.u0), std::min(a.v0, b.v0), std::max(a.u1, b.u1),
                  std::max(a.v1, b.v1)};
}

// Depth margin (m) around a detection's depth extent: its pixels' depth noise.
constexpr float kBandMargin = 0.1f;
// Each side of a split along the ray holds at least this share of the detection's pixels, and a
// depth cell holding at most kEmptyShare of them counts as empty (flying pixels at silhouettes).
constexpr float kMinPartShare = 0.1f;
constexpr float kEmptyShare = 0.01f;
// The column profile is averaged over this width (m): a few centimetres of arm or flying pixels
// between two people should not hide the minimum, nor one thin column make one.
constexpr float kProfileSmoothing = 0.05f;
// Rows read for a detection's split decision (its parts are measured from every row).
constexpr int kProfileRows = 48;
// A part whose bottom is this close above the floor cut (m) stands on the floor.
constexpr float kFloorContact = 0.1f;
// A part's rows must hold in-band pixels in this share of its columns (the detector's row fill).
constexpr float kRowFill = 0.2f;

}  // namespace

Status DetectionRefinerConfig::validate() const noexcept {
  return all_in_range(*this, params::kDetectionRefiner) ? Status::kOk : Status::kInvalidArgument;
}

Status DetectionRefiner::init(const DetectionRefinerConfig& config, float floor_top) noexcept {
  const Status s = config.validate();
  if (!ok(s)) return s;
  if (std::isnan(floor_top)) return Status::kInvalidArgument;
  config_ = config;
  floor_top_ = floor_top;
  return Status::kOk;
}

bool DetectionRefiner::joinable(const Detection& a, const Detection& b) const noexcept {
  const Box3& p = a.raw_box;
  const Box3& q = b.raw_box;
  for (int axis = 0; axis < 2; ++axis) {
    const float gap = std::max(p.min[axis] - q.max[axis], q.min[axis] - p.max[axis]);
    if (gap > config_.max_gap) return false;
  }
  const Box3 joined = box_union(p, q);
  return std::max(joined.size().x(), joined.size().y()) <= config_.max_footprint;
}

std::size_t DetectionRefiner::join(DetectionList& dets) const noexcept {
  if (!config_.join_fragments) return 0;
  std::size_t joins = 0;
  // Each join removes one detection, so the scan runs at most kMaxDetections times.
  bool joined = true;
  while (joined) {
    joined = false;
    for (std::size_t i = 0; i < dets.size() && !joined; ++i) {
      for (std::size_t j = i + 1; j < dets.size() && !joined; ++j) {
        if (!joinable(dets[i], dets[j])) continue;
        Detection& a = dets[i];
        const Detection& b = dets[j];
        a.box = box_union(a.box, b.box);
        a.raw_box = box_union(a.raw_box, b.raw_box);
        a.image_box = image_union(a.image_box, b.image_box);
        a.near_depth = std::min(a.near_depth, b.near_depth);
        a.refined = a.refined && b.refined;
        for (std::size_t k = j + 1; k < dets.size(); ++k) dets[k - 1] = dets[k];
        dets.pop_back();
        ++joins;
        joined = true;
      }
    }
  }
  return joins;
}

bool DetectionRefiner::region_of(const Detection& d, const DepthView& depth,
                                 const CameraIntrinsics& cam, const Pose& T_map_camera,
                                 PixelRegion* r) const noexcept {
  const ImageBox& ib = d.image_box;
  r->u0 = std::max(ib.u0, 0);
  r->v0 = std::max(ib.v0, 0);
  r->u1 = std::min(ib.u1, depth.width - 1);
  r->v1 = std::min(ib.v1, depth.height - 1);
  if (r->u1 < r->u0 || r->v1 < r->v0 || !(d.near_depth > 0.f)) return false;
  // Depth band: from the nearest surface to the raw box's farthest corner in the camera frame.
  const Eigen::Matrix3f Rt = T_map_camera.rotation.toRotationMatrix().transpose();
  float far = d.near_depth;
  for (int c = 0; c < 8; ++c) {
    const Eigen::Vector3f p((c & 1) ? d.raw_box.max.x() : d.raw_box.min.x(),
                            (c & 2) ? d.raw_box.max.y() : d.raw_box.min.y(),
                            (c & 4) ? d.raw_box.max.z() : d.raw_box.min.z());
    far = std::max(far, (Rt * (p - T_map_camera.translation)).z());
  }
  far = std::min(far, d.near_depth + kSplitDepthCell * static_cast<float>(kSplitDepthCells) -
                          2.f * kBandMargin);
  const float lo = std::max(d.near_depth - kBandMargin, 0.f) / cam.depth_scale;
  const float hi = (far + kBandMargin) / cam.depth_scale;
  if (!(hi < 65535.f)) return false;
  r->lo = static_cast<std::uint32_t>(std::max(lo, 1.f));
  r->hi = static_cast<std::uint32_t>(hi);
  // Most detections are one person: neither wide enough at their farthest depth nor deep
  // enough to hold the gap, so their pixels are not read at all.
  const float cols = static_cast<float>(r->u1 - r->u0 + 1);
  const bool wide = cols * (far + kBandMargin) / cam.fx > config_.split_width;
  const bool deep = far - d.near_depth >= config_.split_depth_gap;
  return r->hi > r->lo && (wide || deep);
}

void DetectionRefiner::floor_test(const CameraIntrinsics& cam, const Pose& T_map_camera,
                                  const PixelRegion& r) noexcept {
  // Map height of a pixel: t.z + depth * (R.row(2) . ((u - cx) / fx, (v - cy) / fy, 1)).
  const Eigen::Matrix3f R = T_map_camera.rotation.toRotationMatrix();
  floor_base_ = T_map_camera.translation.z();
  for (int u = r.u0; u <= r.u1; ++u) {
    col_slope_[static_cast<std::size_t>(u)] =
        R(2, 0) * (static_cast<float>(u) - cam.cx) / cam.fx * cam.depth_scale;
  }
  for (int v = r.v0; v <= r.v1; ++v) {
    row_slope_[static_cast<std::size_t>(v)] =
        (R(2, 1) * (static_cast<float>(v) - cam.cy) / cam.fy + R(2, 2)) * cam.depth_scale;
  }
}

bool DetectionRefiner::above_floor(int u, int v, std::uint32_t d) const noexcept {
  const float slope =
      col_slope_[static_cast<std::size_t>(u)] + row_slope_[static_cast<std::size_t>(v)];
  return floor_base_ + static_cast<float>(d) * slope >= floor_top_;
}

void DetectionRefiner::profile(const DepthView& depth, const CameraIntrinsics& cam,
                               const PixelRegion& r) noexcept {
  std::fill(col_count_.begin() + r.u0, col_count_.begin() + r.u1 + 1, std::uint16_t{0});
  depth_hist_.fill(0);
  region_pixels_ = 0;
  region_depth_sum_ = 0;
  const auto cell = std::max<std::uint32_t>(
      1u, static_cast<std::uint32_t>(std::lround(kSplitDepthCell / cam.depth_scale)));
  // Evenly spaced rows, at most kProfileRows of them: the shares and ratios the tests use do
  // not need every row, and wide background boxes (walls, tables) are read on every frame.
  const int step = std::max(1, (r.v1 - r.v0 + kProfileRows) / kProfileRows);
  for (int v = r.v0; v <= r.v1; v += step) {
    const std::uint16_t* row = depth.row(v);
    for (int u = r.u0; u <= r.u1; ++u) {
      const std::uint32_t d = row[u];
      if (d < r.lo || d > r.hi || !above_floor(u, v, d)) continue;
      const auto ui = static_cast<std::size_t>(u);
      col_count_[ui] = static_cast<std::uint16_t>(col_count_[ui] + 1);
      ++region_pixels_;
      region_depth_sum_ += d;
      ++depth_hist_[std::min<std::size_t>((d - r.lo) / cell, kSplitDepthCells - 1)];
    }
  }
}

bool DetectionRefiner::split_across(const PixelRegion& r, const CameraIntrinsics& cam,
                                    PixelRegion* a, PixelRegion* b) noexcept {
  // Columns to metres at the region's mean depth; only groups wider than one person.
  const float z = static_cast<float>(static_cast<double>(region_depth_sum_) /
                                     static_cast<double>(region_pixels_)) *
                  cam.depth_scale;
  const float cols_per_m = cam.fx / z;
  if (static_cast<float>(r.u1 - r.u0 + 1) <= config_.split_width * cols_per_m) return false;
  const int half = std::max(1, static_cast<int>(0.5f * kProfileSmoothing * cols_per_m));
  const int min_part =
      std::max(1, static_cast<int>(std::ceil(config_.split_min_part * cols_per_m)));
  if (r.u0 + min_part > r.u1 - min_part) return false;
  col_prefix_[static_cast<std::size_t>(r.u0)] = 0;
  for (int u = r.u0; u <= r.u1; ++u) {
    const auto ui = static_cast<std::size_t>(u);
    col_prefix_[ui + 1] = col_prefix_[ui] + col_count_[ui];
  }
  const auto smoothed = [&](int u) {
    const int lo = std::max(u - half, r.u0), hi = std::min(u + half, r.u1);
    const std::uint32_t n =
        col_prefix_[static_cast<std::size_t>(hi) + 1] - col_prefix_[static_cast<std::size_t>(lo)];
    return static_cast<float>(n) / static_cast<float>(hi - lo + 1);
  };
  int cut = -1;
  float cut_value = std::numeric_limits<float>::max();
  for (int u = r.u0 + min_part; u <= r.u1 - min_part; ++u) {
    const float s = smoothed(u);
    if (s < cut_value) {
      cut_value = s;
      cut = u;
    }
  }
  float left_peak = 0.f, right_peak = 0.f;
  for (int u = r.u0; u <= cut; ++u) left_peak = std::max(left_peak, smoothed(u));
  for (int u = cut; u <= r.u1; ++u) right_peak = std::max(right_peak, smoothed(u));
  const float low_peak = std::min(left_peak, right_peak);
  if (cut_value > config_.split_dip * low_peak) return false;
  // Cut in the middle of the valley (the stretch of arms or background between two people),
  // not at its deepest column, which noise and the smoothing place anywhere in it.
  const float floor_level = cut_value + 0.25f * (low_peak - cut_value);
  int lo = cut, hi = cut;
  while (lo > r.u0 + min_part && smoothed(lo - 1) <= floor_level) --lo;
  while (hi < r.u1 - min_part && smoothed(hi + 1) <= floor_level) ++hi;
  cut = (lo + hi) / 2;
  *a = r;
  *b = r;
  a->u1 = cut;
  b->u0 = cut + 1;
  return true;
}

bool DetectionRefiner::split_along(const PixelRegion& r, const CameraIntrinsics& cam,
                                   PixelRegion* a, PixelRegion* b) const noexcept {
  // The first run of (almost) empty depth cells at least split_depth_gap long with enough of
  // the pixels on either side: one person behind another, joined by flying pixels or an arm.
  const auto cell = std::max<std::uint32_t>(
      1u, static_cast<std::uint32_t>(std::lround(kSplitDepthCell / cam.depth_scale)));
  const auto gap_cells =
      static_cast<std::size_t>(std::ceil(config_.split_depth_gap / kSplitDepthCell - 1e-3f));
  const auto total = static_cast<float>(region_pixels_);
  const auto empty = static_cast<std::uint32_t>(kEmptyShare * total);
  std::uint32_t before = 0;
  std::size_t run = 0;
  for (std::size_t c = 0; c < kSplitDepthCells; ++c) {
    if (depth_hist_[c] <= empty) {
      ++run;
      continue;
    }
    if (run >= gap_cells && static_cast<float>(before) >= kMinPartShare * total) {
      const std::uint32_t after = region_pixels_ - before;
      if (static_cast<float>(after) >= kMinPartShare * total) {
        *a = r;
        *b = r;
        a->hi = r.lo + static_cast<std::uint32_t>(c - run) * cell - 1u;
        b->lo = r.lo + static_cast<std::uint32_t>(c) * cell;
        return a->hi > a->lo && b->hi > b->lo;
      }
    }
    // Pixels in a short empty run still count for the near side.
    for (std::size_t k = c - run; k <= c; ++k) before += depth_hist_[k];
    run = 0;
  }
  return false;
}

bool DetectionRefiner::sum_part(const DepthView& depth, const PixelRegion& r, int* pu0,
                                int* pu1) noexcept {
  // Per-column and per-row pixel counts, depth sums and moments of the part's pixels; the
  // columns [pu0, pu1] that hold any.
  for (int u = r.u0; u <= r.u1; ++u) {
    const auto ui = static_cast<std::size_t>(u);
    col_count_[ui] = 0;
    col_depth_sum_[ui] = 0;
    col_vdepth_sum_[ui] = 0;
  }
  *pu0 = r.u1;
  *pu1 = r.u0;
  for (int v = r.v0; v <= r.v1; ++v) {
    const std::uint16_t* row = depth.row(v);
    std::uint32_t n = 0, sum = 0;
    std::uint64_t usum = 0;
    for (int u = r.u0; u <= r.u1; ++u) {
      const std::uint32_t d = row[u];
      if (d < r.lo || d > r.hi || !above_floor(u, v, d)) continue;
      const auto ui = static_cast<std::size_t>(u);
      col_count_[ui] = static_cast<std::uint16_t>(col_count_[ui] + 1);
      col_depth_sum_[ui] += d;
      col_vdepth_sum_[ui] += static_cast<std::uint64_t>(d) * static_cast<std::uint32_t>(v);
      ++n;
      sum += d;
      usum += static_cast<std::uint64_t>(d) * static_cast<std::uint32_t>(u);
      *pu0 = std::min(*pu0, u);
      *pu1 = std::max(*pu1, u);
    }
    const auto vi = static_cast<std::size_t>(v);
    row_count_[vi] = static_cast<std::uint16_t>(n);
    row_depth_sum_[vi] = sum;
    row_udepth_sum_[vi] = usum;
  }
  return *pu1 >= *pu0;
}

bool DetectionRefiner::measure(const DepthView& depth, const CameraIntrinsics& cam,
                               const Pose& T_map_camera, const PixelRegion& r,
                               Detection* out) noexcept {
  // As the detector measures its boxes (umap_detector.md): every column (row) of the part at the
  // mean map-frame point of its in-band pixels, so flying pixels do not stretch the box.
  int pu0 = 0, pu1 = -1;
  if (!sum_part(depth, r, &pu0, &pu1)) return false;
  const float big = std::numeric_limits<float>::max();
  const Eigen::Matrix3f R = T_map_camera.rotation.toRotationMatrix();
  const Eigen::Vector3f& t = T_map_camera.translation;
  Eigen::Vector3f mn = Eigen::Vector3f::Constant(big), mx = Eigen::Vector3f::Constant(-big);
  float z_near = big;
  for (int u = pu0; u <= pu1; ++u) {
    const auto ui = static_cast<std::size_t>(u);
    if (col_count_[ui] == 0) continue;
    const float z = static_cast<float>(col_depth_sum_[ui]) / static_cast<float>(col_count_[ui]) *
                    cam.depth_scale;
    const float v_mean = static_cast<float>(static_cast<double>(col_vdepth_sum_[ui]) /
                                            static_cast<double>(col_depth_sum_[ui]));
    detail::grow_by_column(cam, R, t, u, z, v_mean, mn, mx);
    z_near = std::min(z_near, z);
  }
  const auto min_row =
      static_cast<std::uint32_t>(std::max(1.f, kRowFill * static_cast<float>(pu1 - pu0 + 1)));
  int pv0 = r.v1, pv1 = r.v0;
  for (int v = r.v0; v <= r.v1; ++v) {
    const auto vi = static_cast<std::size_t>(v);
    if (row_count_[vi] < min_row) continue;
    const float z = static_cast<float>(row_depth_sum_[vi]) / static_cast<float>(row_count_[vi]) *
                    cam.depth_scale;
    const float u_mean = static_cast<float>(static_cast<double>(row_udepth_sum_[vi]) /
                                            static_cast<double>(row_depth_sum_[vi]));
    detail::grow_by_row(cam, R, t, v, z, u_mean, mn.z(), mx.z());
    pv0 = std::min(pv0, v);
    pv1 = std::max(pv1, v);
  }
  if (pv1 < pv0) return false;
  // Floor pixels were left out, so a part standing on the floor ends just above it: it keeps
  // its group's bottom, as the detector measures a person down to the feet.
  if (mn.z() <= floor_top_ + kFloorContact) mn.z() = std::min(mn.z(), out->raw_box.min.z());
  out->raw_box = Box3{mn, mx};
  out->box = out->raw_box;
  out->image_box = ImageBox{pu0, pv0, pu1, pv1};
  out->near_depth = z_near;
  out->refined = false;
  out->ever_free = 0.f;
  return true;
}

std::size_t DetectionRefiner::split(const DepthView& depth, const CameraIntrinsics& cam,
                                    const Pose& T_map_camera, DetectionList& dets) noexcept {
  if (!config_.split_groups || depth.data == nullptr || depth.width > kMaxImageWidth ||
      depth.height > kMaxImageHeight) {
    return 0;
  }
  std::size_t splits = 0;
  // Each split adds a detection, so at most kMaxDetections - 1 splits; every detection is
  // examined once and each split's two parts once more: at most 3 * kMaxDetections passes over
  // a detection's pixels.
  for (std::size_t i = 0; i < dets.size() && !dets.full();) {
    PixelRegion r, a, b;
    bool cut = false;
    if (region_of(dets[i], depth, cam, T_map_camera, &r)) {
      floor_test(cam, T_map_camera, r);
      profile(depth, cam, r);
      cut = region_pixels_ > 0 && (split_along(r, cam, &a, &b) || split_across(r, cam, &a, &b));
    }
    Detection near = dets[i], far = dets[i];
    if (!cut || !measure(depth, cam, T_map_camera, a, &near) ||
        !measure(depth, cam, T_map_camera, b, &far)) {
      ++i;
      continue;
    }
    dets[i] = near;
    (void)dets.push_back(far);  // not full: checked by the loop
    for (std::size_t k = dets.size() - 1; k > i + 1; --k) std::swap(dets[k], dets[k - 1]);
    ++splits;
  }
  return splits;
}

}  // namespace dynamap
