// The view library: camera parsing (--camera), the view frame (rays, projection, the share of
// the view a box covers), the view frustum, the default view, and the transfer function as lod
// and the renderer take it (its JSON read and written by protocol/transfer_function.h).
#include <gtest/gtest.h>

#include <cmath>

#include "tetrascope/view/camera.h"
#include "tetrascope/protocol/transfer_function.h"
#include "tetrascope/view/transfer_function.h"

namespace tetrascope::testing {
namespace {

storage::Bounds box_1x2x3() {
  storage::Bounds box;
  box.min = {0, 0, 0};
  box.max = {1, 2, 3};
  return box;
}

double distance(const view::Camera& c) { return std::sqrt(std::pow(c.eye[0] - c.target[0], 2) + std::pow(c.eye[1] - c.target[1], 2) + std::pow(c.eye[2] - c.target[2], 2)); }

TEST(View, CameraParsing) {
  const storage::Bounds box = box_1x2x3();
  auto c = view::parse_camera("eye=5,1,1.5,target=0.5,1,1.5,fov=40", box);
  EXPECT_EQ(c.eye[0], 5);
  EXPECT_EQ(c.fov_degrees, 40);
  auto orbit = view::parse_camera("azimuth=90,elevation=0,distance=2", box);
  EXPECT_NEAR(orbit.eye[1] - orbit.target[1], 2 * std::sqrt(14.0), 1e-9);
  EXPECT_NEAR(distance(view::parse_camera("azimuth=10", box)), view::kAzimuthCameraDistance * std::sqrt(14.0), 1e-9);
}

TEST(View, BadCamerasAreRefusedNamingTheItem) {
  const storage::Bounds box = box_1x2x3();
  EXPECT_THROW(view::parse_camera("eye=1,2", box), std::invalid_argument);
  EXPECT_THROW(view::parse_camera("zoom=3", box), std::invalid_argument);
  EXPECT_THROW(view::parse_camera("eye=1,1,1,target=1,1,1", box), std::invalid_argument);
  EXPECT_THROW(view::parse_camera("azimuth=x", box), std::invalid_argument);
  EXPECT_THROW(view::parse_camera("azimuth=1e999", box), std::invalid_argument);
  EXPECT_THROW(view::parse_camera("eye=0,0,5,target=0,0,0,up=0,0,0", box), std::invalid_argument);
  try {
    view::parse_camera("fov=abc", box);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fov"), std::string::npos) << e.what();
  }
}

TEST(View, TheDefaultViewShowsTheWholeBoundingSphere) {
  const storage::Bounds box = box_1x2x3();
  const view::Camera c = view::default_camera(box);
  const double diagonal = std::sqrt(14.0);
  EXPECT_NEAR(distance(c), view::kDefaultViewDistance * diagonal, 1e-9);
  // the sphere of radius diagonal/2 fits the vertical field of view
  EXPECT_LE(std::asin(0.5 * diagonal / distance(c)), c.fov_degrees * M_PI / 360);
  EXPECT_EQ(c.fov_degrees, 30);
}

TEST(View, FrustumCullsBoxesBehindTheCamera) {
  const storage::Bounds box = box_1x2x3();
  view::Frustum f = view::view_frustum(view::parse_camera("eye=0.5,1,10,target=0.5,1,1.5,up=0,1,0", box), 0.1, 100);
  const float inside[6] = {0, 0, 0, 1, 2, 3}, behind[6] = {0, 0, 20, 1, 2, 21};
  EXPECT_TRUE(f.intersects(inside));
  EXPECT_FALSE(f.intersects(behind));
}

TEST(View, TransferFunctionFiles) {
  auto tf = protocol::transfer_function_from_json(nlohmann::json::parse(R"({"attribute":"Temp","range":[0,10],"opacity":[[2,0],[4,1]],"name":"mine"})"));
  EXPECT_DOUBLE_EQ(tf.alpha(3), 0.5);
  EXPECT_DOUBLE_EQ(tf.alpha(100), 1);
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"({"opacity":[[2,0],[1,1]]})")), std::invalid_argument);
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"({"opacity":[[2,1.5]]})")), std::invalid_argument);
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"({"rang":[0,1]})")), std::invalid_argument);
  const auto y = protocol::transfer_function_from_json(nlohmann::json::parse(R"({"attribute":"V","component":"y"})"));
  EXPECT_EQ(y.component, 1);
  EXPECT_EQ(protocol::transfer_function_json(y)["component"], "y");  // written back as read
  EXPECT_FALSE(protocol::transfer_function_json(tf).contains("component"));
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"({"component":"w"})")), std::invalid_argument);
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"({"colormap":"rainbow"})")), std::invalid_argument);
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"([1, 2])")), std::invalid_argument);
  // user colour points: components in [0, 1], values ascending
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"({"colors": [[0, 1, 0, 2]]})")), std::invalid_argument);
  EXPECT_THROW(protocol::transfer_function_from_json(nlohmann::json::parse(R"({"colors": [[1, 1, 0, 0], [0, 0, 0, 1]]})")), std::invalid_argument);
  nlohmann::json many = {{"opacity", nlohmann::json::array()}};
  for (uint32_t i = 0; i <= protocol::kMaxTfPoints; ++i) many["opacity"].push_back({i, 0.5});
  EXPECT_THROW(protocol::transfer_function_from_json(many), std::invalid_argument);  // past the limit
  many["opacity"].erase(many["opacity"].size() - 1);
  EXPECT_NO_THROW(protocol::transfer_function_from_json(many));  // at the limit
  const auto round_trip = protocol::transfer_function_from_json(protocol::transfer_function_json(tf));
  EXPECT_EQ(round_trip.opacity, tf.opacity);
  EXPECT_EQ(round_trip.range, tf.range);
}

// A pixel's ray and the projection of a point on it agree: the point projects back to the pixel
// centre, in perspective and orthographic views alike (the GL renderer and the CPU reference
// both go through them).
TEST(View, ARayAndTheProjectionOfAPointOnItMeetAtThePixelCentre) {
  for (const char* text : {"eye=0.5,1,10,target=0.5,1,1.5,up=0,1,0,fov=40", "eye=3,-4,5,target=0,0,0,up=0,0,1,ortho"}) {
    const view::ViewFrame f = view::ViewFrame::of(view::parse_camera(text, box_1x2x3()), 64, 48);
    for (const auto& [x, y] : {std::pair{0, 0}, std::pair{63, 47}, std::pair{20, 30}}) {
      Vec3 origin, direction;
      f.ray(x, y, &origin, &direction);
      double px = -1, py = -1;
      ASSERT_TRUE(f.project(origin + 7.5 * direction, &px, &py)) << text;
      EXPECT_NEAR(px, x, 1e-9) << text;
      EXPECT_NEAR(py, y, 1e-9) << text;
    }
  }
}

// The share of the view a box covers: all of it around the eye, none behind it, about the
// fraction of the view's area a centred box takes, and the same whether the box is given as
// bounds or as the cut's float box.
TEST(View, TheShareOfTheViewABoxCoversFollowsItsProjection) {
  const view::ViewFrame f = view::ViewFrame::of(view::parse_camera("eye=0,0,10,target=0,0,0,up=0,1,0,fov=90", box_1x2x3()), 100, 100);
  ASSERT_TRUE(f.valid);
  storage::Bounds around_eye{{-1, -1, 9}, {1, 1, 11}}, behind{{-1, -1, 11}, {1, 1, 12}}, centred{{-5, -5, -0.001}, {5, 5, 0.001}};
  EXPECT_DOUBLE_EQ(f.box_share(around_eye), 1.0);
  EXPECT_DOUBLE_EQ(f.box_share(behind), 1.0);  // a corner at or behind the eye: the whole view
  // at depth 10 a 90-degree view spans 20 units: a 10-unit square covers a quarter of it
  EXPECT_NEAR(f.box_share(centred), 0.25, 1e-3);
  const float box[6] = {-5, -5, -0.001f, 5, 5, 0.001f};
  EXPECT_NEAR(f.box_share(box), f.box_share(centred), 1e-6);
  storage::Bounds aside{{100, 100, -1}, {101, 101, 1}};
  EXPECT_DOUBLE_EQ(f.box_share(aside), 0.0);
  // a degenerate camera says so rather than inventing a basis
  view::Camera flat;
  flat.eye = flat.target = {1, 1, 1};
  EXPECT_FALSE(view::ViewFrame::of(flat).valid);
}

}  // namespace
}  // namespace tetrascope::testing
