// OpenFOAM cases: a case folder (or a `.foam` / `.OpenFOAM` file in it, as ParaView opens
// them) with constant/polyMesh/{points,faces,owner,neighbour} and time folders holding
// volScalarField, volVectorField, volSymmTensorField and volTensorField files, ASCII or
// binary, each optionally gzip-compressed.
// Format: OpenFOAM user guide, "Mesh description" and "Data file format".
//
// Cells become VTK cells: a cell of 4 triangles is a tet, of a quad and 4 triangles a
// pyramid, of 2 triangles and 3 quads a wedge, of 6 quads on 8 points a hexahedron (each then
// split as any cell of its type); any other polyhedron is decomposed about a point at its
// centre (the mean of its points): a triangle face gives one tet, a quad face two (cut by the
// diagonal through its point of smallest id, as hexahedra are, so neighbours agree), a face of
// more points one tet per edge about a point at the face's centre. Fields are cell data: the
// latest time folder's fields, averaged at the vertices by volume like any cell data, a
// decomposed polyhedron counting as one cell of its whole volume. The case is read whole:
// memory follows the mesh, not a chunk.
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

namespace fs = std::filesystem;

// One OpenFOAM file read whole, its FoamFile header parsed, and a parser over the rest.
class FoamText {
 public:
  FoamText(const fs::path& path, const ReadLimits& limits);
  bool binary = false;
  int label_bytes = 4, scalar_bytes = 8;
  std::string cls;  // the header's class

  [[noreturn]] void fail(const std::string& what) const {
    throw MeshError(name_ + ": line " + std::to_string(1 + std::count(bytes_.begin(), bytes_.begin() + static_cast<std::ptrdiff_t>(std::min(at_, bytes_.size())), '\n')) + ": " + what);
  }
  void skip();  // white space and comments
  bool next_is(char c) {
    skip();
    return at_ < bytes_.size() && bytes_[at_] == c;
  }
  void expect(char c, const char* what) {
    if (!next_is(c)) fail(std::string("expected '") + c + "' " + what);
    ++at_;
  }
  std::string word();
  int64_t label(const char* what);
  double scalar(const char* what);
  // A list's count and its '(' (or N{value}: `uniform` true); the count is checked against
  // the bytes left at `least` bytes an item.
  uint64_t open_list(const char* what, size_t least, bool* uniform = nullptr);
  void close_list(const char* what) { expect(')', what); }
  // `n` raw items of `size` bytes (binary lists), little-endian as written on x86.
  const char* raw(uint64_t n, size_t size, const char* what);
  double raw_scalar(const char* p) const;
  int64_t raw_label(const char* p) const;
  // Moves past the next entry named `key` at this dictionary level; false at the end.
  bool find_entry(const std::string& key);
  // The text of the entry just named, up to its ';' (consumed); a sub-dictionary's value is
  // read past whole and gives "{}".
  std::string entry_value();

 private:
  std::string name_;
  std::string bytes_;
  size_t at_ = 0;
};

std::string read_whole(const fs::path& path, const ReadLimits& limits, std::string& name) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    name = path.string();
    std::ifstream in(path, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  }
  fs::path gz = path;
  gz += ".gz";
  name = gz.string();
  if (!fs::is_regular_file(gz, ec)) throw MeshError(path.string() + ": missing (an OpenFOAM case needs it)");
  const uint64_t limit = limits.max_inflated_bytes(fs::file_size(gz, ec));
  gzFile file = gzopen(gz.c_str(), "rb");
  if (!file) throw MeshError(name + ": cannot be opened");
  std::string out;
  char buffer[1 << 16];
  int n = 0;
  while ((n = gzread(file, buffer, sizeof buffer)) > 0) {
    out.append(buffer, static_cast<size_t>(n));
    if (out.size() > limit) {
      gzclose(file);
      throw MeshError(name + ": inflates past " + std::to_string(limit) + " bytes (raise --max-inflate-ratio if the file is genuine)");
    }
  }
  const bool bad = n < 0;
  gzclose(file);
  if (bad) throw MeshError(name + ": damaged gzip data");
  return out;
}

FoamText::FoamText(const fs::path& path, const ReadLimits& limits) {
  bytes_ = read_whole(path, limits, name_);
  skip();
  if (word() != "FoamFile") fail("not an OpenFOAM file (no FoamFile header)");
  expect('{', "after FoamFile");
  while (!next_is('}')) {
    const std::string key = word();
    skip();
    std::string value;
    while (at_ < bytes_.size() && bytes_[at_] != ';' && bytes_[at_] != '}') value += bytes_[at_++];
    if (!next_is(';')) fail("FoamFile entry '" + key + "' has no ';'");
    ++at_;
    while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.pop_back();
    if (key == "format") binary = value == "binary";
    else if (key == "class") cls = value;
    else if (key == "arch") {
      if (value.find("label=64") != std::string::npos) label_bytes = 8;
      if (value.find("scalar=32") != std::string::npos) scalar_bytes = 4;
    }
  }
  ++at_;
}

void FoamText::skip() {
  while (at_ < bytes_.size()) {
    const char c = bytes_[at_];
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
      ++at_;
    } else if (c == '/' && at_ + 1 < bytes_.size() && bytes_[at_ + 1] == '/') {
      while (at_ < bytes_.size() && bytes_[at_] != '\n') ++at_;
    } else if (c == '/' && at_ + 1 < bytes_.size() && bytes_[at_ + 1] == '*') {
      const size_t end = bytes_.find("*/", at_ + 2);
      at_ = end == std::string::npos ? bytes_.size() : end + 2;
    } else {
      return;
    }
  }
}

std::string FoamText::word() {
  skip();
  const size_t start = at_;
  while (at_ < bytes_.size() && !std::strchr(" \t\r\n;{}()[]", bytes_[at_])) ++at_;
  return bytes_.substr(start, at_ - start);
}

int64_t FoamText::label(const char* what) {
  const std::string w = word();
  char* end = nullptr;
  const long long v = std::strtoll(w.c_str(), &end, 10);
  if (w.empty() || *end != '\0') fail(std::string("expected ") + what + ", got '" + w.substr(0, 40) + "'");
  return v;
}

double FoamText::scalar(const char* what) {
  const std::string w = word();
  char* end = nullptr;
  const double v = std::strtod(w.c_str(), &end);
  if (w.empty() || *end != '\0') fail(std::string("expected ") + what + ", got '" + w.substr(0, 40) + "'");
  return v;
}

uint64_t FoamText::open_list(const char* what, size_t least, bool* uniform) {
  const int64_t n = label(what);
  if (n < 0 || static_cast<uint64_t>(n) > (bytes_.size() - at_) / std::max<size_t>(least, 1) + 1) fail(std::string(what) + " " + std::to_string(n) + " does not fit in the file");
  if (uniform) *uniform = next_is('{');
  if (uniform && *uniform) {
    ++at_;
    return static_cast<uint64_t>(n);
  }
  expect('(', what);
  return static_cast<uint64_t>(n);
}

const char* FoamText::raw(uint64_t n, size_t size, const char* what) {
  if (n * size > bytes_.size() - at_) fail(std::string(what) + ": the file ends inside the binary list");
  const char* p = bytes_.data() + at_;
  at_ += static_cast<size_t>(n * size);
  return p;
}

double FoamText::raw_scalar(const char* p) const {
  if (scalar_bytes == 4) {
    float f;
    std::memcpy(&f, p, 4);
    return f;
  }
  double d;
  std::memcpy(&d, p, 8);
  return d;
}

int64_t FoamText::raw_label(const char* p) const {
  if (label_bytes == 8) {
    int64_t v;
    std::memcpy(&v, p, 8);
    return v;
  }
  int32_t v;
  std::memcpy(&v, p, 4);
  return v;
}

bool FoamText::find_entry(const std::string& key) {
  for (;;) {
    skip();
    if (at_ >= bytes_.size()) return false;
    if (word() == key) return true;
    int depth = 0;  // skip the entry: to its ';' or its closing '}'
    while (at_ < bytes_.size()) {
      const char c = bytes_[at_++];
      if (c == '(' || c == '[' || c == '{') ++depth;
      else if (c == ')' || c == ']' || c == '}') {
        if (--depth == 0 && c == '}') break;
      } else if (c == ';' && depth == 0) break;
    }
  }
}

std::string FoamText::entry_value() {
  skip();
  if (next_is('{')) {
    int depth = 0;
    while (at_ < bytes_.size()) {
      const char c = bytes_[at_++];
      if (c == '{') ++depth;
      else if (c == '}' && --depth == 0) return "{}";
    }
    fail("a sub-dictionary has no closing '}'");
  }
  std::string value;
  int depth = 0;
  while (at_ < bytes_.size() && (depth > 0 || (bytes_[at_] != ';' && bytes_[at_] != '}'))) {
    const char c = bytes_[at_++];
    if (c == '(' || c == '[') ++depth;
    else if (c == ')' || c == ']') --depth;
    value += c;
  }
  if (!next_is(';')) fail("an entry has no ';'");
  ++at_;
  while (!value.empty() && std::strchr(" \t\r\n", value.back())) value.pop_back();
  return value;
}

std::vector<int64_t> read_labels(FoamText& f, const char* what) {
  const uint64_t n = f.open_list(what, f.binary ? static_cast<size_t>(f.label_bytes) : 2);
  std::vector<int64_t> out(n);
  if (f.binary) {
    const char* p = f.raw(n, static_cast<size_t>(f.label_bytes), what);
    for (uint64_t i = 0; i < n; ++i) out[i] = f.raw_label(p + i * static_cast<uint64_t>(f.label_bytes));
  } else {
    for (auto& v : out) v = f.label(what);
  }
  f.close_list(what);
  return out;
}

// n vectors (ASCII "(x y z)") or n scalars into out (components each).
void read_values(FoamText& f, uint64_t n, uint32_t components, std::vector<double>& out, const char* what) {
  out.resize(n * components);
  if (f.binary) {
    const char* p = f.raw(n * components, static_cast<size_t>(f.scalar_bytes), what);
    for (uint64_t i = 0; i < n * components; ++i) out[i] = f.raw_scalar(p + i * static_cast<uint64_t>(f.scalar_bytes));
    return;
  }
  for (uint64_t i = 0; i < n; ++i) {
    if (components > 1) f.expect('(', what);
    for (uint32_t k = 0; k < components; ++k) out[i * components + k] = f.scalar(what);
    if (components > 1) f.expect(')', what);
  }
}

// faces as CSR: faceList "n(a b c)" or faceCompactList (offsets, then the points).
void read_faces(FoamText& f, std::vector<uint64_t>& offsets, std::vector<int64_t>& points) {
  offsets.assign(1, 0);
  points.clear();
  if (f.cls == "faceCompactList") {
    const std::vector<int64_t> starts = read_labels(f, "face offsets");
    points = read_labels(f, "face points");
    if (starts.empty() || starts.front() != 0 || static_cast<uint64_t>(starts.back()) != points.size()) f.fail("face offsets do not match the face points");
    for (size_t i = 1; i < starts.size(); ++i) {
      if (starts[i] < starts[i - 1]) f.fail("face offsets go backwards at face " + std::to_string(i - 1));
      offsets.push_back(static_cast<uint64_t>(starts[i]));
    }
    return;
  }
  const uint64_t n = f.open_list("face count", 8);
  offsets.reserve(n + 1);
  for (uint64_t i = 0; i < n; ++i) {
    const int64_t size = f.label("a face's point count");
    if (size < 3 || size > 10000) f.fail("face " + std::to_string(i) + " has " + std::to_string(size) + " points");
    f.expect('(', "before a face's points");
    for (int64_t k = 0; k < size; ++k) points.push_back(f.label("a face's point"));
    f.expect(')', "after a face's points");
    offsets.push_back(points.size());
  }
  f.close_list("faces");
}

struct Field {
  AttributeInfo info;
  std::vector<float> values;  // per cell
};

// Components of a field class that is read; 0 for any other class.
uint32_t field_components(const std::string& cls) {
  if (cls == "volScalarField") return 1;
  if (cls == "volVectorField") return 3;
  if (cls == "volSymmTensorField") return 6;  // XX XY XZ YY YZ ZZ
  if (cls == "volTensorField") return 9;      // XX XY XZ YX YY YZ ZX ZY ZZ: VTK's row-major order
  return 0;
}

// A symmetric tensor's values from OpenFOAM's order (XX XY XZ YY YZ ZZ) to VTK's (xx yy zz xy yz xz).
void to_vtk_symmetric_order(std::vector<float>& values) {
  for (size_t i = 0; i + 6 <= values.size(); i += 6) {
    const float xx = values[i], xy = values[i + 1], xz = values[i + 2], yy = values[i + 3], yz = values[i + 4], zz = values[i + 5];
    const float vtk[6] = {xx, yy, zz, xy, yz, xz};
    std::copy_n(vtk, 6, values.begin() + static_cast<std::ptrdiff_t>(i));
  }
}

// internalField of a field of one of the classes above: uniform or nonuniform. A tensor value
// that is not a finite 32-bit float is an error (no eigen-analysis can use it).
Field read_field(const fs::path& path, const ReadLimits& limits, uint64_t cells, ReadStats& stats) {
  FoamText f(path, limits);
  const uint32_t components = field_components(f.cls);
  const bool tensor = components == 6 || components == 9;
  Field field{{path.filename().string(), components, tensor ? AttributeKind::kTensor : AttributeKind::kValue}, {}};
  if (field.info.name.size() > 3 && field.info.name.substr(field.info.name.size() - 3) == ".gz") field.info.name.resize(field.info.name.size() - 3);
  if (!f.find_entry("internalField")) f.fail("no internalField");
  const std::string kind = f.word();
  std::vector<double> values;
  if (kind == "uniform") {
    // a uniform value is text even in a binary file (OpenFOAM writes it as tokens)
    const bool binary = f.binary;
    f.binary = false;
    read_values(f, 1, components, values, "a uniform value");
    f.binary = binary;
    field.values.resize(cells * components);
    for (uint64_t c = 0; c < cells; ++c)
      for (uint32_t k = 0; k < components; ++k)
        if (!to_stored_float(values[k], field.values[c * components + k]) && tensor) f.fail("tensor '" + field.info.name + "': a value is not a finite 32-bit float");
    if (components == 6) to_vtk_symmetric_order(field.values);
    return field;
  }
  if (kind != "nonuniform") f.fail("internalField must be uniform or nonuniform, not '" + kind + "'");
  f.word();  // List<scalar> / List<vector>
  bool uniform = false;
  const uint64_t n = f.open_list("internalField count", f.binary ? static_cast<size_t>(f.scalar_bytes) * components : 2, &uniform);
  if (n != cells) f.fail("internalField has " + std::to_string(n) + " values for " + std::to_string(cells) + " cells");
  read_values(f, uniform ? 1 : n, components, values, "internalField");
  if (uniform) {
    f.expect('}', "after a uniform list value");
    values.resize(n * components);
    for (uint64_t c = 1; c < n; ++c) std::copy_n(values.begin(), components, values.begin() + static_cast<std::ptrdiff_t>(c * components));
  } else {
    f.close_list("internalField");
  }
  field.values.resize(values.size());
  for (size_t i = 0; i < values.size(); ++i) {
    if (to_stored_float(values[i], field.values[i])) continue;
    if (tensor) f.fail("tensor '" + field.info.name + "': value " + std::to_string(i / components) + " is not a finite 32-bit float");
    ++stats.nonfinite_attribute_values;
  }
  if (components == 6) to_vtk_symmetric_order(field.values);
  return field;
}

// What a cell becomes.
enum class Shape : uint8_t { kTet, kPyramid, kWedge, kHex, kPolyhedron };

class OpenFoamReader final : public FormatReader {
 public:
  OpenFoamReader(fs::path path, const ReadLimits& limits) : path_(std::move(path)), limits_(limits) {}
  MeshHeader index(ReadStats& stats) override;
  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override;
  bool read_cells(CellBatch& batch, size_t max_cells) override;
  void read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) override;
  void rewind_cells() override { next_cell_ = 0; }

 private:
  void read_mesh(const fs::path& mesh);
  void classify(ReadStats& stats);
  void read_fields(const fs::path& folder, ReadStats& stats);
  void finish_header(const std::string& when);
  // The cell's points with, for a hexahedron or wedge, the VTK order; false when its faces do
  // not make the shape.
  bool vtk_order(uint64_t cell, Shape shape, std::vector<uint32_t>& out) const;
  void decompose(uint64_t cell, CellBatch& batch);
  // polyMesh/boundary's patches: each patch's faces as tagged triangles, cut as the tets are.
  void read_patches(const fs::path& mesh);
  FaceTags take_face_tags() override { return std::move(face_tags_); }

  fs::path path_;
  ReadLimits limits_;
  MeshHeader header_;
  std::vector<double> points_;                 // 3 a point
  std::vector<uint64_t> face_offsets_;
  std::vector<int64_t> face_points_;
  std::vector<uint64_t> cell_offsets_;         // CSR of cell -> faces
  std::vector<uint64_t> cell_faces_;
  std::vector<Shape> shapes_;
  std::vector<uint32_t> centre_;               // per cell: its centre point (polyhedra)
  std::vector<uint32_t> face_centre_;          // per face: its centre point (faces of > 4 points of polyhedra)
  std::vector<float> extra_xyz_;               // the centre points
  uint64_t internal_faces_ = 0;                // faces with a neighbour (the first ones)
  FaceTags face_tags_;
  std::vector<Field> fields_;
  uint64_t cells_ = 0, next_cell_ = 0, vertices_given_ = 0;
  std::vector<uint64_t> batch_cells_;          // per entry of the last batch: its cell
  std::vector<uint64_t> order_offsets_{0};     // per cell: its VTK points (none for a polyhedron), CSR
  std::vector<uint32_t> orders_;
  mutable std::vector<std::pair<uint32_t, uint32_t>> edges_;  // vtk_order's scratch
};

void OpenFoamReader::read_mesh(const fs::path& mesh) {
  {
    FoamText f(mesh / "points", limits_);
    const uint64_t n = f.open_list("point count", f.binary ? 3 * static_cast<size_t>(f.scalar_bytes) : 6);
    if (n >= std::numeric_limits<uint32_t>::max() / 2) f.fail(std::to_string(n) + " points are more than tetrascope reads");
    read_values(f, n, 3, points_, "a point");
    f.close_list("points");
    for (double v : points_)
      if (float x; !to_stored_float(v, x)) f.fail(not_a_float_message("point coordinate", v));
  }
  FoamText faces(mesh / "faces", limits_);
  read_faces(faces, face_offsets_, face_points_);
  const uint64_t face_count = face_offsets_.size() - 1, point_count = points_.size() / 3;
  for (int64_t p : face_points_)
    if (p < 0 || static_cast<uint64_t>(p) >= point_count) faces.fail("a face names point " + std::to_string(p) + " of " + std::to_string(point_count));
  FoamText owner_file(mesh / "owner", limits_);
  const std::vector<int64_t> owner = read_labels(owner_file, "owner count");
  FoamText neighbour_file(mesh / "neighbour", limits_);
  const std::vector<int64_t> neighbour = read_labels(neighbour_file, "neighbour count");
  if (owner.size() != face_count) owner_file.fail("owner has " + std::to_string(owner.size()) + " entries for " + std::to_string(face_count) + " faces");
  if (neighbour.size() > face_count) neighbour_file.fail("neighbour has more entries than there are faces");
  internal_faces_ = neighbour.size();
  int64_t largest = -1;
  for (int64_t c : owner) largest = std::max(largest, c);
  for (int64_t c : neighbour) largest = std::max(largest, c);
  cells_ = static_cast<uint64_t>(largest + 1);
  if (cells_ > face_count) owner_file.fail("cell " + std::to_string(largest) + " is more than the faces can close");
  std::vector<uint64_t> count(cells_ + 1, 0);
  auto check = [&](FoamText& f, int64_t c, size_t i) {
    if (c < 0) f.fail("face " + std::to_string(i) + " names cell " + std::to_string(c));
    return static_cast<uint64_t>(c);
  };
  for (size_t i = 0; i < owner.size(); ++i) ++count[check(owner_file, owner[i], i) + 1];
  for (size_t i = 0; i < neighbour.size(); ++i) ++count[check(neighbour_file, neighbour[i], i) + 1];
  for (uint64_t c = 0; c < cells_; ++c) count[c + 1] += count[c];
  cell_offsets_ = count;
  cell_faces_.resize(count.back());
  std::vector<uint64_t> fill(count.begin(), count.end() - 1);
  for (size_t i = 0; i < owner.size(); ++i) cell_faces_[fill[static_cast<size_t>(owner[i])]++] = i;
  for (size_t i = 0; i < neighbour.size(); ++i) cell_faces_[fill[static_cast<size_t>(neighbour[i])]++] = i;
  for (uint64_t c = 0; c < cells_; ++c)
    if (cell_offsets_[c + 1] - cell_offsets_[c] < 4) owner_file.fail("cell " + std::to_string(c) + " has " + std::to_string(cell_offsets_[c + 1] - cell_offsets_[c]) + " faces; a volume needs at least 4");
}

// Sizes of a cell's faces: counts of triangles, quads and larger faces, and its points.
struct FaceCounts {
  int triangles = 0, quads = 0, larger = 0;
  std::vector<uint32_t> points;
};

void OpenFoamReader::classify(ReadStats& stats) {
  shapes_.assign(cells_, Shape::kPolyhedron);
  centre_.assign(cells_, 0);
  face_centre_.assign(face_offsets_.size() - 1, 0);
  const uint32_t base = static_cast<uint32_t>(points_.size() / 3);
  uint32_t next = base;
  std::vector<uint32_t> order;
  FaceCounts k;
  order_offsets_.reserve(cells_ + 1);
  for (uint64_t c = 0; c < cells_; ++c) {
    k.triangles = k.quads = k.larger = 0;
    k.points.clear();
    for (uint64_t i = cell_offsets_[c]; i < cell_offsets_[c + 1]; ++i) {
      const uint64_t f = cell_faces_[i], n = face_offsets_[f + 1] - face_offsets_[f];
      (n == 3 ? k.triangles : n == 4 ? k.quads : k.larger) += 1;
      for (uint64_t q = face_offsets_[f]; q < face_offsets_[f + 1]; ++q) k.points.push_back(static_cast<uint32_t>(face_points_[q]));
    }
    std::sort(k.points.begin(), k.points.end());
    k.points.erase(std::unique(k.points.begin(), k.points.end()), k.points.end());
    const size_t faces = cell_offsets_[c + 1] - cell_offsets_[c], p = k.points.size();
    Shape shape = Shape::kPolyhedron;
    if (faces == 4 && k.triangles == 4 && p == 4) shape = Shape::kTet;
    else if (faces == 5 && k.quads == 1 && k.triangles == 4 && p == 5) shape = Shape::kPyramid;
    else if (faces == 5 && k.quads == 3 && k.triangles == 2 && p == 6) shape = Shape::kWedge;
    else if (faces == 6 && k.quads == 6 && p == 8) shape = Shape::kHex;
    if (shape != Shape::kPolyhedron && !vtk_order(c, shape, order)) shape = Shape::kPolyhedron;
    shapes_[c] = shape;
    if (shape != Shape::kPolyhedron) orders_.insert(orders_.end(), order.begin(), order.end());
    order_offsets_.push_back(orders_.size());
    if (shape != Shape::kPolyhedron) continue;
    ++stats.polyhedra;
    double sum[3] = {0, 0, 0};
    for (uint32_t q : k.points)
      for (int d = 0; d < 3; ++d) sum[d] += points_[3 * size_t{q} + static_cast<size_t>(d)];
    for (int d = 0; d < 3; ++d) extra_xyz_.push_back(static_cast<float>(sum[d] / double(p)));
    centre_[c] = next++;
    for (uint64_t i = cell_offsets_[c]; i < cell_offsets_[c + 1]; ++i) {
      const uint64_t f = cell_faces_[i], n = face_offsets_[f + 1] - face_offsets_[f];
      if (n <= 4 || face_centre_[f] != 0) continue;
      double centre[3] = {0, 0, 0};
      for (uint64_t q = face_offsets_[f]; q < face_offsets_[f + 1]; ++q)
        for (int d = 0; d < 3; ++d) centre[d] += points_[3 * static_cast<size_t>(face_points_[q]) + static_cast<size_t>(d)];
      for (int d = 0; d < 3; ++d) extra_xyz_.push_back(static_cast<float>(centre[d] / double(n)));
      face_centre_[f] = next++;
    }
    if (next >= std::numeric_limits<uint32_t>::max() - 1) throw MeshError(path_.string() + ": too many points after decomposing the polyhedra");
  }
}

bool OpenFoamReader::vtk_order(uint64_t cell, Shape shape, std::vector<uint32_t>& out) const {
  out.clear();
  // the first face of the right size is the base; each base point's partner is the point
  // off the base it shares an edge with
  const size_t base_size = shape == Shape::kWedge || shape == Shape::kTet ? 3 : 4;
  std::vector<std::pair<uint32_t, uint32_t>>& edges = edges_;
  edges.clear();
  int64_t base = -1;
  for (uint64_t i = cell_offsets_[cell]; i < cell_offsets_[cell + 1]; ++i) {
    const uint64_t f = cell_faces_[i], a = face_offsets_[f], n = face_offsets_[f + 1] - a;
    if (base < 0 && n == base_size) base = static_cast<int64_t>(f);
    for (uint64_t q = 0; q < n; ++q) {
      const uint32_t u = static_cast<uint32_t>(face_points_[a + q]), v = static_cast<uint32_t>(face_points_[a + (q + 1) % n]);
      edges.push_back({std::min(u, v), std::max(u, v)});
    }
  }
  if (base < 0) return false;
  const uint64_t a = face_offsets_[static_cast<size_t>(base)];
  for (uint64_t q = 0; q < base_size; ++q) out.push_back(static_cast<uint32_t>(face_points_[a + q]));
  if (shape == Shape::kTet) {
    for (uint64_t i = cell_offsets_[cell]; i < cell_offsets_[cell + 1] && out.size() < 4; ++i)
      for (uint64_t q = face_offsets_[cell_faces_[i]]; q < face_offsets_[cell_faces_[i] + 1] && out.size() < 4; ++q)
        if (std::find(out.begin(), out.end(), static_cast<uint32_t>(face_points_[q])) == out.end()) out.push_back(static_cast<uint32_t>(face_points_[q]));
    return out.size() == 4;
  }
  if (shape == Shape::kPyramid) {
    for (const auto& [u, v] : edges) {
      for (uint32_t w : {u, v})
        if (std::find(out.begin(), out.end(), w) == out.end()) {
          out.push_back(w);
          return true;
        }
    }
    return false;
  }
  for (size_t q = 0; q < base_size; ++q) {
    const uint32_t p = out[q];
    uint32_t partner = std::numeric_limits<uint32_t>::max();
    for (const auto& [u, v] : edges) {
      const uint32_t w = u == p ? v : v == p ? u : std::numeric_limits<uint32_t>::max();
      if (w != std::numeric_limits<uint32_t>::max() && std::find(out.begin(), out.begin() + static_cast<std::ptrdiff_t>(base_size), w) == out.begin() + static_cast<std::ptrdiff_t>(base_size)) partner = w;
    }
    if (partner == std::numeric_limits<uint32_t>::max()) return false;
    out.push_back(partner);
  }
  std::vector<uint32_t> distinct(out);
  std::sort(distinct.begin(), distinct.end());
  return std::unique(distinct.begin(), distinct.end()) == distinct.end();
}

// A polyhedron's tets about its centre; every entry after the first is marked as part of the
// same cell.
void OpenFoamReader::decompose(uint64_t cell, CellBatch& batch) {
  const uint32_t centre = centre_[cell];
  bool first = true;
  auto tet = [&](uint32_t a, uint32_t b, uint32_t c) {
    const uint32_t nodes[4] = {centre, a, b, c};
    batch.push(kVtkTetra, nodes);
    batch.same_cell.resize(batch.size(), 0);
    batch.same_cell.back() = first ? 2 : 1;
    first = false;
  };
  for (uint64_t i = cell_offsets_[cell]; i < cell_offsets_[cell + 1]; ++i) {
    const uint64_t f = cell_faces_[i], a = face_offsets_[f], n = face_offsets_[f + 1] - a;
    auto at = [&](uint64_t q) { return static_cast<uint32_t>(face_points_[a + q % n]); };
    if (n == 3) {
      tet(at(0), at(1), at(2));
    } else if (n == 4) {  // the diagonal through the point of smallest id
      uint64_t k = 0;
      for (uint64_t q = 1; q < 4; ++q)
        if (at(q) < at(k)) k = q;
      tet(at(k), at(k + 1), at(k + 2));
      tet(at(k), at(k + 2), at(k + 3));
    } else {
      for (uint64_t q = 0; q < n; ++q) tet(face_centre_[f], at(q), at(q + 1));
    }
  }
}

void OpenFoamReader::read_patches(const fs::path& mesh) {
  std::error_code ec;
  if (!fs::exists(mesh / "boundary", ec) && !fs::exists(mesh / "boundary.gz", ec)) return;  // regions from sharp edges
  FoamText f(mesh / "boundary", limits_);
  const uint64_t patches = f.open_list("patch count", 8);
  const uint64_t face_count = face_offsets_.size() - 1;
  for (uint64_t p = 0; p < patches; ++p) {
    const std::string name = f.word();
    if (name.empty() || name.size() > 255) f.fail("patch " + std::to_string(p) + " has no name, or one over 255 characters");
    f.expect('{', "after a patch name");
    int64_t faces = -1, start = -1;
    while (!f.next_is('}')) {
      const std::string key = f.word();
      if (key.empty()) f.fail("patch '" + name + "' is not closed");
      const std::string value = f.entry_value();
      if (key != "nFaces" && key != "startFace") continue;
      char* end = nullptr;
      const long long v = std::strtoll(value.c_str(), &end, 10);
      if (value.empty() || *end != '\0' || v < 0) f.fail("patch '" + name + "': " + key + " '" + value.substr(0, 40) + "' is not a count");
      (key == "nFaces" ? faces : start) = v;
    }
    f.expect('}', "after a patch");
    if (faces < 0 || start < 0) f.fail("patch '" + name + "' has no nFaces or startFace");
    const uint64_t first = static_cast<uint64_t>(start), n = static_cast<uint64_t>(faces);
    if (first < internal_faces_ || first > face_count || n > face_count - first)
      f.fail("patch '" + name + "' names faces " + std::to_string(first) + ".." + std::to_string(first + n) + ", outside the boundary faces " + std::to_string(internal_faces_) + ".." + std::to_string(face_count));
    if (n == 0) continue;
    const uint32_t tag = face_tags_.tag(name);
    for (uint64_t face = first; face < first + n; ++face) {
      const uint64_t a = face_offsets_[face], k = face_offsets_[face + 1] - a;
      auto at = [&](uint64_t q) { return static_cast<uint32_t>(face_points_[a + q % k]); };
      if (k == 3) {
        face_tags_.add(tag, at(0), at(1), at(2));
      } else if (k == 4) {  // the diagonal through the point of smallest id, as the cells are cut
        uint64_t s = 0;
        for (uint64_t q = 1; q < 4; ++q)
          if (at(q) < at(s)) s = q;
        face_tags_.add(tag, at(s), at(s + 1), at(s + 2));
        face_tags_.add(tag, at(s), at(s + 2), at(s + 3));
      } else if (face_centre_[face] != 0) {  // a polyhedron's face, fanned about its centre
        for (uint64_t q = 0; q < k; ++q) face_tags_.add(tag, face_centre_[face], at(q), at(q + 1));
      }
    }
  }
  f.close_list("patches");
}

void OpenFoamReader::read_fields(const fs::path& folder, ReadStats& stats) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(folder, ec))
    if (entry.is_regular_file(ec)) files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  for (const fs::path& file : files) {
    std::string head;
    {
      std::ifstream in(file, std::ios::binary);
      head.resize(4096);
      in.read(head.data(), static_cast<std::streamsize>(head.size()));
      head.resize(static_cast<size_t>(in.gcount()));
    }
    const bool gz = file.extension() == ".gz";
    if (!gz && head.find("volScalarField") == std::string::npos && head.find("volVectorField") == std::string::npos &&
        head.find("TensorField") == std::string::npos)
      continue;
    fs::path plain = file;
    if (gz) plain.replace_extension();
    FoamText probe(plain, limits_);
    if (field_components(probe.cls) == 0) {
      if (probe.cls.rfind("vol", 0) == 0) stats.warnings.push_back(file.filename().string() + ": a " + probe.cls + " is not read");
      continue;
    }
    fields_.push_back(read_field(plain, limits_, cells_, stats));
  }
}

MeshHeader OpenFoamReader::index(ReadStats& stats) {
  std::error_code ec;
  const bool one_time = is_openfoam_time_folder(path_);  // CASE/TIME: that time's fields
  fs::path folder = one_time ? path_.parent_path() : fs::is_directory(path_, ec) ? path_ : path_.parent_path();
  if (folder.empty()) folder = ".";  // "case.foam" in the working folder
  const fs::path mesh = folder / "constant" / "polyMesh";
  if (!fs::is_directory(mesh, ec)) throw MeshError(path_.string() + ": not an OpenFOAM case (no constant/polyMesh beside it)");
  read_mesh(mesh);
  classify(stats);
  read_patches(mesh);
  if (one_time) {
    read_fields(path_, stats);
    finish_header("time " + path_.filename().string());
    return header_;
  }
  // the latest time folder that holds a field
  std::vector<std::pair<double, fs::path>> times;
  for (const auto& entry : fs::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    char* end = nullptr;
    const double t = std::strtod(name.c_str(), &end);
    if (!name.empty() && *end == '\0' && entry.is_directory(ec) && std::isfinite(t)) times.push_back({t, entry.path()});
  }
  std::sort(times.begin(), times.end());
  std::string when = "no time folder";
  for (auto it = times.rbegin(); it != times.rend() && fields_.empty(); ++it) {
    read_fields(it->second, stats);
    if (!fields_.empty()) when = "time " + it->second.filename().string() + " (" + std::to_string(times.size()) + " time folders)";
  }
  if (times.size() > 1 && !fields_.empty()) stats.warnings.push_back(std::to_string(times.size()) + " time folders: the latest with fields, " + when + ", is read");
  finish_header(when);
  return header_;
}

void OpenFoamReader::finish_header(const std::string& when) {
  header_.format = MeshFormat::kOpenFoam;
  header_.description = "OpenFOAM case, " + std::to_string(cells_) + " cells, " + when;
  header_.vertex_count = points_.size() / 3 + extra_xyz_.size() / 3;
  header_.cell_count = cells_;
  for (const Field& f : fields_) header_.cell_attributes.push_back(f.info);
}

void OpenFoamReader::read_vertices(size_t count, float* xyz, std::span<float* const>, ReadStats&) {
  const uint64_t points = points_.size() / 3;
  for (size_t i = 0; i < count; ++i, ++vertices_given_) {
    for (int d = 0; d < 3; ++d) {
      xyz[3 * i + static_cast<size_t>(d)] = vertices_given_ < points ? static_cast<float>(points_[3 * vertices_given_ + static_cast<uint64_t>(d)])
                                                                     : extra_xyz_[3 * (vertices_given_ - points) + static_cast<uint64_t>(d)];
    }
  }
}

bool OpenFoamReader::read_cells(CellBatch& batch, size_t max_cells) {
  batch_cells_.clear();
  while (batch.size() < max_cells && next_cell_ < cells_) {
    const uint64_t c = next_cell_++;
    switch (shapes_[c]) {
      case Shape::kPolyhedron: decompose(c, batch); break;
      default: {
        const std::span<const uint32_t> order(orders_.data() + order_offsets_[c], order_offsets_[c + 1] - order_offsets_[c]);
        const uint8_t type = shapes_[c] == Shape::kTet ? kVtkTetra : shapes_[c] == Shape::kPyramid ? kVtkPyramid : shapes_[c] == Shape::kWedge ? kVtkWedge : kVtkHexahedron;
        batch.push(type, order);
        if (!batch.same_cell.empty()) batch.same_cell.resize(batch.size(), 0);
      }
    }
    batch_cells_.resize(batch.size(), c);
  }
  return !batch_cells_.empty();
}

void OpenFoamReader::read_cell_values(size_t count, std::span<float* const> values, ReadStats&) {
  for (size_t a = 0; a < fields_.size(); ++a) {
    const size_t c = fields_[a].info.components;
    for (size_t i = 0; i < count && i < batch_cells_.size(); ++i) std::copy_n(fields_[a].values.data() + batch_cells_[i] * c, c, values[a] + i * c);
  }
}

}  // namespace

std::unique_ptr<FormatReader> make_openfoam_reader(const std::filesystem::path& path, const ReadLimits& limits) {
  return std::make_unique<OpenFoamReader>(path, limits);
}

}  // namespace tetrascope::storage::detail
