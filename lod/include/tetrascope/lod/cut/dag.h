// The runtime DAG of the multi-triangulation (dissertation §6.3): dag.bin of a store read
// back and checked, then used by the cut (cut.h). The store itself is written by
// `tetrascope preprocess` (mt_build.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include "tetrascope/lod/cut/dag_format.h"
#include "tetrascope/storage/store.h"

namespace tetrascope::lod {

class DagError : public std::runtime_error {
 public:
  explicit DagError(const std::string& message) : std::runtime_error(message) {}
};
// dag.bin could not be read (permissions, out of descriptors): not damage.
class DagIoError : public DagError {
 public:
  using DagError::DagError;
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
  // The error mass per bin, Σ |error|·volume over the original vertices whose value falls in
  // the bin (volume in units of the diagonal cubed), and where that mass lies (its centroid's
  // coordinate `axis`). Stores of format 1 have neither (has_mass() false).
  bool has_mass() const { return kinds_ == dag::kKinds; }
  std::span<const float> mass_histogram(uint32_t n, uint32_t c) const { return histogram(n, c, 2); }
  std::span<const float> mass_centroid(uint32_t n, uint32_t c, int axis) const { return histogram(n, c, 3 + axis); }

 private:
  std::span<const float> histogram(uint32_t n, uint32_t c, int kind) const {
    return {histograms_.data() + ((size_t{n} * header_.channel_count + c) * kinds_ + kind) * header_.bins, header_.bins};
  }
  uint32_t kinds_ = dag::kKinds;
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

// Writes dag.bin (used by preprocess; exposed for tests of the reader's checks),
// `histograms` as float[node][channel][kinds][bins]: format 2 with dag::kKinds, format 1 (as
// stores made before the error masses) with dag::kKindsV1.
void write_dag(const std::filesystem::path& file, uint32_t levels, std::span<const dag::Node> nodes, std::span<const dag::Patch> patches,
               uint32_t channels, uint32_t bins, std::span<const float> histograms, uint32_t kinds = dag::kKinds);

}  // namespace tetrascope::lod
