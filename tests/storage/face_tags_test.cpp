// Boundary face tags: Gmsh physical surfaces (MSH 2.2 and 4.1, ASCII and binary, with
// $PhysicalNames) read as tagged triangles that are exactly boundary faces of the tets; the
// shared ONERA M6 file's wing, symmetry plane and far field; a store keeping them in
// boundary_tags.bin (the spilled build as the build in memory), checked by verify; a damaged
// file a clear error, never a crash.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <fstream>
#include <map>

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
