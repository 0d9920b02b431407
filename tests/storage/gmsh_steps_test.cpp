// Gmsh files holding several time steps ($NodeData and $ElementData sections of several time
// step numbers): read at each field's last section alone, at any one step by ReadLimits, and
// preprocessed with --all-steps into one store of every step (rendered step by step); steps
// that give values for other nodes, non-finite values and a step past the last get a clear
// error.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "fixture_writers.h"
#include "mesh_checks.h"
#include "step_checks.h"
#include "test_paths.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/series.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/time_steps.h"

namespace tetrascope::testing {
namespace {

namespace fs = std::filesystem;
using storage::MeshError;
using storage::TetMesh;

double temp_at(int step, double x, double y, double z) { return (step + 1) * x - y + 2 * z + step; }
std::array<double, 3> flow_at(int step, double x, double y, double z) { return {y * step, -x, z + 0.25 * step}; }
double load_at(int step, size_t tet) { return 5.0 * step + double(tet % 5); }

const TetMesh& box() {
  static const TetMesh m = kuhn_box(5, 0.3, [](double, double, double) { return 0.0; });
  return m;
}

struct StepsFile {
  std::vector<double> times{0, 0.5, 1.25};
  size_t drop_node_at_step = 0;  // a step (1 or 2) whose temp leaves out node tag 4; 0: none
  size_t nan_at_step = 0;        // a step whose flow is NaN at node tag 9; 0: none
  bool binary41 = false;         // MSH 4.1 binary, else 2.2 ASCII
};

// The box as MSH 2.2 ASCII (or 4.1 binary) with, at each step s (time step number 10 + s), nodal
// "temp" and "flow" (3) and element "load"; the sections of a field in a row, as Gmsh writes a view.
void write_gmsh_steps(const fs::path& path, const StepsFile& o = {}) {
  const TetMesh& m = box();
  CellMesh mesh = from_tets(m);
  mesh.attributes.clear();  // the fields are the steps' alone
  write_gmsh(path, mesh, {.version4 = o.binary41, .binary = o.binary41});
  std::string out = read_file(path);
  for (int s = 0; s < int(o.times.size()); ++s) {
    std::vector<std::pair<size_t, std::vector<double>>> rows;
    for (size_t v = 0; v < m.vertex_count(); ++v)
      if (!(o.drop_node_at_step == size_t(s) && s > 0 && v + 1 == 4)) rows.push_back({v + 1, {temp_at(s, m.x[v], m.y[v], m.z[v])}});
    out += gmsh_data_section("NodeData", "temp", 10 + s, o.times[size_t(s)], 1, rows, o.binary41);
  }
  for (int s = 0; s < int(o.times.size()); ++s) {
    std::vector<std::pair<size_t, std::vector<double>>> rows;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      const auto f = flow_at(s, m.x[v], m.y[v], m.z[v]);
      rows.push_back({v + 1, {f[0], o.nan_at_step == size_t(s) && s > 0 && v + 1 == 9 ? std::nan("") : f[1], f[2]}});
    }
    out += gmsh_data_section("NodeData", "flow", 10 + s, o.times[size_t(s)], 3, rows, o.binary41);
  }
  for (int s = 0; s < int(o.times.size()); ++s) {
    std::vector<std::pair<size_t, std::vector<double>>> rows;
    for (size_t t = 0; t < m.tet_count(); ++t) rows.push_back({t + 1, {load_at(s, t)}});
    out += gmsh_data_section("ElementData", "load", 10 + s, o.times[size_t(s)], 1, rows, o.binary41);
  }
  write_file(path, out);
}

const std::string kSmallBuild = " --base-tets 300 --segment-tets 512 --progress none --threads 1";

TEST(GmshSteps, EachFieldsLastStepIsReadAloneAndAnyStepByNumber) {
  const fs::path path = scratch_dir("gmsh_steps_read") / "m.msh";
  write_gmsh_steps(path);
  auto stream = storage::MeshStream::open(path);
  EXPECT_EQ(stream->header().step_times, (std::vector<double>{0, 0.5, 1.25}));
  bool warned = false;
  for (const auto& w : stream->stats().warnings) warned |= w == "3 time steps: each field's last is read (preprocess --all-steps reads them all)";
  EXPECT_TRUE(warned);
  const TetMesh last = storage::load_stream(*stream);
  for (int s : {-1, 0, 1}) {
    storage::ReadLimits limits;
    limits.time_step = s;
    const TetMesh m = s < 0 ? last : storage::load_mesh(path, nullptr, limits);
    const int step = s < 0 ? 2 : s;
    const storage::Attribute* temp = m.find_attribute("temp");
    const storage::Attribute* flow = m.find_attribute("flow");
    ASSERT_TRUE(temp && flow && m.find_attribute("load"));
    size_t wrong = 0;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      wrong += std::abs(temp->values[v] - temp_at(step, m.x[v], m.y[v], m.z[v])) > 1e-5;
      const auto f = flow_at(step, m.x[v], m.y[v], m.z[v]);
      for (int c = 0; c < 3; ++c) wrong += std::abs(flow->values[3 * v + size_t(c)] - f[size_t(c)]) > 1e-5;
    }
    EXPECT_EQ(wrong, 0u) << "step " << step;
  }
  expect_step_refused(path, 3, "m.msh: time step 3 asked for, the file holds 3");
}

// The same steps in an MSH 4.1 binary file: every step read by number, and --all-steps lists them.
TEST(GmshSteps, AMsh41BinaryFileHoldsItsStepsToo) {
  const fs::path dir = scratch_dir("gmsh_steps_binary");
  StepsFile o;
  o.binary41 = true;
  write_gmsh_steps(dir / "m.msh", o);
  EXPECT_EQ(storage::MeshStream::open(dir / "m.msh")->header().step_times, (std::vector<double>{0, 0.5, 1.25}));
  for (int s : {0, 1, 2}) {
    storage::ReadLimits limits;
    limits.time_step = s;
    const TetMesh m = storage::load_mesh(dir / "m.msh", nullptr, limits);
    const storage::Attribute* temp = m.find_attribute("temp");
    const storage::Attribute* load = m.find_attribute("load");
    ASSERT_TRUE(temp && load && m.find_attribute("flow"));
    size_t wrong = 0;
    for (size_t v = 0; v < m.vertex_count(); ++v) wrong += std::abs(temp->values[v] - temp_at(s, m.x[v], m.y[v], m.z[v])) > 1e-5;
    EXPECT_EQ(wrong, 0u) << "step " << s;
  }
  expect_step_refused(dir / "m.msh", 3, "m.msh: time step 3 asked for, the file holds 3");
  EXPECT_EQ(all_steps_listed(dir / "m.msh", dir / "s.store", kSmallBuild).size(), 3u);
}

TEST(GmshSteps, AllStepsMakesOneStoreOfEveryStepWithItsTimesAndValues) {
  const fs::path dir = scratch_dir("gmsh_steps_store");
  write_gmsh_steps(dir / "m.msh");
  const nlohmann::json listed = all_steps_listed(dir / "m.msh", dir / "s.store", kSmallBuild);
  ASSERT_EQ(listed.size(), 3u) << listed.dump();
  const std::vector<double> times{0, 0.5, 1.25};
  for (int s = 0; s < 3; ++s) {
    EXPECT_DOUBLE_EQ(listed[s]["time"].get<double>(), times[size_t(s)]);
    EXPECT_EQ(listed[s]["name"], "m.msh step " + std::to_string(s));
  }
  EXPECT_EQ(run_cli("verify " + (dir / "s.store").string(), 120).status, 0);
  // render draws each step's own field, and refuses a step past the last
  std::string images[2];
  for (int s : {0, 2}) {
    const fs::path out = dir / ("step_" + std::to_string(s) + ".png");
    const CliResult drawn = run_cli("render " + (dir / "s.store").string() + " --step " + std::to_string(s) + " --size 64x48 --backend cpu -o " + out.string(), 120);
    ASSERT_EQ(drawn.status, 0) << drawn.out;
    images[s / 2] = read_file(out);
  }
  EXPECT_NE(images[0], images[1]) << "steps 0 and 2 drew the same image";
  const CliResult past = run_cli("render " + (dir / "s.store").string() + " --step 3 --size 64x48 --backend cpu -o " + (dir / "past.png").string(), 60);
  EXPECT_EQ(past.status, 2) << past.out;
  EXPECT_NE(past.out.find("steps 0..2"), std::string::npos) << past.out;
  // steps 1 and 2 at the input's vertices: the nodal fields as written, the element field as
  // the file read at that step converts it
  const TetMesh& m = box();
  const auto store = storage::Store::open(dir / "s.store");
  const auto steps = storage::TimeSteps::open(*store);
  ASSERT_NE(steps, nullptr);
  ASSERT_EQ(steps->layout().floats, 5u);
  ASSERT_EQ(steps->layout().input_vertices, m.vertex_count());
  for (int s = 1; s < 3; ++s) {
    storage::ReadLimits limits;
    limits.time_step = s;
    const TetMesh read = storage::load_mesh(dir / "m.msh", nullptr, limits);
    const auto values = steps->values(static_cast<uint32_t>(s));
    size_t wrong = 0;
    for (size_t v = 0; v < m.vertex_count(); ++v) {
      const float* row = values->data() + 5 * v;
      const auto f = flow_at(s, m.x[v], m.y[v], m.z[v]);
      wrong += std::abs(row[0] - temp_at(s, m.x[v], m.y[v], m.z[v])) > 1e-5;
      for (int c = 0; c < 3; ++c) wrong += std::abs(row[1 + c] - f[size_t(c)]) > 1e-5;
      wrong += std::abs(row[4] - read.find_attribute("load")->values[v]) > 1e-5;
      wrong += row[4] < 5.0f * s - 1e-4f || row[4] > 5.0f * s + 4 + 1e-4f;  // a mean of the step's loads
    }
    EXPECT_EQ(wrong, 0u) << "step " << s;
  }
}

TEST(HostileGmshSteps, AStepGivingValuesForOtherNodesIsRefusedNamingBothSteps) {
  const fs::path dir = scratch_dir("gmsh_steps_nodes");
  fs::remove_all(dir / "n.store");
  StepsFile o;
  o.drop_node_at_step = 2;
  write_gmsh_steps(dir / "m.msh", o);
  const CliResult r = run_cli("preprocess " + (dir / "m.msh").string() + " -o " + (dir / "n.store").string() + " --all-steps" + kSmallBuild, 300);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("m.msh: line "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("$NodeData 'temp' at time step 2 (number 12, t = 1.25) gives values for other nodes than at time step 0 (number 10, t = 0)"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "n.store"));
  EXPECT_FALSE(fs::exists(dir / "n.store.series"));
  // alone, the file still reads (each field's last; the node left out is NaN)
  EXPECT_EQ(mesh_read_error(dir / "m.msh"), "");
}

TEST(HostileGmshSteps, ANonFiniteValueOfAStepIsRefusedNamingTheFileAndStep) {
  const fs::path dir = scratch_dir("gmsh_steps_nan");
  fs::remove_all(dir / "n.store");
  StepsFile o;
  o.nan_at_step = 1;
  write_gmsh_steps(dir / "m.msh", o);
  const CliResult r = run_cli("preprocess " + (dir / "m.msh").string() + " -o " + (dir / "n.store").string() + " --all-steps" + kSmallBuild, 300);
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("step 1 (" + (dir / "m.msh").string() + ", time step 1): attribute 'flow' at vertex 8 is nan"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir / "n.store"));
}

TEST(HostileGmshSteps, TimesThatDoNotIncreaseAreRefusedBeforeAnythingIsBuilt) {
  const fs::path dir = scratch_dir("gmsh_steps_times");
  StepsFile o;
  o.times = {0, 1, 1};
  write_gmsh_steps(dir / "m.msh", o);
  try {
    storage::series_inputs({(dir / "m.msh").string()}, true);
    ADD_FAILURE() << "two steps of one time were taken";
  } catch (const MeshError& e) {
    EXPECT_NE(std::string(e.what()).find("m.msh: time step 2 (t = 1.000000) is not after step 1"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace tetrascope::testing
