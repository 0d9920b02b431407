// The binary vertex hierarchy of dissertation §5.2.1: the edge collapses a quadric
// simplification of the whole mesh made, each one a node whose children are the two vertices it
// merged, and the order between them the tets they share imply.
//
// Vertex ids: the input's vertices are the leaves 0 .. V-1; collapse i makes vertex V + i.
// Collapse i consumes the tets around its two vertices at its time and makes them again around
// the new vertex (less the fan tets, which had both). A state of the hierarchy is the set of
// collapses applied; it is a conforming mesh whenever it is closed under `before` (a collapse
// applied has every collapse that made a tet it consumes applied too): the multi-triangulation
// of §6.3 at the granularity of single vertex splits. Its mesh is then the input's tets with
// every vertex replaced by its highest ancestor whose collapse is applied, less the tets whose
// `killer` is applied (those degenerate).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::lod {

constexpr uint32_t kNoCollapse = 0xFFFFFFFFu;

struct VertexNode {
  std::array<uint32_t, 2> child{};  // the vertices merged
  float error = 0;   // the collapse's quadric error, at least its children's (monotone upwards)
  float radius = 0;  // the sphere around the new vertex that holds every tet the collapse changed
  uint32_t fan = 0;  // tets the collapse removes (its split adds them back)
};

// The value a vertex's attribute ranges and the occlusion grid use: a scalar itself, a vector
// (components > 1) its length.
inline float attribute_scalar(const float* values, uint32_t components) {
  if (components == 1) return values[0];
  double sum = 0;
  for (uint32_t k = 0; k < components; ++k) sum += double(values[k]) * values[k];
  return static_cast<float>(std::sqrt(sum));
}

struct VertexHierarchy {
  uint32_t input_vertices = 0;                  // V, the leaves
  std::vector<storage::AttributeInfo> attributes;
  uint32_t value_floats = 0;                    // Σ components
  std::vector<float> positions;                 // 3 per vertex (V + C)
  std::vector<float> values;                    // value_floats per vertex
  std::vector<uint32_t> tets;                   // 4 per input tet, over the leaves
  std::vector<uint32_t> killer;                 // per input tet: the collapse that removes it, or kNoCollapse
  std::vector<VertexNode> nodes;                // per collapse
  // per collapse and attribute: the least and greatest value (a vector's length) at the leaves
  // below the vertices of every tet the collapse changed, and at those vertices
  std::vector<float> ranges;
  // per collapse: the later collapses that consume a tet it makes (they are split before it),
  // and the earlier collapses that made a tet it consumes (collapsed before it); CSR
  std::vector<uint32_t> after_offsets, after, before_offsets, before;

  uint32_t collapse_count() const { return static_cast<uint32_t>(nodes.size()); }
  uint32_t vertex_count() const { return input_vertices + collapse_count(); }
  uint64_t input_tets() const { return killer.size(); }
  uint64_t base_tets() const;  // tets with every collapse applied
  uint32_t depth() const;      // the longest chain of `after` links
  float range_lo(uint32_t collapse, uint32_t attribute) const { return ranges[2 * (size_t{collapse} * attributes.size() + attribute)]; }
  float range_hi(uint32_t collapse, uint32_t attribute) const { return ranges[2 * (size_t{collapse} * attributes.size() + attribute) + 1]; }
};

struct VertexHierarchyOptions {
  uint64_t base_tets = 0;      // simplify down to this many tets (0: 0.5% of the input, at least 500)
  bool independent = false;    // independent edge collapses in runs (§4.1.1, §5.2.1): a shallower hierarchy
  uint32_t threads = 1;        // the simplifier's regions (their collapses touch disjoint tets)
};

struct VertexHierarchyReport {
  uint64_t input_tets = 0, base_tets = 0, collapses = 0;
  uint32_t depth = 0;
  double simplify_seconds = 0, build_seconds = 0;
};

// Simplifies a copy of `mesh` by quadric edge collapses (the simplifier of `tetrascope
// simplify`, its defaults) and records them as the hierarchy.
VertexHierarchy build_vertex_hierarchy(const storage::TetMesh& mesh, const VertexHierarchyOptions& options = {}, VertexHierarchyReport* report = nullptr);

// vertices.bin: the hierarchy in a store (format in hierarchy_file.cpp), each section
// checksummed. write_ writes beside and renames, so a reader never sees half a file.
// read_ throws VertexHierarchyError for a file that is truncated, fails a checksum or whose
// links are out of range; std::runtime_error when it cannot be read at all.
struct VertexHierarchyError : std::runtime_error {
  using std::runtime_error::runtime_error;
};
constexpr const char* kVertexHierarchyFile = "vertices.bin";
// The version written: 2, its sections deflated and the links a reader can derive left out;
// version 1 (every array as it is in memory) is still read, and written when asked.
constexpr uint32_t kVertexHierarchyVersion = 2;
struct VertexHierarchyWriteOptions {
  uint32_t version = kVertexHierarchyVersion;
  // The input's vertices (positions and values) left out, to be read from the segments.bin
  // beside the file: for a store whose input vertices are exactly the hierarchy's leaves
  // (preprocess checks that, bit for bit, before it asks for this).
  bool leaves_in_store = false;
  // The input's tets left out, to be read from the finest level's segments (in their order and
  // orientation): for a store whose input tets are the hierarchy's (the same vertices each).
  bool tets_in_store = false;
  // The value ranges and the `after` links left out, for a reader to find again by replaying
  // the collapses over the input's tets (where that gives them back exactly; version 2).
  bool derive_star_links = true;
};
void write_vertex_hierarchy(const std::filesystem::path& path, const VertexHierarchy& hierarchy, const VertexHierarchyWriteOptions& options = {});
VertexHierarchy read_vertex_hierarchy(const std::filesystem::path& path);
// The hierarchy of the store in `store_directory`, read once and shared while anyone holds
// it (read again when the file changed); null when the store has none. Throws as read_.
std::shared_ptr<const VertexHierarchy> open_vertex_hierarchy(const std::filesystem::path& store_directory);
// What `tetrascope verify` reports for a store's vertices.bin (empty: sound or absent).
std::vector<std::string> verify_vertex_hierarchy(const std::filesystem::path& store);

}  // namespace tetrascope::lod
