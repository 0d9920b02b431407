// The tets of every patch in a depth-first order over the faces they share, for the
// connectivity coding of segments (storage/src/segment_codec.cpp). The coder keeps the order
// it is given, and names each tet by a face it shares with an earlier one, counted back from
// it: in the build's order (input order at level 0, the simplifier's at coarser levels) that
// neighbour is often thousands of tets back or missing; depth first, it is mostly the tet just
// before. Dissertation §6.3.3 gets the same from the cut-border machine's own traversal (there
// a vertex FIFO); depth first measured a little smaller here (bench/results/segment_compression.json).
// A patch is a range of its floor segment's tets (dag.bin), so reordering inside one keeps
// every range; opposites and links are computed from the reordered tets afterwards.
#include <vector>

#include "mt_stages.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::lod::mt {

struct OrderScratch {
  FacePairingScratch pairing;
  std::vector<uint32_t> opposite, stack, order, reordered;
  std::vector<uint8_t> visited;
};

namespace {

// Reorders tets [begin, begin + count) of `tets` (4 ids each) depth first, starting from the
// first unvisited tet in the current order whenever a component is done.
void order_range(std::vector<uint32_t>& tets, uint32_t begin, uint32_t count, OrderScratch& s) {
  const std::span<const uint32_t> range(tets.data() + 4 * size_t{begin}, 4 * size_t{count});
  pair_faces(range, s.pairing, s.opposite);
  s.visited.assign(count, 0);
  s.order.clear();
  for (uint32_t seed = 0; seed < count; ++seed) {
    if (s.visited[seed]) continue;
    s.stack.assign(1, seed);
    while (!s.stack.empty()) {
      const uint32_t t = s.stack.back();
      s.stack.pop_back();
      if (s.visited[t]) continue;
      s.visited[t] = 1;
      s.order.push_back(t);
      for (int f = 3; f >= 0; --f) {  // face 0's neighbour is visited next
        const uint32_t o = s.opposite[4 * size_t{t} + size_t(f)];
        if (o != kNoOppositeFace && !s.visited[o / 4]) s.stack.push_back(o / 4);
      }
    }
  }
  s.reordered.resize(range.size());
  for (size_t i = 0; i < s.order.size(); ++i)
    for (int k = 0; k < 4; ++k) s.reordered[4 * i + size_t(k)] = range[4 * size_t{s.order[i]} + size_t(k)];
  std::copy(s.reordered.begin(), s.reordered.end(), tets.begin() + 4 * std::ptrdiff_t{begin});
}

}  // namespace

PatchOrderer::PatchOrderer() : scratch_(std::make_unique<OrderScratch>()) {}
PatchOrderer::~PatchOrderer() = default;

void PatchOrderer::order(std::vector<uint32_t>& tets, std::span<const std::pair<uint32_t, uint32_t>> ranges) {
  for (const auto& [begin, count] : ranges) order_range(tets, begin, count, *scratch_);
}

}  // namespace tetrascope::lod::mt
