// `tetrascope info` as a user runs it: exit codes, the documented JSON keys, clear errors.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "fixture_writers.h"
#include "test_paths.h"

namespace tetrascope::testing {
namespace {

struct Result {
  int status;
  std::string out;
};

Result run(const std::string& args) {
  std::string command = tetrascope_binary().string() + " " + args + " 2>&1";
  FILE* pipe = popen(command.c_str(), "r");
  std::string out;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) out.append(buffer.data(), n);
  int status = pclose(pipe);
  return {WEXITSTATUS(status), out};
}

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
