// libFuzzer target for the readers that go through a library and read a file by its name
// (Exodus II, CGNS): the input is written to a file of this process with the format's
// extension (TETRA_FUZZ_EXTENSION) and read whole through MeshStream, which loads the reader's
// module. Any outcome but success or MeshError is a bug. The libraries under the modules
// (NetCDF, CGNS, HDF5) are not instrumented: ASan sees their crashes, not their silent
// overreads.
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "tetrascope/storage/mesh_stream.h"

namespace fs = std::filesystem;

// The CGNS library's ADF layer leaks a buffer on some of its error paths (ADF_Read_All_Data):
// a leak inside the library, not tetrascope's, would otherwise end every run.
extern "C" const char* __asan_default_options() { return "detect_leaks=0"; }

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const fs::path path = fs::temp_directory_path() / ("tetrascope_fuzz_" + std::to_string(::getpid()) + TETRA_FUZZ_EXTENSION);
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  try {
    auto stream = tetrascope::storage::MeshStream::open(path);
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
