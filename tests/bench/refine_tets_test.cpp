// bench/refine_tets: the 1:8 refinement is conforming, keeps the volume, orients
// every child positively, numbers one midpoint an edge, evaluates the analytic field of
// ../shared/data/make/analytic_field.py at every vertex, writes the same bytes twice, and
// refuses bad input without leaving a file behind. The readers (load_mesh, `tetrascope info`)
// must accept what it writes.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <utility>

#include "cli_run.h"
#include "fixture_writers.h"
#include "mesh_checks.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/vtk_writer.h"

namespace tetrascope::testing {
namespace {

namespace fs = std::filesystem;

CliResult run_refine(const std::string& args) {
  const std::string command = std::string(TETRA_REFINE_TETS) + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
  return {WEXITSTATUS(pclose(pipe)), out};
}

size_t edge_count(const storage::TetMesh& mesh) {
  std::set<std::pair<uint32_t, uint32_t>> edges;
  for (size_t t = 0; t < mesh.tet_count(); ++t)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) {
        uint32_t a = mesh.tets[4 * t + i], b = mesh.tets[4 * t + j];
        edges.insert({std::min(a, b), std::max(a, b)});
      }
  return edges.size();
}

size_t boundary_faces(const MeshCheck& check) {
  size_t faces = 0;
  for (const auto& [face, uses] : check.face_uses) faces += uses == 1;
  return faces;
}

// The field as the docstring of analytic_field.py states it, written out independently.
struct Expected {
  double f, grad[3];
};
Expected docstring_field(const double x[3], const double c[3], double length) {
  const double a[3][3] = {{0.15, 0.10, 0.25}, {-0.20, -0.10, -0.15}, {0.0, 0.05, -0.30}};
  const double amplitude[3] = {1.0, 0.7, -0.5}, width[3] = {0.02, 0.05, 0.01};
  const double pi = std::numbers::pi;
  double u[3];
  for (int i = 0; i < 3; ++i) u[i] = (x[i] - c[i]) / length;
  Expected e{0, {0, 0, 0}};
  for (int k = 0; k < 3; ++k) {
    double r2 = 0;
    for (int i = 0; i < 3; ++i) r2 += (u[i] - a[k][i]) * (u[i] - a[k][i]);
    double g = amplitude[k] * std::exp(-r2 / width[k]);
    e.f += g;
    for (int i = 0; i < 3; ++i) e.grad[i] += -2 * (u[i] - a[k][i]) / width[k] * g / length;  // d/dx = d/du / L
  }
  e.f += 0.25 * std::sin(6 * pi * u[0]) * std::sin(4 * pi * u[1]) * std::cos(5 * pi * u[2]);
  e.grad[0] += 0.25 * 6 * pi * std::cos(6 * pi * u[0]) * std::sin(4 * pi * u[1]) * std::cos(5 * pi * u[2]) / length;
  e.grad[1] += 0.25 * 4 * pi * std::sin(6 * pi * u[0]) * std::cos(4 * pi * u[1]) * std::cos(5 * pi * u[2]) / length;
  e.grad[2] += -0.25 * 5 * pi * std::sin(6 * pi * u[0]) * std::sin(4 * pi * u[1]) * std::sin(5 * pi * u[2]) / length;
  return e;
}

// A jittered box of 6 * 5^3 tets, stretched so that the bounding box is not a cube, with a
// linear field "f" that the midpoint average reproduces exactly.
storage::TetMesh small_box() {
  storage::TetMesh mesh = kuhn_box(5, 0.4, [](double x, double y, double z) { return x + 2 * y + 3 * z; });
  for (float& x : mesh.x) x = 3 * x + 1;
  for (float& z : mesh.z) z = 2 * z - 5;
  for (size_t v = 0; v < mesh.vertex_count(); ++v) mesh.attributes[0].values[v] = mesh.x[v] + 2 * mesh.y[v] + 3 * mesh.z[v];
  return mesh;
}

TEST(RefineTets, BoxIsConformingPositiveAndKeepsTheVolume) {
  const fs::path dir = scratch_dir("refine_tets");
  const storage::TetMesh in = small_box();
  storage::write_vtk(dir / "box.vtk", in, "jittered box");
  CliResult r = run_refine((dir / "box.vtk").string() + " " + (dir / "box8.vtk").string());
  ASSERT_EQ(r.status, 0) << r.out;
  auto report = nlohmann::json::parse(r.out.substr(r.out.find('{'), r.out.find('\n', r.out.find('{')) - r.out.find('{')));

  storage::ReadStats stats;
  const storage::TetMesh out = storage::load_mesh(dir / "box8.vtk", &stats);
  const size_t edges = edge_count(in);
  EXPECT_EQ(out.tet_count(), 8 * in.tet_count());
  EXPECT_EQ(out.vertex_count(), in.vertex_count() + edges);
  EXPECT_EQ(report["output_vertices"], in.vertex_count() + edges);
  EXPECT_EQ(report["edges"], edges);
  EXPECT_EQ(stats.inverted, 0u) << "the reader had to re-orient children";
  EXPECT_EQ(stats.degenerate, 0u);
  EXPECT_EQ(report["children_flipped"], 0);
  // the input vertices come first, unchanged
  for (size_t v = 0; v < in.vertex_count(); ++v) ASSERT_EQ(out.x[v], in.x[v]);

  const MeshCheck before = check_mesh(in), after = check_mesh(out);
  EXPECT_EQ(after.nonpositive, 0u);
  EXPECT_EQ(after.faces_shared_by_more_than_two, 0u);
  EXPECT_EQ(boundary_faces(after), 4 * boundary_faces(before));  // each boundary triangle in 4, no holes
  EXPECT_NEAR(after.volume, before.volume, 1e-6 * before.volume);

  // "f" is carried over linearly: exact for a linear field (to float rounding)
  const storage::Attribute* f = out.find_attribute("f");
  const storage::Attribute* analytic = out.find_attribute("analytic_f");
  const storage::Attribute* gradient = out.find_attribute("analytic_grad");
  ASSERT_TRUE(f && analytic && gradient);
  ASSERT_EQ(gradient->info.components, 3u);
  double lo[3] = {1e30, 1e30, 1e30}, hi[3] = {-1e30, -1e30, -1e30};
  for (size_t v = 0; v < in.vertex_count(); ++v) {
    const double x[3] = {in.x[v], in.y[v], in.z[v]};
    for (int i = 0; i < 3; ++i) lo[i] = std::min(lo[i], x[i]), hi[i] = std::max(hi[i], x[i]);
  }
  const double centre[3] = {(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, (lo[2] + hi[2]) / 2};
  const double length = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
  ASSERT_EQ(length, 3.0);
  for (size_t v = 0; v < out.vertex_count(); ++v) {
    const double x[3] = {out.x[v], out.y[v], out.z[v]};
    ASSERT_NEAR(f->values[v], x[0] + 2 * x[1] + 3 * x[2], 1e-5) << "vertex " << v;
    const Expected e = docstring_field(x, centre, length);
    ASSERT_NEAR(analytic->values[v], e.f, 1e-6) << "vertex " << v;
    for (int i = 0; i < 3; ++i) ASSERT_NEAR(gradient->values[3 * v + i], e.grad[i], 1e-5) << "vertex " << v;
  }
}

TEST(RefineTets, SameInputSameBytes) {
  const fs::path dir = scratch_dir("refine_tets");
  storage::write_vtk(dir / "box.vtk", small_box(), "jittered box");
  ASSERT_EQ(run_refine((dir / "box.vtk").string() + " " + (dir / "a.vtk").string()).status, 0);
  ASSERT_EQ(run_refine((dir / "box.vtk").string() + " " + (dir / "b.vtk").string()).status, 0);
  EXPECT_TRUE(read_file(dir / "a.vtk") == read_file(dir / "b.vtk"));
  for (const auto& entry : fs::directory_iterator(dir))
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos) << entry.path();
}

// The bundled sample (real CFD data, 7 arrays), every field linear; `tetrascope info` reads it.
TEST(RefineTets, SampleLinearFieldsReadBack) {
  const fs::path dir = scratch_dir("refine_tets");
  const storage::TetMesh in = storage::load_mesh(sample_mesh());
  CliResult r = run_refine(sample_mesh().string() + " " + (dir / "disk8.vtk").string() + " --field linear");
  ASSERT_EQ(r.status, 0) << r.out;

  storage::ReadStats stats;
  const storage::TetMesh out = storage::load_mesh(dir / "disk8.vtk", &stats);
  const size_t edges = edge_count(in);
  EXPECT_EQ(out.tet_count(), 8 * in.tet_count());
  EXPECT_EQ(out.vertex_count(), in.vertex_count() + edges);
  EXPECT_EQ(stats.inverted, 0u);
  EXPECT_EQ(stats.degenerate, 0u);
  ASSERT_EQ(out.attributes.size(), in.attributes.size());
  EXPECT_EQ(out.find_attribute("analytic_f"), nullptr);
  double volume_in = 0, volume_out = 0;
  size_t nonpositive = 0;
  for (size_t t = 0; t < in.tet_count(); ++t) volume_in += storage::signed_volume(in, in.tets[4 * t], in.tets[4 * t + 1], in.tets[4 * t + 2], in.tets[4 * t + 3]);
  for (size_t t = 0; t < out.tet_count(); ++t) {
    double v = storage::signed_volume(out, out.tets[4 * t], out.tets[4 * t + 1], out.tets[4 * t + 2], out.tets[4 * t + 3]);
    nonpositive += v <= 0;
    volume_out += v;
  }
  EXPECT_EQ(nonpositive, 0u);
  EXPECT_NEAR(volume_out, volume_in, 1e-6 * volume_in);
  // every value at a midpoint lies between the input's extremes (it is an average)
  for (size_t a = 0; a < in.attributes.size(); ++a) {
    const auto& before = in.attributes[a].values;
    const auto& after = out.attributes[a].values;
    ASSERT_EQ(after.size(), before.size() / in.vertex_count() * out.vertex_count());
    auto [lo, hi] = std::minmax_element(before.begin(), before.end());
    auto [lo8, hi8] = std::minmax_element(after.begin(), after.end());
    EXPECT_GE(*lo8, *lo);
    EXPECT_LE(*hi8, *hi);
  }

  CliResult info = run_cli("info --json " + (dir / "disk8.vtk").string());
  ASSERT_EQ(info.status, 0) << info.out;
  auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["tetrahedra"], 8 * in.tet_count());
  EXPECT_EQ(j["vertices"], in.vertex_count() + edges);
  EXPECT_EQ(j["quality"]["inverted"], 0);
  EXPECT_EQ(j["attributes"].size(), 7u);
}

TEST(RefineTets, RefusesBadInputAndLeavesNothing) {
  const fs::path dir = scratch_dir("refine_tets");
  const std::string out = (dir / "out.vtk").string();

  CliResult missing = run_refine((dir / "nope.vtk").string() + " " + out);
  EXPECT_EQ(missing.status, 1);
  EXPECT_NE(missing.out.find("nope.vtk"), std::string::npos) << missing.out;

  storage::write_vtk(dir / "box.vtk", small_box(), "jittered box");
  std::string bytes = read_file(dir / "box.vtk");
  write_file(dir / "cut.vtk", bytes.substr(0, bytes.size() / 2));
  CliResult cut = run_refine((dir / "cut.vtk").string() + " " + out);
  EXPECT_EQ(cut.status, 1);
  EXPECT_NE(cut.out.find("cut.vtk"), std::string::npos) << cut.out;

  write_file(dir / "points.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 1 float\n0 0 0\nCELLS 0 0\nCELL_TYPES 0\n");
  CliResult empty = run_refine((dir / "points.vtk").string() + " " + out);
  EXPECT_EQ(empty.status, 1);
  EXPECT_NE(empty.out.find("no tetrahedra"), std::string::npos) << empty.out;

  EXPECT_EQ(run_refine((dir / "box.vtk").string()).status, 2);
  EXPECT_EQ(run_refine((dir / "box.vtk").string() + " " + out + " --field cubic").status, 2);
  EXPECT_EQ(run_refine((dir / "box.vtk").string() + " " + (dir / "box.vtk").string()).status, 2);
  for (const auto& entry : fs::directory_iterator(dir)) {
    EXPECT_NE(entry.path().filename(), "out.vtk");
    EXPECT_EQ(entry.path().string().find(".tmp-"), std::string::npos) << entry.path();
  }
}

}  // namespace
}  // namespace tetrascope::testing
