// A tensor dataset as a user meets it: `info` on the file and on its store lists the tensor
// (kind, component order, positive semi-definiteness) and its derived scalars, and a derived
// scalar renders like any attribute, from the mesh (checked against the reference integrator)
// and from the store's cut.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iterator>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "fixture_writers.h"
#include "mesh_checks.h"

namespace tetrascope::testing {
namespace {

nlohmann::json last_json_line(const std::string& out) {
  std::string last = out.substr(0, out.find_last_not_of('\n') + 1);
  last = last.substr(last.rfind('\n') == std::string::npos ? 0 : last.rfind('\n') + 1);
  return nlohmann::json::parse(last);
}

// A box of 6000 tets with a 3x3 stress tensor (VTK TENSORS) of a bar under tension along x
// with a bending part: σxx = 100 + 50 y, σxy = σyx = 10 z, the rest 0.
std::filesystem::path write_tensor_mesh(const std::filesystem::path& dir) {
  CellMesh m = from_tets(kuhn_box(10, 0.2, [](float x, float, float) { return x; }));
  storage::Attribute stress{{"stress", 9, storage::AttributeKind::kTensor}, {}};
  for (size_t v = 0; v < m.x.size(); ++v) {
    const float sxx = 100 + 50 * m.y[v], sxy = 10 * m.z[v];
    for (float c : {sxx, sxy, 0.f, sxy, 0.f, 0.f, 0.f, 0.f, 0.f}) stress.values.push_back(c);
  }
  m.attributes.push_back(stress);
  const auto path = dir / "bar.vtk";
  write_vtk_legacy(path, m);
  return path;
}

const nlohmann::json* find(const nlohmann::json& attributes, const std::string& name) {
  for (const auto& a : attributes)
    if (a["name"] == name) return &a;
  return nullptr;
}

void expect_tensor_attributes(const nlohmann::json& attributes, const std::string& label) {
  SCOPED_TRACE(label);
  const nlohmann::json* stress = find(attributes, "stress");
  ASSERT_TRUE(stress) << attributes.dump();
  EXPECT_EQ((*stress)["kind"], "tensor");
  EXPECT_EQ((*stress)["components"], 6);
  EXPECT_EQ((*stress)["tensor"]["order"], nlohmann::json({"xx", "yy", "zz", "xy", "yz", "xz"}));
  EXPECT_FALSE((*stress)["tensor"]["positive_semidefinite"].get<bool>()) << "a tension-shear state has a negative principal stress";
  const nlohmann::json* von_mises = find(attributes, "stress.von_mises");
  ASSERT_TRUE(von_mises);
  EXPECT_EQ((*von_mises)["kind"], "derived");
  EXPECT_EQ((*von_mises)["derived_from"], "stress");
  EXPECT_EQ((*von_mises)["quantity"], "von_mises");
  // von Mises of σxx = s, σxy = t is sqrt(s² + 3t²): from 100 (y = z = 0) to sqrt(150² + 300)
  EXPECT_NEAR((*von_mises)["min"].get<double>(), 100, 1e-3);
  EXPECT_NEAR((*von_mises)["max"].get<double>(), std::sqrt(150.0 * 150 + 300), 1e-3);
  for (const char* q : {"lambda1", "lambda2", "lambda3", "trace", "fa", "cl", "cp", "cs"}) {
    std::string name = "stress.";
    name += q;
    EXPECT_TRUE(find(attributes, name)) << name;
  }
}

TEST(TensorCli, InfoListsTheTensorAndItsDerivedScalarsForTheFileAndTheStore) {
  const auto dir = scratch_dir("tensor-cli");
  const auto mesh = write_tensor_mesh(dir);
  CliResult file = run_cli("info --json " + mesh.string());
  ASSERT_EQ(file.status, 0) << file.out;
  expect_tensor_attributes(nlohmann::json::parse(file.out)["attributes"], "mesh file");
  CliResult text = run_cli("info " + mesh.string());
  EXPECT_NE(text.out.find("tensor (xx yy zz xy yz xz)"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("scalar from tensor 'stress'"), std::string::npos) << text.out;

  const std::string store = (dir / "bar.store").string();
  CliResult built = run_cli("preprocess " + mesh.string() + " -o " + store + " --segment-tets 2000 --base-tets 3000 --progress none");
  ASSERT_EQ(built.status, 0) << built.out;
  CliResult info = run_cli("info --json " + store);
  ASSERT_EQ(info.status, 0) << info.out;
  expect_tensor_attributes(nlohmann::json::parse(info.out)["attributes"], "store");
  CliResult store_text = run_cli("info " + store);
  EXPECT_NE(store_text.out.find("tensor (xx yy zz xy yz xz)"), std::string::npos) << store_text.out;

  // a cut written as VTK reads back with its tensor and derived scalars, without warnings
  const std::string cut = (dir / "cut.vtk").string();
  ASSERT_EQ(run_cli("cut " + store + " --budget 3000 -o " + cut).status, 0);
  CliResult cut_info = run_cli("info --json " + cut);
  ASSERT_EQ(cut_info.status, 0) << cut_info.out;
  const auto j = nlohmann::json::parse(cut_info.out);
  EXPECT_EQ((*find(j["attributes"], "stress"))["kind"], "tensor");
  EXPECT_EQ((*find(j["attributes"], "stress.von_mises"))["kind"], "derived");
  EXPECT_TRUE(j["warnings"].empty()) << j["warnings"].dump();
}

TEST(TensorCli, ADerivedScalarRendersFromTheMeshAndTheStore) {
  const auto dir = scratch_dir("tensor-cli-render");
  const auto mesh = write_tensor_mesh(dir);
  CliResult cpu = run_cli("render " + mesh.string() + " -o " + (dir / "vm.png").string() + " --size 64x48 --attribute stress.von_mises --backend cpu --reference --json");
  ASSERT_EQ(cpu.status, 0) << cpu.out;
  const auto j = last_json_line(cpu.out);
  EXPECT_GT(j["reference_psnr_db"].get<double>(), 50);
  EXPECT_GT(j["tets_drawn"].get<uint64_t>(), 0u);
  const std::string store = (dir / "bar.store").string();
  ASSERT_EQ(run_cli("preprocess " + mesh.string() + " -o " + store + " --segment-tets 2000 --base-tets 3000 --progress none").status, 0);
  CliResult cut = run_cli("render " + store + " -o " + (dir / "cut.png").string() + " --size 48x32 --budget 3000 --attribute stress.fa --mode dvr+iso --iso 0.5 --json");
  ASSERT_EQ(cut.status, 0) << cut.out;
  const auto c = last_json_line(cut.out);
  const auto& range = c["legend"]["range"];
  EXPECT_LT(range[0].get<double>(), range[1].get<double>()) << cut.out;
}

// Lines along the major principal stress: the bar's tension runs along x, so a line through
// the middle reaches both ends; --min-cl is refused for a field that is not a tensor.
TEST(TensorCli, StreamLinesFollowTheMajorPrincipalStress) {
  const auto dir = scratch_dir("tensor-cli-lines");
  const auto mesh = write_tensor_mesh(dir);
  const std::string out = (dir / "lines.vtk").string();
  CliResult r = run_cli("streamlines " + mesh.string() + " --field stress --seeds points:0.5,0.5,0.5 --min-cl 0.5 -o " + out + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["lines"], 1);
  EXPECT_EQ(j["stops"]["boundary"], 2) << r.out;
  CliResult vector = run_cli("streamlines " + mesh.string() + " --field f --seeds points:0.5,0.5,0.5 --min-cl 0.5 -o " + out);
  EXPECT_EQ(vector.status, 2) << vector.out;
  EXPECT_NE(vector.out.find("--min-cl needs a tensor"), std::string::npos) << vector.out;
}

// Diffusion surfaces of a pancake-shaped tensor whose minor eigenvector is z: the surface
// through a seed is the plane z = const across the box, written as VTK polygons with its
// normals; a field that is not a tensor, critical-point seeds and a bend of 90 degrees or more
// get a usage error that names them.
TEST(TensorCli, DiffusionSurfacesOfAPlanarTensorAreFlat) {
  const auto dir = scratch_dir("tensor-cli-surfaces");
  CellMesh m = from_tets(kuhn_box(8, 0.2, [](float x, float, float) { return x; }));
  storage::Attribute d{{"D", 9, storage::AttributeKind::kTensor}, {}};
  for (size_t v = 0; v < m.x.size(); ++v)
    for (float c : {1.f, 0.f, 0.f, 0.f, 0.9f, 0.f, 0.f, 0.f, 0.05f}) d.values.push_back(c);
  m.attributes.push_back(d);
  const auto mesh = dir / "pancakes.vtk";
  write_vtk_legacy(mesh, m);
  const std::string out = (dir / "surfaces.vtk").string();
  CliResult r = run_cli("diffusion-surfaces " + mesh.string() + " --tensor D --seeds 'points:0.5,0.5,0.3;0.5,0.5,0.3001;0.5,0.5,0.7' -o " + out + " --json");
  ASSERT_EQ(r.status, 0) << r.out;
  const auto j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j["surfaces"], 2) << "the second seed lies on the first surface";
  EXPECT_EQ(j["seeds_refused"], 1);
  EXPECT_GT(j["triangles"].get<int>(), 100);
  EXPECT_GT(j["operations"]["C"].get<int>(), 0);
  EXPECT_GT(j["operations"]["B"].get<int>(), 0) << "the planes end at the box";
  EXPECT_NEAR(j["anisotropy"]["planar"]["volume_share"].get<double>(), 1.0, 1e-9);
  std::ifstream file(out, std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.rfind("# vtk DataFile Version 3.0\n", 0), 0u);
  EXPECT_NE(text.find("POLYGONS " + std::to_string(j["triangles"].get<int>()) + " "), std::string::npos);
  EXPECT_NE(text.find("NORMALS minor_eigenvector float"), std::string::npos);
  for (const auto& [args, message] : std::vector<std::pair<std::string, std::string>>{
           {"--tensor x --seeds dense:4", "'x' is not a symmetric tensor attribute"},
           {"--tensor D --seeds critical:2", "critical-point seeds need a vector field"},
           {"--tensor D --seeds dense:4 --max-bend 90", "--max-bend must be below 90"}}) {
    CliResult bad = run_cli("diffusion-surfaces " + mesh.string() + " " + args + " -o " + out);
    EXPECT_EQ(bad.status, 2) << args << ": " << bad.out;
    EXPECT_NE(bad.out.find(message), std::string::npos) << bad.out;
  }
}

}  // namespace
}  // namespace tetrascope::testing
