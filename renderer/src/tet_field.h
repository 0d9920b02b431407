// The linear field of one tet, shared by the CPU reference and the CPU ray caster.
#pragma once

#include <cmath>

#include "tetrascope/core/vec3.h"

namespace tetrascope::renderer {

// The field s(x) = g.x + c that takes the values s[k] at the corners p[k] (g.e_i = s_i - s_0
// along the edges from p[0]); false for a tet of no volume.
inline bool linear_field(const Vec3 p[4], const double s[4], Vec3* g, double* c) {
  const Vec3 e1 = p[1] - p[0], e2 = p[2] - p[0], e3 = p[3] - p[0];
  const double det = dot(e1, cross(e2, e3));
  if (!(std::fabs(det) > 0)) return false;
  const Vec3 c23 = cross(e2, e3), c31 = cross(e3, e1), c12 = cross(e1, e2);
  for (int k = 0; k < 3; ++k) (*g)[k] = ((s[1] - s[0]) * c23[k] + (s[2] - s[0]) * c31[k] + (s[3] - s[0]) * c12[k]) / det;
  *c = s[0] - dot(*g, p[0]);
  return true;
}

}  // namespace tetrascope::renderer
