// Stage 1 of `tetrascope preprocess`: the whole input mesh in memory (16 bytes a tet plus the
// vertices), its vertices in one table that later levels extend, and the normalisation of
// every attribute (histogram channels, simplifier ranges).
#include <algorithm>
#include <cmath>
#include <limits>

#include "mt_stages.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::lod::mt {
namespace {

// Channels and simplifier ranges from the input's attribute values; copies them into the table.
void add_attributes(const storage::TetMesh& input, IngestedMesh& out) {
  const uint32_t n0 = out.input_vertices;
  VertexTable& table = out.table;
  uint32_t base = 0;
  for (const auto& a : input.attributes) {
    const uint32_t c = a.info.components;
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (uint32_t v = 0; v < n0; ++v) {
      double m = 0;
      for (uint32_t k = 0; k < c; ++k) {
        table.values[size_t{v} * table.floats + base + k] = a.values[size_t{v} * c + k];
        m += double(a.values[size_t{v} * c + k]) * a.values[size_t{v} * c + k];
      }
      m = c == 1 ? double(a.values[v]) : std::sqrt(m);
      if (!std::isfinite(m)) continue;
      lo = std::min(lo, m);
      hi = std::max(hi, m);
    }
    if (!std::isfinite(lo)) lo = hi = 0;
    out.channels.offset.push_back(base);
    out.channels.components.push_back(c);
    out.channels.lo.push_back(c == 1 ? lo : 0);
    out.channels.scale.push_back(c == 1 ? (hi > lo ? 1 / (hi - lo) : 0) : (hi > 0 ? 1 / hi : 0));
    out.ranges.push_back(c == 1 ? std::array<double, 2>{lo, hi} : std::array<double, 2>{0, hi});
    base += c;
  }
}

}  // namespace

IngestedMesh ingest_mesh(const std::filesystem::path& mesh_path, const storage::ReadLimits& limits) {
  IngestedMesh out;
  storage::TetMesh input = storage::load_mesh(mesh_path, &out.read_stats, limits);
  out.dropped_unused_vertices = storage::drop_unused_vertices(input);
  if (input.tet_count() == 0) throw std::runtime_error(mesh_path.string() + ": the mesh has no tetrahedra");
  if (input.vertex_count() >= 0x7FFFFFFFu) throw std::runtime_error(mesh_path.string() + ": too many vertices for one store");
  const uint32_t n0 = static_cast<uint32_t>(input.vertex_count());
  out.input_vertices = n0;
  out.input_tets = input.tet_count();
  VertexTable& table = out.table;
  table.xyz.resize(3 * size_t{n0});
  for (uint32_t v = 0; v < n0; ++v) {
    table.xyz[3 * size_t{v}] = input.x[v];
    table.xyz[3 * size_t{v} + 1] = input.y[v];
    table.xyz[3 * size_t{v} + 2] = input.z[v];
  }
  for (const auto& a : input.attributes) {
    out.attributes.push_back(a.info);
    table.floats += a.info.components;
  }
  table.values.resize(size_t{n0} * table.floats);
  add_attributes(input, out);
  out.bounds = storage::compute_bounds(input);
  const storage::Bounds& bounds = out.bounds;
  out.diagonal = std::max(1e-30, std::sqrt(std::pow(bounds.max[0] - bounds.min[0], 2) + std::pow(bounds.max[1] - bounds.min[1], 2) +
                                           std::pow(bounds.max[2] - bounds.min[2], 2)));
  out.tets = std::move(input.tets);
  return out;
}

}  // namespace tetrascope::lod::mt
