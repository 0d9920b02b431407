// A fuzz input as a store folder: manifest.json, then segments.bin, dag.bin and variants.bin
// after lines "#segments.bin", "#dag.bin" and "#variants.bin" (fuzz_seeds writes real stores
// so). The store fuzzers write it to a scratch folder of the process and open it from there.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

namespace tetrascope::fuzz {

inline void write_file(const std::filesystem::path& path, std::string_view bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// A folder of this process's own (in /dev/shm where there is one): `name`-PID.
inline std::filesystem::path scratch_folder(const std::string& name) {
  const std::filesystem::path base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
  auto d = base / (name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(d);
  return d;
}

// Writes the store the input holds into `dir` (a file the input lacks is removed).
inline void write_store_input(const std::filesystem::path& dir, const uint8_t* data, size_t size) {
  std::string_view manifest(reinterpret_cast<const char*>(data), size), segments, dag, variants;
  if (size_t at = manifest.find("\n#segments.bin\n"); at != std::string_view::npos) {
    segments = manifest.substr(at + 15);
    manifest = manifest.substr(0, at + 1);
  }
  if (size_t at = segments.find("\n#dag.bin\n"); at != std::string_view::npos) {
    dag = segments.substr(at + 10);
    segments = segments.substr(0, at);
  }
  if (size_t at = dag.find("\n#variants.bin\n"); at != std::string_view::npos) {
    variants = dag.substr(at + 15);
    dag = dag.substr(0, at);
  }
  write_file(dir / "manifest.json", manifest);
  write_file(dir / "segments.bin", segments);
  std::filesystem::remove(dir / "dag.bin");
  if (!dag.empty()) write_file(dir / "dag.bin", dag);
  std::filesystem::remove(dir / "variants.bin");
  if (!variants.empty()) write_file(dir / "variants.bin", variants);
}

}  // namespace tetrascope::fuzz
