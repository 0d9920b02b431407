// In-memory tetrahedral meshes: struct-of-arrays, tets as flat VTK-ordered quadruples.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace tetrascope::storage {

// What an attribute holds beyond its component count (see tensor.h and docs/formats.md).
enum class AttributeKind : uint8_t {
  kValue,           // a scalar (1 component) or a vector or plain array (more)
  // A tensor. From a reader: 9 components (row-major 3x3) or 6 (symmetric, in VTK's order xx yy
  // zz xy yz xz). From MeshStream and in stores: always the 6 symmetric components, the 3x3
  // symmetrised as (A + A^T) / 2.
  kTensor,
  kTensorDerived,   // a scalar computed from the tensor `derived_from` (eigenvalue, von Mises, ...)
};

// One per-vertex field. Scalars have 1 component, vectors 3.
struct AttributeInfo {
  std::string name;
  uint32_t components = 1;
  AttributeKind kind = AttributeKind::kValue;
  // kTensor: every finite tensor of the attribute has eigenvalues >= 0 (a diffusion tensor;
  // stress tensors are indefinite). Known once every vertex was read.
  bool positive_semidefinite = false;
  std::string derived_from{};  // kTensorDerived: the tensor attribute's name
};

struct Attribute {
  AttributeInfo info;
  std::vector<float> values;  // vertex_count * components, vertex-major
};

// What a reader saw while turning cells into tetrahedra.
struct ReadStats {
  uint64_t cells = 0;               // volume cells in the file (before splitting)
  uint64_t tetrahedra = 0;          // tets produced
  uint64_t hexahedra = 0;           // hexes and voxels split into tets
  uint64_t wedges = 0;
  uint64_t pyramids = 0;
  uint64_t polyhedra = 0;           // general polyhedra (OpenFOAM) decomposed into tets about a centre point
  uint64_t quadratic_cells = 0;     // higher-order cells reduced to their corner vertices
  uint64_t skipped_cells = 0;       // vertices, lines and surface cells (not part of a volume)
  uint64_t inverted = 0;            // tets re-oriented to positive volume
  uint64_t degenerate = 0;          // tets of (numerically) zero volume, kept and counted
  // Tets that name one vertex twice (e.g. "0 0 6 31"), as written or after splitting a collapsed
  // hexahedron: they have no volume and no well-defined faces, so they are dropped and counted
  // here (and a warning added), never passed on.
  uint64_t repeated_vertex = 0;
  uint64_t nonfinite_attribute_values = 0;
  std::vector<std::string> warnings;  // e.g. "cell data 'Label' ignored"
};

struct Bounds {
  std::array<double, 3> min{0, 0, 0};
  std::array<double, 3> max{0, 0, 0};
};

// Boundary faces as the input tags them: Gmsh physical surfaces, OpenFOAM boundary patches,
// Exodus II side sets.
// Polygons arrive as the triangles the tet decomposition gives their faces (a quad cut by the
// diagonal through its vertex of smallest id, a larger face fanned about its centre point).
// A triangle that is no boundary face of the tets (an interface inside the volume) is kept
// here and ignored by the region finder.
struct FaceTags {
  std::vector<std::string> names;                  // per tag: the input's name for it
  std::vector<std::array<uint32_t, 3>> triangles;  // vertex ids of the mesh
  std::vector<uint32_t> tags;                      // per triangle, < names.size()
  bool empty() const { return triangles.empty(); }
  // The index of the tag called `name`, added when new.
  uint32_t tag(const std::string& name);
  void add(uint32_t tag, uint32_t a, uint32_t b, uint32_t c) {
    triangles.push_back({a, b, c});
    tags.push_back(tag);
  }
  // Replaces every vertex id v by renumber[v]; triangles with a vertex renumbered to `dropped`
  // (one no tet uses) go. Tags no triangle is left with stay (they cost a name).
  void renumber(const std::vector<uint32_t>& renumber, uint32_t dropped);
};

// A whole mesh in memory; for small meshes, tests and tools. Large meshes go through MeshStream.
struct TetMesh {
  std::vector<float> x, y, z;
  std::vector<Attribute> attributes;
  std::vector<uint32_t> tets;  // 4 * tet_count vertex indices, positively oriented
  FaceTags face_tags;          // the input's tagged boundary faces; empty when it has none

  size_t vertex_count() const { return x.size(); }
  size_t tet_count() const { return tets.size() / 4; }
  // The attribute called `name`, or nullptr.
  const Attribute* find_attribute(const std::string& name) const;
};

// Signed volume of the tet (a, b, c, d): positive when (b-a)x(c-a).(d-a) > 0.
double signed_volume(const TetMesh& mesh, uint32_t a, uint32_t b, uint32_t c, uint32_t d);

Bounds compute_bounds(const TetMesh& mesh);

// Removes the vertices (and their attribute values) that no tet uses and renumbers the tets;
// returns how many were removed. A file may hold millions of points and one tet: those
// points would otherwise cost memory and store bytes for nothing.
uint64_t drop_unused_vertices(TetMesh& mesh);

}  // namespace tetrascope::storage
