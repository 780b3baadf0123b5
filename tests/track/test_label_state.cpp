// One test per transition of LabelState (include/dynamap/track/label_state.hpp).
#include <gtest/gtest.h>

#include "dynamap/track/label_state.hpp"
#include "dynamap/track/tracker.hpp"

namespace dynamap {
namespace {

LabelEvidence vote(bool dynamic, bool slow = false) {
  LabelEvidence e;
  e.voted = true;
  e.dynamic_vote = dynamic;
  e.slow = slow;
  return e;
}

LabelEvidence no_vote(bool in_ever_free, bool plausible_size = true) {
  LabelEvidence e;
  e.in_ever_free = in_ever_free;
  e.plausible_size = plausible_size;
  return e;
}

LabelConfig plain() {  // votes only: no early label, no ever-free label, no hold
  LabelConfig c;
  c.early_votes = 0;
  c.ever_free_frames = 0;
  c.dynamic_hold_frames = 0;
  return c;
}

class LabelStateTest : public ::testing::Test {
 protected:
  void measure(const LabelEvidence& e, std::size_t times = 1) {
    for (std::size_t i = 0; i < times; ++i) s.measured(e, cc, lc);
  }
  // Labels the track dynamic by the vote window (T_c dynamic votes) and keeps it so.
  void make_dynamic_by_votes(std::size_t frames) {
    measure(vote(true), frames);
    ASSERT_EQ(s.mode(), LabelMode::kDynamic);
  }

  ContinuityConfig cc{};
  LabelConfig lc = plain();
  LabelState s;
};

TEST_F(LabelStateTest, StartIsStaticWithoutEverFreeRun) {
  lc.ever_free_frames = 1;
  s.start(no_vote(false), lc);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  EXPECT_FALSE(s.dynamic());
  s.start(no_vote(true, /*plausible_size=*/false), lc);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  lc.ever_free_frames = 2;  // one frame is not a run of two
  s.start(no_vote(true), lc);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, StartIsDynamicOnAnEverFreeRunOfOne) {
  lc.ever_free_frames = 1;
  s.start(no_vote(true), lc);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  EXPECT_TRUE(s.dynamic());
}

TEST_F(LabelStateTest, StartResetsEverything) {
  make_dynamic_by_votes(cc.dynamic_votes);
  s.start(no_vote(false), lc);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  EXPECT_EQ(s.voter().votes(), 0u);
  EXPECT_EQ(s.dynamic_streak(), 0u);
  EXPECT_EQ(s.held_frames(), 0u);
}

TEST_F(LabelStateTest, StartDoesNotCountTowardsTheHold) {
  lc.ever_free_frames = 1;
  lc.dynamic_hold_frames = 5;
  lc.hold_min_dynamic_frames = 1;
  s.start(no_vote(true), lc);
  ASSERT_TRUE(s.dynamic());
  measure(vote(false, /*slow=*/true));  // the label goes while slow: no hold, never counted
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, VoteWindowLabelsDynamicAtTcVotes) {
  s.start(no_vote(false), lc);
  measure(vote(true), cc.dynamic_votes - 1);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  EXPECT_TRUE(s.dynamic());
}

TEST_F(LabelStateTest, VoteWindowHysteresisThenStatic) {
  s.start(no_vote(false), lc);
  make_dynamic_by_votes(cc.vote_window);
  // Dynamic votes fall out of the window: the label stays until <= static_votes are left.
  measure(vote(false), cc.vote_window - cc.static_votes - 1);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  measure(vote(false));
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  EXPECT_FALSE(s.dynamic());
}

TEST_F(LabelStateTest, EarlyRunLabelsDynamic) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(true), 3);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  EXPECT_EQ(s.dynamic_streak(), 4u);
}

LabelEvidence view_bounded() {
  LabelEvidence e;
  e.view_bounded = true;
  return e;
}

// A frame whose box the view and the occluders bound carries no evidence: an early label and
// its run stay as they were, where an abstention (no history, not rigid) ends the run.
TEST_F(LabelStateTest, ViewBoundedFramesNeitherEndNorExtendTheEarlyRun) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(true), 4);
  ASSERT_EQ(s.mode(), LabelMode::kDynamic);
  measure(view_bounded(), 10);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  EXPECT_EQ(s.dynamic_streak(), 4u);
  EXPECT_EQ(s.voter().votes(), 4u);
  measure(vote(true));
  EXPECT_EQ(s.dynamic_streak(), 5u);
  measure(no_vote(false));  // an abstention ends the run: the window (5 of T_c) says static
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, ViewBoundedFramesDoNotStartALabel) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(true), 3);
  measure(view_bounded(), 5);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  EXPECT_EQ(s.dynamic_streak(), 3u);
}

TEST_F(LabelStateTest, EarlyRunNeedsEveryVoteDynamicOnceTheWindowIsFull) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(false), cc.vote_window);
  measure(vote(true), 6);  // never dynamic before: a later run does not count
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, EarlyRunMayFollowStaticVotesWhileTheWindowIsYoung) {
  // A walker stepping out from behind a nearer person, clear of the image border: its
  // first votes are static (continuity not there yet), then it votes dynamic on every frame.
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(false), 3);
  measure(vote(true), 3);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  lc.early_while_young = false;  // the rule off: every vote so far must have been dynamic
  s.start(no_vote(false), lc);
  measure(vote(false), 3);
  measure(vote(true), 4);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, EarlyRunAfterStaticVotesNeedsAFullView) {
  // A static thing cut by the image border, just reached by the view and with no static
  // evidence in the map yet, can vote dynamic after static votes, so only a run whose
  // detections were all clear of the left and right border labels a track after static votes.
  lc.early_votes = 4;
  const LabelEvidence first = no_vote(false);
  LabelEvidence cut = vote(true);
  cut.side_cut = true;
  s.start(first, lc);
  measure(vote(false), 3);
  measure(vote(true), 2);
  measure(cut);  // one side-cut frame spoils the whole run
  measure(vote(true), 5);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  s.start(first, lc);
  measure(vote(false), 3);
  measure(cut, 2);
  measure(vote(false));  // a new run in full view counts
  measure(vote(true), 3);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  s.start(first, lc);
  measure(cut, 4);  // every vote dynamic: the early label as before, cut or not
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

TEST_F(LabelStateTest, EarlyRunLabelsOnlyWithinTheMapsRange) {
  // Beyond early_max_depth the map holds no static evidence to stop a sliding wall end, so the
  // early run waits; the vote window still decides, and a walker coming nearer is labelled at
  // the first frame of its run within range.
  lc.early_votes = 4;
  LabelEvidence far = vote(true);
  far.near_depth = lc.early_max_depth + 0.5f;
  s.start(no_vote(false), lc);
  measure(far, cc.dynamic_votes - 1);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  EXPECT_EQ(s.dynamic_streak(), cc.dynamic_votes - 1);
  LabelEvidence near = far;
  near.near_depth = lc.early_max_depth;
  measure(near);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);

  s.start(no_vote(false), lc);
  measure(far, cc.dynamic_votes);  // T_c of c: dynamic at any range
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);

  // An early run beyond the range counts as a label earned: after static votes fill the window,
  // E dynamic votes within range re-label the track, as they do a walker after a pause.
  s.start(no_vote(false), lc);
  measure(far, 4);
  measure(vote(false), cc.vote_window);
  measure(near, 3);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(near);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);

  lc.early_max_depth = 0.f;  // no limit
  s.start(no_vote(false), lc);
  measure(far, 4);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

TEST_F(LabelStateTest, EarlyRunSurvivesAbstentionsBeforeItButNotInsideIt) {
  // Frames without a vote (a walker still stepping out from behind a pillar) leave "every vote
  // dynamic" alone, but a run of E dynamic votes must not straddle one.
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(no_vote(false), 10);
  measure(vote(true), 2);
  measure(no_vote(false));
  EXPECT_EQ(s.dynamic_streak(), 0u);
  measure(vote(true), 3);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

TEST_F(LabelStateTest, EarlyLabelWithdrawnByAStaticVote) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(true), 4);
  ASSERT_EQ(s.mode(), LabelMode::kDynamic);
  measure(vote(false));
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  EXPECT_EQ(s.dynamic_streak(), 0u);
}

TEST_F(LabelStateTest, EarlyLabelWithdrawnByAMissedFrame) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(true), 4);
  ASSERT_TRUE(s.dynamic());
  s.missed();
  EXPECT_EQ(s.mode(), LabelMode::kCoasting);
  EXPECT_FALSE(s.dynamic());  // the vote window alone: 4 of T_c votes
  EXPECT_EQ(s.dynamic_streak(), 0u);
  measure(vote(true), 3);  // a new run: dynamic before, so it counts once it is 4 long
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

TEST_F(LabelStateTest, MissedFrameAfterAVoteEndsTheFirstEarlyRun) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  measure(vote(true), 2);
  s.missed();  // never labelled dynamic: the early label needs a new track now
  measure(vote(true), 6);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, MissedFrameBeforeTheFirstVoteKeepsTheEarlyRun) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  s.missed();
  measure(vote(true), 4);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

TEST_F(LabelStateTest, EarlyRunRelabelsATrackThatWasDynamic) {
  lc.early_votes = 4;
  s.start(no_vote(false), lc);
  make_dynamic_by_votes(cc.dynamic_votes);
  measure(vote(false), cc.vote_window);  // static again
  ASSERT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true), 3);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

// A track that stood still (slower than v_min on restart_slow_frames measured frames) and was
// never dynamic is labelled by E dynamic votes after a full window of static ones; one that
// stood still for fewer frames, or with the rule off, waits for T_c of c.
TEST_F(LabelStateTest, EarlyRunLabelsATrackThatStoodStill) {
  lc.early_votes = 4;
  lc.early_while_young = false;
  for (const std::size_t slow : {std::size_t{20}, std::size_t{14}}) {
    for (const std::size_t rule : {std::size_t{15}, std::size_t{0}}) {
      lc.restart_slow_frames = rule;
      s.start(no_vote(false), lc);
      measure(vote(false, /*slow=*/true), slow);
      measure(vote(false), cc.vote_window);  // a full window of static votes
      measure(vote(true), 3);
      ASSERT_FALSE(s.dynamic());
      measure(vote(true));
      EXPECT_EQ(s.dynamic(), slow >= 15 && rule > 0) << "slow " << slow << " rule " << rule;
    }
  }
}

// A new track where a dynamic track was lost a moment ago starts dynamic and keeps the label
// through abstentions and dynamic votes; a static vote or a missed frame withdraws it, and so
// does leaving the early run's range. An implausible size or a start beyond the range gets none.
TEST_F(LabelStateTest, LabelFromALostDynamicTrackHoldsUntilContradicted) {
  lc.early_votes = 4;
  LabelEvidence follows = no_vote(false);
  follows.follows_lost_dynamic = true;
  follows.near_depth = 3.f;
  const auto started = [&] {
    s.start(follows, lc);
    return s.dynamic();
  };
  EXPECT_TRUE(started());
  measure(no_vote(false));  // no history yet: no vote
  EXPECT_TRUE(s.dynamic());
  measure(vote(true), 2);
  EXPECT_TRUE(s.dynamic());
  measure(vote(false));
  EXPECT_FALSE(s.dynamic());

  ASSERT_TRUE(started());
  s.missed();
  EXPECT_FALSE(s.dynamic());
  measure(no_vote(false));
  EXPECT_FALSE(s.dynamic());

  ASSERT_TRUE(started());
  LabelEvidence far = no_vote(false);
  far.near_depth = 6.f;  // beyond early_max_depth (5 m)
  measure(far);
  EXPECT_FALSE(s.dynamic());

  follows.plausible_size = false;
  EXPECT_FALSE(started());
  follows.plausible_size = true;
  follows.near_depth = 6.f;
  EXPECT_FALSE(started());
  follows.follows_lost_dynamic = false;
  follows.near_depth = 3.f;
  EXPECT_FALSE(started());
}

TEST_F(LabelStateTest, EverFreeRunLabelsDynamicBeforeAnyVote) {
  lc.ever_free_frames = 3;
  s.start(no_vote(true), lc);
  measure(no_vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(no_vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  measure(no_vote(false));  // the run ends: the votes (none yet) decide
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, EverFreeRunNeedsAPlausibleSize) {
  lc.ever_free_frames = 2;
  s.start(no_vote(true), lc);
  measure(no_vote(true, /*plausible_size=*/false), 5);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, EverFreeRunOverridesStaticVotes) {
  lc.ever_free_frames = 2;
  s.start(no_vote(false), lc);
  LabelEvidence e = vote(false);
  e.in_ever_free = true;
  measure(e);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  measure(e);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

TEST_F(LabelStateTest, MissedFrameEndsTheEverFreeRun) {
  lc.ever_free_frames = 2;
  s.start(no_vote(true), lc);
  s.missed();
  measure(no_vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kStatic);  // a run of 1 after the gap
  measure(no_vote(true));
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
}

TEST_F(LabelStateTest, EverFreeFramesOnStaticStructureNeitherStartNorEndARun) {
  lc.ever_free_frames = 2;
  LabelEvidence overruled = no_vote(true);
  overruled.ever_free_overruled = true;
  s.start(overruled, lc);
  measure(overruled, 30);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);  // a crate long in the map: no run ever starts
  measure(no_vote(true), 2);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  measure(overruled);
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);  // a walker one frame beside a wall keeps its run
  measure(no_vote(false));
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST_F(LabelStateTest, CoastingKeepsOnlyTheVoteWindowLabel) {
  s.start(no_vote(false), lc);
  make_dynamic_by_votes(cc.dynamic_votes);
  s.missed();
  EXPECT_EQ(s.mode(), LabelMode::kCoasting);
  EXPECT_TRUE(s.dynamic());
  s.missed();
  EXPECT_TRUE(s.dynamic());
  LabelState fresh;
  fresh.missed();
  EXPECT_FALSE(fresh.dynamic());
}

class LabelHoldTest : public LabelStateTest {
 protected:
  void SetUp() override {
    lc.dynamic_hold_frames = 3;
    lc.hold_min_dynamic_frames = 2;
    s.start(no_vote(false), lc);
    make_dynamic_by_votes(cc.vote_window);                       // 5 frames dynamic >= 2
    measure(vote(false), cc.vote_window - cc.static_votes - 1);  // still dynamic (hysteresis)
    ASSERT_EQ(s.mode(), LabelMode::kDynamic);
  }
};

TEST_F(LabelHoldTest, SlowTrackLosingItsLabelIsHeld) {
  measure(vote(false, /*slow=*/true));
  EXPECT_EQ(s.mode(), LabelMode::kHeld);
  EXPECT_TRUE(s.dynamic());
  EXPECT_EQ(s.held_frames(), 1u);
}

TEST_F(LabelHoldTest, FastTrackLosingItsLabelIsNotHeld) {
  measure(vote(false, /*slow=*/false));
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
  EXPECT_FALSE(s.dynamic());
  measure(vote(false, /*slow=*/true));  // slows down later: the hold starts then
  EXPECT_EQ(s.mode(), LabelMode::kHeld);
}

TEST_F(LabelHoldTest, HoldRunsOnWhileFastAndThenIsSpent) {
  measure(vote(false, true));
  measure(vote(false, false), 2);  // walks off again: the hold runs on
  EXPECT_EQ(s.mode(), LabelMode::kHeld);
  EXPECT_EQ(s.held_frames(), 3u);
  measure(vote(false, true));
  EXPECT_EQ(s.mode(), LabelMode::kHoldSpent);
  EXPECT_FALSE(s.dynamic());
  measure(vote(false, true), 5);  // no second hold while slow
  EXPECT_EQ(s.mode(), LabelMode::kHoldSpent);
}

TEST_F(LabelHoldTest, EvidenceEndsTheHold) {
  lc.early_votes = 2;
  measure(vote(false, true));
  ASSERT_EQ(s.mode(), LabelMode::kHeld);
  measure(vote(true), 2);  // was dynamic before: an early run relabels
  EXPECT_EQ(s.mode(), LabelMode::kDynamic);
  EXPECT_EQ(s.held_frames(), 0u);
  measure(vote(false, true));  // a new hold may start
  EXPECT_EQ(s.mode(), LabelMode::kHeld);
}

TEST_F(LabelHoldTest, MissedFramesDoNotExtendTheHold) {
  measure(vote(false, true));
  ASSERT_EQ(s.held_frames(), 1u);
  s.missed();
  EXPECT_EQ(s.mode(), LabelMode::kCoasting);
  EXPECT_FALSE(s.dynamic());  // the vote window says static
  EXPECT_EQ(s.held_frames(), 1u);
  measure(vote(false, false));  // the hold resumes although fast
  EXPECT_EQ(s.mode(), LabelMode::kHeld);
  EXPECT_EQ(s.held_frames(), 2u);
}

TEST_F(LabelHoldTest, NoHoldWhenDisabled) {
  lc.dynamic_hold_frames = 0;
  measure(vote(false, true));
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST(LabelStateHold, NoHoldBeforeEnoughDynamicFrames) {
  const ContinuityConfig cc{};
  LabelConfig lc = plain();
  lc.early_votes = 2;
  lc.dynamic_hold_frames = 10;
  lc.hold_min_dynamic_frames = 3;
  LabelState s;
  s.start(no_vote(false), lc);
  s.measured(vote(true), cc, lc);
  s.measured(vote(true), cc, lc);
  s.measured(vote(true), cc, lc);  // 2 frames labelled dynamic (early)
  ASSERT_EQ(s.mode(), LabelMode::kDynamic);
  s.measured(vote(false, true), cc, lc);
  EXPECT_EQ(s.mode(), LabelMode::kStatic);
}

TEST(LabelConfig, Validate) {
  EXPECT_EQ(LabelConfig{}.validate(), Status::kOk);
  LabelConfig c;
  c.early_votes = kMaxVoteWindow + 1;
  EXPECT_EQ(c.validate(), Status::kInvalidArgument);
  c = LabelConfig{};
  c.hold_min_dynamic_frames = 0;
  EXPECT_EQ(c.validate(), Status::kInvalidArgument);
  c = LabelConfig{};
  c.dynamic_hold_frames = 100001;
  EXPECT_EQ(c.validate(), Status::kInvalidArgument);
}

// early_votes against the vote window relates two configs: the tracker's rule.
TEST(LabelConfig, EarlyVotesBeyondTheWindowAreRefusedByTheTracker) {
  TrackerConfig t;
  t.label.early_votes = t.continuity.vote_window + 1;
  EXPECT_EQ(t.label.validate(), Status::kOk);
  EXPECT_EQ(t.validate(), Status::kInvalidArgument);
}

}  // namespace
}  // namespace dynamap
