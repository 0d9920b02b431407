// Image comparison: peak signal-to-noise ratio over RGB, the measure every render test uses.
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

double psnr(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height) throw std::invalid_argument("psnr: images differ in size");
  double sum = 0;
  const size_t pixels = size_t{a.width} * a.height;
  for (size_t i = 0; i < pixels; ++i)
    for (int k = 0; k < 3; ++k) {
      const double d = double(a.rgba[4 * i + k]) - b.rgba[4 * i + k];
      sum += d * d;
    }
  const double mse = sum / (3.0 * std::max<size_t>(pixels, 1));
  return mse > 0 ? 10 * std::log10(255.0 * 255.0 / mse) : 99.0;
}

}  // namespace tetrascope::renderer
