// The datasets a server offers: the multiresolution stores under --data, named by their
// folder. Names and paths clients send are untrusted and resolved here.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/dag.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::server {

// A file or dataset name: 1-128 characters of [A-Za-z0-9._-], not starting with a dot.
bool valid_name(const std::string& name);

// `relative` resolved inside `root`: refused (nullopt) when absolute, when it holds "..",
// or when the existing part of the path leads outside `root` through a symlink.
std::optional<std::filesystem::path> resolve_inside(const std::filesystem::path& root, const std::string& relative);

class NotFound : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Dataset {
  std::string name;
  std::unique_ptr<storage::Store> store;
  std::unique_ptr<lod::Dag> dag;
  std::unique_ptr<storage::SegmentCache> cache;
  nlohmann::json info;  // name, counts, levels, bounds, attributes (range, 64-bin histogram of the coarsest level)
};

class DatasetRegistry {
 public:
  DatasetRegistry(std::filesystem::path data_dir, uint64_t cache_bytes) : data_dir_(std::move(data_dir)), cache_bytes_(cache_bytes) {}
  // Every store folder: name, state ("ready", or why it cannot be viewed) and, when ready,
  // counts, attributes with ranges and bounds.
  nlohmann::json list() const;
  // Opens (once) and returns a dataset. Throws NotFound, or std::runtime_error saying why the
  // store cannot be viewed.
  std::shared_ptr<Dataset> open(const std::string& name);
  void cache_stats(uint64_t& hits, uint64_t& misses, uint64_t& resident_bytes) const;

 private:
  std::filesystem::path data_dir_;
  uint64_t cache_bytes_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Dataset>> open_;
};

}  // namespace tetrascope::server
