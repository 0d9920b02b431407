// Whole-process read benchmark: reads MESH once the way later stages do and prints one
// JSON line. Peak RSS is measured from outside (bench/read_throughput.sh, /usr/bin/time).
//   read_bench MESH stream   vertices then tets in chunks, nothing kept but coordinates
//   read_bench MESH load     the whole mesh in memory (load_mesh)
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "tetrascope/storage/mesh_stream.h"

int main(int argc, char** argv) {
  if (argc != 3 || (std::strcmp(argv[2], "stream") && std::strcmp(argv[2], "load"))) {
    std::fprintf(stderr, "usage: read_bench MESH stream|load\n");
    return 2;
  }
  namespace ts = tetrascope::storage;
  auto start = std::chrono::steady_clock::now();
  uint64_t vertices = 0, tets = 0, checksum = 0, mesh_bytes = 0;
  try {
    if (!std::strcmp(argv[2], "stream")) {
      auto stream = ts::MeshStream::open(argv[1]);
      ts::VertexChunk v;
      while (stream->next_vertices(v)) vertices += v.count;
      ts::TetChunk t;
      while (stream->next_tets(t)) {
        tets += t.count;
        checksum += t.tets[0];
      }
    } else {
      ts::TetMesh mesh = ts::load_mesh(argv[1]);
      vertices = mesh.vertex_count();
      tets = mesh.tet_count();
      checksum = mesh.tets.empty() ? 0 : mesh.tets[0];
      mesh_bytes = mesh.tets.size() * 4 + mesh.x.size() * 12;
      for (const auto& a : mesh.attributes) mesh_bytes += a.values.size() * 4;
    }
  } catch (const ts::MeshError& e) {
    std::fprintf(stderr, "%s\n", e.what());
    return 1;
  }
  double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  uint64_t bytes = std::filesystem::file_size(argv[1]);
  std::printf("{\"seconds\": %.4f, \"vertices\": %llu, \"tetrahedra\": %llu, \"file_bytes\": %llu, \"mesh_bytes\": %llu, \"checksum\": %llu}\n",
              seconds, static_cast<unsigned long long>(vertices), static_cast<unsigned long long>(tets),
              static_cast<unsigned long long>(bytes), static_cast<unsigned long long>(mesh_bytes), static_cast<unsigned long long>(checksum));
  return 0;
}
