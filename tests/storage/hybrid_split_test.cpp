// Hexahedra, voxels, wedges and pyramids split into a conforming tet mesh: every interior
// triangle is shared by exactly two tets, the boundary is the box boundary, volume is kept.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <map>
#include <numeric>
#include <random>

#include "fixture_writers.h"
#include "mesh_checks.h"
#include "test_paths.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

// A box of hexahedral cells with shuffled global vertex ids, so the diagonal rule picks
// different diagonals from cell to cell. Some cells are written as voxels, some as six
// pyramids around a centre point. Wedges get their own column mesh below.
CellMesh hybrid_box(int nx, int ny, int nz, unsigned seed, double* volume) {
  std::mt19937 rng(seed);
  const std::vector<double> xs = {0, 0.7, 1.5, 2.0, 3.1, 3.5}, ys = {0, 1.1, 1.6, 2.9, 3.0}, zs = {0, 0.4, 1.5, 2.2};
  int points = (nx + 1) * (ny + 1) * (nz + 1);
  std::vector<uint32_t> id(static_cast<size_t>(points));
  std::iota(id.begin(), id.end(), 0u);
  std::shuffle(id.begin(), id.end(), rng);
  CellMesh m;
  m.x.resize(static_cast<size_t>(points));
  m.y.resize(static_cast<size_t>(points));
  m.z.resize(static_cast<size_t>(points));
  auto at = [&](int i, int j, int k) { return id[static_cast<size_t>((k * (ny + 1) + j) * (nx + 1) + i)]; };
  for (int k = 0; k <= nz; ++k)
    for (int j = 0; j <= ny; ++j)
      for (int i = 0; i <= nx; ++i) {
        uint32_t v = at(i, j, k);
        m.x[v] = static_cast<float>(xs[static_cast<size_t>(i)]);
        m.y[v] = static_cast<float>(ys[static_cast<size_t>(j)]);
        m.z[v] = static_cast<float>(zs[static_cast<size_t>(k)]);
      }
  storage::Attribute field{{"f", 1}, {}};
  for (size_t v = 0; v < m.x.size(); ++v) field.values.push_back(m.x[v] + 2 * m.y[v] - m.z[v]);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        uint32_t c[8] = {at(i, j, k), at(i + 1, j, k), at(i + 1, j + 1, k), at(i, j + 1, k),
                         at(i, j, k + 1), at(i + 1, j, k + 1), at(i + 1, j + 1, k + 1), at(i, j + 1, k + 1)};
        int kind = (i + 2 * j + 3 * k) % 3;
        if (kind == 0) {
          m.add_cell(12, {c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]});
        } else if (kind == 1) {
          m.add_cell(11, {c[0], c[1], c[3], c[2], c[4], c[5], c[7], c[6]});
        } else {
          uint32_t centre = static_cast<uint32_t>(m.x.size());
          m.x.push_back(static_cast<float>((xs[i] + xs[i + 1]) / 2));
          m.y.push_back(static_cast<float>((ys[j] + ys[j + 1]) / 2));
          m.z.push_back(static_cast<float>((zs[k] + zs[k + 1]) / 2));
          field.values.push_back(m.x.back() + 2 * m.y.back() - m.z.back());
          const int faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
          for (auto& f : faces) m.add_cell(14, {c[f[0]], c[f[1]], c[f[2]], c[f[3]], centre});
        }
      }
  m.attributes.push_back(field);
    auto f = [](double v) { return static_cast<double>(static_cast<float>(v)); };  // as stored
  *volume = (f(xs[nx]) - f(xs[0])) * (f(ys[ny]) - f(ys[0])) * (f(zs[nz]) - f(zs[0]));
  return m;
}

// Triangulated square base extruded in layers: a column of wedges.
CellMesh wedge_column(unsigned seed, double* volume) {
  std::mt19937 rng(seed);
  const int n = 4, layers = 3;
  int points = (n + 1) * (n + 1) * (layers + 1);
  std::vector<uint32_t> id(static_cast<size_t>(points));
  std::iota(id.begin(), id.end(), 0u);
  std::shuffle(id.begin(), id.end(), rng);
  CellMesh m;
  m.x.resize(id.size());
  m.y.resize(id.size());
  m.z.resize(id.size());
  auto at = [&](int i, int j, int k) { return id[static_cast<size_t>((k * (n + 1) + j) * (n + 1) + i)]; };
  for (int k = 0; k <= layers; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        m.x[at(i, j, k)] = static_cast<float>(i);
        m.y[at(i, j, k)] = static_cast<float>(j);
        m.z[at(i, j, k)] = static_cast<float>(0.5 * k);
      }
  for (int k = 0; k < layers; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        bool flip = (i + j) % 2 == 0;
        uint32_t a = at(i, j, k), b = at(i + 1, j, k), c = at(i + 1, j + 1, k), d = at(i, j + 1, k);
        uint32_t A = at(i, j, k + 1), B = at(i + 1, j, k + 1), C = at(i + 1, j + 1, k + 1), D = at(i, j + 1, k + 1);
        if (flip) {
          m.add_cell(13, {a, b, c, A, B, C});
          m.add_cell(13, {a, c, d, A, C, D});
        } else {
          m.add_cell(13, {a, b, d, A, B, D});
          m.add_cell(13, {b, c, d, B, C, D});
        }
      }
  *volume = n * n * 0.5 * layers;
  return m;
}

struct Conformity {
  size_t faces_shared_by_more_than_two = 0;
  size_t boundary_faces = 0;
  size_t boundary_faces_off_the_box = 0;
  double volume = 0;
  size_t nonpositive = 0;
};

Conformity check(const storage::TetMesh& mesh) {
  const MeshCheck base = check_mesh(mesh);
  Conformity r{base.faces_shared_by_more_than_two, 0, 0, base.volume, base.nonpositive};
  storage::Bounds b = storage::compute_bounds(mesh);
  for (const auto& [key, count] : base.face_uses) {
    if (count != 1) continue;
    ++r.boundary_faces;
    bool on_box = false;
    const std::vector<float>* axes[3] = {&mesh.x, &mesh.y, &mesh.z};
    for (int k = 0; k < 3; ++k) {
      for (double side : {b.min[k], b.max[k]}) {
        bool all = true;
        for (uint32_t v : key) all &= (*axes[k])[v] == side;
        on_box |= all;
      }
    }
    if (!on_box) ++r.boundary_faces_off_the_box;
  }
  return r;
}

TEST(HybridSplit, HexVoxelPyramidBoxIsConformingAndKeepsVolume) {
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    double volume = 0;
    CellMesh cells = hybrid_box(5, 4, 3, seed, &volume);
    auto dir = scratch_dir("hybrid" + std::to_string(seed));
    write_vtk_legacy(dir / "box.vtk", cells, {.binary = true});
    storage::ReadStats stats;
    storage::TetMesh mesh = storage::load_mesh(dir / "box.vtk", &stats);
    Conformity c = check(mesh);
    EXPECT_EQ(c.faces_shared_by_more_than_two, 0u) << "seed " << seed;
    EXPECT_EQ(c.boundary_faces_off_the_box, 0u) << "seed " << seed << ": a split left a hole (non-conforming)";
    // the box has 2*(5*4 + 5*3 + 4*3) = 94 boundary quads, two triangles each
    EXPECT_EQ(c.boundary_faces, 2u * 94u) << "seed " << seed;
    EXPECT_NEAR(c.volume, volume, 1e-9 * volume) << "seed " << seed;
    EXPECT_EQ(c.nonpositive, 0u);
    EXPECT_EQ(stats.degenerate, 0u);
    EXPECT_GT(stats.hexahedra, 0u);
    EXPECT_GT(stats.pyramids, 0u);
    // Gmsh carries the same hybrid cells (voxels become hexahedra there)
    CellMesh as_hex = cells;
    for (size_t cell = 0; cell < as_hex.cell_count(); ++cell) {
      if (as_hex.types[cell] != 11) continue;
      uint32_t* n = &as_hex.connectivity[as_hex.offsets[cell]];
      std::swap(n[2], n[3]);
      std::swap(n[6], n[7]);
      as_hex.types[cell] = 12;
    }
    write_gmsh(dir / "box.msh", as_hex, {.version4 = true});
    storage::TetMesh from_gmsh = storage::load_mesh(dir / "box.msh");
    EXPECT_EQ(from_gmsh.tets, mesh.tets) << "seed " << seed;
  }
}

TEST(HybridSplit, WedgeColumnIsConformingAndKeepsVolume) {
  for (unsigned seed : {7u, 8u, 9u}) {
    double volume = 0;
    CellMesh cells = wedge_column(seed, &volume);
    auto dir = scratch_dir("wedges" + std::to_string(seed));
    write_vtu(dir / "col.vtu", cells, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true});
    storage::ReadStats stats;
    storage::TetMesh mesh = storage::load_mesh(dir / "col.vtu", &stats);
    EXPECT_EQ(mesh.tet_count(), 3u * cells.cell_count());
    EXPECT_EQ(stats.wedges, cells.cell_count());
    Conformity c = check(mesh);
    EXPECT_EQ(c.faces_shared_by_more_than_two, 0u);
    EXPECT_EQ(c.boundary_faces_off_the_box, 0u);
    // top and bottom: 2*16 triangles; sides: 4 sides * 4 * 3 quads * 2 triangles
    EXPECT_EQ(c.boundary_faces, 2u * 32u + 4u * 4u * 3u * 2u);
    EXPECT_NEAR(c.volume, volume, 1e-9 * volume);
    EXPECT_EQ(c.nonpositive, 0u);
  }
}

TEST(HybridSplit, HigherOrderCellsKeepTheirCorners) {
  // one quadratic tetra (10 nodes), as FEM codes write it
  std::string vtk =
      "# vtk DataFile Version 3.0\nq\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 10 float\n"
      "0 0 0 1 0 0 0 1 0 0 0 1 0.5 0 0 0.5 0.5 0 0 0.5 0 0 0 0.5 0.5 0 0.5 0 0.5 0.5\n"
      "CELLS 1 11\n10 0 1 2 3 4 5 6 7 8 9\nCELL_TYPES 1\n24\n";
  auto stream = storage::MeshStream::open_memory(storage::MeshFormat::kVtkLegacy, "q.vtk", vtk);
  storage::TetMesh mesh = storage::load_stream(*stream);
  ASSERT_EQ(mesh.tet_count(), 1u);
  EXPECT_EQ(stream->stats().quadratic_cells, 1u);
  std::vector<uint32_t> corners(mesh.tets.begin(), mesh.tets.end());
  std::sort(corners.begin(), corners.end());
  EXPECT_EQ(corners, (std::vector<uint32_t>{0, 1, 2, 3}));
}

}  // namespace
}  // namespace tetrascope::testing
