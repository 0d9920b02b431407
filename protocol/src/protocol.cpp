// Control-message parsing and the binary frame header (protocol/schema/messages.schema.json
// says the same in JSON Schema; protocol/js/codec.js in JavaScript).
#include "tetrascope/protocol/protocol.h"

#include <algorithm>

#include <cmath>
#include <cstring>

#include "json_fields.h"

namespace tetrascope::protocol {
namespace {

using nlohmann::json;
using detail::Fields;


std::array<double, 6> two_points(const Fields& f, const std::string& field, const json& v) {
  if (!v.is_array() || v.size() != 2 || !v[0].is_array() || v[0].size() != 3 || !v[1].is_array() || v[1].size() != 3)
    f.fail(field, "expected [[x, y, z], [x, y, z]]");
  std::array<double, 6> out{};
  for (size_t i = 0; i < 6; ++i) out[i] = f.number(field, v[i / 3][i % 3], -1e30, 1e30);
  return out;
}

LinesSet parse_lines_set(const Fields& f, uint32_t) {
  LinesSet m;
  m.field = f.string("field", 128);
  if (const json* seeds = f.find("seeds")) {
    if (seeds->is_string() && seeds->get<std::string>() == "dense") m.dense = true;
    else if (seeds->is_array()) m.rake = two_points(f, "seeds", *seeds);
    else f.fail("seeds", "expected \"dense\" or rake ends [[x, y, z], [x, y, z]]");
  }
  if (f.find("count")) {
    if (!m.dense && !m.rake) f.fail("count", "needs seeds (\"dense\" or a rake) in the same message");
    m.count = static_cast<uint32_t>(*f.integer("count", 1, m.dense ? kMaxDenseLineCells : kMaxLineSeeds));
  }
  if (auto steps = f.integer("max_steps", 1, kMaxLineSteps)) m.max_steps = static_cast<uint32_t>(*steps);
  if (const json* select = f.find("select")) {
    if (!select->is_object()) f.fail("select", "expected an object with lines, box or pixel");
    m.select = true;
    const Fields s(*select, f.id());
    if (const json* lines = s.find("lines")) {
      if (!lines->is_array()) f.fail("select.lines", "expected a list of line ids");
      if (lines->size() > kMaxSelectedLines) f.fail("select.lines", "more than " + std::to_string(kMaxSelectedLines) + " lines");
      for (const json& id : *lines) {
        if (!id.is_number_unsigned() || id.get<uint64_t>() > 0xFFFFFFFFull) f.fail("select.lines", "expected whole numbers");
        m.select_lines.push_back(static_cast<uint32_t>(id.get<uint64_t>()));
      }
    }
    if (const json* box = s.find("box")) {
      m.select_box = two_points(f, "select.box", *box);
      const auto& b = *m.select_box;
      if (!(b[0] <= b[3] && b[1] <= b[4] && b[2] <= b[5])) f.fail("select.box", "the first corner must be the low one");
    }
    if (const json* pixel = s.find("pixel")) {
      if (!pixel->is_array() || pixel->size() != 2) f.fail("select.pixel", "expected [x, y], fractions of the image");
      m.select_pixel = std::array<double, 2>{f.number("select.pixel", (*pixel)[0], 0, 1), f.number("select.pixel", (*pixel)[1], 0, 1)};
    }
  }
  m.ghost_opacity = f.number("ghost_opacity", 0.01, 1);
  m.line_width = f.number("line_width", 1, kMaxLineWidthPixels);
  m.halos = f.boolean("halos");
  m.flow = f.string("flow", 16);
  if (m.flow && *m.flow != "arrows" && *m.flow != "dashes" && *m.flow != "none") f.fail("flow", "expected arrows, dashes or none");
  m.depth_correction = f.number("depth_correction", 0, 1);
  m.dash_phase = f.number("dash_phase", 0, 1);
  return m;
}

CameraSet parse_camera_set(const Fields& f) {
  CameraSet m;
  m.eye = f.vector3("eye");
  m.target = f.vector3("target");
  if (f.find("up")) m.up = f.vector3("up");
  m.fov = f.number("fov", 1, 170).value_or(30);
  m.orthographic = f.boolean("orthographic").value_or(false);
  m.height = f.number("height", 1e-30, 1e30).value_or(1);
  m.interacting = f.boolean("interacting").value_or(true);
  const std::array<double, 3> d{m.target[0] - m.eye[0], m.target[1] - m.eye[1], m.target[2] - m.eye[2]};
  const double dl = std::sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(dl > 0)) f.fail("target", "equals eye");
  const std::array<double, 3> c{d[1] * m.up[2] - d[2] * m.up[1], d[2] * m.up[0] - d[0] * m.up[2], d[0] * m.up[1] - d[1] * m.up[0]};
  const double ul = std::sqrt(m.up[0] * m.up[0] + m.up[1] * m.up[1] + m.up[2] * m.up[2]);
  if (!(std::sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) > 1e-9 * dl * ul)) f.fail("up", "zero or parallel to the view direction");
  return m;
}

ModeSet parse_mode_set(const Fields& f) {
  ModeSet m;
  const std::string mode = f.string("mode", 64).value_or("");
  if (mode.empty()) f.fail("mode", "missing");
  try {
    const Modes modes = parse_modes(mode);
    m.dvr = modes.dvr;
    m.iso = modes.iso;
    m.surface = modes.surface;
    m.lines = modes.lines;
    m.points = modes.points;
    m.tensors = modes.tensors;
  } catch (const std::invalid_argument& e) {
    f.fail("mode", e.what());
  }
  m.wireframe = f.boolean("wireframe");
  m.box = f.boolean("box");
  if (const json* background = f.find("background")) {
    if (!background->is_array() || background->size() != 3) f.fail("background", "expected [r, g, b], each 0 to 1");
    std::array<float, 3> rgb{};
    for (size_t k = 0; k < 3; ++k) rgb[k] = static_cast<float>(f.number("background", (*background)[k], 0, 1));
    m.background = rgb;
  }
  return m;
}

RegionsSet parse_regions_set(const Fields& f) {
  RegionsSet m;
  const json& hidden = f.require("hidden");
  if (!hidden.is_array()) f.fail("hidden", "expected a list of region ids");
  const std::string most = std::to_string(kMaxHiddenRegions);
  if (hidden.size() > kMaxHiddenRegions) f.fail("hidden", "more than " + most + " regions");
  for (const json& region : hidden) {
    if (!region.is_number_unsigned() || region.get<uint64_t>() >= kMaxHiddenRegions) f.fail("hidden", "expected region ids from 0 to " + std::to_string(kMaxHiddenRegions - 1));
    m.hidden.push_back(static_cast<uint32_t>(region.get<uint64_t>()));
  }
  std::sort(m.hidden.begin(), m.hidden.end());
  m.hidden.erase(std::unique(m.hidden.begin(), m.hidden.end()), m.hidden.end());
  return m;
}

Message parse_body(const std::string& type, const Fields& f, const Limits& limits, uint32_t id) {
  if (type == "hello") {
    Hello m;
    const json& version = f.require("version");
    if (!version.is_number_unsigned()) f.fail("version", "expected a whole number");
    if (version.get<uint64_t>() != kVersion)
      throw ProtocolError(code::kUnsupportedVersion, "this server speaks protocol version " + std::to_string(kVersion) + ", the client " + version.dump(), id);
    m.token = f.string("token", 1024).value_or("");
    return m;
  }
  if (type == "dataset.open") {
    DatasetOpen m;
    m.name = f.string("name", 128).value_or("");
    if (m.name.empty()) f.fail("name", "missing");
    return m;
  }
  if (type == "camera.set") return parse_camera_set(f);
  if (type == "tf.set") return TfSet{parse_transfer_function(f.object(), limits.max_tf_points, id)};
  if (type == "mode.set") return parse_mode_set(f);
  if (type == "iso.set") {
    IsoSet m;
    const json& values = f.require("values");
    if (!values.is_array()) f.fail("values", "expected a list of numbers");
    if (values.size() > limits.max_isovalues) f.fail("values", "more than " + std::to_string(limits.max_isovalues) + " isovalues");
    for (const json& v : values) m.values.push_back(f.number("values", v, -1e30, 1e30));
    m.opacity = f.number("opacity", 0, 1);
    m.color_by = f.string("color_by", 128);
    return m;
  }
  if (type == "lod.set") {
    LodSet m;
    m.budget = f.integer("budget", 1, kMaxBudget);
    m.interaction_budget = f.integer("interaction_budget", 1, kMaxBudget);
    m.max_error = f.number("max_error", 0, 1e30);
    if (!m.budget && !m.interaction_budget && !m.max_error) f.fail("budget", "missing (budget, interaction_budget or max_error)");
    return m;
  }
  if (type == "view.resize") {
    ViewResize m;
    m.width = static_cast<uint32_t>(f.integer("width", kMinImageSide, limits.max_image_side).value_or(0));
    m.height = static_cast<uint32_t>(f.integer("height", kMinImageSide, limits.max_image_side).value_or(0));
    if (!m.width) f.fail("width", "missing");
    if (!m.height) f.fail("height", "missing");
    return m;
  }
  if (type == "quality.set") {
    QualitySet m;
    if (auto q = f.integer("interaction", 1, kMaxJpegQuality)) m.interaction = static_cast<int>(*q);
    if (auto q = f.integer("still", 1, kMaxJpegQuality)) m.still = static_cast<int>(*q);
    m.still_codec = f.string("still_codec", 8);
    if (m.still_codec && *m.still_codec != "jpeg" && *m.still_codec != "png") f.fail("still_codec", "expected jpeg or png");
    m.interaction_scale = f.number("interaction_scale", kMinInteractionScale, 1);
    return m;
  }
  if (type == "lines.set") return parse_lines_set(f, id);
  if (type == "points.set") {
    PointsSet m;
    if (const json* values = f.find("values")) {
      if (!values->is_array()) f.fail("values", "expected a list of numbers");
      if (values->size() > limits.max_isovalues) f.fail("values", "more than " + std::to_string(limits.max_isovalues) + " isovalues");
      for (const json& v : *values) m.values.push_back(f.number("values", v, -1e30, 1e30));
    }
    m.size = f.number("size", 0, kMaxPointSizePixels);
    return m;
  }
  if (type == "tensors.set") {
    TensorsSet m;
    m.field = f.string("field", 128);
    if (m.field && m.field->empty()) f.fail("field", "empty");
    if (auto n = f.integer("density", 0, kMaxTensorCells)) m.density = uint32_t(*n);
    if (auto n = f.integer("surface_density", 0, kMaxTensorCells)) m.surface_density = uint32_t(*n);
    m.min_cl = f.number("min_cl", 0, 1);
    m.min_cp = f.number("min_cp", 0, 1);
    m.color = f.string("color", 32);
    if (m.color) {
      static constexpr const char* kColors[] = {"class", "lambda1", "lambda2", "lambda3", "trace", "von_mises", "fa", "cl", "cp", "cs"};
      if (std::find(std::begin(kColors), std::end(kColors), *m.color) == std::end(kColors))
        f.fail("color", "expected class, lambda1, lambda2, lambda3, trace, von_mises, fa, cl, cp or cs");
    }
    m.size = f.number("size", 0, kMaxPointSizePixels);
    return m;
  }
  if (type == "ping") return Ping{};
  if (type == "regions.set") return parse_regions_set(f);
  if (type == "time.set") {
    TimeSet m;
    const auto step = f.integer("step", 0, kMaxTimeStep);
    if (!step) f.fail("step", "missing");
    m.step = static_cast<uint32_t>(*step);
    if (auto next = f.integer("prefetch", 0, kMaxTimeStep)) m.prefetch = static_cast<uint32_t>(*next);
    return m;
  }
  if (type == "clip.set") return ClipSet{parse_clip_spec(f.object(), id)};  // planes.cpp
  if (type == "slice.set") return SliceSet{parse_slice_spec(f.object(), id)};
  if (type == "probe") return parse_probe(f.object(), limits.max_image_side, id);
  throw ProtocolError(code::kUnknownType, "unknown message type '" + type + "'", id);
}

void put(uint8_t* at, uint64_t value, size_t bytes) {
  for (size_t i = 0; i < bytes; ++i) at[i] = static_cast<uint8_t>(value >> (8 * i));
}
uint64_t get(const uint8_t* at, size_t bytes) {
  uint64_t value = 0;
  for (size_t i = 0; i < bytes; ++i) value |= uint64_t(at[i]) << (8 * i);
  return value;
}

}  // namespace

Modes parse_modes(std::string_view text) {
  Modes m;
  for (size_t at = 0; at <= text.size();) {
    size_t plus = text.find('+', at);
    if (plus == std::string_view::npos) plus = text.size();
    const std::string_view part = text.substr(at, plus - at);
    if (part == "dvr") m.dvr = true;
    else if (part == "iso" || part == "isosurface") m.iso = true;
    else if (part == "surface") m.surface = true;
    else if (part == "lines") m.lines = true;
    else if (part == "points") m.points = true;
    else if (part == "tensors") m.tensors = true;
    else if (part == "slice") {  // the slice planes only (planes.h): none of the others
    }
    else throw std::invalid_argument("unknown mode '" + std::string(part) + "' (dvr, iso, surface, lines, points, tensors, slice or combinations such as dvr+lines)");
    at = plus + 1;
  }
  return m;
}

Envelope parse_message(std::string_view text, const Limits& limits) {
  if (text.size() > limits.max_message_bytes)
    throw ProtocolError(code::kTooLarge, "message of " + std::to_string(text.size()) + " bytes; the limit is " + std::to_string(limits.max_message_bytes));
  json object = json::parse(text.begin(), text.end(), nullptr, false);
  if (object.is_discarded() || !object.is_object()) throw ProtocolError(code::kBadJson, "a control message is one JSON object");
  std::optional<uint32_t> id;
  auto id_field = object.find("id");
  if (id_field != object.end() && id_field->is_number_unsigned() && id_field->get<uint64_t>() <= 0xFFFFFFFFull) id = static_cast<uint32_t>(id_field->get<uint64_t>());
  auto type_field = object.find("type");
  if (type_field == object.end() || !type_field->is_string()) throw ProtocolError(code::kBadMessage, "missing \"type\"", id);
  if (!id) throw ProtocolError(code::kBadMessage, "\"id\" must be a whole number 0..4294967295", std::nullopt);
  Envelope envelope;
  envelope.type = type_field->get<std::string>();
  envelope.id = *id;
  envelope.message = parse_body(envelope.type, Fields(object, *id), limits, *id);
  return envelope;
}

std::string error_reply(const std::string& error_code, const std::string& message, std::optional<uint32_t> id) {
  nlohmann::json j = {{"type", "error"}, {"code", error_code}, {"message", message}};
  j["id"] = id ? nlohmann::json(*id) : nlohmann::json(nullptr);
  return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
}

std::string pong_reply(uint32_t id) { return nlohmann::json({{"type", "pong"}, {"id", id}}).dump(); }

std::array<uint8_t, kFrameHeaderBytes> encode_frame_header(const FrameHeader& h) {
  std::array<uint8_t, kFrameHeaderBytes> out{};
  uint8_t* p = out.data();
  uint32_t render_bits = 0, encode_bits = 0, error_bits = 0;
  std::memcpy(&render_bits, &h.render_ms, 4);
  std::memcpy(&encode_bits, &h.encode_ms, 4);
  std::memcpy(&error_bits, &h.estimated_error, 4);
  put(p + 0, kFrameMagic, 4);
  put(p + 4, kVersion, 2);
  p[6] = static_cast<uint8_t>(h.codec);
  p[7] = static_cast<uint8_t>((h.still ? 1 : 0) | (h.refining ? 2 : 0));
  put(p + 8, h.frame_number, 4);
  put(p + 12, h.message_id, 4);
  put(p + 16, h.width, 4);
  put(p + 20, h.height, 4);
  put(p + 24, h.tets, 8);
  put(p + 32, render_bits, 4);
  put(p + 36, encode_bits, 4);
  put(p + 40, h.payload_bytes, 4);
  put(p + 44, error_bits, 4);
  return out;
}

FrameHeader decode_frame_header(std::span<const uint8_t> bytes, const Limits& limits) {
  if (bytes.size() < kFrameHeaderBytes) throw ProtocolError(code::kBadMessage, "frame shorter than its " + std::to_string(kFrameHeaderBytes) + "-byte header");
  const uint8_t* p = bytes.data();
  if (get(p, 4) != kFrameMagic) throw ProtocolError(code::kBadMessage, "frame: bad magic");
  if (get(p + 4, 2) != kVersion) throw ProtocolError(code::kUnsupportedVersion, "frame: version " + std::to_string(get(p + 4, 2)));
  if (p[6] > 1) throw ProtocolError(code::kBadMessage, "frame: unknown codec " + std::to_string(p[6]));
  if (p[7] > 3) throw ProtocolError(code::kBadMessage, "frame: unknown flags");
  if (p[7] == 3) throw ProtocolError(code::kBadMessage, "frame: both still and refining");
  FrameHeader h;
  h.codec = static_cast<Codec>(p[6]);
  h.still = p[7] & 1;
  h.refining = (p[7] & 2) != 0;
  h.frame_number = static_cast<uint32_t>(get(p + 8, 4));
  h.message_id = static_cast<uint32_t>(get(p + 12, 4));
  h.width = static_cast<uint32_t>(get(p + 16, 4));
  h.height = static_cast<uint32_t>(get(p + 20, 4));
  h.tets = get(p + 24, 8);
  const uint32_t render_bits = static_cast<uint32_t>(get(p + 32, 4)), encode_bits = static_cast<uint32_t>(get(p + 36, 4));
  std::memcpy(&h.render_ms, &render_bits, 4);
  std::memcpy(&h.encode_ms, &encode_bits, 4);
  const uint32_t error_bits = static_cast<uint32_t>(get(p + 44, 4));
  std::memcpy(&h.estimated_error, &error_bits, 4);
  if (!(h.estimated_error >= 0) || std::isinf(h.estimated_error)) throw ProtocolError(code::kBadMessage, "frame: estimated error not a finite number >= 0");
  h.payload_bytes = static_cast<uint32_t>(get(p + 40, 4));
  if (h.width == 0 || h.height == 0 || h.width > limits.max_image_side || h.height > limits.max_image_side)
    throw ProtocolError(code::kBadMessage, "frame: image size " + std::to_string(h.width) + "x" + std::to_string(h.height) + " outside 1.." + std::to_string(limits.max_image_side));
  if (uint64_t(h.payload_bytes) + kFrameHeaderBytes != bytes.size())
    throw ProtocolError(code::kBadMessage, "frame: header says " + std::to_string(h.payload_bytes) + " payload bytes, message has " + std::to_string(bytes.size() - kFrameHeaderBytes));
  return h;
}

}  // namespace tetrascope::protocol
