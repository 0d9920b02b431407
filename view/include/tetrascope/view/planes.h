// Clip planes, a clip box and slice planes of a view. A plane is n.x = d; a clip plane keeps
// the half-space n.x <= d (n.x >= d with `invert`). They arrive checked
// (protocol/planes.h: clip.set, slice.set, `--clip`/`--slice`): past that edge a plane's
// normal has unit length, so side() is a distance, and the counts are within the limits here.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace tetrascope::view {

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
  bool operator==(const ClipSpec&) const = default;
};

struct SliceSpec {
  std::vector<Plane> planes;  // at most kMaxSlicePlanes
  bool edges = false;         // draw the tets' edges on the slice
  bool lit = true;            // shaded by the headlight; false: flat, the transfer function's colour of the value
  bool operator==(const SliceSpec&) const = default;
};

}  // namespace tetrascope::view
