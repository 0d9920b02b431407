// Symmetric 3x3 tensors: closed-form eigenvalues (O. K. Smith, "Eigenvalues of a symmetric 3x3
// matrix", CACM 4(4), 1961) with cyclic Jacobi rotations where two eigenvalues nearly coincide
// (and for the eigenvectors of the rare tensor that must be clamped), and the derived scalars of dissertation §7.4.2 (Westin et al. 1997's cl, cp, cs) and
// of structural mechanics (von Mises).
#include "tetrascope/storage/tensor.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

namespace tetrascope::storage {

namespace {

// 1 - |r| below this takes the Jacobi fallback (there acos's slope exceeds ~70).
constexpr double kNearlyRepeated = 1e-4;

bool finite(const SymmetricTensor& t) {
  return std::isfinite(t.xx) && std::isfinite(t.yy) && std::isfinite(t.zz) && std::isfinite(t.xy) && std::isfinite(t.yz) && std::isfinite(t.xz);
}

void sort_descending(std::array<double, 3>& v) {
  if (v[0] < v[1]) std::swap(v[0], v[1]);
  if (v[1] < v[2]) std::swap(v[1], v[2]);
  if (v[0] < v[1]) std::swap(v[0], v[1]);
}

}  // namespace

SymmetricTensor tensor_from_symmetric(const float* six) { return {six[0], six[1], six[2], six[3], six[4], six[5]}; }

SymmetricTensor tensor_from_full(const float* nine, double& asymmetry) {
  // row-major: 0 xx, 1 xy, 2 xz, 3 yx, 4 yy, 5 yz, 6 zx, 7 zy, 8 zz
  const double xy = 0.5 * (double(nine[1]) + nine[3]), yz = 0.5 * (double(nine[5]) + nine[7]), xz = 0.5 * (double(nine[2]) + nine[6]);
  asymmetry = 0.5 * std::max({std::fabs(double(nine[1]) - nine[3]), std::fabs(double(nine[5]) - nine[7]), std::fabs(double(nine[2]) - nine[6])});
  return {nine[0], nine[4], nine[8], xy, yz, xz};
}

void store_tensor(const SymmetricTensor& t, float* six) {
  six[0] = static_cast<float>(t.xx);
  six[1] = static_cast<float>(t.yy);
  six[2] = static_cast<float>(t.zz);
  six[3] = static_cast<float>(t.xy);
  six[4] = static_cast<float>(t.yz);
  six[5] = static_cast<float>(t.xz);
}

SymmetricTensor interpolate_tensor(const float* six_per_vertex, const uint32_t corners[4], const double weights[4]) {
  double c[6] = {0, 0, 0, 0, 0, 0};
  for (int i = 0; i < 4; ++i) {
    const float* f = six_per_vertex + 6 * size_t{corners[i]};
    for (int k = 0; k < 6; ++k) c[k] += weights[i] * f[k];
  }
  return {c[0], c[1], c[2], c[3], c[4], c[5]};
}

std::array<double, 3> eigenvalues(const SymmetricTensor& t) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  if (!finite(t)) return {kNaN, kNaN, kNaN};
  std::array<double, 3> values{t.xx, t.yy, t.zz};
  const double off = t.xy * t.xy + t.yz * t.yz + t.xz * t.xz;
  if (off == 0) {  // diagonal: the diagonal is the answer, exactly
    sort_descending(values);
    return values;
  }
  // Scaled to a largest entry of 1 so that p^(3/2) neither overflows nor underflows.
  const double scale = std::max({std::fabs(t.xx), std::fabs(t.yy), std::fabs(t.zz), std::fabs(t.xy), std::fabs(t.yz), std::fabs(t.xz)});
  const double xx = t.xx / scale, yy = t.yy / scale, zz = t.zz / scale, xy = t.xy / scale, yz = t.yz / scale, xz = t.xz / scale;
  const double mean = (xx + yy + zz) / 3;
  const double a = xx - mean, b = yy - mean, c = zz - mean;
  const double p = (a * a + b * b + c * c + 2 * (xy * xy + yz * yz + xz * xz)) / 6;  // > 0: some off-diagonal entry is not 0
  // det(B) / 2 for B = A - mean I, then r = det(B) / (2 p^(3/2)) in [-1, 1] up to rounding
  const double det = a * (b * c - yz * yz) - xy * (xy * c - yz * xz) + xz * (xy * yz - b * xz);
  const double r = std::clamp(det / (2 * p * std::sqrt(p)), -1.0, 1.0);
  // Near |r| = 1 (two equal eigenvalues) acos turns a rounding error ε in r into √ε in the
  // angle, eigenvalues good to ~1e-8 only: Jacobi rotations are exact to rounding there.
  if (1 - std::fabs(r) < kNearlyRepeated) return eigensystem(t).values;
  const double phi = std::acos(r) / 3;
  const double radius = 2 * std::sqrt(p);
  values[0] = mean + radius * std::cos(phi);
  values[2] = mean + radius * std::cos(phi + 2 * std::numbers::pi / 3);
  values[1] = 3 * mean - values[0] - values[2];  // the trace is kept exactly
  sort_descending(values);                       // rounding may swap nearly equal values
  for (double& v : values) v *= scale;
  return values;
}

Eigensystem eigensystem(const SymmetricTensor& t) {
  double m[3][3] = {{t.xx, t.xy, t.xz}, {t.xy, t.yy, t.yz}, {t.xz, t.yz, t.zz}};
  double v[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  constexpr int kMaxSweeps = 64;
  for (int sweep = 0; sweep < kMaxSweeps; ++sweep) {
    const double off = m[0][1] * m[0][1] + m[1][2] * m[1][2] + m[0][2] * m[0][2];
    const double diagonal = m[0][0] * m[0][0] + m[1][1] * m[1][1] + m[2][2] * m[2][2];
    if (!(off > 1e-32 * diagonal)) break;  // also ends on NaN
    for (int p = 0; p < 2; ++p) {
      for (int q = p + 1; q < 3; ++q) {
        if (m[p][q] == 0) continue;
        // the rotation that zeroes m[p][q] (Golub and Van Loan, Algorithm 8.4.1)
        const double theta = (m[q][q] - m[p][p]) / (2 * m[p][q]);
        const double tangent = (theta >= 0 ? 1.0 : -1.0) / (std::fabs(theta) + std::sqrt(theta * theta + 1));
        const double cosine = 1 / std::sqrt(tangent * tangent + 1), sine = tangent * cosine;
        for (int k = 0; k < 3; ++k) {  // m = J^T m J, columns then rows
          const double mkp = m[k][p], mkq = m[k][q];
          m[k][p] = cosine * mkp - sine * mkq;
          m[k][q] = sine * mkp + cosine * mkq;
        }
        for (int k = 0; k < 3; ++k) {
          const double mpk = m[p][k], mqk = m[q][k];
          m[p][k] = cosine * mpk - sine * mqk;
          m[q][k] = sine * mpk + cosine * mqk;
        }
        for (int k = 0; k < 3; ++k) {
          const double vkp = v[k][p], vkq = v[k][q];
          v[k][p] = cosine * vkp - sine * vkq;
          v[k][q] = sine * vkp + cosine * vkq;
        }
      }
    }
  }
  int order[3] = {0, 1, 2};
  std::sort(order, order + 3, [&](int i, int j) { return m[i][i] > m[j][j]; });
  Eigensystem e;
  for (int i = 0; i < 3; ++i) {
    e.values[i] = m[order[i]][order[i]];
    for (int k = 0; k < 3; ++k) e.vectors[i][k] = v[k][order[i]];
  }
  return e;
}

SymmetricTensor clamp_positive_semidefinite(const SymmetricTensor& t) {
  if (!finite(t) || eigenvalues(t)[2] >= 0) return t;
  const Eigensystem e = eigensystem(t);
  SymmetricTensor out;
  for (int i = 0; i < 3; ++i) {
    const double l = std::max(e.values[i], 0.0);
    const auto& u = e.vectors[i];
    out.xx += l * u[0] * u[0];
    out.yy += l * u[1] * u[1];
    out.zz += l * u[2] * u[2];
    out.xy += l * u[0] * u[1];
    out.yz += l * u[1] * u[2];
    out.xz += l * u[0] * u[2];
  }
  return out;
}

std::array<double, kTensorQuantityCount> tensor_quantities(const SymmetricTensor& t) {
  std::array<double, kTensorQuantityCount> q;
  if (!finite(t)) {
    q.fill(std::numeric_limits<double>::quiet_NaN());
    return q;
  }
  const std::array<double, 3> l = eigenvalues(t);
  q[size_t(TensorQuantity::kLambda1)] = l[0];
  q[size_t(TensorQuantity::kLambda2)] = l[1];
  q[size_t(TensorQuantity::kLambda3)] = l[2];
  const double trace = t.xx + t.yy + t.zz;
  q[size_t(TensorQuantity::kTrace)] = trace;
  const double dxy = t.xx - t.yy, dyz = t.yy - t.zz, dzx = t.zz - t.xx;
  q[size_t(TensorQuantity::kVonMises)] = std::sqrt(0.5 * (dxy * dxy + dyz * dyz + dzx * dzx + 6 * (t.xy * t.xy + t.yz * t.yz + t.xz * t.xz)));
  const double mean = (l[0] + l[1] + l[2]) / 3;
  const double spread = (l[0] - mean) * (l[0] - mean) + (l[1] - mean) * (l[1] - mean) + (l[2] - mean) * (l[2] - mean);
  const double norm2 = l[0] * l[0] + l[1] * l[1] + l[2] * l[2];
  q[size_t(TensorQuantity::kFractionalAnisotropy)] = norm2 > 0 ? std::sqrt(1.5 * spread / norm2) : 0;
  std::array<double, 3> magnitude{std::fabs(l[0]), std::fabs(l[1]), std::fabs(l[2])};
  sort_descending(magnitude);
  const double sum = magnitude[0] + magnitude[1] + magnitude[2];
  q[size_t(TensorQuantity::kLinear)] = sum > 0 ? (magnitude[0] - magnitude[1]) / sum : 0;
  q[size_t(TensorQuantity::kPlanar)] = sum > 0 ? 2 * (magnitude[1] - magnitude[2]) / sum : 0;
  q[size_t(TensorQuantity::kSpherical)] = sum > 0 ? 3 * magnitude[2] / sum : 1;
  return q;
}

std::array<AttributeInfo, kTensorQuantityCount> derived_attribute_infos(const std::string& tensor_name) {
  std::array<AttributeInfo, kTensorQuantityCount> infos;
  for (size_t k = 0; k < kTensorQuantityCount; ++k) {
    infos[k].name = tensor_name + "." + kTensorQuantityNames[k];
    infos[k].components = 1;
    infos[k].kind = AttributeKind::kTensorDerived;
    infos[k].derived_from = tensor_name;
  }
  return infos;
}

namespace {

// The quantity a derived attribute holds, from its name "TENSOR.QUANTITY"; -1 if none.
int quantity_of(const AttributeInfo& info) {
  const std::string prefix = info.derived_from + ".";
  if (info.name.compare(0, prefix.size(), prefix) != 0) return -1;
  const std::string quantity = info.name.substr(prefix.size());
  for (size_t k = 0; k < kTensorQuantityCount; ++k)
    if (quantity == kTensorQuantityNames[k]) return static_cast<int>(k);
  return -1;
}

// Where attribute a's components of vertex v lie: values[a] + v * stride[a].
struct AttributeArrays {
  std::vector<float*> values;
  std::vector<size_t> stride;
};

void refresh_tensors(std::span<const AttributeInfo> infos, const AttributeArrays& arrays, size_t vertices) {
  for (size_t t = 0; t < infos.size(); ++t) {
    const AttributeInfo& tensor = infos[t];
    if (tensor.kind != AttributeKind::kTensor || tensor.components != 6 || arrays.values[t] == nullptr) continue;
    const auto at = [&](size_t a, size_t v) { return arrays.values[a] + v * arrays.stride[a]; };
    if (tensor.positive_semidefinite) {
      for (size_t v = 0; v < vertices; ++v) store_tensor(clamp_positive_semidefinite(tensor_from_symmetric(at(t, v))), at(t, v));
    }
    std::vector<std::pair<size_t, int>> targets;
    for (size_t d = 0; d < infos.size(); ++d) {
      if (infos[d].kind != AttributeKind::kTensorDerived || infos[d].derived_from != tensor.name || arrays.values[d] == nullptr) continue;
      const int quantity = quantity_of(infos[d]);
      if (quantity >= 0) targets.emplace_back(d, quantity);
    }
    if (targets.empty()) continue;
    for (size_t v = 0; v < vertices; ++v) {
      const auto q = tensor_quantities(tensor_from_symmetric(at(t, v)));
      for (const auto& target : targets) *at(target.first, v) = static_cast<float>(q[static_cast<size_t>(target.second)]);
    }
  }
}

}  // namespace

void refresh_tensor_attributes(TetMesh& mesh) {
  const size_t vertices = mesh.vertex_count();
  std::vector<AttributeInfo> infos;
  AttributeArrays arrays;
  for (Attribute& a : mesh.attributes) {
    infos.push_back(a.info);
    const bool whole = a.values.size() >= size_t{a.info.components} * vertices;
    arrays.values.push_back(whole ? a.values.data() : nullptr);  // a short array is left as it is
    arrays.stride.push_back(a.info.components);
  }
  refresh_tensors(infos, arrays, vertices);
}

void refresh_tensor_values(std::span<const AttributeInfo> infos, float* values, size_t vertices) {
  AttributeArrays arrays;
  size_t floats = 0;
  for (const AttributeInfo& info : infos) floats += info.components;
  size_t first = 0;
  for (const AttributeInfo& info : infos) {
    arrays.values.push_back(values + first);
    arrays.stride.push_back(floats);
    first += info.components;
  }
  if (floats > 0) refresh_tensors(infos, arrays, vertices);
}

void add_attribute_kind_json(nlohmann::json& entry, const AttributeInfo& info) {
  switch (info.kind) {
    case AttributeKind::kValue: entry["kind"] = "value"; break;
    case AttributeKind::kTensor:
      entry["kind"] = "tensor";
      entry["tensor"] = {{"symmetric", true}, {"order", kTensorComponentNames}, {"positive_semidefinite", info.positive_semidefinite}};
      break;
    case AttributeKind::kTensorDerived:
      entry["kind"] = "derived";
      entry["derived_from"] = info.derived_from;
      if (const int q = quantity_of(info); q >= 0) entry["quantity"] = kTensorQuantityNames[static_cast<size_t>(q)];
      break;
  }
}

void read_attribute_kind_json(const nlohmann::json& entry, AttributeKind& kind, bool& positive_semidefinite, std::string& derived_from) {
  kind = AttributeKind::kValue;
  positive_semidefinite = false;
  derived_from.clear();
  if (!entry.contains("kind")) return;
  const std::string name = entry.at("kind").get<std::string>();
  if (name == "tensor") {
    kind = AttributeKind::kTensor;
    if (entry.contains("tensor")) positive_semidefinite = entry.at("tensor").value("positive_semidefinite", false);
  } else if (name == "derived") {
    kind = AttributeKind::kTensorDerived;
    derived_from = entry.value("derived_from", std::string());
  }
}

std::string attribute_kind_text(const AttributeInfo& info) {
  if (info.kind == AttributeKind::kTensor) {
    return info.positive_semidefinite ? "tensor (xx yy zz xy yz xz, positive semi-definite)" : "tensor (xx yy zz xy yz xz)";
  }
  if (info.kind == AttributeKind::kTensorDerived) return "scalar from tensor '" + info.derived_from + "'";
  return info.components == 1 ? "scalar" : std::to_string(info.components) + "-vector";
}

}  // namespace tetrascope::storage
