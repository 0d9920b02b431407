#include "datasets.h"

#include <stdlib.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstdio>
#include <cmath>
#include <cstring>

#include "tetrascope/lod/cut/cut.h"
#include "tetrascope/lod/cut/variants.h"
#include "tetrascope/lod/vertex/vertex_hierarchy.h"
#include "tetrascope/protocol/protocol.h"
#include "tetrascope/renderer/boundary_regions.h"
#include "tetrascope/storage/boundary_tags.h"
#include "tetrascope/storage/tensor.h"

namespace tetrascope::server {
namespace fs = std::filesystem;

bool valid_name(const std::string& name) {
  if (name.empty() || name.size() > 128 || name[0] == '.' || name[0] == '-') return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) return false;
  return true;
}

std::optional<fs::path> resolve_inside(const fs::path& root, const std::string& relative) {
  if (relative.empty() || relative.find('\0') != std::string::npos) return std::nullopt;
  const fs::path rel(relative);
  if (rel.is_absolute() || rel.has_root_name() || rel.has_root_directory()) return std::nullopt;
  for (const auto& part : rel)
    if (part == "..") return std::nullopt;
  std::error_code ec;
  const fs::path base = fs::weakly_canonical(root, ec);
  if (ec) return std::nullopt;
  const fs::path full = fs::weakly_canonical(base / rel, ec);  // resolves symlinks of the existing part
  if (ec) return std::nullopt;
  auto b = base.begin();
  auto f = full.begin();
  for (; b != base.end(); ++b, ++f)
    if (f == full.end() || *f != *b) return std::nullopt;
  return full;
}

std::string without_server_paths(std::string message, const fs::path& data_dir) {
  const std::string folder = data_dir.string();
  if (folder.empty() || folder == "/") return message;
  for (const std::string& from : {folder + "/", folder}) {
    const std::string to = from.back() == '/' ? "" : ".";
    for (size_t at = message.find(from); at != std::string::npos; at = message.find(from, at + to.size())) message.replace(at, from.size(), to);
  }
  return message;
}

size_t sweep_data_leftovers(const fs::path& data_dir) {
  std::error_code ec;
  std::vector<fs::path> leftovers;
  for (const auto& entry : fs::directory_iterator(data_dir, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind(".trash-", 0) == 0 || (name.size() > 4 && name.ends_with(".tmp"))) leftovers.push_back(entry.path());
  }
  for (const auto& path : leftovers) fs::remove_all(path, ec);
  return leftovers.size();
}

bool is_store_damage(const std::exception& e) {
  if (dynamic_cast<const storage::StoreIoError*>(&e) || dynamic_cast<const lod::DagIoError*>(&e)) return false;  // could not read: not damage
  return dynamic_cast<const storage::StoreError*>(&e) || dynamic_cast<const lod::DagError*>(&e) || dynamic_cast<const lod::VariantsError*>(&e) ||
         dynamic_cast<const lod::VertexHierarchyError*>(&e) || dynamic_cast<const DatasetDamaged*>(&e);
}

void Dataset::watch(std::weak_ptr<void> owner, OnClosed on_closed) {
  std::string code, message;
  {
    std::lock_guard lock(watch_mutex_);
    std::erase_if(watchers_, [](const auto& w) { return w.first.expired(); });
    if (!closed_) {
      watchers_.emplace_back(std::move(owner), std::move(on_closed));
      return;
    }
    code = closed_code_;
    message = closed_message_;
  }
  on_closed(code, message);  // closed between the session's open and this call: told at once
}

size_t Dataset::notify_closed(const std::string& code, const std::string& message) {
  decltype(watchers_) watchers;
  {
    std::lock_guard lock(watch_mutex_);
    if (closed_) return 0;  // told once, whoever closes it second
    closed_ = true;
    closed_code_ = code;
    closed_message_ = message;
    watchers.swap(watchers_);
  }
  size_t told = 0;
  for (auto& [owner, callback] : watchers)
    if (!owner.expired()) {
      callback(code, message);
      ++told;
    }
  return told;
}

namespace {

// The latest status change of a store's files (ns): any write, rename or copy into place moves
// it, a copy that keeps modification times (cp -a) included. -1 when none can be read.
int64_t store_change_time(const fs::path& folder) {
  int64_t latest = -1;
  for (const char* file : {"manifest.json", "segments.bin", "dag.bin", "variants.bin", lod::kVertexHierarchyFile, storage::kBoundaryTagsFile}) {
    struct stat st {};
    if (::stat((folder / file).c_str(), &st) == 0) latest = std::max<int64_t>(latest, int64_t{st.st_ctim.tv_sec} * 1000000000 + st.st_ctim.tv_nsec);
  }
  return latest;
}

// 64 bins over [lo, hi] of one value per vertex: value(v).
template <typename Value>
std::vector<uint64_t> histogram(size_t vertices, double lo, double hi, Value&& value) {
  std::vector<uint64_t> bins(64, 0);
  for (size_t v = 0; v < vertices; ++v) {
    const double t = hi > lo ? (value(v) - lo) / (hi - lo) : 0;
    if (std::isfinite(t)) ++bins[std::clamp<int64_t>(static_cast<int64_t>(t * 64), 0, 63)];
  }
  return bins;
}

// An attribute's histogram in dataset.info (of the value, or a vector's magnitude) and, for a
// vector, its components' ranges over the dataset and histograms (the colours of tf.set's
// "component"), from the coarsest level's vertices.
void add_histograms(const storage::Attribute& attr, const storage::StoreAttribute& stored, nlohmann::json& out) {
  const double lo = out["range"][0], hi = out["range"][1];
  const uint32_t c = attr.info.components;
  const size_t n = attr.values.size() / std::max<uint32_t>(c, 1);
  out["histogram"] = histogram(n, lo, hi, [&](size_t v) {
    if (c == 1) return double(attr.values[v]);
    double m = 0;
    for (uint32_t k = 0; k < c; ++k) m += double(attr.values[v * c + k]) * attr.values[v * c + k];
    return std::sqrt(m);
  });
  if (c < 2) return;
  nlohmann::json ranges = nlohmann::json::array(), histograms = nlohmann::json::array();
  for (uint32_t k = 0; k < std::min(c, uint32_t(view::kComponentNames.size())); ++k) {
    const std::array<double, 2> r = storage::component_range(stored, k);
    ranges.push_back({r[0], r[1]});
    histograms.push_back(histogram(n, r[0], r[1], [&](size_t v) { return double(attr.values[v * c + k]); }));
  }
  out["component_ranges"] = ranges;
  out["component_histograms"] = histograms;
}

// A time series' steps (index, time, name, each attribute's range), and each attribute's
// range over them all; an empty list for one step (a damaged list: reported when opened).
nlohmann::json time_steps_json(const storage::StoreManifest& m) {
  nlohmann::json steps = nlohmann::json::array();
  std::vector<storage::TimeStep> listed;
  try {
    listed = storage::manifest_time_steps(m);
  } catch (const storage::TimeStepsError&) {
    return steps;
  }
  for (const storage::TimeStep& s : listed) {
    nlohmann::json ranges = nlohmann::json::array();
    for (const auto& r : s.ranges) ranges.push_back({r[0], r[1]});
    steps.push_back({{"index", s.index}, {"time", s.time}, {"name", s.name}, {"ranges", ranges}});
  }
  return steps;
}

nlohmann::json store_summary(const std::string& name, const storage::Store& store) {
  const auto& m = store.manifest();
  nlohmann::json attributes = nlohmann::json::array();
  for (size_t i = 0; i < m.attributes.size(); ++i) {
    const storage::StoreAttribute& a = m.attributes[i];
    nlohmann::json entry = {{"name", a.name}, {"components", a.components}, {"range", {a.min, a.max}}};
    // tensors and their derived scalars say so (storage/tensor.h): the viewer's tensor panel
    if (a.kind != storage::AttributeKind::kValue) {
      storage::AttributeInfo info{a.name, a.components, a.kind, a.positive_semidefinite, a.derived_from};
      storage::add_attribute_kind_json(entry, info);
    }
    if (m.json.contains("time_steps")) {  // over every step: the range colours keep while the steps play
      const auto r = storage::series_range(m, i);
      entry["series_range"] = {r[0], r[1]};
    }
    attributes.push_back(std::move(entry));
  }
  // a multiresolution store holds every level: its mesh is the input's
  const nlohmann::json input = m.json.contains("multiresolution") ? m.json["multiresolution"].value("input", nlohmann::json::object()) : nlohmann::json::object();
  // the multiresolution model (preprocess --model): the segments' multi-triangulation or binary hierarchy
  const std::string model = m.json.contains("multiresolution") ? m.json["multiresolution"].value("model", std::string("mt")) : std::string("none");
  return {{"name", name},
          {"state", "ready"},
          {"model", model},
          {"tets", input.value("tetrahedra", m.tet_count)},
          {"vertices", input.value("vertices", m.vertex_count)},
          {"stored_tets", m.tet_count},
          {"source", fs::path(m.source_file).filename().string()},
          {"attributes", attributes},
          {"bounds", {{"min", m.bounds.min}, {"max", m.bounds.max}}},
          {"time_steps", time_steps_json(m)}};
}

}  // namespace

nlohmann::json DatasetRegistry::list() const {
  nlohmann::json out = nlohmann::json::array();
  std::error_code ec;
  std::vector<fs::path> folders;
  for (const auto& entry : fs::directory_iterator(data_dir_, ec))
    if (!entry.is_symlink() && entry.is_directory() && valid_name(entry.path().filename().string()) && entry.path().filename() != "uploads")
      folders.push_back(entry.path());
  std::sort(folders.begin(), folders.end());
  for (const auto& folder : folders) {
    const std::string name = folder.filename().string();
    if (!fs::exists(folder / "manifest.json")) continue;
    {
      std::lock_guard lock(mutex_);
      if (auto why = damage_of(name)) {
        out.push_back({{"name", name}, {"state", "damaged: " + *why}});
        continue;
      }
    }
    try {
      auto store = storage::Store::open(folder);
      nlohmann::json summary = store_summary(name, *store);
      if (!fs::exists(folder / "dag.bin")) summary["state"] = "single-level store: run tetrascope preprocess to view it";
      out.push_back(std::move(summary));
    } catch (const std::exception& e) {
      out.push_back({{"name", name}, {"state", "unreadable: " + without_server_paths(e.what(), data_dir_)}});
    }
  }
  return out;
}

std::optional<std::string> DatasetRegistry::damage_of(const std::string& name) const {
  auto it = damaged_.find(name);
  if (it == damaged_.end()) return std::nullopt;
  if (store_change_time(data_dir_ / name) != it->second.changed) return std::nullopt;  // written, copied or restored since
  return it->second.why;
}

namespace {

// The boundary regions of a store, on its finest cut (the input mesh); null above kMaxRegionTets
// or past `memory_bytes` at kRegionBytesPerTet. A segment that fails its checks leaves the
// dataset without regions rather than unopened: the open checks the coarsest level only, and
// the frame that maps the segment reports it.
std::shared_ptr<const renderer::RegionMap> find_regions(const storage::Store& store, const lod::Dag& dag, const std::optional<storage::FaceTags>& tags,
                                                        const fs::path& data_dir, uint64_t memory_bytes) {
  const uint64_t tets = store.manifest().tet_count;
  if (tets > kMaxRegionTets || tets > memory_bytes / kRegionBytesPerTet) return nullptr;
  try {
    return renderer::RegionMap::of_store(store, dag, kRegionCacheBytes, tags);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "tetrascope serve: no boundary regions for %s: %s\n", store.path().filename().c_str(), without_server_paths(e.what(), data_dir).c_str());
    return nullptr;
  }
}

nlohmann::json regions_json(const renderer::RegionMap* regions) {
  nlohmann::json out = nlohmann::json::array();
  if (!regions) return out;
  for (const renderer::BoundaryRegion& r : regions->regions())
    out.push_back({{"id", r.id},
                   {"name", r.name},
                   {"source", renderer::region_source_name(regions->source())},
                   {"triangles", r.triangles},
                   {"area", r.area},
                   {"bounds", {{"min", r.bounds.min}, {"max", r.bounds.max}}},
                   {"touches_domain_box", r.touches_domain_box}});
  return out;
}

}  // namespace

storage::SegmentCache& Dataset::step_cache(uint32_t step) {
  if (step == 0 || !steps) return *cache;
  if (step >= steps->count()) throw std::invalid_argument("no time step " + std::to_string(step));
  std::lock_guard lock(steps_mutex_);
  auto& slot = step_caches_[step];
  if (!slot) {
    // the values are asked for as segments are mapped (TimeSteps keeps the last few inflated):
    // a cache of a step no longer shown holds none of them
    std::shared_ptr<const storage::TimeSteps> series = steps;
    const storage::Store* s = store.get();
    slot = std::make_unique<storage::SegmentCache>(*store, pool_, [series, s, step](std::shared_ptr<const storage::MappedSegment> segment) {
      return storage::with_step_values(std::move(segment), s->manifest(), series->layout(), *series->values(step));
    });
  }
  return *slot;
}

void Dataset::prefetch(uint32_t step) {
  if (!steps || step == 0 || step >= steps->count()) return;
  std::lock_guard lock(steps_mutex_);
  if (prefetching_.valid() && prefetching_.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  std::shared_ptr<const storage::TimeSteps> series = steps;
  prefetching_ = std::async(std::launch::async, [series, step] {
    try {
      series->values(step);
    } catch (const std::exception&) {
      // damage is reported when the step is shown
    }
  });
}

Dataset::~Dataset() {
  if (prefetching_.valid()) prefetching_.wait();
  step_caches_.clear();  // before the store they read
}

std::shared_ptr<Dataset> DatasetRegistry::open(const std::string& name) {
  if (!valid_name(name)) throw NotFound("no dataset named '" + name + "'");
  std::lock_guard lock(mutex_);
  if (auto it = open_.find(name); it != open_.end()) return it->second;
  const fs::path folder = data_dir_ / name;
  std::error_code ec;
  // a symlink may lead anywhere on the server: only folders inside the data folder are served
  if (name == "uploads" || fs::is_symlink(folder, ec) || !fs::exists(folder / "manifest.json", ec)) throw NotFound("no dataset named '" + name + "'");
  if (auto why = damage_of(name)) throw DatasetDamaged("'" + name + "' is damaged: " + *why);
  damaged_.erase(name);
  auto d = std::make_shared<Dataset>();
  d->name = name;
  std::optional<storage::FaceTags> tags;
  try {
    d->store = storage::Store::open(folder);
    d->dag = lod::open_dag(*d->store);
    if (d->dag) lod::Variants::open(*d->store, *d->dag);  // its header and index checked now; a variant's block when shown
    d->vertices = lod::open_vertex_hierarchy(folder);      // every section's checksum and link checked now
    tags = storage::open_boundary_tags(*d->store);          // boundary_tags.bin: checksums, names and ids checked now
    d->steps = storage::TimeSteps::open(*d->store);         // steps.bin: header and index checked now; a step's block when shown
    if (d->steps && d->vertices && d->steps->layout().collapses != d->vertices->collapse_count())
      throw storage::TimeStepsError("steps.bin: values for " + std::to_string(d->steps->layout().collapses) + " collapsed vertices, vertices.bin has " +
                                    std::to_string(d->vertices->collapse_count()));
  } catch (const std::exception& e) {
    const std::string why = without_server_paths(e.what(), data_dir_);
    if (!is_store_damage(e)) throw std::runtime_error(why);
    damaged_[name] = {why, store_change_time(folder)};
    throw DatasetDamaged("'" + name + "' is damaged: " + why);
  }
  if (!d->dag) throw std::runtime_error(name + " is a single-level store: run tetrascope preprocess to view it");
  d->cache = std::make_unique<storage::SegmentCache>(*d->store, pool_);
  d->pool_ = pool_;
  d->info = store_summary(name, *d->store);
  d->info["levels"] = d->dag->level_count();
  // value histograms of the coarsest level, for the transfer-function editor
  lod::Cut coarse(*d->dag);
  storage::TetMesh mesh;
  try {
    mesh = lod::assemble_cut(*d->store, *d->cache, coarse, false).mesh;
  } catch (const std::exception& e) {  // a coarsest segment fails its checksum
    const std::string why = without_server_paths(e.what(), data_dir_);
    if (!is_store_damage(e)) throw std::runtime_error(why);
    damaged_[name] = {why, store_change_time(folder)};
    throw DatasetDamaged("'" + name + "' is damaged: " + why);
  }
  d->info["coarsest_tets"] = mesh.tet_count();
  d->regions = find_regions(*d->store, *d->dag, tags, data_dir_, pool_->budget());
  d->info["regions"] = regions_json(d->regions.get());
  if (d->regions) d->info["regions_source"] = renderer::region_source_name(d->regions->source());
  for (size_t a = 0; a < mesh.attributes.size() && a < d->info["attributes"].size(); ++a) add_histograms(mesh.attributes[a], d->store->manifest().attributes[a], d->info["attributes"][a]);
  open_[name] = d;
  return d;
}

size_t DatasetRegistry::close_damaged(const std::shared_ptr<Dataset>& dataset, const std::string& why) {
  if (!dataset) return 0;
  const std::string reason = without_server_paths(why, data_dir_);
  {
    std::lock_guard lock(mutex_);
    if (auto it = open_.find(dataset->name); it != open_.end() && it->second == dataset) {
      open_.erase(it);
      damaged_[dataset->name] = {reason, store_change_time(data_dir_ / dataset->name)};
    }
  }
  return dataset->notify_closed(protocol::code::kDatasetDamaged, "the dataset '" + dataset->name + "' is damaged and was closed: " + reason);
}

size_t DatasetRegistry::remove(const std::string& name) {
  if (!valid_name(name) || name == "uploads") throw NotFound("no dataset named '" + name + "'");
  std::shared_ptr<Dataset> open;
  std::string trash = (data_dir_ / (".trash-" + name + "-XXXXXX")).string();
  {
    std::lock_guard lock(mutex_);  // no open() of the name between the check and the rename
    const fs::path folder = data_dir_ / name;
    std::error_code ec;
    if (fs::is_symlink(folder, ec) || !fs::is_directory(folder, ec) || !fs::exists(folder / "manifest.json", ec)) throw NotFound("no dataset named '" + name + "'");
    if (::mkdtemp(trash.data()) == nullptr) throw std::runtime_error("cannot delete '" + name + "': " + std::strerror(errno));
    fs::rename(folder, trash, ec);  // over the empty folder mkdtemp made: one step, nothing half deleted
    if (ec) {
      fs::remove(trash, ec);
      throw std::runtime_error("cannot delete '" + name + "': " + ec.message());
    }
    if (auto it = open_.find(name); it != open_.end()) {
      open = it->second;
      open_.erase(it);
    }
    damaged_.erase(name);
  }
  const size_t sessions = open ? open->notify_closed(protocol::code::kDatasetDeleted, "the dataset '" + name + "' was deleted; open another") : 0;
  std::error_code ec;
  fs::remove_all(trash, ec);  // sessions still rendering hold mapped segments: unlinked files stay readable
  return sessions;
}

std::map<std::string, storage::SegmentCache::Stats> DatasetRegistry::cache_by_dataset() const {
  std::lock_guard lock(mutex_);
  std::map<std::string, storage::SegmentCache::Stats> stats;
  for (const auto& [name, d] : open_) stats[name] = d->cache->stats();
  return stats;
}

}  // namespace tetrascope::server
