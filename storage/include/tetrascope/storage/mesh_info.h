// The summary `tetrascope info` prints: counts, attribute ranges, bounds, quality counters.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/mesh_stream.h"

namespace tetrascope::storage {

struct AttributeSummary {
  AttributeInfo info;
  double min = 0, max = 0;  // of the value (scalars) or of the magnitude (vectors)
  std::vector<std::array<double, 2>> component_ranges;
  uint64_t nonfinite = 0;
};

struct MeshSummary {
  std::string file;
  MeshHeader header;
  uint64_t file_bytes = 0;
  ReadStats stats;
  std::vector<AttributeSummary> attributes;
  Bounds bounds;
  double read_seconds = 0;
  // The input's boundary face tags (Gmsh physical surfaces, OpenFOAM patches): per tag its
  // name and tagged triangles (quads count as two). Empty: the input tags no face.
  std::vector<std::pair<std::string, uint64_t>> face_tags;
};

// Streams the whole mesh once (memory in proportion to the vertices). Throws MeshError.
MeshSummary summarize_mesh(const std::filesystem::path& path);
MeshSummary summarize_stream(MeshStream& stream);

// Stable JSON: top-level keys vertices, tetrahedra, attributes, bounds (see docs/commands/info.md).
nlohmann::json summary_json(const MeshSummary& summary);
std::string summary_text(const MeshSummary& summary);

}  // namespace tetrascope::storage
