// Stream lines (lod/field/streamlines.cpp) on Kuhn-split boxes with analytic per-vertex fields,
// and `tetrascope streamlines` on the sample mesh.
#include "tetrascope/lod/field/streamlines.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mesh_checks.h"
#include "tetrascope/core/tet_topology.h"
#include "cli_run.h"
#include "test_paths.h"

namespace tetrascope::testing {
namespace {

using lod::StopReason;

// A box mesh with a vector attribute "v" = field(x, y, z) at every vertex.
template <class Field>
storage::TetMesh box_with_field(int n, double jitter, Field field) {
  storage::TetMesh m = kuhn_box(n, jitter, [](double x, double, double) { return x; });
  storage::Attribute v{{"v", 3}, {}};
  for (size_t i = 0; i < m.vertex_count(); ++i) {
    Vec3 f = field(m.x[i], m.y[i], m.z[i]);
    for (double c : f) v.values.push_back(static_cast<float>(c));
  }
  m.attributes.push_back(v);
  return m;
}

struct Traced {
  storage::TetMesh mesh;
  std::vector<uint32_t> opposite;
  lod::Streamlines lines;
};

Vec3 point(const lod::Streamlines& s, size_t i) { return {s.x[i], s.y[i], s.z[i]}; }

template <class Field>
Traced trace(int n, Field field, std::vector<Vec3> seeds, const lod::StreamlineOptions& o, double jitter = 0.3) {
  Traced t{box_with_field(n, jitter, field), {}, {}};
  t.opposite = pair_faces(t.mesh.tets).opposite;
  lod::StreamlineTracer tracer(t.mesh, t.opposite, "v");
  t.lines = tracer.trace(std::span<const Vec3>(seeds), o);
  return t;
}

TEST(Streamlines, RigidRotationGivesCirclesThatStopByLength) {
  // v = (-(y - c), x - c, 0) about the box's axis: circles of constant radius
  auto rotation = [](double x, double y, double) { return Vec3{-(y - 0.5), x - 0.5, 0}; };
  lod::StreamlineOptions o;
  o.direction = lod::StreamDirection::forward;
  o.max_length = 2 * 3.14159265358979 * 0.3 * 1.5;  // one and a half turns
  o.tolerance = 1e-3;
  auto t = trace(10, rotation, {{0.8, 0.5, 0.5}, {0.5, 0.25, 0.3}}, o);
  ASSERT_EQ(t.lines.line_count(), 2u);
  const double radii[2] = {0.3, 0.25};
  for (size_t l = 0; l < 2; ++l) {
    double worst = 0, turned = 0;
    for (uint32_t i = t.lines.line_first[l]; i < t.lines.line_first[l + 1]; ++i) {
      const Vec3 p = point(t.lines, i);
      worst = std::max(worst, std::abs(std::hypot(p[0] - 0.5, p[1] - 0.5) - radii[l]));
      EXPECT_NEAR(p[2], l == 0 ? 0.5 : 0.3, 1e-5);
      if (i > t.lines.line_first[l]) turned += length(p - point(t.lines, i - 1));
    }
    EXPECT_LT(worst, 0.01 * radii[l]) << "line " << l;  // radius kept within 1 % over 1.5 turns
    EXPECT_GT(turned, 2 * 3.14159 * radii[l]);           // a full turn at least
  }
  EXPECT_EQ(t.lines.stops[size_t(StopReason::max_length)], 2u);  // bounded: no endless orbit
}

TEST(Streamlines, ClosedOrbitStopsAtTheStepLimit) {
  auto rotation = [](double x, double y, double) { return Vec3{-(y - 0.5), x - 0.5, 0}; };
  lod::StreamlineOptions o;
  o.direction = lod::StreamDirection::both;
  o.max_steps = 50;
  o.max_length = 1e9;
  auto t = trace(6, rotation, {{0.7, 0.5, 0.5}}, o);
  ASSERT_EQ(t.lines.line_count(), 1u);
  EXPECT_EQ(t.lines.stops[size_t(StopReason::max_steps)], 2u);
  EXPECT_EQ(t.lines.point_count(), 2 * 50u + 1);
}

TEST(Streamlines, UniformFieldGivesStraightLinesEndingOnTheBoundary) {
  auto uniform = [](double, double, double) { return Vec3{1, 0.5, 0}; };
  lod::StreamlineOptions o;
  o.direction = lod::StreamDirection::both;
  auto t = trace(8, uniform, {{0.3, 0.3, 0.4}, {0.5, 0.2, 0.9}}, o);
  ASSERT_EQ(t.lines.line_count(), 2u);
  EXPECT_EQ(t.lines.stops[size_t(StopReason::boundary)], 4u);
  for (size_t l = 0; l < 2; ++l) {
    const uint32_t first = t.lines.line_first[l], last = t.lines.line_first[l + 1] - 1;
    const Vec3 a = point(t.lines, first), b = point(t.lines, last);
    // straight: every point on the chord
    const Vec3 d = normalise(b - a);
    for (uint32_t i = first; i <= last; ++i) EXPECT_LT(length(cross(point(t.lines, i) - a, d)), 1e-5);
    // direction of the field, and both ends exactly on the box's faces (x = 0 going back, x = 1 or y = 1 going forward)
    EXPECT_NEAR(d[1] / d[0], 0.5, 1e-5);
    EXPECT_NEAR(std::min(a[0], a[1]), 0.0, 1e-5) << "backward end " << a[0] << "," << a[1];
    EXPECT_NEAR(std::max(b[0], b[1]), 1.0, 1e-5) << "forward end " << b[0] << "," << b[1];
  }
}

TEST(Streamlines, SeedsOutsideTheDomainGiveNoLine) {
  auto uniform = [](double, double, double) { return Vec3{0, 0, 1}; };
  std::vector<Vec3> seeds;
  for (int i = 0; i < 1000; ++i) seeds.push_back({1.5 + i * 0.01, -2.0, std::nan("")});  // far away, one NaN coordinate
  seeds.push_back({0.5, 0.5, 0.5});
  seeds.push_back({1.0000001, 0.5, 0.5});  // just past a face
  auto t = trace(4, uniform, seeds, {});
  EXPECT_EQ(t.lines.line_count(), 1u);
  EXPECT_EQ(t.lines.seeds_outside, 1001u);
  EXPECT_EQ(t.lines.line_seed[0], 1000u);
}

TEST(Streamlines, NonFiniteFieldEndsTheLine) {
  storage::TetMesh mesh = box_with_field(4, 0, [](double, double, double) { return Vec3{1, 0, 0}; });
  auto& v = mesh.attributes.back().values;
  for (size_t i = 0; i < mesh.vertex_count(); ++i)
    if (mesh.x[i] > 0.6f) v[3 * i] = std::nanf("");
  auto opposite = pair_faces(mesh.tets).opposite;
  lod::StreamlineTracer tracer(mesh, opposite, "v");
  lod::StreamlineOptions o;
  o.direction = lod::StreamDirection::forward;
  std::vector<Vec3> seeds{{0.1, 0.4, 0.4}};
  auto lines = tracer.trace(std::span<const Vec3>(seeds), o);
  ASSERT_EQ(lines.line_count(), 1u);
  EXPECT_EQ(lines.stops[size_t(StopReason::lost)] + lines.stops[size_t(StopReason::zero_velocity)], 1u);
  for (size_t i = 0; i < lines.point_count(); ++i) EXPECT_TRUE(std::isfinite(lines.x[i]));
}

TEST(Streamlines, PointBudgetBoundsAllLinesTogether) {
  auto rotation = [](double x, double y, double) { return Vec3{-(y - 0.5), x - 0.5, 0}; };
  lod::StreamlineOptions o;
  o.max_length = 1e9;
  o.max_steps = 100000;
  o.max_points = 500;
  o.threads = 2;
  std::vector<Vec3> seeds;
  for (int i = 0; i < 20; ++i) seeds.push_back({0.6 + 0.015 * i, 0.5, 0.5});
  auto t = trace(4, rotation, seeds, o);
  EXPECT_EQ(t.lines.line_count(), 20u);
  EXPECT_LE(t.lines.point_count(), 500u + 20u);  // the budget plus the seeds themselves
  EXPECT_EQ(t.lines.stops[size_t(StopReason::point_budget)], 40u);
}

TEST(Streamlines, SinkStopsAtZeroVelocity) {
  auto sink = [](double x, double y, double z) { return Vec3{-(x - 0.5), -(y - 0.5), -(z - 0.5)}; };
  lod::StreamlineOptions o;
  o.direction = lod::StreamDirection::forward;
  auto t = trace(8, sink, {{0.9, 0.2, 0.7}, {0.1, 0.1, 0.1}}, o, 0.0);  // vertex at the centre: v exactly 0 there
  ASSERT_EQ(t.lines.line_count(), 2u);
  EXPECT_EQ(t.lines.stops[size_t(StopReason::zero_velocity)], 2u) << t.lines.stops[0] << " " << t.lines.stops[2] << " " << t.lines.stops[3];
  for (size_t l = 0; l < 2; ++l) EXPECT_LT(length(point(t.lines, t.lines.line_first[l + 1] - 1) - Vec3{0.5, 0.5, 0.5}), 1e-4);
}

TEST(Streamlines, ForwardAndBackwardJoinThroughTheSeed) {
  auto rotation = [](double x, double y, double) { return Vec3{-(y - 0.5), x - 0.5, 0.2}; };
  lod::StreamlineOptions o;
  o.max_length = 0.5;
  const Vec3 seed{0.75, 0.5, 0.5};
  o.direction = lod::StreamDirection::both;
  auto both = trace(8, rotation, {seed}, o);
  o.direction = lod::StreamDirection::forward;
  auto forward = trace(8, rotation, {seed}, o);
  o.direction = lod::StreamDirection::backward;
  auto backward = trace(8, rotation, {seed}, o);
  ASSERT_EQ(both.lines.line_count(), 1u);
  const size_t nb = backward.lines.point_count(), nf = forward.lines.point_count();
  ASSERT_EQ(both.lines.point_count(), nb + nf - 1);
  // the seed once, in the middle; lines run along the flow, so a backward line ends at its seed;
  // z rises along the line
  EXPECT_LT(length(point(both.lines, nb - 1) - seed), 1e-6);
  EXPECT_LT(length(point(backward.lines, nb - 1) - seed), 1e-6);
  EXPECT_LT(length(point(both.lines, 0) - point(backward.lines, 0)), 1e-6);
  EXPECT_LT(length(point(both.lines, nb + nf - 2) - point(forward.lines, nf - 1)), 1e-6);
  for (size_t i = 1; i < both.lines.point_count(); ++i) EXPECT_GT(both.lines.z[i], both.lines.z[i - 1]);
}

TEST(Streamlines, ValuesCarryMagnitudeAndScalars) {
  auto uniform = [](double, double, double) { return Vec3{0, 3, 4}; };
  auto t = trace(4, uniform, {{0.2, 0.1, 0.1}}, {});
  ASSERT_EQ(t.lines.value_names.size(), 2u);
  EXPECT_EQ(t.lines.value_names[0], "v_magnitude");
  EXPECT_EQ(t.lines.value_names[1], "f");
  for (size_t i = 0; i < t.lines.point_count(); ++i) {
    EXPECT_NEAR(t.lines.values[0][i], 5.0, 1e-5);
    EXPECT_NEAR(t.lines.values[1][i], t.lines.x[i], 1e-5);  // f = x
  }
}

TEST(Streamlines, DenseSeedingCoversTheBox) {
  auto field = [](double x, double y, double) { return Vec3{-(y - 0.5), x - 0.5, 0.3}; };
  storage::TetMesh mesh = box_with_field(6, 0.2, field);
  auto opposite = pair_faces(mesh.tets).opposite;
  lod::StreamlineTracer tracer(mesh, opposite, "v");
  lod::StreamlineOptions o;
  o.threads = 3;
  auto lines = tracer.trace(lod::parse_seeds("dense:5"), o);
  EXPECT_GT(lines.line_count(), 3u);
  EXPECT_LT(lines.line_count(), 125u);  // later seeds skip cells earlier lines crossed
  EXPECT_EQ(lines.seeds_outside, 0u);
}

// §7.3.1: seeds on spheres about the critical points. A saddle v = (x - a, y - b, -2 (z - c))
// with its zero at (a, b, c) inside a tet (not at a vertex): found to rounding, and the
// seeds lie on a sphere about it; lines leave it along x and y and come in along z.
TEST(Streamlines, CriticalPointSeedingFindsTheSaddleAndSeedsASphereAboutIt) {
  const Vec3 zero{0.43, 0.58, 0.51};
  auto saddle = [&](double x, double y, double z) { return Vec3{x - zero[0], y - zero[1], -2 * (z - zero[2])}; };
  storage::TetMesh mesh = box_with_field(6, 0.2, saddle);
  auto opposite = pair_faces(mesh.tets).opposite;
  lod::StreamlineTracer tracer(mesh, opposite, "v");
  const auto points = tracer.critical_points();
  ASSERT_EQ(points.size(), 1u) << "one zero, found once though it may lie on shared faces";
  EXPECT_LT(length(points[0].position - zero), 1e-6) << "a linear field is interpolated exactly";
  EXPECT_EQ(lod::sphere_points(1).size(), 4u);
  EXPECT_EQ(lod::sphere_points(3).size(), 20u);  // 2 K^2 + 2
  for (const Vec3& p : lod::sphere_points(5)) EXPECT_NEAR(length(p), 1, 1e-12);
  const lod::SeedSpec spec = lod::parse_seeds("critical:3,1.5");
  EXPECT_EQ(spec.critical_subdivision, 3u);
  EXPECT_EQ(spec.critical_radius_cells, 1.5);
  const std::vector<Vec3> seeds = tracer.critical_seeds(3, 1.5);
  ASSERT_EQ(seeds.size(), 20u);
  for (const Vec3& s : seeds) EXPECT_NEAR(length(s - points[0].position), 1.5 * points[0].cell_size, 1e-12);
  lod::StreamlineOptions o;
  o.threads = 2;
  const lod::Streamlines lines = tracer.trace(spec, o);
  EXPECT_EQ(lines.seeds, 20u);
  EXPECT_EQ(lines.line_count(), 20u);
  // both halves of a line leave the saddle for the boundary, except those of the six seeds on
  // its axes (the sphere's edge midpoints), which run straight into the zero
  EXPECT_GE(lines.stops[size_t(StopReason::boundary)], 34u - 2);
  EXPECT_EQ(lines.stops[size_t(StopReason::lost)], 0u);
  // fields with no isolated zero: none, and no seeds (not an error)
  storage::TetMesh uniform = box_with_field(3, 0.2, [](double, double, double) { return Vec3{1, 0.5, 0}; });
  auto uo = pair_faces(uniform.tets).opposite;
  EXPECT_TRUE(lod::StreamlineTracer(uniform, uo, "v").critical_points().empty());
  EXPECT_EQ(lod::StreamlineTracer(uniform, uo, "v").trace(spec, o).line_count(), 0u);
}

TEST(Streamlines, DegenerateFieldsGiveNoCriticalPointStorm) {
  // a zero field and one zero along a whole line (v = (y - b, -(x - a), 0): a rotation, zero on
  // the axis): no isolated zero, so no seeds - not one per tet
  storage::TetMesh zero = box_with_field(4, 0.2, [](double, double, double) { return Vec3{0, 0, 0}; });
  auto zo = pair_faces(zero.tets).opposite;
  EXPECT_TRUE(lod::StreamlineTracer(zero, zo, "v").critical_points().empty());
  storage::TetMesh rotation = box_with_field(4, 0.2, [](double x, double y, double) { return Vec3{y - 0.5, -(x - 0.5), 0}; });
  auto ro = pair_faces(rotation.tets).opposite;
  EXPECT_TRUE(lod::StreamlineTracer(rotation, ro, "v").critical_points().empty());
  // a zero on the boundary (a no-slip wall, here the box's corner): not a critical point inside
  storage::TetMesh corner = box_with_field(4, 0.2, [](double x, double y, double z) { return Vec3{x, y, 2 * z}; });
  auto co = pair_faces(corner.tets).opposite;
  EXPECT_TRUE(lod::StreamlineTracer(corner, co, "v").critical_points().empty());
  for (const char* bad : {"critical:", "critical:0", "critical:33", "critical:3,0", "critical:3,-1", "critical:3,nan", "critical:3,2,1", "critical:3,1e9"})
    EXPECT_THROW(lod::parse_seeds(bad), std::invalid_argument) << bad;
}

TEST(Streamlines, WrongFieldsAndMalformedSeedsAreClearErrors) {
  storage::TetMesh mesh = box_with_field(2, 0, [](double, double, double) { return Vec3{1, 0, 0}; });
  auto opposite = pair_faces(mesh.tets).opposite;
  EXPECT_THROW(lod::StreamlineTracer(mesh, opposite, "nope"), std::invalid_argument);
  EXPECT_THROW(lod::StreamlineTracer(mesh, opposite, "f"), std::invalid_argument);  // a scalar
  for (const char* bad : {"", "line:", "line:0,0,0,1,1,1", "line:0,0,0,1,1,1,0", "line:0,0,0,1,1,1,2.5", "line:a,0,0,1,1,1,3", "line:0,0,0,1,1,1,1e30",
                          "plane:0,0,0,1,0,0,0,1,0,5", "plane:0,0,0,1,0,0,0,1,0,5000,5000", "points:1,2", "points:", "dense:0", "dense:257", "line:0,0,0,1,1,1,1000001", "circle:1", "line:0,0,nan,1,1,1,3"})
    EXPECT_THROW(lod::parse_seeds(bad), std::invalid_argument) << bad;
  EXPECT_EQ(lod::parse_seeds("line:0,0,0,1,1,1,5").points.size(), 5u);
  EXPECT_EQ(lod::parse_seeds("plane:0,0,0,1,0,0,0,1,0,3,4").points.size(), 12u);
  EXPECT_EQ(lod::parse_seeds("points:1,2,3;4,5,6").points.size(), 2u);
  EXPECT_EQ(lod::parse_seeds("line:0,0,0,1,1,1,1000000").points.size(), lod::kMaxSeeds);  // at the limit
  EXPECT_EQ(lod::parse_seeds("dense:256").dense_resolution, lod::kMaxDenseResolution);
}

// Reads back the binary POLYDATA: point and line counts and the connectivity.
TEST(Streamlines, VtkOutputParsesBack) {
  auto rotation = [](double x, double y, double) { return Vec3{-(y - 0.5), x - 0.5, 0.1}; };
  lod::StreamlineOptions o;
  o.max_length = 1;
  auto t = trace(5, rotation, {{0.7, 0.5, 0.2}, {0.3, 0.5, 0.5}, {5, 5, 5}}, o);
  auto path = scratch_dir("streamlines") / "lines.vtk";
  lod::write_streamlines_vtk(path, t.lines, "v", "test");
  std::ifstream in(path, std::ios::binary);
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "# vtk DataFile Version 3.0");
  std::getline(in, line);
  std::getline(in, line);
  EXPECT_EQ(line, "BINARY");
  std::getline(in, line);
  EXPECT_EQ(line, "DATASET POLYDATA");
  std::getline(in, line);
  size_t points = 0;
  ASSERT_EQ(std::sscanf(line.c_str(), "POINTS %zu float", &points), 1);
  EXPECT_EQ(points, t.lines.point_count());
  in.seekg(std::streamoff(12 * points), std::ios::cur);
  std::getline(in, line);
  std::getline(in, line);
  size_t lines = 0, size = 0;
  ASSERT_EQ(std::sscanf(line.c_str(), "LINES %zu %zu", &lines, &size), 2);
  EXPECT_EQ(lines, 2u);
  EXPECT_EQ(size, lines + points);
  std::vector<unsigned char> cells(4 * size);
  in.read(reinterpret_cast<char*>(cells.data()), std::streamsize(cells.size()));
  auto big = [&](size_t i) { return uint32_t(cells[4 * i]) << 24 | uint32_t(cells[4 * i + 1]) << 16 | uint32_t(cells[4 * i + 2]) << 8 | cells[4 * i + 3]; };
  EXPECT_EQ(big(0), t.lines.line_first[1]);
  EXPECT_EQ(big(1 + big(0)), t.lines.line_first[2] - t.lines.line_first[1]);
  std::stringstream rest;
  rest << in.rdbuf();
  EXPECT_NE(rest.str().find("POINT_DATA " + std::to_string(points)), std::string::npos);
  EXPECT_NE(rest.str().find("VECTORS v float"), std::string::npos);
  EXPECT_NE(rest.str().find("SCALARS v_magnitude float 1"), std::string::npos);
}

TEST(StreamlinesCli, SampleMeshVelocity) {
  auto out = scratch_dir("streamlines_cli") / "lines.vtk";
  CliResult r = run_cli("streamlines " + sample_mesh().string() + " --field Velocity --seeds line:-4,0,-8,4,0,8,200 --direction both --max-steps 5000 -o " + out.string() + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_GT(j["lines"].get<int>(), 50);
  EXPECT_EQ(j["lines"].get<int>() + j["seeds_outside"].get<int>(), 200);
  EXPECT_GT(j["points"].get<int>(), 1000);
  EXPECT_EQ(j["stops"]["lost"].get<int>(), 0);
  EXPECT_TRUE(j["seconds"].is_number());
  EXPECT_TRUE(std::filesystem::file_size(out) > 1000);

  CliResult scalar = run_cli("streamlines " + sample_mesh().string() + " --field Temp --seeds dense:4 -o " + out.string());
  EXPECT_EQ(scalar.status, 2);
  EXPECT_NE(scalar.out.find("3-component"), std::string::npos) << scalar.out;
  CliResult unknown = run_cli("streamlines " + sample_mesh().string() + " --field Speed --seeds dense:4 -o " + out.string());
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.out.find("vector fields: Velocity"), std::string::npos) << unknown.out;
  CliResult malformed = run_cli("streamlines " + sample_mesh().string() + " --field Velocity --seeds line:1,2,3 -o " + out.string());
  EXPECT_EQ(malformed.status, 2);
  EXPECT_NE(malformed.out.find("expects 7"), std::string::npos) << malformed.out;
  CliResult outside = run_cli("streamlines " + sample_mesh().string() + " --field Velocity --seeds points:100,100,100 -o " + out.string() + " --json");
  ASSERT_EQ(outside.status, 0) << outside.out;
  EXPECT_EQ(nlohmann::json::parse(outside.out)["seeds_outside"], 1);
  CliResult usage = run_cli("streamlines " + sample_mesh().string());
  EXPECT_EQ(usage.status, 2);
}

// A store is traced on its full-resolution mesh: the same lines as the mesh it was made from
// (up to the store's vertex order, so compare counts and ends, not bytes).
TEST(StreamlinesCli, StoreGivesTheMeshsLines) {
  auto dir = scratch_dir("streamlines_store");
  CliResult made = run_cli("preprocess " + sample_mesh().string() + " -o " + (dir / "store").string() + " --progress none");
  ASSERT_EQ(made.status, 0) << made.out;
  const std::string common = " --field Velocity --seeds line:0,-5,2,0,5,2,50 --direction forward --max-length 30 --json -o ";
  CliResult mesh = run_cli("streamlines " + sample_mesh().string() + common + (dir / "m.vtk").string());
  CliResult store = run_cli("streamlines " + (dir / "store").string() + common + (dir / "s.vtk").string());
  ASSERT_EQ(mesh.status, 0) << mesh.out;
  ASSERT_EQ(store.status, 0) << store.out;
  auto a = nlohmann::json::parse(mesh.out), b = nlohmann::json::parse(store.out);
  EXPECT_EQ(a["lines"], b["lines"]);
  EXPECT_EQ(a["tets"], b["tets"]);
  EXPECT_NEAR(a["points"].get<double>(), b["points"].get<double>(), 0.05 * a["points"].get<double>());
}

}  // namespace
}  // namespace tetrascope::testing
