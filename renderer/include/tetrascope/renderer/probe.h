// The hover probe (ParaView's): the point under a pixel of a view and the field there - the
// nearest hit of the pixel's ray with a slice, an isosurface (in iso mode) or the boundary of
// the scene drawn (clipped, when a clip is set; the boundary in front of a slice or
// isosurface counts only in surface mode), with the attribute interpolated linearly -
// and every point attribute of the mesh at that point (values_at).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

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

// One point attribute at a point: its components interpolated (one for a scalar) and, with
// several, the magnitude of the interpolated vector.
struct PointValue {
  std::string name;
  std::vector<double> components;
  double magnitude = 0;
};
// Every point attribute of `scene` (SceneMesh::attributes) at `position`, interpolated
// linearly in the tet holding it: a slice's or an isosurface's point lies inside one, a
// boundary point on one within rounding (the tet it is least outside of, within 1e-4 of its
// barycentric range). Empty when no tet holds it or the scene has no attributes (a clipped
// scene: pass the unclipped one, whose tets hold every point of the clipped). Scans the tets.
std::vector<PointValue> values_at(const SceneMesh& scene, const std::array<double, 3>& position);

}  // namespace tetrascope::renderer
