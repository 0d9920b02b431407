// The GL passes of stream lines (§7.3), point-based isosurfaces (§7.2) and tensor points (§7.4.2), hooked into
// GlRenderer's frame (gl_renderer.cpp): each pass gets the frame's camera, matrix and
// colormap through PassView and leaves the GL state as it found it (depth test on, blending
// off, depth writes on).
#pragma once

#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <array>
#include <map>
#include <memory>
#include <vector>

#include "camera_math.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {

struct PassView {
  Frame frame;
  std::array<float, 16> mvp{};
  uint32_t width = 1, height = 1;
  double lo = 0, hi = 1;       // the transfer function's range (colours of point isosurfaces)
  GLuint colormap = 0;         // 1D colour texture over [lo, hi]
};

// Throws std::invalid_argument for line or point settings out of range (RenderSettings says
// the ranges), or selected line ids the line set lacks.
void check_line_settings(const RenderSettings& s);
void check_point_settings(const RenderSettings& s);

class LinePass {
 public:
  LinePass();
  ~LinePass();
  LinePass(const LinePass&) = delete;
  LinePass& operator=(const LinePass&) = delete;
  // The opaque lines (every line, or the selected ones) with halos and flow marks: colour,
  // depth and the distance target (the volume's rays stop there). False when none drawn.
  bool draw_opaque(const PassView& view, const RenderSettings& s, FrameTimings& tm);
  // The ghosted lines (those not selected): one colour, blended back to front, depth-tested
  // against everything opaque, not writing depth. Drawn after the volume.
  void draw_ghosts(const PassView& view, const RenderSettings& s, FrameTimings& tm);

 private:
  void upload(const std::shared_ptr<const LineSet>& lines);
  void use(const PassView& view, const RenderSettings& s);
  void draw_segments(const std::vector<uint32_t>& segments, int kind, float half_width, float push, float cap);
  // The arrows' and dashes' coordinate at every point: the arc length, depth corrected
  // (§7.3.3) for this view; summed again only when the view or the correction changes.
  void update_pattern(const PassView& view, const RenderSettings& s);
  GLuint program_ = 0, points_ = 0, tangents_ = 0, segments_ = 0, pattern_ = 0, vao_ = 0;
  std::vector<float> arc_;                    // world arc length at every point (the uncorrected pattern)
  std::vector<float> pattern_scratch_;
  std::array<double, 8> pattern_key_{};       // eye, forward, reference depth, correction of the uploaded pattern
  bool pattern_valid_ = false;
  std::shared_ptr<const LineSet> held_;  // the uploaded set (held, so its address is not reused)
  std::vector<uint32_t> scratch_;
  std::vector<std::pair<float, uint32_t>> order_;
};

class PointIsoPass {
 public:
  PointIsoPass();
  ~PointIsoPass();
  PointIsoPass(const PointIsoPass&) = delete;
  PointIsoPass& operator=(const PointIsoPass&) = delete;
  void set_mesh(const SceneMesh& mesh);
  // Lit splats, opaque, depth-tested: colour, depth and distance. False when no point.
  bool draw(const PassView& view, const RenderSettings& s, FrameTimings& tm);

 private:
  struct Uploaded {
    GLuint buffer = 0;
    uint64_t count = 0;
    double area = 0;
  };
  const Uploaded& points_for(const std::vector<double>& isovalues, double area, uint64_t target);
  GLuint program_ = 0, vao_ = 0;
  const SceneMesh* mesh_ = nullptr;
  std::map<std::vector<double>, Uploaded> cache_;  // key: isovalues, area, target
};

// A tensor field's points (§7.4.2, tensor_pass.cpp): lit splats, opaque, depth-tested.
class TensorPointPass {
 public:
  TensorPointPass();
  ~TensorPointPass();
  TensorPointPass(const TensorPointPass&) = delete;
  TensorPointPass& operator=(const TensorPointPass&) = delete;
  // Colour, depth and distance. False when no point.
  bool draw(const PassView& view, const RenderSettings& s, FrameTimings& tm);
  void release();

 private:
  GLuint program_ = 0, vao_ = 0, buffer_ = 0;
  std::shared_ptr<const TensorPoints> held_;  // the uploaded set
};

}  // namespace tetrascope::renderer
