// What the writers of legacy VTK POLYDATA in lod/field share: the file's head and points,
// 4-byte values big-endian, and array names without white space.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <stdexcept>
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

// Three per-point arrays written as one big-endian array of triples (POINTS, VECTORS, NORMALS).
inline void put_triples(std::ofstream& file, const std::vector<float>& x, const std::vector<float>& y, const std::vector<float>& z) {
  std::vector<float> xyz(3 * x.size());
  for (size_t i = 0; i < x.size(); ++i) xyz[3 * i] = x[i], xyz[3 * i + 1] = y[i], xyz[3 * i + 2] = z[i];
  put_big_endian(file, xyz.data(), xyz.size());
}

// `path` opened and a binary POLYDATA's head written: the title (200 characters at most, on one
// line) and POINTS.
inline std::ofstream start_polydata(const std::filesystem::path& path, const std::string& title, const std::vector<float>& x, const std::vector<float>& y,
                                    const std::vector<float>& z) {
  std::ofstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error("cannot write " + path.string());
  std::string heading = title.substr(0, 200);
  std::replace(heading.begin(), heading.end(), '\n', ' ');
  file << "# vtk DataFile Version 3.0\n" << heading << "\nBINARY\nDATASET POLYDATA\nPOINTS " << x.size() << " float\n";
  put_triples(file, x, y, z);
  return file;
}

inline std::string vtk_name(std::string name) {
  for (char& c : name)
    if (c == ' ' || c == '\t' || c == '\n') c = '_';
  return name.empty() ? "unnamed" : name;
}

}  // namespace tetrascope::lod::detail
