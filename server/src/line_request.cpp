#include "line_request.h"

#include <cstdio>

namespace tetrascope::server {

namespace {

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

}  // namespace

void apply_lines_set(const protocol::LinesSet& m, view::LineRequest& line) {
  if (m.field) line.field = *m.field;
  if (m.dense) line.seeds = "dense:" + std::to_string(m.count.value_or(kDefaultDenseCells));
  if (m.rake) {
    line.seeds = "line:";
    for (double v : *m.rake) line.seeds += number(v) + ",";
    line.seeds += std::to_string(m.count.value_or(kDefaultRakeSeeds));
  }
  if (m.max_steps) line.max_steps = *m.max_steps;
  if (m.select) {
    line.selected = m.select_lines;
    line.select_box = m.select_box;
    line.select_pixel = m.select_pixel;
  }
  if (m.ghost_opacity) line.ghost_opacity = *m.ghost_opacity;
  if (m.line_width) line.line_width = *m.line_width;
  if (m.halos) line.halos = *m.halos;
  if (m.depth_correction) line.depth_correction = *m.depth_correction;
  if (m.dash_phase) line.dash_phase = *m.dash_phase;
  if (m.flow) line.flow = *m.flow == "arrows" ? view::FlowStyle::arrows : *m.flow == "dashes" ? view::FlowStyle::dashes : view::FlowStyle::none;
}

bool is_animation_step(const protocol::LinesSet& m) {
  return m.dash_phase && !m.field && !m.dense && !m.rake && !m.count && !m.max_steps && !m.select && !m.ghost_opacity && !m.line_width && !m.halos && !m.flow &&
         !m.depth_correction;
}

void apply_points_set(const protocol::PointsSet& m, view::ViewRequest& view) {
  view.point_isovalues = m.values;
  if (m.size) view.point_size = *m.size;
}

void check_vector_field(const Dataset& dataset, const std::string& name, uint32_t id) {
  std::string vectors;
  const storage::StoreAttribute* found = nullptr;
  for (const auto& a : dataset.store->manifest().attributes) {
    if (a.components == 3) vectors += (vectors.empty() ? "" : ", ") + a.name;
    if (a.name == name) found = &a;
  }
  if (vectors.empty()) vectors = "none";
  if (!found) throw protocol::ProtocolError(protocol::code::kNotFound, "no attribute '" + name + "' in " + dataset.name + " (its vector fields: " + vectors + ")", id);
  if (found->components != 3)
    throw protocol::ProtocolError(protocol::code::kBadField, "field: '" + name + "' has " + std::to_string(found->components) + " component(s); stream lines need a vector field (" + dataset.name + " has: " + vectors + ")", id);
}

void apply_tensors_set(const protocol::TensorsSet& m, view::TensorRequest& tensor) {
  if (m.field) tensor.field = *m.field;
  if (m.density) tensor.tube_cells = *m.density;
  if (m.surface_density) tensor.surface_cells = *m.surface_density;
  if (m.min_cl) tensor.min_linear = *m.min_cl;
  if (m.min_cp) tensor.min_planar = *m.min_cp;
  if (m.color) tensor.color = *m.color;
  if (m.size) tensor.point_size = *m.size;
}

void check_tensor_field(const Dataset& dataset, const std::string& name, uint32_t id) {
  std::string tensors;
  const storage::StoreAttribute* found = nullptr;
  for (const auto& a : dataset.store->manifest().attributes) {
    if (a.kind == storage::AttributeKind::kTensor) tensors += (tensors.empty() ? "" : ", ") + a.name;
    if (a.name == name) found = &a;
  }
  if (tensors.empty()) tensors = "none";
  if (!found) throw protocol::ProtocolError(protocol::code::kNotFound, "no attribute '" + name + "' in " + dataset.name + " (its tensor fields: " + tensors + ")", id);
  if (found->kind != storage::AttributeKind::kTensor)
    throw protocol::ProtocolError(protocol::code::kBadField, "field: '" + name + "' is not a symmetric tensor (" + dataset.name + " has: " + tensors + ")", id);
}

}  // namespace tetrascope::server
