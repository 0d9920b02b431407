// The 0-segment (§6.2.3): the border triangles of every patch, found once from the segments'
// face adjacency, and the docking slots the front's patches fill.
#include "tetrascope/lod/cut/zero_segment.h"

#include <algorithm>
#include <array>
#include <unordered_map>

namespace tetrascope::lod {
namespace {

struct TriangleKey {
  std::array<uint32_t, 3> v;
  bool operator==(const TriangleKey& o) const { return v == o.v; }
};
struct TriangleHash {
  size_t operator()(const TriangleKey& k) const {
    uint64_t h = k.v[0] * 0x9E3779B97F4A7C15ull;
    h ^= (h >> 29) ^ (uint64_t{k.v[1]} * 0xBF58476D1CE4E5B9ull);
    h ^= (h >> 31) ^ (uint64_t{k.v[2]} * 0x94D049BB133111EBull);
    return static_cast<size_t>(h ^ (h >> 32));
  }
};

}  // namespace

ZeroSegment::ZeroSegment(storage::SegmentCache& cache, const Dag& dag) {
  using storage::store::kMeshBoundary;
  using storage::store::kSegmentBorder;
  std::unordered_map<TriangleKey, uint32_t, TriangleHash> index;
  first_.assign(size_t{dag.patch_count()} + 1, 0);
  // the patches of a floor segment are read with it: patches grouped by floor
  std::vector<std::vector<uint32_t>> patches_of(dag.node_count());
  for (uint32_t p = 0; p < dag.patch_count(); ++p) patches_of[dag.patch(p).floor].push_back(p);
  std::vector<std::vector<Border>> per_patch(dag.patch_count());
  for (uint32_t n = 0; n < dag.node_count(); ++n) {
    if (patches_of[n].empty()) continue;
    const auto segment = cache.get(n);
    const storage::SegmentView& s = segment->view();
    for (uint32_t p : patches_of[n]) {
      const dag::Patch& patch = dag.patch(p);
      if (uint64_t{patch.tet_begin} + patch.tet_count > s.tet_count) throw DagError("patch " + std::to_string(p) + " reaches past its segment's tets");
      for (uint32_t t = patch.tet_begin; t < patch.tet_begin + patch.tet_count; ++t)
        for (uint32_t f = 0; f < 4; ++f) {
          const uint32_t o = s.opposites[4 * size_t{t} + f];
          if (o == kMeshBoundary) continue;
          if (o != kSegmentBorder && o / 4 >= patch.tet_begin && o / 4 < patch.tet_begin + patch.tet_count) continue;  // inside the patch
          TriangleKey key{};
          for (uint32_t k = 0, j = 0; k < 4; ++k)
            if (k != f) key.v[j++] = s.global_ids[s.tets[4 * size_t{t} + k]];
          std::sort(key.v.begin(), key.v.end());
          const auto [it, inserted] = index.try_emplace(key, static_cast<uint32_t>(index.size()));
          per_patch[p].push_back({4 * t + f, it->second});
        }
    }
  }
  for (uint32_t p = 0; p < dag.patch_count(); ++p) {
    std::sort(per_patch[p].begin(), per_patch[p].end(), [](const Border& a, const Border& b) { return a.tet_face < b.tet_face; });
    first_[p] = static_cast<uint32_t>(borders_.size());
    borders_.insert(borders_.end(), per_patch[p].begin(), per_patch[p].end());
  }
  first_[dag.patch_count()] = static_cast<uint32_t>(borders_.size());
  slots_.assign(2 * index.size(), Dock{});
  docked_.assign(dag.patch_count(), 0);
}

void ZeroSegment::dock(uint32_t patch) {
  if (docked_[patch]) return;
  const std::span<const Border> list = borders(patch);
  for (size_t i = 0; i < list.size(); ++i) {
    Dock* slot = &slots_[2 * size_t{list[i].triangle}];
    if (!slot->empty()) ++slot;
    if (!slot->empty()) {
      for (size_t j = 0; j < i; ++j) {  // nothing changed: the slots taken so far are freed
        Dock* s = &slots_[2 * size_t{list[j].triangle}];
        if (s[1].patch == patch) s[1] = Dock{};
        else s[0] = Dock{};
      }
      throw ZeroSegmentError("patch " + std::to_string(patch) + " docks on triangle " + std::to_string(list[i].triangle) +
                             ", already shared by patches " + std::to_string(slot[-1].patch) + " and " + std::to_string(slot->patch) + ": the front is not conforming");
    }
    *slot = Dock{patch, list[i].tet_face / 4, list[i].tet_face % 4};
  }
  docked_[patch] = 1;
}

void ZeroSegment::undock(uint32_t patch) {
  if (!docked_[patch]) return;
  for (const Border& b : borders(patch)) {
    Dock* s = &slots_[2 * size_t{b.triangle}];
    if (s[0].patch == patch && s[0].tet == b.tet_face / 4 && s[0].face == b.tet_face % 4) s[0] = Dock{};
    else if (s[1].patch == patch && s[1].tet == b.tet_face / 4 && s[1].face == b.tet_face % 4) s[1] = Dock{};
  }
  docked_[patch] = 0;
}

void ZeroSegment::swap(std::span<const uint32_t> removed, std::span<const uint32_t> added) {
  for (uint32_t p : removed) undock(p);
  for (uint32_t p : added) dock(p);
}

size_t ZeroSegment::follow(const Cut& cut) {
  size_t changed = 0;
  for (uint32_t p = 0; p < docked_.size(); ++p)
    if (docked_[p] && !cut.active(p)) {
      undock(p);
      ++changed;
    }
  for (uint32_t p = 0; p < docked_.size(); ++p)
    if (!docked_[p] && cut.active(p)) {
      dock(p);
      ++changed;
    }
  return changed;
}

void ZeroSegment::clear() {
  std::fill(slots_.begin(), slots_.end(), Dock{});
  std::fill(docked_.begin(), docked_.end(), uint8_t{0});
}

ZeroSegment::Dock ZeroSegment::across(uint32_t patch, uint32_t tet, uint32_t face) const {
  const std::span<const Border> list = borders(patch);
  const uint32_t key = 4 * tet + face;
  const auto it = std::lower_bound(list.begin(), list.end(), key, [](const Border& b, uint32_t k) { return b.tet_face < k; });
  if (it == list.end() || it->tet_face != key) return Dock{};
  const Dock* s = &slots_[2 * size_t{it->triangle}];
  if (s[0].patch == patch && s[0].tet == tet && s[0].face == face) return s[1];
  if (s[1].patch == patch && s[1].tet == tet && s[1].face == face) return s[0];
  return Dock{};  // not docked
}

}  // namespace tetrascope::lod
