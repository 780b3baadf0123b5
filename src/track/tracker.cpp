#include "dynamap/track/tracker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "dynamap/track/track_params.hpp"

namespace dynamap {

namespace {

/// Weight of the newest frame in the box growth rate behind the reported velocity σ: about
/// three frames, long enough to average out a box's jitter, short enough to follow an emergence.
constexpr float kGrowthSmoothing = 0.3f;

/// A nearer detection whose image box comes this close (pixels) to a side of another's hides
/// that side: the boxes of an occluder and the surface it cuts meet at the depth edge, where the
/// sensor's edge dropouts leave a pixel or two and the detector trims end columns with few
/// pixels (a far wall above a shoulder, beside a rounded head: 5 px on suite seed 5).
constexpr int kOccluderGapPixels = 8;
/// ... and lies at least this much nearer (m): a walker beside a wall, not in front of it, is
/// at about the wall's depth.
constexpr float kOccluderDepthGap = 0.2f;

/// Slack (m) of the view-sweep test (border_sweep_votes_static), about twice the detector's 1.6 cm
/// noise: a side that the view itself sets (where the range limit or a dark face's dropouts end
/// the face) moves exactly with the view, on the test's edge.
constexpr float kViewSweepSlack = 0.03f;

float seconds_between(Stamp earlier, Stamp later) noexcept {
  return static_cast<float>(static_cast<double>(later - earlier) * 1e-9);
}

/// Top-view overlap area of two boxes.
float overlap_area_xy(const Box3& a, const Box3& b) noexcept {
  const float dx = std::min(a.max.x(), b.max.x()) - std::max(a.min.x(), b.min.x());
  const float dy = std::min(a.max.y(), b.max.y()) - std::max(a.min.y(), b.min.y());
  return (dx > 0.f && dy > 0.f) ? dx * dy : 0.f;
}

Status validate_box(const Box3& b) noexcept {
  if (!b.min.allFinite() || !b.max.allFinite()) return Status::kNonFinite;
  if ((b.min.array() > b.max.array()).any()) return Status::kInvalidArgument;
  return Status::kOk;
}

/// Both boxes: either may be the one measured (TrackerConfig::measure_raw_box).
Status validate_detection(const Detection& d) noexcept {
  const Status s = validate_box(d.box);
  return ok(s) ? validate_box(d.raw_box) : s;
}

/// The top-view corner of a detection box (edges: min x, min y, max x, max y) seen furthest right
/// in the image from `view` (optical frame: x right, z forward), or furthest left.
Eigen::Vector2f image_side_corner(const Eigen::Vector4f& edges, float z, const Pose& view,
                                  bool rightmost) noexcept {
  Eigen::Vector2f best = edges.head<2>();
  float best_ratio =
      rightmost ? -std::numeric_limits<float>::infinity() : std::numeric_limits<float>::infinity();
  for (int c = 0; c < 4; ++c) {
    const Eigen::Vector2f corner(edges[(c & 1) != 0 ? 2 : 0], edges[(c & 2) != 0 ? 3 : 1]);
    const Eigen::Vector3f in_view = view.apply_inverse(Eigen::Vector3f(corner.x(), corner.y(), z));
    if (in_view.z() <= 0.f) continue;
    const float ratio = in_view.x() / in_view.z();
    if (rightmost ? ratio > best_ratio : ratio < best_ratio) {
      best_ratio = ratio;
      best = corner;
    }
  }
  return best;
}

}  // namespace

Status TrackerConfig::validate() const noexcept {
  if (!ok(kalman.validate()) || !ok(continuity.validate()) || !ok(label.validate())) {
    return Status::kInvalidArgument;
  }
  return all_in_range(*this, params::kTracker) && all_hold(*this, params::kTrackerRelations)
             ? Status::kOk
             : Status::kInvalidArgument;
}

Tracker::Tracker() noexcept {
  clear();
}

Status Tracker::init(const TrackerConfig& config, int image_width, int image_height) noexcept {
  const Status s = config.validate();
  if (!ok(s)) return s;
  if (image_width <= 2 * config.image_margin || image_height <= 2 * config.image_margin) {
    return Status::kInvalidArgument;
  }
  config_ = config;
  image_width_ = image_width;
  image_height_ = image_height;
  clear();
  return Status::kOk;
}

void Tracker::clear() noexcept {
  for (Track& t : tracks_) t.active = false;
  output_count_ = 0;
  has_stamp_ = false;
  last_stamp_ = 0;
  lost_count_ = 0;
  lost_next_ = 0;
}

bool Tracker::fully_in_view(const ImageBox& b) const noexcept {
  const int m = config_.image_margin;
  if (b.u1 < b.u0 || b.v1 < b.v0) return false;  // unknown / empty image box
  return b.u0 >= m && b.v0 >= m && b.u1 <= image_width_ - 1 - m && b.v1 <= image_height_ - 1 - m;
}

bool Tracker::moves_rigidly(const Track& t) const noexcept {
  if (config_.max_extent_change_ratio < 0.f) return true;
  // Compare the newest detection box with the oldest one in the history (k frames back): the
  // longest span gives the most displacement against the same edge noise.
  const Eigen::Vector4f d = t.edges.at_age(0) - t.edges.at_age(t.edges.size() - 1);
  const Eigen::Vector2f moved = 0.5f * (d.head<2>() + d.tail<2>());  // centre
  const Eigen::Vector2f grown = d.tail<2>() - d.head<2>();           // size
  return grown.norm() <= config_.max_extent_change_ratio * moved.norm();
}

Tracker::Measurement Tracker::measure(const Detection& det, const Eigen::Vector3f& camera,
                                      const Eigen::Vector3f* fixed_size) const noexcept {
  Measurement m;
  const Box3& box = config_.measure_raw_box ? det.raw_box : det.box;
  m.center = box.center();
  m.raw_size = box.size();
  m.edges << box.min.head<2>(), box.max.head<2>();
  m.in_view = fully_in_view(det.image_box);
  m.near_enough = det.near_depth <= config_.size_fix_max_depth;
  m.on_static = on_static_structure(det);
  m.size = m.raw_size;
  m.own_size = m.raw_size;
  const bool round = config_.max_round_footprint <= 0.f ||
                     std::max(m.raw_size.x(), m.raw_size.y()) <= config_.max_round_footprint;
  if (config_.correct_near_surface_bias && round) {
    const float footprint = std::max(m.raw_size.x(), m.raw_size.y());
    m.own_size.x() = footprint;
    m.own_size.y() = footprint;
  }
  if (fixed_size != nullptr) m.size = *fixed_size;
  if (config_.correct_near_surface_bias && round) {
    if (fixed_size == nullptr) {
      // Depth sees only the near surface, so the extent along the ray is too small. Assume a
      // round / square footprint: the full horizontal size is the larger horizontal extent.
      const float footprint = std::max(m.raw_size.x(), m.raw_size.y());
      m.size.x() = footprint;
      m.size.y() = footprint;
    }
    // The near face is measured correctly; the missing depth lies on the far side, so move the
    // centre away from the camera by half of it, per horizontal axis.
    for (int a = 0; a < 2; ++a) {
      const float missing = std::max(0.f, m.size[a] - m.raw_size[a]);
      const float away = m.center[a] - camera[a];
      if (away > 0.f) {
        m.center[a] += 0.5f * missing;
      } else if (away < 0.f) {
        m.center[a] -= 0.5f * missing;
      }
    }
  }
  return m;
}

void Tracker::start_track(Track& t, const Measurement& m, const Pose& view, Stamp stamp) noexcept {
  t.active = true;
  t.dormant = false;
  t.out = TrackedObstacle{};
  t.out.id = next_id_++;
  t.out.age = 1;
  t.out.hits = 1;
  t.out.last_seen = stamp;
  t.kf.reset(Eigen::Vector4f(m.center.x(), m.center.y(), 0.f, 0.f), config_.kalman);
  t.positions.clear();
  t.positions.push(m.center.head<2>(), config_.history_length + 1);
  t.velocities.clear();
  t.edges.clear();
  t.edges.push(m.edges, config_.history_length + 1);
  t.views.clear();
  t.views.push(view, config_.history_length + 1);
  t.boxes.clear();
  t.boxes.push(Box3::from_center_size(m.center, m.size), config_.box_history_length);
  t.last_measured = m.center.head<2>();
  t.last_measured_velocity.setZero();
  t.last_measured_stamp = stamp;
  t.z_center = m.center.z();
  t.size = m.size;
  t.corrected_with = m.size;
  t.last_raw_size = m.raw_size.head<2>();
  t.growth_rate.setZero();
  const bool counts = m.in_view && m.near_enough;
  t.in_view_frames = counts ? 1 : 0;
  t.seen_in_full = m.in_view;
  t.size_sum = counts ? m.size : Eigen::Vector3f::Zero();
  if (t.in_view_frames >= config_.size_fix_frames) {
    t.out.size_fixed = true;
    t.in_view_frames = 0;
    t.size_sum.setZero();
  }
}

void Tracker::correct_track(Track& t, const Detection& det, bool own_edge, const Pose& view,
                            Stamp stamp) noexcept {
  const Eigen::Vector3f& camera = view.translation;
  const Measurement m = measure(det, camera, t.out.size_fixed ? &t.size : nullptr);
  const Eigen::Vector2f xy = m.center.head<2>();
  // A step of the frozen size (just set or raised) changes how the detection is turned into a
  // centre, which is no motion (compensate_size_steps); so does the footprint of a box cut by
  // the image border, which grows as a person enters the view (compensate_cut_footprint).
  // Measure the same detection with the size the last frame used and move the track's
  // reference (filter position, position history, last measurement) by the difference.
  const bool size_step = m.size != t.corrected_with &&
                         ((config_.compensate_size_steps && t.out.size_fixed) ||
                          (config_.compensate_cut_footprint && !t.out.size_fixed && !m.in_view));
  if (size_step) {
    const Eigen::Vector2f step = xy - measure(det, camera, &t.corrected_with).center.head<2>();
    t.kf.shift_position(step);
    t.positions.add_to_all(step);
    t.last_measured += step;
  }
  t.corrected_with = m.size;
  const float dt = seconds_between(t.last_measured_stamp, stamp);
  const Eigen::Vector2f v_meas = (xy - t.last_measured) / dt;
  float noise_scale = 1.f;
  if (config_.noise_reference_depth > 0.f && det.near_depth > config_.noise_reference_depth) {
    const float q = det.near_depth / config_.noise_reference_depth;
    noise_scale = (q * q) * (q * q);
  }
  (void)t.kf.update(Eigen::Vector4f(xy.x(), xy.y(), v_meas.x(), v_meas.y()), noise_scale);
  // Signed, so a box's frame-to-frame jitter averages out and only a steady growth remains.
  const Eigen::Vector2f growth = (m.raw_size.head<2>() - t.last_raw_size) / dt;
  t.growth_rate += kGrowthSmoothing * (growth - t.growth_rate);
  t.last_raw_size = m.raw_size.head<2>();

  t.last_measured = xy;
  t.last_measured_velocity = t.kf.velocity();
  t.last_measured_stamp = stamp;
  t.z_center = m.center.z();
  t.positions.push(xy, config_.history_length + 1);
  t.velocities.push(t.kf.velocity(), kMaxTrackHistory);
  t.edges.push(m.edges, config_.history_length + 1);
  t.views.push(view, config_.history_length + 1);
  t.boxes.push(Box3::from_center_size(m.center, m.size), config_.box_history_length);
  t.seen_in_full = t.seen_in_full || m.in_view;
  update_size(t, m);
  t.out.missed_frames = 0;
  ++t.out.hits;
  t.out.last_seen = stamp;
  t.label.measured(evidence(t, det, own_edge), config_.continuity, config_.label);
  t.dynamic_when_measured = t.label.dynamic();
  t.dormant = false;
}

bool Tracker::plausible_size(const Eigen::Vector3f& size) const noexcept {
  const ContinuityConfig& cc = config_.continuity;
  return !cc.check_size || ((size.array() >= cc.min_size.array()).all() &&
                            (size.array() <= cc.max_size.array()).all());
}

void Tracker::update_size(Track& t, const Measurement& m) noexcept {
  if (!t.out.size_fixed) {
    t.size = m.size;
    if (m.in_view && m.near_enough) {
      ++t.in_view_frames;
      t.size_sum += m.size;
    } else if (m.in_view) {
      // Too far for a trustworthy size (lost edge pixels, depth noise): not counted.
    } else {
      // Clipped by the image border: the box may be cut, start counting again.
      t.in_view_frames = 0;
      t.size_sum.setZero();
    }
    if (t.in_view_frames >= config_.size_fix_frames) {
      t.size = t.size_sum / static_cast<float>(t.in_view_frames);
      t.out.size_fixed = true;
      t.in_view_frames = 0;
      t.size_sum.setZero();
    }
  } else if (config_.size_fix_growth) {
    // Same windows as above, on the sizes this detection alone gives.
    if (m.in_view && m.near_enough) {
      ++t.in_view_frames;
      t.size_sum += m.own_size;
    } else if (!m.in_view) {
      t.in_view_frames = 0;
      t.size_sum.setZero();
    }
    if (t.in_view_frames >= config_.size_fix_frames) {
      const Eigen::Vector3f mean = t.size_sum / static_cast<float>(t.in_view_frames);
      const bool refreeze =
          config_.refreeze_implausible_size && !plausible_size(t.size) && plausible_size(mean);
      t.size = refreeze ? mean : Eigen::Vector3f(t.size.cwiseMax(mean));
      t.in_view_frames = 0;
      t.size_sum.setZero();
    }
  }
}

void Tracker::ever_free_evidence(const Detection& det, LabelEvidence* e) const noexcept {
  e->in_ever_free = det.ever_free >= config_.ever_free_share;
  e->ever_free_overruled =
      e->in_ever_free &&
      ((config_.static_overrules_ever_free && on_static_structure(det)) || border_sliver(det));
}

bool Tracker::border_sliver(const Detection& det) const noexcept {
  if (config_.ever_free_min_cut_extent <= 0.f || !side_cut(det.image_box)) return false;
  const Eigen::Vector3f size = det.raw_box.size();
  return std::hypot(size.x(), size.y()) < config_.ever_free_min_cut_extent;
}

LabelEvidence Tracker::evidence(Track& t, const Detection& det, bool own_edge) const noexcept {
  LabelEvidence e;
  ever_free_evidence(det, &e);
  e.plausible_size = plausible_size(t.size);
  e.near_depth = det.near_depth;
  e.side_cut = side_cut(det.image_box);
  e.slow = t.kf.velocity().norm() < config_.continuity.min_speed;
  // Continuity filter over the measured history (oldest first), then the vote.
  std::array<Eigen::Vector2f, kMaxTrackHistory> ordered;
  const std::size_t n = t.positions.size();
  for (std::size_t i = 0; i < n; ++i) ordered[i] = t.positions.at_age(n - 1 - i);
  float c_con = 0.f;
  std::size_t span = config_.continuity.displacement_frames;
  const std::size_t early_span = config_.early_displacement_frames;
  if (n < span + 2 && early_span > 0 && n >= 2 * early_span + 1) span = early_span;
  if (!continuity_score(ordered.data(), n, span, &c_con)) return e;  // no vote yet
  t.out.continuity = c_con;
  const float speed = t.kf.velocity().norm();
  const ContinuityFilter filter(config_.continuity);
  // A detection on long-occupied voxels lies on static structure: it votes static.
  const bool on_static = on_static_structure(det);
  const bool moving = filter.vote(speed, c_con, t.size) && !on_static;
  const bool rigid = moving && moves_rigidly(t);
  // Only before the track's first vote: a wall piece that passed a vote keeps its static ones.
  const bool first_vote = t.label.voter().votes() == 0;
  e.voted = rigid || !moving || !config_.abstain_when_not_rigid || !first_vote;
  e.dynamic_vote = rigid;
  if (config_.vote_needs_own_edge && !own_edge) {
    e.view_bounded = true;  // the box shows the view and the occluders, not the object
    e.voted = false;
    e.dynamic_vote = false;
  } else if (config_.border_sweep_votes_static && !t.seen_in_full && side_cut(det.image_box) &&
             view_sweep_explains(t, det.image_box)) {
    e.dynamic_vote = false;  // the view's motion, not the object's
  }
  return e;
}

bool Tracker::side_cut(const ImageBox& b) const noexcept {
  const int m = config_.image_margin;
  return b.u1 >= b.u0 && (b.u0 < m || b.u1 > image_width_ - 1 - m);
}

bool Tracker::view_sweep_explains(const Track& t, const ImageBox& b) const noexcept {
  // Over the whole history, like the rigid-motion test: the longest span gives the most
  // displacement against the same corner noise.
  const std::size_t age = t.edges.size() - 1;
  if (age == 0 || t.views.size() <= age) return false;
  // The object's own side: the box corner furthest from the cut border in the image, then and
  // now (the centre of anything cut by the border follows the border, compensate_cut_footprint).
  const Pose& now = t.views.at_age(0);
  const Pose& then = t.views.at_age(age);
  const bool left_cut = b.u0 < config_.image_margin;
  const Eigen::Vector2f own = image_side_corner(t.edges.at_age(0), t.z_center, now, left_cut);
  const Eigen::Vector2f own_then =
      image_side_corner(t.edges.at_age(age), t.z_center, then, left_cut);
  // Where the point the view now shows there lay then, had it moved with the camera.
  const Eigen::Vector3f in_view = now.apply_inverse(Eigen::Vector3f(own.x(), own.y(), t.z_center));
  const Eigen::Vector2f swept = own - then.apply(in_view).head<2>();
  const Eigen::Vector2f moved = own - own_then;
  // A static object's own side stays put (its far end) or slides with the view (where the
  // sensor ends a face), between none and all of the sweep and along it: inside the circle over
  // `swept`, whose points see its two ends at a right angle.
  return (moved - 0.5f * swept).norm() <= 0.5f * swept.norm() + kViewSweepSlack;
}

Status Tracker::check_input(const Detection* dets, std::size_t count, const Pose& T_map_camera,
                            Stamp stamp) const noexcept {
  if (count > 0 && dets == nullptr) return Status::kNullData;
  if (count > kMaxDetections) return Status::kCapacityExceeded;
  const Status pose_status = validate_pose(T_map_camera);
  if (!ok(pose_status)) return pose_status;
  if (has_stamp_ && stamp <= last_stamp_) return Status::kTimeNotIncreasing;
  for (std::size_t i = 0; i < count; ++i) {
    const Status s = validate_detection(dets[i]);
    if (!ok(s)) return s;
  }
  return Status::kOk;
}

Status Tracker::update(const Detection* dets, std::size_t count, const Pose& T_map_camera,
                       Stamp stamp) noexcept {
  const Status bad = check_input(dets, count, T_map_camera, stamp);  // before any change
  if (!ok(bad)) return bad;
  const Eigen::Vector3f camera = T_map_camera.translation;
  predict_tracks(stamp);
  for (std::size_t i = 0; i < count; ++i) frame_.meas[i] = measure(dets[i], camera, nullptr);
  mark_own_edges(dets, count);
  frame_.det_used.fill(false);
  frame_.track_used.fill(false);
  associate(count);
  for (std::size_t p = 0; p < frame_.pair_count; ++p) {
    const Pair& pr = frame_.pairs[p];
    if (frame_.det_used[pr.det] || frame_.track_used[pr.slot]) continue;
    frame_.det_used[pr.det] = true;
    frame_.track_used[pr.slot] = true;
    correct_track(tracks_[pr.slot], dets[pr.det], frame_.meas[pr.det].own_edge, T_map_camera,
                  stamp);
    tracks_[pr.slot].out.detection = pr.det;
    tracks_[pr.slot].out.cut = !frame_.meas[pr.det].in_view;
  }
  coast_unmatched();
  start_tracks(dets, count, T_map_camera, stamp);
  last_stamp_ = stamp;
  has_stamp_ = true;
  publish();
  return Status::kOk;
}

void Tracker::mark_own_edges(const Detection* dets, std::size_t count) noexcept {
  if (!config_.vote_needs_own_edge) return;  // measure() left every own_edge true
  const int m = config_.image_margin;
  for (std::size_t i = 0; i < count; ++i) {
    const ImageBox& a = dets[i].image_box;
    frame_.meas[i].own_edge = true;
    if (a.u1 < a.u0 || a.v1 < a.v0) continue;  // no image box: nothing to judge by
    bool left_apparent = a.u0 < m;
    bool right_apparent = a.u1 > image_width_ - 1 - m;
    for (std::size_t j = 0; j < count && !(left_apparent && right_apparent); ++j) {
      const ImageBox& b = dets[j].image_box;
      if (j == i || b.u1 < b.u0) continue;
      if (dets[j].near_depth > dets[i].near_depth - kOccluderDepthGap) continue;
      // Beside half of the rows or more: a crate's top next to a walker's legs leaves the edge
      // of the body above it in view.
      const int rows = std::min(a.v1, b.v1) - std::max(a.v0, b.v0) + 1;
      if (2 * rows < a.v1 - a.v0 + 1) continue;
      // An occluder ending within the box hides one side; one spanning the whole width (a
      // crate in front of a walker's legs) hides neither.
      if (b.u0 < a.u0 && b.u1 >= a.u0 - kOccluderGapPixels && b.u1 < a.u1) left_apparent = true;
      if (b.u1 > a.u1 && b.u0 <= a.u1 + kOccluderGapPixels && b.u0 > a.u0) right_apparent = true;
    }
    frame_.meas[i].own_edge = !(left_apparent && right_apparent);
  }
}

void Tracker::predict_tracks(Stamp stamp) noexcept {
  // Tracks unmeasured for longer than max_coast_time end; the rest are predicted.
  const float dt = has_stamp_ ? seconds_between(last_stamp_, stamp) : 0.f;
  for (Track& t : tracks_) {
    if (!t.active) continue;
    if (seconds_between(t.last_measured_stamp, stamp) > config_.max_coast_time) {
      drop_track(t);
      continue;
    }
    if (dt > 0.f) (void)t.kf.predict(dt);
    ++t.out.age;
  }
}

void Tracker::associate(std::size_t count) noexcept {
  // Candidate pairs in the top view, closest centre first (taken one-to-one by the caller).
  frame_.pair_count = 0;
  for (std::size_t i = 0; i < count; ++i) {
    const Measurement& m = frame_.meas[i];
    const Box3 det_box = Box3::from_center_size(m.center, m.size);
    const Eigen::Vector3f ds = det_box.size();
    const float det_area = ds.x() * ds.y();
    for (std::size_t s = 0; s < kMaxTracks; ++s) {
      const Track& t = tracks_[s];
      if (!t.active) continue;
      // A hidden walker comes back as a body, not as the wall or crate it went behind.
      if (t.dormant && m.on_static) continue;
      const Eigen::Vector2f predicted = t.kf.position();
      const Box3 track_box =
          Box3::from_center_size(Eigen::Vector3f(predicted.x(), predicted.y(), t.z_center), t.size);
      const float distance = (m.center.head<2>() - predicted).norm();
      const float overlap = overlap_area_xy(det_box, track_box);
      const bool overlapping =
          det_area > 0.f ? overlap >= config_.overlap_threshold * det_area : false;
      if (overlapping || distance < config_.centre_gate) {
        frame_.pairs[frame_.pair_count++] =
            Pair{distance, static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(s)};
      }
    }
  }
  std::sort(frame_.pairs.begin(),
            frame_.pairs.begin() + static_cast<std::ptrdiff_t>(frame_.pair_count),
            [](const Pair& a, const Pair& b) { return a.distance < b.distance; });
}

void Tracker::coast_unmatched() noexcept {
  for (std::size_t s = 0; s < kMaxTracks; ++s) {
    Track& t = tracks_[s];
    if (!t.active || frame_.track_used[s]) continue;
    ++t.out.missed_frames;
    t.out.detection = -1;
    t.label.missed();
    if (t.out.missed_frames == 1) coast_on_earlier_velocity(t);
    if (t.out.missed_frames <= config_.max_missed_frames) continue;
    // Only a track whose vote window still says dynamic: it comes back labelled.
    const std::size_t extra = t.label.dynamic() ? config_.reacquire_frames : 0;
    if (t.out.missed_frames > config_.max_missed_frames + extra) {
      drop_track(t);
    } else {
      t.dormant = true;
    }
  }
}

void Tracker::coast_on_earlier_velocity(Track& t) noexcept {
  const std::size_t skip = config_.coast_velocity_skip;
  const std::size_t end = std::min(t.velocities.size(), skip + config_.coast_velocity_frames);
  if (end <= skip) return;
  Eigen::Vector2f sum = Eigen::Vector2f::Zero();
  for (std::size_t age = skip; age < end; ++age) sum += t.velocities.at_age(age);
  const Eigen::Vector2f v = sum / static_cast<float>(end - skip);
  t.kf.set_velocity(v);
  t.last_measured_velocity = v;
}

void Tracker::start_tracks(const Detection* dets, std::size_t count, const Pose& view,
                           Stamp stamp) noexcept {
  // Unmatched detections start tracks while slots last; the rest are refused and counted.
  std::size_t free_slot = 0;
  for (std::size_t i = 0; i < count; ++i) {
    if (frame_.det_used[i]) continue;
    while (free_slot < kMaxTracks && (tracks_[free_slot].active || frame_.track_used[free_slot])) {
      ++free_slot;
    }
    std::size_t slot = free_slot;
    if (slot == kMaxTracks) {
      // Every slot taken: a dormant track gives way to a detection in view.
      for (slot = 0; slot < kMaxTracks; ++slot) {
        if (tracks_[slot].dormant && !frame_.track_used[slot]) break;
      }
      if (slot < kMaxTracks) drop_track(tracks_[slot]);
    }
    if (slot >= kMaxTracks) {
      ++refused_tracks_;
      continue;
    }
    Track& t = tracks_[slot];
    start_track(t, frame_.meas[i], view, stamp);
    t.out.detection = static_cast<std::int32_t>(i);
    t.out.cut = !frame_.meas[i].in_view;
    LabelEvidence e;
    ever_free_evidence(dets[i], &e);
    e.plausible_size = plausible_size(t.size);
    e.near_depth = dets[i].near_depth;
    Eigen::Vector2f velocity = Eigen::Vector2f::Zero();
    float since = 0.f;
    e.follows_lost_dynamic =
        !frame_.meas[i].on_static && follows_lost_dynamic(frame_.meas[i], stamp, &velocity, &since);
    e.lost_recently = e.follows_lost_dynamic && since <= config_.inherit_trusted_time;
    t.label.start(e, config_.label);
    if (t.label.dynamic() && e.follows_lost_dynamic) {
      const Eigen::Vector3f& c = frame_.meas[i].center;
      t.kf.reset(Eigen::Vector4f(c.x(), c.y(), velocity.x(), velocity.y()), config_.kalman);
    }
    t.dynamic_when_measured = t.label.dynamic();
    if (slot == free_slot) ++free_slot;
  }
}

void Tracker::drop_track(Track& t) noexcept {
  if (t.active && t.dynamic_when_measured && config_.inherit_time > 0.f) {
    lost_[lost_next_] =
        LostTrack{t.last_measured, t.last_measured_velocity, t.size.z(), t.last_measured_stamp};
    lost_next_ = (lost_next_ + 1) % kMaxTracks;
    lost_count_ = std::min(lost_count_ + 1, kMaxTracks);
  }
  t.active = false;
  t.dormant = false;
  ++dropped_tracks_;
}

bool Tracker::follows_lost_dynamic(const Measurement& m, Stamp stamp, Eigen::Vector2f* velocity,
                                   float* since_loss) const noexcept {
  if (config_.inherit_time <= 0.f) return false;
  float best = std::numeric_limits<float>::infinity();
  const auto consider = [&](const Eigen::Vector2f& position, const Eigen::Vector2f& v, float height,
                            Stamp measured) {
    const float since = seconds_between(measured, stamp);
    if (since > config_.inherit_time) return;
    if (std::abs(m.size.z() - height) > config_.inherit_height_tolerance) return;
    const float radius = config_.inherit_radius + config_.inherit_radius_growth * since;
    // Anywhere along the way its last velocity would have carried it: the velocity at a loss is
    // often stale (a walker slowing to turn, a box shrinking behind an occluder), and a walker
    // who stopped or turned while hidden comes back short of the extrapolated point.
    const Eigen::Vector2f path = v * since;
    const Eigen::Vector2f offset = m.center.head<2>() - position;
    const float squared = path.squaredNorm();
    const float along = squared > 0.f ? std::clamp(offset.dot(path) / squared, 0.f, 1.f) : 0.f;
    const float distance = (offset - path * along).norm();
    if (distance <= radius && distance < best) {
      best = distance;
      *velocity = v;
      *since_loss = since;
    }
  };
  for (std::size_t k = 0; k < lost_count_; ++k) {
    const LostTrack& l = lost_[k];
    consider(l.position, l.velocity, l.height, l.last_measured_stamp);
  }
  // Tracks still coasting or dormant (not measured this frame, nor started in it).
  for (const Track& t : tracks_) {
    if (!t.active || t.last_measured_stamp == stamp || !t.dynamic_when_measured) continue;
    consider(t.last_measured, t.last_measured_velocity, t.size.z(), t.last_measured_stamp);
  }
  return best < std::numeric_limits<float>::infinity();
}

void Tracker::publish() noexcept {
  output_count_ = 0;
  for (std::size_t s = 0; s < kMaxTracks; ++s) {
    Track& t = tracks_[s];
    if (!t.active || t.dormant) continue;
    const Eigen::Vector2f p = t.kf.position();
    const Eigen::Vector2f v = t.kf.velocity();
    t.out.box = Box3::from_center_size(Eigen::Vector3f(p.x(), p.y(), t.z_center), t.size);
    t.out.velocity = Eigen::Vector3f(v.x(), v.y(), 0.f);
    t.out.speed = v.norm();
    const Eigen::Vector2f bias = config_.velocity_sigma_growth_share * t.growth_rate;
    t.out.velocity_covariance = t.kf.velocity_covariance();
    t.out.velocity_covariance.diagonal() += bias.cwiseProduct(bias);
    t.out.dynamic = t.label.dynamic();
    if (!t.out.dynamic) {
      t.out.dynamic_frames = 0;
    } else if (t.label.trusted() && t.out.dynamic_frames < kMaxLabelCount) {
      ++t.out.dynamic_frames;
    }
    t.out.dynamic_votes = static_cast<std::uint32_t>(t.label.voter().dynamic_votes());
    t.out.votes = static_cast<std::uint32_t>(t.label.voter().votes());
    t.out.dynamic_streak = static_cast<std::uint32_t>(t.label.dynamic_streak());
    output_[output_count_] = t.out;
    output_slot_[output_count_] = static_cast<std::uint8_t>(s);
    ++output_count_;
  }
}

std::size_t Tracker::box_history_size(std::size_t i) const noexcept {
  return i < output_count_ ? tracks_[output_slot_[i]].boxes.size() : 0;
}

const Box3& Tracker::past_box(std::size_t i, std::size_t age) const noexcept {
  return tracks_[output_slot_[i]].boxes.at_age(age);
}

}  // namespace dynamap
