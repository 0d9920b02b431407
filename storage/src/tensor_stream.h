// The tensors a reader delivers (9 components, row-major, or 6 symmetric ones) turned into what
// MeshStream delivers: the 6 symmetric components, (A + A^T) / 2, followed by the derived
// scalars of tensor.h as attributes of their own.
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::storage::detail {

class TensorExpansion {
 public:
  // The header MeshStream shows for a reader's header `raw` (whose cell attributes were already
  // renamed where a point array has their name); warns in `stats` about derived names taken.
  MeshHeader plan(const MeshHeader& raw, ReadStats& stats);
  // Whether any attribute is a tensor (otherwise the raw attributes pass unchanged).
  bool active() const { return active_; }
  // `attributes` holds the raw attributes of `count` vertices; on return, the delivered ones
  // (spans into this object's scratch or the raw arrays, valid until the next call).
  void expand(size_t count, std::vector<std::span<const float>>& attributes);
  // After the last vertex: every tensor's positive semi-definiteness into `header`, and a
  // warning with the largest asymmetry of each tensor that was not symmetric.
  void finish(MeshHeader& header, ReadStats& stats);

 private:
  struct Output {
    size_t raw = 0;            // the raw attribute it comes from
    uint32_t raw_components = 1;
    bool tensor = false;       // the symmetric tensor (6 floats a vertex)
    bool derived = false;      // a derived scalar
    std::vector<float> scratch;
  };
  struct TensorState {
    size_t output = 0;  // of the tensor
    std::vector<std::pair<size_t, size_t>> derived;  // (output, TensorQuantity) of its derived scalars
    double max_asymmetry = 0;
    uint64_t asymmetry_vertex = 0;
    bool positive_semidefinite = true;
    uint64_t finite = 0;
  };
  bool active_ = false;
  uint64_t vertices_done_ = 0;
  std::vector<Output> outputs_;
  std::vector<TensorState> tensors_;
  std::vector<std::string> carried_;  // tensors whose file has all nine derived scalars already
};

}  // namespace tetrascope::storage::detail
