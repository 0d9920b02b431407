// The datasets a server offers: the multiresolution stores under --data, named by their
// folder. Names and paths clients send are untrusted and resolved here.
#pragma once

#include <filesystem>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/cut/dag.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/storage/store.h"
#include "tetrascope/storage/time_steps.h"

namespace tetrascope::server {

// A file or dataset name: 1-128 characters of [A-Za-z0-9._-], not starting with a dot or a
// dash (a name is passed to `tetrascope` as an argument, where "-x" would read as an option).
bool valid_name(const std::string& name);

// True for the errors that say a store's bytes are damaged or do not fit together (a checksum,
// a count, a format version): the dataset is closed for every session, not only the one whose
// frame met it.
bool is_store_damage(const std::exception& e);

// `relative` resolved inside `root`: refused (nullopt) when absolute, when it holds "..",
// or when the existing part of the path leads outside `root` through a symlink.
std::optional<std::filesystem::path> resolve_inside(const std::filesystem::path& root, const std::string& relative);

// `message` with every mention of the data folder's absolute path made relative to it: no
// reply a client sees names a path on the server.
std::string without_server_paths(std::string message, const std::filesystem::path& data_dir);

// What a killed server, a killed CLI writing into --data or an interrupted delete left, swept
// at start: DATA/.trash-* (a deleted dataset not yet removed) and DATA/*.tmp (a store being
// written, StoreWriter's NAME.tmp). Returns how many entries were removed.
size_t sweep_data_leftovers(const std::filesystem::path& data_dir);

// Boundary regions (renderer/boundary_regions.h) are found when a dataset opens, on its full
// resolution, for stores of at most kMaxRegionTets tets whose finding fits the segment cache's
// budget at kRegionBytesPerTet (the finest cut, its face pairing and the map: about 130 bytes a
// tet measured on ONERA M6), so a server fitted to a memory limit is not pushed past it; a
// larger store lists none (its boundary is shown whole). The finest cut is read through a
// segment cache of its own, of kRegionCacheBytes, so the shared cache keeps what the views use.
constexpr uint64_t kMaxRegionTets = 20'000'000;
constexpr uint64_t kRegionBytesPerTet = 160;
constexpr uint64_t kRegionCacheBytes = uint64_t{256} << 20;

class NotFound : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct Dataset {
  std::string name;
  std::unique_ptr<storage::Store> store;
  std::unique_ptr<lod::Dag> dag;
  std::unique_ptr<storage::SegmentCache> cache;
  std::shared_ptr<const lod::VertexHierarchy> vertices;  // vertices.bin, null when the store has none
  nlohmann::json info;  // name, counts, levels, bounds, attributes (range, 64-bin histogram of the coarsest level), regions
  std::shared_ptr<const renderer::RegionMap> regions;  // null: none found (a store above kMaxRegionTets)
  std::shared_ptr<const storage::TimeSteps> steps;     // a time series' steps.bin, null for one step

  // The segments of time step `step` (0: `cache`), sharing the server's cache budget; made on
  // first use. Thread-safe.
  storage::SegmentCache& step_cache(uint32_t step);
  // Step `step`'s values inflated in the background (the step the viewer plays next), unless a
  // prefetch is still running. Thread-safe.
  void prefetch(uint32_t step);
  ~Dataset();

  // Sessions viewing the dataset register here; closing it (deleted, or found damaged) calls
  // each callback once with an error code and message (from the closing thread: a callback
  // posts to its session's executor). `owner` expires with its session, and its callback is
  // dropped then. A watcher that registers after the close is called at once.
  using OnClosed = std::function<void(const std::string& code, const std::string& message)>;
  void watch(std::weak_ptr<void> owner, OnClosed on_closed);
  size_t notify_closed(const std::string& code, const std::string& message);  // how many live watchers were told

 private:
  std::mutex watch_mutex_;
  bool closed_ = false;
  std::string closed_code_, closed_message_;
  std::vector<std::pair<std::weak_ptr<void>, OnClosed>> watchers_;
  std::mutex steps_mutex_;
  std::map<uint32_t, std::unique_ptr<storage::SegmentCache>> step_caches_;
  std::future<void> prefetching_;
  friend class DatasetRegistry;
  std::shared_ptr<storage::SegmentPool> pool_;  // the registry's, for the steps' caches
};

// Thrown by DatasetRegistry::open for a store that fails its checks (what is wrong, paths
// relative to the data folder).
class DatasetDamaged : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class DatasetRegistry {
 public:
  // Every dataset's segments share one cache budget of `cache_bytes` (serve --cache-mb).
  DatasetRegistry(std::filesystem::path data_dir, uint64_t cache_bytes)
      : data_dir_(std::move(data_dir)), pool_(std::make_shared<storage::SegmentPool>(cache_bytes)) {}
  // Every store folder: name, state ("ready", or why it cannot be viewed) and, when ready,
  // counts, attributes with ranges and bounds.
  nlohmann::json list() const;
  // Opens (once) and returns a dataset: its manifest, segment directory, DAG and variants index
  // checked (segments are checked as they are mapped). Throws NotFound (no such store, or a
  // symlink: only folders inside the data folder are served), DatasetDamaged, or
  // std::runtime_error saying why the store cannot be viewed.
  std::shared_ptr<Dataset> open(const std::string& name);
  // `dataset` failed a check while it was viewed: it is closed for all its sessions (each is told
  // `dataset_damaged` and why), and refused by open() and marked in list() until its store
  // changes on disk. Returns how many sessions were viewing it.
  size_t close_damaged(const std::shared_ptr<Dataset>& dataset, const std::string& why);
  storage::SegmentPool::Stats cache_totals() const { return pool_->stats(); }
  uint64_t cache_budget() const { return pool_->budget(); }
  std::map<std::string, storage::SegmentCache::Stats> cache_by_dataset() const;  // the open datasets
  // Deletes dataset `name`: its folder is renamed to DATA/.trash-NAME-XXXXXX (one atomic
  // step: it is never half deleted), sessions viewing it are told, then the trash is removed.
  // Returns how many sessions were viewing it. Throws NotFound.
  size_t remove(const std::string& name);

 private:
  std::filesystem::path data_dir_;
  std::shared_ptr<storage::SegmentPool> pool_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Dataset>> open_;
  // Stores found damaged: why, and the latest status change of their files then (a store
  // written, copied or restored since is tried again).
  struct Damage {
    std::string why;
    int64_t changed = -1;
  };
  std::map<std::string, Damage> damaged_;
  std::optional<std::string> damage_of(const std::string& name) const;  // under mutex_
};

}  // namespace tetrascope::server
