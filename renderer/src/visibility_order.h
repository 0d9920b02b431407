// The volume pass's CPU half: which tets can show under the transfer function (a tet whose
// value range maps to zero opacity everywhere is skipped), and their back-to-front order by
// centroid depth (LSD radix sort on the float key). Scratch buffers are kept between frames.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "camera_math.h"
#include "scene_geometry.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

class VisibilityOrder {
 public:
  // Marks which of kValueSlots slices of [lo, hi] have any opacity.
  void set_transfer_function(const lod::TransferFunction& tf, double lo, double hi);
  // The tets that can show, farthest first; counts drawn and skipped tets into `timings`.
  std::span<const uint32_t> sort(const TetSortInputs& tets, double lo, double hi, const Frame& frame, FrameTimings& timings);

 private:
  static constexpr int kValueSlots = 1024;
  std::vector<int> visible_prefix_;  // slices with opacity among the first i
  std::vector<uint32_t> keys_, keys2_, ids_, ids2_;
};

}  // namespace tetrascope::renderer
