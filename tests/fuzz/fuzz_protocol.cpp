// libFuzzer target: control messages and frame headers from untrusted bytes. Either parses
// or raises ProtocolError; nothing else may happen.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "tetrascope/protocol/protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace tetrascope::protocol;
  Limits limits;
  limits.max_message_bytes = 4096;
  try {
    parse_message(std::string_view(reinterpret_cast<const char*>(data), size), limits);
  } catch (const ProtocolError&) {
  }
  try {
    const FrameHeader h = decode_frame_header({data, size}, limits);
    const auto again = encode_frame_header(h);
    if (!std::equal(again.begin(), again.begin() + 44, data)) __builtin_trap();  // round trip of what was read
  } catch (const ProtocolError&) {
  }
  return 0;
}
