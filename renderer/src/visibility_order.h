// The volume pass's CPU half: which tets can show under the transfer function (a tet whose
// value range maps to zero opacity everywhere is skipped), their back-to-front order by
// centroid depth (LSD radix sort on the float key), and which of them reach the region
// between the eye and the near plane inside the view (their front faces are clipped there, so
// the renderer draws their back faces and starts the segments at the near plane; under
// perspective also those that cross the near plane's whole plane inside the view frustum,
// whose projection the projected tetrahedra cannot classify). Tets that
// contain a perspective eye go last: along every ray through them they are the nearest.
// Scratch buffers are kept between frames.
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
  void set_transfer_function(const view::TransferFunction& tf, double lo, double hi);
  // Isovalues composed in the volume, over [lo, hi] (0..1): a tet whose range holds one is
  // drawn even where the transfer function is transparent.
  void set_isovalues(std::vector<float> isos) { isos_ = std::move(isos); }
  // The tets that can show, farthest first; counts drawn and skipped tets into `timings`.
  // `near_depth`: the near plane's distance from the eye along the view direction.
  std::span<const uint32_t> sort(const SceneMesh& mesh, const TetSortInputs& tets, double lo, double hi, const Frame& frame, double near_depth,
                                 FrameTimings& timings);
  // Positions in the last order whose tets reach nearer than the near plane inside the view.
  std::span<const uint32_t> near_positions() const { return near_positions_; }

 private:
  // `corner`: the distance from a perspective eye to the near rectangle's corners.
  bool holds_isovalue(float a, float b, double lo, double hi) const;
  bool reaches_near_region(const TetSortInputs& tets, size_t t, const Frame& frame, double near_depth, double corner) const;

  static constexpr int kValueSlots = 1024;
  std::vector<int> visible_prefix_;
  std::vector<float> isos_;  // slices with opacity among the first i
  std::vector<uint32_t> keys_, keys2_, ids_, ids2_, near_positions_;
  std::vector<uint8_t> near_;  // per tet, during a sort
};

}  // namespace tetrascope::renderer
