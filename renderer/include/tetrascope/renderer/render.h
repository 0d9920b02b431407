// Headless rendering of tet meshes: an EGL context without a display (Mesa
// llvmpipe here, NVIDIA EGL on GPU hosts), rendering into a framebuffer object.
//
// Modes:
//  - dvr: direct volume rendering by cell projection, in one of two methods (VolumeMethod):
//    projected: Shirley-Tuchman projected tetrahedra - each visible tet's
//    projection is classified on the CPU (both cores) and split into 3 or 4 triangles around
//    a thick vertex carrying front value, back value and thickness, so a fragment does one
//    table lookup on interpolated values; tets reaching the near plane are drawn exactly as
//    below, in their place in the order (on llvmpipe it measured no faster than exact, so it is
//    not the default); exact (the default): every tet's front faces are drawn in
//    back-to-front order (radix sort of centroid depths); each fragment intersects its view
//    ray with the tet's planes to find the exact segment through it (front value, back
//    value, length) and looks up a pre-integrated transfer function table (Engel et al.
//    2001) over (front, back, length). The camera may be inside the mesh: tets that reach
//    the near plane are drawn by their back faces with segments starting at the near plane,
//    and colour is composed in 32-bit floats, so thousands of tiny tets along a ray add up as
//    the exact integrator (reference_render) says;
//  - iso: marching tetrahedra for one or more isovalues, lit, opaque; with dvr and an
//    isosurface opacity below 1, the isosurfaces are composed inside the volume instead: a
//    tet whose ray segment crosses an isovalue composes the part in front, the lit surface,
//    then the part behind (both methods, and reference_render alike);
//  - surface: the mesh boundary coloured by the attribute, lit, with silhouette edges
//    (§7.1) and an optional wireframe; dvr+iso and surface+iso combine;
//  - lines: stream lines (§7.3), lit by the illuminated-lines model, with depth-aware halos
//    and the flow direction as arrowheads or dashes by arc length; with a selection, the
//    selected lines opaque and the others ghosted (semi-transparent, one colour, sorted back
//    to front; §7.3.2). Opaque lines are drawn before the volume and stop its rays; ghosts
//    are blended after it (see renderer/src/lines.cpp for what that costs);
//  - points: many isosurfaces sampled by points, density by area, drawn as lit splats (§7.2);
//  - tensors: a tensor field's stream tubes and diffusion surfaces sampled by points (§7.4.2),
//    tube points lit by the illuminated-lines model about their tangent, surface points by
//    Blinn-Phong about the surface normal, opaque, before the volume.
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

#include "tetrascope/lod/field/streamlines.h"
#include "tetrascope/view/view_request.h"
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
  std::vector<float> rgb;     // reference_render only: the colours before rounding to 8 bits (RGB, top row first)
};

// Stream lines ready to draw (§7.3): points of all lines back to back in flow order, line l
// spanning [line_first[l], line_first[l+1]). Built once per traced set (line_set_from) and
// shared between frames; the renderer uploads a set once and keeps it while the pointer stays.
struct LineSet {
  std::vector<float> xyz;                // interleaved positions
  std::vector<float> flow;               // interleaved field vector at each point
  std::vector<float> value;              // colour value per point (|v|)
  std::vector<uint32_t> line_first{0};   // line count + 1 offsets
  double value_min = 0, value_max = 1;
  double diagonal = 1;                   // of the lines' bounding box (halo depth, arrow spacing)
  std::string field;                     // the vector field traced
  size_t line_count() const { return line_first.size() - 1; }
  size_t point_count() const { return value.size(); }
};
LineSet line_set_from(const lod::Streamlines& lines, const std::string& field);
// The lines passing the box [lo, hi] (§7.3.2's selection box): ids, ascending.
std::vector<uint32_t> lines_in_box(const LineSet& lines, const std::array<double, 3>& lo, const std::array<double, 3>& hi);
// The line drawn nearest pixel (x, y) (top-left origin) of a view, within `max_pixels`: a
// click. Empty when none is that close.
std::vector<uint32_t> line_at_pixel(const LineSet& lines, const view::Camera& camera, uint32_t width, uint32_t height, double x, double y,
                                    double max_pixels = 8);

using view::FlowStyle;

// A tensor field drawn by points (§7.4.2), built once per trace (tensor_points) and shared
// between frames like a LineSet. Stream tubes: the lines of the major eigenvector through
// linear regions (cl at least the request's min_linear), resampled every `spacing` of arc
// length, each sample a ring of kTubeRingPoints points on the ellipse of the cross-section,
// its axes the medium and minor eigenvectors with radii in the ratio of their eigenvalues'
// magnitudes (the smaller at least a quarter of the larger), the larger `radius`. Diffusion
// surfaces (lod/field/diffusion_surfaces.h) through planar regions: points spread over their
// triangles by area, one a spacing² on average (§7.2's sampling). Per point: position, normal
// (the ellipse's outward normal on a tube, the surface's minor eigenvector), tangent (a tube's
// direction; zero on a surface, which the pass takes for a surface point), colour value.
struct TensorPoints {
  std::vector<float> xyz, normal, tangent, value;
  uint64_t tubes = 0, surfaces = 0, tube_points = 0, surface_points = 0, surface_triangles = 0;
  double spacing = 0, radius = 0;        // world units
  bool by_class = true;                  // value is the anisotropy class (0 isotropic, 1 linear, 2 planar)
  double value_min = 0, value_max = 1;   // the colour range of a derived quantity
  std::string field, color;              // the tensor drawn; "class" or the quantity colouring it
  double trace_ms = 0;                   // tracing and sampling
  size_t count() const { return value.size(); }
};
constexpr int kTubeRingPoints = 8;
constexpr uint64_t kMaxTensorPoints = 4'000'000;  // more: the spacing grows until they fit
// The tubes and surfaces of `request` through `mesh` (trusted), resolving an empty field to
// the first tensor attribute. Throws std::invalid_argument for a field that is not a symmetric
// tensor (or none at all), a colour that is neither "class" nor a derived quantity, or
// thresholds outside [0, 1].
TensorPoints tensor_points(const storage::TetMesh& mesh, const view::TensorRequest& request);
// The colours of the classes in "class" colouring (§7.4.4's figure 7.21: red linear, green
// planar, blue isotropic), by Anisotropy order (isotropic, linear, planar), RGB 0..1.
constexpr std::array<std::array<float, 3>, 3> kAnisotropyColors = {{{0.25f, 0.45f, 0.95f}, {0.92f, 0.22f, 0.18f}, {0.20f, 0.78f, 0.30f}}};

// Limits of the line and point passes (checked by Renderer::render).
constexpr double kMaxLineWidth = 32;   // pixels
constexpr double kMaxPointSize = 64;   // pixels
// How the volume is drawn (see the top of this file).
using view::VolumeMethod;

// Tets a volume draw call issues at most: between two, Renderer::render asks
// RenderSettings::should_stop whether to go on. A frame that may be stopped draws smaller
// chunks, sized as it goes so one takes about kStopCheckMs (from kFirstStopChunk tets, at most
// doubling, up to kTetsPerChunk).
constexpr uint32_t kTetsPerChunk = 65536;
constexpr uint32_t kFirstStopChunk = 1024;
constexpr double kStopCheckMs = 30;

// What a frame draws: the view's drawing options, resolved against the dataset (the attribute,
// its colour range, isovalues), and the camera, lines and points as drawn.
struct RenderSettings : view::DrawOptions {
  view::Camera camera;
  bool use_iso_color_attribute = false;  // colour isosurfaces by the scene's iso_color_attribute (else by value)
  std::array<float, 3> background{0.1f, 0.1f, 0.12f};
  // stream lines (§7.3): drawn when set
  std::shared_ptr<const LineSet> lines;
  std::vector<uint32_t> selected_lines;  // ascending ids; empty: every line opaque, else the rest ghosted
  double line_width = 2.5;               // pixels, 1..kMaxLineWidth
  double ghost_opacity = 0.15;           // (0, 1]
  std::array<float, 3> ghost_color{0.85f, 0.88f, 0.95f};
  bool halos = true;                     // depth-aware halos (3x the line width, pushed back)
  FlowStyle flow = FlowStyle::arrows;
  double flow_spacing = 0;               // arc length between arrows or dashes; 0: 1/30 of the lines' diagonal
  double dash_phase = 0;                 // 0..1, moves dashes along the flow (animation)
  // §7.3.3's depth correction, 0..1: the halo's world width is g(d) = g0 * ((1 - c) + c * d / d0)
  // at view depth d (d0: the camera's distance to its target, where sizes are nominal), and the
  // arrows' and dashes' pattern runs by arc length over the same factor. 1 (the dissertation's
  // corrected halos and arrows): the same size in the image at every depth; 0: a fixed size in
  // the world, so far halos are narrower and far arrows shorter, like the geometry. No effect
  // in an orthographic view.
  double depth_correction = 1;
  // a tensor field's tubes and surfaces as lit points (§7.4.2): drawn when set, opaque
  std::shared_ptr<const TensorPoints> tensor_points;
  double tensor_point_size = 0;          // splat diameter in pixels; 0: covering splats
  // point-based isosurfaces (§7.2, DrawOptions::points)
  double point_area = 0;                 // isosurface area a point stands for; 0: total area / point_target
  bool point_depth_scaling = false;      // §7.2: fewer points far away
  // Asked between draw calls (every kTetsPerChunk tets of the volume, and between passes);
  // true stops drawing: the frame is read back as it stands and FrameTimings::interrupted is
  // set. Empty: never stop.
  std::function<bool()> should_stop;
};

struct FrameTimings {
  double sort_ms = 0, draw_ms = 0, readback_ms = 0, encode_ms = 0, total_ms = 0;
  uint64_t tets_drawn = 0, tets_skipped = 0, iso_triangles = 0;
  uint64_t line_segments_opaque = 0, line_segments_ghosted = 0, points = 0, tensor_points = 0;
  bool interrupted = false;  // should_stop said stop: a partial image
  double classify_ms = 0;    // projected tetrahedra: the CPU classification (inside draw_ms)
  double cpu_ms = 0;         // CPU time of the whole process over the frame, every thread (llvmpipe's too): the work, on a shared machine
};

// A mesh prepared for drawing: positions, the chosen attribute's values (vector magnitude
// for vectors, or the chosen component), tets, boundary faces.
struct SceneMesh {
  std::vector<float> xyz;      // interleaved
  std::vector<float> value;    // attribute value per vertex, attribute units
  std::vector<uint32_t> tets;
  std::vector<std::array<uint32_t, 3>> boundary;  // outward
  // per boundary face, its region (boundary_regions.h; kNoRegion: none); empty: no regions known
  std::vector<uint32_t> boundary_region;
  storage::Bounds bounds;
  double diagonal = 1, max_edge = 0;
  std::string attribute;
  int component = view::kMagnitude;  // of a vector attribute: the magnitude or component 0..2 (x, y, z)
  double value_min = 0, value_max = 1;
  // optional: the attribute that colours isosurfaces (`render --iso-color`), per vertex
  std::string iso_color_attribute;
  std::vector<float> iso_color_value;
  double iso_color_min = 0, iso_color_max = 1;
  // every point attribute of the source mesh, vertex-aligned, for the probe (values_at in
  // probe.h); a clipped scene (clip_scene) has none: probe its source
  std::vector<storage::Attribute> attributes;
  // `component`: view::kMagnitude, or a component (0..2) of a vector attribute; throws
  // std::invalid_argument for an attribute the mesh lacks or a component it has not
  static SceneMesh from(const storage::TetMesh& mesh, const std::string& attribute, const std::string& iso_color_attribute = "", int component = view::kMagnitude);
};

// The values the transfer function's colours and opacity span: its range, else the scene's
// values; never empty (lo + 1 when they meet).
inline std::array<double, 2> colour_range(const SceneMesh& mesh, const view::TransferFunction& tf) {
  std::array<double, 2> r{mesh.value_min, mesh.value_max};
  if (tf.range) r = {(*tf.range)[0], (*tf.range)[1]};
  if (!(r[1] > r[0])) r[1] = r[0] + 1;
  return r;
}

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
PreintegrationTable preintegrate(const view::TransferFunction& tf, double lo, double hi, double unit_distance, double max_length, uint32_t n = 128,
                                 uint32_t lengths = 32);

// The transfer function on a fine grid of `blocks` x `cells` intervals over [0, 1], for
// segments whose value changes by less than a bin of the pre-integrated table: there the
// table's interpolation between bins (over a kink of the opacity, say) would veil thin opacity
// over long paths, while the extinction and colour at the segment's middle value give its
// optical depth (length times extinction) and colour. `at` is [block][cells + 1][4]
// (extinction per unit length, colour), a block's last node being the next block's first,
// so that a texture of its rows interpolates within each row only.
struct FineTransfer {
  uint32_t blocks = 0, cells = 0;
  std::vector<float> at;
};
FineTransfer fine_transfer(const view::TransferFunction& tf, double lo, double hi, double unit_distance, uint32_t blocks, uint32_t cells);

// Colour and opacity of one ray segment through a tet, integrated exactly (fine steps): the
// reference the table approximates.
std::array<double, 4> integrate_segment(const view::TransferFunction& tf, double lo, double hi, double unit_distance, double front, double back,
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
  // Gives back what set_mesh uploaded and what frames left behind: the scene's buffers, the
  // framebuffers, the transfer function's table, the isosurface and slice caches (the context
  // and its compiled shaders stay). The next render needs a set_mesh first.
  virtual void release_memory() = 0;
};

// CPU reference: rays through every pixel, tets intersected exactly, segments composed front
// to back with integrate_segment. Small meshes only (tests, PSNR).
Image reference_render(const SceneMesh& mesh, const RenderSettings& settings);

double psnr(const Image& a, const Image& b);  // dB over RGB
std::vector<uint8_t> encode_jpeg(const Image& image, int quality);
std::vector<uint8_t> encode_png(const Image& image);
// A PNG file as RGBA (untrusted: std::invalid_argument naming the file when it is not one).
Image read_png(const std::string& path);
// Writes .png or .jpg/.jpeg by the extension (atomically: temp name, then rename).
void write_image(const std::string& path, const Image& image, int quality);
// image.rgb as a Portable Float Map (little-endian, rows bottom first): a measurement's image
// without the 8-bit rounding, which decides a PSNR above about 50 dB. Throws without image.rgb.
void write_pfm(const std::string& path, const Image& image);

// Marching tetrahedra: triangles (xyz per corner, 9 floats a triangle) where the values cross
// `isovalue`, oriented towards increasing values. With `iso_color`, also the scene's
// iso_color_attribute interpolated at every corner (3 a triangle).
std::vector<float> marching_tets(const SceneMesh& mesh, double isovalue, std::vector<float>* iso_color = nullptr);

// §7.2's point sampling of isosurfaces: the marching-tets triangles of every isovalue,
// subdivided until each is below `area`, then one point a triangle, a triangle smaller than
// `area` kept with probability |t| / area (a fixed table of 100 random numbers, as §7.2).
// `area` 0: the total isosurface area / `target`. Per point: position, unit normal (oriented
// towards increasing values), the isovalue, and a random number in [0, 1) (depth scaling).
struct IsoPoints {
  std::vector<float> xyz, normal, value, dice;
  double area = 0;          // the area a point stands for
  double total_area = 0;    // of all isosurfaces
  uint64_t triangles = 0;   // marching-tets triangles sampled
  size_t count() const { return value.size(); }
};
IsoPoints sample_isosurfaces(const SceneMesh& mesh, const std::vector<double>& isovalues, double area, uint64_t target);
// The isovalues points mode draws when none are given: n regularly spaced inside (lo, hi).
std::vector<double> regular_isovalues(double lo, double hi, uint32_t n);

}  // namespace tetrascope::renderer
