// The raw triangle ceiling of this machine's GL for a mesh's volume rendering: how
// fast the triangles that `tetrascope render --mode dvr` emits could be drawn if a fragment
// did nothing but write a constant colour.
//
// For every frame of the render orbit (`--orbit N`: azimuth 30 + 360 k / N, elevation 20,
// 1.6 box diagonals, fov 30) it projects every tet with the renderer's own camera maths and
// counts what each method emits:
//   exact      4 faces a tet, back faces culled: the front faces (1-3 a tet) cover the tet's
//              projection, the back faces are culled after the vertex stage;
//   projected  4 triangles a tet (the fan around the thick vertex; a 3-triangle class has a
//              degenerate fourth), none culled, covering the tet's projection.
// Then it draws that many synthetic triangles of the same mean pixel area (equilateral,
// scattered uniformly over the mesh's projected box, the back faces with reversed winding)
// with a pass-through vertex shader and a constant-colour fragment shader, into an RGBA32F
// target of the same size with the DVR's blending (ONE, ONE_MINUS_SRC_ALPHA) and depth test,
// in draw calls of 65,536 tets' triangles, and times it (glFinish on both sides; one untimed
// warm-up draw of each kind first).
// Equilateral, scattered triangles of the mean area are a best case: the ceiling.
//
//   triangle_ceiling MESH WxH FRAMES    prints one JSON object
#define GL_GLEXT_PROTOTYPES 1
#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include "camera_math.h"
#include "egl_context.h"
#include "gl_shaders.h"
#include "tetrascope/view/camera.h"
#include "tetrascope/view/transfer_function.h"
#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/mesh_stream.h"

using namespace tetrascope;  // Vec3 and its operators

namespace {

namespace r = tetrascope::renderer;
namespace st = tetrascope::storage;

struct Counts {
  double front = 0, back = 0;  // faces, exact method
  double area = 0;             // sum of the tets' projected areas, pixels
  double x0 = 1e30, x1 = -1e30, y0 = 1e30, y1 = -1e30;
};

Counts count(const st::TetMesh& mesh, const r::Frame& f) {
  Counts c;
  const size_t n = mesh.tet_count();
  static constexpr int kFaces[4][4] = {{0, 1, 2, 3}, {0, 1, 3, 2}, {0, 2, 3, 1}, {1, 2, 3, 0}};  // 3 corners, the opposite one
  for (size_t t = 0; t < n; ++t) {
    Vec3 p[4];
    double px[4], py[4];
    for (int k = 0; k < 4; ++k) {
      const uint32_t v = mesh.tets[4 * t + k];
      p[k] = {mesh.x[v], mesh.y[v], mesh.z[v]};
      r::project(f, p[k], &px[k], &py[k]);
      c.x0 = std::min(c.x0, px[k]);
      c.x1 = std::max(c.x1, px[k]);
      c.y0 = std::min(c.y0, py[k]);
      c.y1 = std::max(c.y1, py[k]);
    }
    for (const auto& face : kFaces) {
      const Vec3 a = p[face[0]], b = p[face[1]], d = p[face[2]];
      Vec3 normal = cross(b - a, d - a);
      if (dot(normal, p[face[3]] - a) > 0) normal = -1.0 * normal;  // outward
      const Vec3 towards_eye = f.ortho ? -1.0 * f.forward : f.eye - a;
      const double area = std::abs((px[face[1]] - px[face[0]]) * (py[face[2]] - py[face[0]]) - (px[face[2]] - px[face[0]]) * (py[face[1]] - py[face[0]])) / 2;
      if (dot(normal, towards_eye) > 0) {
        c.front += 1;
        c.area += area;
      } else {
        c.back += 1;
      }
    }
  }
  return c;
}

double cpu_ms() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

struct Timing {
  double ms = 0, cpu_ms = 0;  // wall; process CPU (every thread, llvmpipe's included)
};

// Draws `front` front-facing and `back` back-facing equilateral triangles of `area` pixels
// scattered over the box; returns the draw time.
Timing draw(double front, double back, double area, const Counts& box, uint32_t w, uint32_t h, bool cull, uint32_t per_call, std::mt19937& rng) {
  const size_t nf = static_cast<size_t>(std::llround(front)), nb = static_cast<size_t>(std::llround(back));
  const double radius = std::sqrt(4 * area / (3 * std::sqrt(3.0)));
  const double x0 = std::max(0.0, box.x0), x1 = std::min(double(w), box.x1), y0 = std::max(0.0, box.y0), y1 = std::min(double(h), box.y1);
  std::uniform_real_distribution<double> ux(x0, std::max(x0 + 1, x1)), uy(y0, std::max(y0 + 1, y1)), angle(0, 2 * M_PI);
  std::vector<float> vertices;
  vertices.reserve((nf + nb) * 6);
  // interleave front and back triangles as a tet's faces come
  const size_t total = nf + nb;
  for (size_t i = 0; i < total; ++i) {
    const bool is_back = nb && (i * nb / total != (i + 1) * nb / total);
    const double cx = ux(rng), cy = uy(rng), a0 = angle(rng);
    for (int k = 0; k < 3; ++k) {
      const int kk = is_back ? 2 - k : k;
      const double a = a0 + kk * 2 * M_PI / 3;
      const double x = cx + radius * std::cos(a), y = cy + radius * std::sin(a);
      vertices.push_back(static_cast<float>(2 * (x + 0.5) / w - 1));
      vertices.push_back(static_cast<float>(1 - 2 * (y + 0.5) / h));
    }
  }
  GLuint buffer = 0, vao = 0;
  glCreateBuffers(1, &buffer);
  glNamedBufferStorage(buffer, static_cast<GLsizeiptr>(vertices.size() * sizeof(float)), vertices.data(), 0);
  glCreateVertexArrays(1, &vao);
  glVertexArrayVertexBuffer(vao, 0, buffer, 0, 2 * sizeof(float));
  glEnableVertexArrayAttrib(vao, 0);
  glVertexArrayAttribFormat(vao, 0, 2, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao, 0, 0);
  glBindVertexArray(vao);
  glFinish();
  const float bg[4] = {1, 1, 1, 1};
  glClearBufferfv(GL_COLOR, 0, bg);
  glClear(GL_DEPTH_BUFFER_BIT);
  if (cull) {
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
  } else {
    glDisable(GL_CULL_FACE);
  }
  glFinish();
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = cpu_ms();
  const size_t count = total * 3;
  for (size_t first = 0; first < count; first += size_t{per_call} * 3) {
    glDrawArrays(GL_TRIANGLES, static_cast<GLint>(first), static_cast<GLsizei>(std::min<size_t>(size_t{per_call} * 3, count - first)));
    glFlush();
  }
  glFinish();
  const Timing t{std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(), cpu_ms() - cpu_start};
  glDeleteVertexArrays(1, &vao);
  glDeleteBuffers(1, &buffer);
  return t;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: triangle_ceiling MESH WxH FRAMES\n");
    return 2;
  }
  const std::string path = argv[1], size = argv[2];
  const uint32_t frames = static_cast<uint32_t>(std::stoul(argv[3]));
  const auto x = size.find('x');
  const uint32_t w = static_cast<uint32_t>(std::stoul(size.substr(0, x))), h = static_cast<uint32_t>(std::stoul(size.substr(x + 1)));
  const st::TetMesh mesh = st::load_mesh(path);
  const st::Bounds bounds = st::compute_bounds(mesh);

  r::EglContext context;
  GLuint fb = 0, colour = 0, depth = 0;
  glCreateFramebuffers(1, &fb);
  glCreateRenderbuffers(1, &colour);
  glNamedRenderbufferStorage(colour, GL_RGBA32F, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
  glCreateRenderbuffers(1, &depth);
  glNamedRenderbufferStorage(depth, GL_DEPTH_COMPONENT32F, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
  glNamedFramebufferRenderbuffer(fb, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, colour);
  glNamedFramebufferRenderbuffer(fb, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
  if (glCheckNamedFramebufferStatus(fb, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    std::fprintf(stderr, "framebuffer incomplete\n");
    return 1;
  }
  glBindFramebuffer(GL_FRAMEBUFFER, fb);
  glViewport(0, 0, static_cast<GLsizei>(w), static_cast<GLsizei>(h));
  const GLuint program = r::link_program("#version 450 core\nlayout(location = 0) in vec2 p;\nvoid main() { gl_Position = vec4(p, 0.5, 1); }\n",
                                         "#version 450 core\nout vec4 colour;\nvoid main() { colour = vec4(0.004, 0.004, 0.004, 0.01); }\n");
  glUseProgram(program);
  glEnable(GL_BLEND);
  glBlendFunc(GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LEQUAL);
  glDepthMask(GL_FALSE);

  std::mt19937 rng(16);
  std::vector<double> exact_ms, projected_ms, exact_cpu, projected_cpu, exact_tris, projected_tris, exact_area, projected_area, front_per_tet;
  const double tets = double(mesh.tet_count());
  for (uint32_t k = 0; k < frames; ++k) {
    if (k == 0) {  // warm-up, untimed: the shaders' first use compiles them
      tetrascope::view::Camera camera = tetrascope::view::parse_camera("azimuth=30,elevation=20", bounds);
      camera.aspect = double(w) / h;
      const Counts c = count(mesh, r::camera_frame(camera, w, h));
      draw(c.front, c.back, c.area / c.front, c, w, h, true, 65536 * 4, rng);
      draw(4 * tets, 0, c.area / (4 * tets), c, w, h, false, 65536 * 4, rng);
    }
    tetrascope::view::Camera camera = tetrascope::view::parse_camera("azimuth=" + std::to_string(30 + 360.0 * k / frames) + ",elevation=20", bounds);
    camera.aspect = double(w) / h;
    const r::Frame f = r::camera_frame(camera, w, h);
    const Counts c = count(mesh, f);
    const Timing te = draw(c.front, c.back, c.area / c.front, c, w, h, true, 65536 * 4, rng);
    exact_ms.push_back(te.ms);
    exact_cpu.push_back(te.cpu_ms);
    exact_tris.push_back(c.front);
    exact_area.push_back(c.area / c.front);
    front_per_tet.push_back(c.front / tets);
    const Timing tp = draw(4 * tets, 0, c.area / (4 * tets), c, w, h, false, 65536 * 4, rng);
    projected_ms.push_back(tp.ms);
    projected_cpu.push_back(tp.cpu_ms);
    projected_tris.push_back(4 * tets);
    projected_area.push_back(c.area / (4 * tets));
    std::fprintf(stderr, "frame %u: %.0f front faces (%.2f a tet), %.2f px each; exact ceiling %.1f ms, projected ceiling %.1f ms\n", k, c.front, c.front / tets,
                 c.area / c.front, exact_ms.back(), projected_ms.back());
  }
  const double em = median(exact_ms), pm = median(projected_ms);
  std::printf(
      "{\"mesh\": \"%s\", \"tets\": %zu, \"size\": \"%s\", \"frames\": %u, \"front_faces_per_tet\": %.4f,"
      " \"exact\": {\"triangles_rasterised\": %.0f, \"triangles_culled\": %.0f, \"mean_area_px\": %.3f, \"median_ms\": %.2f, \"median_cpu_ms\": %.2f, \"emitted_per_s\": %.0f},"
      " \"projected\": {\"triangles\": %.0f, \"mean_area_px\": %.3f, \"median_ms\": %.2f, \"median_cpu_ms\": %.2f, \"triangles_per_s\": %.0f}}\n",
      path.c_str(), mesh.tet_count(), size.c_str(), frames, median(front_per_tet), median(exact_tris), 4 * tets - median(exact_tris), median(exact_area), em, median(exact_cpu),
      (4 * tets) / em * 1000, median(projected_tris), median(projected_area), pm, median(projected_cpu), median(projected_tris) / pm * 1000);
  return 0;
}
