// The hover probe (ParaView's): the point under a pixel of a view and the field there - the
// nearest hit of the pixel's ray with a slice, an isosurface (in iso mode) or the boundary of
// the scene drawn (clipped, when a clip is set), with the attribute interpolated linearly.
#pragma once

#include <array>
#include <optional>
#include <string>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

struct ProbeHit {
  std::string surface;  // "slice", "isosurface" or "boundary"; empty: the ray hits nothing
  std::array<double, 3> position{};
  double value = 0;                      // the scene's attribute (vector magnitude for vectors)
  std::optional<double> iso_color_value;  // the iso-colour attribute, when the scene has one
  double distance = 0;                   // along the ray from the eye
};

// (x, y): pixel coordinates of `settings`' image, (0, 0) the top-left corner; outside the
// image: no hit. Scans the whole scene (one click, not every frame).
ProbeHit probe(const SceneMesh& scene, const RenderSettings& settings, double x, double y);

}  // namespace tetrascope::renderer
