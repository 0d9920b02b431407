#include "tetrascope/storage/parse_number.h"

#include <charconv>
#include <cstdlib>
#include <string>

namespace tetrascope {

bool parse_number(std::string_view t, double& out) {
  const char* begin = t.data();
  const char* end = begin + t.size();
  if (begin != end && *begin == '+') ++begin;
  auto [p, ec] = std::from_chars(begin, end, out);
  if (ec == std::errc::result_out_of_range && p == end) {
    // denormal or huge: accept what strtod makes of it
    out = std::strtod(std::string(t).c_str(), nullptr);
    return true;
  }
  if (ec == std::errc() && p == end) return true;
  // Fortran-style exponents ("1.0D+03") appear in some solver output.
  if (t.size() < 64 && t.find_first_of("dD") != std::string_view::npos) {
    std::string copy(t);
    for (char& c : copy) if (c == 'd' || c == 'D') c = 'e';
    return parse_number(copy, out);
  }
  return false;
}

bool parse_number(std::string_view t, int64_t& out) {
  const char* begin = t.data();
  const char* end = begin + t.size();
  if (begin != end && *begin == '+') ++begin;
  auto [p, ec] = std::from_chars(begin, end, out);
  return ec == std::errc() && p == end;
}

bool parse_number(std::string_view t, uint64_t& out) {
  const char* begin = t.data();
  const char* end = begin + t.size();
  if (begin != end && *begin == '+') ++begin;
  auto [p, ec] = std::from_chars(begin, end, out);
  return ec == std::errc() && p == end;
}

}  // namespace tetrascope
