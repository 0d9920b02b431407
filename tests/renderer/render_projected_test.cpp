// The projected-tetrahedra volume method (`--volume projected`) and the exact one (the default) against the CPU
// reference (reference_render): from outside and inside meshes, with isosurfaces composed in
// the volume; the thick vertex against the exact ray through it; frames stopped between
// chunks by RenderSettings::should_stop.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "mesh_checks.h"
#include "projected_tets.h"
#include "test_paths.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/core/tet_topology.h"
#include "tetrascope/core/vec3.h"

namespace tetrascope::testing {
namespace {

using view::VolumeMethod;

renderer::Renderer& gl() {
  // kept until exit: Mesa's driver frees some of its memory only while loaded
  static renderer::Renderer* r = renderer::Renderer::create().release();
  return *r;
}

renderer::RenderSettings settings_for(const renderer::SceneMesh& scene, uint32_t w, uint32_t h, const view::Camera& camera) {
  renderer::RenderSettings s;
  s.width = w;
  s.height = h;
  s.camera = camera;
  s.camera.aspect = double(w) / h;
  s.tf.attribute = scene.attribute;
  s.tf.opacity = {{scene.value_min, 0.05}, {scene.value_max, 0.6}};
  return s;
}

struct Psnrs {
  double projected, exact;
};

// Both methods against one reference image.
Psnrs both_methods(const renderer::SceneMesh& scene, renderer::RenderSettings s, const char* name) {
  gl().set_mesh(scene);
  const renderer::Image reference = renderer::reference_render(scene, s);
  s.volume = VolumeMethod::projected;
  const double projected = renderer::psnr(gl().render(s), reference);
  s.volume = VolumeMethod::exact;
  const double exact = renderer::psnr(gl().render(s), reference);
  std::printf("%s, %ux%u: projected %.1f dB, exact %.1f dB\n", name, s.width, s.height, projected, exact);
  return {projected, exact};
}

view::Camera look(std::array<double, 3> eye, std::array<double, 3> target) {
  view::Camera c;
  c.eye = eye;
  c.target = target;
  c.up = {0, 0, 1};
  return c;
}

// The centroid of the tet whose centroid is nearest `wanted`: a point inside the mesh.
std::array<double, 3> inside_point(const renderer::SceneMesh& scene, std::array<double, 3> wanted) {
  std::array<double, 3> best{};
  double best_d2 = 1e300;
  for (size_t t = 0; t < scene.tets.size() / 4; ++t) {
    std::array<double, 3> c{};
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 3; ++k) c[k] += 0.25 * scene.xyz[3 * size_t{scene.tets[4 * t + j]} + k];
    const double d2 = std::pow(c[0] - wanted[0], 2) + std::pow(c[1] - wanted[1], 2) + std::pow(c[2] - wanted[2], 2);
    if (d2 < best_d2) {
      best_d2 = d2;
      best = c;
    }
  }
  return best;
}

// The thick vertex of random tets, perspective and orthographic: the ray from the eye (or
// along the view) through it enters the tet there, and leaves it `thickness` further on with
// the back value; the values are the linear field's.
TEST(ProjectedTets, ThickVertexIsTheRayThroughTheTet) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (bool ortho : {false, true}) {
    renderer::SceneMesh mesh;
    for (int t = 0; t < 200; ++t) {
      for (int k = 0; k < 4; ++k) {
        mesh.tets.push_back(static_cast<uint32_t>(mesh.value.size()));
        const double x = u(rng), y = u(rng), z = u(rng);
        mesh.xyz.insert(mesh.xyz.end(), {float(x), float(y), float(z)});
        mesh.value.push_back(float(2 * x - y + 0.5 * z));  // linear: the segment's values are exact
      }
    }
    view::Camera c = look({4, -3, 2}, {0, 0, 0});
    c.orthographic = ortho;
    c.ortho_height = 4;
    const renderer::Frame f = renderer::camera_frame(c, 100, 100);
    int crossing = 0;
    for (uint32_t t = 0; t < 200; ++t) {
      renderer::ProjectedVertex fan[renderer::kVerticesPerTet];
      renderer::classify_tet(mesh, t, f, -3, 1.0 / 6, false, fan);
      const renderer::ProjectedVertex& th = fan[4];
      const Vec3 p{th.x, th.y, th.z};
      const Vec3 d = f.ortho ? f.forward : normalise(p - f.eye);
      // the exact segment of the ray through p
      Vec3 q[4];
      for (int k = 0; k < 4; ++k) q[k] = {mesh.xyz[3 * (4 * t + k)], mesh.xyz[3 * (4 * t + k) + 1], mesh.xyz[3 * (4 * t + k) + 2]};
      const Vec3 centre = 0.25 * (q[0] + q[1] + q[2] + q[3]);
      double t_in = -1e300, t_out = 1e300;
      for (int face = 0; face < 4; ++face) {
        Vec3 n = cross(q[kTetFace[face][1]] - q[kTetFace[face][0]], q[kTetFace[face][2]] - q[kTetFace[face][0]]);
        if (dot(n, centre - q[kTetFace[face][0]]) > 0) n = -1.0 * n;  // outward
        const double dn = dot(n, d), num = -dot(n, p - q[kTetFace[face][0]]);
        if (dn > 0) t_out = std::min(t_out, num / dn);
        if (dn < 0) t_in = std::max(t_in, num / dn);
      }
      const double scale = length(q[1] - q[0]) + length(q[2] - q[0]) + length(q[3] - q[0]);
      EXPECT_NEAR(t_in, 0, 1e-4 * scale) << "tet " << t << (ortho ? " ortho" : "");
      EXPECT_NEAR(t_out, th.thickness, 1e-4 * scale) << "tet " << t << (ortho ? " ortho" : "");
      const Vec3 back = p + double(th.thickness) * d;
      auto value = [](const Vec3& x) { return (2 * x[0] - x[1] + 0.5 * x[2] + 3) / 6; };
      EXPECT_NEAR(th.front, value(p), 1e-4);
      EXPECT_NEAR(th.back, value(back), 1e-4);
      crossing += fan[2].x != fan[3].x;  // a quadrilateral projection (a triangle repeats p2)
      for (int j = 0; j < 4; ++j) EXPECT_EQ(fan[j].thickness, 0.0f);
    }
    EXPECT_GT(crossing, 20) << "both classes occur";
    EXPECT_LT(crossing, 180) << "both classes occur";
  }
}

TEST(ProjectedTets, SampleFromOutsideMatchesTheReference) {
  const storage::TetMesh m = storage::load_mesh(sample_mesh());
  const auto scene = renderer::SceneMesh::from(m, "Temp");
  const auto s = settings_for(scene, 160, 160, view::parse_camera("azimuth=35,elevation=25", scene.bounds));
  const Psnrs db = both_methods(scene, s, "disk_out_ref from outside");
  EXPECT_GE(db.projected, 40.0);
  EXPECT_GE(db.exact, 50.0);
  view::Camera ortho = view::parse_camera("azimuth=35,elevation=25", scene.bounds);
  ortho.orthographic = true;
  const Psnrs o = both_methods(scene, settings_for(scene, 128, 96, ortho), "disk_out_ref from outside, orthographic");
  EXPECT_GE(o.projected, 40.0);
  EXPECT_GE(o.exact, 50.0);
}

TEST(ProjectedTets, SampleAndSharedDatasetsFromInside) {
  const storage::TetMesh m = storage::load_mesh(sample_mesh());
  const auto scene = renderer::SceneMesh::from(m, "Temp");
  const auto eye = inside_point(scene, {2, -2, 3});
  const Psnrs disk = both_methods(scene, settings_for(scene, 120, 90, look(eye, {0, 0, 0})), "disk_out_ref from inside");
  EXPECT_GE(disk.projected, 35.0);
  EXPECT_GE(disk.exact, 50.0);
  // the reference takes about a minute on these two under ASan; the release run covers them
  if (kSanitized) GTEST_SKIP() << "sanitizer build: the shared datasets from inside are left to the release run";
  struct Case {
    const char* file;
    const char* attribute;
    std::array<double, 3> wanted_eye, target;
  };
  for (const Case& c : {Case{"onera_m6_potential.vtk", "pressure_coefficient", {-0.5, 0.6, 0.3}, {0.4, 0.6, 0}},
                        Case{"fea_bracket.vtk", "von_mises_stress_psi", {0, 0.4, 1.1}, {1.5, 0.4, 1.1}}}) {
    const auto path = shared_data() / c.file;
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " missing";
    const storage::TetMesh mesh = storage::load_mesh(path);
    const auto sc = renderer::SceneMesh::from(mesh, c.attribute);
    const Psnrs db = both_methods(sc, settings_for(sc, 96, 72, look(inside_point(sc, c.wanted_eye), c.target)), c.file);
    EXPECT_GE(db.projected, 35.0) << c.file;
    EXPECT_GE(db.exact, 45.0) << c.file;
  }
}

// Translucent isosurfaces inside the volume: both methods against the reference, which splits
// each segment at the isovalues; and the surfaces show (the image differs from the volume's).
TEST(ProjectedTets, TranslucentIsosurfacesInTheVolume) {
  if (kSanitized) GTEST_SKIP() << "about 30 s under a sanitizer (seconds in release): the release run covers it";
  const storage::TetMesh m = storage::load_mesh(sample_mesh());
  const auto scene = renderer::SceneMesh::from(m, "Temp");
  auto s = settings_for(scene, 128, 128, view::parse_camera("azimuth=35,elevation=25", scene.bounds));
  s.tf.opacity = {{scene.value_min, 0.02}, {scene.value_max, 0.3}};
  gl().set_mesh(scene);
  const renderer::Image volume_only = gl().render(s);
  s.iso = true;
  s.isovalues = {500, 750};
  s.iso_opacity = 0.5;
  const Psnrs outside = both_methods(scene, s, "isosurfaces at 0.5 in the volume, outside");
  EXPECT_GE(outside.projected, 35.0);
  EXPECT_GE(outside.exact, 35.0);
  renderer::FrameTimings t;
  const renderer::Image with_iso = gl().render(s, &t);
  EXPECT_EQ(t.iso_triangles, 0u) << "composed in the volume, not drawn as triangles";
  EXPECT_LT(renderer::psnr(with_iso, volume_only), 40.0) << "the isosurfaces show";
  // where the transfer function is transparent the isosurfaces still show
  s.tf.opacity = {{scene.value_min, 0}, {scene.value_max, 0}};
  const Psnrs clear = both_methods(scene, s, "isosurfaces at 0.5 in a transparent volume");
  EXPECT_GE(clear.projected, 35.0);
  EXPECT_GE(clear.exact, 35.0);
  // and from inside
  s.tf.opacity = {{scene.value_min, 0.02}, {scene.value_max, 0.3}};
  s.camera = look(inside_point(scene, {2, -2, 3}), {0, 0, 0});
  const Psnrs inside = both_methods(scene, s, "isosurfaces at 0.5 in the volume, inside");
  EXPECT_GE(inside.projected, 35.0);
  EXPECT_GE(inside.exact, 35.0);
}

// should_stop after the first chunk: the frame stops there, says so, and drew fewer tets.
TEST(ProjectedTets, ShouldStopEndsTheFrameBetweenChunks) {
  const storage::TetMesh m = kuhn_box(24, 0, [](float x, float y, float z) { return x + y * z; });
  const auto scene = renderer::SceneMesh::from(m, "f");
  const uint64_t tets = scene.tets.size() / 4;
  ASSERT_GT(tets, uint64_t{renderer::kTetsPerChunk});
  gl().set_mesh(scene);
  for (VolumeMethod method : {VolumeMethod::projected, VolumeMethod::exact}) {
    auto s = settings_for(scene, 64, 64, view::parse_camera("azimuth=35,elevation=25", scene.bounds));
    s.volume = method;
    renderer::FrameTimings whole;
    gl().render(s, &whole);
    EXPECT_FALSE(whole.interrupted);
    EXPECT_EQ(whole.tets_drawn, tets);
    int asked = 0;
    s.should_stop = [&] { return ++asked > 1; };  // the check before the volume says go on
    renderer::FrameTimings part;
    const renderer::Image image = gl().render(s, &part);
    EXPECT_TRUE(part.interrupted);
    EXPECT_EQ(part.tets_drawn, uint64_t{renderer::kFirstStopChunk}) << "a frame that may be stopped starts with a small chunk";
    EXPECT_EQ(image.width, 64u);
    // three chunks, each at most twice the one before
    asked = 0;
    s.should_stop = [&] { return ++asked > 3; };
    renderer::FrameTimings three;
    gl().render(s, &three);
    EXPECT_TRUE(three.interrupted);
    EXPECT_GE(three.tets_drawn, uint64_t{3 * renderer::kFirstStopChunk});
    EXPECT_LE(three.tets_drawn, uint64_t{7 * renderer::kFirstStopChunk});
    s.should_stop = [] { return false; };
    renderer::FrameTimings again;
    gl().render(s, &again);
    EXPECT_FALSE(again.interrupted);
    EXPECT_EQ(again.tets_drawn, tets);
  }
}

}  // namespace
}  // namespace tetrascope::testing
