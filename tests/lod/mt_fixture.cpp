#include "mt_fixture.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>

#include "mesh_checks.h"
#include "test_paths.h"

namespace tetrascope::testing {

const Built& built(const std::string& name, uint32_t variants) {
  static std::map<std::string, Built> cache;
  const std::string key = name + (variants ? "-variants" + std::to_string(variants) : "");
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const std::filesystem::path mesh = name == "sample" ? sample_mesh() : shared_data() / name;
  Built b;
  b.store = run_scratch_dir("multires-" + std::filesystem::path(name).stem().string() + (variants ? "-variants" + std::to_string(variants) : "")) / "store";
  lod::PreprocessOptions options;
  options.segment_tets = 2000;
  options.base_tets = 3000;
  options.variants = variants;
  options.replace = true;
  b.report = lod::preprocess(mesh, b.store, options);
  return cache[key] = b;
}

const Built& built_binary(const std::string& name, double dependency_ratio) {
  static std::map<std::string, Built> cache;
  const std::string key = name + "-binary" + std::to_string(dependency_ratio);
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  const std::filesystem::path mesh = name == "sample" ? sample_mesh() : shared_data() / name;
  Built b;
  b.store = run_scratch_dir("binary-" + std::filesystem::path(name).stem().string() + (dependency_ratio < 0 ? "-nodeps" : "-r" + std::to_string(int(dependency_ratio * 100)))) / "store";
  lod::PreprocessOptions options;
  options.model = lod::MultiresModel::kBinary;
  options.dependency_ratio = dependency_ratio;
  options.segment_tets = 2000;
  options.base_tets = 3000;
  options.replace = true;
  b.report = lod::preprocess(mesh, b.store, options);
  return cache[key] = b;
}

std::multiset<Tet> tets_by_global_id(const lod::CutMesh& m) {
  std::multiset<Tet> out;
  for (size_t t = 0; t < m.mesh.tet_count(); ++t) {
    Tet tet;
    for (int k = 0; k < 4; ++k) tet[k] = m.global_ids[m.mesh.tets[4 * t + k]];
    std::sort(tet.begin(), tet.end());
    out.insert(tet);
  }
  return out;
}

size_t expect_conforming(const storage::TetMesh& mesh, const std::string& what) {
  const MeshCheck c = check_mesh(mesh);
  EXPECT_EQ(c.faces_shared_by_more_than_two, 0u) << what;
  size_t inverted = 0;
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    const uint32_t* v = &mesh.tets[4 * t];
    inverted += storage::signed_volume(mesh, v[0], v[1], v[2], v[3]) < 0;
  }
  EXPECT_EQ(inverted, 0u) << what;
  // boundary triangles, outward (face f of a positive tet, vertices in kTetFace order)
  const int kFace[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
  std::map<std::array<uint32_t, 2>, int> edge_uses;
  double enclosed = 0;
  size_t boundary_faces = 0;
  for (size_t t = 0; t < mesh.tet_count(); ++t)
    for (int f = 0; f < 4; ++f) {
      std::array<uint32_t, 3> tri{mesh.tets[4 * t + kFace[f][0]], mesh.tets[4 * t + kFace[f][1]], mesh.tets[4 * t + kFace[f][2]]}, key = tri;
      std::sort(key.begin(), key.end());
      if (c.face_uses.at(key) != 1) continue;
      ++boundary_faces;
      double p[3][3];
      for (int i = 0; i < 3; ++i) {
        p[i][0] = mesh.x[tri[i]];
        p[i][1] = mesh.y[tri[i]];
        p[i][2] = mesh.z[tri[i]];
      }
      enclosed += (p[0][0] * (p[1][1] * p[2][2] - p[1][2] * p[2][1]) - p[0][1] * (p[1][0] * p[2][2] - p[1][2] * p[2][0]) +
                   p[0][2] * (p[1][0] * p[2][1] - p[1][1] * p[2][0])) / 6;
      for (int i = 0; i < 3; ++i) ++edge_uses[{std::min(key[i], key[(i + 1) % 3]), std::max(key[i], key[(i + 1) % 3])}];
    }
  EXPECT_GT(boundary_faces, 0u) << what;
  size_t open_edges = 0;
  for (const auto& [edge, uses] : edge_uses) open_edges += uses != 2;
  EXPECT_EQ(open_edges, 0u) << what << ": the boundary is not a closed surface";
  EXPECT_NEAR(c.volume, enclosed, 1e-6 * std::fabs(enclosed)) << what << ": tets overlap or leave gaps";
  return boundary_faces;
}

void expect_conforming(const lod::CutMesh& m, const std::string& what) {
  const size_t boundary_faces = expect_conforming(m.mesh, what);
  // the cut's own adjacency agrees
  size_t unpaired = 0;
  for (uint32_t o : m.opposites) unpaired += o == storage::store::kMeshBoundary;
  EXPECT_EQ(unpaired, boundary_faces) << what << ": cross-patch adjacency misses faces";
}

}  // namespace tetrascope::testing
