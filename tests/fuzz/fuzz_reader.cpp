// libFuzzer target: one per reader, chosen by TETRA_FUZZ_FORMAT (a storage::MeshFormat).
// Any outcome but success or MeshError is a bug (ASan/UBSan report the rest).
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "tetrascope/storage/mesh_stream.h"

using tetrascope::storage::MeshFormat;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  constexpr auto kFormat = static_cast<MeshFormat>(TETRA_FUZZ_FORMAT);
  std::string_view bytes(reinterpret_cast<const char*>(data), size);
  std::string_view second;
  if constexpr (kFormat == MeshFormat::kTetgen) {
    // .node and .ele separated by a line "#ele"
    size_t split = bytes.find("\n#ele\n");
    if (split != std::string_view::npos) {
      second = bytes.substr(split + 6);
      bytes = bytes.substr(0, split + 1);
    }
  }
  try {
    auto stream = tetrascope::storage::MeshStream::open_memory(kFormat, "fuzz", bytes, second);
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
