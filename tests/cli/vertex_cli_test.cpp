// The vertex hierarchy as a user meets it: `preprocess` writes vertices.bin, `verify` checks
// it, `render` and `cut` refine by vertex splits unless told `--lod segments`, and a damaged
// vertices.bin gets a clear error from every command, never a crash.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "test_paths.h"

namespace tetrascope::testing {
namespace {

namespace fs = std::filesystem;
CliResult run(const std::string& args) { return run_cli(args, 300); }

std::string read_bytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// The last line of a --json run's output as JSON (render prints one line; cut and
// preprocess print a pretty object: the whole text from its first brace).
nlohmann::json json_of(const std::string& out, bool pretty) {
  if (pretty) return nlohmann::json::parse(out.substr(out.find('{')));
  const size_t end = out.find_last_not_of('\n');
  const size_t start = out.rfind('\n', end);
  return nlohmann::json::parse(out.substr(start == std::string::npos ? 0 : start + 1, end + 1));
}

const fs::path& store() {
  static const fs::path path = [] {
    const fs::path p = run_scratch_dir("vertex-cli") / "sample.store";
    const CliResult r = run("preprocess " + sample_mesh().string() + " -o " + p.string() + " --progress none --json");
    EXPECT_EQ(r.status, 0) << r.out;
    const auto j = json_of(r.out, true);
    EXPECT_GT(j["vertices"]["collapses"].get<uint64_t>(), 0u) << r.out;
    EXPECT_GT(j["vertices"]["bytes"].get<uint64_t>(), 0u) << r.out;
    return p;
  }();
  return path;
}

TEST(VertexCli, PreprocessWritesAHierarchyThatVerifies) {
  ASSERT_TRUE(fs::exists(store() / "vertices.bin"));
  const CliResult verify = run("verify " + store().string());
  EXPECT_EQ(verify.status, 0) << verify.out;
  const CliResult off = run("preprocess " + sample_mesh().string() + " -o " + (scratch_dir("vertex-off") / "s").string() + " --vertices off --progress none --json");
  ASSERT_EQ(off.status, 0) << off.out;
  EXPECT_FALSE(fs::exists(scratch_dir("vertex-off") / "s" / "vertices.bin"));
  EXPECT_TRUE(json_of(off.out, true)["vertices"].contains("skipped")) << off.out;
}

// The hierarchy is built beside the levels by default, after them where --memory-mb is
// tight (the sample's build, about 11 MB, is more than half of 16 MB): the same store.
TEST(VertexCli, BuiltBesideTheLevelsOrAfterThemTheStoreIsTheSame) {
  const fs::path after = scratch_dir("vertex-after") / "s";
  const CliResult r = run("preprocess " + sample_mesh().string() + " -o " + after.string() + " --memory-mb 16 --progress none --json");
  ASSERT_EQ(r.status, 0) << r.out;
  ASSERT_TRUE(fs::exists(after / "vertices.bin")) << r.out;
  for (const char* file : {"vertices.bin", "segments.bin", "dag.bin"}) {
    ASSERT_TRUE(fs::exists(store() / file)) << file;
    EXPECT_EQ(read_bytes(store() / file), read_bytes(after / file)) << file;
  }
}

TEST(VertexCli, RenderRefinesByVertexSplitsUnlessAskedForSegments) {
  const fs::path out = scratch_dir("vertex-render");
  const CliResult vertices = run("render " + store().string() + " -o " + (out / "v.png").string() + " --size 96x72 --budget 20000 --json");
  ASSERT_EQ(vertices.status, 0) << vertices.out;
  const auto v = json_of(vertices.out, false);
  EXPECT_EQ(v["cut"]["by"], "vertices") << vertices.out;
  EXPECT_LE(v["cut"]["tets"].get<uint64_t>(), 20000u);
  EXPECT_GE(v["cut"]["budget_used"].get<double>(), 0.99) << vertices.out;  // single splits spend the budget
  const CliResult segments = run("render " + store().string() + " -o " + (out / "s.png").string() + " --size 96x72 --budget 20000 --lod segments --json");
  ASSERT_EQ(segments.status, 0) << segments.out;
  EXPECT_EQ(json_of(segments.out, false)["cut"]["by"], "segments") << segments.out;
  const CliResult bad = run("render " + store().string() + " -o " + (out / "b.png").string() + " --lod triangles");
  EXPECT_EQ(bad.status, 2) << bad.out;
  EXPECT_NE(bad.out.find("--lod"), std::string::npos) << bad.out;
}

TEST(VertexCli, CutWritesTheFrontWithinTheBudget) {
  const fs::path out = scratch_dir("vertex-cut") / "cut.vtk";
  const CliResult r = run("cut " + store().string() + " --budget 15000 -o " + out.string() + " --camera azimuth=40,elevation=10 --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = json_of(r.out, true);
  EXPECT_EQ(j["by"], "vertices");
  EXPECT_LE(j["tets"].get<uint64_t>(), 15000u);
  EXPECT_GE(j["tets"].get<uint64_t>(), 14800u) << r.out;
  EXPECT_TRUE(fs::exists(out));
}

// A vertices.bin cut short or with a flipped byte: verify names it, render and cut fail with
// a message (exit 1), no signal.
TEST(VertexCli, ADamagedVerticesFileGetsAClearErrorFromEveryCommand) {
  for (const std::string damage : {"truncated", "flipped"}) {
    const fs::path copy = scratch_dir("vertex-damaged-" + damage) / "s.store";
    fs::copy(store(), copy, fs::copy_options::recursive);
    const fs::path file = copy / "vertices.bin";
    std::string bytes;
    {
      std::ifstream in(file, std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    }
    if (damage == "truncated") bytes.resize(bytes.size() * 2 / 3);
    else bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
    std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
    const CliResult verify = run("verify " + copy.string());
    EXPECT_NE(verify.status, 0) << damage << ": " << verify.out;
    EXPECT_NE(verify.out.find("vertices.bin"), std::string::npos) << verify.out;
    const CliResult render = run("render " + copy.string() + " -o " + (copy.parent_path() / "r.png").string() + " --size 64x48");
    EXPECT_EQ(render.status, 1) << damage << ": " << render.out;
    EXPECT_NE(render.out.find("vertices.bin"), std::string::npos) << render.out;
    const CliResult cut = run("cut " + copy.string() + " --budget 5000 -o " + (copy.parent_path() / "c.vtk").string());
    EXPECT_EQ(cut.status, 1) << damage << ": " << cut.out;
    // the segments' cut does not read it
    const CliResult segments = run("render " + copy.string() + " -o " + (copy.parent_path() / "s.png").string() + " --size 64x48 --lod segments");
    EXPECT_EQ(segments.status, 0) << segments.out;
  }
}

}  // namespace
}  // namespace tetrascope::testing
