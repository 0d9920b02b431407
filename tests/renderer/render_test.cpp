// The headless renderer against independent references: DVR against the CPU ray caster
// (PSNR), isosurfaces against exact areas, every mode against golden images (PSNR with a
// tolerance), and the errors a caller can make.
#include <gtest/gtest.h>
#include <png.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <thread>

#include "mesh_checks.h"
#include "test_paths.h"
#include "tetrascope/renderer/render.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::testing {
namespace {

renderer::Renderer& gl() {
  // kept until exit: Mesa's driver frees some of its memory only while loaded
  static renderer::Renderer* r = renderer::Renderer::create().release();
  return *r;
}

// The unit box with f = x.
storage::TetMesh box(int n) {
  return kuhn_box(n, 0, [](float x, float, float) { return x; });
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

renderer::RenderSettings settings_for(const renderer::SceneMesh& scene, uint32_t size) {
  renderer::RenderSettings s;
  s.width = s.height = size;
  s.camera = view::parse_camera("azimuth=35,elevation=25", scene.bounds);
  s.tf.attribute = scene.attribute;
  s.tf.opacity = {{scene.value_min, 0.05}, {scene.value_max, 0.6}};
  return s;
}

TEST(Render, ContextOpensAndDescribesItself) {
  const std::string d = gl().description();
  EXPECT_NE(d.find("OpenGL"), std::string::npos) << d;
}

TEST(Render, VolumeMatchesTheReferenceRayCaster) {
  for (const std::filesystem::path& mesh : {sample_mesh()}) {
    const storage::TetMesh m = storage::load_mesh(mesh);
    const auto scene = renderer::SceneMesh::from(m, "Temp");
    auto s = settings_for(scene, 160);
    gl().set_mesh(scene);
    const renderer::Image image = gl().render(s);
    const renderer::Image reference = renderer::reference_render(scene, s);
    const double db = renderer::psnr(image, reference);
    std::printf("GL volume rendering vs reference ray caster, %s, 160x160: %.1f dB\n", mesh.filename().c_str(), db);
    EXPECT_GE(db, 50.0) << mesh;  // 47.6 dB with an 8-bit target and a linear length axis; 65.1 dB now
    // and not trivially: the volume shows (differs from the bare background)
    renderer::Image empty = reference;
    for (size_t i = 0; i < empty.rgba.size(); i += 4)
      for (int k = 0; k < 3; ++k) empty.rgba[i + k] = static_cast<uint8_t>(std::lround(s.background[k] * 255));
    EXPECT_LT(renderer::psnr(reference, empty), 25.0);
  }
}

TEST(Render, LinearFieldInABoxMatchesExactly) {
  // f = x in the unit cube: the isosurface f = 0.3 is the square x = 0.3 (area 1), and the
  // volume rendering equals the reference ray caster's
  const storage::TetMesh m = box(6);
  const auto scene = renderer::SceneMesh::from(m, "f");
  const std::vector<float> tris = renderer::marching_tets(scene, 0.3);
  double area = 0;
  for (size_t i = 0; i < tris.size(); i += 9) {
    const double e1[3] = {tris[i + 3] - tris[i], tris[i + 4] - tris[i + 1], tris[i + 5] - tris[i + 2]};
    const double e2[3] = {tris[i + 6] - tris[i], tris[i + 7] - tris[i + 1], tris[i + 8] - tris[i + 2]};
    const double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    area += 0.5 * std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    EXPECT_GT(n[0], 0) << "oriented towards increasing values";
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(tris[i + 3 * k], 0.3, 1e-6);
  }
  EXPECT_NEAR(area, 1.0, 1e-5);
  auto s = settings_for(scene, 96);
  s.iso = true;
  s.isovalues = {0.3};
  s.dvr = false;
  gl().set_mesh(scene);
  renderer::FrameTimings t;
  gl().render(s, &t);
  EXPECT_EQ(t.iso_triangles, tris.size() / 9);
  s.iso = false;
  s.dvr = true;
  EXPECT_GE(renderer::psnr(gl().render(s), renderer::reference_render(scene, s)), 38.0);
}

TEST(Render, UserColourPointsReplaceTheColormap) {
  // f = x: colours from red (x = 0) to blue (x = 1); the GPU path and the reference agree,
  // and the image holds both reddish and bluish pixels (no colormap has both)
  const storage::TetMesh m = box(6);
  const auto scene = renderer::SceneMesh::from(m, "f");
  auto s = settings_for(scene, 96);
  s.tf.attribute = "f";
  s.tf.range = std::array<double, 2>{0, 1};
  s.tf.opacity = {{0, 0.5}, {1, 0.5}};
  s.tf.colors = {{0, 1, 0, 0}, {1, 0, 0, 1}};
  ASSERT_EQ(s.tf.colors.size(), 2u);
  gl().set_mesh(scene);
  const renderer::Image image = gl().render(s);
  EXPECT_GE(renderer::psnr(image, renderer::reference_render(scene, s)), 35.0);
  size_t reddish = 0, bluish = 0;
  for (size_t i = 0; i < image.rgba.size(); i += 4) {
    const int r = image.rgba[i], g = image.rgba[i + 1], b = image.rgba[i + 2];
    reddish += r > b + 40 && r > g + 40;
    bluish += b > r + 40 && b > g + 40;
  }
  EXPECT_GT(reddish, 100u);
  EXPECT_GT(bluish, 100u);
}

TEST(Render, EveryModeMatchesItsGoldenImage) {
  const storage::TetMesh m = storage::load_mesh(sample_mesh());
  const auto scene = renderer::SceneMesh::from(m, "Temp");
  gl().set_mesh(scene);
  const auto golden = source_dir() / "tests" / "renderer" / "golden";
  struct Case {
    const char* name;
    bool dvr, iso, surface, wireframe;
  };
  for (const Case& c : {Case{"dvr", true, false, false, false}, Case{"iso", false, true, false, false}, Case{"surface", false, false, true, true},
                        Case{"dvr_iso", true, true, false, false}}) {
    auto s = settings_for(scene, 192);
    s.dvr = c.dvr;
    s.iso = c.iso;
    s.surface = c.surface;
    s.wireframe = c.wireframe;
    s.box = true;
    s.isovalues = {500, 750};
    const renderer::Image image = gl().render(s);
    const auto path = golden / (std::string(c.name) + ".png");
    if (std::getenv("TETRA_UPDATE_GOLDEN")) renderer::write_image(path.string(), image, 90);
    const renderer::Image expected = read_png(path);
    ASSERT_EQ(expected.width, 192u) << "missing golden image " << path << " (TETRA_UPDATE_GOLDEN=1 writes it)";
    EXPECT_GE(renderer::psnr(image, expected), 30.0) << c.name;
  }
}

TEST(Render, SurfaceShowsSilhouettesAndBadSettingsAreRefused) {
  const storage::TetMesh m = box(4);
  const auto scene = renderer::SceneMesh::from(m, "f");
  gl().set_mesh(scene);
  auto s = settings_for(scene, 64);
  s.dvr = false;
  s.surface = true;
  const renderer::Image image = gl().render(s);
  size_t dark = 0;
  for (size_t i = 0; i < image.rgba.size(); i += 4) dark += image.rgba[i] < 20 && image.rgba[i + 1] < 20 && image.rgba[i + 2] < 20;
  EXPECT_GT(dark, 20u) << "silhouette edges are drawn";
  // semi-transparent isosurfaces let the background through
  auto iso = settings_for(scene, 64);
  iso.dvr = false;
  iso.iso = true;
  iso.isovalues = {0.5};
  iso.camera = view::parse_camera("eye=4,0.5,0.5,target=0.5,0.5,0.5,up=0,0,1", scene.bounds);
  const renderer::Image opaque = gl().render(iso);
  iso.iso_opacity = 0.3;
  const renderer::Image glass = gl().render(iso);
  iso.isovalues = {};
  const renderer::Image none = gl().render(iso);
  const size_t centre = 4 * (32 * 64 + 32);
  for (int k = 0; k < 3; ++k) {
    const double expected = 0.3 * opaque.rgba[centre + k] + 0.7 * none.rgba[centre + k];
    EXPECT_NEAR(glass.rgba[centre + k], expected, 2.0) << "channel " << k;
  }
  EXPECT_NE(opaque.rgba[centre], none.rgba[centre]);
  iso.iso_opacity = 1.5;
  EXPECT_THROW(gl().render(iso), std::invalid_argument);
  // coloured by a second attribute (g = z): the plane x = 0.5 shades from bottom to top
  storage::TetMesh two = box(4);
  storage::Attribute g{{"g", 1}, {}};
  for (size_t v = 0; v < two.vertex_count(); ++v) g.values.push_back(two.z[v]);
  two.attributes.push_back(g);
  const auto scene2 = renderer::SceneMesh::from(two, "f", "g");
  gl().set_mesh(scene2);
  iso.iso_opacity = 1;
  iso.isovalues = {0.5};
  const renderer::Image by_value = gl().render(iso);
  iso.use_iso_color_attribute = true;
  const renderer::Image by_g = gl().render(iso);
  auto pixel = [](const renderer::Image& im, int x, int y) { return std::array<int, 3>{im.rgba[4 * (y * 64 + x)], im.rgba[4 * (y * 64 + x) + 1], im.rgba[4 * (y * 64 + x) + 2]}; };
  auto difference = [&](const renderer::Image& im) {
    const auto a = pixel(im, 32, 16), b = pixel(im, 32, 48);
    return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
  };
  EXPECT_LT(difference(by_value), 20) << "one isovalue, one colour (only the lighting differs)";
  EXPECT_GT(difference(by_g), 60) << "the second attribute varies from top to bottom";
  EXPECT_THROW(renderer::SceneMesh::from(two, "f", "nope"), std::invalid_argument);
  gl().set_mesh(scene);
  s.tf.colormap = "rainbow-of-doom";
  EXPECT_THROW(gl().render(s), std::invalid_argument);
  s.tf.colormap = "viridis";
  s.width = 0;
  EXPECT_THROW(gl().render(s), std::invalid_argument);
  EXPECT_THROW(renderer::SceneMesh::from(m, "nope"), std::invalid_argument);
  EXPECT_THROW(renderer::write_image("/tmp/x.bmp", image, 90), std::invalid_argument);
}

// The fidelity bench compares the integrator's images past 8 bits (above about 50 dB the
// rounding decides a PNG's PSNR): the reference keeps its colours unrounded, and write_pfm
// stores them as a Portable Float Map, rows bottom first, little-endian.
TEST(Render, TheReferenceKeepsItsColoursUnroundedAndWritesThemAsAFloatMap) {
  const auto scene = renderer::SceneMesh::from(box(3), "f");
  auto s = settings_for(scene, 12);
  s.width = 16;  // not square: width and height cannot swap unseen
  const renderer::Image image = renderer::reference_render(scene, s);
  ASSERT_EQ(image.rgb.size(), size_t{16} * 12 * 3);
  size_t between = 0;  // values that 8 bits round
  for (size_t i = 0; i < size_t{16} * 12; ++i)
    for (int k = 0; k < 3; ++k) {
      const float v = image.rgb[3 * i + k];
      ASSERT_GE(v, 0.0f);
      ASSERT_LE(v, 1.0f);
      EXPECT_EQ(image.rgba[4 * i + k], static_cast<uint8_t>(std::lround(v * 255))) << "pixel " << i;
      between += std::fabs(v * 255 - std::round(v * 255)) > 0.01;
    }
  EXPECT_GT(between, size_t{16} * 12) << "the float colours are the rounded ones";
  const auto path = scratch_dir("render-pfm") / "box.pfm";
  renderer::write_pfm(path.string(), image);
  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string header = "PF\n16 12\n-1.0\n";
  ASSERT_EQ(bytes.size(), header.size() + size_t{16} * 12 * 3 * 4);
  EXPECT_EQ(bytes.substr(0, header.size()), header);
  for (size_t x = 0; x < 16 * 3; ++x) {  // the file's first row is the image's bottom row
    uint32_t word = 0;
    for (int b = 0; b < 4; ++b) word |= uint32_t(uint8_t(bytes[header.size() + 4 * x + size_t(b)])) << (8 * b);
    float v;
    std::memcpy(&v, &word, 4);
    EXPECT_EQ(v, image.rgb[size_t{11} * 16 * 3 + x]) << "value " << x;
  }
  for (const auto& entry : std::filesystem::directory_iterator(path.parent_path()))  // no temporary left
    EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
  renderer::Image rounded = image;
  rounded.rgb.clear();  // as the GL renderer's images: no float colours to write
  EXPECT_THROW(renderer::write_pfm(path.string(), rounded), std::invalid_argument);
}

// Threat: two renders writing one output path at once. Both used PATH.tmp: one could rename
// the other's half-written file into place, or find its temporary gone. Each write now has a
// temporary of its own; the file left is whole and one of the two images.
TEST(Render, TwoWritersOfOneImagePathNeverShareATemporaryFile) {
  auto solid = [](uint8_t red) {
    renderer::Image image{64, 48, std::vector<uint8_t>(size_t{64} * 48 * 4, 255), {}};
    for (size_t i = 0; i < size_t{64} * 48; ++i) image.rgba[4 * i] = red;
    return image;
  };
  const renderer::Image a = solid(10), b = solid(200);
  const auto dir = scratch_dir("render-two-writers");
  const std::string path = (dir / "frame.png").string();
  std::atomic<int> failures{0};
  auto writer = [&](const renderer::Image& image) {
    for (int i = 0; i < 40; ++i) try {
        renderer::write_image(path, image, 90);
      } catch (const std::exception&) {
        ++failures;
      }
  };
  std::thread first(writer, std::cref(a)), second(writer, std::cref(b));
  first.join();
  second.join();
  EXPECT_EQ(failures.load(), 0);
  const renderer::Image left = renderer::read_png(path);
  EXPECT_TRUE(left.rgba == a.rgba || left.rgba == b.rgba) << "the file is neither image whole";
  for (const auto& entry : std::filesystem::directory_iterator(dir)) EXPECT_EQ(entry.path().filename().string(), "frame.png");
}

TEST(Render, ImageSideAtAndPastTheLimit) {
  const auto scene = renderer::SceneMesh::from(box(2), "f");
  gl().set_mesh(scene);
  auto s = settings_for(scene, 1);
  s.width = renderer::kMaxImageSide;  // at the limit (one row, to stay small)
  EXPECT_EQ(gl().render(s).width, renderer::kMaxImageSide);
  s.width = renderer::kMaxImageSide + 1;
  EXPECT_THROW(gl().render(s), std::invalid_argument);
  s.width = 1;
  s.height = renderer::kMaxImageSide + 1;
  EXPECT_THROW(gl().render(s), std::invalid_argument);
}

}  // namespace
}  // namespace tetrascope::testing
