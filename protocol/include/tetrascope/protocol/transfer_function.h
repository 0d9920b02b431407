// The transfer function: a colormap (or user colour points) and a piecewise-linear opacity
// over a value range of one attribute. It arrives as JSON (tf.set, `tetrascope render --tf
// FILE`), is checked once here and travels as this typed value through lod (cut criteria)
// and the renderer; nothing past the parser checks it again.
//
// JSON (the same the browser sends):
//   {"attribute": "Temp", "component": "x", "range": [lo, hi], "colormap": "viridis",
//    "opacity": [[value, alpha], ...], "colors": [[value, r, g, b], ...]}
// values in the attribute's own units; alpha and r, g, b in [0, 1]; outside the points the
// end values hold; without "opacity" a ramp from 0 to 1 over the range; "colors" (user colour
// points) replace the colormap; without "range" the attribute's full range; without
// "attribute" the dataset's first; "component" ("magnitude", "x", "y" or "z"; without it the
// magnitude) picks what of a vector attribute is drawn (the session and `render` refuse a
// component the attribute lacks).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/view/transfer_function.h"

namespace tetrascope::protocol {

// The transfer function itself is view's (view/transfer_function.h): this converts JSON to and
// from it.
using view::kColormapNames;
using view::kComponentNames;
using view::kMaxAttributeNameLength;
using view::kMaxTfPoints;
using view::TransferFunction;

// A transfer-function file (`--tf FILE`): the JSON above, plus an optional "name" label;
// unknown keys are refused (a typo must not pass silently). Throws std::invalid_argument.
TransferFunction transfer_function_from_json(const nlohmann::json& j);
nlohmann::json transfer_function_json(const TransferFunction& tf);

// The one check of a transfer function's fields in `object` (untrusted), used by tf.set and
// from_json; keys other than the fields above are ignored. Throws ProtocolError
// (code::kBadField, carrying `id`) naming the field.
TransferFunction parse_transfer_function(const nlohmann::json& object, uint32_t max_points, std::optional<uint32_t> id);

}  // namespace tetrascope::protocol
