#include "tetrascope/protocol/transfer_function.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "json_fields.h"
#include "tetrascope/protocol/protocol.h"

namespace tetrascope::protocol {
namespace {

using nlohmann::json;

constexpr double kMaxValue = 1e30;  // values and ranges, in attribute units

class TfFields : public detail::Fields {
 public:
  using Fields::Fields;
  template <size_t N>
  std::vector<std::array<double, N>> points(const char* field, const std::array<const char*, N>& parts, uint32_t max_points) const {
    std::vector<std::array<double, N>> out;
    const json* v = find(field);
    if (!v) return out;
    if (!v->is_array()) fail(field, "expected a list of points");
    if (v->size() > max_points) fail(field, "more than " + std::to_string(max_points) + " points");
    for (size_t i = 0; i < v->size(); ++i) {
      const json& p = (*v)[i];
      const std::string name = std::string(field) + "[" + std::to_string(i) + "]";
      if (!p.is_array() || p.size() != N) fail(name, "expected " + std::to_string(N) + " numbers [" + join(parts) + "]");
      std::array<double, N> point{};
      point[0] = number(name + " " + parts[0], p[0], -kMaxValue, kMaxValue);
      if (!out.empty() && point[0] < out.back()[0]) fail(name, "values must ascend");
      for (size_t k = 1; k < N; ++k) point[k] = number(name + " " + parts[k], p[k], 0, 1);
      out.push_back(point);
    }
    return out;
  }

  template <size_t N>
  static std::string join(const std::array<const char*, N>& parts) {
    std::string out;
    for (const char* part : parts) out += (out.empty() ? "" : ", ") + std::string(part);
    return out;
  }
};

}  // namespace

TransferFunction parse_transfer_function(const json& object, uint32_t max_points, std::optional<uint32_t> id) {
  TfFields f(object, id);
  if (!object.is_object()) f.fail("transfer function", "expected a JSON object");
  TransferFunction tf;
  tf.attribute = f.string("attribute", kMaxAttributeNameLength).value_or("");
  if (auto colormap = f.string("colormap", 64)) {
    if (std::find(kColormapNames.begin(), kColormapNames.end(), *colormap) == kColormapNames.end())
      f.fail("colormap", "unknown '" + *colormap + "' (viridis, plasma, cool-warm, grayscale)");
    tf.colormap = *colormap;
  }
  if (const json* r = f.find("range")) {
    if (!r->is_array() || r->size() != 2) f.fail("range", "expected [low, high]");
    const double lo = f.number("range", (*r)[0], -kMaxValue, kMaxValue), hi = f.number("range", (*r)[1], -kMaxValue, kMaxValue);
    if (!(hi > lo)) f.fail("range", "high must exceed low");
    tf.range = std::array<double, 2>{lo, hi};
  }
  tf.opacity = f.points<2>("opacity", {"value", "alpha"}, max_points);
  tf.colors = f.points<4>("colors", {"value", "r", "g", "b"}, max_points);
  return tf;
}

TransferFunction TransferFunction::from_json(const json& j) {
  if (!j.is_object()) throw std::invalid_argument("transfer function: expected a JSON object");
  for (const auto& [key, value] : j.items())
    if (key != "attribute" && key != "range" && key != "colormap" && key != "opacity" && key != "colors" && key != "name")
      throw std::invalid_argument("transfer function: unknown key \"" + key + "\" (attribute, range, colormap, opacity, colors, name)");
  try {
    return parse_transfer_function(j, kMaxTfPoints, std::nullopt);
  } catch (const ProtocolError& e) {
    throw std::invalid_argument(std::string("transfer function: ") + e.what());
  }
}

json TransferFunction::to_json() const {
  json j = {{"attribute", attribute}, {"colormap", colormap}};
  if (range) j["range"] = {(*range)[0], (*range)[1]};
  json points = json::array();
  for (const auto& p : opacity) points.push_back({p[0], p[1]});
  j["opacity"] = points;
  if (!colors.empty()) {
    json c = json::array();
    for (const auto& p : colors) c.push_back({p[0], p[1], p[2], p[3]});
    j["colors"] = c;
  }
  return j;
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

}  // namespace tetrascope::protocol
