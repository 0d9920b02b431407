// Error histograms of the multi-triangulation (dissertation §6.3.4): every original vertex is
// followed down the levels (the tet of the current level that holds it); a segment's field
// error in value slot n is the largest difference, at the original vertices it holds whose
// normalised value falls in slot n, between the original value and the segment's
// interpolated one; the spatial error divides that by the segment's local gradient (how far
// the isosurface through the vertex moved). Both are then made monotone: a segment's
// histogram is at least its children's.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "tet_locator.h"
#include "mt_stages.h"
#include "tetrascope/lod/cut/dag_format.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::lod::mt {
namespace {

using detail::TetLocator;

// How far the isosurface of channel c through a point moved for a value error `err`: err
// over the channel's gradient in the tet (corners P, in units of the diagonal; Cramer's rule),
// at most 1.
double isosurface_displacement(const double P[4][3], const std::vector<double>& corner, uint32_t channels, uint32_t c, double err) {
  double e[3][3];
  for (int j = 0; j < 3; ++j)
    for (int q = 0; q < 3; ++q) e[j][q] = P[j + 1][q] - P[0][q];
  const double det = e[0][0] * (e[1][1] * e[2][2] - e[1][2] * e[2][1]) - e[0][1] * (e[1][0] * e[2][2] - e[1][2] * e[2][0]) + e[0][2] * (e[1][0] * e[2][1] - e[1][1] * e[2][0]);
  double g2 = 0;
  if (std::fabs(det) > 0) {
    double d[3];
    for (int j = 0; j < 3; ++j) d[j] = corner[static_cast<size_t>(j + 1) * channels + c] - corner[c];
    double grad[3];
    for (int q = 0; q < 3; ++q) {
      double m3[3][3];
      for (int r = 0; r < 3; ++r)
        for (int s = 0; s < 3; ++s) m3[r][s] = s == q ? d[r] : e[r][s];
      grad[q] = (m3[0][0] * (m3[1][1] * m3[2][2] - m3[1][2] * m3[2][1]) - m3[0][1] * (m3[1][0] * m3[2][2] - m3[1][2] * m3[2][0]) +
                 m3[0][2] * (m3[1][0] * m3[2][1] - m3[1][1] * m3[2][0])) / det;
    }
    g2 = grad[0] * grad[0] + grad[1] * grad[1] + grad[2] * grad[2];
  }
  return err > 0 ? (g2 > 0 ? std::min(1.0, err / std::sqrt(g2)) : 1.0) : 0.0;
}

}  // namespace

CeilingError measure_ceiling_error(const storage::TetMesh& m, std::span<const uint32_t> original_vertices, const IngestedMesh& mesh, uint32_t bins) {
  const VertexTable& table = mesh.table;
  const Channels& channels = mesh.channels;
  const uint32_t C = static_cast<uint32_t>(channels.size()), N = bins;
  CeilingError out;
  out.field.assign(size_t{C} * N, 0.0f);
  out.spatial.assign(size_t{C} * N, 0.0f);
  std::vector<double> mass(size_t{C} * 4 * N, 0.0);  // per channel: Σ err·vol, Σ err·vol·x, ·y, ·z
  const double unit_volume = mesh.diagonal * mesh.diagonal * mesh.diagonal;
  const TetLocator locator(m);
  std::vector<double> original(C), corner(4 * size_t{C});
  std::vector<float> values(table.floats);
  out.located_tet.resize(original_vertices.size());
  if (m.tet_count() == 0) return out;  // nothing to locate in (the caller keeps a ceiling's tets)
  for (size_t i = 0; i < original_vertices.size(); ++i) {
    const uint32_t v = original_vertices[i];
    double bary[4];
    const Vec3 p{table.xyz[3 * size_t{v}], table.xyz[3 * size_t{v} + 1], table.xyz[3 * size_t{v} + 2]};
    const uint32_t t = locator.nearest(p, bary);
    out.located_tet[i] = t;
    if (C == 0) continue;
    channels.normalise(&table.values[size_t{v} * table.floats], original.data());
    const uint32_t* tet = &m.tets[4 * size_t{t}];
    for (int j = 0; j < 4; ++j) {
      size_t base = 0;
      for (size_t a = 0; a < m.attributes.size(); ++a) {
        const uint32_t c = m.attributes[a].info.components;
        for (uint32_t q = 0; q < c; ++q) values[base + q] = m.attributes[a].values[size_t{tet[j]} * c + q];
        base += c;
      }
      channels.normalise(values.data(), &corner[static_cast<size_t>(j) * C]);
    }
    // corners per unit of the diagonal, for the gradient
    double P[4][3];
    for (int j = 0; j < 4; ++j) {
      P[j][0] = m.x[tet[j]] / mesh.diagonal;
      P[j][1] = m.y[tet[j]] / mesh.diagonal;
      P[j][2] = m.z[tet[j]] / mesh.diagonal;
    }
    for (uint32_t c = 0; c < C; ++c) {
      double a = 0;
      for (int j = 0; j < 4; ++j) a += bary[j] * corner[static_cast<size_t>(j) * C + c];
      const double err = std::fabs(a - original[c]);
      const uint32_t bin = std::min<uint32_t>(N - 1, static_cast<uint32_t>(std::clamp(original[c], 0.0, 1.0) * N));
      float& f = out.field[size_t{c} * N + bin];
      f = std::max(f, static_cast<float>(err));
      float& s = out.spatial[size_t{c} * N + bin];
      s = std::max(s, static_cast<float>(isosurface_displacement(P, corner, C, c, err)));
      const double w = err * (v < mesh.vertex_volume.size() ? mesh.vertex_volume[v] / unit_volume : 0.0);
      double* sum = &mass[size_t{c} * 4 * N + bin];
      sum[0] += w;
      for (int k = 0; k < 3; ++k) sum[(k + 1) * N] += w * p[k];
    }
  }
  out.mass.assign(mass.size(), 0.0f);
  for (size_t c = 0; c < C; ++c)
    for (size_t bin = 0; bin < N; ++bin) {
      const double* sum = &mass[c * 4 * N + bin];
      if (!(sum[0] > 0) || !std::isfinite(sum[0])) continue;
      float* at = &out.mass[c * 4 * N + bin];
      at[0] = static_cast<float>(sum[0]);
      for (size_t k = 1; k < 4; ++k) at[k * N] = static_cast<float>(sum[k * N] / sum[0]);
    }
  return out;
}

std::vector<PatchRange> dag_arcs(Hierarchy& h, uint32_t values_per_node) {
  const uint32_t levels = h.level_count();
  const uint32_t node_count = static_cast<uint32_t>(h.nodes.size());
  // the coarsest segments hang from the root; patches grouped by ceiling, roots first
  std::vector<PatchRange> all;
  for (uint32_t n = h.level_first[levels - 1]; n < node_count; ++n) all.push_back({dag::kRoot, n, 0, static_cast<uint32_t>(h.nodes.tet_count(n))});
  std::stable_sort(h.patches.begin(), h.patches.end(), [](const PatchRange& a, const PatchRange& b) { return a.ceiling < b.ceiling; });
  all.insert(all.end(), h.patches.begin(), h.patches.end());
  std::vector<PatchRange>().swap(h.patches);
  // monotone histograms: a segment's error is at least its children's (children have lower ids)
  const size_t V = values_per_node;
  for (const PatchRange& p : all) {
    if (p.ceiling == dag::kRoot) continue;
    for (size_t i = 0; i < V; ++i) {
      h.field[size_t{p.ceiling} * V + i] = std::max(h.field[size_t{p.ceiling} * V + i], h.field[size_t{p.floor} * V + i]);
      h.spatial[size_t{p.ceiling} * V + i] = std::max(h.spatial[size_t{p.ceiling} * V + i], h.spatial[size_t{p.floor} * V + i]);
    }
  }
  return all;
}

}  // namespace tetrascope::lod::mt
