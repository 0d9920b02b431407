// The CPU ray caster against the exact integrator (renderer::reference_render): from outside
// and from inside, with thin opacity, isosurfaces and slices, through a mesh in two pieces and
// across faces two regions do not share; the modes it leaves to the GL renderer are refused.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "mesh_checks.h"
#include "test_paths.h"
#include "tetrascope/renderer/ray_caster.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

renderer::RenderSettings settings_for(const renderer::SceneMesh& scene, uint32_t size, const std::string& camera = "azimuth=35,elevation=25") {
  renderer::RenderSettings s;
  s.width = s.height = size;
  s.camera = view::parse_camera(camera, scene.bounds);
  s.tf.attribute = scene.attribute;
  s.tf.opacity = {{scene.value_min, 0.05}, {scene.value_max, 0.6}};
  return s;
}

// Not the bare background: the volume shows.
void expect_shows_something(const renderer::Image& image, const renderer::RenderSettings& s) {
  renderer::Image empty = image;
  for (size_t i = 0; i < empty.rgba.size(); i += 4)
    for (int k = 0; k < 3; ++k) empty.rgba[i + k] = static_cast<uint8_t>(std::lround(s.background[k] * 255));
  EXPECT_LT(renderer::psnr(image, empty), 25.0);
}

double caster_db(const renderer::SceneMesh& scene, const renderer::RenderSettings& s, const char* what) {
  const renderer::RayCaster caster(scene);
  const renderer::Image image = caster.render(s);
  const renderer::Image reference = renderer::reference_render(scene, s);
  const double db = renderer::psnr(image, reference);
  std::printf("CPU ray caster vs the exact integrator, %s: %.1f dB\n", what, db);
  expect_shows_something(reference, s);
  return db;
}

// A second copy of `mesh` moved by `dx` along x, with vertices of its own.
storage::TetMesh with_copy(const storage::TetMesh& mesh, double dx) {
  storage::TetMesh out = mesh;
  const uint32_t V = static_cast<uint32_t>(mesh.vertex_count());
  for (uint32_t v = 0; v < V; ++v) {
    out.x.push_back(static_cast<float>(mesh.x[v] + dx));
    out.y.push_back(mesh.y[v]);
    out.z.push_back(mesh.z[v]);
  }
  for (uint32_t v : mesh.tets) out.tets.push_back(v + V);
  for (auto& a : out.attributes) {
    const auto copy = a.values;
    a.values.insert(a.values.end(), copy.begin(), copy.end());
  }
  return out;
}

storage::TetMesh wavy_box(int n) {
  return kuhn_box(n, 0.25, [](double x, double y, double z) { return std::sin(5 * x) * std::cos(3 * y) + z; });
}

TEST(RayCaster, MatchesTheExactIntegratorFromOutsideAndInside) {
  const storage::TetMesh m = storage::load_mesh(sample_mesh());
  const auto scene = renderer::SceneMesh::from(m, "Temp");
  EXPECT_GE(caster_db(scene, settings_for(scene, 160), "disk_out_ref from outside"), 55.0);
  const storage::TetMesh box = wavy_box(8);
  const auto boxes = renderer::SceneMesh::from(box, "f");
  EXPECT_GE(caster_db(boxes, settings_for(boxes, 128, "eye=0.4,0.45,0.5,target=1,0.8,0.7,up=0,0,1,fov=60"), "eye inside a box"), 50.0);  // 54.9 dB measured: short segments near the eye read the table's first lengths
}

// A faint transfer function through a long path: opacity 0.002 a unit distance over the
// whole box; and a field of values within 0.01 of a transfer function's kink (opacity 0.5
// at both ends of the range, 0 at 0) seen through a path 200 unit distances long, where an
// interpolated table between values turns the nearly clear volume into a veil.
TEST(RayCaster, ThinOpacityOverALongPathMatchesTheExactIntegrator) {
  const storage::TetMesh box = wavy_box(10);
  const auto scene = renderer::SceneMesh::from(box, "f");
  auto s = settings_for(scene, 96);
  s.tf.opacity = {{scene.value_min, 0.002}, {scene.value_max, 0.004}};
  s.unit_distance = 0.01;
  EXPECT_GE(caster_db(scene, s, "thin opacity"), 55.0);
  const storage::TetMesh near_kink = kuhn_box(10, 0.25, [](double x, double y, double) { return 0.01 * std::sin(5 * x) * std::cos(3 * y); });
  const auto kink_scene = renderer::SceneMesh::from(near_kink, "f");
  auto k = settings_for(kink_scene, 96);
  k.tf.range = {{-1, 1}};
  k.tf.opacity = {{-1, 0.5}, {0, 0}, {1, 0.5}};
  k.unit_distance = 0.005;
  EXPECT_GE(caster_db(kink_scene, k, "values near the transfer function's kink"), 55.0);
}

TEST(RayCaster, IsosurfacesAndSlicesMatchTheExactIntegrator) {
  const storage::TetMesh box = wavy_box(8);
  const auto scene = renderer::SceneMesh::from(box, "f");
  auto s = settings_for(scene, 128);
  s.iso = true;
  s.isovalues = {0.2, 0.9};
  s.iso_opacity = 0.6;
  EXPECT_GE(caster_db(scene, s, "two translucent isosurfaces in the volume"), 45.0);
  auto sliced = settings_for(scene, 128);
  sliced.slices.planes.push_back({{1, 0, 0}, 0.5});
  EXPECT_GE(caster_db(scene, sliced, "a slice behind the volume"), 45.0);
}

// Rays leave the first box and enter the second; two boxes that touch without sharing
// vertices have faces no tet pairs inside the volume.
TEST(RayCaster, RaysEnterAgainAfterAGapAndAcrossUnsharedFaces) {
  const storage::TetMesh box = wavy_box(6);
  for (const double dx : {1.5, 1.0}) {
    const auto scene = renderer::SceneMesh::from(with_copy(box, dx), "f");
    const std::string what = dx > 1 ? "two boxes apart" : "two boxes touching";
    EXPECT_GE(caster_db(scene, settings_for(scene, 128, "azimuth=80,elevation=10"), what.c_str()), 55.0) << what;
  }
}

TEST(RayCaster, OneThreadAndEveryThreadDrawTheSameImage) {
  const storage::TetMesh box = wavy_box(6);
  const auto scene = renderer::SceneMesh::from(box, "f");
  const renderer::RayCaster caster(scene);
  const auto s = settings_for(scene, 100);
  renderer::FrameTimings t;
  const renderer::Image one = caster.render(s, &t, 1), all = caster.render(s, nullptr, 0);
  EXPECT_EQ(one.rgba, all.rgba);
  EXPECT_GT(t.tets_drawn, 0u);
}

TEST(RayCaster, WhatItDoesNotDrawIsRefusedNamingIt) {
  const storage::TetMesh box = wavy_box(3);
  const auto scene = renderer::SceneMesh::from(box, "f");
  const renderer::RayCaster caster(scene);
  auto s = settings_for(scene, 32);
  s.surface = true;
  EXPECT_NE(renderer::RayCaster::unsupported(s).find("surfaces"), std::string::npos);
  try {
    caster.render(s);
    ADD_FAILURE() << "a surface was drawn";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("GL"), std::string::npos) << e.what();
  }
  s.surface = false;
  s.width = renderer::kMaxImageSide + 1;
  EXPECT_THROW(caster.render(s), std::invalid_argument);
  EXPECT_TRUE(renderer::software_renderer("Mesa/X.org, llvmpipe (LLVM 15.0.6, 256 bits), 4.5 (Core Profile) Mesa 22.3.6"));
  EXPECT_FALSE(renderer::software_renderer("NVIDIA Corporation, NVIDIA H200/PCIe/SSE2, 4.6.0 NVIDIA 580.159.04"));
}

}  // namespace
}  // namespace tetrascope::testing
