// What a frame is asked for, as the command line (`tetrascope render`) and a viewing session
// (the server's ViewState) build it and the renderer's frame pipeline draws it: the drawing
// options (DrawOptions, which the renderer's RenderSettings carries resolved), the camera,
// the cut's budget, clip planes and the stream lines' request. Fields were checked where they
// arrived (protocol's parsers, the CLI's options); only the dataset can check attribute names.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "tetrascope/view/camera.h"
#include "tetrascope/view/planes.h"
#include "tetrascope/view/transfer_function.h"

namespace tetrascope::view {

// How stream lines show their direction (§7.3.3).
enum class FlowStyle : uint8_t { none, arrows, dashes };
// How the volume is drawn (renderer/render.h says how each works).
enum class VolumeMethod { projected, exact };

// The options a view draws with, in the request and, resolved against the dataset (attribute,
// colour range, isovalues), in what is drawn.
struct DrawOptions {
  bool dvr = true, iso = false, surface = false, wireframe = false, box = false;
  bool points = false;                   // point-based isosurfaces (§7.2)
  uint32_t width = 512, height = 512;
  TransferFunction tf;                   // no attribute: the dataset's first; no range: the attribute's over the whole dataset
  double unit_distance = 0;              // opacity is that of a slab this thick (0: 1/100 of the box diagonal)
  VolumeMethod volume = VolumeMethod::exact;
  std::vector<double> isovalues;         // attribute units; none (with iso): mid-range
  double iso_opacity = 1;                // < 1: semi-transparent isosurfaces
  std::vector<double> point_isovalues;   // points mode; none: 8 regularly spaced over the colour range
  double point_size = 0;                 // splat diameter in pixels; 0: covering splats
  uint64_t point_target = 400000;        // points wanted
  // Slice planes drawn, opaque, coloured through the colormap, lit by the headlight (flat
  // without `slices.lit`), with the tets' edges on them when `slices.edges`; the cut refines
  // where they cross.
  SliceSpec slices;
  // Boundary regions the surface leaves out (renderer/boundary_regions.h): ids ascending, each
  // below the dataset's region count (checked where the request arrived).
  std::vector<uint32_t> hidden_regions;
};

// Stream lines of a view (§7.3): traced on the view's mesh when the field, seeds or steps
// change; the selection and style change without tracing again.
struct LineRequest {
  std::string field;               // a 3-component attribute; empty: the dataset's first
  std::string seeds;               // lod::parse_seeds text (line:, plane:, points:, dense:N); empty: dense:12
  uint32_t max_steps = 2000;       // per direction
  // the opaque lines; none of the three: every line opaque, else the rest ghosted
  std::vector<uint32_t> selected;                  // line ids
  std::optional<std::array<double, 6>> select_box;  // lo x, y, z, hi x, y, z: the lines passing it (§7.3.2)
  std::optional<std::array<double, 2>> select_pixel;  // a click, fractions 0..1 of the image from the top left: the nearest line within 8 pixels
  double line_width = 2.5, ghost_opacity = 0.15;
  bool halos = true;
  FlowStyle flow = FlowStyle::arrows;
  double depth_correction = 1;     // RenderSettings::depth_correction
  double dash_phase = 0;           // RenderSettings::dash_phase
  bool operator==(const LineRequest&) const = default;
};

// Tensor fields drawn by points (§7.4.2): stream tubes along the major eigenvector in linear
// regions and diffusion surfaces in planar ones, each sampled by lit points; traced on the
// view's mesh when the field, seeding or thresholds change, recoloured without tracing.
struct TensorRequest {
  std::string field;               // a symmetric tensor attribute; empty: the dataset's first
  uint32_t tube_cells = 8;         // dense seeding of the tubes: cells along the box's longest side (0: no tubes)
  uint32_t surface_cells = 3;      // dense seeding of the diffusion surfaces (0: no surfaces)
  double min_linear = 0.2;         // cl: a tube runs where the linear anisotropy is at least this
  double min_planar = 0.25;        // cp: a surface grows where the planar anisotropy is at least this
  // "class": red linear, green planar, blue isotropic (the point's own tensor against the two
  // thresholds, the larger measure deciding); else a derived quantity of the tensor
  // (storage::kTensorQuantityNames: lambda1, ..., von_mises, fa, cl, cp, cs) through the colormap
  std::string color = "class";
  double point_size = 0;           // splat diameter in pixels; 0: covering splats
  bool operator==(const TensorRequest&) const = default;
};

struct ViewRequest : DrawOptions {
  ViewRequest() {
    width = 1024;
    height = 768;
  }
  std::optional<Camera> camera;        // none: default_camera of the dataset's bounds
  std::string iso_color_attribute;     // a second attribute colouring the isosurfaces; empty: by value
  bool lines = false;
  LineRequest line;
  bool tensors = false;
  TensorRequest tensor;
  uint64_t budget = 0;                 // tets of the cut (stores only)
  // stores with a vertex hierarchy (vertices.bin): the cut by single vertex splits (the
  // default) or through the segments' DAG
  bool segment_cut = false;
  // a frame while the view moves: the vertex front may take its quicker search (the run-time
  // front alone, lod::FrontSearch::run_time) rather than the better of two
  bool moving = false;
  ClipSpec clip;                       // applied to the scene and to the cut (criteria, assembly)
};

}  // namespace tetrascope::view
