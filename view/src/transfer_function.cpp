// The transfer function's values (transfer_function.h).
#include "tetrascope/view/transfer_function.h"

#include <algorithm>
#include <cstdio>

namespace tetrascope::view {

std::array<float, 3> TransferFunction::user_color(double value) const {
  auto rgb = [](const std::array<double, 4>& c) { return std::array<float, 3>{float(c[1]), float(c[2]), float(c[3])}; };
  if (value <= colors.front()[0]) return rgb(colors.front());
  if (value >= colors.back()[0]) return rgb(colors.back());
  size_t i = 1;
  while (value > colors[i][0]) ++i;
  const double span = colors[i][0] - colors[i - 1][0], t = span > 0 ? (value - colors[i - 1][0]) / span : 1;
  std::array<float, 3> out{};
  for (int k = 0; k < 3; ++k) out[k] = static_cast<float>(colors[i - 1][k + 1] + t * (colors[i][k + 1] - colors[i - 1][k + 1]));
  return out;
}

double TransferFunction::alpha(double value) const {
  if (opacity.empty()) {
    if (!range) return 1;
    const double span = (*range)[1] - (*range)[0];
    return span > 0 ? std::clamp((value - (*range)[0]) / span, 0.0, 1.0) : 1.0;
  }
  if (value <= opacity.front()[0]) return opacity.front()[1];
  if (value >= opacity.back()[0]) return opacity.back()[1];
  for (size_t i = 1; i < opacity.size(); ++i) {
    if (value <= opacity[i][0]) {
      const double span = opacity[i][0] - opacity[i - 1][0];
      const double t = span > 0 ? (value - opacity[i - 1][0]) / span : 1;
      return opacity[i - 1][1] + t * (opacity[i][1] - opacity[i - 1][1]);
    }
  }
  return opacity.back()[1];
}

std::string TransferFunction::key() const {
  std::string out = attribute + "|" + std::to_string(component) + "|" + colormap + "|";
  char number[32];
  auto add = [&](double v) {
    std::snprintf(number, sizeof number, "%.17g,", v);
    out += number;
  };
  if (range) add((*range)[0]), add((*range)[1]);
  out += "|";
  for (const auto& p : opacity) add(p[0]), add(p[1]);
  out += "|";
  for (const auto& c : colors)
    for (double v : c) add(v);
  return out;
}

}  // namespace tetrascope::view
