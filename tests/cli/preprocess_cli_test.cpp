// `tetrascope preprocess` against hostile inputs: it never reports a store as written
// that `verify` would call damaged, fails fast on inputs that are not regular files, and does
// not let one input cost far more than its size.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <iterator>
#include <sstream>
#include <vector>
#include <nlohmann/json.hpp>

#include "fixture_writers.h"
#include "cli_run.h"
#include "test_paths.h"
#include "tetrascope/lod/mt/mt_build.h"
#include "tetrascope/lod/mt/store_check.h"

namespace tetrascope::testing {
namespace {

using Result = CliResult;
Result run(const std::string& args) { return run_cli(args, 60); }

// An OFF grid of k^3 cubes, 5 tets each, with a scalar; `extra` lines appended to the tets.
std::string grid_off(int k, const std::string& extra_points = "", int extra_point_count = 0,
                     const std::string& extra_tets = "", int extra_tet_count = 0) {
  std::string points, tets;
  auto at = [&](int i, int j, int l) { return (l * (k + 1) + j) * (k + 1) + i; };
  for (int l = 0; l <= k; ++l)
    for (int j = 0; j <= k; ++j)
      for (int i = 0; i <= k; ++i) points += std::to_string(i) + " " + std::to_string(j) + " " + std::to_string(l) + " " + std::to_string(i + j) + "\n";
  int tet_count = 0;
  auto tet = [&](int a, int b, int c, int d) {
    tets += std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(c) + " " + std::to_string(d) + "\n";
    ++tet_count;
  };
  for (int l = 0; l < k; ++l)
    for (int j = 0; j < k; ++j)
      for (int i = 0; i < k; ++i) {
        int c[8] = {at(i, j, l), at(i + 1, j, l), at(i + 1, j + 1, l), at(i, j + 1, l),
                    at(i, j, l + 1), at(i + 1, j, l + 1), at(i + 1, j + 1, l + 1), at(i, j + 1, l + 1)};
        if ((i + j + l) % 2) {
          tet(c[0], c[1], c[3], c[4]); tet(c[1], c[2], c[3], c[6]); tet(c[1], c[4], c[5], c[6]);
          tet(c[3], c[4], c[6], c[7]); tet(c[1], c[3], c[4], c[6]);
        } else {
          tet(c[0], c[1], c[2], c[5]); tet(c[0], c[2], c[3], c[7]); tet(c[0], c[4], c[5], c[7]);
          tet(c[2], c[5], c[6], c[7]); tet(c[0], c[2], c[5], c[7]);
        }
      }
  const int vertex_count = (k + 1) * (k + 1) * (k + 1) + extra_point_count;
  return std::to_string(vertex_count) + " " + std::to_string(tet_count + extra_tet_count) + "\n" + points + extra_points + tets + extra_tets;
}

nlohmann::json manifest(const std::filesystem::path& store) { return nlohmann::json::parse(read_file(store / "manifest.json")); }

TEST(PreprocessCli, TetThatRepeatsAVertexNeverGivesADamagedStore) {
  auto dir = scratch_dir("pre_repeat");
  write_file(dir / "r.off", grid_off(6, "", 0, "0 0 6 31\n", 1));
  Result r = run("preprocess " + (dir / "r.off").string() + " -o " + (dir / "s").string() + " --progress none");
  ASSERT_EQ(r.status, 0) << r.out;
  Result v = run("verify " + (dir / "s").string());
  EXPECT_EQ(v.status, 0) << v.out;
  EXPECT_EQ(manifest(dir / "s")["counts"]["dropped_repeated_vertex_tetrahedra"], 1);
  EXPECT_EQ(manifest(dir / "s")["counts"]["tetrahedra"], 6 * 6 * 6 * 5);
}

TEST(PreprocessCli, CoordinateThatOverflowsFloatLeavesNoStore) {
  auto dir = scratch_dir("pre_inf");
  std::string off = grid_off(4);
  off.replace(off.find('\n') + 1, 1, "1e39");  // the first vertex's x
  write_file(dir / "inf.off", off);
  Result r = run("preprocess " + (dir / "inf.off").string() + " -o " + (dir / "s").string() + " --progress none");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("inf.off: line 2: vertex 0: coordinate 1e+39 is not a finite 32-bit float"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
  EXPECT_FALSE(std::filesystem::exists(dir / "s.tmp"));
}

TEST(PreprocessCli, MillionsOfUnusedPointsDoNotReachTheStore) {
  auto dir = scratch_dir("pre_unused");
  std::string unused;
  const int unused_count = 200000;
  for (int i = 0; i < unused_count; ++i) unused += "0.5 0.5 0.5 0\n";
  write_file(dir / "u.off", grid_off(4, unused, unused_count));
  Result r = run("preprocess " + (dir / "u.off").string() + " -o " + (dir / "s").string() + " --progress none");
  ASSERT_EQ(r.status, 0) << r.out;
  auto m = manifest(dir / "s");
  EXPECT_EQ(m["counts"]["dropped_unused_vertices"], unused_count);
  EXPECT_EQ(m["counts"]["vertices"], 5 * 5 * 5);
  EXPECT_LT(std::filesystem::file_size(dir / "s" / "segments.bin"), 1'000'000u);  // 200k points would be 3.2 MB
}

TEST(PreprocessCli, SymlinkToDevZeroFailsAtOnceInsteadOfHashingForever) {
  auto dir = scratch_dir("pre_zero");
  std::filesystem::create_symlink("/dev/zero", dir / "zero.off");
  Result r = run("preprocess " + (dir / "zero.off").string() + " -o " + (dir / "s").string() + " --progress none");
  EXPECT_EQ(r.status, 1) << r.out;  // timeout(1) would say 124
  EXPECT_NE(r.out.find("not a regular file"), std::string::npos) << r.out;
  EXPECT_LT(r.seconds, 10);
}

TEST(PreprocessCli, ReaderErrorIsReportedWithoutHashingAHugeFileFirst) {
  // a 16 GB sparse file: the reader fails on its first line; hashing it all takes many seconds
  auto dir = scratch_dir("pre_sparse");
  const auto path = dir / "sparse.off";
  write_file(path, "not a mesh\n");
  std::filesystem::resize_file(path, uint64_t{16} << 30);
  Result r = run("preprocess " + path.string() + " -o " + (dir / "s").string() + " --progress none");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("sparse.off: line 1"), std::string::npos) << r.out;
  EXPECT_LT(r.seconds, 5) << "the error waited for the hash";
}

TEST(PreprocessCli, InfoOnAFifoDoesNotBlock) {
  auto dir = scratch_dir("info_fifo");
  ASSERT_EQ(::mkfifo((dir / "m.vtk").c_str(), 0600), 0);
  Result r = run("info " + (dir / "m.vtk").string());
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("not a regular file"), std::string::npos) << r.out;
}

// A 100 KB VTU that inflates to 96 MB (8M unused points): written once for the tests below.
const std::filesystem::path& decompression_bomb() {
  static const std::filesystem::path bomb = [] {
    const auto path = run_scratch_dir("bomb") / "bomb.vtu";
    write_vtu(path, one_tet_and_unused_points(8'000'000), {.encoding = VtuEncoding::kAppendedRaw, .zlib = true, .block_size = 1 << 20});
    return path;
  }();
  return bomb;
}

TEST(PreprocessCli, DecompressionBombIsRefusedWithTheOptionToRaiseIt) {
  auto dir = scratch_dir("pre_bomb");
  std::filesystem::copy_file(decompression_bomb(), dir / "bomb.vtu");
  Result r = run("preprocess " + (dir / "bomb.vtu").string() + " -o " + (dir / "s").string() + " --progress none");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("--max-inflate-ratio"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
  Result bad = run("preprocess " + (dir / "bomb.vtu").string() + " -o " + (dir / "s").string() + " --max-inflate-ratio 0");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("--max-inflate-ratio must be at least 1"), std::string::npos) << bad.out;
}

TEST(SegmentCli, DecompressionBombIsRefusedWithTheOptionToRaiseIt) {
  // segment reads through the same limits as preprocess (it used to inflate the bomb in full)
  auto dir = scratch_dir("seg_bomb");
  std::filesystem::copy_file(decompression_bomb(), dir / "bomb.vtu");
  Result r = run("segment " + (dir / "bomb.vtu").string() + " -o " + (dir / "s").string() + " --progress none");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("--max-inflate-ratio"), std::string::npos) << r.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
  EXPECT_FALSE(std::filesystem::exists(dir / "s.tmp"));
  Result bad = run("segment " + (dir / "bomb.vtu").string() + " -o " + (dir / "s").string() + " --max-inflate-ratio 0");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("--max-inflate-ratio must be at least 1"), std::string::npos) << bad.out;
}

TEST(PreprocessCli, UnknownLevelTargetsIsRefusedNamingTheChoices) {
  auto dir = scratch_dir("pre_level_targets");
  write_file(dir / "grid.off", grid_off(12));  // 8,640 tets
  Result bad = run("preprocess " + (dir / "grid.off").string() + " -o " + (dir / "s").string() + " --progress none --level-targets median");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("--level-targets must be 'error'"), std::string::npos) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
  for (const char* mode : {"error", "ratio"}) {  // both choices build a store that verifies
    Result ok = run("preprocess " + (dir / "grid.off").string() + " -o " + (dir / mode).string() + " --progress none --segment-tets 1000 --base-tets 500 --level-targets " + mode);
    EXPECT_EQ(ok.status, 0) << mode << ": " << ok.out;
    Result verify = run("verify " + (dir / mode).string());
    EXPECT_EQ(verify.status, 0) << mode << ": " << verify.out;
  }
}

// --model binary builds the binary segment hierarchy: a store that verifies, whose manifest and
// `info` name the model, and that `cut` adapts; an unknown model, and --dependency-ratio
// without the binary model, are refused naming the choices and leave no store.
TEST(PreprocessCli, ModelBinaryBuildsAStoreThatVerifiesAndUnknownModelIsRefused) {
  auto dir = scratch_dir("pre_model");
  write_file(dir / "grid.off", grid_off(12));  // 8,640 tets
  const std::string mesh = (dir / "grid.off").string();
  Result bad = run("preprocess " + mesh + " -o " + (dir / "bad").string() + " --progress none --model octree");
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.out.find("--model must be 'mt'"), std::string::npos) << bad.out;
  Result stray = run("preprocess " + mesh + " -o " + (dir / "bad").string() + " --progress none --dependency-ratio 2");
  EXPECT_NE(stray.status, 0);
  EXPECT_NE(stray.out.find("--dependency-ratio applies to --model binary"), std::string::npos) << stray.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
  Result ok = run("preprocess " + mesh + " -o " + (dir / "binary").string() + " --progress none --model binary --segment-tets 1000 --base-tets 500 --json");
  ASSERT_EQ(ok.status, 0) << ok.out;
  EXPECT_EQ(manifest(dir / "binary")["multiresolution"]["model"], "binary");
  EXPECT_EQ(run("verify " + (dir / "binary").string()).status, 0);
  Result info = run("info " + (dir / "binary").string());
  EXPECT_NE(info.out.find("binary segment hierarchy"), std::string::npos) << info.out;
  Result cut = run("cut " + (dir / "binary").string() + " --budget 4000 -o " + (dir / "cut.vtk").string() + " --json");
  EXPECT_EQ(cut.status, 0) << cut.out;
  EXPECT_TRUE(std::filesystem::exists(dir / "cut.vtk"));
}

// --variants K: 0 to 8 segment variants; more is refused naming the range and
// leaves no store. With some, the store holds variants.bin, which info lists and verify checks,
// and `cut` exports a cut that uses the budget its refinements could not.
// Copies of one tet (a cell written twice, or 20,000 times): preprocess builds a store that
// verifies, with the defaults, one-tet levels and the sampling simplifier alike, or refuses
// with a message; it never dies of a signal (it crashed measuring an emptied level's error).
TEST(PreprocessCli, DuplicatedTetsNeverCrashPreprocess) {
  auto dir = scratch_dir("pre_duplicates");
  const std::string corners = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n";
  write_file(dir / "twice.off", "OFF\n4 2 0\n" + corners + "4 0 1 2 3\n4 0 1 2 3\n");
  std::string many = "OFF\n4 20000 0\n" + corners;
  for (int i = 0; i < 20000; ++i) many += "4 0 1 2 3\n";
  write_file(dir / "many.off", many);
  const std::pair<const char*, const char*> runs[] = {{"twice.off", "--base-tets 1"}, {"many.off", ""}, {"many.off", "--simplifier sample"}};
  int built = 0;
  for (const auto& [file, options] : runs) {
    const std::string out = (dir / ("s" + std::to_string(built))).string();
    Result r = run("preprocess " + (dir / file).string() + " -o " + out + " --progress none " + options);
    ASSERT_LT(r.status, 128) << file << " " << options << ": died of a signal\n" << r.out;
    if (r.status == 0) {
      EXPECT_EQ(run("verify " + out).status, 0) << file << " " << options;
    } else {
      EXPECT_NE(r.out.find("error"), std::string::npos) << file << " " << options << ": no message\n" << r.out;
    }
    ++built;
  }
}

// A flat mesh (every tet of zero volume: a grid with its z collapsed) builds with variants as it
// builds without them: a variant's flat tets are flat as its segment's are, not inverted
// (`--variants 2` refused the store: "tets are not positively oriented").
TEST(PreprocessCli, AFlatMeshBuildsWithVariantsAsWithout) {
  auto dir = scratch_dir("pre_flat_variants");
  std::string off = grid_off(6);
  // z of every point (the third number of each point line) to 0
  std::istringstream lines(off);
  std::string line, flat;
  int row = 0, points = 0;
  while (std::getline(lines, line)) {
    std::istringstream words(line);
    std::vector<std::string> w((std::istream_iterator<std::string>(words)), std::istream_iterator<std::string>());
    if (row == 0) points = std::stoi(w.at(0));  // "points tets", then the points
    if (row >= 1 && row < 1 + points && w.size() >= 3) w[2] = "0";
    for (size_t i = 0; i < w.size(); ++i) flat += (i ? " " : "") + w[i];
    flat += "\n";
    ++row;
  }
  write_file(dir / "flat.off", flat);
  for (const char* variants : {"0", "2"}) {
    const std::string out = (dir / (std::string("v") + variants)).string();
    Result r = run("preprocess " + (dir / "flat.off").string() + " -o " + out + " --progress none --segment-tets 256 --base-tets 100 --variants " + variants);
    EXPECT_EQ(r.status, 0) << "--variants " << variants << "\n" << r.out;
  }
  EXPECT_TRUE(std::filesystem::exists(dir / "v2" / "variants.bin"));
}

TEST(PreprocessCli, VariantsOutOfRangeAreRefusedAndVariantsBuiltAreListedAndVerified) {
  auto dir = scratch_dir("pre_variants");
  write_file(dir / "grid.off", grid_off(12));  // 8,640 tets
  Result bad = run("preprocess " + (dir / "grid.off").string() + " -o " + (dir / "bad").string() + " --progress none --variants 9");
  EXPECT_EQ(bad.status, 2) << bad.out;
  EXPECT_NE(bad.out.find("--variants must be 0 to 8"), std::string::npos) << bad.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "bad"));
  Result ok = run("preprocess " + (dir / "grid.off").string() + " -o " + (dir / "s").string() + " --progress none --segment-tets 1000 --base-tets 500 --variants 3 --json");
  ASSERT_EQ(ok.status, 0) << ok.out;
  EXPECT_TRUE(std::filesystem::exists(dir / "s" / "variants.bin"));
  EXPECT_EQ(manifest(dir / "s")["multiresolution"]["build"]["variants"], 3);
  EXPECT_GT(manifest(dir / "s")["multiresolution"]["variants"]["tets"].get<uint64_t>(), 0u);
  Result info = run("info " + (dir / "s").string());
  EXPECT_NE(info.out.find("variants.bin"), std::string::npos) << info.out;
  Result verify = run("verify " + (dir / "s").string());
  EXPECT_EQ(verify.status, 0) << verify.out;
  // a store built without: no file, and the same segments
  Result plain = run("preprocess " + (dir / "grid.off").string() + " -o " + (dir / "p").string() + " --progress none --segment-tets 1000 --base-tets 500");
  ASSERT_EQ(plain.status, 0) << plain.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "p" / "variants.bin"));
  EXPECT_EQ(read_file(dir / "p" / "segments.bin"), read_file(dir / "s" / "segments.bin")) << "variants changed the segments";
}

// The grid of grid_off(k) with x stretched: the cubes grow `ratio`-fold a step along x.
std::string graded_grid_off(int k, double ratio) {
  std::istringstream in(grid_off(k));
  std::ostringstream out;
  int vertices = 0, tets = 0;
  in >> vertices >> tets;
  out << vertices << " " << tets << "\n";
  for (int v = 0; v < vertices; ++v) {
    double x, y, z, value;
    in >> x >> y >> z >> value;
    out << (std::pow(ratio, x) - 1) / (ratio - 1) << " " << y << " " << z << " " << value << "\n";
  }
  for (int t = 0; t < tets; ++t) {
    int a, b, c, d;
    in >> a >> b >> c >> d;
    out << a << " " << b << " " << c << " " << d << "\n";
  }
  return out.str();
}

// --segment-tets auto and --level-ratio auto (the defaults) follow how graded the
// mesh is: 8192 tets a segment and levels 4:1 apart on a graded mesh, 16384 and 2:1 on a nearly
// uniform one; the store records what it was built with, and a size or ratio given is kept.
TEST(PreprocessCli, TheDefaultSegmentSizeAndLevelRatioFollowTheMeshGrading) {
  auto dir = scratch_dir("pre_grading");
  write_file(dir / "uniform.off", grid_off(12));  // 8,640 tets of two sizes (cbrt 2 apart)
  write_file(dir / "graded.off", graded_grid_off(12, 2.2));  // the cubes 2.2^11 ~ 5,800:1 along x
  auto build = [&](const std::string& mesh, const std::string& extra) {
    Result r = run("preprocess " + (dir / (mesh + ".off")).string() + " -o " + (dir / (mesh + std::to_string(extra.size()) + ".store")).string() + " --progress none --json" + extra);
    EXPECT_EQ(r.status, 0) << r.out;
    const auto json_at = r.out.find('{');
    return json_at == std::string::npos ? nlohmann::json::object() : nlohmann::json::parse(r.out.substr(json_at));
  };
  const nlohmann::json uniform = build("uniform", ""), graded = build("graded", ""), given = build("graded", " --segment-tets 4000");
  const nlohmann::json given_ratio = build("uniform", " --level-ratio 0.3"), said_auto = build("graded", " --level-ratio auto --segment-tets auto");
  ASSERT_TRUE(uniform.contains("grading") && graded.contains("grading")) << uniform.dump() << graded.dump();
  EXPECT_LT(uniform["grading"].get<double>(), 1.5);
  EXPECT_EQ(uniform["segment_tets"], 16384);
  EXPECT_GT(graded["grading"].get<double>(), lod::kGradedMesh);
  EXPECT_EQ(graded["segment_tets"], 8192);
  EXPECT_EQ(given["segment_tets"], 4000);
  // levels 2:1 apart on the uniform mesh, 4:1 on the graded one; a given ratio is kept
  EXPECT_EQ(uniform["level_ratio"], lod::kUniformLevelRatio);
  EXPECT_EQ(graded["level_ratio"], lod::kGradedLevelRatio);
  EXPECT_NE(lod::kUniformLevelRatio, lod::kGradedLevelRatio);
  EXPECT_EQ(given["level_ratio"], lod::kGradedLevelRatio);
  EXPECT_EQ(given_ratio["level_ratio"], 0.3);
  EXPECT_EQ(given_ratio["segment_tets"], 16384);
  EXPECT_EQ(said_auto["level_ratio"], lod::kGradedLevelRatio);
  EXPECT_EQ(said_auto["segment_tets"], 8192);
  EXPECT_EQ(manifest(dir / "uniform0.store")["multiresolution"]["build"]["level_ratio"], lod::kUniformLevelRatio);
  EXPECT_EQ(manifest(dir / "graded0.store")["multiresolution"]["build"]["level_ratio"], lod::kGradedLevelRatio);
  EXPECT_EQ(manifest(dir / "uniform0.store")["multiresolution"]["build"]["segment_tets"], 16384);
  EXPECT_EQ(manifest(dir / "graded0.store")["multiresolution"]["build"]["segment_tets"], 8192);
  Result zero = run("preprocess " + (dir / "graded.off").string() + " -o " + (dir / "zero").string() + " --progress none --segment-tets 0");
  EXPECT_NE(zero.status, 0);
  EXPECT_NE(zero.out.find("--segment-tets must be 'auto' or at least 256"), std::string::npos) << zero.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "zero"));
  Result no_ratio = run("preprocess " + (dir / "graded.off").string() + " -o " + (dir / "zero").string() + " --progress none --level-ratio 0");
  EXPECT_NE(no_ratio.status, 0);
  EXPECT_NE(no_ratio.out.find("--level-ratio must be 'auto' or in (0.01, 0.95)"), std::string::npos) << no_ratio.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "zero"));
}

TEST(PreprocessCli, StoreThatFailsVerifyIsRemovedNotReported) {
  auto dir = scratch_dir("pre_check");
  write_file(dir / "g.off", grid_off(4));
  Result r = run("preprocess " + (dir / "g.off").string() + " -o " + (dir / "s").string() + " --progress none");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(lod::check_store(dir / "s").empty());
  // damage one byte of a segment, as a bug in the writer would
  const auto segments = dir / "s" / "segments.bin";
  std::string bytes = read_file(segments);
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x40);
  write_file(segments, bytes);
  ASSERT_FALSE(lod::check_store(dir / "s").empty());
  try {
    lod::require_sound_store(dir / "s");
    FAIL() << "a damaged store passed";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("failed its checks and was removed"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "s"));
}

}  // namespace
}  // namespace tetrascope::testing
