// libFuzzer target for the OpenFOAM reader. The input holds a case's files, each after a
// line "#NAME": points, faces, owner and neighbour go to constant/polyMesh, any other name
// into the time folder 1. They are written into a folder of this process and the case is
// read; any outcome but success or MeshError is a bug (ASan/UBSan report the rest).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>

#include "tetrascope/storage/mesh_stream.h"

namespace fs = std::filesystem;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const fs::path dir = fs::temp_directory_path() / ("tetrascope_fuzz_openfoam_" + std::to_string(::getpid()));
  std::error_code ec;
  fs::remove_all(dir, ec);
  fs::create_directories(dir / "constant" / "polyMesh", ec);
  fs::create_directories(dir / "1", ec);
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  for (size_t at = bytes.find('#'); at != std::string_view::npos && (at == 0 || bytes[at - 1] == '\n');) {
    const size_t name_end = bytes.find('\n', at);
    if (name_end == std::string_view::npos) break;
    const std::string name(bytes.substr(at + 1, name_end - at - 1));
    size_t next = bytes.find("\n#", name_end);
    const std::string_view content = bytes.substr(name_end + 1, next == std::string_view::npos ? std::string_view::npos : next + 1 - name_end - 1);
    if (!name.empty() && name.find_first_of("/.\\") == std::string::npos && name.size() < 64) {
      const bool mesh = name == "points" || name == "faces" || name == "owner" || name == "neighbour";
      std::ofstream(mesh ? dir / "constant" / "polyMesh" / name : dir / "1" / name, std::ios::binary).write(content.data(), static_cast<std::streamsize>(content.size()));
    }
    at = next == std::string_view::npos ? next : next + 1;
  }
  try {
    auto stream = tetrascope::storage::MeshStream::open(dir);
    tetrascope::storage::VertexChunk vertices;
    while (stream->next_vertices(vertices, 4096)) {
    }
    tetrascope::storage::TetChunk tets;
    while (stream->next_tets(tets, 4096)) {
    }
  } catch (const tetrascope::storage::MeshError&) {
  }
  return 0;
}
