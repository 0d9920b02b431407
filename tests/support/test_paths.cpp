#include "test_paths.h"

#include <gtest/gtest.h>
#include <unistd.h>

namespace tetrascope::testing {

std::filesystem::path source_dir() { return TETRA_SOURCE_DIR; }
std::filesystem::path sample_mesh() { return source_dir() / "data/samples/disk_out_ref.vtk"; }
std::filesystem::path shared_data() {
  std::filesystem::path p = TETRA_SHARED_DATA;
  return std::filesystem::exists(p / "README.md") ? p : std::filesystem::path();
}
std::filesystem::path tetrascope_binary() { return TETRA_BINARY; }
std::filesystem::path scratch_dir(const std::string& name) {
  std::filesystem::path p = std::filesystem::path(::testing::TempDir()) / ("tetrascope-" + std::to_string(::getpid())) / name;
  std::filesystem::remove_all(p);
  std::filesystem::create_directories(p);
  return p;
}

}  // namespace tetrascope::testing
