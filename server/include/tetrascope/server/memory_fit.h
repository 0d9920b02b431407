// Serving inside a memory limit: the limit a process runs under (its memory cgroup,
// v1 or v2, or `serve --memory-mb`), and the server's options fitted to it. What a server
// needs was measured on the 20M blade (bench/results/serve_memory_limit-*.json,
// docs/commands/serve.md, "Under a memory limit"): about 32 MB plus 32 MB a render worker of its own
// memory, about 80 MB of Mesa's and LLVM's code kept in the page cache, the segment cache,
// and about 512 bytes a tet of the still it draws (the cut, its GL buffers, the sort). Under
// a limit that the defaults would overrun, the still budget and the segment cache shrink to
// fit; under one too small to draw at all, the server refuses to start and says why, rather
// than being killed by the kernel mid-frame or thrashing its code pages (both seen).
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>

namespace tetrascope::server {

struct ServerOptions;

struct MemoryLimit {
  uint64_t bytes = 0;
  std::string source;  // e.g. "cgroup v1 /sys/fs/cgroup/memory/x/memory.limit_in_bytes", "--memory-mb"
};

// The smallest memory limit of the cgroups this process is in, and of their ancestors: v2
// (`memory.max`) and v1 (`memory.limit_in_bytes`). `proc_self_cgroup` is the text of
// /proc/self/cgroup, `root` the cgroup mount (/sys/fs/cgroup). None when unlimited ("max", or
// v1's page-rounded 2^63) or unreadable.
std::optional<MemoryLimit> cgroup_memory_limit(std::string_view proc_self_cgroup, const std::filesystem::path& root);
// The same for this process.
std::optional<MemoryLimit> process_memory_limit();

struct MemoryFit {
  uint64_t still_budget = 0, cache_bytes = 0;  // as fitted
  bool changed = false;
  std::string message;  // what was changed and why, for the log; empty when nothing was
};

// Sizes a server with `options` under `limit` bytes: the segment cache at most an eighth of
// the limit (but enough for a still's segments), the still budget what the rest allows.
// Throws std::runtime_error, naming the limit and what is needed, when even an interaction
// frame would not fit.
MemoryFit fit_to_memory(const ServerOptions& options, const MemoryLimit& limit);

}  // namespace tetrascope::server
