// The tensor points' pass (§7.4.2): every point of a TensorPoints set as a round splat, lit by
// what it was sampled from. Tube points by the illuminated-lines model of Zöckler et al. (1996)
// about the tube's tangent T, with the headlight L = V: diffuse sqrt(1 - (L.T)^2), specular
// (sqrt(1 - (L.T)^2) sqrt(1 - (V.T)^2) - (L.T)(V.T))^24, weighed by how far the point's ring
// normal faces the observer, so a tube's far side is darker and the ring reads as a tube.
// Surface points by Blinn-Phong about the surface normal (the minor eigenvector), two-sided.
// Colour: the anisotropy class (kAnisotropyColors) or the derived quantity through the
// frame's colormap over the set's range. Splats: a fixed diameter in pixels, or the disc of
// the set's spacing projected at the point's depth (x kCoverSpacings, so the gaps close).
#include <algorithm>
#include <cmath>

#include "gl_shaders.h"
#include "lines.h"

namespace tetrascope::renderer {
namespace {

constexpr double kCoverSpacings = 1.6;  // a covering splat's diameter, in spacings
constexpr int kFloatsPerPoint = 10;     // position, normal, tangent, value

const char* const kVertex = R"(#version 450 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal_in;
layout(location = 2) in vec3 tangent_in;
layout(location = 3) in float value;
uniform mat4 mvp;
uniform vec3 eye, forward;
uniform bool ortho;
uniform float size_px;          // > 0: this diameter
uniform float diameter;         // else: a disc of this world diameter, projected
uniform float pixels_per_unit;  // at distance 1 along `forward` (orthographic: everywhere)
uniform float max_size;
out vec3 world;
out vec3 normal;
out vec3 tangent;
out float v;
void main() {
  world = position;
  normal = normal_in;
  tangent = tangent_in;
  v = value;
  gl_Position = mvp * vec4(position, 1.0);
  float depth = ortho ? 1.0 : max(dot(position - eye, forward), 1e-9);
  gl_PointSize = size_px > 0.0 ? size_px : clamp(diameter * pixels_per_unit / depth, 1.0, max_size);
}
)";

const char* const kFragment = R"(#version 450 core
in vec3 world;
in vec3 normal;
in vec3 tangent;
in float v;
uniform vec3 eye, forward;
uniform bool ortho;
uniform bool by_class;
uniform vec3 class_colors[3];
uniform sampler1D colormap;
uniform float lo, inv_span;
layout(location = 0) out vec4 color;
layout(location = 1) out float distance_out;
void main() {
  vec2 q = gl_PointCoord * 2.0 - 1.0;
  if (dot(q, q) > 1.0) discard;
  vec3 d = ortho ? forward : normalize(world - eye);
  vec3 l = -d;  // the headlight: light and view directions agree
  vec3 base = by_class ? class_colors[clamp(int(v + 0.5), 0, 2)] : texture(colormap, clamp((v - lo) * inv_span, 0.0, 1.0)).rgb;
  vec3 n = normalize(normal);
  float light, specular;
  if (dot(tangent, tangent) > 0.25) {
    vec3 t = normalize(tangent);
    float lt = dot(l, t);
    float diffuse = sqrt(max(0.0, 1.0 - lt * lt));
    float facing = max(0.0, dot(n, l));
    light = 0.2 + 0.8 * diffuse * (0.35 + 0.65 * facing);
    specular = 0.35 * facing * pow(max(0.0, diffuse * diffuse - lt * lt), 24.0);
  } else {
    if (dot(n, l) < 0.0) n = -n;
    float nl = max(0.0, dot(n, l));
    light = 0.2 + 0.8 * nl;
    specular = 0.3 * pow(nl, 32.0);
  }
  color = vec4(base * light + vec3(specular), 1.0);
  distance_out = ortho ? dot(world - eye, forward) : length(world - eye);
}
)";

}  // namespace

TensorPointPass::TensorPointPass() {
  program_ = link_program(kVertex, kFragment);
  glCreateVertexArrays(1, &vao_);
  const GLint sizes[4] = {3, 3, 3, 1}, offsets[4] = {0, 12, 24, 36};
  for (GLuint a = 0; a < 4; ++a) {
    glEnableVertexArrayAttrib(vao_, a);
    glVertexArrayAttribFormat(vao_, a, sizes[a], GL_FLOAT, GL_FALSE, static_cast<GLuint>(offsets[a]));
    glVertexArrayAttribBinding(vao_, a, 0);
  }
  glCreateBuffers(1, &buffer_);
}

TensorPointPass::~TensorPointPass() {
  glDeleteBuffers(1, &buffer_);
  glDeleteVertexArrays(1, &vao_);
  glDeleteProgram(program_);
}

void TensorPointPass::release() {
  held_.reset();
  glNamedBufferData(buffer_, 4, nullptr, GL_STATIC_DRAW);
}

bool TensorPointPass::draw(const PassView& view, const RenderSettings& s, FrameTimings& tm) {
  const std::shared_ptr<const TensorPoints>& points = s.tensor_points;
  if (!points || !points->count()) return false;
  if (points != held_) {
    std::vector<float> interleaved(size_t(kFloatsPerPoint) * points->count());
    for (size_t i = 0; i < points->count(); ++i) {
      float* p = &interleaved[size_t(kFloatsPerPoint) * i];
      std::copy_n(&points->xyz[3 * i], 3, p);
      std::copy_n(&points->normal[3 * i], 3, p + 3);
      std::copy_n(&points->tangent[3 * i], 3, p + 6);
      p[9] = points->value[i];
    }
    glNamedBufferData(buffer_, static_cast<GLsizeiptr>(interleaved.size() * 4), interleaved.data(), GL_STATIC_DRAW);
    held_ = points;
  }
  tm.tensor_points = points->count();
  const Frame& f = view.frame;
  glUseProgram(program_);
  auto at = [&](const char* name) { return glGetUniformLocation(program_, name); };
  glUniformMatrix4fv(at("mvp"), 1, GL_FALSE, view.mvp.data());
  glUniform3f(at("eye"), float(f.eye[0]), float(f.eye[1]), float(f.eye[2]));
  glUniform3f(at("forward"), float(f.forward[0]), float(f.forward[1]), float(f.forward[2]));
  glUniform1i(at("ortho"), f.ortho);
  glUniform1i(at("by_class"), points->by_class);
  glUniform3fv(at("class_colors"), 3, kAnisotropyColors[0].data());
  glUniform1f(at("lo"), float(points->value_min));
  glUniform1f(at("inv_span"), float(1 / (points->value_max - points->value_min)));
  glUniform1f(at("size_px"), float(s.tensor_point_size));
  glUniform1f(at("diameter"), float(kCoverSpacings * points->spacing));
  glUniform1f(at("pixels_per_unit"), float(f.ortho ? view.height / (2 * f.half_height) : view.height / (2 * f.tan_half)));
  GLfloat range[2] = {1, 64};
  glGetFloatv(GL_POINT_SIZE_RANGE, range);
  glUniform1f(at("max_size"), std::min(range[1], float(kMaxPointSize)));
  glBindTextureUnit(0, view.colormap);
  glUniform1i(at("colormap"), 0);
  static constexpr GLenum kBoth[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, kBoth);
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glEnable(GL_PROGRAM_POINT_SIZE);
  glVertexArrayVertexBuffer(vao_, 0, buffer_, 0, kFloatsPerPoint * 4);
  glBindVertexArray(vao_);
  glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(points->count()));
  glDisable(GL_PROGRAM_POINT_SIZE);
  return true;
}

}  // namespace tetrascope::renderer
