// PROTOTYPE: variants.bin (see variants.h). Little-endian: "TSVARNT1", u32 floats, u32 nodes;
// per node u32 count; per variant u64 vertices, u64 tets, then global ids, xyz, values, tets.
#include "tetrascope/lod/variants.h"

#include <cstring>
#include <fstream>
#include <stdexcept>

namespace tetrascope::lod {

namespace {
template <class T>
void put(std::ofstream& out, const T& v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof v);
}
template <class T>
void put_all(std::ofstream& out, const std::vector<T>& v) {
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
}
template <class T>
T get(std::ifstream& in) {
  T v{};
  if (!in.read(reinterpret_cast<char*>(&v), sizeof v)) throw std::runtime_error("variants.bin: truncated");
  return v;
}
template <class T>
void get_all(std::ifstream& in, std::vector<T>& v, uint64_t count) {
  if (count > (uint64_t{1} << 34)) throw std::runtime_error("variants.bin: implausible size");
  v.resize(count);
  if (!in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(count * sizeof(T)))) throw std::runtime_error("variants.bin: truncated");
}
}  // namespace

void write_variants(const std::filesystem::path& file, const Variants& variants) {
  std::ofstream out(file, std::ios::binary);
  out.write("TSVARNT1", 8);
  put(out, variants.floats);
  put(out, static_cast<uint32_t>(variants.of_node.size()));
  for (const auto& list : variants.of_node) {
    put(out, static_cast<uint32_t>(list.size()));
    for (const VariantMesh& v : list) {
      put(out, v.vertex_count());
      put(out, v.tet_count());
      put_all(out, v.global);
      put_all(out, v.xyz);
      put_all(out, v.values);
      put_all(out, v.tets);
    }
  }
  if (!out) throw std::runtime_error("cannot write " + file.string());
}

Variants read_variants(const std::filesystem::path& file) {
  Variants out;
  std::ifstream in(file, std::ios::binary);
  if (!in) return out;
  char magic[8];
  if (!in.read(magic, 8) || std::memcmp(magic, "TSVARNT1", 8) != 0) throw std::runtime_error("variants.bin: not a variants file");
  out.floats = get<uint32_t>(in);
  out.of_node.resize(get<uint32_t>(in));
  for (auto& list : out.of_node) {
    list.resize(get<uint32_t>(in));
    for (VariantMesh& v : list) {
      const uint64_t nv = get<uint64_t>(in), nt = get<uint64_t>(in);
      get_all(in, v.global, nv);
      get_all(in, v.xyz, 3 * nv);
      get_all(in, v.values, nv * out.floats);
      get_all(in, v.tets, 4 * nt);
      for (uint32_t l : v.tets)
        if (l >= nv) throw std::runtime_error("variants.bin: a tet names a vertex it does not have");
    }
  }
  return out;
}

}  // namespace tetrascope::lod
