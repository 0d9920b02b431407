// Stream lines through a per-vertex vector field on a tetrahedral mesh (dissertation §7.3):
// seeds from a rake, a plane grid, points or dense seeding; adaptive Runge–Kutta
// (Dormand–Prince 5(4)) walking from tet to tet by face adjacency.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include "tetrascope/storage/mesh.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::lod {

enum class StreamDirection { forward, backward, both };

// Why one direction of a line ended.
enum class StopReason : uint8_t {
  boundary,       // left the domain; the last segment is clipped to the boundary face
  zero_velocity,  // |v| fell below the zero speed
  max_length,     // reached the maximal length
  max_steps,      // reached the maximal step count
  lost,           // the walk found no tet, or the field is not finite there
  point_budget,   // all lines together reached StreamlineOptions::max_points
  kCount
};
const char* stop_reason_name(StopReason reason);

// Limits are named, all configurable; the defaults suit the shared datasets.
struct StreamlineOptions {
  StreamDirection direction = StreamDirection::both;
  uint32_t max_steps = 10000;          // accepted steps per direction
  double max_length = 0;               // arc length per direction; 0: 4 bounding-box diagonals
  double tolerance = 1e-3;             // local error per step, relative to the local cell size
  double zero_speed = 0;               // |v| below this stops; 0: 1e-6 of the field's largest |v|
  double max_step_cells = 2;           // a step advances at most this many local cell sizes
  double min_step_cells = 1e-4;        // the smallest step before a stop at the boundary
  uint64_t max_points = 50'000'000;    // integration points of all lines together (memory bound)
  unsigned threads = 0;                // 0: hardware concurrency
};

// Seeds, parsed from a user's text (untrusted): line:x0,y0,z0,x1,y1,z1,N | plane:ox,oy,oz,ux,uy,uz,
// vx,vy,vz,NU,NV | points:x,y,z;x,y,z… | dense:N | critical:K[,R]. Throws std::invalid_argument
// with a message naming the problem. `dense` sets dense_resolution and `critical` the
// critical-point fields; both leave points empty (they need the mesh).
struct SeedSpec {
  std::vector<Vec3> points;
  uint32_t dense_resolution = 0;  // cells along the longest side of the bounding box
  // §7.3.1: seeds on a sphere about every critical point (zero of the field): the sphere from
  // a tetrahedron whose faces are split K x K (2K^2 + 2 points), of R local cell sizes radius.
  uint32_t critical_subdivision = 0;
  double critical_radius_cells = 2;
};
constexpr uint32_t kMaxSeeds = 1'000'000;
constexpr uint32_t kMaxDenseResolution = 256;  // the coverage grid has at most 256^3 cells
constexpr uint32_t kMaxCriticalSubdivision = 32;
constexpr double kMaxCriticalRadiusCells = 1000;
// 2K^2 + 2 points evenly on the unit sphere: a tetrahedron's faces split K x K, projected.
std::vector<Vec3> sphere_points(uint32_t subdivision);
SeedSpec parse_seeds(const std::string& text);

// The traced lines: points of all lines back to back, line l spanning
// [line_first[l], line_first[l+1]). Values hold, per point, |v| and then every scalar attribute.
struct Streamlines {
  std::vector<float> x, y, z;
  std::vector<float> vx, vy, vz;               // the field at each point
  std::vector<uint32_t> line_first{0};         // line count + 1 offsets
  std::vector<uint32_t> line_seed;             // per line, the seed index it came from
  std::vector<std::string> value_names;        // "<field>_magnitude", then the scalars
  std::vector<std::vector<float>> values;      // per name, one value per point
  uint64_t seeds = 0, seeds_outside = 0;
  uint64_t stops[size_t(StopReason::kCount)] = {};  // per direction traced
  size_t line_count() const { return line_first.size() - 1; }
  size_t point_count() const { return x.size(); }
};

// Traces through `mesh`, whose face adjacency `opposite` (4 per tet, from pair_faces) must be
// consistent with its tets. Builds a uniform grid over the tets' boxes once for seed location.
// The mesh is trusted (checked by its reader); `field` must name a 3-component attribute or a
// symmetric tensor (AttributeKind::kTensor), otherwise std::invalid_argument. Through a tensor
// the lines follow the major eigenvector (of λ1) of the tensor interpolated at each point,
// scaled by its linear anisotropy cl, the sign of every stage chosen to agree with the step's
// first direction: zero_speed is then the cl below which a line stops, and critical points are
// refused (std::invalid_argument).
class StreamlineTracer {
 public:
  StreamlineTracer(const storage::TetMesh& mesh, std::span<const uint32_t> opposite, const std::string& field);
  ~StreamlineTracer();
  StreamlineTracer(const StreamlineTracer&) = delete;
  StreamlineTracer& operator=(const StreamlineTracer&) = delete;

  // The tet containing p, or UINT32_MAX.
  uint32_t locate(const Vec3& p) const;
  // One line per seed inside the domain (seeds outside are counted, not traced).
  Streamlines trace(std::span<const Vec3> seeds, const StreamlineOptions& options) const;
  // §7.3.1: a grid of `resolution` cells along the longest side; a line is seeded (both
  // directions) at the centre of every cell inside the domain that no earlier line crossed.
  Streamlines trace_dense(uint32_t resolution, const StreamlineOptions& options) const;
  // The isolated zeros of the field (linear in each tet): a point where the field vanishes
  // inside or on a tet whose field is not degenerate (a tet with a constant or planar field
  // has none isolated). Duplicates on shared faces merged; zeros on the domain's boundary
  // (no-slip walls) left out; sorted by position.
  struct CriticalPoint {
    Vec3 position;
    double cell_size;          // of its tet
    bool on_boundary = false;  // (found on a boundary face; such points are not returned)
  };
  std::vector<CriticalPoint> critical_points() const;
  // §7.3.1's spheres: seeds about every critical point. Throws std::invalid_argument when the
  // seeds would be more than kMaxSeeds.
  std::vector<Vec3> critical_seeds(uint32_t subdivision, double radius_cells) const;
  Streamlines trace(const SeedSpec& seeds, const StreamlineOptions& options) const;

  struct Impl;

 private:
  Impl* impl_;
};

// Legacy VTK POLYDATA (binary): POINTS, LINES, POINT_DATA with the field as VECTORS and every
// value as SCALARS; ParaView opens it.
void write_streamlines_vtk(const std::filesystem::path& path, const Streamlines& lines, const std::string& field, const std::string& title);

}  // namespace tetrascope::lod
