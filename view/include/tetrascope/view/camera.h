// What a viewer looks with: the camera, from the command line (`--camera`) or the browser
// (camera.set), and its one view frame: the basis, the projection of points and rays through
// pixels (the GL renderer and the CPU reference agree pixel for pixel through it), the share
// of the view a box covers (the cut's criteria, the server's frame cost) and the frustum.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "tetrascope/storage/mesh.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::view {

struct Camera {
  std::array<double, 3> eye{0, 0, 1}, target{0, 0, 0}, up{0, 1, 0};
  double fov_degrees = 30;   // vertical; perspective
  bool orthographic = false;
  double ortho_height = 1;   // visible height for orthographic views
  double aspect = 1;         // width / height
  bool operator==(const Camera&) const = default;
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

// A camera's frame in a view of width x height pixels.
struct ViewFrame {
  Vec3 eye{}, forward{0, 0, -1}, right{1, 0, 0}, up{0, 1, 0};
  double tan_half = 0.27;     // perspective: tan of half the vertical field of view
  double half_height = 1;     // orthographic: half the visible height
  double aspect = 1;          // width / height
  double distance = 1;        // eye to target
  bool ortho = false;
  bool valid = true;          // false for a degenerate camera (eye on the target, up along the view)
  uint32_t width = 1, height = 1;

  // The frame of `camera` in a view of width x height (its aspect ratio from them).
  static ViewFrame of(const Camera& camera, uint32_t width, uint32_t height);
  // The frame of `camera` with its own aspect ratio (a view of unknown pixels).
  static ViewFrame of(const Camera& camera);

  // The view's half-extent at unit depth (orthographic: in units) across and up.
  double half_w() const { return (ortho ? half_height : tan_half) * aspect; }
  double half_h() const { return ortho ? half_height : tan_half; }
  double depth(const Vec3& p) const { return dot(p - eye, forward); }
  // The point in normalised view coordinates ([-1, 1] across the view), for depth z > 0.
  std::array<double, 2> ndc(const Vec3& p, double z) const {
    const Vec3 d = p - eye;
    const double scale = ortho ? 1.0 : 1.0 / z;
    return {dot(d, right) * scale / half_w(), dot(d, up) * scale / half_h()};
  }
  // The ray through the centre of pixel (x, y), row 0 at the top.
  void ray(int x, int y, Vec3* origin, Vec3* direction) const;
  // Pixel coordinates (x right, y down, pixel centres at integers) of a point; false when it
  // is behind the eye.
  bool project(const Vec3& p, double* px, double* py) const;
  // The share of the view a box (lo x, y, z, hi x, y, z) covers: the screen rectangle around
  // its projected corners, clipped to the view, over the view's area; 1 with a corner at or
  // behind the eye.
  double box_share(const float box[6]) const;
  double box_share(const storage::Bounds& bounds) const;
};

// Six planes (a, b, c, d); a point is inside when a x + b y + c z + d >= 0 for all.
struct Frustum {
  std::array<std::array<double, 4>, 6> planes{};
  bool intersects(const float box[6]) const;
};
Frustum view_frustum(const Camera& camera, double near_plane, double far_plane);

}  // namespace tetrascope::view
