// The CPU ray caster: volume rendering of a tet mesh without a sort, for hosts whose only
// EGL device is software. A ray walks the tets through their shared faces front to back,
// composing the pre-integrated transfer function over exact segments (finely integrated
// where the value is nearly constant), and stops when opaque; isosurfaces and slices are composed in the walk.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "tetrascope/core/vec3.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

// Whether a GL renderer's description (Renderer::description) names a software rasteriser
// (Mesa's llvmpipe, softpipe or swrast).
bool software_renderer(const std::string& description);
// The backends `render --backend` and `serve --backend` take: gl, cpu or auto.
bool known_backend(const std::string& name);

class RayCaster {
 public:
  // Face adjacency, per-tet planes and gradients (the tets reordered along a Morton curve of
  // their centroids, so that a tile's rays read nearby memory), and a hierarchy of boxes over
  // the boundary faces. Keeps a reference to `mesh`: it must outlive the caster.
  explicit RayCaster(const SceneMesh& mesh);
  ~RayCaster();
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  // What of `settings` the caster does not draw (empty: it draws all of it): surfaces,
  // wireframes, boxes, points, stream lines, isosurfaces coloured by another attribute,
  // frames without the volume and the projected-tetrahedra volume stay with the GL renderer.
  static std::string unsupported(const RenderSettings& settings);
  // One frame over `threads` threads (0: every core). Throws std::invalid_argument for what
  // unsupported names and for bad image sides. FrameTimings: draw_ms, tets_drawn counts the
  // tets the rays visited, and interrupted says settings.should_stop stopped the frame
  // (asked between tiles; the image is partial).
  Image render(const RenderSettings& settings, FrameTimings* timings = nullptr, unsigned threads = 0) const;

  // One step of a ray's walk: the tet (its index in the mesh) and the ray parameter where the
  // ray leaves it.
  struct Step {
    uint32_t tet = 0;
    double t_out = 0;
  };
  // The tets a ray from `origin` along `direction` visits, in order, as render walks them
  // (entering from outside, or from the tet that holds `origin`), and where it leaves each.
  std::vector<Step> walk(const Vec3& origin, const Vec3& direction) const;

 private:
  // One tet as the walk reads it, in two cache lines, in float (the mesh's own precision;
  // the walk computes in double, relative to the tet's corner): the outward unit normals of
  // its faces (face f opposite vertex f) with their signed distances n.(x - corner) + offset,
  // the value and its gradient (value + gradient.(x - corner)), and the faces across.
  struct alignas(64) Cell {
    float nx[4], ny[4], nz[4], offset[4];
    float corner[3];
    float value;
    float gradient[3];
    uint32_t flat;       // no volume: no gradient, never holds a point
    uint32_t across[4];  // 4 * cell + face on the other side of face f, or kNoOppositeFace
  };
  struct Bvh;
  struct Shading;
  struct Ray;
  void shading(const RenderSettings& settings, Shading& out) const;
  void compact_tables() const;
  void start(Ray& ray, uint32_t eye_tet) const;
  void advance(Ray& ray, int exit, double t_out) const;
  // a ray whose steps stopped advancing (circling an edge or a vertex it runs through): on a little
  void move_on(Ray& ray) const;
  struct EntryBins;
  void trace(const Shading& shading, Ray& ray, double stop, double acc[4], uint64_t& visits) const;
  uint32_t enter(const Ray& ray, double after, double* t_hit, uint32_t left) const;
  uint32_t enter_binned(const EntryBins& bins, uint32_t tile, uint32_t x, uint32_t y, const Vec3& origin, const Vec3& direction, double after, double* t_hit,
                        uint32_t left) const;
  uint32_t enter(const Vec3& origin, const Vec3& direction, double after, double* t_hit, uint32_t left) const;
  uint32_t locate(const Vec3& p) const;
  uint32_t walk_to(uint32_t from, uint32_t also, const Vec3& origin, const Vec3& direction, double t) const;

  const SceneMesh& mesh_;
  std::vector<Cell> cells_;        // the tets along a space-filling curve of their centroids
  std::vector<uint32_t> source_;   // cell -> the mesh's tet
  std::unique_ptr<Bvh> bvh_;
  mutable std::mutex table_mutex_;
  mutable PreintegrationTable table_;                      // the GL path's
  mutable std::vector<float> extinction_;                 // per unit length, over the colour range
  mutable std::vector<std::array<float, 3>> colors_;      // over the colour range
  mutable std::vector<std::array<double, 4>> integrals_;  // of extinction and of colour times extinction, on extinction_'s grid
  mutable std::array<double, 4> below_{}, above_{};       // their rates past the range's ends
  mutable std::vector<std::array<double, 4>> prefix_base_;  // integrals_ compact: at each block's start
  mutable std::vector<std::array<float, 4>> prefix_fine_;   // and less that within the block
  mutable std::vector<uint32_t> lit_bins_;                // bins of the table below each with some opacity (a prefix count)
  mutable std::string table_key_;
};

}  // namespace tetrascope::renderer
