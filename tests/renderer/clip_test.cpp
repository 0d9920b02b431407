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
#include "tetrascope/view/planes.h"
#include "tetrascope/renderer/clip.h"
#include "tetrascope/renderer/probe.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::testing {
namespace {

renderer::Renderer& gl() {
  static renderer::Renderer* r = renderer::Renderer::create().release();  // kept until exit (Mesa)
  return *r;
}

view::ClipPlane clip_plane(std::array<double, 3> n, double d, bool invert = false) {
  const double l = std::hypot(n[0], n[1], n[2]);
  return {{{n[0] / l, n[1] / l, n[2] / l}, d / l}, invert};
}

view::ClipSpec clip_of(std::vector<view::ClipPlane> planes) {
  view::ClipSpec c;
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

// The slice alone (no volume) of the unit cube seen from +z, f over [0, 1] through viridis.
renderer::RenderSettings slice_view(const renderer::SceneMesh& scene, const view::Plane& plane, bool lit) {
  renderer::RenderSettings s;
  s.width = s.height = 96;
  s.dvr = false;
  s.camera = view::parse_camera("eye=0.5,0.5,3,target=0.5,0.5,0.5,up=0,1,0,fov=30", scene.bounds);
  s.tf.attribute = scene.attribute;
  s.tf.colormap = "viridis";
  s.tf.range = std::array<double, 2>{0, 1};
  s.tf.opacity = {{0, 0}, {1, 0}};  // a clear volume: the CPU reference draws one always
  s.slices.planes = {plane};
  s.slices.lit = lit;
  return s;
}

TEST(Slice, AFlatSliceHasTheColormapColourOfTheValueAndALitObliqueOneIsShaded) {
  // f = x; the head-on plane z = 0.5 and the oblique x + z = 1 (45 degrees to the view)
  const auto scene = renderer::SceneMesh::from(kuhn_box(6, 0, [](float x, float, float) { return x; }), "f");
  gl().set_mesh(scene);
  const double h = 1 / std::sqrt(2.0);
  for (const view::Plane& plane : {view::Plane{{0, 0, 1}, 0.5}, view::Plane{{h, 0, h}, h}}) {
    const bool oblique = plane.normal[0] != 0;
    SCOPED_TRACE(oblique ? "oblique" : "head-on");
    const auto flat_settings = slice_view(scene, plane, false);
    const renderer::Image flat = gl().render(flat_settings);
    const renderer::Image lit = gl().render(slice_view(scene, plane, true));
    // the value under every pixel's centre, found on the CPU: the pixel's ray (from the eye
    // through the probe's hit on the box) meets the plane at q, where f = q.x
    renderer::RenderSettings bare = flat_settings;
    bare.slices.planes.clear();
    const std::array<double, 3> eye = bare.camera.eye;
    const uint32_t W = flat.width, H = flat.height;
    size_t covered = 0, off = 0, shaded = 0;
    int worst = 0;
    for (uint32_t y = 0; y < H; ++y)
      for (uint32_t x = 0; x < W; ++x) {
        const renderer::ProbeHit box_hit = renderer::probe(scene, bare, x + 0.5, y + 0.5);
        if (box_hit.surface.empty()) continue;
        double along = 0, across = 0;
        for (int k = 0; k < 3; ++k) {
          along += plane.normal[k] * (box_hit.position[k] - eye[k]);
          across += plane.normal[k] * eye[k];
        }
        const double t = (plane.offset - across) / along;
        std::array<double, 3> q;
        bool inner = true;  // pixels on the slice's outline are partly background: judged by the inner ones
        for (int k = 0; k < 3; ++k) {
          q[k] = eye[k] + t * (box_hit.position[k] - eye[k]);
          inner &= q[k] > 0.03 && q[k] < 0.97;
        }
        if (!inner) continue;
        ++covered;
        const auto expected = renderer::colormap("viridis", q[0]);
        const size_t at = 4 * (size_t{y} * flat.width + x);
        int d = 0, dl = 0;
        for (int k = 0; k < 3; ++k) {
          d = std::max(d, std::abs(int(flat.rgba[at + k]) - int(std::lround(expected[k] * 255))));
          dl = std::max(dl, std::abs(int(lit.rgba[at + k]) - int(flat.rgba[at + k])));
        }
        worst = std::max(worst, d);
        off += d > 2;
        shaded += dl > 8;
      }
    EXPECT_GT(covered, 96u * 96 / 8) << "the slice covers part of the view";
    EXPECT_EQ(off, 0u) << "flat pixels away from the colormap's colour of the value, worst by " << worst << " levels";
    if (oblique) {
      EXPECT_GT(shaded, covered * 9 / 10) << "lit at 45 degrees to the headlight is darker than flat";
    } else {
      EXPECT_LT(shaded, covered / 10) << "head-on, lit is nearly flat";
    }
    // the CPU reference draws flat slices alike
    EXPECT_GE(renderer::psnr(flat, renderer::reference_render(scene, flat_settings)), 35.0);
  }
}

TEST(Probe, EveryPointAttributeAtThePickedPointOnASliceTheBoundaryAndThroughAClip) {
  // f = x and the vector v = (y, 2z, x + y) in a jittered box: linear, so interpolation in any
  // tet gives them exactly at the picked point
  storage::TetMesh box = kuhn_box(5, 0.3, [](float x, float, float) { return x; });
  storage::Attribute v{{"v", 3}, {}};
  for (size_t i = 0; i < box.vertex_count(); ++i) v.values.insert(v.values.end(), {box.y[i], 2 * box.z[i], box.x[i] + box.y[i]});
  box.attributes.push_back(v);
  const auto scene = renderer::SceneMesh::from(box, "f");
  auto check = [](const std::vector<renderer::PointValue>& values, const std::array<double, 3>& p) {
    ASSERT_EQ(values.size(), 2u);
    EXPECT_EQ(values[0].name, "f");
    ASSERT_EQ(values[0].components.size(), 1u);
    EXPECT_NEAR(values[0].components[0], p[0], 1e-5);
    EXPECT_EQ(values[1].name, "v");
    ASSERT_EQ(values[1].components.size(), 3u);
    const double expected[3] = {p[1], 2 * p[2], p[0] + p[1]};
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(values[1].components[k], expected[k], 1e-5) << k;
    EXPECT_NEAR(values[1].magnitude, std::hypot(expected[0], expected[1], expected[2]), 1e-5);
  };
  renderer::RenderSettings s = slice_view(scene, {{0, 0, 1}, 0.4}, true);
  // the slice is nearer than the boundary from an eye inside the box
  renderer::RenderSettings inside = s;
  inside.camera = view::parse_camera("eye=0.5,0.5,0.9,target=0.5,0.5,0,up=0,1,0,fov=60", scene.bounds);
  size_t probed = 0;
  for (const auto& [x, y] : {std::pair{48.5, 48.5}, std::pair{30.2, 61.7}, std::pair{70.9, 25.1}}) {
    // on the slice z = 0.4
    const renderer::ProbeHit on_slice = renderer::probe(scene, inside, x, y);
    ASSERT_EQ(on_slice.surface, "slice");
    EXPECT_NEAR(on_slice.position[2], 0.4, 1e-5);
    check(renderer::values_at(scene, on_slice.position), on_slice.position);
    // from outside, the slice inside the volume, unless the boundary is drawn as a surface
    EXPECT_EQ(renderer::probe(scene, s, x, y).surface, "slice");
    renderer::RenderSettings surface = s;
    surface.surface = true;
    EXPECT_EQ(renderer::probe(scene, surface, x, y).surface, "boundary");
    // on the boundary z = 1 (no slice), seen from outside
    renderer::RenderSettings bare = s;
    bare.slices.planes.clear();
    const renderer::ProbeHit on_boundary = renderer::probe(scene, bare, x, y);
    ASSERT_EQ(on_boundary.surface, "boundary");
    EXPECT_NEAR(on_boundary.position[2], 1.0, 1e-5);
    check(renderer::values_at(scene, on_boundary.position), on_boundary.position);
    // clipped to z <= 0.7: the cut face, probed in the clipped scene, valued in the unclipped one
    const auto clipped = renderer::clip_scene(scene, clip_of({clip_plane({0, 0, 1}, 0.7)}));
    EXPECT_TRUE(clipped.attributes.empty());
    const renderer::ProbeHit on_cut = renderer::probe(clipped, bare, x, y);
    ASSERT_EQ(on_cut.surface, "boundary");
    EXPECT_NEAR(on_cut.position[2], 0.7, 1e-5);
    check(renderer::values_at(scene, on_cut.position), on_cut.position);
    ++probed;
  }
  EXPECT_EQ(probed, 3u);
  // a point outside the mesh has none
  EXPECT_TRUE(renderer::values_at(scene, {2, 2, 2}).empty());
}

TEST(Clip, ABoxCutInHalfKeepsHalfItsVolumeAndStaysConforming) {
  for (double jitter : {0.0, 0.4}) {
    const storage::TetMesh box = kuhn_box(5, jitter, [](float x, float y, float z) { return x + 2 * y - z; });
    struct Case {
      view::ClipPlane plane;
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
  view::ClipSpec boxed;
  boxed.box = view::ClipBox{{0.1, 0.2, 0.3}, {0.6, 0.7, 0.9}};
  EXPECT_NEAR(check_mesh(renderer::clip_mesh(box, boxed)).volume, 0.5 * 0.5 * 0.6, 1e-5);
  // crinkle keeps whole original tets: more than the half, less than all, nothing new
  view::ClipSpec crinkle = clip_of({clip_plane({1, 0, 0}, 0.5)});
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
  s.camera = view::parse_camera("azimuth=35,elevation=25", scene.bounds);
  s.tf.attribute = scene.attribute;
  s.tf.opacity = {{scene.value_min, 0.05}, {scene.value_max, 0.6}};
  return s;
}

// The clip plane through the middle of a mesh's box, across its longest side, tilted.
view::ClipPlane middle_plane(const renderer::SceneMesh& scene) {
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
  if (kSanitized || shared_data().empty()) meshes.resize(1);  // the CPU reference over 200K tets takes minutes under ASan; release runs all
  if (shared_data().empty()) std::printf("[ SKIPPED  ] the shared datasets: ../shared/data is not beside this checkout; the sample only\n");
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
  s.camera = view::parse_camera("eye=0.7,0.7,3,target=0.7,0.7,0,up=0,1,0,fov=40", scene.bounds);
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
