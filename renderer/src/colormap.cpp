// The named colormaps. Viridis and plasma: 6th-degree polynomial fits of matplotlib's maps;
// cool-warm: Moreland, "Diverging Color Maps for Scientific Visualization" (2009), through
// its published control colours.
#include <algorithm>
#include <cmath>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

bool known_colormap(const std::string& name) { return name == "viridis" || name == "plasma" || name == "cool-warm" || name == "grayscale"; }

std::array<float, 3> colormap(const std::string& name, double t) {
  t = std::isfinite(t) ? std::clamp(t, 0.0, 1.0) : 0.0;
  auto poly = [&](const double c[7][3]) {
    std::array<float, 3> out{};
    for (int k = 0; k < 3; ++k) {
      double v = c[6][k];
      for (int i = 5; i >= 0; --i) v = c[i][k] + t * v;
      out[k] = static_cast<float>(std::clamp(v, 0.0, 1.0));
    }
    return out;
  };
  if (name == "plasma") {
    static const double c[7][3] = {{0.05873234392399702, 0.02333670892565664, 0.5433401826748754}, {2.176514634195958, 0.2383834171260182, 0.7539604599784036},
                                   {-2.689460476458034, -7.455851135738909, 3.110799939717086},   {6.130348345893603, 42.3461881477227, -28.51885465332158},
                                   {-11.10743619062271, -82.66631109428045, 60.13984767418263},   {10.02306557647065, 71.41361770095349, -54.07218655560067},
                                   {-3.658713842777788, -22.93153465461149, 18.19190778539828}};
    return poly(c);
  }
  if (name == "cool-warm") {  // Moreland's diverging map through its published control colours
    static const double p[5][4] = {{0.0, 0.230, 0.299, 0.754}, {0.25, 0.552, 0.690, 0.996}, {0.5, 0.865, 0.865, 0.865}, {0.75, 0.956, 0.604, 0.486}, {1.0, 0.706, 0.016, 0.150}};
    int i = std::min(3, static_cast<int>(t * 4));
    const double u = (t - p[i][0]) / (p[i + 1][0] - p[i][0]);
    return {static_cast<float>(p[i][1] + u * (p[i + 1][1] - p[i][1])), static_cast<float>(p[i][2] + u * (p[i + 1][2] - p[i][2])),
            static_cast<float>(p[i][3] + u * (p[i + 1][3] - p[i][3]))};
  }
  if (name == "grayscale") return {static_cast<float>(t), static_cast<float>(t), static_cast<float>(t)};
  static const double c[7][3] = {{0.2777273272234177, 0.005407344544966578, 0.3340998053353061}, {0.1050930431085774, 1.404613529898575, 1.384590162594685},
                                 {-0.3308618287255563, 0.214847559468213, 0.09509516302823659},  {-4.634230498983486, -5.799100973351585, -19.33244095627987},
                                 {6.228269936347081, 14.17993336680509, 56.69055260068105},      {4.776384997670288, -13.74514537774601, -65.35303263337234},
                                 {-5.435455855934631, 4.645852612178535, 26.3124352495832}};
  return poly(c);  // viridis
}

}  // namespace tetrascope::renderer
