// Time series as a user meets them: `preprocess` of a .pvd or a file series builds one store
// whose steps share the mesh, `info` lists the steps, `verify` checks every step's block,
// `cut` and `render` show the step asked for (--step, --time), and a series whose steps do
// not share the mesh, a missing step file or a damaged step block gets a clear error.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "fixture_writers.h"
#include "test_paths.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

namespace fs = std::filesystem;
CliResult run(const std::string& args) { return run_cli(args, 300); }

// The step's fields: linear in the position, so that a vertex simplification made carries
// exactly the value interpolated at it.
double scalar_at(int step, double x, double y, double z) { return (step + 1) * x - 2 * y + 0.5 * step * z + step; }
std::array<double, 3> vector_at(int step, double x, double y, double z) { return {x, step * y, z + step}; }

// A k^3 grid of cubes, 5 tets each, with the step's fields (`extra` more vertices along x: a
// mesh of other counts).
CellMesh grid_step(int step, int k = 12, int extra = 0) {
  storage::TetMesh m;
  const int nx = k + extra;
  auto at = [&](int i, int j, int l) { return static_cast<uint32_t>((l * (k + 1) + j) * (nx + 1) + i); };
  for (int l = 0; l <= k; ++l)
    for (int j = 0; j <= k; ++j)
      for (int i = 0; i <= nx; ++i) {
        m.x.push_back(float(i) / k);
        m.y.push_back(float(j) / k);
        m.z.push_back(float(l) / k);
      }
  for (int l = 0; l < k; ++l)
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < nx; ++i) {
        const uint32_t c[8] = {at(i, j, l), at(i + 1, j, l), at(i + 1, j + 1, l), at(i, j + 1, l), at(i, j, l + 1), at(i + 1, j, l + 1), at(i + 1, j + 1, l + 1), at(i, j + 1, l + 1)};
        const bool odd = (i + j + l) % 2;
        const uint32_t five[2][5][4] = {{{0, 1, 2, 5}, {0, 2, 3, 7}, {0, 4, 5, 7}, {2, 5, 6, 7}, {0, 2, 5, 7}}, {{0, 1, 3, 4}, {1, 2, 3, 6}, {1, 4, 5, 6}, {3, 4, 6, 7}, {1, 3, 4, 6}}};
        for (const auto& t : five[odd]) m.tets.insert(m.tets.end(), {c[t[0]], c[t[1]], c[t[2]], c[t[3]]});
      }
  storage::Attribute p{{"pressure", 1}, {}}, u{{"velocity", 3}, {}};
  for (size_t v = 0; v < m.x.size(); ++v) {
    p.values.push_back(static_cast<float>(scalar_at(step, m.x[v], m.y[v], m.z[v])));
    for (double c : vector_at(step, m.x[v], m.y[v], m.z[v])) u.values.push_back(static_cast<float>(c));
  }
  m.attributes = {p, u};
  return from_tets(m);
}

// Writes `steps` step files and a .pvd naming them (times 0, 0.25, 0.5, ...).
fs::path write_pvd_series(const fs::path& dir, int steps) {
  fs::create_directories(dir / "data");
  std::string pvd = "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n";
  for (int s = 0; s < steps; ++s) {
    write_vtu(dir / "data" / ("flow_" + std::to_string(s) + ".vtu"), grid_step(s));
    pvd += "    <DataSet timestep=\"" + std::to_string(0.25 * s) + "\" group=\"\" part=\"0\" file=\"data/flow_" + std::to_string(s) + ".vtu\"/>\n";
  }
  pvd += "  </Collection>\n</VTKFile>\n";
  std::ofstream(dir / "flow.pvd") << pvd;
  return dir / "flow.pvd";
}

const std::string kBuild = " --base-tets 1500 --segment-tets 1024 --progress none";

// One store of four steps, shared by the tests that only read it.
const fs::path& series_store() {
  static const fs::path path = [] {
    const fs::path dir = run_scratch_dir("time-series-cli");
    const fs::path pvd = write_pvd_series(dir, 4);
    const CliResult r = run("preprocess " + pvd.string() + " -o " + (dir / "flow.store").string() + kBuild);
    EXPECT_EQ(r.status, 0) << r.out;
    return dir / "flow.store";
  }();
  return path;
}

TEST(TimeSeriesCli, APvdSeriesPreprocessesVerifiesAndInfoListsItsSteps) {
  const fs::path& store = series_store();
  EXPECT_TRUE(fs::exists(store / "steps.bin"));
  const CliResult verify = run("verify " + store.string());
  EXPECT_EQ(verify.status, 0) << verify.out;
  const CliResult info = run("info " + store.string() + " --json");
  ASSERT_EQ(info.status, 0) << info.out;
  const auto j = nlohmann::json::parse(info.out.substr(info.out.find('{')));
  const auto& steps = j["time_steps"]["steps"];
  ASSERT_EQ(steps.size(), 4u) << info.out;
  for (int s = 0; s < 4; ++s) {
    EXPECT_EQ(steps[s]["index"], s);
    EXPECT_DOUBLE_EQ(steps[s]["time"].get<double>(), 0.25 * s);
    EXPECT_EQ(steps[s]["name"], "data/flow_" + std::to_string(s) + ".vtu");
    // pressure over the unit cube: (s+1)x - 2y + 0.5 s z + s ranges over [s - 2, 1.5 s + s + 1]
    EXPECT_NEAR(steps[s]["ranges"][0][0].get<double>(), s - 2.0, 1e-5);
    EXPECT_NEAR(steps[s]["ranges"][0][1].get<double>(), 2.5 * s + 1, 1e-5);
  }
  const CliResult text = run("info " + store.string());
  EXPECT_NE(text.out.find("time steps  4, t = 0 .. 0.75"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("data/flow_3.vtu"), std::string::npos) << text.out;
}

// Every vertex of a coarse cut (simplified vertices among them) carries the step's field.
void expect_step_field(const fs::path& store, int step, const std::string& choose, const std::string& lod) {
  static const fs::path dir = scratch_dir("time-series-cut");
  const fs::path out = dir / ("cut_" + std::to_string(step) + "_" + lod + ".vtk");
  const CliResult r = run("cut " + store.string() + " --budget 2500 --lod " + lod + " " + choose + " -o " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  const storage::TetMesh m = storage::load_mesh(out);
  ASSERT_GT(m.tet_count(), 0u);
  ASSERT_LT(m.tet_count(), 8640u) << "the cut is coarser than the input";
  const auto* p = m.find_attribute("pressure");
  const auto* u = m.find_attribute("velocity");
  ASSERT_TRUE(p && u);
  size_t off_grid = 0;  // vertices simplification moved off the input's grid points
  for (size_t v = 0; v < m.vertex_count(); ++v) {
    EXPECT_NEAR(p->values[v], scalar_at(step, m.x[v], m.y[v], m.z[v]), 2e-3) << lod << " vertex " << v;
    const auto want = vector_at(step, m.x[v], m.y[v], m.z[v]);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(u->values[3 * v + c], want[c], 2e-3) << lod << " vertex " << v;
    const double gx = m.x[v] * 12;
    off_grid += std::abs(gx - std::round(gx)) > 1e-3;
  }
  EXPECT_GT(off_grid, 0u) << lod << ": the cut should hold vertices simplification made";
}

TEST(TimeSeriesCli, EveryStoredVertexOfAStepCarriesThatStepsField) {
  expect_step_field(series_store(), 1, "--step 1", "vertices");
  expect_step_field(series_store(), 3, "--step 3", "vertices");
  expect_step_field(series_store(), 2, "--step 2", "segments");
  expect_step_field(series_store(), 3, "--time 0.7", "segments");  // the step nearest t = 0.7
  expect_step_field(series_store(), 0, "--step 0", "vertices");
}

TEST(TimeSeriesCli, RenderDrawsEachStepsOwnFieldAndRefusesAStepPastTheLast) {
  const fs::path dir = scratch_dir("time-series-render");
  std::string images[2];
  for (int s : {0, 3}) {
    const fs::path out = dir / ("render_" + std::to_string(s) + ".png");
    const CliResult r = run("render " + series_store().string() + " --step " + std::to_string(s) + " --size 96x72 --backend cpu -o " + out.string());
    ASSERT_EQ(r.status, 0) << r.out;
    images[s == 0 ? 0 : 1] = read_file(out);
  }
  EXPECT_NE(images[0], images[1]) << "two steps of other fields drew the same image";
  const CliResult past = run("render " + series_store().string() + " --step 4 --size 96x72 -o " + (dir / "past.png").string());
  EXPECT_EQ(past.status, 2) << past.out;
  EXPECT_NE(past.out.find("steps 0..3"), std::string::npos) << past.out;
}

TEST(TimeSeriesCli, AFilePatternIsOrderedByTheNumbersInTheNames) {
  const fs::path dir = scratch_dir("time-series-pattern");
  for (int s : {1, 2, 10}) write_vtu(dir / ("wave_" + std::to_string(s) + ".vtu"), grid_step(s == 10 ? 2 : s - 1, 8));
  const CliResult r = run("preprocess '" + (dir / "wave_*.vtu").string() + "' -o " + (dir / "wave.store").string() + kBuild);
  ASSERT_EQ(r.status, 0) << r.out;
  const CliResult info = run("info " + (dir / "wave.store").string() + " --json");
  const auto j = nlohmann::json::parse(info.out.substr(info.out.find('{')));
  ASSERT_EQ(j["time_steps"]["steps"].size(), 3u);
  EXPECT_EQ(j["time_steps"]["steps"][0]["name"], "wave_1.vtu");
  EXPECT_EQ(j["time_steps"]["steps"][1]["name"], "wave_2.vtu");
  EXPECT_EQ(j["time_steps"]["steps"][2]["name"], "wave_10.vtu");
  EXPECT_DOUBLE_EQ(j["time_steps"]["steps"][2]["time"].get<double>(), 2.0);
}

TEST(HostileTimeSeries, AStepWithAnotherVertexCountIsRefusedNamingTheStepAndLeavesNoStore) {
  const fs::path dir = scratch_dir("time-series-mismatch");
  write_vtu(dir / "s_0.vtu", grid_step(0, 8));
  write_vtu(dir / "s_1.vtu", grid_step(1, 8));
  write_vtu(dir / "s_2.vtu", grid_step(2, 8, 1));  // one more column of vertices
  const CliResult r = run("preprocess " + (dir / "s_0.vtu").string() + " " + (dir / "s_1.vtu").string() + " " + (dir / "s_2.vtu").string() + " -o " + (dir / "s.store").string() + kBuild);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("step 2"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("vertices where the first step has"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "s.store"));
  EXPECT_FALSE(fs::exists(dir / "s.store.series"));
}

TEST(HostileTimeSeries, AStepWithOtherAttributesIsRefusedNamingThem) {
  const fs::path dir = scratch_dir("time-series-attributes");
  write_vtu(dir / "a_0.vtu", grid_step(0, 8));
  CellMesh other = grid_step(1, 8);
  other.attributes.pop_back();  // no velocity
  write_vtu(dir / "a_1.vtu", other);
  const CliResult r = run("preprocess " + (dir / "a_0.vtu").string() + " " + (dir / "a_1.vtu").string() + " -o " + (dir / "a.store").string() + kBuild);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("step 1"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("attributes pressure(1) where the first step has pressure(1), velocity(3)"), std::string::npos) << r.out;
}

TEST(HostileTimeSeries, AMissingStepFileIsRefusedBeforeAnythingIsBuilt) {
  const fs::path dir = scratch_dir("time-series-missing");
  const fs::path pvd = write_pvd_series(dir, 3);
  fs::remove(dir / "data" / "flow_1.vtu");
  const CliResult r = run("preprocess " + pvd.string() + " -o " + (dir / "m.store").string() + kBuild);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("step 1: "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("flow_1.vtu: no such file"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "m.store"));
}

TEST(HostileTimeSeries, APvdNamingAFileOutsideItsFolderIsRefused) {
  const fs::path dir = scratch_dir("time-series-outside");
  std::ofstream(dir / "escape.pvd") << "<VTKFile type=\"Collection\"><Collection>\n<DataSet timestep=\"0\" file=\"../x.vtu\"/>\n"
                                       "<DataSet timestep=\"1\" file=\"/etc/passwd.vtu\"/></Collection></VTKFile>\n";
  const CliResult r = run("preprocess " + (dir / "escape.pvd").string() + " -o " + (dir / "e.store").string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("a .pvd names files in its own folder or below it"), std::string::npos) << r.out;
}

TEST(HostileTimeSeries, ADamagedStepBlockIsReportedByVerifyAndRefusedWhenShown) {
  const fs::path dir = scratch_dir("time-series-damaged");
  fs::remove_all(dir / "d.store");
  fs::copy(series_store(), dir / "d.store", fs::copy_options::recursive);
  const fs::path steps = dir / "d.store" / "steps.bin";
  std::string bytes = read_file(steps);
  ASSERT_GT(bytes.size(), 400u);
  bytes[bytes.size() - 100] = static_cast<char>(bytes[bytes.size() - 100] ^ 0x5a);  // inside the last step's block
  std::ofstream(steps, std::ios::binary | std::ios::trunc) << bytes;
  const CliResult verify = run("verify " + (dir / "d.store").string());
  EXPECT_EQ(verify.status, 1) << verify.out;
  EXPECT_NE(verify.out.find("steps.bin: step 3: block checksum mismatch"), std::string::npos) << verify.out;
  const CliResult cut = run("cut " + (dir / "d.store").string() + " --budget 2000 --step 3 -o " + (dir / "d.vtk").string());
  EXPECT_EQ(cut.status, 1) << cut.out;
  EXPECT_NE(cut.out.find("step 3: block checksum mismatch"), std::string::npos) << cut.out;
  const CliResult earlier = run("cut " + (dir / "d.store").string() + " --budget 2000 --step 2 -o " + (dir / "d2.vtk").string());
  EXPECT_EQ(earlier.status, 0) << earlier.out;  // the other steps stay readable
  // a steps.bin cut short: refused when the store's steps are opened
  std::ofstream(steps, std::ios::binary | std::ios::trunc) << bytes.substr(0, 40);
  const CliResult truncated = run("cut " + (dir / "d.store").string() + " --budget 2000 --step 1 -o " + (dir / "d3.vtk").string());
  EXPECT_EQ(truncated.status, 1) << truncated.out;
  EXPECT_NE(truncated.out.find("steps.bin: shorter than its header"), std::string::npos) << truncated.out;
}

TEST(HostileTimeSeries, AStepOfAStoreWithoutASeriesIsRefused) {
  const fs::path dir = scratch_dir("time-series-single");
  write_vtu(dir / "one.vtu", grid_step(0, 8));
  ASSERT_EQ(run("preprocess " + (dir / "one.vtu").string() + " -o " + (dir / "one.store").string() + kBuild).status, 0);
  const CliResult r = run("cut " + (dir / "one.store").string() + " --budget 2000 --step 1 -o " + (dir / "one.vtk").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("holds one time step"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace tetrascope::testing
