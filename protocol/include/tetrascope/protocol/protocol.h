// The WebSocket protocol between the browser and the server.
//
// Control messages are JSON text frames {"type": "camera.set", "id": 7, ...}; every field is
// checked here, at the edge, and a bad message becomes a ProtocolError whose code and message
// go back to the client in an `error` reply (the session lives on). Frames are binary
// messages: a 48-byte little-endian header (FrameHeader) followed by the JPEG or PNG.
// protocol/schema/messages.schema.json describes the same messages; the test vectors in
// protocol/testdata/ are checked against this codec and the browser's (protocol/js/codec.js).
// Input of parse_message and decode_frame_header is untrusted.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/protocol/planes.h"
#include "tetrascope/protocol/transfer_function.h"

namespace tetrascope::protocol {

constexpr uint32_t kVersion = 1;
constexpr uint32_t kFrameMagic = 0x31465354;  // "TSF1" in file order
constexpr size_t kFrameHeaderBytes = 48;

// Fixed ranges of control-message fields (schema/messages.schema.json and js/codec.js say
// the same).
constexpr uint32_t kMinImageSide = 16;            // view.resize width and height
constexpr uint64_t kMaxBudget = 4000000000ull;    // lod.set, tets
constexpr int kMaxJpegQuality = 100;              // quality.set, from 1
constexpr double kMinInteractionScale = 0.25;     // quality.set interaction_scale, to 1
constexpr uint32_t kMaxLineSeeds = 2000;          // lines.set count with a rake
constexpr uint32_t kMaxDenseLineCells = 64;       // lines.set count with dense seeding
constexpr uint32_t kMaxLineSteps = 100000;        // lines.set max_steps
constexpr uint32_t kMaxSelectedLines = 4096;      // lines.set select.lines
constexpr double kMaxLineWidthPixels = 32;        // lines.set line_width, from 1
constexpr double kMaxPointSizePixels = 64;        // points.set size, from 0 (covering)
constexpr uint32_t kMaxHiddenRegions = 1024;
constexpr uint32_t kMaxTensorCells = 32;          // tensors.set density and surface_density (0: none)      // regions.set hidden: ids below this, at most this many

// Every limit of a session, each configurable (ServerOptions::limits; `serve` has options for
// the sessions, message size and rate and the image side) and tested at and past it.
struct Limits {
  size_t max_message_bytes = 64 * 1024;
  uint32_t max_messages_per_second = 200;
  uint32_t max_image_side = 4096;
  uint32_t max_sessions = 32;
  uint32_t max_bad_messages = 16;  // bad messages in a row before the session is closed (policy violation)
  uint32_t max_isovalues = 16;
  uint32_t max_tf_points = kMaxTfPoints;
};

// Error codes of `error` replies (and of ProtocolError).
namespace code {
constexpr const char* kBadJson = "bad_json";              // not a JSON object
constexpr const char* kTooLarge = "too_large";            // over Limits::max_message_bytes
constexpr const char* kBadMessage = "bad_message";        // no string `type` or no integer `id`
constexpr const char* kUnknownType = "unknown_type";
constexpr const char* kBadField = "bad_field";            // a field is missing, mistyped or out of range
constexpr const char* kUnsupportedVersion = "unsupported_version";
constexpr const char* kHelloFirst = "hello_first";        // a message before `hello`
constexpr const char* kUnauthorized = "unauthorized";
constexpr const char* kNoDataset = "no_dataset";          // needs dataset.open first
constexpr const char* kNotFound = "not_found";            // no such dataset or attribute
constexpr const char* kDatasetDeleted = "dataset_deleted";  // (no id) the open dataset was deleted; open another
constexpr const char* kDatasetDamaged = "dataset_damaged";  // the store failed a check (checksum, count): closed for every session
constexpr const char* kRateLimited = "rate_limited";
constexpr const char* kBinaryMessage = "binary_message";  // clients send text frames only
constexpr const char* kInternal = "internal";
}  // namespace code

class ProtocolError : public std::runtime_error {
 public:
  ProtocolError(std::string code, const std::string& message, std::optional<uint32_t> id = std::nullopt)
      : std::runtime_error(message), code_(std::move(code)), id_(id) {}
  const std::string& code() const { return code_; }
  std::optional<uint32_t> id() const { return id_; }

 private:
  std::string code_;
  std::optional<uint32_t> id_;
};

struct Hello {
  uint32_t version = kVersion;
  std::string token;
};
struct DatasetOpen {
  std::string name;
};
struct CameraSet {
  std::array<double, 3> eye{}, target{}, up{0, 1, 0};
  double fov = 30;  // vertical, degrees
  bool orthographic = false;
  double height = 1;         // visible height of orthographic views
  bool interacting = true;   // false: a jump (reset, saved view), rendered as a still at once
};
struct TfSet {
  TransferFunction tf;  // checked (parse_transfer_function); the attribute is the session's to find
};
// What to draw: "dvr", "iso" (or "isosurface"), "surface", "lines" (stream lines) and
// "points" (point isosurfaces) and "tensors" (a tensor field's tubes and diffusion surfaces
// as points) joined by '+', as mode.set and `tetrascope render --mode` take
// them; "slice" alone draws none of them (only the slice planes of slice.set / --slice).
// Throws std::invalid_argument naming an unknown part.
struct Modes {
  bool dvr = false, iso = false, surface = false, lines = false, points = false, tensors = false;
};
Modes parse_modes(std::string_view text);

struct ModeSet {
  bool dvr = true, iso = false, surface = false, lines = false, points = false, tensors = false;
  std::optional<bool> wireframe, box;
  std::optional<std::array<float, 3>> background;  // r g b in [0, 1]
};
struct IsoSet {
  std::vector<double> values;
  std::optional<double> opacity;
  std::optional<std::string> color_by;  // a second attribute; "" colours by value
};
struct LodSet {
  std::optional<uint64_t> budget, interaction_budget;  // tets
  // Refine stills until the cut's estimated error (FrameHeader::estimated_error) is at most
  // this, instead of up to the still budget (which stays the upper limit); 0: by budget.
  std::optional<double> max_error;
};
struct ViewResize {
  uint32_t width = 0, height = 0;
};
struct QualitySet {
  std::optional<int> interaction, still;        // JPEG quality 1..100
  std::optional<std::string> still_codec;       // "jpeg" or "png"
  std::optional<double> interaction_scale;      // 0.25..1 of the view size
};
// Stream lines (§7.3). Every field optional; what is absent stays as it was.
struct LinesSet {
  std::optional<std::string> field;              // a vector attribute (the session checks it)
  bool dense = false;                            // seeds "dense": §7.3.1 dense seeding
  std::optional<std::array<double, 6>> rake;     // seeds [[x0,y0,z0],[x1,y1,z1]]: a line rake
  std::optional<uint32_t> count;                 // rake seeds (1..kMaxLineSeeds) or dense cells (1..kMaxDenseLineCells); needs seeds
  std::optional<uint32_t> max_steps;
  bool select = false;                           // `select` present: the selection is replaced
  std::vector<uint32_t> select_lines;
  std::optional<std::array<double, 6>> select_box;    // [[lo], [hi]]
  std::optional<std::array<double, 2>> select_pixel;  // a click, fractions 0..1 of the image
  std::optional<double> ghost_opacity, line_width;
  std::optional<bool> halos;
  std::optional<std::string> flow;               // "arrows", "dashes" or "none"
  std::optional<double> depth_correction;        // 0..1, §7.3.3 (RenderSettings::depth_correction)
  std::optional<double> dash_phase;              // 0..1, moves dashes along the flow (the viewer animates it)
};
// Point isosurfaces (§7.2).
struct PointsSet {
  std::vector<double> values;       // none: 8 regularly spaced over the colour range
  std::optional<double> size;       // splat pixels; 0: covering
};
// A tensor field's stream tubes and diffusion surfaces as points (§7.4.2). Every field
// optional; what is absent stays as it was.
struct TensorsSet {
  std::optional<std::string> field;        // a symmetric tensor attribute (the session checks it)
  std::optional<uint32_t> density;         // tube seeding: cells along the longest side, 0..kMaxTensorCells
  std::optional<uint32_t> surface_density; // diffusion-surface seeding, 0..kMaxTensorCells
  std::optional<double> min_cl, min_cp;    // 0..1: the anisotropy where tubes run and surfaces grow
  std::optional<std::string> color;        // "class" or a derived quantity (lambda1 ... cs)
  std::optional<double> size;              // splat pixels, 0..kMaxPointSizePixels; 0: covering
};
struct Ping {};
// Boundary regions the surface leaves out (ids of dataset.info's regions), the whole set each
// time. The session checks the ids against the dataset.
struct RegionsSet {
  std::vector<uint32_t> hidden;  // ascending, each once
};

// The time step of a time series shown (dataset.info's time_steps: 0..count-1; the session
// checks it against the dataset), and optionally the step the viewer shows next (its values
// are made ready meanwhile: play).
constexpr uint32_t kMaxTimeStep = 99999;
struct TimeSet {
  uint32_t step = 0;
  std::optional<uint32_t> prefetch;
};

using Message = std::variant<Hello, DatasetOpen, CameraSet, TfSet, ModeSet, IsoSet, LodSet, ViewResize, QualitySet, LinesSet, PointsSet, Ping,
                             ClipSet, SliceSet, Probe, RegionsSet, TensorsSet, TimeSet>;

struct Envelope {
  std::string type;
  uint32_t id = 0;
  Message message;
};

// Parses and checks one control message. Throws ProtocolError (with the message's id when it
// could be read).
Envelope parse_message(std::string_view text, const Limits& limits);

// Replies (JSON text).
std::string error_reply(const std::string& code, const std::string& message, std::optional<uint32_t> id);
std::string pong_reply(uint32_t id);

enum class Codec : uint8_t { kJpeg = 0, kPng = 1 };

struct FrameHeader {
  uint32_t frame_number = 0;
  uint32_t message_id = 0;  // id of the last control message applied to this frame
  uint32_t width = 0, height = 0;
  Codec codec = Codec::kJpeg;
  bool still = false;       // the refined frame after interaction stops (the last refinement step)
  bool refining = false;    // a refinement step towards the still (more follow unless input comes)
  uint64_t tets = 0;        // tets rendered
  float render_ms = 0, encode_ms = 0;
  uint32_t payload_bytes = 0;
  float estimated_error = 0;  // the cut's estimated error (lod::CutChanges::estimated_error); 0 for a whole mesh
};
// Layout (little-endian): u32 magic, u16 version, u8 codec, u8 flags (bit 0: still, bit 1:
// refining), u32 frame_number, u32 message_id, u32 width, u32 height, u64 tets, f32 render_ms,
// f32 encode_ms, u32 payload_bytes, f32 estimated_error.
std::array<uint8_t, kFrameHeaderBytes> encode_frame_header(const FrameHeader& header);
// Checks magic, version, codec, sizes against `bytes` (header + payload). Throws ProtocolError.
FrameHeader decode_frame_header(std::span<const uint8_t> bytes, const Limits& limits);

}  // namespace tetrascope::protocol
