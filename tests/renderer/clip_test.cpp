// Clip planes and slices (renderer/clip.h): exact areas, volumes and values on hand-built
// boxes, conformity of the clipped mesh, clipped and sliced volume rendering against the CPU
// reference, and a golden image of the ONERA M6 wing seen through a clip.
#include <gtest/gtest.h>
#include <png.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "mesh_checks.h"
#include "test_paths.h"
#include "tetrascope/protocol/planes.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/tet_topology.h"

namespace tetrascope::testing {
namespace {

renderer::Renderer& gl() {
  static renderer::Renderer* r = renderer::Renderer::create().release();  // kept until exit (Mesa)
  return *r;
}

protocol::ClipPlane clip_plane(std::array<double, 3> n, double d, bool invert = false) {
  const double l = std::hypot(n[0], n[1], n[2]);
  return {{{n[0] / l, n[1] / l, n[2] / l}, d / l}, invert};
}

protocol::ClipSpec clip_of(std::vector<protocol::ClipPlane> planes) {
  protocol::ClipSpec c;
  c.planes = std::move(planes);
  return c;
}

double boundary_area(const storage::TetMesh& m) {
  double area = 0;
  for (const auto& f : boundary_faces(m.tets)) {
    const double e1[3] = {double(m.x[f[1]]) - m.x[f[0]], double(m.y[f[1]]) - m.y[f[0]], double(m.z[f[1]]) - m.z[f[0]]};
    const double e2[3] = {double(m.x[f[2]]) - m.x[f[0]], double(m.y[f[2]]) - m.y[f[0]], double(m.z[f[2]]) - m.z[f[0]]};
    area += 0.5 * std::hypot(e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]);
  }
  return area;
}

TEST(Slice, LinearFieldInABoxHasTheCrossSectionAreaAndTheValueEverywhere) {
  // f = x in the unit cube: the slice x = c is the unit square, f = c on all of it; once
  // through vertices (c = 0.5 on a 6-grid: faces in the plane count once) and once between
  const auto scene = renderer::SceneMesh::from(kuhn_box(6, 0, [](float x, float, float) { return x; }), "f");
  for (double c : {0.5, 0.3, 0.9}) {
    std::vector<float> triangles, edges;
    renderer::slice_scene(scene, {{1, 0, 0}, c}, triangles, &edges);
    ASSERT_FALSE(triangles.empty());
    EXPECT_NEAR(renderer::triangles_area(triangles), 1.0, 1e-5) << c;
    for (size_t i = 0; i < triangles.size(); i += 4) {
      EXPECT_NEAR(triangles[i], c, 1e-6);
      EXPECT_NEAR(triangles[i + 3], c, 1e-6);
    }
    EXPECT_FALSE(edges.empty());
  }
  // an oblique plane through the centre, x + y + z = 1.5: a regular hexagon of side sqrt(2)/2
  std::vector<float> triangles;
  const double s = 1 / std::sqrt(3.0);
  renderer::slice_scene(scene, {{s, s, s}, 1.5 * s}, triangles, nullptr);
  EXPECT_NEAR(renderer::triangles_area(triangles), 3 * std::sqrt(3.0) / 2 * 0.5, 1e-5);
  // a plane that misses the mesh gives nothing
  triangles.clear();
  renderer::slice_scene(scene, {{1, 0, 0}, 2}, triangles, nullptr);
  EXPECT_TRUE(triangles.empty());
}

TEST(Clip, ABoxCutInHalfKeepsHalfItsVolumeAndStaysConforming) {
  for (double jitter : {0.0, 0.4}) {
    const storage::TetMesh box = kuhn_box(5, jitter, [](float x, float y, float z) { return x + 2 * y - z; });
    struct Case {
      protocol::ClipPlane plane;
      double area;  // of the kept half's boundary
    };
    // x <= 0.5 (not on the 5-grid), x >= 0.4 (inverted: through jittered vertices or not), and the
    // oblique x + y + z <= 1.5 (half by symmetry)
    for (const Case& c : {Case{clip_plane({1, 0, 0}, 0.5), 4.0}, Case{clip_plane({1, 0, 0}, 0.4, true), 2 + 4 * 0.6},
                          Case{clip_plane({1, 1, 1}, 1.5), -1}}) {
      const storage::TetMesh half = renderer::clip_mesh(box, clip_of({c.plane}));
      const MeshCheck check = check_mesh(half);
      const double expected = c.plane.invert ? 0.6 : 0.5;
      EXPECT_NEAR(check.volume, expected, 1e-5) << "jitter " << jitter;
      EXPECT_EQ(check.faces_shared_by_more_than_two, 0u);
      EXPECT_EQ(check.nonpositive, 0u);
      if (c.area > 0) {
        EXPECT_NEAR(boundary_area(half), c.area, 1e-4) << "a face used once inside would add area";
      }
      // the linear field is reproduced exactly on the cut vertices, and every vertex is kept
      for (size_t v = 0; v < half.vertex_count(); ++v) {
        EXPECT_NEAR(half.attributes[0].values[v], half.x[v] + 2 * half.y[v] - half.z[v], 1e-5);
        EXPECT_LE(c.plane.kept().side(half.x[v], half.y[v], half.z[v]), 1e-6);
      }
    }
  }
}

TEST(Clip, PlanesABoxAndCrinkleCompose) {
  const storage::TetMesh box = kuhn_box(4, 0.3, [](float x, float, float) { return x; });
  // three planes cut the corner x, y, z <= 0.5: an eighth
  const auto corner = renderer::clip_mesh(box, clip_of({clip_plane({1, 0, 0}, 0.5), clip_plane({0, 1, 0}, 0.5), clip_plane({0, 0, 1}, 0.5)}));
  EXPECT_NEAR(check_mesh(corner).volume, 0.125, 1e-5);
  EXPECT_NEAR(boundary_area(corner), 6 * 0.25, 1e-4);
  // a clip box
  protocol::ClipSpec boxed;
  boxed.box = protocol::ClipBox{{0.1, 0.2, 0.3}, {0.6, 0.7, 0.9}};
  EXPECT_NEAR(check_mesh(renderer::clip_mesh(box, boxed)).volume, 0.5 * 0.5 * 0.6, 1e-5);
  // crinkle keeps whole original tets: more than the half, less than all, nothing new
  protocol::ClipSpec crinkle = clip_of({clip_plane({1, 0, 0}, 0.5)});
  crinkle.crinkle = true;
  const auto whole = renderer::clip_mesh(box, crinkle);
  const double volume = check_mesh(whole).volume;
  EXPECT_GT(volume, 0.5 + 1e-3);
  EXPECT_LT(volume, 1.0 - 1e-3);
  EXPECT_LE(whole.vertex_count(), box.vertex_count());
  // clipping everything away leaves an empty mesh, not a crash
  EXPECT_EQ(renderer::clip_mesh(box, clip_of({clip_plane({1, 0, 0}, -1)})).tet_count(), 0u);
}

TEST(Clip, TheScenesRangeAndCapStay) {
  const auto scene = renderer::SceneMesh::from(kuhn_box(4, 0, [](float x, float, float) { return x; }), "f");
  const auto clipped = renderer::clip_scene(scene, clip_of({clip_plane({1, 0, 0}, 0.3)}));
  EXPECT_EQ(clipped.value_min, scene.value_min);
  EXPECT_EQ(clipped.value_max, scene.value_max);
  EXPECT_EQ(clipped.diagonal, scene.diagonal);
  // the cap: boundary faces in the plane x = 0.3, coloured 0.3
  size_t cap = 0;
  for (const auto& f : clipped.boundary) {
    bool on = true;
    for (uint32_t v : f) on &= std::fabs(clipped.xyz[3 * size_t{v}] - 0.3) < 1e-6 && std::fabs(clipped.value[v] - 0.3) < 1e-6;
    cap += on;
  }
  EXPECT_GE(cap, 2u * 4 * 4);
}

renderer::RenderSettings settings_for(const renderer::SceneMesh& scene, uint32_t size) {
  renderer::RenderSettings s;
  s.width = s.height = size;
  s.camera = lod::parse_camera("azimuth=35,elevation=25", scene.bounds);
  s.tf.attribute = scene.attribute;
  s.tf.opacity = {{scene.value_min, 0.05}, {scene.value_max, 0.6}};
  return s;
}

// The clip plane through the middle of a mesh's box, across its longest side, tilted.
protocol::ClipPlane middle_plane(const renderer::SceneMesh& scene) {
  int axis = 0;
  for (int k = 1; k < 3; ++k)
    if (scene.bounds.max[k] - scene.bounds.min[k] > scene.bounds.max[axis] - scene.bounds.min[axis]) axis = k;
  std::array<double, 3> n{0.2, 0.3, 0.1};
  n[axis] = 1;
  double d = 0;
  for (int k = 0; k < 3; ++k) d += n[k] * 0.5 * (scene.bounds.min[k] + scene.bounds.max[k]);
  return clip_plane(n, d);
}

TEST(Clip, ClippedAndSlicedVolumeMatchesTheReferenceOnTheSharedDatasets) {
  std::vector<std::filesystem::path> meshes = {sample_mesh(), shared_data() / "fea_bracket.vtk", shared_data() / "nasa_bluntfin.vtk"};
  if (kSanitized) meshes.resize(1);  // the CPU reference over 200K tets takes minutes under ASan; release runs all
  for (const auto& path : meshes) {
    const storage::TetMesh m = storage::load_mesh(path);
    const auto full = renderer::SceneMesh::from(m, "");
    const auto scene = renderer::clip_scene(full, clip_of({middle_plane(full)}));
    ASSERT_GT(scene.tets.size(), 0u);
    ASSERT_LT(scene.tets.size(), full.tets.size());
    gl().set_mesh(scene);
    auto s = settings_for(full, 160);
    const renderer::Image clipped = gl().render(s);
    const double db = renderer::psnr(clipped, renderer::reference_render(scene, s));
    std::printf("clipped DVR vs reference, %s: %.1f dB\n", path.filename().c_str(), db);
    EXPECT_GE(db, 35.0) << path;
    // the clip shows: the image differs from the unclipped one
    gl().set_mesh(full);
    EXPECT_LT(renderer::psnr(clipped, gl().render(s)), 30.0) << path;
    // a slice across the other half of the clipped mesh, composited with the volume
    gl().set_mesh(scene);
    // a slice facing the camera through the box's centre
    std::array<double, 3> n, centre;
    for (int k = 0; k < 3; ++k) {
      n[k] = s.camera.target[k] - s.camera.eye[k];
      centre[k] = 0.5 * (full.bounds.min[k] + full.bounds.max[k]);
    }
    const double nl = std::hypot(n[0], n[1], n[2]);
    for (double& c : n) c /= nl;
    s.slices.planes = {{n, n[0] * centre[0] + n[1] * centre[1] + n[2] * centre[2]}};
    const renderer::Image sliced = gl().render(s);
    const double sliced_db = renderer::psnr(sliced, renderer::reference_render(scene, s));
    std::printf("clipped and sliced DVR vs reference, %s: %.1f dB\n", path.filename().c_str(), sliced_db);
    EXPECT_GE(sliced_db, 35.0) << path;
    // the slice alone shows (the volume before it may hide most of it above)
    s.dvr = false;
    const renderer::Image slice_only = gl().render(s);
    size_t covered = 0;  // pixels not the background
    for (size_t i = 0; i < slice_only.rgba.size(); i += 4) {
      int d = 0;
      for (int k = 0; k < 3; ++k) d += std::abs(int(slice_only.rgba[i + k]) - int(std::lround(s.background[k] * 255)));
      covered += d > 12;
    }
    EXPECT_GT(covered, slice_only.rgba.size() / 4 / 200) << "the slice shows";
  }
}

renderer::Image read_png(const std::filesystem::path& path) {
  png_image png{};
  png.version = PNG_IMAGE_VERSION;
  renderer::Image image;
  if (!png_image_begin_read_from_file(&png, path.c_str())) return image;
  png.format = PNG_FORMAT_RGBA;
  image.width = png.width;
  image.height = png.height;
  image.rgba.resize(PNG_IMAGE_SIZE(png));
  png_image_finish_read(&png, nullptr, image.rgba.data(), 0, nullptr);
  return image;
}

TEST(Clip, AClipPlaneOnOneraShowsTheWing) {
  if (kSanitized) GTEST_SKIP() << "450K tets: the release run covers it (minutes under ASan)";
  // the wing sits in a 100-chord far field: the plane z = 0 cuts the domain through the wing,
  // whose planform shows in the cut face, coloured by the pressure coefficient
  const auto full = renderer::SceneMesh::from(storage::load_mesh(shared_data() / "onera_m6_potential.vtk"), "pressure_coefficient");
  const auto scene = renderer::clip_scene(full, clip_of({clip_plane({0, 0, 1}, 0)}));
  gl().set_mesh(scene);
  renderer::RenderSettings s;
  s.width = 192;
  s.height = 144;
  s.dvr = false;
  s.surface = true;
  s.camera = lod::parse_camera("eye=0.7,0.7,3,target=0.7,0.7,0,up=0,1,0,fov=40", scene.bounds);
  s.camera.aspect = 192.0 / 144;
  const renderer::Image image = gl().render(s);
  const auto path = source_dir() / "tests" / "renderer" / "golden" / "onera_clip.png";
  if (std::getenv("TETRA_UPDATE_GOLDEN")) renderer::write_image(path.string(), image, 90);
  const renderer::Image expected = read_png(path);
  ASSERT_EQ(expected.width, 192u) << "missing golden image " << path << " (TETRA_UPDATE_GOLDEN=1 writes it)";
  EXPECT_GE(renderer::psnr(image, expected), 30.0);
  // and the cut face is there: the clipped scene has boundary faces on z = 0 around the wing
  size_t cap = 0;
  for (const auto& f : scene.boundary) cap += std::fabs(scene.xyz[3 * size_t{f[0]} + 2]) < 1e-6 && std::fabs(scene.xyz[3 * size_t{f[1]} + 2]) < 1e-6 && std::fabs(scene.xyz[3 * size_t{f[2]} + 2]) < 1e-6;
  EXPECT_GT(cap, 1000u);
}

}  // namespace
}  // namespace tetrascope::testing
