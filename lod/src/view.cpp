#include "tetrascope/lod/view.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tetrascope::lod {
namespace {

using V3 = std::array<double, 3>;
V3 sub(const V3& a, const V3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
V3 cross(const V3& a, const V3& b) { return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]}; }
double dot(const V3& a, const V3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
V3 normalise(const V3& a) {
  double l = std::sqrt(dot(a, a));
  return l > 0 ? V3{a[0] / l, a[1] / l, a[2] / l} : V3{0, 0, 0};
}

double number(const std::string& key, const std::string& text) {
  size_t used = 0;
  double v = 0;
  try {
    v = std::stod(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != text.size() || text.empty() || !std::isfinite(v)) throw std::invalid_argument("--camera: " + key + " expects numbers, got '" + text + "'");
  return v;
}

}  // namespace

Camera default_camera(const storage::Bounds& bounds) { return parse_camera("azimuth=30,elevation=20", bounds); }

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
  const double diagonal = std::max(1e-30, std::sqrt(dot(sub(V3{bounds.max[0], bounds.max[1], bounds.max[2]}, V3{bounds.min[0], bounds.min[1], bounds.min[2]}),
                                                        sub(V3{bounds.max[0], bounds.max[1], bounds.max[2]}, V3{bounds.min[0], bounds.min[1], bounds.min[2]}))));
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
    const double az = (azimuth ? *azimuth : 30) * M_PI / 180, el = (elevation ? *elevation : 20) * M_PI / 180, d = (distance ? *distance : 1.6) * diagonal;
    // z up; azimuth from +x towards +y
    c.target = target ? c.target : centre;
    c.eye = {c.target[0] + d * std::cos(el) * std::cos(az), c.target[1] + d * std::cos(el) * std::sin(az), c.target[2] + d * std::sin(el)};
    c.up = std::fabs(std::sin(el)) > 0.999 ? V3{0, 1, 0} : V3{0, 0, 1};
  } else if (!eye) {
    if (!items.empty() && !target) throw std::invalid_argument("--camera: give eye=X,Y,Z (and target) or azimuth/elevation");
    Camera d = parse_camera("azimuth=30,elevation=20", bounds);
    if (target) {
      V3 offset = sub(d.eye, d.target);
      d.target = c.target;
      d.eye = {c.target[0] + offset[0], c.target[1] + offset[1], c.target[2] + offset[2]};
    }
    d.fov_degrees = c.fov_degrees;
    d.orthographic = c.orthographic;
    c = d;
  }
  if (dot(sub(c.eye, c.target), sub(c.eye, c.target)) <= 0) throw std::invalid_argument("--camera: eye and target coincide");
  if (dot(cross(normalise(sub(c.target, c.eye)), normalise(c.up)), cross(normalise(sub(c.target, c.eye)), normalise(c.up))) < 1e-12) {
    throw std::invalid_argument("--camera: up is parallel to the view direction");
  }
  c.ortho_height = std::sqrt(dot(sub(c.eye, c.target), sub(c.eye, c.target))) * 2 * std::tan(c.fov_degrees * M_PI / 360);
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

Frustum view_frustum(const Camera& c, double near_plane, double far_plane) {
  const V3 forward = normalise(sub(c.target, c.eye));
  const V3 right = normalise(cross(forward, c.up));
  const V3 up = cross(right, forward);
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
    return plane(normalise(n), c.eye);
  };
  f.planes[2] = side(right, half_h, 1);
  f.planes[3] = side(right, half_h, -1);
  f.planes[4] = side(up, half_v, 1);
  f.planes[5] = side(up, half_v, -1);
  return f;
}

std::array<float, 3> TransferFunction::user_color(double value) const {
  auto rgb = [](const std::array<double, 4>& c) { return std::array<float, 3>{float(c[1]), float(c[2]), float(c[3])}; };
  if (value <= colors.front()[0]) return rgb(colors.front());
  if (value >= colors.back()[0]) return rgb(colors.back());
  size_t i = 1;
  while (value > colors[i][0]) ++i;
  const double span = colors[i][0] - colors[i - 1][0], t = span > 0 ? (value - colors[i - 1][0]) / span : 1;
  std::array<float, 3> out{};
  for (int k = 0; k < 3; ++k) out[k] = static_cast<float>(colors[i - 1][k + 1] + t * (colors[i][k + 1] - colors[i - 1][k + 1]));
  return out;
}

double TransferFunction::alpha(double value) const {
  if (opacity.empty()) {
    if (!range) return 1;
    const double span = (*range)[1] - (*range)[0];
    return span > 0 ? std::clamp((value - (*range)[0]) / span, 0.0, 1.0) : 1.0;
  }
  if (value <= opacity.front()[0]) return opacity.front()[1];
  if (value >= opacity.back()[0]) return opacity.back()[1];
  for (size_t i = 1; i < opacity.size(); ++i) {
    if (value <= opacity[i][0]) {
      const double span = opacity[i][0] - opacity[i - 1][0];
      const double t = span > 0 ? (value - opacity[i - 1][0]) / span : 1;
      return opacity[i - 1][1] + t * (opacity[i][1] - opacity[i - 1][1]);
    }
  }
  return opacity.back()[1];
}

TransferFunction TransferFunction::from_json(const nlohmann::json& j) {
  TransferFunction tf;
  if (!j.is_object()) throw std::invalid_argument("transfer function: expected a JSON object");
  for (const auto& [key, value] : j.items()) {
    if (key == "attribute") {
      if (!value.is_string()) throw std::invalid_argument("transfer function: \"attribute\" must be a string");
      tf.attribute = value.get<std::string>();
    } else if (key == "range") {
      if (!value.is_array() || value.size() != 2 || !value[0].is_number() || !value[1].is_number()) throw std::invalid_argument("transfer function: \"range\" must be [lo, hi]");
      std::array<double, 2> r{value[0].get<double>(), value[1].get<double>()};
      if (!(std::isfinite(r[0]) && std::isfinite(r[1]) && r[0] < r[1])) throw std::invalid_argument("transfer function: \"range\" must be finite with lo < hi");
      tf.range = r;
    } else if (key == "colormap") {
      if (!value.is_string()) throw std::invalid_argument("transfer function: \"colormap\" must be a string");
      tf.colormap = value.get<std::string>();
    } else if (key == "opacity") {
      if (!value.is_array() || value.size() > 256) throw std::invalid_argument("transfer function: \"opacity\" must be a list of at most 256 [value, alpha] points");
      for (const auto& point : value) {
        if (!point.is_array() || point.size() != 2 || !point[0].is_number() || !point[1].is_number()) throw std::invalid_argument("transfer function: opacity points are [value, alpha]");
        const double v = point[0].get<double>(), a = point[1].get<double>();
        if (!std::isfinite(v) || !(a >= 0 && a <= 1)) throw std::invalid_argument("transfer function: opacity values must be finite and alphas in [0, 1]");
        if (!tf.opacity.empty() && v < tf.opacity.back()[0]) throw std::invalid_argument("transfer function: opacity points must ascend in value");
        tf.opacity.push_back({v, a});
      }
    } else if (key == "colors") {
      if (!value.is_array() || value.size() > 256) throw std::invalid_argument("transfer function: \"colors\" must be a list of at most 256 [value, r, g, b] points");
      for (const auto& point : value) {
        if (!point.is_array() || point.size() != 4) throw std::invalid_argument("transfer function: colour points are [value, r, g, b]");
        std::array<double, 4> c{};
        for (size_t k = 0; k < 4; ++k) {
          if (!point[k].is_number()) throw std::invalid_argument("transfer function: colour points are [value, r, g, b]");
          c[k] = point[k].get<double>();
        }
        if (!std::isfinite(c[0]) || !(c[1] >= 0 && c[1] <= 1 && c[2] >= 0 && c[2] <= 1 && c[3] >= 0 && c[3] <= 1))
          throw std::invalid_argument("transfer function: colour values must be finite and r, g, b in [0, 1]");
        if (!tf.colors.empty() && c[0] < tf.colors.back()[0]) throw std::invalid_argument("transfer function: colour points must ascend in value");
        tf.colors.push_back(c);
      }
    } else if (key == "name") {
      // a label for the client
    } else {
      throw std::invalid_argument("transfer function: unknown key \"" + key + "\"");
    }
  }
  return tf;
}

nlohmann::json TransferFunction::to_json() const {
  nlohmann::json j = {{"attribute", attribute}, {"colormap", colormap}};
  if (range) j["range"] = {(*range)[0], (*range)[1]};
  nlohmann::json points = nlohmann::json::array();
  for (const auto& p : opacity) points.push_back({p[0], p[1]});
  j["opacity"] = points;
  if (!colors.empty()) {
    nlohmann::json c = nlohmann::json::array();
    for (const auto& p : colors) c.push_back({p[0], p[1], p[2], p[3]});
    j["colors"] = c;
  }
  return j;
}

}  // namespace tetrascope::lod
