// CGNS meshes (.cgns, .adf; HDF5 and ADF files) through the CGNS library's node layer (cgio),
// built as a module of its own (libtetrascope_cgns.so) that tetrascope loads on the first CGNS file, so
// that no other process maps the CGNS and HDF5 libraries:
// the unstructured zones of the first base, joined in file order (vertex ids offset by the
// zones before; points shared by two zones stay two vertices), element sections of tets,
// pyramids, wedges and hexahedra (higher-order ones by their corners), MIXED sections, and
// surface, line and point sections counted and skipped; a FlowSolution at Vertex as point data
// and one at CellCenter as cell data (the last of each location, or the one the zone's
// ZoneIterativeData names for the last step, or for the step ReadLimits::time_step names:
// BaseIterativeData's TimeValues give the steps' times), fields NAMEX NAMEY NAMEZ joined into a vector (vertex NAMEXX NAMEXY NAMEXZ NAMEYY NAMEYZ
// NAMEZZ into a symmetric tensor)
// NAME as ParaView does; the BC_t of a zone's ZoneBC as boundary face tags named by the BC
// (face elements by number, or the boundary faces whose corners are all in a vertex set).
// Coordinates, connectivity and values are read in chunks (partial reads of the arrays), so
// memory follows the chunk, not the file. The node layer rather than
// the mid-level library: the mid-level library of Debian 12 (CGNS 3.4) refuses every file
// written by CGNS 4 (ParaView's writer, current solvers) although the layout it reads is the
// same, and its partial read of MIXED sections trusts stored offsets. The library keeps global
// state and is not thread-safe: every call into it holds one process-wide lock.
// SIDS (the CGNS Standard Interface Data Structures), sections 6 (zones), 7 (elements), 11
// (flow solutions) and 12.5 (ZoneIterativeData).
#include <ADF.h>
#include <cgns_io.h>
#include <cgnslib.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>
#include <optional>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

// What one file may declare, whatever its size: as many zones, sections, solutions and fields
// as any real file has, bounded so that a hostile header costs no memory.
constexpr int kMaxSections = 100000;
constexpr size_t kAdfHeaderBytes = 186;  // ADF's file header, "@(#)ADF Database Version" to "AdF5"
constexpr int kMaxFields = 10000;
constexpr cgsize_t kMaxTimeSteps = 1000000;

std::mutex& library_lock() {
  static std::mutex lock;
  return lock;
}

// ReadLimits::max_inflated_bytes, here too: the module links none of tetrascope's code.
uint64_t inflate_limit(const ReadLimits& limits, uint64_t file_bytes) {
  const double allowed = static_cast<double>(ReadLimits::kInflateAllowanceBytes) + limits.max_inflate_ratio * static_cast<double>(file_bytes);
  return allowed >= 1.8e19 ? UINT64_MAX : static_cast<uint64_t>(allowed);
}

// The VTK type and corner count of a CGNS element type, by its name; corners 0 for an element
// of lower dimension (skipped), -1 for one that cannot be read. Higher-order elements list
// their corners first, in the order of the linear element.
std::pair<int, int> element_kind(CGNS_ENUMT(ElementType_t) type) {
  const char* name = type >= 0 && type < NofValidElementTypes ? ElementTypeName[type] : "";
  auto starts = [&](const char* prefix) { return std::strncmp(name, prefix, std::strlen(prefix)) == 0; };
  if (starts("TETRA_")) return {kVtkTetra, 4};
  if (starts("PYRA_")) return {kVtkPyramid, 5};
  if (starts("PENTA_")) return {kVtkWedge, 6};
  if (starts("HEXA_")) return {kVtkHexahedron, 8};
  if (starts("NGON_n") || starts("NFACE_n") || !*name) return {0, -1};
  return {kVtkVertex, 0};  // NODE, BAR_*, TRI_*, QUAD_*
}

// The corner count of a face element (TRI_* 3, QUAD_* 4; higher-order ones list their corners
// first), 0 for any other.
int face_corners(CGNS_ENUMT(ElementType_t) type) {
  const char* name = type >= 0 && type < NofValidElementTypes ? ElementTypeName[type] : "";
  if (std::strncmp(name, "TRI_", 4) == 0) return 3;
  if (std::strncmp(name, "QUAD_", 5) == 0) return 4;
  return 0;
}

// The faces of a linear volume cell, VTK (and CGNS) corner order: corner indices, a triangle's
// fourth -1.
struct CellFaces {
  int count;
  int corners[6][4];
};
const CellFaces& cell_faces(int vtk_type) {
  static const CellFaces tet{4, {{0, 1, 2, -1}, {0, 1, 3, -1}, {1, 2, 3, -1}, {0, 2, 3, -1}}};
  static const CellFaces pyramid{5, {{0, 1, 2, 3}, {0, 1, 4, -1}, {1, 2, 4, -1}, {2, 3, 4, -1}, {3, 0, 4, -1}}};
  static const CellFaces wedge{5, {{0, 1, 2, -1}, {3, 4, 5, -1}, {0, 1, 4, 3}, {1, 2, 5, 4}, {2, 0, 3, 5}}};
  static const CellFaces hex{6, {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}}};
  return vtk_type == kVtkTetra ? tet : vtk_type == kVtkPyramid ? pyramid : vtk_type == kVtkWedge ? wedge : hex;
}

using Triangle = std::array<uint32_t, 3>;

// FaceTags::tag, here too: the module links none of tetrascope's code.
uint32_t tag_named(FaceTags& tags, const std::string& name) {
  const auto it = std::find(tags.names.begin(), tags.names.end(), name);
  if (it != tags.names.end()) return static_cast<uint32_t>(it - tags.names.begin());
  tags.names.push_back(name);
  return static_cast<uint32_t>(tags.names.size() - 1);
}

// A face's triangles: a quad split by the diagonal through its vertex of smallest id, as the
// hexahedra are split (cell_split.cpp).
template <typename Add>
void face_triangles(const uint32_t* c, int corners, Add&& add) {
  if (corners == 3) return add(Triangle{c[0], c[1], c[2]});
  const int k = static_cast<int>(std::min_element(c, c + 4) - c);
  add(Triangle{c[k], c[(k + 1) % 4], c[(k + 2) % 4]});
  add(Triangle{c[k], c[(k + 2) % 4], c[(k + 3) % 4]});
}

// A variable of the file: one field, three joined into a vector, or six into a symmetric tensor.
struct Variable {
  std::string name;
  std::vector<std::string> fields;  // the CGNS field names, one a component (a tensor's in the order xx yy zz xy yz xz)
  bool tensor = false;
};

// NAMEXX NAMEXY NAMEXZ NAMEYY NAMEYZ NAMEZZ (SIDS's symmetric tensors, as ReynoldsStressXX ...;
// YX, ZX, ZY accepted for XY, XZ, YZ; lower case likewise), anywhere in the list, with
// `names[i]` its XX: the six fields in the stored order; empty when they are not all there.
std::vector<std::string> symmetric_tensor_fields(const std::vector<std::string>& names, size_t i, const std::vector<bool>& used) {
  const std::string& a = names[i];
  if (a.size() < 3) return {};
  const std::string tail = a.substr(a.size() - 2), base = a.substr(0, a.size() - 2);
  const bool upper = tail == "XX";
  if (!upper && tail != "xx") return {};
  auto find = [&](const char* one, const char* other) -> std::string {
    for (const char* suffix : {one, other}) {
      std::string end = suffix;
      if (!upper)
        for (char& c : end) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      const std::string want = base + end;
      const auto it = std::find(names.begin(), names.end(), want);
      if (it != names.end() && !used[static_cast<size_t>(it - names.begin())]) return want;
    }
    return "";
  };
  std::vector<std::string> fields = {a, find("YY", "YY"), find("ZZ", "ZZ"), find("XY", "YX"), find("YZ", "ZY"), find("XZ", "ZX")};
  for (const std::string& f : fields)
    if (f.empty()) return {};
  return fields;
}

// NAMEX NAMEY NAMEZ (or NAMEx ..., anywhere in the list) become one vector NAME, at the place
// of its X component, as ParaView's CGNS reader joins VelocityX/Y/Z and MomentumX/Y/Z; with
// `tensors`, the six components of a symmetric tensor (symmetric_tensor_fields) one tensor NAME.
std::vector<Variable> join_components(const std::vector<std::string>& names, bool tensors) {
  std::vector<Variable> out;
  std::vector<bool> used(names.size(), false);
  for (size_t i = 0; i < names.size(); ++i) {
    if (used[i]) continue;
    const std::string& a = names[i];
    if (std::vector<std::string> six = tensors ? symmetric_tensor_fields(names, i, used) : std::vector<std::string>{}; !six.empty()) {
      for (const std::string& f : six) used[static_cast<size_t>(std::find(names.begin(), names.end(), f) - names.begin())] = true;
      std::string shown = a.substr(0, a.size() - 2);
      if (shown.size() > 1 && shown.back() == '_') shown.pop_back();
      out.push_back({shown, std::move(six), true});
      continue;
    }
    const char last = a.empty() ? '\0' : a.back();
    if (a.size() >= 2 && (last == 'X' || last == 'x')) {
      const std::string base = a.substr(0, a.size() - 1);
      const bool upper = last == 'X';
      const auto y = std::find(names.begin(), names.end(), base + (upper ? 'Y' : 'y'));
      const auto z = std::find(names.begin(), names.end(), base + (upper ? 'Z' : 'z'));
      if (y != names.end() && z != names.end()) {
        used[static_cast<size_t>(y - names.begin())] = used[static_cast<size_t>(z - names.begin())] = true;
        std::string shown = base;
        if (shown.size() > 1 && shown.back() == '_') shown.pop_back();
        out.push_back({shown, {a, *y, *z}, false});
        continue;
      }
    }
    out.push_back({a, {a}, false});
  }
  return out;
}

// The file's first bytes: an HDF5 file (signature at 0) or an ADF one whose file header is
// whole. The ADF layer asserts (and so aborts the process) on a header it cannot parse, so
// its fixed layout is checked here: the tags AdF0..AdF5 in place, a known number format and
// word size, the machine's type sizes those of a real machine and every pointer hex.
bool looks_like_cgns(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char head[kAdfHeaderBytes] = {};
  in.read(head, sizeof head);
  const size_t got = static_cast<size_t>(in.gcount());
  if (got >= 8 && std::memcmp(head, "\x89HDF\r\n\x1a\n", 8) == 0) return true;
  if (got < sizeof head || std::memcmp(head + 4, "ADF Database Version", 20) != 0) return false;  // after "@(#)", high bits set
  for (const auto& [at, tag] : {std::pair{32, "AdF0"}, {64, "AdF1"}, {96, "AdF2"}, {102, "AdF3"}, {130, "AdF4"}, {182, "AdF5"}})
    if (std::memcmp(head + at, tag, 4) != 0) return false;
  if (!std::strchr("BLCN", head[100]) || !head[100] || !std::strchr("BL", head[101]) || !head[101]) return false;
  // the sizes of char, short, int, long, float, double and of pointers to them, two digits each:
  // ADF converts values by them, so only those of real machines pass
  static const char* const sizes[12] = {"01", "02", "04", "0408", "04", "08", "0408", "0408", "0408", "0408", "0408", "0408"};
  for (int k = 0; k < 12; ++k) {
    bool known = false;
    for (const char* option = sizes[k]; *option; option += 2) known |= std::memcmp(head + 106 + 2 * k, option, 2) == 0;
    if (!known) return false;
  }
  for (int i = 134; i < 182; ++i)
    if (!std::isxdigit(static_cast<unsigned char>(head[i]))) return false;
  return true;
}

// A DataArray_t of the file: its node, type ("I4", "I8", "R4", "R8") and length.
struct Array {
  double node = 0;
  std::string type;
  int64_t length = 0;
};

struct Section {
  std::string name;
  CGNS_ENUMT(ElementType_t) type = CGNS_ENUMV(ElementTypeNull);
  int64_t start = 0, count = 0;
  int vtk_type = 0, corners = 0, nodes = 0;  // nodes: per element, 0 for MIXED
  Array connectivity;
};

struct Field {
  std::string name;
  Array values;
};

struct Solution {
  std::string name;  // "": none
  std::vector<Field> fields;
  const Array* find(const std::string& field) const {
    for (const Field& f : fields)
      if (f.name == field) return &f.values;
    return nullptr;
  }
};

// A BC_t of a zone's ZoneBC: its point set, face elements by number or vertices (1-based, the
// zone's own), as a range or a sorted list.
struct Boundary {
  std::string name;
  bool faces = false;
  bool range = false;
  int64_t low = 0, high = -1;  // the range
  std::vector<int64_t> list;
  bool holds(int64_t index) const { return range ? index >= low && index <= high : std::binary_search(list.begin(), list.end(), index); }
};

struct Zone {
  std::string name;
  std::vector<Boundary> boundaries;
  bool face_boundaries = false, vertex_boundaries = false;
  int64_t vertices = 0, cells = 0;
  uint64_t first_vertex = 0;
  Array coordinates[3];
  std::vector<Section> sections;
  Solution vertex_solution, cell_solution;
};

struct Node {
  double id = 0;
  std::string name, label;
};

class CgnsReader final : public FormatReader {
 public:
  CgnsReader(std::filesystem::path path, const ReadLimits& limits) : path_(std::move(path)), name_(path_.filename().string()), limits_(limits) {}
  ~CgnsReader() override {
    if (cgio_ >= 0) {
      std::lock_guard<std::mutex> hold(library_lock());
      cgio_close_file(cgio_);
    }
  }
  MeshHeader index(ReadStats& stats) override;
  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override;
  bool read_cells(CellBatch& batch, size_t max_cells) override;
  void read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) override;
  FaceTags take_face_tags() override;
  void rewind_cells() override {
    surface_faces_.clear();
    candidates_.clear();
    zone_ = section_ = 0;
    in_section_ = 0;
    mixed_position_ = 0;
    volume_in_zone_ = 0;
    runs_.clear();
    volume_cell_.clear();
  }

 private:
  [[noreturn]] void fail(const std::string& what) const { throw MeshError(name_ + ": " + what); }
  // The node layer, each call under the lock; a failure names `what`.
  std::vector<Node> children(double parent, const std::string& what) const;
  Array array(const Node& node, const std::string& what) const;
  std::string text(double node, const std::string& what) const;
  // The node's data type when it is one plain type ("I4", "R8", "C1", ...), under the lock.
  bool stored_type(double node, char (&type)[CGIO_MAX_DATATYPE_LENGTH + 1]) const;
  // A node's data type and dimensions (the library lock held by the caller): none when the
  // library cannot read them; shape() fails naming `what` instead.
  struct Shape {
    std::string type;
    int dimensions = 0;
    cgsize_t extent[CGIO_MAX_DIMENSIONS] = {};
  };
  std::optional<Shape> try_shape(double node) const;
  Shape shape(double node, const std::string& what) const;
  // `count` values from 0-based `first` of an integer or real array, converted.
  void read_values(const Array& a, int64_t first, size_t count, const std::string& what, int64_t* ints, double* reals);
  std::vector<int64_t> small_ints(const Node& node, size_t most, const std::string& what);

  void open_file();
  Zone read_zone(const Node& node, uint64_t& declared_bytes, uint64_t& cells);
  Section read_section(const Zone& zone, const Node& node, uint64_t& declared_bytes);
  void read_solutions(Zone& zone, const std::vector<Node>& nodes, ReadStats& stats);
  void read_boundaries(Zone& zone, const std::vector<Node>& nodes, ReadStats& stats);
  std::vector<int64_t> index_values(const Node& node, const std::string& what) const;
  void note_faces(const Zone& zone, int64_t element, int vtk_type, int corners, int face);
  // The solution names a ZoneIterativeData array `pointers` gives each time step ("" for
  // "Null"); empty without one.
  std::vector<std::string> step_solutions(const std::vector<Node>& iterative, const char* pointers);
  // The name of the step read among `pointers` (the last named one, or ReadLimits::time_step's).
  std::string step_solution(const Zone& zone, const std::vector<std::string>& pointers);
  // BaseIterativeData's TimeValues, when the base has them.
  void read_time_values(const std::vector<Node>& base_children);
  // MeshHeader::step_times from the zones' steps and the base's times.
  void set_step_times(ReadStats& stats);
  void read_field(const Zone& zone, const Solution& solution, const std::string& field, int64_t first, size_t count, std::vector<double>& out);
  void read_section_cells(const Zone& zone, const Section& s, int64_t n, CellBatch& batch);
  void read_mixed_cells(const Zone& zone, const Section& s, int64_t low, int64_t n, CellBatch& batch);
  void append_element(const Zone& zone, const Section& s, int64_t element, int vtk_type, int corners, int face, std::span<const int64_t> nodes,
                      CellBatch& batch);

  std::filesystem::path path_;
  std::string name_;
  ReadLimits limits_;
  uint64_t file_bytes_ = 0;
  int cgio_ = -1;
  bool adf_ = false;
  MeshHeader header_;
  std::vector<Zone> zones_;
  std::vector<Variable> point_variables_, cell_variables_;
  uint64_t vertex_total_ = 0;
  size_t steps_ = 0;                  // the time steps ZoneIterativeData lists (0: none)
  std::vector<double> time_values_;  // BaseIterativeData's TimeValues
  // vertices
  size_t vertex_zone_ = 0;
  int64_t in_vertex_zone_ = 0;
  // cells
  size_t zone_ = 0, section_ = 0;
  int64_t in_section_ = 0;
  int64_t volume_in_zone_ = 0;  // volume elements of the zone delivered so far
  int64_t mixed_position_ = 0;  // values of the current MIXED section's connectivity consumed
  struct Run {
    size_t zone;
    int64_t first_volume, volumes;  // 0-based among the zone's volume elements
  };
  std::vector<Run> runs_;             // the volume elements the last read_cells appended, by zone
  std::vector<uint8_t> volume_cell_;  // per cell the last read_cells appended: 1 for a volume element
  std::vector<int64_t> connectivity_;
  std::vector<uint8_t> raw_;
  std::vector<double> scratch_[3];
  std::vector<uint32_t> nodes_scratch_;
  // boundary conditions: the face elements of zones with face BCs, and the faces of volume
  // elements whose corners are all in some vertex BC (a face met once is a boundary face)
  struct SurfaceFace {
    size_t zone;
    int64_t element;
    uint32_t corners[4];
    int count;
  };
  std::vector<SurfaceFace> surface_faces_;
  std::vector<bool> on_vertex_boundary_;  // per vertex, empty when no zone has a vertex BC
  std::vector<Triangle> candidates_;      // sorted corners
};

std::string cgio_message() {
  char message[CGIO_MAX_ERROR_LENGTH + 1] = {};
  cgio_error_message(message);
  return message[0] ? std::string(" (") + message + ")" : std::string();
}

// The node layer reports an ADF node's type by its first two characters, but ADF reads data by
// the whole type string (a compound "R8I4" takes 12 bytes a value), and would write past a
// buffer sized by the first: an ADF type is taken whole and must be one plain type.
bool CgnsReader::stored_type(double node, char (&type)[CGIO_MAX_DATATYPE_LENGTH + 1]) const {
  if (!adf_) return cgio_get_data_type(cgio_, node, type) == CGIO_ERR_NONE;
  char whole[ADF_DATA_TYPE_LENGTH + 1] = {};
  int error = 0;
  ADF_Get_Data_Type(node, whole, &error);
  if (error != NO_ERROR) return false;
  std::string t(whole, strnlen(whole, ADF_DATA_TYPE_LENGTH));
  while (!t.empty() && t.back() == ' ') t.pop_back();
  if (t.size() != 2) return false;
  std::memcpy(type, t.data(), 2);
  type[2] = '\0';
  return true;
}

std::optional<CgnsReader::Shape> CgnsReader::try_shape(double node) const {
  char type[CGIO_MAX_DATATYPE_LENGTH + 1] = {};
  Shape out;
  if (!stored_type(node, type) || cgio_get_dimensions(cgio_, node, &out.dimensions, out.extent) != CGIO_ERR_NONE) return std::nullopt;
  out.type.assign(type, strnlen(type, CGIO_MAX_DATATYPE_LENGTH));
  return out;
}

CgnsReader::Shape CgnsReader::shape(double node, const std::string& what) const {
  std::optional<Shape> out = try_shape(node);
  if (!out) fail("CGNS: cannot read " + what + cgio_message());
  return *out;
}

std::vector<Node> CgnsReader::children(double parent, const std::string& what) const {
  std::lock_guard<std::mutex> hold(library_lock());
  int count = 0;
  if (cgio_number_children(cgio_, parent, &count) != CGIO_ERR_NONE) fail("CGNS: cannot read " + what + cgio_message());
  // every node takes bytes of the file: a count past that is damage, not a large file
  if (count < 0 || static_cast<uint64_t>(count) > file_bytes_ / 8 + 64) fail("CGNS: " + what + " has " + std::to_string(count) + " children");
  std::vector<double> ids(static_cast<size_t>(count));
  int got = 0;
  if (count > 0 && (cgio_children_ids(cgio_, parent, 1, count, &got, ids.data()) != CGIO_ERR_NONE || got != count)) fail("CGNS: cannot read " + what + cgio_message());
  std::vector<Node> nodes(ids.size());
  for (size_t i = 0; i < ids.size(); ++i) {
    char name[CGIO_MAX_NAME_LENGTH + 1] = {}, label[CGIO_MAX_LABEL_LENGTH + 1] = {};
    if (cgio_get_name(cgio_, ids[i], name) != CGIO_ERR_NONE || cgio_get_label(cgio_, ids[i], label) != CGIO_ERR_NONE) fail("CGNS: cannot read " + what + cgio_message());
    nodes[i] = {ids[i], std::string(name, strnlen(name, CGIO_MAX_NAME_LENGTH)), std::string(label, strnlen(label, CGIO_MAX_LABEL_LENGTH))};
  }
  return nodes;
}

Array CgnsReader::array(const Node& node, const std::string& what) const {
  std::lock_guard<std::mutex> hold(library_lock());
  const Shape shaped = shape(node.id, what);
  Array a{node.id, shaped.type, 0};
  if (a.type != "I4" && a.type != "I8" && a.type != "R4" && a.type != "R8") fail("CGNS: " + what + " holds " + a.type + " values, not numbers");
  if (shaped.dimensions != 1 || shaped.extent[0] < 0) fail("CGNS: " + what + " is an array of " + std::to_string(shaped.dimensions) + " dimensions, not a list");
  a.length = shaped.extent[0];
  return a;
}

// A short character array (ZoneType_t, GridLocation_t).
std::string CgnsReader::text(double node, const std::string& what) const {
  std::lock_guard<std::mutex> hold(library_lock());
  const Shape shaped = shape(node, what);
  if (shaped.type != "C1" || shaped.dimensions != 1 || shaped.extent[0] < 1 || shaped.extent[0] > 64) fail("CGNS: " + what + " is not a short text");
  char value[65] = {};
  if (cgio_read_all_data(cgio_, node, value) != CGIO_ERR_NONE) fail("CGNS: cannot read " + what + cgio_message());
  std::string out(value, strnlen(value, static_cast<size_t>(shaped.extent[0])));
  while (!out.empty() && out.back() == ' ') out.pop_back();
  return out;
}

void CgnsReader::read_values(const Array& a, int64_t first, size_t count, const std::string& what, int64_t* ints, double* reals) {
  if (count == 0) return;
  if (first < 0 || static_cast<uint64_t>(first) + count > static_cast<uint64_t>(a.length)) fail("CGNS: " + what + " is shorter than its zone declares");
  const size_t width = a.type == "I4" || a.type == "R4" ? 4 : 8;
  raw_.resize(count * width);
  {
    std::lock_guard<std::mutex> hold(library_lock());
    const cgsize_t from = static_cast<cgsize_t>(first + 1), to = static_cast<cgsize_t>(first + static_cast<int64_t>(count)), length = static_cast<cgsize_t>(count), one = 1;
    if (cgio_read_data(cgio_, a.node, &from, &to, &one, 1, &length, &one, &length, &one, raw_.data()) != CGIO_ERR_NONE) fail("CGNS: cannot read " + what + cgio_message());
  }
  // one loop a stored type: this runs over every value of the file
  auto decode = [&](auto stored, auto&& to_int) {
    using Stored = decltype(stored);
    for (size_t i = 0; i < count; ++i) {
      Stored v;
      std::memcpy(&v, raw_.data() + i * sizeof(Stored), sizeof(Stored));
      if (ints) ints[i] = to_int(v);
      if (reals) reals[i] = static_cast<double>(v);
    }
  };
  auto real_to_int = [](double v) { return std::isfinite(v) && std::fabs(v) < 9e18 ? static_cast<int64_t>(v) : int64_t{-1}; };
  if (a.type == "I4") decode(int32_t{}, [](int32_t v) { return int64_t{v}; });
  else if (a.type == "I8") decode(int64_t{}, [](int64_t v) { return v; });
  else if (a.type == "R4") decode(float{}, [&](float v) { return real_to_int(v); });
  else decode(double{}, real_to_int);
}

std::vector<int64_t> CgnsReader::small_ints(const Node& node, size_t most, const std::string& what) {
  std::lock_guard<std::mutex> hold(library_lock());
  const Shape shaped = shape(node.id, what);
  const std::string& type = shaped.type;
  const int dimensions = shaped.dimensions;
  const cgsize_t* extent = shaped.extent;
  uint64_t values = dimensions > 0 ? 1 : 0;
  for (int d = 0; d < std::min(dimensions, CGIO_MAX_DIMENSIONS); ++d) values = extent[d] < 0 ? UINT64_MAX : values * static_cast<uint64_t>(std::min<cgsize_t>(extent[d], 1 << 20));
  const bool wide = type == "I8";
  if ((!wide && type != "I4") || values == 0 || values > most) fail("CGNS: " + what + " is not a list of at most " + std::to_string(most) + " integers");
  std::vector<int64_t> out(values);
  std::vector<int32_t> narrow(wide ? 0 : values);
  if (cgio_read_all_data(cgio_, node.id, wide ? static_cast<void*>(out.data()) : static_cast<void*>(narrow.data())) != CGIO_ERR_NONE) {
    fail("CGNS: cannot read " + what + cgio_message());
  }
  if (!wide) std::copy(narrow.begin(), narrow.end(), out.begin());
  return out;
}

void CgnsReader::open_file() {
  std::lock_guard<std::mutex> hold(library_lock());
  if (cgio_open_file(path_.c_str(), CGIO_MODE_READ, CGIO_FILE_NONE, &cgio_) != CGIO_ERR_NONE) {
    cgio_ = -1;
    fail("CGNS: the file cannot be opened" + cgio_message());
  }
  int file_type = 0;
  adf_ = cgio_get_file_type(cgio_, &file_type) != CGIO_ERR_NONE || file_type != CGIO_FILE_HDF5;
}

MeshHeader CgnsReader::index(ReadStats& stats) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path_, ec)) fail("not a regular file");
  file_bytes_ = std::filesystem::file_size(path_, ec);
  if (!looks_like_cgns(path_)) fail("not a CGNS file (neither an HDF5 nor an ADF file)");
  open_file();
  double root = 0;
  {
    std::lock_guard<std::mutex> hold(library_lock());
    if (cgio_get_root_id(cgio_, &root) != CGIO_ERR_NONE) fail("CGNS: no root node" + cgio_message());
  }
  std::vector<Node> bases;
  std::string version = "?";
  for (const Node& n : children(root, "the file's top level")) {
    if (n.label == "CGNSBase_t") bases.push_back(n);
    if (n.label == "CGNSLibraryVersion_t") {
      std::lock_guard<std::mutex> hold(library_lock());
      float v = 0;
      const std::optional<Shape> shaped = try_shape(n.id);
      if (shaped && shaped->type == "R4" && shaped->dimensions == 1 && shaped->extent[0] == 1 && cgio_read_all_data(cgio_, n.id, &v) == CGIO_ERR_NONE && v > 0 && v < 100) {
        char shown[16];
        std::snprintf(shown, sizeof shown, "%.2g", static_cast<double>(v));
        version = shown;
      }
    }
  }
  if (bases.empty()) fail("not a CGNS file (no CGNSBase_t node)");
  const Node& base = bases.front();
  const std::vector<int64_t> dims = small_ints(base, 2, "base '" + base.name + "'");
  if (dims.size() != 2 || dims[0] != 3 || dims[1] != 3) {
    fail("CGNS base '" + base.name + "' has cell dimension " + std::to_string(dims[0]) + " in " + std::to_string(dims.size() > 1 ? dims[1] : 0) +
         " dimensions; tetrascope reads 3D volumes");
  }
  if (bases.size() > 1) stats.warnings.push_back(std::to_string(bases.size()) + " CGNS bases: the first ('" + base.name + "') is read");
  uint64_t declared = 0, cells = 0;
  const std::vector<Node> base_children = children(base.id, "base '" + base.name + "'");
  for (const Node& n : base_children) {
    if (n.label != "Zone_t") continue;
    zones_.push_back(read_zone(n, declared, cells));
    zones_.back().first_vertex = vertex_total_;
    vertex_total_ += static_cast<uint64_t>(zones_.back().vertices);
    if (vertex_total_ >= std::numeric_limits<uint32_t>::max()) fail("CGNS: more than 4294967294 vertices");
    const std::vector<Node> parts = children(n.id, "zone '" + n.name + "'");
    read_solutions(zones_.back(), parts, stats);
    read_boundaries(zones_.back(), parts, stats);
  }
  if (zones_.empty()) fail("CGNS base '" + base.name + "' has no zone");
  for (const Zone& zone : zones_) {
    if (!zone.vertex_boundaries) continue;
    on_vertex_boundary_.resize(vertex_total_, false);
    for (const Boundary& b : zone.boundaries) {
      if (b.faces) continue;
      auto mark = [&](int64_t v) { on_vertex_boundary_[zone.first_vertex + static_cast<uint64_t>(v - 1)] = true; };
      if (b.range)
        for (int64_t v = b.low; v <= b.high; ++v) mark(v);
      else
        for (int64_t v : b.list) mark(v);
    }
  }
  read_time_values(base_children);
  set_step_times(stats);
  const uint64_t limit = inflate_limit(limits_, file_bytes_);
  if (declared > limit) {
    fail("CGNS: its zones declare " + std::to_string(declared) + " bytes of coordinates and connectivity, more than " + std::to_string(limit) +
         " allowed for a file of " + std::to_string(file_bytes_) + " bytes (raise --max-inflate-ratio if the file is genuine)");
  }
  // the variables of the first zone that has a solution of the location name the attributes
  auto names = [](const Solution& s) {
    std::vector<std::string> out;
    for (const Field& f : s.fields) out.push_back(f.name);
    return out;
  };
  for (const Zone& zone : zones_)
    if (point_variables_.empty() && !zone.vertex_solution.name.empty()) point_variables_ = join_components(names(zone.vertex_solution), true);
  for (const Zone& zone : zones_)
    if (cell_variables_.empty() && !zone.cell_solution.name.empty()) cell_variables_ = join_components(names(zone.cell_solution), false);  // cell tensors stay six scalars (averaged per component)
  int file_type = 0;
  {
    std::lock_guard<std::mutex> hold(library_lock());
    cgio_get_file_type(cgio_, &file_type);
  }
  header_.format = MeshFormat::kCgns;
  header_.description = "CGNS " + version + (file_type == CGIO_FILE_HDF5 ? " HDF5" : " ADF") + ", base '" + base.name + "', " + std::to_string(zones_.size()) +
                        " unstructured zone" + (zones_.size() == 1 ? "" : "s");
  header_.vertex_count = vertex_total_;
  header_.cell_count = cells;
  for (const Variable& v : point_variables_)
    header_.attributes.push_back({v.name, static_cast<uint32_t>(v.fields.size()), v.tensor ? AttributeKind::kTensor : AttributeKind::kValue});
  for (const Variable& v : cell_variables_) header_.cell_attributes.push_back({v.name, static_cast<uint32_t>(v.fields.size())});
  if (zones_.size() > 1) stats.warnings.push_back(std::to_string(zones_.size()) + " zones joined: points on zone interfaces are not merged");
  return header_;
}

Zone CgnsReader::read_zone(const Node& node, uint64_t& declared_bytes, uint64_t& cells) {
  Zone zone;
  zone.name = node.name;
  const std::string label = "zone '" + zone.name + "'";
  const std::vector<Node> parts = children(node.id, label);
  std::string type;
  for (const Node& n : parts)
    if (n.label == "ZoneType_t") type = text(n.id, "the type of " + label);
  if (type == "Structured") fail("CGNS " + label + " is structured; tetrascope reads unstructured zones only");
  if (type != "Unstructured") fail("CGNS " + label + " is of no known type ('" + type + "', neither structured nor unstructured)");
  const std::vector<int64_t> size = small_ints(node, 3, "the size of " + label);
  if (size.size() != 3 || size[0] < 0 || size[1] < 0) {
    fail("CGNS " + label + " declares " + std::to_string(size[0]) + " vertices and " + std::to_string(size.size() > 1 ? size[1] : 0) + " cells");
  }
  zone.vertices = size[0];
  zone.cells = size[1];
  declared_bytes += static_cast<uint64_t>(zone.vertices) * 3 * 4;
  static const char* const axes[3] = {"CoordinateX", "CoordinateY", "CoordinateZ"};
  int found = 0;
  for (const Node& n : parts) {
    if (n.label != "GridCoordinates_t" || n.name != "GridCoordinates") continue;
    for (const Node& c : children(n.id, "the coordinates of " + label))
      for (int k = 0; k < 3; ++k)
        if (c.label == "DataArray_t" && c.name == axes[k]) {
          zone.coordinates[k] = array(c, c.name + " of " + label);
          if (zone.coordinates[k].type[0] != 'R') fail("CGNS " + c.name + " of " + label + " holds integers");
          if (zone.coordinates[k].length != zone.vertices) {
            fail("CGNS " + c.name + " of " + label + " holds " + std::to_string(zone.coordinates[k].length) + " values for " + std::to_string(zone.vertices) + " vertices");
          }
          ++found;
        }
  }
  if (found != 3 && zone.vertices > 0) fail("CGNS " + label + " has no CoordinateX, CoordinateY and CoordinateZ (other coordinate systems are not read)");
  size_t sections = 0;
  for (const Node& n : parts) {
    if (n.label != "Elements_t") continue;
    if (++sections > static_cast<size_t>(kMaxSections)) fail("CGNS " + label + ": more than " + std::to_string(kMaxSections) + " element sections");
    zone.sections.push_back(read_section(zone, n, declared_bytes));
    cells += static_cast<uint64_t>(zone.sections.back().count);
  }
  // cell-centred values follow the element numbers, so the sections are read in that order
  std::stable_sort(zone.sections.begin(), zone.sections.end(), [](const Section& a, const Section& b) { return a.start < b.start; });
  return zone;
}

Section CgnsReader::read_section(const Zone& zone, const Node& node, uint64_t& declared_bytes) {
  Section s;
  s.name = node.name;
  const std::string named = "CGNS element section '" + s.name + "' of zone '" + zone.name + "'";
  const std::vector<int64_t> kind = small_ints(node, 2, named);
  const int64_t type = kind[0];
  if (type < 1 || type >= NofValidElementTypes) fail(named + " holds elements of an unknown type (" + std::to_string(type) + ")");
  s.type = static_cast<CGNS_ENUMT(ElementType_t)>(type);
  bool range = false, connectivity = false;
  for (const Node& n : children(node.id, named)) {
    if (n.name == "ElementRange") {
      const std::vector<int64_t> r = small_ints(n, 2, "the ElementRange of " + named);
      if (r.size() != 2 || r[0] < 1 || r[1] < r[0] - 1 || r[1] >= std::numeric_limits<int32_t>::max()) fail(named + " has a damaged ElementRange");
      s.start = r[0];
      s.count = r[1] - r[0] + 1;
      range = true;
    } else if (n.name == "ElementConnectivity") {
      s.connectivity = array(n, "the ElementConnectivity of " + named);
      if (s.connectivity.type[0] != 'I') fail(named + ": its ElementConnectivity holds real numbers");
      connectivity = true;
    }
  }
  if (!range || !connectivity) fail(named + " has no " + (range ? "ElementConnectivity" : "ElementRange"));
  auto [vtk, corners] = element_kind(s.type);
  if (s.type == CGNS_ENUMV(MIXED)) {
    vtk = corners = 0;
    if (s.connectivity.length < 2 * s.count) fail(named + " holds " + std::to_string(s.connectivity.length) + " connectivity values for " + std::to_string(s.count) + " elements");
  } else if (corners < 0) {
    fail(named + " holds " + ElementTypeName[s.type] + " elements (polyhedra), which are not read");
  } else {
    int nodes = 0;
    if (cg_npe(s.type, &nodes) != CG_OK || nodes <= 0) fail(named + " holds elements of an unknown type");
    s.nodes = nodes;
    if (s.connectivity.length != s.count * nodes) fail(named + " holds " + std::to_string(s.connectivity.length) + " connectivity values for " + std::to_string(s.count) + " elements");
  }
  s.vtk_type = vtk;
  s.corners = corners;
  declared_bytes += static_cast<uint64_t>(s.connectivity.length) * 4;
  return s;
}

// The names a ZoneIterativeData array gives each time step (32 characters each, blank
// padded; "Null" or blank: no solution that step); empty when the array is absent or is no
// such list.
std::vector<std::string> CgnsReader::step_solutions(const std::vector<Node>& iterative, const char* pointers) {
  for (const Node& n : iterative) {
    if (n.name != pointers) continue;
    std::lock_guard<std::mutex> hold(library_lock());
    const std::optional<Shape> shaped = try_shape(n.id);
    if (!shaped || shaped->type != "C1" || shaped->dimensions != 2 || shaped->extent[0] != 32 || shaped->extent[1] < 1 || shaped->extent[1] > kMaxTimeSteps) return {};
    const cgsize_t* extent = shaped->extent;
    std::vector<char> names(static_cast<size_t>(32 * extent[1]));
    if (cgio_read_all_data(cgio_, n.id, names.data()) != CGIO_ERR_NONE) return {};
    std::vector<std::string> out;
    for (cgsize_t step = 0; step < extent[1]; ++step) {
      std::string chosen(names.data() + 32 * step, 32);
      chosen = chosen.substr(0, chosen.find('\0'));
      while (!chosen.empty() && chosen.back() == ' ') chosen.pop_back();
      out.push_back(chosen == "Null" ? std::string() : chosen);
    }
    return out;
  }
  return {};
}

std::string CgnsReader::step_solution(const Zone& zone, const std::vector<std::string>& pointers) {
  if (limits_.time_step < 0) {
    for (size_t step = pointers.size(); step-- > 0;)
      if (!pointers[step].empty()) return pointers[step];
    return "";
  }
  if (pointers.empty()) return "";
  if (static_cast<size_t>(limits_.time_step) >= pointers.size()) {
    fail("CGNS zone '" + zone.name + "': its ZoneIterativeData names " + std::to_string(pointers.size()) + " time steps, time step " + std::to_string(limits_.time_step) +
         " asked for");
  }
  return pointers[static_cast<size_t>(limits_.time_step)];
}

void CgnsReader::read_time_values(const std::vector<Node>& base_children) {
  for (const Node& n : base_children) {
    if (n.label != "BaseIterativeData_t") continue;
    for (const Node& c : children(n.id, "the base's BaseIterativeData")) {
      if (c.name != "TimeValues" || c.label != "DataArray_t") continue;
      const Array a = array(c, "BaseIterativeData's TimeValues");
      if (a.type[0] != 'R' || a.length < 1 || a.length > kMaxTimeSteps) fail("CGNS: BaseIterativeData's TimeValues is not a list of at most " + std::to_string(kMaxTimeSteps) + " reals");
      time_values_.resize(static_cast<size_t>(a.length));
      read_values(a, 0, time_values_.size(), "BaseIterativeData's TimeValues", nullptr, time_values_.data());
    }
  }
}

void CgnsReader::set_step_times(ReadStats& stats) {
  if (limits_.time_step >= 0 && static_cast<size_t>(limits_.time_step) >= std::max<size_t>(steps_, 1))
    fail("CGNS: time step " + std::to_string(limits_.time_step) + " asked for, the file holds " + std::to_string(std::max<size_t>(steps_, 1)));
  if (steps_ < 2) return;
  if (time_values_.size() == steps_) {
    header_.step_times = time_values_;
    return;
  }
  if (!time_values_.empty())
    stats.warnings.push_back("CGNS: BaseIterativeData's TimeValues holds " + std::to_string(time_values_.size()) + " times for " + std::to_string(steps_) + " steps: the steps' times are their numbers");
  for (size_t k = 0; k < steps_; ++k) header_.step_times.push_back(static_cast<double>(k));
}

// Per location (Vertex, CellCenter) the last FlowSolution over the whole zone, or the one of
// that location that ZoneIterativeData names for the last step (FlowSolutionPointers, or
// VTK's FlowSolutionVertexPointers and FlowSolutionCellPointers); solutions over a point set,
// with rind layers or at other locations are left out with a warning, and so are fields
// whose length is not the zone's.
void CgnsReader::read_solutions(Zone& zone, const std::vector<Node>& nodes, ReadStats& stats) {
  std::vector<std::string> pointers[2];
  for (const Node& n : nodes) {
    if (n.label != "ZoneIterativeData_t") continue;
    const std::vector<Node> iterative = children(n.id, "the ZoneIterativeData of zone '" + zone.name + "'");
    pointers[0] = pointers[1] = step_solutions(iterative, "FlowSolutionPointers");
    if (std::vector<std::string> p = step_solutions(iterative, "FlowSolutionVertexPointers"); !p.empty()) pointers[0] = p;
    if (std::vector<std::string> p = step_solutions(iterative, "FlowSolutionCellPointers"); !p.empty()) pointers[1] = p;
  }
  const size_t zone_steps = std::max(pointers[0].size(), pointers[1].size());
  if (zone_steps > 0 && steps_ > 0 && zone_steps != steps_ && limits_.time_step >= 0)
    fail("CGNS zone '" + zone.name + "': its ZoneIterativeData names " + std::to_string(zone_steps) + " time steps where the zone before names " + std::to_string(steps_));
  steps_ = std::max(steps_, zone_steps);
  const std::string pointed[2] = {step_solution(zone, pointers[0]), step_solution(zone, pointers[1])};
  std::vector<Solution> usable[2];  // at vertices, at cell centres
  for (const Node& n : nodes) {
    if (n.label != "FlowSolution_t") continue;
    const std::string label = "CGNS solution '" + n.name + "' of zone '" + zone.name + "'";
    const std::vector<Node> parts = children(n.id, label);
    std::string location = "Vertex";
    bool partial = false;
    for (const Node& p : parts) {
      if (p.label == "GridLocation_t") location = text(p.id, "the GridLocation of " + label);
      partial |= p.label == "IndexRange_t" || p.label == "IndexArray_t" || p.label == "Rind_t";
    }
    const bool vertex = location == "Vertex", cell = location == "CellCenter";
    if (!vertex && !cell) {
      stats.warnings.push_back(label + ": values at " + location + " are not read");
      continue;
    }
    if (partial) {
      stats.warnings.push_back(label + " does not cover the zone (a point set or rind layers) and is not read");
      continue;
    }
    Solution solution{n.name, {}};
    const int64_t want = vertex ? zone.vertices : zone.cells;
    for (const Node& p : parts) {
      if (p.label != "DataArray_t") continue;
      if (solution.fields.size() >= static_cast<size_t>(kMaxFields)) fail(label + ": more than " + std::to_string(kMaxFields) + " fields");
      Field f{p.name, array(p, "field '" + p.name + "' of " + label)};
      if (f.values.length != want) {
        stats.warnings.push_back(label + ": field '" + p.name + "' holds " + std::to_string(f.values.length) + " values for " + std::to_string(want) + " and is not read");
        continue;
      }
      solution.fields.push_back(f);
    }
    usable[vertex ? 0 : 1].push_back(solution);
  }
  for (int l = 0; l < 2; ++l) {
    if (usable[l].empty()) continue;
    Solution chosen = usable[l].back();
    bool named = false;
    for (const Solution& s : usable[l])
      if (s.name == pointed[l]) chosen = s, named = true;
    const char* where = l == 0 ? "vertices" : "cell centres";
    if (limits_.time_step >= 0 && !named && usable[l].size() > 1) {  // one solution alone holds for every step
      fail("CGNS zone '" + zone.name + "': time step " + std::to_string(limits_.time_step) + " names " + (pointed[l].empty() ? std::string("no solution") : "solution '" + pointed[l] + "'") +
           ", none of its " + std::to_string(usable[l].size()) + " solutions at " + where);
    }
    if (usable[l].size() > 1 && limits_.time_step < 0) {
      stats.warnings.push_back("CGNS zone '" + zone.name + "' has " + std::to_string(usable[l].size()) + " solutions at " + where + ": the last step's ('" + chosen.name + "') is read" +
                               (zone_steps > 1 ? " (preprocess --all-steps reads every step)" : ""));
    }
    (l == 0 ? zone.vertex_solution : zone.cell_solution) = chosen;
  }
}

// The values of a BC's point set (an IndexArray_t or IndexRange_t: integers, in an array of
// any shape), bounded by what the file can hold.
std::vector<int64_t> CgnsReader::index_values(const Node& node, const std::string& what) const {
  std::lock_guard<std::mutex> hold(library_lock());
  const Shape shaped = shape(node.id, what);
  const std::string& type = shaped.type;
  const int dimensions = shaped.dimensions;
  const cgsize_t* extent = shaped.extent;
  const bool wide = type == "I8";
  if (!wide && type != "I4") fail("CGNS: " + what + " holds " + type + " values, not integers");
  const uint64_t most = inflate_limit(limits_, file_bytes_) / 4;
  uint64_t values = dimensions > 0 ? 1 : 0;
  for (int d = 0; d < std::min(dimensions, CGIO_MAX_DIMENSIONS); ++d) {
    if (extent[d] < 0 || (extent[d] > 0 && values > most / static_cast<uint64_t>(extent[d]))) fail("CGNS: " + what + " declares more values than the file can hold");
    values *= static_cast<uint64_t>(extent[d]);
  }
  std::vector<int64_t> out(values);
  if (values == 0) return out;
  std::vector<int32_t> narrow(wide ? 0 : values);
  if (cgio_read_all_data(cgio_, node.id, wide ? static_cast<void*>(out.data()) : static_cast<void*>(narrow.data())) != CGIO_ERR_NONE) {
    fail("CGNS: cannot read " + what + cgio_message());
  }
  if (!wide) std::copy(narrow.begin(), narrow.end(), out.begin());
  return out;
}

// Each BC_t of the zone's ZoneBC: a point set of face elements (ElementList or ElementRange, or
// PointList or PointRange at FaceCenter) or of vertices (PointList or PointRange at Vertex);
// BCs of other locations are left out with a warning.
void CgnsReader::read_boundaries(Zone& zone, const std::vector<Node>& nodes, ReadStats& stats) {
  for (const Node& n : nodes) {
    if (n.label != "ZoneBC_t") continue;
    for (const Node& bc : children(n.id, "the ZoneBC of zone '" + zone.name + "'")) {
      if (bc.label != "BC_t") continue;
      const std::string label = "CGNS BC '" + bc.name + "' of zone '" + zone.name + "'";
      Boundary b;
      b.name = bc.name;
      std::string location = "Vertex";
      bool found = false, elements = false;
      for (const Node& p : children(bc.id, label)) {
        if (p.label == "GridLocation_t") location = text(p.id, "the GridLocation of " + label);
        const bool is_range = p.name == "PointRange" || p.name == "ElementRange", is_list = p.name == "PointList" || p.name == "ElementList";
        if (!is_range && !is_list) continue;
        std::vector<int64_t> values = index_values(p, "the " + p.name + " of " + label);
        if (is_range && values.size() != 2) fail(label + ": its " + p.name + " holds " + std::to_string(values.size()) + " values, not 2");
        found = true;
        elements = p.name[0] == 'E';
        b.range = is_range;
        if (is_range) {
          b.low = values[0];
          b.high = values[1];
        } else {
          std::sort(values.begin(), values.end());
          values.erase(std::unique(values.begin(), values.end()), values.end());
          b.list = std::move(values);
        }
      }
      if (!found) continue;
      b.faces = elements || location == "FaceCenter";
      if (!b.faces && location != "Vertex") {
        stats.warnings.push_back(label + ": a point set at " + location + " is not read as boundary faces");
        continue;
      }
      if (!b.faces) {
        const int64_t first = b.range ? b.low : b.list.empty() ? 1 : b.list.front(), last = b.range ? b.high : b.list.empty() ? 0 : b.list.back();
        if (first <= last && (first < 1 || last > zone.vertices)) {
          fail(label + " names vertex " + std::to_string(first < 1 ? first : last) + " of a zone of " + std::to_string(zone.vertices) + " vertices");
        }
      }
      zone.face_boundaries |= b.faces;
      zone.vertex_boundaries |= !b.faces;
      zone.boundaries.push_back(std::move(b));
    }
  }
}

void CgnsReader::read_field(const Zone& zone, const Solution& solution, const std::string& field, int64_t first, size_t count, std::vector<double>& out) {
  out.resize(count);
  const Array* values = solution.find(field);
  if (!values) {
    std::fill(out.begin(), out.end(), std::numeric_limits<double>::quiet_NaN());  // a zone without the field
    return;
  }
  read_values(*values, first, count, "field '" + field + "' of zone '" + zone.name + "'", nullptr, out.data());
}

void CgnsReader::read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) {
  size_t done = 0;
  while (done < count) {
    if (vertex_zone_ >= zones_.size()) fail("CGNS: more vertices asked for than the zones hold");
    const Zone& zone = zones_[vertex_zone_];
    const size_t n = static_cast<size_t>(std::min<uint64_t>(static_cast<uint64_t>(zone.vertices - in_vertex_zone_), count - done));
    if (n == 0) {
      ++vertex_zone_;
      in_vertex_zone_ = 0;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      scratch_[k].resize(n);
      read_values(zone.coordinates[k], in_vertex_zone_, n, std::string("the coordinates of zone '") + zone.name + "'", nullptr, scratch_[k].data());
    }
    for (size_t i = 0; i < n; ++i)
      for (size_t k = 0; k < 3; ++k)
        if (!to_stored_float(scratch_[k][i], xyz[3 * (done + i) + k])) {
          fail("zone '" + zone.name + "', vertex " + std::to_string(in_vertex_zone_ + static_cast<int64_t>(i) + 1) + ": point coordinate " + std::to_string(scratch_[k][i]) +
               " is not a finite 32-bit float");
        }
    for (size_t a = 0; a < point_variables_.size(); ++a) {
      const size_t c = point_variables_[a].fields.size();
      for (size_t k = 0; k < c; ++k) {
        read_field(zone, zone.vertex_solution, point_variables_[a].fields[k], in_vertex_zone_, n, scratch_[0]);
        for (size_t i = 0; i < n; ++i) {
          if (to_stored_float(scratch_[0][i], attributes[a][(done + i) * c + k])) continue;
          if (point_variables_[a].tensor)  // a tensor's eigen-analysis needs every component
            fail("zone '" + zone.name + "', tensor '" + point_variables_[a].name + "' (field " + point_variables_[a].fields[k] + "), vertex " +
                 std::to_string(in_vertex_zone_ + static_cast<int64_t>(i) + 1) + ": " + std::to_string(scratch_[0][i]) + " is not a finite 32-bit float");
          ++stats.nonfinite_attribute_values;
        }
      }
    }
    in_vertex_zone_ += static_cast<int64_t>(n);
    done += n;
  }
}

void CgnsReader::append_element(const Zone& zone, const Section& s, int64_t element, int vtk_type, int corners, int face, std::span<const int64_t> nodes,
                                CellBatch& batch) {
  if (!zone.face_boundaries || nodes.size() < static_cast<size_t>(face)) face = 0;  // a face element's corners matter to face BCs only
  const size_t used = corners > 0 ? static_cast<size_t>(corners) : face > 0 ? static_cast<size_t>(face) : std::min<size_t>(1, nodes.size());
  nodes_scratch_.resize(used);
  for (size_t k = 0; k < used; ++k) {
    const int64_t node = nodes[k];
    if (node < 1 || node > zone.vertices) {
      fail("CGNS element " + std::to_string(element) + " of section '" + s.name + "' in zone '" + zone.name + "': vertex " + std::to_string(node) +
           " out of range (the zone has " + std::to_string(zone.vertices) + " vertices)");
    }
    nodes_scratch_[k] = static_cast<uint32_t>(zone.first_vertex + static_cast<uint64_t>(node - 1));
  }
  if (corners > 0 && nodes.size() > static_cast<size_t>(corners)) ++batch.reduced;
  const bool volume = corners > 0;
  if (volume) {
    if (!cell_variables_.empty() && volume_in_zone_ >= zone.cells) {
      fail("CGNS zone '" + zone.name + "' holds more volume elements than the " + std::to_string(zone.cells) + " cells it declares");
    }
    if (runs_.empty() || runs_.back().zone != zone_) runs_.push_back({zone_, volume_in_zone_, 0});
    ++runs_.back().volumes;
    ++volume_in_zone_;
  }
  volume_cell_.push_back(volume ? 1 : 0);
  note_faces(zone, element, vtk_type, corners, face);
  if (!volume) nodes_scratch_.resize(std::min<size_t>(1, used));
  batch.push(static_cast<uint8_t>(volume ? vtk_type : kVtkVertex), nodes_scratch_);
}

// What the zone's BCs need of the element just read (its corners in nodes_scratch_): a face
// element of a zone with face BCs, the faces of a volume element whose corners all lie in a
// vertex BC.
void CgnsReader::note_faces(const Zone& zone, int64_t element, int vtk_type, int corners, int face) {
  if (face > 0 && zone.face_boundaries) {
    SurfaceFace f{zone_, element, {0, 0, 0, 0}, face};
    std::copy_n(nodes_scratch_.begin(), face, f.corners);
    surface_faces_.push_back(f);
  }
  if (corners <= 0 || !zone.vertex_boundaries) return;
  const CellFaces& faces = cell_faces(vtk_type);
  for (int f = 0; f < faces.count; ++f) {
    const int n = faces.corners[f][3] < 0 ? 3 : 4;
    uint32_t c[4] = {0, 0, 0, 0};
    bool all = true;
    for (int k = 0; k < n; ++k) {
      c[k] = nodes_scratch_[static_cast<size_t>(faces.corners[f][k])];
      all = all && on_vertex_boundary_[c[k]];
    }
    if (!all) continue;
    face_triangles(c, n, [&](Triangle t) {
      std::sort(t.begin(), t.end());
      candidates_.push_back(t);
    });
  }
}

// The BCs' faces, zone by zone and BC by BC in file order (a face two BCs hold goes to the
// first): face elements by number; for a vertex set, the boundary faces (faces of one volume
// element only) whose corners are all in it.
FaceTags CgnsReader::take_face_tags() {
  FaceTags tags;
  std::sort(candidates_.begin(), candidates_.end());
  std::vector<Triangle> boundary;
  for (size_t i = 0, j = 0; i < candidates_.size(); i = j) {
    for (j = i + 1; j < candidates_.size() && candidates_[j] == candidates_[i];) ++j;
    if (j == i + 1) boundary.push_back(candidates_[i]);
  }
  std::vector<bool> face_taken(surface_faces_.size(), false), boundary_taken(boundary.size(), false);
  for (size_t z = 0; z < zones_.size(); ++z) {
    const Zone& zone = zones_[z];
    for (const Boundary& b : zone.boundaries) {
      const uint32_t tag = tag_named(tags, b.name);
      auto add = [&](Triangle t) { tags.add(tag, t[0], t[1], t[2]); };
      for (size_t f = 0; f < surface_faces_.size() && b.faces; ++f) {
        const SurfaceFace& face = surface_faces_[f];
        if (face_taken[f] || face.zone != z || !b.holds(face.element)) continue;
        face_taken[f] = true;
        face_triangles(face.corners, face.count, add);
      }
      const auto local = [&](uint32_t v) { return static_cast<int64_t>(v - zone.first_vertex) + 1; };
      for (size_t f = 0; f < boundary.size() && !b.faces; ++f) {
        const Triangle& t = boundary[f];
        if (boundary_taken[f] || t[0] < zone.first_vertex || !b.holds(local(t[0])) || !b.holds(local(t[1])) || !b.holds(local(t[2]))) continue;
        boundary_taken[f] = true;
        add(t);
      }
    }
  }
  // a BC none of whose faces was found keeps no name
  std::vector<uint64_t> used(tags.names.size(), 0);
  for (uint32_t t : tags.tags) ++used[t];
  if (std::find(used.begin(), used.end(), 0) != used.end()) {
    FaceTags kept;
    std::vector<uint32_t> renamed(tags.names.size());
    for (size_t t = 0; t < tags.names.size(); ++t)
      if (used[t] > 0) renamed[t] = tag_named(kept, tags.names[t]);
    for (size_t i = 0; i < tags.tags.size(); ++i) kept.add(renamed[tags.tags[i]], tags.triangles[i][0], tags.triangles[i][1], tags.triangles[i][2]);
    tags = std::move(kept);
  }
  surface_faces_.clear();
  candidates_.clear();
  return tags;
}

void CgnsReader::read_section_cells(const Zone& zone, const Section& s, int64_t n, CellBatch& batch) {
  const int64_t low = s.start + in_section_;
  if (s.nodes == 0) return read_mixed_cells(zone, s, low, n, batch);
  const size_t values = static_cast<size_t>(n) * static_cast<size_t>(s.nodes);
  connectivity_.resize(values);
  read_values(s.connectivity, in_section_ * s.nodes, values, "the elements of section '" + s.name + "' in zone '" + zone.name + "'", connectivity_.data(), nullptr);
  for (int64_t e = 0; e < n; ++e) {
    const std::span<const int64_t> nodes(connectivity_.data() + static_cast<size_t>(e) * static_cast<size_t>(s.nodes), static_cast<size_t>(s.nodes));
    append_element(zone, s, low + e, s.vtk_type, s.corners, face_corners(s.type), nodes, batch);
  }
}

// MIXED: each element is its type and then its nodes. The connectivity is read in file order, a
// window at a time, and walked by the element types (the offsets stored beside it are not
// trusted: the library's own partial read follows them, and a damaged file crashed it); every
// type, count and index is checked before use.
void CgnsReader::read_mixed_cells(const Zone& zone, const Section& s, int64_t low, int64_t n, CellBatch& batch) {
  constexpr int64_t kMaxElementValues = 1 + 125;  // HEXA_125 and its type
  const std::string section = "MIXED section '" + s.name + "' in zone '" + zone.name + "'";
  const int64_t window = std::min<int64_t>(s.connectivity.length - mixed_position_, n * kMaxElementValues);
  if (window <= 0) fail("CGNS " + section + ": its connectivity ends before element " + std::to_string(low));
  connectivity_.resize(static_cast<size_t>(window));
  read_values(s.connectivity, mixed_position_, static_cast<size_t>(window), "the connectivity of " + section, connectivity_.data(), nullptr);
  size_t at = 0;
  for (int64_t e = 0; e < n; ++e) {
    auto element = [&] { return "CGNS element " + std::to_string(low + e) + " of " + section; };
    if (at >= connectivity_.size()) fail(element() + ": the connectivity ends before it");
    const int64_t type_value = connectivity_[at];
    const auto type = static_cast<CGNS_ENUMT(ElementType_t)>(type_value >= 0 && type_value < NofValidElementTypes ? type_value : 0);
    int nodes = 0;
    const auto [vtk, corners] = element_kind(type);
    if (type == CGNS_ENUMV(ElementTypeNull) || corners < 0 || type == CGNS_ENUMV(MIXED) || cg_npe(type, &nodes) != CG_OK || nodes <= 0) {
      fail(element() + ": element type " + std::to_string(type_value) + " cannot be read in a MIXED section");
    }
    if (connectivity_.size() - at - 1 < static_cast<size_t>(nodes)) fail(element() + ": the connectivity ends inside it");
    append_element(zone, s, low + e, vtk, corners, face_corners(type), std::span<const int64_t>(connectivity_.data() + at + 1, static_cast<size_t>(nodes)), batch);
    at += 1 + static_cast<size_t>(nodes);
  }
  mixed_position_ += static_cast<int64_t>(at);
}

bool CgnsReader::read_cells(CellBatch& batch, size_t max_cells) {
  runs_.clear();
  volume_cell_.clear();
  size_t added = 0;
  while (added < max_cells && zone_ < zones_.size()) {
    const Zone& zone = zones_[zone_];
    if (section_ >= zone.sections.size()) {
      if (!cell_variables_.empty() && volume_in_zone_ != zone.cells) {
        fail("CGNS zone '" + zone.name + "' holds " + std::to_string(volume_in_zone_) + " volume elements but declares " + std::to_string(zone.cells) +
             " cells, so its cell-centred values cannot be matched to them");
      }
      ++zone_;
      section_ = 0;
      in_section_ = 0;
      mixed_position_ = 0;
      volume_in_zone_ = 0;
      continue;
    }
    const Section& s = zone.sections[section_];
    const int64_t n = std::min<int64_t>(s.count - in_section_, static_cast<int64_t>(std::min<size_t>(max_cells - added, 1 << 20)));
    if (n <= 0) {
      ++section_;
      in_section_ = 0;
      mixed_position_ = 0;
      continue;
    }
    read_section_cells(zone, s, n, batch);
    in_section_ += n;
    added += static_cast<size_t>(n);
  }
  return added > 0;
}

void CgnsReader::read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) {
  if (count != volume_cell_.size()) fail("CGNS: cell values out of step with the elements");
  for (size_t a = 0; a < cell_variables_.size(); ++a) {
    const size_t c = cell_variables_[a].fields.size();
    for (size_t k = 0; k < c; ++k) {
      // the runs' values in order, then handed to the volume elements; other elements get NaN
      std::vector<double>& gathered = scratch_[1];
      gathered.clear();
      for (const Run& run : runs_) {
        const Zone& zone = zones_[run.zone];
        read_field(zone, zone.cell_solution, cell_variables_[a].fields[k], run.first_volume, static_cast<size_t>(run.volumes), scratch_[0]);
        gathered.insert(gathered.end(), scratch_[0].begin(), scratch_[0].end());
      }
      size_t next = 0;
      for (size_t e = 0; e < count; ++e) {
        float& out = values[a][e * c + k];
        if (!volume_cell_[e]) out = std::numeric_limits<float>::quiet_NaN();
        else if (!to_stored_float(gathered[next++], out)) ++stats.nonfinite_attribute_values;
      }
    }
  }
}

}  // namespace

}  // namespace tetrascope::storage::detail

// The module's one entry point (storage/src/reader_modules.cpp loads it with dlopen): a new
// reader, or null with `error` set when the reader cannot be made.
extern "C" __attribute__((visibility("default"))) tetrascope::storage::detail::FormatReader* tetrascope_make_cgns_reader(
    const char* path, const tetrascope::storage::ReadLimits* limits, std::string* error) {
  try {
    return new tetrascope::storage::detail::CgnsReader(path, *limits);
  } catch (const std::exception& e) {
    *error = e.what();
    return nullptr;
  }
}
