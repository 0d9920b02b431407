// lines.set, points.set and tensors.set (protocol.h) applied to a session's view request, and
// the checks of a stream-line or tensor field against the dataset (at the edge, so a bad field
// is answered at once).
#pragma once

#include <cstdint>
#include <string>

#include "datasets.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/view_frame.h"

namespace tetrascope::server {

constexpr uint32_t kDefaultRakeSeeds = 100;
constexpr uint32_t kDefaultDenseCells = 12;

// What the message carries replaces the request's; the rest stays.
void apply_lines_set(const protocol::LinesSet& message, view::LineRequest& line);
// A lines.set carrying only dash_phase: a step of the viewer's dash animation, answered with
// an interaction frame (not refined to a still at once, so the animation stays cheap).
bool is_animation_step(const protocol::LinesSet& message);
void apply_points_set(const protocol::PointsSet& message, view::ViewRequest& view);
// Throws ProtocolError: not_found when the dataset has no attribute `name`, bad_field when it
// is not a 3-component (vector) attribute; both name the dataset's vector fields.
void check_vector_field(const Dataset& dataset, const std::string& name, uint32_t id);

void apply_tensors_set(const protocol::TensorsSet& message, view::TensorRequest& tensor);
// Throws ProtocolError: not_found when the dataset has no attribute `name`, bad_field when it
// is not a symmetric tensor; both name the dataset's tensor fields.
void check_tensor_field(const Dataset& dataset, const std::string& name, uint32_t id);

}  // namespace tetrascope::server
