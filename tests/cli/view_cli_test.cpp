// `tetrascope render` as a user runs it: images of meshes and stores, timings, the limits of
// its options and the errors it gives.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <iterator>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "fixture_writers.h"

namespace tetrascope::testing {
namespace {

using Result = CliResult;
Result run(const std::string& args) { return run_cli(args); }

nlohmann::json last_json_line(const std::string& out) {
  std::string last = out.substr(0, out.find_last_not_of('\n') + 1);
  last = last.substr(last.rfind('\n') == std::string::npos ? 0 : last.rfind('\n') + 1);
  return nlohmann::json::parse(last);
}


// --backend cpu: the CPU ray caster draws the volume (reported as the backend), close to the
// exact integrator; what it does not draw is refused naming it, and an unknown backend too.
// --backend auto takes it where the only EGL device is software.
TEST(RenderCli, TheCpuBackendRendersTheVolumeAndRefusesWhatItDoesNotDraw) {
  const auto dir = scratch_dir("render-cli-cpu");
  const std::string out = (dir / "cpu.png").string();
  Result cpu = run("render " + sample_mesh().string() + " -o " + out + " --size 96x64 --attribute Temp --backend cpu --reference --json");
  ASSERT_EQ(cpu.status, 0) << cpu.out;
  auto j = last_json_line(cpu.out);
  EXPECT_EQ(j["backend"], "cpu");
  EXPECT_NE(j["renderer"].get<std::string>().find("ray caster"), std::string::npos) << j["renderer"];
  EXPECT_GT(j["reference_psnr_db"].get<double>(), 50);
  EXPECT_GT(j["tets_drawn"].get<uint64_t>(), 0u);
  EXPECT_GT(j["median_cpu_ms"].get<double>(), 0) << "the caster reports the CPU time of its frames";
  // one thread draws the image every core draws (each pixel's ray is its own)
  const std::string one = (dir / "one-thread.png").string();
  Result single = run("render " + sample_mesh().string() + " -o " + one + " --size 96x64 --attribute Temp --backend cpu --threads 1 --json");
  ASSERT_EQ(single.status, 0) << single.out;
  EXPECT_NE(last_json_line(single.out)["renderer"].get<std::string>().find("(1 threads)"), std::string::npos) << single.out;
  EXPECT_EQ(tetrascope::testing::read_file(one), tetrascope::testing::read_file(out));
  Result surface = run("render " + sample_mesh().string() + " -o " + out + " --size 32x32 --mode surface --backend cpu");
  EXPECT_EQ(surface.status, 2) << surface.out;
  EXPECT_NE(surface.out.find("surfaces"), std::string::npos) << surface.out;
  Result bogus = run("render " + sample_mesh().string() + " -o " + out + " --size 32x32 --backend vulkan");
  EXPECT_EQ(bogus.status, 2) << bogus.out;
  EXPECT_NE(bogus.out.find("gl, cpu or auto"), std::string::npos) << bogus.out;
  Result automatic = run("render " + sample_mesh().string() + " -o " + out + " --size 32x32 --backend auto --json");
  ASSERT_EQ(automatic.status, 0) << automatic.out;
  const auto a = last_json_line(automatic.out);
  // llvmpipe here takes the caster; a hardware GL device keeps the GL renderer
  EXPECT_EQ(a["backend"], a["renderer"].get<std::string>().find("ray caster") != std::string::npos ? "cpu" : "gl");
  Result surface_auto = run("render " + sample_mesh().string() + " -o " + out + " --size 32x32 --mode surface --backend auto --json");
  ASSERT_EQ(surface_auto.status, 0) << surface_auto.out;
  EXPECT_EQ(last_json_line(surface_auto.out)["backend"], "gl");
}

TEST(RenderCli, RendersImagesReportsTimingsAndRefusesBadOptions) {
  const auto dir = scratch_dir("render-cli");
  const std::string out = (dir / "frame.png").string();
  Result ok = run("render " + sample_mesh().string() + " -o " + out + " --size 96x64 --attribute Temp --orbit 2 --json");
  ASSERT_EQ(ok.status, 0) << ok.out;
  auto j = last_json_line(ok.out);  // --json: the last line is one JSON object
  EXPECT_GT(j["median_ms"].get<double>(), 0);
  EXPECT_EQ(j["frames"], 2);
  EXPECT_EQ(j["legend"]["attribute"], "Temp");
  EXPECT_GT(std::filesystem::file_size(out), 100u);
  // --reference: the exact integrator's image beside the output, as PNG and as unrounded floats
  const std::string exact = (dir / "exact.png").string();
  Result reference = run("render " + sample_mesh().string() + " -o " + exact + " --size 48x32 --attribute Temp --reference --json");
  ASSERT_EQ(reference.status, 0) << reference.out;
  EXPECT_GT(last_json_line(reference.out)["reference_psnr_db"].get<double>(), 20);
  EXPECT_GT(std::filesystem::file_size(dir / "exact.reference.png"), 100u);
  EXPECT_EQ(std::filesystem::file_size(dir / "exact.reference.pfm"), std::string("PF\n48 32\n-1.0\n").size() + 48u * 32 * 3 * 4);
  Result jpeg = run("render " + sample_mesh().string() + " -o " + (dir / "frame.jpg").string() + " --size 64x64 --mode surface+iso --iso 500 --quality 50");
  EXPECT_EQ(jpeg.status, 0) << jpeg.out;
  Result mode = run("render " + sample_mesh().string() + " -o " + out + " --mode hologram");
  EXPECT_EQ(mode.status, 2);
  EXPECT_NE(mode.out.find("unknown mode"), std::string::npos) << mode.out;
  Result size = run("render " + sample_mesh().string() + " -o " + out + " --size 0x10");
  EXPECT_EQ(size.status, 2);
  Result format = run("render " + sample_mesh().string() + " -o " + (dir / "frame.bmp").string() + " --size 16x16");
  EXPECT_EQ(format.status, 2);
  EXPECT_NE(format.out.find(".png"), std::string::npos) << format.out;
  EXPECT_FALSE(std::filesystem::exists(dir / "frame.bmp"));
  Result attribute = run("render " + sample_mesh().string() + " -o " + out + " --attribute Nope");
  EXPECT_EQ(attribute.status, 2);
  EXPECT_NE(attribute.out.find("Temp"), std::string::npos) << "the message lists the attributes there are: " << attribute.out;
}

// `render` of lines (a selection ghosting the rest) and of point isosurfaces, as a user runs it.
void render_lines_and_points(const std::string& mesh, const std::string& out, const std::filesystem::path& dir) {
  Result ok = run("render " + mesh + " -o " + out + " --size 96x96 --mode dvr+lines --field Velocity --seeds line:0,-5,2,0,5,2,20 --select-lines 3,4 --json");
  ASSERT_EQ(ok.status, 0) << ok.out;
  auto j = last_json_line(ok.out);
  EXPECT_EQ(j["lines"]["count"], 20);
  EXPECT_EQ(j["lines"]["selected"], 2);
  EXPECT_GT(j["lines"]["segments_ghosted"].get<int>(), j["lines"]["segments_opaque"].get<int>());
  Result compared = run("render " + mesh + " -o " + (dir / "plain.png").string() + " --size 96x96 --compare " + out + " --json");
  ASSERT_EQ(compared.status, 0) << compared.out;
  EXPECT_LT(last_json_line(compared.out)["compare_psnr_db"].get<double>(), 40.0) << "the lines change the image";
  Result points = run("render " + mesh + " -o " + out + " --size 96x96 --mode points --attribute Temp --iso 400,600 --point-target 20000 --json");
  ASSERT_EQ(points.status, 0) << points.out;
  EXPECT_NEAR(last_json_line(points.out)["points"].get<double>(), 20000, 3000);
}

TEST(RenderCli, StreamLinesAndPointsRenderAndBadSeedsOrFieldsAreClearErrors) {
  const auto dir = scratch_dir("render-cli-lines");
  const std::string out = (dir / "lines.png").string();
  const std::string mesh = sample_mesh().string();
  // under ASan the three renders take minutes (30 s in release on the shared machine): the
  // release run covers them; the refusals below come before any rendering and run in both
  if (!kSanitized) render_lines_and_points(mesh, out, dir);
  // the threats: a scalar field, a field the mesh lacks, a malformed seed spec, line options
  // without lines, a PNG to compare that is not one
  Result scalar = run("render " + mesh + " -o " + out + " --mode lines --field Temp");
  EXPECT_EQ(scalar.status, 2);
  EXPECT_NE(scalar.out.find("Temp"), std::string::npos) << scalar.out;
  Result missing = run("render " + mesh + " -o " + out + " --mode lines --field Nope");
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.out.find("Nope"), std::string::npos) << missing.out;
  Result seeds = run("render " + mesh + " -o " + out + " --mode lines --seeds line:0,0,0");
  EXPECT_EQ(seeds.status, 2);
  EXPECT_NE(seeds.out.find("line"), std::string::npos) << seeds.out;
  Result too_many = run("render " + mesh + " -o " + out + " --mode lines --seeds dense:100000");
  EXPECT_EQ(too_many.status, 2) << too_many.out;
  Result depth = run("render " + mesh + " -o " + out + " --mode lines --depth-correction 2");
  EXPECT_EQ(depth.status, 2);
  EXPECT_NE(depth.out.find("--depth-correction must be in [0, 1]"), std::string::npos) << depth.out;
  Result no_lines = run("render " + mesh + " -o " + out + " --seeds dense:4");
  EXPECT_EQ(no_lines.status, 2);
  EXPECT_NE(no_lines.out.find("needs a mode with lines"), std::string::npos) << no_lines.out;
  Result bad_compare = run("render " + mesh + " -o " + out + " --size 16x16 --compare " + mesh);
  EXPECT_EQ(bad_compare.status, 2);
  EXPECT_NE(bad_compare.out.find("not a PNG"), std::string::npos) << bad_compare.out;
}

TEST(RenderCli, ASliceIsLitUnlessSliceFlat) {
  const auto dir = scratch_dir("render-cli-slice");
  auto bytes = [](const std::filesystem::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), {});
  };
  const std::string base = "render " + sample_mesh().string() + " --mode slice --slice 1,0,0,0 --size 96x64 --camera azimuth=60,elevation=20";
  Result lit = run(base + " -o " + (dir / "lit.png").string());
  ASSERT_EQ(lit.status, 0) << lit.out;
  Result flat = run(base + " --slice-flat -o " + (dir / "flat.png").string());
  ASSERT_EQ(flat.status, 0) << flat.out;
  EXPECT_NE(bytes(dir / "lit.png"), bytes(dir / "flat.png")) << "the oblique slice is shaded when lit";
}

// --hide-regions leaves boundary regions out of the surface (ids, or "box": every region on the
// domain's box); the report lists the regions; an id the boundary lacks, or a mode without the
// surface, is a clear error.
TEST(RenderCli, HiddenBoundaryRegionsLeaveTheSurfaceAndBadIdsAreClearErrors) {
  const auto dir = scratch_dir("render-cli-regions");
  const std::string mesh = sample_mesh().string(), all = (dir / "all.png").string(), box = (dir / "box.png").string();
  Result shown = run("render " + mesh + " -o " + all + " --size 96x96 --mode surface");
  ASSERT_EQ(shown.status, 0) << shown.out;
  Result hidden = run("render " + mesh + " -o " + box + " --size 96x96 --mode surface --hide-regions box --json");
  ASSERT_EQ(hidden.status, 0) << hidden.out;
  const auto j = last_json_line(hidden.out);
  ASSERT_GE(j["regions"].size(), 2u) << j.dump();
  size_t hidden_count = 0;
  for (const auto& region : j["regions"]) {
    EXPECT_EQ(region["hidden"], region["touches_domain_box"]) << region.dump();
    hidden_count += region["hidden"].get<bool>();
  }
  EXPECT_GT(hidden_count, 0u);
  EXPECT_NE(read_file(all), read_file(box)) << "the regions on the box are gone";
  Result past = run("render " + mesh + " -o " + box + " --mode surface --hide-regions 0,99");
  EXPECT_NE(past.status, 0);
  EXPECT_NE(past.out.find("no region 99"), std::string::npos) << past.out;
  Result fraction = run("render " + mesh + " -o " + box + " --mode surface --hide-regions 1.5");
  EXPECT_NE(fraction.status, 0);
  EXPECT_NE(fraction.out.find("no region 1.5"), std::string::npos) << fraction.out;
  Result volume = run("render " + mesh + " -o " + box + " --hide-regions 0");
  EXPECT_NE(volume.status, 0);
  EXPECT_NE(volume.out.find("needs a mode with surface"), std::string::npos) << volume.out;
}

// A Gmsh mesh whose boundary carries physical surfaces: --hide-regions takes the input's names
// (and ids) for the mesh file and for its store alike, the report lists each region's name and
// "input tags" as its source, hiding a named region changes the image, and an unknown name is a
// clear error; `info` on the store lists the same regions.
TEST(RenderCli, HiddenRegionsByTheInputsNamesOnAMeshFileAndItsStore) {
  const auto dir = scratch_dir("render-cli-tagged");
  TaggedCube cube = tagged_cube();
  const std::string mesh = (dir / "cube.msh").string(), store = (dir / "cube").string();
  write_gmsh(mesh, cube.mesh, cube.gmsh);
  ASSERT_EQ(run("preprocess " + mesh + " -o " + store + " --progress none").status, 0);
  const std::string camera = " --size 96x96 --mode surface";
  for (const std::string& input : {mesh, store}) {
    const std::string all = (dir / "all.png").string(), hidden = (dir / "hidden.png").string();
    Result shown = run("render " + input + " -o " + all + camera);
    ASSERT_EQ(shown.status, 0) << shown.out;
    Result named = run("render " + input + " -o " + hidden + camera + " --hide-regions outlet,walls --json");
    ASSERT_EQ(named.status, 0) << named.out;
    const auto j = last_json_line(named.out);
    std::map<std::string, bool> hidden_by_name;
    for (const auto& region : j["regions"]) {
      EXPECT_EQ(region["source"], "input tags") << region.dump();
      hidden_by_name[region["name"].get<std::string>()] = region["hidden"].get<bool>();
    }
    EXPECT_EQ(hidden_by_name, (std::map<std::string, bool>{{"inlet", false}, {"outlet", true}, {"walls", true}, {"physical 7", false}, {"untagged", false}}))
        << input << ": " << j["regions"].dump();
    EXPECT_NE(read_file(all), read_file(hidden)) << input << ": the outlet and the walls are gone";
    Result unknown = run("render " + input + " -o " + hidden + " --mode surface --hide-regions wing");
    EXPECT_NE(unknown.status, 0);
    EXPECT_NE(unknown.out.find("no region named 'wing'"), std::string::npos) << unknown.out;
  }
  Result info = run("info " + store + " --json");
  ASSERT_EQ(info.status, 0) << info.out;
  const auto j = nlohmann::json::parse(info.out);
  EXPECT_EQ(j["regions"]["source"], "input tags");
  ASSERT_EQ(j["regions"]["regions"].size(), 5u) << j["regions"].dump();
  EXPECT_GT(j["files"]["boundary_tags.bin"]["bytes"].get<uint64_t>(), 32u);
  Result text = run("info " + store);
  EXPECT_NE(text.out.find("regions     5, from input tags"), std::string::npos) << text.out;
}

TEST(RenderCli, ImageSidesAreLimited) {
  const auto dir = scratch_dir("render-cli-limits");
  const std::string out = (dir / "frame.png").string();
  Result at = run("render " + sample_mesh().string() + " -o " + out + " --size 8192x2 --mode surface");  // at the limit (kMaxFrameSide)
  EXPECT_EQ(at.status, 0) << at.out;
  Result past = run("render " + sample_mesh().string() + " -o " + out + " --size 8193x2");
  EXPECT_EQ(past.status, 2);
  EXPECT_NE(past.out.find("8192"), std::string::npos) << past.out;
  Result junk = run("render " + sample_mesh().string() + " -o " + out + " --size 16x16x");
  EXPECT_EQ(junk.status, 2);
}

// Without --tf a whole mesh and its store at full resolution draw alike: the opacity ramps over
// the attribute's range in both (a mesh was drawn opaque before, the store with the ramp).
TEST(RenderCli, AMeshAndItsStoreWithoutATransferFunctionLookAlike) {
  const auto dir = scratch_dir("render-cli-default-tf");
  const std::string store = (dir / "sample.store").string(), mesh_png = (dir / "mesh.png").string();
  ASSERT_EQ(run("preprocess " + sample_mesh().string() + " -o " + store + " --segment-tets 2000 --base-tets 3000 --progress none").status, 0);
  Result mesh = run("render " + sample_mesh().string() + " -o " + mesh_png + " --size 96x72 --attribute Temp --json");
  ASSERT_EQ(mesh.status, 0) << mesh.out;
  Result whole = run("render " + store + " -o " + (dir / "store.png").string() + " --size 96x72 --attribute Temp --budget 1000000 --compare " + mesh_png + " --json");
  ASSERT_EQ(whole.status, 0) << whole.out;
  const auto j = last_json_line(whole.out);
  ASSERT_EQ(j["tets"], last_json_line(mesh.out)["tets"]) << "the store's full resolution is the mesh";
  EXPECT_GT(j["compare_psnr_db"].get<double>(), 45) << whole.out;
}

TEST(RenderCli, RendersTheCutOfAStoreFromTheDefaultView) {
  const auto dir = scratch_dir("render-cli-store");
  const std::string store = (dir / "sample.store").string();
  ASSERT_EQ(run("preprocess " + sample_mesh().string() + " -o " + store + " --segment-tets 2000 --base-tets 3000 --progress none").status, 0);
  Result r = run("render " + store + " -o " + (dir / "store.png").string() + " --size 64x48 --budget 9000 --attribute Temp --mode dvr+iso --iso 500 --backend gl --json");  // the GL renderer's isosurface triangles
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = last_json_line(r.out);
  EXPECT_LE(j["tets"].get<uint64_t>(), 9000u);
  EXPECT_GT(j["iso_triangles"].get<uint64_t>(), 0u);
  const auto& range = j["legend"]["range"];
  EXPECT_LT(range[0].get<double>(), range[1].get<double>()) << "the colour range is the attribute's over the whole dataset";
  // how the cut met its budget is reported; below the coarsest level it says so, not silently
  EXPECT_EQ(j["cut"]["budget"], 9000);
  EXPECT_EQ(j["cut"]["tets"], j["tets"]);
  EXPECT_FALSE(j["cut"]["over_budget"].get<bool>());
  // (the CPU ray caster: the report is the cut's, whichever backend draws it)
  Result below = run("render " + store + " -o " + (dir / "below.png").string() + " --size 32x24 --budget 10 --backend cpu --json");
  ASSERT_EQ(below.status, 0) << below.out;
  const auto b = last_json_line(below.out);
  EXPECT_TRUE(b["cut"]["over_budget"].get<bool>()) << below.out;
  EXPECT_GT(b["cut"]["tets"].get<uint64_t>(), 10u);
  EXPECT_NE(below.out.find("above the budget of 10"), std::string::npos) << below.out;
  Result mesh_budget = run("render " + sample_mesh().string() + " -o " + (dir / "x.png").string() + " --budget 9000");
  EXPECT_EQ(mesh_budget.status, 2);
  EXPECT_NE(mesh_budget.out.find("multiresolution"), std::string::npos) << mesh_budget.out;
  Result attribute = run("render " + store + " -o " + (dir / "x.png").string() + " --size 16x16 --attribute Nope");
  EXPECT_EQ(attribute.status, 2);
  EXPECT_NE(attribute.out.find("Nope"), std::string::npos) << attribute.out;
}

// --component: one component of a vector attribute is drawn, over its own range (the whole
// dataset's for a store, the mesh's for a mesh file), and the legend says which; a component of
// a scalar, or an unknown one, is a clear error.
TEST(RenderCli, AVectorComponentIsDrawnOverItsRangeAndBadComponentsAreClearErrors) {
  const auto dir = scratch_dir("render-cli-component");
  const std::string out = (dir / "x.png").string();
  Result magnitude = run("render " + sample_mesh().string() + " -o " + (dir / "m.png").string() + " --size 48x32 --attribute Velocity --json");
  ASSERT_EQ(magnitude.status, 0) << magnitude.out;
  Result x = run("render " + sample_mesh().string() + " -o " + out + " --size 48x32 --attribute Velocity --component x --json");
  ASSERT_EQ(x.status, 0) << x.out;
  const auto m = last_json_line(magnitude.out)["legend"], j = last_json_line(x.out)["legend"];
  EXPECT_EQ(m["component"], "magnitude");
  EXPECT_EQ(j["component"], "x");
  EXPECT_GE(m["range"][0].get<double>(), 0) << "a magnitude is never negative";
  EXPECT_LT(j["range"][0].get<double>(), 0) << "the X component of the disk's flow takes both signs";
  EXPECT_LE(j["range"][1].get<double>(), m["range"][1].get<double>());
  Result scalar = run("render " + sample_mesh().string() + " -o " + out + " --size 16x16 --attribute Temp --component x");
  EXPECT_EQ(scalar.status, 2);
  EXPECT_NE(scalar.out.find("no component x"), std::string::npos) << scalar.out;
  Result unknown = run("render " + sample_mesh().string() + " -o " + out + " --size 16x16 --attribute Velocity --component w");
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.out.find("--component expects magnitude, x, y or z"), std::string::npos) << unknown.out;
}

}  // namespace
}  // namespace tetrascope::testing
