// Tet skipping by value range and the back-to-front radix sort (see visibility_order.h).
#include "visibility_order.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

namespace {

// Whether `point` lies in tet t (on its boundary included, with a relative tolerance).
bool tet_contains(const SceneMesh& mesh, size_t t, const Vec3& point) {
  Vec3 p[4];
  for (int k = 0; k < 4; ++k) {
    const uint32_t v = mesh.tets[4 * t + k];
    p[k] = {mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2]};
  }
  const double volume6 = std::fabs(dot(p[1] - p[0], cross(p[2] - p[0], p[3] - p[0])));
  if (!(volume6 > 0)) return false;
  for (int f = 0; f < 4; ++f) {
    const Vec3& a = p[kTetFace[f][0]];
    const double outside = dot(cross(p[kTetFace[f][1]] - a, p[kTetFace[f][2]] - a), point - a);  // > 0: beyond face f
    if (outside > 1e-9 * volume6) return false;
  }
  return true;
}

}  // namespace

void VisibilityOrder::set_transfer_function(const view::TransferFunction& tf, double lo, double hi) {
  visible_prefix_.assign(kValueSlots + 1, 0);
  for (int i = 0; i < kValueSlots; ++i) {
    const double a0 = tf.alpha(lo + (hi - lo) * i / kValueSlots), a1 = tf.alpha(lo + (hi - lo) * (i + 1) / kValueSlots);
    visible_prefix_[i + 1] = visible_prefix_[i] + (a0 > 0 || a1 > 0);
  }
}

// Conservatively, by the tet's bounding sphere: perspective, the ball about the eye through the
// near rectangle's corners; orthographic, the slab in front of the near plane across the view.
bool VisibilityOrder::reaches_near_region(const TetSortInputs& tets, size_t t, const Frame& f, double near_depth, double corner) const {
  const float* c = &tets.centroid[3 * t];
  const Vec3 q = Vec3{c[0], c[1], c[2]} - f.eye;
  const double r = tets.radius[t];
  if (!f.ortho) {
    if (dot(q, q) < (r + corner) * (r + corner)) return true;
    if (dot(q, f.forward) - r >= near_depth) return false;
    // crossing the near plane: near unless the ball lies beyond a side of the frustum
    const double tx = f.tan_half * f.aspect, ty = f.tan_half, z = dot(q, f.forward), x = dot(q, f.right), y = dot(q, f.up);
    return std::fabs(x) - tx * z < r * std::sqrt(1 + tx * tx) && std::fabs(y) - ty * z < r * std::sqrt(1 + ty * ty);
  }
  return dot(q, f.forward) - r < near_depth && std::fabs(dot(q, f.right)) < f.half_height * f.aspect + r && std::fabs(dot(q, f.up)) < f.half_height + r;
}

bool VisibilityOrder::holds_isovalue(float a, float b, double lo, double hi) const {
  for (float iso : isos_) {
    const double v = lo + iso * (hi - lo);
    if (a <= v && v <= b) return true;
  }
  return false;
}

std::span<const uint32_t> VisibilityOrder::sort(const SceneMesh& mesh, const TetSortInputs& tets, double lo, double hi, const Frame& f, double near_depth,
                                                FrameTimings& tm) {
  const size_t count = tets.centroid.size() / 3;
  keys_.clear();
  ids_.clear();
  near_.assign(count, 0);
  const double corner = near_depth * std::sqrt(1 + std::pow(f.tan_half * f.aspect, 2) + std::pow(f.tan_half, 2));  // its distance from the eye
  const double scale = kValueSlots / (hi - lo);
  for (size_t t = 0; t < count; ++t) {
    int a = static_cast<int>(std::floor((tets.range[2 * t] - lo) * scale)), b = static_cast<int>(std::floor((tets.range[2 * t + 1] - lo) * scale));
    a = std::clamp(a, 0, kValueSlots - 1);
    b = std::clamp(b, 0, kValueSlots - 1);
    if (visible_prefix_[b + 1] - visible_prefix_[a] == 0 && !holds_isovalue(tets.range[2 * t], tets.range[2 * t + 1], lo, hi)) {
      ++tm.tets_skipped;
      continue;
    }
    const float* c = &tets.centroid[3 * t];
    const double dx = c[0] - f.eye[0], dy = c[1] - f.eye[1], dz = c[2] - f.eye[2];
    const double depth = f.ortho ? dx * f.forward[0] + dy * f.forward[1] + dz * f.forward[2] : dx * dx + dy * dy + dz * dz;
    // larger depth first: sort ascending on the complement of the float's order-preserving bits
    uint32_t bits;
    const float fd = static_cast<float>(depth);
    std::memcpy(&bits, &fd, 4);
    bits = (bits & 0x80000000u) ? ~bits : bits | 0x80000000u;
    uint32_t key = ~bits;
    if (reaches_near_region(tets, t, f, near_depth, corner)) {
      near_[t] = 1;
      if (!f.ortho && tet_contains(mesh, t, f.eye)) key = 0xFFFFFFFFu;  // nearest on every ray through it: last
    }
    keys_.push_back(key);
    ids_.push_back(static_cast<uint32_t>(t));
  }
  const size_t n = keys_.size();
  keys2_.resize(n);
  ids2_.resize(n);
  for (int shift = 0; shift < 32; shift += 11) {
    uint32_t histogram[2049] = {};
    for (uint32_t k : keys_) ++histogram[((k >> shift) & 2047) + 1];
    for (int i = 0; i < 2048; ++i) histogram[i + 1] += histogram[i];
    for (size_t i = 0; i < n; ++i) {
      const uint32_t slot = histogram[(keys_[i] >> shift) & 2047]++;
      keys2_[slot] = keys_[i];
      ids2_[slot] = ids_[i];
    }
    keys_.swap(keys2_);
    ids_.swap(ids2_);
  }
  near_positions_.clear();
  for (size_t i = 0; i < n; ++i)
    if (near_[ids_[i]]) near_positions_.push_back(static_cast<uint32_t>(i));
  tm.tets_drawn = n;
  return ids_;
}

}  // namespace tetrascope::renderer
