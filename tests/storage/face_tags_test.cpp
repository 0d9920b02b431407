// Boundary face tags: Gmsh physical surfaces (MSH 2.2 and 4.1, ASCII and binary, with
// $PhysicalNames) read as tagged triangles that are exactly boundary faces of the tets; the
// shared ONERA M6 file's wing, symmetry plane and far field; a store keeping them in
// boundary_tags.bin (the spilled build as the build in memory), checked by verify; a damaged
// file a clear error, never a crash. VTK legacy and VTU triangles and quads tagged by a
// region-id cell array: a tag per id, named "region ID", through `info` and into a store.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <map>

#include "cli_run.h"
#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/lod/mt/store_check.h"
#include "tetrascope/storage/boundary_tags.h"
#include "tetrascope/storage/mesh_info.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store_verify.h"

namespace tetrascope::testing {
namespace {

namespace fs = std::filesystem;
using Key = std::array<uint32_t, 3>;

Key sorted(Key t) {
  std::sort(t.begin(), t.end());
  return t;
}

// Per tag name: the tagged triangles, and how many of them are boundary faces of the tets.
struct TagCounts {
  std::map<std::string, size_t> triangles, on_boundary;
  size_t untagged_boundary = 0;
};

TagCounts count_tags(const storage::TetMesh& mesh) {
  TagCounts out;
  std::map<Key, uint32_t> tag_of;
  for (size_t t = 0; t < mesh.face_tags.triangles.size(); ++t) {
    ++out.triangles[mesh.face_tags.names[mesh.face_tags.tags[t]]];
    tag_of[sorted(mesh.face_tags.triangles[t])] = mesh.face_tags.tags[t];
  }
  for (const auto& face : boundary_faces(mesh.tets)) {
    const auto it = tag_of.find(sorted(face));
    if (it == tag_of.end()) ++out.untagged_boundary;
    else ++out.on_boundary[mesh.face_tags.names[it->second]];
  }
  return out;
}

fs::path write_cube(const std::string& name, bool version4, bool binary) {
  TaggedCube cube = tagged_cube();
  cube.gmsh.version4 = version4;
  cube.gmsh.binary = binary;
  const fs::path path = scratch_dir(name) / "cube.msh";
  write_gmsh(path, cube.mesh, cube.gmsh);
  return path;
}

class GmshFaceTags : public ::testing::TestWithParam<std::tuple<bool, bool>> {};

TEST_P(GmshFaceTags, PhysicalSurfacesArriveNamedAndCutAsTheHexahedraAre) {
  const auto [version4, binary] = GetParam();
  const fs::path path = write_cube(std::string("gmsh_tags_") + (version4 ? "41" : "22") + (binary ? "_bin" : "_ascii"), version4, binary);
  const storage::TetMesh mesh = storage::load_mesh(path);
  ASSERT_EQ(mesh.tet_count(), 48u);
  ASSERT_EQ(mesh.face_tags.names, (std::vector<std::string>{"inlet", "outlet", "walls", "physical 7", "mid plane"}));
  const TagCounts c = count_tags(mesh);
  EXPECT_EQ(c.triangles, (std::map<std::string, size_t>{{"inlet", 8}, {"outlet", 8}, {"walls", 16}, {"physical 7", 8}, {"mid plane", 8}}));
  // the quads' diagonals are the hexahedra's: every tagged boundary quad is two boundary faces
  EXPECT_EQ(c.on_boundary, (std::map<std::string, size_t>{{"inlet", 8}, {"outlet", 8}, {"walls", 16}, {"physical 7", 8}}));
  EXPECT_EQ(c.untagged_boundary, 8u) << "the y = 0 side has no physical surface";
}

INSTANTIATE_TEST_SUITE_P(Versions, GmshFaceTags, ::testing::Combine(::testing::Bool(), ::testing::Bool()));

TEST(GmshFaceTagsInfo, InfoListsEachTagWithItsNameAndTriangles) {
  const storage::MeshSummary s = storage::summarize_mesh(write_cube("gmsh_tags_info", false, false));
  const nlohmann::json j = storage::summary_json(s);
  EXPECT_EQ(j["regions_source"], "input tags");
  ASSERT_EQ(j["face_tags"].size(), 5u);
  EXPECT_EQ(j["face_tags"][2]["name"], "walls");
  EXPECT_EQ(j["face_tags"][2]["triangles"], 16);
  const std::string text = storage::summary_text(s);
  EXPECT_NE(text.find("regions     from the input's 5 face tags"), std::string::npos) << text;
  EXPECT_NE(text.find("mid plane"), std::string::npos) << text;
}

TEST(GmshFaceTagsInfo, AMeshWithoutPhysicalSurfacesHasNoTags) {
  TaggedCube cube = tagged_cube();
  cube.gmsh.version4 = true;
  cube.gmsh.physical.clear();
  cube.gmsh.surface_names.clear();
  const fs::path path = scratch_dir("gmsh_tags_none") / "cube.msh";
  write_gmsh(path, cube.mesh, cube.gmsh);
  EXPECT_TRUE(storage::load_mesh(path).face_tags.empty());
  EXPECT_EQ(storage::summary_json(storage::summarize_mesh(path))["regions_source"], "sharp edges");
}

TEST(GmshFaceTagsInfo, ThePhysicalNamesOfTheOneraM6FileNameItsBoundary) {
  if (shared_data().empty()) GTEST_SKIP() << "needs ../shared/data/formats/onera_m6_coarse.msh";
  const storage::TetMesh mesh = storage::load_mesh(shared_data() / "formats" / "onera_m6_coarse.msh");
  const TagCounts c = count_tags(mesh);
  ASSERT_EQ(c.on_boundary.size(), 3u);
  for (const char* name : {"wing", "symmetry", "farfield"}) {
    EXPECT_GT(c.on_boundary.count(name) ? c.on_boundary.at(name) : 0u, 0u) << name;
    EXPECT_EQ(c.on_boundary.at(name), c.triangles.at(name)) << name << ": every tagged triangle is a boundary face";
  }
  EXPECT_EQ(c.untagged_boundary, 0u);
}

// ---- VTK region-id arrays --------------------------------------------------------------------

// The cube [0,1]^3 as 2x2x2 cubes of six tets each (all about the cube's main diagonal, so
// every boundary quad is cut through its vertex of smallest id) with surface cells beside them:
// x = 0 four quads (region 1, before the tets), x = 1 eight triangles (region 2), y = 0, y = 1
// and z = 0 twelve quads (region 3); z = 1 has none. The tets carry region 7 in the array (not
// a tag). `array` names the region array ("" for none); `other` adds a first array of that
// name, all 4, before it.
CellMesh region_cube(const std::string& array, const std::string& other = "") {
  CellMesh m;
  auto node = [](int i, int j, int k) { return static_cast<uint32_t>(i + 3 * j + 9 * k); };
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        m.x.push_back(0.5f * float(i));
        m.y.push_back(0.5f * float(j));
        m.z.push_back(0.5f * float(k));
      }
  std::vector<float> region;
  auto plane = [&](int axis, int level, float id, bool triangles) {
    for (int u = 0; u < 2; ++u)
      for (int w = 0; w < 2; ++w) {
        uint32_t q[4];
        for (int c = 0; c < 4; ++c) {
          int at[3];
          at[axis] = level;
          at[(axis + 1) % 3] = u + (c == 1 || c == 2);
          at[(axis + 2) % 3] = w + (c >= 2);
          q[c] = node(at[0], at[1], at[2]);
        }
        if (!triangles) {
          m.add_cell(9, {q[0], q[1], q[2], q[3]});
          region.push_back(id);
          continue;
        }
        const int s = static_cast<int>(std::min_element(q, q + 4) - q);
        m.add_cell(5, {q[s], q[(s + 1) % 4], q[(s + 2) % 4]});
        m.add_cell(5, {q[s], q[(s + 2) % 4], q[(s + 3) % 4]});
        region.insert(region.end(), {id, id});
      }
  };
  plane(0, 0, 1, false);
  static const int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2}, {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i)
        for (const auto& order : kOrders) {
          int at[3] = {i, j, k};
          uint32_t tet[4];
          tet[0] = node(at[0], at[1], at[2]);
          for (int step = 0; step < 3; ++step) {
            ++at[order[step]];
            tet[step + 1] = node(at[0], at[1], at[2]);
          }
          m.add_cell(10, {tet[0], tet[1], tet[2], tet[3]});
          region.push_back(7);
        }
  plane(0, 2, 2, true);
  plane(1, 0, 3, false);
  plane(1, 2, 3, false);
  plane(2, 0, 3, false);
  if (!other.empty()) m.cell_attributes.push_back({{other, 1}, std::vector<float>(region.size(), 4.0f)});
  if (!array.empty()) m.cell_attributes.push_back({{array, 1}, region});
  return m;
}

const std::map<std::string, size_t> kRegionTriangles{{"region 1", 8}, {"region 2", 8}, {"region 3", 24}};

void expect_region_cube_tags(const storage::TetMesh& mesh) {
  ASSERT_EQ(mesh.tet_count(), 48u);
  EXPECT_EQ(mesh.face_tags.names, (std::vector<std::string>{"region 1", "region 2", "region 3"}));
  const TagCounts c = count_tags(mesh);
  EXPECT_EQ(c.triangles, kRegionTriangles);
  EXPECT_EQ(c.on_boundary, kRegionTriangles) << "every tagged triangle is a boundary face of the tets";
  EXPECT_EQ(c.untagged_boundary, 8u) << "z = 1 has no surface cells";
}

class VtkLegacyRegionTags : public ::testing::TestWithParam<std::tuple<bool, bool>> {};

TEST_P(VtkLegacyRegionTags, TrianglesAndQuadsTaggedByARegionArrayArriveAsRegions) {
  const auto [binary, version5] = GetParam();
  const fs::path path = scratch_dir(std::string("vtk_region_") + (binary ? "bin" : "ascii") + (version5 ? "_51" : "_30")) / "cube.vtk";
  write_vtk_legacy(path, region_cube("gmsh:physical"), {.binary = binary, .version5 = version5});
  expect_region_cube_tags(storage::load_mesh(path));
}

INSTANTIATE_TEST_SUITE_P(Encodings, VtkLegacyRegionTags, ::testing::Combine(::testing::Bool(), ::testing::Bool()));

TEST(VtkLegacyRegionTagsNames, ANameMatchesWhateverItsCaseAndTheFirstMatchingArrayWins) {
  const fs::path dir = scratch_dir("vtk_region_names");
  write_vtk_legacy(dir / "field.vtk", region_cube("regionID"), {.field = true});
  expect_region_cube_tags(storage::load_mesh(dir / "field.vtk"));
  write_vtk_legacy(dir / "first.vtk", region_cube("RegionId", "zone"));  // zone (all 4) comes first
  const storage::TetMesh mesh = storage::load_mesh(dir / "first.vtk");
  EXPECT_EQ(mesh.face_tags.names, (std::vector<std::string>{"region 4"}));
  EXPECT_EQ(mesh.face_tags.triangles.size(), 40u);
  write_vtk_legacy(dir / "other.vtk", region_cube("", "Pressure"));  // a cell array of no region name
  EXPECT_TRUE(storage::load_mesh(dir / "other.vtk").face_tags.empty());
  EXPECT_EQ(storage::summary_json(storage::summarize_mesh(dir / "other.vtk"))["regions_source"], "sharp edges");
}

class VtuRegionTags : public ::testing::TestWithParam<VtuEncoding> {};

TEST_P(VtuRegionTags, TrianglesAndQuadsTaggedByARegionArrayArriveAsRegions) {
  const fs::path path = scratch_dir("vtu_region_" + std::to_string(static_cast<int>(GetParam()))) / "cube.vtu";
  write_vtu(path, region_cube("CellEntityIds"), {.encoding = GetParam(), .zlib = GetParam() == VtuEncoding::kAppendedBase64});
  expect_region_cube_tags(storage::load_mesh(path));
}

INSTANTIATE_TEST_SUITE_P(Encodings, VtuRegionTags,
                         ::testing::Values(VtuEncoding::kAscii, VtuEncoding::kInlineBase64, VtuEncoding::kAppendedRaw, VtuEncoding::kAppendedBase64));

// An integer array (Int32) reads as the floats do; a float array with a fraction on a
// surface cell is refused, naming the array and the cell.
TEST(VtuRegionTagsTypes, AnIntegerArrayTagsAndAFractionalIdIsRefused) {
  const fs::path dir = scratch_dir("vtu_region_types");
  write_vtu(dir / "ints.vtu", region_cube("boundary_id"), {.encoding = VtuEncoding::kAscii});
  std::string text = read_file(dir / "ints.vtu");
  const std::string float_array = "type=\"Float32\" Name=\"boundary_id\"";
  ASSERT_NE(text.find(float_array), std::string::npos);
  text.replace(text.find(float_array), float_array.size(), "type=\"Int32\" Name=\"boundary_id\"");
  write_file(dir / "ints.vtu", text);
  expect_region_cube_tags(storage::load_mesh(dir / "ints.vtu"));
  CellMesh m = region_cube("BoundaryId");
  m.cell_attributes[0].values[2] = 1.5f;  // a quad of x = 0
  write_vtu(dir / "fraction.vtu", m);
  const std::string error = mesh_read_error(dir / "fraction.vtu");
  EXPECT_NE(error.find("cell array 'BoundaryId' (region ids): surface cell 2 has the value 1.5"), std::string::npos) << error;
}

TEST(VtkRegionTagsVolumeOnly, ARegionArrayOnVolumeCellsOnlyGivesNoTags) {
  CellMesh m = region_cube("region");
  CellMesh tets;
  tets.x = m.x, tets.y = m.y, tets.z = m.z;
  storage::Attribute region{{"region", 1}, {}};
  for (size_t c = 0; c < m.cell_count(); ++c) {
    if (m.types[c] != 10) continue;
    tets.add_cell(10, {m.connectivity[m.offsets[c]], m.connectivity[m.offsets[c] + 1], m.connectivity[m.offsets[c] + 2], m.connectivity[m.offsets[c] + 3]});
    region.values.push_back(float(c % 3));
  }
  tets.cell_attributes = {region};
  const fs::path dir = scratch_dir("vtk_region_volume_only");
  write_vtk_legacy(dir / "tets.vtk", tets);
  write_vtu(dir / "tets.vtu", tets);
  for (const char* name : {"tets.vtk", "tets.vtu"}) {
    const storage::TetMesh mesh = storage::load_mesh(dir / name);
    EXPECT_EQ(mesh.tet_count(), 48u) << name;
    EXPECT_TRUE(mesh.face_tags.empty()) << name;
    ASSERT_EQ(mesh.attributes.size(), 1u) << name << ": the array stays cell data";
    EXPECT_EQ(storage::summary_json(storage::summarize_mesh(dir / name))["regions_source"], "sharp edges") << name;
  }
}

// Hostile: a region array with fewer values than the file has cells is an error that names the
// array, in every encoding, never a read past its end.
TEST(HostileRegionTags, ARegionArrayShorterThanTheCellsIsAnErrorNamingIt) {
  const fs::path dir = scratch_dir("vtk_region_short");
  CellMesh m = region_cube("RegionId");
  m.cell_attributes[0].values.resize(m.cell_count() - 5);
  write_vtk_legacy(dir / "short_ascii.vtk", m, {.binary = false});
  write_vtk_legacy(dir / "short_bin.vtk", m, {.binary = true});
  write_vtu(dir / "short_ascii.vtu", m, {.encoding = VtuEncoding::kAscii});
  write_vtu(dir / "short_raw.vtu", m, {.encoding = VtuEncoding::kAppendedRaw});
  write_vtu(dir / "short_zlib.vtu", m, {.encoding = VtuEncoding::kInlineBase64, .zlib = true});
  for (const char* name : {"short_ascii.vtk", "short_bin.vtk", "short_ascii.vtu", "short_raw.vtu", "short_zlib.vtu"}) {
    const std::string error = mesh_read_error(dir / name);
    EXPECT_NE(error.find("'RegionId'"), std::string::npos) << name << ": " << error;
    EXPECT_NE(error.find(name), std::string::npos) << name << ": " << error;
  }
}

// End to end: `info --json` lists the regions with their source, and `preprocess` keeps them in
// the store's boundary_tags.bin.
TEST(VtkRegionTagsEndToEnd, InfoListsTheRegionsAndAStoreKeepsThem) {
  const fs::path dir = scratch_dir("vtk_region_cli");
  write_vtk_legacy(dir / "cube.vtk", region_cube("RegionId"));
  const CliResult info = run_cli("info --json " + (dir / "cube.vtk").string(), 120);
  ASSERT_EQ(info.status, 0) << info.out;
  const nlohmann::json j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["regions_source"], "input tags");
  ASSERT_EQ(j["face_tags"].size(), 3u);
  for (size_t t = 0; t < 3; ++t) {
    const std::string name = j["face_tags"][t]["name"];
    EXPECT_EQ(name, "region " + std::to_string(t + 1));
    EXPECT_EQ(j["face_tags"][t]["triangles"], kRegionTriangles.at(name));
  }
  const CliResult preprocess = run_cli("preprocess " + (dir / "cube.vtk").string() + " -o " + (dir / "store").string() + " --progress none", 300);
  ASSERT_EQ(preprocess.status, 0) << preprocess.out;
  const auto store = storage::Store::open(dir / "store");
  const std::optional<storage::FaceTags> tags = storage::open_boundary_tags(*store);
  ASSERT_TRUE(tags);
  EXPECT_EQ(tags->names, (std::vector<std::string>{"region 1", "region 2", "region 3"}));
  EXPECT_EQ(tags->triangles.size(), 40u);
  EXPECT_TRUE(storage::verify_store(dir / "store").ok);
}

// ---- boundary_tags.bin in a store --------------------------------------------------------------

fs::path tagged_store(const std::string& name) {
  const fs::path mesh = write_cube(name, true, false);
  lod::PreprocessOptions options;
  options.threads = 1;
  lod::preprocess(mesh, mesh.parent_path() / "store", options, nullptr);
  return mesh.parent_path() / "store";
}

TEST(BoundaryTagsFile, AStoreKeepsTheTagsOverItsGlobalIdsAndVerifyPassesIt) {
  const fs::path dir = tagged_store("tags_store");
  const auto store = storage::Store::open(dir);
  ASSERT_TRUE(store->manifest().json.contains("boundary_tags"));
  EXPECT_EQ(store->manifest().json["boundary_tags"]["triangles"], 48);
  const std::optional<storage::FaceTags> tags = storage::open_boundary_tags(*store);
  ASSERT_TRUE(tags);
  EXPECT_EQ(tags->names, (std::vector<std::string>{"inlet", "outlet", "walls", "physical 7", "mid plane"}));
  ASSERT_EQ(tags->triangles.size(), 48u);
  for (const Key& t : tags->triangles) EXPECT_TRUE(t[0] < t[1] && t[1] < t[2]) << "ids ascending";
  const storage::VerifyReport report = storage::verify_store(dir);
  EXPECT_TRUE(report.ok) << (report.problems.empty() ? "" : report.problems[0]);
  EXPECT_TRUE(lod::check_store(dir).empty());
}

// The streaming build (tets spilled to disk under a 1 MB budget) keeps the same tags as the
// build in memory, byte for byte.
TEST(BoundaryTagsFile, TheSpilledBuildKeepsTheSameTagsAsTheBuildInMemory) {
  if (shared_data().empty()) GTEST_SKIP() << "needs ../shared/data/formats/onera_m6_coarse.msh";
  const fs::path mesh = shared_data() / "formats" / "onera_m6_coarse.msh", dir = scratch_dir("tags_store_spilled");
  lod::PreprocessOptions options;
  options.threads = 1;
  const auto whole = lod::preprocess(mesh, dir / "whole", options, nullptr);
  options.memory_mb = 1;
  const auto spilled = lod::preprocess(mesh, dir / "spilled", options, nullptr);
  EXPECT_GT(spilled.spilled_bytes, 0u) << "the tets went through the spill file";
  EXPECT_EQ(whole.spilled_bytes, 0u);
  const std::string kept = read_file(dir / "whole" / storage::kBoundaryTagsFile);
  EXPECT_GT(kept.size(), 32u);
  EXPECT_EQ(read_file(dir / "spilled" / storage::kBoundaryTagsFile), kept);
  EXPECT_TRUE(storage::verify_store(dir / "spilled").ok);
}

TEST(BoundaryTagsFile, AStoreOfAnUntaggedMeshHasNoTagsFile) {
  const fs::path dir = scratch_dir("tags_store_none");
  lod::PreprocessOptions options;
  options.threads = 1;
  lod::preprocess(sample_mesh(), dir / "store", options, nullptr);
  const auto store = storage::Store::open(dir / "store");
  EXPECT_FALSE(storage::open_boundary_tags(*store));
  EXPECT_FALSE(fs::exists(dir / "store" / storage::kBoundaryTagsFile));
}

// Every way the file can be damaged is a BoundaryTagsError naming boundary_tags.bin (and a
// verify problem), never a crash or a silent misread: a flipped byte in the body or header, a
// truncation, a missing file, counts that differ from the manifest's.
TEST(BoundaryTagsFile, ADamagedTagsFileIsAClearErrorNeverACrash) {
  const fs::path dir = tagged_store("tags_store_damaged");
  const fs::path file = dir / storage::kBoundaryTagsFile;
  const std::string good = read_file(file);
  auto expect_damage = [&](const std::string& bytes, const std::string& says) {
    write_file(file, bytes);
    const auto store = storage::Store::open(dir);
    try {
      storage::open_boundary_tags(*store);
      ADD_FAILURE() << "accepted damage: " << says;
    } catch (const storage::BoundaryTagsError& e) {
      EXPECT_NE(std::string(e.what()).find("boundary_tags.bin: "), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(says), std::string::npos) << e.what();
    }
    const storage::VerifyReport report = storage::verify_store(dir);
    EXPECT_FALSE(report.ok) << says;
    ASSERT_FALSE(report.problems.empty());
    EXPECT_NE(report.problems[0].find("boundary_tags.bin"), std::string::npos) << report.problems[0];
  };
  std::string body = good;
  body[body.size() - 3] ^= 0x40;
  expect_damage(body, "the body fails its checksum");
  std::string head = good;
  head[13] ^= 0x01;
  expect_damage(head, "the header fails its checksum");
  expect_damage(good.substr(0, good.size() - 16), "the body fails its checksum");
  expect_damage(good.substr(0, 20), "not a boundary tags file");
  expect_damage("", "not a boundary tags file");
  fs::remove(file);
  const auto store = storage::Store::open(dir);
  EXPECT_THROW(storage::open_boundary_tags(*store), storage::BoundaryTagsError) << "listed in the manifest, missing on disk";
  write_file(file, good);
  EXPECT_TRUE(storage::verify_store(dir).ok) << "restored";
}

TEST(BoundaryTagsFile, TagsOutOfRangeAreRefusedByTheReaderOfTheFile) {
  const fs::path dir = scratch_dir("tags_file_range");
  storage::FaceTags tags;
  tags.names = {"wing"};
  tags.add(0, 5, 1, 9);
  storage::write_boundary_tags(dir / "t.bin", tags);
  EXPECT_EQ(storage::read_boundary_tags(dir / "t.bin", 10).triangles[0], (Key{1, 5, 9}));
  EXPECT_THROW(storage::read_boundary_tags(dir / "t.bin", 9), storage::BoundaryTagsError) << "vertex 9 of 9";
  tags.tags[0] = 3;
  storage::write_boundary_tags(dir / "t.bin", tags);
  try {
    storage::read_boundary_tags(dir / "t.bin", 10);
    ADD_FAILURE() << "a tag past the names was accepted";
  } catch (const storage::BoundaryTagsError& e) {
    EXPECT_NE(std::string(e.what()).find("has tag 3 of 1"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tetrascope::testing
