// The one strict number parser: a whole token must be a number (an optional leading '+',
// Fortran 'D' exponents accepted), nothing before or after it. Used by the mesh readers, the
// command line and the camera/transfer-function parsers alike. Untrusted input is fine.
#pragma once

#include <cstdint>
#include <string_view>

namespace tetrascope {

// false when the token is not exactly one number of that type. A double out of range is
// returned as strtod gives it (inf or a denormal); callers that store floats check finiteness.
bool parse_number(std::string_view token, double& out);
bool parse_number(std::string_view token, int64_t& out);
bool parse_number(std::string_view token, uint64_t& out);

}  // namespace tetrascope
