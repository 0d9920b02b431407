// The streaming interface delivers vertices first, then tets, in chunks of the asked size,
// and the concatenation equals the whole-mesh loader's result.
#include <gtest/gtest.h>

#include "test_paths.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

TEST(MeshStream, ChunksConcatenateToTheWholeMesh) {
  storage::TetMesh whole = storage::load_mesh(sample_mesh());
  auto stream = storage::MeshStream::open(sample_mesh());
  EXPECT_EQ(stream->header().vertex_count, 8499u);
  EXPECT_EQ(stream->header().attributes.size(), 7u);
  std::vector<float> x, temperature;
  size_t temp_index = 0;
  for (size_t a = 0; a < stream->header().attributes.size(); ++a) {
    if (stream->header().attributes[a].name == "Temp") temp_index = a;
  }
  storage::VertexChunk v;
  size_t chunks = 0;
  while (stream->next_vertices(v, 1000)) {
    EXPECT_LE(v.count, 1000u);
    EXPECT_EQ(v.first, x.size());
    x.insert(x.end(), v.x.begin(), v.x.end());
    temperature.insert(temperature.end(), v.attributes[temp_index].begin(), v.attributes[temp_index].end());
    ++chunks;
  }
  EXPECT_EQ(chunks, 9u);
  EXPECT_EQ(x, whole.x);
  EXPECT_EQ(temperature, whole.find_attribute("Temp")->values);
  std::vector<uint32_t> tets;
  storage::TetChunk t;
  while (stream->next_tets(t, 5000)) {
    EXPECT_LE(t.count, 5000u);
    EXPECT_EQ(t.first * 4, tets.size());
    tets.insert(tets.end(), t.tets.begin(), t.tets.end());
  }
  EXPECT_EQ(tets, whole.tets);
  EXPECT_EQ(stream->stats().tetrahedra, whole.tet_count());
}

TEST(MeshStream, TetsBeforeVerticesStillOrients) {
  auto stream = storage::MeshStream::open(sample_mesh());
  storage::TetChunk t;
  size_t total = 0;
  while (stream->next_tets(t)) total += t.count;
  EXPECT_EQ(total, 44832u);
  EXPECT_EQ(stream->xyz().size(), 3u * 8499u);
}

TEST(MeshStream, InvertedTetsAreReorientedAndCounted) {
  std::string vtk =
      "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 6 float\n"
      "0 0 0 1 0 0 0 1 0 0 0 1 1 1 1 1 1 0\nCELLS 4 20\n4 0 1 2 3\n4 0 2 1 3\n4 0 1 2 5\n4 0 1 2 0\nCELL_TYPES 4\n10 10 10 10\n";
  auto stream = storage::MeshStream::open_memory(storage::MeshFormat::kVtkLegacy, "o.vtk", vtk);
  storage::TetMesh mesh = storage::load_stream(*stream);
  ASSERT_EQ(mesh.tet_count(), 3u);  // the flat tet is kept; the one that repeats vertex 0 is dropped
  EXPECT_GT(storage::signed_volume(mesh, mesh.tets[0], mesh.tets[1], mesh.tets[2], mesh.tets[3]), 0);
  EXPECT_GT(storage::signed_volume(mesh, mesh.tets[4], mesh.tets[5], mesh.tets[6], mesh.tets[7]), 0);
  EXPECT_EQ(stream->stats().inverted, 1u);
  EXPECT_EQ(stream->stats().degenerate, 1u);
  EXPECT_EQ(stream->stats().repeated_vertex, 1u);
}

}  // namespace
}  // namespace tetrascope::testing
