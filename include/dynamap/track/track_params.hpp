// Parameter tables of the track stage: Kalman filter, continuity filter, label rules and tracker.
// One row per config field (core/parameter.hpp): member path, unit, valid range, tier, help; the
// default is the struct's member initialiser. The configs' validate() checks these ranges; the
// pipeline assembles the tables into PipelineConfig's (src/pipeline/parameters.cpp).
#pragma once

#include "dynamap/core/parameter.hpp"
#include "dynamap/track/continuity_filter.hpp"
#include "dynamap/track/kalman_filter.hpp"
#include "dynamap/track/label_state.hpp"
#include "dynamap/track/tracker.hpp"

namespace dynamap::params {
using namespace param_rows;  // NOLINT(google-build-using-namespace): U, C, X, kOpen, ...

inline constexpr ParamChoice kMotionModels[] = {
    {"cv", static_cast<int>(MotionModel::kConstantVelocity)},
    {"imm", static_cast<int>(MotionModel::kTurnImm)},
};
/// The parameters of KalmanConfig, one row per field (PipelineConfig prefix "tracker.kalman.").
inline constexpr Param<KalmanConfig> kKalman[] = {
    // clang-format off
    {DYNAMAP_PARAM(KalmanConfig, p0_position), X, "m^2", 0, kInf, kOpen, kOpen, "initial position variance"},
    {DYNAMAP_PARAM(KalmanConfig, p0_velocity), X, "(m/s)^2", 0, kInf, kOpen, kOpen, "initial velocity variance"},
    {DYNAMAP_PARAM(KalmanConfig, q_position), X, "m^2", 0, kInf, kOpen, kOpen, "position process noise per reference interval (cv)"},
    {DYNAMAP_PARAM(KalmanConfig, q_velocity), X, "(m/s)^2", 0, kInf, kOpen, kOpen, "velocity process noise per reference interval (cv)"},
    {DYNAMAP_PARAM(KalmanConfig, r_position), X, "m^2", 0, kInf, kOpen, kOpen, "position measurement variance"},
    {DYNAMAP_PARAM(KalmanConfig, r_velocity), X, "(m/s)^2", 0, kInf, kOpen, kOpen, "velocity measurement variance (cv)"},
    {DYNAMAP_PARAM(KalmanConfig, q_reference_dt), X, "s", 0, kInf, kOpen, kOpen, "interval q_position and q_velocity refer to"},
    {DYNAMAP_PARAM(KalmanConfig, model), X, "", 0, 1, kClosed, kClosed, "motion model: cv (original) or imm (adds the coordinated turn)", kMotionModels, 2},
    // clang-format on
};
static_assert(paths_unique(kKalman));

/// The parameters of ImmConfig, one row per field (PipelineConfig prefix "tracker.kalman.imm.").
inline constexpr Param<ImmConfig> kImm[] = {
    // clang-format off
    {DYNAMAP_PARAM(ImmConfig, q_accel_straight), X, "m^2/s^3", 0, kInf, kOpen, kOpen, "acceleration noise density of the straight mode"},
    {DYNAMAP_PARAM(ImmConfig, q_accel_turn), X, "m^2/s^3", 0, kInf, kOpen, kOpen, "acceleration noise density of the turn mode"},
    {DYNAMAP_PARAM(ImmConfig, q_turn_rate), X, "rad^2/s^3", 0, kInf, kOpen, kOpen, "turn-rate noise density of the turn mode"},
    {DYNAMAP_PARAM(ImmConfig, p0_turn_rate), X, "rad^2/s^2", 0, kInf, kOpen, kOpen, "initial turn-rate variance"},
    {DYNAMAP_PARAM(ImmConfig, max_turn_rate), X, "rad/s", 0, kInf, kOpen, kOpen, "turn rate clamp"},
    {DYNAMAP_PARAM(ImmConfig, mean_straight_time), X, "s", 0, kInf, kOpen, kOpen, "expected stay in the straight mode"},
    {DYNAMAP_PARAM(ImmConfig, mean_turn_time), X, "s", 0, kInf, kOpen, kOpen, "expected stay in the turn mode"},
    // clang-format on
};
static_assert(paths_unique(kImm));

/// The parameters of ContinuityConfig, one row per field (PipelineConfig prefix
/// "tracker.continuity.").
inline constexpr Param<ContinuityConfig> kContinuity[] = {
    // clang-format off
    {DYNAMAP_PARAM(ContinuityConfig, displacement_frames), X, "frames", 1, kMaxTrackHistory, kClosed, kClosed, "n: displacements span n history states"},
    {DYNAMAP_PARAM(ContinuityConfig, continuity_threshold), X, "", -kInf, kInf, kOpen, kOpen, "T_con: mean cosine of successive displacements that votes dynamic"},
    {DYNAMAP_PARAM(ContinuityConfig, min_speed), U, "m/s", -kInf, kInf, kOpen, kOpen, "slower obstacles vote static"},
    {DYNAMAP_PARAM(ContinuityConfig, vote_window), X, "frames", 1, kMaxVoteWindow, kClosed, kClosed, "c: votes kept"},
    {DYNAMAP_PARAM(ContinuityConfig, dynamic_votes), X, "", 1, kMaxVoteWindow, kClosed, kClosed, "T_c: this many dynamic votes of c label dynamic"},
    {DYNAMAP_PARAM(ContinuityConfig, static_votes), X, "", 0, kMaxVoteWindow, kClosed, kClosed, "this many or fewer dynamic votes label static"},
    {DYNAMAP_PARAM(ContinuityConfig, check_size), X, "", 0, 1, kClosed, kClosed, "only obstacles within [min_size, max_size] vote dynamic"},
    {DYNAMAP_PARAM(ContinuityConfig, min_size), U, "m", 0, kInf, kClosed, kOpen, "smallest box (x, y, z) that may vote dynamic"},
    {DYNAMAP_PARAM(ContinuityConfig, max_size), U, "m", 0, kInf, kClosed, kOpen, "largest box (x, y, z) that may vote dynamic"},
    // clang-format on
};
static_assert(paths_unique(kContinuity));

/// Relations between ContinuityConfig fields, checked by ContinuityConfig::validate() after the
/// ranges and named by the pipeline's validate().
inline constexpr Relation<ContinuityConfig> kContinuityRelations[] = {
    {"dynamic_votes", "must be <= tracker.continuity.vote_window",
     [](const ContinuityConfig& c) noexcept { return c.dynamic_votes <= c.vote_window; }},
    {"static_votes", "must be < tracker.continuity.dynamic_votes",
     [](const ContinuityConfig& c) noexcept { return c.static_votes < c.dynamic_votes; }},
    {"max_size", "must be >= tracker.continuity.min_size on every axis",
     [](const ContinuityConfig& c) noexcept {
       return (c.min_size.array() <= c.max_size.array()).all();
     }},
};

/// The parameters of LabelConfig, one row per field (PipelineConfig prefix "tracker.label.").
inline constexpr Param<LabelConfig> kLabel[] = {
    // clang-format off
    {DYNAMAP_PARAM(LabelConfig, early_votes), X, "", 0, kMaxVoteWindow, kClosed, kClosed, "this many consecutive dynamic votes label dynamic early (0: off)"},
    {DYNAMAP_PARAM(LabelConfig, early_while_young), X, "", 0, 1, kClosed, kClosed, "the early run may follow static votes until c votes are cast, if its detections were clear of the left and right image border"},
    {DYNAMAP_PARAM(LabelConfig, early_max_depth), X, "m", 0, kInf, kClosed, kOpen, "the early run labels only detections this near (the map's range: beyond it no static evidence; 0: no limit)"},
    {DYNAMAP_PARAM(LabelConfig, restart_slow_frames), X, "frames", 0, 100000, kClosed, kClosed, "a track slower than v_min on this many frames (it stood still) may be labelled by the early run after static votes (0: off)"},
    {DYNAMAP_PARAM(LabelConfig, dynamic_hold_frames), X, "frames", 0, 100000, kClosed, kClosed, "a confirmed dynamic track keeps its label this long after its votes turn static (0: off)"},
    {DYNAMAP_PARAM(LabelConfig, hold_min_dynamic_frames), X, "frames", 1, 100000, kClosed, kClosed, "frames labelled dynamic before the hold applies"},
    {DYNAMAP_PARAM(LabelConfig, ever_free_frames), X, "frames", 0, kMaxVoteWindow, kClosed, kClosed, "detections in ever-free space in a row that label a track dynamic (0: off)"},
    // clang-format on
};
static_assert(paths_unique(kLabel));

/// The parameters of TrackerConfig, one row per field (PipelineConfig prefix "tracker.").
inline constexpr Param<TrackerConfig> kTracker[] = {
    // clang-format off
    {DYNAMAP_PARAM(TrackerConfig, overlap_threshold), X, "", 0, 1, kOpen, kClosed, "top-view overlap share that pairs a detection with a track"},
    {DYNAMAP_PARAM(TrackerConfig, centre_gate), X, "m", 0, kInf, kClosed, kOpen, "or a top-view centre distance below this"},
    {DYNAMAP_PARAM(TrackerConfig, max_missed_frames), X, "frames", 0, kInf, kClosed, kOpen, "frames a track coasts unmeasured before it is dropped"},
    {DYNAMAP_PARAM(TrackerConfig, reacquire_frames), X, "frames", 0, 1000, kClosed, kClosed, "a track whose votes say dynamic is kept this much longer, unpublished, for a detection to take it up again (0: off)"},
    {DYNAMAP_PARAM(TrackerConfig, coast_velocity_frames), X, "frames", 0, kMaxTrackHistory, kClosed, kClosed, "at its first unmeasured frame a track goes on with its mean velocity over this many measured frames (0: off)"},
    {DYNAMAP_PARAM(TrackerConfig, coast_velocity_skip), X, "frames", 0, kMaxTrackHistory - 1, kClosed, kClosed, "... leaving out this many of the newest (a walker being hidden slides)"},
    {DYNAMAP_PARAM(TrackerConfig, inherit_time), X, "s", 0, 10, kClosed, kClosed, "a new track where a track labelled dynamic was lost this recently starts dynamic, until a static vote or a missed frame (0: off)"},
    {DYNAMAP_PARAM(TrackerConfig, inherit_radius), X, "m", 0, 10, kClosed, kClosed, "... within this distance of the way from the lost track's last centre to where its velocity would carry it"},
    {DYNAMAP_PARAM(TrackerConfig, inherit_radius_growth), X, "m/s", 0, 10, kClosed, kClosed, "... plus this much per second since the lost track's last measurement"},
    {DYNAMAP_PARAM(TrackerConfig, inherit_height_tolerance), X, "m", 0, 10, kClosed, kClosed, "... and whose height differs from the lost track's by at most this"},
    {DYNAMAP_PARAM(TrackerConfig, inherit_trusted_time), X, "s", 0, 10, kClosed, kClosed, "an inherited label counts for the cleaner at once only from a loss this recent; from an older one once the track's own votes label it"},
    {DYNAMAP_PARAM(TrackerConfig, max_coast_time), X, "s", 0, kInf, kOpen, kOpen, "a track unmeasured this long is dropped whatever the frame count"},
    {DYNAMAP_PARAM(TrackerConfig, history_length), X, "frames", 2, kMaxTrackHistory - 1, kClosed, kClosed, "k: positions kept for the continuity filter"},
    {DYNAMAP_PARAM(TrackerConfig, box_history_length), X, "frames", 1, kMaxBoxHistory, kClosed, kClosed, "f: past boxes kept for the cleaner"},
    {DYNAMAP_PARAM(TrackerConfig, size_fix_frames), X, "frames", 1, kInf, kClosed, kOpen, "k': frames fully in view before the size is frozen"},
    {DYNAMAP_PARAM(TrackerConfig, image_margin), X, "px", 0, kMaxImageHeight, kClosed, kClosed, "an image box this close to the border is cut, not fully in view"},
    {DYNAMAP_PARAM(TrackerConfig, size_fix_max_depth), X, "m", 0, kInf, kOpen, kOpen, "only nearer detections count towards the frozen size"},
    {DYNAMAP_PARAM(TrackerConfig, noise_reference_depth), X, "m", 0, kInf, kClosed, kOpen, "measurement noise grows with (depth / this)^4 beyond it (0: off)"},
    {DYNAMAP_PARAM(TrackerConfig, velocity_sigma_growth_share), X, "", 0, kInf, kClosed, kOpen, "reported velocity sigma adds this share of the box's growth rate (0: filter's alone)"},
    {DYNAMAP_PARAM(TrackerConfig, correct_near_surface_bias), X, "", 0, 1, kClosed, kClosed, "move box centres back by half their missing depth"},
    {DYNAMAP_PARAM(TrackerConfig, max_extent_change_ratio), X, "", -kInf, kInf, kOpen, kOpen, "rigid-motion test of the vote (negative: off)"},
    {DYNAMAP_PARAM(TrackerConfig, abstain_when_not_rigid), X, "", 0, 1, kClosed, kClosed, "before a track's first vote, a frame failing only the rigid-motion test casts no vote (not a static one)"},
    {DYNAMAP_PARAM(TrackerConfig, vote_needs_own_edge), X, "", 0, 1, kClosed, kClosed, "a detection whose left and right image edges are both the border or a nearer detection casts no vote"},
    {DYNAMAP_PARAM(TrackerConfig, max_round_footprint), X, "m", 0, kInf, kClosed, kOpen, "bias correction only for footprints up to this long (0: no limit)"},
    {DYNAMAP_PARAM(TrackerConfig, early_displacement_frames), X, "frames", 0, kMaxTrackHistory, kClosed, kClosed, "displacement span of the early votes (0: no early votes)"},
    {DYNAMAP_PARAM(TrackerConfig, size_fix_growth), X, "", 0, 1, kClosed, kClosed, "raise a frozen size to a larger window mean"},
    {DYNAMAP_PARAM(TrackerConfig, refreeze_implausible_size), X, "", 0, 1, kClosed, kClosed, "replace a frozen size failing the size check by a later window mean passing it"},
    {DYNAMAP_PARAM(TrackerConfig, measure_raw_box), X, "", 0, 1, kClosed, kClosed, "measure from the detector's box, not the map-refined one"},
    {DYNAMAP_PARAM(TrackerConfig, compensate_size_steps), X, "", 0, 1, kClosed, kClosed, "keep a step of the frozen size from reading as motion"},
    {DYNAMAP_PARAM(TrackerConfig, compensate_cut_footprint), X, "", 0, 1, kClosed, kClosed, "keep the growing footprint of a border-cut detection from reading as motion"},
    {DYNAMAP_PARAM(TrackerConfig, ever_free_share), X, "", 0, 1, kOpen, kClosed, "share of a detection's surface cells that must be ever free"},
    {DYNAMAP_PARAM(TrackerConfig, max_static_share), X, "", 0, 1, kClosed, kClosed, "detections with more of their voxels long occupied vote static (1: off)"},
    {DYNAMAP_PARAM(TrackerConfig, static_overrules_ever_free), X, "", 0, 1, kClosed, kClosed, "a detection on long-occupied voxels neither extends nor ends an ever-free run"},
    {DYNAMAP_PARAM(TrackerConfig, ever_free_min_cut_extent), X, "m", 0, 10, kClosed, kClosed, "a detection cut by the left or right border and narrower than this neither extends nor ends an ever-free run (0: off)"},
    {DYNAMAP_PARAM(TrackerConfig, border_sweep_votes_static), X, "", 0, 1, kClosed, kClosed, "on a track never fully in view, a detection cut by the left or right border votes static while its own side (away from that border) moves no further than the view there, and along it"},
    // clang-format on
};
static_assert(paths_unique(kTracker));

/// Relations between TrackerConfig fields and its nested configs' (those within one nested
/// config are its own table's), checked by TrackerConfig::validate() after the ranges and named
/// by the pipeline's validate(). The image margin against the camera size is Tracker::init()'s.
inline constexpr Relation<TrackerConfig> kTrackerRelations[] = {
    {"continuity.displacement_frames",
     "must be <= tracker.history_length - 1 (the filter needs n + 2 states)",
     [](const TrackerConfig& c) noexcept {
       return c.continuity.displacement_frames + 1 <= c.history_length;
     }},
    {"label.early_votes", "must be <= tracker.continuity.vote_window",
     [](const TrackerConfig& c) noexcept {
       return c.label.early_votes <= c.continuity.vote_window;
     }},
    {"early_displacement_frames", "must be < tracker.continuity.displacement_frames",
     [](const TrackerConfig& c) noexcept {
       return c.early_displacement_frames < c.continuity.displacement_frames;
     }},
};

}  // namespace dynamap::params
