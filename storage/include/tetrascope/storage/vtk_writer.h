// Writes tet meshes as VTK legacy BINARY unstructured grids (big-endian, as the spec says).
#pragma once

#include <filesystem>

#include "tetrascope/storage/mesh.h"

namespace tetrascope::storage {

// Writes to `path` through a temporary name and renames when complete, so a crash never
// leaves a half-written file. Scalars as SCALARS, 3-component attributes as VECTORS,
// symmetric tensors as TENSORS6 (read back as tensors, with their derived scalars), others in
// a FIELD. Throws std::runtime_error on I/O failure.
void write_vtk(const std::filesystem::path& path, const TetMesh& mesh,
               const std::string& title = "tetrascope mesh");

}  // namespace tetrascope::storage
