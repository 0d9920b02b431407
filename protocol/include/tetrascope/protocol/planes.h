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

#include "tetrascope/view/planes.h"

namespace tetrascope::protocol {

// The planes themselves are view's (view/planes.h): this checks and converts JSON and text.
using view::ClipBox;
using view::ClipPlane;
using view::ClipSpec;
using view::kMaxClipPlanes;
using view::kMaxPlaneCoordinate;
using view::kMaxSlicePlanes;
using view::Plane;
using view::SliceSpec;

// The JSON of clip.set and slice.set for a spec (parse_clip_spec / parse_slice_spec read it back).
nlohmann::json clip_json(const ClipSpec& clip);
nlohmann::json slice_json(const SliceSpec& slices);

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
//    "attribute": "a", ["component": "x",] "value": v, ["iso_color_attribute": "b", "iso_color_value": w,]
//    "values": {"a": v, "velocity": [x, y, z], ...}, "magnitudes": {"velocity": m}}
// `values` holds every point attribute at the position (a scalar as a number, a vector as its
// components; a non-finite component as null), `magnitudes` the vectors' lengths.
struct ProbeResult {
  bool hit = false;
  std::string surface;  // "slice", "isosurface" or "boundary"
  std::array<double, 3> position{};
  std::string attribute;  // the attribute shown, and its value (vector magnitude for vectors)
  std::string component;  // "x", "y" or "z": the component of the vector shown (and `value` is it); empty: its magnitude
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
