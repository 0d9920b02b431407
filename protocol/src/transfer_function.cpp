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
  if (auto component = f.string("component", 16); component && *component != "magnitude") {
    auto it = std::find(kComponentNames.begin(), kComponentNames.end(), *component);
    if (it == kComponentNames.end()) f.fail("component", "unknown '" + *component + "' (magnitude, x, y, z)");
    tf.component = static_cast<int>(it - kComponentNames.begin());
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

TransferFunction transfer_function_from_json(const json& j) {
  if (!j.is_object()) throw std::invalid_argument("transfer function: expected a JSON object");
  for (const auto& [key, value] : j.items())
    if (key != "attribute" && key != "component" && key != "range" && key != "colormap" && key != "opacity" && key != "colors" && key != "name")
      throw std::invalid_argument("transfer function: unknown key \"" + key + "\" (attribute, component, range, colormap, opacity, colors, name)");
  try {
    return parse_transfer_function(j, kMaxTfPoints, std::nullopt);
  } catch (const ProtocolError& e) {
    throw std::invalid_argument(std::string("transfer function: ") + e.what());
  }
}

json transfer_function_json(const TransferFunction& tf) {
  json j = {{"attribute", tf.attribute}, {"colormap", tf.colormap}};
  if (tf.component != view::kMagnitude) j["component"] = std::string(kComponentNames[size_t(tf.component)]);
  if (tf.range) j["range"] = {(*tf.range)[0], (*tf.range)[1]};
  json points = json::array();
  for (const auto& p : tf.opacity) points.push_back({p[0], p[1]});
  j["opacity"] = points;
  if (!tf.colors.empty()) {
    json c = json::array();
    for (const auto& p : tf.colors) c.push_back({p[0], p[1], p[2], p[3]});
    j["colors"] = c;
  }
  return j;
}

}  // namespace tetrascope::protocol
