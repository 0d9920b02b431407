// Tet skipping by value range and the back-to-front radix sort (see visibility_order.h).
#include "visibility_order.h"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace tetrascope::renderer {

void VisibilityOrder::set_transfer_function(const lod::TransferFunction& tf, double lo, double hi) {
  visible_prefix_.assign(kValueSlots + 1, 0);
  for (int i = 0; i < kValueSlots; ++i) {
    const double a0 = tf.alpha(lo + (hi - lo) * i / kValueSlots), a1 = tf.alpha(lo + (hi - lo) * (i + 1) / kValueSlots);
    visible_prefix_[i + 1] = visible_prefix_[i] + (a0 > 0 || a1 > 0);
  }
}

std::span<const uint32_t> VisibilityOrder::sort(const TetSortInputs& tets, double lo, double hi, const Frame& f, FrameTimings& tm) {
  const size_t count = tets.centroid.size() / 3;
  keys_.clear();
  ids_.clear();
  const double scale = kValueSlots / (hi - lo);
  for (size_t t = 0; t < count; ++t) {
    int a = static_cast<int>(std::floor((tets.range[2 * t] - lo) * scale)), b = static_cast<int>(std::floor((tets.range[2 * t + 1] - lo) * scale));
    a = std::clamp(a, 0, kValueSlots - 1);
    b = std::clamp(b, 0, kValueSlots - 1);
    if (visible_prefix_[b + 1] - visible_prefix_[a] == 0) {
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
    keys_.push_back(~bits);
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
  tm.tets_drawn = n;
  return ids_;
}

}  // namespace tetrascope::renderer
