// Reading one JSON object's fields at the protocol edge: each accessor checks type and range
// and throws ProtocolError(bad_field) naming the field, for the message answered by `id`.
// Shared by the message codec and the transfer-function parser.
#pragma once

#include <array>
#include <cmath>
#include <cstdio>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "tetrascope/protocol/protocol.h"

namespace tetrascope::protocol::detail {

using nlohmann::json;

class Fields {
 public:
  Fields(const json& object, std::optional<uint32_t> id) : object_(object), id_(id) {}

  [[noreturn]] void fail(const std::string& field, const std::string& what) const {
    throw ProtocolError(code::kBadField, field + ": " + what, id_);
  }
  const json* find(const std::string& field) const {
    auto it = object_.find(field);
    return it == object_.end() || it->is_null() ? nullptr : &*it;
  }
  const json& require(const std::string& field) const {
    const json* v = find(field);
    if (!v) fail(field, "missing");
    return *v;
  }
  double number(const std::string& field, const json& v, double lo, double hi) const {
    if (!v.is_number()) fail(field, "expected a number");
    const double d = v.get<double>();
    if (!std::isfinite(d) || d < lo || d > hi) fail(field, "out of range [" + text(lo) + ", " + text(hi) + "]");
    return d;
  }
  std::optional<double> number(const std::string& field, double lo, double hi) const {
    const json* v = find(field);
    if (!v) return std::nullopt;
    return number(field, *v, lo, hi);
  }
  std::optional<uint64_t> integer(const std::string& field, uint64_t lo, uint64_t hi) const {
    const json* v = find(field);
    if (!v) return std::nullopt;
    if (!v->is_number_unsigned()) fail(field, "expected a whole number");
    const uint64_t n = v->get<uint64_t>();
    if (n < lo || n > hi) fail(field, "out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return n;
  }
  std::optional<bool> boolean(const std::string& field) const {
    const json* v = find(field);
    if (!v) return std::nullopt;
    if (!v->is_boolean()) fail(field, "expected true or false");
    return v->get<bool>();
  }
  std::optional<std::string> string(const std::string& field, size_t max_length) const {
    const json* v = find(field);
    if (!v) return std::nullopt;
    if (!v->is_string()) fail(field, "expected a string");
    std::string s = v->get<std::string>();
    if (s.size() > max_length) fail(field, "longer than " + std::to_string(max_length) + " characters");
    return s;
  }
  std::array<double, 3> vector3(const std::string& field) const {
    const json& v = require(field);
    if (!v.is_array() || v.size() != 3) fail(field, "expected [x, y, z]");
    std::array<double, 3> out{};
    for (size_t i = 0; i < 3; ++i) out[i] = number(field, v[i], -1e30, 1e30);
    return out;
  }
  const json& object() const { return object_; }
  std::optional<uint32_t> id() const { return id_; }

 protected:
  static std::string text(double v) {
    char buffer[32];
    std::snprintf(buffer, sizeof buffer, "%g", v);
    return buffer;
  }
  const json& object_;
  std::optional<uint32_t> id_;
};

}  // namespace tetrascope::protocol::detail
