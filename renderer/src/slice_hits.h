// The CPU reference's view of slices: per pixel, the nearest slice under the pixel's ray
// (distance along the ray as reference_render measures it) and its lit colour, shaded as the
// GL surface program shades (0.25 + 0.75 |n.d|).
#pragma once

#include <array>
#include <vector>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

struct SliceHits {
  std::vector<float> distance;              // +inf: no slice under the pixel
  std::vector<std::array<float, 3>> rgb;
};
SliceHits slice_hits(const SceneMesh& scene, const RenderSettings& settings, double lo, double hi);

}  // namespace tetrascope::renderer
