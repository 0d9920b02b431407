// Uniform 1:8 refinement of a tet mesh, streamed to disk: makes the
// 100M+-tet test meshes that gmsh cannot (it needs ~0.5 GB a million tets).
//
//   refine_tets IN OUT.vtk [--field analytic|linear]
//
// Red refinement after J. Bey, "Tetrahedral grid refinement", Computing 55 (1995): every
// edge gets its midpoint, every tet gives its 4 corner tets and the inner octahedron cut
// into 4 along its shortest diagonal (the choice that keeps the children's shapes bounded).
// Faces are cut the same way from both sides, so the output is conforming.
//
// Memory is O(input), never O(output): the input tets and one sorted neighbour list per
// vertex (the edges, which number the midpoints) stay in memory; the 8 children of a tet
// are written as soon as they are made. Output: VTK legacy 3.0 BINARY like
// ../shared/data/make/tetvtk.py writes, with V + E points and 8 T tets. Midpoint k of the
// sorted edge list (by lower, then higher vertex) is point V + k; the children of input tet
// t are cells 8t .. 8t+7. Same input, same bytes.
//
// Point data: `--field analytic` (default) evaluates the documented analytic field of
// ../shared/data/make/analytic_field.py (`analytic_f`, `analytic_grad`, c and L from the
// input's bounding box, which midpoints do not change) at every output vertex, replacing
// or adding those two arrays; every other array, and all of them with `--field linear`,
// gets the average of the edge's two ends at a midpoint.
//
// The input is untrusted and read by storage::MeshStream (any format it reads; tets come
// positively oriented). The output goes to OUT.tmp-PID and is renamed when complete. One
// JSON line on stdout gives counts, volumes, times and peak RSS; progress goes to stderr.
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include "tetrascope/storage/mesh_stream.h"

namespace {

namespace fs = std::filesystem;
namespace ts = tetrascope::storage;

// Point ids and CELLS entries are int32 in the legacy format.
constexpr uint64_t kMaxOutputVertices = std::numeric_limits<int32_t>::max();
constexpr size_t kTetChunk = 1 << 16;            // input tets refined per write
constexpr size_t kWriteBuffer = size_t{8} << 20;  // bytes buffered before a write(2)
constexpr int kVtkTetra = 10;

// --- the analytic field (../shared/data/make/analytic_field.py, term for term) -------------

struct AnalyticField {
  double centre[3] = {0, 0, 0};
  double length = 1;  // largest bounding-box extent

  // f and grad_x f at x (double), in the same order of operations as the numpy original.
  void evaluate(const double x[3], double& f, double grad[3]) const {
    struct Bump {
      double amplitude, a[3], s;
    };
    static constexpr Bump kBumps[3] = {{1.0, {0.15, 0.10, 0.25}, 0.02},
                                       {0.7, {-0.20, -0.10, -0.15}, 0.05},
                                       {-0.5, {0.0, 0.05, -0.30}, 0.01}};
    double u[3];
    for (int i = 0; i < 3; ++i) u[i] = (x[i] - centre[i]) / length;
    f = 0;
    double g[3] = {0, 0, 0};
    for (const Bump& b : kBumps) {
      double d[3] = {u[0] - b.a[0], u[1] - b.a[1], u[2] - b.a[2]};
      double e = b.amplitude * std::exp(-(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) / b.s);
      f += e;
      for (int i = 0; i < 3; ++i) g[i] += (-2.0 / b.s) * e * d[i];
    }
    constexpr double kx = 6 * std::numbers::pi, ky = 4 * std::numbers::pi, kz = 5 * std::numbers::pi;
    double sx = std::sin(kx * u[0]), sy = std::sin(ky * u[1]), cz = std::cos(kz * u[2]);
    f += 0.25 * sx * sy * cz;
    g[0] += 0.25 * kx * std::cos(kx * u[0]) * sy * cz;
    g[1] += 0.25 * ky * sx * std::cos(ky * u[1]) * cz;
    g[2] += -0.25 * kz * sx * sy * std::sin(kz * u[2]);
    for (int i = 0; i < 3; ++i) grad[i] = g[i] / length;
  }
};

// --- the red refinement pattern ---------------------------------------------------------

// Local vertices: corners 0..3, then the midpoints of 01 02 03 12 13 23 as 4..9.
constexpr int kEdgeEnds[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
using Child = std::array<int, 4>;
// The corner tets are the parent shrunk by 1/2 about a corner: same orientation.
constexpr Child kCornerChildren[4] = {{0, 4, 5, 6}, {4, 1, 7, 8}, {5, 7, 2, 9}, {6, 8, 9, 3}};
// The octahedron 4..9 cut along each of its 3 diagonals (01-23, 02-13, 03-12): the diagonal
// and two consecutive vertices of the ring around it.
constexpr int kDiagonals[3][2] = {{4, 9}, {5, 8}, {6, 7}};
constexpr int kRings[3][4] = {{5, 6, 8, 7}, {4, 6, 9, 7}, {4, 5, 9, 8}};

// 6 x signed volume of (a, b, c, d): (b-a)x(c-a).(d-a), in double from the float coordinates
// written, as storage::MeshStream orients.
template <class Real>
double orientation(const Real* pa, const Real* pb, const Real* pc, const Real* pd) {
  const double a[3] = {pa[0], pa[1], pa[2]}, b[3] = {pb[0], pb[1], pb[2]};
  const double c[3] = {pc[0], pc[1], pc[2]}, d[3] = {pd[0], pd[1], pd[2]};
  double ax = b[0] - a[0], ay = b[1] - a[1], az = b[2] - a[2];
  double bx = c[0] - a[0], by = c[1] - a[1], bz = c[2] - a[2];
  double cx = d[0] - a[0], cy = d[1] - a[1], cz = d[2] - a[2];
  return ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx);
}

// Vertex orders of the 8 children for each diagonal, positive in a positive parent: the sign
// of a child relative to its parent is affine invariant, so one reference tet decides it.
struct RedPattern {
  Child children[3][8];
  RedPattern() {
    double p[10][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (int e = 0; e < 6; ++e)
      for (int i = 0; i < 3; ++i) p[4 + e][i] = 0.5 * (p[kEdgeEnds[e][0]][i] + p[kEdgeEnds[e][1]][i]);
    for (int d = 0; d < 3; ++d) {
      for (int c = 0; c < 4; ++c) children[d][c] = kCornerChildren[c];
      for (int r = 0; r < 4; ++r) children[d][4 + r] = {kDiagonals[d][0], kDiagonals[d][1], kRings[d][r], kRings[d][(r + 1) % 4]};
      for (Child& c : children[d]) {
        double v = orientation(p[c[0]], p[c[1]], p[c[2]], p[c[3]]);
        if (v == 0) throw std::logic_error("red refinement pattern: a flat child");
        if (v < 0) std::swap(c[2], c[3]);
      }
    }
  }
};

// --- edges: one sorted list of higher neighbours a vertex ---------------------------------

struct EdgeList {
  std::vector<uint64_t> first;  // vertex v's edges are first[v] .. first[v+1]-1
  std::vector<uint32_t> high;   // the higher end of each edge, sorted within a vertex

  uint64_t count() const { return high.size(); }
  // The index of edge {a, b}; it must exist.
  uint64_t find(uint32_t a, uint32_t b) const {
    if (a > b) std::swap(a, b);
    const uint32_t* begin = high.data() + first[a];
    const uint32_t* end = high.data() + first[a + 1];
    return static_cast<uint64_t>(std::lower_bound(begin, end, b) - high.data());
  }
};

EdgeList build_edges(const std::vector<uint32_t>& tets, size_t vertex_count) {
  EdgeList edges;
  const size_t tet_count = tets.size() / 4;
  edges.first.assign(vertex_count + 1, 0);
  for (size_t t = 0; t < tet_count; ++t)
    for (const auto& e : kEdgeEnds) ++edges.first[std::min(tets[4 * t + e[0]], tets[4 * t + e[1]]) + 1];
  for (size_t v = 0; v < vertex_count; ++v) edges.first[v + 1] += edges.first[v];
  // every tet's copy of every edge, then each vertex's list sorted and made unique in place
  edges.high.resize(6 * tet_count);
  {
    std::vector<uint64_t> fill(edges.first.begin(), edges.first.end() - 1);
    for (size_t t = 0; t < tet_count; ++t)
      for (const auto& e : kEdgeEnds) {
        uint32_t a = tets[4 * t + e[0]], b = tets[4 * t + e[1]];
        edges.high[fill[std::min(a, b)]++] = std::max(a, b);
      }
  }
  uint64_t kept = 0;
  for (size_t v = 0; v < vertex_count; ++v) {
    auto begin = edges.high.begin() + static_cast<ptrdiff_t>(edges.first[v]);
    auto end = edges.high.begin() + static_cast<ptrdiff_t>(edges.first[v + 1]);
    std::sort(begin, end);
    auto last = std::unique(begin, end);
    edges.first[v] = kept;
    kept = static_cast<uint64_t>(std::copy(begin, last, edges.high.begin() + static_cast<ptrdiff_t>(kept)) - edges.high.begin());
  }
  edges.first[vertex_count] = kept;
  edges.high.resize(kept);
  edges.high.shrink_to_fit();
  return edges;
}

// --- output ------------------------------------------------------------------------------

// Big-endian output through one large buffer; the file is removed unless commit() ran.
class VtkOut {
 public:
  VtkOut(fs::path temp, fs::path final_path) : temp_(std::move(temp)), final_(std::move(final_path)) {
    file_ = std::fopen(temp_.c_str(), "wb");
    if (!file_) throw std::runtime_error(temp_.string() + ": cannot write: " + std::strerror(errno));
    buffer_.resize(kWriteBuffer);
  }
  ~VtkOut() {
    if (file_) std::fclose(file_);
    if (!committed_) {
      std::error_code ignored;
      fs::remove(temp_, ignored);
    }
  }
  VtkOut(const VtkOut&) = delete;
  VtkOut& operator=(const VtkOut&) = delete;

  void text(const std::string& s) {
    for (char c : s) {
      if (used_ == buffer_.size()) flush();
      buffer_[used_++] = c;
    }
  }
  void put_float(float v) { put_u32(std::bit_cast<uint32_t>(v)); }
  void put_int(int32_t v) { put_u32(static_cast<uint32_t>(v)); }
  uint64_t bytes() const { return written_ + used_; }

  void commit() {
    flush();
    if (std::fflush(file_) != 0 || std::ferror(file_) != 0 || fsync(fileno(file_)) != 0) fail();
    int closed = std::fclose(file_);
    file_ = nullptr;
    if (closed != 0) fail();
    fs::rename(temp_, final_);
    committed_ = true;
  }

 private:
  void put_u32(uint32_t v) {
    if (used_ + 4 > buffer_.size()) flush();
    if constexpr (std::endian::native == std::endian::little) v = __builtin_bswap32(v);
    std::memcpy(buffer_.data() + used_, &v, 4);
    used_ += 4;
  }
  void flush() {
    if (std::fwrite(buffer_.data(), 1, used_, file_) != used_) fail();
    written_ += used_;
    used_ = 0;
  }
  [[noreturn]] void fail() { throw std::runtime_error(temp_.string() + ": write failed: " + std::strerror(errno)); }

  fs::path temp_, final_;
  std::FILE* file_ = nullptr;
  std::vector<char> buffer_;
  size_t used_ = 0;
  uint64_t written_ = 0;
  bool committed_ = false;
};

std::string legacy_title(const fs::path& in) {
  std::string line, title;
  std::ifstream file(in, std::ios::binary);
  if (std::getline(file, line) && line.rfind("# vtk DataFile", 0) == 0 && std::getline(file, title)) {
    if (!title.empty() && title.back() == '\r') title.pop_back();
    if (!title.empty()) return title;
  }
  return in.filename().string();
}

std::string safe_name(const std::string& name) {
  std::string s;
  for (char c : name) s += (c == ' ' || c == '\t' || c == '\n' || c == '\r') ? '_' : c;
  return s.empty() ? "field" : s;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// An output point array: an input array carried over (averaged at midpoints) or the analytic
// field evaluated everywhere.
struct OutputArray {
  std::string name;
  uint32_t components = 1;
  enum Kind { kInput, kAnalyticF, kAnalyticGrad } kind = kInput;
  const std::vector<float>* values = nullptr;  // kInput: vertex-major input values
};

enum class FieldMode { kAnalytic, kLinear };

struct Options {
  fs::path in, out;
  FieldMode field = FieldMode::kAnalytic;
};

int usage() {
  std::fprintf(stderr,
               "usage: refine_tets IN OUT.vtk [--field analytic|linear]\n"
               "  every tet split 1:8 (edge midpoints, Bey's red refinement); output VTK legacy binary\n");
  return 2;
}

// The input mesh: coordinates (held by the stream), point arrays, tets.
struct InputMesh {
  std::span<const float> xyz;
  std::vector<std::vector<float>> values;  // per point array, vertex-major
  std::vector<uint32_t> tets;
};

// 1. read: coordinates and point arrays, then every tet (positively oriented)
InputMesh read_input(ts::MeshStream& stream) {
  InputMesh input;
  input.values.resize(stream.header().attributes.size());
  ts::VertexChunk vertices;
  while (stream.next_vertices(vertices))
    for (size_t a = 0; a < vertices.attributes.size(); ++a)
      input.values[a].insert(input.values[a].end(), vertices.attributes[a].begin(), vertices.attributes[a].end());
  input.xyz = stream.xyz();
  ts::TetChunk chunk;
  while (stream.next_tets(chunk)) input.tets.insert(input.tets.end(), chunk.tets.begin(), chunk.tets.end());
  return input;
}

// the analytic field's frame: the input's bounding box
AnalyticField analytic_field_frame(const Options& options, std::span<const float> xyz) {
  const size_t vertex_count = xyz.size() / 3;
  AnalyticField field;
  double lo[3], hi[3];
  for (int i = 0; i < 3; ++i) lo[i] = hi[i] = xyz[i];
  for (size_t v = 0; v < vertex_count; ++v)
    for (int i = 0; i < 3; ++i) {
      lo[i] = std::min<double>(lo[i], xyz[3 * v + i]);
      hi[i] = std::max<double>(hi[i], xyz[3 * v + i]);
    }
  field.length = 0;
  for (int i = 0; i < 3; ++i) {
    field.centre[i] = 0.5 * (lo[i] + hi[i]);
    field.length = std::max(field.length, hi[i] - lo[i]);
  }
  if (!(field.length > 0) && options.field == FieldMode::kAnalytic)
    throw ts::MeshError(options.in.string() + ": the bounding box has no extent");
  return field;
}

// The output's point arrays: the input's in order (with --field analytic, analytic_f and
// analytic_grad evaluated instead of carried over), then the analytic ones the input lacks.
std::vector<OutputArray> output_arrays(const ts::MeshHeader& header, const std::vector<std::vector<float>>& input_values, FieldMode mode) {
  std::vector<OutputArray> arrays;
  bool have_f = false, have_grad = false;
  for (size_t a = 0; a < header.attributes.size(); ++a) {
    OutputArray out{header.attributes[a].name, header.attributes[a].components, OutputArray::kInput, &input_values[a]};
    if (mode == FieldMode::kAnalytic && out.name == "analytic_f" && out.components == 1) {
      out.kind = OutputArray::kAnalyticF;
      have_f = true;
    } else if (mode == FieldMode::kAnalytic && out.name == "analytic_grad" && out.components == 3) {
      out.kind = OutputArray::kAnalyticGrad;
      have_grad = true;
    }
    arrays.push_back(out);
  }
  if (mode == FieldMode::kAnalytic && !have_f) arrays.push_back({"analytic_f", 1, OutputArray::kAnalyticF, nullptr});
  if (mode == FieldMode::kAnalytic && !have_grad) arrays.push_back({"analytic_grad", 3, OutputArray::kAnalyticGrad, nullptr});
  return arrays;
}

// Every edge's midpoint, rounded to float, 3 an edge in edge order.
std::vector<float> midpoints(std::span<const float> xyz, const EdgeList& edges) {
  const size_t vertex_count = xyz.size() / 3;
  std::vector<float> mid(3 * edges.count());
  for (uint32_t a = 0; a < vertex_count; ++a)
    for (uint64_t e = edges.first[a]; e < edges.first[a + 1]; ++e)
      for (int i = 0; i < 3; ++i)
        mid[3 * e + i] = static_cast<float>((double(xyz[3 * size_t{a} + i]) + double(xyz[3 * size_t{edges.high[e]} + i])) * 0.5);
  return mid;
}

// The refined mesh's points: the input's vertices, then one midpoint an edge.
struct RefinedPoints {
  std::span<const float> xyz;     // the input's coordinates
  size_t vertex_count;            // the input's vertices
  const EdgeList& edges;
  std::span<const float> mid;     // the midpoints as written
};

// The file header (the input's title) and POINTS.
void write_points(VtkOut& out, const fs::path& in, const RefinedPoints& points, uint64_t out_vertices) {
  std::string title = legacy_title(in) + " refined 1:8";
  for (char& c : title)
    if (c == '\n' || c == '\r') c = ' ';
  out.text("# vtk DataFile Version 3.0\n" + title.substr(0, 250) + "\nBINARY\nDATASET UNSTRUCTURED_GRID\n");
  out.text("POINTS " + std::to_string(out_vertices) + " float\n");
  for (float v : points.xyz) out.put_float(v);
  for (float v : points.mid) out.put_float(v);
}

// What writing the cells measured.
struct CellStats {
  double volume_in = 0, volume_out = 0;
  uint64_t diagonal_use[3] = {0, 0, 0}, children_flipped = 0, children_flat = 0;
};

// CELLS and CELL_TYPES: each input tet's 8 children, its octahedron cut along the shortest
// diagonal, every child positively oriented in the coordinates written.
void write_cells(VtkOut& out, const std::vector<uint32_t>& tets, const RefinedPoints& points, uint64_t out_tets, CellStats& stats) {
  const std::span<const float> xyz = points.xyz, mid = points.mid;
  const size_t vertex_count = points.vertex_count;
  const EdgeList& edges = points.edges;
  const size_t tet_count = tets.size() / 4;
  out.text("\nCELLS " + std::to_string(out_tets) + " " + std::to_string(5 * out_tets) + "\n");
  static const RedPattern kPattern;
  for (size_t t = 0; t < tet_count; ++t) {
    uint32_t id[10];
    const float* p[10];
    for (int c = 0; c < 4; ++c) {
      id[c] = tets[4 * t + c];
      p[c] = &xyz[3 * size_t{id[c]}];
    }
    for (int e = 0; e < 6; ++e) {
      uint64_t edge = edges.find(id[kEdgeEnds[e][0]], id[kEdgeEnds[e][1]]);
      id[4 + e] = static_cast<uint32_t>(vertex_count + edge);
      p[4 + e] = &mid[3 * edge];
    }
    int diagonal = 0;
    double shortest = std::numeric_limits<double>::infinity();
    for (int d = 0; d < 3; ++d) {
      const float* a = p[kDiagonals[d][0]];
      const float* b = p[kDiagonals[d][1]];
      double length2 = 0;
      for (int i = 0; i < 3; ++i) length2 += (double(a[i]) - b[i]) * (double(a[i]) - b[i]);
      if (length2 < shortest) shortest = length2, diagonal = d;
    }
    ++stats.diagonal_use[diagonal];
    stats.volume_in += orientation(p[0], p[1], p[2], p[3]) / 6;
    for (Child c : kPattern.children[diagonal]) {
      // rounding the midpoints to float can flip a child of a near-flat parent; write it as the
      // reader would orient it
      double v = orientation(p[c[0]], p[c[1]], p[c[2]], p[c[3]]);
      if (v < 0) {
        std::swap(c[2], c[3]);
        v = orientation(p[c[0]], p[c[1]], p[c[2]], p[c[3]]);
        ++stats.children_flipped;
      }
      if (v == 0) ++stats.children_flat;
      stats.volume_out += v / 6;
      out.put_int(4);
      for (int k : c) out.put_int(static_cast<int32_t>(id[k]));
    }
  }
  out.text("\nCELL_TYPES " + std::to_string(out_tets) + "\n");
  for (uint64_t t = 0; t < out_tets; ++t) out.put_int(kVtkTetra);
  out.text("\n");
}

// The analytic field against the input's own values.
struct FieldCheck {
  double max_f_difference = 0, max_f = 0;
};

// One point array's values at every output point: an input array carried over and averaged
// at the midpoints, or the analytic field evaluated (and checked against the input's values).
void write_array(VtkOut& out, const OutputArray& array, const AnalyticField& field, const RefinedPoints& points, FieldCheck& check) {
  const std::span<const float> xyz = points.xyz, mid = points.mid;
  const size_t vertex_count = points.vertex_count;
  const EdgeList& edges = points.edges;
  if (array.kind == OutputArray::kInput) {
    const std::vector<float>& values = *array.values;
    for (float v : values) out.put_float(v);
    for (uint32_t a = 0; a < vertex_count; ++a)
      for (uint64_t e = edges.first[a]; e < edges.first[a + 1]; ++e)
        for (uint32_t i = 0; i < array.components; ++i)
          out.put_float(static_cast<float>(
              (double(values[a * size_t{array.components} + i]) + double(values[edges.high[e] * size_t{array.components} + i])) * 0.5));
    return;
  }
  auto put = [&](const double x[3]) {
    double f, grad[3];
    field.evaluate(x, f, grad);
    if (array.kind == OutputArray::kAnalyticF) out.put_float(static_cast<float>(f));
    else
      for (double g : grad) out.put_float(static_cast<float>(g));
    return f;
  };
  for (size_t v = 0; v < vertex_count; ++v) {
    double x[3] = {xyz[3 * v], xyz[3 * v + 1], xyz[3 * v + 2]};
    double f = put(x);
    if (array.kind == OutputArray::kAnalyticF && array.values) {
      check.max_f_difference = std::max(check.max_f_difference, std::abs(f - double((*array.values)[v])));
      check.max_f = std::max(check.max_f, std::abs(f));
    }
  }
  for (uint64_t e = 0; e < edges.count(); ++e) {
    double x[3] = {mid[3 * e], mid[3 * e + 1], mid[3 * e + 2]};
    put(x);
  }
}

// POINT_DATA (when there are arrays): 1-component arrays as SCALARS, then 3-component ones as
// VECTORS, then any others in one FIELD block.
void write_point_data(VtkOut& out, const std::vector<OutputArray>& arrays, const AnalyticField& field, const RefinedPoints& points, uint64_t out_vertices,
                      FieldCheck& check) {
  if (arrays.empty()) return;
  out.text("POINT_DATA " + std::to_string(out_vertices) + "\n");
  auto block = [&](const OutputArray& array) {
    out.text(array.components == 1 ? "SCALARS " + safe_name(array.name) + " float 1\nLOOKUP_TABLE default\n"
                                   : "VECTORS " + safe_name(array.name) + " float\n");
    write_array(out, array, field, points, check);
    out.text("\n");
  };
  for (const OutputArray& a : arrays)
    if (a.components == 1) block(a);
  for (const OutputArray& a : arrays)
    if (a.components == 3) block(a);
  std::vector<const OutputArray*> other;
  for (const OutputArray& a : arrays)
    if (a.components != 1 && a.components != 3) other.push_back(&a);
  if (!other.empty()) {
    out.text("FIELD FieldData " + std::to_string(other.size()) + "\n");
    for (const OutputArray* a : other) {
      out.text(safe_name(a->name) + " " + std::to_string(a->components) + " " + std::to_string(out_vertices) + " float\n");
      write_array(out, *a, field, points, check);
      out.text("\n");
    }
  }
}

int run(const Options& options) {
  const auto start = std::chrono::steady_clock::now();

  // 1. read: coordinates and point arrays, then every tet (positively oriented)
  auto stream = ts::MeshStream::open(options.in);
  const ts::MeshHeader& header = stream->header();
  const InputMesh input = read_input(*stream);
  const std::span<const float> xyz = input.xyz;
  const size_t vertex_count = xyz.size() / 3;
  const std::vector<uint32_t>& tets = input.tets;
  const size_t tet_count = tets.size() / 4;
  if (tet_count == 0) throw ts::MeshError(options.in.string() + ": no tetrahedra to refine");
  const double read_seconds = seconds_since(start);
  std::fprintf(stderr, "refine_tets: read %zu vertices, %zu tets in %.1f s\n", vertex_count, tet_count, read_seconds);

  // 2. edges
  auto phase = std::chrono::steady_clock::now();
  const EdgeList edges = build_edges(tets, vertex_count);
  const uint64_t out_vertices = vertex_count + edges.count(), out_tets = 8 * uint64_t{tet_count};
  if (out_vertices > kMaxOutputVertices)
    throw ts::MeshError(options.in.string() + ": the refined mesh would have " + std::to_string(out_vertices) +
                        " points, more than the 2^31-1 a legacy VTK file can index");
  const double edge_seconds = seconds_since(phase);
  std::fprintf(stderr, "refine_tets: %llu edges in %.1f s; writing %llu points, %llu tets\n",
               static_cast<unsigned long long>(edges.count()), edge_seconds,
               static_cast<unsigned long long>(out_vertices), static_cast<unsigned long long>(out_tets));

  const AnalyticField field = analytic_field_frame(options, xyz);
  const std::vector<OutputArray> arrays = output_arrays(header, input.values, options.field);

  // 3. write: points, cells, types, point data, each streamed in output order
  phase = std::chrono::steady_clock::now();
  // The midpoints, rounded to float once and kept (12 bytes an edge): orientations, diagonals
  // and the field are computed from exactly the coordinates written. Recomputing them in place
  // is not safe: GCC 12 at -O3 (C++ has -fexcess-precision=fast) vectorized a
  // double->float->double round trip away, and a child of a sliver came out inverted.
  const std::vector<float> mid = midpoints(xyz, edges);
  const RefinedPoints points{xyz, vertex_count, edges, mid};
  fs::path temp = options.out;
  temp += ".tmp-" + std::to_string(getpid());
  VtkOut out(temp, options.out);
  write_points(out, options.in, points, out_vertices);
  CellStats cells;
  write_cells(out, tets, points, out_tets, cells);
  FieldCheck check;  // the analytic field against the input's own values
  write_point_data(out, arrays, field, points, out_vertices, check);
  const uint64_t out_bytes = out.bytes();
  out.commit();
  const double write_seconds = seconds_since(phase);

  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const ts::ReadStats& stats = stream->stats();
  std::printf(
      "{\"input\": \"%s\", \"output\": \"%s\", \"field\": \"%s\", \"input_vertices\": %zu, \"input_tets\": %zu, "
      "\"edges\": %llu, \"output_vertices\": %llu, \"output_tets\": %llu, \"output_bytes\": %llu, "
      "\"volume_in\": %.17g, \"volume_out\": %.17g, \"input_degenerate\": %llu, \"input_inverted\": %llu, "
      "\"children_flipped\": %llu, \"children_flat\": %llu, \"diagonals\": [%llu, %llu, %llu], "
      "\"analytic_max_abs_difference_at_input_vertices\": %.3g, \"analytic_max_abs\": %.6g, "
      "\"read_seconds\": %.2f, \"edge_seconds\": %.2f, \"write_seconds\": %.2f, \"seconds\": %.2f, \"peak_rss_bytes\": %llu}\n",
      options.in.c_str(), options.out.c_str(), options.field == FieldMode::kAnalytic ? "analytic" : "linear", vertex_count,
      tet_count, static_cast<unsigned long long>(edges.count()), static_cast<unsigned long long>(out_vertices),
      static_cast<unsigned long long>(out_tets), static_cast<unsigned long long>(out_bytes), cells.volume_in, cells.volume_out,
      static_cast<unsigned long long>(stats.degenerate), static_cast<unsigned long long>(stats.inverted),
      static_cast<unsigned long long>(cells.children_flipped), static_cast<unsigned long long>(cells.children_flat),
      static_cast<unsigned long long>(cells.diagonal_use[0]), static_cast<unsigned long long>(cells.diagonal_use[1]),
      static_cast<unsigned long long>(cells.diagonal_use[2]), check.max_f_difference, check.max_f, read_seconds, edge_seconds, write_seconds,
      seconds_since(start), static_cast<unsigned long long>(usage.ru_maxrss) * 1024);
  for (const std::string& w : stats.warnings) std::fprintf(stderr, "refine_tets: warning: %s\n", w.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options options;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    if (arg == "--field" && i + 1 < argc) {
      std::string mode = argv[++i];
      if (mode == "analytic") options.field = FieldMode::kAnalytic;
      else if (mode == "linear") options.field = FieldMode::kLinear;
      else {
        std::fprintf(stderr, "refine_tets: --field must be analytic or linear, not '%s'\n", mode.c_str());
        return usage();
      }
    } else if (arg.size() > 1 && arg[0] == '-') {
      std::fprintf(stderr, "refine_tets: unknown option '%s'\n", arg.c_str());
      return usage();
    } else {
      positional.push_back(arg);
    }
  }
  if (positional.size() != 2) return usage();
  options.in = positional[0];
  options.out = positional[1];
  std::error_code ec;
  if (fs::equivalent(options.in, options.out, ec)) {
    std::fprintf(stderr, "refine_tets: %s: the output would replace the input\n", options.out.c_str());
    return 2;
  }
  try {
    return run(options);
  } catch (const std::exception& e) {  // MeshError names the file and offset; I/O errors the file
    std::fprintf(stderr, "refine_tets: %s\n", e.what());
    return 1;
  }
}
