// The transfer function: a colormap (or user colour points) and a piecewise-linear opacity
// over a value range of one attribute. It arrives as JSON (tf.set, `tetrascope render --tf
// FILE`), is checked once where it arrives (protocol/transfer_function.h) and travels as this
// typed value through lod (cut criteria) and the renderer; nothing past the parser checks it
// again. Values in the attribute's own units; alpha and r, g, b in [0, 1]; outside the points
// the end values hold; without opacity points a ramp from 0 to 1 over the range; colour
// points replace the colormap; without a range the attribute's full range; without an
// attribute the dataset's first. A vector attribute is drawn by its magnitude, or by one
// component (`component`: 0, 1, 2 for x, y, z).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tetrascope::view {

// The colormaps the renderer draws (renderer::colormap).
inline constexpr std::array<std::string_view, 4> kColormapNames{"viridis", "plasma", "cool-warm", "grayscale"};
// Opacity or colour points of a transfer function; protocol::Limits::max_tf_points defaults to it.
inline constexpr uint32_t kMaxTfPoints = 256;
inline constexpr size_t kMaxAttributeNameLength = 128;
// TransferFunction::component of a vector attribute drawn by its magnitude (and of a scalar).
inline constexpr int kMagnitude = -1;
// The components a transfer function can choose, by index: "x", "y", "z" (and "magnitude").
inline constexpr std::array<std::string_view, 3> kComponentNames{"x", "y", "z"};

struct TransferFunction {
  std::string attribute;  // empty: the dataset's first attribute
  std::optional<std::array<double, 2>> range;  // lo < hi, finite
  std::string colormap = "viridis";            // one of kColormapNames
  std::vector<std::array<double, 2>> opacity;  // (value, alpha), ascending values
  std::vector<std::array<double, 4>> colors;   // (value, r, g, b), ascending values; empty: the colormap
  int component = kMagnitude;                  // of a vector attribute: kMagnitude or 0..2 (x, y, z)

  // Opacity at a value.
  double alpha(double value) const;
  // The user colour at a value (colors must not be empty).
  std::array<float, 3> user_color(double value) const;
  // Every field as text, exact (for caches of what was drawn with it).
  std::string key() const;
  bool operator==(const TransferFunction&) const = default;
};

}  // namespace tetrascope::view
