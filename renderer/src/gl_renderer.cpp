// The EGL + OpenGL 4.5 core renderer: one function per draw pass, in the order a frame draws
// them: boundary surface, opaque isosurfaces, lines (silhouettes or wireframe, box),
// translucent isosurfaces, volume, then the readback. Opaque passes write the distance along
// the ray to a second target, which limits the volume's rays.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <map>
#include <optional>

#include "camera_math.h"
#include "egl_context.h"
#include "gl_shaders.h"
#include "lines.h"
#include "projected_tets.h"
#include "scene_geometry.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/core/vec3.h"
#include "visibility_order.h"

namespace tetrascope::renderer {
namespace {

using clock_type = std::chrono::steady_clock;
double ms_since(clock_type::time_point t) { return std::chrono::duration<double, std::milli>(clock_type::now() - t).count(); }
double process_cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

constexpr uint32_t kSlotsPerDraw = kTetsPerChunk;  // tets a draw call (the index buffers' size)
constexpr unsigned kClassifyThreads = 2;          // projected tetrahedra: CPU threads classifying a chunk
constexpr size_t kMaxIsosInVolume = 8;            // isovalues composed in the volume (the shader's array)
constexpr size_t kMaxCachedIsosurfaces = 8;    // isovalue sets kept per mesh

// What every pass of one frame shares.
struct FrameSetup {
  Frame frame;
  std::array<float, 16> mvp{};
  double near_depth = 0;  // the near plane's distance from the eye along the view direction
  double lo = 0, hi = 1;  // the transfer function's range
};

void check_settings(const RenderSettings& s) {
  if (s.width < 1 || s.height < 1 || s.width > kMaxImageSide || s.height > kMaxImageSide)
    throw std::invalid_argument("image size must be 1.." + std::to_string(kMaxImageSide) + " a side");
  if (!known_colormap(s.tf.colormap)) throw std::invalid_argument("unknown colormap '" + s.tf.colormap + "' (viridis, plasma, cool-warm, grayscale)");
  if (!(s.iso_opacity > 0 && s.iso_opacity <= 1)) throw std::invalid_argument("isosurface opacity must be in (0, 1]");
  check_line_settings(s);
  check_point_settings(s);
  if (!(s.tensor_point_size >= 0 && s.tensor_point_size <= kMaxPointSize)) throw std::invalid_argument("tensor point size must be 0 (covering) to 64 pixels");
}

// The camera, its matrix (near and far planes around the mesh's bounding sphere; with the eye
// inside it, the near plane just in front of the eye, or for orthographic views at the eye's
// plane, where the reference's rays start) and the transfer function's range.
FrameSetup frame_setup(const SceneMesh& mesh, const RenderSettings& s) {
  FrameSetup out;
  out.frame = camera_frame(s.camera, s.width, s.height);
  const Vec3 centre{(mesh.bounds.min[0] + mesh.bounds.max[0]) / 2, (mesh.bounds.min[1] + mesh.bounds.max[1]) / 2, (mesh.bounds.min[2] + mesh.bounds.max[2]) / 2};
  const double distance = length(centre - out.frame.eye);
  const double far_plane = distance + mesh.diagonal;
  out.near_depth = out.frame.ortho ? std::max(0.0, distance - mesh.diagonal) : std::max(far_plane * 1e-5, distance - mesh.diagonal);
  out.mvp = view_projection(out.frame, out.near_depth, far_plane);
  const auto [lo, hi] = colour_range(mesh, s.tf);
  out.lo = lo;
  out.hi = hi;
  return out;
}

// Whether isosurfaces are composed inside the volume (translucent, with dvr) rather than drawn
// as triangles.
bool isosurfaces_in_volume(const RenderSettings& s) { return s.dvr && s.iso && s.iso_opacity < 1 && !s.use_iso_color_attribute && !s.isovalues.empty(); }

// The isovalues composed in the volume, over the transfer function's range, ascending and
// distinct; at most kMaxIsosInVolume.
std::vector<float> volume_isovalues(const RenderSettings& s, double lo, double hi) {
  std::vector<float> out;
  if (!isosurfaces_in_volume(s)) return out;
  for (double v : s.isovalues) out.push_back(static_cast<float>((v - lo) / (hi - lo)));
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  if (out.size() > kMaxIsosInVolume) out.resize(kMaxIsosInVolume);
  return out;
}

class GlRenderer final : public Renderer {
 public:
  GlRenderer() {
    tet_program_ = link_program(kTetVertex, kTetFragment);
    projected_program_ = link_program(kProjectedVertex, kProjectedFragment);
    surface_program_ = link_program(kSurfaceVertex, kSurfaceFragment);
    line_program_ = link_program(kSurfaceVertex, kLineFragment);
    glCreateVertexArrays(1, &empty_vao_);
    glCreateVertexArrays(1, &projected_vao_);  // ProjectedVertex: position, segment, light
    for (GLuint a = 0; a < 3; ++a) {
      glEnableVertexArrayAttrib(projected_vao_, a);
      glVertexArrayAttribFormat(projected_vao_, a, a == 2 ? 1 : 3, GL_FLOAT, GL_FALSE, 12 * a);
      glVertexArrayAttribBinding(projected_vao_, a, 0);
    }
    glCreateVertexArrays(1, &surface_vao_);
    glCreateBuffers(1, &surface_buffer_);
    glCreateBuffers(1, &line_buffer_);
    glCreateVertexArrays(1, &line_vao_);
    for (GLuint vao : {surface_vao_, line_vao_}) {  // (x, y, z, value) corners
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

  std::string description() const override {
    return std::string(reinterpret_cast<const char*>(glGetString(GL_VENDOR))) + ", " + reinterpret_cast<const char*>(glGetString(GL_RENDERER)) + ", OpenGL " +
           reinterpret_cast<const char*>(glGetString(GL_VERSION));
  }

  void set_mesh(const SceneMesh& mesh) override {
    mesh_ = &mesh;
    // CPU geometry first, then the uploads
    sort_inputs_ = tet_sort_inputs(mesh);
    boundary_ = boundary_geometry(mesh);
    upload_mesh(mesh, tet_cells(mesh));
    iso_cache_.clear();
    point_pass_.set_mesh(mesh);
    slices_ = {};
  }

  void release_memory() override {
    glFinish();
    shrink_framebuffer();
    release_projected_ring();
    // the scene's buffers shrink to nothing (their names stay: the vertex arrays refer to them)
    for (GLuint buffer : {vertex_buffer_, tet_buffer_, order_buffer_, cell_buffer_, surface_buffer_, line_buffer_})
      if (buffer) glNamedBufferData(buffer, 4, nullptr, GL_STATIC_DRAW);
    surface_vertices_ = 0;
    tensor_pass_.release();
    if (table_texture_) glDeleteTextures(1, &table_texture_);
    table_texture_ = 0;
    table_ = {};
    table_key_.clear();
    mesh_ = nullptr;  // render() needs a set_mesh first
    sort_inputs_ = {};
    boundary_ = {};
    visibility_ = {};
    iso_cache_.clear();
    slices_ = {};
    forget_bindings();
  }

  // Mesa keeps the storage of what a draw last used (buffers, textures, vertex buffers) until
  // the next draw validates the context's state, deleted objects included: so the bindings go,
  // one point is drawn with rasteriser discard, and the queued work is finished.
  void forget_bindings() {
    for (GLuint i = 0; i < 4; ++i) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, i, 0);
    for (GLuint unit = 1; unit < 3; ++unit) glBindTextureUnit(unit, 0);
    const float point[4] = {};
    glNamedBufferData(line_buffer_, sizeof(point), point, GL_STATIC_DRAW);
    glUseProgram(line_program_);
    glBindVertexArray(line_vao_);
    glEnable(GL_RASTERIZER_DISCARD);
    glDrawArrays(GL_POINTS, 0, 1);
    glDisable(GL_RASTERIZER_DISCARD);
    glBindVertexArray(0);
    glUseProgram(0);
    glFinish();
  }

  Image render(const RenderSettings& s, FrameTimings* timings) override {
    if (!mesh_) throw RenderError("no mesh set");
    check_settings(s);
    const SceneMesh& mesh = *mesh_;
    if (s.use_iso_color_attribute && mesh.iso_color_value.size() != mesh.value.size())
      throw std::invalid_argument("isosurfaces coloured by an attribute need a scene built with one (iso_color_attribute)");
    FrameTimings local;
    FrameTimings& tm = timings ? *timings : local;
    tm = FrameTimings();
    const auto start = clock_type::now();
    const double cpu_start = process_cpu_ms();
    ensure_framebuffer(s.width, s.height);
    const FrameSetup setup = frame_setup(mesh, s);
    update_colormap(s.tf, setup.lo, setup.hi);
    begin_frame(s);
    bool opaque = false;
    // between passes and between the volume's chunks: should the frame stop here?
    auto stop = [&] { return s.should_stop && (tm.interrupted = tm.interrupted || s.should_stop()); };
    glEnable(GL_POLYGON_OFFSET_FILL);
    glPolygonOffset(1, 1);
    if (s.surface) opaque |= draw_boundary_surface(setup, s.hidden_regions);
    const bool translucent_iso = s.iso && !s.dvr && s.iso_opacity < 1;
    const bool iso_triangles_drawn = s.iso && !s.isovalues.empty() && !isosurfaces_in_volume(s);
    if (iso_triangles_drawn && !translucent_iso && !stop()) opaque |= draw_opaque_isosurfaces(setup, s, tm);
    if (!s.slices.planes.empty() && !stop()) opaque |= draw_slices(setup, s.slices);
    glDisable(GL_POLYGON_OFFSET_FILL);
    // stream lines, point isosurfaces and tensor points (lines.cpp, point_iso.cpp,
    // tensor_pass.cpp): opaque before the volume
    const PassView pass_view{setup.frame, setup.mvp, s.width, s.height, setup.lo, setup.hi, colormap_texture_};
    if (s.points && !stop()) opaque |= point_pass_.draw(pass_view, s, tm);
    if (s.tensor_points && !stop()) opaque |= tensor_pass_.draw(pass_view, s, tm);
    if (s.lines && !stop()) opaque |= line_pass_.draw_opaque(pass_view, s, tm);
    if (s.slices.edges && !s.slices.planes.empty()) draw_lines(setup, slices_.edges);
    if (s.surface && !stop()) draw_boundary_edges(setup, s.wireframe, s.hidden_regions);
    if (s.box) draw_box(setup);
    if (iso_triangles_drawn && translucent_iso && !stop()) draw_translucent_isosurfaces(setup, s, tm);
    if (s.dvr && !mesh.tets.empty() && !stop()) draw_volume(setup, s, opaque, stop, tm);
    if (s.lines && !tm.interrupted) line_pass_.draw_ghosts(pass_view, s, tm);  // blended over the volume
    glFinish();
    tm.draw_ms = ms_since(start) - tm.sort_ms;
    Image image = read_back(s.width, s.height, tm);
    // the framebuffers take ~36 bytes a pixel (float colour, depth, distances, readback): a
    // large still's (600 MB at 4096^2) is given back at once instead of held by the worker
    if (uint64_t{s.width} * s.height > kKeepFramebufferPixels) shrink_framebuffer();
    tm.total_ms = ms_since(start);
    tm.cpu_ms = process_cpu_ms() - cpu_start;
    return image;
  }

 private:
  // ---- set-up per mesh and per frame ----

  void upload_mesh(const SceneMesh& mesh, const std::vector<float>& cells) {
    std::vector<float> vertices(4 * (mesh.xyz.size() / 3));  // (x, y, z, value)
    for (size_t v = 0; v < mesh.xyz.size() / 3; ++v) {
      std::copy_n(&mesh.xyz[3 * v], 3, &vertices[4 * v]);
      vertices[4 * v + 3] = mesh.value[v];
    }
    upload(vertex_buffer_, vertices.data(), vertices.size() * 4);
    upload(tet_buffer_, mesh.tets.data(), mesh.tets.size() * 4);
    upload(order_buffer_, nullptr, std::max<size_t>(mesh.tets.size() / 4, 1) * 4);
    upload(cell_buffer_, cells.data(), cells.size() * 4);
    if (!index_buffer_) {
      const std::vector<uint32_t> indices = tet_corner_indices(kSlotsPerDraw);
      upload(index_buffer_, indices.data(), indices.size() * 4);
      const std::vector<uint32_t> fans = projected_fan_indices(kSlotsPerDraw);
      upload(projected_index_buffer_, fans.data(), fans.size() * 4);
      glVertexArrayElementBuffer(projected_vao_, projected_index_buffer_);
    }
    glNamedBufferData(surface_buffer_, static_cast<GLsizeiptr>(boundary_.corners.size() * 4), boundary_.corners.data(), GL_STATIC_DRAW);
    surface_vertices_ = static_cast<GLsizei>(boundary_.corners.size() / 4);
    surface_hidden_.clear();
  }

  void upload(GLuint& buffer, const void* data, size_t bytes) {
    if (!buffer) glCreateBuffers(1, &buffer);
    glNamedBufferData(buffer, static_cast<GLsizeiptr>(std::max<size_t>(bytes, 4)), data, GL_STATIC_DRAW);
  }

  static constexpr uint64_t kKeepFramebufferPixels = uint64_t{2048} * 2048;

  // The projected tetrahedra's ring of persistently mapped vertex buffers (9 MB each), made at
  // the first projected draw and again after release_memory.
  void ensure_projected_ring() {
    if (projected_ring_[0].buffer) return;
    for (RingBuffer& ring : projected_ring_) {
      glCreateBuffers(1, &ring.buffer);
      const GLbitfield flags = GL_MAP_WRITE_BIT | GL_MAP_PERSISTENT_BIT | GL_MAP_COHERENT_BIT;
      const auto bytes = static_cast<GLsizeiptr>(size_t{kTetsPerChunk} * kVerticesPerTet * sizeof(ProjectedVertex));
      glNamedBufferStorage(ring.buffer, bytes, nullptr, flags);
      ring.vertices = static_cast<ProjectedVertex*>(glMapNamedBufferRange(ring.buffer, 0, bytes, flags));
      if (!ring.vertices) throw RenderError("cannot map the projected tetrahedra's vertex buffers");
    }
  }

  void release_projected_ring() {
    for (RingBuffer& ring : projected_ring_) {
      if (ring.fence) {
        glClientWaitSync(ring.fence, GL_SYNC_FLUSH_COMMANDS_BIT, ~GLuint64{0});
        glDeleteSync(ring.fence);
      }
      if (ring.buffer) {
        glUnmapNamedBuffer(ring.buffer);
        glDeleteBuffers(1, &ring.buffer);
      }
      ring = {};
    }
    ring_next_ = 0;
  }

  void release_framebuffer() {
    if (!framebuffer_) return;
    glDeleteFramebuffers(1, &framebuffer_);
    glDeleteRenderbuffers(1, &color_);
    glDeleteFramebuffers(1, &resolve_framebuffer_);
    glDeleteRenderbuffers(1, &resolve_color_);
    glDeleteTextures(1, &depth_);
    glDeleteTextures(1, &distance_texture_);
    glDeleteTextures(1, &distance_copy_);
    glDeleteBuffers(1, &pack_buffer_);
    framebuffer_ = 0;
    fb_width_ = fb_height_ = 0;
  }

  // Frees the framebuffers. Deleting them is not enough: Mesa keeps the bound framebuffer's
  // surfaces (float colour, depth, distance: 24 bytes a pixel) until this context validates
  // its framebuffer state again, and what the last readback read from (8 bytes a pixel) until
  // another readback, and a worker may draw nothing for hours. So a 1x1 set takes their place,
  // is cleared and read back, and the queued work is finished.
  void shrink_framebuffer() {
    ensure_framebuffer(1, 1);
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    FrameTimings ignored;
    read_back(1, 1, ignored);
    glFinish();
  }

  void ensure_framebuffer(uint32_t w, uint32_t h) {
    if (framebuffer_ && w == fb_width_ && h == fb_height_) return;
    release_framebuffer();
    glCreateFramebuffers(1, &framebuffer_);
    glCreateRenderbuffers(1, &color_);
    // float colour: a ray through thousands of tiny tets composes thousands of tiny
    // contributions, each below the 1/255 step of an 8-bit target, which would drop them
    glNamedRenderbufferStorage(color_, GL_RGBA32F, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
    glCreateFramebuffers(1, &resolve_framebuffer_);  // 8-bit, for a fast readback
    glCreateRenderbuffers(1, &resolve_color_);
    glNamedRenderbufferStorage(resolve_color_, GL_RGBA8, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
    glNamedFramebufferRenderbuffer(resolve_framebuffer_, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, resolve_color_);
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
  void update_colormap(const view::TransferFunction& tf, double lo, double hi) {
    std::string key = tf.colormap;
    if (!tf.colors.empty()) key = tf.key() + "|" + std::to_string(lo) + "|" + std::to_string(hi);
    if (key == colormap_key_) return;
    std::vector<uint8_t> texels(256 * 4);
    for (int i = 0; i < 256; ++i) {
      auto c = tf.colors.empty() ? colormap(tf.colormap, i / 255.0) : tf.user_color(lo + (hi - lo) * i / 255.0);
      for (int k = 0; k < 3; ++k) texels[4 * i + k] = static_cast<uint8_t>(std::lround(c[k] * 255));
      texels[4 * i + 3] = 255;
    }
    glTextureSubImage1D(colormap_texture_, 0, 0, 256, GL_RGBA, GL_UNSIGNED_BYTE, texels.data());
    colormap_key_ = key;
  }

  // The pre-integrated table and, in kFineSlices slices after its lengths, the transfer
  // function on a fine grid (FineTransfer, its extinction times the unit distance so that it
  // keeps within half floats), in one 3D texture: a segment's colour is one read of it.
  void update_table(const view::TransferFunction& tf, double lo, double hi, double unit, double max_length) {
    const std::string key = tf.key() + "|" + std::to_string(lo) + "|" + std::to_string(hi) + "|" + std::to_string(unit) + "|" + std::to_string(max_length);
    if (key == table_key_) return;
    table_ = preintegrate(tf, lo, hi, unit, std::max(max_length, 1e-30));
    const GLsizei n = static_cast<GLsizei>(table_.n), lengths = static_cast<GLsizei>(table_.lengths);
    if (!table_texture_) {
      glCreateTextures(GL_TEXTURE_3D, 1, &table_texture_);
      glTextureStorage3D(table_texture_, 1, GL_RGBA16F, n, n, lengths + kFineSlices);
      glTextureParameteri(table_texture_, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
      glTextureParameteri(table_texture_, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
      for (GLenum w : {GL_TEXTURE_WRAP_S, GL_TEXTURE_WRAP_T, GL_TEXTURE_WRAP_R}) glTextureParameteri(table_texture_, w, GL_CLAMP_TO_EDGE);
    }
    glTextureSubImage3D(table_texture_, 0, 0, 0, 0, n, n, lengths, GL_RGBA, GL_FLOAT, table_.rgba.data());
    FineTransfer fine = fine_transfer(tf, lo, hi, unit, table_.n * kFineSlices, table_.n - 1);
    for (size_t i = 0; i < fine.at.size(); i += 4) fine.at[i] = static_cast<float>(fine.at[i] * unit);
    glTextureSubImage3D(table_texture_, 0, 0, 0, lengths, n, n, kFineSlices, GL_RGBA, GL_FLOAT, fine.at.data());
    visibility_.set_transfer_function(tf, lo, hi);
    table_key_ = key;
    table_unit_ = unit;
  }

  // Clears colour, distance and depth; opaque drawing state.
  void begin_frame(const RenderSettings& s) {
    glBindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
    glViewport(0, 0, static_cast<GLsizei>(s.width), static_cast<GLsizei>(s.height));
    glDrawBuffers(2, kBothTargets);
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
  }

  // Binds a program and sets the uniforms every program shares.
  void use_program(GLuint p, const FrameSetup& setup) {
    const Frame& f = setup.frame;
    glUseProgram(p);
    glUniformMatrix4fv(glGetUniformLocation(p, "mvp"), 1, GL_FALSE, setup.mvp.data());
    glUniform3f(glGetUniformLocation(p, "eye"), float(f.eye[0]), float(f.eye[1]), float(f.eye[2]));
    glUniform3f(glGetUniformLocation(p, "forward"), float(f.forward[0]), float(f.forward[1]), float(f.forward[2]));
    glUniform1i(glGetUniformLocation(p, "ortho"), f.ortho);
    glUniform1f(glGetUniformLocation(p, "lo"), float(setup.lo));
    glUniform1f(glGetUniformLocation(p, "inv_span"), float(1 / (setup.hi - setup.lo)));
  }

  // The surface program coloured through the colormap; isosurfaces coloured by the
  // iso-colour attribute take its range instead of the transfer function's.
  void use_surface_program(const FrameSetup& setup, bool iso_color_range) {
    use_program(surface_program_, setup);
    if (iso_color_range) {
      const SceneMesh& m = *mesh_;
      const double span = m.iso_color_max > m.iso_color_min ? m.iso_color_max - m.iso_color_min : 1.0;
      glUniform1f(glGetUniformLocation(surface_program_, "lo"), float(m.iso_color_min));
      glUniform1f(glGetUniformLocation(surface_program_, "inv_span"), float(1 / span));
    }
    glUniform4f(glGetUniformLocation(surface_program_, "solid"), 0, 0, 0, -1);
    glUniform1i(glGetUniformLocation(surface_program_, "lit"), 1);
    glBindTextureUnit(0, colormap_texture_);
    glUniform1i(glGetUniformLocation(surface_program_, "colormap"), 0);
  }

  // ---- the passes ----

  // The boundary less its hidden regions: the surface buffer is filled again when the hidden
  // set changes.
  bool draw_boundary_surface(const FrameSetup& setup, const std::vector<uint32_t>& hidden) {
    if (hidden != surface_hidden_) {
      const std::vector<uint8_t> skip = hidden_faces(*mesh_, hidden);
      std::vector<float> corners;
      if (skip.empty()) {
        corners = boundary_.corners;
      } else {
        corners.reserve(boundary_.corners.size());
        for (size_t f = 0; f < skip.size(); ++f)
          if (!skip[f]) corners.insert(corners.end(), boundary_.corners.begin() + 12 * f, boundary_.corners.begin() + 12 * (f + 1));
      }
      glNamedBufferData(surface_buffer_, static_cast<GLsizeiptr>(std::max<size_t>(corners.size(), 1) * 4), corners.data(), GL_STATIC_DRAW);
      surface_vertices_ = static_cast<GLsizei>(corners.size() / 4);
      surface_hidden_ = hidden;
    }
    if (surface_vertices_ == 0) return false;
    use_surface_program(setup, false);
    glBindVertexArray(surface_vao_);
    glDrawArrays(GL_TRIANGLES, 0, surface_vertices_);
    return true;
  }

  bool draw_opaque_isosurfaces(const FrameSetup& setup, const RenderSettings& s, FrameTimings& tm) {
    const std::vector<float>& tris = iso_triangles(s.isovalues, s.use_iso_color_attribute);
    glNamedBufferData(line_buffer_, static_cast<GLsizeiptr>(tris.size() * 4), tris.data(), GL_STREAM_DRAW);
    use_surface_program(setup, s.use_iso_color_attribute);
    glBindVertexArray(line_vao_);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(tris.size() / 4));
    tm.iso_triangles = tris.size() / 12;
    return true;
  }

  // Slice planes (clip.h), opaque like isosurfaces, lit or flat; their triangles cached per
  // mesh and planes (and edges: lit or flat does not slice again).
  bool draw_slices(const FrameSetup& setup, const view::SliceSpec& slices) {
    view::SliceSpec geometry = slices;
    geometry.lit = true;
    if (!slices_.key || !(*slices_.key == geometry)) {
      slices_ = {geometry, {}, {}};
      for (const view::Plane& plane : slices.planes) slice_scene(*mesh_, plane, slices_.triangles, slices.edges ? &slices_.edges : nullptr);
    }
    if (slices_.triangles.empty()) return false;
    glNamedBufferData(line_buffer_, static_cast<GLsizeiptr>(slices_.triangles.size() * 4), slices_.triangles.data(), GL_STREAM_DRAW);
    use_surface_program(setup, false);
    glUniform1i(glGetUniformLocation(surface_program_, "lit"), slices.lit);
    glBindVertexArray(line_vao_);
    glDrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(slices_.triangles.size() / 4));
    return true;
  }

  // Silhouette edges of the boundary (every boundary edge with `wireframe`).
  void draw_boundary_edges(const FrameSetup& setup, bool wireframe, const std::vector<uint32_t>& hidden) {
    std::vector<float> lines;
    append_boundary_edges(*mesh_, boundary_, setup.frame, wireframe, lines, hidden_faces(*mesh_, hidden));
    draw_lines(setup, lines);
  }

  void draw_box(const FrameSetup& setup) {
    std::vector<float> lines;
    append_box_edges(mesh_->bounds, lines);
    draw_lines(setup, lines);
  }

  void draw_lines(const FrameSetup& setup, const std::vector<float>& lines) {
    if (lines.empty()) return;
    glNamedBufferData(line_buffer_, static_cast<GLsizeiptr>(lines.size() * 4), lines.data(), GL_STREAM_DRAW);
    use_program(line_program_, setup);
    glUniform4f(glGetUniformLocation(line_program_, "solid"), 0.02f, 0.02f, 0.02f, 1);
    glBindVertexArray(line_vao_);
    glDrawArrays(GL_LINES, 0, static_cast<GLsizei>(lines.size() / 4));
  }

  // Semi-transparent isosurfaces (without the volume): triangles sorted back to front by
  // centroid, blended, not writing depth.
  void draw_translucent_isosurfaces(const FrameSetup& setup, const RenderSettings& s, FrameTimings& tm) {
    const Frame& frame = setup.frame;
    const std::vector<float>& tris = iso_triangles(s.isovalues, s.use_iso_color_attribute);
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
    glDrawBuffers(1, kBothTargets);
    use_surface_program(setup, s.use_iso_color_attribute);
    glUniform1f(glGetUniformLocation(surface_program_, "opacity"), float(s.iso_opacity));
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

  // The volume: visible tets back to front, blended premultiplied; with `opaque`, rays stop at
  // the distance the opaque passes wrote. Tets that reach the near plane are drawn in their
  // place in the order by their back faces, their segments starting at the near plane (their
  // front faces are clipped there, or behind the eye), with the exact method; the others by
  // the settings' method. Issued kTetsPerChunk tets a draw call, asking `stop` after each.
  template <class Stop>
  void draw_volume(const FrameSetup& setup, const RenderSettings& s, bool opaque, Stop& stop, FrameTimings& tm) {
    const SceneMesh& mesh = *mesh_;
    const double unit = s.unit_distance > 0 ? s.unit_distance : mesh.diagonal / 100;
    // the table's length axis covers the scene's longest edge rounded up to a power of two:
    // the cuts of one store differ in their longest edge, and a new table (tens of ms) for
    // every cut change was a large share of an interaction frame
    update_table(s.tf, setup.lo, setup.hi, unit, std::exp2(std::ceil(std::log2(std::max(mesh.max_edge, 1e-30)))));
    const std::vector<float> isos = volume_isovalues(s, setup.lo, setup.hi);
    visibility_.set_isovalues(isos);
    const auto sort_start = clock_type::now();
    const std::span<const uint32_t> order = visibility_.sort(mesh, sort_inputs_, setup.lo, setup.hi, setup.frame, setup.near_depth, tm);
    const auto count = static_cast<uint32_t>(order.size());
    tm.sort_ms = ms_since(sort_start);
    tm.tets_drawn = 0;
    if (!count) return;
    glNamedBufferSubData(order_buffer_, 0, count * 4, order.data());
    if (opaque) {
      glCopyImageSubData(distance_texture_, GL_TEXTURE_2D, 0, 0, 0, 0, distance_copy_, GL_TEXTURE_2D, 0, 0, 0, 0, static_cast<GLsizei>(s.width),
                         static_cast<GLsizei>(s.height), 1);
    }
    glDrawBuffers(1, kBothTargets);
    for (GLuint p : {tet_program_, projected_program_}) set_volume_uniforms(p, setup, s, opaque, isos);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, vertex_buffer_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, tet_buffer_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, order_buffer_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, cell_buffer_);
    glBindTextureUnit(0, colormap_texture_);
    glBindTextureUnit(1, table_texture_);
    glBindTextureUnit(2, distance_copy_);
    glFrontFace(GL_CCW);
    glProvokingVertex(GL_FIRST_VERTEX_CONVENTION);  // the fans' thick vertex
    glEnable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);  // back to front, premultiplied
    glDepthMask(GL_FALSE);
    const bool projected = s.volume == VolumeMethod::projected;
    // [first, end) by the settings' method, a chunk a draw call; false when stopped. A frame
    // that may be stopped finishes each chunk before asking, so a stop waits for one chunk at
    // most (llvmpipe would otherwise still hold every chunk issued so far), and sizes its
    // chunks to take about kStopCheckMs each: 65,536 tets at 1024x768 took over a second on
    // llvmpipe under load, which was the wait of a user who moved during a still.
    uint32_t chunk = s.should_stop ? kFirstStopChunk : kTetsPerChunk;
    auto draw_range = [&](uint32_t first, uint32_t end) {
      for (uint32_t slot = first; slot < end;) {
        const uint32_t n = std::min(chunk, end - slot);
        const auto chunk_start = clock_type::now();
        if (projected) draw_projected(setup, order.subspan(slot, n), !isos.empty(), tm);
        else draw_exact(slot, n, false);
        tm.tets_drawn += n;
        slot += n;
        if (s.should_stop) {
          glFinish();
          if (n == chunk) {  // a whole chunk: the next one sized by its time, at most doubling
            const double ms = std::max(ms_since(chunk_start), 0.01);
            chunk = static_cast<uint32_t>(std::clamp(chunk * std::min(2.0, kStopCheckMs / ms), double(kFirstStopChunk), double(kTetsPerChunk)));
          }
        }
        if (stop()) return false;
      }
      return true;
    };
    uint32_t first = 0;
    bool going = true;
    for (uint32_t near : visibility_.near_positions()) {
      if (!(going = draw_range(first, near))) break;
      draw_exact(near, 1, true);
      ++tm.tets_drawn;
      first = near + 1;
    }
    if (going) draw_range(first, count);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
    glDisable(GL_CULL_FACE);
    glEnable(GL_DEPTH_TEST);
    glProvokingVertex(GL_LAST_VERTEX_CONVENTION);
  }

  void set_volume_uniforms(GLuint p, const FrameSetup& setup, const RenderSettings& s, bool opaque, const std::vector<float>& isos) {
    use_program(p, setup);
    glUniform1i(glGetUniformLocation(p, "colormap"), 0);
    glUniform1i(glGetUniformLocation(p, "table"), 1);
    glUniform1i(glGetUniformLocation(p, "depth_limit"), 2);
    glUniform1f(glGetUniformLocation(p, "fine_slices"), float(kFineSlices));
    glUniform1f(glGetUniformLocation(p, "inv_unit"), float(1 / table_unit_));
    glUniform1i(glGetUniformLocation(p, "clip_depth"), opaque);
    glUniform2f(glGetUniformLocation(p, "viewport"), float(s.width), float(s.height));
    glUniform1f(glGetUniformLocation(p, "length_scale"), float(table_.length_scale));
    glUniform1f(glGetUniformLocation(p, "inv_log_length_range"), float(1 / std::log1p(table_.max_length / table_.length_scale)));
    glUniform1f(glGetUniformLocation(p, "table_n"), float(table_.n));
    glUniform1f(glGetUniformLocation(p, "table_lengths"), float(table_.lengths));
    glUniform1f(glGetUniformLocation(p, "near_depth"), float(setup.near_depth));
    glUniform1i(glGetUniformLocation(p, "iso_count"), static_cast<GLint>(isos.size()));
    if (!isos.empty()) glUniform1fv(glGetUniformLocation(p, "isos"), static_cast<GLsizei>(isos.size()), isos.data());
    glUniform1f(glGetUniformLocation(p, "iso_opacity"), float(s.iso_opacity));
  }

  // Tets at positions [first, first + n) of the order, exact: front faces, or for `near` back
  // faces with no depth test (the segment from the near plane may end before an opaque
  // surface that the back face lies behind; the distance limit cuts it there).
  void draw_exact(uint32_t first, uint32_t n, bool near) {
    glUseProgram(tet_program_);
    glUniform1i(glGetUniformLocation(tet_program_, "near_pass"), near);
    glEnable(GL_CULL_FACE);
    glCullFace(near ? GL_FRONT : GL_BACK);
    if (near) glDisable(GL_DEPTH_TEST);
    else glEnable(GL_DEPTH_TEST);
    glUniform1ui(glGetUniformLocation(tet_program_, "first_slot"), first);
    glBindVertexArray(empty_vao_);
    glVertexArrayElementBuffer(empty_vao_, index_buffer_);
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(12 * n), GL_UNSIGNED_INT, nullptr);
    if (!near) glFlush();  // llvmpipe rasterises this chunk while the next one is issued
  }

  // Tets `tets` by projected tetrahedra: classified on the CPU straight into the next buffer
  // of a ring of persistently mapped vertex buffers (waiting only for that buffer's last draw;
  // a fresh buffer store a chunk cost a page-faulted, zeroed allocation each), drawn as a fan
  // of 4 triangles a tet with the thick vertex first (provoking), no culling.
  void draw_projected(const FrameSetup& setup, std::span<const uint32_t> tets, bool light, FrameTimings& tm) {
    const auto classify_start = clock_type::now();
    ensure_projected_ring();
    RingBuffer& ring = projected_ring_[ring_next_];
    ring_next_ = (ring_next_ + 1) % kRingBuffers;
    if (ring.fence) {
      glClientWaitSync(ring.fence, GL_SYNC_FLUSH_COMMANDS_BIT, ~GLuint64{0});
      glDeleteSync(ring.fence);
      ring.fence = nullptr;
    }
    classify_tets(*mesh_, tets, setup.frame, setup.lo, 1 / (setup.hi - setup.lo), light, kClassifyThreads, ring.vertices);
    tm.classify_ms += ms_since(classify_start);
    glUseProgram(projected_program_);
    glDisable(GL_CULL_FACE);
    glEnable(GL_DEPTH_TEST);
    glBindVertexArray(projected_vao_);
    glVertexArrayVertexBuffer(projected_vao_, 0, ring.buffer, 0, sizeof(ProjectedVertex));
    glDrawElements(GL_TRIANGLES, static_cast<GLsizei>(12 * tets.size()), GL_UNSIGNED_INT, nullptr);
    ring.fence = glFenceSync(GL_SYNC_GPU_COMMANDS_COMPLETE, 0);
    glFlush();
  }

  // The colour target through a pixel buffer, rows flipped to top first.
  Image read_back(uint32_t width, uint32_t height, FrameTimings& tm) {
    const auto read_start = clock_type::now();
    Image image{width, height, std::vector<uint8_t>(size_t{width} * height * 4), {}};
    glNamedFramebufferReadBuffer(framebuffer_, GL_COLOR_ATTACHMENT0);
    glBlitNamedFramebuffer(framebuffer_, resolve_framebuffer_, 0, 0, static_cast<GLint>(width), static_cast<GLint>(height), 0, 0, static_cast<GLint>(width),
                           static_cast<GLint>(height), GL_COLOR_BUFFER_BIT, GL_NEAREST);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, resolve_framebuffer_);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, pack_buffer_);
    glReadBuffer(GL_COLOR_ATTACHMENT0);
    glReadPixels(0, 0, static_cast<GLsizei>(width), static_cast<GLsizei>(height), GL_RGBA, GL_UNSIGNED_BYTE, nullptr);
    const uint8_t* pixels = static_cast<const uint8_t*>(glMapBufferRange(GL_PIXEL_PACK_BUFFER, 0, static_cast<GLsizeiptr>(image.rgba.size()), GL_MAP_READ_BIT));
    if (!pixels) throw RenderError("cannot map the pixel buffer");
    const size_t row = size_t{width} * 4;
    for (uint32_t y = 0; y < height; ++y) std::memcpy(&image.rgba[y * row], pixels + (height - 1 - y) * row, row);
    glUnmapBuffer(GL_PIXEL_PACK_BUFFER);
    glBindBuffer(GL_PIXEL_PACK_BUFFER, 0);
    tm.readback_ms = ms_since(read_start);
    if (GLenum error = glGetError(); error != GL_NO_ERROR) throw RenderError("OpenGL error " + std::to_string(error));
    return image;
  }

  // Isosurface triangles as (x, y, z, value) corners; value = the isovalue, or the
  // iso-colour attribute interpolated at the corner. Cached per mesh.
  const std::vector<float>& iso_triangles(const std::vector<double>& isovalues, bool by_iso_color) {
    std::vector<double> key = isovalues;
    key.push_back(by_iso_color);
    auto it = iso_cache_.find(key);
    if (it != iso_cache_.end()) return it->second;
    std::vector<float> out;
    for (double iso : isovalues) {
      std::vector<float> iso_color;
      std::vector<float> tris = marching_tets(*mesh_, iso, by_iso_color ? &iso_color : nullptr);
      for (size_t i = 0; i < tris.size(); i += 3)
        out.insert(out.end(), {tris[i], tris[i + 1], tris[i + 2], by_iso_color ? iso_color[i / 3] : static_cast<float>(iso)});
    }
    if (iso_cache_.size() > kMaxCachedIsosurfaces) iso_cache_.clear();
    return iso_cache_[key] = std::move(out);
  }

  static constexpr GLenum kBothTargets[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};  // colour, distance
  EglContext context_;  // first: made before any GL call, torn down after every GL object
  GLuint tet_program_ = 0, surface_program_ = 0, line_program_ = 0, empty_vao_ = 0, surface_vao_ = 0, line_vao_ = 0;
  GLuint cell_buffer_ = 0, index_buffer_ = 0, projected_index_buffer_ = 0, projected_program_ = 0, projected_vao_ = 0;
  GLuint vertex_buffer_ = 0, tet_buffer_ = 0, order_buffer_ = 0, surface_buffer_ = 0, line_buffer_ = 0, pack_buffer_ = 0;
  GLuint resolve_framebuffer_ = 0, resolve_color_ = 0;
  GLuint framebuffer_ = 0, color_ = 0, depth_ = 0, distance_texture_ = 0, distance_copy_ = 0, table_texture_ = 0, colormap_texture_ = 0;
  uint32_t fb_width_ = 0, fb_height_ = 0;
  GLsizei surface_vertices_ = 0;
  std::vector<uint32_t> surface_hidden_;  // the regions the surface buffer leaves out
  const SceneMesh* mesh_ = nullptr;
  TetSortInputs sort_inputs_;
  BoundaryGeometry boundary_;
  VisibilityOrder visibility_;
  struct RingBuffer {
    GLuint buffer = 0;
    ProjectedVertex* vertices = nullptr;  // mapped for good
    GLsync fence = nullptr;               // after the last draw from it
  };
  static constexpr int kRingBuffers = 3;
  std::array<RingBuffer, kRingBuffers> projected_ring_;
  int ring_next_ = 0;
  PreintegrationTable table_;
  static constexpr GLsizei kFineSlices = 4;  // of n x n texels: 4 x 128 rows of 127 intervals, 65,024 (the ray caster's 65,536)
  double table_unit_ = 1;
  std::string table_key_, colormap_key_;
  std::map<std::vector<double>, std::vector<float>> iso_cache_;  // key: isovalues, then by_iso_color
  LinePass line_pass_;       // after context_: made with a current context, gone before it
  PointIsoPass point_pass_;
  TensorPointPass tensor_pass_;
  struct SliceCache {
    std::optional<view::SliceSpec> key;  // the planes sliced (lit or flat alike)
    std::vector<float> triangles, edges;  // (x, y, z, value) corners
  } slices_;
};

}  // namespace

std::unique_ptr<Renderer> Renderer::create() { return std::make_unique<GlRenderer>(); }

}  // namespace tetrascope::renderer
