// `tetrascope error`: how far a simplified mesh is from the original (dissertation §4.2.5).
#pragma once

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::lod {

struct FieldError {
  std::string name;
  uint32_t components = 1;
  double mean = 0;  // Ẽ_M^f: RMS over the original vertices of the normalised attribute difference
  double max = 0;   // largest normalised difference at an original vertex
};

struct MeshErrorReport {
  std::vector<FieldError> fields;   // per attribute present in both meshes; values normalised to [0, 1]
  double mean_all = 0;              // Ẽ_M^f over all those attributes together
  uint64_t vertices = 0, outside = 0;  // original vertices, and those outside the simplified mesh (projected)
  double hausdorff = 0, mean_distance = 0;  // domain error: between the two boundary surfaces
  double diagonal = 0;              // bounding-box diagonal of the original, for relative figures
  uint64_t samples = 0;
  nlohmann::json to_json() const;
};

// Attributes are normalised as in the simplifier: scalars by the original's range to [0, 1],
// vectors by the longest original vector, 0.5 v + 0.5. Original vertices outside the
// simplified mesh are projected to its nearest boundary point. The boundary surfaces are
// compared at `samples_per_surface` area-weighted points plus their vertices.
MeshErrorReport measure_error(const storage::TetMesh& original, const storage::TetMesh& simplified, uint32_t samples_per_surface = 20000);

}  // namespace tetrascope::lod
