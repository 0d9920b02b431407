// The EGL + OpenGL 4.5 core renderer.
#define GL_GLEXT_PROTOTYPES 1
#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <map>
#include <thread>

#include "camera_math.h"
#include "tetrascope/renderer/render.h"

namespace tetrascope::renderer {
namespace {

using clock_type = std::chrono::steady_clock;
double ms_since(clock_type::time_point t) { return std::chrono::duration<double, std::milli>(clock_type::now() - t).count(); }

// Per tet, precomputed once per mesh: its four outward face planes and its linear field
// (gradient, offset) in attribute units: five vec4 a tet. Drawn indexed: the 12 face corners
// of a tet index its 4 vertices, so a vertex cache runs 4 vertex shaders a tet, not 12.
const char* kTetVertex = R"(#version 450 core
layout(std430, binding = 0) readonly buffer Vertices { vec4 vertices[]; };
layout(std430, binding = 1) readonly buffer Tets { uvec4 tets[]; };
layout(std430, binding = 2) readonly buffer Order { uint order[]; };
layout(std430, binding = 3) readonly buffer Cells { vec4 cells[]; };
uniform mat4 mvp;
uniform uint first_slot;
out vec3 world;
flat out vec4 plane0, plane1, plane2, plane3, field;
void main() {
  uint slot = first_slot + uint(gl_VertexID) / 4u;
  uint tet = order[slot];
  uint corner = uint(gl_VertexID) % 4u;
  world = vertices[tets[tet][corner]].xyz;
  plane0 = cells[5u * tet];
  plane1 = cells[5u * tet + 1u];
  plane2 = cells[5u * tet + 2u];
  plane3 = cells[5u * tet + 3u];
  field = cells[5u * tet + 4u];
  gl_Position = mvp * vec4(world, 1.0);
}
)";

const char* kTetFragment = R"(#version 450 core
in vec3 world;
flat in vec4 plane0, plane1, plane2, plane3, field;
uniform vec3 eye, forward;
uniform bool ortho;
uniform float lo, inv_span;
uniform sampler3D table;
uniform float max_length, table_n, table_lengths;
uniform bool clip_depth;
uniform sampler2D depth_limit;   // distance along the ray to the nearest opaque surface
uniform vec2 viewport;
out vec4 color;
void exit_of(vec4 pl, vec3 d, inout float t) {
  float dn = dot(pl.xyz, d);
  if (dn > 1e-20) t = min(t, -(dot(pl.xyz, world) + pl.w) / dn);
}
void main() {
  vec3 d = ortho ? forward : normalize(world - eye);
  float t = 3.4e38;
  exit_of(plane0, d, t);
  exit_of(plane1, d, t);
  exit_of(plane2, d, t);
  exit_of(plane3, d, t);
  t = max(t, 0.0);
  if (clip_depth) {
    float limit = texture(depth_limit, gl_FragCoord.xy / viewport).r;
    float here = ortho ? dot(world - eye, forward) : length(world - eye);
    t = min(t, max(limit - here, 0.0));
  }
  float sf = (dot(field.xyz, world) + field.w - lo) * inv_span;
  float sb = sf + dot(field.xyz, d) * t * inv_span;
  vec3 uvw = vec3((clamp(sf, 0.0, 1.0) * (table_n - 1.0) + 0.5) / table_n, (clamp(sb, 0.0, 1.0) * (table_n - 1.0) + 0.5) / table_n,
                  (clamp(t / max_length, 0.0, 1.0) * (table_lengths - 1.0) + 0.5) / table_lengths);
  color = texture(table, uvw);
}
)";

const char* kSurfaceVertex = R"(#version 450 core
layout(location = 0) in vec3 position;
layout(location = 1) in float value;
uniform mat4 mvp;
out vec3 world;
out float v;
void main() {
  world = position;
  v = value;
  gl_Position = mvp * vec4(position, 1.0);
}
)";

const char* kSurfaceFragment = R"(#version 450 core
in vec3 world;
in float v;
uniform vec3 eye, forward;
uniform bool ortho;
uniform sampler1D colormap;
uniform float lo, inv_span;
uniform vec4 solid;   // a >= 0: this colour instead of the colormap
uniform float opacity = 1.0;  // premultiplied output
uniform float depth_out; // 1: write the distance along the ray into the colour's alpha target 1
layout(location = 0) out vec4 color;
layout(location = 1) out float distance_out;
void main() {
  vec3 n = normalize(cross(dFdx(world), dFdy(world)));
  vec3 d = ortho ? forward : normalize(world - eye);
  float light = 0.25 + 0.75 * abs(dot(n, d));
  vec3 base = solid.a >= 0.0 ? solid.rgb : texture(colormap, clamp((v - lo) * inv_span, 0.0, 1.0)).rgb;
  color = vec4(base * light * opacity, opacity);
  distance_out = ortho ? dot(world - eye, forward) : length(world - eye);
}
)";

const char* kLineFragment = R"(#version 450 core
uniform vec4 solid;
layout(location = 0) out vec4 color;
layout(location = 1) out float distance_out;
void main() { color = solid; distance_out = 3.4e38; }
)";

GLuint compile(GLenum type, const char* source) {
  GLuint shader = glCreateShader(type);
  glShaderSource(shader, 1, &source, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(shader, sizeof log, nullptr, log);
    throw RenderError(std::string("shader does not compile: ") + log);
  }
  return shader;
}

GLuint program(const char* vs, const char* fs) {
  GLuint p = glCreateProgram();
  GLuint a = compile(GL_VERTEX_SHADER, vs), b = compile(GL_FRAGMENT_SHADER, fs);
  glAttachShader(p, a);
  glAttachShader(p, b);
  glLinkProgram(p);
  glDeleteShader(a);
  glDeleteShader(b);
  GLint ok = 0;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetProgramInfoLog(p, sizeof log, nullptr, log);
    throw RenderError(std::string("shaders do not link: ") + log);
  }
  return p;
}

class GlRenderer final : public Renderer {
 public:
  GlRenderer() {
    open_display();
    tet_program_ = program(kTetVertex, kTetFragment);
    surface_program_ = program(kSurfaceVertex, kSurfaceFragment);
    line_program_ = program(kSurfaceVertex, kLineFragment);
    glCreateVertexArrays(1, &empty_vao_);
    glCreateVertexArrays(1, &surface_vao_);
    glCreateBuffers(1, &surface_buffer_);
    glCreateBuffers(1, &line_buffer_);
    glCreateVertexArrays(1, &line_vao_);
    for (GLuint vao : {surface_vao_, line_vao_}) {
      glEnableVertexArrayAttrib(vao, 0);
      glEnableVertexArrayAttrib(vao, 1);
      glVertexArrayAttribFormat(vao, 0, 3, GL_FLOAT, GL_FALSE, 0);
      glVertexArrayAttribFormat(vao, 1, 1, GL_FLOAT, GL_FALSE, 12);
      glVertexArrayAttribBinding(vao, 0, 0);
      glVertexArrayAttribBinding(vao, 1, 0);
    }
    glVertexArrayVertexBuffer(surface_vao_, 0, surface_buffer_, 0, 16);
    glVertexArrayVertexBuffer(line_vao_, 0, line_buffer_, 0, 16);
    glCreateTextures(GL_TEXTURE_1D, 1, &colormap_texture_);
    glTextureStorage1D(colormap_texture_, 1, GL_RGBA8, 256);
    glTextureParameteri(colormap_texture_, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(colormap_texture_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(colormap_texture_, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  }
  ~GlRenderer() override {
    if (display_ != EGL_NO_DISPLAY) {
      eglMakeCurrent(display_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
      if (context_ != EGL_NO_CONTEXT) eglDestroyContext(display_, context_);
      eglTerminate(display_);
    }
  }

  std::string description() const override {
    return std::string(reinterpret_cast<const char*>(glGetString(GL_VENDOR))) + ", " + reinterpret_cast<const char*>(glGetString(GL_RENDERER)) + ", OpenGL " +
           reinterpret_cast<const char*>(glGetString(GL_VERSION));
  }

  void set_mesh(const SceneMesh& mesh) override {
    mesh_ = &mesh;
    std::vector<float> vertices(4 * (mesh.xyz.size() / 3));
    for (size_t v = 0; v < mesh.xyz.size() / 3; ++v) {
      std::copy_n(&mesh.xyz[3 * v], 3, &vertices[4 * v]);
      vertices[4 * v + 3] = mesh.value[v];
    }
    upload(vertex_buffer_, vertices.data(), vertices.size() * 4);
    upload(tet_buffer_, mesh.tets.data(), mesh.tets.size() * 4);
    const size_t tets = mesh.tets.size() / 4;
    upload(order_buffer_, nullptr, std::max<size_t>(tets, 1) * 4);
    std::vector<float> cells(20 * tets);
    const int F[4][3] = {{1, 2, 3}, {0, 3, 2}, {0, 1, 3}, {0, 2, 1}};
    for (size_t t = 0; t < tets; ++t) {
      V3 p[4];
      double value[4];
      for (int k = 0; k < 4; ++k) {
        const uint32_t v = mesh.tets[4 * t + k];
        p[k] = {mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2]};
        value[k] = mesh.value[v];
      }
      float* c = &cells[20 * t];
      for (int f = 0; f < 4; ++f) {
        const V3 n = normalise(cross(sub(p[F[f][1]], p[F[f][0]]), sub(p[F[f][2]], p[F[f][0]])));
        c[4 * f] = static_cast<float>(n[0]);
        c[4 * f + 1] = static_cast<float>(n[1]);
        c[4 * f + 2] = static_cast<float>(n[2]);
        c[4 * f + 3] = static_cast<float>(-dot(n, p[F[f][0]]));
      }
      const V3 e1 = sub(p[1], p[0]), e2 = sub(p[2], p[0]), e3 = sub(p[3], p[0]);
      const double det = dot(e1, cross(e2, e3));
      V3 g{0, 0, 0};
      if (std::fabs(det) > 0) {
        const V3 c23 = cross(e2, e3), c31 = cross(e3, e1), c12 = cross(e1, e2);
        for (int k = 0; k < 3; ++k) g[k] = ((value[1] - value[0]) * c23[k] + (value[2] - value[0]) * c31[k] + (value[3] - value[0]) * c12[k]) / det;
      }
      c[16] = static_cast<float>(g[0]);
      c[17] = static_cast<float>(g[1]);
      c[18] = static_cast<float>(g[2]);
      c[19] = static_cast<float>(value[0] - dot(g, p[0]));
    }
    upload(cell_buffer_, cells.data(), cells.size() * 4);
    if (!index_buffer_) {  // 12 face corners a tet slot, indexing its 4 vertices
      std::vector<uint32_t> indices(12 * size_t{kSlotsPerDraw});
      for (uint32_t i = 0; i < kSlotsPerDraw; ++i)
        for (int f = 0; f < 4; ++f)
          for (int k = 0; k < 3; ++k) indices[12 * size_t{i} + 3 * f + k] = 4 * i + static_cast<uint32_t>(F[f][k]);
      upload(index_buffer_, indices.data(), indices.size() * 4);
    }
    centroid_.resize(3 * tets);
    range_.resize(2 * tets);
    for (size_t t = 0; t < tets; ++t) {
      float lo = 3.4e38f, hi = -3.4e38f;
      for (int k = 0; k < 3; ++k) centroid_[3 * t + k] = 0;
      for (int j = 0; j < 4; ++j) {
        const uint32_t v = mesh.tets[4 * t + j];
        for (int k = 0; k < 3; ++k) centroid_[3 * t + k] += 0.25f * mesh.xyz[3 * size_t{v} + k];
        lo = std::min(lo, mesh.value[v]);
        hi = std::max(hi, mesh.value[v]);
      }
      range_[2 * t] = lo;
      range_[2 * t + 1] = hi;
    }
    // boundary triangles (position + value) and boundary edges with their two faces
    std::vector<float> surface;
    surface.reserve(mesh.boundary.size() * 12);
    std::map<std::pair<uint32_t, uint32_t>, std::array<uint32_t, 2>> edges;
    for (uint32_t f = 0; f < mesh.boundary.size(); ++f) {
      const auto& tri = mesh.boundary[f];
      for (int i = 0; i < 3; ++i) {
        const uint32_t v = tri[i];
        surface.insert(surface.end(), {mesh.xyz[3 * size_t{v}], mesh.xyz[3 * size_t{v} + 1], mesh.xyz[3 * size_t{v} + 2], mesh.value[v]});
        auto key = std::minmax(tri[i], tri[(i + 1) % 3]);
        auto [it, inserted] = edges.try_emplace({key.first, key.second}, std::array<uint32_t, 2>{f, 0xFFFFFFFFu});
        if (!inserted) it->second[1] = f;
      }
    }
    glNamedBufferData(surface_buffer_, static_cast<GLsizeiptr>(surface.size() * 4), surface.data(), GL_STATIC_DRAW);
    surface_vertices_ = static_cast<GLsizei>(surface.size() / 4);
    edges_.clear();
    for (const auto& [e, faces] : edges) edges_.push_back({e.first, e.second, faces[0], faces[1]});
    iso_cache_.clear();
  }

  Image render(const RenderSettings& s, FrameTimings* timings) override {
    if (!mesh_) throw RenderError("no mesh set");
    if (s.width < 1 || s.height < 1 || s.width > 8192 || s.height > 8192) throw std::invalid_argument("image size must be 1..8192 a side");
    const SceneMesh& mesh = *mesh_;
    FrameTimings local;
    FrameTimings& tm = timings ? *timings : local;
    tm = FrameTimings();
    const auto start = clock_type::now();
    ensure_framebuffer(s.width, s.height);
    const Frame frame = camera_frame(s.camera, s.width, s.height);
    const double distance = std::sqrt(dot(sub(V3{(mesh.bounds.min[0] + mesh.bounds.max[0]) / 2, (mesh.bounds.min[1] + mesh.bounds.max[1]) / 2,
                                                   (mesh.bounds.min[2] + mesh.bounds.max[2]) / 2}, frame.eye),
                                              sub(V3{(mesh.bounds.min[0] + mesh.bounds.max[0]) / 2, (mesh.bounds.min[1] + mesh.bounds.max[1]) / 2,
                                                     (mesh.bounds.min[2] + mesh.bounds.max[2]) / 2}, frame.eye)));
    const double far_plane = distance + mesh.diagonal, near_plane = std::max(far_plane * 1e-5, distance - mesh.diagonal);
    const std::array<float, 16> mvp = view_projection(frame, frame.ortho ? distance - mesh.diagonal : near_plane, far_plane);
    double lo = mesh.value_min, hi = mesh.value_max;
    if (s.tf.range) {
      lo = (*s.tf.range)[0];
      hi = (*s.tf.range)[1];
    }
    if (!(hi > lo)) hi = lo + 1;
    if (!known_colormap(s.tf.colormap)) throw std::invalid_argument("unknown colormap '" + s.tf.colormap + "' (viridis, plasma, cool-warm, grayscale)");
    update_colormap(s.tf, lo, hi);

    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
    glViewport(0, 0, static_cast<GLsizei>(s.width), static_cast<GLsizei>(s.height));
    const GLenum both[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glDrawBuffers(2, both);
    const float bg[4] = {s.background[0], s.background[1], s.background[2], 1};
    const float far_value[4] = {3.4e38f, 0, 0, 0};
    glClearBufferfv(GL_COLOR, 0, bg);
    glClearBufferfv(GL_COLOR, 1, far_value);
    glClearDepth(1.0);
    glClear(GL_DEPTH_BUFFER_BIT);
    glEnable(GL_DEPTH_TEST);
    glDepthFunc(GL_LEQUAL);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    bool opaque = false;
    // ---- opaque parts: boundary surface, isosurfaces, lines ----
    auto common = [&](GLuint p) {
      glUseProgram(p);
      glUniformMatrix4fv(glGetUniformLocation(p, "mvp"), 1, GL_FALSE, mvp.data());
      glUniform3f(glGetUniformLocation(p, "eye"), float(frame.eye[0]), float(frame.eye[1]), float(frame.eye[2]));
      glUniform3f(glGetUniformLocation(p, "forward"), float(frame.forward[0]), float(frame.forward[1]), float(frame.forward[2]));
      glUniform1i(glGetUniformLocation(p, "ortho"), frame.ortho);
      glUniform1f(glGetUniformLocation(p, "lo"), float(lo));
      glUniform1f(glGetUniformLocation(p, "inv_span"), float(1 / (hi - lo)));
    };
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1, 1);
    if (s.surface) {
      common(surface_program_);
      glUniform4f(glGetUniformLocation(surface_program_, "solid"), 0, 0, 0, -1);
      glBindTextureUnit(0, colormap_texture_);
      glUniform1i(glGetUniformLocation(surface_program_, "colormap"), 0);
      glBindVertexArray(surface_vao_);
      glDrawArrays(GL_TRIANGLES, 0, surface_vertices_);
      opaque = true;
    }
    if (!(s.iso_opacity > 0 && s.iso_opacity <= 1)) throw std::invalid_argument("isosurface opacity must be in (0, 1]");
    const bool translucent_iso = s.iso && !s.dvr && s.iso_opacity < 1;
    const bool by_second = s.iso_by_second;
    if (by_second && mesh.second.size() != mesh.value.size()) throw std::invalid_argument("isosurfaces coloured by a second attribute need a scene built with one");
    // the isosurface's colour range: the second attribute's, or the transfer function's
    auto iso_range = [&](GLuint p) {
      if (!by_second) return;
      const double span = mesh.second_max > mesh.second_min ? mesh.second_max - mesh.second_min : 1.0;
      glUniform1f(glGetUniformLocation(p, "lo"), float(mesh.second_min));
      glUniform1f(glGetUniformLocation(p, "inv_span"), float(1 / span));
    };
    if (s.iso && !s.isovalues.empty() && !translucent_iso) {
      std::vector<float>& tris = iso_triangles(s.isovalues, by_second);
      glNamedBufferData(line_buffer_, static_cast<GLsizeiptr>(tris.size() * 4), tris.data(), GL_STREAM_DRAW);
      common(surface_program_);
      iso_range(surface_program_);
      glUniform4f(glGetUniformLocation(surface_program_, "solid"), 0, 0, 0, -1);
      glBindTextureUnit(0, colormap_texture_);
      glUniform1i(glGetUniformLocation(surface_program_, "colormap"), 0);
      glBindVertexArray(line_vao_);
      glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(tris.size() / 4));
      tm.iso_triangles = tris.size() / 12;
      opaque = true;
    }
    glDisable(GL_POLYGON_OFFSET_FILL);
    std::vector<float> lines;
    if (s.surface) silhouettes(frame, s.wireframe, lines);
    if (s.box) box_lines(lines);
    if (!lines.empty()) {
      glNamedBufferData(line_buffer_, static_cast<GLsizeiptr>(lines.size() * 4), lines.data(), GL_STREAM_DRAW);
      common(line_program_);
      glUniform4f(glGetUniformLocation(line_program_, "solid"), 0.02f, 0.02f, 0.02f, 1);
      glBindVertexArray(line_vao_);
      glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(lines.size() / 4));
    }
    // ---- semi-transparent isosurfaces: triangles sorted back to front, blended ----
    if (translucent_iso && !s.isovalues.empty()) {
      const std::vector<float>& tris = iso_triangles(s.isovalues, by_second);
      const size_t count = tris.size() / 12;
      std::vector<std::pair<float, uint32_t>> depth(count);
      for (size_t i = 0; i < count; ++i) {
        double d = 0;
        for (int k = 0; k < 3; ++k) {
          const double c = (tris[12 * i + k] + tris[12 * i + 4 + k] + tris[12 * i + 8 + k]) / 3 - frame.eye[k];
          d += frame.ortho ? c * frame.forward[k] : c * c;
        }
        depth[i] = {static_cast<float>(-d), static_cast<uint32_t>(i)};
      }
      std::sort(depth.begin(), depth.end());
      std::vector<float> sorted(tris.size());
      for (size_t i = 0; i < count; ++i) std::copy_n(&tris[12 * size_t{depth[i].second}], 12, &sorted[12 * i]);
      glNamedBufferData(line_buffer_, static_cast<GLsizeiptr>(sorted.size() * 4), sorted.data(), GL_STREAM_DRAW);
      glDrawBuffers(1, both);
      common(surface_program_);
      iso_range(surface_program_);
      glUniform4f(glGetUniformLocation(surface_program_, "solid"), 0, 0, 0, -1);
      glUniform1f(glGetUniformLocation(surface_program_, "opacity"), float(s.iso_opacity));
      glBindTextureUnit(0, colormap_texture_);
      glUniform1i(glGetUniformLocation(surface_program_, "colormap"), 0);
      glEnable(GL_BLEND);
      glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
      glDepthMask(GL_FALSE);
      glBindVertexArray(line_vao_);
      glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(sorted.size() / 4));
      glDepthMask(GL_TRUE);
      glDisable(GL_BLEND);
      glUniform1f(glGetUniformLocation(surface_program_, "opacity"), 1.0f);
      tm.iso_triangles = count;
    }
    // ---- volume ----
    if (s.dvr && !mesh.tets.empty()) {
      const double unit = s.unit_distance > 0 ? s.unit_distance : mesh.diagonal / 100;
      update_table(s.tf, lo, hi, unit, mesh.max_edge);
      const auto sort_start = clock_type::now();
      const uint32_t count = visibility_order(lo, hi, frame, tm);
      tm.sort_ms = ms_since(sort_start);
      if (count) {
        glNamedBufferSubData(order_buffer_, 0, count * 4, order_.data());
        if (opaque) {  // the distance to the opaque surfaces limits the rays
          glCopyImageSubData(distance_texture_, GL_TEXTURE_2D, 0, 0, 0, 0, distance_copy_, GL_TEXTURE_2D, 0, 0, 0, 0, static_cast<GLsizei>(s.width),
                             static_cast<GLsizei>(s.height), 1);
        }
        glDrawBuffers(1, both);
        glUseProgram(tet_program_);
        common(tet_program_);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, vertex_buffer_);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, tet_buffer_);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, order_buffer_);
        glBindTextureUnit(1, table_texture_);
        glUniform1i(glGetUniformLocation(tet_program_, "table"), 1);
        glBindTextureUnit(2, distance_copy_);
        glUniform1i(glGetUniformLocation(tet_program_, "depth_limit"), 2);
        glUniform1i(glGetUniformLocation(tet_program_, "clip_depth"), opaque);
        glUniform2f(glGetUniformLocation(tet_program_, "viewport"), float(s.width), float(s.height));
        glUniform1f(glGetUniformLocation(tet_program_, "max_length"), float(table_.max_length));
        glUniform1f(glGetUniformLocation(tet_program_, "table_n"), float(table_.n));
        glUniform1f(glGetUniformLocation(tet_program_, "table_lengths"), float(table_.lengths));
        glEnable(GL_CULL_FACE);
        glCullFace(GL_BACK);
        glFrontFace(GL_CCW);
        glEnable(GL_BLEND);
        glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // back to front, premultiplied
        glDepthMask(GL_FALSE);
        glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, cell_buffer_);
        glBindVertexArray(empty_vao_);
        glVertexArrayElementBuffer(empty_vao_, index_buffer_);
        const GLint first_slot = glGetUniformLocation(tet_program_, "first_slot");
        for (uint32_t first = 0; first < count; first += kSlotsPerDraw) {
          glUniform1ui(first_slot, first);
          glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(12 * std::min(kSlotsPerDraw, count - first)), GL_UNSIGNED_INT, nullptr);
        }
        glDepthMask(GL_TRUE);
        glDisable(GL_BLEND);
        glDisable(GL_CULL_FACE);
      }
    }
    // ---- readback through a pixel buffer ----
    const auto draw_done = clock_type::now();
    glFinish();
    tm.draw_ms = ms_since(start) - tm.sort_ms;
    const auto read_start = clock_type::now();
    Image image{s.width, s.height, std::vector<uint8_t>(size_t{s.width} * s.height * 4)};
    glBindBuffer(GL_PIXEL_PACK_BUFFER, pack_buffer_);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, static_cast<GLsizei>(s.width), static_cast<GLsizei>(s.height), GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    const uint8_t* pixels = static_cast<const uint8_t*>(glMapBufferRange(GL_PIXEL_PACK_BUFFER, 0, static_cast<GLsizeiptr>(image.rgba.size()), GL_MAP_READ_BIT));
    if (!pixels) throw RenderError("cannot map the pixel buffer");
    const size_t row = size_t{s.width} * 4;
    for (uint32_t y = 0; y < s.height; ++y) std::memcpy(&image.rgba[y * row], pixels + (s.height - 1 - y) * row, row);
    glUnmapBuffer(GL_PIXEL_PACK_BUFFER);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    (void)draw_done;
    tm.readback_ms = ms_since(read_start);
    tm.total_ms = ms_since(start);
    if (GLenum error = glGetError(); error != GL_NO_ERROR) throw RenderError("OpenGL error " + std::to_string(error));
    return image;
  }

 private:
  void open_display() {
    // llvmpipe: rasterising threads overlap its single-threaded vertex stage; two a core
    // drew the sample 15% faster than one a core (one run: 291 against 340 ms). A user's setting wins.
    if (!std::getenv("LP_NUM_THREADS")) {
      const unsigned threads = std::min(32u, 2 * std::max(1u, std::thread::hardware_concurrency()));
      setenv("LP_NUM_THREADS", std::to_string(threads).c_str(), 0);
    }
    auto get_platform_display = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(eglGetProcAddress("eglGetPlatformDisplayEXT"));
    auto query_devices = reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(eglGetProcAddress("eglQueryDevicesEXT"));
    auto query_device_string = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(eglGetProcAddress("eglQueryDeviceStringEXT"));
    std::vector<EGLDisplay> candidates;
    std::string tried;
    if (get_platform_display && query_devices) {
      EGLDeviceEXT devices[16];
      EGLint count = 0;
      if (query_devices(16, devices, &count)) {
        // hardware devices first, Mesa's software device last
        std::vector<std::pair<bool, EGLDeviceEXT>> order;
        for (EGLint i = 0; i < count; ++i) {
          const char* ext = query_device_string ? query_device_string(devices[i], EGL_EXTENSIONS) : nullptr;
          order.push_back({ext && std::strstr(ext, "EGL_MESA_device_software"), devices[i]});
        }
        std::stable_sort(order.begin(), order.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
        for (auto& [software, device] : order) candidates.push_back(get_platform_display(EGL_PLATFORM_DEVICE_EXT, device, nullptr));
      }
      tried += std::to_string(count) + " EGL device(s)";
    }
    if (get_platform_display) candidates.push_back(get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr));
    for (EGLDisplay d : candidates) {
      if (d == EGL_NO_DISPLAY) continue;
      EGLint major = 0, minor = 0;
      if (!eglInitialize(d, &major, &minor)) continue;
      if (!eglBindAPI(EGL_OPENGL_API)) {
        eglTerminate(d);
        continue;
      }
      const EGLint config_attributes[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
      EGLConfig config = nullptr;
      EGLint configs = 0;
      eglChooseConfig(d, config_attributes, &config, 1, &configs);
      const EGLint context_attributes[] = {EGL_CONTEXT_MAJOR_VERSION, 4, EGL_CONTEXT_MINOR_VERSION, 5, EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                           EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
      EGLContext c = eglCreateContext(d, configs ? config : EGL_NO_CONFIG_KHR, EGL_NO_CONTEXT, context_attributes);
      if (c == EGL_NO_CONTEXT) {
        tried += "; a display without an OpenGL 4.5 core context";
        eglTerminate(d);
        continue;
      }
      if (!eglMakeCurrent(d, EGL_NO_SURFACE, EGL_NO_SURFACE, c)) {
        eglDestroyContext(d, c);
        eglTerminate(d);
        continue;
      }
      display_ = d;
      context_ = c;
      return;
    }
    throw RenderError("no EGL device with OpenGL 4.5 core could be opened (tried " + (tried.empty() ? std::string("none") : tried) +
                      " and Mesa's surfaceless platform); install libegl-mesa0 and libgl1-mesa-dri, or the NVIDIA driver's EGL");
  }

  void upload(GLuint& buffer, const void* data, size_t bytes) {
    if (!buffer) glCreateBuffers(1, &buffer);
    glNamedBufferData(buffer, static_cast<GLsizeiptr>(std::max<size_t>(bytes, 4)), data, GL_STATIC_DRAW);
  }

  void ensure_framebuffer(uint32_t w, uint32_t h) {
    if (w == fb_width_ && h == fb_height_) return;
    if (framebuffer_) {
      glDeleteFramebuffers(1, &framebuffer_);
      glDeleteRenderbuffers(1, &color_);
      glDeleteTextures(1, &depth_);
      glDeleteTextures(1, &distance_texture_);
      glDeleteTextures(1, &distance_copy_);
      glDeleteBuffers(1, &pack_buffer_);
    }
    glCreateFramebuffers(1, &framebuffer_);
    glCreateRenderbuffers(1, &color_);
    glNamedRenderbufferStorage(color_, GL_RGBA8, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
    glCreateTextures(GL_TEXTURE_2D, 1, &depth_);
    glTextureStorage2D(depth_, 1, GL_DEPTH_COMPONENT32F, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
    for (GLuint* t : {&distance_texture_, &distance_copy_}) {
      glCreateTextures(GL_TEXTURE_2D, 1, t);
      glTextureStorage2D(*t, 1, GL_R32F, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
      glTextureParameteri(*t, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
      glTextureParameteri(*t, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    }
    glNamedFramebufferRenderbuffer(framebuffer_, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color_);
    glNamedFramebufferTexture(framebuffer_, GL_COLOR_ATTACHMENT1, distance_texture_, 0);
    glNamedFramebufferTexture(framebuffer_, GL_DEPTH_ATTACHMENT, depth_, 0);
    if (glCheckNamedFramebufferStatus(framebuffer_, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) throw RenderError("framebuffer incomplete");
    glCreateBuffers(1, &pack_buffer_);
    glNamedBufferData(pack_buffer_, static_cast<GLsizeiptr>(size_t{w} * h * 4), nullptr, GL_STREAM_READ);
    fb_width_ = w;
    fb_height_ = h;
  }

  // the colour texture over [lo, hi]: the named colormap, or the user's colour points
  void update_colormap(const lod::TransferFunction& tf, double lo, double hi) {
    std::string key = tf.colormap;
    if (!tf.colors.empty()) key = tf.to_json()["colors"].dump() + "|" + std::to_string(lo) + "|" + std::to_string(hi);
    if (key == colormap_name_) return;
    std::vector<uint8_t> texels(256 * 4);
    for (int i = 0; i < 256; ++i) {
      auto c = tf.colors.empty() ? colormap(tf.colormap, i / 255.0) : tf.user_color(lo + (hi - lo) * i / 255.0);
      for (int k = 0; k < 3; ++k) texels[4 * i + k] = static_cast<uint8_t>(std::lround(c[k] * 255));
      texels[4 * i + 3] = 255;
    }
    glTextureSubImage1D(colormap_texture_, 0, 0, 256, GL_RGBA, GL_UNSIGNED_BYTE, texels.data());
    colormap_name_ = key;
  }

  void update_table(const lod::TransferFunction& tf, double lo, double hi, double unit, double max_length) {
    const std::string key = tf.to_json().dump() + "|" + std::to_string(lo) + "|" + std::to_string(hi) + "|" + std::to_string(unit) + "|" + std::to_string(max_length);
    if (key == table_key_) return;
    table_ = preintegrate(tf, lo, hi, unit, std::max(max_length, 1e-30));
    if (!table_texture_) {
      glCreateTextures(GL_TEXTURE_3D, 1, &table_texture_);
      glTextureStorage3D(table_texture_, 1, GL_RGBA16F, static_cast<GLsizei>(table_.n), static_cast<GLsizei>(table_.n), static_cast<GLsizei>(table_.lengths));
      glTextureParameteri(table_texture_, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTextureParameteri(table_texture_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) glTextureParameteri(table_texture_, w, GL_CLAMP_TO_EDGE);
    }
    glTextureSubImage3D(table_texture_, 0, 0, 0, 0, static_cast<GLsizei>(table_.n), static_cast<GLsizei>(table_.n), static_cast<GLsizei>(table_.lengths),
                        GL_RGBA, GL_FLOAT, table_.rgba.data());
    // which normalised value slots are fully transparent (tets entirely in them are skipped)
    visible_prefix_.assign(kSlots + 1, 0);
    for (int i = 0; i < kSlots; ++i) {
      const double a0 = tf.alpha(lo + (hi - lo) * i / kSlots), a1 = tf.alpha(lo + (hi - lo) * (i + 1) / kSlots);
      visible_prefix_[i + 1] = visible_prefix_[i] + (a0 > 0 || a1 > 0);
    }
    table_key_ = key;
  }

  // Tets that can show, sorted back to front by centroid depth (LSD radix sort on the key).
  uint32_t visibility_order(double lo, double hi, const Frame& f, FrameTimings& tm) {
    const size_t tets = centroid_.size() / 3;
    keys_.clear();
    ids_.clear();
    const double scale = kSlots / (hi - lo);
    for (size_t t = 0; t < tets; ++t) {
      int a = static_cast<int>(std::floor((range_[2 * t] - lo) * scale)), b = static_cast<int>(std::floor((range_[2 * t + 1] - lo) * scale));
      a = std::clamp(a, 0, kSlots - 1);
      b = std::clamp(b, 0, kSlots - 1);
      if (visible_prefix_[b + 1] - visible_prefix_[a] == 0) {
        ++tm.tets_skipped;
        continue;
      }
      const float* c = &centroid_[3 * t];
      const double dx = c[0] - f.eye[0], dy = c[1] - f.eye[1], dz = c[2] - f.eye[2];
      const double depth = f.ortho ? dx * f.forward[0] + dy * f.forward[1] + dz * f.forward[2] : dx * dx + dy * dy + dz * dz;
      // larger depth first: sort ascending on the complement of the float's order-preserving bits
      uint32_t bits;
      const float fd = static_cast<float>(depth);
      std::memcpy(&bits, &fd, 4);
      bits = (bits & 0x80000000u) ? ~bits : bits | 0x80000000u;
      keys_.push_back(~bits);
      ids_.push_back(static_cast<uint32_t>(t));
    }
    const size_t n = keys_.size();
    keys2_.resize(n);
    ids2_.resize(n);
    for (int shift = 0; shift < 32; shift += 11) {
      uint32_t count[2049] = {};
      for (uint32_t k : keys_) ++count[((k >> shift) & 2047) + 1];
      for (int i = 0; i < 2048; ++i) count[i + 1] += count[i];
      for (size_t i = 0; i < n; ++i) {
        const uint32_t slot = count[(keys_[i] >> shift) & 2047]++;
        keys2_[slot] = keys_[i];
        ids2_[slot] = ids_[i];
      }
      keys_.swap(keys2_);
      ids_.swap(ids2_);
    }
    order_ = ids_;
    tm.tets_drawn = n;
    return static_cast<uint32_t>(n);
  }

  // Isosurface triangles as (x, y, z, value) corners; value = the isovalue, or the second
  // attribute interpolated at the corner.
  std::vector<float>& iso_triangles(const std::vector<double>& isovalues, bool by_second) {
    std::vector<double> key = isovalues;
    key.push_back(by_second);
    auto it = iso_cache_.find(key);
    if (it != iso_cache_.end()) return it->second;
    std::vector<float> out;
    for (double iso : isovalues) {
      std::vector<float> second;
      std::vector<float> tris = marching_tets(*mesh_, iso, by_second ? &second : nullptr);
      for (size_t i = 0; i < tris.size(); i += 3) out.insert(out.end(), {tris[i], tris[i + 1], tris[i + 2], by_second ? second[i / 3] : static_cast<float>(iso)});
    }
    if (iso_cache_.size() > 8) iso_cache_.clear();
    return iso_cache_[key] = std::move(out);
  }

  void silhouettes(const Frame& f, bool wireframe, std::vector<float>& lines) {
    const SceneMesh& m = *mesh_;
    std::vector<int8_t> facing(m.boundary.size());
    for (size_t i = 0; i < m.boundary.size(); ++i) {
      const auto& t = m.boundary[i];
      V3 a{m.xyz[3 * size_t{t[0]}], m.xyz[3 * size_t{t[0]} + 1], m.xyz[3 * size_t{t[0]} + 2]};
      V3 b{m.xyz[3 * size_t{t[1]}], m.xyz[3 * size_t{t[1]} + 1], m.xyz[3 * size_t{t[1]} + 2]};
      V3 c{m.xyz[3 * size_t{t[2]}], m.xyz[3 * size_t{t[2]} + 1], m.xyz[3 * size_t{t[2]} + 2]};
      const V3 n = cross(sub(b, a), sub(c, a));
      facing[i] = (f.ortho ? -dot(n, f.forward) : dot(n, sub(f.eye, a))) > 0;
    }
    for (const auto& e : edges_) {
      const bool edge = e[3] == 0xFFFFFFFFu || facing[e[2]] != facing[e[3]];  // silhouette (or an open edge)
      if (!edge && !wireframe) continue;
      for (uint32_t v : {e[0], e[1]}) lines.insert(lines.end(), {m.xyz[3 * size_t{v}], m.xyz[3 * size_t{v} + 1], m.xyz[3 * size_t{v} + 2], 0.0f});
    }
  }

  void box_lines(std::vector<float>& lines) {
    const auto& b = mesh_->bounds;
    for (int axis = 0; axis < 3; ++axis)
      for (int i = 0; i < 4; ++i) {
        double p[3], q[3];
        const int u = (axis + 1) % 3, w = (axis + 2) % 3;
        p[axis] = b.min[axis];
        q[axis] = b.max[axis];
        p[u] = q[u] = (i & 1) ? b.max[u] : b.min[u];
        p[w] = q[w] = (i & 2) ? b.max[w] : b.min[w];
        lines.insert(lines.end(), {float(p[0]), float(p[1]), float(p[2]), 0.0f, float(q[0]), float(q[1]), float(q[2]), 0.0f});
      }
  }

  static constexpr int kSlots = 1024;
  static constexpr uint32_t kSlotsPerDraw = 1u << 20;  // tets a draw call (the index buffer's size)
  EGLDisplay display_ = EGL_NO_DISPLAY;
  EGLContext context_ = EGL_NO_CONTEXT;
  GLuint tet_program_ = 0, surface_program_ = 0, line_program_ = 0, empty_vao_ = 0, surface_vao_ = 0, line_vao_ = 0;
  GLuint cell_buffer_ = 0, index_buffer_ = 0;
  GLuint vertex_buffer_ = 0, tet_buffer_ = 0, order_buffer_ = 0, surface_buffer_ = 0, line_buffer_ = 0, pack_buffer_ = 0;
  GLuint framebuffer_ = 0, color_ = 0, depth_ = 0, distance_texture_ = 0, distance_copy_ = 0, table_texture_ = 0, colormap_texture_ = 0;
  uint32_t fb_width_ = 0, fb_height_ = 0;
  GLsizei surface_vertices_ = 0;
  const SceneMesh* mesh_ = nullptr;
  std::vector<float> centroid_, range_;
  std::vector<std::array<uint32_t, 4>> edges_;  // a, b, face, face
  std::vector<uint32_t> keys_, keys2_, ids_, ids2_, order_;
  std::vector<int> visible_prefix_;
  PreintegrationTable table_;
  std::string table_key_, colormap_name_;
  std::map<std::vector<double>, std::vector<float>> iso_cache_;  // key: isovalues, then by_second
};

}  // namespace

std::unique_ptr<Renderer> Renderer::create() { return std::make_unique<GlRenderer>(); }

}  // namespace tetrascope::renderer
