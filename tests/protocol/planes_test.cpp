// clip.set and slice.set against the shared vectors (protocol/testdata/planes.json, also run
// by the JS codec), the planes' normalisation, and the command line's plane text.
#include <cmath>
#include <fstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "test_paths.h"
#include "tetrascope/protocol/planes.h"
#include "tetrascope/protocol/protocol.h"

namespace tetrascope::protocol {
namespace {

TEST(PlaneVectors, EveryClipAndSliceMessageParsesOrIsRefusedWithItsCode) {
  std::ifstream in(tetrascope::testing::source_dir() / "protocol" / "testdata" / "planes.json");
  ASSERT_TRUE(in.good());
  const nlohmann::json file = nlohmann::json::parse(in);
  Limits limits;
  size_t accepted = 0, refused = 0;
  for (const auto& vector : file["messages"]) {
    SCOPED_TRACE(vector["name"].get<std::string>());
    const std::string text = vector["text"];
    if (vector.contains("error")) {
      try {
        parse_message(text, limits);
        ADD_FAILURE() << "accepted";
      } catch (const ProtocolError& e) {
        EXPECT_EQ(e.code(), vector["error"].get<std::string>()) << e.what();
        if (vector["error_id"].is_null()) {
          EXPECT_FALSE(e.id().has_value());
        } else {
          EXPECT_EQ(e.id(), vector["error_id"].get<uint32_t>());
        }
        ++refused;
      }
    } else {
      const Envelope e = parse_message(text, limits);
      EXPECT_EQ(e.type, vector["type"].get<std::string>());
      EXPECT_EQ(e.id, vector["id"].get<uint32_t>());
      ++accepted;
    }
  }
  EXPECT_GE(accepted, 5u);
  EXPECT_GE(refused, 10u);
}

TEST(Planes, NormalsAreMadeUnitAndTheOffsetScaledWithThem) {
  const Envelope e = parse_message(R"({"type":"clip.set","id":1,"planes":[{"normal":[0,3,4],"offset":10,"invert":true}],"box":{"min":[0,0,0],"max":[1,2,3]}})", Limits{});
  const ClipSpec& clip = std::get<ClipSet>(e.message).clip;
  ASSERT_EQ(clip.planes.size(), 1u);
  EXPECT_DOUBLE_EQ(clip.planes[0].plane.normal[1], 0.6);
  EXPECT_DOUBLE_EQ(clip.planes[0].plane.normal[2], 0.8);
  EXPECT_DOUBLE_EQ(clip.planes[0].plane.offset, 2);
  EXPECT_TRUE(clip.planes[0].invert);
  // inverted: kept is -n.x <= -d; plus the box's six
  const auto half = clip.half_spaces();
  ASSERT_EQ(half.size(), 7u);
  EXPECT_LE(half[0].side(0, 10, 10), 0);  // far on the normal's side: kept when inverted
  EXPECT_GT(half[0].side(0, 0, 0), 0);
  // a round trip through JSON
  EXPECT_EQ(parse_clip_spec(clip.to_json(), 1), clip);
}

TEST(Planes, PlaneTextWithAZeroNormalIsRefused) {
  EXPECT_THROW(parse_plane_text("0,0,0,1", true), std::invalid_argument);
  try {
    parse_plane_text("0,0,0,1", true);
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("normal is zero"), std::string::npos) << e.what();
  }
}

TEST(Planes, PlaneTextWithNaNOrInfinityIsRefused) {
  for (const char* text : {"nan,0,0,1", "1,0,0,nan", "inf,0,0,0", "1,0,0,1e400", "1,0,0,-inf"}) EXPECT_THROW(parse_plane_text(text, true), std::invalid_argument) << text;
}

TEST(Planes, MalformedPlaneTextIsRefused) {
  for (const char* text : {"", "1,0,0", "1,0,0,1,2", "1,0,0,x", "1,,0,1", "1,0,0,1,invert"}) EXPECT_THROW(parse_plane_text(text, false), std::invalid_argument) << text;
  const ClipPlane inverted = parse_plane_text("!2,0,0,1", true);
  EXPECT_TRUE(inverted.invert);
  EXPECT_DOUBLE_EQ(inverted.plane.offset, 0.5);
  EXPECT_TRUE(parse_plane_text("1,0,0,1,invert", true).invert);
}

TEST(Planes, MoreThanSixPlanesAreRefused) {
  nlohmann::json planes = nlohmann::json::array();
  for (int i = 0; i < 7; ++i) planes.push_back({{"normal", {1, 0, 0}}, {"offset", i}});
  EXPECT_THROW(parse_clip_spec({{"planes", planes}}, 1), ProtocolError);
  EXPECT_THROW(parse_slice_spec({{"planes", planes}}, 1), ProtocolError);
  planes.erase(planes.begin());
  EXPECT_EQ(parse_clip_spec({{"planes", planes}}, 1).planes.size(), 6u);
}

}  // namespace
}  // namespace tetrascope::protocol
