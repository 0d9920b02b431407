// What the writers of legacy VTK POLYDATA in lod/field share: 4-byte values big-endian, and
// array names without white space.
#pragma once

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace tetrascope::lod::detail {

// `count` 4-byte values (floats or 32-bit integers) written big-endian, as legacy VTK wants.
inline void put_big_endian(std::ofstream& file, const void* data, size_t count) {
  const auto* bytes = static_cast<const uint8_t*>(data);
  std::vector<uint8_t> swapped(count * 4);
  for (size_t i = 0; i < count; ++i)
    for (int b = 0; b < 4; ++b) swapped[4 * i + b] = bytes[4 * i + 3 - b];
  file.write(reinterpret_cast<const char*>(swapped.data()), std::streamsize(swapped.size()));
}

inline std::string vtk_name(std::string name) {
  for (char& c : name)
    if (c == ' ' || c == '\t' || c == '\n') c = '_';
  return name.empty() ? "unnamed" : name;
}

}  // namespace tetrascope::lod::detail
