// The multi-triangulation of dissertation §6.3: `tetrascope preprocess` builds it into a
// store (segments.bin holds every level's segments, dag.bin the DAG and the error
// histograms), and a Dag read back from a store drives the runtime cut (cut.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tetrascope/lod/dag_format.h"
#include "tetrascope/storage/mesh_stream.h"
#include "tetrascope/storage/progress.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::lod {

struct PreprocessOptions {
  uint32_t segment_tets = 16384;  // target tets a segment, at every level
  uint64_t base_tets = 100000;    // stop when a level has at most this many tets (or one segment)
  double level_ratio = 0.25;      // each segment is simplified to this share of its tets
  uint32_t histogram_bins = 256;  // N
  uint32_t threads = 2;           // segments simplified at once
  uint32_t max_levels = 24;
  int seed = 1;
  bool replace = false;
  storage::ReadLimits read_limits;  // what one input may cost (--max-inflate-ratio)
};

struct LevelReport {
  uint32_t level = 0, segments = 0, patches = 0;
  uint64_t tets = 0, vertices = 0;
};

struct PreprocessReport {
  uint64_t input_vertices = 0, input_tets = 0;
  std::vector<LevelReport> levels;
  uint32_t segments = 0, patches = 0;
  uint64_t store_bytes = 0, dag_bytes = 0;
  double seconds = 0, read_seconds = 0, segment_seconds = 0, simplify_seconds = 0, write_seconds = 0;
  nlohmann::json to_json() const;
};

// ingest -> partition (octree + METIS, §6.1) -> per level: partition again (rotated 45° every
// other level, §6.3.2), patches, simplify every new segment with its border locked, error
// histograms -> store, written atomically (NAME.tmp/ renamed to NAME/ when complete).
// Throws storage::MeshError for a bad mesh, std::invalid_argument for bad options,
// std::runtime_error otherwise; on failure no store directory is left behind.
PreprocessReport preprocess(const std::filesystem::path& mesh, const std::filesystem::path& store, const PreprocessOptions& options,
                            storage::Progress* progress = nullptr);

class DagError : public std::runtime_error {
 public:
  explicit DagError(const std::string& message) : std::runtime_error(message) {}
};

// dag.bin, read and checked (every block's CRC, every count, range and index, patch ranges
// tiling each segment, levels decreasing along every arc, histograms finite).
class Dag {
 public:
  // `segment_tets[s]`: tets of segment s in segments.bin (from the store's directory).
  static std::unique_ptr<Dag> open(const std::filesystem::path& file, std::span<const uint32_t> segment_tets);

  uint32_t level_count() const { return header_.level_count; }
  uint32_t node_count() const { return header_.node_count; }
  uint32_t patch_count() const { return header_.patch_count; }
  uint32_t channel_count() const { return header_.channel_count; }
  uint32_t bins() const { return header_.bins; }
  const dag::Node& node(uint32_t n) const { return nodes_[n]; }
  const dag::Patch& patch(uint32_t p) const { return patches_[p]; }
  std::span<const dag::Patch> patches() const { return patches_; }
  // patches with node n as floor (its parents' arcs)
  std::span<const uint32_t> parent_patches(uint32_t n) const {
    return {parents_.data() + nodes_[n].first_parent, nodes_[n].parent_count};
  }
  std::span<const dag::Patch> child_patches(uint32_t n) const {
    return {patches_.data() + nodes_[n].first_child, nodes_[n].child_count};
  }
  uint32_t root_patch_count() const { return root_patches_; }
  // field and spatial error histograms of node n, channel c (normalised units)
  std::span<const float> field_histogram(uint32_t n, uint32_t c) const { return histogram(n, c, 0); }
  std::span<const float> spatial_histogram(uint32_t n, uint32_t c) const { return histogram(n, c, 1); }

 private:
  std::span<const float> histogram(uint32_t n, uint32_t c, int kind) const {
    return {histograms_.data() + ((size_t{n} * header_.channel_count + c) * 2 + kind) * header_.bins, header_.bins};
  }
  dag::Header header_{};
  std::vector<dag::Node> nodes_;
  std::vector<dag::Patch> patches_;
  std::vector<uint32_t> parents_;
  std::vector<float> histograms_;
  uint32_t root_patches_ = 0;
};

// Checks beyond Dag::open: every coarse segment has the same boundary (faces by global
// vertex ids) as the union of its child patches, so refining it keeps the mesh conforming;
// histograms never fall from a segment to its parent. Returns the problems found (at most
// `limit`).
std::vector<std::string> verify_dag(const storage::Store& store, const Dag& dag, size_t limit = 20);

// Dag of a store directory (dag.bin), or nullptr for a single-level store.
std::unique_ptr<Dag> open_dag(const storage::Store& store);

// Writes dag.bin (used by preprocess; exposed for tests of the reader's checks).
void write_dag(const std::filesystem::path& file, uint32_t levels, std::span<const dag::Node> nodes, std::span<const dag::Patch> patches,
               uint32_t channels, uint32_t bins, std::span<const float> histograms);

}  // namespace tetrascope::lod
