// The grid, the weights and the two searches of tet_locator.h.
#include "tet_locator.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

namespace tetrascope::lod::detail {

TetLocator::TetLocator(const storage::TetMesh& mesh) : mesh_(mesh) {
  std::vector<std::array<Vec3, 2>> boxes(mesh.tet_count());
  lo_ = {std::numeric_limits<double>::max(), std::numeric_limits<double>::max(), std::numeric_limits<double>::max()};
  hi_ = {-lo_[0], -lo_[1], -lo_[2]};
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    Vec3 lo = at(mesh.tets[4 * t]), hi = lo;
    for (int k = 1; k < 4; ++k) {
      const Vec3 p = at(mesh.tets[4 * t + k]);
      for (int i = 0; i < 3; ++i) {
        lo[i] = std::min(lo[i], p[i]);
        hi[i] = std::max(hi[i], p[i]);
      }
    }
    boxes[t] = {lo, hi};
    for (int i = 0; i < 3; ++i) {
      lo_[i] = std::min(lo_[i], lo[i]);
      hi_[i] = std::max(hi_[i], hi[i]);
    }
  }
  if (!boxes.empty()) grid_.build(boxes);
}

bool TetLocator::weights(uint32_t t, const Vec3& p, double w[4]) const {
  const uint32_t* v = &mesh_.tets[4 * size_t{t}];
  const Vec3 a = at(v[0]), e1 = at(v[1]) - a, e2 = at(v[2]) - a, e3 = at(v[3]) - a, r = p - a;
  const double total = dot(e1, cross(e2, e3));
  if (!(std::fabs(total) > 0)) {
    w[0] = w[1] = w[2] = w[3] = -1;
    return false;
  }
  w[1] = dot(r, cross(e2, e3)) / total;
  w[2] = dot(e1, cross(r, e3)) / total;
  w[3] = dot(e1, cross(e2, r)) / total;
  w[0] = 1 - w[1] - w[2] - w[3];
  return true;
}

uint32_t TetLocator::containing(const Vec3& p, double w[4], double slack) const {
  if (empty()) return kNoTet;
  uint32_t found = kNoTet;
  double best = -std::numeric_limits<double>::max();
  grid_.ring(p, 0, [&](uint32_t t) {
    double b[4];
    if (!weights(t, p, b)) return;
    const double worst = std::min({b[0], b[1], b[2], b[3]});
    if (worst > best) {
      best = worst;
      found = t;
      std::copy(b, b + 4, w);
    }
  });
  return best >= -slack ? found : kNoTet;
}

uint32_t TetLocator::nearest(const Vec3& p, double bary[4]) const {
  uint32_t best = kNoTet;
  double best_low = -std::numeric_limits<double>::infinity();
  for (int r = 0; r < 64 && (best == kNoTet || best_low < -1e-9); ++r) {
    const bool any = grid_.ring(p, r, [&](uint32_t t) {
      if (best_low >= -1e-9) return;
      double w[4];
      if (!weights(t, p, w)) return;
      const double low = std::min({w[0], w[1], w[2], w[3]});
      if (low > best_low) {
        best_low = low;
        best = t;
        std::copy(w, w + 4, bary);
      }
    });
    if (!any || (best != kNoTet && r >= 1)) break;  // outside: the best of the nearest cells
  }
  if (best == kNoTet) {
    best = 0;
    bary[0] = 1;
    bary[1] = bary[2] = bary[3] = 0;
  }
  double sum = 0;
  for (int k = 0; k < 4; ++k) sum += bary[k] = std::max(bary[k], 0.0);
  for (int k = 0; k < 4; ++k) bary[k] = sum > 0 ? bary[k] / sum : 0.25;
  return best;
}

}  // namespace tetrascope::lod::detail
