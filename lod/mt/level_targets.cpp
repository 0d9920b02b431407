// Per-ceiling targets for a level simplified to a common error (level_targets.h).
#include "tetrascope/lod/mt/level_targets.h"

#include <algorithm>
#include <stdexcept>
#include <tuple>

namespace tetrascope::lod {

std::vector<uint64_t> common_error_targets(std::span<const CeilingTrace> traces, uint64_t total_target, double max_ratio, double* threshold) {
  if (!(max_ratio > 0 && max_ratio <= 1)) throw std::invalid_argument("common_error_targets: max_ratio must be in (0, 1]");
  std::vector<uint64_t> target(traces.size());
  uint64_t total = 0;
  // (running maximum of the cost, ceiling, step) of every optional collapse; step kBlocked:
  // the tets a blocked trace could not remove
  constexpr uint32_t kBlocked = 0xFFFFFFFFu;
  std::vector<std::tuple<double, uint32_t, uint32_t>> optional;
  std::vector<uint64_t> blocked(traces.size(), 0);
  for (uint32_t k = 0; k < traces.size(); ++k) {
    const CeilingTrace& t = traces[k];
    target[k] = t.tets;
    double running = 0;
    bool mandatory = max_ratio < 1;
    for (uint32_t i = 0; i < t.steps.size(); ++i) {
      running = std::max(running, t.steps[i].second);
      if (mandatory) {
        target[k] = t.steps[i].first;
        mandatory = double(t.steps[i].first) > max_ratio * double(t.tets);
      } else {
        optional.emplace_back(running, k, i);
      }
    }
    const uint64_t end = t.steps.empty() ? t.tets : t.steps.back().first;
    if (t.goal && end > t.goal) {
      blocked[k] = end - t.goal;
      optional.emplace_back(running, k, kBlocked);
    }
    total += target[k];
  }
  std::sort(optional.begin(), optional.end());
  if (threshold) *threshold = 0;
  for (const auto& [cost, k, i] : optional) {
    if (total <= total_target) break;
    if (threshold) *threshold = cost;
    if (i == kBlocked) {  // counted, not removed: its target stays where its trace ended
      total -= std::min(total, blocked[k]);
      continue;
    }
    const uint64_t now = traces[k].steps[i].first;
    total -= target[k] - std::min(target[k], now);
    target[k] = std::min(target[k], now);
  }
  return target;
}

}  // namespace tetrascope::lod
