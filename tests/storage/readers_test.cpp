// Every format and variant reads the same dataset to identical counts, coordinates,
// tetrahedra and attribute ranges; the original files in shared/data/formats read to the
// counts their provenance documents.
#include <gtest/gtest.h>

#include <functional>

#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/storage/mesh_info.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

using storage::TetMesh;

struct Variant {
  std::string name;
  std::string file;  // file name written into the scratch dir
  std::function<void(const std::filesystem::path&, const CellMesh&)> write;
  bool scalars_only = false;      // format keeps only scalar attributes
  bool first_scalar_only = false; // format keeps one scalar, named "scalar"
};

void PrintTo(const Variant& v, std::ostream* os) { *os << v.name; }

std::vector<Variant> variants() {
  std::vector<Variant> v;
  v.push_back({"vtk_binary", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = true}); }});
  v.push_back({"vtk_ascii", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = false}); }});
  v.push_back({"vtk_binary_double_field", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = true, .doubles = true, .field = true}); }});
  v.push_back({"vtk_ascii_field", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = false, .field = true}); }});
  v.push_back({"vtk51_binary", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = true, .version5 = true}); }});
  v.push_back({"vtk51_ascii", "m.vtk", [](auto& p, auto& m) { write_vtk_legacy(p, m, {.binary = false, .version5 = true}); }});
  v.push_back({"vtu_ascii", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAscii}); }});
  v.push_back({"vtu_inline_base64_u32", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kInlineBase64, .header_uint64 = false}); }});
  v.push_back({"vtu_inline_base64_separate", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kInlineBase64, .separate_header = true}); }});
  v.push_back({"vtu_inline_base64_zlib", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kInlineBase64, .zlib = true}); }});
  v.push_back({"vtu_appended_raw_u64", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedRaw}); }});
  v.push_back({"vtu_appended_raw_u32_double", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedRaw, .header_uint64 = false, .doubles = true}); }});
  v.push_back({"vtu_appended_raw_zlib_u32", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true, .header_uint64 = false}); }});
  v.push_back({"vtu_appended_raw_zlib_u64", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true}); }});
  v.push_back({"vtu_appended_base64", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedBase64}); }});
  v.push_back({"vtu_appended_base64_zlib", "m.vtu", [](auto& p, auto& m) { write_vtu(p, m, {.encoding = VtuEncoding::kAppendedBase64, .zlib = true}); }});
  v.push_back({"msh22_ascii", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = false, .binary = false}); }});
  v.push_back({"msh22_binary", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = false, .binary = true}); }});
  v.push_back({"msh41_ascii", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = true, .binary = false}); }});
  v.push_back({"msh41_binary", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = true, .binary = true}); }});
  v.push_back({"msh41_sparse_tags", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = true, .binary = false, .first_tag = 1000, .tag_step = 7}); }});
  v.push_back({"msh22_sparse_tags_binary", "m.msh", [](auto& p, auto& m) { write_gmsh(p, m, {.version4 = false, .binary = true, .first_tag = 5, .tag_step = 1000}); }});
  v.push_back({"tetgen", "m.node", [](auto& p, auto& m) { write_tetgen(p, m); }, true});
  v.push_back({"off", "m.off", [](auto& p, auto& m) { write_off(p, m); }, true, true});
  return v;
}

class FormatRoundTrip : public ::testing::TestWithParam<Variant> {
 protected:
  static void SetUpTestSuite() {
    reference_ = new TetMesh(storage::load_mesh(sample_mesh()));
    reference_summary_ = new storage::MeshSummary(storage::summarize_mesh(sample_mesh()));
  }
  static void TearDownTestSuite() {
    delete reference_;
    delete reference_summary_;
  }
  static TetMesh* reference_;
  static storage::MeshSummary* reference_summary_;
};
TetMesh* FormatRoundTrip::reference_ = nullptr;
storage::MeshSummary* FormatRoundTrip::reference_summary_ = nullptr;

TEST_P(FormatRoundTrip, ReadsSameMeshAsReference) {
  const Variant& variant = GetParam();
  const TetMesh& ref = *reference_;
  ASSERT_EQ(ref.vertex_count(), 8499u);
  ASSERT_EQ(ref.tet_count(), 44832u);
  std::filesystem::path dir = scratch_dir("roundtrip_" + variant.name);
  std::filesystem::path file = dir / variant.file;
  variant.write(file, from_tets(ref));

  storage::MeshSummary summary = storage::summarize_mesh(file);
  EXPECT_EQ(summary.header.vertex_count, ref.vertex_count());
  EXPECT_EQ(summary.stats.tetrahedra, ref.tet_count());
  EXPECT_EQ(summary.stats.degenerate, reference_summary_->stats.degenerate);
  EXPECT_EQ(summary.bounds.min, reference_summary_->bounds.min);
  EXPECT_EQ(summary.bounds.max, reference_summary_->bounds.max);

  // attribute ranges identical, for every attribute the format can carry
  size_t expected_attributes = 0;
  for (const storage::AttributeSummary& want : reference_summary_->attributes) {
    if (variant.scalars_only && want.info.components != 1) continue;
    if (variant.first_scalar_only && expected_attributes == 1) break;
    ++expected_attributes;
    std::string name = variant.first_scalar_only ? "scalar" : want.info.name;
    auto it = std::find_if(summary.attributes.begin(), summary.attributes.end(), [&](auto& a) { return a.info.name == name; });
    ASSERT_NE(it, summary.attributes.end()) << "attribute " << name << " missing";
    EXPECT_EQ(it->info.components, want.info.components) << name;
    EXPECT_EQ(it->min, want.min) << name;
    EXPECT_EQ(it->max, want.max) << name;
    EXPECT_EQ(it->component_ranges, want.component_ranges) << name;
  }
  EXPECT_EQ(summary.attributes.size(), expected_attributes);

  // the mesh itself: same coordinates and tets, in the same order
  TetMesh mesh = storage::load_mesh(file);
  EXPECT_EQ(mesh.x, ref.x);
  EXPECT_EQ(mesh.y, ref.y);
  EXPECT_EQ(mesh.z, ref.z);
  EXPECT_EQ(mesh.tets, ref.tets);
}

INSTANTIATE_TEST_SUITE_P(AllFormats, FormatRoundTrip, ::testing::ValuesIn(variants()),
                         [](const auto& test_info) { return test_info.param.name; });

// ---- the original files in shared/data -------------------------------------------------

class SharedData : public ::testing::Test {
 protected:
  void SetUp() override {
    data_ = shared_data();
    if (data_.empty()) GTEST_SKIP() << "../shared/data is not next to this checkout; original-format cases skipped";
  }
  std::filesystem::path data_;
};

const storage::AttributeSummary& attribute(const storage::MeshSummary& s, const std::string& name) {
  for (const auto& a : s.attributes) {
    if (a.info.name == name) return a;
  }
  throw std::runtime_error("no attribute " + name);
}

TEST_F(SharedData, EveryVtkDatasetReadsToDocumentedCounts) {
  struct Row { const char* file; uint64_t vertices, tets, degenerate; };
  const Row rows[] = {{"nasa_bluntfin.vtk", 40960, 187395, 77}, {"nasa_combustion_chamber.vtk", 47025, 215040, 0},
                      {"nasa_oxygen_post.vtk", 109744, 513375, 0}, {"disk_out_ref.vtk", 8499, 44832, 0},
                      {"fea_bracket.vtk", 16468, 56786, 0}, {"freefem_leman.vtk", 25715, 136838, 0},
                      {"onera_m6_potential.vtk", 82231, 450778, 0}};
  for (const Row& row : rows) {
    auto s = storage::summarize_mesh(data_ / row.file);
    EXPECT_EQ(s.header.vertex_count, row.vertices) << row.file;
    EXPECT_EQ(s.stats.tetrahedra, row.tets) << row.file;
    EXPECT_EQ(s.stats.degenerate, row.degenerate) << row.file;
    EXPECT_EQ(s.stats.inverted, 0u) << row.file << " (docs/formats.md says every tet is positively oriented)";
  }
  auto temp = attribute(storage::summarize_mesh(data_ / "disk_out_ref.vtk"), "Temp");
  EXPECT_NEAR(temp.min, 293.2, 0.1);
  EXPECT_NEAR(temp.max, 913.2, 0.1);
  auto velocity = attribute(storage::summarize_mesh(data_ / "nasa_combustion_chamber.vtk"), "Velocity");
  EXPECT_EQ(velocity.info.components, 3u);
  EXPECT_NEAR(velocity.max, 1529, 1);
}

TEST_F(SharedData, OffIsTheSameMeshAsTheVtk) {
  TetMesh off = storage::load_mesh(data_ / "formats/nasa_bluntfin.off");
  TetMesh vtk = storage::load_mesh(data_ / "nasa_bluntfin.vtk");
  ASSERT_EQ(off.vertex_count(), 40960u);
  ASSERT_EQ(off.tet_count(), 187395u);
  EXPECT_EQ(off.tets, vtk.tets);
  const auto* density = vtk.find_attribute("Density");
  const auto* scalar = off.find_attribute("scalar");
  ASSERT_TRUE(density && scalar);
  for (size_t i = 0; i < off.vertex_count(); i += 97) {
    EXPECT_NEAR(off.x[i], vtk.x[i], 1e-6 * (1 + std::fabs(vtk.x[i])));
    EXPECT_NEAR(scalar->values[i], density->values[i], 1e-6 * (1 + std::fabs(density->values[i])));
  }
}

TEST_F(SharedData, TetgenIsTheSameMeshAsTheVtk) {
  auto node = storage::summarize_mesh(data_ / "formats/disk_out_ref.node");
  auto vtk = storage::summarize_mesh(data_ / "disk_out_ref.vtk");
  EXPECT_EQ(node.header.vertex_count, 8499u);
  EXPECT_EQ(node.stats.tetrahedra, 44832u);
  for (const char* name : {"Temp", "Pres"}) {
    EXPECT_NEAR(attribute(node, name).min, attribute(vtk, name).min, 1e-6 * std::fabs(attribute(vtk, name).min) + 1e-12) << name;
    EXPECT_NEAR(attribute(node, name).max, attribute(vtk, name).max, 1e-6 * std::fabs(attribute(vtk, name).max)) << name;
  }
  // opening through the .ele name finds the pair too
  EXPECT_EQ(storage::summarize_mesh(data_ / "formats/disk_out_ref.ele").stats.tetrahedra, 44832u);
}

TEST_F(SharedData, FreeFemVtuWithBoundaryTrianglesAndCellLabels) {
  auto s = storage::summarize_mesh(data_ / "formats/freefem_leman_published.vtu");
  EXPECT_EQ(s.header.vertex_count, 3669u);
  EXPECT_EQ(s.stats.tetrahedra, 17164u);
  EXPECT_EQ(s.stats.skipped_cells, 2900u);
  // the int cell array Label arrives at the vertices; the tets all carry 0 (the boundary
  // triangles' labels do not count)
  ASSERT_EQ(s.header.cell_attributes.size(), 1u);
  EXPECT_EQ(s.header.cell_attributes[0].name, "Label");
  ASSERT_EQ(s.attributes.size(), 3u);
  EXPECT_EQ(s.attributes[2].info.name, "Label");
  EXPECT_EQ(s.attributes[2].min, 0);
  EXPECT_EQ(s.attributes[2].max, 0);
}

TEST_F(SharedData, GmshWithPhysicalGroupsAndTriangles) {
  auto s = storage::summarize_mesh(data_ / "formats/onera_m6_coarse.msh");
  EXPECT_EQ(s.header.vertex_count, 6213u);
  EXPECT_EQ(s.stats.tetrahedra, 30201u);
  EXPECT_EQ(s.stats.skipped_cells, 5288u);
  EXPECT_NEAR(s.bounds.max[1], 99.93, 0.01);
}

}  // namespace
}  // namespace tetrascope::testing
