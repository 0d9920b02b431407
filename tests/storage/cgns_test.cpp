// CGNS files written by the CGNS mid-level library itself (HDF5, and ADF): a zone of hexahedra
// with a vertex and a cell-centred solution, a MIXED zone of every volume type and a surface
// element, two zones joined, several solutions with ZoneIterativeData (the last step read, or
// every step with preprocess --all-steps); `info` and `preprocess` on a CGNS file through the
// command line; boundary conditions (BC_t) as boundary face tags named by the BCs; and damaged
// or hostile files refused
// with a message that names the threat, never a crash.
#include <cgns_io.h>
#include <cgnslib.h>
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <map>
#include <random>
#include <set>

#include "cli_run.h"
#include "fixture_writers.h"
#include "mesh_checks.h"
#include "step_checks.h"
#include "test_paths.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/storage/mesh_info.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/time_steps.h"

namespace tetrascope::testing {
namespace {

using storage::MeshError;
using storage::TetMesh;

CGNS_ENUMT(ElementType_t) cgns_type(uint8_t vtk) {
  switch (vtk) {
    case 10: return CGNS_ENUMV(TETRA_4);
    case 12: return CGNS_ENUMV(HEXA_8);
    case 13: return CGNS_ENUMV(PENTA_6);
    case 14: return CGNS_ENUMV(PYRA_5);
    case 9: return CGNS_ENUMV(QUAD_4);
    default: return CGNS_ENUMV(TRI_3);
  }
}
bool volume_type(uint8_t vtk) { return vtk >= 10; }

struct CgnsOptions {
  bool adf = false;
  bool mixed = false;             // one MIXED section, else one section a type
  bool structured = false;        // the first zone written as a structured one
  std::vector<std::string> extra_cell_solutions{};  // written before the real one, values -1
  bool pointers = false;          // ZoneIterativeData naming the real cell solution for the last step, written first
  const char* pointers_name = "FlowSolutionPointers";  // or VTK's FlowSolutionCellPointers
  struct Bc {
    const char* name;
    CGNS_ENUMT(PointSetType_t) set;
    std::vector<cgsize_t> points;  // 1-based element or vertex numbers (a range: first and last)
    CGNS_ENUMT(GridLocation_t) location = CGNS_ENUMV(GridLocationNull);  // written when not null
  };
  std::vector<Bc> bcs{};  // of the first zone
};

void check(int status) {
  if (status != CG_OK) throw std::runtime_error(std::string("CGNS writer: ") + cg_get_error());
}

// The fields of `attributes` (NAME, or NAMEX NAMEY NAMEZ for a vector); cell values only for
// the cells in `order` that are volumes.
void write_fields(int fn, int B, int Z, int S, const std::vector<storage::Attribute>& attributes, const std::vector<size_t>* order, const CellMesh& m, double fill) {
  for (const storage::Attribute& a : attributes) {
    for (uint32_t k = 0; k < a.info.components; ++k) {
      std::vector<double> values;
      if (order) {
        for (size_t c : *order)
          if (volume_type(m.types[c])) values.push_back(fill != 0 ? fill : a.values[c * a.info.components + k]);
      } else {
        for (size_t v = 0; v < m.x.size(); ++v) values.push_back(a.values[v * a.info.components + k]);
      }
      // a tensor (6 components, stored xx yy zz xy yz xz) as SIDS names it: NAMEXX ... NAMEZZ
      static const char* const kTensorSuffix[6] = {"XX", "YY", "ZZ", "XY", "YZ", "XZ"};
      const std::string name = a.info.components == 1 ? a.info.name : a.info.kind == storage::AttributeKind::kTensor ? a.info.name + kTensorSuffix[k] : a.info.name + "XYZ"[k];
      int F = 0;
      check(cg_field_write(fn, B, Z, S, CGNS_ENUMV(RealDouble), name.c_str(), values.data(), &F));
    }
  }
}

// Sections of one zone, in the order the types first appear (or one MIXED section); returns
// the cells in file order.
std::vector<size_t> write_sections(int fn, int B, int Z, const CellMesh& m, const CgnsOptions& options) {
  std::vector<size_t> order;
  int S = 0;
  if (options.mixed) {
    std::vector<cgsize_t> elements, offsets{0};
    for (size_t c = 0; c < m.cell_count(); ++c) {
      order.push_back(c);
      elements.push_back(cgns_type(m.types[c]));
      for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) elements.push_back(static_cast<cgsize_t>(m.connectivity[k]) + 1);
      offsets.push_back(static_cast<cgsize_t>(elements.size()));
    }
    check(cg_poly_section_write(fn, B, Z, "Mixed", CGNS_ENUMV(MIXED), 1, static_cast<cgsize_t>(m.cell_count()), 0, elements.data(), offsets.data(), &S));
    return order;
  }
  std::vector<uint8_t> types;
  for (uint8_t t : m.types)
    if (std::find(types.begin(), types.end(), t) == types.end()) types.push_back(t);
  cgsize_t next = 1;
  for (uint8_t t : types) {
    std::vector<cgsize_t> elements;
    cgsize_t count = 0;
    for (size_t c = 0; c < m.cell_count(); ++c) {
      if (m.types[c] != t) continue;
      order.push_back(c);
      ++count;
      for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) elements.push_back(static_cast<cgsize_t>(m.connectivity[k]) + 1);
    }
    const std::string name = std::string("Section") + std::to_string(t);
    check(cg_section_write(fn, B, Z, name.c_str(), cgns_type(t), next, next + count - 1, 0, elements.data(), &S));
    next += count;
  }
  return order;
}

void write_pointers(int fn, int B, int Z, const std::vector<std::string>& steps, const char* array) {
  check(cg_biter_write(fn, B, "BaseIterativeData", static_cast<int>(steps.size())));
  check(cg_ziter_write(fn, B, Z, "ZoneIterativeData"));
  check(cg_goto(fn, B, "Zone_t", Z, "ZoneIterativeData_t", 1, "end"));
  std::string names;
  for (const std::string& s : steps) names += s + std::string(32 - s.size(), ' ');
  const cgsize_t dims[2] = {32, static_cast<cgsize_t>(steps.size())};
  check(cg_array_write(array, CGNS_ENUMV(Character), 2, dims, names.data()));
}

// Each mesh a zone of the first base: coordinates, its sections, a Vertex solution of its
// attributes and a CellCenter one of its cell attributes (volume cells only).
void write_cgns(const std::filesystem::path& path, const std::vector<CellMesh>& zones, const CgnsOptions& options = {}) {
  std::filesystem::remove(path);
  check(cg_set_file_type(options.adf ? CG_FILE_ADF : CG_FILE_HDF5));
  int fn = 0, B = 0;
  check(cg_open(path.c_str(), CG_MODE_WRITE, &fn));
  check(cg_base_write(fn, "Base", 3, 3, &B));
  for (size_t z = 0; z < zones.size(); ++z) {
    const CellMesh& m = zones[z];
    cgsize_t volumes = 0;
    for (uint8_t t : m.types) volumes += volume_type(t);
    int Z = 0, C = 0;
    const std::string name = "Zone" + std::to_string(z + 1);
    if (options.structured && z == 0) {
      const cgsize_t size[9] = {2, 2, 2, 1, 1, 1, 0, 0, 0};
      check(cg_zone_write(fn, B, name.c_str(), size, CGNS_ENUMV(Structured), &Z));
      continue;
    }
    const cgsize_t size[3] = {static_cast<cgsize_t>(m.x.size()), volumes, 0};
    check(cg_zone_write(fn, B, name.c_str(), size, CGNS_ENUMV(Unstructured), &Z));
    std::vector<double> x(m.x.begin(), m.x.end()), y(m.y.begin(), m.y.end()), zs(m.z.begin(), m.z.end());
    check(cg_coord_write(fn, B, Z, CGNS_ENUMV(RealDouble), "CoordinateX", x.data(), &C));
    check(cg_coord_write(fn, B, Z, CGNS_ENUMV(RealDouble), "CoordinateY", y.data(), &C));
    check(cg_coord_write(fn, B, Z, CGNS_ENUMV(RealDouble), "CoordinateZ", zs.data(), &C));
    const std::vector<size_t> order = write_sections(fn, B, Z, m, options);
    for (const CgnsOptions::Bc& bc : z == 0 ? options.bcs : std::vector<CgnsOptions::Bc>{}) {
      int BC = 0;
      check(cg_boco_write(fn, B, Z, bc.name, CGNS_ENUMV(BCWall), bc.set, static_cast<cgsize_t>(bc.points.size()), bc.points.data(), &BC));
      if (bc.location != CGNS_ENUMV(GridLocationNull)) check(cg_boco_gridlocation_write(fn, B, Z, BC, bc.location));
    }
    if (options.pointers) write_pointers(fn, B, Z, {"Early", "FlowSolutionCells"}, options.pointers_name);
    int S = 0;
    if (!m.attributes.empty()) {
      check(cg_sol_write(fn, B, Z, "FlowSolution", CGNS_ENUMV(Vertex), &S));
      write_fields(fn, B, Z, S, m.attributes, nullptr, m, 0);
    }
    if (options.pointers) {  // the real one first: only the pointer finds it
      check(cg_sol_write(fn, B, Z, "FlowSolutionCells", CGNS_ENUMV(CellCenter), &S));
      write_fields(fn, B, Z, S, m.cell_attributes, &order, m, 0);
    }
    for (const std::string& extra : options.extra_cell_solutions) {
      check(cg_sol_write(fn, B, Z, extra.c_str(), CGNS_ENUMV(CellCenter), &S));
      write_fields(fn, B, Z, S, m.cell_attributes, &order, m, -1);
    }
    if (!m.cell_attributes.empty() && !options.pointers) {
      check(cg_sol_write(fn, B, Z, "FlowSolutionCells", CGNS_ENUMV(CellCenter), &S));
      write_fields(fn, B, Z, S, m.cell_attributes, &order, m, 0);
    }
  }
  check(cg_close(fn));
}

// Cells and their closed-form volumes (0 for a surface cell), with point fields Density (z)
// and Velocity (x, -x, 2x) and cell fields Pressure (1.5c + 1; 1000 on a surface) and
// Momentum (p, -p, 2p).
struct Fixture {
  CellMesh mesh;
  std::vector<double> volumes;
};

void add_fields(Fixture& f) {
  CellMesh& m = f.mesh;
  storage::Attribute density{{"Density", 1}, {}}, velocity{{"Velocity", 3}, {}};
  for (size_t v = 0; v < m.x.size(); ++v) {
    density.values.push_back(m.z[v]);
    velocity.values.insert(velocity.values.end(), {m.x[v], -m.x[v], 2 * m.x[v]});
  }
  m.attributes = {density, velocity};
  storage::Attribute pressure{{"Pressure", 1}, {}}, momentum{{"Momentum", 3}, {}};
  for (size_t c = 0; c < m.cell_count(); ++c) {
    const float p = f.volumes[c] > 0 ? 1.5f * float(c) + 1 : 1000;
    pressure.values.push_back(p);
    momentum.values.insert(momentum.values.end(), {p, -p, 2 * p});
  }
  m.cell_attributes = {pressure, momentum};
}

// 2 × 2 hexahedra of volume 1 and the four quads under them; `shift` moves it along x.
Fixture hex_zone(float shift = 0) {
  Fixture f;
  CellMesh& m = f.mesh;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) m.x.push_back(float(i) + shift), m.y.push_back(float(j) * 0.5f), m.z.push_back(float(k) * 2.0f);
  auto at = [](int i, int j, int k) { return uint32_t(i + 3 * j + 9 * k); };
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      m.add_cell(12, {at(i, j, 0), at(i + 1, j, 0), at(i + 1, j + 1, 0), at(i, j + 1, 0), at(i, j, 1), at(i + 1, j, 1), at(i + 1, j + 1, 1), at(i, j + 1, 1)});
      f.volumes.push_back(1.0);
    }
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      m.add_cell(9, {at(i, j, 0), at(i, j + 1, 0), at(i + 1, j + 1, 0), at(i + 1, j, 0)});
      f.volumes.push_back(0);
    }
  add_fields(f);
  return f;
}

// The hexahedra, a quad inside the volume cells, a pyramid on top, a tet beside and a wedge
// apart: every volume type and a surface in one MIXED section.
Fixture mixed_zone() {
  Fixture f = hex_zone();
  CellMesh m;
  m.x = f.mesh.x, m.y = f.mesh.y, m.z = f.mesh.z;
  std::vector<double> volumes;
  auto at = [](int i, int j, int k) { return uint32_t(i + 3 * j + 9 * k); };
  for (size_t c = 0; c < 4; ++c) {
    std::vector<uint32_t> nodes(f.mesh.connectivity.begin() + f.mesh.offsets[c], f.mesh.connectivity.begin() + f.mesh.offsets[c + 1]);
    m.types.push_back(12);
    m.connectivity.insert(m.connectivity.end(), nodes.begin(), nodes.end());
    m.offsets.push_back(static_cast<uint32_t>(m.connectivity.size()));
    volumes.push_back(1.0);
    if (c == 1) {
      m.add_cell(9, {at(0, 0, 0), at(1, 0, 0), at(1, 1, 0), at(0, 1, 0)});
      volumes.push_back(0);
    }
  }
  const uint32_t apex = static_cast<uint32_t>(m.x.size());
  m.x.push_back(0.5f), m.y.push_back(0.25f), m.z.push_back(3.5f);
  m.add_cell(14, {at(0, 0, 1), at(1, 0, 1), at(1, 1, 1), at(0, 1, 1), apex});
  volumes.push_back(0.5 * 1.5 / 3);
  const uint32_t tip = static_cast<uint32_t>(m.x.size());
  m.x.push_back(3), m.y.push_back(0), m.z.push_back(0);
  m.add_cell(10, {at(2, 0, 0), at(2, 1, 0), at(2, 0, 1), tip});
  volumes.push_back(1.0 / 6);
  const uint32_t w = static_cast<uint32_t>(m.x.size());
  for (int k = 0; k < 2; ++k) {
    m.x.insert(m.x.end(), {10, 11, 10}), m.y.insert(m.y.end(), {0, 0, 1}), m.z.insert(m.z.end(), {float(k), float(k), float(k)});
  }
  m.add_cell(13, {w, w + 1, w + 2, w + 3, w + 4, w + 5});
  volumes.push_back(0.5);
  Fixture out{m, volumes};
  add_fields(out);
  return out;
}

double tet_volume(const TetMesh& mesh, size_t t) {
  const uint32_t* v = &mesh.tets[4 * t];
  const double ax = mesh.x[v[1]] - mesh.x[v[0]], ay = mesh.y[v[1]] - mesh.y[v[0]], az = mesh.z[v[1]] - mesh.z[v[0]];
  const double bx = mesh.x[v[2]] - mesh.x[v[0]], by = mesh.y[v[2]] - mesh.y[v[0]], bz = mesh.z[v[2]] - mesh.z[v[0]];
  const double cx = mesh.x[v[3]] - mesh.x[v[0]], cy = mesh.y[v[3]] - mesh.y[v[0]], cz = mesh.z[v[3]] - mesh.z[v[0]];
  return (ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)) / 6;
}

// The fixtures' fields as read: point data exact, cell data the volume-weighted mean of the
// volume cells around each vertex (surface cells left out), vectors joined, tets filling the
// cells' volume. `first` is the zone's first vertex in the joined mesh.
void expect_fields(const TetMesh& mesh, const Fixture& f, size_t first = 0, double pressure_fill = 0) {
  const CellMesh& m = f.mesh;
  ASSERT_EQ(mesh.attributes.size(), 4u);
  EXPECT_EQ(mesh.attributes[0].info.name, "Density");
  EXPECT_EQ(mesh.attributes[1].info.name, "Velocity");
  EXPECT_EQ(mesh.attributes[1].info.components, 3u);
  EXPECT_EQ(mesh.attributes[2].info.name, "Pressure");
  EXPECT_EQ(mesh.attributes[3].info.name, "Momentum");
  EXPECT_EQ(mesh.attributes[3].info.components, 3u);
  std::vector<double> sum(m.x.size(), 0), weight(m.x.size(), 0);
  for (size_t c = 0; c < m.cell_count(); ++c)
    for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) {
      sum[m.connectivity[k]] += f.volumes[c] * (pressure_fill != 0 ? pressure_fill : m.cell_attributes[0].values[c]);
      weight[m.connectivity[k]] += f.volumes[c];
    }
  for (size_t v = 0; v < m.x.size(); ++v) {
    const size_t g = first + v;
    EXPECT_EQ(mesh.x[g], m.x[v]);
    EXPECT_EQ(mesh.attributes[0].values[g], m.z[v]);
    EXPECT_FLOAT_EQ(mesh.attributes[1].values[3 * g + 1], -m.x[v]);
    EXPECT_FLOAT_EQ(mesh.attributes[1].values[3 * g + 2], 2 * m.x[v]);
    const double want = weight[v] > 0 ? sum[v] / weight[v] : 0;
    EXPECT_NEAR(mesh.attributes[2].values[g], want, 1e-5 * std::max(1.0, std::fabs(want))) << "vertex " << v;
    EXPECT_NEAR(mesh.attributes[3].values[3 * g + 2], 2 * want, 1e-5 * std::max(1.0, std::fabs(want))) << "vertex " << v;
  }
}

double total_volume(const TetMesh& mesh) {
  double volume = 0;
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    EXPECT_GT(tet_volume(mesh, t), 0) << "tet " << t;
    volume += tet_volume(mesh, t);
  }
  return volume;
}

TEST(Cgns, AHexZoneReadsWithItsVertexAndCellCentredSolutions) {
  const Fixture f = hex_zone();
  const auto path = scratch_dir("cgns_hex") / "m.cgns";
  write_cgns(path, {f.mesh});
  auto stream = storage::MeshStream::open(path);
  EXPECT_EQ(stream->header().format, storage::MeshFormat::kCgns);
  EXPECT_NE(stream->header().description.find("HDF5"), std::string::npos) << stream->header().description;
  const TetMesh mesh = storage::load_stream(*stream);
  EXPECT_EQ(stream->stats().cells, 4u);
  EXPECT_EQ(stream->stats().skipped_cells, 4u);
  EXPECT_EQ(stream->stats().hexahedra, 4u);
  EXPECT_EQ(mesh.tet_count(), 4u * 6);
  EXPECT_NEAR(total_volume(mesh), 4.0, 1e-5);
  expect_fields(mesh, f);
}

TEST(Cgns, AnAdfFileReadsAsTheHdf5OneDoes) {
  const Fixture f = hex_zone();
  const auto path = scratch_dir("cgns_adf") / "m.adf";
  write_cgns(path, {f.mesh}, {.adf = true});
  auto stream = storage::MeshStream::open(path);
  EXPECT_NE(stream->header().description.find("ADF"), std::string::npos) << stream->header().description;
  const TetMesh mesh = storage::load_stream(*stream);
  EXPECT_EQ(mesh.tet_count(), 4u * 6);
  expect_fields(mesh, f);
}

TEST(Cgns, AMixedSectionOfEveryVolumeTypeAndASurfaceReads) {
  const Fixture f = mixed_zone();
  const auto path = scratch_dir("cgns_mixed") / "m.cgns";
  write_cgns(path, {f.mesh}, {.mixed = true});
  auto stream = storage::MeshStream::open(path);
  const TetMesh mesh = storage::load_stream(*stream);
  EXPECT_EQ(stream->stats().cells, 7u);
  EXPECT_EQ(stream->stats().skipped_cells, 1u);
  EXPECT_EQ(stream->stats().pyramids, 1u);
  EXPECT_EQ(stream->stats().wedges, 1u);
  EXPECT_EQ(mesh.tet_count(), 4u * 6 + 2 + 1 + 3);
  EXPECT_NEAR(total_volume(mesh), 4 + 0.25 + 1.0 / 6 + 0.5, 1e-5);
  expect_fields(mesh, f);
}

TEST(Cgns, SectionsOfOneTypeEachReadAsTheMixedOne) {
  const Fixture f = mixed_zone();
  const auto path = scratch_dir("cgns_typed") / "m.cgns";
  write_cgns(path, {f.mesh});
  const TetMesh mesh = storage::load_mesh(path);
  EXPECT_EQ(mesh.tet_count(), 4u * 6 + 2 + 1 + 3);
  expect_fields(mesh, f);
}

TEST(Cgns, TwoZonesAreJoinedWithTheirVerticesOffset) {
  const Fixture a = hex_zone(), b = hex_zone(2);  // b's first column of points lies on a's last
  const auto path = scratch_dir("cgns_zones") / "m.cgns";
  write_cgns(path, {a.mesh, b.mesh});
  storage::ReadStats stats;
  const TetMesh mesh = storage::load_mesh(path, &stats);
  EXPECT_EQ(mesh.vertex_count(), 2 * a.mesh.x.size());  // interface points are not merged
  EXPECT_EQ(mesh.tet_count(), 2u * 4 * 6);
  EXPECT_NEAR(total_volume(mesh), 8.0, 1e-5);
  expect_fields(mesh, a, 0);
  expect_fields(mesh, b, a.mesh.x.size());
  bool warned = false;
  for (const std::string& w : stats.warnings) warned |= w.find("2 zones joined") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(Cgns, OfSeveralSolutionsTheLastIsReadOrTheOneZoneIterativeDataNames) {
  const Fixture f = hex_zone();
  const auto dir = scratch_dir("cgns_steps");
  write_cgns(dir / "last.cgns", {f.mesh}, {.extra_cell_solutions = {"Early"}});  // Early (-1) written before the real one
  expect_fields(storage::load_mesh(dir / "last.cgns"), f);
  write_cgns(dir / "early.cgns", {f.mesh}, {.extra_cell_solutions = {"Early"}, .pointers = true});  // the real one first, named for the last step
  storage::ReadStats stats;
  expect_fields(storage::load_mesh(dir / "early.cgns", &stats), f);
  bool warned = false;
  for (const std::string& w : stats.warnings) warned |= w.find("the last step's ('FlowSolutionCells') is read") != std::string::npos;
  EXPECT_TRUE(warned);
  // VTK's writers name the steps' cell solutions in FlowSolutionCellPointers
  write_cgns(dir / "vtk.cgns", {f.mesh}, {.extra_cell_solutions = {"Early"}, .pointers = true, .pointers_name = "FlowSolutionCellPointers"});
  expect_fields(storage::load_mesh(dir / "vtk.cgns"), f);
}

// Marks the file as written by CGNS `version` (the CGNSLibraryVersion node).
void set_version(const std::filesystem::path& path, float version) {
  int cgio = 0;
  double root = 0, node = 0;
  if (cgio_open_file(path.c_str(), CGIO_MODE_MODIFY, CGIO_FILE_NONE, &cgio) != 0) throw std::runtime_error("cgio_open_file");
  cgio_get_root_id(cgio, &root);
  if (cgio_get_node_id(cgio, root, "/CGNSLibraryVersion", &node) != 0) throw std::runtime_error("no /CGNSLibraryVersion");
  if (cgio_write_all_data(cgio, node, &version) != 0) throw std::runtime_error("cgio_write_all_data");
  cgio_close_file(cgio);
}

TEST(Cgns, AFileWrittenByCgns4ReadsThoughTheMidLevelLibraryRefusesIt) {
  const Fixture f = mixed_zone();
  const auto path = scratch_dir("cgns_version4") / "m.cgns";
  write_cgns(path, {f.mesh}, {.mixed = true});
  set_version(path, 4.2f);
  int fn = 0;
  EXPECT_NE(cg_open(path.c_str(), CG_MODE_READ, &fn), CG_OK);  // Debian 12's CGNS 3.4
  auto stream = storage::MeshStream::open(path);
  EXPECT_NE(stream->header().description.find("CGNS 4.2"), std::string::npos) << stream->header().description;
  expect_fields(storage::load_stream(*stream), f);
}

TEST(Cgns, InfoAndPreprocessReadItThroughTheCommandLine) {
  const Fixture f = mixed_zone();
  const auto dir = scratch_dir("cgns_cli");
  write_cgns(dir / "m.cgns", {f.mesh}, {.mixed = true});
  const CliResult info = run_cli("info --json " + (dir / "m.cgns").string(), 120);
  ASSERT_EQ(info.status, 0) << info.out;
  const nlohmann::json j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["format"], "cgns");
  EXPECT_EQ(j["tetrahedra"], 30);
  ASSERT_EQ(j["attributes"].size(), 4u);
  EXPECT_EQ(j["attributes"][1]["name"], "Velocity");
  EXPECT_EQ(j["attributes"][2]["association"], "cell");
  const CliResult preprocess = run_cli("preprocess " + (dir / "m.cgns").string() + " -o " + (dir / "store").string() + " --progress none", 300);
  ASSERT_EQ(preprocess.status, 0) << preprocess.out;
  const CliResult verify = run_cli("verify " + (dir / "store").string(), 120);
  EXPECT_EQ(verify.status, 0) << verify.out;
}

// The hex zone's boundary conditions as face tags named by the BCs: "floor" the four quads
// under the hexahedra by their element numbers (5 to 8), "lid" the vertices of the top (z = 2)
// as a range, "inlet" those of the side x = 0 as a list, and "outlet" two of the floor's
// quads by a PointList at FaceCenter; each face as two boundary triangles of the tets.
TEST(Cgns, BoundaryConditionsArriveAsFaceTagsNamedByTheBcs) {
  Fixture f = hex_zone();
  const auto path = scratch_dir("cgns_bcs") / "m.cgns";
  std::vector<cgsize_t> side;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j) side.push_back(1 + 3 * j + 9 * k);  // i = 0
  write_cgns(path, {f.mesh},
             {.bcs = {{"floor", CGNS_ENUMV(ElementRange), {5, 8}},
                      {"lid", CGNS_ENUMV(PointRange), {10, 18}},
                      {"inlet", CGNS_ENUMV(PointList), side},
                      {"outlet", CGNS_ENUMV(PointList), {6, 8}, CGNS_ENUMV(FaceCenter)}}});
  auto stream = storage::MeshStream::open(path);
  const TetMesh mesh = storage::load_stream(*stream);
  ASSERT_EQ(mesh.tet_count(), 4u * 6);
  // "outlet" names quads "floor" took first: a face goes to the first BC that holds it
  EXPECT_EQ(mesh.face_tags.names, (std::vector<std::string>{"floor", "lid", "inlet"}));
  std::map<std::string, size_t> triangles;
  std::set<std::array<uint32_t, 3>> boundary;
  for (auto face : boundary_faces(mesh.tets)) {
    std::sort(face.begin(), face.end());
    boundary.insert(face);
  }
  for (size_t t = 0; t < mesh.face_tags.triangles.size(); ++t) {
    ++triangles[mesh.face_tags.names[mesh.face_tags.tags[t]]];
    auto key = mesh.face_tags.triangles[t];
    std::sort(key.begin(), key.end());
    EXPECT_TRUE(boundary.count(key)) << "a tagged triangle that is no boundary face of the tets";
  }
  EXPECT_EQ(triangles, (std::map<std::string, size_t>{{"floor", 8}, {"lid", 8}, {"inlet", 4}}));
  const nlohmann::json j = storage::summary_json(storage::summarize_mesh(path));
  EXPECT_EQ(j["regions_source"], "input tags");
  EXPECT_EQ(j["face_tags"][1]["name"], "lid");
}

TEST(Cgns, AFaceCenterListNamesItsFaceElementsAndAZoneWithoutBcsHasNoTags) {
  Fixture f = hex_zone();
  const auto dir = scratch_dir("cgns_bcs_faces");
  write_cgns(dir / "m.cgns", {f.mesh},
             {.bcs = {{"west", CGNS_ENUMV(PointList), {5, 7}, CGNS_ENUMV(FaceCenter)}, {"east", CGNS_ENUMV(ElementList), {6, 8}}}});
  const TetMesh mesh = storage::load_mesh(dir / "m.cgns");
  EXPECT_EQ(mesh.face_tags.names, (std::vector<std::string>{"west", "east"}));
  EXPECT_EQ(mesh.face_tags.triangles.size(), 8u);
  write_cgns(dir / "none.cgns", {f.mesh});
  EXPECT_TRUE(storage::load_mesh(dir / "none.cgns").face_tags.empty());
}

// ---- hostile files -------------------------------------------------------------------

// Overwrites the zone's size array (vertices, cells, boundary vertices) in the file.
void set_zone_size(const std::filesystem::path& path, cgsize_t vertices, cgsize_t cells) {
  int cgio = 0;
  double root = 0, zone = 0;
  if (cgio_open_file(path.c_str(), CGIO_MODE_MODIFY, CGIO_FILE_NONE, &cgio) != 0) throw std::runtime_error("cgio_open_file");
  cgio_get_root_id(cgio, &root);
  if (cgio_get_node_id(cgio, root, "/Base/Zone1", &zone) != 0) throw std::runtime_error("no /Base/Zone1");
  const cgsize_t size[3] = {vertices, cells, 0};
  if (cgio_write_all_data(cgio, zone, size) != 0) throw std::runtime_error("cgio_write_all_data");
  cgio_close_file(cgio);
}

TEST(HostileCgns, AFileThatIsNotCgnsIsRefusedNamingIt) {
  const auto path = scratch_dir("cgns_not") / "m.cgns";
  write_file(path, "this is not an HDF5 file\n");
  EXPECT_NE(mesh_read_error(path).find("m.cgns: not a CGNS file"), std::string::npos) << mesh_read_error(path);
}

// A zone's size is checked against its coordinate arrays; sizes that agree with arrays larger
// than the file could hold (compressed HDF5 datasets) meet the check against ReadLimits.
TEST(HostileCgns, AZoneOfANegativeSizeIsRefused) {
  for (const bool adf : {false, true}) {
    const auto path = scratch_dir("cgns_negative") / (adf ? "m.adf" : "m.cgns");
    write_cgns(path, {hex_zone().mesh}, {.adf = adf});
    set_zone_size(path, -5, 4);
    const std::string error = mesh_read_error(path);
    EXPECT_NE(error.find("zone 'Zone1' declares -5 vertices"), std::string::npos) << error;
  }
}

TEST(HostileCgns, AZoneOfAHugeSizeIsRefusedBeforeAnyAllocation) {
  for (const bool adf : {false, true}) {
    const auto path = scratch_dir("cgns_huge") / (adf ? "m.adf" : "m.cgns");
    write_cgns(path, {hex_zone().mesh}, {.adf = adf});
    set_zone_size(path, 2000000000, 1000000000);
    const std::string error = mesh_read_error(path);
    EXPECT_NE(error.find("CoordinateX of zone 'Zone1' holds 18 values for 2000000000 vertices"), std::string::npos) << error;
  }
}

TEST(HostileCgns, AVertexIndexPastTheZoneIsRefusedNamingTheElement) {
  Fixture f = mixed_zone();
  f.mesh.connectivity[f.mesh.offsets[5] + 3] = 998;  // the pyramid's fourth corner
  const auto path = scratch_dir("cgns_range") / "m.cgns";
  write_cgns(path, {f.mesh}, {.mixed = true});
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("vertex 999 out of range"), std::string::npos) << error;
  EXPECT_NE(error.find("element 6"), std::string::npos) << error;
}

TEST(HostileCgns, ABcVertexPastTheZoneIsRefusedNamingTheBc) {
  const Fixture f = hex_zone();
  const auto path = scratch_dir("cgns_bc_past") / "m.cgns";
  write_cgns(path, {f.mesh}, {.bcs = {{"lid", CGNS_ENUMV(PointList), {10, 11, 99}}}});
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("CGNS BC 'lid' of zone 'Zone1' names vertex 99 of a zone of 18 vertices"), std::string::npos) << error;
}

TEST(HostileCgns, AStructuredZoneIsRefusedNamingIt) {
  const auto path = scratch_dir("cgns_structured") / "m.cgns";
  write_cgns(path, {hex_zone().mesh, hex_zone().mesh}, {.structured = true});
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("zone 'Zone1' is structured"), std::string::npos) << error;
}

TEST(HostileCgns, AFileWithNoUnstructuredZoneIsRefused) {
  const auto path = scratch_dir("cgns_empty") / "m.cgns";
  write_cgns(path, {});
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("has no zone"), std::string::npos) << error;
}

// The CGNS library's ADF layer aborts on a file header it cannot parse, and converts values by
// the type sizes the header gives: both are checked before the library sees the file.
TEST(HostileCgns, AnAdfFileCutInsideItsHeaderIsRefused) {
  const auto dir = scratch_dir("cgns_adf_header");
  write_cgns(dir / "good.adf", {hex_zone().mesh}, {.adf = true});
  write_file(dir / "cut.adf", read_file(dir / "good.adf").substr(0, 91));
  EXPECT_NE(mesh_read_error(dir / "cut.adf").find("cut.adf: not a CGNS file"), std::string::npos) << mesh_read_error(dir / "cut.adf");
}

TEST(HostileCgns, AnAdfHeaderWithTypeSizesOfNoMachineIsRefused) {
  const auto dir = scratch_dir("cgns_adf_sizes");
  write_cgns(dir / "good.adf", {hex_zone().mesh}, {.adf = true});
  std::string bad = read_file(dir / "good.adf");
  bad.replace(116, 2, "86");  // the size of a double
  write_file(dir / "bad.adf", bad);
  EXPECT_NE(mesh_read_error(dir / "bad.adf").find("bad.adf: not a CGNS file"), std::string::npos) << mesh_read_error(dir / "bad.adf");
}

TEST(HostileCgns, TruncatedAndFlippedFilesGetAnErrorOrReadNeverCrash) {
  const Fixture f = mixed_zone();
  const auto dir = scratch_dir("cgns_damaged");
  for (const bool adf : {false, true}) {
    const auto good_path = dir / (adf ? "good.adf" : "good.cgns");
    // with boundary conditions by element and by vertex, so damage reaches their nodes too
    write_cgns(good_path, {f.mesh}, {.adf = adf, .mixed = true, .bcs = {{"floor", CGNS_ENUMV(ElementList), {3}}, {"lid", CGNS_ENUMV(PointRange), {10, 18}}}});
    ASSERT_EQ(storage::load_mesh(good_path).face_tags.names, (std::vector<std::string>{"floor", "lid"}));
    const std::string good = read_file(good_path);
    std::mt19937 random(20261127);
    int refused = 0;
    for (int trial = 0; trial < 150; ++trial) {
      std::string bad = good;
      if (trial % 3 == 0) {
        bad.resize(random() % bad.size());
      } else {
        for (int k = 0; k < 4; ++k) bad[random() % bad.size()] = static_cast<char>(random());
      }
      const auto bad_path = dir / (adf ? "bad.adf" : "bad.cgns");
      write_file(bad_path, bad);
      try {
        storage::load_mesh(bad_path);
      } catch (const MeshError&) {
        ++refused;
      }
    }
    EXPECT_GT(refused, 0) << (adf ? "ADF" : "HDF5");
  }
}

// A hex zone with the vertex tensor ReynoldsStress (SIDS's NAMEXX ... NAMEZZ; σxx = 10 + x,
// σyy = 2, σzz = 1, σxy = y, σyz = 0.5, σxz = z), one vertex's XY NaN when `bad` is set.
Fixture tensor_zone(bool bad) {
  Fixture f = hex_zone();
  storage::Attribute stress{{"ReynoldsStress", 6, storage::AttributeKind::kTensor}, {}};
  for (size_t v = 0; v < f.mesh.x.size(); ++v) {
    const float xy = bad && v == 3 ? std::nanf("") : f.mesh.y[v];
    stress.values.insert(stress.values.end(), {10 + f.mesh.x[v], 2.f, 1.f, xy, 0.5f, f.mesh.z[v]});
  }
  f.mesh.attributes.push_back(stress);
  return f;
}

TEST(Cgns, SixFieldsNamedXXToZZAreOneSymmetricTensorWithItsDerivedScalars) {
  const Fixture f = tensor_zone(false);
  const auto path = scratch_dir("cgns_tensor") / "m.cgns";
  write_cgns(path, {f.mesh});
  const TetMesh mesh = storage::load_mesh(path);
  const storage::Attribute* stress = mesh.find_attribute("ReynoldsStress");
  ASSERT_NE(stress, nullptr);
  EXPECT_EQ(stress->info.kind, storage::AttributeKind::kTensor);
  ASSERT_EQ(stress->info.components, 6u);
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    const float* t = &stress->values[6 * v];
    EXPECT_FLOAT_EQ(t[0], 10 + mesh.x[v]);
    EXPECT_FLOAT_EQ(t[3], mesh.y[v]);
    EXPECT_FLOAT_EQ(t[5], mesh.z[v]);
    EXPECT_FLOAT_EQ(t[4], 0.5f);
  }
  ASSERT_NE(mesh.find_attribute("ReynoldsStress.von_mises"), nullptr);
  EXPECT_NE(mesh.find_attribute("Velocity"), nullptr) << "the vector beside it";
  EXPECT_EQ(mesh.find_attribute("ReynoldsStressXX"), nullptr);
}

TEST(HostileCgns, ANonFiniteTensorComponentIsRefusedNamingTheTensorAndVertex) {
  const Fixture f = tensor_zone(true);
  const auto path = scratch_dir("cgns_tensor_nan") / "m.cgns";
  write_cgns(path, {f.mesh});
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("tensor 'ReynoldsStress' (field ReynoldsStressXY), vertex 4"), std::string::npos) << error;
}

// ---- time steps: ZoneIterativeData and BaseIterativeData ------------------------------

double temp_at(int step, double x, double y, double z) { return (step + 2) * x - y + z * step; }
double heat_at(int step, size_t tet) { return 7.0 * step + double(tet % 4); }

const TetMesh& steps_box() {
  static const TetMesh m = kuhn_box(4, 0.0, [](double, double, double) { return 0.0; });  // tets of one volume
  return m;
}

// The box as one TETRA_4 zone with vertex solutions Flow0.. (Temp, VelocityX/Y/Z) and cell
// solutions Cells0.. (Heat) for `times`, named by FlowSolutionVertexPointers and
// FlowSolutionCellPointers (`vertex_names` in their place when given), the times in
// BaseIterativeData's TimeValues.
void write_cgns_steps(const std::filesystem::path& path, const std::vector<double>& times, std::vector<std::string> vertex_names = {}) {
  const TetMesh& m = steps_box();
  std::filesystem::remove(path);
  check(cg_set_file_type(CG_FILE_HDF5));
  int fn = 0, B = 0, Z = 0, C = 0, S = 0, F = 0;
  check(cg_open(path.c_str(), CG_MODE_WRITE, &fn));
  check(cg_base_write(fn, "Base", 3, 3, &B));
  const cgsize_t size[3] = {static_cast<cgsize_t>(m.vertex_count()), static_cast<cgsize_t>(m.tet_count()), 0};
  check(cg_zone_write(fn, B, "Box", size, CGNS_ENUMV(Unstructured), &Z));
  std::vector<double> x(m.x.begin(), m.x.end()), y(m.y.begin(), m.y.end()), z(m.z.begin(), m.z.end());
  check(cg_coord_write(fn, B, Z, CGNS_ENUMV(RealDouble), "CoordinateX", x.data(), &C));
  check(cg_coord_write(fn, B, Z, CGNS_ENUMV(RealDouble), "CoordinateY", y.data(), &C));
  check(cg_coord_write(fn, B, Z, CGNS_ENUMV(RealDouble), "CoordinateZ", z.data(), &C));
  std::vector<cgsize_t> elements;
  for (uint32_t v : m.tets) elements.push_back(static_cast<cgsize_t>(v) + 1);
  check(cg_section_write(fn, B, Z, "Tets", CGNS_ENUMV(TETRA_4), 1, static_cast<cgsize_t>(m.tet_count()), 0, elements.data(), &S));
  std::vector<std::string> cell_names;
  for (int s = 0; s < int(times.size()); ++s) {
    const std::string flow = "Flow" + std::to_string(s), cells = "Cells" + std::to_string(s);
    if (vertex_names.size() < times.size()) vertex_names.push_back(flow);
    cell_names.push_back(cells);
    check(cg_sol_write(fn, B, Z, flow.c_str(), CGNS_ENUMV(Vertex), &S));
    std::vector<double> temp, vx, vy, vz;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      temp.push_back(temp_at(s, x[v], y[v], z[v]));
      vx.push_back(x[v] * s), vy.push_back(-y[v]), vz.push_back(z[v] + s);
    }
    check(cg_field_write(fn, B, Z, S, CGNS_ENUMV(RealDouble), "Temp", temp.data(), &F));
    check(cg_field_write(fn, B, Z, S, CGNS_ENUMV(RealDouble), "VelocityX", vx.data(), &F));
    check(cg_field_write(fn, B, Z, S, CGNS_ENUMV(RealDouble), "VelocityY", vy.data(), &F));
    check(cg_field_write(fn, B, Z, S, CGNS_ENUMV(RealDouble), "VelocityZ", vz.data(), &F));
    check(cg_sol_write(fn, B, Z, cells.c_str(), CGNS_ENUMV(CellCenter), &S));
    std::vector<double> heat;
    for (size_t t = 0; t < m.tet_count(); ++t) heat.push_back(heat_at(s, t));
    check(cg_field_write(fn, B, Z, S, CGNS_ENUMV(RealDouble), "Heat", heat.data(), &F));
  }
  check(cg_biter_write(fn, B, "BaseIterativeData", static_cast<int>(times.size())));
  check(cg_goto(fn, B, "BaseIterativeData_t", 1, "end"));
  const cgsize_t count = static_cast<cgsize_t>(times.size());
  check(cg_array_write("TimeValues", CGNS_ENUMV(RealDouble), 1, &count, times.data()));
  check(cg_ziter_write(fn, B, Z, "ZoneIterativeData"));
  check(cg_goto(fn, B, "Zone_t", Z, "ZoneIterativeData_t", 1, "end"));
  for (const auto& [array, names] : {std::pair{"FlowSolutionVertexPointers", vertex_names}, std::pair{"FlowSolutionCellPointers", cell_names}}) {
    std::string text;
    for (const std::string& n : names) text += n + std::string(32 - n.size(), ' ');
    const cgsize_t dims[2] = {32, count};
    check(cg_array_write(array, CGNS_ENUMV(Character), 2, dims, text.data()));
  }
  check(cg_close(fn));
}

// Heat at each vertex as read: the mean of the step's values over the tets around it (they
// have one volume).
std::vector<double> heat_at_vertices(int step) {
  const TetMesh& m = steps_box();
  std::vector<double> sum(m.vertex_count(), 0), count(m.vertex_count(), 0);
  for (size_t t = 0; t < m.tet_count(); ++t)
    for (int k = 0; k < 4; ++k) sum[m.tets[4 * t + size_t(k)]] += heat_at(step, t), count[m.tets[4 * t + size_t(k)]] += 1;
  for (size_t v = 0; v < sum.size(); ++v) sum[v] /= count[v];
  return sum;
}

TEST(CgnsSteps, TheLastStepIsReadAloneAndTheWarningNamesAllSteps) {
  const auto path = scratch_dir("cgns_steps_last") / "m.cgns";
  write_cgns_steps(path, {0, 0.5, 1.25});
  auto stream = storage::MeshStream::open(path);
  EXPECT_EQ(stream->header().step_times, (std::vector<double>{0, 0.5, 1.25}));
  bool warned = false;
  for (const std::string& w : stream->stats().warnings) warned |= w == "CGNS zone 'Box' has 3 solutions at vertices: the last step's ('Flow2') is read (preprocess --all-steps reads every step)";
  EXPECT_TRUE(warned);
  const TetMesh last = storage::load_stream(*stream);
  storage::ReadLimits limits;
  limits.time_step = 1;
  const TetMesh second = storage::load_mesh(path, nullptr, limits);
  for (const auto& [mesh, step] : {std::pair<const TetMesh*, int>{&last, 2}, {&second, 1}}) {
    const storage::Attribute* temp = mesh->find_attribute("Temp");
    const storage::Attribute* heat = mesh->find_attribute("Heat");
    ASSERT_TRUE(temp && heat && mesh->find_attribute("Velocity"));
    const std::vector<double> want = heat_at_vertices(step);
    size_t wrong = 0;
    for (size_t v = 0; v < mesh->vertex_count(); ++v) {
      wrong += std::abs(temp->values[v] - temp_at(step, mesh->x[v], mesh->y[v], mesh->z[v])) > 1e-5;
      wrong += std::abs(heat->values[v] - want[v]) > 1e-5;
    }
    EXPECT_EQ(wrong, 0u) << "step " << step;
  }
  expect_step_refused(path, 3, "m.cgns: CGNS zone 'Box': its ZoneIterativeData names 3 time steps, time step 3 asked for");
}

TEST(CgnsSteps, AllStepsMakesOneStoreOfEveryStepWithItsTimesAndValues) {
  const auto dir = scratch_dir("cgns_steps_store");
  const std::vector<double> times{0, 0.5, 1.25};
  write_cgns_steps(dir / "m.cgns", times);
  const nlohmann::json listed = all_steps_listed(dir / "m.cgns", dir / "s.store", " --base-tets 100 --segment-tets 256 --progress none --threads 1");
  ASSERT_EQ(listed.size(), 3u) << listed.dump();
  for (int s = 0; s < 3; ++s) {
    EXPECT_DOUBLE_EQ(listed[s]["time"].get<double>(), times[size_t(s)]);
    EXPECT_EQ(listed[s]["name"], "m.cgns step " + std::to_string(s));
  }
  EXPECT_EQ(run_cli("verify " + (dir / "s.store").string(), 120).status, 0);
  const TetMesh& m = steps_box();
  const auto store = storage::Store::open(dir / "s.store");
  const auto steps = storage::TimeSteps::open(*store);
  ASSERT_NE(steps, nullptr);
  ASSERT_EQ(steps->layout().floats, 5u);  // Temp, Velocity (3), Heat
  ASSERT_EQ(steps->layout().input_vertices, m.vertex_count());
  for (int s = 1; s < 3; ++s) {
    const auto values = steps->values(static_cast<uint32_t>(s));
    const std::vector<double> heat = heat_at_vertices(s);
    size_t wrong = 0;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      const float* row = values->data() + 5 * v;
      wrong += std::abs(row[0] - temp_at(s, m.x[v], m.y[v], m.z[v])) > 1e-5;
      wrong += std::abs(row[1] - m.x[v] * s) > 1e-5 || std::abs(row[3] - (m.z[v] + s)) > 1e-5;
      wrong += std::abs(row[4] - heat[v]) > 1e-5;
    }
    EXPECT_EQ(wrong, 0u) << "step " << s;
  }
}

TEST(HostileCgnsSteps, AStepNamingASolutionTheZoneLacksIsRefusedNamingTheZoneAndStep) {
  const auto dir = scratch_dir("cgns_steps_missing");
  std::filesystem::remove_all(dir / "s.store");
  write_cgns_steps(dir / "m.cgns", {0, 1, 2}, {"Flow0", "Missing", "Flow2"});
  const CliResult r = run_cli("preprocess " + (dir / "m.cgns").string() + " -o " + (dir / "s.store").string() + " --all-steps --base-tets 100 --segment-tets 256 --progress none", 300);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("m.cgns: CGNS zone 'Box': time step 1 names solution 'Missing', none of its 3 solutions at vertices"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "s.store"));
}

}  // namespace
}  // namespace tetrascope::testing
