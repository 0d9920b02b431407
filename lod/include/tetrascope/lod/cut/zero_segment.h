// The 0-segment of dissertation §6.2.3: every triangle on a border between two patches of the
// DAG (a segment border, or a border between patches of one segment), held once, each with
// two docking slots. A patch on the front docks its border faces there; the face across a
// border face is the other slot's occupant. Swapping patches (a refinement or coarsening of
// the cut) touches only the slots of the patches that leave and join, never their neighbours,
// where rebuilding the cut mesh's adjacency hashes every border face of the whole front.
//
// The store's segments keep their own layout (segments.bin is shared with the
// multi-triangulation): instead of the triangle's index in the tets' opposites, each patch
// holds the list of its border faces (tet, face, triangle), sorted, read from its segment
// once when the 0-segment is built.
#pragma once

#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::lod {

// Two patches would dock on one slot pair already full: the front is not conforming (an
// over-shared face).
class ZeroSegmentError : public std::runtime_error {
 public:
  explicit ZeroSegmentError(const std::string& message) : std::runtime_error(message) {}
};

class ZeroSegment {
 public:
  static constexpr uint32_t kEmpty = 0xFFFFFFFFu;
  // A tet face of a patch: the tet's index in its floor segment and the face (0-3, opposite
  // that corner).
  struct Dock {
    uint32_t patch = kEmpty, tet = 0, face = 0;
    bool empty() const { return patch == kEmpty; }
  };
  struct Border {
    uint32_t tet_face;  // 4 · tet + face
    uint32_t triangle;
  };

  // Reads every segment of the DAG once (through `cache`) for its patches' border faces.
  ZeroSegment(storage::SegmentCache& cache, const Dag& dag);

  uint32_t triangle_count() const { return static_cast<uint32_t>(slots_.size() / 2); }
  size_t bytes() const { return slots_.size() * sizeof(Dock) + borders_.size() * sizeof(Border) + first_.size() * sizeof(uint32_t); }
  std::span<const Border> borders(uint32_t patch) const { return {borders_.data() + first_[patch], first_[patch + 1] - first_[patch]}; }

  // The patch joins the front: its border faces take a free slot each. Throws ZeroSegmentError
  // (changing nothing) when a triangle's slots are both taken.
  void dock(uint32_t patch);
  // The patch leaves the front: its slots are freed.
  void undock(uint32_t patch);
  // The swaps of one cut update: `removed` leave, then `added` join (CutChanges' lists).
  void swap(std::span<const uint32_t> removed, std::span<const uint32_t> added);
  // Brings the docked patches to the cut's active ones (undocks the others first); returns the
  // patches docked and undocked.
  size_t follow(const Cut& cut);
  void clear();
  bool docked(uint32_t patch) const { return docked_[patch] != 0; }

  // The face across tet `tet` (of the patch's floor segment), face `face`, of a docked patch:
  // another patch's face, empty when nothing is docked there, or when it is no border face.
  Dock across(uint32_t patch, uint32_t tet, uint32_t face) const;
  // Occupied slots of a triangle (0, 1 or 2).
  uint32_t occupants(uint32_t triangle) const { return uint32_t(!slots_[2 * size_t{triangle}].empty()) + uint32_t(!slots_[2 * size_t{triangle} + 1].empty()); }

 private:
  std::vector<uint32_t> first_;  // per patch: its borders [first_[p], first_[p + 1])
  std::vector<Border> borders_;  // sorted by tet_face within a patch
  std::vector<Dock> slots_;      // two per triangle
  std::vector<uint8_t> docked_;
};

}  // namespace tetrascope::lod
