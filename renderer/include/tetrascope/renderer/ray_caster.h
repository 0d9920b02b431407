// The CPU ray caster: volume rendering of a tet mesh without a sort, for hosts whose only
// EGL device is software. A ray walks the tets through their shared faces front to back,
// composing the pre-integrated transfer function over exact segments (finely integrated
// where the value is nearly constant), and stops when opaque; isosurfaces and slices are composed in the walk.
#pragma once

#include <array>
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
  // Face adjacency, per-tet planes and gradients, and a hierarchy of boxes over the boundary
  // faces. Keeps a reference to `mesh`: it must outlive the caster.
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

 private:
  struct Cell {
    std::array<std::array<double, 4>, 4> plane;  // outward face planes: n.x + d, face f opposite vertex f
    std::array<double, 4> gradient;              // the value: g.x + c
    bool flat = false;                           // no volume: no gradient, never holds a point
  };
  struct Bvh;
  struct Shading;
  void shading(const RenderSettings& settings, Shading& out) const;
  void trace(const Shading& shading, const Vec3& origin, const Vec3& direction, double stop, uint32_t eye_tet, double acc[4], uint64_t& visits) const;
  uint32_t enter(const Vec3& origin, const Vec3& direction, double after, double* t_hit, uint32_t left) const;
  uint32_t locate(const Vec3& p) const;
  uint32_t walk_to(uint32_t from, uint32_t also, const Vec3& origin, const Vec3& direction, double t) const;

  const SceneMesh& mesh_;
  std::vector<uint32_t> opposite_;
  std::vector<Cell> cells_;
  std::unique_ptr<Bvh> bvh_;
  mutable std::mutex table_mutex_;
  mutable PreintegrationTable table_;                      // the GL path's
  mutable std::vector<float> extinction_;                 // per unit length, over the colour range
  mutable std::vector<std::array<float, 3>> colors_;      // over the colour range
  mutable std::string table_key_;
};

}  // namespace tetrascope::renderer
