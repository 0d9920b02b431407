// Untrusted input: truncated files, flipped bytes, absurd counts, bad indices, NaNs,
// unknown cell types. Each must give a MeshError naming the file, never a crash, a hang or
// an allocation driven by a claimed count. Run under ASan+UBSan in CI (preset "asan").
#include <gtest/gtest.h>

#include <sys/stat.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <future>
#include <random>

#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

using storage::MeshError;
using storage::MeshFormat;

// Reads fully; returns "" on success or the MeshError text. Any other exception fails.
std::string try_read(MeshFormat format, const std::string& name, const std::string& bytes, const std::string& second = {}) {
  try {
    auto stream = storage::MeshStream::open_memory(format, name, bytes, second);
    storage::VertexChunk v;
    while (stream->next_vertices(v, 777)) {
    }
    storage::TetChunk t;
    while (stream->next_tets(t, 999)) {
    }
    return "";
  } catch (const MeshError& e) {
    return e.what();
  }
}

CellMesh small_mesh() {
  CellMesh m;
  const int n = 3;
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        m.x.push_back(static_cast<float>(i));
        m.y.push_back(static_cast<float>(j) * 1.5f);
        m.z.push_back(static_cast<float>(k) * 0.5f);
      }
  auto at = [&](int i, int j, int k) { return static_cast<uint32_t>((k * (n + 1) + j) * (n + 1) + i); };
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        // 5-tet split with alternating parity: conforming
        uint32_t c[8] = {at(i, j, k), at(i + 1, j, k), at(i + 1, j + 1, k), at(i, j + 1, k),
                         at(i, j, k + 1), at(i + 1, j, k + 1), at(i + 1, j + 1, k + 1), at(i, j + 1, k + 1)};
        if ((i + j + k) % 2) {
          m.add_cell(10, {c[0], c[1], c[3], c[4]});
          m.add_cell(10, {c[1], c[2], c[3], c[6]});
          m.add_cell(10, {c[1], c[4], c[5], c[6]});
          m.add_cell(10, {c[3], c[4], c[6], c[7]});
          m.add_cell(10, {c[1], c[3], c[4], c[6]});
        } else {
          m.add_cell(12, {c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]});
        }
      }
  storage::Attribute t{{"temperature", 1}, {}}, v{{"velocity", 3}, {}};
  for (size_t i = 0; i < m.x.size(); ++i) {
    t.values.push_back(m.x[i] * m.y[i]);
    v.values.insert(v.values.end(), {m.z[i], -m.x[i], 1.0f});
  }
  m.attributes = {t, v};
  return m;
}

struct Sample {
  std::string name;
  MeshFormat format;
  std::string bytes, second;
};

void PrintTo(const Sample& s, std::ostream* os) { *os << s.name; }

std::vector<Sample> samples() {
  CellMesh m = small_mesh();
  // tets only, for formats without hybrid cells
  auto dir = scratch_dir("hostile_samples");
  write_vtk_legacy(dir / "h.vtk", m);
  CellMesh tets = from_tets(storage::load_mesh(dir / "h.vtk"));
  std::vector<Sample> s;
  auto add = [&](const std::string& name, MeshFormat format, const std::string& file) {
    s.push_back({name, format, read_file(dir / file), ""});
  };
  write_vtk_legacy(dir / "a.vtk", m, {.binary = false});
  add("vtk_ascii", MeshFormat::kVtkLegacy, "a.vtk");
  write_vtk_legacy(dir / "b.vtk", m, {.binary = true});
  add("vtk_binary", MeshFormat::kVtkLegacy, "b.vtk");
  write_vtk_legacy(dir / "c.vtk", m, {.binary = true, .version5 = true});
  add("vtk51_binary", MeshFormat::kVtkLegacy, "c.vtk");
  write_vtu(dir / "a.vtu", m, {.encoding = VtuEncoding::kAscii});
  add("vtu_ascii", MeshFormat::kVtu, "a.vtu");
  write_vtu(dir / "b.vtu", m, {.encoding = VtuEncoding::kInlineBase64, .zlib = true, .block_size = 256});
  add("vtu_base64_zlib", MeshFormat::kVtu, "b.vtu");
  write_vtu(dir / "c.vtu", m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true, .block_size = 256});
  add("vtu_raw_zlib", MeshFormat::kVtu, "c.vtu");
  write_vtu(dir / "d.vtu", m, {.encoding = VtuEncoding::kAppendedRaw, .header_uint64 = false});
  add("vtu_raw", MeshFormat::kVtu, "d.vtu");
  write_gmsh(dir / "a.msh", m, {.version4 = false, .binary = false});
  add("msh22_ascii", MeshFormat::kGmsh, "a.msh");
  write_gmsh(dir / "b.msh", m, {.version4 = false, .binary = true});
  add("msh22_binary", MeshFormat::kGmsh, "b.msh");
  write_gmsh(dir / "c.msh", m, {.version4 = true, .binary = false});
  add("msh41_ascii", MeshFormat::kGmsh, "c.msh");
  write_gmsh(dir / "d.msh", m, {.version4 = true, .binary = true});
  add("msh41_binary", MeshFormat::kGmsh, "d.msh");
  write_off(dir / "a.off", tets);
  add("off", MeshFormat::kOff, "a.off");
  write_tetgen(dir / "t", tets);
  s.push_back({"tetgen", MeshFormat::kTetgen, read_file(dir / "t.node"), read_file(dir / "t.ele")});
  return s;
}

class Hostile : public ::testing::TestWithParam<Sample> {};

TEST_P(Hostile, IntactSampleReads) {
  const Sample& s = GetParam();
  EXPECT_EQ(try_read(s.format, s.name, s.bytes, s.second), "");
}

TEST_P(Hostile, TruncationsFailCleanly) {
  const Sample& s = GetParam();
  const std::string& bytes = s.bytes;
  size_t rejected = 0, tried = 0;
  for (size_t cut = 0; cut < bytes.size(); cut += std::max<size_t>(1, bytes.size() / 150)) {
    std::string error = try_read(s.format, s.name, bytes.substr(0, cut), s.second);
    ++tried;
    if (!error.empty()) {
      ++rejected;
      EXPECT_EQ(error.rfind(s.name + ":", 0), 0u) << "error does not name the file: " << error;
    }
  }
  // cutting a file in half must always be noticed
  EXPECT_NE(try_read(s.format, s.name, bytes.substr(0, bytes.size() / 2), s.second), "");
  EXPECT_GT(rejected, tried * 8 / 10);
  if (!s.second.empty()) {
    EXPECT_NE(try_read(s.format, s.name, s.bytes, s.second.substr(0, s.second.size() / 2)), "");
  }
}

TEST_P(Hostile, FlippedBytesNeverCrash) {
  const Sample& s = GetParam();
  std::mt19937 rng(12345);
  for (int round = 0; round < 300; ++round) {
    std::string bytes = s.bytes, second = s.second;
    std::string& target = (!second.empty() && round % 2) ? second : bytes;
    int flips = 1 + round % 4;
    for (int f = 0; f < flips; ++f) {
      size_t at = rng() % target.size();
      target[at] = static_cast<char>(target[at] ^ static_cast<char>(1 + rng() % 255));
    }
    try_read(s.format, s.name, bytes, second);  // only MeshError may come out
  }
}

INSTANTIATE_TEST_SUITE_P(AllFormats, Hostile, ::testing::ValuesIn(samples()), [](const auto& test_info) { return test_info.param.name; });

// ---- specific threats, each with the message a user needs ------------------------------

void expect_error(MeshFormat format, const std::string& bytes, const std::string& fragment, const std::string& second = {}) {
  std::string error = try_read(format, "bad", bytes, second);
  ASSERT_NE(error, "") << "accepted hostile input";
  EXPECT_NE(error.find(fragment), std::string::npos) << "message was: " << error;
  EXPECT_EQ(error.rfind("bad", 0), 0u) << error;
}

const std::string kVtkHead = "# vtk DataFile Version 3.0\nt\nASCII\nDATASET UNSTRUCTURED_GRID\n";

TEST(HostileVtk, ClaimsATrillionPointsInASmallFile) {
  expect_error(MeshFormat::kVtkLegacy, kVtkHead + "POINTS 1000000000000 float\n0 0 0\n", "declared");
  std::string binary = "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 999999999 float\n";
  expect_error(MeshFormat::kVtkLegacy, binary + std::string(64, '\0'), "declared");
}
TEST(HostileVtk, WrongMagic) { expect_error(MeshFormat::kVtkLegacy, "# not vtk\n", "not a VTK legacy file"); }
TEST(HostileVtk, VertexIndexOutOfRange) {
  expect_error(MeshFormat::kVtkLegacy, kVtkHead + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 7\nCELL_TYPES 1\n10\n",
               "vertex id 7 out of range");
}
TEST(HostileVtk, NanCoordinateNamesTheLine) {
  expect_error(MeshFormat::kVtkLegacy, kVtkHead + "POINTS 4 float\n0 0 0\n1 nan 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
               "line 7: point coordinate is not a finite number");
}
TEST(HostileVtk, UnknownCellType) {
  expect_error(MeshFormat::kVtkLegacy, kVtkHead + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n99\n",
               "unsupported cell type 99");
}
TEST(HostileVtk, WrongVertexCountForTetra) {
  expect_error(MeshFormat::kVtkLegacy, kVtkHead + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 4\n3 0 1 2\nCELL_TYPES 1\n10\n",
               "unsupported cell type 10 with 3 vertices");
}
TEST(HostileVtk, MissingAttributeArrayData) {
  expect_error(MeshFormat::kVtkLegacy,
               kVtkHead + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 4\nSCALARS t float 1\nLOOKUP_TABLE default\n1 2\n",
               "SCALARS 't': 4 declared");
}
TEST(HostileVtk, PointDataCountDisagreesWithPoints) {
  expect_error(MeshFormat::kVtkLegacy,
               kVtkHead + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\nPOINT_DATA 5\n",
               "POINT_DATA has 5 values but POINTS has 4");
}
TEST(HostileVtk, BinaryCellDataWithoutWhitespaceIsNotTokenised) {
  // Regression: the reader looked for a 5.1 OFFSETS keyword by reading a token, which ran into
  // binary cell data. Ids 0..3 as big-endian int32 hold no whitespace byte at all.
  std::string vtk = "# vtk DataFile Version 3.0\nt\nBINARY\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n";
  auto put32 = [&](uint32_t v) {
    for (int k = 3; k >= 0; --k) vtk += static_cast<char>((v >> (8 * k)) & 0xFF);
  };
  const float points[12] = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  for (float f : points) {
    uint32_t u;
    std::memcpy(&u, &f, 4);
    put32(u);
  }
  const int cells = 3000;
  vtk += "\nCELLS " + std::to_string(cells) + " " + std::to_string(5 * cells) + "\n";
  for (int c = 0; c < cells; ++c) {
    put32(4);
    for (uint32_t v : {0u, 1u, 2u, 3u}) put32(v);
  }
  vtk += "\nCELL_TYPES " + std::to_string(cells) + "\n";
  for (int c = 0; c < cells; ++c) put32(10);
  vtk += "\nPOINT_DATA 4\nSCALARS s float\nLOOKUP_TABLE default\n";
  for (int i = 0; i < 4; ++i) put32(0x3F800000u);  // 1.0f: no whitespace bytes either
  vtk += "\n";
  EXPECT_EQ(try_read(MeshFormat::kVtkLegacy, "cells.vtk", vtk), "");
  auto stream = storage::MeshStream::open_memory(MeshFormat::kVtkLegacy, "cells.vtk", vtk);
  EXPECT_EQ(storage::load_stream(*stream).tet_count(), static_cast<size_t>(cells));
}
TEST(HostileVtk, NotAVolumeDataset) {
  expect_error(MeshFormat::kVtkLegacy, "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n", "not a volume mesh");
}

TEST(HostileVtu, ClaimsHugePointCount) {
  expect_error(MeshFormat::kVtu,
               "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"1000000000000\" NumberOfCells=\"1\">",
               "does not fit");
}
TEST(HostileVtu, AppendedOffsetPastTheEnd) {
  CellMesh m = small_mesh();
  auto dir = scratch_dir("vtu_offset");
  write_vtu(dir / "m.vtu", m, {.encoding = VtuEncoding::kAppendedRaw});
  std::string bytes = read_file(dir / "m.vtu");
  size_t at = bytes.find("offset=\"0\"");
  ASSERT_NE(at, std::string::npos);
  bytes.replace(at, 10, "offset=\"99999999\"");
  expect_error(MeshFormat::kVtu, bytes, "past the end");
}
TEST(HostileVtu, CorruptZlibBlock) {
  CellMesh m = small_mesh();
  auto dir = scratch_dir("vtu_zlib");
  write_vtu(dir / "m.vtu", m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true});
  std::string bytes = read_file(dir / "m.vtu");
  size_t data = bytes.find(">\n_") + 3;
  // first array: header of 3 + blocks UInt64 items; damage the deflate stream after it
  bytes[data + 40] = static_cast<char>(bytes[data + 40] ^ 0x5a);
  bytes[data + 41] = static_cast<char>(bytes[data + 41] ^ 0xa5);
  expect_error(MeshFormat::kVtu, bytes, "corrupt");
}
TEST(HostileVtu, EmptyClosingTagFoundByFuzzer) {
  expect_error(MeshFormat::kVtu, "<VTKFile type=\"UnstructuredGrid\"></>", "empty XML tag");
}
TEST(HostileVtu, UnsupportedCompressor) {
  expect_error(MeshFormat::kVtu, "<VTKFile type=\"UnstructuredGrid\" compressor=\"vtkLZ4DataCompressor\">", "not supported");
}

TEST(HostileGmsh, ClaimsHugeNodeCount) {
  expect_error(MeshFormat::kGmsh, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n5000000000\n1 0 0 0\n", "declared");
}
TEST(HostileGmsh, ElementRefersToMissingNode) {
  expect_error(MeshFormat::kGmsh,
               "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n"
               "$Elements\n1\n1 4 0 1 2 3 42\n$EndElements\n",
               "refers to node 42, which is not in $Nodes");
}
TEST(HostileGmsh, UnknownElementType) {
  expect_error(MeshFormat::kGmsh,
               "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n$EndNodes\n"
               "$Elements\n1\n1 77 0 1 2 3 4\n$EndElements\n",
               "unknown Gmsh element type 77");
}
TEST(HostileGmsh, UnsupportedVersion) { expect_error(MeshFormat::kGmsh, "$MeshFormat\n3.0 0 8\n$EndMeshFormat\n", "not supported"); }

TEST(HostileOff, ClaimsHugeCounts) { expect_error(MeshFormat::kOff, "100000000000 5\n0 0 0 1\n", "declared"); }
TEST(HostileOff, IndexOutOfRange) {
  expect_error(MeshFormat::kOff, "4 1\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n0 1 2 4\n", "vertex index 4 out of range");
}

TEST(HostileTetgen, NodeOutOfRange) {
  expect_error(MeshFormat::kTetgen, "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 1\n", "node 5 out of range", "1 4 0\n1 1 2 3 5\n");
}
TEST(HostileTetgen, NonConsecutiveNumbering) {
  expect_error(MeshFormat::kTetgen, "3 3 0 0\n1 0 0 0\n2 1 0 0\n9 0 1 0\n", "numbered consecutively", "0 4 0\n");
}

TEST(HostileFiles, MissingFileAndUnknownExtension) {
  try {
    storage::MeshStream::open("/nonexistent/mesh.vtk");
    FAIL() << "opened a missing file";
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos);
  }
  EXPECT_THROW(storage::MeshStream::open("mesh.stl"), MeshError);
}

// ---- values that are finite as doubles but not as the stored float ----------

const std::string kTetLines = "0 1 2 3\n";
TEST(HostileOff, CoordinateThatOverflowsFloatIsRefused) {
  expect_error(MeshFormat::kOff, "4 1\n0 0 0\n1e39 0 0\n0 1 0\n0 0 1\n" + kTetLines,
               "line 3: vertex 1: coordinate 1e+39 is not a finite 32-bit float");
  expect_error(MeshFormat::kOff, "4 1\n0 0 0\n1 0 0\n0 -3.5e38 0\n0 0 1\n" + kTetLines, "line 4: vertex 2: coordinate -3.5e+38");
}
TEST(HostileTetgen, CoordinateThatOverflowsFloatIsRefused) {
  expect_error(MeshFormat::kTetgen, "4 3 0 0\n1 0 0 0\n2 1 0 0\n3 0 1e39 0\n4 0 0 1\n",
               "line 4: point 3: coordinate 1e+39 is not a finite 32-bit float", "1 4 0\n1 1 2 3 4\n");
}
TEST(HostileGmsh, CoordinateThatOverflowsFloatIsRefused) {
  expect_error(MeshFormat::kGmsh,
               "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n4\n1 0 0 0\n2 1 0 0\n3 0 1 0\n4 0 0 -1e39\n$EndNodes\n"
               "$Elements\n1\n1 4 0 1 2 3 4\n$EndElements\n",
               "line 9: node 4: coordinate -1e+39 is not a finite 32-bit float");
}
TEST(HostileVtk, CoordinateThatOverflowsFloatIsRefused) {
  expect_error(MeshFormat::kVtkLegacy, kVtkHead + "POINTS 4 double\n0 0 0\n1e39 0 0\n0 1 0\n0 0 1\nCELLS 1 5\n4 0 1 2 3\nCELL_TYPES 1\n10\n",
               "line 7: point coordinate is not a finite number");
}
TEST(HostileVtu, CoordinateThatOverflowsFloatIsRefused) {
  expect_error(MeshFormat::kVtu,
               "<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">"
               "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1e39 0 0 0 1 0 0 0 1</DataArray></Points>"
               "<Cells><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>"
               "<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">4</DataArray>"
               "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10</DataArray></Cells></Piece></UnstructuredGrid></VTKFile>\n",
               "point coordinate is not a finite number");
}
// ASCII values written right against the closing tag ("1.5</DataArray>", as some writers do)
// are values, not a malformed number.
TEST(HostileVtu, AsciiValuesRightBeforeTheClosingTagRead) {
  auto stream = storage::MeshStream::open_memory(
      MeshFormat::kVtu, "a.vtu",
      std::string("<VTKFile type=\"UnstructuredGrid\"><UnstructuredGrid><Piece NumberOfPoints=\"4\" NumberOfCells=\"1\">"
                  "<PointData><DataArray type=\"Float32\" Name=\"f\" format=\"ascii\">0 1 2 1.5</DataArray></PointData>"
                  "<Points><DataArray type=\"Float64\" NumberOfComponents=\"3\" format=\"ascii\">0 0 0 1 0 0 0 1 0 0 0 1</DataArray></Points>"
                  "<Cells><DataArray type=\"Int32\" Name=\"connectivity\" format=\"ascii\">0 1 2 3</DataArray>"
                  "<DataArray type=\"Int32\" Name=\"offsets\" format=\"ascii\">4</DataArray>"
                  "<DataArray type=\"UInt8\" Name=\"types\" format=\"ascii\">10</DataArray></Cells></Piece></UnstructuredGrid></VTKFile>\n"));
  const storage::TetMesh mesh = storage::load_stream(*stream);
  ASSERT_EQ(mesh.tet_count(), 1u);
  ASSERT_EQ(mesh.attributes.size(), 1u);
  EXPECT_FLOAT_EQ(mesh.attributes[0].values[3], 1.5f);
  EXPECT_FLOAT_EQ(mesh.y[2], 1.0f);
}
// Attributes are kept, and a value a float cannot hold counts as non-finite (as `info` reports
// it), so ranges and the manifest skip it instead of holding infinity or null.
TEST(HostileOff, AttributeThatOverflowsFloatCountsAsNonFinite) {
  auto stream = storage::MeshStream::open_memory(MeshFormat::kOff, "a.off", std::string("4 1\n0 0 0 1\n1 0 0 1e39\n0 1 0 2\n0 0 1 nan\n" + kTetLines));
  storage::load_stream(*stream);
  EXPECT_EQ(stream->stats().nonfinite_attribute_values, 2u);
}
TEST(HostileTetgen, AttributeThatOverflowsFloatCountsAsNonFinite) {
  auto stream = storage::MeshStream::open_memory(MeshFormat::kTetgen, "a", std::string("4 3 1 0\n1 0 0 0 1\n2 1 0 0 -1e40\n3 0 1 0 2\n4 0 0 1 3\n"),
                                                 std::string("1 4 0\n1 1 2 3 4\n"));
  storage::load_stream(*stream);
  EXPECT_EQ(stream->stats().nonfinite_attribute_values, 1u);
}

// ---- a tet that names a vertex twice has no faces: dropped and counted ------------------

TEST(HostileOff, TetThatRepeatsAVertexIsDroppedAndCounted) {
  const std::string off = "5 3\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n1 1 1\n0 1 2 3\n0 0 1 4\n1 2 3 4\n";
  auto stream = storage::MeshStream::open_memory(MeshFormat::kOff, "r.off", off);
  storage::TetMesh mesh = storage::load_stream(*stream);
  EXPECT_EQ(mesh.tet_count(), 2u);
  EXPECT_EQ(stream->stats().repeated_vertex, 1u);
  ASSERT_EQ(stream->stats().warnings.size(), 1u);
  EXPECT_NE(stream->stats().warnings[0].find("1 tetrahedra that repeat a vertex"), std::string::npos);
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    const uint32_t* v = mesh.tets.data() + 4 * t;
    EXPECT_TRUE(v[0] != v[1] && v[0] != v[2] && v[0] != v[3] && v[1] != v[2] && v[1] != v[3] && v[2] != v[3]);
  }
}
TEST(HostileVtk, ChunkOfOnlyRepeatedVertexTetsDoesNotEndTheStream) {
  // 3000 collapsed tets first, then one good one: the first chunks hold nothing to emit
  std::string vtk = kVtkHead + "POINTS 4 float\n0 0 0 1 0 0 0 1 0 0 0 1\nCELLS 3001 15005\n";
  for (int c = 0; c < 3000; ++c) vtk += "4 0 0 0 0\n";
  vtk += "4 0 1 2 3\nCELL_TYPES 3001\n";
  for (int c = 0; c < 3001; ++c) vtk += "10\n";
  auto stream = storage::MeshStream::open_memory(MeshFormat::kVtkLegacy, "c.vtk", vtk);
  storage::TetChunk chunk;
  uint64_t tets = 0;
  while (stream->next_tets(chunk, 500)) tets += chunk.count;
  EXPECT_EQ(tets, 1u);
  EXPECT_EQ(stream->stats().repeated_vertex, 3000u);
}

// ---- what one input may cost ------------------------------------------------------------

TEST(HostileVtu, DecompressionBombIsRefusedBeforeAllocating) {
  // one tet and 8 million unused points at the origin: ~100 KB compressed, 96 MB inflated
  const size_t points = 8'000'000;
  const CellMesh m = one_tet_and_unused_points(points);
  auto dir = scratch_dir("vtu_bomb");
  write_vtu(dir / "bomb.vtu", m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true, .block_size = 1 << 20});
  ASSERT_LT(std::filesystem::file_size(dir / "bomb.vtu"), 1'000'000u);
  try {
    storage::MeshStream::open(dir / "bomb.vtu");
    FAIL() << "a decompression bomb was accepted";
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("bomb.vtu: its compressed arrays inflate to 96000"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("--max-inflate-ratio"), std::string::npos) << e.what();
  }
  // the limit is an option: a generous ratio admits the same file
  storage::ReadLimits generous;
  generous.max_inflate_ratio = 2000;
  EXPECT_EQ(storage::MeshStream::open(dir / "bomb.vtu", generous)->header().vertex_count, points);
}
TEST(HostileVtu, WellCompressedSmallFileIsWithinTheAllowance) {
  // at the limit: small files inflate freely up to the fixed allowance
  CellMesh m = small_mesh();
  auto dir = scratch_dir("vtu_small");
  write_vtu(dir / "m.vtu", m, {.encoding = VtuEncoding::kAppendedRaw, .zlib = true});
  storage::ReadLimits strict;
  strict.max_inflate_ratio = 1;
  EXPECT_EQ(storage::load_mesh(dir / "m.vtu", nullptr, strict).vertex_count(), m.x.size());
}
TEST(HostileMesh, UnusedPointsAreDropped) {
  storage::TetMesh mesh;
  mesh.x = {9, 0, 1, 9, 0, 0};
  mesh.y = {9, 0, 0, 9, 1, 0};
  mesh.z = {9, 0, 0, 9, 0, 1};
  storage::Attribute values;
  values.info.name = "v";
  values.values = {90, 0, 1, 93, 4, 5};
  mesh.attributes.push_back(values);
  mesh.tets = {1, 2, 4, 5};
  EXPECT_EQ(storage::drop_unused_vertices(mesh), 2u);
  EXPECT_EQ(mesh.x, (std::vector<float>{0, 1, 0, 0}));
  EXPECT_EQ(mesh.z, (std::vector<float>{0, 0, 0, 1}));
  EXPECT_EQ(mesh.attributes[0].values, (std::vector<float>{0, 1, 4, 5}));
  EXPECT_EQ(mesh.tets, (std::vector<uint32_t>{0, 1, 2, 3}));
  EXPECT_EQ(storage::drop_unused_vertices(mesh), 0u);
}

// ---- inputs that are not regular files --------------------------------------------------

TEST(HostileFiles, FifoNamedAsAMeshDoesNotBlockOpen) {
  auto dir = scratch_dir("fifo");
  const auto fifo = dir / "mesh.vtk";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto opened = std::async(std::launch::async, [&] {
    try {
      storage::MeshStream::open(fifo);
      return std::string("opened");
    } catch (const MeshError& e) {
      return std::string(e.what());
    }
  });
  if (opened.wait_for(std::chrono::seconds(5)) != std::future_status::ready) {
    int unblock = ::open(fifo.c_str(), O_WRONLY | O_NONBLOCK);  // lets the blocked open() return
    opened.wait();
    if (unblock >= 0) ::close(unblock);
    FAIL() << "open() blocked on a FIFO";
  }
  EXPECT_NE(opened.get().find("not a regular file"), std::string::npos);
}
TEST(HostileFiles, SymlinkToDevZeroIsRefused) {
  auto dir = scratch_dir("devzero");
  std::filesystem::create_symlink("/dev/zero", dir / "mesh.off");
  try {
    storage::MeshStream::open(dir / "mesh.off");
    FAIL() << "opened /dev/zero";
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("not a regular file"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tetrascope::testing
