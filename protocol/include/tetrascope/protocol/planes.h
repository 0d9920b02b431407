// Clip planes, a clip box and slice planes: what `clip.set` and `slice.set` carry and
// `tetrascope render|cut --clip/--slice` take. A plane is n.x = d; a clip plane keeps the
// half-space n.x <= d (n.x >= d with `invert`). Checked once here (parse_clip_spec,
// parse_slice_planes for JSON, parse_plane_text for the command line): a zero, non-finite or
// absurd normal, a non-finite offset, too many planes and an inverted box are refused with a
// message naming the field. Past this edge a plane's normal has unit length (the parsers
// divide n and d by |n|), so side() is a distance.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace tetrascope::protocol {

constexpr size_t kMaxClipPlanes = 6;   // half-spaces of one clip (plus the optional box)
constexpr size_t kMaxSlicePlanes = 6;  // slices drawn at once
constexpr double kMaxPlaneCoordinate = 1e30;

struct Plane {
  std::array<double, 3> normal{1, 0, 0};
  double offset = 0;  // d of n.x = d
  // signed distance in units of |n|: <= 0 on the kept side of a clip plane
  double side(double x, double y, double z) const { return normal[0] * x + normal[1] * y + normal[2] * z - offset; }
  bool operator==(const Plane&) const = default;
};

struct ClipPlane {
  Plane plane;
  bool invert = false;  // keep n.x >= d instead
  // the plane as it keeps: n.x <= d after inversion
  Plane kept() const { return invert ? Plane{{-plane.normal[0], -plane.normal[1], -plane.normal[2]}, -plane.offset} : plane; }
  bool operator==(const ClipPlane&) const = default;
};

struct ClipBox {
  std::array<double, 3> min{}, max{};  // kept: inside, min <= max on every axis
  bool operator==(const ClipBox&) const = default;
};

struct ClipSpec {
  std::vector<ClipPlane> planes;  // at most kMaxClipPlanes
  std::optional<ClipBox> box;
  bool crinkle = false;  // keep whole tets touching the kept side instead of cutting them
  bool empty() const { return planes.empty() && !box; }
  // Every half-space the clip keeps (n.x <= d): the planes after inversion, then the box's six.
  std::vector<Plane> half_spaces() const;
  nlohmann::json to_json() const;
  bool operator==(const ClipSpec&) const = default;
};

struct SliceSpec {
  std::vector<Plane> planes;  // at most kMaxSlicePlanes
  bool edges = false;         // draw the tets' edges on the slice
  bool lit = true;            // shaded by the headlight; false: flat, the transfer function's colour of the value
  nlohmann::json to_json() const;
  bool operator==(const SliceSpec&) const = default;
};

// The messages (protocol.h's Message holds them).
struct ClipSet {
  ClipSpec clip;
};
struct SliceSet {
  SliceSpec slice;
};

// probe: the field under pixel (x, y) of the view (0, 0 the top-left corner, in the view.resize
// size), answered by probe.result {id, hit, surface, position, attribute, value}.
struct Probe {
  double x = 0, y = 0;
};
Probe parse_probe(const nlohmann::json& object, uint32_t max_image_side, std::optional<uint32_t> id);

// probe.result (server to client), built by the server (server/src/frame_probe.cpp), read by
// the viewer (protocol/js/planes.js probeRows):
//   {"type": "probe.result", "id": n, "hit": true, "surface": "slice", "position": [x, y, z],
//    "attribute": "a", "value": v, ["iso_color_attribute": "b", "iso_color_value": w,]
//    "values": {"a": v, "velocity": [x, y, z], ...}, "magnitudes": {"velocity": m}}
// `values` holds every point attribute at the position (a scalar as a number, a vector as its
// components; a non-finite component as null), `magnitudes` the vectors' lengths.
struct ProbeResult {
  bool hit = false;
  std::string surface;  // "slice", "isosurface" or "boundary"
  std::array<double, 3> position{};
  std::string attribute;  // the attribute shown, and its value (vector magnitude for vectors)
  double value = 0;
  std::optional<std::pair<std::string, double>> iso_color;  // the iso-colour attribute and its value
  std::vector<std::pair<std::string, std::vector<double>>> values;  // name, components
  nlohmann::json to_json(uint32_t id) const;
  // the fields of `object`; throws ProtocolError(code::kBadField) naming a malformed one
  static ProbeResult from_json(const nlohmann::json& object);
  bool operator==(const ProbeResult&) const = default;
};

// The fields of clip.set / slice.set in `object` (untrusted):
//   clip.set:  {"planes": [{"normal": [nx, ny, nz], "offset": d, "invert": false}, ...],
//               "box": {"min": [x, y, z], "max": [x, y, z]}, "crinkle": false}
//   slice.set: {"planes": [{"normal": [nx, ny, nz], "offset": d}, ...], "edges": false, "lit": true}
// Throws ProtocolError(code::kBadField, carrying `id`) naming the field.
ClipSpec parse_clip_spec(const nlohmann::json& object, std::optional<uint32_t> id);
SliceSpec parse_slice_spec(const nlohmann::json& object, std::optional<uint32_t> id);

// "nx,ny,nz,d" (the command line's --clip and --slice; a leading '!' or a trailing ",invert"
// inverts a clip plane). Throws std::invalid_argument saying what is wrong.
ClipPlane parse_plane_text(std::string_view text, bool allow_invert);

}  // namespace tetrascope::protocol
