// Tensor attributes as MeshStream delivers them: symmetrised, with their derived scalars, and
// checked for positive semi-definiteness on the way (docs/formats.md, "Tensors").
#include "tensor_stream.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "tetrascope/storage/tensor.h"

namespace tetrascope::storage::detail {

MeshHeader TensorExpansion::plan(const MeshHeader& raw, ReadStats& stats) {
  MeshHeader out = raw;
  out.attributes.clear();
  out.cell_attributes.clear();
  const size_t points = raw.point_attribute_count();
  std::vector<std::string> taken;
  for (const AttributeInfo& info : raw.attributes) taken.push_back(info.name);
  for (size_t a = 0; a < raw.attributes.size(); ++a) {
    const AttributeInfo& info = raw.attributes[a];
    const AttributeInfo* cell = a >= points ? &raw.cell_attributes[a - points] : nullptr;
    if (info.kind != AttributeKind::kTensor) {
      outputs_.push_back({a, info.components, false, false, {}});
      out.attributes.push_back(info);
      if (cell) out.cell_attributes.push_back(*cell);
      continue;
    }
    if (info.components != 9 && info.components != 6) throw MeshError("tensor '" + info.name + "' has " + std::to_string(info.components) + " components, expected 9 or 6");
    active_ = true;
    tensors_.push_back({outputs_.size(), {}, 0, 0, true, 0});
    outputs_.push_back({a, info.components, true, false, {}});
    AttributeInfo tensor{info.name, 6, AttributeKind::kTensor};
    out.attributes.push_back(tensor);
    if (cell) out.cell_attributes.push_back({cell->name, 6, AttributeKind::kTensor});
    const auto derived = derived_attribute_infos(info.name);
    size_t clashes = 0, carried = 0;
    for (const AttributeInfo& d : derived) {
      clashes += std::find(taken.begin(), taken.end(), d.name) != taken.end();
      for (const AttributeInfo& r : raw.attributes) carried += r.name == d.name && r.components == 1 && r.kind == AttributeKind::kValue;
    }
    if (carried == kTensorQuantityCount) {  // a file tetrascope wrote (simplify, cut): its derived scalars are taken as they are
      carried_.push_back(info.name);
      continue;
    }
    if (clashes > 0) {
      stats.warnings.push_back("tensor '" + info.name + "': its derived scalars are not added (an attribute has one of their names, '" + info.name + ".*')");
      continue;
    }
    const auto cell_derived = derived_attribute_infos(cell ? cell->name : info.name);
    for (size_t k = 0; k < kTensorQuantityCount; ++k) {
      tensors_.back().derived.emplace_back(outputs_.size(), k);
      outputs_.push_back({a, 1, false, true, {}});
      out.attributes.push_back(derived[k]);
      taken.push_back(derived[k].name);
      if (cell) out.cell_attributes.push_back(cell_derived[k]);
    }
  }
  for (const std::string& tensor : carried_) {
    for (const AttributeInfo& d : derived_attribute_infos(tensor)) {
      for (AttributeInfo& a : out.attributes) {
        if (a.name != d.name) continue;
        a.kind = AttributeKind::kTensorDerived;
        a.derived_from = tensor;
      }
    }
  }
  return out;
}

void TensorExpansion::expand(size_t count, std::vector<std::span<const float>>& attributes) {
  const std::vector<std::span<const float>> raw = std::move(attributes);
  attributes.assign(outputs_.size(), {});
  for (size_t o = 0; o < outputs_.size(); ++o) {
    Output& out = outputs_[o];
    if (!out.tensor && !out.derived) {
      attributes[o] = raw[out.raw];
      continue;
    }
    out.scratch.resize(count * (out.tensor ? 6 : 1));
    attributes[o] = out.scratch;
  }
  for (TensorState& state : tensors_) {
    Output& tensor = outputs_[state.output];
    const float* in = raw[tensor.raw].data();
    for (size_t v = 0; v < count; ++v) {
      double asymmetry = 0;
      const SymmetricTensor t = tensor.raw_components == 9 ? tensor_from_full(in + 9 * v, asymmetry) : tensor_from_symmetric(in + 6 * v);
      store_tensor(t, tensor.scratch.data() + 6 * v);
      if (asymmetry > state.max_asymmetry) {
        state.max_asymmetry = asymmetry;
        state.asymmetry_vertex = vertices_done_ + v;
      }
      // from the stored floats, so that recomputing them later (refresh_tensor_attributes) agrees
      const auto q = tensor_quantities(tensor_from_symmetric(tensor.scratch.data() + 6 * v));
      for (const auto& [output, quantity] : state.derived) outputs_[output].scratch[v] = static_cast<float>(q[quantity]);
      const double l1 = q[size_t(TensorQuantity::kLambda1)], l3 = q[size_t(TensorQuantity::kLambda3)];
      if (!std::isfinite(l1)) continue;  // a tensor the file did not give (Gmsh nodes without data)
      ++state.finite;
      if (l3 < -kPsdTolerance * std::max(std::fabs(l1), std::fabs(l3))) state.positive_semidefinite = false;
    }
  }
  vertices_done_ += count;
}

void TensorExpansion::finish(MeshHeader& header, ReadStats& stats) {
  for (const TensorState& state : tensors_) {
    AttributeInfo& info = header.attributes[state.output];
    info.positive_semidefinite = state.positive_semidefinite && state.finite > 0;
    if (state.max_asymmetry > 0) {
      char value[32];
      std::snprintf(value, sizeof value, "%g", state.max_asymmetry);
      stats.warnings.push_back("tensor '" + info.name + "' is not symmetric (largest |A_ij - A_ji| / 2 = " + value + ", at vertex " +
                               std::to_string(state.asymmetry_vertex) + "): stored as (A + A^T) / 2");
    }
  }
}

}  // namespace tetrascope::storage::detail
