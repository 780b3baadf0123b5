// Tracker: fixed-capacity multi-obstacle tracker. Per frame it associates detections with tracks
// in the top view, runs a motion filter per track (by default an IMM of constant velocity and
// coordinated turn), fixes the obstacle size once it has been fully in view, corrects the
// near-surface bias of depth boxes, and labels each track static or dynamic with the continuity
// filter, a voting window and the rules of LabelState. No heap, no exceptions.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>

#include <Eigen/Core>

#include "dynamap/core/constants.hpp"
#include "dynamap/core/detection.hpp"
#include "dynamap/core/status.hpp"
#include "dynamap/core/types.hpp"
#include "dynamap/track/continuity_filter.hpp"
#include "dynamap/track/detail/history_ring.hpp"
#include "dynamap/track/detail/tracker_scratch.hpp"
#include "dynamap/track/kalman_filter.hpp"
#include "dynamap/track/label_state.hpp"

namespace dynamap {

/// Longest state history per track (k + 1 states for the continuity filter).
inline constexpr std::size_t kMaxTrackHistory = 32;

/// Tracker parameters. Defaults: original association thresholds (overlap 0.3, centre gate
/// 0.22 m), history k = 20, cleaning horizon f = 50; coasting, k' and the margin are ours.
struct TrackerConfig {
  KalmanConfig kalman{};
  ContinuityConfig continuity{};
  LabelConfig label{};                ///< early label, ever-free label, hold (label_state.hpp)
  float overlap_threshold = 0.3f;     ///< top-view A_overlap / A_detection for a candidate pair
  float centre_gate = 0.22f;          ///< or a top-view centre distance below this (m)
  std::size_t max_missed_frames = 3;  ///< frames a track coasts on its prediction, then dropped
  /// A track whose vote window says dynamic is kept this many frames longer than
  /// max_missed_frames (0: off), predicted but not published (not an obstacle, no prediction,
  /// nothing cleared): a detection that pairs with it, and is not on long-occupied voxels, takes
  /// it up again with its id, label and history. A walker hidden for a moment by another or a
  /// pillar otherwise came back as a new track that had to earn its label again.
  std::size_t reacquire_frames = 15;
  /// At its first unmeasured frame a track goes on with the mean of its filter's velocities
  /// over this many measured frames (0: off, the filter's velocity as it is), leaving out the
  /// newest coast_velocity_skip of them. A walker is mostly lost to an occluder or the image
  /// border, and on the frames before, the visible part shrinks and its centre slides: those
  /// frames' velocity is off by four times the usual error, and coasting carried it on.
  std::size_t coast_velocity_frames = 16;
  std::size_t coast_velocity_skip = 2;  ///< newest measured frames the coasting mean leaves out
  /// A new track whose first detection lies where a track labelled dynamic at its last
  /// measurement was lost at most this long ago (s; dropped, or coasting unmatched) starts
  /// labelled dynamic, until a static vote or a missed frame (LabelEvidence::follows_lost_dynamic;
  /// 0: off), with the lost track's velocity as its filter's first guess (the initial velocity
  /// covariance unchanged). A walker hidden for a moment often comes back away from its track's
  /// prediction (a sliver stepping out from behind someone, a turn while hidden), beyond the
  /// association gate, and as a new track it had to earn its label again: seven frames before
  /// its first vote, with a velocity starting from zero.
  float inherit_time = 1.0f;
  /// An inherited label counts for the dynamic-region cleaner (TrackedObstacle::dynamic_frames)
  /// at once only when the loss was at most this long ago (s); from an older loss, only once the
  /// new track's own votes or ever-free run label it. A standing person uncovered by a walker
  /// passing in front takes the label of that walker's loss, and the cleaner must not clear it.
  float inherit_trusted_time = 0.5f;
  /// ... "where": within this distance (m) of the way from the lost track's last measured centre
  /// to where its last velocity would carry it by now (a walker may have stopped or turned while
  /// hidden), plus inherit_radius_growth for every second since that measurement.
  float inherit_radius = 0.5f;
  float inherit_radius_growth = 0.5f;  ///< m/s: the lost track's velocity is a guess that ages
  /// ... and the detection's height differs from the lost track's by at most this (m): a
  /// walker's head stays in view as it steps out from behind someone or something, while the
  /// face of the crate a walker went behind, which nothing in the map may mark as static beyond
  /// its range, is lower.
  float inherit_height_tolerance = 0.3f;
  /// Seconds a track may go unmeasured, whatever the frame count: at the next frame later than
  /// this after its last measurement it is dropped before it is predicted, so a time gap in
  /// the input (a stalled sensor) ends coasting instead of extrapolating across it. At 30 Hz,
  /// max_missed_frames ends coasting long before this.
  float max_coast_time = 1.0f;
  std::size_t history_length = 20;      ///< k: the state history holds k + 1 positions
  std::size_t box_history_length = 50;  ///< f: past boxes kept for dynamic-region cleaning
  std::size_t size_fix_frames = 10;     ///< k': frames fully in view before the size is frozen
  int image_margin = 5;                 ///< pixels the image box must stay away from the border
  /// Only detections whose nearest surface is at most this far (m) count towards size fixing:
  /// far away the depth noise and lost edge pixels make boxes too small.
  float size_fix_max_depth = 5.0f;
  /// Stereo depth noise grows with depth squared: beyond this depth (m) the Kalman measurement
  /// noise is scaled by (near_depth / noise_reference_depth)^4, so far, jittering boxes (a wall
  /// piece 7 m away) do not gain a speed. 0 disables the scaling.
  float noise_reference_depth = 3.0f;
  /// The reported velocity covariance adds (this × the measured box's growth rate)² per axis to
  /// the filter's: a box growing on one side (a person emerging from behind something or from
  /// the image border) moves its centre at half the growth rate without the person moving, a
  /// bias the filter cannot see. Reporting only (0: the filter's covariance alone).
  float velocity_sigma_growth_share = 0.5f;
  /// Shift depth boxes away from the camera by half their missing depth (docs/tracker.md).
  bool correct_near_surface_bias = true;
  /// Rigid-motion test of the vote: over the position history, the detection box's top-view
  /// extent may change by at most this fraction of its centre's displacement, or the frame votes
  /// static. A wall piece whose visible part slides (one end fixed, the other cut by the image
  /// border or an occluder) grows or shrinks by twice its centre's motion; an object moves both
  /// edges together. Judged on the detection boxes themselves (before the bias correction).
  /// Negative disables the test.
  float max_extent_change_ratio = 1.0f;
  /// Before a track's first vote, a frame that fails only the rigid-motion test (fast,
  /// continuous, plausible size, not on static structure) casts no vote instead of a static
  /// one. A walker stepping out from behind a pillar grows as it emerges: with static votes its
  /// label waits for T_c of c votes (a second); without, the early label can follow. Once a
  /// track has voted, such frames vote static (a wall piece that passed a vote).
  bool abstain_when_not_rigid = true;
  /// A frame votes only when its detection shows one of the object's own sides: a detection
  /// whose left and right image edges are both apparent, each at the image border or next to a
  /// nearer detection, is a piece of something whose visible part the view and the occluders
  /// decide (a crate face between a walker and the border, a far wall between two pillars), and
  /// its box moves with them. Such a frame casts no vote and leaves the label as it was
  /// (LabelEvidence::view_bounded; docs/tracker.md).
  bool vote_needs_own_edge = true;
  /// The round-footprint bias correction is applied only when the box's longer horizontal side
  /// is at most this long (m): a longer box is a wall piece or a group, not round, and its
  /// visible face's centre is kept. 0 disables the limit.
  float max_round_footprint = 1.0f;
  /// While the history is shorter than the n + 2 states the continuity filter needs, vote with
  /// displacements this many frames apart once 2 * early_displacement_frames + 1 states exist
  /// (0: no votes before n + 2 states). At 1 m/s, 3 frames are 10 cm, six times the
  /// detector's 1.6 cm centre noise, so the direction of each displacement is still clear.
  std::size_t early_displacement_frames = 3;
  /// After the size is frozen, keep averaging k' in-view frames at a time and raise the frozen
  /// size to a larger window mean. A nearer occluder (a pillar the walker steps out from behind)
  /// only ever shrinks the visible extent, and the "fully in view" test sees the image border
  /// only, so a size frozen during a partial occlusion was too small for good, and so was the
  /// bias correction of the centre. The size never shrinks once frozen.
  bool size_fix_growth = true;
  /// A frozen size that fails the size check is replaced by a later window mean that passes
  /// it: two people merged with a third in a track's first frames froze a size wider than 1 m,
  /// and every vote of that track was static for good.
  bool refreeze_implausible_size = true;
  /// Measure each detection from the detector's own box (`Detection::raw_box`, the mean surface
  /// points of this depth image) instead of the box refined against the occupancy map. The map
  /// confirms a voxel only after repeated hits (two at prob_hit 0.7, prob_occupied 0.8) and
  /// quantises to its resolution, so the support of a moving surface lags at its leading edge
  /// and advances in voxel steps, so the refined box's centre saw-tooths (docs/tracker.md,
  /// "Measurement"). No choice to validate: both are boxes of the same detection.
  bool measure_raw_box = true;
  /// Keep a step of the frozen size from reading as motion. The near-surface bias correction
  /// moves a detection's centre away from the camera by half the depth the box misses, which
  /// depends on the estimated full size; when the size is frozen or raised (`size_fix_growth`)
  /// every corrected centre from then on moves by up to half the step although the obstacle did
  /// not, and the filter reads the jump as motion. With this on, the first detection corrected with
  /// the new size is also corrected with the previous one, and the filter's position, the position
  /// history and the last measured position move by the difference before the update
  /// (docs/tracker.md, "Measurement"). The per-frame footprint of a track whose size is not frozen
  /// yet is left alone: it is detection noise, not a re-estimate. No value to validate.
  bool compensate_size_steps = true;
  /// Keep the footprint of a detection cut by the image border from reading as motion while the
  /// size is not frozen: a person entering the view grows from a sliver to a full body within a
  /// few frames, and the bias correction pushes the centre back along the ray by half of that
  /// growth, which the filter reads as motion away from the camera. With this on, a cut
  /// detection whose footprint differs from the last frame's is handled like a size step
  /// (docs/tracker.md, "Measurement"). No value to validate.
  bool compensate_cut_footprint = true;
  /// A detection lies in ever-free space (the evidence of LabelConfig::ever_free_frames) when
  /// at least this share of its surface cells (0, 1] is ever free (Detection::ever_free).
  float ever_free_share = 0.5f;
  /// A detection most of whose voxels the map has held occupied for a long time
  /// (Detection::static_share above this) lies on static structure: its apparent motion is the
  /// camera's view sliding along it, and it votes static (1: off; docs/tracker.md).
  float max_static_share = 0.5f;
  /// A detection on static structure (static share above max_static_share) neither extends nor
  /// ends an ever-free run, whatever its ever-free share: rays grazing a wall or a crate's top
  /// from a moving camera mark cells beside the surface free, and a crate that had been in the
  /// map for seconds was labelled dynamic by its ever-free run. A walker's body arrives on
  /// voxels that were free a moment ago; one frame of it beside a wall does not end its run.
  bool static_overrules_ever_free = true;
  /// A detection cut by the left or right image border whose horizontal extent is below this
  /// (m) neither extends nor ends an ever-free run (0: off). The ever-free cells along the
  /// view's sides were partly outside it: while an object stood just beyond the border, the
  /// rays beside it saw the in-view part of its cells empty. A sliver narrower than one
  /// ever-free cell (ever_free.resolution, 0.2 m) lies wholly in such cells, so their evidence
  /// says nothing about it: a standing child and a box corner at the border of a turning camera
  /// were labelled dynamic by it. A walker leaving the view keeps its run.
  float ever_free_min_cut_extent = 0.2f;
  /// On a track never measured fully in view, a detection cut by the left or right image border
  /// votes static when its own side (the box corner furthest from that border in the image)
  /// moved along with the view: no further than a point fixed in the camera's view there did
  /// over the position history, and in its direction. The border sweeping over a static object
  /// slides its visible part: the side face of a box a flying camera passes (corridor_flight) was
  /// labelled dynamic by its votes before any voxel of it was old enough to count as static
  /// structure. A walker keeping pace with the view at the border looks the same, and waits
  /// until it moves ahead of the view or comes into full view (docs/tracker.md).
  bool border_sweep_votes_static = true;

  /// kInvalidArgument for out-of-range values or broken relations (nested configs included;
  /// params::kTrackerRelations, track_params.hpp).
  Status validate() const noexcept;
};

/// One tracked obstacle as the tracker reports it (map frame).
struct TrackedObstacle {
  std::uint32_t id = 0;                                ///< unique within a run, never reused
  Box3 box;                                            ///< filtered centre, estimated full size
  Eigen::Vector3f velocity = Eigen::Vector3f::Zero();  ///< (vx, vy, 0) from the Kalman filter
  float speed = 0.f;                                   ///< |velocity| (m/s)
  /// Covariance of (vx, vy) ((m/s)^2): a planner can weight the velocity by it. The Kalman
  /// filter's (a new track starts wide, tracker.kalman.p0_velocity, and narrows as it is
  /// measured), widened while the box grows or shrinks (velocity_sigma_growth_share).
  Eigen::Matrix2f velocity_covariance = Eigen::Matrix2f::Zero();
  float continuity = 0.f;   ///< last C_con (0 until computable)
  bool dynamic = false;     ///< label after voting
  bool size_fixed = false;  ///< size frozen after k' frames in view
  /// The last matched detection touched the image border (within image_margin): the obstacle
  /// is cut by the view (near the camera or at the edge), its box holds the visible part only
  /// and its size is not fixed from it. Kept while the track coasts.
  bool cut = false;
  std::uint32_t dynamic_votes = 0;   ///< dynamic votes in the current window
  std::uint32_t votes = 0;           ///< votes in the window (<= c)
  std::uint32_t dynamic_streak = 0;  ///< dynamic votes in a row (early label)
  /// Frames in a row this track has been published dynamic (0 while it is not), counted from
  /// its first label the cleaner may trust (not a label inherited from a loss older than
  /// TrackerConfig::inherit_trusted_time alone): how long the label has held, e.g. for the
  /// cleaner, which trusts no label younger than a few frames.
  std::uint32_t dynamic_frames = 0;
  std::uint32_t age = 0;            ///< frames since the track started
  std::uint32_t hits = 0;           ///< frames with a matched detection
  std::uint32_t missed_frames = 0;  ///< consecutive frames without a match
  Stamp last_seen = 0;              ///< stamp of the last matched detection
  /// Index of this frame's detection the track was updated with, -1 when it coasted: lets a
  /// caller (diagnosis tools) relate the estimate to the measurement behind it.
  std::int32_t detection = -1;
};

class Tracker {
 public:
  Tracker() noexcept;
  /// Validates and applies `config` for depth images of image_width x image_height pixels (the
  /// "fully in view" test), dropping all tracks. Bad config, or an image too small for
  /// config.image_margin: kInvalidArgument, no change.
  [[nodiscard]] Status init(const TrackerConfig& config, int image_width,
                            int image_height) noexcept;
  /// One frame: `count` detections (map frame) seen from camera pose T_map_camera at `stamp`.
  /// Errors (nothing changes): kNullData (dets null with count > 0), kCapacityExceeded
  /// (count > kMaxDetections), kNonFinite / kNonUnitQuaternion (pose), kNonFinite /
  /// kInvalidArgument (NaN or inverted box), kTimeNotIncreasing (stamp <= previous stamp).
  [[nodiscard]] Status update(const Detection* dets, std::size_t count, const Pose& T_map_camera,
                              Stamp stamp) noexcept;
  /// Drops all tracks and the stamp; ids keep counting up (never reused within a run).
  void clear() noexcept;

  /// Current obstacles, compact: entries [0, size()) of obstacle_array().
  std::size_t size() const noexcept { return output_count_; }
  const std::array<TrackedObstacle, kMaxTracks>& obstacle_array() const noexcept { return output_; }
  const TrackedObstacle& obstacle(std::size_t i) const noexcept { return output_[i]; }

  /// Past boxes of obstacle i (measured frames only), age 0 = newest, up to f of them.
  std::size_t box_history_size(std::size_t i) const noexcept;
  const Box3& past_box(std::size_t i, std::size_t age) const noexcept;

  /// Detections refused because every track slot was taken (cumulative).
  std::uint64_t refused_tracks() const noexcept { return refused_tracks_; }
  /// Tracks dropped after coasting too long (cumulative).
  std::uint64_t dropped_tracks() const noexcept { return dropped_tracks_; }
  const TrackerConfig& config() const noexcept { return config_; }

 private:
  struct Track {
    TrackedObstacle out;
    TrackFilter kf;
    LabelState label;
    HistoryRing<Eigen::Vector2f, kMaxTrackHistory> positions;  // measured, bias-corrected
    HistoryRing<Box3, kMaxBoxHistory> boxes;
    HistoryRing<Eigen::Vector4f, kMaxTrackHistory> edges;  // detection boxes' top-view min, max
    HistoryRing<Pose, kMaxTrackHistory> views;             // camera pose of each measured frame
    HistoryRing<Eigen::Vector2f, kMaxTrackHistory> velocities;  // the filter's, when measured
    Eigen::Vector2f last_measured = Eigen::Vector2f::Zero();
    Eigen::Vector2f last_measured_velocity = Eigen::Vector2f::Zero();  // then, or the coasting one
    Stamp last_measured_stamp = 0;
    float z_center = 0.f;
    Eigen::Vector3f size = Eigen::Vector3f::Zero();  // estimated full size (fixed once frozen)
    Eigen::Vector3f corrected_with = Eigen::Vector3f::Zero();  // size behind the last correction
    Eigen::Vector3f size_sum = Eigen::Vector3f::Zero();
    Eigen::Vector2f last_raw_size = Eigen::Vector2f::Zero();  // top-view extent last measured
    Eigen::Vector2f growth_rate = Eigen::Vector2f::Zero();    // smoothed d(extent)/dt (m/s)
    std::size_t in_view_frames = 0;
    bool active = false;
    bool seen_in_full = false;  // a detection fully in view has been measured (not only cut)
    bool dormant = false;  // beyond max_missed_frames, kept for reacquire_frames, not published
    bool dynamic_when_measured = false;  // the label after the last measured frame
  };
  /// Where a track labelled dynamic at its last measurement was lost (inherit_time).
  struct LostTrack {
    Eigen::Vector2f position = Eigen::Vector2f::Zero();  // last measured centre
    Eigen::Vector2f velocity = Eigen::Vector2f::Zero();
    float height = 0.f;
    Stamp last_measured_stamp = 0;
  };
  using Measurement = detail::TrackMeasurement;
  using Pair = detail::TrackPair;
  // The steps of update(): input checks, prediction, candidate pairs, coasting, new tracks.
  Status check_input(const Detection* dets, std::size_t count, const Pose& T_map_camera,
                     Stamp stamp) const noexcept;
  void predict_tracks(Stamp stamp) noexcept;
  void associate(std::size_t count) noexcept;
  void coast_unmatched() noexcept;
  /// The filter's velocity replaced by the mean over the measured frames before the newest
  /// (TrackerConfig::coast_velocity_frames); unchanged when there are none.
  void coast_on_earlier_velocity(Track& t) noexcept;
  void mark_own_edges(const Detection* dets, std::size_t count) noexcept;
  void start_tracks(const Detection* dets, std::size_t count, const Pose& view,
                    Stamp stamp) noexcept;
  Measurement measure(const Detection& det, const Eigen::Vector3f& camera,
                      const Eigen::Vector3f* fixed_size) const noexcept;
  bool fully_in_view(const ImageBox& b) const noexcept;
  bool moves_rigidly(const Track& t) const noexcept;
  void start_track(Track& t, const Measurement& m, const Pose& view, Stamp stamp) noexcept;
  void correct_track(Track& t, const Detection& det, bool own_edge, const Pose& view,
                     Stamp stamp) noexcept;
  // The steps of correct_track after the filter update: size estimate (freeze, growth) and
  // the evidence for the label (the continuity filter's vote among it).
  void update_size(Track& t, const Measurement& m) noexcept;
  LabelEvidence evidence(Track& t, const Detection& det, bool own_edge) const noexcept;
  void ever_free_evidence(const Detection& det, LabelEvidence* e) const noexcept;
  /// Cut by the left or right border and narrower than config_.ever_free_min_cut_extent.
  bool border_sliver(const Detection& det) const noexcept;
  /// The image box touches the left or right border (within image_margin).
  bool side_cut(const ImageBox& b) const noexcept;
  /// The own side (away from the cut border) of the detection box `b` moved over the position
  /// history as the view's own motion moves a static object's (border_sweep_votes_static).
  bool view_sweep_explains(const Track& t, const ImageBox& b) const noexcept;
  bool plausible_size(const Eigen::Vector3f& size) const noexcept;
  /// Most of the detection's voxels long occupied (static share above max_static_share).
  bool on_static_structure(const Detection& det) const noexcept {
    return det.static_share > config_.max_static_share;
  }
  void publish() noexcept;
  /// Deactivates a track and counts it; one labelled dynamic when last measured is remembered.
  void drop_track(Track& t) noexcept;
  /// The detection (measured as m) lies where a track labelled dynamic was lost a moment ago;
  /// *velocity is then the nearest such track's velocity at the loss (the one it coasted on)
  /// and *since_loss the seconds since its last measurement.
  bool follows_lost_dynamic(const Measurement& m, Stamp stamp, Eigen::Vector2f* velocity,
                            float* since_loss) const noexcept;

  TrackerConfig config_{};
  int image_width_ = 0;  ///< of the depth images, from init
  int image_height_ = 0;
  std::array<Track, kMaxTracks> tracks_{};
  std::array<TrackedObstacle, kMaxTracks> output_{};
  std::array<std::uint8_t, kMaxTracks> output_slot_{};
  detail::TrackerScratch frame_{};  ///< one update's working memory
  std::size_t output_count_ = 0;
  std::uint32_t next_id_ = 1;
  Stamp last_stamp_ = 0;
  bool has_stamp_ = false;
  std::array<LostTrack, kMaxTracks> lost_{};  ///< ring of the latest losses (inherit_time)
  std::size_t lost_count_ = 0;
  std::size_t lost_next_ = 0;
  std::uint64_t refused_tracks_ = 0;
  std::uint64_t dropped_tracks_ = 0;
};

}  // namespace dynamap
