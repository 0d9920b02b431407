// Camera and transfer-function parsing (lod/view.h).
#include <gtest/gtest.h>

#include <cmath>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/view.h"

namespace tetrascope::testing {
namespace {

TEST(Multires, CameraAndTransferFunctionParsing) {
  storage::Bounds box;
  box.min = {0, 0, 0};
  box.max = {1, 2, 3};
  auto c = lod::parse_camera("eye=5,1,1.5,target=0.5,1,1.5,fov=40", box);
  EXPECT_EQ(c.eye[0], 5);
  EXPECT_EQ(c.fov_degrees, 40);
  auto orbit = lod::parse_camera("azimuth=90,elevation=0,distance=2", box);
  EXPECT_NEAR(orbit.eye[1] - orbit.target[1], 2 * std::sqrt(14.0), 1e-9);
  EXPECT_THROW(lod::parse_camera("eye=1,2", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("zoom=3", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("eye=1,1,1,target=1,1,1", box), std::invalid_argument);
  EXPECT_THROW(lod::parse_camera("azimuth=x", box), std::invalid_argument);
  lod::Frustum f = lod::view_frustum(lod::parse_camera("eye=0.5,1,10,target=0.5,1,1.5,up=0,1,0", box), 0.1, 100);
  const float inside[6] = {0, 0, 0, 1, 2, 3}, behind[6] = {0, 0, 20, 1, 2, 21};
  EXPECT_TRUE(f.intersects(inside));
  EXPECT_FALSE(f.intersects(behind));
  auto tf = lod::TransferFunction::from_json(nlohmann::json::parse(R"({"attribute":"Temp","range":[0,10],"opacity":[[2,0],[4,1]]})"));
  EXPECT_DOUBLE_EQ(tf.alpha(3), 0.5);
  EXPECT_DOUBLE_EQ(tf.alpha(100), 1);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"({"opacity":[[2,0],[1,1]]})")), std::invalid_argument);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"({"opacity":[[2,1.5]]})")), std::invalid_argument);
  EXPECT_THROW(lod::TransferFunction::from_json(nlohmann::json::parse(R"({"rang":[0,1]})")), std::invalid_argument);
}

}  // namespace
}  // namespace tetrascope::testing
