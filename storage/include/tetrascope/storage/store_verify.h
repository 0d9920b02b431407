// `tetrascope verify`: checksums of every block plus the structure of the whole store.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/storage/progress.h"

namespace tetrascope::storage {

struct VerifyReport {
  bool ok = false;
  std::vector<std::string> problems;  // the first problems found, each naming segment and field
  uint64_t segments = 0, vertices = 0, tets = 0, shared_vertex_copies = 0, border_faces = 0, boundary_faces = 0;
  nlohmann::json to_json() const;
};

// Never throws for a damaged store: every problem becomes a line in `problems`.
VerifyReport verify_store(const std::filesystem::path& directory, Progress* progress = nullptr);

}  // namespace tetrascope::storage
