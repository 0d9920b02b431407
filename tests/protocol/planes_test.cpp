// clip.set and slice.set against the shared vectors (protocol/testdata/planes.json, also run
// by the JS codec), the planes' normalisation, and the command line's plane text.
#include <algorithm>
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
  EXPECT_EQ(parse_clip_spec(clip_json(clip), 1), clip);
}

TEST(Planes, SlicesAreLitUnlessSentFlat) {
  const auto slice = [](const char* text) { return std::get<SliceSet>(parse_message(text, Limits{}).message).slice; };
  EXPECT_TRUE(slice(R"({"type":"slice.set","id":1,"planes":[{"normal":[1,0,0],"offset":0}]})").lit);
  const SliceSpec flat = slice(R"({"type":"slice.set","id":2,"planes":[{"normal":[1,0,0],"offset":0}],"lit":false})");
  EXPECT_FALSE(flat.lit);
  EXPECT_EQ(slice_json(flat)["lit"], false);
  EXPECT_EQ(parse_slice_spec(slice_json(flat), 2), flat);
  // a lit that is not a boolean names the field
  try {
    parse_slice_spec(nlohmann::json::parse(R"({"planes":[],"lit":"off"})"), 3);
    ADD_FAILURE() << "accepted";
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.code(), code::kBadField);
    EXPECT_NE(std::string(e.what()).find("lit"), std::string::npos) << e.what();
  }
}

TEST(ProbeResultVectors, EveryProbeResultRoundTripsAndHoldsItsRows) {
  std::ifstream in(tetrascope::testing::source_dir() / "protocol" / "testdata" / "planes.json");
  const nlohmann::json file = nlohmann::json::parse(in);
  ASSERT_GE(file["probe_results"].size(), 4u);
  for (const auto& vector : file["probe_results"]) {
    SCOPED_TRACE(vector["name"].get<std::string>());
    const nlohmann::json& expected = vector["json"];
    const ProbeResult r = ProbeResult::from_json(expected);
    nlohmann::json encoded = r.to_json(expected["id"].get<uint32_t>());
    if (!expected.contains("values")) encoded.erase("values");  // an older server's reply
    EXPECT_EQ(encoded, expected);
    // every row the viewer shows (protocol/js/planes.js probeRows) is in the values
    for (const auto& row : vector["rows"]) {
      if (!expected.contains("values")) break;
      const auto it = std::find_if(r.values.begin(), r.values.end(), [&](const auto& v) { return v.first == row["name"]; });
      ASSERT_NE(it, r.values.end()) << row["name"];
      const nlohmann::json value = row["value"].is_array() ? row["value"] : nlohmann::json::array({row["value"]});
      ASSERT_EQ(it->second.size(), value.size());
      for (size_t k = 0; k < value.size(); ++k) {
        if (value[k].is_null()) {
          EXPECT_TRUE(std::isnan(it->second[k]));
        } else {
          EXPECT_EQ(it->second[k], value[k].get<double>());
        }
      }
    }
  }
}

TEST(ProbeResultVectors, AMalformedProbeResultIsRefusedNamingTheField) {
  for (const char* text : {R"({"hit":true,"surface":"slice","position":[0,0],"attribute":"f","value":1})",
                           R"({"hit":true,"surface":"slice","position":[0,0,0],"attribute":"f","value":"1"})",
                           R"({"hit":true,"surface":"slice","position":[0,0,0],"attribute":"f","value":1,"values":[1]})",
                           R"({"hit":true,"surface":"slice","position":[0,0,0],"attribute":"f","value":1,"values":{"v":[]}})",
                           R"({"hit":true,"surface":"slice","position":[0,0,0],"attribute":"f","value":1,"values":{"v":["x"]}})"}) {
    EXPECT_THROW(ProbeResult::from_json(nlohmann::json::parse(text)), ProtocolError) << text;
  }
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
