// `tetrascope info`, `preprocess`, `verify` and `cut` as a user runs them: exit codes, the
// documented JSON keys, clear errors.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "fixture_writers.h"

namespace tetrascope::testing {
namespace {

using Result = CliResult;
Result run(const std::string& args) { return run_cli(args); }

TEST(InfoCli, JsonHasTheDocumentedKeys) {
  Result r = run("info --json " + sample_mesh().string());
  ASSERT_EQ(r.status, 0) << r.out;
  auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["vertices"], 8499);
  EXPECT_EQ(j["tetrahedra"], 44832);
  ASSERT_EQ(j["attributes"].size(), 7u);
  bool found = false;
  for (auto& a : j["attributes"]) {
    if (a["name"] == "Velocity") {
      found = true;
      EXPECT_EQ(a["components"], 3);
      EXPECT_NEAR(a["max"].get<double>(), 22.42, 0.01);
    }
  }
  EXPECT_TRUE(found);
  EXPECT_NEAR(j["bounds"]["max"][2].get<double>(), 10.16, 0.01);
  EXPECT_EQ(j["format"], "vtk");
  EXPECT_TRUE(j["read_seconds"].is_number());
}

TEST(InfoCli, TextOutputAndErrors) {
  Result ok = run("info " + sample_mesh().string());
  EXPECT_EQ(ok.status, 0);
  EXPECT_NE(ok.out.find("tetrahedra  44832"), std::string::npos) << ok.out;

  auto dir = scratch_dir("cli");
  write_file(dir / "broken.vtk", "# vtk DataFile Version 3.0\nx\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS 4 float\n0 0 0\n");
  Result bad = run("info " + (dir / "broken.vtk").string());
  EXPECT_EQ(bad.status, 1);
  EXPECT_NE(bad.out.find("broken.vtk: line"), std::string::npos) << bad.out;

  Result missing = run("info");
  EXPECT_EQ(missing.status, 2);
  Result unknown = run("frobnicate");
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.out.find("unknown command"), std::string::npos);
}

}  // namespace
}  // namespace tetrascope::testing

namespace tetrascope::testing {
namespace {

TEST(PreprocessCli, PreprocessInfoVerifyCutAndClearErrors) {
  const auto dir = scratch_dir("preprocess-cli");
  const std::string store = (dir / "sample.store").string();
  Result built = run("preprocess " + sample_mesh().string() + " -o " + store + " --segment-tets 2000 --base-tets 3000 --progress json --json");
  ASSERT_EQ(built.status, 0) << built.out;
  EXPECT_NE(built.out.find("\"stage\""), std::string::npos) << "--progress json emits JSON lines";
  Result again = run("preprocess " + sample_mesh().string() + " -o " + store);
  EXPECT_EQ(again.status, 1);
  EXPECT_NE(again.out.find("--force"), std::string::npos) << again.out;
  Result info = run("info --json " + store);
  ASSERT_EQ(info.status, 0) << info.out;
  auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["tetrahedra"], 44832);
  EXPECT_GE(j["multiresolution"]["levels"].size(), 3u);
  EXPECT_GT(j["files"]["dag.bin"]["bytes"].get<uint64_t>(), 0u);
  Result verify = run("verify --progress none " + store);
  EXPECT_EQ(verify.status, 0) << verify.out;
  Result cut = run("cut " + store + " --budget 20000 --camera azimuth=10,elevation=5 --attribute Temp --json -o " + (dir / "cut.vtk").string());
  ASSERT_EQ(cut.status, 0) << cut.out;
  auto c = nlohmann::json::parse(cut.out);
  EXPECT_LE(c["tets"].get<uint64_t>(), 20000u);
  EXPECT_GT(c["tets"].get<uint64_t>(), 11277u) << "the single root refines, then some level-1 segments";
  Result full = run("cut " + store + " --budget 44832 --json -o " + (dir / "full.vtk").string());
  ASSERT_EQ(full.status, 0) << full.out;
  EXPECT_EQ(nlohmann::json::parse(full.out)["tets"], 44832) << "a budget of the input's tets gives the finest cut";
  // errors a user can act on
  write_file(dir / "bad-tf.json", "{\"opacity\": [[1, 2]]}");
  Result bad_tf = run("cut " + store + " --budget 9000 --tf " + (dir / "bad-tf.json").string() + " -o " + (dir / "x.vtk").string());
  EXPECT_EQ(bad_tf.status, 2);
  EXPECT_NE(bad_tf.out.find("alpha"), std::string::npos) << bad_tf.out;
  Result bad_camera = run("cut " + store + " --budget 9000 --camera zoom=2 -o " + (dir / "x.vtk").string());
  EXPECT_EQ(bad_camera.status, 2);
  EXPECT_NE(bad_camera.out.find("unknown key"), std::string::npos) << bad_camera.out;
  const std::string single = (dir / "single.store").string();
  ASSERT_EQ(run("segment " + sample_mesh().string() + " -o " + single + " --progress none").status, 0);
  Result not_mt = run("cut " + single + " --budget 9000 -o " + (dir / "x.vtk").string());
  EXPECT_EQ(not_mt.status, 2);
  EXPECT_NE(not_mt.out.find("preprocess"), std::string::npos) << not_mt.out;
  Result ratio = run("preprocess " + sample_mesh().string() + " -o " + (dir / "r.store").string() + " --level-ratio 2");
  EXPECT_EQ(ratio.status, 2);
  EXPECT_FALSE(std::filesystem::exists(dir / "r.store"));
}

}  // namespace
}  // namespace tetrascope::testing
