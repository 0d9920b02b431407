// The checks `tetrascope verify` runs, for use right after a store is written: a store that
// fails them is never reported as written.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace tetrascope::lod {

// Every problem `tetrascope verify` reports for the store at `directory`: block checksums and
// structure (storage::verify_store) and, for a multiresolution store, the DAG (verify_dag).
// Empty when the store is sound. Never throws for a damaged store.
std::vector<std::string> check_store(const std::filesystem::path& directory);

// Runs check_store on a store that was just written. When it finds problems the store is
// removed and std::runtime_error names the first of them, so nothing damaged is left to serve.
void require_sound_store(const std::filesystem::path& directory);

}  // namespace tetrascope::lod
