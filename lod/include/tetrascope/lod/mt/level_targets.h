// Per-segment tet targets for one level of the multi-triangulation simplified to a common
// error rather than to a common ratio: every ceiling of a level is first simplified
// far (a cost trace), then each keeps the tets it has where the costs of its collapses, in
// one order across all ceilings (the global queue a whole-mesh decimation would run), pass
// the level's total target. Smooth ceilings end up coarser, varied ones finer.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

namespace tetrascope::lod {

struct CeilingTrace {
  uint64_t tets = 0;  // before simplification
  // per collapse, in order: tets alive after it, its quadric cost (SimplifyReport::cost_trace)
  std::vector<std::pair<uint64_t, double>> steps;
  // the tets the trace was asked to reach (0: none). A trace that ended above it was stopped
  // by the simplifier's checks (topology, geometry, a locked border), not by its costs.
  uint64_t goal = 0;
};

// The tets each ceiling keeps so that the level holds at most `total_target` tets (as near as
// the steps allow) with one error threshold across the ceilings: a ceiling's collapses are
// taken in order of the running maximum of their costs, cheapest first across all ceilings.
// Every ceiling takes at least the collapses that bring it to `max_ratio` of its tets (so it
// is simplified at all) and no more than its trace holds. Each target is a count from its
// trace (or its own tets when it has no steps). The tets a blocked trace could not remove
// (down to its goal) count as removed at the last cost it reached: a whole-mesh queue would
// have taken them about then, and the next level, whose borders lie elsewhere, takes them.
// So a ceiling that cannot go on does not drive the others past the error it stopped at (on
// the 1M blade, when the traces still ran with their borders locked, a level ate the blade's
// tip to reach its total; free-border traces still stop early now and then: 9 times in the
// oxygen post's build, once in ONERA's).
// Throws std::invalid_argument for max_ratio outside (0, 1].
// `threshold`, when given, is set to the common error: the running cost of the last optional
// collapse taken (0 when none was needed).
std::vector<uint64_t> common_error_targets(std::span<const CeilingTrace> traces, uint64_t total_target, double max_ratio, double* threshold = nullptr);

}  // namespace tetrascope::lod
