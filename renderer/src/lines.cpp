// Stream lines with ghosting and halos, dissertation §7.3.2-7.3.3 (after Sondershaus &
// Straßer 2006); lit by the illuminated-lines model (Zöckler, Stalling & Hege 1996).
//
// Every segment is drawn as a screen-aligned quad (6 vertices from an SSBO of points, so the
// width is in pixels and needs no wide-line support): the vertex shader projects both ends
// and offsets the corners along the segment's screen normal.
//  - opaque lines: the line, then its halo - a strip 2.5x as wide in a dark colour, moved
//    `halo depth` away from the eye (§7.3.3's "broader width and a small z-offset"), depth
//    tested: it shows only beside the line and in front of lines farther behind, so a crossing
//    reads as one line passing over the other. Flow direction in stills: arrowheads in the
//    halo by arc length (§7.3.3's textured arrows, computed in the shader), or dashes along
//    the line (§7.3.3's stipple, by arc length instead of pixels; `dash_phase` moves them).
//  - depth correction (§7.3.3, figure 7.12): the halo's world width is g(d) = g0 ((1 - c) +
//    c d / d0), linear in the view depth d as the dissertation's g = s/e * |o - p|, with d0 the
//    camera's distance to its target; in pixels that is half_width ((1 - c) d0 / d + c). The
//    arrows' (and dashes') pattern coordinate advances by the arc length over the same factor,
//    t_i = t_{i-1} + |p_i - p_{i-1}| / ((1 - c) + c d / d0) (§7.3.3's h(|o - p|)), summed on
//    the CPU when the camera or c changes. c = 1 (default): halos and arrows keep their size in
//    the image at every depth; c = 0: their size is fixed in the world and perspective shrinks
//    far ones.
//  - ghosted lines (§7.3.2): one colour and opacity, segments sorted back to front by their
//    midpoint's distance, blended, depth tested, no depth writes.
//
// Compositing with the volume: opaque lines are drawn before the volume and write the
// distance target, so the volume's rays stop at them (exact). Ghosts are blended after the
// volume, over it: a ghost behind a dense part of the volume is not dimmed by it. What that
// costs: one CPU sort of the ghosted segments a frame (O(S log S)) and one blended draw; the
// exact alternative - merging ghost segments into the volume's back-to-front tet order - would
// split the volume's batched draws at every ghost and is not done.
#include <algorithm>
#include <cmath>

#include "gl_shaders.h"
#include "lines.h"

namespace tetrascope::renderer {
namespace {

constexpr float kHaloWidthFactor = 2.5f;       // halo width / line width
constexpr double kHaloDepthFraction = 0.004;   // halo pushed back by this much of the lines' diagonal
constexpr double kFlowSpacingFraction = 1.0 / 30;
constexpr std::array<float, 3> kHaloColor{0.02f, 0.02f, 0.03f};

enum Kind : int { kLine = 0, kHalo = 1, kGhost = 2 };

const char* const kStreamlineVertex = R"(#version 450 core
layout(std430, binding = 0) readonly buffer Points { vec4 points[]; };     // xyz, value
layout(std430, binding = 1) readonly buffer Tangents { vec4 tangents[]; }; // unit tangent, arc length
layout(std430, binding = 2) readonly buffer Segments { uint segments[]; }; // first point of each segment drawn
layout(std430, binding = 3) readonly buffer Pattern { float pattern[]; };  // arrow and dash coordinate (depth corrected arc length)
uniform mat4 mvp;
uniform vec2 viewport;
uniform float half_width;   // pixels
uniform float cap;          // pixels the quad reaches past each end (closes joints)
uniform float push;         // world distance the strip moves away from the eye (halos)
uniform vec3 eye, forward;
uniform bool ortho;
uniform bool depth_scaled;  // halos: half_width at depth ref_depth, corrected by depth_correction
uniform float ref_depth, depth_correction;
out vec3 world;
out float v;
out float arc;
out float across;
out vec3 tangent;
void main() {
  uint seg = segments[uint(gl_VertexID) / 6u];
  uint corner = uint(gl_VertexID) % 6u;
  bool at_b = corner == 1u || corner == 2u || corner == 4u;
  float side = (corner == 2u || corner == 4u || corner == 5u) ? 1.0 : -1.0;
  uint i = at_b ? seg + 1u : seg;
  vec3 pa = points[seg].xyz, pb = points[seg + 1u].xyz;
  vec3 p = points[i].xyz;
  vec3 dir = ortho ? forward : normalize(p - eye);
  world = p + push * dir;
  v = points[i].w;
  arc = pattern[i];
  tangent = tangents[i].xyz;
  across = side;
  vec4 ca = mvp * vec4(pa, 1.0), cb = mvp * vec4(pb, 1.0);
  if (ca.w <= 1e-6 || cb.w <= 1e-6) {  // reaches behind the eye: not drawn
    gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
    return;
  }
  vec2 sa = ca.xy / ca.w * viewport * 0.5, sb = cb.xy / cb.w * viewport * 0.5;
  vec2 d = sb - sa;
  float len = length(d);
  d = len > 1e-6 ? d / len : vec2(1.0, 0.0);
  vec2 n = vec2(-d.y, d.x);
  vec4 c = mvp * vec4(world, 1.0);
  float width = half_width;
  if (depth_scaled && !ortho) width *= mix(ref_depth / max(c.w, 1e-6 * ref_depth), 1.0, depth_correction);
  vec2 offset = n * side * width + d * (at_b ? cap : -cap);
  c.xy += offset * 2.0 / viewport * c.w;
  gl_Position = c;
}
)";

const char* const kStreamlineFragment = R"(#version 450 core
in vec3 world;
in float v;
in float arc;
in float across;
in vec3 tangent;
uniform vec3 eye, forward, light;
uniform bool ortho;
uniform sampler1D colormap;
uniform float lo, inv_span;
uniform int kind;          // 0: line, 1: halo, 2: ghost
uniform int flow;          // 0: none, 1: arrows, 2: dashes
uniform float spacing, phase;
uniform vec3 halo_color;
uniform vec4 ghost;        // colour, opacity
layout(location = 0) out vec4 color;
layout(location = 1) out float distance_out;
// Illuminated lines: diffuse and specular terms from the tangent alone (the normal that
// maximises them lies in the plane of the tangent and the light).
vec3 lit(vec3 base, float tube) {
  float tl = length(tangent);
  vec3 T = tl > 1e-12 ? tangent / tl : vec3(0.0, 0.0, 1.0);
  vec3 V = ortho ? -forward : normalize(eye - world);
  float lt = dot(light, T), vt = dot(V, T);
  float diffuse = sqrt(max(0.0, 1.0 - lt * lt));
  float specular = pow(max(0.0, diffuse * sqrt(max(0.0, 1.0 - vt * vt)) - lt * vt), 24.0);
  return base * (0.3 + 0.7 * diffuse) * (0.7 + 0.3 * tube) + vec3(0.3 * specular);
}
void main() {
  distance_out = ortho ? dot(world - eye, forward) : length(world - eye);
  float u = fract(arc / spacing - phase);
  if (kind == 2) {
    vec3 c = lit(ghost.rgb, 1.0);
    color = vec4(c * ghost.a, ghost.a);
    return;
  }
  vec3 base = texture(colormap, clamp((v - lo) * inv_span, 0.0, 1.0)).rgb;
  if (kind == 1) {
    // an arrowhead each `spacing`: its base across the halo's width, its tip along the flow
    bool arrow = flow == 1 && u > 0.5 && abs(across) < (1.0 - u) * 2.0;
    color = vec4(arrow ? lit(base, 1.0) : halo_color, 1.0);
    return;
  }
  if (flow == 2 && u > 0.7) discard;
  color = vec4(lit(base, sqrt(max(0.0, 1.0 - across * across))), 1.0);
}
)";

bool is_selected(const std::vector<uint32_t>& selected, uint32_t line) { return selected.empty() || std::binary_search(selected.begin(), selected.end(), line); }

}  // namespace

void check_line_settings(const RenderSettings& s) {
  if (!s.lines) return;
  if (!(s.line_width >= 1 && s.line_width <= kMaxLineWidth)) throw std::invalid_argument("line width must be 1.." + std::to_string(int(kMaxLineWidth)) + " pixels");
  if (!(s.ghost_opacity > 0 && s.ghost_opacity <= 1)) throw std::invalid_argument("ghost opacity must be in (0, 1]");
  if (!(s.flow_spacing >= 0 && std::isfinite(s.flow_spacing))) throw std::invalid_argument("flow spacing must be 0 (automatic) or a positive length");
  if (!(s.dash_phase >= 0 && s.dash_phase <= 1)) throw std::invalid_argument("dash phase must be in [0, 1]");
  if (!(s.depth_correction >= 0 && s.depth_correction <= 1)) throw std::invalid_argument("depth correction must be in [0, 1]");
  if (!std::is_sorted(s.selected_lines.begin(), s.selected_lines.end())) throw std::invalid_argument("selected lines must be ascending ids");
  if (!s.selected_lines.empty() && s.selected_lines.back() >= s.lines->line_count())
    throw std::invalid_argument("selected line " + std::to_string(s.selected_lines.back()) + " does not exist (there are " + std::to_string(s.lines->line_count()) + " lines)");
}

LinePass::LinePass() {
  program_ = link_program(kStreamlineVertex, kStreamlineFragment);
  glCreateBuffers(1, &points_);
  glCreateBuffers(1, &tangents_);
  glCreateBuffers(1, &segments_);
  glCreateBuffers(1, &pattern_);
  glCreateVertexArrays(1, &vao_);
}

LinePass::~LinePass() {
  glDeleteBuffers(1, &points_);
  glDeleteBuffers(1, &tangents_);
  glDeleteBuffers(1, &segments_);
  glDeleteBuffers(1, &pattern_);
  glDeleteVertexArrays(1, &vao_);
  glDeleteProgram(program_);
}

// Points as (x, y, z, value), tangents as (unit tangent, arc length from the line's start):
// the tangent by central differences, so the lighting is smooth along the line.
void LinePass::upload(const std::shared_ptr<const LineSet>& lines) {
  if (held_ == lines) return;
  const LineSet& set = *lines;
  const size_t n = set.point_count();
  std::vector<float> points(4 * std::max<size_t>(n, 1)), tangents(4 * std::max<size_t>(n, 1));
  arc_.assign(std::max<size_t>(n, 1), 0.0f);
  for (size_t l = 0; l < set.line_count(); ++l) {
    const uint32_t first = set.line_first[l], end = set.line_first[l + 1];
    double arc = 0;
    for (uint32_t i = first; i < end; ++i) {
      const uint32_t a = i > first ? i - 1 : i, b = i + 1 < end ? i + 1 : i;
      Vec3 t{set.xyz[3 * b] - set.xyz[3 * a], set.xyz[3 * b + 1] - set.xyz[3 * a + 1], set.xyz[3 * b + 2] - set.xyz[3 * a + 2]};
      t = normalise(t, {0, 0, 0});
      if (i > first) {
        const Vec3 step{set.xyz[3 * i] - set.xyz[3 * (i - 1)], set.xyz[3 * i + 1] - set.xyz[3 * (i - 1) + 1], set.xyz[3 * i + 2] - set.xyz[3 * (i - 1) + 2]};
        arc += length(step);
      }
      for (int k = 0; k < 3; ++k) {
        points[4 * i + k] = set.xyz[3 * i + k];
        tangents[4 * i + k] = static_cast<float>(t[k]);
      }
      points[4 * i + 3] = set.value[i];
      tangents[4 * i + 3] = static_cast<float>(arc);
      arc_[i] = static_cast<float>(arc);
    }
  }
  glNamedBufferData(points_, static_cast<GLsizeiptr>(points.size() * 4), points.data(), GL_STATIC_DRAW);
  glNamedBufferData(tangents_, static_cast<GLsizeiptr>(tangents.size() * 4), tangents.data(), GL_STATIC_DRAW);
  held_ = lines;
  pattern_valid_ = false;
}

void LinePass::update_pattern(const PassView& view, const RenderSettings& s) {
  const Frame& f = view.frame;
  const double ref = length(s.camera.target - s.camera.eye);
  // orthographic, or no correction asked for the world size: the pattern is the arc length
  const double c = f.ortho ? 0.0 : s.depth_correction;
  const std::array<double, 8> key{f.eye[0], f.eye[1], f.eye[2], f.forward[0], f.forward[1], f.forward[2], ref, c};
  if (pattern_valid_ && (key == pattern_key_ || (c == 0 && pattern_key_[7] == 0))) return;
  const LineSet& set = *s.lines;
  const float* upload = arc_.data();
  if (c > 0 && ref > 0) {
    pattern_scratch_.assign(arc_.size(), 0.0f);
    const double floor_depth = 1e-3 * ref;  // segments at or behind the eye are not drawn
    for (size_t l = 0; l < set.line_count(); ++l) {
      double t = 0;
      for (uint32_t i = set.line_first[l] + 1; i < set.line_first[l + 1]; ++i) {
        double depth = 0;
        for (int k = 0; k < 3; ++k) depth += (0.5 * (double(set.xyz[3 * i + k]) + set.xyz[3 * (i - 1) + k]) - f.eye[k]) * f.forward[k];
        const double scale = (1 - c) + c * std::max(depth, floor_depth) / ref;  // world size / nominal size there
        t += (double(arc_[i]) - arc_[i - 1]) / scale;
        pattern_scratch_[i] = static_cast<float>(t);
      }
    }
    upload = pattern_scratch_.data();
  }
  glNamedBufferData(pattern_, static_cast<GLsizeiptr>(arc_.size() * 4), upload, GL_DYNAMIC_DRAW);
  pattern_key_ = key;
  pattern_valid_ = true;
}

void LinePass::use(const PassView& view, const RenderSettings& s) {
  const LineSet& set = *s.lines;
  const Frame& f = view.frame;
  glUseProgram(program_);
  auto at = [&](const char* name) { return glGetUniformLocation(program_, name); };
  glUniformMatrix4fv(at("mvp"), 1, GL_FALSE, view.mvp.data());
  glUniform2f(at("viewport"), float(view.width), float(view.height));
  glUniform3f(at("eye"), float(f.eye[0]), float(f.eye[1]), float(f.eye[2]));
  glUniform3f(at("forward"), float(f.forward[0]), float(f.forward[1]), float(f.forward[2]));
  glUniform1i(at("ortho"), f.ortho);
  // a light over the viewer's left shoulder
  const Vec3 light = normalise(f.forward * -1.0 + f.up * 0.5 - f.right * 0.3);
  glUniform3f(at("light"), float(light[0]), float(light[1]), float(light[2]));
  glUniform1f(at("lo"), float(set.value_min));
  glUniform1f(at("inv_span"), float(1 / (set.value_max - set.value_min)));
  glBindTextureUnit(0, view.colormap);
  glUniform1i(at("colormap"), 0);
  glUniform1i(at("flow"), static_cast<int>(s.flow));
  const double spacing = s.flow_spacing > 0 ? s.flow_spacing : set.diagonal * kFlowSpacingFraction;
  glUniform1f(at("spacing"), float(spacing));
  glUniform1f(at("phase"), float(s.dash_phase));
  glUniform3f(at("halo_color"), kHaloColor[0], kHaloColor[1], kHaloColor[2]);
  glUniform4f(at("ghost"), s.ghost_color[0], s.ghost_color[1], s.ghost_color[2], float(s.ghost_opacity));
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, points_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, tangents_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, segments_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, pattern_);
  glUniform1f(at("ref_depth"), float(length(s.camera.target - s.camera.eye)));
  glUniform1f(at("depth_correction"), float(s.depth_correction));
  glUniform1i(at("depth_scaled"), 0);
  glBindVertexArray(vao_);
}

void LinePass::draw_segments(const std::vector<uint32_t>& segments, int kind, float half_width, float push, float cap) {
  glUniform1i(glGetUniformLocation(program_, "kind"), kind);
  glUniform1f(glGetUniformLocation(program_, "half_width"), half_width);
  glUniform1f(glGetUniformLocation(program_, "push"), push);
  glUniform1f(glGetUniformLocation(program_, "cap"), cap);
  glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(6 * segments.size()));
}

bool LinePass::draw_opaque(const PassView& view, const RenderSettings& s, FrameTimings& tm) {
  if (!s.lines || s.lines->point_count() < 2) return false;
  upload(s.lines);
  const LineSet& set = *s.lines;
  scratch_.clear();
  for (uint32_t l = 0; l < set.line_count(); ++l)
    if (is_selected(s.selected_lines, l))
      for (uint32_t i = set.line_first[l]; i + 1 < set.line_first[l + 1]; ++i) scratch_.push_back(i);
  tm.line_segments_opaque = scratch_.size();
  if (scratch_.empty()) return false;
  update_pattern(view, s);
  glNamedBufferData(segments_, static_cast<GLsizeiptr>(scratch_.size() * 4), scratch_.data(), GL_STREAM_DRAW);
  static constexpr GLenum kBoth[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, kBoth);
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  use(view, s);
  const float half = float(s.line_width / 2);
  draw_segments(scratch_, kLine, half, 0, half);
  if (s.halos) {
    glUniform1i(glGetUniformLocation(program_, "depth_scaled"), 1);
    draw_segments(scratch_, kHalo, half * kHaloWidthFactor, float(set.diagonal * kHaloDepthFraction), half);
  }
  return true;
}

void LinePass::draw_ghosts(const PassView& view, const RenderSettings& s, FrameTimings& tm) {
  if (!s.lines || s.selected_lines.empty()) return;
  upload(s.lines);
  const LineSet& set = *s.lines;
  const Frame& f = view.frame;
  update_pattern(view, s);  // bound by use(); ghosts draw no flow marks
  order_.clear();
  for (uint32_t l = 0; l < set.line_count(); ++l) {
    if (is_selected(s.selected_lines, l)) continue;
    for (uint32_t i = set.line_first[l]; i + 1 < set.line_first[l + 1]; ++i) {
      double d = 0;
      for (int k = 0; k < 3; ++k) {
        const double c = 0.5 * (set.xyz[3 * i + k] + set.xyz[3 * i + 3 + k]) - f.eye[k];
        d += f.ortho ? c * f.forward[k] : c * c;
      }
      order_.push_back({static_cast<float>(-d), i});  // far first
    }
  }
  tm.line_segments_ghosted = order_.size();
  if (order_.empty()) return;
  std::sort(order_.begin(), order_.end());
  scratch_.resize(order_.size());
  for (size_t i = 0; i < order_.size(); ++i) scratch_[i] = order_[i].second;
  glNamedBufferData(segments_, static_cast<GLsizeiptr>(scratch_.size() * 4), scratch_.data(), GL_STREAM_DRAW);
  static constexpr GLenum kColour[1] = {GL_COLOR_ATTACHMENT0};
  glDrawBuffers(1, kColour);
  glEnable(GL_DEPTH_TEST);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // premultiplied
  glDepthMask(GL_FALSE);
  use(view, s);
  draw_segments(scratch_, kGhost, float(s.line_width / 2), 0, 0);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
}

}  // namespace tetrascope::renderer
