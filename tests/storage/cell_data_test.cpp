// Cell data (VTK CELL_DATA, VTU CellData, Gmsh $ElementData) arrives at the vertices as the
// volume-weighted mean over the volume cells around each vertex, identically in every format
// and encoding; surface cells do not count; names, counts and tags are checked.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

using storage::MeshFormat;
using storage::TetMesh;

// A 2×2×1 block of boxes of different heights (hexahedra, one of them a voxel-free hex of
// height 2), a pyramid and a wedge on top, a tet beside, and a surface triangle whose value
// (1000) must not reach any vertex. Cell volumes are known in closed form.
struct Fixture {
  CellMesh mesh;
  std::vector<double> volumes;  // per cell, 0 for the triangle
};

Fixture hybrid_block() {
  Fixture f;
  CellMesh& m = f.mesh;
  // grid points (i, j, k), i, j in 0..2, k in 0..1 at z = 0 and z = 1; index i + 3j + 9k
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        m.x.push_back(float(i));
        m.y.push_back(float(j) * 0.5f);
        m.z.push_back(float(k) * 2.0f);
      }
  auto at = [](int i, int j, int k) { return uint32_t(i + 3 * j + 9 * k); };
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      m.add_cell(12, {at(i, j, 0), at(i + 1, j, 0), at(i + 1, j + 1, 0), at(i, j + 1, 0), at(i, j, 1), at(i + 1, j, 1), at(i + 1, j + 1, 1), at(i, j + 1, 1)});
      f.volumes.push_back(1.0 * 0.5 * 2.0);
    }
  const uint32_t apex = static_cast<uint32_t>(m.x.size());  // over box (0, 0)
  m.x.push_back(0.5f), m.y.push_back(0.25f), m.z.push_back(3.5f);
  m.add_cell(14, {at(0, 0, 1), at(1, 0, 1), at(1, 1, 1), at(0, 1, 1), apex});
  f.volumes.push_back(0.5 * 1.5 / 3);
  const uint32_t ridge = static_cast<uint32_t>(m.x.size());  // a wedge over box (1, 1): its top edge raised by 1
  m.x.push_back(1), m.y.push_back(1.25f), m.z.push_back(3), m.x.push_back(2), m.y.push_back(1.25f), m.z.push_back(3);
  m.add_cell(13, {at(1, 1, 1), at(1, 2, 1), ridge, at(2, 1, 1), at(2, 2, 1), ridge + 1});
  f.volumes.push_back(0.5 * 0.5 * 1 * 1);
  const uint32_t tip = static_cast<uint32_t>(m.x.size());  // a tet on the side x = 2
  m.x.push_back(3), m.y.push_back(0), m.z.push_back(0);
  m.add_cell(10, {at(2, 0, 0), at(2, 1, 0), at(2, 0, 1), tip});
  f.volumes.push_back(1.0 / 6 * 0.5 * 2 * 1);
  m.add_cell(5, {at(0, 0, 0), at(1, 0, 0), at(0, 1, 0)});
  f.volumes.push_back(0);
  storage::Attribute pressure{{"pressure", 1}, {}}, velocity{{"velocity", 3}, {}};
  for (size_t c = 0; c < m.cell_count(); ++c) {
    const float v = f.volumes[c] > 0 ? 1.5f * float(c) + 1 : 1000;
    pressure.values.push_back(v);
    velocity.values.insert(velocity.values.end(), {v, -v, 2 * v});
  }
  m.cell_attributes = {pressure, velocity};
  storage::Attribute height{{"height", 1}, {}};
  for (float z : m.z) height.values.push_back(z);
  m.attributes = {height};
  return f;
}

// Σ V_c f_c / Σ V_c at each vertex, by the closed-form volumes.
std::vector<double> expected(const Fixture& f, const storage::Attribute& cell, uint32_t component) {
  const CellMesh& m = f.mesh;
  std::vector<double> sum(m.x.size(), 0), weight(m.x.size(), 0);
  for (size_t c = 0; c < m.cell_count(); ++c)
    for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) {
      sum[m.connectivity[k]] += f.volumes[c] * cell.values[c * cell.info.components + component];
      weight[m.connectivity[k]] += f.volumes[c];
    }
  for (size_t v = 0; v < sum.size(); ++v) sum[v] = weight[v] > 0 ? sum[v] / weight[v] : 0;
  return sum;
}

struct Variant {
  std::string name, file;
  std::function<void(const std::filesystem::path&, const CellMesh&)> write;
};
void PrintTo(const Variant& v, std::ostream* os) { *os << v.name; }

std::vector<Variant> variants() {
  return {
      {"vtk_ascii", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = false}); }},
      {"vtk_binary_double_field", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = true, .doubles = true, .field = true}); }},
      {"vtk51_binary", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = true, .version5 = true}); }},
      {"vtu_ascii", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAscii}); }},
      {"vtu_inline_base64", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kInlineBase64}); }},
      {"vtu_appended_raw_zlib", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true, .block_size = 64}); }},
      {"msh22_ascii", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = false, .binary = false}); }},
      {"msh22_binary", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = false, .binary = true}); }},
      {"msh41_ascii_sparse_tags", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = true, .binary = false, .first_tag = 100, .tag_step = 3}); }},
      {"msh41_binary", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = true, .binary = true}); }},
  };
}

class CellData : public ::testing::TestWithParam<Variant> {};

TEST_P(CellData, ArrivesAtTheVerticesAsTheVolumeWeightedMeanOfTheVolumeCells) {
  const Fixture f = hybrid_block();
  const auto dir = scratch_dir("cell_data_" + GetParam().name);
  const auto path = dir / GetParam().file;
  GetParam().write(path, f.mesh);
  storage::ReadStats stats;
  const TetMesh mesh = storage::load_mesh(path, &stats);
  ASSERT_EQ(mesh.vertex_count(), f.mesh.x.size());
  ASSERT_EQ(mesh.attributes.size(), 3u);
  EXPECT_EQ(mesh.attributes[0].info.name, "height");
  EXPECT_EQ(mesh.attributes[1].info.name, "pressure");
  EXPECT_EQ(mesh.attributes[2].info.name, "velocity");
  ASSERT_EQ(mesh.attributes[2].info.components, 3u);
  for (size_t v = 0; v < mesh.vertex_count(); ++v) EXPECT_EQ(mesh.attributes[0].values[v], f.mesh.z[v]) << v;
  for (uint32_t a = 0; a < 2; ++a) {
    const storage::Attribute& cell = f.mesh.cell_attributes[a];
    for (uint32_t k = 0; k < cell.info.components; ++k) {
      const std::vector<double> want = expected(f, cell, k);
      double largest = 0;
      for (size_t v = 0; v < want.size(); ++v) {
        const double got = mesh.attributes[1 + a].values[v * cell.info.components + k];
        EXPECT_NEAR(got, want[v], 1e-5 * std::max(1.0, std::fabs(want[v]))) << cell.info.name << "[" << k << "] at vertex " << v;
        largest = std::max(largest, std::fabs(got));
      }
      EXPECT_LT(largest, 100) << "the surface triangle's value reached a vertex";
    }
  }
  EXPECT_EQ(stats.skipped_cells, 1u);
}

INSTANTIATE_TEST_SUITE_P(Formats, CellData, ::testing::ValuesIn(variants()), [](const auto& test) { return test.param.name; });

TEST(CellDataNames, ACellArrayNamedLikeAPointArrayGetsTheSuffixCellsAndAWarning) {
  Fixture f = hybrid_block();
  f.mesh.cell_attributes.resize(1);
  f.mesh.cell_attributes[0].info.name = "height";
  const auto path = scratch_dir("cell_data_names") / "m.vtu";
  write_vtu(path, f.mesh, {.encoding = VtuEncoding::kAscii});
  auto stream = storage::MeshStream::open(path);
  ASSERT_EQ(stream->header().attributes.size(), 2u);
  EXPECT_EQ(stream->header().attributes[0].name, "height");
  EXPECT_EQ(stream->header().attributes[1].name, "height_cells");
  ASSERT_EQ(stream->header().cell_attributes.size(), 1u);
  EXPECT_EQ(stream->header().cell_attributes[0].name, "height");
  ASSERT_FALSE(stream->stats().warnings.empty());
  EXPECT_NE(stream->stats().warnings[0].find("height_cells"), std::string::npos);
}

TEST(CellDataNames, AVertexOnlyInFlatCellsTakesTheirPlainMeanAndOneInNoVolumeCellTakesZero) {
  CellMesh m;
  // one regular tet, one flat tet (all four corners in z = 0) sharing nothing with it, and an
  // unused vertex
  for (auto [x, y, z] : {std::array<float, 3>{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {5, 0, 0}, {6, 0, 0}, {5, 1, 0}, {6, 1, 0}, {9, 9, 9}}) {
    m.x.push_back(x), m.y.push_back(y), m.z.push_back(z);
  }
  m.add_cell(10, {0, 1, 2, 3});
  m.add_cell(10, {4, 5, 6, 7});
  m.add_cell(10, {4, 5, 7, 3});  // a volume cell: its vertices 4, 5, 7 are no longer flat-only
  storage::Attribute cell_q;
  cell_q.info.name = "q";
  cell_q.values = {2, 8, 20};
  m.cell_attributes.push_back(cell_q);
  const auto path = scratch_dir("cell_data_flat") / "m.vtk";
  write_vtk_legacy(path, m, {.binary = false});
  storage::ReadStats stats;
  const TetMesh mesh = storage::load_mesh(path, &stats);
  const auto& q = mesh.attributes.at(0).values;
  EXPECT_FLOAT_EQ(q[0], 2);
  EXPECT_FLOAT_EQ(q[6], 8) << "vertex 6 lies only in the flat tet";
  EXPECT_FLOAT_EQ(q[4], 20) << "the flat tet has no weight next to a volume";
  EXPECT_FLOAT_EQ(q[8], 0);
  bool warned = false;
  for (const std::string& w : stats.warnings) warned |= w.find("1 vertices in no volume cell") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(CellDataNames, FieldArraysEachFollowedByAMetadataBlockReadAsVtk9WritesThem) {
  const std::string text =
      "# vtk DataFile Version 5.1\nvtk output\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\n"
      "CELLS 2 4\nOFFSETS vtktypeint64\n0 4\nCONNECTIVITY vtktypeint64\n0 1 2 3\nCELL_TYPES 1\n10\n\n"
      "CELL_DATA 1\nFIELD FieldData 2\nCH4 1 1 float\n0.5 \nMETADATA\nINFORMATION 0\n\n"
      "Velocity 3 1 float\n1 2 3 \nMETADATA\nINFORMATION 2\nNAME L2_NORM_RANGE LOCATION vtkDataArray\nDATA 2 3.74166 3.74166 \n"
      "NAME L2_NORM_FINITE_RANGE LOCATION vtkDataArray\nDATA 2 3.74166 3.74166 \n\n"
      "POINT_DATA 4\nSCALARS T float 1\nLOOKUP_TABLE default\n1 2 3 4 \nMETADATA\nINFORMATION 0\n\n";
  const auto path = scratch_dir("cell_data_vtk9_field") / "m.vtk";
  write_file(path, text);
  const TetMesh mesh = storage::load_mesh(path);
  ASSERT_EQ(mesh.attributes.size(), 3u);
  EXPECT_EQ(mesh.attributes[0].info.name, "T");
  EXPECT_EQ(mesh.attributes[1].info.name, "CH4");
  EXPECT_EQ(mesh.attributes[2].info.name, "Velocity");
  for (size_t v = 0; v < 4; ++v) {
    EXPECT_FLOAT_EQ(mesh.attributes[1].values[v], 0.5f);
    EXPECT_FLOAT_EQ(mesh.attributes[2].values[3 * v + 2], 3.0f);
  }
}

TEST(HostileCellData, ACellDataCountOtherThanTheCellsIsRefusedNamingBoth) {
  Fixture f = hybrid_block();
  const auto path = scratch_dir("hostile_cell_count") / "m.vtk";
  write_vtk_legacy(path, f.mesh, {.binary = false});
  std::string text = read_file(path);
  const std::string count = "CELL_DATA " + std::to_string(f.mesh.cell_count());
  text.replace(text.find(count), count.size(), "CELL_DATA 3");
  write_file(path, text);
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("CELL_DATA has 3 values but CELLS has 8"), std::string::npos) << error;
}

TEST(HostileCellData, ElementDataGivingAnElementTwiceIsRefused) {
  Fixture f = hybrid_block();
  f.mesh.cell_attributes.resize(1);
  const auto path = scratch_dir("hostile_element_twice") / "m.msh";
  write_gmsh(path, f.mesh, {.version4 = false, .binary = false});
  std::string text = read_file(path);
  // the last element's entry (written first) names element 7 instead of 8
  const size_t at = text.find("$ElementData");
  const size_t entry = text.find("\n8 ", at);
  ASSERT_NE(entry, std::string::npos);
  text.replace(entry + 1, 1, "7");
  write_file(path, text);
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("gives element 7 twice"), std::string::npos) << error;
}

TEST(HostileCellData, TruncatedCellDataIsRefusedNamingTheArray) {
  Fixture f = hybrid_block();
  const auto path = scratch_dir("hostile_cell_truncated") / "m.vtu";
  write_vtu(path, f.mesh, {.encoding = VtuEncoding::kAscii});
  std::string text = read_file(path);
  const size_t at = text.find("Name=\"pressure\"");
  const size_t values = text.find('\n', at) + 1;
  text.erase(values, text.find("</DataArray>", values) - values);
  text.insert(values, "1 2 3");
  write_file(path, text);
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("pressure"), std::string::npos) << error;
}

}  // namespace
}  // namespace tetrascope::testing
