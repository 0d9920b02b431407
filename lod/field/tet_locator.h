// Point location in a tet mesh, the one locator of lod/: a uniform grid of the tets' boxes
// (box_grid.h) and barycentric weights. The error measure finds the simplified tet holding an
// original vertex, the build's error histograms the ceiling tet holding (or nearest) one, stream
// lines the tet a seed or a lost walk lies in, and the sampling simplifier the input tet a
// sample lies in, for its values.
#pragma once

#include <cstdint>

#include "box_grid.h"
#include "tetrascope/core/vec3.h"
#include "tetrascope/storage/mesh.h"

namespace tetrascope::lod::detail {

constexpr uint32_t kNoTet = 0xFFFFFFFFu;

class TetLocator {
 public:
  // The grid over `mesh`'s tets (which must outlive the locator).
  explicit TetLocator(const storage::TetMesh& mesh);
  bool empty() const { return mesh_.tet_count() == 0; }
  // The box around every tet.
  const Vec3& lo() const { return lo_; }
  const Vec3& hi() const { return hi_; }
  double diagonal() const { return length(hi_ - lo_); }

  // Barycentric weights of p in tet t (w[f] < 0: p is beyond the face opposite corner f);
  // false for a flat tet.
  bool weights(uint32_t t, const Vec3& p, double w[4]) const;
  // The tet of p's grid cell that p is most inside (its smallest weight the largest), when
  // that weight is at least -slack, with p's weights in it; kNoTet otherwise.
  uint32_t containing(const Vec3& p, double w[4], double slack) const;
  // The first tet found holding p (within 1e-9), else the one p is least outside of among the
  // nearest cells (rings of cells out to 64), its weights clamped to the tet and normalised;
  // tet 0 with weights (1, 0, 0, 0) when no cell near holds a tet. For a mesh with tets.
  uint32_t nearest(const Vec3& p, double w[4]) const;

 private:
  Vec3 at(uint32_t v) const { return {mesh_.x[v], mesh_.y[v], mesh_.z[v]}; }
  const storage::TetMesh& mesh_;
  BoxGrid grid_;
  Vec3 lo_{}, hi_{};
};

}  // namespace tetrascope::lod::detail
