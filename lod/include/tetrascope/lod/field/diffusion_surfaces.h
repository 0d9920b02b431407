// Diffusion surfaces of a symmetric tensor field (dissertation §7.4): the domain segmented into
// linear, planar and isotropic regions by Westin's measures (§7.4.2), and in planar regions
// surfaces whose tangent plane is everywhere that of the major and medium eigenvectors (normal
// to the minor one), grown from seeds by a cut-border (§7.4.3): the border of the surface built
// so far is a set of loops; at the most convex border edge (the gate) the surface grows by one
// triangle, closing a corner (L, R), a last triangle (E), a new vertex integrated along the
// surface in a search plane (C), a border where the integration leaves the planar region (B),
// or by joining a border vertex the new triangle would cover, on its own loop (S) or another
// (M). The surfaces pass the field's singular lines, close where they are closed, and keep
// every edge in at most two triangles.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "tetrascope/core/vec3.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::lod {

// §7.4.2's classes, by cl and cp against two thresholds (the larger measure decides when both pass).
enum class Anisotropy : uint8_t { isotropic, linear, planar };

struct AnisotropySegmentation {
  std::vector<Anisotropy> vertex_class;      // per vertex of the mesh
  std::array<double, 3> volume_share{};      // of the domain, per class (a tet's volume shared by its corners' classes)
  std::array<uint64_t, 3> vertices{};        // per class
};

// The class of one tensor's cl and cp (segment_anisotropy's rule).
Anisotropy classify_anisotropy(double cl, double cp, double min_linear, double min_planar);

// Throws std::invalid_argument when `tensor` is not a symmetric tensor attribute of `mesh`.
AnisotropySegmentation segment_anisotropy(const storage::TetMesh& mesh, const std::string& tensor, double min_linear, double min_planar);

// The tensor `tensor` interpolated linearly at each point, found in its tet by a grid over
// the tets' boxes; a point outside every tet gets NaN components. Throws
// std::invalid_argument when `tensor` is not a symmetric tensor attribute of `mesh`.
std::vector<storage::SymmetricTensor> tensors_at(const storage::TetMesh& mesh, const std::string& tensor, std::span<const Vec3> points);

// The cut-border's operations, counted per run.
enum class SurfaceOperation : uint8_t { create, left, right, end, split, merge, border, kCount };
const char* surface_operation_name(SurfaceOperation op);

struct DiffusionSurfaceOptions {
  double min_planar = 0.25;          // Cp: the surface grows where cp is at least this
  double edge = 0;                   // integrated edge length; 0: 1/48 of the bounding-box diagonal
  double max_bend_degrees = 35;      // an edge whose ends' tangent planes differ more ends at a border
  uint32_t max_triangles_per_surface = 100'000;
  uint64_t max_triangles = 2'000'000;  // all surfaces together (memory bound)
};

// The grown surfaces: vertices and triangles of all surfaces back to back, surface s holding
// triangles [surface_first[s], surface_first[s+1]). Normals are the minor eigenvector, oriented
// consistently over each surface (its triangles counter-clockwise about them).
struct DiffusionSurfaces {
  std::vector<float> x, y, z;
  std::vector<float> nx, ny, nz;
  std::vector<float> planar;                   // cp at each vertex
  std::vector<uint32_t> triangles;             // 3 vertex indices each
  std::vector<uint32_t> surface_first{0};
  std::vector<uint32_t> surface_seed;          // per surface, the seed it grew from
  uint64_t seeds = 0, seeds_refused = 0;       // refused: outside, not planar, or on an earlier surface
  std::array<uint64_t, size_t(SurfaceOperation::kCount)> operations{};
  bool truncated = false;                      // a triangle limit stopped a surface
  size_t surface_count() const { return surface_first.size() - 1; }
  size_t triangle_count() const { return triangles.size() / 3; }
  size_t vertex_count() const { return x.size(); }
};

// Grows surfaces through `mesh`'s symmetric tensor attribute `tensor` (std::invalid_argument
// otherwise). The mesh is trusted (checked by its reader).
class DiffusionSurfaceTracer {
 public:
  DiffusionSurfaceTracer(const storage::TetMesh& mesh, const std::string& tensor);
  ~DiffusionSurfaceTracer();
  DiffusionSurfaceTracer(const DiffusionSurfaceTracer&) = delete;
  DiffusionSurfaceTracer& operator=(const DiffusionSurfaceTracer&) = delete;

  // One surface per seed that lies in a planar region and off every earlier surface (half an
  // edge from its vertices).
  DiffusionSurfaces trace(std::span<const Vec3> seeds, const DiffusionSurfaceOptions& options) const;
  // Seeds at the centres of a grid of `resolution` cells along the box's longest side, in the
  // order of the cells, each refused when planar anisotropy is too low there or a surface
  // already passes within two edge lengths.
  DiffusionSurfaces trace_dense(uint32_t resolution, const DiffusionSurfaceOptions& options) const;

  struct Impl;

 private:
  Impl* impl_;
};

// Legacy VTK POLYDATA (binary): POINTS, POLYGONS, POINT_DATA with the normals and cp, and a
// per-triangle surface index; ParaView opens it.
void write_diffusion_surfaces_vtk(const std::filesystem::path& path, const DiffusionSurfaces& surfaces, const std::string& title);

}  // namespace tetrascope::lod
