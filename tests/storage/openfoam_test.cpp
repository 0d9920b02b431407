// OpenFOAM cases written here the way OpenFOAM writes them (ASCII and binary, faceList and
// faceCompactList, gzip): a pentagonal prism (a general polyhedron), a hexahedron and a
// pyramid; the polyhedron decomposed about its centre so that the whole mesh conforms; the
// latest time folder's fields arriving at the vertices by cell volume; damaged cases refused.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>

#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/storage/mesh_info.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/series.h"

namespace tetrascope::testing {
namespace {

using storage::TetMesh;

struct Case {
  std::vector<std::array<double, 3>> points;
  std::vector<std::vector<int>> faces;  // internal faces first
  std::vector<int> owner, neighbour;
  std::vector<double> volumes;  // per cell
};

// cell 0: a pentagonal prism (pentagon of area 3, height 1); cell 1: a hexahedron (2×1×1) on
// its side y = 0; cell 2: a pyramid (base 2, height 1) on the hexahedron's top.
Case three_cells() {
  Case c;
  const double pentagon[5][2] = {{0, 0}, {2, 0}, {2, 1}, {1, 2}, {0, 1}};
  for (double z : {0.0, 1.0})
    for (auto& p : pentagon) c.points.push_back({p[0], p[1], z});
  for (auto p : {std::array<double, 3>{0, -1, 0}, {2, -1, 0}, {2, -1, 1}, {0, -1, 1}, {1, -0.5, 2}}) c.points.push_back(p);
  // 0..9 the prism, 10..13 the hexahedron's far side, 14 the apex
  c.faces = {{0, 1, 6, 5}, {5, 6, 12, 13},                                           // internal
             {0, 4, 3, 2, 1}, {5, 6, 7, 8, 9}, {1, 2, 7, 6}, {2, 3, 8, 7}, {3, 4, 9, 8}, {4, 0, 5, 9},  // prism
             {0, 10, 11, 1}, {10, 13, 12, 11}, {0, 5, 13, 10}, {1, 11, 12, 6},      // hexahedron
             {5, 14, 6}, {6, 14, 12}, {12, 14, 13}, {13, 14, 5}};                   // pyramid
  c.owner = {0, 1, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2};
  c.neighbour = {1, 2};
  c.volumes = {3, 2, 2.0 / 3};
  return c;
}

std::string header(const std::string& cls, const std::string& object, bool binary) {
  return "/*--------------------------------*- C++ -*----------------------------------*\\\n  =========  OpenFOAM\n\\*---------------------------------------------------------------------------*/\nFoamFile\n{\n    version     2.0;\n    format      " +
         std::string(binary ? "binary" : "ascii") + ";\n    arch        \"LSB;label=32;scalar=64\";\n    class       " + cls + ";\n    location    \"constant/polyMesh\";\n    object      " + object +
         ";\n}\n// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //\n\n";
}

template <typename T>
std::string bytes_of(const std::vector<T>& v) {
  return std::string(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
}

std::string label_list(const std::vector<int>& v, bool binary) {
  std::string out = std::to_string(v.size()) + "\n(";
  if (binary) return out + bytes_of(v) + ")\n";
  for (int x : v) out += std::to_string(x) + "\n";
  return out + ")\n";
}

void write_gz(const std::filesystem::path& path, const std::string& bytes) {
  gzFile f = gzopen(path.c_str(), "wb");
  gzwrite(f, bytes.data(), static_cast<unsigned>(bytes.size()));
  gzclose(f);
}

// Writes the case; fields p (1, 5, 9) and U ((1 0 0), (0 5 0), (0 0 9)) at time 0.5, and
// uniform -1 at time 0 (a folder the reader passes over).
void write_case(const std::filesystem::path& dir, const Case& c, bool binary, bool gz_points = false) {
  const auto mesh = dir / "constant" / "polyMesh";
  std::filesystem::create_directories(mesh);
  std::filesystem::create_directories(dir / "0");
  std::filesystem::create_directories(dir / "0.5");
  std::string points = header("vectorField", "points", binary) + std::to_string(c.points.size()) + "\n(";
  if (binary) {
    std::vector<double> flat;
    for (auto& p : c.points) flat.insert(flat.end(), p.begin(), p.end());
    points += bytes_of(flat);
  } else {
    for (auto& p : c.points) {
      points += '(';
      for (int k = 0; k < 3; ++k) points.append(std::to_string(p[static_cast<size_t>(k)])).append(k < 2 ? " " : ")\n");
    }
  }
  points += ")\n";
  if (gz_points) write_gz(mesh / "points.gz", points);
  else write_file(mesh / "points", points);
  if (binary) {  // faceCompactList: offsets, then the points
    std::vector<int> offsets{0}, flat;
    for (auto& f : c.faces) {
      flat.insert(flat.end(), f.begin(), f.end());
      offsets.push_back(static_cast<int>(flat.size()));
    }
    write_file(mesh / "faces", header("faceCompactList", "faces", true) + label_list(offsets, true) + "\n" + label_list(flat, true));
  } else {
    std::string faces = header("faceList", "faces", false) + std::to_string(c.faces.size()) + "\n(\n";
    for (auto& f : c.faces) {
      faces.append(std::to_string(f.size())).append("(");
      for (size_t k = 0; k < f.size(); ++k) faces.append(k ? " " : "").append(std::to_string(f[k]));
      faces.append(")\n");
    }
    write_file(mesh / "faces", faces + ")\n");
  }
  write_file(mesh / "owner", header("labelList", "owner", binary) + label_list(c.owner, binary));
  write_file(mesh / "neighbour", header("labelList", "neighbour", binary) + label_list(c.neighbour, binary));
  write_file(mesh / "boundary", header("polyBoundaryMesh", "boundary", false) + "0\n(\n)\n");
  const std::string dims = "dimensions      [0 2 -2 0 0 0 0];\n\n";
  write_file(dir / "0" / "p", header("volScalarField", "p", false) + dims + "internalField   uniform -1;\n\nboundaryField\n{\n}\n");
  std::string p = header("volScalarField", "p", binary) + dims + "internalField   nonuniform List<scalar> 3(";
  std::string u = header("volVectorField", "U", binary) + dims + "internalField   nonuniform List<vector> 3(";
  if (binary) {
    p += bytes_of(std::vector<double>{1, 5, 9});
    u += bytes_of(std::vector<double>{1, 0, 0, 0, 5, 0, 0, 0, 9});
  } else {
    p += "1 5 9";
    u += "(1 0 0) (0 5 0) (0 0 9)";
  }
  const std::string boundary = ");\n\nboundaryField\n{\n    walls { type zeroGradient; }\n}\n";
  write_file(dir / "0.5" / "p", p + boundary);
  write_file(dir / "0.5" / "U", u + boundary);
  write_file(dir / "case.foam", "");
}

double tet_volume(const TetMesh& m, size_t t) {
  const uint32_t* v = &m.tets[4 * t];
  double a[3], b[3], c[3];
  for (int k = 0; k < 3; ++k) {
    const float* axis = k == 0 ? m.x.data() : k == 1 ? m.y.data() : m.z.data();
    a[k] = axis[v[1]] - axis[v[0]];
    b[k] = axis[v[2]] - axis[v[0]];
    c[k] = axis[v[3]] - axis[v[0]];
  }
  return (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0])) / 6;
}

class OpenFoam : public ::testing::TestWithParam<bool> {};

TEST_P(OpenFoam, APolyhedronAHexahedronAndAPyramidReadConformingWithTheLatestFieldsAtTheVertices) {
  const bool binary = GetParam();
  const Case c = three_cells();
  const auto dir = scratch_dir(binary ? "openfoam_binary" : "openfoam_ascii");
  write_case(dir, c, binary, /*gz_points=*/binary);
  storage::ReadStats stats;
  const TetMesh mesh = storage::load_mesh(dir / "case.foam", &stats);
  // 15 points, the prism's centre and its two pentagons' centres
  EXPECT_EQ(mesh.vertex_count(), 18u);
  // prism: 2 pentagons of 5 tets, 5 quads of 2; hexahedron 6; pyramid 2
  EXPECT_EQ(mesh.tet_count(), 28u);
  EXPECT_EQ(stats.cells, 3u);
  EXPECT_EQ(stats.polyhedra, 1u);
  double volume = 0;
  for (size_t t = 0; t < mesh.tet_count(); ++t) {
    EXPECT_GT(tet_volume(mesh, t), 1e-6) << "tet " << t;
    volume += tet_volume(mesh, t);
  }
  EXPECT_NEAR(volume, 3 + 2 + 2.0 / 3, 1e-5);
  // conforming: every triangle is shared by two tets or lies on the boundary (30 of them)
  std::map<std::array<uint32_t, 3>, int> triangles;
  for (size_t t = 0; t < mesh.tet_count(); ++t)
    for (int skip = 0; skip < 4; ++skip) {
      std::array<uint32_t, 3> f{};
      for (int k = 0, n = 0; k < 4; ++k)
        if (k != skip) f[static_cast<size_t>(n++)] = mesh.tets[4 * t + static_cast<size_t>(k)];
      std::sort(f.begin(), f.end());
      ++triangles[f];
    }
  int boundary = 0;
  for (auto& [f, n] : triangles) {
    EXPECT_LE(n, 2);
    boundary += n == 1;
  }
  EXPECT_EQ(boundary, 30);
  // the latest time (0.5), by cell volume: point 0 lies in the prism (3, p 1) and the
  // hexahedron (2, p 5); point 14 only in the pyramid; point 3 only in the prism
  ASSERT_EQ(mesh.attributes.size(), 2u);
  EXPECT_EQ(mesh.attributes[0].info.name, "U");
  EXPECT_EQ(mesh.attributes[1].info.name, "p");
  const auto& p = mesh.attributes[1].values;
  EXPECT_NEAR(p[0], (3 * 1 + 2 * 5) / 5.0, 1e-5);
  EXPECT_NEAR(p[5], (3 * 1 + 2 * 5 + 2.0 / 3 * 9) / (5 + 2.0 / 3), 1e-5);
  EXPECT_NEAR(p[14], 9, 1e-6);
  EXPECT_NEAR(p[3], 1, 1e-6);
  EXPECT_NEAR(mesh.attributes[0].values[3 * 14 + 2], 9, 1e-6);
}

INSTANTIATE_TEST_SUITE_P(Encodings, OpenFoam, ::testing::Values(false, true), [](const auto& test) { return test.param ? "binary" : "ascii"; });

TEST(OpenFoamCase, TheCaseFolderItselfOpensAndInfoSaysWhatItRead) {
  const auto dir = scratch_dir("openfoam_folder");
  write_case(dir, three_cells(), false);
  const auto s = storage::summarize_mesh(dir);
  const nlohmann::json j = storage::summary_json(s);
  EXPECT_EQ(j["format"], "openfoam");
  EXPECT_EQ(j["cells"]["polyhedra"], 1);
  EXPECT_NE(s.header.description.find("time 0.5"), std::string::npos) << s.header.description;
}

// A time folder (CASE/TIME) reads as the case with that time's fields (a uniform value in a
// binary file too), and a case's time folders that hold fields are a time series' steps, in
// time order.
TEST(OpenFoamCase, ATimeFolderReadsThatTimesFieldsAndTheCaseListsItsTimesAsSteps) {
  const auto dir = scratch_dir("openfoam_times");
  write_case(dir, three_cells(), false);
  std::filesystem::create_directories(dir / "2");  // a time folder without a field: no step
  // a binary field file whose internalField is uniform: the value is text (as OpenFOAM writes it)
  write_file(dir / "0" / "p", header("volScalarField", "p", true) + "dimensions      [0 2 -2 0 0 0 0];\n\ninternalField   uniform -1;\n\nboundaryField\n{\n}\n");
  EXPECT_EQ(storage::format_from_path(dir / "0"), storage::MeshFormat::kOpenFoam);
  const TetMesh first = storage::load_mesh(dir / "0");
  ASSERT_NE(first.find_attribute("p"), nullptr);
  EXPECT_EQ(first.find_attribute("U"), nullptr) << "the 0 folder holds p alone";
  for (float v : first.find_attribute("p")->values) EXPECT_FLOAT_EQ(v, -1.0f);
  const TetMesh later = storage::load_mesh(dir / "0.5");
  ASSERT_NE(later.find_attribute("U"), nullptr);
  const auto& p = later.find_attribute("p")->values;
  EXPECT_GE(*std::min_element(p.begin(), p.end()), 1.0f);
  EXPECT_LE(*std::max_element(p.begin(), p.end()), 9.0f);
  EXPECT_EQ(later.tet_count(), first.tet_count());
  const auto steps = storage::series_inputs({dir.string()}, true);
  ASSERT_EQ(steps.size(), 2u);
  EXPECT_EQ(steps[0].name, "0");
  EXPECT_EQ(steps[1].name, "0.5");
  EXPECT_DOUBLE_EQ(steps[1].time, 0.5);
  EXPECT_TRUE(storage::series_inputs({(dir / "case.foam").string()}, false).empty()) << "one case without --all-steps is one step";
}

TEST(OpenFoamCase, AllStepsOfAFileThatIsNoCaseIsRefusedNamingWhatItReads) {
  const auto dir = scratch_dir("openfoam_all_steps_file");
  std::ofstream(dir / "mesh.vtk") << "# vtk DataFile Version 3.0\n";
  try {
    storage::series_inputs({(dir / "mesh.vtk").string()}, true);
    FAIL() << "accepted";
  } catch (const storage::MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("mesh.vtk: --all-steps reads the time steps of an Exodus II, Gmsh or CGNS file or an OpenFOAM case's time folders; give the steps of vtk files as files"), std::string::npos) << e.what();
  }
}

TEST(SeriesInputs, NumbersInNamesOrderAFileSeries) {
  EXPECT_TRUE(storage::natural_less("step_2.vtu", "step_10.vtu"));
  EXPECT_FALSE(storage::natural_less("step_10.vtu", "step_2.vtu"));
  EXPECT_TRUE(storage::natural_less("a_002.vtu", "a_3.vtu"));
  EXPECT_TRUE(storage::natural_less("run1_t9.vtu", "run2_t1.vtu"));
  EXPECT_FALSE(storage::natural_less("same.vtu", "same.vtu"));
}

// polyMesh/boundary with the three cells' boundary faces in three patches (the order OpenFOAM
// writes them: name, then a dictionary with type, inGroups, nFaces and startFace).
std::string three_patches(int prism_faces = 6) {
  auto patch = [](const std::string& name, int n, int start) {
    return "    " + name + "\n    {\n        type            wall;\n        inGroups        List<word> 1(wall);\n        nFaces          " + std::to_string(n) +
           ";\n        startFace       " + std::to_string(start) + ";\n    }\n";
  };
  return header("polyBoundaryMesh", "boundary", false) + "3\n(\n" + patch("prism", prism_faces, 2) + patch("hexahedron", 4, 8) + patch("apex", 4, 12) + ")\n";
}

// Each patch's faces arrive as triangles cut as the tets are (the pentagons fanned about their
// centres, the quads by the diagonal through their smallest point), so that every boundary face
// of the tets carries its patch's name.
TEST(OpenFoamCase, BoundaryPatchesTagEveryBoundaryFaceOfTheTetsByName) {
  const auto dir = scratch_dir("openfoam_patches");
  write_case(dir, three_cells(), false);
  write_file(dir / "constant" / "polyMesh" / "boundary", three_patches());
  const TetMesh mesh = storage::load_mesh(dir);
  const storage::FaceTags& tags = mesh.face_tags;
  ASSERT_EQ(tags.names, (std::vector<std::string>{"prism", "hexahedron", "apex"}));
  std::map<uint32_t, size_t> per_tag;
  std::map<std::array<uint32_t, 3>, uint32_t> tag_of;
  for (size_t t = 0; t < tags.triangles.size(); ++t) {
    ++per_tag[tags.tags[t]];
    auto key = tags.triangles[t];
    std::sort(key.begin(), key.end());
    tag_of[key] = tags.tags[t];
  }
  EXPECT_EQ(per_tag[0], 18u) << "two pentagons of five triangles and four quads of two";
  EXPECT_EQ(per_tag[1], 8u);
  EXPECT_EQ(per_tag[2], 4u);
  std::map<uint32_t, size_t> boundary_per_tag;
  for (auto face : boundary_faces(mesh.tets)) {
    std::sort(face.begin(), face.end());
    const auto it = tag_of.find(face);
    ASSERT_NE(it, tag_of.end()) << "a boundary face of the tets has no patch";
    ++boundary_per_tag[it->second];
  }
  EXPECT_EQ(boundary_per_tag, per_tag) << "every tagged triangle is a boundary face of the tets";
  const auto s = storage::summarize_mesh(dir);
  const nlohmann::json j = storage::summary_json(s);
  EXPECT_EQ(j["regions_source"], "input tags");
  ASSERT_EQ(j["face_tags"].size(), 3u);
  EXPECT_EQ(j["face_tags"][0]["name"], "prism");
  EXPECT_EQ(j["face_tags"][0]["triangles"], 18);
}

TEST(HostileOpenFoam, APatchPastTheFacesOrWithoutItsCountsIsRefusedNamingIt) {
  const auto dir = scratch_dir("openfoam_bad_patch");
  write_case(dir, three_cells(), false);
  const auto boundary = dir / "constant" / "polyMesh" / "boundary";
  write_file(boundary, three_patches(99));
  EXPECT_NE(mesh_read_error(dir).find("patch 'prism' names faces 2..101"), std::string::npos) << mesh_read_error(dir);
  std::string text = three_patches();
  text.replace(text.find("nFaces          6;"), 18, "");
  write_file(boundary, text);
  EXPECT_NE(mesh_read_error(dir).find("patch 'prism' has no nFaces or startFace"), std::string::npos) << mesh_read_error(dir);
  text = three_patches();
  text.replace(text.find("nFaces          6;"), 18, "nFaces          x6;");
  write_file(boundary, text);
  EXPECT_NE(mesh_read_error(dir).find("is not a count"), std::string::npos) << mesh_read_error(dir);
}

TEST(HostileOpenFoam, AFaceNamingAPointPastThePointsIsRefused) {
  Case c = three_cells();
  c.faces[3][2] = 99;
  const auto dir = scratch_dir("openfoam_bad_point");
  write_case(dir, c, false);
  EXPECT_NE(mesh_read_error(dir).find("names point 99 of 15"), std::string::npos) << mesh_read_error(dir);
}

TEST(HostileOpenFoam, AnOwnerListShorterThanTheFacesIsRefused) {
  Case c = three_cells();
  c.owner.pop_back();
  const auto dir = scratch_dir("openfoam_short_owner");
  write_case(dir, c, true);
  EXPECT_NE(mesh_read_error(dir).find("owner has 15 entries for 16 faces"), std::string::npos) << mesh_read_error(dir);
}

TEST(HostileOpenFoam, ABinaryListCutShortAndAHugeCountAreRefused) {
  const auto dir = scratch_dir("openfoam_cut");
  write_case(dir, three_cells(), true);
  const auto faces = dir / "constant" / "polyMesh" / "neighbour";
  std::string text = read_file(faces);
  write_file(faces, text.substr(0, text.size() - 6));
  EXPECT_NE(mesh_read_error(dir).find("ends inside the binary list"), std::string::npos) << mesh_read_error(dir);
  const auto points = dir / "constant" / "polyMesh" / "owner";
  text = read_file(points);
  text.replace(text.find("16\n("), 2, "99999999999");
  write_file(points, text);
  EXPECT_NE(mesh_read_error(dir).find("does not fit in the file"), std::string::npos) << mesh_read_error(dir);
}

// solidDisplacementFoam's sigma (volSymmTensorField, OpenFOAM's order XX XY XZ YY YZ ZZ) and a
// velocity gradient (volTensorField, row-major) arrive as symmetric tensors in VTK's order.
TEST(OpenFoamCase, SymmetricAndFullTensorFieldsArriveAsTensors) {
  for (bool binary : {false, true}) {
    const auto dir = scratch_dir(binary ? "openfoam_tensors_binary" : "openfoam_tensors_ascii");
    write_case(dir, three_cells(), binary);
    const std::string dims = "dimensions      [1 -1 -2 0 0 0 0];\n\n";
    const std::string boundary = "\n\nboundaryField\n{\n}\n";
    write_file(dir / "0.5" / "sigma", header("volSymmTensorField", "sigma", false) + dims + "internalField   uniform (1 2 3 4 5 6);" + boundary);
    std::string grad = header("volTensorField", "gradU", binary) + dims + "internalField   nonuniform List<tensor> 3(";
    const std::vector<double> rows = {1, 2, 0, 4, 1, 0, 0, 0, 1, 1, 2, 0, 4, 1, 0, 0, 0, 1, 1, 2, 0, 4, 1, 0, 0, 0, 1};
    if (binary) {
      grad += bytes_of(rows);
    } else {
      for (int c = 0; c < 3; ++c) grad += "(1 2 0 4 1 0 0 0 1) ";
    }
    write_file(dir / "0.5" / "gradU", grad + ");" + boundary);
    storage::ReadStats stats;
    const TetMesh mesh = storage::load_mesh(dir / "case.foam", &stats);
    const storage::Attribute* sigma = mesh.find_attribute("sigma");
    const storage::Attribute* gradient = mesh.find_attribute("gradU");
    ASSERT_TRUE(sigma && gradient);
    EXPECT_EQ(sigma->info.kind, storage::AttributeKind::kTensor);
    const float expected[6] = {1, 4, 6, 2, 5, 3};
    for (size_t v = 0; v < mesh.vertex_count(); ++v)
      for (int k = 0; k < 6; ++k) EXPECT_NEAR(sigma->values[6 * v + size_t(k)], expected[k], 1e-5) << "vertex " << v;
    EXPECT_NEAR(gradient->values[3], 3, 1e-5) << "xy = (2 + 4) / 2";
    EXPECT_NE(mesh.find_attribute("sigma.von_mises"), nullptr);
    bool warned = false;
    for (const std::string& w : stats.warnings) warned |= w.find("tensor 'gradU' is not symmetric (largest |A_ij - A_ji| / 2 = 1") != std::string::npos;
    EXPECT_TRUE(warned) << ::testing::PrintToString(stats.warnings);
  }
}

TEST(HostileOpenFoam, ATensorWithFiveComponentsOrAnInfiniteValueNamesTheField) {
  const auto dir = scratch_dir("openfoam_bad_tensor");
  write_case(dir, three_cells(), false);
  const std::string dims = "dimensions      [1 -1 -2 0 0 0 0];\n\n";
  write_file(dir / "0.5" / "sigma", header("volSymmTensorField", "sigma", false) + dims + "internalField   uniform (1 2 3 4 5);\n");
  std::string error = mesh_read_error(dir);
  EXPECT_NE(error.find("sigma"), std::string::npos) << error;
  EXPECT_NE(error.find("line"), std::string::npos) << error;
  write_file(dir / "0.5" / "sigma", header("volSymmTensorField", "sigma", false) + dims + "internalField   nonuniform List<symmTensor> 3((1 0 0 1 0 1) (1 0 0 1e39 0 1) (1 0 0 1 0 1));\n");
  error = mesh_read_error(dir);
  EXPECT_NE(error.find("tensor 'sigma': value 1 is not a finite 32-bit float"), std::string::npos) << error;
}

TEST(HostileOpenFoam, AFolderWithoutAMeshIsNotACase) {
  const auto dir = scratch_dir("openfoam_none");
  std::filesystem::create_directories(dir / "constant");
  write_file(dir / "case.foam", "");
  EXPECT_NE(mesh_read_error(dir / "case.foam").find("not an OpenFOAM case"), std::string::npos) << mesh_read_error(dir / "case.foam");
}

}  // namespace
}  // namespace tetrascope::testing
