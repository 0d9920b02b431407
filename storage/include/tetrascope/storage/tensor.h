// Symmetric 3x3 tensors at the vertices: eigen-analysis, the derived scalars a user colours by,
// and keeping a simplified mesh's tensors consistent (positive semi-definite where the input
// was, derived scalars recomputed from the interpolated tensor).
//
// Stored order of a symmetric tensor's 6 components is VTK's: xx yy zz xy yz xz.
#pragma once

#include <array>
#include <span>
#include <string>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::storage {

struct SymmetricTensor {
  double xx = 0, yy = 0, zz = 0, xy = 0, yz = 0, xz = 0;
};

constexpr std::array<const char*, 6> kTensorComponentNames = {"xx", "yy", "zz", "xy", "yz", "xz"};

// The scalars derived from every tensor attribute, in this order, each stored as the attribute
// "NAME.QUANTITY" (e.g. "stress.von_mises").
enum class TensorQuantity { kLambda1, kLambda2, kLambda3, kTrace, kVonMises, kFractionalAnisotropy, kLinear, kPlanar, kSpherical };
constexpr size_t kTensorQuantityCount = 9;
constexpr std::array<const char*, kTensorQuantityCount> kTensorQuantityNames = {
    "lambda1", "lambda2", "lambda3", "trace", "von_mises", "fa", "cl", "cp", "cs"};

// A tensor whose smallest eigenvalue is at least -kPsdTolerance times its largest eigenvalue
// magnitude counts as positive semi-definite (float storage rounds zero eigenvalues both ways).
constexpr double kPsdTolerance = 1e-5;

// From 6 stored components (xx yy zz xy yz xz).
SymmetricTensor tensor_from_symmetric(const float* six);
// From a row-major 3x3: the symmetric part (A + A^T) / 2; `asymmetry` gets max |A_ij - A_ji| / 2.
SymmetricTensor tensor_from_full(const float* nine, double& asymmetry);
void store_tensor(const SymmetricTensor& t, float* six);
// The tensor at barycentric `weights` in the tet of `corners`, from 6 stored components a
// vertex in `six_per_vertex` (linear interpolation, componentwise).
SymmetricTensor interpolate_tensor(const float* six_per_vertex, const uint32_t corners[4], const double weights[4]);

// Eigenvalues, λ1 >= λ2 >= λ3: closed form (the trigonometric solution of the characteristic
// cubic, Smith 1961), exact for diagonal tensors; where two eigenvalues nearly coincide (the
// closed form loses half its digits there) from Jacobi rotations. NaN for a non-finite tensor.
std::array<double, 3> eigenvalues(const SymmetricTensor& t);

// Eigenvalues (descending) and unit eigenvectors (vectors[i] belongs to values[i]) by cyclic
// Jacobi rotations: slower than `eigenvalues`, robust for any symmetric tensor.
struct Eigensystem {
  std::array<double, 3> values{};
  std::array<std::array<double, 3>, 3> vectors{};
};
Eigensystem eigensystem(const SymmetricTensor& t);

// The tensor with negative eigenvalues set to 0 (the nearest positive semi-definite tensor in
// the Frobenius norm); returned unchanged when it has none.
SymmetricTensor clamp_positive_semidefinite(const SymmetricTensor& t);

// Every derived quantity, in TensorQuantity order. Von Mises: sqrt(((σxx-σyy)² + (σyy-σzz)² +
// (σzz-σxx)² + 6(σxy² + σyz² + σxz²)) / 2). FA: sqrt(3/2) |λ - mean λ| / |λ| (0 for the zero
// tensor). cl, cp, cs: Westin et al. 1997, (λ1-λ2)/Σ, 2(λ2-λ3)/Σ, 3λ3/Σ, computed on the
// eigenvalues' magnitudes sorted again (equal to the usual definition for positive semi-definite
// tensors, and defined for indefinite stress tensors); the zero tensor has cs = 1.
std::array<double, kTensorQuantityCount> tensor_quantities(const SymmetricTensor& t);

// The derived attributes' infos for the tensor attribute `tensor_name`.
std::array<AttributeInfo, kTensorQuantityCount> derived_attribute_infos(const std::string& tensor_name);

// For a mesh whose tensor attributes were interpolated (simplification, resampling): clamps the
// positive semi-definite ones and recomputes every derived attribute from its tensor. Attributes
// of other kinds are untouched; a derived attribute whose tensor is missing is left as it is.
void refresh_tensor_attributes(TetMesh& mesh);
// The same for `vertices` vertices whose attributes lie interleaved in `values`, vertex-major,
// each vertex's attributes in the order of `infos` (a vertex hierarchy's values).
void refresh_tensor_values(std::span<const AttributeInfo> infos, float* values, size_t vertices);

// Keys added to an attribute's JSON (store manifest, `info --json`): "kind" ("value", "tensor"
// or "derived"); tensors add "tensor": {"symmetric", "order", "positive_semidefinite"}, derived
// scalars "derived_from" and "quantity".
void add_attribute_kind_json(nlohmann::json& entry, const AttributeInfo& info);
// The reverse, for a manifest entry (absent keys: a plain value); throws nlohmann's errors on
// keys of the wrong type.
void read_attribute_kind_json(const nlohmann::json& entry, AttributeKind& kind, bool& positive_semidefinite, std::string& derived_from);
// "tensor (xx yy zz xy yz xz, positive semi-definite)", "from tensor 'stress'", "scalar", "3-vector".
std::string attribute_kind_text(const AttributeInfo& info);

}  // namespace tetrascope::storage
