// Simplified tensor fields: both simplifiers (quadric collapses and the sampler) interpolate the
// symmetric tensor components like any attribute, keep a positive semi-definite attribute
// positive semi-definite, leave an indefinite one indefinite, and recompute the derived scalars
// from the interpolated tensor.
#include <gtest/gtest.h>

#include <cmath>

#include "mesh_checks.h"
#include "tetrascope/lod/simplify/simplify.h"
#include "tetrascope/lod/vertex/vertex_front.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::testing {
namespace {

using storage::AttributeKind;
using storage::SymmetricTensor;

// R(θ) diag(l) R(θ)^T, R about z.
SymmetricTensor about_z(double theta, double l1, double l2, double l3) {
  const double c = std::cos(theta), s = std::sin(theta);
  return {l1 * c * c + l2 * s * s, l1 * s * s + l2 * c * c, l3, (l1 - l2) * c * s, 0, 0};
}

// A jittered box with a rank-two diffusion tensor whose major direction turns with x (its third
// eigenvalue is 0: any overshoot shows as a negative one) and an indefinite stress tensor.
storage::TetMesh tensor_box() {
  storage::TetMesh m = kuhn_box(8, 0.3, [](float x, float y, float z) { return x + y * z; });
  for (const char* name : {"diffusion", "stress"}) {
    storage::Attribute tensor{{name, 6, AttributeKind::kTensor, std::string(name) == "diffusion"}, {}};
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      const double x = m.x[v], y = m.y[v], z = m.z[v];
      const SymmetricTensor t = tensor.info.positive_semidefinite ? about_z(3 * x * x + y, 1 + z, 0.2, 0) : SymmetricTensor{std::sin(4 * x), -1 - y, z, 0.3, x * y, -0.2};
      float six[6];
      storage::store_tensor(t, six);
      tensor.values.insert(tensor.values.end(), six, six + 6);
    }
    m.attributes.push_back(tensor);
    for (const auto& info : storage::derived_attribute_infos(name)) m.attributes.push_back({info, std::vector<float>(m.vertex_count())});
  }
  storage::refresh_tensor_attributes(m);
  return m;
}

void expect_tensors_kept(const storage::TetMesh& mesh, const char* label) {
  SCOPED_TRACE(label);
  const storage::Attribute* diffusion = mesh.find_attribute("diffusion");
  const storage::Attribute* stress = mesh.find_attribute("stress");
  const storage::Attribute* fa = mesh.find_attribute("diffusion.fa");
  const storage::Attribute* lambda3 = mesh.find_attribute("stress.lambda3");
  ASSERT_TRUE(diffusion && stress && fa && lambda3);
  EXPECT_TRUE(diffusion->info.positive_semidefinite);
  double most_negative = 0;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const SymmetricTensor d = storage::tensor_from_symmetric(&diffusion->values[6 * v]);
    const auto l = storage::eigenvalues(d);
    EXPECT_GE(l[2], -storage::kPsdTolerance * l[0]) << "vertex " << v;
    EXPECT_NEAR(fa->values[v], storage::tensor_quantities(d)[size_t(storage::TensorQuantity::kFractionalAnisotropy)], 1e-6);
    most_negative = std::min(most_negative, double(lambda3->values[v]));
    EXPECT_NEAR(lambda3->values[v], storage::eigenvalues(storage::tensor_from_symmetric(&stress->values[6 * v]))[2], 1e-5);
  }
  EXPECT_LT(most_negative, -1) << "the stress tensor stays indefinite";
}

TEST(TensorSimplify, QuadricCollapsesKeepPositiveSemidefiniteTensorsAndDerivedScalars) {
  storage::TetMesh mesh = tensor_box();
  const size_t before = mesh.tet_count();
  lod::SimplifyOptions options;
  options.target_tets = before / 6;
  lod::simplify(mesh, options);
  EXPECT_LT(mesh.tet_count(), before / 3);
  expect_tensors_kept(mesh, "quadric");
}

TEST(TensorSimplify, SamplerKeepsPositiveSemidefiniteTensorsAndDerivedScalars) {
  storage::TetMesh mesh = tensor_box();
  const size_t before = mesh.tet_count();
  lod::SimplifyOptions options;
  options.target_tets = before / 5;
  options.border_error = 0.01;
  lod::simplify_sampled(mesh, options);
  EXPECT_LT(mesh.tet_count(), before / 2);
  expect_tensors_kept(mesh, "sample");
}

// The collapsed vertices of a vertex hierarchy carry interpolated tensors: every front the
// renderer and `cut` draw has them positive semi-definite and their derived scalars recomputed.
TEST(TensorSimplify, VertexFrontsKeepPositiveSemidefiniteTensorsAndDerivedScalars) {
  const storage::TetMesh mesh = tensor_box();
  const lod::VertexHierarchy h = lod::build_vertex_hierarchy(mesh, {.base_tets = 200});
  lod::VertexFront front(h);
  const storage::TetMesh base = front.mesh();
  EXPECT_LT(base.tet_count(), mesh.tet_count() / 3);
  expect_tensors_kept(base, "vertex front at the base");
}

}  // namespace
}  // namespace tetrascope::testing
