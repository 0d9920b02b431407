// Exodus II meshes (.exo .e .ex2 .exii .g .gen) through the Exodus II library (NetCDF), built
// as a module of its own (libtetrascope_exodus.so) that tetrascope loads on the first Exodus
// file, so that no other process maps NetCDF, HDF5 and their libraries:
// element blocks of tets, hexahedra, wedges and pyramids (higher-order ones by their
// corners; shells, bars and other lower-dimensional blocks counted and skipped), nodal
// variables as point data and element variables as cell data at one time step (the last, or
// the one ReadLimits::time_step names; MeshHeader::step_times lists them),
// components named NAME_x, NAME_y, NAME_z (or NAMEx, ...) joined into a vector as ParaView
// does, and nodal NAME_XX NAME_YY NAME_ZZ NAME_XY NAME_YZ NAME_ZX (in a row, any order) into a
// symmetric tensor. Coordinates, connectivity and values are read in chunks (the library's partial
// reads), so memory follows the chunk, not the file. The NetCDF library is not thread-safe:
// every call into it holds one process-wide lock.
#include <exodusII.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <mutex>

#include "format_reader.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::storage::detail {
namespace {

std::mutex& library_lock() {
  static std::mutex lock;
  return lock;
}

// ReadLimits::max_inflated_bytes, here too: the module links none of tetrascope's code.
uint64_t inflate_limit(const ReadLimits& limits, uint64_t file_bytes) {
  const double allowed = static_cast<double>(ReadLimits::kInflateAllowanceBytes) + limits.max_inflate_ratio * static_cast<double>(file_bytes);
  return allowed >= 1.8e19 ? UINT64_MAX : static_cast<uint64_t>(allowed);
}

std::string upper(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// The VTK type and corner count of an Exodus element type, by its leading name; corners 0
// for a block of lower dimension (skipped), -1 for one that cannot be read.
std::pair<int, int> element_kind(const std::string& name) {
  const std::string t = upper(name);
  auto starts = [&](const char* prefix) { return t.rfind(prefix, 0) == 0; };
  if (starts("TET")) return {kVtkTetra, 4};
  if (starts("HEX")) return {kVtkHexahedron, 8};
  if (starts("WEDGE")) return {kVtkWedge, 6};
  if (starts("PYRAMID")) return {kVtkPyramid, 5};
  if (starts("NFACED") || starts("NSIDED")) return {0, -1};
  return {kVtkVertex, 0};  // TRI, QUAD, SHELL, BAR, BEAM, TRUSS, SPHERE, CIRCLE, ...
}

// A variable of the file: one Exodus variable, three joined into a vector, or six into a
// symmetric tensor.
struct Variable {
  std::string name;
  std::vector<int> indices;  // 1-based Exodus variable indices, one a component (a tensor's in the order xx yy zz xy yz xz)
  bool tensor = false;
};

std::string upper_text(std::string s) {
  for (char& c : s) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return s;
}

// NAME_XX NAME_YY NAME_ZZ NAME_XY NAME_YZ NAME_ZX (or _XZ; any order, any case, the '_'
// optional) in a row of six: SEACAS's and ParaView's convention for a symmetric tensor. The
// indices in the stored order xx yy zz xy yz xz; empty when the six are not one.
std::vector<int> symmetric_tensor_at(const std::vector<std::string>& names, size_t i, std::string& base) {
  if (i + 6 > names.size() || names[i].size() < 3) return {};
  const size_t n = names[i].size();
  base = names[i].substr(0, n - 2);
  std::vector<int> indices(6, 0);
  for (size_t k = 0; k < 6; ++k) {
    const std::string& name = names[i + k];
    if (name.size() != n || name.compare(0, n - 2, base) != 0) return {};
    const std::string suffix = upper_text(name.substr(n - 2));
    static const char* const kSuffixes[6][2] = {{"XX", "XX"}, {"YY", "YY"}, {"ZZ", "ZZ"}, {"XY", "YX"}, {"YZ", "ZY"}, {"XZ", "ZX"}};
    int slot = -1;
    for (int s = 0; s < 6; ++s)
      if (suffix == kSuffixes[s][0] || suffix == kSuffixes[s][1]) slot = s;
    if (slot < 0 || indices[size_t(slot)] != 0) return {};
    indices[size_t(slot)] = int(i + k) + 1;
  }
  if (!base.empty() && base.back() == '_') base.pop_back();
  if (base.empty()) return {};
  return indices;
}

// NAME_x NAME_y NAME_z (or NAMEx NAMEy NAMEz, any case) in a row become one vector NAME; with
// `tensors`, six components of a symmetric tensor (symmetric_tensor_at) one tensor NAME.
std::vector<Variable> join_components(const std::vector<std::string>& names, bool tensors) {
  std::vector<Variable> out;
  for (size_t i = 0; i < names.size();) {
    std::string tensor_name;
    if (std::vector<int> six = tensors ? symmetric_tensor_at(names, i, tensor_name) : std::vector<int>{}; !six.empty()) {
      out.push_back({tensor_name, std::move(six), true});
      i += 6;
      continue;
    }
    if (i + 2 < names.size()) {
      const std::string& a = names[i];
      const size_t n = a.size();
      bool vector = n >= 2 && a.size() == names[i + 1].size() && a.size() == names[i + 2].size() && std::tolower(static_cast<unsigned char>(a[n - 1])) == 'x';
      for (int k = 1; k < 3 && vector; ++k) {
        const std::string& b = names[i + static_cast<size_t>(k)];
        vector = b.compare(0, n - 1, a, 0, n - 1) == 0 && std::tolower(static_cast<unsigned char>(b[n - 1])) == "xyz"[k];
      }
      if (vector) {
        std::string base = a.substr(0, n - 1);
        if (!base.empty() && base.back() == '_') base.pop_back();
        out.push_back({base.empty() ? a : base, {int(i) + 1, int(i) + 2, int(i) + 3}, false});
        i += 3;
        continue;
      }
    }
    out.push_back({names[i], {int(i) + 1}, false});
    ++i;
  }
  return out;
}

// NetCDF's classic header ("CDF" 1, 2 or 5), walked before the library opens the file: every
// list and string length and attribute size must fit in the bytes left, and every variable's
// values in `limit` bytes. The library sizes its allocations by these counts, so a damaged
// header of a few bytes could otherwise cost gigabytes. Returns "" or what is wrong.
// NetCDF-4 files (HDF5, "\x89HDF") are left to the library.
std::string check_classic_header(const std::filesystem::path& path, uint64_t limit) {
  std::ifstream in(path, std::ios::binary);
  std::vector<uint8_t> bytes(1 << 20);
  in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<size_t>(in.gcount()));
  if (bytes.size() >= 4 && bytes[0] == 0x89 && bytes[1] == 'H' && bytes[2] == 'D' && bytes[3] == 'F') return "";
  if (bytes.size() < 8 || bytes[0] != 'C' || bytes[1] != 'D' || bytes[2] != 'F' || (bytes[3] != 1 && bytes[3] != 2 && bytes[3] != 5)) return "not an Exodus II file (no NetCDF header)";
  const bool wide = bytes[3] == 5, offsets64 = bytes[3] != 1;
  size_t at = 4;
  bool short_header = false;
  auto get = [&](size_t n) -> uint64_t {  // big-endian, n bytes
    if (at + n > bytes.size()) {
      short_header = true;
      at = bytes.size();
      return 0;
    }
    uint64_t v = 0;
    for (size_t k = 0; k < n; ++k) v = (v << 8) | bytes[at++];
    return v;
  };
  auto count = [&]() { return get(wide ? 8 : 4); };
  auto left = [&]() { return bytes.size() - at; };
  auto skip = [&](uint64_t n) {
    if (n > left()) short_header = true;
    at += static_cast<size_t>(std::min<uint64_t>(n, left()));
  };
  auto type_size = [](uint64_t type) -> uint64_t {
    static const uint64_t sizes[] = {0, 1, 1, 2, 4, 4, 8, 1, 2, 4, 8, 8};
    return type < 12 ? sizes[type] : 0;
  };
  auto name = [&]() { skip((count() + 3) / 4 * 4); };
  auto attributes = [&]() -> std::string {
    const uint64_t tag = get(4), n = count();
    if (tag == 0 && n == 0) return "";
    if (tag != 0x0C || n > left() / 12) return "a damaged NetCDF attribute list";
    for (uint64_t i = 0; i < n && !short_header; ++i) {
      name();
      const uint64_t size = type_size(get(4)), values = count();
      if (size == 0 || values > left() / size) return "a damaged NetCDF attribute";
      skip((values * size + 3) / 4 * 4);
    }
    return "";
  };
  count();  // numrecs
  std::vector<uint64_t> dims;
  const uint64_t dim_tag = get(4), dim_count = count();
  if (!(dim_tag == 0 && dim_count == 0) && (dim_tag != 0x0A || dim_count > left() / 8)) return "a damaged NetCDF dimension list";
  for (uint64_t i = 0; i < dim_count && !short_header && dim_tag == 0x0A; ++i) {
    name();
    dims.push_back(count());
  }
  if (std::string e = attributes(); !e.empty()) return e;
  const uint64_t var_tag = get(4), var_count = count();
  if (!(var_tag == 0 && var_count == 0) && (var_tag != 0x0B || var_count > left() / 16)) return "a damaged NetCDF variable list";
  for (uint64_t i = 0; i < var_count && !short_header && var_tag == 0x0B; ++i) {
    name();
    const uint64_t rank = count();
    if (rank > left() / 4) return "a damaged NetCDF variable";
    double values = 1;
    for (uint64_t r = 0; r < rank; ++r) {
      const uint64_t d = count();
      if (d >= dims.size()) return "a NetCDF variable of an unknown dimension";
      values *= static_cast<double>(std::max<uint64_t>(dims[d], 1));
    }
    if (std::string e = attributes(); !e.empty()) return e;
    const uint64_t size = type_size(get(4));
    count();  // vsize
    get(offsets64 ? 8 : 4);  // begin
    if (size == 0) return "a NetCDF variable of an unknown type";
    if (values * static_cast<double>(size) > static_cast<double>(limit)) return "a NetCDF variable larger than the file could hold";
  }
  return short_header ? "a NetCDF header cut short" : "";
}

constexpr int64_t kMaxSteps = 100000;  // as a time series holds at most (storage::kMaxTimeSteps)

struct Block {
  int64_t id = 0;
  std::string type;
  int64_t count = 0, nodes = 0;
  int vtk_type = 0, corners = 0;
};

class ExodusReader final : public FormatReader {
 public:
  ExodusReader(std::filesystem::path path, const ReadLimits& limits) : path_(std::move(path)), name_(path_.filename().string()), limits_(limits) {}
  ~ExodusReader() override {
    if (exoid_ >= 0) {
      std::lock_guard<std::mutex> hold(library_lock());
      ex_close(exoid_);
    }
  }
  MeshHeader index(ReadStats& stats) override;
  void read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) override;
  bool read_cells(CellBatch& batch, size_t max_cells) override;
  void read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) override;
  void rewind_cells() override {
    block_ = 0;
    in_block_ = 0;
    runs_.clear();
  }
  FaceTags take_face_tags() override { return std::move(face_tags_); }

 private:
  [[noreturn]] void fail(const std::string& what) const { throw MeshError(name_ + ": " + what); }
  // Runs one library call under the lock; a negative status fails naming `what`.
  template <typename Call>
  void call(const std::string& what, Call&& c) const {
    std::lock_guard<std::mutex> hold(library_lock());
    if (c() < 0) fail("Exodus II: cannot read " + what);
  }
  std::vector<std::string> variable_names(ex_entity_type type);
  // Side sets as boundary face tags (read whole while indexing: they are boundary-sized).
  void read_side_sets(int64_t count, uint64_t file_bytes);

  // Fails when what the header declares could not come from a file of this size, compressed
  // as far as ReadLimits allows (a damaged header would otherwise drive reads of fill values).
  void check_declared_size(uint64_t declared_bytes, uint64_t file_bytes) const;

  std::filesystem::path path_;
  std::string name_;
  ReadLimits limits_;
  int exoid_ = -1;
  MeshHeader header_;
  int64_t nodes_ = 0;
  int step_ = 0;  // 1-based; 0: no time step (no values)
  std::vector<Block> blocks_;
  std::vector<Variable> nodal_, element_;
  std::vector<int> truth_;  // blocks × element variables: 1 where the variable is defined
  uint64_t vertices_given_ = 0;
  size_t block_ = 0;
  int64_t in_block_ = 0;
  struct Run {
    size_t block;
    int64_t first, count;  // 0-based within the block
  };
  std::vector<Run> runs_;  // the blocks' elements the last read_cells appended, in order
  std::vector<int64_t> connectivity_;
  std::vector<double> scratch_[3];
  std::vector<uint32_t> nodes_scratch_;
  FaceTags face_tags_;
};

std::vector<std::string> ExodusReader::variable_names(ex_entity_type type) {
  int count = 0;
  call("the variable count", [&] { return ex_get_variable_param(exoid_, type, &count); });
  if (count < 0 || count > 100000) fail("Exodus II: " + std::to_string(count) + " variables");
  std::vector<std::string> names(static_cast<size_t>(count));
  if (count == 0) return names;
  std::vector<std::vector<char>> storage(static_cast<size_t>(count), std::vector<char>(257, '\0'));
  std::vector<char*> pointers;
  for (auto& s : storage) pointers.push_back(s.data());
  call("the variable names", [&] { return ex_get_variable_names(exoid_, type, count, pointers.data()); });
  for (size_t i = 0; i < names.size(); ++i) {
    names[i] = std::string(storage[i].data(), strnlen(storage[i].data(), 256));
    while (!names[i].empty() && names[i].back() == ' ') names[i].pop_back();
    if (names[i].empty()) names[i] = (type == EX_NODAL ? "nodal" : "element") + std::to_string(i + 1);
  }
  return names;
}

MeshHeader ExodusReader::index(ReadStats& stats) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path_, ec)) fail("not a regular file");
  const uint64_t file_bytes = std::filesystem::file_size(path_, ec);
  if (const std::string problem = check_classic_header(path_, inflate_limit(limits_, file_bytes)); !problem.empty()) fail(problem);
  {
    std::lock_guard<std::mutex> hold(library_lock());
    ex_opts(0);  // errors come back as status codes, never printed or fatal
    int word = 8, io_word = 0;
    float version = 0;
    exoid_ = ex_open(path_.c_str(), EX_READ, &word, &io_word, &version);
  }
  if (exoid_ < 0) fail("not an Exodus II file (the Exodus library cannot open it)");
  call("its integer size", [&] { return ex_set_int64_status(exoid_, EX_ALL_INT64_API); });
  call("its name length", [&] { return ex_set_max_name_length(exoid_, 256); });
  ex_init_params init{};
  call("its header", [&] { return ex_get_init_ext(exoid_, &init); });
  if (init.num_dim != 3) fail("a " + std::to_string(init.num_dim) + "-dimensional Exodus II mesh; tetrascope reads 3D volumes");
  if (init.num_nodes < 0 || init.num_nodes >= std::numeric_limits<uint32_t>::max()) fail("Exodus II: " + std::to_string(init.num_nodes) + " nodes");
  if (init.num_elem_blk < 0 || init.num_elem_blk > 1000000) fail("Exodus II: " + std::to_string(init.num_elem_blk) + " element blocks");
  nodes_ = init.num_nodes;
  std::vector<int64_t> ids(static_cast<size_t>(init.num_elem_blk));
  if (!ids.empty()) call("the element block ids", [&] { return ex_get_ids(exoid_, EX_ELEM_BLOCK, ids.data()); });
  uint64_t cells = 0;
  for (int64_t id : ids) {
    Block b;
    b.id = id;
    char type[MAX_STR_LENGTH + 1] = {};
    int64_t edges = 0, faces = 0, attributes = 0;
    call("element block " + std::to_string(id), [&] { return ex_get_block(exoid_, EX_ELEM_BLOCK, id, type, &b.count, &b.nodes, &edges, &faces, &attributes); });
    b.type = std::string(type, strnlen(type, MAX_STR_LENGTH));
    auto [vtk, corners] = element_kind(b.type);
    if (corners < 0) fail("element block " + std::to_string(id) + " holds " + b.type + " elements (polyhedra), which are not read");
    if (b.count < 0 || b.nodes < 0 || b.nodes > 1000 || (corners > 0 && b.nodes < corners)) {
      fail("element block " + std::to_string(id) + " (" + b.type + ") has " + std::to_string(b.count) + " elements of " + std::to_string(b.nodes) + " nodes");
    }
    b.vtk_type = vtk;
    b.corners = corners;
    cells += static_cast<uint64_t>(b.count);
    blocks_.push_back(b);
  }
  uint64_t declared = static_cast<uint64_t>(nodes_) * 3 * 4;
  for (const Block& b : blocks_) declared += static_cast<uint64_t>(b.count) * static_cast<uint64_t>(b.nodes) * 4;
  check_declared_size(declared, file_bytes);
  const int64_t steps = ex_inquire_int(exoid_, EX_INQ_TIME);
  nodal_ = join_components(variable_names(EX_NODAL), true);
  const std::vector<std::string> element_names = variable_names(EX_ELEM_BLOCK);
  const size_t element_variables = element_names.size();
  element_ = join_components(element_names, false);  // element tensors stay six scalars (cell data is averaged per component)
  std::string when = "no time step";
  if (limits_.time_step >= 0 && limits_.time_step >= steps) {
    fail("Exodus II: time step " + std::to_string(limits_.time_step) + " asked for, the file holds " +
         (steps > 0 ? std::to_string(steps) + " (0.." + std::to_string(steps - 1) + ")" : std::string("none")));
  }
  if (steps > 0) {
    if (steps > kMaxSteps) fail("Exodus II: " + std::to_string(steps) + " time steps, more than " + std::to_string(kMaxSteps) + " are not read");
    std::vector<double> times(static_cast<size_t>(steps));
    call("the time values", [&] { return ex_get_all_times(exoid_, times.data()); });
    if (steps > 1) header_.step_times = times;
    step_ = limits_.time_step >= 0 ? static_cast<int>(limits_.time_step) + 1 : static_cast<int>(steps);
    char text[80];
    std::snprintf(text, sizeof text, "step %d of %lld, t = %g", step_, static_cast<long long>(steps), times[static_cast<size_t>(step_ - 1)]);
    when = text;
    if (steps > 1 && limits_.time_step < 0) stats.warnings.push_back(std::to_string(steps) + " time steps: the last (" + when + ") is read (preprocess --all-steps reads them all)");
  } else if (!nodal_.empty() || !element_.empty()) {
    stats.warnings.push_back("variables without a time step: none is read");
    nodal_.clear();
    element_.clear();
  }
  truth_.assign(element_.empty() ? 0 : blocks_.size() * element_variables, 1);
  if (!truth_.empty()) {
    call("the element variable table", [&] { return ex_get_truth_table(exoid_, EX_ELEM_BLOCK, static_cast<int>(blocks_.size()), static_cast<int>(element_variables), truth_.data()); });
  }
  read_side_sets(init.num_side_sets, file_bytes);
  header_.format = MeshFormat::kExodus;
  header_.description = "Exodus II, " + std::to_string(blocks_.size()) + " element blocks, " + when;
  header_.vertex_count = static_cast<uint64_t>(nodes_);
  header_.cell_count = cells;
  for (const Variable& v : nodal_) header_.attributes.push_back({v.name, static_cast<uint32_t>(v.indices.size()), v.tensor ? AttributeKind::kTensor : AttributeKind::kValue});
  for (const Variable& v : element_) header_.cell_attributes.push_back({v.name, static_cast<uint32_t>(v.indices.size())});
  return header_;
}

// Each side's nodes as the library gives them (in the element's face order), a triangle's
// three corners or a quad's four cut by the diagonal through its smallest node, as hexahedra
// are; named by the side set's name, else "side set ID". Sides of other node counts are
// left out.
void ExodusReader::read_side_sets(int64_t count, uint64_t file_bytes) {
  if (count <= 0) return;
  if (count > 100000) fail("Exodus II: " + std::to_string(count) + " side sets");
  std::vector<int64_t> ids(static_cast<size_t>(count));
  call("the side set ids", [&] { return ex_get_ids(exoid_, EX_SIDE_SET, ids.data()); });
  std::vector<std::vector<char>> storage(ids.size(), std::vector<char>(257, '\0'));
  std::vector<char*> pointers;
  for (auto& text : storage) pointers.push_back(text.data());
  call("the side set names", [&] { return ex_get_names(exoid_, EX_SIDE_SET, pointers.data()); });
  std::vector<int64_t> counts, nodes;
  for (size_t s = 0; s < ids.size(); ++s) {
    const int64_t id = ids[s];
    int64_t sides = 0, factors = 0, length = 0;
    call("side set " + std::to_string(id), [&] { return ex_get_set_param(exoid_, EX_SIDE_SET, id, &sides, &factors); });
    if (sides <= 0) continue;
    call("the nodes of side set " + std::to_string(id), [&] { return ex_get_side_set_node_list_len(exoid_, id, &length); });
    if (length < 0 || length > 27 * sides) fail("Exodus II: side set " + std::to_string(id) + " has " + std::to_string(length) + " nodes for " + std::to_string(sides) + " sides");
    check_declared_size(static_cast<uint64_t>(sides + length) * 4, file_bytes);
    counts.assign(static_cast<size_t>(sides), 0);
    nodes.assign(static_cast<size_t>(length), 0);
    call("the nodes of side set " + std::to_string(id), [&] { return ex_get_side_set_node_list(exoid_, id, counts.data(), nodes.data()); });
    std::string name(storage[s].data(), strnlen(storage[s].data(), 256));
    while (!name.empty() && name.back() == ' ') name.pop_back();
    face_tags_.names.push_back(name.empty() ? "side set " + std::to_string(id) : name);
    const uint32_t tag = static_cast<uint32_t>(face_tags_.names.size() - 1);
    size_t at = 0;
    for (int64_t n : counts) {
      if (n < 0 || static_cast<size_t>(n) > nodes.size() - at) fail("Exodus II: side set " + std::to_string(id) + "'s node counts pass its node list");
      const int corners = n == 3 || n == 6 || n == 7 ? 3 : n == 4 || n == 8 || n == 9 ? 4 : 0;
      uint32_t c[4] = {0, 0, 0, 0};
      for (int k = 0; k < corners; ++k) {
        const int64_t node = nodes[at + static_cast<size_t>(k)];
        if (node < 1 || node > nodes_) fail("Exodus II: side set " + std::to_string(id) + " names node " + std::to_string(node) + " of " + std::to_string(nodes_));
        c[k] = static_cast<uint32_t>(node - 1);
      }
      at += static_cast<size_t>(n);
      if (corners == 3) {
        face_tags_.add(tag, c[0], c[1], c[2]);
      } else if (corners == 4) {
        const int m = static_cast<int>(std::min_element(c, c + 4) - c);
        face_tags_.add(tag, c[m], c[(m + 1) % 4], c[(m + 2) % 4]);
        face_tags_.add(tag, c[m], c[(m + 2) % 4], c[(m + 3) % 4]);
      }
    }
  }
}

void ExodusReader::check_declared_size(uint64_t declared_bytes, uint64_t file_bytes) const {
  const uint64_t limit = inflate_limit(limits_, file_bytes);
  if (declared_bytes > limit) {
    fail("Exodus II: its header declares " + std::to_string(declared_bytes) + " bytes of coordinates and connectivity, more than " + std::to_string(limit) +
         " allowed for a file of " + std::to_string(file_bytes) + " bytes (raise --max-inflate-ratio if the file is genuine)");
  }
}

void ExodusReader::read_vertices(size_t count, float* xyz, std::span<float* const> attributes, ReadStats& stats) {
  const int64_t first = static_cast<int64_t>(vertices_given_) + 1;
  for (auto& s : scratch_) s.resize(count);
  call("the coordinates", [&] { return ex_get_partial_coord(exoid_, first, static_cast<int64_t>(count), scratch_[0].data(), scratch_[1].data(), scratch_[2].data()); });
  for (size_t i = 0; i < count; ++i)
    for (int k = 0; k < 3; ++k) {
      if (!to_stored_float(scratch_[k][i], xyz[3 * i + static_cast<size_t>(k)])) {
        fail("node " + std::to_string(vertices_given_ + i + 1) + ": point coordinate " + std::to_string(scratch_[k][i]) + " is not a finite 32-bit float");
      }
    }
  for (size_t a = 0; a < nodal_.size(); ++a) {
    const size_t c = nodal_[a].indices.size();
    for (size_t k = 0; k < c; ++k) {
      call("nodal variable '" + nodal_[a].name + "'", [&] { return ex_get_partial_var(exoid_, step_, EX_NODAL, nodal_[a].indices[k], 1, first, static_cast<int64_t>(count), scratch_[0].data()); });
      for (size_t i = 0; i < count; ++i) {
        if (to_stored_float(scratch_[0][i], attributes[a][i * c + k])) continue;
        if (nodal_[a].tensor)  // a tensor's eigen-analysis needs every component
          fail("nodal tensor '" + nodal_[a].name + "': node " + std::to_string(vertices_given_ + i + 1) + ", component " + kTensorComponentNames[k] + ": " +
               std::to_string(scratch_[0][i]) + " is not a finite 32-bit float");
        ++stats.nonfinite_attribute_values;
      }
    }
  }
  vertices_given_ += count;
}

bool ExodusReader::read_cells(CellBatch& batch, size_t max_cells) {
  runs_.clear();
  size_t added = 0;
  while (added < max_cells && block_ < blocks_.size()) {
    const Block& b = blocks_[block_];
    const int64_t n = std::min<int64_t>(b.count - in_block_, static_cast<int64_t>(max_cells - added));
    if (n <= 0) {
      ++block_;
      in_block_ = 0;
      continue;
    }
    connectivity_.resize(static_cast<size_t>(n * b.nodes));
    if (b.nodes > 0) {
      call("the connectivity of element block " + std::to_string(b.id), [&] { return ex_get_partial_conn(exoid_, EX_ELEM_BLOCK, b.id, in_block_ + 1, n, connectivity_.data(), nullptr, nullptr); });
    }
    const size_t used = b.corners > 0 ? static_cast<size_t>(b.corners) : std::min<size_t>(1, static_cast<size_t>(b.nodes));
    for (int64_t e = 0; e < n; ++e) {
      nodes_scratch_.resize(used);
      for (size_t k = 0; k < used; ++k) {
        const int64_t node = connectivity_[static_cast<size_t>(e * b.nodes) + k];
        if (node < 1 || node > nodes_) {
          fail("element " + std::to_string(in_block_ + e + 1) + " of block " + std::to_string(b.id) + ": node " + std::to_string(node) + " out of range (the mesh has " + std::to_string(nodes_) + " nodes)");
        }
        nodes_scratch_[k] = static_cast<uint32_t>(node - 1);
      }
      if (b.corners > 0 && b.nodes > b.corners) ++batch.reduced;
      batch.push(static_cast<uint8_t>(b.vtk_type), nodes_scratch_);
    }
    runs_.push_back({block_, in_block_, n});
    in_block_ += n;
    added += static_cast<size_t>(n);
  }
  return added > 0;
}

void ExodusReader::read_cell_values(size_t count, std::span<float* const> values, ReadStats& stats) {
  const size_t per_block = element_.empty() ? 0 : truth_.size() / std::max<size_t>(blocks_.size(), 1);
  size_t at = 0;
  for (const Run& run : runs_) {
    const Block& b = blocks_[run.block];
    scratch_[0].resize(static_cast<size_t>(run.count));
    for (size_t a = 0; a < element_.size(); ++a) {
      const size_t c = element_[a].indices.size();
      for (size_t k = 0; k < c; ++k) {
        const int index = element_[a].indices[k];
        const bool defined = truth_[run.block * per_block + static_cast<size_t>(index - 1)] != 0;
        if (defined) {
          call("element variable '" + element_[a].name + "' of block " + std::to_string(b.id),
               [&] { return ex_get_partial_var(exoid_, step_, EX_ELEM_BLOCK, index, b.id, run.first + 1, run.count, scratch_[0].data()); });
        }
        for (int64_t e = 0; e < run.count; ++e) {
          float& out = values[a][(at + static_cast<size_t>(e)) * c + k];
          if (!defined) out = std::numeric_limits<float>::quiet_NaN();  // a block the variable leaves out
          else if (!to_stored_float(scratch_[0][static_cast<size_t>(e)], out)) ++stats.nonfinite_attribute_values;
        }
      }
    }
    at += static_cast<size_t>(run.count);
  }
  if (at != count) fail("Exodus II: element values out of step with the elements");
}

}  // namespace

}  // namespace tetrascope::storage::detail

// The module's one entry point (storage/src/reader_modules.cpp loads it with dlopen): a new
// reader, or null with `error` set when the reader cannot be made.
extern "C" __attribute__((visibility("default"))) tetrascope::storage::detail::FormatReader* tetrascope_make_exodus_reader(
    const char* path, const tetrascope::storage::ReadLimits* limits, std::string* error) {
  try {
    return new tetrascope::storage::detail::ExodusReader(path, *limits);
  } catch (const std::exception& e) {
    *error = e.what();
    return nullptr;
  }
}
