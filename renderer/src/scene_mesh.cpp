// The scene mesh: a tet mesh reduced to what drawing needs (positions, one attribute's values
// per vertex, the boundary faces, the longest edge), built once per mesh.
#include <algorithm>
#include <cmath>

#include "tetrascope/renderer/render.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::renderer {

namespace {

// values of an attribute per vertex (vector magnitude for vectors, or one component when
// `component` is not view::kMagnitude), non-finite as 0
std::vector<float> values_of(const storage::TetMesh& mesh, const storage::Attribute& a, int component = view::kMagnitude) {
  std::vector<float> out(mesh.vertex_count(), 0.0f);
  const uint32_t c = a.info.components;
  for (size_t v = 0; v < out.size(); ++v) {
    double m = 0;
    for (uint32_t k = 0; k < c; ++k) m += double(a.values[v * c + k]) * a.values[v * c + k];
    const double value = component != view::kMagnitude ? double(a.values[v * c + size_t(component)]) : c == 1 ? double(a.values[v]) : std::sqrt(m);
    out[v] = std::isfinite(value) ? static_cast<float>(value) : 0.0f;
  }
  return out;
}

void value_range(const std::vector<float>& values, double* lo, double* hi) {
  if (values.empty()) return;
  auto [a, b] = std::minmax_element(values.begin(), values.end());
  *lo = *a;
  *hi = *b;
}

// A component of a vector attribute: one it has (a scalar has none to choose).
void check_component(const storage::Attribute& a, int component) {
  if (component == view::kMagnitude) return;
  const uint32_t c = a.info.components;
  if (component < 0 || component >= int(view::kComponentNames.size()) || c < 2 || uint32_t(component) >= c)
    throw std::invalid_argument("attribute '" + a.info.name + "' has " + std::to_string(c) + " component" + (c == 1 ? "" : "s") + ": no component " +
                                (component >= 0 && component < int(view::kComponentNames.size()) ? std::string(view::kComponentNames[size_t(component)]) : std::to_string(component)) +
                                (c == 1 ? " (a scalar is drawn by its value)" : ""));
}

const storage::Attribute* chosen_attribute(const storage::TetMesh& mesh, const std::string& attribute) {
  if (attribute.empty()) return mesh.attributes.empty() ? nullptr : &mesh.attributes.front();
  if (const storage::Attribute* a = mesh.find_attribute(attribute)) return a;
  std::string names;
  for (const auto& b : mesh.attributes) names += (names.empty() ? "" : ", ") + b.info.name;
  throw std::invalid_argument("no attribute '" + attribute + "' (the mesh has: " + (names.empty() ? "none" : names) + ")");
}

double longest_edge(const std::vector<float>& xyz, const std::vector<uint32_t>& tets) {
  double longest = 0;
  for (size_t t = 0; t < tets.size() / 4; ++t) {
    const uint32_t* tet = &tets[4 * t];
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        double d2 = 0;
        for (int k = 0; k < 3; ++k) d2 += std::pow(double(xyz[3 * size_t{tet[i]} + k]) - xyz[3 * size_t{tet[j]} + k], 2);
        longest = std::max(longest, d2);
      }
  }
  return std::sqrt(longest);
}

}  // namespace

SceneMesh SceneMesh::from(const storage::TetMesh& mesh, const std::string& attribute, const std::string& iso_color_attribute, int component) {
  SceneMesh s;
  const size_t n = mesh.vertex_count();
  s.xyz.resize(3 * n);
  for (size_t v = 0; v < n; ++v) {
    s.xyz[3 * v] = mesh.x[v];
    s.xyz[3 * v + 1] = mesh.y[v];
    s.xyz[3 * v + 2] = mesh.z[v];
  }
  s.tets = mesh.tets;
  s.bounds = storage::compute_bounds(mesh);
  s.diagonal = std::max(1e-30, std::sqrt(std::pow(s.bounds.max[0] - s.bounds.min[0], 2) + std::pow(s.bounds.max[1] - s.bounds.min[1], 2) +
                                         std::pow(s.bounds.max[2] - s.bounds.min[2], 2)));
  s.value.assign(n, 0.0f);
  if (const storage::Attribute* a = chosen_attribute(mesh, attribute)) {
    check_component(*a, component);
    s.attribute = a->info.name;
    s.component = component;
    s.value = values_of(mesh, *a, component);
  }
  value_range(s.value, &s.value_min, &s.value_max);
  if (!iso_color_attribute.empty()) {
    const storage::Attribute* b = mesh.find_attribute(iso_color_attribute);
    if (!b) throw std::invalid_argument("no attribute '" + iso_color_attribute + "' to colour by");
    s.iso_color_value = values_of(mesh, *b);
    s.iso_color_attribute = iso_color_attribute;
    value_range(s.iso_color_value, &s.iso_color_min, &s.iso_color_max);
  }
  s.attributes = mesh.attributes;
  s.boundary = boundary_faces(s.tets);
  s.max_edge = longest_edge(s.xyz, s.tets);
  return s;
}

}  // namespace tetrascope::renderer
