// Camera parsing (--camera), the view frame (projection, rays, the share of the view a box
// covers) and the view frustum a cut is restricted to.
#include "tetrascope/view/camera.h"

#include <algorithm>
#include <cmath>
#include <optional>
#include <stdexcept>

#include "tetrascope/storage/parse_number.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::view {
namespace {

using V3 = Vec3;
// zero stays zero (the checks below rely on it)
V3 unit(const V3& a) { return normalise(a, V3{0, 0, 0}); }

double number(const std::string& key, const std::string& text) {
  double v = 0;
  if (!parse_number(text, v) || !std::isfinite(v)) throw std::invalid_argument("--camera: " + key + " expects numbers, got '" + text + "'");
  return v;
}

}  // namespace

double view_scale(const storage::Bounds& bounds) {
  const V3 lo{bounds.min[0], bounds.min[1], bounds.min[2]}, hi{bounds.max[0], bounds.max[1], bounds.max[2]};
  const double diagonal = std::sqrt(dot(hi - lo, hi - lo));
  double far_from_origin = 0;  // a box far from the origin needs a distance its coordinates can resolve
  for (int k = 0; k < 3; ++k) far_from_origin = std::max({far_from_origin, std::fabs(lo[k]), std::fabs(hi[k])});
  if (!std::isfinite(far_from_origin)) return 1;
  if (!std::isfinite(diagonal)) return 1;
  // a box within a few float32 steps of a point: a size its coordinates resolve, seen around it
  const double scale = std::max(diagonal, 1e-5 * far_from_origin);
  return scale > 0 ? scale : 1;
}

Camera default_camera(const storage::Bounds& bounds) {
  return parse_camera("azimuth=30,elevation=20,fov=30,distance=" + std::to_string(kDefaultViewDistance), bounds);
}

Camera parse_camera(const std::string& text, const storage::Bounds& bounds) {
  std::vector<std::pair<std::string, std::vector<std::string>>> items;
  size_t at = 0;
  while (at <= text.size()) {
    size_t comma = text.find(',', at);
    if (comma == std::string::npos) comma = text.size();
    std::string item = text.substr(at, comma - at);
    at = comma + 1;
    if (item.empty()) continue;
    size_t eq = item.find('=');
    if (eq != std::string::npos) {
      items.push_back({item.substr(0, eq), {item.substr(eq + 1)}});
    } else if (item == "ortho" || item == "perspective") {
      items.push_back({item, {}});
    } else if (!items.empty()) {
      items.back().second.push_back(item);
    } else {
      throw std::invalid_argument("--camera: '" + item + "' is not key=value");
    }
  }
  Camera c;
  const V3 centre{(bounds.min[0] + bounds.max[0]) / 2, (bounds.min[1] + bounds.max[1]) / 2, (bounds.min[2] + bounds.max[2]) / 2};
  const double diagonal = view_scale(bounds);
  std::optional<double> azimuth, elevation, distance;
  bool eye = false, target = false;
  auto vec = [](const std::string& key, const std::vector<std::string>& v) {
    if (v.size() != 3) throw std::invalid_argument("--camera: " + key + " expects three numbers");
    return V3{number(key, v[0]), number(key, v[1]), number(key, v[2])};
  };
  auto one = [](const std::string& key, const std::vector<std::string>& v) {
    if (v.size() != 1) throw std::invalid_argument("--camera: " + key + " expects one number");
    return number(key, v[0]);
  };
  for (const auto& [key, values] : items) {
    if (key == "eye") {
      c.eye = vec(key, values);
      eye = true;
    } else if (key == "target") {
      c.target = vec(key, values);
      target = true;
    } else if (key == "up") {
      c.up = vec(key, values);
    } else if (key == "fov") {
      c.fov_degrees = one(key, values);
      if (!(c.fov_degrees > 1 && c.fov_degrees < 170)) throw std::invalid_argument("--camera: fov must be in (1, 170) degrees");
    } else if (key == "azimuth") {
      azimuth = one(key, values);
    } else if (key == "elevation") {
      elevation = one(key, values);
      if (std::fabs(*elevation) > 90) throw std::invalid_argument("--camera: elevation must be in [-90, 90]");
    } else if (key == "distance") {
      distance = one(key, values);
      if (!(*distance > 0)) throw std::invalid_argument("--camera: distance must be > 0");
    } else if (key == "ortho") {
      c.orthographic = true;
    } else if (key == "perspective") {
      c.orthographic = false;
    } else {
      throw std::invalid_argument("--camera: unknown key '" + key + "' (eye, target, up, fov, azimuth, elevation, distance, ortho)");
    }
  }
  if (azimuth || elevation || distance) {
    if (eye) throw std::invalid_argument("--camera: give eye/target or azimuth/elevation, not both");
    const double az = (azimuth ? *azimuth : 30) * M_PI / 180, el = (elevation ? *elevation : 20) * M_PI / 180, d = (distance ? *distance : kAzimuthCameraDistance) * diagonal;
    // z up; azimuth from +x towards +y
    c.target = target ? c.target : centre;
    c.eye = {c.target[0] + d * std::cos(el) * std::cos(az), c.target[1] + d * std::cos(el) * std::sin(az), c.target[2] + d * std::sin(el)};
    c.up = std::fabs(std::sin(el)) > 0.999 ? V3{0, 1, 0} : V3{0, 0, 1};
  } else if (!eye) {
    if (!items.empty() && !target) throw std::invalid_argument("--camera: give eye=X,Y,Z (and target) or azimuth/elevation");
    Camera d = parse_camera("azimuth=30,elevation=20", bounds);
    if (target) {
      V3 offset = (d.eye - d.target);
      d.target = c.target;
      d.eye = {c.target[0] + offset[0], c.target[1] + offset[1], c.target[2] + offset[2]};
    }
    d.fov_degrees = c.fov_degrees;
    d.orthographic = c.orthographic;
    c = d;
  }
  if (dot((c.eye - c.target), (c.eye - c.target)) <= 0) throw std::invalid_argument("--camera: eye and target coincide");
  if (dot(cross(unit((c.target - c.eye)), unit(c.up)), cross(unit((c.target - c.eye)), unit(c.up))) < 1e-12) {
    throw std::invalid_argument("--camera: up is parallel to the view direction");
  }
  c.ortho_height = std::sqrt(dot((c.eye - c.target), (c.eye - c.target))) * 2 * std::tan(c.fov_degrees * M_PI / 360);
  return c;
}

bool Frustum::intersects(const float box[6]) const {
  for (const auto& p : planes) {
    // the box corner furthest along the plane normal
    const double x = p[0] >= 0 ? box[3] : box[0], y = p[1] >= 0 ? box[4] : box[1], z = p[2] >= 0 ? box[5] : box[2];
    if (p[0] * x + p[1] * y + p[2] * z + p[3] < 0) return false;
  }
  return true;
}

ViewFrame ViewFrame::of(const Camera& c) {
  ViewFrame f;
  f.eye = c.eye;
  const V3 view = c.target - c.eye;
  f.distance = length(view);
  f.forward = unit(view);
  const V3 side = cross(f.forward, c.up);
  f.valid = f.distance > 0 && length(side) > 0;
  if (f.valid) {
    f.right = unit(side);
    f.up = cross(f.right, f.forward);
  }
  f.tan_half = std::tan(c.fov_degrees * M_PI / 360);
  f.ortho = c.orthographic;
  f.half_height = c.ortho_height / 2;
  f.aspect = std::max(c.aspect, 1e-6);
  return f;
}

ViewFrame ViewFrame::of(const Camera& c, uint32_t width, uint32_t height) {
  ViewFrame f = of(c);
  f.aspect = double(width) / std::max(1u, height);
  f.width = width;
  f.height = height;
  return f;
}

void ViewFrame::ray(int x, int y, V3* origin, V3* direction) const {
  const double u = 2 * (x + 0.5) / width - 1, v = 1 - 2 * (y + 0.5) / height;
  if (ortho) {
    for (int k = 0; k < 3; ++k) (*origin)[k] = eye[k] + u * half_height * aspect * right[k] + v * half_height * up[k];
    *direction = forward;
    return;
  }
  *origin = eye;
  V3 d;
  for (int k = 0; k < 3; ++k) d[k] = forward[k] + u * tan_half * aspect * right[k] + v * tan_half * up[k];
  *direction = normalise(d);
}

bool ViewFrame::project(const V3& p, double* px, double* py) const {
  const V3 q = p - eye;
  const double x = dot(q, right), y = dot(q, up), z = dot(q, forward);
  double u, v;
  if (ortho) {
    u = x / (half_height * aspect);
    v = y / half_height;
  } else {
    if (z <= 1e-12) {
      *px = *py = 0;
      return false;
    }
    u = x / (z * tan_half * aspect);
    v = y / (z * tan_half);
  }
  *px = (u + 1) * width / 2 - 0.5;
  *py = (1 - v) * height / 2 - 0.5;
  return true;
}

// (A bounding sphere, clamped to 1, gave every large box reaching past the view the share of
// the whole view: the cut's error weights and the frame cost both take this rectangle.)
double ViewFrame::box_share(const storage::Bounds& b) const {
  double lo[2] = {1e300, 1e300}, hi[2] = {-1e300, -1e300};
  for (int corner = 0; corner < 8; ++corner) {
    const V3 p{(corner & 1) ? b.max[0] : b.min[0], (corner & 2) ? b.max[1] : b.min[1], (corner & 4) ? b.max[2] : b.min[2]};
    const double z = depth(p);
    if (!ortho && z <= 1e-9 * distance) return 1.0;  // reaches the eye's plane: fills the view
    const auto xy = ndc(p, z);
    for (int k = 0; k < 2; ++k) {
      lo[k] = std::min(lo[k], xy[k]);
      hi[k] = std::max(hi[k], xy[k]);
    }
  }
  const double w = std::clamp(hi[0], -1.0, 1.0) - std::clamp(lo[0], -1.0, 1.0);
  const double h = std::clamp(hi[1], -1.0, 1.0) - std::clamp(lo[1], -1.0, 1.0);
  return std::max(0.0, w) * std::max(0.0, h) / 4;
}

double ViewFrame::box_share(const float box[6]) const {
  storage::Bounds b;
  for (int k = 0; k < 3; ++k) {
    b.min[k] = box[k];
    b.max[k] = box[3 + k];
  }
  return box_share(b);
}

Frustum view_frustum(const Camera& c, double near_plane, double far_plane) {
  const ViewFrame frame = ViewFrame::of(c);
  const V3 forward = frame.forward, right = frame.right, up = frame.up;
  Frustum f;
  auto plane = [&](const V3& n, const V3& point) { return std::array<double, 4>{n[0], n[1], n[2], -dot(n, point)}; };
  const V3 near_point{c.eye[0] + near_plane * forward[0], c.eye[1] + near_plane * forward[1], c.eye[2] + near_plane * forward[2]};
  const V3 far_point{c.eye[0] + far_plane * forward[0], c.eye[1] + far_plane * forward[1], c.eye[2] + far_plane * forward[2]};
  f.planes[0] = plane(forward, near_point);
  f.planes[1] = plane(V3{-forward[0], -forward[1], -forward[2]}, far_point);
  const double half_v = c.fov_degrees * M_PI / 360, half_h = std::atan(std::tan(half_v) * c.aspect);
  if (c.orthographic) {
    const double h = c.ortho_height / 2, w = h * c.aspect;
    f.planes[2] = plane(right, V3{c.eye[0] - w * right[0], c.eye[1] - w * right[1], c.eye[2] - w * right[2]});
    f.planes[3] = plane(V3{-right[0], -right[1], -right[2]}, V3{c.eye[0] + w * right[0], c.eye[1] + w * right[1], c.eye[2] + w * right[2]});
    f.planes[4] = plane(up, V3{c.eye[0] - h * up[0], c.eye[1] - h * up[1], c.eye[2] - h * up[2]});
    f.planes[5] = plane(V3{-up[0], -up[1], -up[2]}, V3{c.eye[0] + h * up[0], c.eye[1] + h * up[1], c.eye[2] + h * up[2]});
    return f;
  }
  auto side = [&](const V3& axis, double half, double sign) {
    // normal of the plane through the eye that leans `half` from forward towards sign*axis
    V3 n{std::cos(half) * -sign * axis[0] + std::sin(half) * forward[0], std::cos(half) * -sign * axis[1] + std::sin(half) * forward[1],
         std::cos(half) * -sign * axis[2] + std::sin(half) * forward[2]};
    return plane(unit(n), c.eye);
  };
  f.planes[2] = side(right, half_h, 1);
  f.planes[3] = side(right, half_h, -1);
  f.planes[4] = side(up, half_v, 1);
  f.planes[5] = side(up, half_v, -1);
  return f;
}

}  // namespace tetrascope::view
