// boundary_tags.bin: the input's tagged boundary faces kept in a store (Gmsh physical
// surfaces, OpenFOAM patches), so that the boundary regions a viewer shows and hides are the
// input's, named as the input names them. Layout and checks: docs/store-format.md.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "tetrascope/storage/mesh.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::storage {

inline constexpr const char* kBoundaryTagsFile = "boundary_tags.bin";

// boundary_tags.bin fails its checks (damage: the dataset cannot be trusted as it is).
class BoundaryTagsError : public StoreError {
 public:
  using StoreError::StoreError;
};

// Writes `tags` (triangles over the store's global vertex ids) to `path`; returns the bytes
// written. Each triangle's ids are written ascending.
uint64_t write_boundary_tags(const std::filesystem::path& path, const FaceTags& tags);

// Reads `path` and checks it whole: magic, version, both checksums, its exact size, every
// name, every id below `vertex_count` and every tag named. Throws BoundaryTagsError.
FaceTags read_boundary_tags(const std::filesystem::path& path, uint64_t vertex_count);

// The store's tags when its manifest lists boundary_tags.bin (counts checked against the
// manifest's); nullopt when it lists none. Throws BoundaryTagsError.
std::optional<FaceTags> open_boundary_tags(const Store& store);

// The manifest's entry for a file of `tags` written in `bytes`.
nlohmann::json boundary_tags_manifest(const FaceTags& tags, uint64_t bytes);

}  // namespace tetrascope::storage
