// Point-based isosurfaces, dissertation §7.2 (after Sondershaus & Straßer 2005): many
// isosurfaces sampled by points, density by area, drawn as lit round splats. Points need no
// sorting: the gaps between splats let inner isosurfaces show through.
//
// Sampling (sample_isosurfaces): the marching-tets triangles of every isovalue; a triangle
// larger than the area A a point stands for is split into four by its edge midpoints until
// below A; a triangle t below A gives a point (its centroid) with probability |t| / A, so the
// expected density is 1/A everywhere. (§7.2 prints the test as D > |t|/A; that would keep
// small triangles more often than large ones, the opposite of density by area, so the point
// is kept when D < |t|/A.) The dice are a fixed table of 100 numbers, as §7.2 does.
//
// Lighting (§7.2): the triangle's normal, turned towards the observer, with the surfaces'
// headlight; colour by isovalue through the colormap. Splat size: fixed in pixels, or the
// disc of area A projected at the point's depth (x kCoverFactor, so random gaps close).
// Depth scaling (§7.2, optional): a point is drawn when its own die exceeds
// clamp(d / d_max, 0.1, 0.9), d its distance from the eye, d_max the mesh's diagonal.
#include <algorithm>
#include <cmath>
#include <random>
#include <thread>

#include "gl_shaders.h"
#include "lines.h"
#include "tetrascope/core/parallel_for.h"

namespace tetrascope::renderer {
namespace {

constexpr int kDiceCount = 100;
constexpr int kMaxSubdivisions = 10;           // 4^10 points from one triangle at most
constexpr double kCoverFactor = 1.5;           // covering splat diameter / the disc of area A
constexpr size_t kMaxCachedPointSets = 4;
constexpr uint32_t kDefaultPointIsovalues = 8;

const std::array<float, kDiceCount>& dice_table() {
  static const std::array<float, kDiceCount> table = [] {
    std::array<float, kDiceCount> t{};
    std::minstd_rand random(20050607);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (float& d : t) d = unit(random);
    return t;
  }();
  return table;
}

struct Sampler {
  double area;
  float value;
  uint64_t serial = 0;
  IsoPoints* out;
  void triangle(const Vec3& a, const Vec3& b, const Vec3& c, const Vec3& normal, int depth) {
    const double t = 0.5 * length(cross(b - a, c - a));
    if (t > area && depth < kMaxSubdivisions) {
      const Vec3 ab = (a + b) * 0.5, bc = (b + c) * 0.5, ca = (c + a) * 0.5;
      triangle(a, ab, ca, normal, depth + 1);
      triangle(ab, b, bc, normal, depth + 1);
      triangle(ca, bc, c, normal, depth + 1);
      triangle(ab, bc, ca, normal, depth + 1);
      return;
    }
    const auto& dice = dice_table();
    const uint64_t n = serial++;
    // two dice a triangle from the table, at indices that do not repeat in step
    if (dice[n % kDiceCount] >= t / area) return;
    const Vec3 centre = (a + b + c) * (1.0 / 3);
    for (int k = 0; k < 3; ++k) {
      out->xyz.push_back(static_cast<float>(centre[k]));
      out->normal.push_back(static_cast<float>(normal[k]));
    }
    out->value.push_back(value);
    out->dice.push_back(dice[(n * 37 + n / kDiceCount) % kDiceCount]);
  }
};

Vec3 corner(const std::vector<float>& tris, size_t i) { return {tris[3 * i], tris[3 * i + 1], tris[3 * i + 2]}; }

}  // namespace

std::vector<double> regular_isovalues(double lo, double hi, uint32_t n) {
  std::vector<double> out;
  for (uint32_t k = 1; k <= n; ++k) out.push_back(lo + (hi - lo) * k / (n + 1));
  return out;
}

IsoPoints sample_isosurfaces(const SceneMesh& mesh, const std::vector<double>& isovalues, double area, uint64_t target) {
  std::vector<std::vector<float>> tris(isovalues.size());
  std::vector<double> areas(isovalues.size());
  const unsigned workers = std::max(1u, std::thread::hardware_concurrency());
  parallel_for(isovalues.size(), workers, [&](size_t k, unsigned) {
    tris[k] = marching_tets(mesh, isovalues[k]);
    double sum = 0;
    for (size_t i = 0; i + 2 < tris[k].size() / 3; i += 3) sum += 0.5 * length(cross(corner(tris[k], i + 1) - corner(tris[k], i), corner(tris[k], i + 2) - corner(tris[k], i)));
    areas[k] = sum;
  });
  IsoPoints out;
  for (size_t k = 0; k < isovalues.size(); ++k) {
    out.total_area += areas[k];
    out.triangles += tris[k].size() / 9;
  }
  out.area = area > 0 ? area : out.total_area / double(std::max<uint64_t>(target, 1));
  if (!(out.area > 0)) return out;  // no isosurface at all
  for (size_t k = 0; k < isovalues.size(); ++k) {
    Sampler sampler{out.area, static_cast<float>(isovalues[k]), k * 7919, &out};
    const std::vector<float>& t = tris[k];
    for (size_t i = 0; i + 2 < t.size() / 3; i += 3) {
      const Vec3 a = corner(t, i), b = corner(t, i + 1), c = corner(t, i + 2);
      sampler.triangle(a, b, c, normalise(cross(b - a, c - a)), 0);
    }
  }
  return out;
}

void check_point_settings(const RenderSettings& s) {
  if (!s.points) return;
  if (!(s.point_area >= 0 && std::isfinite(s.point_area))) throw std::invalid_argument("point area must be 0 (automatic) or a positive area");
  if (s.point_area == 0 && s.point_target == 0) throw std::invalid_argument("point target must be at least 1");
  if (!(s.point_size >= 0 && s.point_size <= kMaxPointSize)) throw std::invalid_argument("point size must be 0 (covering) to " + std::to_string(int(kMaxPointSize)) + " pixels");
  for (double v : s.point_isovalues)
    if (!std::isfinite(v)) throw std::invalid_argument("point isovalues must be finite");
}

namespace {

const char* const kPointVertex = R"(#version 450 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal_in;
layout(location = 2) in float value;
layout(location = 3) in float dice;
uniform mat4 mvp;
uniform vec3 eye, forward;
uniform bool ortho;
uniform float size_px;          // > 0: this diameter
uniform float radius;           // else: a disc of this world radius, projected
uniform float pixels_per_unit;  // at distance 1 along `forward` (orthographic: everywhere)
uniform float max_size;
uniform bool depth_scaling;
uniform float d_max;
out vec3 world;
out vec3 normal;
out float v;
void main() {
  world = position;
  normal = normal_in;
  v = value;
  gl_Position = mvp * vec4(position, 1.0);
  if (depth_scaling && dice <= clamp(length(position - eye) / d_max, 0.1, 0.9)) gl_Position = vec4(2.0, 2.0, 2.0, 1.0);
  float depth = ortho ? 1.0 : max(dot(position - eye, forward), 1e-9);
  gl_PointSize = size_px > 0.0 ? size_px : clamp(2.0 * radius * pixels_per_unit / depth, 1.0, max_size);
}
)";

const char* const kPointFragment = R"(#version 450 core
in vec3 world;
in vec3 normal;
in float v;
uniform vec3 eye, forward;
uniform bool ortho;
uniform sampler1D colormap;
uniform float lo, inv_span;
layout(location = 0) out vec4 color;
layout(location = 1) out float distance_out;
void main() {
  vec2 q = gl_PointCoord * 2.0 - 1.0;
  if (dot(q, q) > 1.0) discard;
  vec3 d = ortho ? forward : normalize(world - eye);
  vec3 n = normalize(normal);
  if (dot(n, d) > 0.0) n = -n;  // towards the observer
  float light = 0.25 + 0.75 * max(0.0, -dot(n, d));
  color = vec4(texture(colormap, clamp((v - lo) * inv_span, 0.0, 1.0)).rgb * light, 1.0);
  distance_out = ortho ? dot(world - eye, forward) : length(world - eye);
}
)";

}  // namespace

PointIsoPass::PointIsoPass() {
  program_ = link_program(kPointVertex, kPointFragment);
  glCreateVertexArrays(1, &vao_);
  const GLint sizes[4] = {3, 3, 1, 1}, offsets[4] = {0, 12, 24, 28};
  for (GLuint a = 0; a < 4; ++a) {
    glEnableVertexArrayAttrib(vao_, a);
    glVertexArrayAttribFormat(vao_, a, sizes[a], GL_FLOAT, GL_FALSE, static_cast<GLuint>(offsets[a]));
    glVertexArrayAttribBinding(vao_, a, 0);
  }
}

PointIsoPass::~PointIsoPass() {
  for (auto& [key, u] : cache_) glDeleteBuffers(1, &u.buffer);
  glDeleteVertexArrays(1, &vao_);
  glDeleteProgram(program_);
}

void PointIsoPass::set_mesh(const SceneMesh& mesh) {
  mesh_ = &mesh;
  for (auto& [key, u] : cache_) glDeleteBuffers(1, &u.buffer);
  cache_.clear();
}

const PointIsoPass::Uploaded& PointIsoPass::points_for(const std::vector<double>& isovalues, double area, uint64_t target) {
  std::vector<double> key = isovalues;
  key.push_back(area);
  key.push_back(double(target));
  if (auto it = cache_.find(key); it != cache_.end()) return it->second;
  if (cache_.size() >= kMaxCachedPointSets) {
    for (auto& [k, u] : cache_) glDeleteBuffers(1, &u.buffer);
    cache_.clear();
  }
  const IsoPoints points = sample_isosurfaces(*mesh_, isovalues, area, target);
  std::vector<float> interleaved(8 * std::max<size_t>(points.count(), 1));
  for (size_t i = 0; i < points.count(); ++i) {
    for (int k = 0; k < 3; ++k) {
      interleaved[8 * i + k] = points.xyz[3 * i + k];
      interleaved[8 * i + 3 + k] = points.normal[3 * i + k];
    }
    interleaved[8 * i + 6] = points.value[i];
    interleaved[8 * i + 7] = points.dice[i];
  }
  Uploaded u;
  glCreateBuffers(1, &u.buffer);
  glNamedBufferData(u.buffer, static_cast<GLsizeiptr>(interleaved.size() * 4), interleaved.data(), GL_STATIC_DRAW);
  u.count = points.count();
  u.area = points.area;
  return cache_[key] = u;
}

bool PointIsoPass::draw(const PassView& view, const RenderSettings& s, FrameTimings& tm) {
  if (!mesh_) return false;
  const std::vector<double> isovalues = s.point_isovalues.empty() ? regular_isovalues(view.lo, view.hi, kDefaultPointIsovalues) : s.point_isovalues;
  const Uploaded& u = points_for(isovalues, s.point_area, s.point_target);
  tm.points = u.count;
  if (!u.count) return false;
  const Frame& f = view.frame;
  glUseProgram(program_);
  auto at = [&](const char* name) { return glGetUniformLocation(program_, name); };
  glUniformMatrix4fv(at("mvp"), 1, GL_FALSE, view.mvp.data());
  glUniform3f(at("eye"), float(f.eye[0]), float(f.eye[1]), float(f.eye[2]));
  glUniform3f(at("forward"), float(f.forward[0]), float(f.forward[1]), float(f.forward[2]));
  glUniform1i(at("ortho"), f.ortho);
  glUniform1f(at("lo"), float(view.lo));
  glUniform1f(at("inv_span"), float(1 / (view.hi - view.lo)));
  glUniform1f(at("size_px"), float(s.point_size));
  glUniform1f(at("radius"), float(kCoverFactor * std::sqrt(u.area / M_PI)));
  glUniform1f(at("pixels_per_unit"), float(f.ortho ? view.height / (2 * f.half_height) : view.height / (2 * f.tan_half)));
  GLfloat range[2] = {1, 64};
  glGetFloatv(GL_POINT_SIZE_RANGE, range);
  glUniform1f(at("max_size"), std::min(range[1], float(kMaxPointSize)));
  glUniform1i(at("depth_scaling"), s.point_depth_scaling);
  glUniform1f(at("d_max"), float(mesh_->diagonal));
  glBindTextureUnit(0, view.colormap);
  glUniform1i(at("colormap"), 0);
  static constexpr GLenum kBoth[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
  glDrawBuffers(2, kBoth);
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_TRUE);
  glDisable(GL_BLEND);
  glEnable(GL_PROGRAM_POINT_SIZE);
  glVertexArrayVertexBuffer(vao_, 0, u.buffer, 0, 32);
  glBindVertexArray(vao_);
  glDrawArrays(GL_POINTS, 0, static_cast<GLsizei>(u.count));
  glDisable(GL_PROGRAM_POINT_SIZE);
  return true;
}

}  // namespace tetrascope::renderer
