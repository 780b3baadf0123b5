// The static/dynamic label of one track as a state machine (docs/tracker.md, "Static or
// dynamic"). The tracker turns each frame into events; this class alone decides the label:
//
//   start(e)    -> kDynamic if the ever-free run is already long enough or the detection
//                  follows a lost dynamic track (within range, plausible size), else kStatic
//   measured(e) -> kDynamic    on evidence: T_c of c votes, an early run of dynamic votes, an
//                              ever-free run (before the first vote: the ever-free run only),
//                              or a label from a lost track not yet contradicted
//               -> kHeld       no evidence, hold allowed (labelled dynamic on enough frames) and
//                              either already holding or slower than v_min; up to hold frames
//               -> kHoldSpent  no evidence, the hold ran out: static until new evidence
//               -> kStatic     no evidence and no hold
//               (a measured frame without a vote ends the early run)
//   missed()    -> kCoasting   only the vote window's label; runs of evidence are broken, a hold
//                              in progress resumes at the next measured frame
#pragma once

#include <cstddef>
#include <cstdint>

#include "dynamap/core/status.hpp"
#include "dynamap/track/continuity_filter.hpp"

namespace dynamap {

/// Saturation of the count of frames labelled dynamic: far above any hold_min_dynamic_frames.
inline constexpr std::size_t kMaxLabelCount = std::size_t{1} << 20;

/// The label rules beyond the vote window of ContinuityConfig (docs/tracker.md).
struct LabelConfig {
  /// Early label (0 disables): a track is labelled dynamic as soon as its first `early_votes`
  /// votes were all dynamic, cast on consecutive frames (no missed frame in between), instead of
  /// waiting for T_c of c votes. A walker in view is detected every frame and votes dynamic from
  /// its first vote; the wall pieces and people standing that pass a vote flicker in and out
  /// and start with short runs of dynamic votes, so the default keeps a margin over the longest
  /// run measured (docs/tracker.md, "Static or dynamic"). The label is provisional: a static vote
  /// or a missed frame before the T_c rule holds withdraws it. A track that was dynamic before (a
  /// walker after a pause) may be re-labelled the same way by `early_votes` consecutive dynamic
  /// votes.
  std::size_t early_votes = 4;
  /// The early run may follow static votes while the vote window is not full yet (fewer than c
  /// votes cast), the track was detected on every frame since its first vote and the run's
  /// detections were all clear of the left and right image border: a walker speeding up or
  /// stepping out from behind someone votes static first (continuity or speed not there yet)
  /// and otherwise waited for T_c of c votes. Tracks that flicker in and out (wall pieces,
  /// fragments) still need every vote dynamic, and so does a thing cut by the border, whose
  /// visible part changes with the view and the sensor's dropouts: a box corner or sliver the
  /// view has just reached, with no static evidence in the map yet, can cast four dynamic
  /// votes after static ones.
  bool early_while_young = true;
  /// The early run labels only a detection whose nearest surface is at most this far (m, camera
  /// depth; 0: no limit). Four votes are enough because a wall piece sliding in the view lies on
  /// voxels the map has held for long and votes static; beyond the map's range
  /// (map.max_depth, 5 m) there is no such evidence, and far windows and wall ends sliding
  /// between pillars as the camera flies passed four votes. Beyond it the T_c of c rule decides;
  /// a track with an early run beyond it is then re-labelled like one that was dynamic before.
  float early_max_depth = 5.0f;
  /// A track measured slower than continuity.min_speed on at least this many frames (it stood
  /// still) may be labelled by an early run after static votes, like a walker after a pause
  /// (0: off). A person standing in view from their track's first frame filled the vote window
  /// with static votes, and walking off waited for T_c of c dynamic votes. A static thing is kept
  /// out by the map's static evidence (TrackerConfig::max_static_share), which a stop shorter
  /// than refiner.static_frames may not have built yet (docs/tracker.md).
  std::size_t restart_slow_frames = 15;
  /// Ever-free label (0 disables): a track whose detections lay mostly in space the camera had
  /// observed free (TrackerConfig::ever_free_share) on this many measured frames in a row is
  /// labelled dynamic, whatever its votes: it has moved into empty space. Its size must pass
  /// the continuity filter's size check. A frame without that evidence ends the run and the
  /// label falls back to the votes (docs/tracker.md, "Static or dynamic").
  std::size_t ever_free_frames = 3;
  /// Label hold (0 disables): a track labelled dynamic on at least `hold_min_dynamic_frames`
  /// frames whose label goes while it is slower than continuity.min_speed (it stopped) keeps the
  /// label for up to this many measured frames, through the restart until the votes take over.
  /// A person who stops (at a door, in a queue) is still a person: without the hold the label
  /// goes with the motion and comes back only after new votes once they walk on, and meanwhile
  /// the planner sees a static obstacle and the map takes the person in as static. A track
  /// whose votes turn static while it still moves fast (a sliding wall piece) gets no hold.
  std::size_t dynamic_hold_frames = 90;
  std::size_t hold_min_dynamic_frames = 8;  ///< frames labelled dynamic before a hold applies

  /// kInvalidArgument when a field is outside its range (params::kLabel, track_params.hpp).
  /// early_votes against continuity.vote_window is TrackerConfig's rule (kTrackerRelations).
  Status validate() const noexcept;
};

/// What one frame tells about a track; the tracker computes it, LabelState weighs it.
struct LabelEvidence {
  bool voted = false;         ///< a vote: history long enough, not a rigid-test abstention
  bool dynamic_vote = false;  ///< and the frame voted dynamic (ContinuityFilter and the tracker)
  bool in_ever_free = false;  ///< the detection lay in ever-free space
  /// In ever-free space but on long-occupied voxels (static evidence), or a sliver at the image
  /// border (TrackerConfig::ever_free_min_cut_extent): the frame neither extends nor ends the
  /// ever-free run, so a run cannot start on static structure or in the cells along the view's
  /// sides, and a walker's run is not broken by one frame beside a wall or by leaving the view.
  bool ever_free_overruled = false;
  bool plausible_size = true;  ///< the track's size passes the size check (or the check is off)
  bool slow = false;           ///< the filtered speed is below continuity.min_speed
  float near_depth = 0.f;      ///< camera depth of the detection's nearest surface (m)
  /// The detection's sides are the image border and nearer detections, not the object's own:
  /// its box moves with the view and the occluders. No vote, and the runs and the label stay as
  /// they were (neither extended nor ended).
  bool view_bounded = false;
  /// The detection touches the left or right image border (within the tracker's image_margin).
  bool side_cut = false;
  /// Read at start(): the detection lies where a track labelled dynamic was lost a moment ago
  /// (TrackerConfig::inherit_time). The new track starts labelled dynamic within
  /// early_max_depth, and keeps the label while every vote is dynamic and no frame is missed.
  bool follows_lost_dynamic = false;
  /// ... and that track was measured at most TrackerConfig::inherit_trusted_time ago.
  bool lost_recently = false;
};

/// The states of LabelState: why a track carries its label.
enum class LabelMode : std::uint8_t {
  kStatic,     ///< no evidence of motion and no hold (a new track starts here)
  kDynamic,    ///< evidence this frame: votes, an early run or an ever-free run
  kHeld,       ///< no evidence, but a stop of a track that was dynamic: still labelled dynamic
  kHoldSpent,  ///< the hold ran out: static, and no new hold until new evidence
  kCoasting,   ///< no detection this frame: the vote window's label alone
};

/// One track's label: the vote window, the runs of evidence, the hold and the mode. Fixed size.
class LabelState {
 public:
  /// A new track from its first detection (no vote yet, does not count towards the hold).
  void start(const LabelEvidence& e, const LabelConfig& config) noexcept;
  /// A frame with a matched detection.
  void measured(const LabelEvidence& e, const ContinuityConfig& continuity,
                const LabelConfig& config) noexcept;
  /// A frame without a matched detection.
  void missed() noexcept;

  /// The label: dynamic in kDynamic and kHeld, the vote window's label in kCoasting.
  bool dynamic() const noexcept;
  LabelMode mode() const noexcept { return mode_; }
  const DynamicVoter& voter() const noexcept { return voter_; }
  std::size_t dynamic_streak() const noexcept { return dynamic_streak_; }
  std::size_t held_frames() const noexcept { return held_frames_; }
  /// Labelled dynamic at some frame by its own votes or ever-free run, or from a recent loss
  /// (LabelEvidence::lost_recently). The cleaner counts only such labels: a standing person
  /// uncovered by a walker passing in front takes the walker's label until its votes speak.
  bool trusted() const noexcept { return trusted_; }

 private:
  bool ever_free_run(const LabelEvidence& e, const LabelConfig& config) const noexcept;
  void hold_or_drop(const LabelEvidence& e, const LabelConfig& config) noexcept;

  DynamicVoter voter_;
  LabelMode mode_ = LabelMode::kStatic;
  std::size_t dynamic_streak_ = 0;    ///< dynamic votes in a row on consecutive frames
  std::size_t ever_free_streak_ = 0;  ///< measured frames in a row in ever-free space
  std::size_t dynamic_frames_ = 0;    ///< frames measured() left in kDynamic (saturates)
  std::size_t slow_frames_ = 0;       ///< measured frames slower than v_min (saturates)
  std::size_t held_frames_ = 0;       ///< measured frames of the current hold (0: none)
  bool every_vote_dynamic_ = true;    ///< no static vote and no missed frame since the first vote
  bool missed_after_vote_ = false;    ///< a missed frame since the first vote
  bool side_cut_in_streak_ = false;   ///< a detection of the dynamic streak was side-cut
  bool early_run_beyond_range_ = false;  ///< an early run beyond early_max_depth (not labelled)
  /// Started from a lost dynamic track's label; ends with a static vote or a missed frame.
  bool inherited_ = false;
  bool trusted_ = false;  ///< votes, an ever-free run or a recent loss have labelled it dynamic
};

}  // namespace dynamap
