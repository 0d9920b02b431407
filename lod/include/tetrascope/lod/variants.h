// PROTOTYPE (branch `variants`, issue 14): finer versions of a segment with its border.
// A segment of level k+1 is its region of level k simplified with the region's border
// locked; the same run stopped earlier gives versions in between that share that border, so
// a cut can show one in place of the segment without any new border (no border tax) and
// without refining. variants.bin holds them; a store without the file has none.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

namespace tetrascope::lod {

struct VariantMesh {
  std::vector<uint32_t> global;  // per vertex: the store's global id, or 0xFFFFFFFF (a moved vertex)
  std::vector<float> xyz;        // per vertex
  std::vector<float> values;     // per vertex: every attribute's components in manifest order
  std::vector<uint32_t> tets;    // 4 local vertex ids a tet
  uint64_t tet_count() const { return tets.size() / 4; }
  uint64_t vertex_count() const { return global.size(); }
};

struct Variants {
  uint32_t floats = 0;                             // values per vertex
  std::vector<std::vector<VariantMesh>> of_node;   // per DAG node, coarsest first (fewest tets first)
  bool empty() const {
    for (const auto& v : of_node)
      if (!v.empty()) return false;
    return true;
  }
};

void write_variants(const std::filesystem::path& file, const Variants& variants);
// The store's variants.bin, or none when it has no such file.
Variants read_variants(const std::filesystem::path& file);

}  // namespace tetrascope::lod
