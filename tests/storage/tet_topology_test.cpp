#include "tetrascope/core/tet_topology.h"

#include <gtest/gtest.h>

#include <atomic>
#include <set>

#include "tetrascope/core/parallel_for.h"

namespace tetrascope {
namespace {

TEST(TetTopology, TwoTetsShareOneFace) {
  // tets 0-1-2-3 and 1-2-3-4 share face {1,2,3}
  const std::vector<uint32_t> tets{0, 1, 2, 3, 4, 3, 2, 1};
  const FacePairing p = pair_faces(tets);
  ASSERT_EQ(p.opposite.size(), 8u);
  EXPECT_EQ(p.opposite[0], 4u);  // face 0 of tet 0 (opposite vertex 0) is {1,2,3}
  EXPECT_EQ(p.opposite[4], 0u);
  size_t unpaired = 0;
  for (uint32_t o : p.opposite) unpaired += o == kNoOppositeFace;
  EXPECT_EQ(unpaired, 6u);
  EXPECT_EQ(boundary_faces(tets).size(), 6u);
  EXPECT_EQ(p.non_manifold_faces, 0u);
}

TEST(TetTopology, FacesOfAPositiveTetPointOutward) {
  const double v[4][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};  // positive orientation
  const std::vector<uint32_t> tet{0, 1, 2, 3};
  for (int f = 0; f < 4; ++f) {
    const FaceVertices face = tet_face(tet, 0, f);
    double a[3], b[3], n[3];
    for (int k = 0; k < 3; ++k) a[k] = v[face[1]][k] - v[face[0]][k], b[k] = v[face[2]][k] - v[face[0]][k];
    n[0] = a[1] * b[2] - a[2] * b[1], n[1] = a[2] * b[0] - a[0] * b[2], n[2] = a[0] * b[1] - a[1] * b[0];
    double to_apex = 0;  // the vertex opposite the face lies behind it
    for (int k = 0; k < 3; ++k) to_apex += n[k] * (v[f][k] - v[face[0]][k]);
    EXPECT_LT(to_apex, 0) << "face " << f;
  }
}

TEST(TetTopology, AFaceOfThreeTetsIsNonManifold) {
  const std::vector<uint32_t> tets{0, 1, 2, 3, 4, 1, 2, 3, 5, 1, 2, 3};
  EXPECT_EQ(pair_faces(tets).non_manifold_faces, 1u);
}

TEST(TetTopology, ReusedScratchPairsAsAFreshOne) {
  // two meshes in a row through one scratch: the second must not see the first's ids
  const std::vector<uint32_t> first{10, 11, 12, 13, 14, 13, 12, 11, 14, 12, 13, 15};
  const std::vector<uint32_t> second{0, 1, 2, 3, 4, 3, 2, 1, 11, 12, 13, 14};
  FacePairingScratch scratch;
  std::vector<uint32_t> opposite;
  for (const auto* tets : {&first, &second, &first}) {
    EXPECT_EQ(pair_faces(*tets, scratch, opposite), 0u);
    EXPECT_EQ(opposite, pair_faces(*tets).opposite);
    for (size_t f = 0; f < opposite.size(); ++f)  // symmetric, and joins faces with one key
      if (opposite[f] != kNoOppositeFace) {
        EXPECT_EQ(opposite[opposite[f]], f);
        EXPECT_EQ(face_key(tet_face(*tets, f / 4, int(f % 4))), face_key(tet_face(*tets, opposite[f] / 4, int(opposite[f] % 4))));
      }
  }
}

TEST(TetTopology, OpenFacesGlueInPairsOnly) {
  // key {1,2,3} twice (glued), {4,5,6} once (boundary), {7,8,9} three times (left alone)
  std::vector<OpenFace> faces{{{7, 8, 9}, 2, 0}, {{1, 2, 3}, 1, 5}, {{4, 5, 6}, 0, 1}, {{7, 8, 9}, 0, 2}, {{1, 2, 3}, 0, 9}, {{7, 8, 9}, 1, 3}};
  std::vector<std::pair<uint32_t, uint32_t>> glued;
  pair_open_faces(faces, [&](const OpenFace& a, const OpenFace& b) { glued.push_back({a.segment, b.segment}); });
  ASSERT_EQ(glued.size(), 1u);
  EXPECT_EQ(glued[0], (std::pair<uint32_t, uint32_t>{0, 1}));  // ordered by segment within a key
}

TEST(ParallelFor, EveryItemOnceAndErrorsRethrown) {
  std::vector<std::atomic<int>> seen(1000);
  parallel_for(seen.size(), 3, [&](size_t i, unsigned) { seen[i]++; });
  for (auto& s : seen) EXPECT_EQ(s.load(), 1);
  EXPECT_THROW(parallel_for(100, 2, [](size_t i, unsigned) { if (i == 57) throw std::runtime_error("x"); }),
               std::runtime_error);
}

}  // namespace
}  // namespace tetrascope
