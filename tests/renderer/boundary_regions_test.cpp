// Boundary regions (renderer/boundary_regions.h): a box inside a box splits into its twelve
// faces by the sharp-edge rule, tags win over the rule, a coarsely tessellated cylinder keeps
// its side whole, small regions merge into a neighbour, the map carries regions to another
// scene of the same domain (a clip's cut faces in none), and a mesh's face tags from its file
// make one named region a tag.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

#include <gtest/gtest.h>

#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::renderer {
namespace {

using Triangle = std::array<uint32_t, 3>;

// A triangulated surface under construction: positions and triangles, with the face each
// triangle was made for.
struct Surface {
  std::vector<float> xyz;
  std::vector<Triangle> triangles;
  std::vector<uint32_t> face;  // per triangle
  uint32_t vertex(double x, double y, double z) {
    xyz.insert(xyz.end(), {float(x), float(y), float(z)});
    return static_cast<uint32_t>(xyz.size() / 3 - 1);
  }
};

// The six faces of the box [lo, hi]^3, each a 2x2 grid of quads (8 triangles), faces numbered
// from `first_face`. Corners are repeated per face and joined by a shared vertex table so the
// faces meet along shared edges.
void add_box(Surface& s, double lo, double hi, uint32_t first_face) {
  std::map<std::array<int, 3>, uint32_t> at;
  auto vertex = [&](std::array<int, 3> g) {  // g in 0..2 along each axis
    auto [it, fresh] = at.try_emplace(g, 0);
    if (fresh) it->second = s.vertex(lo + (hi - lo) * g[0] / 2, lo + (hi - lo) * g[1] / 2, lo + (hi - lo) * g[2] / 2);
    return it->second;
  };
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const uint32_t face = first_face + 2 * axis + side;
      const int u = (axis + 1) % 3, w = (axis + 2) % 3;
      for (int i = 0; i < 2; ++i)
        for (int j = 0; j < 2; ++j) {
          std::array<int, 3> c[4];
          for (int k = 0; k < 4; ++k) {
            c[k][axis] = 2 * side;
            c[k][u] = i + (k == 1 || k == 2);
            c[k][w] = j + (k >= 2);
          }
          s.triangles.push_back({vertex(c[0]), vertex(c[1]), vertex(c[2])});
          s.triangles.push_back({vertex(c[0]), vertex(c[2]), vertex(c[3])});
          s.face.insert(s.face.end(), {face, face});
        }
    }
}

TEST(BoundaryRegions, ABoxInsideABoxSplitsIntoItsTwelveFacesBySharpEdges) {
  Surface s;
  add_box(s, -10, 10, 0);  // the far field
  add_box(s, -1, 1, 6);    // the body
  const BoundaryRegions r = find_boundary_regions(s.xyz, s.triangles);
  ASSERT_EQ(r.regions.size(), 12u);
  ASSERT_EQ(r.triangle_region.size(), s.triangles.size());
  // one region per face: triangles of a face share it, triangles of two faces never do
  std::map<uint32_t, std::set<uint32_t>> regions_of_face, faces_of_region;
  for (size_t t = 0; t < s.triangles.size(); ++t) {
    regions_of_face[s.face[t]].insert(r.triangle_region[t]);
    faces_of_region[r.triangle_region[t]].insert(s.face[t]);
  }
  for (const auto& [face, regions] : regions_of_face) EXPECT_EQ(regions.size(), 1u) << "face " << face;
  for (const auto& [region, faces] : faces_of_region) EXPECT_EQ(faces.size(), 1u) << "region " << region;
  // numbered by area: the outer faces (400 each) first; the outer ones lie on the domain's box
  for (const BoundaryRegion& region : r.regions) {
    const bool outer = region.id < 6;
    EXPECT_EQ(region.triangles, 8u);
    EXPECT_NEAR(region.area, outer ? 400 : 4, 1e-3) << region.id;
    EXPECT_EQ(region.touches_domain_box, outer) << region.id;
    EXPECT_TRUE(region.name.empty());
    const double extent = outer ? 20 : 2;
    int flat = 0;
    for (int k = 0; k < 3; ++k) {
      const double size = region.bounds.max[k] - region.bounds.min[k];
      EXPECT_TRUE(std::abs(size) < 1e-6 || std::abs(size - extent) < 1e-6) << region.id;
      flat += std::abs(size) < 1e-6;
    }
    EXPECT_EQ(flat, 1) << "region " << region.id << " is one face";
  }
}

TEST(BoundaryRegions, TagsWinOverSharpEdges) {
  Surface s;
  add_box(s, -10, 10, 0);
  add_box(s, -1, 1, 6);
  std::vector<uint32_t> tags(s.triangles.size());
  for (size_t t = 0; t < tags.size(); ++t) tags[t] = s.face[t] < 6 ? 4 : (s.face[t] == 6 ? 9 : 7);  // the body's first face tagged apart
  const std::vector<std::string> names(10, "");
  std::vector<std::string> named = names;
  named[4] = "farfield";
  const BoundaryRegions r = find_boundary_regions(s.xyz, s.triangles, tags, named);
  ASSERT_EQ(r.regions.size(), 3u) << "one region per tag, across the box's sharp edges";
  EXPECT_EQ(r.regions[0].name, "farfield");
  EXPECT_EQ(r.regions[0].triangles, 48u);
  EXPECT_TRUE(r.regions[0].touches_domain_box);
  EXPECT_EQ(r.regions[1].name, "tag 7");
  EXPECT_EQ(r.regions[1].triangles, 40u);
  EXPECT_FALSE(r.regions[1].touches_domain_box);
  EXPECT_EQ(r.regions[2].name, "tag 9");
  EXPECT_EQ(r.regions[2].triangles, 8u) << "a small tagged region is kept";
  for (size_t t = 0; t < tags.size(); ++t) EXPECT_EQ(r.triangle_region[t], tags[t] == 4 ? 0u : tags[t] == 7 ? 1u : 2u);
}

// A cylinder of 12 facets (30 degrees from facet to facet, below the 40-degree feature angle)
// with flat caps: three regions, the side whole.
TEST(BoundaryRegions, ACoarselyTessellatedCylinderKeepsItsSideWhole) {
  Surface s;
  constexpr int kSides = 12;
  std::vector<uint32_t> ring[2];
  for (int level = 0; level < 2; ++level)
    for (int i = 0; i < kSides; ++i) {
      const double a = 2 * std::numbers::pi * i / kSides;
      ring[level].push_back(s.vertex(std::cos(a), std::sin(a), level * 3.0));
    }
  const uint32_t centre[2] = {s.vertex(0, 0, 0), s.vertex(0, 0, 3)};
  for (int i = 0; i < kSides; ++i) {
    const int j = (i + 1) % kSides;
    s.triangles.push_back({ring[0][i], ring[0][j], ring[1][j]});
    s.triangles.push_back({ring[0][i], ring[1][j], ring[1][i]});
    s.triangles.push_back({centre[0], ring[0][j], ring[0][i]});
    s.triangles.push_back({centre[1], ring[1][i], ring[1][j]});
    s.face.insert(s.face.end(), {0, 0, 1, 2});
  }
  const BoundaryRegions r = find_boundary_regions(s.xyz, s.triangles);
  ASSERT_EQ(r.regions.size(), 3u);
  EXPECT_EQ(r.regions[0].triangles, 24u) << "the side";
  for (size_t t = 0; t < s.triangles.size(); ++t)
    for (size_t u = 0; u < s.triangles.size(); ++u) EXPECT_EQ(r.triangle_region[t] == r.triangle_region[u], s.face[t] == s.face[u]);
  // with a feature angle below the facets' 30 degrees the side falls apart
  RegionOptions sharp;
  sharp.feature_angle_degrees = 20;
  sharp.min_region_triangles = 1;
  EXPECT_GT(find_boundary_regions(s.xyz, s.triangles, {}, {}, sharp).regions.size(), 3u);
}

TEST(BoundaryRegions, SmallRegionsMergeIntoANeighbourAndTheCountIsCapped) {
  Surface s;
  add_box(s, -10, 10, 0);
  RegionOptions options;
  options.min_region_triangles = 9;  // every face (8 triangles) is too small
  EXPECT_EQ(find_boundary_regions(s.xyz, s.triangles, {}, {}, options).regions.size(), 1u);
  options = {};
  options.max_regions = 4;
  const BoundaryRegions capped = find_boundary_regions(s.xyz, s.triangles, {}, {}, options);
  ASSERT_EQ(capped.regions.size(), 4u);
  uint64_t total = 0;
  for (const auto& region : capped.regions) total += region.triangles;
  EXPECT_EQ(total, s.triangles.size());
}

// Threat: a mesh of many loose pieces (tets that share no face) gives a component each; the
// list stays at kMaxRegions, every triangle in one of them, in one pass.
TEST(BoundaryRegions, ManyLoosePiecesAreCappedAtTheMostRegions) {
  Surface s;
  constexpr uint32_t kPieces = 20000;
  for (uint32_t i = 0; i < kPieces; ++i) {
    const double x = 3.0 * i;
    s.triangles.push_back({s.vertex(x, 0, 0), s.vertex(x + 1, 0, 0), s.vertex(x, 1, 0)});
  }
  const BoundaryRegions r = find_boundary_regions(s.xyz, s.triangles);
  ASSERT_EQ(r.regions.size(), kMaxRegions);
  uint64_t total = 0;
  for (const auto& region : r.regions) total += region.triangles;
  EXPECT_EQ(total, kPieces);
  for (uint32_t id : r.triangle_region) EXPECT_LT(id, kMaxRegions);
}

// The unit cube in 6 tets (Kuhn's split along the diagonal from (0,0,0) to (1,1,1)).
storage::TetMesh cube() {
  storage::TetMesh m;
  for (int i = 0; i < 8; ++i) {
    m.x.push_back(float(i & 1));
    m.y.push_back(float((i >> 1) & 1));
    m.z.push_back(float((i >> 2) & 1));
  }
  const uint32_t paths[6][2] = {{1, 3}, {1, 5}, {2, 3}, {2, 6}, {4, 5}, {4, 6}};
  for (const auto& p : paths) {
    std::array<uint32_t, 4> t{0, p[0], p[1], 7};
    if (storage::signed_volume(m, t[0], t[1], t[2], t[3]) < 0) std::swap(t[1], t[2]);
    m.tets.insert(m.tets.end(), t.begin(), t.end());
  }
  storage::Attribute f;
  f.info.name = "f";
  f.values.assign(8, 1.0f);
  m.attributes.push_back(f);
  return m;
}

TEST(BoundaryRegions, TheMapCarriesRegionsToAnotherSceneAndLeavesClipFacesOut) {
  const storage::TetMesh mesh = cube();
  RegionOptions options;
  options.min_region_triangles = 1;
  const auto map = RegionMap::from(mesh, {}, {}, options);
  ASSERT_EQ(map->regions().size(), 6u) << "the cube's six faces";
  for (const auto& region : map->regions()) EXPECT_TRUE(region.touches_domain_box);
  const SceneMesh scene = SceneMesh::from(mesh, "f");
  const std::vector<uint32_t> region = map->classify(scene);
  ASSERT_EQ(region.size(), scene.boundary.size());
  // the two triangles on each face of the cube share a region, and faces differ
  std::map<std::pair<int, int>, std::set<uint32_t>> by_face;
  for (size_t f = 0; f < scene.boundary.size(); ++f) {
    std::array<float, 3> sum{};
    for (uint32_t v : scene.boundary[f])
      for (int k = 0; k < 3; ++k) sum[k] += scene.xyz[3 * size_t{v} + k];
    int axis = 0, side = 0;
    for (int k = 0; k < 3; ++k)
      if (sum[k] == 0 || sum[k] == 3) axis = k, side = sum[k] == 3;
    by_face[{axis, side}].insert(region[f]);
  }
  ASSERT_EQ(by_face.size(), 6u);
  std::set<uint32_t> all;
  for (const auto& [face, regions] : by_face) {
    EXPECT_EQ(regions.size(), 1u);
    EXPECT_NE(*regions.begin(), kNoRegion);
    all.insert(*regions.begin());
  }
  EXPECT_EQ(all.size(), 6u);
  // clipped at x <= 0.5: the cut faces on the plane are in no region, the others keep theirs
  view::ClipSpec clip;
  clip.planes.push_back({{{1, 0, 0}, 0.5}, false});
  const SceneMesh clipped = clip_scene(scene, clip);
  const std::vector<uint32_t> clipped_region = map->classify(clipped, std::vector<std::array<double, 4>>{{1, 0, 0, 0.5}});
  size_t on_plane = 0;
  for (size_t f = 0; f < clipped.boundary.size(); ++f) {
    bool plane = true;
    for (uint32_t v : clipped.boundary[f]) plane = plane && std::abs(clipped.xyz[3 * size_t{v}] - 0.5f) < 1e-6f;
    on_plane += plane;
    EXPECT_EQ(clipped_region[f] == kNoRegion, plane) << "face " << f;
  }
  EXPECT_GT(on_plane, 0u);
  // hidden_faces marks the faces of the regions asked for
  SceneMesh marked = scene;
  marked.boundary_region = region;
  const std::vector<uint32_t> hide{region[0]};
  const std::vector<uint8_t> hidden = hidden_faces(marked, hide);
  ASSERT_EQ(hidden.size(), scene.boundary.size());
  EXPECT_EQ(std::count(hidden.begin(), hidden.end(), 1), 2);
  EXPECT_TRUE(hidden_faces(marked, {}).empty());
}

}  // namespace
}  // namespace tetrascope::renderer

namespace tetrascope::renderer {
namespace {

// A Gmsh mesh's physical surfaces (testing::tagged_cube): one region a tag that reaches the
// boundary, named as the file names it, and one "untagged" for the side without a physical
// surface; the inner plane's tag reaches no boundary triangle and makes no region. Tags that
// name no boundary triangle leave the regions to sharp edges.
TEST(BoundaryRegions, TheInputsFaceTagsMakeOneNamedRegionATag) {
  testing::TaggedCube cube = testing::tagged_cube();
  const auto path = testing::scratch_dir("regions-tagged") / "cube.msh";
  testing::write_gmsh(path, cube.mesh, cube.gmsh);
  const storage::TetMesh mesh = storage::load_mesh(path);
  const auto map = RegionMap::tagged(mesh, mesh.face_tags);
  EXPECT_EQ(map->source(), RegionSource::kInputTags);
  EXPECT_STREQ(region_source_name(map->source()), "input tags");
  std::map<std::string, uint64_t> triangles;
  for (const auto& r : map->regions()) triangles[r.name] = r.triangles;
  EXPECT_EQ(triangles, (std::map<std::string, uint64_t>{{"inlet", 8}, {"outlet", 8}, {"walls", 16}, {"physical 7", 8}, {kUntaggedRegionName, 8}}));
  EXPECT_EQ(map->regions()[0].name, "walls") << "numbered by decreasing area";

  storage::FaceTags inner;  // only the inner plane
  for (size_t t = 0; t < mesh.face_tags.triangles.size(); ++t)
    if (mesh.face_tags.names[mesh.face_tags.tags[t]] == "mid plane") inner.add(0, mesh.face_tags.triangles[t][0], mesh.face_tags.triangles[t][1], mesh.face_tags.triangles[t][2]);
  inner.names = {"mid plane"};
  ASSERT_EQ(inner.triangles.size(), 8u);
  const auto edges = RegionMap::tagged(mesh, inner);
  EXPECT_EQ(edges->source(), RegionSource::kSharpEdges);
  EXPECT_EQ(edges->regions().size(), 6u) << "the cube's six sides by sharp edges";
}

}  // namespace
}  // namespace tetrascope::renderer
