// A uniform grid of axis-aligned boxes (tets, triangles) for point queries: the tet locator's
// (tet_locator.h) and the error measure's nearest boundary triangle.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <vector>

#include "tetrascope/core/vec3.h"

namespace tetrascope::lod::detail {

// Items with bounding boxes in a uniform grid; queries visit the cells near a point.
class BoxGrid {
 public:
  void build(const std::vector<std::array<Vec3, 2>>& boxes) {
    Vec3 lo{std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), std::numeric_limits<double>::max()};
    Vec3 hi{-lo[0], -lo[1], -lo[2]};
    for (const auto& b : boxes)
      for (int k = 0; k < 3; ++k) {
        lo[k] = std::min(lo[k], b[0][k]);
        hi[k] = std::max(hi[k], b[1][k]);
      }
    lo_ = lo;
    double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-30});
    int cells = std::max(1, static_cast<int>(std::cbrt(static_cast<double>(boxes.size()) / 2)));
    cell_ = extent / cells * (1 + 1e-9);
    for (int k = 0; k < 3; ++k) n_[k] = std::max(1, static_cast<int>((hi[k] - lo[k]) / cell_) + 1);
    start_.assign(static_cast<size_t>(n_[0]) * n_[1] * n_[2] + 1, 0);
    auto range = [&](const std::array<Vec3, 2>& b, int lo_c[3], int hi_c[3]) {
      for (int k = 0; k < 3; ++k) {
        lo_c[k] = clamp_cell(k, b[0][k]);
        hi_c[k] = clamp_cell(k, b[1][k]);
      }
    };
    for (int pass = 0; pass < 2; ++pass) {
      if (pass == 1) {
        for (size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
        items_.resize(start_.back());
      }
      std::vector<uint32_t> fill(start_.begin(), start_.end() - 1);
      for (uint32_t i = 0; i < boxes.size(); ++i) {
        int a[3], b[3];
        range(boxes[i], a, b);
        for (int z = a[2]; z <= b[2]; ++z)
          for (int y = a[1]; y <= b[1]; ++y)
            for (int x = a[0]; x <= b[0]; ++x) {
              size_t c = index(x, y, z);
              if (pass == 0) ++start_[c + 1];
              else items_[fill[c]++] = i;
            }
      }
    }
  }
  int clamp_cell(int k, double v) const { return std::clamp(static_cast<int>((v - lo_[k]) / cell_), 0, n_[k] - 1); }
  size_t index(int x, int y, int z) const { return (static_cast<size_t>(z) * n_[1] + y) * n_[0] + x; }
  double cell() const { return cell_; }
  // Calls visit(item) for items in cells at Chebyshev ring r around the point's cell; false when r is past the grid.
  template <typename Visit>
  bool ring(const Vec3& p, int r, Visit&& visit) const {
    int c[3];
    for (int k = 0; k < 3; ++k) c[k] = clamp_cell(k, p[k]);
    bool any = false;
    for (int z = c[2] - r; z <= c[2] + r; ++z) {
      if (z < 0 || z >= n_[2]) continue;
      for (int y = c[1] - r; y <= c[1] + r; ++y) {
        if (y < 0 || y >= n_[1]) continue;
        for (int x = c[0] - r; x <= c[0] + r; ++x) {
          if (x < 0 || x >= n_[0]) continue;
          if (std::max({std::abs(x - c[0]), std::abs(y - c[1]), std::abs(z - c[2])}) != r) continue;
          any = true;
          size_t cell = index(x, y, z);
          for (uint32_t i = start_[cell]; i < start_[cell + 1]; ++i) visit(items_[i]);
        }
      }
    }
    return any;
  }

 private:
  Vec3 lo_{};
  double cell_ = 1;
  int n_[3] = {1, 1, 1};
  std::vector<uint32_t> start_, items_;
};

}  // namespace tetrascope::lod::detail
