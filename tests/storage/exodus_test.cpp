// Exodus II files written by the Exodus II library itself: element blocks of every volume
// type and a shell block, nodal and element variables (x/y/z components joined into vectors)
// over two time steps, read at the last; a file of several time steps preprocessed with
// --all-steps into one store of every step; side sets as named boundary face tags; and damaged
// files refused with a message, never a crash.
#include <exodusII.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "fixture_writers.h"
#include "mesh_checks.h"
#include "step_checks.h"
#include "test_paths.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/storage/mesh_info.h"
#include "tetrascope/storage/series.h"
#include "tetrascope/storage/time_steps.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

using storage::MeshError;
using storage::TetMesh;

const char* exodus_type(uint8_t vtk) {
  switch (vtk) {
    case 10: return "TETRA";
    case 12: return "HEX8";
    case 13: return "WEDGE";
    case 14: return "PYRAMID";
    case 9: return "SHELL4";
    default: return "TRI3";
  }
}

// Cells grouped into one block a type (in the order the types first appear); the element
// variables "pressure" and "u_x", "u_y", "u_z"; the nodal "height" and "vel_x/y/z". Step 1
// holds -1 everywhere, step 2 the values. Returns the cells in file order (block by block).
std::vector<size_t> write_exodus(const std::filesystem::path& path, const CellMesh& m, double scale = 1) {
  std::vector<uint8_t> types;
  for (uint8_t t : m.types)
    if (std::find(types.begin(), types.end(), t) == types.end()) types.push_back(t);
  int word = 8, io_word = 8;
  const int exoid = ex_create(path.c_str(), EX_CLOBBER, &word, &io_word);
  if (exoid < 0) throw std::runtime_error("ex_create failed");
  ex_put_init(exoid, "fixture", 3, static_cast<int64_t>(m.x.size()), static_cast<int64_t>(m.cell_count()), static_cast<int64_t>(types.size()), 0, 0);
  std::vector<double> x(m.x.begin(), m.x.end()), y(m.y.begin(), m.y.end()), z(m.z.begin(), m.z.end());
  ex_put_coord(exoid, x.data(), y.data(), z.data());
  std::vector<size_t> order;
  std::vector<std::vector<size_t>> blocks(types.size());
  for (size_t b = 0; b < types.size(); ++b) {
    std::vector<int> conn;
    for (size_t c = 0; c < m.cell_count(); ++c) {
      if (m.types[c] != types[b]) continue;
      blocks[b].push_back(c);
      order.push_back(c);
      for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) conn.push_back(static_cast<int>(m.connectivity[k]) + 1);
    }
    const int64_t nodes = m.offsets[blocks[b][0] + 1] - m.offsets[blocks[b][0]];
    ex_put_block(exoid, EX_ELEM_BLOCK, static_cast<int64_t>(b + 10), exodus_type(types[b]), static_cast<int64_t>(blocks[b].size()), nodes, 0, 0, 0);
    ex_put_conn(exoid, EX_ELEM_BLOCK, static_cast<int64_t>(b + 10), conn.data(), nullptr, nullptr);
  }
  const char* nodal[] = {"height", "vel_x", "vel_y", "vel_z"};
  const char* element[] = {"pressure", "u_x", "u_y", "u_z"};
  ex_put_variable_param(exoid, EX_NODAL, 4);
  ex_put_variable_names(exoid, EX_NODAL, 4, const_cast<char**>(nodal));
  ex_put_variable_param(exoid, EX_ELEM_BLOCK, 4);
  ex_put_variable_names(exoid, EX_ELEM_BLOCK, 4, const_cast<char**>(element));
  std::vector<int> truth(types.size() * 4, 1);
  ex_put_truth_table(exoid, EX_ELEM_BLOCK, static_cast<int>(types.size()), 4, truth.data());
  for (int step = 1; step <= 2; ++step) {
    const double t = 0.5 * step;
    ex_put_time(exoid, step, &t);
    for (int v = 0; v < 4; ++v) {
      std::vector<double> values;
      for (size_t i = 0; i < m.x.size(); ++i) values.push_back(step == 1 ? -1.0 : v == 0 ? m.z[i] : (v == 1 ? 1 : v == 2 ? -1 : 2) * double(m.x[i]) * scale);
      ex_put_var(exoid, step, EX_NODAL, v + 1, 1, static_cast<int64_t>(m.x.size()), values.data());
      for (size_t b = 0; b < types.size(); ++b) {
        std::vector<double> cells;
        for (size_t c : blocks[b]) cells.push_back(step == 1 ? -1.0 : v == 0 ? m.cell_attributes[0].values[c] : m.cell_attributes[1].values[3 * c + size_t(v - 1)]);
        ex_put_var(exoid, step, EX_ELEM_BLOCK, v + 1, static_cast<int64_t>(b + 10), static_cast<int64_t>(cells.size()), cells.data());
      }
    }
  }
  ex_close(exoid);
  return order;
}

// The block of the cell-data tests: hexahedra, a pyramid, a wedge, a tet and one shell quad
// (value 1000, which must reach no vertex), with closed-form volumes.
struct Fixture {
  CellMesh mesh;
  std::vector<double> volumes;
};

Fixture hybrid_block() {
  Fixture f;
  CellMesh& m = f.mesh;
  for (int k = 0; k < 2; ++k)
    for (int j = 0; j < 3; ++j)
      for (int i = 0; i < 3; ++i) m.x.push_back(float(i)), m.y.push_back(float(j) * 0.5f), m.z.push_back(float(k) * 2.0f);
  auto at = [](int i, int j, int k) { return uint32_t(i + 3 * j + 9 * k); };
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      m.add_cell(12, {at(i, j, 0), at(i + 1, j, 0), at(i + 1, j + 1, 0), at(i, j + 1, 0), at(i, j, 1), at(i + 1, j, 1), at(i + 1, j + 1, 1), at(i, j + 1, 1)});
      f.volumes.push_back(1.0);
    }
  m.add_cell(9, {at(0, 0, 0), at(1, 0, 0), at(1, 1, 0), at(0, 1, 0)});
  f.volumes.push_back(0);
  const uint32_t apex = static_cast<uint32_t>(m.x.size());
  m.x.push_back(0.5f), m.y.push_back(0.25f), m.z.push_back(3.5f);
  m.add_cell(14, {at(0, 0, 1), at(1, 0, 1), at(1, 1, 1), at(0, 1, 1), apex});
  f.volumes.push_back(0.5 * 1.5 / 3);
  const uint32_t tip = static_cast<uint32_t>(m.x.size());
  m.x.push_back(3), m.y.push_back(0), m.z.push_back(0);
  m.add_cell(10, {at(2, 0, 0), at(2, 1, 0), at(2, 0, 1), tip});
  f.volumes.push_back(1.0 / 6);
  storage::Attribute pressure{{"pressure", 1}, {}}, u{{"u", 3}, {}};
  for (size_t c = 0; c < m.cell_count(); ++c) {
    const float v = f.volumes[c] > 0 ? 1.5f * float(c) + 1 : 1000;
    pressure.values.push_back(v);
    u.values.insert(u.values.end(), {v, -v, 2 * v});
  }
  m.cell_attributes = {pressure, u};
  return f;
}

TEST(Exodus, BlocksOfEveryVolumeTypeReadWithNodalAndElementVariablesAtTheLastStep) {
  const Fixture f = hybrid_block();
  const auto path = scratch_dir("exodus_hybrid") / "m.exo";
  write_exodus(path, f.mesh);
  auto stream = storage::MeshStream::open(path);
  const storage::MeshHeader& header = stream->header();
  EXPECT_EQ(header.format, storage::MeshFormat::kExodus);
  EXPECT_NE(header.description.find("step 2 of 2"), std::string::npos) << header.description;
  ASSERT_EQ(header.attributes.size(), 4u);
  EXPECT_EQ(header.attributes[0].name, "height");
  EXPECT_EQ(header.attributes[1].name, "vel");
  EXPECT_EQ(header.attributes[1].components, 3u);
  EXPECT_EQ(header.attributes[2].name, "pressure");
  EXPECT_EQ(header.attributes[3].name, "u");
  EXPECT_EQ(header.attributes[3].components, 3u);
  const TetMesh mesh = storage::load_stream(*stream);
  EXPECT_EQ(stream->stats().cells, 6u);
  EXPECT_EQ(stream->stats().skipped_cells, 1u);
  EXPECT_EQ(stream->stats().hexahedra, 4u);
  EXPECT_EQ(mesh.tet_count(), 4u * 6 + 2 + 1);
  // the volume-weighted mean of the volume cells around each vertex, the shell left out
  std::vector<double> sum(mesh.vertex_count(), 0), weight(mesh.vertex_count(), 0);
  const CellMesh& m = f.mesh;
  for (size_t c = 0; c < m.cell_count(); ++c)
    for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) {
      sum[m.connectivity[k]] += f.volumes[c] * m.cell_attributes[0].values[c];
      weight[m.connectivity[k]] += f.volumes[c];
    }
  for (size_t v = 0; v < mesh.vertex_count(); ++v) {
    EXPECT_EQ(mesh.attributes[0].values[v], m.z[v]);
    EXPECT_FLOAT_EQ(mesh.attributes[1].values[3 * v + 2], 2 * m.x[v]);
    const double want = weight[v] > 0 ? sum[v] / weight[v] : 0;
    EXPECT_NEAR(mesh.attributes[2].values[v], want, 1e-5 * std::max(1.0, want)) << "vertex " << v;
    EXPECT_NEAR(mesh.attributes[3].values[3 * v + 1], -want, 1e-5 * std::max(1.0, want)) << "vertex " << v;
  }
  bool warned = false;
  for (const std::string& w : stream->stats().warnings) warned |= w.find("2 time steps") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(Exodus, InfoListsTheVariablesAndMarksTheElementOnes) {
  const Fixture f = hybrid_block();
  const auto path = scratch_dir("exodus_info") / "m.e";
  write_exodus(path, f.mesh);
  const auto s = storage::summarize_mesh(path);
  const nlohmann::json j = storage::summary_json(s);
  EXPECT_EQ(j["format"], "exodus");
  ASSERT_EQ(j["attributes"].size(), 4u);
  EXPECT_EQ(j["attributes"][1]["association"], "point");
  EXPECT_EQ(j["attributes"][2]["association"], "cell");
  EXPECT_EQ(j["tetrahedra"], 27);
}

TEST(Exodus, AStoreBuiltFromItHoldsTheElementVariablesAtTheVertices) {
  const Fixture f = hybrid_block();
  const auto dir = scratch_dir("exodus_store");
  write_exodus(dir / "m.exo", f.mesh);
  lod::PreprocessOptions options;
  options.threads = 1;
  lod::preprocess(dir / "m.exo", dir / "store", options, nullptr);
  const auto store = storage::Store::open(dir / "store");
  const auto& attributes = store->manifest().attributes;
  ASSERT_EQ(attributes.size(), 4u);
  EXPECT_EQ(attributes[2].name, "pressure");
  EXPECT_EQ(attributes[3].name, "u");
  EXPECT_EQ(attributes[3].components, 3u);
  // the pressure of the volume cells is 1 .. 10 (the shell's 1000 reaches no vertex)
  EXPECT_GE(attributes[2].min, 1.0 - 1e-6);
  EXPECT_LE(attributes[2].max, 10 + 1e-6);
  EXPECT_EQ(store->manifest().tet_count, 27u);
}

// The tagged cube's hexahedra (testing::tagged_cube) in one block with three side sets by
// element and side (Exodus's hexahedron sides: 2 is x = 1, 4 is x = 0, 6 is z = 1): "inlet",
// "outlet" and an unnamed one. Returns nothing; the file is written at `path`.
void write_exodus_side_sets(const std::filesystem::path& path) {
  const CellMesh m = tagged_cube().mesh;
  std::vector<int> conn;
  for (size_t c = 0; c < m.cell_count(); ++c)
    if (m.types[c] == 12)
      for (uint32_t k = m.offsets[c]; k < m.offsets[c + 1]; ++k) conn.push_back(static_cast<int>(m.connectivity[k]) + 1);
  int word = 8, io_word = 8;
  const int exoid = ex_create(path.c_str(), EX_CLOBBER, &word, &io_word);
  ASSERT_GE(exoid, 0);
  ex_put_init(exoid, "side sets", 3, static_cast<int64_t>(m.x.size()), 8, 1, 0, 3);
  std::vector<double> x(m.x.begin(), m.x.end()), y(m.y.begin(), m.y.end()), z(m.z.begin(), m.z.end());
  ex_put_coord(exoid, x.data(), y.data(), z.data());
  ex_put_block(exoid, EX_ELEM_BLOCK, 1, "HEX8", 8, 8, 0, 0, 0);
  ex_put_conn(exoid, EX_ELEM_BLOCK, 1, conn.data(), nullptr, nullptr);
  // hexahedron e (1-based) is at i = (e-1) % 2, j = (e-1) / 2 % 2, k = (e-1) / 4
  auto put = [&](int64_t id, int side, auto&& wanted) {
    std::vector<int> elements, sides;
    for (int e = 1; e <= 8; ++e)
      if (wanted((e - 1) % 2, (e - 1) / 2 % 2, (e - 1) / 4)) elements.push_back(e), sides.push_back(side);
    ex_put_set_param(exoid, EX_SIDE_SET, id, static_cast<int64_t>(elements.size()), 0);
    ex_put_set(exoid, EX_SIDE_SET, id, elements.data(), sides.data());
  };
  put(1, 4, [](int i, int, int) { return i == 0; });
  put(2, 2, [](int i, int, int) { return i == 1; });
  put(7, 6, [](int, int, int k) { return k == 1; });
  const char* names[] = {"inlet", "outlet", ""};
  ex_put_names(exoid, EX_SIDE_SET, const_cast<char**>(names));
  ex_close(exoid);
}

TEST(Exodus, SideSetsArriveAsNamedBoundaryFaceTagsCutAsTheHexahedraAre) {
  const auto path = scratch_dir("exodus_side_sets") / "m.exo";
  write_exodus_side_sets(path);
  const TetMesh mesh = storage::load_mesh(path);
  ASSERT_EQ(mesh.face_tags.names, (std::vector<std::string>{"inlet", "outlet", "side set 7"}));
  std::map<std::array<uint32_t, 3>, uint32_t> tag_of;
  for (size_t t = 0; t < mesh.face_tags.triangles.size(); ++t) {
    auto key = mesh.face_tags.triangles[t];
    std::sort(key.begin(), key.end());
    tag_of[key] = mesh.face_tags.tags[t];
  }
  EXPECT_EQ(mesh.face_tags.triangles.size(), 24u);
  std::map<uint32_t, size_t> on_boundary;
  for (auto face : boundary_faces(mesh.tets)) {
    std::sort(face.begin(), face.end());
    if (auto it = tag_of.find(face); it != tag_of.end()) ++on_boundary[it->second];
  }
  EXPECT_EQ(on_boundary, (std::map<uint32_t, size_t>{{0, 8}, {1, 8}, {2, 8}})) << "each side set's 4 quads are 8 boundary faces of the tets";
  const nlohmann::json j = storage::summary_json(storage::summarize_mesh(path));
  EXPECT_EQ(j["regions_source"], "input tags");
}

TEST(HostileExodus, AFileThatIsNotExodusIsRefusedNamingIt) {
  const auto path = scratch_dir("exodus_not") / "m.exo";
  write_file(path, "this is not a NetCDF file\n");
  EXPECT_NE(mesh_read_error(path).find("m.exo: not an Exodus II file"), std::string::npos) << mesh_read_error(path);
}

TEST(HostileExodus, ANodeIndexPastTheNodesIsRefusedNamingTheElement) {
  Fixture f = hybrid_block();
  f.mesh.connectivity.back() = 999;  // the tet's last node
  const auto path = scratch_dir("exodus_node_range") / "m.exo";
  write_exodus(path, f.mesh);
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("node 1000 out of range"), std::string::npos) << error;
}

TEST(HostileExodus, TruncatedAndFlippedFilesGetAnErrorOrReadNeverCrash) {
  const Fixture f = hybrid_block();
  const auto dir = scratch_dir("exodus_damaged");
  write_exodus(dir / "good.exo", f.mesh);
  const std::string good = read_file(dir / "good.exo");
  std::mt19937 random(20261127);
  int refused = 0;
  for (int trial = 0; trial < 200; ++trial) {
    std::string bad = good;
    if (trial % 3 == 0) {
      bad.resize(random() % bad.size());
    } else {
      for (int k = 0; k < 4; ++k) bad[random() % bad.size()] = static_cast<char>(random());
    }
    write_file(dir / "bad.exo", bad);
    try {
      storage::load_mesh(dir / "bad.exo");
    } catch (const MeshError&) {
      ++refused;
    }
  }
  EXPECT_GT(refused, 0);
}

// A block of 48 tets with the nodal variables `names` (six of a tensor, by SEACAS's suffixes,
// in the order given) holding, at node i, the components of the stress σxx = 100 + 10 x, σyy =
// 20, σzz = -5, σxy = 3 y, σyz = 1, σzx = 2 z (by the suffix's letters); `bad_node` gets a NaN in
// its XY component.
void write_exodus_tensor(const std::filesystem::path& path, const std::vector<std::string>& names, int bad_node = -1) {
  const TetMesh box = kuhn_box(2, 0, [](float, float, float) { return 0.0; });
  int word = 8, io_word = 8;
  const int exoid = ex_create(path.c_str(), EX_CLOBBER, &word, &io_word);
  if (exoid < 0) throw std::runtime_error("ex_create failed");
  ex_put_init(exoid, "tensor fixture", 3, static_cast<int64_t>(box.vertex_count()), static_cast<int64_t>(box.tet_count()), 1, 0, 0);
  std::vector<double> x(box.x.begin(), box.x.end()), y(box.y.begin(), box.y.end()), z(box.z.begin(), box.z.end());
  ex_put_coord(exoid, x.data(), y.data(), z.data());
  std::vector<int> conn;
  for (uint32_t v : box.tets) conn.push_back(static_cast<int>(v) + 1);
  ex_put_block(exoid, EX_ELEM_BLOCK, 1, "TETRA", static_cast<int64_t>(box.tet_count()), 4, 0, 0, 0);
  ex_put_conn(exoid, EX_ELEM_BLOCK, 1, conn.data(), nullptr, nullptr);
  std::vector<const char*> pointers;
  for (const auto& n : names) pointers.push_back(n.c_str());
  ex_put_variable_param(exoid, EX_NODAL, static_cast<int>(names.size()));
  ex_put_variable_names(exoid, EX_NODAL, static_cast<int>(names.size()), const_cast<char**>(pointers.data()));
  const double t = 1;
  ex_put_time(exoid, 1, &t);
  for (size_t v = 0; v < names.size(); ++v) {
    std::string suffix = names[v].substr(names[v].size() - 2);
    for (char& c : suffix) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
    std::vector<double> values;
    for (size_t i = 0; i < box.vertex_count(); ++i) {
      double value = suffix == "XX" ? 100 + 10 * box.x[i] : suffix == "YY" ? 20 : suffix == "ZZ" ? -5 : suffix == "XY" ? 3 * box.y[i] : suffix == "YZ" ? 1 : 2 * box.z[i];
      if (int(i) == bad_node && suffix == "XY") value = std::nan("");
      values.push_back(value);
    }
    ex_put_var(exoid, 1, EX_NODAL, static_cast<int>(v) + 1, 1, static_cast<int64_t>(values.size()), values.data());
  }
  ex_close(exoid);
}

TEST(Exodus, NodalVariablesNamedXXToZXAreOneSymmetricTensorWithItsDerivedScalars) {
  const auto path = scratch_dir("exodus_tensor") / "m.exo";
  write_exodus_tensor(path, {"stress_XX", "stress_YY", "stress_ZZ", "stress_XY", "stress_YZ", "stress_ZX", "temp"});
  const TetMesh m = storage::load_mesh(path);
  const storage::Attribute* stress = m.find_attribute("stress");
  ASSERT_NE(stress, nullptr);
  EXPECT_EQ(stress->info.kind, storage::AttributeKind::kTensor);
  EXPECT_EQ(stress->info.components, 6u);
  for (size_t i = 0; i < m.vertex_count(); ++i) {
    const float* t = &stress->values[6 * i];  // xx yy zz xy yz xz
    EXPECT_FLOAT_EQ(t[0], 100 + 10 * m.x[i]);
    EXPECT_FLOAT_EQ(t[1], 20);
    EXPECT_FLOAT_EQ(t[2], -5);
    EXPECT_FLOAT_EQ(t[3], 3 * m.y[i]);
    EXPECT_FLOAT_EQ(t[4], 1);
    EXPECT_FLOAT_EQ(t[5], 2 * m.z[i]);
  }
  const storage::Attribute* von_mises = m.find_attribute("stress.von_mises");
  ASSERT_NE(von_mises, nullptr);
  EXPECT_EQ(von_mises->info.kind, storage::AttributeKind::kTensorDerived);
  ASSERT_NE(m.find_attribute("temp"), nullptr) << "the seventh variable stays a scalar";
  EXPECT_EQ(m.find_attribute("stress_XX"), nullptr);
  // lower case, another order, XZ for ZX and no underscore
  write_exodus_tensor(path, {"sigxz", "sigyy", "sigxx", "sigzz", "sigyz", "sigxy"});
  const TetMesh n = storage::load_mesh(path);
  const storage::Attribute* sig = n.find_attribute("sig");
  ASSERT_NE(sig, nullptr);
  EXPECT_EQ(sig->info.kind, storage::AttributeKind::kTensor);
  for (size_t i = 0; i < n.vertex_count(); ++i) EXPECT_FLOAT_EQ(sig->values[6 * i], 100 + 10 * n.x[i]) << "xx first";
}

TEST(HostileExodus, ANonFiniteTensorComponentIsRefusedNamingTheTensorAndNode) {
  const auto path = scratch_dir("exodus_tensor_nan") / "m.exo";
  write_exodus_tensor(path, {"stress_XX", "stress_YY", "stress_ZZ", "stress_XY", "stress_YZ", "stress_ZX"}, 4);
  const std::string error = mesh_read_error(path);
  EXPECT_NE(error.find("nodal tensor 'stress': node 5, component xy"), std::string::npos) << error;
}

TEST(HostileExodus, SixNamesThatAreNotOneTensorStayScalars) {
  const auto path = scratch_dir("exodus_tensor_not") / "m.exo";
  // a repeated suffix, and a base that changes: no tensor, six scalars
  write_exodus_tensor(path, {"s_XX", "s_XX", "s_ZZ", "s_XY", "s_YZ", "s_ZX"});
  const TetMesh m = storage::load_mesh(path);
  for (const auto& a : m.attributes) EXPECT_NE(a.info.kind, storage::AttributeKind::kTensor) << a.info.name;
  write_exodus_tensor(path, {"a_XX", "a_YY", "a_ZZ", "b_XY", "b_YZ", "b_ZX"});
  for (const auto& a : storage::load_mesh(path).attributes) EXPECT_NE(a.info.kind, storage::AttributeKind::kTensor) << a.info.name;
}

// ---- time steps: one file, several steps ------------------------------------------------

// The fields of the steps file: nodal "temp" and "vel_x/y/z" (one vector), element "heat".
double temp_at(int step, double x, double y, double z) { return (step + 1) * x + 2 * y - z + 0.5 * step; }
std::array<double, 3> vel_at(int step, double x, double y, double z) { return {x * step, y - step, 3 * z}; }
double heat_at(int step, size_t tet) { return 10.0 * step + double(tet % 7); }

// A Kuhn box of 6^3 cubes in one TETRA block with the fields above at `times` (steps 0, 1,
// ... as listed in `steps`: the file's step k holds the fields of step steps[k]). `poison`:
// the node of step 1 whose temp is NaN (none when negative).
void write_exodus_steps(const std::filesystem::path& path, const std::vector<double>& times, const std::vector<int>& steps, int poison = -1) {
  const TetMesh m = kuhn_box(6, 0.3, [](double, double, double) { return 0.0; });
  int word = 8, io_word = 8;
  const int exoid = ex_create(path.c_str(), EX_CLOBBER, &word, &io_word);
  ASSERT_GE(exoid, 0);
  const int64_t nodes = static_cast<int64_t>(m.vertex_count()), tets = static_cast<int64_t>(m.tet_count());
  ex_put_init(exoid, "steps", 3, nodes, tets, 1, 0, 0);
  std::vector<double> x(m.x.begin(), m.x.end()), y(m.y.begin(), m.y.end()), z(m.z.begin(), m.z.end());
  ex_put_coord(exoid, x.data(), y.data(), z.data());
  std::vector<int> conn;
  for (uint32_t v : m.tets) conn.push_back(static_cast<int>(v) + 1);
  ex_put_block(exoid, EX_ELEM_BLOCK, 1, "TETRA", tets, 4, 0, 0, 0);
  ex_put_conn(exoid, EX_ELEM_BLOCK, 1, conn.data(), nullptr, nullptr);
  const char* nodal[] = {"temp", "vel_x", "vel_y", "vel_z"};
  const char* element[] = {"heat"};
  ex_put_variable_param(exoid, EX_NODAL, 4);
  ex_put_variable_names(exoid, EX_NODAL, 4, const_cast<char**>(nodal));
  ex_put_variable_param(exoid, EX_ELEM_BLOCK, 1);
  ex_put_variable_names(exoid, EX_ELEM_BLOCK, 1, const_cast<char**>(element));
  for (size_t k = 0; k < times.size(); ++k) {
    const int file_step = static_cast<int>(k) + 1, s = steps[k];
    ex_put_time(exoid, file_step, &times[k]);
    for (int v = 0; v < 4; ++v) {
      std::vector<double> values;
      for (size_t i = 0; i < m.vertex_count(); ++i) values.push_back(v == 0 ? temp_at(s, x[i], y[i], z[i]) : vel_at(s, x[i], y[i], z[i])[size_t(v - 1)]);
      if (v == 0 && s == 1 && poison >= 0) values[size_t(poison)] = std::nan("");
      ex_put_var(exoid, file_step, EX_NODAL, v + 1, 1, nodes, values.data());
    }
    std::vector<double> heat;
    for (size_t t = 0; t < m.tet_count(); ++t) heat.push_back(heat_at(s, t));
    ex_put_var(exoid, file_step, EX_ELEM_BLOCK, 1, 1, tets, heat.data());
  }
  ex_close(exoid);
}

const std::string kSmallBuild = " --base-tets 300 --segment-tets 512 --progress none --threads 1";

TEST(ExodusSteps, WithoutAllStepsTheLastStepIsReadAndInfoAndTheWarningNameAllSteps) {
  const auto path = scratch_dir("exodus_steps_last") / "m.exo";
  write_exodus_steps(path, {0, 0.5, 1.25}, {0, 1, 2});
  auto stream = storage::MeshStream::open(path);
  EXPECT_EQ(stream->header().step_times, (std::vector<double>{0, 0.5, 1.25}));
  ASSERT_FALSE(stream->stats().warnings.empty());
  EXPECT_NE(stream->stats().warnings[0].find("3 time steps: the last (step 3 of 3, t = 1.25) is read (preprocess --all-steps reads them all)"), std::string::npos)
      << stream->stats().warnings[0];
  const storage::MeshSummary summary = storage::summarize_mesh(path);
  EXPECT_EQ(storage::summary_json(summary)["step_times"], nlohmann::json::parse("[0, 0.5, 1.25]"));
  const std::string text = storage::summary_text(summary);
  EXPECT_NE(text.find("time steps  3, t = 0 .. 1.25 (one read; preprocess --all-steps makes a series of them all)"), std::string::npos) << text;
  const TetMesh last = storage::load_stream(*stream);
  const storage::Attribute* temp = last.find_attribute("temp");
  ASSERT_NE(temp, nullptr);
  for (size_t v = 0; v < last.vertex_count(); ++v) EXPECT_NEAR(temp->values[v], temp_at(2, last.x[v], last.y[v], last.z[v]), 1e-5);
  // a step chosen by number, and one past the last refused
  storage::ReadLimits limits;
  limits.time_step = 1;
  const TetMesh second = storage::load_mesh(path, nullptr, limits);
  for (size_t v = 0; v < second.vertex_count(); ++v) EXPECT_NEAR(second.find_attribute("temp")->values[v], temp_at(1, second.x[v], second.y[v], second.z[v]), 1e-5);
  expect_step_refused(path, 3, "m.exo: Exodus II: time step 3 asked for, the file holds 3 (0..2)");
}

TEST(ExodusSteps, AllStepsMakesOneStoreOfEveryStepWithItsTimesAndValues) {
  const auto dir = scratch_dir("exodus_steps_store");
  const std::vector<double> times{0, 0.5, 1.25};
  write_exodus_steps(dir / "m.exo", times, {0, 1, 2});
  const nlohmann::json listed = all_steps_listed(dir / "m.exo", dir / "s.store", kSmallBuild);
  ASSERT_EQ(listed.size(), 3u) << listed.dump();
  const TetMesh m = kuhn_box(6, 0.3, [](double, double, double) { return 0.0; });
  for (int s = 0; s < 3; ++s) {
    EXPECT_DOUBLE_EQ(listed[s]["time"].get<double>(), times[size_t(s)]);
    EXPECT_EQ(listed[s]["name"], "m.exo step " + std::to_string(s));
    double lo = INFINITY, hi = -INFINITY;
    for (size_t v = 0; v < m.vertex_count(); ++v) lo = std::min(lo, temp_at(s, m.x[v], m.y[v], m.z[v])), hi = std::max(hi, temp_at(s, m.x[v], m.y[v], m.z[v]));
    EXPECT_NEAR(listed[s]["ranges"][0][0].get<double>(), lo, 1e-5) << "step " << s;
    EXPECT_NEAR(listed[s]["ranges"][0][1].get<double>(), hi, 1e-5) << "step " << s;
  }
  EXPECT_EQ(run_cli("verify " + (dir / "s.store").string(), 120).status, 0);
  // the stored values of steps 1 and 2 at the input's vertices: the nodal fields as written,
  // the element field as a file of that step alone is converted at ingest
  const auto store = storage::Store::open(dir / "s.store");
  const auto steps = storage::TimeSteps::open(*store);
  ASSERT_NE(steps, nullptr);
  ASSERT_EQ(store->manifest().attributes.size(), 3u);
  EXPECT_EQ(store->manifest().attributes[2].name, "heat");
  const uint32_t floats = steps->layout().floats;
  ASSERT_EQ(floats, 5u);
  ASSERT_EQ(steps->layout().input_vertices, m.vertex_count());
  for (int s = 1; s < 3; ++s) {
    write_exodus_steps(dir / "alone.exo", {times[size_t(s)]}, {s});
    const TetMesh alone = storage::load_mesh(dir / "alone.exo");
    const storage::Attribute* heat = alone.find_attribute("heat");
    ASSERT_NE(heat, nullptr);
    const auto values = steps->values(static_cast<uint32_t>(s));
    size_t wrong = 0;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      const float* row = values->data() + v * floats;
      const auto vel = vel_at(s, m.x[v], m.y[v], m.z[v]);
      wrong += std::abs(row[0] - temp_at(s, m.x[v], m.y[v], m.z[v])) > 1e-5;
      for (int c = 0; c < 3; ++c) wrong += std::abs(row[1 + c] - vel[size_t(c)]) > 1e-5;
      wrong += std::abs(row[4] - heat->values[v]) > 1e-5;
    }
    EXPECT_EQ(wrong, 0u) << "step " << s;
  }
  // the steps differ: step 2's heat is 20 more than step 0's everywhere
  EXPECT_NEAR(listed[2]["ranges"][2][0].get<double>() - listed[0]["ranges"][2][0].get<double>(), 20, 1e-4);
}

TEST(HostileExodusSteps, ANonFiniteValueOfAStepIsRefusedNamingTheFileAndStepAndLeavesNoStore) {
  const auto dir = scratch_dir("exodus_steps_nan");
  std::filesystem::remove_all(dir / "n.store");
  write_exodus_steps(dir / "m.exo", {0, 1, 2}, {0, 1, 2}, 17);
  const CliResult r = run_cli("preprocess " + (dir / "m.exo").string() + " -o " + (dir / "n.store").string() + " --all-steps" + kSmallBuild, 300);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("m.exo, time step 1): attribute 'temp' at vertex 17 is nan"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("every value of every step of a series must be finite"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "n.store"));
  EXPECT_FALSE(std::filesystem::exists(dir / "n.store.series"));
}

TEST(HostileExodusSteps, TimesThatDoNotIncreaseAndAFileOfOneStepAreRefusedBeforeAnythingIsBuilt) {
  const auto dir = scratch_dir("exodus_steps_times");
  write_exodus_steps(dir / "back.exo", {0, 2, 1}, {0, 1, 2});
  try {
    storage::series_inputs({(dir / "back.exo").string()}, true);
    ADD_FAILURE() << "times out of order were taken";
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("back.exo: time step 2 (t = 1.000000) is not after step 1 (t = 2.000000)"), std::string::npos) << e.what();
  }
  write_exodus_steps(dir / "one.exo", {0.5}, {0});
  const CliResult r = run_cli("preprocess " + (dir / "one.exo").string() + " -o " + (dir / "one.store").string() + " --all-steps" + kSmallBuild, 60);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("one.exo: holds fewer than two time steps: --all-steps needs two or more"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "one.store"));
}

}  // namespace
}  // namespace tetrascope::testing
