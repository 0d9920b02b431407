#include "fixture_writers.h"

#include <zlib.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {

void CellMesh::add_cell(uint8_t type, std::initializer_list<uint32_t> nodes) {
  types.push_back(type);
  connectivity.insert(connectivity.end(), nodes.begin(), nodes.end());
  offsets.push_back(static_cast<uint32_t>(connectivity.size()));
}

CellMesh from_tets(const storage::TetMesh& mesh) {
  CellMesh c;
  c.x = mesh.x;
  c.y = mesh.y;
  c.z = mesh.z;
  c.attributes = mesh.attributes;
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    c.add_cell(10, {mesh.tets[4 * t], mesh.tets[4 * t + 1], mesh.tets[4 * t + 2], mesh.tets[4 * t + 3]});
  }
  return c;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string mesh_read_error(const std::filesystem::path& path) {
  try {
    storage::load_mesh(path);
    return "";
  } catch (const storage::MeshError& e) {
    return e.what();
  }
}

void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path.string());
}

namespace {

std::string fmt(double v) {
  char b[40];
  std::snprintf(b, sizeof b, "%.9g", v);
  return b;
}

template <typename T>
void append(std::string& out, T value, bool big_endian) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  if (big_endian == (std::endian::native == std::endian::little)) std::reverse(b, b + sizeof(T));
  out.append(b, sizeof(T));
}

std::string base64(const std::string& bytes) {
  static const char* letters = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    uint32_t v = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    for (int k = 3; k >= 0; --k) out += letters[(v >> (6 * k)) & 63];
  }
  if (i < bytes.size()) {
    uint32_t v = uint8_t(bytes[i]) << 16;
    if (i + 1 < bytes.size()) v |= uint8_t(bytes[i + 1]) << 8;
    out += letters[(v >> 18) & 63];
    out += letters[(v >> 12) & 63];
    out += i + 1 < bytes.size() ? letters[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

}  // namespace

void write_vtk_legacy(const std::filesystem::path& path, const CellMesh& m, const VtkOptions& o) {
  std::string out = "# vtk DataFile Version " + std::string(o.version5 ? "5.1" : "3.0") + "\nfixture\n" +
                    (o.binary ? "BINARY" : "ASCII") + "\nDATASET UNSTRUCTURED_GRID\n";
  const size_t n = m.x.size(), cells = m.cell_count();
  auto values = [&](const std::vector<double>& v) {
    if (o.binary) {
      for (double d : v) o.doubles ? append(out, d, true) : append(out, static_cast<float>(d), true);
      out += "\n";
    } else {
      for (size_t i = 0; i < v.size(); ++i) out += fmt(v[i]) + ((i % 9 == 8) ? "\n" : " ");
      out += "\n";
    }
  };
  auto ints = [&](const std::vector<int64_t>& v, bool wide) {
    if (o.binary) {
      for (int64_t d : v) wide ? append(out, d, true) : append(out, static_cast<int32_t>(d), true);
      out += "\n";
    } else {
      for (size_t i = 0; i < v.size(); ++i) out += std::to_string(v[i]) + ((i % 12 == 11) ? "\n" : " ");
      out += "\n";
    }
  };
  const char* real = o.doubles ? "double" : "float";
  out += "POINTS " + std::to_string(n) + " " + real + "\n";
  std::vector<double> xyz;
  for (size_t i = 0; i < n; ++i) xyz.insert(xyz.end(), {m.x[i], m.y[i], m.z[i]});
  values(xyz);
  if (o.version5) {
    out += "CELLS " + std::to_string(cells + 1) + " " + std::to_string(m.connectivity.size()) + "\n";
    out += "OFFSETS vtktypeint64\n";
    ints(std::vector<int64_t>(m.offsets.begin(), m.offsets.end()), true);
    out += "CONNECTIVITY vtktypeint64\n";
    ints(std::vector<int64_t>(m.connectivity.begin(), m.connectivity.end()), true);
  } else {
    std::vector<int64_t> list;
    for (size_t c = 0; c < cells; ++c) {
      list.push_back(m.offsets[c + 1] - m.offsets[c]);
      for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) list.push_back(m.connectivity[k]);
    }
    out += "CELLS " + std::to_string(cells) + " " + std::to_string(list.size()) + "\n";
    ints(list, false);
  }
  out += "CELL_TYPES " + std::to_string(cells) + "\n";
  ints(std::vector<int64_t>(m.types.begin(), m.types.end()), false);
  auto section = [&](const char* keyword, const std::vector<storage::Attribute>& arrays, size_t tuples) {
    if (arrays.empty()) return;
    out += std::string(keyword) + " " + std::to_string(tuples) + "\n";
    if (o.field) out += "FIELD FieldData " + std::to_string(arrays.size()) + "\n";
    for (const auto& a : arrays) {
      if (o.field) out += a.info.name + " " + std::to_string(a.info.components) + " " + std::to_string(tuples) + " " + real + "\n";
      else if (a.info.components == 3) out += "VECTORS " + a.info.name + " " + real + "\n";
      else if (a.info.kind == storage::AttributeKind::kTensor) {
        out += a.info.components == 9 ? "TENSORS " : "TENSORS6 ";
        out += a.info.name;
        out += " ";
        out += real;
        out += "\n";
      }
      else out += "SCALARS " + a.info.name + " " + real + " " + std::to_string(a.info.components) + "\nLOOKUP_TABLE default\n";
      values(std::vector<double>(a.values.begin(), a.values.end()));
    }
  };
  section("CELL_DATA", m.cell_attributes, cells);
  section("POINT_DATA", m.attributes, n);
  write_file(path, out);
}

namespace {

struct VtuArray {
  std::string name;
  std::string type;   // VTK XML type name
  uint32_t components;
  std::string raw;    // little-endian bytes
  std::string ascii;  // text values
};

// `ascii`: also the text form (formatting millions of values is what makes a large fixture slow)
VtuArray real_array(const std::string& name, uint32_t components, const std::vector<float>& v, bool doubles, bool ascii) {
  VtuArray a{name, doubles ? "Float64" : "Float32", components, "", ""};
  for (float f : v) {
    doubles ? append(a.raw, static_cast<double>(f), false) : append(a.raw, f, false);
    if (ascii) a.ascii += fmt(f) + " ";
  }
  return a;
}

template <typename T>
VtuArray int_array(const std::string& name, const std::string& type, const std::vector<T>& v, bool ascii) {
  VtuArray a{name, type, 1, "", ""};
  for (T x : v) {
    append(a.raw, x, false);
    if (ascii) a.ascii += std::to_string(static_cast<int64_t>(x)) + " ";
  }
  return a;
}

std::string header_items(const std::vector<uint64_t>& items, bool uint64) {
  std::string s;
  for (uint64_t v : items) uint64 ? append(s, v, false) : append(s, static_cast<uint32_t>(v), false);
  return s;
}

// The bytes VTK stores for one binary array: size header + data, or zlib header + blocks.
std::pair<std::string, std::string> encode_binary(const std::string& raw, const VtuOptions& o) {
  if (!o.zlib) return {header_items({raw.size()}, o.header_uint64), raw};
  std::vector<uint64_t> sizes;
  std::string blocks;
  size_t count = (raw.size() + o.block_size - 1) / o.block_size;
  for (size_t b = 0; b < count; ++b) {
    size_t len = std::min(o.block_size, raw.size() - b * o.block_size);
    uLongf out_len = compressBound(static_cast<uLong>(len));
    std::string z(out_len, '\0');
    compress2(reinterpret_cast<Bytef*>(z.data()), &out_len, reinterpret_cast<const Bytef*>(raw.data() + b * o.block_size), static_cast<uLong>(len), 6);
    z.resize(out_len);
    sizes.push_back(out_len);
    blocks += z;
  }
  size_t last = count == 0 ? 0 : raw.size() - (count - 1) * o.block_size;
  std::vector<uint64_t> header{count, o.block_size, last};
  header.insert(header.end(), sizes.begin(), sizes.end());
  return {header_items(header, o.header_uint64), blocks};
}

}  // namespace

void write_vtu(const std::filesystem::path& path, const CellMesh& m, const VtuOptions& o) {
  const bool ascii = o.encoding == VtuEncoding::kAscii;
  std::vector<VtuArray> point_data, cell_data;
  for (const auto& a : m.attributes) point_data.push_back(real_array(a.info.name, a.info.components, a.values, o.doubles, ascii));
  for (const auto& a : m.cell_attributes) cell_data.push_back(real_array(a.info.name, a.info.components, a.values, o.doubles, ascii));
  std::vector<float> xyz;
  for (size_t i = 0; i < m.x.size(); ++i) xyz.insert(xyz.end(), {m.x[i], m.y[i], m.z[i]});
  VtuArray points = real_array("Points", 3, xyz, o.doubles, ascii);
  std::vector<int64_t> connectivity(m.connectivity.begin(), m.connectivity.end());
  std::vector<int64_t> offsets(m.offsets.begin() + 1, m.offsets.end());
  VtuArray cells[3] = {int_array("connectivity", "Int64", connectivity, ascii), int_array("offsets", "Int64", offsets, ascii),
                       int_array("types", "UInt8", m.types, ascii)};
  std::string appended;
  auto element = [&](const VtuArray& a) {
    std::string head = "<DataArray type=\"" + a.type + "\" Name=\"" + a.name + "\" NumberOfComponents=\"" + std::to_string(a.components) + "\"";
    if (o.encoding == VtuEncoding::kAscii) return head + " format=\"ascii\">\n" + a.ascii + "\n</DataArray>\n";
    auto [header, data] = encode_binary(a.raw, o);
    std::string encoded;
    if (o.encoding == VtuEncoding::kAppendedRaw) {
      encoded = header + data;
    } else {
      bool separate = o.separate_header || o.zlib;  // VTK encodes a compression header on its own
      encoded = separate ? base64(header) + base64(data) : base64(header + data);
    }
    if (o.encoding == VtuEncoding::kInlineBase64) return head + " format=\"binary\">\n" + encoded + "\n</DataArray>\n";
    std::string tag = head + " format=\"appended\" offset=\"" + std::to_string(appended.size()) + "\"/>\n";
    appended += encoded;
    return tag;
  };
  std::string out = "<?xml version=\"1.0\"?>\n<!-- fixture -->\n<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"" +
                    std::string(o.header_uint64 ? "UInt64" : "UInt32") + "\"" + (o.zlib ? " compressor=\"vtkZLibDataCompressor\"" : "") + ">\n";
  out += "<UnstructuredGrid>\n<Piece NumberOfPoints=\"" + std::to_string(m.x.size()) + "\" NumberOfCells=\"" + std::to_string(m.cell_count()) + "\">\n";
  out += "<PointData>\n";
  for (const auto& a : point_data) out += element(a);
  out += "</PointData>\n";
  if (!cell_data.empty()) {
    out += "<CellData>\n";
    for (const auto& a : cell_data) out += element(a);
    out += "</CellData>\n";
  }
  out += "<Points>\n" + element(points) + "</Points>\n<Cells>\n";
  for (const auto& a : cells) out += element(a);
  out += "</Cells>\n</Piece>\n</UnstructuredGrid>\n";
  if (o.encoding == VtuEncoding::kAppendedRaw || o.encoding == VtuEncoding::kAppendedBase64) {
    out += std::string("<AppendedData encoding=\"") + (o.encoding == VtuEncoding::kAppendedRaw ? "raw" : "base64") + "\">\n_" + appended + "\n</AppendedData>\n";
  }
  out += "</VTKFile>\n";
  write_file(path, out);
}

namespace {
int gmsh_type(uint8_t vtk) {
  switch (vtk) {
    case 10: return 4;
    case 12: return 5;
    case 13: return 6;
    case 14: return 7;
    case 5: return 2;
    case 9: return 3;
    default: throw std::runtime_error("write_gmsh: unsupported cell type " + std::to_string(vtk));
  }
}
}  // namespace

// MSH 4.1 $Entities: per run of surface cells a surface entity (tag: the run's index + 1) with
// the run's physical tag (none for 0), and one volume; `physical_of` gives -1 for a volume cell.
template <typename Physical>
void write_gmsh_entities(std::string& out, const std::vector<std::pair<size_t, size_t>>& runs, Physical physical_of, bool bin) {
  std::vector<std::pair<int32_t, int32_t>> surfaces;  // entity, physical
  for (size_t r = 0; r < runs.size(); ++r)
    if (physical_of(runs[r].first) >= 0) surfaces.push_back({int32_t(r + 1), physical_of(runs[r].first)});
  auto entity = [&](int32_t tag, int32_t physical, bool bounded) {
    if (bin) {
      append(out, tag, false);
      for (int k = 0; k < 6; ++k) append(out, double(k < 3 ? 0 : 1), false);
      append(out, uint64_t(physical > 0 ? 1 : 0), false);
      if (physical > 0) append(out, physical, false);
      if (bounded) append(out, uint64_t{0}, false);
    } else {
      out += std::to_string(tag) + " 0 0 0 1 1 1 " + (physical > 0 ? "1 " + std::to_string(physical) : std::string("0")) + " 0\n";
    }
  };
  out += "$Entities\n";
  if (bin) {
    for (uint64_t v : {uint64_t{0}, uint64_t{0}, uint64_t(surfaces.size()), uint64_t{1}}) append(out, v, false);
  } else {
    out += "0 0 " + std::to_string(surfaces.size()) + " 1\n";
  }
  for (const auto& [tag, physical] : surfaces) entity(tag, physical, true);
  entity(1, 0, true);
  out += (bin ? "\n" : "") + std::string("$EndEntities\n");
}

TaggedCube tagged_cube() {
  TaggedCube cube;
  CellMesh& m = cube.mesh;
  auto node = [](int i, int j, int k) { return static_cast<uint32_t>(i + 3 * j + 9 * k); };
  for (int k = 0; k < 3; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) {
        m.x.push_back(0.5f * float(i));
        m.y.push_back(0.5f * float(j));
        m.z.push_back(0.5f * float(k));
      }
  std::vector<int32_t>& physical = cube.gmsh.physical;
  // the quads of the plane axis = level (in half steps), corners in cyclic order
  auto plane = [&](int axis, int level, int32_t tag, bool triangles) {
    for (int u = 0; u < 2; ++u)
      for (int w = 0; w < 2; ++w) {
        uint32_t q[4];
        for (int c = 0; c < 4; ++c) {
          int at[3];
          at[axis] = level;
          at[(axis + 1) % 3] = u + (c == 1 || c == 2);
          at[(axis + 2) % 3] = w + (c >= 2);
          q[c] = node(at[0], at[1], at[2]);
        }
        if (!triangles) {
          m.add_cell(9, {q[0], q[1], q[2], q[3]});
          physical.push_back(tag);
          continue;
        }
        int s = 0;  // the diagonal through the smallest id
        for (int c = 1; c < 4; ++c)
          if (q[c] < q[s]) s = c;
        m.add_cell(5, {q[s], q[(s + 1) % 4], q[(s + 2) % 4]});
        m.add_cell(5, {q[s], q[(s + 2) % 4], q[(s + 3) % 4]});
        physical.insert(physical.end(), {tag, tag});
      }
  };
  plane(0, 0, 1, false);
  plane(0, 2, 2, false);
  plane(1, 2, 3, false);
  plane(2, 0, 3, false);
  plane(2, 2, 7, true);
  plane(1, 0, 0, false);
  plane(0, 1, 4, false);
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 2; ++j)
      for (int i = 0; i < 2; ++i) {
        m.add_cell(12, {node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k), node(i, j, k + 1), node(i + 1, j, k + 1),
                        node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)});
        physical.push_back(10);
      }
  cube.gmsh.surface_names = {{1, "inlet"}, {2, "outlet"}, {3, "walls"}, {4, "mid plane"}};
  return cube;
}

// $Nodes of write_gmsh: 2.2 one list; 4.1 two entity blocks (to exercise block handling).
void write_gmsh_nodes(std::string& out, const CellMesh& m, const GmshOptions& o) {
  const bool bin = o.binary;
  const size_t n = m.x.size();
  auto tag = [&](size_t i) { return static_cast<uint64_t>(o.first_tag) + i * o.tag_step; };
  out += "$Nodes\n";
  if (!o.version4) {
    out += std::to_string(n) + "\n";
    for (size_t i = 0; i < n; ++i) {
      if (bin) {
        append(out, static_cast<int32_t>(tag(i)), false);
        for (double v : {double(m.x[i]), double(m.y[i]), double(m.z[i])}) append(out, v, false);
      } else {
        out += std::to_string(tag(i)) + " " + fmt(m.x[i]) + " " + fmt(m.y[i]) + " " + fmt(m.z[i]) + "\n";
      }
    }
  } else {
    // two entity blocks to exercise block handling
    size_t half = n / 2;
    size_t ranges[2][2] = {{0, half}, {half, n}};
    if (bin) {
      for (uint64_t v : {uint64_t{2}, uint64_t{n}, tag(0), tag(n - 1)}) append(out, v, false);
    } else {
      out += "2 " + std::to_string(n) + " " + std::to_string(tag(0)) + " " + std::to_string(tag(n - 1)) + "\n";
    }
    for (auto& r : ranges) {
      uint64_t count = r[1] - r[0];
      if (bin) {
        append(out, int32_t{3}, false);
        append(out, int32_t{1}, false);
        append(out, int32_t{0}, false);
        append(out, count, false);
        for (size_t i = r[0]; i < r[1]; ++i) append(out, tag(i), false);
        for (size_t i = r[0]; i < r[1]; ++i) for (double v : {double(m.x[i]), double(m.y[i]), double(m.z[i])}) append(out, v, false);
      } else {
        out += "3 1 0 " + std::to_string(count) + "\n";
        for (size_t i = r[0]; i < r[1]; ++i) out += std::to_string(tag(i)) + "\n";
        for (size_t i = r[0]; i < r[1]; ++i) out += fmt(m.x[i]) + " " + fmt(m.y[i]) + " " + fmt(m.z[i]) + "\n";
      }
    }
  }
}

void write_gmsh(const std::filesystem::path& path, const CellMesh& m, const GmshOptions& o) {
  const bool bin = o.binary;
  std::string out = "$MeshFormat\n" + std::string(o.version4 ? "4.1" : "2.2") + (bin ? " 1 8\n" : " 0 8\n");
  if (bin) {
    append(out, int32_t{1}, false);
    out += "\n";
  }
  out += "$EndMeshFormat\n";
  if (!o.surface_names.empty()) {
    out += "$PhysicalNames\n" + std::to_string(o.surface_names.size()) + "\n";
    for (const auto& [physical, name] : o.surface_names) out += "2 " + std::to_string(physical) + " \"" + name + "\"\n";
    out += "$EndPhysicalNames\n";
  }
  const size_t n = m.x.size(), cells = m.cell_count();
  auto physical_of = [&](size_t c) { return o.physical.empty() ? int32_t{o.version4 ? 0 : 1} : o.physical[c]; };
  auto surface = [&](size_t c) { return m.types[c] == 5 || m.types[c] == 9; };
  // 4.1: one block per run of equal types and physical tags, a surface entity of its own each
  std::vector<std::pair<size_t, size_t>> runs;
  for (size_t c = 0; c < cells; ++c) {
    if (runs.empty() || m.types[runs.back().first] != m.types[c] || physical_of(runs.back().first) != physical_of(c)) runs.push_back({c, c});
    runs.back().second = c + 1;
  }
  if (o.version4 && !o.physical.empty()) write_gmsh_entities(out, runs, [&](size_t c) { return surface(c) ? physical_of(c) : -1; }, bin);
  auto tag = [&](size_t i) { return static_cast<uint64_t>(o.first_tag) + i * o.tag_step; };
  write_gmsh_nodes(out, m, o);
  out += (bin ? "\n" : "") + std::string("$EndNodes\n$Elements\n");
  if (!o.version4) {
    out += std::to_string(cells) + "\n";
    for (size_t c = 0; c < cells; ++c) {
      int type = gmsh_type(m.types[c]);
      if (bin) {  // one block per element keeps the writer simple and exercises block headers
        for (int32_t v : {int32_t(type), int32_t{1}, int32_t{2}}) append(out, v, false);
        for (int32_t v : {int32_t(c + 1), physical_of(c), int32_t{1}}) append(out, v, false);
        for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) append(out, static_cast<int32_t>(tag(m.connectivity[k])), false);
      } else {
        out += std::to_string(c + 1) + " " + std::to_string(type) + " 2 " + std::to_string(physical_of(c)) + " 1";
        for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) out += " " + std::to_string(tag(m.connectivity[k]));
        out += "\n";
      }
    }
  } else {
    if (bin) {
      for (uint64_t v : {uint64_t(runs.size()), uint64_t(cells), uint64_t{1}, uint64_t(cells)}) append(out, v, false);
    } else {
      out += std::to_string(runs.size()) + " " + std::to_string(cells) + " 1 " + std::to_string(cells) + "\n";
    }
    for (size_t r = 0; r < runs.size(); ++r) {
      const auto [begin, end] = runs[r];
      int type = gmsh_type(m.types[begin]);
      int dim = surface(begin) ? 2 : 3;
      const int32_t entity = dim == 2 && !o.physical.empty() ? int32_t(r + 1) : 1;
      if (bin) {
        for (int32_t v : {int32_t(dim), entity, int32_t(type)}) append(out, v, false);
        append(out, uint64_t(end - begin), false);
      } else {
        out += std::to_string(dim) + " " + std::to_string(entity) + " " + std::to_string(type) + " " + std::to_string(end - begin) + "\n";
      }
      for (size_t c = begin; c < end; ++c) {
        if (bin) {
          append(out, uint64_t(c + 1), false);
          for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) append(out, tag(m.connectivity[k]), false);
        } else {
          out += std::to_string(c + 1);
          for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) out += " " + std::to_string(tag(m.connectivity[k]));
          out += "\n";
        }
      }
    }
  }
  out += (bin ? "\n" : "") + std::string("$EndElements\n");
  // $NodeData by node tag; $ElementData by element tag (c + 1), written in reverse order
  auto data = [&](const std::string& section, const storage::Attribute& a, size_t count, bool elements) {
    out += "$" + section + "\n1\n\"" + a.info.name + "\"\n1\n0.0\n3\n0\n" + std::to_string(a.info.components) + "\n" + std::to_string(count) + "\n";
    for (size_t j = 0; j < count; ++j) {
      const size_t i = elements ? count - 1 - j : j;
      const uint64_t t = elements ? i + 1 : tag(i);
      if (bin) {
        append(out, static_cast<int32_t>(t), false);
        for (uint32_t k = 0; k < a.info.components; ++k) append(out, double(a.values[i * a.info.components + k]), false);
      } else {
        out += std::to_string(t);
        for (uint32_t k = 0; k < a.info.components; ++k) out += " " + fmt(a.values[i * a.info.components + k]);
        out += "\n";
      }
    }
    out += (bin ? "\n" : "") + std::string("$End") + section + "\n";
  };
  for (const auto& a : m.attributes) data("NodeData", a, n, false);
  for (const auto& a : m.cell_attributes) data("ElementData", a, cells, true);
  write_file(path, out);
}

void write_tetgen(const std::filesystem::path& base, const CellMesh& m) {
  std::vector<const storage::Attribute*> scalars;
  for (const auto& a : m.attributes) if (a.info.components == 1) scalars.push_back(&a);
  std::string node = std::to_string(m.x.size()) + " 3 " + std::to_string(scalars.size()) + " 0\n# attributes:";
  for (auto* a : scalars) node += " " + a->info.name;
  node += "\n";
  for (size_t i = 0; i < m.x.size(); ++i) {
    node += std::to_string(i + 1) + " " + fmt(m.x[i]) + " " + fmt(m.y[i]) + " " + fmt(m.z[i]);
    for (auto* a : scalars) node += " " + fmt(a->values[i]);
    node += "\n";
  }
  std::string ele = std::to_string(m.cell_count()) + " 4 0\n";
  for (size_t c = 0; c < m.cell_count(); ++c) {
    if (m.types[c] != 10) throw std::runtime_error("write_tetgen: tets only");
    ele += std::to_string(c + 1);
    for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) ele += " " + std::to_string(m.connectivity[k] + 1);
    ele += "\n";
  }
  std::filesystem::path node_path = base, ele_path = base;
  write_file(node_path.replace_extension(".node"), node);
  write_file(ele_path.replace_extension(".ele"), ele);
}

void write_off(const std::filesystem::path& path, const CellMesh& m) {
  const storage::Attribute* scalar = nullptr;
  for (const auto& a : m.attributes) if (!scalar && a.info.components == 1) scalar = &a;
  std::string out = std::to_string(m.x.size()) + " " + std::to_string(m.cell_count()) + "\n";
  for (size_t i = 0; i < m.x.size(); ++i) {
    out += fmt(m.x[i]) + " " + fmt(m.y[i]) + " " + fmt(m.z[i]);
    if (scalar) out += " " + fmt(scalar->values[i]);
    out += "\n";
  }
  for (size_t c = 0; c < m.cell_count(); ++c) {
    if (m.types[c] != 10) throw std::runtime_error("write_off: tets only");
    for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) out += std::to_string(m.connectivity[k]) + (k + 1 < m.offsets[c + 1] ? " " : "\n");
  }
  write_file(path, out);
}

CellMesh one_tet_and_unused_points(size_t points) {
  CellMesh m;
  m.x.assign(points, 0.f);
  m.y.assign(points, 0.f);
  m.z.assign(points, 0.f);
  m.x[1] = m.y[2] = m.z[3] = 1.f;
  m.add_cell(10, {0, 1, 2, 3});
  return m;
}

std::string gmsh_data_section(const std::string& section, const std::string& name, int step_number, double time, uint32_t components,
                              const std::vector<std::pair<size_t, std::vector<double>>>& rows, bool binary) {
  std::string out;
  for (const std::string& line : {"$" + section, std::string("1"), "\"" + name + "\"", std::string("1"), fmt(time), std::string("3"), std::to_string(step_number),
                                  std::to_string(components), std::to_string(rows.size())}) {
    out.append(line).append("\n");
  }
  for (const auto& [tag, values] : rows) {
    if (binary) {
      const int32_t t = static_cast<int32_t>(tag);
      out.append(reinterpret_cast<const char*>(&t), sizeof t);
      for (double v : values) out.append(reinterpret_cast<const char*>(&v), sizeof v);
      continue;
    }
    out.append(std::to_string(tag));
    for (double v : values) out.append(" ").append(fmt(v));
    out.append("\n");
  }
  if (binary) out.append("\n");
  return out.append("$End").append(section).append("\n");
}

}  // namespace tetrascope::testing
