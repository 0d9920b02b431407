// The transfer function: a colormap (or user colour points) and a piecewise-linear opacity
// over a value range of one attribute. It arrives as JSON (tf.set, `tetrascope render --tf
// FILE`), is checked once here and travels as this typed value through lod (cut criteria)
// and the renderer; nothing past the parser checks it again.
//
// JSON (the same the browser sends):
//   {"attribute": "Temp", "range": [lo, hi], "colormap": "viridis",
//    "opacity": [[value, alpha], ...], "colors": [[value, r, g, b], ...]}
// values in the attribute's own units; alpha and r, g, b in [0, 1]; outside the points the
// end values hold; without "opacity" a ramp from 0 to 1 over the range; "colors" (user colour
// points) replace the colormap; without "range" the attribute's full range; without
// "attribute" the dataset's first.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

namespace tetrascope::protocol {

// The colormaps the renderer draws (renderer::colormap).
inline constexpr std::array<std::string_view, 4> kColormapNames{"viridis", "plasma", "cool-warm", "grayscale"};
// Opacity or colour points of a transfer function; Limits::max_tf_points defaults to it.
inline constexpr uint32_t kMaxTfPoints = 256;
inline constexpr size_t kMaxAttributeNameLength = 128;

struct TransferFunction {
  std::string attribute;  // empty: the dataset's first attribute
  std::optional<std::array<double, 2>> range;  // lo < hi, finite
  std::string colormap = "viridis";            // one of kColormapNames
  std::vector<std::array<double, 2>> opacity;  // (value, alpha), ascending values
  std::vector<std::array<double, 4>> colors;   // (value, r, g, b), ascending values; empty: the colormap

  // Opacity at a value.
  double alpha(double value) const;
  // The user colour at a value (colors must not be empty).
  std::array<float, 3> user_color(double value) const;

  // A transfer-function file (`--tf FILE`): the JSON above, plus an optional "name" label;
  // unknown keys are refused (a typo must not pass silently). Throws std::invalid_argument.
  static TransferFunction from_json(const nlohmann::json& j);
  nlohmann::json to_json() const;
};

// The one check of a transfer function's fields in `object` (untrusted), used by tf.set and
// from_json; keys other than the fields above are ignored. Throws ProtocolError
// (code::kBadField, carrying `id`) naming the field.
TransferFunction parse_transfer_function(const nlohmann::json& object, uint32_t max_points, std::optional<uint32_t> id);

}  // namespace tetrascope::protocol
