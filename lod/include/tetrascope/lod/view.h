// What a viewer looks with: the camera (and its view frustum) and the transfer function.
// Both come from the command line (`--camera`, `--tf FILE`) or, later, from the browser,
// in the same forms.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::lod {

struct Camera {
  std::array<double, 3> eye{0, 0, 1}, target{0, 0, 0}, up{0, 1, 0};
  double fov_degrees = 30;   // vertical; perspective
  bool orthographic = false;
  double ortho_height = 1;   // visible height for orthographic views
  double aspect = 1;         // width / height
};

// `text`: comma-separated key=value items; a value may run over several items:
//   eye=X,Y,Z,target=X,Y,Z[,up=X,Y,Z][,fov=DEG][,ortho]
//   azimuth=DEG,elevation=DEG[,distance=D][,fov=DEG][,ortho]   (about the centre of `bounds`;
//   distance in units of the bounding-box diagonal, default 1.6)
// Throws std::invalid_argument naming the bad item.
Camera parse_camera(const std::string& text, const storage::Bounds& bounds);
// A camera that shows the whole box from azimuth 30°, elevation 20°.
Camera default_camera(const storage::Bounds& bounds);

// Six planes (a, b, c, d); a point is inside when a x + b y + c z + d >= 0 for all.
struct Frustum {
  std::array<std::array<double, 4>, 6> planes{};
  bool intersects(const float box[6]) const;
};
Frustum view_frustum(const Camera& camera, double near_plane, double far_plane);

// Transfer function: a colormap and a piecewise-linear opacity over a value range of one
// attribute. JSON (the same the browser sends):
//   {"attribute": "Temp", "range": [lo, hi], "colormap": "viridis",
//    "opacity": [[value, alpha], ...], "colors": [[value, r, g, b], ...]}
// values in the attribute's own units; alpha and r, g, b in [0, 1]; outside the points the
// end values hold; without "opacity" a ramp from 0 to 1 over the range; "colors" (user
// colour points) replace the colormap; without "range" the attribute's full range.
struct TransferFunction {
  std::string attribute;
  std::optional<std::array<double, 2>> range;
  std::string colormap = "viridis";
  std::vector<std::array<double, 2>> opacity;  // (value, alpha), ascending values
  std::vector<std::array<double, 4>> colors;   // (value, r, g, b), ascending values; empty: the colormap
  // Opacity at a value.
  double alpha(double value) const;
  // The user colour at a value (colors must not be empty).
  std::array<float, 3> user_color(double value) const;
  static TransferFunction from_json(const nlohmann::json& j);  // throws std::invalid_argument
  nlohmann::json to_json() const;
};

}  // namespace tetrascope::lod
