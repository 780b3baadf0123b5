#include "dynamap/track/label_state.hpp"

#include "dynamap/track/track_params.hpp"

namespace dynamap {

Status LabelConfig::validate() const noexcept {
  return all_in_range(*this, params::kLabel) ? Status::kOk : Status::kInvalidArgument;
}

void LabelState::start(const LabelEvidence& e, const LabelConfig& config) noexcept {
  *this = LabelState{};
  ever_free_streak_ = e.in_ever_free && !e.ever_free_overruled ? 1 : 0;
  const bool in_range = config.early_max_depth <= 0.f || e.near_depth <= config.early_max_depth;
  inherited_ = e.follows_lost_dynamic && e.plausible_size && in_range;
  const bool ever_free = ever_free_run(e, config);
  trusted_ = ever_free || (inherited_ && e.lost_recently);
  mode_ = ever_free || inherited_ ? LabelMode::kDynamic : LabelMode::kStatic;
}

void LabelState::measured(const LabelEvidence& e, const ContinuityConfig& continuity,
                          const LabelConfig& config) noexcept {
  if (!e.in_ever_free) {
    ever_free_streak_ = 0;
  } else if (!e.ever_free_overruled) {
    ++ever_free_streak_;
  }
  if (e.view_bounded) {
    if (ever_free_run(e, config)) {
      trusted_ = true;
      mode_ = LabelMode::kDynamic;
    } else if (mode_ == LabelMode::kCoasting) {
      mode_ = voter_.dynamic() ? LabelMode::kDynamic : LabelMode::kStatic;
    }
    return;
  }
  if (e.slow && slow_frames_ < kMaxLabelCount) ++slow_frames_;
  bool votes_say = false;
  if (e.voted) {
    voter_.push(e.dynamic_vote, continuity);
    dynamic_streak_ = e.dynamic_vote ? dynamic_streak_ + 1 : 0;
    side_cut_in_streak_ = (dynamic_streak_ > 1 && side_cut_in_streak_) || e.side_cut;
    if (!e.dynamic_vote) {
      every_vote_dynamic_ = false;
      inherited_ = false;
    }
    // The early run counts for a track whose votes were all dynamic, one dynamic before (or with
    // an early run beyond the range), one that stood still, or a young one (window not full, no
    // gap) whose run was in full view. It labels only within early_max_depth.
    const bool stood_still =
        config.restart_slow_frames > 0 && slow_frames_ >= config.restart_slow_frames;
    const bool young_run = config.early_while_young && !side_cut_in_streak_;
    const bool early_run =
        config.early_votes > 0 && dynamic_streak_ >= config.early_votes &&
        (every_vote_dynamic_ || dynamic_frames_ > 0 || early_run_beyond_range_ || stood_still ||
         (young_run && !missed_after_vote_ && voter_.votes() < continuity.vote_window));
    const bool in_range = config.early_max_depth <= 0.f || e.near_depth <= config.early_max_depth;
    if (early_run && !in_range) early_run_beyond_range_ = true;
    votes_say = voter_.dynamic() || (early_run && in_range);
  } else {
    dynamic_streak_ = 0;  // an abstention (no history yet, or not rigid) ends the early run
  }
  const bool inherited =
      inherited_ && (config.early_max_depth <= 0.f || e.near_depth <= config.early_max_depth);
  const bool own = votes_say || ever_free_run(e, config);
  if (own || inherited) {
    trusted_ = trusted_ || own;
    mode_ = LabelMode::kDynamic;
    held_frames_ = 0;
    if (dynamic_frames_ < kMaxLabelCount) ++dynamic_frames_;
    return;
  }
  hold_or_drop(e, config);
}

void LabelState::hold_or_drop(const LabelEvidence& e, const LabelConfig& config) noexcept {
  const std::size_t hold = config.dynamic_hold_frames;
  const bool holding = held_frames_ > 0;
  // A hold starts only on a track slower than v_min (a stop); one whose votes turn static while
  // it still moves (non-rigid, implausible size) gets none. Once started it runs on while the
  // person walks off again, until the votes take over or it runs out.
  if (hold == 0 || dynamic_frames_ < config.hold_min_dynamic_frames || (!holding && !e.slow)) {
    mode_ = LabelMode::kStatic;
  } else if (held_frames_ < hold) {
    ++held_frames_;
    mode_ = LabelMode::kHeld;
  } else {
    mode_ = LabelMode::kHoldSpent;
  }
}

void LabelState::missed() noexcept {
  // The early and ever-free labels need an unbroken run: a gap ends both runs.
  dynamic_streak_ = 0;
  ever_free_streak_ = 0;
  inherited_ = false;
  if (voter_.votes() > 0) {
    every_vote_dynamic_ = false;
    missed_after_vote_ = true;
  }
  mode_ = LabelMode::kCoasting;
}

bool LabelState::dynamic() const noexcept {
  switch (mode_) {
    case LabelMode::kDynamic:
    case LabelMode::kHeld:
      return true;
    case LabelMode::kCoasting:
      return voter_.dynamic();
    case LabelMode::kStatic:
    case LabelMode::kHoldSpent:
      break;
  }
  return false;
}

bool LabelState::ever_free_run(const LabelEvidence& e, const LabelConfig& config) const noexcept {
  return config.ever_free_frames > 0 && ever_free_streak_ >= config.ever_free_frames &&
         e.plausible_size;
}

}  // namespace dynamap
