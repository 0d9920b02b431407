// Pre-integrated volume rendering: the colour and opacity of a ray segment through a linear
// field, tabulated over (front value, back value, length). Engel, Kraus, Ertl, "High-Quality
// Pre-Integrated Volume Rendering Using Hardware-Accelerated Pixel Shading" (2001); the
// exact per-segment integral (integrate_segment) is the reference the table approximates.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <thread>
#include <vector>

#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

namespace {
// colour and extinction (per unit length) at normalised value t
struct Classified {
  std::array<float, 3> color;
  double tau;
};
Classified classify(const view::TransferFunction& tf, double lo, double hi, double unit_distance, double t) {
  const double value = lo + std::clamp(t, 0.0, 1.0) * (hi - lo);
  const double alpha = std::clamp(tf.alpha(value), 0.0, 0.999999);
  return {tf.colors.empty() ? colormap(tf.colormap, t) : tf.user_color(value), -std::log(1 - alpha) / unit_distance};
}
}  // namespace

std::array<double, 4> integrate_segment(const view::TransferFunction& tf, double lo, double hi, double unit_distance, double front, double back,
                                        double length) {
  // steps follow the change of value along the segment (a constant value integrates exactly
  // in any number of steps): at most 1/1024 of the range a step
  const int steps = std::clamp(static_cast<int>(std::ceil(std::fabs(back - front) * 1024)), 4, 1024);
  double r = 0, g = 0, b = 0, a = 0;
  const double dt = length / steps;
  for (int k = 0; k < steps && a < 0.9999; ++k) {
    const double t = front + (back - front) * (k + 0.5) / steps;
    const Classified c = classify(tf, lo, hi, unit_distance, t);
    const double alpha = 1 - std::exp(-c.tau * dt);
    r += (1 - a) * alpha * c.color[0];
    g += (1 - a) * alpha * c.color[1];
    b += (1 - a) * alpha * c.color[2];
    a += (1 - a) * alpha;
  }
  return {r, g, b, a};
}

FineTransfer fine_transfer(const view::TransferFunction& tf, double lo, double hi, double unit_distance, uint32_t blocks, uint32_t cells) {
  FineTransfer f;
  f.blocks = blocks;
  f.cells = cells;
  f.at.resize(size_t{blocks} * (cells + 1) * 4);
  const double intervals = double(blocks) * cells;
  for (uint32_t b = 0; b < blocks; ++b)
    for (uint32_t c = 0; c <= cells; ++c) {
      const Classified p = classify(tf, lo, hi, unit_distance, (double(b) * cells + c) / intervals);
      float* at = &f.at[(size_t{b} * (cells + 1) + c) * 4];
      at[0] = static_cast<float>(p.tau);
      for (int k = 0; k < 3; ++k) at[1 + k] = p.color[k];
    }
  return f;
}

double PreintegrationTable::length_at(uint32_t m) const {
  return length_scale * std::expm1(double(m) / std::max(1u, lengths - 1) * std::log1p(max_length / length_scale));
}

double PreintegrationTable::length_coordinate(double length) const {
  return std::clamp(std::log1p(std::max(length, 0.0) / length_scale) / std::log1p(max_length / length_scale), 0.0, 1.0);
}

PreintegrationTable preintegrate(const view::TransferFunction& tf, double lo, double hi, double unit_distance, double max_length, uint32_t n,
                                 uint32_t lengths) {
  PreintegrationTable table;
  table.n = n;
  table.lengths = lengths;
  table.max_length = max_length;
  // below about 1/16 of the unit distance opacity grows nearly linearly with length: the axis is
  // linear there and logarithmic above
  table.length_scale = std::clamp(unit_distance / 16, max_length * 1e-9, max_length);
  table.rgba.resize(size_t{n} * n * lengths * 4);
  // classified values on a fine grid; a segment's steps read the grid at fixed points (the
  // same for every length), and for one length a grid value's step opacity is one exp: so the
  // exps are per length and grid value (1,025), not per table entry and step (393,216)
  const int fine = 1024;
  const int steps = 24;
  std::vector<Classified> grid(fine + 1);
  for (int i = 0; i <= fine; ++i) grid[i] = classify(tf, lo, hi, unit_distance, double(i) / fine);
  std::vector<uint16_t> step_grid(size_t{n} * n * steps);  // [j][i][k]: the grid index step k reads
  for (uint32_t j = 0; j < n; ++j)
    for (uint32_t i = 0; i < n; ++i) {
      const double front = double(i) / (n - 1), back = double(j) / (n - 1);
      for (int k = 0; k < steps; ++k)
        step_grid[(size_t{j} * n + i) * steps + k] = static_cast<uint16_t>(std::lround(std::clamp(front + (back - front) * (k + 0.5) / steps, 0.0, 1.0) * fine));
    }
  auto work = [&](uint32_t first_length, uint32_t step) {
    std::vector<double> step_alpha(fine + 1);
    for (uint32_t m = first_length; m < lengths; m += step) {
      const double length = table.length_at(m);
      const double dt = length / steps;
      for (int g = 0; g <= fine; ++g) step_alpha[g] = 1 - std::exp(-grid[g].tau * dt);
      for (uint32_t j = 0; j < n; ++j)
        for (uint32_t i = 0; i < n; ++i) {
          const uint16_t* reads = &step_grid[(size_t{j} * n + i) * steps];
          double r = 0, g = 0, b = 0, a = 0;
          for (int k = 0; k < steps; ++k) {
            const Classified& c = grid[reads[k]];
            const double alpha = step_alpha[reads[k]];
            const double w = (1 - a) * alpha;
            r += w * c.color[0];
            g += w * c.color[1];
            b += w * c.color[2];
            a += w;
          }
          float* out = &table.rgba[((size_t{m} * n + j) * n + i) * 4];
          out[0] = static_cast<float>(r);
          out[1] = static_cast<float>(g);
          out[2] = static_cast<float>(b);
          out[3] = static_cast<float>(a);
        }
    }
  };
  std::thread other(work, 1, 2);
  work(0, 2);
  other.join();
  return table;
}

}  // namespace tetrascope::renderer
