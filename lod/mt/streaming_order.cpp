// Segment streaming order, dissertation §6.1.3: a walk over the segment adjacency graph that
// always loads the candidate adding the fewest new candidates, and releases a segment once
// it and all its neighbours have been loaded.
#include "tetrascope/lod/mt/streaming_order.h"

#include <algorithm>
#include <limits>
#include <set>

namespace tetrascope::lod {

StreamOrder streaming_order(const std::vector<std::vector<uint32_t>>& neighbours, std::span<const std::array<float, 6>> bounds) {
  const size_t count = neighbours.size();
  StreamOrder result;
  std::vector<uint32_t> pending(count);  // neighbours not loaded yet
  for (size_t s = 0; s < count; ++s) pending[s] = static_cast<uint32_t>(neighbours[s].size());
  std::vector<uint8_t> loaded(count, 0), candidate(count, 0), released(count, 0);
  std::array<float, 3> corner{std::numeric_limits<float>::max(), std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
  for (const auto& b : bounds) {
    for (int k = 0; k < 3; ++k) corner[k] = std::min(corner[k], b[k]);
  }
  auto distance = [&](size_t s) {
    double d = 0;
    for (int k = 0; k < 3; ++k) d += (double(bounds[s][k]) - corner[k]) * (double(bounds[s][k]) - corner[k]);
    return d;
  };
  std::set<uint32_t> candidates;
  uint32_t active = 0;
  auto release = [&](uint32_t s) {
    result.tags.push_back(-static_cast<int64_t>(s) - 1);
    released[s] = 1;
    --active;
  };
  while (result.order.size() < count) {
    if (candidates.empty()) {  // start, or a new component: the unloaded segment nearest the corner
      uint32_t best = 0;
      double best_distance = std::numeric_limits<double>::max();
      for (uint32_t s = 0; s < count; ++s) {
        if (!loaded[s] && distance(s) < best_distance) {
          best = s;
          best_distance = distance(s);
        }
      }
      candidates.insert(best);
      candidate[best] = 1;
    }
    // the candidate that adds the fewest new candidates (ties: lowest id)
    uint32_t pick = 0;
    size_t fewest = std::numeric_limits<size_t>::max();
    for (uint32_t c : candidates) {
      size_t added = 0;
      for (uint32_t n : neighbours[c]) added += !loaded[n] && !candidate[n];
      if (added < fewest) {
        fewest = added;
        pick = c;
      }
    }
    candidates.erase(pick);
    candidate[pick] = 0;
    loaded[pick] = 1;
    result.order.push_back(pick);
    result.tags.push_back(static_cast<int64_t>(pick) + 1);
    ++active;
    result.max_workload = std::max(result.max_workload, active);
    for (uint32_t n : neighbours[pick]) {
      if (!loaded[n] && !candidate[n]) {
        candidates.insert(n);
        candidate[n] = 1;
      }
      if (--pending[n] == 0 && loaded[n] && !released[n]) release(n);
    }
    if (pending[pick] == 0 && !released[pick]) release(pick);
  }
  return result;
}

}  // namespace tetrascope::lod
