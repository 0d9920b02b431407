// What a viewer looks with: the camera (and its view frustum, lod/src/camera.cpp) and the
// transfer function (checked once where it arrives, protocol/transfer_function.h). The
// camera comes from the command line (`--camera`) or the browser (camera.set).
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "tetrascope/protocol/transfer_function.h"
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
//   distance in units of the bounding-box diagonal, default kAzimuthCameraDistance)
// Throws std::invalid_argument naming the bad item. `text` may be untrusted.
Camera parse_camera(const std::string& text, const storage::Bounds& bounds);
constexpr double kAzimuthCameraDistance = 1.6;
// The view when none is given (`tetrascope render` without --camera, a server session before
// camera.set): azimuth 30°, elevation 20°, fov 30°, kDefaultViewDistance box diagonals away,
// far enough for the whole bounding sphere to fit the field of view.
constexpr double kDefaultViewDistance = 1.95;

// The size a view of `bounds` is scaled by: the box's diagonal, or, for a box collapsed to a
// point (one tet, coincident vertices, a tiny mesh far from the origin that float32 flattened),
// a size the coordinates can resolve, so a default camera never has its eye on its target.
double view_scale(const storage::Bounds& bounds);
Camera default_camera(const storage::Bounds& bounds);

// Six planes (a, b, c, d); a point is inside when a x + b y + c z + d >= 0 for all.
struct Frustum {
  std::array<std::array<double, 4>, 6> planes{};
  bool intersects(const float box[6]) const;
};
Frustum view_frustum(const Camera& camera, double near_plane, double far_plane);

// Checked once, where it arrives (tf.set, --tf FILE); lod and the renderer take it as is.
using TransferFunction = protocol::TransferFunction;

}  // namespace tetrascope::lod
