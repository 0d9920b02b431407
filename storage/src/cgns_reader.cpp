// CGNS meshes (.cgns, .adf) through the CGNS mid-level library (HDF5 and ADF files), built as
// a module of its own (libtetrascope_cgns.so) that tetrascope loads on the first CGNS file, so
// that no other process maps the CGNS and HDF5 libraries:
// the unstructured zones of the first base, joined in file order (vertex ids offset by the
// zones before; points shared by two zones stay two vertices), element sections of tets,
// pyramids, wedges and hexahedra (higher-order ones by their corners), MIXED sections, and
// surface, line and point sections counted and skipped; a FlowSolution at Vertex as point data
// and one at CellCenter as cell data (the last of each location, or the one the zone's
// ZoneIterativeData names for the last step), fields NAMEX NAMEY NAMEZ joined into a vector
// NAME as ParaView does. Coordinates, connectivity and values are read in chunks (the
// library's partial reads), so memory follows the chunk, not the file. The CGNS library keeps
// global state and is not thread-safe: every call into it holds one process-wide lock.
// SIDS (the CGNS Standard Interface Data Structures), sections 6 (zones), 7 (elements), 11
// (flow solutions) and 12.5 (ZoneIterativeData).
#include <cgns_io.h>
#include <cgnslib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>

#include "format_reader.h"

namespace tetrascope::storage::detail {
namespace {

// What one file may declare, whatever its size: as many zones, sections, solutions and fields
// as any real file has, bounded so that a hostile header costs no memory.
constexpr int kMaxZones = 100000;
constexpr int kMaxSections = 100000;
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

// The library reports errors through cg_get_error; its warnings would otherwise go to stderr.
void quiet_handler(int, char*) {}

std::string library_error() {
  const char* e = cg_get_error();
  return e && *e ? std::string(" (") + e + ")" : std::string();
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

// A variable of the file: one field, or three joined into a vector.
struct Variable {
  std::string name;
  std::vector<std::string> fields;  // the CGNS field names, one a component
};

// NAMEX NAMEY NAMEZ (or NAMEx ..., anywhere in the list) become one vector NAME, at the place
// of its X component, as ParaView's CGNS reader joins VelocityX/Y/Z and MomentumX/Y/Z.
std::vector<Variable> join_components(const std::vector<std::string>& names) {
  std::vector<Variable> out;
  std::vector<bool> used(names.size(), false);
  for (size_t i = 0; i < names.size(); ++i) {
    if (used[i]) continue;
    const std::string& a = names[i];
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
        out.push_back({shown, {a, *y, *z}});
        continue;
      }
    }
    out.push_back({a, {a}});
  }
  return out;
}

// The file's first bytes: an HDF5 file (signature at 0, 512, 1024, ...) or an ADF one.
bool looks_like_cgns(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  char head[32] = {};
  in.read(head, sizeof head);
  if (std::memcmp(head, "\x89HDF\r\n\x1a\n", 8) == 0) return true;
  return std::memcmp(head + 4, "ADF Database Version", 20) == 0;  // after "@(#)", high bits set
}

struct Section {
  int index = 0;  // 1-based CGNS section
  std::string name;
  CGNS_ENUMT(ElementType_t) type = CGNS_ENUMV(ElementTypeNull);
  cgsize_t start = 0, count = 0;
  int vtk_type = 0, corners = 0, nodes = 0;  // nodes: per element, 0 for MIXED
  double connectivity_node = 0;               // MIXED: its ElementConnectivity node (cgio)
  bool wide = false;                          // MIXED: 64-bit values
  int64_t values = 0;                         // MIXED: their count
};

struct Solution {
  int index = 0;  // 1-based CGNS FlowSolution; 0: none
  std::vector<std::string> fields;
};

struct Zone {
  int index = 0;
  std::string name;
  cgsize_t vertices = 0, cells = 0;
  uint64_t first_vertex = 0;
  std::vector<Section> sections;
  Solution vertex_solution, cell_solution;
};

class CgnsReader final : public FormatReader {
 public:
  CgnsReader(std::filesystem::path path, const ReadLimits& limits) : path_(std::move(path)), name_(path_.filename().string()), limits_(limits) {}
  ~CgnsReader() override {
    if (file_ >= 0) {
      std::lock_guard<std::mutex> hold(library_lock());
      cg_close(file_);
    }
  }
  MeshHeader index(ReadStats& stats) override;
  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override;
  bool read_cells(CellBatch& batch, size_t max_cells) override;
  void read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) override;
  void rewind_cells() override {
    zone_ = section_ = 0;
    in_section_ = 0;
    mixed_position_ = 0;
    volume_in_zone_ = 0;
    runs_.clear();
    volume_cell_.clear();
  }

 private:
  [[noreturn]] void fail(const std::string& what) const { throw MeshError(name_ + ": " + what); }
  // Runs one library call under the lock; a status other than CG_OK fails naming `what`.
  template <typename Call>
  void call(const std::string& what, Call&& c) const {
    std::lock_guard<std::mutex> hold(library_lock());
    if (c() != CG_OK) {
      std::string message = "CGNS: cannot read ";
      message += what;
      message += library_error();
      fail(message);
    }
  }
  void open_file();
  Zone read_zone(int index, uint64_t& declared_bytes, uint64_t& cells);
  Section read_section(const Zone& zone, int index, uint64_t& declared_bytes);
  void find_connectivity(const Zone& zone, Section& s, const std::string& named);
  void choose_solutions(Zone& zone, ReadStats& stats);
  std::string pointed_solution(const Zone& zone);
  std::vector<std::string> field_names(const Zone& zone, int solution);
  // Reads `count` values of field `field` of `solution` in `zone` from 0-based `first`
  // into out, or NaN when the zone's solution lacks the field.
  void read_field(const Zone& zone, const Solution& solution, const std::string& field, cgsize_t first, size_t count, std::vector<double>& out);
  void read_section_cells(const Zone& zone, const Section& s, cgsize_t n, CellBatch& batch);
  void read_mixed_cells(const Zone& zone, const Section& s, cgsize_t low, cgsize_t n, CellBatch& batch);
  void append_element(const Zone& zone, const Section& s, cgsize_t element, int vtk_type, int corners, std::span<const cgsize_t> nodes, CellBatch& batch);

  std::filesystem::path path_;
  std::string name_;
  ReadLimits limits_;
  int file_ = -1;
  int base_ = 1;
  std::string base_name_;
  int cgio_ = 0;  // the file's node-layer handle
  MeshHeader header_;
  std::vector<Zone> zones_;
  std::vector<Variable> point_variables_, cell_variables_;
  uint64_t vertex_total_ = 0;
  // vertices
  size_t vertex_zone_ = 0;
  cgsize_t in_vertex_zone_ = 0;
  // cells
  size_t zone_ = 0, section_ = 0;
  cgsize_t in_section_ = 0;
  cgsize_t volume_in_zone_ = 0;  // volume elements of the zone delivered so far
  struct Run {
    size_t zone;
    cgsize_t first_volume, volumes;  // 0-based among the zone's volume elements
  };
  std::vector<Run> runs_;             // the volume elements the last read_cells appended, by zone
  std::vector<uint8_t> volume_cell_;  // per cell the last read_cells appended: 1 for a volume element
  std::vector<cgsize_t> connectivity_, nodes_wide_;
  std::vector<int64_t> mixed_;
  std::vector<int32_t> narrow_;
  int64_t mixed_position_ = 0;  // values of the current MIXED section's connectivity consumed
  std::vector<double> scratch_[3];
  std::vector<uint32_t> nodes_scratch_;
};

void CgnsReader::open_file() {
  std::lock_guard<std::mutex> hold(library_lock());
  cg_configure(CG_CONFIG_ERROR, reinterpret_cast<void*>(&quiet_handler));
  if (cg_open(path_.c_str(), CG_MODE_READ, &file_) != CG_OK) {
    file_ = -1;
    std::string message = "CGNS: the library cannot open the file";
    message += library_error();
    fail(message);
  }
}

MeshHeader CgnsReader::index(ReadStats& stats) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path_, ec)) fail("not a regular file");
  const uint64_t file_bytes = std::filesystem::file_size(path_, ec);
  if (!looks_like_cgns(path_)) fail("not a CGNS file (neither an HDF5 nor an ADF file)");
  open_file();
  int bases = 0;
  call("its bases", [&] { return cg_nbases(file_, &bases); });
  if (bases < 1) fail("CGNS: no base (CGNSBase_t) in the file");
  char base_name[33] = {};
  int cell_dim = 0, physical_dim = 0;
  call("base 1", [&] { return cg_base_read(file_, base_, base_name, &cell_dim, &physical_dim); });
  if (cell_dim != 3 || physical_dim != 3) {
    fail("CGNS base '" + std::string(base_name) + "' has cell dimension " + std::to_string(cell_dim) + " in " + std::to_string(physical_dim) +
         " dimensions; tetrascope reads 3D volumes");
  }
  base_name_ = std::string(base_name, strnlen(base_name, 32));
  if (bases > 1) stats.warnings.push_back(std::to_string(bases) + " CGNS bases: the first ('" + base_name + "') is read");
  int zone_count = 0;
  call("its zones", [&] { return cg_nzones(file_, base_, &zone_count); });
  if (zone_count < 1) fail("CGNS base '" + std::string(base_name) + "' has no zone");
  if (zone_count > kMaxZones) fail("CGNS: " + std::to_string(zone_count) + " zones");
  uint64_t declared = 0, cells = 0;
  for (int z = 1; z <= zone_count; ++z) {
    zones_.push_back(read_zone(z, declared, cells));
    zones_.back().first_vertex = vertex_total_;
    vertex_total_ += static_cast<uint64_t>(zones_.back().vertices);
    if (vertex_total_ >= std::numeric_limits<uint32_t>::max()) fail("CGNS: more than 4294967294 vertices");
  }
  const uint64_t limit = inflate_limit(limits_, file_bytes);
  if (declared > limit) {
    fail("CGNS: its zones declare " + std::to_string(declared) + " bytes of coordinates and connectivity, more than " + std::to_string(limit) +
         " allowed for a file of " + std::to_string(file_bytes) + " bytes (raise --max-inflate-ratio if the file is genuine)");
  }
  for (Zone& zone : zones_) choose_solutions(zone, stats);
  // the variables of the first zone that has a solution of the location name the attributes
  for (const Zone& zone : zones_)
    if (zone.vertex_solution.index > 0) {
      point_variables_ = join_components(zone.vertex_solution.fields);
      break;
    }
  for (const Zone& zone : zones_)
    if (zone.cell_solution.index > 0) {
      cell_variables_ = join_components(zone.cell_solution.fields);
      break;
    }
  header_.format = MeshFormat::kCgns;
  int file_type = 0;
  call("its file type", [&] { return cg_get_file_type(file_, &file_type); });
  header_.description = "CGNS ";
  header_.description += file_type == CG_FILE_HDF5 ? "HDF5" : "ADF";
  header_.description += ", base '" + std::string(base_name) + "', " + std::to_string(zones_.size()) + " unstructured zone" + (zones_.size() == 1 ? "" : "s");
  header_.vertex_count = vertex_total_;
  header_.cell_count = cells;
  for (const Variable& v : point_variables_) header_.attributes.push_back({v.name, static_cast<uint32_t>(v.fields.size())});
  for (const Variable& v : cell_variables_) header_.cell_attributes.push_back({v.name, static_cast<uint32_t>(v.fields.size())});
  if (zones_.size() > 1) stats.warnings.push_back(std::to_string(zones_.size()) + " zones joined: points on zone interfaces are not merged");
  return header_;
}

Zone CgnsReader::read_zone(int index, uint64_t& declared_bytes, uint64_t& cells) {
  Zone zone;
  zone.index = index;
  char name[33] = {};
  CGNS_ENUMT(ZoneType_t) type = CGNS_ENUMV(ZoneTypeNull);
  call("zone " + std::to_string(index), [&] { return cg_zone_type(file_, base_, index, &type); });
  cgsize_t size[9] = {};
  call("zone " + std::to_string(index), [&] { return cg_zone_read(file_, base_, index, name, size); });
  zone.name = std::string(name, strnlen(name, 32));
  const std::string label = "zone '" + zone.name + "'";
  if (type == CGNS_ENUMV(Structured)) fail("CGNS " + label + " is structured; tetrascope reads unstructured zones only");
  if (type != CGNS_ENUMV(Unstructured)) fail("CGNS " + label + " is of no known type (neither structured nor unstructured)");
  if (size[0] < 0 || size[1] < 0) fail("CGNS " + label + " declares " + std::to_string(size[0]) + " vertices and " + std::to_string(size[1]) + " cells");
  zone.vertices = size[0];
  zone.cells = size[1];
  declared_bytes += static_cast<uint64_t>(zone.vertices) * 3 * 4;
  int coords = 0;
  call("the coordinates of " + label, [&] { return cg_ncoords(file_, base_, index, &coords); });
  int found = 0;
  for (int c = 1; c <= std::min(coords, 16); ++c) {
    CGNS_ENUMT(DataType_t) data_type;
    char coord[33] = {};
    call("the coordinates of " + label, [&] { return cg_coord_info(file_, base_, index, c, &data_type, coord); });
    found += !std::strcmp(coord, "CoordinateX") || !std::strcmp(coord, "CoordinateY") || !std::strcmp(coord, "CoordinateZ");
  }
  if (found != 3 && zone.vertices > 0) fail("CGNS " + label + " has no CoordinateX, CoordinateY and CoordinateZ (other coordinate systems are not read)");
  int sections = 0;
  call("the element sections of " + label, [&] { return cg_nsections(file_, base_, index, &sections); });
  if (sections < 0 || sections > kMaxSections) fail("CGNS " + label + ": " + std::to_string(sections) + " element sections");
  for (int s = 1; s <= sections; ++s) {
    zone.sections.push_back(read_section(zone, s, declared_bytes));
    cells += static_cast<uint64_t>(zone.sections.back().count);
  }
  // the library reads element sections by their element numbers, so keep them in that order
  std::stable_sort(zone.sections.begin(), zone.sections.end(), [](const Section& a, const Section& b) { return a.start < b.start; });
  return zone;
}

Section CgnsReader::read_section(const Zone& zone, int index, uint64_t& declared_bytes) {
  Section s;
  s.index = index;
  char name[33] = {};
  cgsize_t end = 0;
  int boundary = 0, parent = 0;
  const std::string label = "element section " + std::to_string(index) + " of zone '" + zone.name + "'";
  call(label, [&] { return cg_section_read(file_, base_, zone.index, index, name, &s.type, &s.start, &end, &boundary, &parent); });
  s.name = std::string(name, strnlen(name, 32));
  const std::string named = "CGNS element section '" + s.name + "' of zone '" + zone.name + "'";
  if (s.start < 1 || end < s.start - 1) fail(named + " numbers its elements " + std::to_string(s.start) + " to " + std::to_string(end));
  s.count = end - s.start + 1;
  auto [vtk, corners] = element_kind(s.type);
  if (s.type == CGNS_ENUMV(MIXED)) {
    vtk = 0;
    corners = 0;
  } else if (corners < 0) {
    fail(named + " holds " + (s.type >= 0 && s.type < NofValidElementTypes ? ElementTypeName[s.type] : "unknown") + " elements (polyhedra), which are not read");
  } else {
    int nodes = 0;
    if (cg_npe(s.type, &nodes) != CG_OK || nodes <= 0) fail(named + " holds elements of an unknown type");
    s.nodes = nodes;
  }
  s.vtk_type = vtk;
  s.corners = corners;
  cgsize_t data_size = 0;
  call("the size of " + label, [&] { return cg_ElementDataSize(file_, base_, zone.index, index, &data_size); });
  if (data_size < 0 || (s.nodes > 0 && static_cast<uint64_t>(data_size) != static_cast<uint64_t>(s.count) * static_cast<uint64_t>(s.nodes))) {
    fail(named + " holds " + std::to_string(data_size) + " connectivity values for " + std::to_string(s.count) + " elements");
  }
  declared_bytes += static_cast<uint64_t>(data_size) * sizeof(cgsize_t);
  if (s.type == CGNS_ENUMV(MIXED)) find_connectivity(zone, s, named);
  return s;
}

// The section's ElementConnectivity node, read through the library's node layer (cgio): its
// mid-level calls offer no partial read that checks a MIXED section's contents.
void CgnsReader::find_connectivity(const Zone& zone, Section& s, const std::string& named) {
  std::lock_guard<std::mutex> hold(library_lock());
  int cgio = 0;
  double root = 0;
  const std::string node = "/" + base_name_ + "/" + zone.name + "/" + s.name + "/ElementConnectivity";
  char type[CGIO_MAX_DATATYPE_LENGTH + 1] = {};
  int dimensions = 0;
  cgsize_t extent[CGIO_MAX_DIMENSIONS] = {};
  if (cg_get_cgio(file_, &cgio) != CG_OK || cg_root_id(file_, &root) != CG_OK || cgio_get_node_id(cgio, root, node.c_str(), &s.connectivity_node) != CGIO_ERR_NONE ||
      cgio_get_data_type(cgio, s.connectivity_node, type) != CGIO_ERR_NONE || cgio_get_dimensions(cgio, s.connectivity_node, &dimensions, extent) != CGIO_ERR_NONE) {
    fail(named + ": its ElementConnectivity cannot be read");
  }
  if (dimensions != 1 || extent[0] < 0) fail(named + ": its ElementConnectivity has " + std::to_string(dimensions) + " dimensions");
  if (std::strcmp(type, "I4") != 0 && std::strcmp(type, "I8") != 0) fail(named + ": its ElementConnectivity holds " + type + " values, not integers");
  cgio_ = cgio;
  s.wide = std::strcmp(type, "I8") == 0;
  s.values = extent[0];
}

// The name of the FlowSolution the zone's ZoneIterativeData names for the last time step
// (FlowSolutionPointers), or "".
std::string CgnsReader::pointed_solution(const Zone& zone) {
  std::lock_guard<std::mutex> hold(library_lock());
  char iterative[33] = {};
  if (cg_ziter_read(file_, base_, zone.index, iterative) != CG_OK) return "";
  if (cg_goto(file_, base_, "Zone_t", zone.index, "ZoneIterativeData_t", 1, "end") != CG_OK) return "";
  int arrays = 0;
  if (cg_narrays(&arrays) != CG_OK) return "";
  for (int a = 1; a <= arrays; ++a) {
    char array[33] = {};
    CGNS_ENUMT(DataType_t) type;
    int dimensions = 0;
    cgsize_t extent[12] = {};
    if (cg_array_info(a, array, &type, &dimensions, extent) != CG_OK) continue;
    if (std::strcmp(array, "FlowSolutionPointers") != 0 || type != CGNS_ENUMV(Character) || dimensions != 2) continue;
    if (extent[0] != 32 || extent[1] < 1 || extent[1] > kMaxTimeSteps) continue;
    std::vector<char> names(static_cast<size_t>(32 * extent[1]));
    if (cg_array_read(a, names.data()) != CG_OK) continue;
    for (cgsize_t step = extent[1]; step-- > 0;) {
      std::string chosen(names.data() + 32 * step, 32);
      chosen = chosen.substr(0, chosen.find('\0'));
      while (!chosen.empty() && chosen.back() == ' ') chosen.pop_back();
      if (!chosen.empty() && chosen != "Null") return chosen;
    }
  }
  return "";
}

std::vector<std::string> CgnsReader::field_names(const Zone& zone, int solution) {
  int fields = 0;
  call("the fields of zone '" + zone.name + "'", [&] { return cg_nfields(file_, base_, zone.index, solution, &fields); });
  if (fields < 0 || fields > kMaxFields) fail("CGNS zone '" + zone.name + "': " + std::to_string(fields) + " fields");
  std::vector<std::string> names;
  for (int f = 1; f <= fields; ++f) {
    CGNS_ENUMT(DataType_t) type;
    char name[33] = {};
    call("the fields of zone '" + zone.name + "'", [&] { return cg_field_info(file_, base_, zone.index, solution, f, &type, name); });
    names.emplace_back(name, strnlen(name, 32));
  }
  return names;
}

// Per location (Vertex, CellCenter) the last FlowSolution over the whole zone, or the one of
// that location that ZoneIterativeData names for the last step; solutions over a point set, with rind layers or
// at other locations are left out with a warning.
void CgnsReader::choose_solutions(Zone& zone, ReadStats& stats) {
  int solutions = 0;
  call("the solutions of zone '" + zone.name + "'", [&] { return cg_nsols(file_, base_, zone.index, &solutions); });
  if (solutions < 0 || solutions > kMaxFields) fail("CGNS zone '" + zone.name + "': " + std::to_string(solutions) + " solutions");
  const std::string pointed = solutions > 1 ? pointed_solution(zone) : "";
  std::vector<int> usable[2];  // at vertices, at cell centres
  std::vector<std::string> names[2];
  for (int s = 1; s <= solutions; ++s) {
    char name[33] = {};
    CGNS_ENUMT(GridLocation_t) location;
    call("the solutions of zone '" + zone.name + "'", [&] { return cg_sol_info(file_, base_, zone.index, s, name, &location); });
    const std::string label = "CGNS solution '" + std::string(name) + "' of zone '" + zone.name + "'";
    CGNS_ENUMT(PointSetType_t) point_set = CGNS_ENUMV(PointSetTypeNull);
    cgsize_t points = 0;
    int data_dim = 0;
    cgsize_t extent[12] = {};
    call("the size of " + label, [&] { return cg_sol_ptset_info(file_, base_, zone.index, s, &point_set, &points); });
    call("the size of " + label, [&] { return cg_sol_size(file_, base_, zone.index, s, &data_dim, extent); });
    const bool vertex = location == CGNS_ENUMV(Vertex), cell = location == CGNS_ENUMV(CellCenter);
    const cgsize_t want = vertex ? zone.vertices : zone.cells;
    if (!vertex && !cell) {
      stats.warnings.push_back(label + ": values at " + cg_GridLocationName(location) + " are not read");
    } else if (point_set != CGNS_ENUMV(PointSetTypeNull) || data_dim != 1 || extent[0] != want) {
      stats.warnings.push_back(label + " does not cover the zone (a point set or rind layers) and is not read");
    } else {
      usable[vertex ? 0 : 1].push_back(s);
      names[vertex ? 0 : 1].push_back(name);
    }
  }
  int chosen[2] = {0, 0};
  for (int l = 0; l < 2; ++l) {
    if (usable[l].empty()) continue;
    chosen[l] = usable[l].back();
    for (size_t k = 0; k < usable[l].size(); ++k)
      if (names[l][k] == pointed) chosen[l] = usable[l][k];
    if (usable[l].size() > 1) {
      stats.warnings.push_back("CGNS zone '" + zone.name + "' has " + std::to_string(usable[l].size()) + " solutions at " + (l == 0 ? "vertices" : "cell centres") +
                               ": the last step's is read");
    }
  }
  const int at_vertex = chosen[0], at_cell = chosen[1];
  if (at_vertex > 0) zone.vertex_solution = {at_vertex, field_names(zone, at_vertex)};
  if (at_cell > 0) zone.cell_solution = {at_cell, field_names(zone, at_cell)};
}

void CgnsReader::read_field(const Zone& zone, const Solution& solution, const std::string& field, cgsize_t first, size_t count, std::vector<double>& out) {
  out.resize(count);
  if (solution.index == 0 || std::find(solution.fields.begin(), solution.fields.end(), field) == solution.fields.end()) {
    std::fill(out.begin(), out.end(), std::numeric_limits<double>::quiet_NaN());  // a zone without the field
    return;
  }
  const cgsize_t low = first + 1, high = first + static_cast<cgsize_t>(count);
  call("field '" + field + "' of zone '" + zone.name + "'",
       [&] { return cg_field_read(file_, base_, zone.index, solution.index, field.c_str(), CGNS_ENUMV(RealDouble), &low, &high, out.data()); });
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
    const cgsize_t low = in_vertex_zone_ + 1, high = in_vertex_zone_ + static_cast<cgsize_t>(n);
    static const char* const names[3] = {"CoordinateX", "CoordinateY", "CoordinateZ"};
    for (int k = 0; k < 3; ++k) {
      scratch_[k].resize(n);
      call(std::string(names[k]) + " of zone '" + zone.name + "'",
           [&] { return cg_coord_read(file_, base_, zone.index, names[k], CGNS_ENUMV(RealDouble), &low, &high, scratch_[k].data()); });
    }
    for (size_t i = 0; i < n; ++i)
      for (size_t k = 0; k < 3; ++k)
        if (!to_stored_float(scratch_[k][i], xyz[3 * (done + i) + k])) {
          fail("zone '" + zone.name + "', vertex " + std::to_string(in_vertex_zone_ + static_cast<cgsize_t>(i) + 1) + ": point coordinate " + std::to_string(scratch_[k][i]) +
               " is not a finite 32-bit float");
        }
    for (size_t a = 0; a < point_variables_.size(); ++a) {
      const size_t c = point_variables_[a].fields.size();
      for (size_t k = 0; k < c; ++k) {
        read_field(zone, zone.vertex_solution, point_variables_[a].fields[k], in_vertex_zone_, n, scratch_[0]);
        for (size_t i = 0; i < n; ++i)
          if (!to_stored_float(scratch_[0][i], attributes[a][(done + i) * c + k])) ++stats.nonfinite_attribute_values;
      }
    }
    in_vertex_zone_ += static_cast<cgsize_t>(n);
    done += n;
  }
}

void CgnsReader::append_element(const Zone& zone, const Section& s, cgsize_t element, int vtk_type, int corners, std::span<const cgsize_t> nodes, CellBatch& batch) {
  const size_t used = corners > 0 ? static_cast<size_t>(corners) : std::min<size_t>(1, nodes.size());
  nodes_scratch_.resize(used);
  for (size_t k = 0; k < used; ++k) {
    const cgsize_t node = nodes[k];
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
  batch.push(static_cast<uint8_t>(volume ? vtk_type : kVtkVertex), nodes_scratch_);
}

void CgnsReader::read_section_cells(const Zone& zone, const Section& s, cgsize_t n, CellBatch& batch) {
  const cgsize_t low = s.start + in_section_, high = low + n - 1;
  const std::string label = "the elements of section '" + s.name + "' in zone '" + zone.name + "'";
  if (s.nodes > 0) {
    connectivity_.resize(static_cast<size_t>(n) * static_cast<size_t>(s.nodes));
    call(label, [&] { return cg_elements_partial_read(file_, base_, zone.index, s.index, low, high, connectivity_.data(), nullptr); });
    for (cgsize_t e = 0; e < n; ++e) {
      const std::span<const cgsize_t> nodes(connectivity_.data() + static_cast<size_t>(e) * static_cast<size_t>(s.nodes), static_cast<size_t>(s.nodes));
      append_element(zone, s, low + e, s.vtk_type, s.corners, nodes, batch);
    }
    return;
  }
  read_mixed_cells(zone, s, low, n, batch);
}

// MIXED: each element is its type and then its nodes. The library's own partial read trusts
// the section's offsets (a damaged file crashes it), so the connectivity array is read here in
// file order, a window at a time, and walked by the element types; every type, count and
// index is checked before use.
void CgnsReader::read_mixed_cells(const Zone& zone, const Section& s, cgsize_t low, cgsize_t n, CellBatch& batch) {
  constexpr int64_t kMaxElementValues = 1 + 125;  // HEXA_125 and its type
  const std::string section = "MIXED section '" + s.name + "' in zone '" + zone.name + "'";
  const int64_t window = std::min<int64_t>(s.values - mixed_position_, static_cast<int64_t>(n) * kMaxElementValues);
  if (window <= 0) fail("CGNS " + section + ": its connectivity ends before element " + std::to_string(low));
  mixed_.resize(static_cast<size_t>(window));
  {
    std::lock_guard<std::mutex> hold(library_lock());
    const cgsize_t from = static_cast<cgsize_t>(mixed_position_ + 1), to = static_cast<cgsize_t>(mixed_position_ + window), length = static_cast<cgsize_t>(window), one = 1;
    narrow_.resize(s.wide ? 0 : static_cast<size_t>(window));
    void* into = s.wide ? static_cast<void*>(mixed_.data()) : static_cast<void*>(narrow_.data());
    if (cgio_read_data(cgio_, s.connectivity_node, &from, &to, &one, 1, &length, &one, &length, &one, into) != CGIO_ERR_NONE) {
      fail("CGNS: cannot read the connectivity of " + section);
    }
    std::copy(narrow_.begin(), narrow_.end(), mixed_.begin());
  }
  size_t at = 0;
  for (cgsize_t e = 0; e < n; ++e) {
    const std::string element = "CGNS element " + std::to_string(low + e) + " of " + section;
    if (at >= mixed_.size()) fail(element + ": the connectivity ends before it");
    const int64_t type_value = mixed_[at];
    const auto type = static_cast<CGNS_ENUMT(ElementType_t)>(type_value >= 0 && type_value < NofValidElementTypes ? type_value : 0);
    int nodes = 0;
    const auto [vtk, corners] = element_kind(type);
    if (type == CGNS_ENUMV(ElementTypeNull) || corners < 0 || type == CGNS_ENUMV(MIXED) || cg_npe(type, &nodes) != CG_OK || nodes <= 0) {
      fail(element + ": element type " + std::to_string(type_value) + " cannot be read in a MIXED section");
    }
    if (mixed_.size() - at - 1 < static_cast<size_t>(nodes)) fail(element + ": the connectivity ends inside it");
    nodes_wide_.resize(static_cast<size_t>(nodes));
    for (int k = 0; k < nodes; ++k) {
      const int64_t v = mixed_[at + 1 + static_cast<size_t>(k)];
      nodes_wide_[static_cast<size_t>(k)] = static_cast<cgsize_t>(std::clamp<int64_t>(v, -1, std::numeric_limits<cgsize_t>::max()));
    }
    append_element(zone, s, low + e, vtk, corners, nodes_wide_, batch);
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
    const cgsize_t n = std::min<cgsize_t>(s.count - in_section_, static_cast<cgsize_t>(std::min<size_t>(max_cells - added, 1 << 20)));
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
      // the run's values in order, then handed to the volume elements; other elements get NaN
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
