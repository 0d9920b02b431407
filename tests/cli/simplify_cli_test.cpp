// `tetrascope simplify --method sample`, `preprocess --simplifier` and `error`'s border check as
// a user runs them: bad methods and thresholds get a message naming the option; the sampled
// mesh is written and its border reported free of self-intersections; the default method
// chooses by the mesh and says why; a mesh whose border crosses itself is reported as such.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "mesh_checks.h"
#include "test_paths.h"
#include "tetrascope/storage/vtk_writer.h"

namespace tetrascope::testing {
namespace {

CliResult run(const std::string& args) { return run_cli(args, 120); }

// made once for the whole program and kept across its tests (a test's own scratch_dir is
// removed when that test passes)
const std::filesystem::path& dir() {
  static const std::filesystem::path d = run_scratch_dir("simplify-cli");
  return d;
}

std::string box_file(const std::string& name, bool crossing = false) {
  storage::TetMesh m = kuhn_box(6, 0.2, [](float x, float y, float z) { return x * y + z; });
  if (crossing) {  // a separate tet poking through the face x = 1
    const uint32_t b = static_cast<uint32_t>(m.vertex_count());
    for (auto [x, y, z] : std::vector<std::array<float, 3>>{{0.9f, 0.4f, 0.4f}, {1.5f, 0.4f, 0.4f}, {1.2f, 0.7f, 0.4f}, {1.2f, 0.5f, 0.8f}}) {
      m.x.push_back(x);
      m.y.push_back(y);
      m.z.push_back(z);
      m.attributes[0].values.push_back(x);
    }
    uint32_t tet[4] = {b, b + 1, b + 2, b + 3};
    if (storage::signed_volume(m, tet[0], tet[1], tet[2], tet[3]) < 0) std::swap(tet[2], tet[3]);
    m.tets.insert(m.tets.end(), tet, tet + 4);
  }
  const auto path = dir() / name;
  storage::write_vtk(path, m, "box");
  return path.string();
}

TEST(SimplifyCli, BadMethodsAndThresholdsAreRefusedWithTheOptionNamed) {
  const std::string in = box_file("box.vtk"), out = (dir() / "out.vtk").string();
  struct Case {
    std::string args, expected;
  };
  for (const Case& c : std::vector<Case>{
           {"--method fast --ratio 0.5", "--method must be 'qem' or 'sample'"},
           {"--method sample --field-error -1", "--field-error must be a finite number > 0"},
           {"--method sample --space-error nan", "--space-error"},
           {"--method sample --ratio 0.5 --border-error 3", "--border-error"},
           {"--method sample --max-error 0.1", "--max-error belongs to --method qem"},
           {"--ratio 0.5 --field-error 0.1", "belong to --method sample"},
       }) {
    const CliResult r = run("simplify " + in + " -o " + out + " " + c.args);
    EXPECT_NE(r.status, 0) << c.args;
    EXPECT_NE(r.out.find(c.expected), std::string::npos) << c.args << ": " << r.out;
  }
  const CliResult r = run("preprocess " + in + " -o " + out + ".store --simplifier fast");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("--simplifier must be 'qem' or 'sample'"), std::string::npos) << r.out;
}

TEST(SimplifyCli, SampledMeshIsWrittenAndItsBorderChecked) {
  const std::string in = box_file("box.vtk"), out = (dir() / "sampled.vtk").string();
  const CliResult s = run("simplify " + in + " -o " + out + " --method sample --ratio 0.25 --json");
  ASSERT_EQ(s.status, 0) << s.out;
  const auto j = nlohmann::json::parse(s.out);
  EXPECT_EQ(j["method"], "sample");
  EXPECT_LT(j["tets_after"].get<uint64_t>(), j["tets_before"].get<uint64_t>());
  EXPECT_GT(j["samples"].get<uint64_t>(), 0u);
  const CliResult e = run("error " + in + " " + out + " --json");
  ASSERT_EQ(e.status, 0) << e.out;
  const auto error = nlohmann::json::parse(e.out);
  EXPECT_FALSE(error["border_self_intersects"].get<bool>());
  EXPECT_GT(error["border_triangles"].get<uint64_t>(), 0u);
}

TEST(SimplifyCli, TheDefaultMethodChoosesByTheMesh) {
  // auto, the default: the quadric simplifier below 30K tets, for an error bound and for its
  // own options, the sampler on a larger mesh; each run says why
  struct Case {
    std::string file, args, method, because;
  };
  const std::string big = (dir() / "big.vtk").string();
  storage::write_vtk(big, kuhn_box(26, 0.2, [](float x, float y, float z) { return std::sin(6 * x) * y + z; }), "box");
  for (const Case& c : std::vector<Case>{{box_file("box.vtk"), "--ratio 0.2", "qem", "fewer than 30000 tets"},
                                         {box_file("box.vtk"), "--max-error 0.1", "qem", "an error bound"},
                                         {big, "--ratio 0.1 --independent", "qem", "an option of the quadric simplifier"},
                                         {big, "--ratio 0.1", "sample", "the sampler"}}) {
    const std::string out = (dir() / "auto.vtk").string();
    const CliResult r = run("simplify " + c.file + " -o " + out + " " + c.args + " --json");
    ASSERT_EQ(r.status, 0) << c.args << ": " << r.out;
    const auto j = nlohmann::json::parse(r.out);
    EXPECT_EQ(j["method"], c.method) << c.args;
    EXPECT_NE(j["method_chosen_because"].get<std::string>().find(c.because), std::string::npos) << j["method_chosen_because"];
    EXPECT_LT(j["tets_after"].get<uint64_t>(), j["tets_before"].get<uint64_t>()) << c.args;
    const CliResult e = run("error " + c.file + " " + out + " --json");
    ASSERT_EQ(e.status, 0) << e.out;
    if (c.method == "sample") {
      EXPECT_FALSE(nlohmann::json::parse(e.out)["border_self_intersects"].get<bool>());
    }
  }
}

TEST(SimplifyCli, ErrorReportsABorderThatCrossesItself) {
  const std::string in = box_file("box.vtk"), crossing = box_file("crossing.vtk", true);
  const CliResult e = run("error " + in + " " + crossing);
  ASSERT_EQ(e.status, 0) << e.out;
  EXPECT_NE(e.out.find("SELF-INTERSECTING"), std::string::npos) << e.out;
}

}  // namespace
}  // namespace tetrascope::testing
