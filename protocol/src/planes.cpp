// Clip and slice planes at the protocol edge (clip.set, slice.set) and on the command line.
#include "tetrascope/protocol/planes.h"

#include <cmath>

#include "json_fields.h"
#include "tetrascope/protocol/protocol.h"

namespace tetrascope::protocol {
namespace {

using nlohmann::json;
using detail::Fields;

// n and d divided by |n|; false for a zero or non-finite normal
bool normalise(Plane& p) {
  const double length = std::hypot(p.normal[0], p.normal[1], p.normal[2]);
  if (!(length > 0) || !std::isfinite(length)) return false;
  for (double& c : p.normal) c /= length;
  p.offset /= length;
  return std::isfinite(p.offset) && std::isfinite(p.normal[0]) && std::isfinite(p.normal[1]) && std::isfinite(p.normal[2]);
}

Plane plane_of(const Fields& f, const std::string& name) {
  Plane p;
  p.normal = f.vector3("normal");
  const json& offset = f.require("offset");
  p.offset = f.number("offset", offset, -kMaxPlaneCoordinate, kMaxPlaneCoordinate);
  if (!normalise(p)) throw ProtocolError(code::kBadField, name + ".normal: zero length (a plane needs a direction)", std::nullopt);
  return p;
}

const json& plane_list(const Fields& f, size_t max) {
  static const json kEmpty = json::array();
  const json* planes = f.find("planes");
  if (!planes) return kEmpty;
  if (!planes->is_array()) f.fail("planes", "expected a list of {\"normal\": [x, y, z], \"offset\": d}");
  if (planes->size() > max) f.fail("planes", std::to_string(planes->size()) + " planes; at most " + std::to_string(max));
  return *planes;
}

// A plane's own fields, with errors naming planes[i] and the message's id.
template <class Read>
auto each_plane(const json& plane, size_t i, std::optional<uint32_t> id, Read read) {
  const std::string name = "planes[" + std::to_string(i) + "]";
  if (!plane.is_object()) throw ProtocolError(code::kBadField, name + ": expected {\"normal\": [x, y, z], \"offset\": d}", id);
  try {
    return read(Fields(plane, id), name);
  } catch (const ProtocolError& e) {
    throw ProtocolError(e.code(), std::string(e.what()).rfind(name, 0) == 0 ? e.what() : name + "." + e.what(), id);
  }
}

}  // namespace

json clip_json(const ClipSpec& clip) {
  json j = {{"planes", json::array()}, {"crinkle", clip.crinkle}};
  for (const ClipPlane& p : clip.planes) j["planes"].push_back({{"normal", p.plane.normal}, {"offset", p.plane.offset}, {"invert", p.invert}});
  if (clip.box) j["box"] = {{"min", clip.box->min}, {"max", clip.box->max}};
  return j;
}

json slice_json(const SliceSpec& slices) {
  json j = {{"planes", json::array()}, {"edges", slices.edges}, {"lit", slices.lit}};
  for (const Plane& p : slices.planes) j["planes"].push_back({{"normal", p.normal}, {"offset", p.offset}});
  return j;
}

ClipSpec parse_clip_spec(const json& object, std::optional<uint32_t> id) {
  const Fields f(object, id);
  ClipSpec spec;
  const json& planes = plane_list(f, kMaxClipPlanes);
  for (size_t i = 0; i < planes.size(); ++i)
    spec.planes.push_back(each_plane(planes[i], i, id, [](const Fields& pf, const std::string& name) {
      ClipPlane c;
      c.plane = plane_of(pf, name);
      c.invert = pf.boolean("invert").value_or(false);
      return c;
    }));
  if (const json* box = f.find("box")) {
    if (!box->is_object()) f.fail("box", "expected {\"min\": [x, y, z], \"max\": [x, y, z]}");
    const Fields bf(*box, id);
    ClipBox b;
    try {
      b.min = bf.vector3("min");
      b.max = bf.vector3("max");
    } catch (const ProtocolError& e) {
      throw ProtocolError(e.code(), "box." + std::string(e.what()), id);
    }
    for (int k = 0; k < 3; ++k)
      if (!(b.min[k] <= b.max[k])) f.fail("box", "min exceeds max on axis " + std::string(1, "xyz"[k]));
    spec.box = b;
  }
  spec.crinkle = f.boolean("crinkle").value_or(false);
  return spec;
}

SliceSpec parse_slice_spec(const json& object, std::optional<uint32_t> id) {
  const Fields f(object, id);
  SliceSpec spec;
  const json& planes = plane_list(f, kMaxSlicePlanes);
  for (size_t i = 0; i < planes.size(); ++i)
    spec.planes.push_back(each_plane(planes[i], i, id, [](const Fields& pf, const std::string& name) { return plane_of(pf, name); }));
  spec.edges = f.boolean("edges").value_or(false);
  spec.lit = f.boolean("lit").value_or(true);
  return spec;
}

Probe parse_probe(const json& object, uint32_t max_image_side, std::optional<uint32_t> id) {
  const Fields f(object, id);
  Probe p;
  p.x = f.number("x", f.require("x"), 0, max_image_side);
  p.y = f.number("y", f.require("y"), 0, max_image_side);
  return p;
}

json ProbeResult::to_json(uint32_t id) const {
  json j = {{"type", "probe.result"}, {"id", id}, {"hit", hit}};
  if (!hit) return j;
  const auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
  j["surface"] = surface;
  j["position"] = position;
  j["attribute"] = attribute;
  if (!component.empty()) j["component"] = component;
  j["value"] = number(value);
  if (iso_color) {
    j["iso_color_attribute"] = iso_color->first;
    j["iso_color_value"] = number(iso_color->second);
  }
  json v = json::object(), m = json::object();
  for (const auto& [name, components] : values) {
    if (components.size() == 1) {
      v[name] = number(components[0]);
      continue;
    }
    json list = json::array();
    double length = 0;
    for (double c : components) {
      list.push_back(number(c));
      length += c * c;
    }
    v[name] = std::move(list);
    m[name] = number(std::sqrt(length));
  }
  j["values"] = std::move(v);
  if (!m.empty()) j["magnitudes"] = std::move(m);
  return j;
}

ProbeResult ProbeResult::from_json(const json& object) {
  const Fields f(object, std::nullopt);
  ProbeResult r;
  r.hit = f.boolean("hit").value_or(false);
  if (!r.hit) return r;
  const auto number = [&](const std::string& field, const json& v) { return v.is_null() ? std::nan("") : f.number(field, v, -1e300, 1e300); };
  const auto text = [&](const std::string& field) {
    f.require(field);
    return *f.string(field, 4096);
  };
  r.surface = text("surface");
  r.position = f.vector3("position");
  r.attribute = text("attribute");
  if (f.find("component")) {
    r.component = text("component");
    if (r.component != "x" && r.component != "y" && r.component != "z") f.fail("component", "expected x, y or z");
  }
  r.value = number("value", f.require("value"));
  if (f.find("iso_color_attribute")) r.iso_color = {{text("iso_color_attribute"), number("iso_color_value", f.require("iso_color_value"))}};
  if (const json* values = f.find("values")) {
    if (!values->is_object()) f.fail("values", "expected {name: number | [x, y, z]}");
    for (const auto& [name, v] : values->items()) {
      std::vector<double> components;
      if (v.is_array()) {
        if (v.empty() || v.size() > 16) f.fail("values." + name, "expected 1 to 16 components");
        for (const json& c : v) components.push_back(number("values." + name, c));
      } else {
        components.push_back(number("values." + name, v));
      }
      r.values.emplace_back(name, std::move(components));
    }
  }
  return r;
}

ClipPlane parse_plane_text(std::string_view text, bool allow_invert) {
  ClipPlane c;
  std::string_view rest = text;
  if (allow_invert && !rest.empty() && rest.front() == '!') {
    c.invert = true;
    rest.remove_prefix(1);
  }
  std::vector<std::string> parts;
  for (size_t at = 0; at <= rest.size();) {
    size_t comma = rest.find(',', at);
    if (comma == std::string_view::npos) comma = rest.size();
    parts.emplace_back(rest.substr(at, comma - at));
    at = comma + 1;
  }
  if (allow_invert && parts.size() == 5 && parts.back() == "invert") {
    c.invert = true;
    parts.pop_back();
  }
  const std::string form = allow_invert ? "nx,ny,nz,d (or nx,ny,nz,d,invert)" : "nx,ny,nz,d";
  if (parts.size() != 4) throw std::invalid_argument("plane '" + std::string(text) + "': expected " + form);
  double v[4];
  for (int i = 0; i < 4; ++i) {
    size_t used = 0;
    try {
      v[i] = std::stod(parts[i], &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used == 0 || used != parts[i].size() || !std::isfinite(v[i]) || std::fabs(v[i]) > kMaxPlaneCoordinate)
      throw std::invalid_argument("plane '" + std::string(text) + "': '" + parts[i] + "' is not a finite number (expected " + form + ")");
  }
  c.plane.normal = {v[0], v[1], v[2]};
  c.plane.offset = v[3];
  if (!normalise(c.plane)) throw std::invalid_argument("plane '" + std::string(text) + "': the normal is zero (a plane needs a direction)");
  return c;
}

}  // namespace tetrascope::protocol
