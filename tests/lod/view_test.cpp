// lod/view.h: camera parsing (--camera), the view frustum, the default view, and the transfer
// function as lod takes it (parsed once in protocol/transfer_function.h).
#include <gtest/gtest.h>

#include <cmath>

#include "tetrascope/lod/view.h"

namespace tetrascope::testing {
namespace {

storage::Bounds box_1x2x3() {
  storage::Bounds box;
  box.min = {0, 0, 0};
  box.max = {1, 2, 3};
  return box;
}

double distance(const lod::Camera& c) { return std::sqrt(std::pow(c.eye[0] - c.target[0], 2) + std::pow(c.eye[1] - c.target[1], 2) + std::pow(c.eye[2] - c.target[2], 2)); }

TEST(View, CameraParsing) {
  const storage::Bounds box = box_1x2x3();
  auto c = lod::parse_camera("eye=5,1,1.5,target=0.5,1,1.5,fov=40", box);
  EXPECT_EQ(c.eye[0], 5);
  EXPECT_EQ(c.fov_degrees, 40);
  auto orbit = lod::parse_camera("azimuth=90,elevation=0,distance=2", box);
  EXPECT_NEAR(orbit.eye[1] - orbit.target[1], 2 * std::sqrt(14.0), 1e-9);
  EXPECT_NEAR(distance(lod::parse_camera("azimuth=10", box)), lod::kAzimuthCameraDistance * std::sqrt(14.0), 1e-9);
}

TEST(View, BadCamerasAreRefusedNamingTheItem) {
  const storage::Bounds box = box_1x2x3();
  EXPECT_THROW(lod::parse_camera("eye=1,2", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("zoom=3", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("eye=1,1,1,target=1,1,1", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("azimuth=x", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("azimuth=1e999", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("eye=0,0,5,target=0,0,0,up=0,0,0", box), std::invalid_argument);
  try {
    lod::parse_camera("fov=abc", box);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("fov"), std::string::npos) << e.what();
  }
}

TEST(View, TheDefaultViewShowsTheWholeBoundingSphere) {
  const storage::Bounds box = box_1x2x3();
  const lod::Camera c = lod::default_camera(box);
  const double diagonal = std::sqrt(14.0);
  EXPECT_NEAR(distance(c), lod::kDefaultViewDistance * diagonal, 1e-9);
  // the sphere of radius diagonal/2 fits the vertical field of view
  EXPECT_LE(std::asin(0.5 * diagonal / distance(c)), c.fov_degrees * M_PI / 360);
  EXPECT_EQ(c.fov_degrees, 30);
}

TEST(View, FrustumCullsBoxesBehindTheCamera) {
  const storage::Bounds box = box_1x2x3();
  lod::Frustum f = lod::view_frustum(lod::parse_camera("eye=0.5,1,10,target=0.5,1,1.5,up=0,1,0", box), 0.1, 100);
  const float inside[6] = {0, 0, 0, 1, 2, 3}, behind[6] = {0, 0, 20, 1, 2, 21};
  EXPECT_TRUE(f.intersects(inside));
  EXPECT_FALSE(f.intersects(behind));
}

TEST(View, TransferFunctionFiles) {
  auto tf = lod::TransferFunction::from_json(nlohmann::json::parse(R"({"attribute":"Temp","range":[0,10],"opacity":[[2,0],[4,1]],"name":"mine"})"));
  EXPECT_DOUBLE_EQ(tf.alpha(3), 0.5);
  EXPECT_DOUBLE_EQ(tf.alpha(100), 1);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"({"opacity":[[2,0],[1,1]]})")), std::invalid_argument);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"({"opacity":[[2,1.5]]})")), std::invalid_argument);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"({"rang":[0,1]})")), std::invalid_argument);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"({"colormap":"rainbow"})")), std::invalid_argument);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"([1, 2])")), std::invalid_argument);
  nlohmann::json many = {{"opacity", nlohmann::json::array()}};
  for (uint32_t i = 0; i <= protocol::kMaxTfPoints; ++i) many["opacity"].push_back({i, 0.5});
  EXPECT_THROW(lod::TransferFunction::from_json(many), std::invalid_argument);  // past the limit
  many["opacity"].erase(many["opacity"].size() - 1);
  EXPECT_NO_THROW(lod::TransferFunction::from_json(many));  // at the limit
  const auto round_trip = lod::TransferFunction::from_json(tf.to_json());
  EXPECT_EQ(round_trip.opacity, tf.opacity);
  EXPECT_EQ(round_trip.range, tf.range);
}

}  // namespace
}  // namespace tetrascope::testing
