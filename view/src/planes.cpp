// The half-spaces a clip keeps (planes.h).
#include "tetrascope/view/planes.h"

namespace tetrascope::view {

std::vector<Plane> ClipSpec::half_spaces() const {
  std::vector<Plane> out;
  for (const ClipPlane& p : planes) out.push_back(p.kept());
  if (box) {
    for (int k = 0; k < 3; ++k) {
      Plane upper, lower;
      upper.normal = {0, 0, 0};
      upper.normal[k] = 1;
      upper.offset = box->max[k];
      lower.normal = {0, 0, 0};
      lower.normal[k] = -1;
      lower.offset = -box->min[k];
      out.push_back(upper);
      out.push_back(lower);
    }
  }
  return out;
}

}  // namespace tetrascope::view
