// Tensor attributes: the eigen-solver against known matrices (repeated, diagonal, zero,
// rotated), the derived scalars against closed forms, and every reader's tensors (VTK TENSORS
// and TENSORS6, VTU 9 and 6 components, Gmsh 9-component views) arriving as symmetric tensors
// with their derived scalars; hostile tensor arrays give a MeshError naming where, never a crash.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/tensor.h"
#include "tetrascope/storage/vtk_writer.h"

namespace tetrascope::testing {
namespace {

using storage::AttributeKind;
using storage::SymmetricTensor;
using storage::TensorQuantity;

double quantity(const SymmetricTensor& t, TensorQuantity q) { return storage::tensor_quantities(t)[static_cast<size_t>(q)]; }

// R diag(l) R^T for the rotation R about the unit axis `axis` by `angle`.
SymmetricTensor rotated(std::array<double, 3> l, std::array<double, 3> axis, double angle) {
  const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  const double x = axis[0] / n, y = axis[1] / n, z = axis[2] / n, c = std::cos(angle), s = std::sin(angle), C = 1 - c;
  const double r[3][3] = {{c + x * x * C, x * y * C - z * s, x * z * C + y * s},
                          {y * x * C + z * s, c + y * y * C, y * z * C - x * s},
                          {z * x * C - y * s, z * y * C + x * s, c + z * z * C}};
  double m[3][3] = {};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) m[i][j] += r[i][k] * l[k] * r[j][k];
  return {m[0][0], m[1][1], m[2][2], m[0][1], m[1][2], m[0][2]};
}

void expect_eigenvalues(const SymmetricTensor& t, std::array<double, 3> expected, double tolerance) {
  const auto l = storage::eigenvalues(t);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(l[i], expected[i], tolerance) << "eigenvalue " << i;
  const auto e = storage::eigensystem(t);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(e.values[i], expected[i], tolerance) << "Jacobi eigenvalue " << i;
}

TEST(TensorEigen, DiagonalZeroAndKnownMatrices) {
  expect_eigenvalues({3, -1, 2, 0, 0, 0}, {3, 2, -1}, 0);
  expect_eigenvalues({0, 0, 0, 0, 0, 0}, {0, 0, 0}, 0);
  expect_eigenvalues({2, 2, 3, 1, 0, 0}, {3, 3, 1}, 1e-12);  // [[2,1,0],[1,2,0],[0,0,3]]
  expect_eigenvalues({1, 1, 1, 1, 1, 1}, {3, 0, 0}, 1e-12);  // all ones: rank one
  expect_eigenvalues({5, 5, 5, 0, 0, 0}, {5, 5, 5}, 0);
}

TEST(TensorEigen, RepeatedAndNearlyRepeatedEigenvaluesUnderRotation) {
  std::mt19937 random(45);
  std::uniform_real_distribution<double> u(-1, 1);
  const std::array<std::array<double, 3>, 6> cases = {{{2, 2, 2}, {3, 1, 1}, {4, 4, -1}, {1 + 1e-9, 1, 1 - 1e-9}, {1e6, 1, 1e-6}, {-2, -2, -7}}};
  for (const auto& l : cases) {
    for (int trial = 0; trial < 20; ++trial) {
      const SymmetricTensor t = rotated(l, {u(random), u(random), u(random) + 0.01}, 3 * u(random));
      expect_eigenvalues(t, l, 1e-9 * std::max(1.0, std::fabs(l[0])));
      const auto e = storage::eigensystem(t);
      for (int i = 0; i < 3; ++i) {  // T v = λ v
        const auto& v = e.vectors[i];
        const double tv[3] = {t.xx * v[0] + t.xy * v[1] + t.xz * v[2], t.xy * v[0] + t.yy * v[1] + t.yz * v[2], t.xz * v[0] + t.yz * v[1] + t.zz * v[2]};
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(tv[k], e.values[i] * v[k], 1e-9 * std::max(1.0, std::fabs(l[0])));
      }
    }
  }
}

TEST(TensorEigen, NonFiniteTensorGivesNaNNotACrash) {
  const auto l = storage::eigenvalues({std::nan(""), 0, 0, 0, 0, 0});
  EXPECT_TRUE(std::isnan(l[0]));
  EXPECT_TRUE(std::isnan(quantity({0, 0, 0, INFINITY, 0, 0}, TensorQuantity::kVonMises)));
}

TEST(TensorQuantities, UniaxialStressVonMisesIsItsMagnitude) {
  for (double sigma : {250.0, -80.0}) {
    const SymmetricTensor t = rotated({sigma, 0, 0}, {1, 2, 3}, 0.7);
    EXPECT_NEAR(quantity(t, TensorQuantity::kVonMises), std::fabs(sigma), 1e-9 * 250);
    EXPECT_NEAR(quantity(t, TensorQuantity::kTrace), sigma, 1e-9 * 250);
    EXPECT_NEAR(quantity(t, TensorQuantity::kLinear), 1, 1e-12);
  }
  EXPECT_NEAR(quantity({0, 0, 0, 10, 0, 0}, TensorQuantity::kVonMises), std::sqrt(3.0) * 10, 1e-12);  // pure shear: √3 τ
  EXPECT_NEAR(quantity({-5, -5, -5, 0, 0, 0}, TensorQuantity::kVonMises), 0, 1e-12);              // hydrostatic
}

TEST(TensorQuantities, IsotropicLinearPlanarAndZeroTensors) {
  const SymmetricTensor isotropic = {2, 2, 2, 0, 0, 0};
  EXPECT_EQ(quantity(isotropic, TensorQuantity::kFractionalAnisotropy), 0);
  EXPECT_NEAR(quantity(isotropic, TensorQuantity::kSpherical), 1, 1e-15);
  EXPECT_NEAR(quantity(isotropic, TensorQuantity::kLinear), 0, 1e-15);
  EXPECT_NEAR(quantity(isotropic, TensorQuantity::kPlanar), 0, 1e-15);
  const SymmetricTensor linear = rotated({1, 0, 0}, {0, 1, 1}, 1.1);
  EXPECT_NEAR(quantity(linear, TensorQuantity::kFractionalAnisotropy), 1, 1e-12);
  EXPECT_NEAR(quantity(linear, TensorQuantity::kLinear), 1, 1e-12);
  const SymmetricTensor planar = rotated({1, 1, 0}, {1, 0, 1}, 0.4);
  EXPECT_NEAR(quantity(planar, TensorQuantity::kPlanar), 1, 1e-12);
  EXPECT_NEAR(quantity(planar, TensorQuantity::kFractionalAnisotropy), std::sqrt(0.5), 1e-12);
  const SymmetricTensor general = {3, 1, 0.5, 0, 0, 0};
  EXPECT_NEAR(quantity(general, TensorQuantity::kLinear), 2 / 4.5, 1e-12);
  EXPECT_NEAR(quantity(general, TensorQuantity::kPlanar), 1 / 4.5, 1e-12);
  EXPECT_NEAR(quantity(general, TensorQuantity::kSpherical), 1.5 / 4.5, 1e-12);
  const SymmetricTensor zero{};
  EXPECT_EQ(quantity(zero, TensorQuantity::kFractionalAnisotropy), 0);
  EXPECT_EQ(quantity(zero, TensorQuantity::kSpherical), 1);
}

TEST(TensorClamp, NegativeEigenvaluesBecomeZeroAndTheRestIsKept) {
  const SymmetricTensor t = rotated({3, 1, -0.5}, {1, -1, 2}, 0.9);
  const auto l = storage::eigenvalues(storage::clamp_positive_semidefinite(t));
  EXPECT_NEAR(l[0], 3, 1e-12);
  EXPECT_NEAR(l[1], 1, 1e-12);
  EXPECT_NEAR(l[2], 0, 1e-12);
  const SymmetricTensor psd = rotated({3, 1, 0.5}, {1, -1, 2}, 0.9);
  const SymmetricTensor same = storage::clamp_positive_semidefinite(psd);
  EXPECT_EQ(same.xy, psd.xy);
  EXPECT_EQ(same.zz, psd.zz);
}

// ---- readers ---------------------------------------------------------------------------

// The unit cube in 5 tets; "stress" (indefinite) and "diffusion" (positive definite) tensors of
// 9 or 6 components, linear in the position. The 9-component stress is not symmetric: its xy
// and yx entries differ by 0.2 x (so the largest asymmetry, 0.1, is at x = 1).
CellMesh tensor_cube(uint32_t components) {
  CellMesh m;
  for (int i = 0; i < 8; ++i) {
    m.x.push_back(float(i & 1));
    m.y.push_back(float((i >> 1) & 1));
    m.z.push_back(float((i >> 2) & 1));
  }
  for (auto t : {std::array<uint32_t, 4>{1, 2, 4, 7}, {0, 1, 2, 4}, {3, 1, 2, 7}, {5, 1, 4, 7}, {6, 2, 4, 7}}) m.add_cell(10, {t[0], t[1], t[2], t[3]});
  storage::Attribute stress{{"stress", components, AttributeKind::kTensor}, {}}, diffusion{{"diffusion", components, AttributeKind::kTensor}, {}};
  for (size_t v = 0; v < 8; ++v) {
    const float x = m.x[v], y = m.y[v], z = m.z[v];
    const SymmetricTensor s{100 * x, -50 * y, 20 + z, 10 * y, -5, 3 * z};
    const SymmetricTensor d{2, 1, 0.5f + y, 0.5f * x, 0, 0};
    for (const auto& [attribute, t] : {std::pair{&stress, s}, std::pair{&diffusion, d}}) {
      if (components == 6) {
        for (double c : {t.xx, t.yy, t.zz, t.xy, t.yz, t.xz}) attribute->values.push_back(float(c));
      } else {
        const double skew = attribute == &stress ? 0.1 * x : 0;
        for (double c : {t.xx, t.xy + skew, t.xz, t.xy - skew, t.yy, t.yz, t.xz, t.yz, t.zz}) attribute->values.push_back(float(c));
      }
    }
  }
  m.attributes = {stress, diffusion};
  return m;
}

void expect_tensor_mesh(const storage::TetMesh& mesh, const storage::ReadStats& stats, uint32_t components, const std::string& label) {
  SCOPED_TRACE(label);
  ASSERT_EQ(mesh.attributes.size(), 2 * (1 + storage::kTensorQuantityCount));
  const storage::Attribute* stress = mesh.find_attribute("stress");
  const storage::Attribute* diffusion = mesh.find_attribute("diffusion");
  ASSERT_TRUE(stress && diffusion);
  EXPECT_EQ(stress->info.kind, AttributeKind::kTensor);
  EXPECT_EQ(stress->info.components, 6u);
  EXPECT_FALSE(stress->info.positive_semidefinite);
  EXPECT_TRUE(diffusion->info.positive_semidefinite);
  const storage::Attribute* von_mises = mesh.find_attribute("stress.von_mises");
  const storage::Attribute* fa = mesh.find_attribute("diffusion.fa");
  ASSERT_TRUE(von_mises && fa);
  EXPECT_EQ(von_mises->info.kind, AttributeKind::kTensorDerived);
  EXPECT_EQ(von_mises->info.derived_from, "stress");
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const float x = mesh.x[v], y = mesh.y[v], z = mesh.z[v];
    const SymmetricTensor s{100 * x, -50 * y, 20 + z, 10 * y, -5, 3 * z};
    const float* got = &stress->values[6 * v];
    const double expected[6] = {s.xx, s.yy, s.zz, s.xy, s.yz, s.xz};
    for (int k = 0; k < 6; ++k) EXPECT_NEAR(got[k], expected[k], 1e-4) << "vertex " << v << " component " << k;
    EXPECT_NEAR(von_mises->values[v], quantity(s, TensorQuantity::kVonMises), 1e-3);
    EXPECT_NEAR(fa->values[v], quantity({2, 1, 0.5 + y, 0.5 * x, 0, 0}, TensorQuantity::kFractionalAnisotropy), 1e-5);
  }
  bool warned = false;
  for (const std::string& w : stats.warnings) warned |= w.find("tensor 'stress' is not symmetric") != std::string::npos && w.find("= 0.1") != std::string::npos;
  EXPECT_EQ(warned, components == 9) << ::testing::PrintToString(stats.warnings);
}

struct Writer {
  const char* label;
  const char* file;
  std::function<void(const std::filesystem::path&, const CellMesh&)> write;
};

TEST(TensorReaders, EveryReaderDeliversSymmetricTensorsAndDerivedScalars) {
  const auto dir = scratch_dir("tensor_readers");
  std::vector<Writer> writers = {
      {"vtk_ascii", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = false}); }},
      {"vtk_binary", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = true, .doubles = true}); }},
      {"vtu_ascii", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAscii}); }},
      {"vtu_zlib", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true}); }},
  };
  for (uint32_t components : {9u, 6u}) {
    for (const Writer& w : writers) {
      const auto path = dir / (std::to_string(components) + "_" + w.file);
      w.write(path, tensor_cube(components));
      storage::ReadStats stats;
      const storage::TetMesh mesh = storage::load_mesh(path, &stats);
      expect_tensor_mesh(mesh, stats, components, std::string(w.label) + " " + std::to_string(components));
    }
  }
  for (bool binary : {false, true}) {  // Gmsh views: 9 components only
    const auto path = dir / (binary ? "binary.msh" : "ascii.msh");
    write_gmsh(path, tensor_cube(9), {.version4 = binary, .binary = binary});
    storage::ReadStats stats;
    expect_tensor_mesh(storage::load_mesh(path, &stats), stats, 9, binary ? "msh41 binary" : "msh22 ascii");
  }
}

TEST(TensorReaders, CellDataTensorsAreAveragedThenExpanded) {
  const auto dir = scratch_dir("tensor_cells");
  CellMesh m = tensor_cube(6);
  storage::Attribute cell{{"cell_stress", 6, AttributeKind::kTensor}, {}};
  for (size_t c = 0; c < m.cell_count(); ++c)
    for (float v : {4.f, 4.f, 4.f, 0.f, 0.f, 0.f}) cell.values.push_back(v);
  m.cell_attributes = {cell};
  write_vtk_legacy(dir / "cells.vtk", m, {.binary = false});
  const storage::TetMesh mesh = storage::load_mesh(dir / "cells.vtk");
  const storage::Attribute* cs = mesh.find_attribute("cell_stress.cs");
  ASSERT_TRUE(cs);
  for (float v : cs->values) EXPECT_NEAR(v, 1, 1e-6);  // isotropic everywhere
  EXPECT_TRUE(mesh.find_attribute("cell_stress")->info.positive_semidefinite);
}

// ---- hostile tensor arrays --------------------------------------------------------------

std::string ascii_vtk_with_tensor(const std::string& keyword, const std::string& values) {
  std::string s = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
  s += "CELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\n";
  s += keyword;
  s += " stress float\n";
  s += values;
  return s;
}

TEST(TensorHostile, NonFiniteTensorValueInAsciiVtkNamesTheLineAndArray) {
  const auto dir = scratch_dir("tensor_hostile");
  std::string rows = "1 0 0 0 1 0 0 0 1\n1 0 0 0 1 0 0 0 1\n1 0 0 0 nan 0 0 0 1\n1 0 0 0 1 0 0 0 1\n";
  write_file(dir / "nan.vtk", ascii_vtk_with_tensor("TENSORS", rows));
  const std::string error = mesh_read_error(dir / "nan.vtk");
  EXPECT_NE(error.find("nan.vtk: line 18"), std::string::npos) << error;
  EXPECT_NE(error.find("tensor 'stress'"), std::string::npos) << error;
  write_file(dir / "huge.vtk", ascii_vtk_with_tensor("TENSORS6", "1 1 1 0 0 0\n1 1 1 0 0 1e39\n1 1 1 0 0 0\n1 1 1 0 0 0\n"));
  EXPECT_NE(mesh_read_error(dir / "huge.vtk").find("tensor 'stress'"), std::string::npos);
}

TEST(TensorHostile, TruncatedTensorArrayIsAnErrorNotACrash) {
  const auto dir = scratch_dir("tensor_hostile");
  write_file(dir / "short.vtk", ascii_vtk_with_tensor("TENSORS", "1 0 0 0 1 0 0 0 1\n1 0 0\n"));
  EXPECT_NE(mesh_read_error(dir / "short.vtk").find("short.vtk"), std::string::npos);
  CellMesh m = tensor_cube(9);
  write_vtk_legacy(dir / "cut.vtk", m, {.binary = true});
  std::string bytes = read_file(dir / "cut.vtk");
  write_file(dir / "cut.vtk", bytes.substr(0, bytes.size() - 40));
  EXPECT_NE(mesh_read_error(dir / "cut.vtk").find("cut.vtk"), std::string::npos);
}

TEST(TensorHostile, VtuTensorsArrayWithFiveOrEightComponentsNamesTheArray) {
  const auto dir = scratch_dir("tensor_hostile");
  for (int components : {5, 8}) {
    std::string values;
    for (int i = 0; i < 4 * components; ++i) values += "1 ";
    std::string s = R"(<?xml version="1.0"?><VTKFile type="UnstructuredGrid" version="1.0"><UnstructuredGrid><Piece NumberOfPoints="4" NumberOfCells="1">
<Points><DataArray type="Float32" NumberOfComponents="3" format="ascii">0 0 0 1 0 0 0 1 0 0 0 1</DataArray></Points>
<Cells><DataArray type="Int32" Name="connectivity" format="ascii">0 1 2 3</DataArray><DataArray type="Int32" Name="offsets" format="ascii">4</DataArray>
<DataArray type="UInt8" Name="types" format="ascii">10</DataArray></Cells>
<PointData Tensors="strain"><DataArray type="Float32" Name="strain" NumberOfComponents=")";
    s += std::to_string(components);
    s += "\" format=\"ascii\">";
    s += values;
    s += "</DataArray></PointData></Piece></UnstructuredGrid></VTKFile>\n";
    write_file(dir / "bad.vtu", s);
    const std::string error = mesh_read_error(dir / "bad.vtu");
    std::string expected = "'strain' is the Tensors array but has ";
    expected += std::to_string(components);
    EXPECT_NE(error.find(expected), std::string::npos) << error;
    EXPECT_NE(error.find("bad.vtu: line 5"), std::string::npos) << error;
  }
}

TEST(TensorHostile, GmshViewWithEightComponentsOrANonFiniteTensorNamesTheLine) {
  const auto dir = scratch_dir("tensor_hostile");
  std::string head = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n";
  head += "$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n";
  std::string eight = head + "$NodeData\n1\n\"strain\"\n1\n0.0\n3\n0\n8\n4\n";
  for (int n = 1; n <= 4; ++n) eight += std::to_string(n) + " 1 1 1 1 1 1 1 1\n";
  write_file(dir / "eight.msh", eight + "$EndNodeData\n");
  EXPECT_NE(mesh_read_error(dir / "eight.msh").find("'strain' has 8 components, expected 1 (scalar), 3 (vector) or 9 (tensor)"), std::string::npos)
      << mesh_read_error(dir / "eight.msh");
  std::string inf = head + "$NodeData\n1\n\"strain\"\n1\n0.0\n3\n0\n9\n4\n";
  for (int n = 1; n <= 4; ++n) inf += std::to_string(n) + (n == 3 ? " 1 0 0 0 1 0 0 0 1e39\n" : " 1 0 0 0 1 0 0 0 1\n");
  write_file(dir / "inf.msh", inf + "$EndNodeData\n");
  const std::string error = mesh_read_error(dir / "inf.msh");
  EXPECT_NE(error.find("inf.msh: line 26"), std::string::npos) << error;
  EXPECT_NE(error.find("tensor value"), std::string::npos) << error;
}

TEST(TensorHostile, DerivedNameTakenByAnotherArrayIsAWarningNotAClash) {
  const auto dir = scratch_dir("tensor_hostile");
  CellMesh m = tensor_cube(6);
  m.attributes.push_back({{"stress.trace", 1}, std::vector<float>(8, 7.f)});
  write_vtk_legacy(dir / "taken.vtk", m, {.binary = false});
  storage::ReadStats stats;
  const storage::TetMesh mesh = storage::load_mesh(dir / "taken.vtk", &stats);
  EXPECT_EQ(mesh.find_attribute("stress.trace")->values[0], 7.f);
  EXPECT_EQ(mesh.find_attribute("stress.von_mises"), nullptr);
  EXPECT_NE(mesh.find_attribute("diffusion.fa"), nullptr);
  bool warned = false;
  for (const std::string& w : stats.warnings) warned |= w.find("derived scalars are not added") != std::string::npos;
  EXPECT_TRUE(warned);
}

}  // namespace
}  // namespace tetrascope::testing

namespace tetrascope::testing {
namespace {

TEST(TensorRefresh, ClampsOnlyPositiveSemidefiniteAttributesAndRecomputesDerivedScalars) {
  storage::TetMesh mesh;
  mesh.x = {0, 1, 0, 0};
  mesh.y = {0, 0, 1, 0};
  mesh.z = {0, 0, 0, 1};
  mesh.tets = {0, 1, 2, 3};
  for (const char* name : {"diffusion", "stress"}) {
    storage::Attribute tensor{{name, 6, AttributeKind::kTensor, std::string(name) == "diffusion"}, {}};
    for (int v = 0; v < 4; ++v)
      for (float c : {2.f, 1.f, -0.5f, 0.f, 0.f, 0.f}) tensor.values.push_back(c);  // as an interpolation might overshoot
    mesh.attributes.push_back(tensor);
    for (const auto& info : storage::derived_attribute_infos(name)) mesh.attributes.push_back({info, std::vector<float>(4, -99.f)});
  }
  storage::refresh_tensor_attributes(mesh);
  EXPECT_EQ(mesh.find_attribute("diffusion")->values[2], 0.f) << "the negative eigenvalue is clamped";
  EXPECT_EQ(mesh.find_attribute("diffusion.lambda3")->values[0], 0.f);
  EXPECT_NEAR(mesh.find_attribute("diffusion.trace")->values[3], 3, 1e-6);
  EXPECT_EQ(mesh.find_attribute("stress")->values[2], -0.5f) << "an indefinite attribute is left as it is";
  EXPECT_EQ(mesh.find_attribute("stress.lambda3")->values[1], -0.5f);
  EXPECT_NEAR(mesh.find_attribute("stress.von_mises")->values[0], quantity({2, 1, -0.5, 0, 0, 0}, TensorQuantity::kVonMises), 1e-6);
}

}  // namespace
}  // namespace tetrascope::testing

namespace tetrascope::testing {
namespace {

TEST(TensorWriter, AMeshWrittenAsVtkReadsBackWithItsTensorsAndDerivedScalarsAndNoWarning) {
  const auto dir = scratch_dir("tensor_writer");
  write_vtk_legacy(dir / "in.vtk", tensor_cube(6), {.binary = false});
  const storage::TetMesh mesh = storage::load_mesh(dir / "in.vtk");
  storage::write_vtk(dir / "out.vtk", mesh);
  storage::ReadStats stats;
  const storage::TetMesh again = storage::load_mesh(dir / "out.vtk", &stats);
  ASSERT_EQ(again.attributes.size(), mesh.attributes.size());
  for (size_t a = 0; a < mesh.attributes.size(); ++a) {
    const storage::AttributeInfo& before = mesh.attributes[a].info;
    const storage::Attribute* after = again.find_attribute(before.name);
    ASSERT_TRUE(after) << before.name;
    EXPECT_EQ(after->info.kind, before.kind) << before.name;
    EXPECT_EQ(after->info.derived_from, before.derived_from) << before.name;
    EXPECT_EQ(after->info.positive_semidefinite, before.positive_semidefinite) << before.name;
    EXPECT_EQ(after->values, mesh.attributes[a].values) << before.name;
  }
  EXPECT_TRUE(stats.warnings.empty()) << ::testing::PrintToString(stats.warnings);
}

}  // namespace
}  // namespace tetrascope::testing
