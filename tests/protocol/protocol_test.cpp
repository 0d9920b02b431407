// The C++ codec against the shared test vectors in protocol/testdata/ (the JS codec is
// checked against the same files by protocol/js/codec.test.mjs).
#include <fstream>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tetrascope/protocol/protocol.h"
#include "test_paths.h"

namespace tetrascope::protocol {
namespace {

nlohmann::json load(const std::string& name) {
  std::ifstream in((tetrascope::testing::source_dir() / "protocol" / "testdata" / name));
  EXPECT_TRUE(in.good()) << name;
  return nlohmann::json::parse(in);
}

std::string text_of(const nlohmann::json& vector) {
  std::string text = vector.at("text");
  if (!vector.contains("length")) return text;
  const size_t length = vector["length"], at = text.find("@PAD@");
  return text.substr(0, at) + std::string(length - (text.size() - 5), 'x') + text.substr(at + 5);
}

Limits limits_of(const nlohmann::json& j) {
  Limits limits;
  limits.max_message_bytes = j.at("max_message_bytes");
  limits.max_image_side = j.at("max_image_side");
  limits.max_isovalues = j.at("max_isovalues");
  limits.max_tf_points = j.at("max_tf_points");
  return limits;
}

TEST(ProtocolVectors, EveryControlMessageParsesOrIsRefusedWithItsCode) {
  const nlohmann::json file = load("messages.json");
  const Limits limits = limits_of(file["limits"]);
  size_t accepted = 0, refused = 0;
  for (const auto& vector : file["messages"]) {
    SCOPED_TRACE(vector["name"].get<std::string>());
    const std::string text = text_of(vector);
    if (vector.contains("length")) {
      EXPECT_EQ(text.size(), vector["length"].get<size_t>());
    }
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
        EXPECT_FALSE(std::string(e.what()).empty());
        ++refused;
      }
    } else {
      const Envelope e = parse_message(text, limits);
      EXPECT_EQ(e.type, vector["type"].get<std::string>());
      EXPECT_EQ(e.id, vector["id"].get<uint32_t>());
      ++accepted;
    }
  }
  EXPECT_GE(accepted, 15u);
  EXPECT_GE(refused, 25u);
}

TEST(ProtocolVectors, ParsedFieldsCarryTheValuesSent) {
  const Limits limits;
  const Envelope camera = parse_message(R"({"type":"camera.set","id":3,"eye":[0,0,5],"target":[1,2,3],"fov":40,"interacting":false})", limits);
  const auto& c = std::get<CameraSet>(camera.message);
  EXPECT_EQ(c.eye[2], 5);
  EXPECT_EQ(c.target[1], 2);
  EXPECT_EQ(c.up[1], 1);  // default
  EXPECT_EQ(c.fov, 40);
  EXPECT_FALSE(c.interacting);
  const auto mode = std::get<ModeSet>(parse_message(R"({"type":"mode.set","id":4,"mode":"surface+iso","wireframe":true})", limits).message);
  EXPECT_FALSE(mode.dvr);
  EXPECT_TRUE(mode.iso);
  EXPECT_TRUE(mode.surface);
  EXPECT_EQ(mode.wireframe, true);
  EXPECT_FALSE(mode.box.has_value());
  const auto tf = std::get<TfSet>(parse_message(R"({"type":"tf.set","id":5,"attribute":"p","range":[0,2],"opacity":[[0,0],[2,1]],"bogus":1})", limits).message);
  EXPECT_EQ(tf.tf.attribute, "p");  // typed: unknown fields ("bogus") are dropped
  ASSERT_EQ(tf.tf.opacity.size(), 2u);
  EXPECT_EQ(tf.tf.opacity[1][1], 1);
  EXPECT_EQ(tf.tf.range, (std::array<double, 2>{0, 2}));
  EXPECT_EQ(tf.tf.colormap, "viridis");
  EXPECT_DOUBLE_EQ(tf.tf.alpha(1), 0.5);
  EXPECT_EQ(tf.tf.component, view::kMagnitude);  // without "component": a vector's magnitude
  const auto x = std::get<TfSet>(parse_message(R"({"type":"tf.set","id":5,"attribute":"velocity","component":"x"})", limits).message);
  EXPECT_EQ(x.tf.component, 0);
  EXPECT_EQ(std::get<TfSet>(parse_message(R"({"type":"tf.set","id":5,"component":"z"})", limits).message).tf.component, 2);
  EXPECT_EQ(std::get<TfSet>(parse_message(R"({"type":"tf.set","id":5,"component":"magnitude"})", limits).message).tf.component, view::kMagnitude);
  EXPECT_NE(x.tf.key(), tf.tf.key());
  try {
    parse_message(R"({"type":"tf.set","id":9,"component":"w"})", limits);
    ADD_FAILURE() << "a component other than magnitude, x, y, z was accepted";
  } catch (const ProtocolError& e) {
    EXPECT_EQ(e.code(), code::kBadField);
    EXPECT_NE(std::string(e.what()).find("component"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("magnitude, x, y, z"), std::string::npos) << e.what();
  }
  const auto lod = std::get<LodSet>(parse_message(R"({"type":"lod.set","id":6,"interaction_budget":20000})", limits).message);
  EXPECT_FALSE(lod.budget.has_value());
  EXPECT_EQ(lod.interaction_budget, 20000u);
  EXPECT_FALSE(lod.max_error.has_value());
  const auto bound = std::get<LodSet>(parse_message(R"({"type":"lod.set","id":7,"max_error":0.25})", limits).message);
  EXPECT_FALSE(bound.budget.has_value());
  EXPECT_DOUBLE_EQ(*bound.max_error, 0.25);
}

TEST(ProtocolVectors, LinesAndPointsMessagesCarryTheirFields) {
  const Limits limits;
  const auto rake = std::get<LinesSet>(parse_message(R"({"type":"lines.set","id":1,"field":"Velocity","seeds":[[0,-5,2],[0,5,2]],"count":100,
                                                         "select":{"pixel":[0.5,0.25],"lines":[3,7]},"flow":"dashes"})", limits).message);
  EXPECT_EQ(rake.field, "Velocity");
  ASSERT_TRUE(rake.rake);
  EXPECT_EQ((*rake.rake)[1], -5);
  EXPECT_EQ((*rake.rake)[4], 5);
  EXPECT_FALSE(rake.dense);
  EXPECT_EQ(rake.count, 100u);
  EXPECT_TRUE(rake.select);
  EXPECT_EQ(rake.select_lines, (std::vector<uint32_t>{3, 7}));
  EXPECT_EQ((*rake.select_pixel)[1], 0.25);
  EXPECT_EQ(rake.flow, "dashes");
  const auto style = std::get<LinesSet>(parse_message(R"({"type":"lines.set","id":2,"ghost_opacity":0.3})", limits).message);
  EXPECT_FALSE(style.select) << "no select field: the selection stays";
  EXPECT_FALSE(style.field);
  EXPECT_EQ(style.ghost_opacity, 0.3);
  EXPECT_FALSE(style.depth_correction);
  const auto animation = std::get<LinesSet>(parse_message(R"({"type":"lines.set","id":2,"dash_phase":0.25,"depth_correction":0})", limits).message);
  EXPECT_EQ(animation.dash_phase, 0.25);
  EXPECT_EQ(animation.depth_correction, 0.0);
  const auto modes = std::get<ModeSet>(parse_message(R"({"type":"mode.set","id":3,"mode":"surface+lines+points"})", limits).message);
  EXPECT_TRUE(modes.surface && modes.lines && modes.points && !modes.dvr);
  const auto points = std::get<PointsSet>(parse_message(R"({"type":"points.set","id":4,"values":[1,2,3],"size":0})", limits).message);
  EXPECT_EQ(points.values.size(), 3u);
  EXPECT_EQ(points.size, 0.0);
}

TEST(ProtocolVectors, LimitsAreTheConfiguredOnes) {
  Limits limits;
  limits.max_image_side = 1024;
  limits.max_message_bytes = 100;
  EXPECT_NO_THROW(parse_message(R"({"type":"view.resize","id":1,"width":1024,"height":16})", limits));
  EXPECT_THROW(parse_message(R"({"type":"view.resize","id":1,"width":1025,"height":16})", limits), ProtocolError);
  const std::string at_limit = R"({"type":"ping","id":1,"p":")" + std::string(100 - 29, 'x') + "\"}";
  ASSERT_EQ(at_limit.size(), 100u);
  EXPECT_NO_THROW(parse_message(at_limit, limits));
  EXPECT_THROW(parse_message(at_limit + " ", limits), ProtocolError);
}

std::vector<uint8_t> from_hex(const std::string& hex) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) out.push_back(static_cast<uint8_t>(std::stoi(hex.substr(i, 2), nullptr, 16)));
  return out;
}

TEST(ProtocolVectors, FrameHeadersDecodeAndEncodeToTheSameBytes) {
  const Limits limits;
  for (const auto& vector : load("frames.json")) {
    SCOPED_TRACE(vector["name"].get<std::string>());
    const std::vector<uint8_t> bytes = from_hex(vector["hex"]);
    if (vector.contains("error")) {
      try {
        decode_frame_header(bytes, limits);
        ADD_FAILURE() << "accepted";
      } catch (const ProtocolError& e) {
        EXPECT_EQ(e.code(), vector["error"].get<std::string>()) << e.what();
      }
      continue;
    }
    const FrameHeader h = decode_frame_header(bytes, limits);
    const auto& want = vector["header"];
    EXPECT_EQ(h.frame_number, want["frame_number"].get<uint32_t>());
    EXPECT_EQ(h.message_id, want["message_id"].get<uint32_t>());
    EXPECT_EQ(h.width, want["width"].get<uint32_t>());
    EXPECT_EQ(h.height, want["height"].get<uint32_t>());
    EXPECT_EQ(h.codec == Codec::kPng ? "png" : "jpeg", want["codec"].get<std::string>());
    EXPECT_EQ(h.still, want["still"].get<bool>());
    EXPECT_EQ(h.tets, want["tets"].get<uint64_t>());
    EXPECT_FLOAT_EQ(h.render_ms, want["render_ms"].get<float>());
    EXPECT_FLOAT_EQ(h.encode_ms, want["encode_ms"].get<float>());
    EXPECT_EQ(h.payload_bytes, want["payload_bytes"].get<uint32_t>());
    EXPECT_EQ(h.refining, want["refining"].get<bool>());
    EXPECT_FLOAT_EQ(h.estimated_error, want["estimated_error"].get<float>());
    const auto encoded = encode_frame_header(h);
    EXPECT_TRUE(std::equal(encoded.begin(), encoded.end(), bytes.begin()));
  }
}

TEST(ProtocolReplies, ErrorRepliesAreJsonEvenForHostileText) {
  const auto j = nlohmann::json::parse(error_reply(code::kBadField, std::string("eye: \xff\xfe bad \"quote\""), 9));
  EXPECT_EQ(j["type"], "error");
  EXPECT_EQ(j["code"], "bad_field");
  EXPECT_EQ(j["id"], 9);
  EXPECT_TRUE(nlohmann::json::parse(error_reply(code::kBadJson, "x", std::nullopt))["id"].is_null());
  EXPECT_EQ(nlohmann::json::parse(pong_reply(77))["id"], 77);
}

}  // namespace
}  // namespace tetrascope::protocol
