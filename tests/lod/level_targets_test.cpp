// Levels simplified to a common error (lod/level_targets.h): the level's tets go to
// the ceilings whose collapses cost most; every target is a count the ceiling's trace reached;
// every ceiling is simplified at least to max_ratio; the total meets the level's target.
#include <gtest/gtest.h>

#include <algorithm>
#include <stdexcept>

#include "tetrascope/lod/mt/level_targets.h"

namespace tetrascope::testing {
namespace {

// A ceiling of `tets` tets whose collapses remove `step` tets each at cost `cost` times the
// collapse's rank (costs grow as simplification goes on, as a quadric queue's do).
lod::CeilingTrace trace(uint64_t tets, uint64_t step, double cost, uint64_t down_to) {
  lod::CeilingTrace t{tets, {}};
  uint64_t alive = tets;
  for (int i = 1; alive > down_to + step - 1; ++i) {
    alive -= step;
    t.steps.push_back({alive, cost * i});
  }
  return t;
}

bool in_trace(const lod::CeilingTrace& t, uint64_t target) {
  if (target == t.tets) return true;
  return std::any_of(t.steps.begin(), t.steps.end(), [&](const auto& s) { return s.first == target; });
}

TEST(LevelTargets, TheCheapCeilingGivesUpMoreTetsThanTheDearOne) {
  // two ceilings of 1000 tets; the smooth one's collapses cost a hundredth of the varied one's
  const std::vector<lod::CeilingTrace> traces{trace(1000, 6, 0.01, 60), trace(1000, 6, 1.0, 60)};
  const auto targets = lod::common_error_targets(traces, 500, 0.5);
  ASSERT_EQ(targets.size(), 2u);
  EXPECT_LE(targets[0] + targets[1], 500u);
  EXPECT_GT(targets[0] + targets[1], 500u - 6) << "the total stops at the first step that meets the target";
  EXPECT_LT(targets[0], 250u) << "the smooth ceiling is simplified further than a common ratio would";
  EXPECT_GT(targets[1], 250u) << "the varied ceiling keeps more than a common ratio would";
  EXPECT_LE(targets[1], 500u) << "every ceiling is simplified at least to max_ratio";
  for (size_t k = 0; k < 2; ++k) EXPECT_TRUE(in_trace(traces[k], targets[k])) << "target " << targets[k] << " of ceiling " << k << " is no count its trace reached";
}

TEST(LevelTargets, EqualCeilingsGetEqualShares) {
  const std::vector<lod::CeilingTrace> traces{trace(800, 4, 0.5, 40), trace(800, 4, 0.5, 40), trace(800, 4, 0.5, 40)};
  const auto targets = lod::common_error_targets(traces, 600, 0.5);
  const auto [lo, hi] = std::minmax_element(targets.begin(), targets.end());
  EXPECT_LE(*hi - *lo, 4u) << "ceilings with the same costs end within one collapse of each other";
  EXPECT_LE(targets[0] + targets[1] + targets[2], 600u);
}

TEST(LevelTargets, MaxRatioIsMetEvenWhereCollapsesAreDear) {
  // the dear ceiling's collapses cost more than any of the cheap one's, and the target is
  // loose: the cheap one alone could meet it, yet the dear one is still halved
  const std::vector<lod::CeilingTrace> traces{trace(1000, 10, 1e-6, 10), trace(1000, 10, 1e6, 10)};
  const auto targets = lod::common_error_targets(traces, 1100, 0.5);
  EXPECT_LE(targets[1], 500u);
  EXPECT_GT(targets[1], 490u) << "no more than max_ratio asks of the dear ceiling";
  EXPECT_LE(targets[0] + targets[1], 1100u);
}

TEST(LevelTargets, AnUnreachableTargetTakesEveryTraceToItsEnd) {
  const std::vector<lod::CeilingTrace> traces{trace(1000, 10, 1.0, 200), trace(500, 5, 2.0, 100), lod::CeilingTrace{300, {}}};
  const auto targets = lod::common_error_targets(traces, 10, 0.5);
  EXPECT_EQ(targets[0], traces[0].steps.back().first);
  EXPECT_EQ(targets[1], traces[1].steps.back().first);
  EXPECT_EQ(targets[2], 300u) << "a ceiling that could not be simplified keeps its tets";
}

TEST(LevelTargets, ABlockedCeilingDoesNotDriveTheOthersPastTheErrorItStoppedAt) {
  // The first ceiling's border locks it at 600 of its 1000 tets (its trace was asked for 62)
  // after cheap collapses; the second could go on, but past 500 tets its collapses cost a
  // thousand times more (a thin feature going). The level's target, 600, cannot be met
  // without the locked tets: they count as removed at the cost the first stopped at.
  lod::CeilingTrace blocked = trace(1000, 10, 1e-4, 600);
  blocked.goal = 62;
  lod::CeilingTrace free = trace(1000, 10, 1e-4, 500);
  for (int i = 1; i <= 40; ++i) free.steps.push_back({500 - 10 * uint64_t(i), 1.0 * i});
  free.goal = 62;
  const auto targets = lod::common_error_targets(std::vector<lod::CeilingTrace>{blocked, free}, 600, 0.5);
  EXPECT_EQ(targets[0], 600u) << "the blocked ceiling ends where its trace ended";
  EXPECT_EQ(targets[1], 500u) << "the free ceiling takes all the cheap collapses and none of the dear ones";
  // without a goal the traces are taken as ending by their costs, and the free one goes on
  blocked.goal = free.goal = 0;
  const auto forced = lod::common_error_targets(std::vector<lod::CeilingTrace>{blocked, free}, 600, 0.5);
  EXPECT_EQ(forced[1], free.steps.back().first);
}

// The common error caps the locked runs of the level (mt_levels.cpp): it must be the cost at
// which the total was met, no ceiling kept past it and none taken beyond it.
TEST(LevelTargets, TheThresholdIsTheErrorAtWhichTheTotalWasMet) {
  const std::vector<lod::CeilingTrace> traces{trace(1000, 6, 0.01, 60), trace(1000, 6, 1.0, 60)};
  double threshold = -1;
  const auto targets = lod::common_error_targets(traces, 500, 1.0, &threshold);
  ASSERT_GT(threshold, 0);
  for (size_t k = 0; k < 2; ++k) {
    double running = 0, next = -1;
    for (const auto& [alive, cost] : traces[k].steps) {
      running = std::max(running, cost);
      if (alive >= targets[k]) {
        EXPECT_LE(running, threshold) << "ceiling " << k << " took a collapse dearer than the threshold";
      } else if (next < 0) {
        next = running;
      }
    }
    if (next >= 0) {
      EXPECT_GE(next, threshold) << "ceiling " << k << " stopped before a collapse cheaper than the threshold";
    }
  }
  double none = -1;
  lod::common_error_targets(traces, 5000, 1.0, &none);
  EXPECT_EQ(none, 0) << "a total met without collapses has no threshold";
}

TEST(LevelTargets, ABadMaxRatioIsRefused) {
  const std::vector<lod::CeilingTrace> traces{trace(100, 1, 1.0, 10)};
  EXPECT_THROW(lod::common_error_targets(traces, 50, 0), std::invalid_argument);
  EXPECT_THROW(lod::common_error_targets(traces, 50, 1.5), std::invalid_argument);
  EXPECT_NO_THROW(lod::common_error_targets(traces, 50, 1.0));
  EXPECT_TRUE(lod::common_error_targets({}, 50, 0.5).empty());
}

}  // namespace
}  // namespace tetrascope::testing
