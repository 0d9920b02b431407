// Stream lines with ghosting and halos (§7.3) and point-based isosurfaces (§7.2) on the GL
// renderer: a golden image of ghosted lines with halos, opaque lines occluding the volume,
// point isosurfaces against marching tets (PSNR), the sampling density, and bad settings.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "mesh_checks.h"
#include "test_paths.h"
#include "tetrascope/lod/field/streamlines.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/renderer/view_frame.h"
#include "tetrascope/core/tet_topology.h"

namespace tetrascope::testing {
namespace {

renderer::Renderer& gl() {
  static renderer::Renderer* r = renderer::Renderer::create().release();  // kept until exit, as render_test
  return *r;
}

// The unit box, f = x, and a swirl v = (-(y - 0.5), x - 0.5, 0.12): helices about the box's axis.
storage::TetMesh swirl_box(int n) {
  storage::TetMesh m = kuhn_box(n, 0, [](float x, float, float) { return x; });
  storage::Attribute v{{"v", 3}, {}};
  for (size_t i = 0; i < m.vertex_count(); ++i) {
    v.values.push_back(-(m.y[i] - 0.5f));
    v.values.push_back(m.x[i] - 0.5f);
    v.values.push_back(0.12f);
  }
  m.attributes.push_back(v);
  return m;
}

std::shared_ptr<const renderer::LineSet> swirl_lines(const storage::TetMesh& m) {
  const std::vector<uint32_t> opposite = pair_faces(m.tets).opposite;
  const lod::StreamlineTracer tracer(m, opposite, "v");
  lod::StreamlineOptions o;
  o.direction = lod::StreamDirection::forward;
  o.threads = 1;
  const lod::Streamlines lines = tracer.trace(lod::parse_seeds("line:0.55,0.5,0.02,0.95,0.5,0.02,8"), o);
  return std::make_shared<const renderer::LineSet>(renderer::line_set_from(lines, "v"));
}

renderer::RenderSettings lines_settings(const renderer::SceneMesh& scene, uint32_t size) {
  renderer::RenderSettings s;
  s.width = s.height = size;
  s.camera = view::parse_camera("azimuth=35,elevation=25", scene.bounds);
  s.tf.attribute = scene.attribute;
  s.tf.opacity = {{scene.value_min, 0.05}, {scene.value_max, 0.6}};
  s.dvr = false;
  return s;
}

size_t differing_pixels(const renderer::Image& a, const renderer::Image& b, int threshold) {
  size_t n = 0;
  for (size_t i = 0; i < a.rgba.size(); i += 4) {
    int d = 0;
    for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(a.rgba[i + k]) - int(b.rgba[i + k])));
    n += d > threshold;
  }
  return n;
}

TEST(Lines, GhostedLinesWithHalosMatchTheirGoldenImage) {
  const storage::TetMesh m = swirl_box(6);
  const auto scene = renderer::SceneMesh::from(m, "f");
  const auto lines = swirl_lines(m);
  ASSERT_EQ(lines->line_count(), 8u);
  gl().set_mesh(scene);
  auto s = lines_settings(scene, 192);
  s.box = true;
  s.lines = lines;
  s.selected_lines = {2, 5};
  renderer::FrameTimings t;
  const renderer::Image image = gl().render(s, &t);
  EXPECT_GT(t.line_segments_opaque, 20u);
  EXPECT_GT(t.line_segments_ghosted, 40u);
  const auto path = source_dir() / "tests" / "renderer" / "golden" / "lines_ghosted_halos.png";
  if (std::getenv("TETRA_UPDATE_GOLDEN")) renderer::write_image(path.string(), image, 90);
  const renderer::Image expected = renderer::read_png(path.string());
  EXPECT_GE(renderer::psnr(image, expected), 30.0);

  // the parts show: ghosts are blended (lighter than the background, darker than opaque
  // ghost colour), halos darken beside the opaque lines, and selecting lines changes the image
  renderer::RenderSettings bare = s;
  bare.lines = nullptr;
  const renderer::Image background = gl().render(bare);
  EXPECT_GT(differing_pixels(image, background, 8), 800u) << "lines drawn";
  renderer::RenderSettings no_halos = s;
  no_halos.halos = false;
  const renderer::Image without = gl().render(no_halos);
  size_t darker = 0;
  for (size_t i = 0; i < image.rgba.size(); i += 4) darker += image.rgba[i] + 30 < without.rgba[i] && image.rgba[i + 1] + 30 < without.rgba[i + 1];
  EXPECT_GT(darker, 100u) << "halos darken pixels beside and behind the opaque lines";
  renderer::RenderSettings all = s;
  all.selected_lines.clear();
  renderer::FrameTimings all_t;
  const renderer::Image all_opaque = gl().render(all, &all_t);
  EXPECT_EQ(all_t.line_segments_ghosted, 0u);
  EXPECT_EQ(all_t.line_segments_opaque, t.line_segments_opaque + t.line_segments_ghosted);
  EXPECT_GT(differing_pixels(all_opaque, image, 30), 500u);
  // arrows and dashes mark the flow: each differs from no flow marks
  renderer::RenderSettings plain = all;
  plain.flow = view::FlowStyle::none;
  renderer::RenderSettings dashes = all;
  dashes.flow = view::FlowStyle::dashes;
  const renderer::Image plain_image = gl().render(plain);
  EXPECT_GT(differing_pixels(all_opaque, plain_image, 30), 50u) << "arrowheads";
  EXPECT_GT(differing_pixels(gl().render(dashes), plain_image, 30), 50u) << "dashes";
}

// Two identical straight lines along x, one 3 units from the eye, one 8 (§7.3.3 depth
// correction, figure 7.12), seen head-on from (0, 0, 5): the near line in the upper half of
// the image, the far one in the lower.
std::shared_ptr<const renderer::LineSet> near_and_far_lines() {
  auto set = std::make_shared<renderer::LineSet>();
  const float ys[2] = {0.3f, -0.6f}, zs[2] = {2.0f, -3.0f};
  for (int l = 0; l < 2; ++l) {
    for (int i = 0; i <= 24; ++i) {
      const float x = -0.3f + 0.6f * float(i) / 24;
      set->xyz.insert(set->xyz.end(), {x, ys[l], zs[l]});
      set->flow.insert(set->flow.end(), {1, 0, 0});
      set->value.push_back(0.5f);
    }
    set->line_first.push_back(uint32_t(set->value.size()));
  }
  set->value_min = 0;
  set->value_max = 1;
  set->diagonal = std::sqrt(0.36 + 0.81 + 25);
  set->field = "v";
  return set;
}

bool halo_dark(const renderer::Image& im, uint32_t x, uint32_t y) {
  const uint8_t* p = &im.rgba[4 * (size_t(y) * im.width + x)];
  return std::max({p[0], p[1], p[2]}) < 16;  // the halo is near black, the background (26, 26, 31)
}

// Rows of the halo (dark pixels) in column x between rows y0 and y1, and the middle row of
// the line (the bright run) there.
std::pair<int, int> halo_rows(const renderer::Image& im, uint32_t x, uint32_t y0, uint32_t y1) {
  int dark = 0, bright_sum = 0, bright = 0;
  for (uint32_t y = y0; y < y1; ++y) {
    const uint8_t* p = &im.rgba[4 * (size_t(y) * im.width + x)];
    if (halo_dark(im, x, y)) ++dark;
    if (std::max({p[0], p[1], p[2]}) > 60) {
      bright_sum += int(y);
      ++bright;
    }
  }
  return {dark, bright ? bright_sum / bright : -1};
}

TEST(Lines, DepthCorrectionKeepsHalosAndArrowsTheirImageSizeAndWorldSizeWithout) {
  storage::TetMesh m = swirl_box(2);  // not drawn; its box [-6, 6]^3 sets the near and far planes
  for (size_t i = 0; i < m.vertex_count(); ++i) {
    m.x[i] = 12 * m.x[i] - 6;
    m.y[i] = 12 * m.y[i] - 6;
    m.z[i] = 12 * m.z[i] - 6;
  }
  const auto scene = renderer::SceneMesh::from(m, "f");
  gl().set_mesh(scene);
  renderer::RenderSettings s;
  s.width = s.height = 256;
  s.camera.eye = {0, 0, 5};
  s.camera.target = {0, 0, 0};
  s.camera.up = {0, 1, 0};
  s.tf.attribute = scene.attribute;
  s.dvr = false;
  s.lines = near_and_far_lines();
  s.line_width = 4;
  s.flow = view::FlowStyle::none;
  const uint32_t mid = 128;
  auto widths = [&](double correction) {
    renderer::RenderSettings t = s;
    t.depth_correction = correction;
    const renderer::Image im = gl().render(t);
    return std::pair{halo_rows(im, mid, 0, mid).first, halo_rows(im, mid, mid, 256).first};
  };
  // corrected (the default): both halos 1.5 line widths of dark rows (2.5x the line, less the line)
  ASSERT_EQ(renderer::RenderSettings{}.depth_correction, 1.0);
  const auto [near1, far1] = widths(1);
  EXPECT_NEAR(near1, 6, 1.5);
  EXPECT_NEAR(far1, near1, 1) << "corrected: the same halo width in the image at depth 3 and 8";
  // uncorrected: a fixed world width, nominal at the target's depth 5: 10 px x 5/3 and x 5/8
  const auto [near0, far0] = widths(0);
  EXPECT_NEAR(near0, 10 * 5.0 / 3 - 4, 2) << "the near halo is wider";
  EXPECT_LE(far0, 3) << "the far halo is narrower";
  EXPECT_GT(near0, far0 + 6);
  // half way between
  const auto [near_half, far_half] = widths(0.5);
  EXPECT_GT(near_half, near1);
  EXPECT_LT(near_half, near0);
  EXPECT_LT(far_half, far1);

  // arrows: corrected, the near line (at 3/5 of the target's depth) holds 5/3 as many arrows
  // (each as long in the image as at the target); uncorrected, as many as its arc length says
  s.flow = view::FlowStyle::arrows;
  s.flow_spacing = 0.1;  // 6 arrows on the 0.6 long line in the world
  auto arrows = [&](double correction) {
    renderer::RenderSettings t = s;
    t.depth_correction = correction;
    const renderer::Image im = gl().render(t);
    const int row = halo_rows(im, mid, 0, mid).second;
    EXPECT_GT(row, 0) << "the near line is drawn";
    const uint32_t y = uint32_t(row + 3);  // inside the halo, beside the 4 px line
    int runs = 0;
    bool lit = false;
    for (uint32_t x = 10; x < 246; ++x) {
      const bool now = !halo_dark(im, x, y) && std::max({im.rgba[4 * (size_t(y) * 256 + x)], im.rgba[4 * (size_t(y) * 256 + x) + 1]}) > 40;
      runs += now && !lit;
      lit = now;
    }
    return runs;
  };
  const int arrows0 = arrows(0), arrows1 = arrows(1);
  EXPECT_NEAR(arrows0, 6, 1) << "uncorrected: one arrow each 0.1 of arc length";
  EXPECT_NEAR(arrows1, 10, 1.5) << "corrected: 6 x 5/3 arrows, each its nominal length in the image";
  renderer::RenderSettings bad = s;
  bad.depth_correction = 1.5;
  EXPECT_THROW(gl().render(bad), std::invalid_argument);
}

TEST(Lines, OpaqueLinesOccludeTheVolumeBehindThem) {
  // a straight line in front of the box (z = 1.3, the camera above it looking down): where
  // the line is drawn the volume is hidden, so its pixels equal those of the line alone; a
  // ghosted line lets the volume through
  const storage::TetMesh m = swirl_box(6);
  const auto scene = renderer::SceneMesh::from(m, "f");
  gl().set_mesh(scene);
  auto line = std::make_shared<renderer::LineSet>();
  for (int i = 0; i <= 20; ++i) {
    const float x = 0.1f + 0.8f * i / 20;
    line->xyz.insert(line->xyz.end(), {x, 0.5f, 1.3f});
    line->flow.insert(line->flow.end(), {1, 0, 0});
    line->value.push_back(float(i));
  }
  line->line_first = {0, 21};
  line->value_min = 0;
  line->value_max = 20;
  line->diagonal = 0.8;
  auto s = lines_settings(scene, 128);
  s.camera = view::parse_camera("eye=0.5,0.5,4,target=0.5,0.5,0.5,up=0,1,0", scene.bounds);
  s.tf.opacity = {{scene.value_min, 0.8}, {scene.value_max, 0.8}};
  s.dvr = true;
  const renderer::Image volume = gl().render(s);
  s.lines = line;
  const renderer::Image both = gl().render(s);
  s.dvr = false;
  const renderer::Image alone = gl().render(s);
  s.selected_lines = {};
  size_t line_pixels = 0, equal = 0, hidden_volume = 0;
  for (size_t i = 0; i < alone.rgba.size(); i += 4) {
    const bool on_line = std::abs(int(alone.rgba[i]) - int(s.background[0] * 255)) > 20 || std::abs(int(alone.rgba[i + 1]) - int(s.background[1] * 255)) > 20;
    if (!on_line) continue;
    ++line_pixels;
    bool same = true;
    for (int k = 0; k < 3; ++k) same &= std::abs(int(both.rgba[i + k]) - int(alone.rgba[i + k])) <= 2;
    equal += same;
    int d = 0;
    for (int k = 0; k < 3; ++k) d = std::max(d, std::abs(int(both.rgba[i + k]) - int(volume.rgba[i + k])));
    hidden_volume += d > 20;
  }
  EXPECT_GT(line_pixels, 100u);
  EXPECT_GE(equal, line_pixels * 99 / 100) << "the volume behind does not show through the line";
  EXPECT_GE(hidden_volume, line_pixels * 9 / 10) << "and the line is not the volume's colour";
  // a ghosted line (another line selected) is blended over the volume instead
  auto two = std::make_shared<renderer::LineSet>(*line);
  for (int i = 0; i <= 1; ++i) {
    two->xyz.insert(two->xyz.end(), {0.02f, 0.02f + 0.01f * i, 1.3f});
    two->flow.insert(two->flow.end(), {0, 1, 0});
    two->value.push_back(0);
  }
  two->line_first.push_back(23);
  s.lines = two;
  s.selected_lines = {1};
  s.dvr = true;
  const renderer::Image ghosted = gl().render(s);
  size_t through = 0;
  for (size_t i = 0; i < alone.rgba.size(); i += 4) {
    const bool on_line = std::abs(int(alone.rgba[i]) - int(s.background[0] * 255)) > 20;
    if (!on_line) continue;
    through += ghosted.rgba[i] != both.rgba[i] || ghosted.rgba[i + 1] != both.rgba[i + 1];
  }
  EXPECT_GT(through, line_pixels / 2) << "a ghost differs from the opaque line where the volume lies behind it";
}

// f = distance from the box centre: spheres.
storage::TetMesh sphere_box(int n) {
  return kuhn_box(n, 0, [](float x, float y, float z) { return std::sqrt((x - 0.5f) * (x - 0.5f) + (y - 0.5f) * (y - 0.5f) + (z - 0.5f) * (z - 0.5f)); });
}

TEST(PointIsosurfaces, DensityFollowsTheArea) {
  const storage::TetMesh m = sphere_box(10);
  const auto scene = renderer::SceneMesh::from(m, "f");
  const std::vector<double> isovalues = {0.2, 0.3, 0.4};
  const renderer::IsoPoints fine = renderer::sample_isosurfaces(scene, isovalues, 0, 20000);
  EXPECT_NEAR(double(fine.count()), 20000.0, 2000.0) << "about total area / A points";
  // the sphere of radius 0.3 has 2.25x the area of the one of radius 0.2: so about 2.25x the points
  size_t at[3] = {};
  for (float v : fine.value) at[v < 0.25f ? 0 : v < 0.35f ? 1 : 2]++;
  EXPECT_NEAR(double(at[1]) / at[0], 2.25, 0.3);
  // upsampling: a coarser area keeps fewer points than triangles (§7.2)
  const renderer::IsoPoints coarse = renderer::sample_isosurfaces(scene, isovalues, fine.area * 20, 0);
  EXPECT_LT(coarse.count(), coarse.triangles / 2);
  EXPECT_NEAR(double(coarse.count()), fine.total_area / coarse.area, 0.2 * fine.total_area / coarse.area);
  for (size_t i = 0; i < fine.count(); i += 97) {
    const double r = std::sqrt(std::pow(fine.xyz[3 * i] - 0.5, 2) + std::pow(fine.xyz[3 * i + 1] - 0.5, 2) + std::pow(fine.xyz[3 * i + 2] - 0.5, 2));
    EXPECT_NEAR(r, fine.value[i], 0.02) << "points lie on their isosurface";
  }
}

TEST(PointIsosurfaces, MatchMarchingTetsImage) {
  const storage::TetMesh m = sphere_box(10);
  const auto scene = renderer::SceneMesh::from(m, "f");
  gl().set_mesh(scene);
  auto s = lines_settings(scene, 160);
  s.isovalues = {0.3};
  s.iso = true;
  const renderer::Image triangles = gl().render(s);
  s.iso = false;
  s.points = true;
  s.point_isovalues = {0.3};
  s.point_target = 60000;
  renderer::FrameTimings t;
  const renderer::Image points = gl().render(s, &t);
  EXPECT_GT(t.points, 40000u);
  const double db = renderer::psnr(points, triangles);
  std::printf("point isosurface vs marching tets, sphere r=0.3, 160x160: %.1f dB\n", db);
  EXPECT_GE(db, 35.0);  // 43.2 dB measured
  s.points = false;
  EXPECT_LT(renderer::psnr(gl().render(s), triangles), 30.0) << "the comparison is not trivially high (22 dB without the surface)";
  // sparse splats let the inner sphere through: fewer pixels equal to the opaque image
  s.points = true;
  s.point_isovalues = {0.2, 0.3};
  s.point_size = 1;
  s.point_target = 3000;
  const renderer::Image sparse = gl().render(s);
  EXPECT_LT(renderer::psnr(sparse, triangles), db);
}

TEST(Lines, BadLineAndPointSettingsAreRefused) {
  const storage::TetMesh m = swirl_box(3);
  const auto scene = renderer::SceneMesh::from(m, "f");
  gl().set_mesh(scene);
  auto s = lines_settings(scene, 32);
  s.lines = swirl_lines(m);
  s.selected_lines = {99};
  EXPECT_THROW(gl().render(s), std::invalid_argument) << "a selected line that does not exist";
  s.selected_lines = {3, 1};
  EXPECT_THROW(gl().render(s), std::invalid_argument) << "selection not ascending";
  s.selected_lines = {};
  s.line_width = 0;
  EXPECT_THROW(gl().render(s), std::invalid_argument);
  s.line_width = 2;
  s.ghost_opacity = 0;
  EXPECT_THROW(gl().render(s), std::invalid_argument);
  s.ghost_opacity = 0.2;
  s.points = true;
  s.point_target = 1000;
  s.point_size = 1000;
  EXPECT_THROW(gl().render(s), std::invalid_argument);
  s.point_size = 0;
  EXPECT_NO_THROW(gl().render(s));
  s.point_area = -1;
  EXPECT_THROW(gl().render(s), std::invalid_argument);
}

TEST(Lines, ThePipelineTracesSelectsAndRefusesBadFieldsAndSeeds) {
  renderer::ViewPipeline pipeline(swirl_box(5));
  view::ViewRequest request;
  request.dvr = false;
  request.lines = true;
  request.width = request.height = 64;
  request.line.seeds = "line:0.55,0.5,0.02,0.95,0.5,0.02,6";
  renderer::RenderSettings s = pipeline.update(request);
  ASSERT_TRUE(s.lines);
  EXPECT_EQ(s.lines->line_count(), 6u);
  EXPECT_EQ(s.lines->field, "v") << "the first vector field by default";
  EXPECT_TRUE(s.selected_lines.empty());
  const auto traced = s.lines;
  request.line.select_box = std::array<double, 6>{0.9, 0.45, 0, 1, 0.55, 0.1};  // around the last seed
  s = pipeline.update(request);
  EXPECT_EQ(s.lines, traced) << "a selection does not trace again";
  EXPECT_EQ(s.selected_lines, (std::vector<uint32_t>{5}));
  // a click on the selected line's image picks it (fractions of the image)
  request.line.select_box.reset();
  double px = 0, py = 0;
  {
    const uint32_t last = s.lines->line_first[6] - 1;  // the line's end point, projected
    const view::Camera& cam = s.camera;
    const Vec3 p{s.lines->xyz[3 * last], s.lines->xyz[3 * last + 1], s.lines->xyz[3 * last + 2]};
    const Vec3 f = normalise(cam.target - cam.eye), r = normalise(cross(f, cam.up)), u = cross(r, f);
    const Vec3 q = p - cam.eye;
    const double t = std::tan(cam.fov_degrees * M_PI / 360);
    px = (dot(q, r) / (dot(q, f) * t) + 1) / 2;
    py = (1 - dot(q, u) / (dot(q, f) * t)) / 2;
  }
  request.line.select_pixel = std::array<double, 2>{px, py};
  s = pipeline.update(request);
  EXPECT_EQ(s.selected_lines, (std::vector<uint32_t>{5})) << "picked at " << px << ", " << py;
  request.line.select_pixel = std::array<double, 2>{0.01, 0.01};
  s = pipeline.update(request);
  EXPECT_TRUE(s.selected_lines.empty()) << "a click far from every line picks none";
  request.line.field = "f";
  EXPECT_THROW(pipeline.update(request), std::invalid_argument) << "a scalar field";
  request.line.field = "nope";
  EXPECT_THROW(pipeline.update(request), std::invalid_argument) << "a field the mesh lacks";
  request.line.field = "v";
  request.line.seeds = "line:0,0,0";
  EXPECT_THROW(pipeline.update(request), std::invalid_argument) << "bad seeds";
  request.line.seeds = "points:5,5,5";
  s = pipeline.update(request);
  EXPECT_EQ(s.lines->line_count(), 0u) << "a seed outside the domain traces no line, no error";
}

}  // namespace
}  // namespace tetrascope::testing
