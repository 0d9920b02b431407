// Headless rendering of tet meshes: an EGL context without a display (Mesa
// llvmpipe here, NVIDIA EGL on GPU hosts), rendering into a framebuffer object.
//
// Modes:
//  - dvr: direct volume rendering by cell projection - every tet's front faces are drawn in
//    back-to-front order (radix sort of centroid depths); each fragment intersects its view
//    ray with the tet's planes to find the exact segment through it (front value, back
//    value, length) and looks up a pre-integrated transfer function table (Engel et al.
//    2001) over (front, back, length). The camera may be inside the mesh: tets that reach
//    the near plane are drawn by their back faces with segments starting at the near plane,
//    and colour is composed in 32-bit floats, so thousands of tiny tets along a ray add up as
//    the exact integrator (reference_render) says;
//  - iso: marching tetrahedra for one or more isovalues, lit, opaque;
//  - surface: the mesh boundary coloured by the attribute, lit, with silhouette edges
//    (§7.1) and an optional wireframe; dvr+iso and surface+iso combine.
// The colour legend is not drawn into the image: `render --json` and the server send it as
// data (colormap, range, attribute), for the client to draw.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "tetrascope/lod/view.h"
#include "tetrascope/storage/mesh.h"

namespace tetrascope::renderer {

// The largest image side Renderer::render accepts, in pixels: at 8192x8192 the renderer's
// targets take about 2.3 GiB (float colour 1 GiB, depth, two distance targets, the 8-bit
// resolve and readback 256 MiB each). Callers that take sizes from users (the CLI, the
// server) check against this or a smaller limit of their own.
constexpr uint32_t kMaxImageSide = 8192;

class RenderError : public std::runtime_error {
 public:
  explicit RenderError(const std::string& message) : std::runtime_error(message) {}
};

struct Image {
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba;  // top row first
};

struct RenderSettings {
  bool dvr = true, iso = false, surface = false, wireframe = false, box = false;
  lod::Camera camera;
  uint32_t width = 512, height = 512;
  lod::TransferFunction tf;          // attribute, range, colormap, opacity
  double unit_distance = 0;          // opacity is that of a slab this thick (0: 1/100 of the box diagonal)
  std::vector<double> isovalues;     // attribute units
  double iso_opacity = 1;            // < 1: semi-transparent isosurfaces (sorted; without dvr only)
  bool use_iso_color_attribute = false;  // colour isosurfaces by the scene's iso_color_attribute (else by value)
  std::array<float, 3> background{0.1f, 0.1f, 0.12f};
  // Asked between chunks of the volume's tets (at most 65,536 a draw call); true stops the
  // frame there: the partial image comes back with FrameTimings::interrupted. Empty: never.
  std::function<bool()> should_stop;
};

struct FrameTimings {
  double sort_ms = 0, draw_ms = 0, readback_ms = 0, encode_ms = 0, total_ms = 0;
  uint64_t tets_drawn = 0, tets_skipped = 0, iso_triangles = 0;
  bool interrupted = false;  // should_stop said stop: the image is partial
};

// A mesh prepared for drawing: positions, the chosen attribute's values (vector magnitude
// for vectors), tets, boundary faces.
struct SceneMesh {
  std::vector<float> xyz;      // interleaved
  std::vector<float> value;    // attribute value per vertex, attribute units
  std::vector<uint32_t> tets;
  std::vector<std::array<uint32_t, 3>> boundary;  // outward
  storage::Bounds bounds;
  double diagonal = 1, max_edge = 0;
  std::string attribute;
  double value_min = 0, value_max = 1;
  // optional: the attribute that colours isosurfaces (`render --iso-color`), per vertex
  std::string iso_color_attribute;
  std::vector<float> iso_color_value;
  double iso_color_min = 0, iso_color_max = 1;
  static SceneMesh from(const storage::TetMesh& mesh, const std::string& attribute, const std::string& iso_color_attribute = "");  // throws std::invalid_argument
};

// Colormaps: viridis, plasma, cool-warm, grayscale; `colors` of the transfer function JSON
// ([[value, r, g, b], ...], 0..1) overrides them.
std::array<float, 3> colormap(const std::string& name, double t);
bool known_colormap(const std::string& name);

// Pre-integrated table over (front, back, length): RGBA premultiplied, front-to-back composed,
// front and back in [0, 1] over the transfer function's range. The length axis is logarithmic
// beyond `length_scale`, so that segments from tiny tets (edges spanning 72,000:1 in one mesh)
// get as fine a resolution as long ones: entry m of `lengths` holds the length L with
//   log(1 + L / length_scale) = m / (lengths - 1) * log(1 + max_length / length_scale).
struct PreintegrationTable {
  uint32_t n = 0, lengths = 0;
  double max_length = 0, length_scale = 1;
  std::vector<float> rgba;  // [length][back][front][4]
  double length_at(uint32_t m) const;
  double length_coordinate(double length) const;  // 0..1 along the length axis (clamped)
};
PreintegrationTable preintegrate(const lod::TransferFunction& tf, double lo, double hi, double unit_distance, double max_length, uint32_t n = 128,
                                 uint32_t lengths = 32);

// Colour and opacity of one ray segment through a tet, integrated exactly (fine steps): the
// reference the table approximates.
std::array<double, 4> integrate_segment(const lod::TransferFunction& tf, double lo, double hi, double unit_distance, double front, double back,
                                        double length);

class Renderer {
 public:
  // Opens an EGL display (a hardware device first, then Mesa's software device, then Mesa's
  // surfaceless platform) and an OpenGL 4.5 core context. Throws RenderError saying what is
  // missing when none can be had.
  static std::unique_ptr<Renderer> create();
  virtual ~Renderer() = default;
  virtual std::string description() const = 0;  // GL vendor, renderer, version
  // The renderer keeps a pointer to `mesh` until the next set_mesh: it must outlive its use.
  virtual void set_mesh(const SceneMesh& mesh) = 0;
  // Throws std::invalid_argument for bad settings (a side outside 1..kMaxImageSide, an
  // unknown colormap, an isosurface opacity outside (0, 1]).
  virtual Image render(const RenderSettings& settings, FrameTimings* timings = nullptr) = 0;
};

// CPU reference: rays through every pixel, tets intersected exactly, segments composed front
// to back with integrate_segment. Small meshes only (tests, PSNR).
Image reference_render(const SceneMesh& mesh, const RenderSettings& settings);

double psnr(const Image& a, const Image& b);  // dB over RGB
std::vector<uint8_t> encode_jpeg(const Image& image, int quality);
std::vector<uint8_t> encode_png(const Image& image);
// Writes .png or .jpg/.jpeg by the extension (atomically: temp name, then rename).
void write_image(const std::string& path, const Image& image, int quality);

// Marching tetrahedra: triangles (xyz per corner, 9 floats a triangle) where the values cross
// `isovalue`, oriented towards increasing values. With `iso_color`, also the scene's
// iso_color_attribute interpolated at every corner (3 a triangle).
std::vector<float> marching_tets(const SceneMesh& mesh, double isovalue, std::vector<float>* iso_color = nullptr);

}  // namespace tetrascope::renderer
