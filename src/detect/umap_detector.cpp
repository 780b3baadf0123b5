#include "dynamap/detect/umap_detector.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <utility>

#include "dynamap/detect/detect_params.hpp"
#include "pixel_footprint.hpp"

namespace dynamap {

namespace {
bool finite_positive(float x) noexcept {
  return std::isfinite(x) && x > 0.f;
}

bool config_valid(const UMapDetectorConfig& c) noexcept {
  return all_in_range(c, params::kUMapDetector) && all_hold(c, params::kUMapDetectorRelations);
}

bool intrinsics_valid(const CameraIntrinsics& cam) noexcept {
  return finite_positive(cam.fx) && finite_positive(cam.fy) && std::isfinite(cam.cx) &&
         std::isfinite(cam.cy) && finite_positive(cam.depth_scale);
}

// Adds one row's in-band depths dd (d when raw_lo <= d <= raw_hi, else 0) of n pixels p[i] to
// the column sums cs (dd), cn (1 per in-band pixel) and ct (the running cs: sum over rows of
// the column sum so far, from which the column moment sum(v * dd) follows without a multiply;
// see sum_band_depths_fast), and
// returns the row's sum and first moment sum(i * dd). Branch-free, one unsigned compare per
// pixel (d - lo wraps above span for d < lo), restrict pointers so that the compiler vectorises
// it without run-time alias checks; the moment is summed in 32 bits per 16 pixels
// (15 * 65535 * 16 < 2^32) and widened once per chunk.
void add_band_row(const std::uint16_t* __restrict p, int n, std::uint16_t lo, std::uint16_t span,
                  std::uint32_t* __restrict cs, std::uint32_t* __restrict cn,
                  std::uint32_t* __restrict ct, std::uint32_t* row_sum,
                  std::uint64_t* row_moment) noexcept {
  constexpr int kChunk = 16;
  std::uint32_t sum = 0;
  std::uint64_t moment = 0;
  int c = 0;
  for (; c + kChunk <= n; c += kChunk) {
    std::uint32_t chunk_sum = 0, chunk_moment = 0;
    for (int i = 0; i < kChunk; ++i) {
      const std::uint16_t d = p[c + i];
      const std::uint16_t in = static_cast<std::uint16_t>(d - lo) <= span ? 0xFFFFu : 0u;
      const std::uint16_t dd = d & in;
      cs[c + i] += dd;
      cn[c + i] += in & 1u;
      ct[c + i] += cs[c + i];
      chunk_sum += dd;
      chunk_moment += static_cast<std::uint32_t>(dd) * static_cast<std::uint16_t>(i);
    }
    sum += chunk_sum;
    moment += static_cast<std::uint64_t>(chunk_sum) * static_cast<std::uint32_t>(c) + chunk_moment;
  }
  for (; c < n; ++c) {
    const std::uint16_t d = p[c];
    const std::uint16_t in = static_cast<std::uint16_t>(d - lo) <= span ? 0xFFFFu : 0u;
    const std::uint16_t dd = d & in;
    cs[c] += dd;
    cn[c] += in & 1u;
    ct[c] += cs[c];
    sum += dd;
    moment += static_cast<std::uint64_t>(dd) * static_cast<std::uint32_t>(c);
  }
  *row_sum = sum;
  *row_moment = moment;
}

}  // namespace

Status UMapDetector::init(const UMapDetectorConfig& config) noexcept {
  if (!config_valid(config)) return Status::kInvalidArgument;
  config_ = config;
  initialized_ = true;
  stats_ = UMapDetectorStats{};
  return Status::kOk;
}

Status UMapDetector::detect(const DepthView& depth, const CameraIntrinsics& cam,
                            const Pose& T_map_camera, DetectionList& out) noexcept {
  if (!initialized_) return Status::kNotInitialized;
  Status s = validate_depth(depth, cam);
  if (!ok(s)) return s;
  if (depth.width > kMaxImageWidth || depth.height > kMaxImageHeight) return Status::kWrongSize;
  if (!intrinsics_valid(cam)) return Status::kInvalidArgument;
  s = validate_pose(T_map_camera);
  if (!ok(s)) return s;
  UMapBinning binning;
  s = make_umap_binning(config_.d_min, config_.d_max, cam.depth_scale, config_.bins, &binning);
  if (!ok(s)) return s;
  const UMapBuffer buffer{counts_.data(), kUMapStride, static_cast<int>(counts_.size())};
  s = config_.use_fast_histogram ? umap_histogram_fast(depth, binning, buffer)
                                 : umap_histogram_scalar(depth, binning, buffer);
  if (!ok(s)) return s;  // e.g. misaligned depth data; nothing else touched yet

  // From here on the call cannot fail.
  binning_ = binning;
  stats_ = UMapDetectorStats{};
  out.clear();

  set_point_thresholds(cam);
  extract_segments(depth.width);
  build_groups();
  boxes_from_groups(depth, cam, T_map_camera, out);
  stats_.detections = out.size();
  return Status::kOk;
}

void UMapDetector::set_point_thresholds(const CameraIntrinsics& cam) noexcept {
  // A U-map cell is a point when its count reaches count_threshold and the column height that
  // min_point_height has at the bin's depth (fewer pixels the farther away).
  for (int b = 0; b < binning_.bins; ++b) {
    const float z = 0.5f * (binning_.bin_near_depth(b) + binning_.bin_far_depth(b));
    const float metric = z > 0.f ? std::ceil(config_.min_point_height * cam.fy / z) : 65535.f;
    const float t =
        std::min(65535.f, std::max(static_cast<float>(config_.count_threshold), metric));
    thresholds_[static_cast<std::size_t>(b)] = static_cast<std::uint16_t>(t);
  }
}

void UMapDetector::boxes_from_groups(const DepthView& depth, const CameraIntrinsics& cam,
                                     const Pose& T_map_camera, DetectionList& out) noexcept {
  std::size_t searched = 0;
  for (std::size_t gi = 0; gi < group_count_; ++gi) {
    const Group& g = groups_[gi];
    if (g.area < config_.min_area) {
      ++stats_.rejected_area;
      continue;
    }
    const int width_px = g.u1 - g.u0 + 1;
    const float near = binning_.bin_near_depth(g.b0);
    if (static_cast<float>(width_px) >=
            config_.max_width_fraction * static_cast<float>(depth.width) ||
        static_cast<float>(width_px) * near / cam.fx > config_.max_width) {
      ++stats_.rejected_size;
      continue;
    }
    if (searched >= config_.max_candidates) {
      ++stats_.candidates_dropped;
      continue;
    }
    ++searched;
    Box3 box_cam, box_map;
    ImageBox ibox;
    float near_depth = 0.f;
    if (!measure_group(g, depth, cam, T_map_camera, &box_cam, &box_map, &ibox, &near_depth)) {
      ++stats_.rejected_height;
      continue;
    }
    const Eigen::Vector3f size = box_cam.size();
    if (size.x() > config_.max_width || size.y() > config_.max_height ||
        size.z() > config_.max_depth_extent) {
      ++stats_.rejected_size;
      continue;
    }
    if (out.size() >= config_.max_detections) {
      ++stats_.detections_dropped;
      continue;
    }
    Detection* d = out.emplace_back();
    if (d == nullptr) {
      ++stats_.detections_dropped;
      continue;
    }
    d->box = box_map;
    d->raw_box = d->box;
    d->image_box = ibox;
    d->near_depth = near_depth;
    d->refined = false;
  }
}

void UMapDetector::extract_segments(int width) noexcept {
  segment_count_ = 0;
  const int bins = binning_.bins;
  const int r = config_.smoothing_radius;
  for (int b = 0; b < bins; ++b) {
    bin_first_segment_[static_cast<std::size_t>(b)] = static_cast<int>(segment_count_);
    const std::uint16_t* sum = counts_.data() + static_cast<std::ptrdiff_t>(b) * kUMapStride;
    if (r > 0) {
      // Smoothed counts of this bin row: sum over bins [b-r, b+r] (max 9 * 480, fits uint16).
      const int k0 = std::max(0, b - r);
      const int k1 = std::min(bins - 1, b + r);
      std::uint16_t* acc = row_sum_.data();
      const std::uint16_t* first = counts_.data() + static_cast<std::ptrdiff_t>(k0) * kUMapStride;
      for (int u = 0; u < width; ++u) acc[u] = first[u];
      for (int k = k0 + 1; k <= k1; ++k) {
        const std::uint16_t* row = counts_.data() + static_cast<std::ptrdiff_t>(k) * kUMapStride;
        for (int u = 0; u < width; ++u) acc[u] = static_cast<std::uint16_t>(acc[u] + row[u]);
      }
      sum = acc;
    }
    scan_bin_row(sum, width, b);
  }
  bin_first_segment_[static_cast<std::size_t>(bins)] = static_cast<int>(segment_count_);
  stats_.segments = segment_count_;
}

void UMapDetector::scan_bin_row(const std::uint16_t* sum, int width, int b) noexcept {
  // Runs of cells at or above the bin's threshold. Most cells are below it: 16 at a time are
  // passed over when their maximum is (a loop the compiler vectorises).
  constexpr int kStep = 16;
  const std::uint16_t thr = thresholds_[static_cast<std::size_t>(b)];
  const int min_len = config_.min_segment_length;
  int u = 0;
  while (u < width) {
    if (u + kStep <= width) {
      std::uint16_t m = 0;
      for (int i = 0; i < kStep; ++i) m = std::max(m, sum[u + i]);
      if (m < thr) {
        u += kStep;
        continue;
      }
    }
    if (sum[u] < thr) {
      ++u;
      continue;
    }
    const int start = u;
    while (u < width && sum[u] >= thr) ++u;
    if (u - start < min_len) continue;
    if (segment_count_ >= kMaxUMapSegments) {
      ++stats_.segments_dropped;
      continue;
    }
    const auto idx = static_cast<std::int16_t>(segment_count_);
    segments_[segment_count_++] =
        Segment{static_cast<std::int16_t>(start), static_cast<std::int16_t>(u - 1),
                static_cast<std::int16_t>(b), idx};
  }
}

int UMapDetector::find_root(int i) noexcept {
  while (segments_[static_cast<std::size_t>(i)].parent != i) {
    Segment& s = segments_[static_cast<std::size_t>(i)];
    s.parent = segments_[static_cast<std::size_t>(s.parent)].parent;  // path halving
    i = s.parent;
  }
  return i;
}

void UMapDetector::unite(int a, int b) noexcept {
  a = find_root(a);
  b = find_root(b);
  if (a == b) return;
  // The earlier segment (nearer bin) stays the root.
  if (b < a) std::swap(a, b);
  segments_[static_cast<std::size_t>(b)].parent = static_cast<std::int16_t>(a);
}

void UMapDetector::build_groups() noexcept {
  const int bins = binning_.bins;
  // Connect segments of adjacent bin rows whose column ranges overlap (two-pointer sweep; the
  // segments of one bin row are sorted by column).
  for (int b = 1; b < bins; ++b) {
    int i = bin_first_segment_[static_cast<std::size_t>(b - 1)];
    const int i_end = bin_first_segment_[static_cast<std::size_t>(b)];
    int j = i_end;
    const int j_end = bin_first_segment_[static_cast<std::size_t>(b) + 1];
    while (i < i_end && j < j_end) {
      const Segment& p = segments_[static_cast<std::size_t>(i)];
      const Segment& c = segments_[static_cast<std::size_t>(j)];
      if (p.u0 <= c.u1 && c.u0 <= p.u1) unite(i, j);
      if (p.u1 < c.u1) {
        ++i;
      } else {
        ++j;
      }
    }
  }
  // Groups are numbered in order of their first segment, i.e. by nearest bin.
  group_count_ = 0;
  for (std::size_t i = 0; i < segment_count_; ++i) group_of_root_[i] = -1;
  for (std::size_t i = 0; i < segment_count_; ++i) {
    const Segment& s = segments_[i];
    const auto root = static_cast<std::size_t>(find_root(static_cast<int>(i)));
    if (group_of_root_[root] < 0) {
      group_of_root_[root] = static_cast<std::int16_t>(group_count_);
      groups_[group_count_++] = Group{s.u0, s.u1, s.bin, s.bin, 0};
    }
    Group& g = groups_[static_cast<std::size_t>(group_of_root_[root])];
    g.u0 = std::min<int>(g.u0, s.u0);
    g.u1 = std::max<int>(g.u1, s.u1);
    g.b0 = std::min<int>(g.b0, s.bin);
    g.b1 = std::max<int>(g.b1, s.bin);
    g.area += s.u1 - s.u0 + 1;
  }
  stats_.groups = group_count_;
}

bool UMapDetector::measure_group(const Group& g, const DepthView& depth,
                                 const CameraIntrinsics& cam, const Pose& T_map_camera,
                                 Box3* box_cam, Box3* box_map, ImageBox* ibox,
                                 float* near_depth) noexcept {
  PixelBand band;
  band.u0 = std::max(0, g.u0);
  band.u1 = std::min(depth.width - 1, g.u1);
  if (band.u1 < band.u0) return false;
  // Depth band [near, near + band_factor * extent] in raw units (integer compares per pixel).
  band.raw_lo = binning_.bin_first_raw(g.b0);
  const std::uint32_t ext = binning_.bin_first_raw(g.b1 + 1) - band.raw_lo;
  const std::uint32_t width = std::max<std::uint32_t>(
      1u, static_cast<std::uint32_t>(config_.band_factor * static_cast<float>(ext)));
  band.raw_hi = std::min<std::uint32_t>(65535u, band.raw_lo + width - 1u);
  if (!find_row_run(depth, &band)) return false;
  if (config_.use_fast_measure) {
    sum_band_depths_fast(depth, band);
  } else {
    sum_band_depths(depth, band);
  }
  return fit_boxes(band, cam, T_map_camera, box_cam, box_map, ibox, near_depth);
}

bool UMapDetector::find_row_run(const DepthView& depth, PixelBand* band) noexcept {
  if (config_.use_fast_measure) {
    count_row_hits_fast(depth, *band);
  } else {
    count_row_hits(depth, *band);
  }
  const int need =
      std::max(1, static_cast<int>(std::ceil(config_.row_fill_fraction *
                                             static_cast<float>(band->u1 - band->u0 + 1))));
  // Longest run of hit rows, bridging gaps of up to max_row_gap rows.
  int best_start = -1, best_end = -1, run_start = -1, last_hit = -1;
  for (int v = 0; v < depth.height; ++v) {
    if (row_hits_[static_cast<std::size_t>(v)] < need) continue;
    if (run_start < 0 || v - last_hit - 1 > config_.max_row_gap) run_start = v;
    last_hit = v;
    if (best_start < 0 || last_hit - run_start > best_end - best_start) {
      best_start = run_start;
      best_end = last_hit;
    }
  }
  if (best_start < 0 || best_end - best_start + 1 < config_.min_run_rows) return false;
  band->v0 = best_start;
  band->v1 = best_end;
  return true;
}

void UMapDetector::count_row_hits(const DepthView& depth, const PixelBand& band) noexcept {
  // Reference: in-band pixels per image row over the group's columns.
  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* row = depth.row(v);
    int n = 0;
    for (int u = band.u0; u <= band.u1; ++u) {
      const std::uint32_t d = row[u];
      n += (d >= band.raw_lo && d <= band.raw_hi) ? 1 : 0;
    }
    row_hits_[static_cast<std::size_t>(v)] = static_cast<std::uint16_t>(n);
  }
}

void UMapDetector::count_row_hits_fast(const DepthView& depth, const PixelBand& band) noexcept {
  // One unsigned compare per pixel: d - raw_lo wraps above the span for d < raw_lo.
  const std::uint32_t lo = band.raw_lo, span = band.raw_hi - band.raw_lo;
  const int w = band.u1 - band.u0 + 1;
  for (int v = 0; v < depth.height; ++v) {
    const std::uint16_t* p = depth.row(v) + band.u0;
    std::uint32_t n = 0;
    for (int i = 0; i < w; ++i) n += (static_cast<std::uint32_t>(p[i]) - lo <= span) ? 1u : 0u;
    row_hits_[static_cast<std::size_t>(v)] = static_cast<std::uint16_t>(n);
  }
}

void UMapDetector::clear_column_sums(const PixelBand& band) noexcept {
  for (int u = band.u0; u <= band.u1; ++u) {
    const auto ui = static_cast<std::size_t>(u);
    col_depth_sum_[ui] = 0;
    col_vdepth_sum_[ui] = 0;
    col_vdepth_part_[ui] = 0;
    col_count_[ui] = 0;
  }
}

void UMapDetector::sum_band_depths(const DepthView& depth, const PixelBand& band) noexcept {
  // Reference: in-band depth sums per column and per row (and their image-coordinate moments),
  // for the mean depths of fit_boxes().
  clear_column_sums(band);
  for (int v = band.v0; v <= band.v1; ++v) {
    const std::uint16_t* row = depth.row(v);
    std::uint32_t row_sum = 0;
    std::uint64_t row_usum = 0;
    for (int u = band.u0; u <= band.u1; ++u) {
      const std::uint32_t d = row[u];
      const bool in = d >= band.raw_lo && d <= band.raw_hi;
      const std::uint32_t dd = in ? d : 0u;
      const auto ui = static_cast<std::size_t>(u);
      col_depth_sum_[ui] += dd;
      col_vdepth_sum_[ui] += static_cast<std::uint64_t>(dd) * static_cast<std::uint32_t>(v);
      col_count_[ui] += in ? 1u : 0u;
      row_sum += dd;
      row_usum += static_cast<std::uint64_t>(dd) * static_cast<std::uint32_t>(u);
    }
    row_depth_sum_[static_cast<std::size_t>(v)] = row_sum;
    row_udepth_sum_[static_cast<std::size_t>(v)] = row_usum;
  }
}

void UMapDetector::sum_band_depths_fast(const DepthView& depth, const PixelBand& band) noexcept {
  // The reference's sums, exactly, with 32-bit work per pixel. Row moments are taken relative
  // to u0. Column moments: with S(k) the column's sum over rows v0..k and T the sum of S(k)
  // over the run, sum(v * d_v) = (v1 + 1) * S(v1) - T; T is kept in 32 bits for
  // kVDepthFlushRows rows at a time (S <= 480 * 65535, times 128 < 2^32).
  clear_column_sums(band);
  // raw_lo <= raw_hi <= 65535: both and their difference fit 16 bits.
  const auto lo = static_cast<std::uint16_t>(band.raw_lo);
  const auto span = static_cast<std::uint16_t>(band.raw_hi - band.raw_lo);
  const int w = band.u1 - band.u0 + 1;
  const auto u0 = static_cast<std::size_t>(band.u0);
  const auto u1 = static_cast<std::size_t>(band.u1);
  int rows_in_part = 0;
  for (int v = band.v0; v <= band.v1; ++v) {
    std::uint32_t row_sum = 0;
    std::uint64_t row_moment = 0;
    add_band_row(depth.row(v) + u0, w, lo, span, col_depth_sum_.data() + u0, col_count_.data() + u0,
                 col_vdepth_part_.data() + u0, &row_sum, &row_moment);
    row_depth_sum_[static_cast<std::size_t>(v)] = row_sum;
    row_udepth_sum_[static_cast<std::size_t>(v)] =
        static_cast<std::uint64_t>(row_sum) * u0 + row_moment;
    if (++rows_in_part == kVDepthFlushRows || v == band.v1) {
      for (std::size_t u = u0; u <= u1; ++u) {
        col_vdepth_sum_[u] += col_vdepth_part_[u];  // T so far
        col_vdepth_part_[u] = 0;
      }
      rows_in_part = 0;
    }
  }
  const auto rows_end = static_cast<std::uint64_t>(band.v1) + 1u;
  for (std::size_t u = u0; u <= u1; ++u) {
    col_vdepth_sum_[u] = rows_end * col_depth_sum_[u] - col_vdepth_sum_[u];
  }
}

bool UMapDetector::fit_boxes(const PixelBand& band, const CameraIntrinsics& cam,
                             const Pose& T_map_camera, Box3* box_cam, Box3* box_map, ImageBox* ibox,
                             float* near_depth) const noexcept {
  // Each column (row) of the box is placed at its own mean in-band depth: exact for front and
  // side faces, and depth noise averages out instead of stretching the box by the extreme
  // pixels. Tight box over pixel footprints ([u - 0.5, u + 0.5]); x, y scaled by fx, fy at the
  // end. Map-frame box: each column contributes the mean map-frame point of its in-band pixels
  // (widened by half a pixel on each side) to the horizontal bounds, each row its mean point's
  // height (+- half a pixel) to the vertical bounds. Averaging real surface points keeps an
  // upright surface at its true distance whatever the camera's pitch.
  const float big = std::numeric_limits<float>::max();
  const Eigen::Matrix3f R = T_map_camera.rotation.toRotationMatrix();
  const Eigen::Vector3f& t = T_map_camera.translation;
  Eigen::Vector3f map_min = Eigen::Vector3f::Constant(big);
  Eigen::Vector3f map_max = Eigen::Vector3f::Constant(-big);
  float xs_min = big, xs_max = -big, ys_min = big, ys_max = -big, z_near = big, z_far = -big;
  int pu0 = band.u1, pu1 = band.u0;
  for (int u = band.u0; u <= band.u1; ++u) {
    const std::uint32_t n = col_count_[static_cast<std::size_t>(u)];
    if (n == 0) continue;
    const float z = static_cast<float>(col_depth_sum_[static_cast<std::size_t>(u)]) /
                    static_cast<float>(n) * cam.depth_scale;
    const float ut = static_cast<float>(u) - 0.5f - cam.cx;
    xs_min = std::min(xs_min, ut * z);
    xs_max = std::max(xs_max, (ut + 1.f) * z);
    const float v_mean =
        static_cast<float>(static_cast<double>(col_vdepth_sum_[static_cast<std::size_t>(u)]) /
                           static_cast<double>(col_depth_sum_[static_cast<std::size_t>(u)]));
    detail::grow_by_column(cam, R, t, u, z, v_mean, map_min, map_max);
    z_near = std::min(z_near, z);
    z_far = std::max(z_far, z);
    pu0 = std::min(pu0, u);
    pu1 = std::max(pu1, u);
  }
  if (pu1 < pu0) return false;
  for (int v = band.v0; v <= band.v1; ++v) {
    const std::uint16_t n = row_hits_[static_cast<std::size_t>(v)];
    if (n == 0) continue;
    const float z = static_cast<float>(row_depth_sum_[static_cast<std::size_t>(v)]) /
                    static_cast<float>(n) * cam.depth_scale;
    const float vt = static_cast<float>(v) - 0.5f - cam.cy;
    ys_min = std::min(ys_min, vt * z);
    ys_max = std::max(ys_max, (vt + 1.f) * z);
    const float u_mean =
        static_cast<float>(static_cast<double>(row_udepth_sum_[static_cast<std::size_t>(v)]) /
                           static_cast<double>(row_depth_sum_[static_cast<std::size_t>(v)]));
    detail::grow_by_row(cam, R, t, v, z, u_mean, map_min.z(), map_max.z());
  }
  if (ys_max < ys_min) return false;
  box_map->min = map_min;
  box_map->max = map_max;
  box_cam->min = Eigen::Vector3f(xs_min / cam.fx, ys_min / cam.fy, z_near);
  box_cam->max = Eigen::Vector3f(xs_max / cam.fx, ys_max / cam.fy, z_far);
  *ibox = ImageBox{pu0, band.v0, pu1, band.v1};
  *near_depth = z_near;
  return true;
}

}  // namespace dynamap
