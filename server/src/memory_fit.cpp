// Serving inside a memory limit: the process's cgroup limit, and the options fitted to it
// (memory_fit.h).
#include "tetrascope/server/memory_fit.h"

#include <algorithm>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "tetrascope/server/server.h"

namespace tetrascope::server {
namespace {

constexpr uint64_t kMiB = uint64_t{1} << 20;
// measured on the 20M blade at 1024x768 (bench/results/serve_memory_limit-*.json and
// bench/README.md): the process's own memory, its code's working set, and a still's bytes a tet
// (400 let the 20M blade's server be killed under 300 MB once in 4 pause runs: 512)
constexpr uint64_t kBaseBytes = 32 * kMiB, kWorkerBytes = 32 * kMiB, kCodeBytes = 80 * kMiB;
constexpr uint64_t kStillBytesPerTet = 512;
// the segment cache: enough for the segments of a still (compressed segments decode to about
// 40 bytes a tet), and at least this much
constexpr uint64_t kCacheBytesPerStillTet = 48, kMinCacheBytes = 32 * kMiB;

std::optional<uint64_t> read_limit_file(const std::filesystem::path& file) {
  std::ifstream in(file);
  std::string text;
  if (!in || !(in >> text)) return std::nullopt;
  if (text == "max") return std::nullopt;
  try {
    const uint64_t v = std::stoull(text);
    if (v >= (uint64_t{1} << 62)) return std::nullopt;  // v1's "unlimited" is 2^63 rounded down to a page
    return v;
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// The limit of group `path` under `mount` and every group above it, the smallest.
void smallest_up(const std::filesystem::path& mount, std::string path, const char* file, const char* kind, std::optional<MemoryLimit>& best) {
  while (true) {
    const std::filesystem::path dir = mount / std::filesystem::path(path).relative_path();
    if (const auto v = read_limit_file(dir / file); v && (!best || *v < best->bytes)) best = MemoryLimit{*v, std::string(kind) + " " + (dir / file).string()};
    if (path.empty() || path == "/") break;
    const size_t slash = path.find_last_of('/');
    path = slash == std::string::npos ? std::string() : path.substr(0, slash);
  }
}

}  // namespace

std::optional<MemoryLimit> cgroup_memory_limit(std::string_view proc_self_cgroup, const std::filesystem::path& root) {
  std::optional<MemoryLimit> best;
  std::istringstream lines{std::string(proc_self_cgroup)};
  std::string line;
  while (std::getline(lines, line)) {
    // hierarchy-id:controllers:path
    const size_t a = line.find(':'), b = a == std::string::npos ? a : line.find(':', a + 1);
    if (b == std::string::npos) continue;
    const std::string controllers = line.substr(a + 1, b - a - 1), path = line.substr(b + 1);
    if (controllers.empty()) {  // v2, the unified hierarchy (on a hybrid system at root/unified)
      for (const auto& mount : {root, root / "unified"}) smallest_up(mount, path, "memory.max", "cgroup v2", best);
    } else {
      std::istringstream names(controllers);
      std::string name;
      while (std::getline(names, name, ','))
        if (name == "memory") smallest_up(root / "memory", path, "memory.limit_in_bytes", "cgroup v1", best);
    }
  }
  return best;
}

std::optional<MemoryLimit> process_memory_limit() {
  std::ifstream in("/proc/self/cgroup");
  std::stringstream text;
  text << in.rdbuf();
  return cgroup_memory_limit(text.str(), "/sys/fs/cgroup");
}

MemoryFit fit_to_memory(const ServerOptions& options, const MemoryLimit& limit) {
  MemoryFit fit;
  fit.still_budget = options.still_budget;
  fit.cache_bytes = options.cache_bytes;
  const uint64_t fixed = kBaseBytes + kWorkerBytes * options.render_workers + kCodeBytes;
  const uint64_t interaction = std::max<uint64_t>(options.interaction_budget, 1) * kStillBytesPerTet;
  const uint64_t needed = fixed + kMinCacheBytes + interaction;  // the least that draws at all
  auto mb = [](uint64_t bytes) { return std::to_string((bytes + kMiB / 2) / kMiB) + " MB"; };
  if (limit.bytes < needed)
    throw std::runtime_error("the memory limit (" + mb(limit.bytes) + ", " + limit.source + ") is below the " + mb(needed) + " a server with " +
                             std::to_string(options.render_workers) + " render worker(s) needs to draw at all; raise the limit, or use fewer --workers");
  // the cache: an eighth of the limit, enough for a still's segments, at most what was asked
  const uint64_t cache = std::min(options.cache_bytes, std::max({limit.bytes / 8, kMinCacheBytes, options.still_budget * kCacheBytesPerStillTet}));
  const uint64_t left = limit.bytes - fixed - std::min(cache, limit.bytes - fixed);
  const uint64_t still = std::max<uint64_t>(options.interaction_budget, std::min<uint64_t>(options.still_budget, left / kStillBytesPerTet));
  // a smaller still needs a smaller cache: the cache's share again, for the fitted still
  fit.cache_bytes = std::min(cache, std::max({limit.bytes / 8, kMinCacheBytes, still * kCacheBytesPerStillTet}));
  fit.still_budget = still;
  fit.changed = fit.still_budget != options.still_budget || fit.cache_bytes != options.cache_bytes;
  if (fit.changed)
    fit.message = "memory limit " + mb(limit.bytes) + " (" + limit.source + "): still budget " + std::to_string(options.still_budget) + " -> " +
                  std::to_string(fit.still_budget) + " tets, segment cache " + mb(options.cache_bytes) + " -> " + mb(fit.cache_bytes);
  return fit;
}

}  // namespace tetrascope::server
